//! Outputs the user names: checked before any work (exit 1 naming the flag), and a render
//! resumed into an existing folder keeps only frames made from the same inputs.

use crate::util::{daystep, office, stderr, Builder};
use daystep::cache::Store;
use daystep::render::{Quantity, RenderOptions};
use daystep::scene::view::View;
use daystep::scene::Scene;
use daystep::sequence::annual::RunControl;
use daystep::sequence::render::{run_render, Camera, FramePlan, RenderOutputs, RenderReport};
use daystep::sequence::{Quality, SkySpec, StepTime};
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// A floor and a wall beside it: enough for interreflection, cheap to render.
fn corner(kd: f64) -> Scene {
    let mut b = Builder::new();
    let m = b.material("grey", kd, 0.0);
    b.hrect(0.0, 4.0, 0.0, 4.0, 0.0, true, m);
    b.quad(
        [
            glam::DVec3::new(0.0, 4.0, 0.0),
            glam::DVec3::new(4.0, 4.0, 0.0),
            glam::DVec3::new(4.0, 4.0, 3.0),
            glam::DVec3::new(0.0, 4.0, 3.0),
        ],
        m,
    );
    b.build()
}

/// The inputs of one render run; each test case changes one of them.
#[derive(Clone)]
struct Inputs {
    kd: f64,
    view: &'static str,
    width: usize,
    dhi: f64,
    seed: u64,
    falsecolor: bool,
}

const BASE: Inputs = Inputs {
    kd: 0.5,
    view: "-vtv -vp 2 -3 1.5 -vd 0 1 -0.3 -vu 0 0 1 -vh 60 -vv 45",
    width: 12,
    dhi: 100.0,
    seed: 1,
    falsecolor: false,
};

fn render_into(dir: &Path, i: &Inputs) -> RenderReport {
    let scene = corner(i.kd);
    let q = Quality::preset("draft").unwrap().with_seed(i.seed);
    let camera = Camera {
        view: View::default()
            .with_options(i.view, Path::new("test"), None)
            .unwrap(),
        options: RenderOptions {
            width: i.width,
            height: 8,
            samples: 1,
            gather_rays: 4,
            quantity: Quantity::Radiance,
            seed: q.transport.seed,
            ..RenderOptions::default()
        },
    };
    let at = StepTime {
        utc: chrono::DateTime::parse_from_rfc3339("2024-03-21T12:00:00Z")
            .unwrap()
            .to_utc(),
        local: chrono::NaiveDate::from_ymd_opt(2024, 3, 21)
            .unwrap()
            .and_hms_opt(12, 0, 0)
            .unwrap(),
    };
    let frames = [FramePlan::new(at, SkySpec::CieOvercast { dhi: i.dhi })];
    let outputs = RenderOutputs {
        max_memory: None,
        png: Some(daystep::render::tonemap::Exposure::Auto),
        falsecolor: i
            .falsecolor
            .then(daystep::render::falsecolor::Falsecolor::default),
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
    run_render(
        &scene, &q, &store, &camera, &frames, dir, &outputs, &control,
    )
    .unwrap()
}

/// Rerun into a folder holding another run's frame, every input that determines the
/// image renders it again, and the file is the one a fresh folder gets; unchanged inputs
/// still resume. (Before frames carried a fingerprint, the old image was kept: "0
/// rendered, 1 resumed".)
#[test]
fn a_resumed_render_with_changed_inputs_renders_again_instead_of_keeping_old_images() {
    let exr = "20240321_1200.exr";
    let dir = tempfile::tempdir().unwrap();
    let r = render_into(dir.path(), &BASE);
    assert_eq!((r.computed, r.resumed), (1, 0));
    let r = render_into(dir.path(), &BASE);
    assert_eq!((r.computed, r.resumed), (0, 1), "unchanged inputs resume");
    let cases = [
        ("material", Inputs { kd: 0.2, ..BASE }),
        (
            "view",
            Inputs {
                view: "-vtv -vp 2 -3 1.5 -vd 0.2 1 -0.3 -vu 0 0 1 -vh 60 -vv 45",
                ..BASE
            },
        ),
        ("size", Inputs { width: 10, ..BASE }),
        ("sky", Inputs { dhi: 250.0, ..BASE }),
        ("seed", Inputs { seed: 7, ..BASE }),
        (
            "outputs",
            Inputs {
                falsecolor: true,
                ..BASE
            },
        ),
    ];
    for (what, changed) in cases {
        let shared = tempfile::tempdir().unwrap();
        render_into(shared.path(), &BASE);
        let r = render_into(shared.path(), &changed);
        assert_eq!(
            (r.computed, r.resumed),
            (1, 0),
            "{what}: not rendered again"
        );
        assert!(
            r.warnings.iter().any(|w| w.contains("other inputs")),
            "{what}: {:?}",
            r.warnings
        );
        let fresh = tempfile::tempdir().unwrap();
        render_into(fresh.path(), &changed);
        assert_eq!(
            std::fs::read(shared.path().join(exr)).unwrap(),
            std::fs::read(fresh.path().join(exr)).unwrap(),
            "{what}: the replaced image is not the one the new inputs make"
        );
    }
}

/// `--gltf` naming an existing folder, or `--out` naming a file, is refused before the
/// solve with exit 1 naming the flag; nothing is computed or written. (Before, `--gltf`
/// onto a folder failed with exit 2 after the whole solve, and `render` left its frames.)
#[test]
fn outputs_that_cannot_be_written_exit_1_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let a_file = dir.path().join("a_file");
    std::fs::write(&a_file, "x").unwrap();
    let folder = dir.path().join("folder.glb");
    std::fs::create_dir(&folder).unwrap();
    let out = dir.path().join("out");
    let (scene, out_s) = (office(), out.to_str().unwrap().to_string());
    let scene = scene.to_str().unwrap();
    let sky = [
        "--time",
        "2024-03-21T12:00",
        "--sky",
        "cie-overcast",
        "--dhi",
        "100",
        "--quality",
        "draft",
        "--no-cache",
    ];
    let view = [
        "--view",
        "-vtv -vp 3 4 1.2 -vd 0 -1 0",
        "-x",
        "8",
        "-y",
        "8",
    ];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            [&["instant", scene][..], &sky, &["--out", &out_s, "--gltf"]].concat(),
            "--gltf",
        ),
        (
            [
                &["render", scene][..],
                &sky,
                &view,
                &["--out", &out_s, "--gltf"],
            ]
            .concat(),
            "--gltf",
        ),
        (
            [
                &["instant", scene][..],
                &sky,
                &["--out", a_file.to_str().unwrap()],
            ]
            .concat(),
            "--out",
        ),
        (
            [
                &["df", scene, "--no-cache", "--out"][..],
                &[a_file.to_str().unwrap()],
            ]
            .concat(),
            "--out",
        ),
    ];
    for (mut args, flag) in cases {
        if flag == "--gltf" {
            args.push(folder.to_str().unwrap());
        }
        let o = daystep(&args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(flag), "{flag}: {}", stderr(&o));
        // Refused before the solve: no frame, table or report was written.
        let written: Vec<_> = std::fs::read_dir(&out)
            .map(|d| d.map(|e| e.unwrap().file_name()).collect())
            .unwrap_or_default();
        assert!(written.is_empty(), "{args:?} wrote {written:?}");
    }
    assert_eq!(std::fs::read(&a_file).unwrap(), b"x");
}
