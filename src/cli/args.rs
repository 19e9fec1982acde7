//! The raw command line, as clap parses it: flags, defaults, help text and the range of
//! every number a flag takes. [`super::config`] turns these strings and numbers into library
//! values.
//!
//! Every numeric flag has a value parser ([`real`], [`whole`], [`exposure`]) that refuses
//! non-finite values and values outside the quantity's range, so clap ends the run with
//! exit 1, naming the flag, the value and the range, before any file is read. The ranges
//! are the `const`s of [`super::ranges`]; a test walks the whole command and fails on a numeric flag
//! without one.

use crate::render::tonemap::Exposure;
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

pub use super::ranges::*;

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
    /// Resident memory the run may use: 4G, 800M, 1.5G (binary units, as Slurm's --mem).
    /// Default: 80 % of the machine's available memory (or of the cgroup's limit). Stages
    /// size their blocks to it; results do not depend on it. A run that cannot fit stops
    /// before its work, naming the smallest cap it needs.
    #[arg(long, global = true, value_name = "SIZE", allow_hyphen_values = true)]
    pub max_memory: Option<String>,
    /// Size limit of the projection cache folder: 2G (default), 20G, 500M (binary units).
    /// Past it the records written longest ago are removed; a run whose records outgrow it
    /// computes some directions again, and its report says so.
    #[arg(long, global = true, value_name = "SIZE", allow_hyphen_values = true)]
    pub cache_size: Option<String>,
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
    /// The scene file (scene.toml), or a Honeybee model (.hbjson) with the default site.
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
    /// The scene file (scene.toml), or a Honeybee model (.hbjson) with the default site.
    pub scene: PathBuf,
    /// The camera as Radiance view options, quoted: "-vtv -vp 3 7 1.5 -vd 0 -1 0 -vh 60
    /// -vv 45" (types -vtv, -vta, -vth, -vtl). Applied after --vf.
    #[arg(long, allow_hyphen_values = true)]
    pub view: Option<String>,
    /// A view file as rvu saves it (.vf); it must set the view, as rpict requires.
    #[arg(long, visible_alias = "view-file")]
    pub vf: Option<PathBuf>,
    /// A view of the model by its identifier (an HBJSON model's `views`); --vf replaces
    /// it, --view options apply over it.
    #[arg(long)]
    pub view_name: Option<String>,
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
    /// The runs' scene, for report.html's plan maps (default: the scene the first
    /// shard's report.json names, when that file exists).
    #[arg(long)]
    pub scene: Option<PathBuf>,
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
    /// The scene file (scene.toml), which must name a sensors file, or a Honeybee model
    /// (.hbjson) with sensor grids.
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
    /// Only these sensor grids of an HBJSON model: identifiers or globs, comma-separated
    /// ("Room_1*,Core_Grid"); default: every grid.
    #[arg(long)]
    pub grids: Option<String>,
    /// The site, "LAT,LON,UTC_OFFSET[,ELEVATION]" (°N, °E, hours of standard time, m): for
    /// a model given without a scene file's [site] (it replaces one, with a warning).
    #[arg(long, allow_hyphen_values = true)]
    pub site: Option<String>,
}

/// Arguments of `daystep convergence`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
// The sky flags are shared with `instant`; two keep the wording they have always had here.
#[command(mut_arg("dni", |a| a.help("Direct-normal irradiance, W/m² (perez, cie)")))]
#[command(mut_arg("turbidity", |a| a.help("Preetham turbidity")))]
pub struct ConvergenceArgs {
    /// The scene file (scene.toml), which must name a sensors file, or a Honeybee model
    /// (.hbjson) with sensor grids.
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
    /// Timed runs per setting (1–20): the cost is their median, and settings whose
    /// fastest-to-slowest spreads overlap count as equal in cost.
    #[arg(long, default_value_t = 3, value_parser = whole(1u32, 20, "runs"))]
    pub repeats: u32,
    /// Seed of the interreflection.
    #[arg(long)]
    pub seed: Option<u64>,
}

/// Arguments of `daystep annual`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct AnnualArgs {
    /// The scene file (scene.toml), or a Honeybee model (.hbjson) with the default site.
    pub scene: PathBuf,
    /// Only these sensor grids of an HBJSON model: identifiers or globs, comma-separated
    /// ("Room_1*,Core_Grid"); default: every grid.
    #[arg(long)]
    pub grids: Option<String>,
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
    /// LEED v4.1 Daylight Option 1 with operable blinds (sDA300/50% with the blind
    /// schedule, ASE1000,250h, points): leed.json, leed_blinds.csv, leed_sensors.csv. Each
    /// aperture group's light path is evaluated beside the run's steps and written under
    /// paths/.
    #[arg(long)]
    pub leed: bool,
    /// EN 17037 daylight provision (minimum, medium, high): en17037.json. Needs the whole
    /// year of an hourly weather file.
    #[arg(long)]
    pub en17037: bool,
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
#[path = "args_tests.rs"]
mod tests;
