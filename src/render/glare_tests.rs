//! Tests of the glare metrics (`super`).

use super::*;
use crate::photometry::Rgb;
use std::f64::consts::PI;
use std::path::Path;

fn fisheye(extra: &str) -> View {
    View::default()
        .with_options(
            &format!("-vta -vp 0 0 0 -vd 0 1 0 -vu 0 0 1 -vh 180 -vv 180 {extra}"),
            Path::new("<test>"),
            None,
        )
        .unwrap()
}

/// An image of `size²` pixels whose luminance (cd/m²) is `f(direction)`.
fn scene(view: &View, size: usize, f: impl Fn(DVec3) -> f64) -> Image {
    let mut im = Image::new(size, size, Quantity::Radiance);
    for row in 0..size {
        for col in 0..size {
            let x = (col as f64 + 0.5) / size as f64;
            let y = 1.0 - (row as f64 + 0.5) / size as f64;
            let l = view.ray(x, y).map(|(_, d)| f(d)).unwrap_or(0.0);
            im.rgb[row * size + col] = Rgb::splat(l / 179.0);
        }
    }
    im
}

fn sums(view: &View, size: usize) -> (f64, f64) {
    let (mut s, mut sc) = (0.0, 0.0);
    for row in 0..size {
        for col in 0..size {
            let x = (col as f64 + 0.5) / size as f64;
            let y = 1.0 - (row as f64 + 0.5) / size as f64;
            if let Some((_, d)) = view.ray(x, y) {
                let c = d.dot(view.vd);
                if c >= 0.0 {
                    let om = angular_pixel_solid_angle(view, size, size, col, row);
                    s += om;
                    sc += om * c;
                }
            }
        }
    }
    (s, sc)
}

#[test]
fn pixel_solid_angles_cover_the_hemisphere() {
    let v = fisheye("");
    let (s, sc) = sums(&v, 151);
    assert!((s / (2.0 * PI) - 1.0).abs() < 0.005, "Σω = {s}");
    assert!((sc / PI - 1.0).abs() < 0.002, "Σω cosθ = {sc}");
    // A narrower fisheye covers the cap of half-angle 45°: 2π(1 − cos 45°) inside the
    // inscribed circle of a square image (the corners reach further).
    let narrow = fisheye("-vh 90 -vv 90");
    let mut cap = 0.0;
    for row in 0..101 {
        for col in 0..101 {
            let (x, y) = ((col as f64 + 0.5) / 101.0, 1.0 - (row as f64 + 0.5) / 101.0);
            if (x - 0.5).hypot(y - 0.5) <= 0.5 {
                cap += angular_pixel_solid_angle(&narrow, 101, 101, col, row);
            }
        }
    }
    let want = 2.0 * PI * (1.0 - 45f64.to_radians().cos());
    assert!((cap / want - 1.0).abs() < 0.01, "{cap} vs {want}");
    assert_eq!(
        angular_pixel_solid_angle(&View::default(), 10, 10, 5, 5),
        0.0
    );
}

#[test]
fn uniform_hemisphere_gives_pi_l_and_no_source() {
    let v = fisheye("");
    for l in [1000.0, 100.0] {
        let g = glare(&scene(&v, 121, |_| l), &v, &GlareOptions::default()).unwrap();
        assert!((g.ev_lux / (PI * l) - 1.0).abs() < 0.005, "Ev {}", g.ev_lux);
        assert!(g.sources.is_empty());
        assert!((g.threshold_cd_m2 / (5.0 * l) - 1.0).abs() < 1e-9);
        let ev = PI * l;
        let mut want = DGP_C1_PER_LUX * ev + DGP_C3;
        if ev < 1000.0 {
            want *= (0.024 * ev - 4.0).exp() / (1.0 + (0.024 * ev - 4.0).exp());
        }
        assert!((g.dgp - want).abs() < 1e-3, "L {l}: {} vs {want}", g.dgp);
    }
}

#[test]
fn bright_disc_on_the_line_of_sight() {
    let v = fisheye("");
    let (lb, ls, alpha) = (200.0, 30_000.0, 0.12_f64);
    // An odd size puts a pixel centre on the line of sight, so the disc's centroid is
    // exactly there.
    let im = scene(&v, 201, |d| {
        if d.angle_between(v.vd) <= alpha {
            ls
        } else {
            lb
        }
    });
    let g = glare(&im, &v, &GlareOptions::default()).unwrap();
    assert_eq!(g.sources.len(), 1, "{:?}", g.sources);
    let s = g.sources[0];
    assert!((s.luminance_cd_m2 - ls).abs() < 1e-6 * ls);
    assert!(
        (s.position_index - 1.0).abs() < 1e-6,
        "P = {}",
        s.position_index
    );
    assert!(s.direction.angle_between(v.vd) < 1e-9);
    // Closed forms: the cap's solid angle and its cosine-weighted one, π sin²α.
    let omega = 2.0 * PI * (1.0 - alpha.cos());
    let ev = PI * lb + (ls - lb) * PI * alpha.sin().powi(2);
    assert!(
        (s.solid_angle_sr / omega - 1.0).abs() < 0.04,
        "{}",
        s.solid_angle_sr
    );
    assert!((g.ev_lux / ev - 1.0).abs() < 0.01, "{} vs {ev}", g.ev_lux);
    let want = DGP_C1_PER_LUX * ev
        + DGP_C2 * (1.0 + ls * ls * omega / ev.powf(DGP_EV_EXPONENT)).log10()
        + DGP_C3;
    assert!((g.dgp - want).abs() < 0.004, "{} vs {want}", g.dgp);
}

#[test]
fn position_index_follows_guth_above_and_iwata_below() {
    let v = fisheye("");
    // σ from the view direction (+y), τ from up (+z) towards right (+x).
    let dir = |sigma: f64, tau: f64| {
        let (s, t) = (sigma.to_radians(), tau.to_radians());
        DVec3::new(s.sin() * t.sin(), s.cos(), s.sin() * t.cos())
    };
    let guth = |s: f64, t: f64| {
        ((35.2 - 0.31889 * t - 1.22 * (-2.0 * t / 9.0).exp()) * 1e-3 * s
            + (21.0 + 0.26667 * t - 0.002963 * t * t) * 1e-5 * s * s)
            .exp()
    };
    assert!((position_index(&v, v.vd) - 1.0).abs() < 1e-12);
    for (s, t) in [
        (30.0, 0.0),
        (60.0, 90.0),
        (20.0, 45.0),
        (45.0, 270.0 + 20.0),
    ] {
        let p = position_index(&v, dir(s, t));
        // τ is unsigned: left and right mirror each other.
        let tu = if t > 180.0 { 360.0 - t } else { t };
        assert!((p - guth(s, tu).min(16.0)).abs() < 1e-9, "σ {s} τ {t}: {p}");
    }
    // Straight below, 30°: β = atan(tan 30° · √1.3225).
    let beta = (30f64.to_radians().tan() * 1.3225f64.sqrt())
        .atan()
        .to_degrees();
    let want = (6.49e-3 * beta + 21e-5 * beta * beta).exp();
    assert!((position_index(&v, dir(30.0, 180.0)) - want).abs() < 1e-9);
    assert!(position_index(&v, dir(30.0, 180.0)) < position_index(&v, dir(30.0, 0.0)));
    assert_eq!(position_index(&v, dir(89.0, 0.0)), 16.0, "capped");
}

#[test]
fn sources_merge_within_half_the_search_radius_and_peaks_split() {
    let v = fisheye("");
    let spot = |c: DVec3, r: f64| move |d: DVec3| d.angle_between(c) <= r;
    let at = |az: f64| DVec3::new(az.to_radians().sin(), az.to_radians().cos(), 0.0);
    let opts = GlareOptions {
        threshold: Threshold::Absolute(2000.0),
        ..Default::default()
    };
    // Two discs of radius 0.04 rad, gaps 0.05 rad (merged) and 0.15 rad (apart: more
    // than half of evalglare's 0.2 rad, though less than all of it).
    for (gap, n) in [(0.05, 1), (0.15, 2)] {
        let sep = (0.08_f64 + gap).to_degrees();
        let (a, b) = (spot(at(0.0), 0.04), spot(at(sep), 0.04));
        let im = scene(&v, 201, |d| if a(d) || b(d) { 10_000.0 } else { 100.0 });
        let g = glare(&im, &v, &opts).unwrap();
        assert_eq!(g.sources.len(), n, "gap {gap}");
    }
    // A sun-like disc inside a bright patch is taken out as its own source; the rest
    // of the patch keeps exactly the patch luminance.
    let (patch, sun) = (spot(at(20.0), 0.3), spot(at(20.0), 0.05));
    let im = scene(&v, 201, |d| {
        if sun(d) {
            1e6
        } else if patch(d) {
            5000.0
        } else {
            100.0
        }
    });
    let g = glare(&im, &v, &opts).unwrap();
    let mut ls: Vec<f64> = g.sources.iter().map(|s| s.luminance_cd_m2).collect();
    ls.sort_by(f64::total_cmp);
    assert_eq!(ls.len(), 2, "{ls:?}");
    assert!(
        (ls[0] - 5000.0).abs() < 1e-6 && (ls[1] - 1e6).abs() < 1e-3,
        "{ls:?}"
    );
    let off = GlareOptions {
        peak_extraction_cd_m2: None,
        ..opts
    };
    assert_eq!(glare(&im, &v, &off).unwrap().sources.len(), 1);
    // Splitting raises Σ L²ω (the mean of a square exceeds the square of the mean).
    assert!(g.dgp > glare(&im, &v, &off).unwrap().dgp);
}

#[test]
fn wrong_views_and_empty_images_are_errors() {
    let v = fisheye("");
    let im = scene(&v, 21, |_| 100.0);
    let persp = View::default();
    let e = glare(&im, &persp, &GlareOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("-vta") && e.contains("-vtv"), "{e}");
    let empty = Image::new(0, 0, Quantity::Radiance);
    assert!(glare(&empty, &v, &GlareOptions::default()).is_err());
    let mut irr = im.clone();
    irr.quantity = Quantity::Irradiance;
    assert!(glare(&irr, &v, &GlareOptions::default()).is_err());
    let bad = GlareOptions {
        threshold: Threshold::TaskFactor(-1.0),
        ..Default::default()
    };
    assert!(glare(&im, &v, &bad).is_err());
    let mut none = im.clone();
    none.valid.iter_mut().for_each(|b| *b = false);
    assert!(glare(&none, &v, &GlareOptions::default()).is_err());
}
