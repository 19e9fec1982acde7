//! Daylight glare probability (Wienold & Christoffersen 2006) and vertical eye
//! illuminance from an angular fisheye (`-vta`) radiance image, the way Radiance's
//! evalglare computes them (its `evalglare.c` and `pictool.c`, version 3.06, read for the
//! rules below; no code taken):
//!
//! - every pixel whose centre looks into the view's front hemisphere counts, with its
//!   solid angle ω (for the angular fisheye, [`angular_pixel_solid_angle`]);
//! - Ev = Σ L cosθ ω, lux, with L = 179 × grey cd/m² and θ from the view direction;
//! - a pixel is a glare-source pixel when L exceeds the threshold: a factor times the
//!   ω-weighted mean luminance of the image (evalglare `-b f` with f ≤ 100 and no task
//!   area), or a fixed luminance (`-b L` with L > 100; 2000 cd/m² is evalglare's default
//!   since its version 2.05);
//! - source pixels are grouped into one source when they lie within half the search
//!   radius of each other (evalglare `-r`, 0.2 rad: it compares twice the angle between
//!   pixel directions with `-r`), transitively;
//! - peak extraction (evalglare `-y`, on by default): the pixels of 50 000 cd/m² or more
//!   are taken out of their source and grouped among themselves the same way, so a sun
//!   disc in a bright window is its own source;
//! - a source's luminance is its ω-weighted mean, its solid angle the sum of its pixels',
//!   its position the L·ω-weighted mean pixel position, where the Guth position index
//!   ([`position_index`]) is evaluated (Iwata's form below the line of sight);
//! - DGP = 5.87e-5·Ev + 9.18e-2·log10(1 + Σ Ls²·ωs / (Ev^1.87·Ps²)) + 0.16, at most 1,
//!   times the low-light factor exp(0.024·Ev − 4)/(1 + exp(0.024·Ev − 4)) when Ev < 1000
//!   lx (evalglare `-C l+`).
//!
//! Where this differs from evalglare: the coefficients are the published ones (evalglare
//! rounds them to 0.092 and 0.159, at most 0.0012 of DGP); the position index is evaluated
//! at the exact centroid rather than at the pixel its coordinates truncate to; pixel solid
//! angles come from the angular fisheye's area element rather than from the spherical
//! quadrilateral of the pixel corners; evalglare's smoothing (`-s`), task areas (`-t`),
//! zones and the Guth field-of-view cut (`-G`) are not offered; and two neighbouring
//! sources of exactly equal solid angle, which evalglare leaves apart, are merged.

use crate::error::{Error, Result};
use crate::render::image::{Image, Quantity};
use crate::scene::view::{View, ViewType};
use glam::DVec3;

/// DGP's vertical-illuminance coefficient, 1/lux (Wienold & Christoffersen 2006).
pub const DGP_C1_PER_LUX: f64 = 5.87e-5;
/// DGP's coefficient of the log10 glare term (dimensionless).
pub const DGP_C2: f64 = 9.18e-2;
/// DGP's constant term (dimensionless).
pub const DGP_C3: f64 = 0.16;
/// Exponent of Ev (lux) in the glare term's denominator.
pub const DGP_EV_EXPONENT: f64 = 1.87;
/// Below this vertical illuminance, lux, the low-light correction applies.
pub const LOW_LIGHT_LIMIT_LUX: f64 = 1000.0;

/// How glare-source pixels are told from the rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Threshold {
    /// Pixels brighter than this factor times the image's ω-weighted mean luminance
    /// (the task area being the whole image, as evalglare `-b factor` without `-t`).
    TaskFactor(f64),
    /// Pixels brighter than this luminance, cd/m² (evalglare `-b value`, value > 100).
    Absolute(f64),
}

/// Settings of [`glare`]; the defaults are those named on each field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlareOptions {
    /// Glare-source threshold; default `TaskFactor(5.0)`. (evalglare 3.06's own default
    /// is `Absolute(2000.0)`.)
    pub threshold: Threshold,
    /// evalglare's search radius `-r`, rad; default 0.2. Source pixels within half of it
    /// of each other belong to the same source.
    pub search_radius_rad: f64,
    /// Peak extraction limit, cd/m² (evalglare `-Y`); default `Some(50 000)`; `None`
    /// turns it off (evalglare `-x`).
    pub peak_extraction_cd_m2: Option<f64>,
    /// Applies the low-light correction below 1000 lx; default true (evalglare `-C l+`;
    /// evalglare 3.06 leaves it off unless asked).
    pub low_light_correction: bool,
}

impl Default for GlareOptions {
    fn default() -> Self {
        GlareOptions {
            threshold: Threshold::TaskFactor(5.0),
            search_radius_rad: 0.2,
            peak_extraction_cd_m2: Some(50_000.0),
            low_light_correction: true,
        }
    }
}

/// One glare source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlareSource {
    /// Unit direction from the eye to the source's luminance-weighted centre (scene
    /// frame).
    pub direction: DVec3,
    /// Solid-angle-weighted mean luminance, cd/m².
    pub luminance_cd_m2: f64,
    /// Solid angle, sr.
    pub solid_angle_sr: f64,
    /// Guth position index at `direction` (dimensionless, 1 on the line of sight, at most
    /// 16).
    pub position_index: f64,
}

/// The result of [`glare`].
#[derive(Clone, Debug, PartialEq)]
pub struct Glare {
    /// Daylight glare probability, 0–1 (dimensionless).
    pub dgp: f64,
    /// Vertical illuminance at the eye, lux.
    pub ev_lux: f64,
    /// The glare sources found.
    pub sources: Vec<GlareSource>,
    /// The luminance a pixel had to exceed to be a source pixel, cd/m².
    pub threshold_cd_m2: f64,
}

/// Solid angle, sr, of the pixel at (`col` from the left, `row` from the top) of a
/// `width × height` angular fisheye image of `view`: the projection's area element
/// dω = sin|a| / |a| · dax · day (a the image-plane angle vector, rad) integrated over
/// the pixel with a 2 × 2 Gauss rule. Zero for views of other types.
pub fn angular_pixel_solid_angle(
    view: &View,
    width: usize,
    height: usize,
    col: usize,
    row: usize,
) -> f64 {
    if view.kind != ViewType::Angular || width == 0 || height == 0 {
        return 0.0;
    }
    let (sh, sv) = (view.vh.to_radians(), view.vv.to_radians());
    let (dax, day) = (sh / width as f64, sv / height as f64);
    let x = (col as f64 + 0.5) / width as f64 - 0.5 + view.vs;
    let y = 1.0 - (row as f64 + 0.5) / height as f64 - 0.5 + view.vl;
    let (ax, ay) = (x * sh, y * sv);
    let g = 0.5 / 3f64.sqrt();
    let sinc = |t: f64| if t < 1e-12 { 1.0 } else { t.sin() / t };
    let mut s = 0.0;
    for u in [-g, g] {
        for v in [-g, g] {
            s += sinc((ax + u * dax).hypot(ay + v * day));
        }
    }
    (s / 4.0).max(0.0) * dax * day
}

/// Guth position index (dimensionless) of `direction` (unit, scene frame) seen from
/// `view`, as evalglare computes it: σ the angle from the view direction, τ the angle
/// between the up vector and the direction's projection across the view direction
/// (degrees); above the line of sight
/// P = exp((35.2 − 0.31889τ − 1.22·e^(−2τ/9))·10⁻³·σ + (21 + 0.26667τ − 0.002963τ²)·10⁻⁵·σ²),
/// below it Iwata & Osterhaus's P = exp(6.49·10⁻³·β + 21·10⁻⁵·β²) with
/// β = atan(tan σ·√(1 + 0.3225 cos²τ)); at most 16.
pub fn position_index(view: &View, direction: DVec3) -> f64 {
    let vd = view.vd.normalize();
    let up = view.vu.normalize();
    let d = direction.normalize();
    let cos_s = d.dot(vd).clamp(-1.0, 1.0);
    let sigma = cos_s.acos().to_degrees();
    // evalglare takes d / cos σ − vd; across vd that is d's projection (flipped behind).
    let across = (d - vd * cos_s) * cos_s.signum();
    let across = across.try_normalize().unwrap_or(DVec3::ZERO);
    let tau = up.dot(across).clamp(-1.0, 1.0).acos().to_degrees();
    // evalglare's vertical axis vd × (vd × up) points down for an upright view.
    let below = vd.cross(vd.cross(up)).dot(d) > 0.0;
    let p = if below {
        let beta = (sigma.to_radians().tan()
            * (1.0 + 0.3225 * tau.to_radians().cos().powi(2)).sqrt())
        .atan()
        .to_degrees();
        (6.49e-3 * beta + 21e-5 * beta * beta).exp()
    } else {
        ((35.2 - 0.31889 * tau - 1.22 * (-2.0 * tau / 9.0).exp()) * 1e-3 * sigma
            + (21.0 + 0.26667 * tau - 0.002963 * tau * tau) * 1e-5 * sigma * sigma)
            .exp()
    };
    p.min(16.0)
}

/// DGP (dimensionless, 0–1) from the vertical illuminance `ev_lux` and the sources:
/// 5.87e-5·Ev + 9.18e-2·log10(1 + Σ Ls²·ωs/(Ev^1.87·Ps²)) + 0.16, at most 1, times
/// exp(0.024·Ev − 4)/(1 + exp(0.024·Ev − 4)) when `low_light` and Ev < 1000 lx.
pub fn daylight_glare_probability(ev_lux: f64, sources: &[GlareSource], low_light: bool) -> f64 {
    let sum: f64 = sources
        .iter()
        .map(|s| s.luminance_cd_m2.powi(2) * s.solid_angle_sr / s.position_index.powi(2))
        .sum();
    let term = if ev_lux > 0.0 && sum > 0.0 {
        DGP_C2 * (1.0 + sum / ev_lux.powf(DGP_EV_EXPONENT)).log10()
    } else {
        0.0
    };
    let dgp = (DGP_C1_PER_LUX * ev_lux + term + DGP_C3).min(1.0);
    if low_light && ev_lux < LOW_LIGHT_LIMIT_LUX {
        let e = (0.024 * ev_lux - 4.0).exp();
        dgp * e / (1.0 + e)
    } else {
        dgp
    }
}

/// DGP, vertical illuminance and glare sources of an angular fisheye radiance `image`
/// rendered with `view` (see the module's notes for the rules).
///
/// # Errors
/// A view that is not angular (`-vta`), an irradiance image, an image without pixels or
/// with none in the view's front hemisphere, a pixel count that does not match the size,
/// or options out of range (a non-positive threshold or search radius).
pub fn glare(image: &Image, view: &View, options: &GlareOptions) -> Result<Glare> {
    let src = "<glare image>";
    if view.kind != ViewType::Angular {
        return Err(Error::input(
            src,
            None,
            Some(&view.options()),
            "glare needs an angular fisheye view (-vta)",
        ));
    }
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 {
        return Err(Error::input(
            src,
            None,
            Some(&format!("{w}x{h}")),
            "glare needs a non-empty image",
        ));
    }
    if image.rgb.len() != w * h || (!image.valid.is_empty() && image.valid.len() != w * h) {
        return Err(Error::Internal(format!(
            "image of {w}×{h} holds {} values and {} flags",
            image.rgb.len(),
            image.valid.len()
        )));
    }
    if image.quantity != Quantity::Radiance {
        return Err(Error::input(
            src,
            None,
            Some(image.quantity.unit()),
            "glare needs a radiance image, not an irradiance one",
        ));
    }
    let (threshold_value, threshold_name) = match options.threshold {
        Threshold::TaskFactor(f) => (f, "threshold factor"),
        Threshold::Absolute(l) => (l, "threshold luminance"),
    };
    if !(threshold_value > 0.0 && threshold_value.is_finite()) {
        return Err(Error::arg(
            threshold_name,
            threshold_value,
            "must be positive",
        ));
    }
    if !(options.search_radius_rad > 0.0 && options.search_radius_rad.is_finite()) {
        return Err(Error::arg(
            "search radius",
            options.search_radius_rad,
            "must be positive (rad)",
        ));
    }

    // Per pixel: direction, solid angle, luminance; counted when in front of the eye.
    let vd = view.vd.normalize();
    let n = w * h;
    let mut dirs = vec![DVec3::ZERO; n];
    let mut omega = vec![0.0; n];
    let mut lum = vec![0.0; n];
    let mut inside = vec![false; n];
    let (mut sang, mut lsum, mut ev) = (0.0, 0.0, 0.0);
    for row in 0..h {
        for col in 0..w {
            let i = row * w + col;
            if !image.valid.get(i).copied().unwrap_or(true) {
                continue;
            }
            let Some((_, d)) = view.ray(
                (col as f64 + 0.5) / w as f64,
                1.0 - (row as f64 + 0.5) / h as f64,
            ) else {
                continue;
            };
            let cos = d.dot(vd);
            let om = angular_pixel_solid_angle(view, w, h, col, row);
            dirs[i] = d;
            if cos < 0.0 || om <= 0.0 {
                continue;
            }
            let l = image.photometric(i);
            inside[i] = true;
            omega[i] = om;
            lum[i] = l;
            sang += om;
            lsum += om * l;
            ev += cos * om * l;
        }
    }
    if sang <= 0.0 {
        return Err(Error::input(
            src,
            None,
            Some(&view.options()),
            "no pixel of the image looks into the view's front hemisphere",
        ));
    }
    let threshold_cd_m2 = match options.threshold {
        Threshold::TaskFactor(f) => f * lsum / sang,
        Threshold::Absolute(l) => l,
    };
    let is_source: Vec<bool> = (0..n)
        .map(|i| inside[i] && lum[i] > threshold_cd_m2)
        .collect();

    // evalglare groups nothing when its search radius is under a pixel (from the angle
    // between the centre pixel and the one 10 pixels off diagonally): each source pixel
    // is then a source, and peaks are not extracted.
    let px = |c: f64, r_from_bottom: f64| {
        view.ray((c + 0.5) / w as f64, (r_from_bottom + 0.5) / h as f64)
            .map(|(_, d)| d)
    };
    let (cx, cy) = ((w / 2) as f64, (h / 2) as f64);
    let pixel_angle = match (px(cx, cy), px(cx + 10.0, cy + 10.0)) {
        (Some(a), Some(b)) => a.dot(b).clamp(-1.0, 1.0).acos() * 2.0 / 10.0,
        _ => f64::INFINITY,
    };
    let grouping = options.search_radius_rad / pixel_angle > 1.0;

    let groups: Vec<Vec<usize>> = if grouping {
        let cos_lim = (options.search_radius_rad / 2.0).cos();
        // The angular fisheye shrinks angles across the radius by at most sin θ / θ ≥ 2/π
        // inside the hemisphere, which bounds the pixel box to search.
        let step = (view.vh.to_radians() / w as f64).min(view.vv.to_radians() / h as f64);
        let half = ((options.search_radius_rad / 2.0) / (step * 2.0 / std::f64::consts::PI)).ceil()
            as usize
            + 1;
        let parents = components(&is_source, w, h, &dirs, cos_lim, half);
        let peak_limit = options
            .peak_extraction_cd_m2
            .filter(|&limit| (0..n).any(|i| is_source[i] && lum[i] > limit));
        match peak_limit {
            None => parents,
            Some(limit) => {
                let is_peak: Vec<bool> = (0..n).map(|i| is_source[i] && lum[i] >= limit).collect();
                let peaks = components(&is_peak, w, h, &dirs, cos_lim, half);
                let mut out: Vec<Vec<usize>> = parents
                    .into_iter()
                    .map(|g| g.into_iter().filter(|&i| !is_peak[i]).collect::<Vec<_>>())
                    .filter(|g| !g.is_empty())
                    .collect();
                out.extend(peaks);
                out
            }
        }
    } else {
        (0..n).filter(|&i| is_source[i]).map(|i| vec![i]).collect()
    };

    let sources: Vec<GlareSource> = groups
        .iter()
        .filter_map(|g| {
            let om: f64 = g.iter().map(|&i| omega[i]).sum();
            let lo: f64 = g.iter().map(|&i| omega[i] * lum[i]).sum();
            if om <= 0.0 || lo <= 0.0 {
                return None;
            }
            // Pixel coordinates as evalglare keeps them: x from the left, y from the
            // bottom, weighted by L·ω.
            let (mut sx, mut sy) = (0.0, 0.0);
            for &i in g {
                let (col, row) = (i % w, i / w);
                let wgt = omega[i] * lum[i];
                sx += col as f64 * wgt;
                sy += (h - 1 - row) as f64 * wgt;
            }
            let direction = px(sx / lo, sy / lo)?;
            Some(GlareSource {
                direction,
                luminance_cd_m2: lo / om,
                solid_angle_sr: om,
                position_index: position_index(view, direction),
            })
        })
        .collect();
    let dgp = daylight_glare_probability(ev, &sources, options.low_light_correction);
    Ok(Glare {
        dgp,
        ev_lux: ev,
        sources,
        threshold_cd_m2,
    })
}

/// Groups the pixels flagged in `mask` that are 8-adjacent or whose directions are within
/// the angle of cosine `cos_lim`, transitively; `half` bounds the pixel box searched.
/// Only pixels on a group's edge need the angular search: a pixel within reach of an
/// inner pixel is within reach of an edge pixel between them or joined by adjacency.
fn components(
    mask: &[bool],
    w: usize,
    h: usize,
    dirs: &[DVec3],
    cos_lim: f64,
    half: usize,
) -> Vec<Vec<usize>> {
    let n = w * h;
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let union = |p: &mut Vec<usize>, a: usize, b: usize| {
        let (ra, rb) = (find(p, a), find(p, b));
        if ra != rb {
            p[ra.max(rb)] = ra.min(rb);
        }
    };
    let at = |c: isize, r: isize| -> Option<usize> {
        (c >= 0 && r >= 0 && (c as usize) < w && (r as usize) < h)
            .then(|| r as usize * w + c as usize)
    };
    let mut edge = vec![false; n];
    for r in 0..h {
        for c in 0..w {
            let i = r * w + c;
            if !mask[i] {
                continue;
            }
            for (dc, dr) in [
                (-1, -1),
                (0, -1),
                (1, -1),
                (-1, 0),
                (1, 0),
                (-1, 1),
                (0, 1),
                (1, 1),
            ] {
                match at(c as isize + dc, r as isize + dr) {
                    Some(j) if mask[j] => union(&mut parent, i, j),
                    _ => edge[i] = true,
                }
            }
        }
    }
    let edges: Vec<usize> = (0..n).filter(|&i| edge[i]).collect();
    for &i in &edges {
        let (c, r) = ((i % w) as isize, (i / w) as isize);
        let k = half as isize;
        for rr in (r - k).max(0)..=(r + k).min(h as isize - 1) {
            for cc in (c - k).max(0)..=(c + k).min(w as isize - 1) {
                let j = rr as usize * w + cc as usize;
                if j != i && edge[j] && dirs[i].dot(dirs[j]) >= cos_lim {
                    union(&mut parent, i, j);
                }
            }
        }
    }
    let mut index = std::collections::HashMap::new();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for i in (0..n).filter(|&i| mask[i]) {
        let root = find(&mut parent, i);
        let g = *index.entry(root).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[g].push(i);
    }
    groups
}

#[cfg(test)]
#[path = "glare_tests.rs"]
mod tests;
