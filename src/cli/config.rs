//! Raw arguments ([`super::args`]) turned into library values: a quality preset, a sky, a
//! projection cache, metric thresholds, dates, a shard, a set of knobs. Every refusal is an
//! [`Error::Input`] naming the flag and the value, so it exits 1 with a message a user can
//! act on.

use super::args::{MetricArgs, RunArgs, SkyArg, SkyParams};
use crate::cache::Store;
use crate::error::{Error, Result};
use crate::metrics::MetricParams;
use crate::sequence::convergence::Ladder;
use crate::sequence::{Quality, SkySpec};
use chrono::NaiveDate;
use std::path::Path;

/// The preset `name` (`--quality`), with every random stream from `seed` when given.
///
/// # Errors
/// [`Error::Input`] on `--quality` for an unknown preset.
pub fn quality(name: &str, seed: Option<u64>) -> Result<Quality> {
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

/// The value of flag `name`, which `--sky {sky}` needs.
fn need(name: &str, v: Option<f64>, sky: &str) -> Result<f64> {
    v.ok_or_else(|| Error::arg(name, "(missing)", format!("--sky {sky} needs {name}")))
}

/// The sky of `--sky` with its parameters: irradiances `--dni`, `--dhi` in W/m², CIE
/// `--type` 1–15, Preetham `--turbidity`, `--dew-point` in °C. Their ranges were checked
/// when the command line was parsed ([`super::args`]); here only their presence.
///
/// # Errors
/// [`Error::Input`] naming the flag the chosen sky needs and lacks.
pub fn sky_spec(sky: SkyArg, p: &SkyParams) -> Result<SkySpec> {
    Ok(match sky {
        SkyArg::Perez => SkySpec::Perez {
            dni: need("--dni", p.dni, "perez")?,
            dhi: need("--dhi", p.dhi, "perez")?,
            dew_point_c: p.dew_point,
        },
        SkyArg::CieOvercast => SkySpec::CieOvercast {
            dhi: need("--dhi", p.dhi, "cie-overcast")?,
        },
        SkyArg::Cie => SkySpec::Cie {
            sky_type: p
                .sky_type
                .ok_or_else(|| Error::arg("--type", "(missing)", "--sky cie needs --type 1..15"))?,
            dhi: need("--dhi", p.dhi, "cie")?,
            dni: p.dni.unwrap_or(0.0),
        },
        SkyArg::Preetham => SkySpec::Preetham {
            turbidity: need("--turbidity", p.turbidity, "preetham")?,
        },
        SkyArg::None => SkySpec::None,
        SkyArg::Image => {
            return Err(Error::arg(
                "--sky",
                "image",
                "image skies are read by `instant` and `render --time` only, so far",
            ))
        }
    })
}

/// The image sky of `--sky image` (`--image`, `--mapping`, `--rotate`, `--dni`) over a
/// ground of reflectance `ground_reflectance`.
///
/// # Errors
/// A missing `--image`, and every error of [`crate::sequence::sky::image_sky`].
pub fn image_sky(p: &SkyParams, ground_reflectance: f64) -> Result<crate::sky::Sky> {
    use crate::sky::image::Mapping;
    let path = p
        .image
        .as_ref()
        .ok_or_else(|| Error::arg("--image", "(missing)", "--sky image needs --image FILE"))?;
    let mapping = match p.mapping {
        super::args::MappingArg::Equirect => Mapping::Equirect,
        super::args::MappingArg::Angular => Mapping::Angular,
    };
    crate::sequence::sky::image_sky(path, mapping, p.rotate, p.dni, ground_reflectance)
}

/// The projection cache of a run: `dir` (`--cache`) limited to `max_bytes` (`--cache-size`), or none
/// with `--no-cache`.
pub fn store(dir: &Path, no_cache: bool, max_bytes: u64) -> Store {
    if no_cache {
        Store::disabled()
    } else {
        Store::open(dir, max_bytes)
    }
}

/// The limits every command reads before its work: the memory cap (`--max-memory`) and
/// the cache folder's size limit (`--cache-size`, bytes).
#[derive(Clone, Debug)]
pub struct Limits {
    /// The resident memory the run may use.
    pub cap: crate::memory::MemoryCap,
    /// The projection cache folder's size limit, bytes.
    pub cache_bytes: u64,
}

impl Limits {
    /// The limits of the global flags' values.
    ///
    /// # Errors
    /// A value that is not a size, or under 1 MiB ([`crate::error::Error::Input`]).
    pub fn from_args(max_memory: Option<&str>, cache_size: Option<&str>) -> Result<Limits> {
        Ok(Limits {
            cap: crate::memory::MemoryCap::from_arg(max_memory)?,
            cache_bytes: cache_size.map_or(Ok(crate::cache::DEFAULT_MAX_BYTES), |t| {
                crate::memory::parse_size_flag("--cache-size", t)
            })?,
        })
    }
}

/// The annual-metric thresholds of the `--occupancy-*`, `--da-threshold`, `--udi-*`,
/// `--sda-fraction` and `--ase-*` flags (hours, lux, fractions as the flags say). Each
/// flag's range was checked when the command line was parsed; here the pairs.
///
/// # Errors
/// [`Error::Input`] naming the flag when `--occupancy-end` is before `--occupancy-start`
/// or `--udi-min` is not below `--udi-max`, and every error of [`MetricParams::validate`].
pub fn metric_params(m: &MetricArgs) -> Result<MetricParams> {
    if m.occupancy_end < m.occupancy_start {
        return Err(Error::arg(
            "--occupancy-end",
            m.occupancy_end,
            format!(
                "the last occupied hour must not be before --occupancy-start {}",
                m.occupancy_start
            ),
        ));
    }
    if m.udi_min >= m.udi_max {
        return Err(Error::arg(
            "--udi-min",
            m.udi_min,
            format!("must be below --udi-max {} lux", m.udi_max),
        ));
    }
    let p = MetricParams {
        occupancy_start_hour: m.occupancy_start,
        occupancy_end_hour: m.occupancy_end,
        da_threshold_lux: m.da_threshold,
        udi_min_lux: m.udi_min,
        udi_max_lux: m.udi_max,
        sda_da_fraction: m.sda_fraction,
        ase_threshold_lux: m.ase_threshold,
        ase_hours: m.ase_hours,
    };
    p.validate()?;
    Ok(p)
}

/// The image size `-x` × `-y`, pixels: each side at least 1 (checked when parsed) and at
/// most [`super::args::MAX_PIXELS`] pixels in all.
///
/// # Errors
/// [`Error::Input`] on `-x` naming both sides when the image is larger.
pub fn image_size(width: usize, height: usize) -> Result<(usize, usize)> {
    let max = super::args::MAX_PIXELS;
    match width.checked_mul(height) {
        Some(n) if n <= max && width > 0 && height > 0 => Ok((width, height)),
        _ => Err(Error::arg(
            "-x",
            format!("{width} -y {height}"),
            format!("an image has at most 2^28 = {max} pixels (16384 × 16384)"),
        )),
    }
}

/// `--shard K/N` as (k, n) with 1 ≤ k ≤ n; (1, 1) when absent.
///
/// # Errors
/// [`Error::Input`] on `--shard` for anything else.
pub fn shard(v: Option<&str>) -> Result<(u32, u32)> {
    let Some(v) = v else { return Ok((1, 1)) };
    let bad = || Error::arg("--shard", v, "expected K/N with 1 <= K <= N");
    let (k, n) = v.split_once('/').ok_or_else(bad)?;
    let (k, n): (u32, u32) = (k.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?);
    if k == 0 || n == 0 || k > n {
        return Err(bad());
    }
    Ok((k, n))
}

/// The date `v` of flag `flag`, `YYYY-MM-DD`.
///
/// # Errors
/// [`Error::Input`] naming the flag and the value when it is not such a date.
pub fn date(flag: &str, v: &str) -> Result<NaiveDate> {
    NaiveDate::parse_from_str(v, "%Y-%m-%d")
        .map_err(|_| Error::arg(flag, v, "expected a date YYYY-MM-DD"))
}

/// `--target`, percent, as a fraction (2 → 0.02).
///
/// # Errors
/// [`Error::Input`] on `--target` outside (0, 100).
pub fn target(percent: f64) -> Result<f64> {
    if !(percent > 0.0 && percent < 100.0) {
        return Err(Error::arg("--target", percent, "a percentage in (0, 100)"));
    }
    Ok(percent / 100.0)
}

/// The ladders named in `--knobs` (comma-separated, spaces around names ignored), in
/// `ladders`' order; all of them when the flag is absent.
///
/// # Errors
/// [`Error::Input`] on `--knobs` naming the first unknown knob and the known ones.
pub fn knobs(mut ladders: Vec<Ladder>, list: Option<&str>) -> Result<Vec<Ladder>> {
    if let Some(list) = list {
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
    Ok(ladders)
}

/// Loads the scene, puts it at `--site` when given, and keeps the sensor grids `--grids`
/// selects (all when not given).
///
/// # Errors
/// As [`crate::scene::Scene::load`], [`site`] and [`crate::scene::grids::select_grids`].
pub fn load_scene(path: &Path, run: &RunArgs) -> Result<crate::scene::Scene> {
    let mut scene = crate::scene::Scene::load(path)?;
    if let Some(text) = &run.site {
        let given = site(text)?;
        if scene.site_given() && scene.site != given {
            scene.warnings.push(format!(
                "{}: --site replaces the scene file's [site]",
                path.display()
            ));
        }
        scene.site = given;
        scene.take_site_if_missing(given, "--site");
    }
    if let Some(g) = &run.grids {
        crate::scene::grids::select_grids(&mut scene, g)?;
    }
    Ok(scene)
}

/// Parses `--site "LAT,LON,UTC_OFFSET[,ELEVATION]"`: degrees north, degrees east, hours,
/// metres, in the ranges of `scene.toml`'s `[site]`.
///
/// # Errors
/// [`Error::Input`] naming `--site` and the value.
pub fn site(text: &str) -> Result<crate::site::Site> {
    let bad = |m: &str| Error::arg("--site", text, m.to_string());
    let v: Vec<f64> = text
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| bad("give LAT,LON,UTC_OFFSET[,ELEVATION] as numbers"))?;
    if !(3..=4).contains(&v.len()) || v.iter().any(|x| !x.is_finite()) {
        return Err(bad(
            "give LAT,LON,UTC_OFFSET[,ELEVATION] as 3 or 4 finite numbers",
        ));
    }
    let ranges = [
        ("latitude", -90.0, 90.0),
        ("longitude", -180.0, 180.0),
        ("UTC offset", -14.0, 14.0),
        ("elevation", -1000.0, 10000.0),
    ];
    for (x, (name, lo, hi)) in v.iter().zip(ranges) {
        if !(lo..=hi).contains(x) {
            return Err(bad(&format!("{name} {x} is outside [{lo}, {hi}]")));
        }
    }
    Ok(crate::site::Site {
        latitude: v[0],
        longitude: v[1],
        utc_offset_h: v[2],
        elevation_m: v.get(3).copied().unwrap_or(0.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn site_flag_is_three_or_four_numbers_in_range() {
        let s = site("36.1,-79.95,-5").unwrap();
        assert_eq!(
            (s.latitude, s.longitude, s.utc_offset_h, s.elevation_m),
            (36.1, -79.95, -5.0, 0.0)
        );
        assert_eq!(site("0, 0, 0, 273").unwrap().elevation_m, 273.0);
        for bad in [
            "",
            "1,2",
            "1,2,3,4,5",
            "91,0,0",
            "0,181,0",
            "0,0,15",
            "0,0,0,20000",
            "a,b,c",
            "nan,0,0",
        ] {
            let e = site(bad).unwrap_err().to_string();
            assert!(e.contains("--site"), "{bad}: {e}");
        }
    }

    #[test]
    fn shard_accepts_k_of_n_only() {
        assert_eq!(shard(None).unwrap(), (1, 1));
        assert_eq!(shard(Some("2/3")).unwrap(), (2, 3));
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", "-1/2"] {
            let (shown, path, _, value) = crate::error::input_parts(shard(Some(bad)).unwrap_err());
            assert_eq!(path, Path::new("<argument --shard>"), "{shown}");
            assert_eq!(value.as_deref(), Some(bad));
        }
    }

    #[test]
    fn errors_name_the_flag_and_value() {
        let (_, path, _, value) = crate::error::input_parts(quality("fast", None).unwrap_err());
        assert_eq!(
            (path, value.as_deref()),
            ("<argument --quality>".into(), Some("fast"))
        );
        let only_dni = SkyParams {
            dni: Some(800.0),
            dhi: None,
            sky_type: None,
            turbidity: None,
            dew_point: None,
            image: None,
            mapping: crate::cli::args::MappingArg::Equirect,
            rotate: 0.0,
        };
        let e = sky_spec(SkyArg::Perez, &only_dni).unwrap_err();
        let (shown, path, _, _) = crate::error::input_parts(e);
        assert_eq!(path, Path::new("<argument --dhi>"));
        assert!(shown.contains("--sky perez needs --dhi"), "{shown}");
        let (_, path, _, value) = crate::error::input_parts(date("--end", "May 1").unwrap_err());
        assert_eq!(
            (path, value.as_deref()),
            ("<argument --end>".into(), Some("May 1"))
        );
        for bad in [0.0, 100.0, f64::NAN] {
            assert!(target(bad).is_err());
        }
        assert_eq!(target(50.0).unwrap(), 0.5);
    }

    #[test]
    fn knobs_keep_the_named_ladders_in_order() {
        let all = crate::sequence::convergence::ladders(&quality("draft", None).unwrap());
        let names: Vec<&str> = all.iter().map(|l| l.knob).collect();
        assert!(names.len() >= 2, "{names:?}");
        let list = format!("{} , {}", names[1], names[0]);
        let kept = knobs(all, Some(&list)).unwrap();
        let kept: Vec<&str> = kept.iter().map(|l| l.knob).collect();
        assert_eq!(kept, [names[0], names[1]]);
        let all = crate::sequence::convergence::ladders(&quality("draft", None).unwrap());
        let Err(e) = knobs(all, Some("colour")) else {
            panic!("an unknown knob is refused")
        };
        let (shown, _, _, value) = crate::error::input_parts(e);
        assert_eq!(value.as_deref(), Some("colour"));
        assert!(shown.contains(names[0]), "{shown}");
    }
}
