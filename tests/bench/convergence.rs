//! `daystep convergence` on the generated 10 000-triangle building (1 620 sensors), which
//! has no scene file (`cargo bench --bench convergence -- [KNOB,KNOB…] [OUT.svg]`): the
//! chosen ladders (default: sky subdivision, LDI resolution, refinement thresholds,
//! interreflection lines) on its 21 June 15:00 instant (Perez DNI 750, DHI 110), printed as
//! the CSV `daystep convergence` writes, and the plot written to OUT.svg (default
//! `target/convergence-building.svg`). `--repeats N` (default 3) runs each rung N times,
//! interleaved, as `daystep convergence --repeats` does. Prints figures; asserts nothing.

use daystep::export::plot::error_vs_time_svg;
use daystep::sequence::convergence::{csv, curves, ladders, recommendation, run_convergence};
use daystep::sequence::{Quality, SkySpec};
use daystep::site::parse_time;

#[path = "../scenes/mod.rs"]
mod scenes;

fn main() {
    let mut args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let repeats = match args.iter().position(|a| a == "--repeats") {
        Some(i) => {
            let n = args
                .get(i + 1)
                .and_then(|v| v.parse().ok())
                .expect("--repeats N");
            args.drain(i..i + 2);
            n
        }
        None => 3,
    };
    let knobs: Vec<String> = args
        .first()
        .map(|k| k.split(',').map(|s| s.trim().to_string()).collect())
        .unwrap_or_else(|| {
            [
                "sky subdivision",
                "LDI resolution",
                "refinement thresholds",
                "interreflection lines",
            ]
            .map(String::from)
            .to_vec()
        });
    let out = args
        .get(1)
        .cloned()
        .unwrap_or_else(|| "target/convergence-building.svg".into());
    let scene = scenes::multi_storey_building(10_000);
    let (utc, local) = parse_time("2021-06-21T15:00", scene.site.utc_offset_h).unwrap();
    let spec = SkySpec::Perez {
        dni: 750.0,
        dhi: 110.0,
        dew_point_c: None,
    };
    let mut ls = ladders(&Quality::default());
    ls.retain(|l| knobs.iter().any(|k| k == l.knob));
    let show = |done: usize, total: usize, knob: &str, setting: &str| {
        if !knob.is_empty() {
            eprintln!("  [{:>2}/{total}] {knob}: {setting}", done + 1);
        }
    };
    let rungs = run_convergence(&scene, utc, local, &spec, &ls, repeats, &show).unwrap();
    print!("{}", csv(&rungs));
    println!("{}", recommendation(&rungs, 0.02));
    let curves = curves(&rungs);
    error_vs_time_svg(
        std::path::Path::new(&out),
        "10 000-triangle building: error against time per knob (default ringed)",
        &curves,
    )
    .unwrap();
    eprintln!("wrote {out}");
}
