//! Days computed in parallel and handed on in batches, in order, without the workers
//! waiting at each batch's end. Each batch ended waiting for its slowest day: with one
//! batch for the whole year instead of twelve, a warm office year took 0.94× the time
//! (paired runs, 2026-12-07). The calling thread hands days to the pool batch by batch,
//! at most two per worker ahead of the results, and a writer thread writes each batch
//! once all its days are in. So the results held are about a batch, and a stop ends at
//! the batch begun.

use crate::error::Result;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;

/// Runs `day` on each of `days` in parallel and gives `batch` each run of `per_batch`
/// days (the last may be shorter) with their results, in order, once all of them are
/// done. `batch` runs on a thread of its own while later days are computed. A stop
/// (`stop`) ends the taking of days at the next batch boundary, so every batch begun is
/// finished and handed on; returns whether it came before the last day.
///
/// # Errors
/// The first (in day order) of `day`'s errors among the days computed, after the batches before it are handed
/// on; days not yet taken are then not computed. Or `batch`'s error.
pub(super) fn run_batches<D: Sync, R: Send>(
    days: &[D],
    per_batch: usize,
    stop: &AtomicBool,
    day: impl Fn(&D) -> Result<R> + Sync,
    mut batch: impl FnMut(&[D], Vec<R>) -> Result<()> + Send,
) -> Result<bool> {
    let per_batch = per_batch.max(1);
    let write_failed = AtomicBool::new(false);
    std::thread::scope(|ts| {
        // One batch may wait while another is written; a slower writer holds the days
        // back.
        let (btx, brx) = mpsc::sync_channel::<(usize, usize, Vec<R>)>(1);
        let writer = ts.spawn(|| {
            for (a, b, results) in brx {
                if let Err(e) = batch(&days[a..b], results) {
                    write_failed.store(true, Ordering::SeqCst);
                    return Err(e);
                }
            }
            Ok(())
        });
        let taken = take_days(days, per_batch, stop, &write_failed, &day, |a, b, r| {
            // The writer is gone only once it failed, which it returns below.
            let _ = btx.send((a, b, r));
        });
        drop(btx);
        let wrote = writer
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p));
        let taken = taken?;
        wrote.map(|()| taken < days.len())
    })
}

/// Hands `days` to the pool batch by batch ([`interleaved`] within each), at most two per
/// worker ahead of the results, and each whole batch with its results to `handed`, in
/// order; stops taking at a stop's next batch boundary, after a failed day and once
/// `write_failed`. Returns the days taken.
fn take_days<D: Sync, R: Send>(
    days: &[D],
    per_batch: usize,
    stop: &AtomicBool,
    write_failed: &AtomicBool,
    day: &(impl Fn(&D) -> Result<R> + Sync),
    mut handed: impl FnMut(usize, usize, Vec<R>),
) -> Result<usize> {
    // More days ahead start more at once: a cold office year's peak doubled with a
    // batch ahead, as workers waiting inside a day took up others.
    let ahead = 2 * rayon::current_num_threads().max(1);
    let (tx, rx) = mpsc::channel::<(usize, Result<R>)>();
    let mut taken = 0;
    rayon::in_place_scope_fifo(|s| -> Result<()> {
        let (mut running, mut next, mut failed) = (0, 0, false);
        let mut held: BTreeMap<usize, Result<R>> = BTreeMap::new();
        loop {
            failed |= write_failed.load(Ordering::SeqCst);
            while !failed && taken < days.len() && running < ahead {
                if taken % per_batch == 0 && stop.load(Ordering::SeqCst) {
                    break;
                }
                let (i, tx) = (interleaved(taken, per_batch, days.len()), tx.clone());
                s.spawn_fifo(move |_| {
                    // The receiver is gone only once the run failed: nothing to do.
                    let _ = tx.send((i, day(&days[i])));
                });
                (taken, running) = (taken + 1, running + 1);
            }
            if running == 0 {
                break;
            }
            let (i, r) = receive(&rx).expect("a sender is kept here");
            running -= 1;
            failed |= r.is_err();
            held.insert(i, r);
            // Every batch whose days are all here, in order.
            while next < days.len() {
                let end = (next + per_batch).min(days.len());
                if !(next..end).all(|j| held.contains_key(&j)) {
                    break;
                }
                let results = (next..end).map(|j| held.remove(&j).expect("held"));
                match results.collect::<Result<Vec<R>>>() {
                    Ok(r) => handed(next, end, r),
                    // The scope waits for the days still running.
                    Err(e) => return Err(e),
                }
                next = end;
            }
        }
        // A failed day in a batch whose later days were then not taken.
        held.into_values().find_map(Result::err).map_or(Ok(()), Err)
    })?;
    Ok(taken)
}

/// The day taken `t`-th: within each batch, the first half's days alternate with the
/// second half's, so that the days running side by side are half a batch apart, as when
/// a batch was a `par_iter` split in halves. Side by side, neighbouring days computed the
/// same coarse nodes at once.
fn interleaved(t: usize, per_batch: usize, n: usize) -> usize {
    let start = t / per_batch * per_batch;
    let (o, len) = (t - start, per_batch.min(n - start));
    let half = len.div_ceil(2);
    start + if o % 2 == 0 { o / 2 } else { half + o / 2 }
}

/// The next day's result. On a worker of a pool (a caller inside `ThreadPool::install`),
/// waiting runs the pool's other work, so that a pool of one thread still computes the
/// days.
fn receive<T>(rx: &mpsc::Receiver<T>) -> Option<T> {
    if rayon::current_thread_index().is_none() {
        return rx.recv().ok();
    }
    loop {
        match rx.try_recv() {
            Ok(m) => return Some(m),
            Err(mpsc::TryRecvError::Disconnected) => return None,
            Err(mpsc::TryRecvError::Empty) => {
                if rayon::yield_now() != Some(rayon::Yield::Executed) {
                    std::thread::sleep(std::time::Duration::from_micros(100));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;

    /// Some work of a length that varies from day to day, so that days finish out of order.
    fn work(d: &u64) -> Result<u64> {
        let n = 1 + crate::math::rng::mix64(*d) % 20_000;
        Ok((0..n).fold(*d, |a, x| crate::math::rng::mix64(a ^ x)))
    }

    /// Each batch handed on: its days and their results.
    type Handed = Vec<(Vec<u64>, Vec<u64>)>;

    fn run(
        days: &[u64],
        per_batch: usize,
        stop: &AtomicBool,
        day: impl Fn(&u64) -> Result<u64> + Sync,
    ) -> (Result<bool>, Handed) {
        let mut got = Vec::new();
        let r = run_batches(days, per_batch, stop, day, |b, r| {
            got.push((b.to_vec(), r));
            Ok(())
        });
        (r, got)
    }

    #[test]
    fn each_batch_takes_each_of_its_days_once() {
        for (per_batch, n) in [(1, 5), (8, 8), (8, 21), (32, 365), (7, 3)] {
            let order: Vec<usize> = (0..n).map(|t| interleaved(t, per_batch, n)).collect();
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..n).collect::<Vec<_>>(), "{per_batch} {n}");
            // Each batch's days are taken before the next batch's.
            for (t, &i) in order.iter().enumerate() {
                assert_eq!(i / per_batch, t / per_batch);
            }
        }
        assert_eq!(
            (0..8).map(|t| interleaved(t, 8, 8)).collect::<Vec<_>>(),
            [0, 4, 1, 5, 2, 6, 3, 7]
        );
    }

    #[test]
    fn batches_come_whole_and_in_order() {
        let days: Vec<u64> = (0..103).collect();
        let want: Vec<u64> = days.iter().map(|d| work(d).unwrap()).collect();
        for threads in [1, 2, 4] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            // Inside a pool (its one worker waits by running the days) and outside one.
            let (r, got) = pool.install(|| run(&days, 8, &AtomicBool::new(false), work));
            assert!(!r.unwrap());
            assert_eq!(got.len(), 13);
            assert!(got.iter().all(|(b, r)| b.len() == r.len() && b.len() <= 8));
            let flat: Vec<u64> = got.iter().flat_map(|(b, _)| b.clone()).collect();
            assert_eq!(flat, days);
            let res: Vec<u64> = got.into_iter().flat_map(|(_, r)| r).collect();
            assert_eq!(res, want, "{threads} threads");
        }
        let (r, got) = run(&days, 8, &AtomicBool::new(false), work);
        assert!(!r.unwrap());
        assert_eq!(
            got.into_iter().flat_map(|(_, r)| r).collect::<Vec<_>>(),
            want
        );
    }

    #[test]
    fn a_stop_finishes_the_batch_begun() {
        let days: Vec<u64> = (0..100).collect();
        let stop = AtomicBool::new(false);
        let (r, got) = run(&days, 10, &stop, |d| {
            if *d == 34 {
                stop.store(true, Ordering::SeqCst);
            }
            work(d)
        });
        assert!(r.unwrap(), "a stop is reported");
        // Day 34 was taken, so its batch (30..40) is finished, and the batches handed on
        // are whole: 0..40 (later ones only where more workers took days ahead of it).
        let flat: Vec<u64> = got.iter().flat_map(|(b, _)| b.clone()).collect();
        let m = flat.len() as u64;
        assert!((40..100).contains(&m) && m % 10 == 0, "{m}");
        assert_eq!(flat, (0..m).collect::<Vec<_>>());
        // A stop before the first day: nothing.
        let (r, got) = run(&days, 10, &AtomicBool::new(true), work);
        assert!(r.unwrap() && got.is_empty());
    }

    #[test]
    fn the_first_failed_day_is_the_error_and_earlier_batches_come() {
        let days: Vec<u64> = (0..100).collect();
        let fail = |d: &u64| match *d {
            47 | 48 | 90 => Err(Error::Numerical(format!("day {d}"))),
            _ => work(d),
        };
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let (r, got) = pool.install(|| run(&days, 10, &AtomicBool::new(false), fail));
            match r {
                Err(Error::Numerical(m)) => assert_eq!(m, "day 47"),
                other => panic!("{other:?}"),
            }
            let flat: Vec<u64> = got.iter().flat_map(|(b, _)| b.clone()).collect();
            assert_eq!(flat, (0..40).collect::<Vec<_>>(), "{threads} threads");
        }
        // A failed hand-on stops the run with its error.
        let mut n = 0;
        let r = run_batches(&days, 10, &AtomicBool::new(false), work, |_, _| {
            n += 1;
            match n {
                3 => Err(Error::Numerical("write".into())),
                _ => Ok(()),
            }
        });
        assert!(matches!(r, Err(Error::Numerical(m)) if m == "write"));
        assert_eq!(n, 3);
    }
}
