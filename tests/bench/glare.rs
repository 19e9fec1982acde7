//! daystep's daylight glare probability against Radiance's evalglare on synthetic angular
//! fisheye scenes (`tests/bench/glare/run.sh`, which puts evalglare on PATH; or
//! `cargo bench --bench glare` with evalglare already there). Not a CI test.
//!
//! Each scene is a uniform background with bright discs and rectangles (a window, a sun,
//! reflections), drawn in azimuth/altitude from the view direction and written with
//! `write_hdr` (with its VIEW line, which evalglare reads) and read back with `read_hdr`,
//! so both programs see the same RGBE-rounded pixels. Two settings are compared:
//! daystep's defaults (5 × the image's mean luminance, low-light correction) against
//! `evalglare -b 5 -C l+`, and evalglare's own defaults (2000 cd/m², no low-light
//! correction) against `Threshold::Absolute(2000)` without it. Prints markdown tables
//! and the largest |ΔDGP| over the synthetic scenes (target ≤ 0.02). Options: `--size N`
//! (pixels a side, default 800), `--out DIR` (default target/glare-bench), `--file F.hdr`
//! (repeatable: also compare on an angular fisheye picture made elsewhere, viewed as its
//! VIEW line says).

use daystep::photometry::Rgb;
use daystep::render::glare::{glare, Glare, GlareOptions, Threshold};
use daystep::render::rgbe::{read_hdr, write_hdr};
use daystep::render::{Image, Quantity};
use daystep::scene::view::View;
use glam::DVec3;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// A bright patch in degrees: azimuth to the right of the view direction, altitude above
/// it; `Disc` by centre and angular radius, `Rect` by its azimuth and altitude ranges.
#[derive(Clone, Copy)]
enum Patch {
    Disc {
        az: f64,
        alt: f64,
        radius: f64,
        lum: f64,
    },
    Rect {
        az: (f64, f64),
        alt: (f64, f64),
        lum: f64,
    },
}

struct SceneSpec {
    name: &'static str,
    background: f64,
    /// Later patches paint over earlier ones.
    patches: Vec<Patch>,
}

fn scenes() -> Vec<SceneSpec> {
    use Patch::{Disc, Rect};
    vec![
        SceneSpec {
            name: "uniform 50",
            background: 50.0,
            patches: vec![],
        },
        SceneSpec {
            name: "uniform 1200",
            background: 1200.0,
            patches: vec![],
        },
        SceneSpec {
            name: "centre disc 20k",
            background: 400.0,
            patches: vec![Disc {
                az: 0.0,
                alt: 0.0,
                radius: 3.0,
                lum: 20_000.0,
            }],
        },
        SceneSpec {
            // Two panes with a 3° mullion: within evalglare's grouping reach, one source.
            name: "two-pane window 3k left",
            background: 300.0,
            patches: vec![
                Rect {
                    az: (-45.0, -29.0),
                    alt: (5.0, 40.0),
                    lum: 3_000.0,
                },
                Rect {
                    az: (-26.0, -10.0),
                    alt: (5.0, 40.0),
                    lum: 3_000.0,
                },
            ],
        },
        SceneSpec {
            name: "window 5k + sun 150k",
            background: 800.0,
            patches: vec![
                Rect {
                    az: (-20.0, 30.0),
                    alt: (0.0, 35.0),
                    lum: 5_000.0,
                },
                Disc {
                    az: 15.0,
                    alt: 25.0,
                    radius: 1.5,
                    lum: 150_000.0,
                },
            ],
        },
        SceneSpec {
            name: "four discs, one below",
            background: 200.0,
            patches: vec![
                Disc {
                    az: 30.0,
                    alt: 10.0,
                    radius: 5.0,
                    lum: 8_000.0,
                },
                // 8.5° (0.15 rad) from the disc above: beyond evalglare's grouping reach of half
                // its 0.2 rad search radius.
                Disc {
                    az: 47.0,
                    alt: 10.0,
                    radius: 3.0,
                    lum: 12_000.0,
                },
                Disc {
                    az: -50.0,
                    alt: -20.0,
                    radius: 4.0,
                    lum: 50_000.0,
                },
                Disc {
                    az: 60.0,
                    alt: 45.0,
                    radius: 1.0,
                    lum: 200_000.0,
                },
            ],
        },
        SceneSpec {
            name: "bright room, floor patch",
            background: 2_000.0,
            patches: vec![Rect {
                az: (10.0, 50.0),
                alt: (-50.0, -20.0),
                lum: 20_000.0,
            }],
        },
        SceneSpec {
            name: "dim room, wide window + sun",
            background: 100.0,
            patches: vec![
                Rect {
                    az: (-35.0, 35.0),
                    alt: (-10.0, 30.0),
                    lum: 2_500.0,
                },
                Disc {
                    az: -30.0,
                    alt: 27.0,
                    radius: 2.0,
                    lum: 100_000.0,
                },
            ],
        },
    ]
}

fn view() -> View {
    View::default()
        .with_options(
            "-vta -vp 0 0 1.2 -vd 0 1 0 -vu 0 0 1 -vh 180 -vv 180",
            Path::new("<bench>"),
            None,
        )
        .expect("bench view")
}

fn render(spec: &SceneSpec, v: &View, size: usize) -> Image {
    let mut im = Image::new(size, size, Quantity::Radiance);
    for row in 0..size {
        for col in 0..size {
            let x = (col as f64 + 0.5) / size as f64;
            let y = 1.0 - (row as f64 + 0.5) / size as f64;
            let l = match v.ray(x, y) {
                Some((_, d)) => luminance(spec, d),
                None => 0.0,
            };
            im.rgb[row * size + col] = Rgb::splat(l / 179.0);
        }
    }
    im
}

fn luminance(spec: &SceneSpec, d: DVec3) -> f64 {
    // The bench view looks along +y with z up: azimuth to the right (+x), altitude up.
    let az = d.x.atan2(d.y).to_degrees();
    let alt = d.z.clamp(-1.0, 1.0).asin().to_degrees();
    let mut l = spec.background;
    for p in &spec.patches {
        match *p {
            Patch::Disc {
                az: a,
                alt: b,
                radius,
                lum,
            } => {
                let c = DVec3::new(
                    b.to_radians().cos() * a.to_radians().sin(),
                    b.to_radians().cos() * a.to_radians().cos(),
                    b.to_radians().sin(),
                );
                if d.angle_between(c).to_degrees() <= radius {
                    l = lum;
                }
            }
            Patch::Rect {
                az: (a0, a1),
                alt: (b0, b1),
                lum,
            } => {
                if az >= a0 && az <= a1 && alt >= b0 && alt <= b1 {
                    l = lum;
                }
            }
        }
    }
    l
}

struct Evalglare {
    dgp: f64,
    ev: f64,
    sources: usize,
}

fn evalglare(args: &[&str], file: &Path) -> Evalglare {
    let out = Command::new("evalglare")
        .args(args)
        .arg("-d")
        .arg(file)
        .output()
        .unwrap_or_else(|e| panic!("cannot run evalglare (is it on PATH? use run.sh): {e}"));
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        panic!(
            "evalglare {args:?} {} failed: {}{}",
            file.display(),
            text,
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let mut sources = 0;
    let mut found = None;
    for line in text.lines() {
        if line.contains("No pixels x-pos") {
            sources = line
                .split_whitespace()
                .next()
                .and_then(|t| t.parse().ok())
                .unwrap_or(0);
        }
        if let Some(rest) = line.strip_prefix("dgp,av_lum,E_v") {
            let values: Vec<f64> = rest
                .split(':')
                .nth(1)
                .unwrap_or("")
                .split_whitespace()
                .filter_map(|t| t.parse().ok())
                .collect();
            found = Some((values[0], values[2]));
        }
    }
    let (dgp, ev) = found.unwrap_or_else(|| panic!("no dgp line from evalglare:\n{text}"));
    Evalglare { dgp, ev, sources }
}

/// daystep's DGP recomputed with evalglare's rounded coefficients (0.092, 0.159 for the
/// published 0.0918, 0.16), to show what of ΔDGP they account for.
fn with_evalglare_coefficients(g: &Glare, low_light: bool) -> f64 {
    let sum: f64 = g
        .sources
        .iter()
        .map(|s| s.luminance_cd_m2.powi(2) * s.solid_angle_sr / s.position_index.powi(2))
        .sum();
    let ev = g.ev_lux;
    let dgp = (5.87e-5 * ev + 0.092 * (1.0 + sum / ev.powf(1.87)).log10() + 0.159).min(1.0);
    if low_light && ev < 1000.0 {
        let e = (0.024 * ev - 4.0).exp();
        dgp * e / (1.0 + e)
    } else {
        dgp
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let size: usize = arg("--size")
        .map(|s| s.parse().expect("--size N"))
        .unwrap_or(800);
    let out_dir = PathBuf::from(arg("--out").unwrap_or_else(|| "target/glare-bench".into()));
    let v = view();
    // Pictures made elsewhere (e.g. evalglare's own resources/evalglare/testimage.hdr):
    // read with read_hdr, viewed as their VIEW line says.
    let extra: Vec<(String, PathBuf, Image, View)> = args
        .iter()
        .enumerate()
        .filter(|(_, a)| *a == "--file")
        .filter_map(|(i, _)| args.get(i + 1))
        .map(|f| {
            let p = PathBuf::from(f);
            let (im, view) = read_hdr(&p).expect("read --file picture");
            let view = View::default()
                .with_options(&view.expect("--file picture without VIEW"), &p, None)
                .expect("VIEW of --file picture");
            (f.clone(), p, im, view)
        })
        .collect();
    let settings: [(&str, GlareOptions, Vec<&str>); 2] = [
        (
            "daystep defaults (5 × mean, low-light correction) vs `evalglare -b 5 -C l+`",
            GlareOptions::default(),
            vec!["-b", "5", "-C", "l+"],
        ),
        (
            "evalglare defaults (2000 cd/m², no low-light correction) vs `Threshold::Absolute(2000)`",
            GlareOptions {
                threshold: Threshold::Absolute(2000.0),
                low_light_correction: false,
                ..Default::default()
            },
            vec![],
        ),
    ];
    let files: Vec<(PathBuf, Image)> = scenes()
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let im = render(s, &v, size);
            let p = out_dir.join(format!("scene{}.hdr", k + 1));
            write_hdr(&p, &im, Some(&v)).expect("write scene");
            // Both programs see the same RGBE-rounded pixels (up to 0.4 % off the
            // drawn luminance), and the reader gets exercised.
            let (back, view) = read_hdr(&p).expect("read scene back");
            assert_eq!(view, Some(v.options()));
            drop(im);
            (p, back)
        })
        .collect();
    println!("{size}×{size} angular fisheye scenes (`-vta -vh 180 -vv 180`, VIEW from the header), in {}\n", out_dir.display());
    let mut worst: f64 = 0.0;
    for (title, opts, eg_args) in &settings {
        println!("### {title}\n");
        println!("| scene | DGP daystep | DGP evalglare | ΔDGP | Ev daystep (lx) | Ev evalglare (lx) | ΔEv | ΔDGP, evalglare's coefficients | sources d/e | time d / e (s) |");
        println!("|---|---|---|---|---|---|---|---|---|---|");
        for (spec, (path, im)) in scenes().iter().zip(&files) {
            let t = Instant::now();
            let g = glare(im, &v, opts).expect("daystep glare");
            let td = t.elapsed().as_secs_f64();
            let t = Instant::now();
            let e = evalglare(eg_args, path);
            let te = t.elapsed().as_secs_f64();
            let dd = g.dgp - e.dgp;
            worst = worst.max(dd.abs());
            let rounded = with_evalglare_coefficients(&g, opts.low_light_correction) - e.dgp;
            println!(
                "| {} | {:.4} | {:.4} | {:+.4} | {:.1} | {:.1} | {:+.2} % | {:+.4} | {}/{} | {:.2} / {:.2} |",
                spec.name,
                g.dgp,
                e.dgp,
                dd,
                g.ev_lux,
                e.ev,
                100.0 * (g.ev_lux / e.ev - 1.0),
                rounded,
                g.sources.len(),
                e.sources,
                td,
                te
            );
        }
        for (name, path, im, view) in &extra {
            let g = glare(im, view, opts).expect("daystep glare");
            let e = evalglare(eg_args, path);
            let rounded = with_evalglare_coefficients(&g, opts.low_light_correction) - e.dgp;
            println!(
                "| {name} | {:.4} | {:.4} | {:+.4} | {:.1} | {:.1} | {:+.2} % | {rounded:+.4} | {}/{} | |",
                g.dgp,
                e.dgp,
                g.dgp - e.dgp,
                g.ev_lux,
                e.ev,
                100.0 * (g.ev_lux / e.ev - 1.0),
                g.sources.len(),
                e.sources
            );
        }
        println!();
    }
    println!(
        "max |ΔDGP| = {worst:.4} (target ≤ 0.02): {}",
        if worst <= 0.02 { "met" } else { "NOT met" }
    );
}
