//! Scenes built in code from closed-form geometry, and helpers to run the pipeline on them.

#![allow(dead_code)]
// Box and rectangle helpers take their coordinates as plain arguments, like the formulas.
#![allow(clippy::too_many_arguments)]

use daystep::photometry::Rgb;
use daystep::scene::{Material, ModelInput, Scene, Triangle};
use daystep::sequence::report::Report;
use daystep::sequence::{instant::run_sky, InstantResult, Quality};
use daystep::site::Site;
use daystep::sky::{Sky, SkyDistribution, Sun};
use glam::DVec3;
use std::path::Path;

/// A scene under construction in the model frame.
#[derive(Default)]
pub struct Builder {
    pub input: ModelInput,
}

impl Builder {
    pub fn new() -> Self {
        let mut b = Builder::default();
        b.input.site = Site::default();
        b.input.ground_reflectance = 0.0;
        b
    }
    pub fn material(&mut self, name: &str, kd: f64, tf: f64) -> u32 {
        self.input.materials.push(Material {
            name: name.into(),
            kd: Rgb::splat(kd),
            tf: Rgb::splat(tf),
            ke: Rgb::ZERO,
        });
        self.input.materials.len() as u32 - 1
    }
    /// A planar quad a, b, c, d counter-clockwise seen from its front.
    pub fn quad(&mut self, q: [DVec3; 4], material: u32) {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            self.input.triangles.push(Triangle {
                v: t,
                material,
                group: 0,
            });
        }
    }
    /// Horizontal rectangle [x0,x1]×[y0,y1] at height z facing up (+z) or down.
    pub fn hrect(&mut self, x0: f64, x1: f64, y0: f64, y1: f64, z: f64, up: bool, m: u32) {
        let q = [
            DVec3::new(x0, y0, z),
            DVec3::new(x1, y0, z),
            DVec3::new(x1, y1, z),
            DVec3::new(x0, y1, z),
        ];
        if up {
            self.quad(q, m)
        } else {
            self.quad([q[0], q[3], q[2], q[1]], m)
        }
    }
    /// Horizontal rectangle with a rectangular hole (4 rectangles around it).
    pub fn hrect_with_hole(
        &mut self,
        outer: (f64, f64, f64, f64),
        hole: (f64, f64, f64, f64),
        z: f64,
        up: bool,
        m: u32,
    ) {
        let (x0, x1, y0, y1) = outer;
        let (hx0, hx1, hy0, hy1) = hole;
        self.hrect(x0, x1, y0, hy0, z, up, m);
        self.hrect(x0, x1, hy1, y1, z, up, m);
        self.hrect(x0, hx0, hy0, hy1, z, up, m);
        self.hrect(hx1, x1, hy0, hy1, z, up, m);
    }
    /// Four vertical walls of the box [x0,x1]×[y0,y1]×[z0,z1], facing inwards.
    pub fn walls_inward(&mut self, x0: f64, x1: f64, y0: f64, y1: f64, z0: f64, z1: f64, m: u32) {
        let p = |x, y, z| DVec3::new(x, y, z);
        self.quad(
            [p(x0, y0, z0), p(x0, y0, z1), p(x1, y0, z1), p(x1, y0, z0)],
            m,
        ); // south, +y
        self.quad(
            [p(x1, y1, z0), p(x1, y1, z1), p(x0, y1, z1), p(x0, y1, z0)],
            m,
        ); // north, -y
        self.quad(
            [p(x0, y1, z0), p(x0, y1, z1), p(x0, y0, z1), p(x0, y0, z0)],
            m,
        ); // west, +x
        self.quad(
            [p(x1, y0, z0), p(x1, y0, z1), p(x1, y1, z1), p(x1, y1, z0)],
            m,
        ); // east, -x
    }
    pub fn sensor(&mut self, p: DVec3, n: DVec3) {
        self.input.sensors.push((p, n));
    }
    pub fn build(self) -> Scene {
        Scene::from_model(Path::new("<test>"), self.input).expect("test scene is valid")
    }
}

/// A sky with a given distribution and optional sun, ground glow as given.
pub fn sky_of(dist: Option<Box<dyn SkyDistribution>>, sun: Option<Sun>, ground: f64) -> Sky {
    Sky {
        distribution: dist,
        sun,
        ground_radiance: Rgb::splat(ground),
        description: "test".into(),
        warnings: vec![],
    }
}

/// Uniform sky of radiance `l` (W·sr⁻¹·m⁻², white).
pub struct Uniform(pub f64);
impl SkyDistribution for Uniform {
    fn radiance(&self, _: DVec3) -> Rgb {
        Rgb::splat(self.0)
    }
}

/// Moon–Spencer overcast: L = L_z (1 + 2 cos Z)/3.
pub struct MoonSpencer(pub f64);
impl SkyDistribution for MoonSpencer {
    fn radiance(&self, d: DVec3) -> Rgb {
        Rgb::splat(self.0 * (1.0 + 2.0 * d.z) / 3.0)
    }
}

pub fn run(scene: &Scene, sky: &Sky, quality: &Quality) -> InstantResult {
    let mut report = Report::default();
    run_sky(scene, sky, quality, &mut report)
}

/// The widest honest stated error (`lux_err`/`lux`, `df_err`/`df`) of one sensor at the
/// `draft` preset. The error estimate is mainly the difference to a run with every knob
/// coarsened ×2 (see the README's *The error estimate*): for a first-order method that is
/// about the coarser run's own error, about twice this run's. The largest error `draft` has
/// been measured to make against `reference` is 12.5 % (README, *Quality presets*), so an
/// estimate beyond twice that no longer estimates anything: an error bar inflated by a
/// defect (a term counted twice, a noise estimate not divided by √n) would still cover the
/// truth, and only this cap fails it.
pub const DRAFT_STATED_ERROR_CAP: f64 = 2.0 * 0.125;

/// Illuminance (lux) of a white irradiance of `w` W/m².
pub fn lux_of(w: f64) -> f64 {
    179.0 * w
}

/// Asserts |actual − expected| ≤ tol, printing all three.
#[track_caller]
pub fn assert_close(what: &str, actual: f64, expected: f64, tol: f64) {
    assert!(
        (actual - expected).abs() <= tol,
        "{what}: actual {actual}, expected {expected}, tolerance {tol}, error {}",
        (actual - expected).abs()
    );
}

/// A uniform sky through the 1 m × 1 m roof opening 3 m above sensor 0 of the roof-hole
/// boxes (read from HBJSON and from `.rad`): sensor 0 reads πL · 4·F(0.5, 0.5, 3) within
/// 2 %, and sensor 1, which sees the opening obliquely, less.
#[track_caller]
pub fn assert_roof_opening_configuration_factor(scene: &Scene) {
    let l = 10.0;
    let r = run(
        scene,
        &sky_of(Some(Box::new(Uniform(l))), None, 0.0),
        &Quality::default(),
    );
    // The opening seen from the floor below its centre: F = 4·F(0.5, 0.5, 3).
    let expected = lux_of(std::f64::consts::PI * l * 4.0 * f_parallel(0.5, 0.5, 3.0));
    let got = r.sensors[0].lux;
    assert_close("under the opening", got, expected, 0.02 * expected);
    assert!(r.sensors[1].lux < got, "{} vs {got}", r.sensors[1].lux);
}

/// Configuration factor of a parallel rectangle a × b at height h with one corner above
/// the point (docs/derivations.md, "Configuration factor: point to a parallel rectangle").
pub fn f_parallel(a: f64, b: f64, h: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let sx = (1.0 + x * x).sqrt();
    let sy = (1.0 + y * y).sqrt();
    (x / sx * (y / sx).atan() + y / sy * (x / sy).atan()) / (2.0 * std::f64::consts::PI)
}

/// Runs the daystep binary with `args`, in a fresh temporary working directory (removed
/// afterwards): whatever the binary writes relative to it (the default `cache/` folder, a
/// relative `--out`) stays out of the project. Paths in `args` must be absolute.
pub fn daystep(args: &[&str]) -> std::process::Output {
    let cwd = tempfile::tempdir().expect("temporary folder");
    std::process::Command::new(env!("CARGO_BIN_EXE_daystep"))
        .args(args)
        .current_dir(cwd.path())
        .output()
        .expect("the binary runs")
}

/// The sample office's scene file.
pub fn office() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/scene.toml")
}

/// A finished process's standard error, as text.
pub fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}
