//! L9 the command line: clap arguments → validated library calls → exit code
//! (0 success, 1 bad input, 2 internal error).

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::sequence::{self, Quality, SkySpec};
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
    /// Inspect or maintain a projection cache folder.
    Cache {
        /// What to do with the cache.
        #[command(subcommand)]
        action: CacheAction,
    },
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

/// Runs a parsed command line.
///
/// # Errors
/// Any library error, to be mapped to an exit code.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Cache { action } => run_cache(action),
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
            let q = Quality::preset(&quality).ok_or_else(|| {
                Error::arg(
                    "--quality",
                    &quality,
                    "expected draft, default, high or reference",
                )
            })?;
            let q = match seed {
                Some(s) => q.with_seed(s),
                None => q,
            };
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
