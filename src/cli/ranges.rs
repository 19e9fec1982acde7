//! The ranges of the numbers flags take, and the clap value parsers that hold them
//! ([`real`], [`whole`], [`exposure`]): a non-finite value or one outside its quantity's
//! range ends the run at parse time with exit 1, naming the flag, the value and the range.

use crate::render::tonemap::Exposure;
use std::fmt::Display;
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
