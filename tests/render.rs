//! Renders against closed forms: a diffuse plane under a uniform sky reads ρL, a sunlit
//! plane ρE cos θ/π, a pane seen against the sky τ(θ)L (the published Radiance-glass
//! table); the `-i` image reads the irradiance; images are the same whatever the thread
//! count.

use crate::util::*;
use daystep::cache::Store;
use daystep::photometry::Rgb;
use daystep::render::{Image, Quantity, RenderOptions};
use daystep::scene::view::View;
use daystep::scene::Scene;
use daystep::sequence::render::{Camera, Renderer};
use daystep::sequence::report::Report;
use daystep::sequence::Quality;
use daystep::sky::{Sky, Sun};
use glam::DVec3;
use std::f64::consts::PI;
use std::path::Path;

fn view(text: &str) -> View {
    View::default()
        .with_options(text, Path::new("test"), None)
        .expect("test view")
}

fn render(scene: &Scene, sky: &Sky, view: View, opts: RenderOptions) -> Image {
    let store = Store::disabled();
    let camera = Camera {
        view,
        options: opts,
    };
    let r = Renderer::new(scene, &Quality::preset("draft").unwrap(), &store, &camera);
    r.frame_sky(sky, Report::default()).image
}

fn small(quantity: Quantity) -> RenderOptions {
    RenderOptions {
        width: 24,
        height: 16,
        samples: 4,
        gather_rays: 16,
        quantity,
        ..RenderOptions::default()
    }
}

/// Every valid pixel's grey value is within `rel` of `expected`; returns how many.
fn all_close(img: &Image, expected: f64, rel: f64) -> usize {
    let mut n = 0;
    for (i, v) in img.rgb.iter().enumerate() {
        if !img.valid[i] {
            continue;
        }
        let g = daystep::photometry::grey(*v);
        assert!(
            (g - expected).abs() <= rel * expected,
            "pixel {i}: {g} against {expected}"
        );
        n += 1;
    }
    n
}

fn plane(rho: f64) -> Scene {
    let mut b = Builder::new();
    let m = b.material("floor", rho, 0.0);
    b.hrect(-20.0, 20.0, -20.0, 20.0, 0.0, true, m);
    b.build()
}

#[test]
fn a_diffuse_plane_under_a_uniform_sky_reads_rho_l() {
    let (rho, l) = (0.5, 10.0);
    let scene = plane(rho);
    let sky = sky_of(Some(Box::new(Uniform(l))), None, 0.0);
    for v in [
        "-vtl -vp 0 0 5 -vd 0 0 -1 -vu 0 1 0 -vh 8 -vv 6",
        "-vtv -vp 0 0 3 -vd 0.3 0 -1 -vu 0 1 0 -vh 60 -vv 45",
        "-vta -vp 0 0 2 -vd 0 0 -1 -vu 0 1 0 -vh 120 -vv 120",
    ] {
        let img = render(&scene, &sky, view(v), small(Quantity::Radiance));
        let n = all_close(&img, rho * l, 0.01);
        assert!(n > 100, "{v}: {n} pixels");
        // The -i image reads the irradiance, π L.
        let img = render(&scene, &sky, view(v), small(Quantity::Irradiance));
        all_close(&img, PI * l, 0.01);
    }
}

/// The filtered gather of a plane under a Moon–Spencer sky (noisy per pixel: the sky's
/// radiance varies 3× over the hemisphere) against the closed form ρ L_z 7/9: every pixel
/// within 4× its stated error, most within 1×, and the filter states well under half the
/// error of the same pixels unfiltered.
#[test]
fn a_filtered_plane_under_an_overcast_sky_reads_its_closed_form_within_its_error() {
    let (rho, lz) = (0.5, 10.0);
    let scene = plane(rho);
    let sky = sky_of(Some(Box::new(MoonSpencer(lz))), None, 0.0);
    let expected = rho * lz * 7.0 / 9.0;
    let opts = RenderOptions {
        width: 48,
        height: 32,
        ..small(Quantity::Radiance)
    };
    let v = view("-vtv -vp 0 0 3 -vd 0.3 0 -1 -vu 0 1 0 -vh 60 -vv 45");
    let img = render(&scene, &sky, v, opts);
    let raw = render(
        &scene,
        &sky,
        v,
        RenderOptions {
            filter_radius: 0,
            ..opts
        },
    );
    let (mut within, mut n) = (0, 0);
    for (i, c) in img.rgb.iter().enumerate() {
        let (g, e) = (daystep::photometry::grey(*c), img.err[i]);
        assert!(
            (g - expected).abs() <= 4.0 * e,
            "pixel {i}: {g} ± {e} against {expected}"
        );
        within += usize::from((g - expected).abs() <= e);
        n += 1;
    }
    assert!(within as f64 >= 0.6 * n as f64, "{within} of {n} within 1σ");
    let median = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (filtered, alone) = (median(&img.err), median(&raw.err));
    assert!(
        filtered < 0.5 * alone,
        "{filtered} against {alone} unfiltered"
    );
    // Unfiltered, the pixels scatter by about what they state: the sky does make noise.
    let scatter = raw
        .rgb
        .iter()
        .map(|c| (daystep::photometry::grey(*c) - expected).abs())
        .collect::<Vec<_>>();
    assert!(
        median(&scatter) > 0.2 * alone,
        "{} against {alone}",
        median(&scatter)
    );
}

#[test]
fn a_sunlit_plane_reads_rho_e_cos_over_pi() {
    let (rho, dni, alt) = (0.3, 800.0, 35.0);
    let scene = plane(rho);
    let sky = sky_of(
        None,
        Some(Sun {
            direction: daystep::site::direction_from_alt_az(alt, 200.0),
            normal_irradiance: Rgb::splat(dni),
        }),
        0.0,
    );
    let cos = (90.0f64 - alt).to_radians().cos();
    let img = render(
        &scene,
        &sky,
        view("-vtv -vp 0 0 4 -vd 0 0.2 -1 -vu 0 1 0 -vh 50 -vv 40"),
        small(Quantity::Radiance),
    );
    let n = all_close(&img, rho * dni * cos / PI, 1e-9);
    assert_eq!(n, 24 * 16);
}

#[test]
fn a_pane_seen_against_a_uniform_sky_reads_tau_l() {
    // Published Radiance-glass transmittance for T_n = 0.88 (docs/derivations.md).
    let table = [(0.0, 0.8800), (30.0, 0.8755), (60.0, 0.7999)];
    let l = 20.0;
    let mut b = Builder::new();
    let g = b.material("glass", 0.0, 0.88);
    b.hrect(-500.0, 500.0, -500.0, 500.0, 1.0, true, g);
    let scene = b.build();
    // Below the pane, its mirror image shows the ground: black here, so only τ L is seen.
    let sky = sky_of(Some(Box::new(Uniform(l))), None, 0.0);
    for (zenith, tau) in table {
        let z = f64::to_radians(zenith);
        let v = format!(
            "-vtl -vp 0 0 0 -vd {} 0 {} -vu 0 1 0 -vh 1 -vv 1",
            z.sin(),
            z.cos()
        );
        let img = render(&scene, &sky, view(&v), small(Quantity::Radiance));
        // Table rounding (5e-5 in τ) is the tolerance.
        all_close(&img, tau * l, 6e-5 / tau);
    }
}

#[test]
fn images_do_not_depend_on_the_thread_count() {
    // A room with a window: gather rays, glazing and sun all take part.
    let mut b = Builder::new();
    let (floor, wall, ceiling) = (
        b.material("f", 0.3, 0.0),
        b.material("w", 0.5, 0.0),
        b.material("c", 0.7, 0.0),
    );
    b.hrect(0.0, 4.0, 0.0, 4.0, 0.0, true, floor);
    b.hrect_with_hole(
        (0.0, 4.0, 0.0, 4.0),
        (1.5, 2.5, 1.5, 2.5),
        3.0,
        false,
        ceiling,
    );
    b.walls_inward(0.0, 4.0, 0.0, 4.0, 0.0, 3.0, wall);
    let g = b.material("glass", 0.0, 0.8);
    b.hrect(1.5, 2.5, 1.5, 2.5, 3.0, true, g);
    let scene = b.build();
    let sky = sky_of(
        Some(Box::new(Uniform(30.0))),
        Some(Sun {
            direction: daystep::site::direction_from_alt_az(60.0, 170.0),
            normal_irradiance: Rgb::splat(600.0),
        }),
        5.0,
    );
    let v = view("-vta -vp 1 1 0.5 -vd 0 0 1 -vu 0 1 0 -vh 180 -vv 180");
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render(&scene, &sky, v, small(Quantity::Radiance)))
    };
    let (a, b) = (run(1), run(2));
    assert!(a.rgb.iter().any(|v| v.x > 0.0));
    assert_eq!(a.rgb, b.rgb);
    assert_eq!(a.err, b.err);
}

/// The office's floor seen from below the ceiling in a parallel `-i` view, pixel for pixel
/// against sensors on the floor at the pixels' centres, overcast and sunny: the render
/// and the sensor path agree within their stated errors.
#[test]
fn the_irradiance_image_agrees_with_sensors_within_the_stated_errors() {
    use daystep::scene::Sensor;
    use daystep::sequence::{SkySpec, StepTime};
    let mut scene = Scene::load(&office()).unwrap();
    // 0.1 m pixels over the 6 × 8 m floor; a sensor at every 5th pixel's centre.
    let (w, h) = (60usize, 80usize);
    let mut at = Vec::new();
    for row in (2..h).step_by(5) {
        for col in (2..w).step_by(5) {
            let p = DVec3::new(0.1 * col as f64 + 0.05, 8.0 - 0.1 * row as f64 - 0.05, 0.0);
            at.push((row * w + col, p));
        }
    }
    scene.sensors = at
        .iter()
        .map(|(_, p)| Sensor {
            position: scene.point_from_model(*p),
            normal: DVec3::Z,
            input_position: *p,
        })
        .collect();
    // Default, not draft: at draft the sensors' own interreflection noise (neighbours
    // 0.5 m apart differ by ±10 %) exceeds what their lux_err states.
    let q = Quality::default();
    let store = Store::disabled();
    let camera = Camera {
        view: view("-vtl -vp 3 4 2.9 -vd 0 0 -1 -vu 0 1 0 -vh 6 -vv 8"),
        options: RenderOptions {
            width: w,
            height: h,
            samples: 1,
            gather_rays: 256,
            quantity: Quantity::Irradiance,
            ..RenderOptions::default()
        },
    };
    let r = Renderer::new(&scene, &q, &store, &camera);
    for (time, spec) in [
        ("2021-02-01T11:00", SkySpec::CieOvercast { dhi: 150.0 }),
        (
            "2021-03-21T12:00",
            SkySpec::Perez {
                dni: 700.0,
                dhi: 120.0,
                dew_point_c: None,
            },
        ),
    ] {
        let (utc, local) = daystep::site::parse_time(time, scene.site.utc_offset_h).unwrap();
        let f = r.frame(&StepTime { utc, local }, &spec).unwrap();
        let (mut covered, mut worst) = (0, 0.0f64);
        for ((pixel, _), s) in at.iter().zip(&f.step.sensors) {
            let lux = f.image.photometric(*pixel);
            let err = 179.0 * f.image.err[*pixel] + s.lux_err;
            let d = (lux - s.lux).abs();
            covered += usize::from(d <= err);
            worst = worst.max(d / s.lux);
        }
        let share = covered as f64 / at.len() as f64;
        eprintln!(
            "{time}: {covered} of {} sensors within the stated errors, worst {:.1} %",
            at.len(),
            100.0 * worst
        );
        assert!(
            share >= 0.9,
            "{time}: {covered} of {} sensors within the stated errors (worst {:.1} %)",
            at.len(),
            100.0 * worst
        );
    }
}

/// A 24-frame sequence (the bundled weather's 21 March at 30-minute steps) stopped after
/// 7 frames and run again gives the same files, byte for byte, as one uninterrupted run;
/// it also writes the playable previews.
#[test]
fn a_sequence_interrupted_and_resumed_gives_identical_files() {
    use daystep::sequence::annual::RunControl;
    use daystep::sequence::render::{plan_weather, run_render, RenderOutputs};
    use std::sync::atomic::{AtomicBool, Ordering};
    let scene = Scene::load(&office()).unwrap();
    let weather = daystep::weather::read_weather(&office().with_file_name("weather.epw")).unwrap();
    let weather = daystep::weather::resample(&weather, 30).unwrap();
    let day = weather.same_day_in_file_year(chrono::NaiveDate::from_ymd_opt(2021, 3, 21).unwrap());
    let (mut frames, _, _) = plan_weather(&scene, &weather, Some(day), Some(day));
    assert!(frames.len() >= 24, "{} frames", frames.len());
    frames.truncate(24);
    let camera = Camera {
        view: view("-vtv -vp 3 7.5 1.5 -vd 0 -1 -0.1 -vu 0 0 1 -vh 70 -vv 50"),
        options: RenderOptions {
            width: 16,
            height: 12,
            samples: 1,
            gather_rays: 4,
            ..RenderOptions::default()
        },
    };
    let outputs = RenderOutputs {
        max_memory: None,
        png: Some(daystep::render::tonemap::Exposure::Auto),
        falsecolor: Some(daystep::render::falsecolor::Falsecolor::default()),
        command: "test".into(),
        ..RenderOutputs::default()
    };
    let q = Quality::preset("draft").unwrap();
    let run = |dir: &Path, stop_after: Option<usize>| {
        let store = Store::disabled();
        let stop = AtomicBool::new(false);
        let progress = |done: usize, _: usize| {
            if stop_after.is_some_and(|n| done >= n) {
                stop.store(true, Ordering::SeqCst);
            }
        };
        let control = RunControl {
            stop: &stop,
            progress: &progress,
            coefficient_progress: &|_, _| {},
        };
        run_render(
            &scene, &q, &store, &camera, &frames, dir, &outputs, &control,
        )
        .unwrap()
    };
    let (once, twice) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let r = run(once.path(), None);
    assert_eq!((r.computed, r.interrupted), (24, false));
    let r = run(twice.path(), Some(7));
    assert!(r.interrupted && r.computed == 7, "{} computed", r.computed);
    assert!(!twice.path().join("preview.html").exists());
    let r = run(twice.path(), None);
    assert_eq!((r.resumed, r.computed), (7, 17));
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| n != "report.json")
            .collect();
        v.sort();
        v
    };
    let files = names(once.path());
    assert_eq!(files, names(twice.path()));
    assert_eq!(files.len(), 24 * 3 + 3, "{files:?}");
    for f in files.iter().filter(|f| *f != "frames.csv") {
        assert_eq!(
            std::fs::read(once.path().join(f)).unwrap(),
            std::fs::read(twice.path().join(f)).unwrap(),
            "{f}"
        );
    }
    // frames.csv: the same frames and values; only each frame's wall time differs.
    let strip = |d: &Path| -> Vec<String> {
        std::fs::read_to_string(d.join("frames.csv"))
            .unwrap()
            .lines()
            .map(|l| l.rsplit_once(',').map_or(l, |(a, _)| a).to_string())
            .collect()
    };
    assert_eq!(strip(once.path()), strip(twice.path()));
}

/// The camera's geometry is cached like projections: a second run reads it and renders
/// the same bits; a damaged record is rebuilt, never trusted.
#[test]
fn the_camera_geometry_is_cached_and_a_damaged_record_is_rebuilt() {
    use daystep::sequence::{SkySpec, StepTime};
    let scene = Scene::load(&office()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let camera = Camera {
        view: view("-vta -vp 3 4 1.2 -vd 0 -1 0 -vu 0 0 1 -vh 180 -vv 180"),
        options: RenderOptions {
            width: 24,
            height: 24,
            samples: 1,
            gather_rays: 9,
            ..RenderOptions::default()
        },
    };
    let (utc, local) =
        daystep::site::parse_time("2021-03-21T12:00", scene.site.utc_offset_h).unwrap();
    let spec = SkySpec::Perez {
        dni: 700.0,
        dhi: 120.0,
        dew_point_c: None,
    };
    let q = Quality::preset("draft").unwrap();
    let render = || {
        let store = Store::open(dir.path(), 1 << 30);
        let r = Renderer::new(&scene, &q, &store, &camera);
        let img = r.frame(&StepTime { utc, local }, &spec).unwrap().image;
        (r.geometry_from_cache, img)
    };
    let (cached, first) = render();
    assert!(!cached);
    let (cached, second) = render();
    assert!(cached, "the second run reads the camera's geometry");
    assert_eq!(first.rgb, second.rgb);
    assert_eq!(first.err, second.err);
    // Truncate every record that holds a camera (the largest file is enough to find it:
    // damage them all, projections are rebuilt too).
    for e in std::fs::read_dir(dir.path()).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "dsr") {
            let b = std::fs::read(&p).unwrap();
            std::fs::write(&p, &b[..b.len() / 2]).unwrap();
        }
    }
    let (cached, third) = render();
    assert!(!cached, "a truncated record is not trusted");
    assert_eq!(first.rgb, third.rgb);
}

/// The glTF of a sequence: the Khronos layout daystep documents (export::gltf), and a
/// plane under a CIE overcast sky of DHI E reads E (illuminance 179 E) and ρE/π (radiance)
/// at every vertex; one frame per rendered frame.
#[test]
fn the_gltf_holds_every_frame_and_a_plane_reads_its_closed_form() {
    use daystep::sequence::annual::RunControl;
    use daystep::sequence::render::{run_render, FramePlan, RenderOutputs};
    use daystep::sequence::{SkySpec, StepTime};
    use std::sync::atomic::AtomicBool;
    let (rho, dhi) = (0.5, 100.0);
    let scene = plane(rho);
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("plane.glb");
    let frames: Vec<FramePlan> = ["2024-03-21T10:00", "2024-03-21T12:00"]
        .iter()
        .map(|t| {
            let (utc, local) = daystep::site::parse_time(t, 0.0).unwrap();
            FramePlan::new(StepTime { utc, local }, SkySpec::CieOvercast { dhi })
        })
        .collect();
    let camera = Camera {
        view: view("-vtl -vp 0 0 5 -vd 0 0 -1 -vu 0 1 0 -vh 8 -vv 6"),
        options: small(Quantity::Radiance),
    };
    let outputs = RenderOutputs {
        max_memory: None,
        gltf: Some(glb.clone()),
        command: "test".into(),
        ..RenderOutputs::default()
    };
    let stop = AtomicBool::new(false);
    let control = RunControl {
        stop: &stop,
        progress: &|_, _| {},
        coefficient_progress: &|_, _| {},
    };
    let store = Store::disabled();
    let q = Quality::preset("draft").unwrap();
    run_render(
        &scene,
        &q,
        &store,
        &camera,
        &frames,
        dir.path(),
        &outputs,
        &control,
    )
    .unwrap();
    let g = gltf::Gltf::from_slice(&std::fs::read(&glb).unwrap()).unwrap();
    let bin = g.blob.as_ref().unwrap();
    let extras: serde_json::Value =
        serde_json::from_str(g.document.as_json().asset.extras.as_ref().unwrap().get()).unwrap();
    let d = &extras["daystep"];
    assert_eq!(d["frames"].as_array().unwrap().len(), 2);
    let scale = d["radiance_scale"].as_f64().unwrap();
    let floats = |acc: gltf::Accessor| -> Vec<f32> {
        let v = acc.view().unwrap();
        let off = v.offset() + acc.offset();
        bin[off..off + acc.count() * acc.size()]
            .chunks(4)
            .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
            .collect()
    };
    let prim = g.meshes().next().unwrap().primitives().next().unwrap();
    let get = |name: &str| {
        prim.attributes()
            .find(|(s, _)| s.to_string() == name)
            .map(|(_, a)| floats(a))
            .unwrap_or_else(|| panic!("no {name}"))
    };
    let ill = get("_ILLUMINANCE");
    let lum = get("_LUMINANCE");
    let col = get("COLOR_0");
    let (e_lux, l_rad) = (179.0 * dhi, rho * dhi / PI);
    for (k, (i, l)) in ill.iter().zip(&lum).enumerate() {
        assert!(
            (f64::from(*i) - e_lux).abs() < 0.01 * e_lux,
            "vertex {k}: {i} lux"
        );
        assert!(
            (f64::from(*l) - 179.0 * l_rad).abs() < 0.01 * 179.0 * l_rad,
            "vertex {k}: {l} cd/m2"
        );
        let c = f64::from(col[3 * k + 1]) * scale;
        assert!(
            (c - l_rad).abs() < 0.01 * l_rad,
            "vertex {k}: COLOR_0 × scale {c}"
        );
    }
}

/// `annual --gltf` for a chosen day: one frame per lit step, a file the gltf crate reads.
#[test]
fn a_days_gltf_has_one_frame_per_lit_step() {
    use daystep::sequence::render::{plan_weather, write_days_gltf};
    let scene = Scene::load(&office()).unwrap();
    let weather = daystep::weather::read_weather(&office().with_file_name("weather.epw")).unwrap();
    let day = weather.same_day_in_file_year(chrono::NaiveDate::from_ymd_opt(2021, 3, 21).unwrap());
    let lit = plan_weather(&scene, &weather, Some(day), Some(day)).0.len();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("day.glb");
    let q = Quality::preset("draft").unwrap();
    let n = write_days_gltf(&scene, &weather, &q, &Store::disabled(), &[day], &path).unwrap();
    assert_eq!(n, lit);
    let g = gltf::Gltf::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let extras: serde_json::Value =
        serde_json::from_str(g.document.as_json().asset.extras.as_ref().unwrap().get()).unwrap();
    assert_eq!(extras["daystep"]["frames"].as_array().unwrap().len(), lit);
}

/// A render under an image sky: a uniform image of radiance L over a plane of ρ reads ρL
/// in every pixel (the EXR daystep wrote, read back).
#[test]
fn a_render_under_a_uniform_image_sky_reads_rho_l() {
    use daystep::sequence::annual::RunControl;
    use daystep::sequence::render::{run_render, FramePlan, RenderOutputs};
    use daystep::sequence::{SkySpec, StepTime};
    use daystep::sky::image::{ImageSky, Mapping};
    use std::sync::atomic::AtomicBool;
    let (rho, l) = (0.4, 12.0);
    let scene = plane(rho);
    let image = ImageSky::new(64, 32, vec![Rgb::splat(l); 64 * 32], Mapping::Equirect, 0.0);
    let (utc, local) = daystep::site::parse_time("2024-03-21T12:00", 0.0).unwrap();
    let mut plan = FramePlan::new(StepTime { utc, local }, SkySpec::None);
    plan.sky = Some(std::sync::Arc::new(sky_of(
        Some(Box::new(image)),
        None,
        0.0,
    )));
    let dir = tempfile::tempdir().unwrap();
    let camera = Camera {
        view: view("-vtv -vp 0 0 3 -vd 0.3 0 -1 -vu 0 1 0 -vh 60 -vv 45"),
        options: small(Quantity::Radiance),
    };
    let stop = AtomicBool::new(false);
    let control = RunControl {
        stop: &stop,
        progress: &|_, _| {},
        coefficient_progress: &|_, _| {},
    };
    let outputs = RenderOutputs::default();
    let q = Quality::preset("draft").unwrap();
    run_render(
        &scene,
        &q,
        &Store::disabled(),
        &camera,
        &[plan.clone()],
        dir.path(),
        &outputs,
        &control,
    )
    .unwrap();
    let img =
        daystep::render::exr::read_exr(&dir.path().join(format!("{}.exr", plan.name))).unwrap();
    // The EXR holds f32: 1 % as the closed-form tolerance, f32 far below it.
    assert!(all_close(&img, rho * l, 0.01) > 100);
}
