//! Memory a run may use and what the process holds.
//!
//! * **The cap** (`--max-memory`, [`MemoryCap`]): bytes of resident memory a run may take.
//!   Its default is [`DEFAULT_SHARE`] of what the machine can give: the smaller of the
//!   kernel's `MemAvailable` and the cgroup's `memory.max` (a Slurm or container limit).
//!   Stages whose memory grows with the model size their blocks to it; a run that cannot
//!   fit stops before its work and names the smallest cap it needs.
//! * **What is held**, from Linux's `/proc/self/status`: resident memory (`VmRSS`) and its
//!   high-water mark (`VmHWM`); [`StagePeaks`] samples the first per stage. Elsewhere
//!   these read `None`.

use crate::error::{Error, Result};

/// Share of the machine's available memory a run may use by default: the rest is left to
/// the page cache and to other processes.
pub const DEFAULT_SHARE: f64 = 0.8;

/// The resident memory a run may use.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemoryCap {
    /// Bytes.
    pub bytes: u64,
    /// Where the figure came from ("--max-memory 4G", "80 % of MemAvailable", …).
    pub from: String,
    /// The user gave it (`--max-memory`): a run may fill it. The machine's default only
    /// bounds a run, which otherwise keeps to its own, smaller working sizes.
    pub given: bool,
}

impl MemoryCap {
    /// A cap given by the user: a size with an optional binary suffix, as Slurm's `--mem`
    /// reads it (`4G` = 4 GiB, `800M`, `1.5G`, `512K`, plain bytes; `B`, `iB` and lower
    /// case are accepted).
    ///
    /// # Errors
    /// Text that is not a size, or a size under 1 MiB ([`Error::Input`]).
    pub fn parse(text: &str) -> Result<MemoryCap> {
        Ok(MemoryCap {
            bytes: parse_size_flag("--max-memory", text)?,
            from: format!("--max-memory {}", text.trim()),
            given: true,
        })
    }

    /// The default cap: [`DEFAULT_SHARE`] of the smaller of `MemAvailable` and the cgroup
    /// limit; 4 GiB where neither can be read.
    pub fn machine_default() -> MemoryCap {
        let avail = meminfo_kib("MemAvailable").map(|k| k * 1024);
        let cgroup = cgroup_limit();
        let (bytes, what) = match (avail, cgroup) {
            (Some(a), Some(c)) if c < a => (c, "the cgroup's memory.max"),
            (Some(a), _) => (a, "MemAvailable"),
            (None, Some(c)) => (c, "the cgroup's memory.max"),
            (None, None) => {
                return MemoryCap {
                    bytes: 4 << 30,
                    from: "4 GiB (the machine's available memory could not be read)".into(),
                    given: false,
                }
            }
        };
        MemoryCap {
            bytes: (bytes as f64 * DEFAULT_SHARE) as u64,
            from: format!("{:.0} % of {what}", DEFAULT_SHARE * 100.0),
            given: false,
        }
    }

    /// The cap given, or the machine's default.
    ///
    /// # Errors
    /// As [`Self::parse`].
    pub fn from_arg(arg: Option<&str>) -> Result<MemoryCap> {
        arg.map_or_else(|| Ok(MemoryCap::machine_default()), MemoryCap::parse)
    }
}

/// A size flag's value (`--max-memory`, `--cache-size`), bytes: a number with an optional
/// binary suffix, as Slurm's `--mem` reads it (`4G` = 4 GiB, `800M`, `1.5G`, `512K`, plain
/// bytes; `B`, `iB` and lower case are accepted).
///
/// # Errors
/// Text that is not a size, or a size under 1 MiB ([`Error::Input`] naming `flag`).
pub fn parse_size_flag(flag: &str, text: &str) -> Result<u64> {
    let bytes = parse_size::Config::new()
        .with_binary()
        .parse_size(text.trim())
        .map_err(|e| {
            Error::arg(
                flag,
                text,
                format!("{e}: give a size such as 4G, 800M or 1.5G (binary units)"),
            )
        })?;
    if bytes < 1 << 20 {
        return Err(Error::arg(
            flag,
            text,
            format!("{bytes} bytes is less than 1 MiB"),
        ));
    }
    Ok(bytes)
}

/// Peak resident memory per stage of one run. While a stage runs, a sampling thread reads
/// the resident memory every [`SAMPLE_MS`] ms; the process's own high-water mark is left
/// alone, so tools outside (`/usr/bin/time`, Slurm's accounting) still read the true peak.
/// Stages may nest (the operator read inside the coefficients' preparation): an outer
/// stage's peak includes its inner stages'. With several runs in one process (tests), a
/// stage's figure includes the others' memory.
#[derive(Debug, Default)]
pub struct StagePeaks {
    done: std::sync::Mutex<Vec<(String, u64)>>,
}

/// Interval of the stage sampler, ms: short next to any stage worth reporting.
pub const SAMPLE_MS: u64 = 10;

impl StagePeaks {
    /// Runs `f` as the stage `name`, recording its peak resident memory (the largest of a
    /// stage's runs when it runs more than once).
    pub fn measure<T>(&self, name: &str, f: impl FnOnce() -> T) -> T {
        use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
        let stop = AtomicBool::new(false);
        let max = AtomicU64::new(resident_bytes().unwrap_or(0));
        let r = std::thread::scope(|s| {
            s.spawn(|| {
                while !stop.load(Ordering::Relaxed) {
                    if let Some(b) = resident_bytes() {
                        max.fetch_max(b, Ordering::Relaxed);
                    }
                    std::thread::sleep(std::time::Duration::from_millis(SAMPLE_MS));
                }
            });
            let r = f();
            stop.store(true, Ordering::Relaxed);
            r
        });
        let peak = max
            .load(Ordering::Relaxed)
            .max(resident_bytes().unwrap_or(0));
        let mut done = self.done.lock().expect("peaks lock");
        match done.iter_mut().find(|(n, _)| n == name) {
            Some((_, v)) => *v = (*v).max(peak),
            None => done.push((name.to_owned(), peak)),
        }
        r
    }

    /// (stage, peak resident bytes) of the stages measured so far, in the order they
    /// ended.
    pub fn stages(&self) -> Vec<(String, u64)> {
        self.done.lock().expect("peaks lock").clone()
    }
}

/// `bytes` as a size a user can type back into `--max-memory` (rounded up to whole MiB,
/// or to a tenth of a GiB above 1 GiB).
pub fn format_size(bytes: u64) -> String {
    const MIB: f64 = (1u64 << 20) as f64;
    let mib = (bytes as f64 / MIB).ceil();
    if mib >= 1024.0 {
        format!("{:.1}G", (mib / 1024.0 * 10.0).ceil() / 10.0)
    } else {
        format!("{mib:.0}M")
    }
}

/// A field of `/proc/meminfo`, kiB.
fn meminfo_kib(field: &str) -> Option<u64> {
    kib_field(&std::fs::read_to_string("/proc/meminfo").ok()?, field)
}

/// `name:   1234 kB` in a `/proc` status text, kiB.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    text.lines()
        .find_map(|l| l.strip_prefix(name)?.strip_prefix(':'))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
}

/// The cgroup v2 memory limit of this process, bytes (`None`: none, or not cgroup v2).
fn cgroup_limit() -> Option<u64> {
    let own = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let path = own.lines().find_map(|l| l.strip_prefix("0::"))?;
    let file = format!("/sys/fs/cgroup{}/memory.max", path.trim_end_matches('/'));
    std::fs::read_to_string(file).ok()?.trim().parse().ok()
}

/// Resident memory of this process now, bytes (`VmRSS`).
pub fn resident_bytes() -> Option<u64> {
    status_kib("VmRSS").map(|k| k * 1024)
}

/// Peak resident memory of the process since it started, bytes (`VmHWM`).
pub fn peak_resident_bytes() -> Option<u64> {
    status_kib("VmHWM").map(|k| k * 1024)
}

fn status_kib(field: &str) -> Option<u64> {
    kib_field(&std::fs::read_to_string("/proc/self/status").ok()?, field)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_read_as_slurm_reads_them() {
        let b = |s: &str| MemoryCap::parse(s).unwrap().bytes;
        assert_eq!(b("4G"), 4 << 30);
        assert_eq!(b("800M"), 800 << 20);
        assert_eq!(b("1.5G"), 3 << 29);
        assert_eq!(b("2048k"), 2 << 20);
        assert_eq!(b("1GiB"), 1 << 30);
        assert_eq!(b("3145728"), 3 << 20);
        for bad in ["", "four", "-1G", "1X", "512K"] {
            assert!(MemoryCap::parse(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn sizes_print_so_they_read_back_at_least_as_large() {
        for bytes in [1u64 << 20, 5 << 20 | 1, 1023 << 20, 1 << 30, (3 << 30) + 1] {
            let s = format_size(bytes);
            assert!(
                MemoryCap::parse(&s).unwrap().bytes >= bytes,
                "{bytes} → {s}"
            );
        }
        assert_eq!(format_size(800 << 20), "800M");
        assert_eq!(format_size(3 << 29), "1.5G");
    }

    #[test]
    fn nested_stages_carry_their_peaks_outwards() {
        let peaks = StagePeaks::default();
        let held = peaks.measure("outer", || {
            let inner = peaks.measure("inner", || {
                let v = vec![1u8; 64 << 20];
                std::hint::black_box(&v);
                // Held for several sampling intervals.
                std::thread::sleep(std::time::Duration::from_millis(10 * SAMPLE_MS));
                v.iter().map(|&b| b as u64).sum::<u64>()
            });
            inner
        });
        assert_eq!(held, 64 << 20);
        let st = peaks.stages();
        assert_eq!(
            st.iter().map(|s| s.0.as_str()).collect::<Vec<_>>(),
            ["inner", "outer"]
        );
        if let Some(hwm) = peak_resident_bytes() {
            assert!(st[0].1 >= 64 << 20, "the inner stage held 64 MiB: {st:?}");
            // The kernel updates the mark from per-thread counters in batches: a few MiB late.
            assert!(
                hwm + (8 << 20) >= st[0].1,
                "{st:?} above the high-water mark {hwm}"
            );
        }
    }

    #[test]
    fn status_fields_parse() {
        let t = "Name:\tx\nVmHWM:\t  2048 kB\nVmRSS:\t 1024 kB\n";
        assert_eq!(kib_field(t, "VmHWM"), Some(2048));
        assert_eq!(kib_field(t, "VmRSS"), Some(1024));
        assert_eq!(kib_field(t, "VmSwap"), None);
    }

    #[test]
    fn the_default_cap_is_a_share_of_something_real() {
        let c = MemoryCap::machine_default();
        assert!(c.bytes >= 1 << 20, "{c:?}");
        if cfg!(target_os = "linux") {
            let avail = meminfo_kib("MemAvailable").unwrap() * 1024;
            assert!(c.bytes <= avail, "{c:?} above MemAvailable {avail}");
        }
    }
}
