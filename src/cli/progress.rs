//! Progress of a long run on standard error: a bar on a terminal, and elsewhere (a Slurm
//! or Kubernetes log, a pipe) a line now and then, so a batch job's log shows that it
//! moves and when it should end.

use super::messages::note;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Seconds between two progress lines when standard error is not a terminal. A run
/// shorter than this writes none.
const LINE_EVERY: Duration = Duration::from_secs(60);

/// A run's progress display: a bar on a terminal, lines otherwise.
pub(super) struct Progress {
    bar: Option<indicatif::ProgressBar>,
    lines: Mutex<Lines>,
    t0: Instant,
}

impl Progress {
    /// Progress counted in `unit` ("steps", "frames").
    pub(super) fn new(unit: &str) -> Progress {
        let bar = std::io::IsTerminal::is_terminal(&std::io::stderr()).then(|| {
            let b = indicatif::ProgressBar::new(0);
            b.set_style(
                indicatif::ProgressStyle::with_template(&format!(
                    "{{bar:40}} {{pos}}/{{len}} {unit} {{per_sec}} ETA {{eta}}"
                ))
                .expect("valid template"),
            );
            b
        });
        Progress {
            bar,
            lines: Mutex::new(Lines::new(unit)),
            t0: Instant::now(),
        }
    }

    /// `done` of `total` are done.
    pub(super) fn show(&self, done: usize, total: usize) {
        if let Some(b) = &self.bar {
            b.set_length(total as u64);
            b.set_position(done as u64);
            return;
        }
        let line = self
            .lines
            .lock()
            .map(|mut l| l.due(self.t0.elapsed(), done, total));
        if let Ok(Some(line)) = line {
            note!("{line}");
        }
    }

    /// Clears the bar; a run that wrote progress lines says where it ended.
    pub(super) fn finish(self) {
        if let Some(b) = self.bar {
            b.finish_and_clear();
        } else if let Ok(mut l) = self.lines.into_inner() {
            if let Some(line) = l.last(self.t0.elapsed()) {
                note!("{line}");
            }
        }
    }
}

/// When the next progress line is due, and what it says.
#[derive(Debug)]
struct Lines {
    unit: String,
    /// When the last line was written (`None`: none yet), since the start.
    last: Option<Duration>,
    /// The first count seen and when: a resumed run's rate counts only its own work.
    first: Option<(Duration, usize)>,
    /// The latest count.
    now: (usize, usize),
    /// The count the last line gave.
    said: (usize, usize),
}

impl Lines {
    fn new(unit: &str) -> Lines {
        Lines {
            unit: unit.into(),
            last: None,
            first: None,
            now: (0, 0),
            said: (0, 0),
        }
    }

    /// The line to write at `t` (since the start) with `done` of `total` done, if one is
    /// due: [`LINE_EVERY`] after the start, then after the previous line.
    fn due(&mut self, t: Duration, done: usize, total: usize) -> Option<String> {
        let first = *self.first.get_or_insert((t, done));
        self.now = (done, total);
        if t < self.last.unwrap_or_default() + LINE_EVERY {
            return None;
        }
        self.last = Some(t);
        self.said = self.now;
        Some(self.line(t, first))
    }

    /// The closing line at `t`, when any line was written and the count moved since.
    fn last(&mut self, t: Duration) -> Option<String> {
        let first = self.first?;
        self.last?;
        (self.now != self.said).then(|| self.line(t, first))
    }

    fn line(&self, t: Duration, (t1, done1): (Duration, usize)) -> String {
        let (done, total) = self.now;
        let pct = if total > 0 {
            100.0 * done as f64 / total as f64
        } else {
            100.0
        };
        let mut s = format!(
            "{done}/{total} {} ({pct:.0} %), {} elapsed",
            self.unit,
            clock(t)
        );
        // The rate since the first count: the setup before it (projections, coefficients)
        // is not per unit.
        if done > done1 && done < total && t > t1 {
            let per = (t - t1).as_secs_f64() / (done - done1) as f64;
            let left = Duration::from_secs_f64(per * (total - done) as f64);
            s += &format!(", about {} left", clock(left));
        }
        s
    }
}

/// `h:mm:ss`.
fn clock(d: Duration) -> String {
    let s = d.as_secs();
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: u64) -> Duration {
        Duration::from_secs(s)
    }

    #[test]
    fn lines_come_a_minute_apart_with_the_time_left_from_the_runs_own_rate() {
        let mut l = Lines::new("steps");
        // A resumed run: 1 000 of 4 000 were done before it started.
        assert_eq!(l.due(at(5), 1000, 4000), None);
        assert_eq!(l.due(at(59), 1500, 4000), None);
        // 1 000 steps in 55 s since the first count: 2 000 left take 110 s.
        assert_eq!(
            l.due(at(60), 2000, 4000).as_deref(),
            Some("2000/4000 steps (50 %), 0:01:00 elapsed, about 0:01:50 left")
        );
        assert_eq!(l.due(at(119), 3000, 4000), None);
        assert!(l.due(at(120), 2500, 4000).is_some());
        assert_eq!(l.due(at(130), 3000, 4000), None);
        // 2 000 steps in 145 s: 1 000 left take 72.5 s.
        assert_eq!(
            l.last(at(150)).as_deref(),
            Some("3000/4000 steps (75 %), 0:02:30 elapsed, about 0:01:12 left")
        );
    }

    #[test]
    fn a_short_run_writes_no_line() {
        let mut l = Lines::new("frames");
        assert_eq!(l.due(at(1), 1, 2), None);
        assert_eq!(l.due(at(2), 2, 2), None);
        assert_eq!(l.last(at(3)), None);
        // Until it outlasts a minute, and then its end is said without a time left.
        assert!(Lines::new("steps").due(at(61), 0, 10).is_some());
        let mut long = Lines::new("steps");
        long.due(at(0), 0, 10);
        long.due(at(70), 9, 10);
        long.due(at(75), 10, 10);
        assert_eq!(
            long.last(at(76)).as_deref(),
            Some("10/10 steps (100 %), 0:01:16 elapsed")
        );
        // A count already said is not said again.
        let mut said = Lines::new("steps");
        said.due(at(0), 0, 10);
        assert!(said.due(at(70), 10, 10).is_some());
        assert_eq!(said.last(at(71)), None);
    }
}
