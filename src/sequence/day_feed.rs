//! Days computed in parallel and handed on in batches, in order, without the workers
//! waiting at each batch's end. Each batch ended waiting for its slowest day: with one
//! batch for the whole year instead of twelve, a warm office year took 0.94× the time
//! (paired runs, 2026-12-07).
//!
//! Each worker of the pool runs a loop of its own (`spawn_broadcast`) that takes the next
//! day, computes it and files its result; the worker that completes a batch hands it to a
//! writer thread, which writes it while later days are computed. A day is never a job in
//! a queue: when days were spawned into the pool, a worker that waited inside one day's
//! nested `par_iter` took a whole later day from the queue, and the earlier day finished
//! only after it. Under `--forward` a 10-day shard then wrote all its days at its end, and
//! a job killed mid-shard had nothing to resume from (the Slurm test of 2026-12-07).
//! Taking stops a bounded number of days ahead of what is written, so the results held
//! are about two batches, and a stop ends at the batch begun.

use crate::error::Result;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Mutex};

/// Runs `day` on each of `days` in parallel and gives `batch` each run of `per_batch`
/// days (the last may be shorter) with their results, in order, once all of them are
/// done. `batch` runs on a thread of its own while later days are computed. A stop
/// (`stop`) ends the taking of days at the next batch boundary, so every batch begun is
/// finished and handed on; returns whether it came before the last day.
///
/// # Errors
/// The first (in day order) of `day`'s errors among the days computed, after the batches
/// before it are handed on; days not yet taken are then not computed. Or `batch`'s error.
pub(super) fn run_batches<D: Sync, R: Send>(
    days: &[D],
    per_batch: usize,
    stop: &AtomicBool,
    day: impl Fn(&D) -> Result<R> + Sync,
    mut batch: impl FnMut(&[D], Vec<R>) -> Result<()> + Send,
) -> Result<bool> {
    let per_batch = per_batch.max(1);
    let ends = Ends {
        written: AtomicUsize::new(0),
        write_failed: AtomicBool::new(false),
    };
    std::thread::scope(|ts| {
        // Unbounded: the workers must never block on the writer, whose work may need them
        // (light paths' batched sums run in the pool). Taking waits instead (`Ends`).
        let (btx, brx) = mpsc::channel::<(usize, usize, Vec<R>)>();
        let writer = ts.spawn(|| {
            // A panic here must also stop the workers, who may wait for what it writes.
            let _flag = OnUnwind(&ends.write_failed);
            for (a, b, results) in brx {
                if let Err(e) = batch(&days[a..b], results) {
                    ends.write_failed.store(true, Ordering::SeqCst);
                    return Err(e);
                }
                ends.written.store(b, Ordering::SeqCst);
            }
            Ok(())
        });
        let taken = take_days(days, per_batch, stop, &ends, &day, move |a, b, r| {
            // The writer is gone only once it failed, which it returns below.
            let _ = btx.send((a, b, r));
        });
        let wrote = writer
            .join()
            .unwrap_or_else(|p| std::panic::resume_unwind(p));
        let taken = taken?;
        wrote.map(|()| taken < days.len())
    })
}

/// What the writer has done: the days written (all before this index), and whether a
/// write failed.
struct Ends {
    written: AtomicUsize,
    write_failed: AtomicBool,
}

/// The days' shared state: how many were taken, the first not handed on, the results
/// held until their batch is whole, whether a day failed.
struct Feed<R, H> {
    taken: usize,
    next: usize,
    held: BTreeMap<usize, Result<R>>,
    failed: bool,
    handed: H,
}

/// Lets each worker of the pool take days in turn ([`interleaved`] within each batch) and
/// hands each whole batch with its results to `handed`, in order; stops taking at a
/// stop's next batch boundary, after a failed day and once a write failed. A worker waits
/// (running the pool's other work) before taking a day more than two batches and a day per
/// worker ahead of what is written. Returns the days taken.
fn take_days<D: Sync, R: Send>(
    days: &[D],
    per_batch: usize,
    stop: &AtomicBool,
    ends: &Ends,
    day: &(impl Fn(&D) -> Result<R> + Sync),
    handed: impl FnMut(usize, usize, Vec<R>) + Send,
) -> Result<usize> {
    let ahead = 2 * per_batch + rayon::current_num_threads().max(1);
    let feed = Mutex::new(Feed {
        taken: 0,
        next: 0,
        held: BTreeMap::new(),
        failed: false,
        handed,
    });
    let lock = || feed.lock().unwrap_or_else(|p| p.into_inner());
    // Set by a day that panicked: the others stop taking, and the scope then re-raises
    // the panic, rather than after the rest of the year.
    let panicked = AtomicBool::new(false);
    rayon::in_place_scope(|s| {
        s.spawn_broadcast(|_, _| loop {
            let t = {
                let mut f = lock();
                f.failed |= ends.write_failed.load(Ordering::SeqCst);
                f.failed |= panicked.load(Ordering::SeqCst);
                let boundary = f.taken % per_batch == 0;
                if f.failed || f.taken == days.len() || (boundary && stop.load(Ordering::SeqCst)) {
                    return;
                }
                if f.taken >= ends.written.load(Ordering::SeqCst) + ahead {
                    drop(f);
                    pause();
                    continue;
                }
                f.taken += 1;
                f.taken - 1
            };
            let i = interleaved(t, per_batch, days.len());
            let r = {
                let _flag = OnUnwind(&panicked);
                day(&days[i])
            };
            let mut f = lock();
            f.failed |= r.is_err();
            f.held.insert(i, r);
            // Every batch whose days are all here, in order; none from a failed one on.
            let f = &mut *f;
            while f.next < days.len() {
                let (a, b) = (f.next, (f.next + per_batch).min(days.len()));
                if !(a..b).all(|j| matches!(f.held.get(&j), Some(Ok(_)))) {
                    break;
                }
                let results = (a..b).map(|j| match f.held.remove(&j) {
                    Some(Ok(r)) => r,
                    _ => unreachable!("checked above"),
                });
                (f.handed)(a, b, results.collect());
                f.next = b;
            }
        });
    });
    let f = feed.into_inner().unwrap_or_else(|p| p.into_inner());
    // The first failed day, in day order.
    match f.held.into_values().find_map(Result::err) {
        Some(e) => Err(e),
        None => Ok(f.taken),
    }
}

/// Sets its flag when dropped by a panic's unwinding.
struct OnUnwind<'a>(&'a AtomicBool);

impl Drop for OnUnwind<'_> {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.store(true, Ordering::SeqCst);
        }
    }
}

/// A worker's wait for the writer: the pool's other work if there is any (the writer's
/// own may be among it), else a short sleep.
fn pause() {
    if rayon::yield_now() != Some(rayon::Yield::Executed) {
        std::thread::sleep(std::time::Duration::from_micros(200));
    }
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
    fn a_worker_never_takes_a_day_inside_another() {
        use rayon::prelude::*;
        use std::cell::Cell;
        thread_local!(static IN_DAY: Cell<bool> = const { Cell::new(false) });
        let nested = AtomicUsize::new(0);
        // Days whose work is a nested parallel loop, in which a worker waits for the
        // parts others took and meanwhile runs what it finds.
        let day = |d: &u64| {
            if IN_DAY.with(|c| c.replace(true)) {
                nested.fetch_add(1, Ordering::SeqCst);
            }
            let r = (0..64u64)
                .into_par_iter()
                .map(|k| work(&(d * 64 + k)).unwrap())
                .reduce(|| 0, |a, b| a ^ b);
            IN_DAY.with(|c| c.set(false));
            Ok(r)
        };
        let days: Vec<u64> = (0..200).collect();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let (r, got) = pool.install(|| run(&days, 8, &AtomicBool::new(false), day));
        assert!(!r.unwrap());
        assert_eq!(got.iter().map(|(b, _)| b.len()).sum::<usize>(), 200);
        // A day taken inside another holds it (and every day after it) back until done.
        assert_eq!(nested.load(Ordering::SeqCst), 0, "days taken inside a day");
    }

    #[test]
    fn a_panicking_day_ends_the_run_soon_and_is_raised() {
        let days: Vec<u64> = (0..400).collect();
        let computed = AtomicUsize::new(0);
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            pool.install(|| {
                run(&days, 8, &AtomicBool::new(false), |d| {
                    assert!(*d != 20, "day 20");
                    computed.fetch_add(1, Ordering::SeqCst);
                    work(d)
                })
            })
        }));
        assert!(r.is_err(), "the panic is raised");
        // The days taken before the others saw it: a few beyond day 20, not the year.
        let n = computed.load(Ordering::SeqCst);
        assert!(n < 100, "{n} days computed after a panic");
        // A writer that panics stops the workers too (they wait for what it writes).
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            pool.install(|| {
                run_batches(&days, 8, &AtomicBool::new(false), work, |b, _| {
                    assert!(b[0] != 16, "batch 16");
                    Ok(())
                })
            })
        }));
        assert!(r.is_err(), "the writer's panic is raised");
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
