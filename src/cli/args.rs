//! The raw command line, as clap parses it: flags, defaults, help text and the range of
//! every number a flag takes. [`super::config`] turns these strings and numbers into library
//! values.
//!
//! Every numeric flag has a value parser ([`real`], [`whole`], [`exposure`]) that refuses
//! non-finite values and values outside the quantity's range, so clap ends the run with
//! exit 1, naming the flag, the value and the range, before any file is read. The ranges
//! are the `const`s below; a test walks the whole command and fails on a numeric flag
//! without one.

use crate::render::tonemap::Exposure;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::fmt::Display;
use std::path::PathBuf;
use std::str::FromStr;

/// The range of a real-valued flag: a finite number from `lo` to `hi` (an end is left
/// out when it is open; ±∞ is no bound), in `unit`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Real {
    /// Lower end, in `unit` (−∞: none).
    pub lo: f64,
    /// Whether `lo` itself is refused.
    pub lo_open: bool,
    /// Upper end, in `unit` (+∞: none).
    pub hi: f64,
    /// Whether `hi` itself is refused.
    pub hi_open: bool,
    /// The unit, as the help text writes it ("" for a pure number).
    pub unit: &'static str,
}

impl Real {
    /// From `lo` to `hi`, both included.
    const fn closed(lo: f64, hi: f64, unit: &'static str) -> Real {
        Real {
            lo,
            lo_open: false,
            hi,
            hi_open: false,
            unit,
        }
    }

    /// Above `lo` (excluded), any finite value.
    const fn above(lo: f64, unit: &'static str) -> Real {
        Real {
            lo,
            lo_open: true,
            hi: f64::INFINITY,
            hi_open: true,
            unit,
        }
    }

    /// The same range without its lower end.
    const fn open_below(self) -> Real {
        Real {
            lo_open: true,
            ..self
        }
    }

    /// The same range without its upper end.
    const fn open_above(self) -> Real {
        Real {
            hi_open: true,
            ..self
        }
    }

    /// Whether `x` is finite and in the range.
    pub fn contains(&self, x: f64) -> bool {
        let above = if self.lo_open {
            x > self.lo
        } else {
            x >= self.lo
        };
        let below = if self.hi_open {
            x < self.hi
        } else {
            x <= self.hi
        };
        x.is_finite() && above && below
    }

    /// The range in words: "a finite number in [0, 2000] W/m²", "a finite number > 0".
    pub fn describe(&self) -> String {
        let unit = if self.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        let (lo, hi) = (self.lo.is_finite(), self.hi.is_finite());
        let range = match (lo, hi) {
            (false, false) => String::new(),
            (true, false) => format!(" {} {}", if self.lo_open { ">" } else { "≥" }, self.lo),
            (false, true) => format!(" {} {}", if self.hi_open { "<" } else { "≤" }, self.hi),
            (true, true) => format!(
                " in {}{}, {}{}",
                if self.lo_open { '(' } else { '[' },
                self.lo,
                self.hi,
                if self.hi_open { ')' } else { ']' }
            ),
        };
        format!("a finite number{range}{unit}")
    }
}

/// The value parser of a real-valued flag in `range`: refuses text that is not a number,
/// NaN, ±∞ (also `1e400`, which overflows to ∞) and numbers outside the range, saying the
/// range and its unit.
pub fn real(range: Real) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |text: &str| match text.trim().parse::<f64>() {
        Ok(x) if range.contains(x) => Ok(x),
        _ => Err(format!("expected {}", range.describe())),
    }
}

/// The value parser of a whole-number flag from `lo` to `hi` (both included), in `unit`.
pub fn whole<T>(
    lo: T,
    hi: T,
    unit: &'static str,
) -> impl Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static
where
    T: FromStr + PartialOrd + Display + Copy + Send + Sync + 'static,
{
    move |text: &str| match text.trim().parse::<T>() {
        Ok(n) if lo <= n && n <= hi => Ok(n),
        _ => {
            let unit = if unit.is_empty() {
                String::new()
            } else {
                format!(" {unit}")
            };
            Err(format!("expected a whole number from {lo} to {hi}{unit}"))
        }
    }
}

/// Irradiance of `--dni` and `--dhi`, W/m². Irradiance at the ground stays below 2000 W/m²
/// (the solar constant is 1361 W/m²); a larger number is usually illuminance in lux or a
/// daily sum in Wh/m² given by mistake.
pub const IRRADIANCE: Real = Real::closed(0.0, 2000.0, "W/m²");
/// Dew point of `--dew-point`, °C: the EnergyPlus weather format's range (its data
/// dictionary's `minimum> -70`, `maximum< 70`).
pub const DEW_POINT: Real = Real::closed(-70.0, 70.0, "°C").open_below().open_above();
/// Turbidity of `--turbidity`: the range the Preetham model is fitted over
/// ([`crate::sky::preetham::TURBIDITY_RANGE`]).
pub const TURBIDITY: Real = Real::closed(
    crate::sky::preetham::TURBIDITY_RANGE.0,
    crate::sky::preetham::TURBIDITY_RANGE.1,
    "",
);
/// Turn of `--rotate`, degrees: one turn either way. (A huge angle would keep no precision
/// in the image's columns once in radians.)
pub const ROTATION: Real = Real::closed(-360.0, 360.0, "degrees");
/// `--glare-threshold`: a factor of the mean luminance, or above 100 a luminance in cd/m².
pub const GLARE_THRESHOLD: Real = Real::above(0.0, "(factor, or cd/m² above 100)");
/// Top of the falsecolor scale (`--scale`), cd/m² or lux.
pub const FALSECOLOR_SCALE: Real = Real::above(0.0, "cd/m² or lux");
/// `--target`, percent.
pub const TARGET_PERCENT: Real = Real::closed(0.0, 100.0, "%").open_below().open_above();
/// An illuminance threshold that may be 0 (`--udi-min`, `--ase-threshold`), lux.
pub const LUX: Real = Real::closed(0.0, f64::INFINITY, "lux").open_above();
/// An illuminance threshold above 0 (`--da-threshold`, which cDA divides by, and
/// `--udi-max`), lux.
pub const POSITIVE_LUX: Real = Real::above(0.0, "lux");
/// `--sda-fraction`: a fraction of the occupied hours, above 0.
pub const FRACTION: Real = Real::closed(0.0, 1.0, "").open_below();
/// `--ase-hours`: hours of a year (8784 in a leap year).
pub const YEAR_HOURS: Real = Real::closed(0.0, 8784.0, "hours");
/// Largest image, pixels (`-x` × `-y`): the same 2²⁸ as the pictures daystep reads.
pub const MAX_PIXELS: usize = crate::render::image::MAX_PIXELS;
/// Most primary or gather rays per pixel (`--samples`, `--gather`): 256², far beyond any
/// useful setting, and small enough that the squares the sampler rounds to stay in a
/// `u32`.
pub const MAX_RAYS_PER_PIXEL: u32 = 1 << 16;
/// Most worker threads (`--threads`).
pub const MAX_THREADS: usize = 4096;
/// Longest timestep (`--step`), minutes: a day.
pub const MAX_STEP_MINUTES: u32 = 24 * 60;

/// `--exposure`: "auto", a multiplier, or, as `pfilt -e` reads a signed number, stops
/// (`+2` = ×4, `-1` = ×½); the multiplier must lie in [10⁻²⁰, 10²⁰], pfilt's own range.
///
/// # Errors
/// Anything else, with the accepted forms.
pub fn exposure(text: &str) -> Result<Exposure, String> {
    let t = text.trim();
    if t == "auto" {
        return Ok(Exposure::Auto);
    }
    let x = t.parse::<f64>().ok().filter(|x| x.is_finite());
    let m = match x {
        Some(stops) if t.starts_with(['+', '-']) => 2f64.powf(stops),
        other => other.unwrap_or(f64::NAN),
    };
    if (1e-20..=1e20).contains(&m) {
        Ok(Exposure::Given(m))
    } else {
        Err(
            "expected \"auto\", a multiplier in [1e-20, 1e20], or stops as pfilt -e \
             takes them (+N = ×2^N, -N = ×2^-N)"
                .into(),
        )
    }
}

/// daystep: incremental time-series daylight engine.
#[derive(Parser, Debug)]
#[command(name = "daystep", version, about, long_about = None)]
#[command(allow_negative_numbers = true)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
    /// Worker threads (default: all cores), 1..4096. Results do not depend on it.
    #[arg(long, global = true, value_parser = whole(1usize, MAX_THREADS, ""))]
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
    /// An HDR image (--image FILE.exr|.hdr, --mapping equirect|angular, --rotate DEG;
    /// with --dni its saturated pixels become the sun). `instant` and `render --time`.
    Image,
    /// No daylight.
    None,
}

/// Image mappings for `--mapping`.
#[derive(Clone, Copy, Debug, ValueEnum, PartialEq, Eq)]
pub enum MappingArg {
    /// Equirectangular, full sphere: azimuth clockwise from north across (north at the
    /// edges), zenith angle down.
    Equirect,
    /// Angular fisheye looking up (Radiance -vta -vh 180 -vv 180), north at the top.
    Angular,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Illuminance at every sensor for one instant (direct sun + sky + ground glow).
    Instant(InstantArgs),
    /// Daylight factor at every sensor under the CIE overcast sky: df.csv, report.json.
    Df(DfArgs),
    /// Error against run time of every quality knob on one instant of the scene:
    /// convergence.csv, convergence.svg, and a recommendation.
    Convergence(ConvergenceArgs),
    /// A time series over a weather file (EPW or WEA): illuminance.csv, direct_sun.csv,
    /// metrics.csv, summary.json, report.json.
    Annual(AnnualArgs),
    /// Images from the solution (final gather): per frame a linear HDR OpenEXR, a
    /// tone-mapped PNG and optionally a falsecolor map; for a weather file's days, a
    /// sequence with frames.csv and a playable preview. Resumable.
    Render(Box<RenderArgs>),
    /// Assembles the output folders of `annual --shard k/n` runs into one run's files.
    Merge(MergeArgs),
    /// Serves the `.glb` solution viewer on 127.0.0.1 and prints its URL; runs until Ctrl-C.
    View(ViewArgs),
    /// Inspect or maintain a projection cache folder.
    Cache {
        /// What to do with the cache.
        #[command(subcommand)]
        action: CacheAction,
    },
}

/// Arguments of `daystep instant`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct InstantArgs {
    /// The scene file (scene.toml).
    pub scene: PathBuf,
    /// Local standard time of the site, YYYY-MM-DDTHH:MM[:SS], or RFC 3339.
    // The help text is the doc comment, so its brackets stay unescaped for rustdoc.
    #[allow(rustdoc::broken_intra_doc_links)]
    #[arg(long)]
    pub time: String,
    /// Sky model.
    #[arg(long, value_enum)]
    pub sky: SkyArg,
    /// The sky's parameters.
    #[command(flatten)]
    pub params: SkyParams,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the solution mesh (glTF binary): radiance as COLOR_0, illuminance and
    /// luminance as custom attributes.
    #[arg(long)]
    pub gltf: Option<PathBuf>,
    /// Quality, cache and seed.
    #[command(flatten)]
    pub run: RunArgs,
}

/// The parameters of `--sky` (`instant`, `convergence`); which ones a sky needs is
/// checked by [`super::config::sky_spec`].
#[derive(Args, Debug)]
pub struct SkyParams {
    /// Direct-normal irradiance, W/m² (0–2000).
    #[arg(long, value_parser = real(IRRADIANCE))]
    pub dni: Option<f64>,
    /// Diffuse-horizontal irradiance, W/m² (0–2000).
    #[arg(long, value_parser = real(IRRADIANCE))]
    pub dhi: Option<f64>,
    /// CIE general sky type, 1..15.
    #[arg(long = "type", value_parser = whole(1u8, 15, ""))]
    pub sky_type: Option<u8>,
    /// Preetham turbidity (2..10).
    #[arg(long, value_parser = real(TURBIDITY))]
    pub turbidity: Option<f64>,
    /// Dew point for the Perez luminous efficacy, °C (−70 to 70).
    #[arg(long, value_parser = real(DEW_POINT))]
    pub dew_point: Option<f64>,
    /// The HDR image of `--sky image` (OpenEXR or Radiance HDR), radiance W·sr⁻¹·m⁻².
    #[arg(long)]
    pub image: Option<PathBuf>,
    /// How the image maps onto the sky.
    #[arg(long, value_enum, default_value = "equirect")]
    pub mapping: MappingArg,
    /// Turn the image clockwise seen from above, degrees (−360 to 360).
    #[arg(long, default_value_t = 0.0, value_parser = real(ROTATION))]
    pub rotate: f64,
}

/// Arguments of `daystep render`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct RenderArgs {
    /// The scene file (scene.toml).
    pub scene: PathBuf,
    /// The camera as Radiance view options, quoted: "-vtv -vp 3 7 1.5 -vd 0 -1 0 -vh 60
    /// -vv 45" (types -vtv, -vta, -vth, -vtl). Applied after --vf.
    #[arg(long, allow_hyphen_values = true)]
    pub view: Option<String>,
    /// A view file as rvu saves it (.vf); it must set the view, as rpict requires.
    #[arg(long, visible_alias = "view-file")]
    pub vf: Option<PathBuf>,
    /// Image width, pixels (Radiance's -x); width × height at most 2^28.
    #[arg(short = 'x', default_value_t = 512, value_parser = whole(1usize, MAX_PIXELS, "pixels"))]
    pub width: usize,
    /// Image height, pixels (Radiance's -y); width × height at most 2^28.
    #[arg(short = 'y', default_value_t = 512, value_parser = whole(1usize, MAX_PIXELS, "pixels"))]
    pub height: usize,
    /// Irradiance on the surfaces seen (lux in falsecolor), as rpict -i, instead of
    /// radiance.
    #[arg(short = 'i')]
    pub irradiance: bool,
    /// Primary rays per pixel (antialiasing; rounded up to a square), 1..65536.
    #[arg(long, default_value_t = 4, value_parser = whole(1u32, MAX_RAYS_PER_PIXEL, "rays"))]
    pub samples: u32,
    /// Gather rays per pixel (sky and interreflection), 1..65536.
    #[arg(long, default_value_t = 64, value_parser = whole(1u32, MAX_RAYS_PER_PIXEL, "rays"))]
    pub gather: u32,
    /// Local standard time of one frame, as for `instant` (with --sky).
    #[arg(long, conflicts_with = "weather")]
    pub time: Option<String>,
    /// Sky model of the one frame.
    #[arg(long, value_enum, requires = "time")]
    pub sky: Option<SkyArg>,
    /// The sky's parameters.
    #[command(flatten)]
    pub params: SkyParams,
    /// Instead of --time/--sky: a weather file (EPW or WEA); one frame per lit record.
    #[arg(long)]
    pub weather: Option<PathBuf>,
    /// First day of the sequence, YYYY-MM-DD.
    #[arg(long, requires = "weather")]
    pub start: Option<String>,
    /// Last day of the sequence, YYYY-MM-DD.
    #[arg(long, requires = "weather")]
    pub end: Option<String>,
    /// Timestep of the sequence, minutes (a divisor of the file's interval).
    #[arg(long, requires = "weather", value_parser = whole(1u32, MAX_STEP_MINUTES, "minutes"))]
    pub step: Option<u32>,
    /// Output folder; a rerun with the same folder continues an interrupted sequence.
    #[arg(long)]
    pub out: PathBuf,
    /// Exposure of the PNG: "auto" (log-average to 18 % grey), a multiplier, or signed
    /// stops (+1 doubles), as pfilt -e.
    #[arg(long, default_value = "auto", value_parser = exposure)]
    pub exposure: Exposure,
    /// Also write a falsecolor map per frame (luminance cd/m², or illuminance lux with -i).
    #[arg(long)]
    pub falsecolor: bool,
    /// Top of the falsecolor scale (falsecolor -s), cd/m² or lux, > 0.
    #[arg(long, default_value_t = 1000.0, value_parser = real(FALSECOLOR_SCALE))]
    pub scale: f64,
    /// Falsecolor bands (falsecolor -n), 1..100.
    #[arg(long, default_value_t = 8, value_parser = whole(1u32, 100, "bands"))]
    pub steps: u32,
    /// Logarithmic falsecolor scale over this many decades (falsecolor -log), 1..20.
    #[arg(long, value_parser = whole(1u32, 20, "decades"))]
    pub log: Option<u32>,
    /// Also write a Radiance HDR picture per frame ({frame}.hdr).
    #[arg(long)]
    pub hdr: bool,
    /// Also write the solution mesh with one frame per rendered frame (glTF binary):
    /// radiance as COLOR_0, illuminance and luminance as custom attributes.
    #[arg(long)]
    pub gltf: Option<PathBuf>,
    /// Daylight glare probability and vertical eye illuminance per frame (frames.csv
    /// columns dgp, ev_lux): angular fisheye views (-vta) only.
    #[arg(long)]
    pub glare: bool,
    /// Glare-source threshold as evalglare -b: a factor of the mean luminance (default
    /// 5), or above 100 a luminance in cd/m²; > 0.
    #[arg(long, requires = "glare", value_parser = real(GLARE_THRESHOLD))]
    pub glare_threshold: Option<f64>,
    /// Quality, cache and seed.
    #[command(flatten)]
    pub run: RunArgs,
}

/// Arguments of `daystep merge`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct MergeArgs {
    /// Shard output folders, any order.
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Timestep of the runs, minutes (the weather file's interval).
    #[arg(long, default_value_t = 60, value_parser = whole(1u32, MAX_STEP_MINUTES, "minutes"))]
    pub step: u32,
    /// Metric thresholds.
    #[command(flatten)]
    pub metrics: MetricArgs,
}

/// Arguments of `daystep df`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct DfArgs {
    /// The scene file (scene.toml); it must name a sensors file.
    pub scene: PathBuf,
    /// Output folder (df.csv, report.json).
    #[arg(long)]
    pub out: PathBuf,
    /// Quality, cache and seed.
    #[command(flatten)]
    pub run: RunArgs,
}

/// The quality, cache and seed flags of one instant (`instant`, `df`).
#[derive(Args, Debug)]
pub struct RunArgs {
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
// The sky flags are shared with `instant`; two keep the wording they have always had here.
#[command(mut_arg("dni", |a| a.help("Direct-normal irradiance, W/m² (perez, cie)")))]
#[command(mut_arg("turbidity", |a| a.help("Preetham turbidity")))]
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
    /// The sky's parameters.
    #[command(flatten)]
    pub params: SkyParams,
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
    /// Relative RMS error the recommendation aims at, percent (above 0, below 100).
    #[arg(long, default_value_t = 2.0, value_parser = real(TARGET_PERCENT))]
    pub target: f64,
    /// Seed of the interreflection.
    #[arg(long)]
    pub seed: Option<u64>,
}

/// Arguments of `daystep annual`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
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
    #[arg(long, value_parser = whole(1u32, MAX_STEP_MINUTES, "minutes"))]
    pub step: Option<u32>,
    /// Also write a Radiance/DAYSIM-style illuminance.ill.
    #[arg(long)]
    pub ill: bool,
    /// Also write surfaces.csv: per OBJ group and step, mean incident irradiance (W/m²)
    /// and, for glazing, transmitted solar power (W).
    #[arg(long)]
    pub surfaces: bool,
    /// Solve the interreflection at every step (warm-started within each day) instead of
    /// summing cached daylight coefficients: slower, and what the coefficients are
    /// checked against (--surfaces implies it).
    #[arg(long)]
    pub forward: bool,
    /// Seed of the Monte Carlo parts (results are a pure function of it).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Also write the solution mesh of the --gltf-day days (every lit step a frame) as
    /// glTF binary.
    #[arg(long, requires = "gltf_day")]
    pub gltf: Option<PathBuf>,
    /// A day for --gltf, YYYY-MM-DD (repeat for several).
    #[arg(long, requires = "gltf")]
    pub gltf_day: Vec<String>,
    /// Metric thresholds.
    #[command(flatten)]
    pub metrics: MetricArgs,
}

/// Annual-metric thresholds (honeybee-radiance-postprocess defaults).
#[derive(Args, Debug)]
pub struct MetricArgs {
    /// First occupied hour (hour starting at), local standard time, 0..23.
    #[arg(long, default_value_t = 8, value_parser = whole(0u32, 23, "h"))]
    pub occupancy_start: u32,
    /// Last occupied hour (inclusive; 17 = the hour 17:00–18:00), 0..23, not before the
    /// first.
    #[arg(long, default_value_t = 17, value_parser = whole(0u32, 23, "h"))]
    pub occupancy_end: u32,
    /// Daylight autonomy threshold, lux (DA counts ≥), > 0.
    #[arg(long, default_value_t = 300.0, value_parser = real(POSITIVE_LUX))]
    pub da_threshold: f64,
    /// UDI lower bound, lux, ≥ 0 and below --udi-max.
    #[arg(long, default_value_t = 100.0, value_parser = real(LUX))]
    pub udi_min: f64,
    /// UDI upper bound, lux.
    #[arg(long, default_value_t = 3000.0, value_parser = real(POSITIVE_LUX))]
    pub udi_max: f64,
    /// sDA: fraction of occupied hours a sensor's DA must reach, in (0, 1].
    #[arg(long, default_value_t = 0.5, value_parser = real(FRACTION))]
    pub sda_fraction: f64,
    /// ASE: direct-sun threshold, lux (counts >), ≥ 0.
    #[arg(long, default_value_t = 1000.0, value_parser = real(LUX))]
    pub ase_threshold: f64,
    /// ASE: hours above the threshold that make a sensor fail (≥), 0..8784.
    #[arg(long, default_value_t = 250.0, value_parser = real(YEAR_HOURS))]
    pub ase_hours: f64,
}

/// Arguments of `daystep view`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct ViewArgs {
    /// The solution file (glTF 2.0 binary, `.glb`).
    pub glb: PathBuf,
    /// Port on 127.0.0.1 (0: any free port).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
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

#[cfg(test)]
mod tests {
    use super::*;
    use clap::builder::Resettable;
    use clap::error::ErrorKind;
    use clap::{Arg, Command as ClapCommand, CommandFactory, FromArgMatches};
    use std::any::TypeId;

    /// Integer flags whose every value is meaningful, so their parser may be clap's own:
    /// a seed is any `u64`, and port 0 means any free port.
    const FULL_RANGE: [&str; 2] = ["seed", "port"];

    /// Every argument that takes a value, with the subcommand names that lead to it.
    fn value_args() -> Vec<(Vec<String>, Arg)> {
        fn walk(cmd: &ClapCommand, path: &[String], out: &mut Vec<(Vec<String>, Arg)>) {
            for a in cmd.get_arguments() {
                if a.get_action().takes_values() {
                    out.push((path.to_vec(), a.clone()));
                }
            }
            for sub in cmd.get_subcommands() {
                let mut p = path.to_vec();
                p.push(sub.get_name().to_string());
                walk(sub, &p, out);
            }
        }
        let mut out = Vec::new();
        walk(&Cli::command(), &[], &mut out);
        out
    }

    fn type_of(a: &Arg) -> clap::builder::ValueParser {
        a.get_value_parser().clone()
    }

    fn is_real(a: &Arg) -> bool {
        let t = type_of(a).type_id();
        t == TypeId::of::<f64>() || t == TypeId::of::<f32>() || t == TypeId::of::<Exposure>()
    }

    fn is_integer(a: &Arg) -> bool {
        let t = type_of(a).type_id();
        [
            TypeId::of::<u8>(),
            TypeId::of::<u16>(),
            TypeId::of::<u32>(),
            TypeId::of::<u64>(),
            TypeId::of::<u128>(),
            TypeId::of::<usize>(),
            TypeId::of::<i8>(),
            TypeId::of::<i16>(),
            TypeId::of::<i32>(),
            TypeId::of::<i64>(),
            TypeId::of::<i128>(),
            TypeId::of::<isize>(),
        ]
        .iter()
        .any(|id| t == *id)
    }

    /// The largest value of an integer flag's type, as text.
    fn type_max(a: &Arg) -> String {
        let t = type_of(a).type_id();
        let maxima: [(TypeId, String); 12] = [
            (TypeId::of::<u8>(), u8::MAX.to_string()),
            (TypeId::of::<u16>(), u16::MAX.to_string()),
            (TypeId::of::<u32>(), u32::MAX.to_string()),
            (TypeId::of::<u64>(), u64::MAX.to_string()),
            (TypeId::of::<u128>(), u128::MAX.to_string()),
            (TypeId::of::<usize>(), usize::MAX.to_string()),
            (TypeId::of::<i8>(), i8::MAX.to_string()),
            (TypeId::of::<i16>(), i16::MAX.to_string()),
            (TypeId::of::<i32>(), i32::MAX.to_string()),
            (TypeId::of::<i64>(), i64::MAX.to_string()),
            (TypeId::of::<i128>(), i128::MAX.to_string()),
            (TypeId::of::<isize>(), isize::MAX.to_string()),
        ];
        maxima.into_iter().find(|(id, _)| t == *id).unwrap().1
    }

    /// `--name=value` or `-x=value` (the `=` keeps clap from reading "-inf" as flags).
    fn spelled(a: &Arg, value: &str) -> String {
        match (a.get_long(), a.get_short()) {
            (Some(l), _) => format!("--{l}={value}"),
            (None, Some(s)) => format!("-{s}={value}"),
            (None, None) => value.to_string(),
        }
    }

    /// Parses the real command line `daystep PATH… FLAG=value`: `Err` with the rendered
    /// message when clap refused the value itself; `Ok` when it took it (the line may still
    /// lack other arguments).
    fn parse_value(path: &[String], a: &Arg, value: &str) -> Result<(), String> {
        let mut line = vec!["daystep".to_string()];
        line.extend(path.iter().cloned());
        line.push(spelled(a, value));
        match Cli::command().try_get_matches_from(&line) {
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::ValueValidation | ErrorKind::InvalidValue
                ) =>
            {
                Err(e.to_string())
            }
            _ => Ok(()),
        }
    }

    #[test]
    fn real_flags_refuse_nan_infinities_and_overflow() {
        let reals: Vec<_> = value_args()
            .into_iter()
            .filter(|(_, a)| is_real(a))
            .collect();
        // --dni, --dhi, --turbidity, --dew-point, --rotate three times over, --scale,
        // --glare-threshold, --exposure, --target, six metric thresholds twice over.
        assert!(
            reals.len() >= 25,
            "the walk found {} real flags",
            reals.len()
        );
        for (path, a) in &reals {
            let flag = spelled(a, "");
            let flag = flag.trim_end_matches('=');
            for bad in [
                "NaN", "nan", "inf", "-inf", "+inf", "infinity", "1e400", "-1e400",
            ] {
                match parse_value(path, a, bad) {
                    Ok(()) => panic!("daystep {} {flag} {bad} was accepted", path.join(" ")),
                    Err(shown) => assert!(
                        shown.contains(flag) && shown.contains(bad),
                        "{flag} {bad}: {shown}"
                    ),
                }
            }
        }
    }

    #[test]
    fn integer_flags_refuse_values_past_their_range() {
        let ints: Vec<_> = value_args()
            .into_iter()
            .filter(|(_, a)| is_integer(a))
            .collect();
        assert!(
            ints.len() >= 15,
            "the walk found {} integer flags",
            ints.len()
        );
        let mut full_range = Vec::new();
        for (path, a) in &ints {
            let id = a.get_id().as_str();
            for bad in ["NaN", "inf", "1e400", "1.5", "-1"] {
                assert!(
                    parse_value(path, a, bad).is_err(),
                    "daystep {} {id} {bad} was accepted",
                    path.join(" ")
                );
            }
            // clap's own integer parser takes the whole type; every flag that is not
            // meaningful over all of it must say its range.
            let max = type_max(a);
            if FULL_RANGE.contains(&id) {
                full_range.push(id);
                assert!(parse_value(path, a, &max).is_ok(), "{id} {max}");
            } else {
                let shown = parse_value(path, a, &max).err().unwrap_or_else(|| {
                    panic!(
                        "daystep {} {id} {max} was accepted: an integer flag without a range",
                        path.join(" ")
                    )
                });
                assert!(shown.contains("expected a whole number from"), "{shown}");
            }
        }
        full_range.sort_unstable();
        full_range.dedup();
        assert_eq!(full_range, ["port", "seed"], "the full-range list is stale");
    }

    #[test]
    fn negative_numbers_reach_every_numeric_flags_parser() {
        // Without `allow_negative_numbers` clap read `--udi-max -1` as an unknown flag -1.
        let mut n = 0;
        for (path, a) in value_args() {
            if !(is_real(&a) || is_integer(&a)) || a.is_positional() {
                continue;
            }
            let flag = spelled(&a, "");
            let flag = flag.trim_end_matches('=').to_string();
            let mut line = vec!["daystep".to_string()];
            line.extend(path.iter().cloned());
            line.extend([flag.clone(), "-1e9".to_string()]);
            let e = Cli::command()
                .try_get_matches_from(&line)
                .expect_err("-1e9 is in no flag's range");
            assert!(
                matches!(
                    e.kind(),
                    ErrorKind::ValueValidation | ErrorKind::InvalidValue
                ),
                "{line:?}: {e}"
            );
            n += 1;
        }
        assert!(n >= 40, "{n} numeric flags");
    }

    /// A command line that gives every argument of every subcommand a value it takes, with
    /// `required`, `requires` and `conflicts_with` lifted, so that every field of the
    /// derived structs is filled from its parser's value.
    #[test]
    fn every_value_parser_yields_its_fields_type() {
        fn relax(c: ClapCommand) -> ClapCommand {
            c.mut_args(|a| {
                a.required(false)
                    .requires(Resettable::Reset)
                    .conflicts_with(Resettable::Reset)
            })
            .mut_subcommands(relax)
        }
        fn line(cmd: &ClapCommand, out: &mut Vec<String>) {
            let mut opts = Vec::new();
            for a in cmd.get_arguments() {
                if !a.get_action().takes_values() {
                    continue;
                }
                let value = if is_real(a) || is_integer(a) {
                    ["1", "2"]
                        .into_iter()
                        .find(|v| {
                            let probe = ClapCommand::new("p").arg(
                                a.clone()
                                    .required(false)
                                    .requires(Resettable::Reset)
                                    .conflicts_with(Resettable::Reset)
                                    .global(false),
                            );
                            probe
                                .try_get_matches_from(["p".to_string(), spelled(a, v)])
                                .is_ok()
                        })
                        .expect("a small value in range")
                        .to_string()
                } else if let Some(v) = a.get_possible_values().first() {
                    v.get_name().to_string()
                } else {
                    "x".to_string()
                };
                if a.is_positional() {
                    out.push(value);
                } else {
                    opts.push(spelled(a, &value));
                }
            }
            out.extend(opts);
        }
        let root = relax(Cli::command());
        let mut n = 0;
        for sub in root.get_subcommands() {
            let leaves: Vec<&ClapCommand> = if sub.get_subcommands().next().is_some() {
                sub.get_subcommands().collect()
            } else {
                vec![sub]
            };
            for leaf in leaves {
                let mut args = vec!["daystep".to_string()];
                line(&root, &mut args);
                args.push(sub.get_name().into());
                if leaf.get_name() != sub.get_name() {
                    line(sub, &mut args);
                    args.push(leaf.get_name().into());
                }
                line(leaf, &mut args);
                let m = root
                    .clone()
                    .try_get_matches_from(&args)
                    .unwrap_or_else(|e| panic!("{args:?}: {e}"));
                // A parser yielding another type than the field panics here.
                Cli::from_arg_matches(&m).unwrap_or_else(|e| panic!("{args:?}: {e}"));
                n += 1;
            }
        }
        assert!(n >= 10, "{n} command lines");
    }

    #[test]
    fn ranges_say_what_they_take() {
        assert_eq!(IRRADIANCE.describe(), "a finite number in [0, 2000] W/m²");
        assert_eq!(DEW_POINT.describe(), "a finite number in (-70, 70) °C");
        assert_eq!(FRACTION.describe(), "a finite number in (0, 1]");
        assert_eq!(LUX.describe(), "a finite number ≥ 0 lux");
        assert!(FRACTION.contains(1.0) && !FRACTION.contains(0.0));
        assert!(!DEW_POINT.contains(70.0) && DEW_POINT.contains(-69.9));
        let p = real(IRRADIANCE);
        assert_eq!(p(" 800 "), Ok(800.0));
        assert!(p("2000.5").is_err() && p("-0.1").is_err() && p("8e2x").is_err());
        let w = whole(1u32, 15, "");
        assert_eq!(w("15"), Ok(15));
        assert!(w("16").is_err() && w("0").is_err());
    }

    #[test]
    fn exposure_reads_multipliers_and_pfilt_stops() {
        assert_eq!(exposure("auto"), Ok(Exposure::Auto));
        assert_eq!(exposure("2"), Ok(Exposure::Given(2.0)));
        assert_eq!(exposure("0.25"), Ok(Exposure::Given(0.25)));
        // pfilt -e: a sign makes it stops, powers of two.
        assert_eq!(exposure("+2"), Ok(Exposure::Given(4.0)));
        assert_eq!(exposure("-1"), Ok(Exposure::Given(0.5)));
        assert_eq!(exposure("-0"), Ok(Exposure::Given(1.0)));
        for bad in [
            "0", "1e-21", "1e21", "+67", "-67", "NaN", "inf", "+inf", "x", "",
        ] {
            assert!(exposure(bad).is_err(), "{bad}");
        }
    }
}
