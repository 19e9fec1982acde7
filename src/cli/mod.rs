//! L9 the command line: clap arguments → validated library calls → exit code
//! (0 success, 1 bad input, 2 internal error).

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::sequence::{self, Quality, SkySpec};
use chrono::Datelike;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// daystep: incremental time-series daylight engine.
#[derive(Parser, Debug)]
#[command(name = "daystep", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long, global = true)]
    pub threads: Option<usize>,
}

/// Sky models for `--sky`.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum SkyArg {
    /// Perez all-weather sky with sun (needs --dni, --dhi).
    Perez,
    /// Traditional CIE overcast sky normalised to --dhi.
    CieOvercast,
    /// CIE standard general sky --type 1..15 normalised to --dhi, sun from --dni.
    Cie,
    /// Preetham clear sky with sun (--turbidity).
    Preetham,
    /// No daylight.
    None,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Illuminance at every sensor for one instant (direct sun + sky + ground glow).
    #[command(allow_negative_numbers = true)]
    Instant {
        /// The scene file (scene.toml).
        scene: PathBuf,
        /// Local standard time of the site, YYYY-MM-DDTHH:MM[:SS], or RFC 3339.
        #[arg(long)]
        time: String,
        /// Sky model.
        #[arg(long, value_enum)]
        sky: SkyArg,
        /// Direct-normal irradiance, W/m².
        #[arg(long)]
        dni: Option<f64>,
        /// Diffuse-horizontal irradiance, W/m².
        #[arg(long)]
        dhi: Option<f64>,
        /// CIE general sky type, 1..15.
        #[arg(long = "type")]
        sky_type: Option<u8>,
        /// Preetham turbidity (2..10).
        #[arg(long)]
        turbidity: Option<f64>,
        /// Dew point for the Perez luminous efficacy, °C.
        #[arg(long)]
        dew_point: Option<f64>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Quality preset: draft, default, high, reference.
        #[arg(long, default_value = "default")]
        quality: String,
        /// Projection cache folder (created if missing; a folder that cannot be written
        /// is used read-only or not at all, with a warning).
        #[arg(long, default_value = "cache")]
        cache: PathBuf,
        /// Run without the projection cache.
        #[arg(long)]
        no_cache: bool,
        /// Seed of the Monte Carlo interreflection (results are a pure function of it).
        #[arg(long)]
        seed: Option<u64>,
    },
    /// Daylight factor at every sensor under the CIE overcast sky: df.csv, report.json.
    Df(DfArgs),
    /// Error against run time of every quality knob on one instant of the scene:
    /// convergence.csv, convergence.svg, and a recommendation.
    Convergence(ConvergenceArgs),
    /// A time series over a weather file (EPW or WEA): illuminance.csv, direct_sun.csv,
    /// metrics.csv, summary.json, report.json.
    Annual(AnnualArgs),
    /// Assembles the output folders of `annual --shard k/n` runs into one run's files.
    Merge {
        /// Shard output folders, any order.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Timestep of the runs, minutes (the weather file's interval).
        #[arg(long, default_value_t = 60)]
        step: u32,
        /// Metric thresholds.
        #[command(flatten)]
        metrics: MetricArgs,
    },
    /// Inspect or maintain a projection cache folder.
    Cache {
        /// What to do with the cache.
        #[command(subcommand)]
        action: CacheAction,
    },
}

/// Arguments of `daystep df`.
#[derive(Args, Debug)]
pub struct DfArgs {
    /// The scene file (scene.toml); it must name a sensors file.
    pub scene: PathBuf,
    /// Output folder (df.csv, report.json).
    #[arg(long)]
    pub out: PathBuf,
    /// Quality preset: draft, default, high, reference.
    #[arg(long, default_value = "default")]
    pub quality: String,
    /// Projection cache folder (created if missing; a folder that cannot be written is
    /// used read-only or not at all, with a warning).
    #[arg(long, default_value = "cache")]
    pub cache: PathBuf,
    /// Run without the projection cache.
    #[arg(long)]
    pub no_cache: bool,
    /// Seed of the Monte Carlo interreflection (results are a pure function of it).
    #[arg(long)]
    pub seed: Option<u64>,
}

/// Arguments of `daystep convergence`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct ConvergenceArgs {
    /// The scene file (scene.toml); it must name a sensors file.
    pub scene: PathBuf,
    /// Output folder (convergence.csv, convergence.svg, report.json).
    #[arg(long)]
    pub out: PathBuf,
    /// Local standard time, as for `instant` (with `--sky`), or a weather file's date.
    #[arg(long)]
    pub time: Option<String>,
    /// Sky model, as for `instant`.
    #[arg(long, value_enum)]
    pub sky: Option<SkyArg>,
    /// Direct-normal irradiance, W/m² (perez, cie).
    #[arg(long)]
    pub dni: Option<f64>,
    /// Diffuse-horizontal irradiance, W/m².
    #[arg(long)]
    pub dhi: Option<f64>,
    /// CIE general sky type, 1..15.
    #[arg(long = "type")]
    pub sky_type: Option<u8>,
    /// Preetham turbidity.
    #[arg(long)]
    pub turbidity: Option<f64>,
    /// Dew point for the Perez luminous efficacy, °C.
    #[arg(long)]
    pub dew_point: Option<f64>,
    /// Instead of --time/--sky: the weather file's sunniest record (largest beam on the
    /// horizontal) is the instant studied.
    #[arg(long, conflicts_with_all = ["time", "sky"])]
    pub weather: Option<PathBuf>,
    /// The preset the ladders vary one knob of.
    #[arg(long, default_value = "default")]
    pub quality: String,
    /// Only these knobs, comma-separated (default: all): sky subdivision, sun snapping, LDI
    /// resolution, refinement thresholds, sensor visibility, interreflection lines,
    /// iteration tolerance, presets.
    #[arg(long)]
    pub knobs: Option<String>,
    /// Relative RMS error the recommendation aims at, percent.
    #[arg(long, default_value_t = 2.0)]
    pub target: f64,
    /// Seed of the interreflection.
    #[arg(long)]
    pub seed: Option<u64>,
}

/// Arguments of `daystep annual`.
#[derive(Args, Debug)]
pub struct AnnualArgs {
    /// The scene file (scene.toml).
    pub scene: PathBuf,
    /// Weather file: EnergyPlus EPW or Radiance/DAYSIM WEA.
    #[arg(long)]
    pub weather: PathBuf,
    /// Output folder; a rerun with the same folder continues an interrupted run.
    #[arg(long)]
    pub out: PathBuf,
    /// Quality preset: draft, default, high, reference.
    #[arg(long, default_value = "default")]
    pub quality: String,
    /// Projection cache folder.
    #[arg(long, default_value = "cache")]
    pub cache: PathBuf,
    /// Run without the projection cache.
    #[arg(long)]
    pub no_cache: bool,
    /// Compute shard k of n (every n-th day); `daystep merge` assembles the shards.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// First day, YYYY-MM-DD (month and day are matched against the weather file's dates).
    #[arg(long)]
    pub start: Option<String>,
    /// Last day, YYYY-MM-DD.
    #[arg(long)]
    pub end: Option<String>,
    /// Timestep, minutes: the weather file's interval (default), or a divisor of it, whose
    /// steps interpolate the file's irradiances linearly in time (the report says so).
    #[arg(long)]
    pub step: Option<u32>,
    /// Also write a Radiance/DAYSIM-style illuminance.ill.
    #[arg(long)]
    pub ill: bool,
    /// Also write surfaces.csv: per OBJ group and step, mean incident irradiance (W/m²)
    /// and, for glazing, transmitted solar power (W).
    #[arg(long)]
    pub surfaces: bool,
    /// Seed of the Monte Carlo parts (results are a pure function of it).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Metric thresholds.
    #[command(flatten)]
    pub metrics: MetricArgs,
}

/// Annual-metric thresholds (honeybee-radiance-postprocess defaults).
#[derive(Args, Debug)]
pub struct MetricArgs {
    /// First occupied hour (hour starting at), local standard time.
    #[arg(long, default_value_t = 8)]
    pub occupancy_start: u32,
    /// Last occupied hour (inclusive; 17 = the hour 17:00–18:00).
    #[arg(long, default_value_t = 17)]
    pub occupancy_end: u32,
    /// Daylight autonomy threshold, lux (DA counts ≥).
    #[arg(long, default_value_t = 300.0)]
    pub da_threshold: f64,
    /// UDI lower bound, lux.
    #[arg(long, default_value_t = 100.0)]
    pub udi_min: f64,
    /// UDI upper bound, lux.
    #[arg(long, default_value_t = 3000.0)]
    pub udi_max: f64,
    /// sDA: fraction of occupied hours a sensor's DA must reach.
    #[arg(long, default_value_t = 0.5)]
    pub sda_fraction: f64,
    /// ASE: direct-sun threshold, lux (counts >).
    #[arg(long, default_value_t = 1000.0)]
    pub ase_threshold: f64,
    /// ASE: hours above the threshold that make a sensor fail (≥).
    #[arg(long, default_value_t = 250.0)]
    pub ase_hours: f64,
}

impl MetricArgs {
    fn params(&self) -> crate::metrics::MetricParams {
        crate::metrics::MetricParams {
            occupancy_start_hour: self.occupancy_start,
            occupancy_end_hour: self.occupancy_end,
            da_threshold_lux: self.da_threshold,
            udi_min_lux: self.udi_min,
            udi_max_lux: self.udi_max,
            sda_da_fraction: self.sda_fraction,
            ase_threshold_lux: self.ase_threshold,
            ase_hours: self.ase_hours,
        }
    }
}

/// The cache folder argument of `daystep cache …`.
#[derive(Args, Debug)]
pub struct CacheDir {
    /// Cache folder.
    #[arg(long = "cache", default_value = "cache")]
    pub dir: PathBuf,
}

/// `daystep cache` subcommands.
#[derive(Subcommand, Debug)]
pub enum CacheAction {
    /// Number, size and age of the records.
    Stats {
        /// The folder.
        #[command(flatten)]
        cache: CacheDir,
    },
    /// Validate every record; exit 1 if any is invalid, unless --fix removes them.
    Verify {
        /// The folder.
        #[command(flatten)]
        cache: CacheDir,
        /// Remove invalid records (they are rebuilt when next needed).
        #[arg(long)]
        fix: bool,
    },
    /// Remove all records and temporary files (keeps .gitignore, README.md, other files).
    Clear {
        /// The folder.
        #[command(flatten)]
        cache: CacheDir,
    },
}

fn format_time(t: Option<std::time::SystemTime>) -> String {
    t.map(|t| {
        chrono::DateTime::<chrono::Local>::from(t)
            .format("%Y-%m-%d %H:%M:%S")
            .to_string()
    })
    .unwrap_or_else(|| "-".into())
}

fn run_cache(action: CacheAction) -> Result<()> {
    match action {
        CacheAction::Stats { cache } => {
            let s = crate::cache::dir_stats(&cache.dir)?;
            println!(
                "{}: {} records, {} bytes ({:.1} MiB), {} temporary files, least recently used {}, most recently used {}",
                cache.dir.display(),
                s.files,
                s.bytes,
                s.bytes as f64 / (1u64 << 20) as f64,
                s.temp_files,
                format_time(s.oldest),
                format_time(s.newest)
            );
            Ok(())
        }
        CacheAction::Verify { cache, fix } => {
            let r = crate::cache::verify(&cache.dir)?;
            for (path, reason) in &r.invalid {
                println!("invalid: {}: {reason}", path.display());
            }
            for path in &r.foreign {
                println!("not a cache file (left alone): {}", path.display());
            }
            let removed = if fix { r.remove_invalid() } else { 0 };
            println!(
                "{}: {} valid, {} invalid{}, {} temporary, {} foreign",
                cache.dir.display(),
                r.ok,
                r.invalid.len(),
                if fix {
                    format!(" ({removed} removed)")
                } else {
                    String::new()
                },
                r.temp_files,
                r.foreign.len()
            );
            if r.is_clean() || fix {
                Ok(())
            } else {
                Err(Error::input(
                    &cache.dir,
                    None,
                    None,
                    format!(
                        "{} invalid cache records (run `daystep cache verify --fix` to remove them)",
                        r.invalid.len()
                    ),
                ))
            }
        }
        CacheAction::Clear { cache } => {
            let n = crate::cache::clear(&cache.dir)?;
            println!("{}: removed {n} files", cache.dir.display());
            Ok(())
        }
    }
}

fn need(name: &str, v: Option<f64>, sky: &str) -> Result<f64> {
    v.ok_or_else(|| Error::arg(name, "(missing)", format!("--sky {sky} needs {name}")))
}

fn sky_spec(
    sky: SkyArg,
    dni: Option<f64>,
    dhi: Option<f64>,
    sky_type: Option<u8>,
    turbidity: Option<f64>,
    dew_point: Option<f64>,
) -> Result<SkySpec> {
    Ok(match sky {
        SkyArg::Perez => SkySpec::Perez {
            dni: need("--dni", dni, "perez")?,
            dhi: need("--dhi", dhi, "perez")?,
            dew_point_c: dew_point,
        },
        SkyArg::CieOvercast => SkySpec::CieOvercast {
            dhi: need("--dhi", dhi, "cie-overcast")?,
        },
        SkyArg::Cie => SkySpec::Cie {
            sky_type: sky_type
                .ok_or_else(|| Error::arg("--type", "(missing)", "--sky cie needs --type 1..15"))?,
            dhi: need("--dhi", dhi, "cie")?,
            dni: dni.unwrap_or(0.0),
        },
        SkyArg::Preetham => SkySpec::Preetham {
            turbidity: need("--turbidity", turbidity, "preetham")?,
        },
        SkyArg::None => SkySpec::None,
    })
}

/// The projection cache of a run: `dir`, or none with `--no-cache`.
fn open_store(dir: &std::path::Path, no_cache: bool) -> crate::cache::Store {
    if no_cache {
        crate::cache::Store::disabled()
    } else {
        crate::cache::Store::open(dir, crate::cache::DEFAULT_MAX_BYTES)
    }
}

/// The preset `name` (`--quality`), with every random stream from `seed` when given.
fn quality_arg(name: &str, seed: Option<u64>) -> Result<Quality> {
    let q = Quality::preset(name).ok_or_else(|| {
        Error::arg(
            "--quality",
            name,
            "expected draft, default, high or reference",
        )
    })?;
    Ok(match seed {
        Some(s) => q.with_seed(s),
        None => q,
    })
}

fn run_df(a: DfArgs) -> Result<()> {
    let q = quality_arg(&a.quality, a.seed)?;
    let scene = Scene::load(&a.scene)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let store = open_store(&a.cache, a.no_cache);
    let result = sequence::df::run_df(&scene, &q, &store)?;
    sequence::df::write_df(&scene, &result, &a.out)?;
    let r = &result.report;
    for w in &r.instant.warnings {
        eprintln!("warning: {w}");
    }
    let s = &r.df_summary;
    eprintln!(
        "daystep df: {} sensors, outside {:.0} lx (CIE overcast, unobstructed, no ground); DF mean {:.2} %, min {:.2} %, max {:.2} %, {:.0} % of sensors >= {} %, uniformity {:.2}; max df_err {:.2} %; {:.3} s; wrote {}",
        s.sensors,
        result.outside_lux,
        s.mean_df,
        s.min_df,
        s.max_df,
        100.0 * s.fraction_at_least_threshold,
        s.threshold_df,
        s.uniformity,
        s.max_df_err,
        r.instant.total_seconds,
        a.out.display()
    );
    Ok(())
}

fn run_convergence(a: ConvergenceArgs) -> Result<()> {
    use crate::sequence::convergence;
    let base = quality_arg(&a.quality, a.seed)?;
    if !(a.target > 0.0 && a.target < 100.0) {
        return Err(Error::arg("--target", a.target, "a percentage in (0, 100)"));
    }
    let scene = Scene::load(&a.scene)?;
    if scene.sensors.is_empty() {
        return Err(Error::input(
            &a.scene,
            None,
            None::<&str>,
            "the scene has no sensors: convergence measures sensor illuminance",
        ));
    }
    let (utc, local, spec, what) = match (&a.weather, &a.time, a.sky) {
        (Some(w), _, _) => {
            let weather = crate::weather::read_weather(w)?;
            let best = weather
                .records
                .iter()
                .filter(|r| !r.missing)
                .map(|r| {
                    let offset = (scene.site.utc_offset_h * 3600.0) as i64;
                    let utc = (r.time - chrono::TimeDelta::seconds(offset)).and_utc();
                    let sun = crate::site::solar_position::solar_position(utc, &scene.site);
                    let beam = r.dni * sun.altitude_deg().to_radians().sin().max(0.0);
                    (beam + r.dhi, r, utc)
                })
                .max_by(|a, b| a.0.total_cmp(&b.0))
                .ok_or_else(|| Error::input(w, None, None::<&str>, "no usable weather record"))?;
            let (_, r, utc) = best;
            let spec = SkySpec::Perez {
                dni: r.dni,
                dhi: r.dhi,
                dew_point_c: r.dew_point_c,
            };
            let what = format!(
                "{} line {}: {} (DNI {} W/m², DHI {} W/m²)",
                w.display(),
                r.line,
                r.time,
                r.dni,
                r.dhi
            );
            (utc, r.time, spec, what)
        }
        (None, Some(t), Some(sky)) => {
            let spec = sky_spec(sky, a.dni, a.dhi, a.sky_type, a.turbidity, a.dew_point)?;
            let (utc, local) = crate::site::parse_time(t, scene.site.utc_offset_h)?;
            let what = format!("{t}, {spec:?}");
            (utc, local, spec, what)
        }
        _ => {
            return Err(Error::arg(
                "--time/--sky",
                "(missing)",
                "give --time and --sky (as for `instant`), or --weather FILE",
            ))
        }
    };
    eprintln!("daystep convergence: {what}");
    let mut ladders = convergence::ladders(&base);
    if let Some(list) = &a.knobs {
        let want: Vec<&str> = list.split(',').map(str::trim).collect();
        let known: Vec<&str> = ladders.iter().map(|l| l.knob).collect();
        if let Some(bad) = want.iter().find(|w| !known.contains(w)) {
            return Err(Error::arg(
                "--knobs",
                bad,
                format!("unknown knob; choose from: {}", known.join(", ")),
            ));
        }
        ladders.retain(|l| want.contains(&l.knob));
    }
    let show = |done: usize, total: usize, knob: &str, setting: &str| {
        if !knob.is_empty() {
            eprintln!("  [{:>2}/{total}] {knob}: {setting}", done + 1);
        }
    };
    let rungs = convergence::run_convergence(&scene, utc, local, &spec, &ladders, &show)?;
    std::fs::create_dir_all(&a.out).map_err(|e| Error::io(&a.out, e))?;
    crate::files::write_atomic(
        &a.out.join("convergence.csv"),
        convergence::csv(&rungs).as_bytes(),
    )?;
    let curves = convergence::curves(&rungs);
    let title = format!(
        "{}: error against time per knob (base `{}`, ringed)",
        a.scene.display(),
        base.name
    );
    crate::export::plot::error_vs_time_svg(&a.out.join("convergence.svg"), &title, &curves)?;
    let advice = convergence::recommendation(&rungs, a.target / 100.0);
    let report = serde_json::json!({
        "version": env!("CARGO_PKG_VERSION"),
        "scene": a.scene.display().to_string(),
        "instant": what,
        "base": base.name,
        "target_rel_err": a.target / 100.0,
        "rungs": rungs,
        "recommendation": advice,
    });
    crate::files::write_atomic(
        &a.out.join("report.json"),
        serde_json::to_string_pretty(&report)
            .map_err(|e| Error::Internal(format!("report: {e}")))?
            .as_bytes(),
    )?;
    println!("{advice}");
    eprintln!("wrote {}", a.out.display());
    Ok(())
}

fn parse_date(flag: &str, v: &str) -> Result<chrono::NaiveDate> {
    chrono::NaiveDate::parse_from_str(v, "%Y-%m-%d")
        .map_err(|_| Error::arg(flag, v, "expected a date YYYY-MM-DD"))
}

fn run_annual(a: AnnualArgs) -> Result<()> {
    let q = Quality::preset(&a.quality).ok_or_else(|| {
        Error::arg(
            "--quality",
            &a.quality,
            "expected draft, default, high or reference",
        )
    })?;
    let q = match a.seed {
        Some(s) => q.with_seed(s),
        None => q,
    };
    let shard = match &a.shard {
        None => (1, 1),
        Some(v) => {
            let bad = || Error::arg("--shard", v, "expected K/N with 1 <= K <= N");
            let (k, n) = v.split_once('/').ok_or_else(bad)?;
            let (k, n): (u32, u32) = (k.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?);
            if k == 0 || n == 0 || k > n {
                return Err(bad());
            }
            (k, n)
        }
    };
    let scene = Scene::load(&a.scene)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let mut weather = crate::weather::read_weather(&a.weather)?;
    if let Some(step) = a.step {
        weather = crate::weather::resample(&weather, step)?;
    }
    let ws = &weather.site;
    if (ws.latitude - scene.site.latitude).abs() > 0.1
        || (ws.longitude - scene.site.longitude).abs() > 0.1
    {
        weather.warnings.push(format!(
            "the weather file's site ({:.2}°, {:.2}°) differs from the scene file's ({:.2}°, {:.2}°) by more than 0.1°: using the scene file's",
            ws.latitude, ws.longitude, scene.site.latitude, scene.site.longitude
        ));
    }
    // Dates are matched by month and day in the year the weather file's times use.
    let year = weather.records.first().map_or(2021, |r| r.time.year());
    let in_year = |d: chrono::NaiveDate| {
        chrono::NaiveDate::from_ymd_opt(year, d.month(), d.day()).unwrap_or(d)
    };
    let opts = sequence::annual::AnnualOptions {
        start: a
            .start
            .as_deref()
            .map(|v| parse_date("--start", v))
            .transpose()?
            .map(in_year),
        end: a
            .end
            .as_deref()
            .map(|v| parse_date("--end", v))
            .transpose()?
            .map(in_year),
        shard,
        metrics: a.metrics.params(),
        ill: a.ill,
        surfaces: a.surfaces,
        ..sequence::annual::AnnualOptions::default()
    };
    opts.metrics.validate()?;
    for w in &weather.warnings {
        eprintln!("warning: {w}");
    }
    let store = open_store(&a.cache, a.no_cache);
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    {
        let stop = stop.clone();
        // A second Ctrl-C while the batch finishes kills the process as usual.
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, std::sync::atomic::Ordering::SeqCst) {
                std::process::exit(130);
            }
            eprintln!("\nstopping after the current days (Ctrl-C again to abort)…");
        });
    }
    let bar = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        let b = indicatif::ProgressBar::new(0);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} steps {per_sec} ETA {eta}",
            )
            .expect("valid template"),
        );
        Some(b)
    } else {
        None
    };
    let progress = |done: usize, total: usize| {
        if let Some(b) = &bar {
            b.set_length(total as u64);
            b.set_position(done as u64);
        }
    };
    let control = sequence::annual::RunControl {
        stop: &stop,
        progress: &progress,
    };
    let r = sequence::annual::run_annual(&scene, &weather, &q, &store, &a.out, &opts, &control)?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    for w in &r.warnings {
        eprintln!("warning: {w}");
    }
    if r.interrupted {
        eprintln!(
            "daystep annual: interrupted after {} of {} steps; finished days are kept in {}. To continue, run the same command again.",
            r.resumed + r.computed,
            r.steps,
            a.out.display()
        );
        return Err(Error::Interrupted);
    }
    eprintln!(
        "daystep annual: {} steps ({} computed, {} resumed; {} night, {} missing skipped), {} directions built, {} from cache, {:.1} s; median stated error {:.2} %; wrote {}",
        r.steps,
        r.computed,
        r.resumed,
        r.night,
        r.missing,
        r.directions.built,
        r.directions.from_cache,
        r.total_seconds,
        100.0 * r.median_relative_err,
        a.out.display()
    );
    Ok(())
}

/// Runs a parsed command line.
///
/// # Errors
/// Any library error, to be mapped to an exit code.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Cache { action } => run_cache(action),
        Command::Annual(a) => run_annual(a),
        Command::Df(a) => run_df(a),
        Command::Convergence(a) => run_convergence(a),
        Command::Merge {
            parts,
            out,
            step,
            metrics,
        } => {
            sequence::annual::merge(&parts, &out, step, &metrics.params())?;
            eprintln!("daystep merge: {} shards → {}", parts.len(), out.display());
            Ok(())
        }
        Command::Instant {
            scene,
            time,
            sky,
            dni,
            dhi,
            sky_type,
            turbidity,
            dew_point,
            out,
            quality,
            cache,
            no_cache,
            seed,
        } => {
            let q = quality_arg(&quality, seed)?;
            let spec = sky_spec(sky, dni, dhi, sky_type, turbidity, dew_point)?;
            let scene = Scene::load(&scene)?;
            for w in &scene.warnings {
                eprintln!("warning: {w}");
            }
            let (utc, local) = crate::site::parse_time(&time, scene.site.utc_offset_h)?;
            let store = open_store(&cache, no_cache);
            let result =
                sequence::instant::run_instant_cached(&scene, utc, local, &spec, &q, &store)?;
            sequence::write_instant(&scene, &result, &out)?;
            for w in &result.report.warnings {
                eprintln!("warning: {w}");
            }
            let r = &result.report;
            eprintln!(
                "daystep instant: {} sensors, {} sources ({} sky, {} ground, {} sun), {} → {} elements, {:.3} s; max lux_err {:.1} lx; wrote {}",
                r.counts.sensors,
                r.counts.sky_sources + r.counts.ground_sources + r.counts.sun_sources,
                r.counts.sky_sources,
                r.counts.ground_sources,
                r.counts.sun_sources,
                r.counts.elements_before,
                r.counts.elements_after,
                r.total_seconds,
                r.max_lux_err,
                out.display()
            );
            Ok(())
        }
    }
}

/// Parses the process arguments, runs, and returns the exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 1 } else { 0 };
            let _ = e.print();
            return code;
        }
    };
    if let Some(n) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()
        {
            eprintln!("error: cannot set up {n} threads: {e}");
            return 2;
        }
    }
    match run(cli) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {e}");
            e.exit_code()
        }
    }
}
