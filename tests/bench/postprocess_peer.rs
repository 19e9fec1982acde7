//! daystep's side of the peer bench against honeybee-radiance-postprocess
//! (tests/bench/postprocess/run.sh): reads each case that `peer.py make` wrote in
//! honeybee's results layout (grids_info.json, sun-up-hours.txt, one float32 `.npy` per
//! light path, state, result type and grid), runs [`daystep::metrics::leed`] and
//! [`daystep::metrics::en17037`] on it and writes `daystep.json` beside `honeybee.json`.
//!
//! `cargo bench --bench postprocess_peer -- DIR`. Not part of `cargo test`.

use daystep::metrics::en17037::{en17037, En17037Grid};
use daystep::metrics::leed::{leed_option_one, LeedGrid, LeedPeriod, LightPath, Shade};
use serde_json::{json, Value};
use std::path::Path;

/// A 2-D little-endian float32 C-order `.npy` (what numpy's `save` writes for these
/// arrays): (rows, columns, values).
fn read_npy(path: &Path) -> (usize, usize, Vec<f32>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&bytes[..6], b"\x93NUMPY", "{}", path.display());
    let (header_len, start) = if bytes[6] == 1 {
        (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10)
    } else {
        (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        )
    };
    let header = std::str::from_utf8(&bytes[start..start + header_len]).unwrap();
    assert!(
        header.contains("'<f4'") && header.contains("'fortran_order': False"),
        "{header}"
    );
    let shape = &header[header.find("'shape': (").unwrap() + 10..];
    let shape: Vec<usize> = shape[..shape.find(')').unwrap()]
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse().unwrap())
        .collect();
    let data: Vec<f32> = bytes[start + header_len..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    assert_eq!(data.len(), shape[0] * shape[1]);
    (shape[0], shape[1], data)
}

/// Sensor-major (sensors × hours, honeybee's layout) to hour-major (daystep's).
fn to_hour_major(rows: usize, cols: usize, v: &[f32]) -> Vec<f32> {
    let mut out = vec![0.0; v.len()];
    for r in 0..rows {
        for c in 0..cols {
            out[c * rows + r] = v[r * cols + c];
        }
    }
    out
}

struct PathData {
    name: String,
    is_static: bool,
    total: Vec<f32>,
    direct: Vec<f32>,
}

fn run_case(case: &Path) {
    let res = case.join("results");
    let info: Value =
        serde_json::from_str(&std::fs::read_to_string(res.join("grids_info.json")).unwrap())
            .unwrap();
    let sun_up: Vec<usize> = std::fs::read_to_string(res.join("sun-up-hours.txt"))
        .unwrap()
        .split_whitespace()
        .map(|s| s.parse::<f64>().unwrap() as usize)
        .collect();
    // LEED's schedule: hours 8 … 17 of every day (honeybee's occupancy_schedule_8_to_6).
    let leed_occ = |h: usize| (8..=17).contains(&(h % 24));
    let occupied: Vec<bool> = sun_up.iter().map(|h| leed_occ(*h)).collect();
    let total_occ = (0..8760).filter(|h| leed_occ(*h)).count();
    let daylight_year: Vec<bool> = std::fs::read_to_string(case.join("daylight_hours.csv"))
        .unwrap()
        .split_whitespace()
        .map(|s| s == "1")
        .collect();
    let daylight: Vec<bool> = sun_up.iter().map(|h| daylight_year[*h]).collect();
    let daylight_steps = daylight_year.iter().filter(|d| **d).count();

    // Sensor areas, when the case has a model (peer.py writes them from its grid meshes).
    let areas: Option<Value> = std::fs::read_to_string(case.join("areas.json"))
        .ok()
        .map(|t| serde_json::from_str(&t).unwrap());
    let area_of = |id: &str| -> Option<Vec<f64>> {
        areas.as_ref().map(|a| {
            a[id]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect()
        })
    };
    let mut grids_data = Vec::new();
    for g in info.as_array().unwrap() {
        let id = g["full_id"].as_str().unwrap().to_string();
        let mut paths = Vec::new();
        for lp in g["light_path"].as_array().unwrap() {
            let lp = lp.as_array().unwrap();
            for name in lp.iter().map(|v| v.as_str().unwrap()) {
                // honeybee's flattening: static apertures inside a multi-path entry skipped
                if name == "__static_apertures__" && lp.len() > 1 {
                    continue;
                }
                let is_static = name == "__static_apertures__";
                let state = if is_static {
                    "default".to_string()
                } else {
                    format!("0_{name}")
                };
                let load = |res_type: &str| {
                    let (r, c, v) = read_npy(
                        &res.join(name)
                            .join(&state)
                            .join(res_type)
                            .join(format!("{id}.npy")),
                    );
                    assert_eq!(c, sun_up.len());
                    to_hour_major(r, c, &v)
                };
                paths.push(PathData {
                    name: name.to_string(),
                    is_static,
                    total: load("total"),
                    direct: load("direct"),
                });
            }
        }
        grids_data.push((
            g["name"].as_str().unwrap().to_string(),
            g["count"].as_u64().unwrap() as usize,
            paths,
            area_of(&id),
        ));
    }
    let grids: Vec<LeedGrid> = grids_data
        .iter()
        .map(|(name, sensors, paths, areas)| LeedGrid {
            name,
            sensors: *sensors,
            areas: areas.as_deref(),
            paths: paths
                .iter()
                .map(|p| LightPath {
                    name: &p.name,
                    total: &p.total,
                    direct: &p.direct,
                    shade: if p.is_static {
                        Shade::Static
                    } else {
                        Shade::Transmittance(0.05)
                    },
                })
                .collect(),
        })
        .collect();
    let t0 = std::time::Instant::now();
    let period = LeedPeriod {
        occupied: &occupied,
        total_occupied_steps: total_occ,
        hours_per_step: 1.0,
    };
    let leed = leed_option_one(&grids, &period).unwrap();
    let leed_time = t0.elapsed();

    // EN 17037 on the open total, summed over the paths in order in f32 (as honeybee's
    // np.sum over the stacked float32 arrays).
    let totals: Vec<Vec<f32>> = grids_data
        .iter()
        .map(|(_, _, paths, _)| {
            let mut t = paths[0].total.clone();
            for p in &paths[1..] {
                for (a, b) in t.iter_mut().zip(&p.total) {
                    *a += *b;
                }
            }
            t
        })
        .collect();
    let en_grids: Vec<En17037Grid> = grids_data
        .iter()
        .zip(&totals)
        .map(|((name, sensors, _, areas), t)| En17037Grid {
            name,
            sensors: *sensors,
            areas: areas.as_deref(),
            total: t,
        })
        .collect();
    let en = en17037(&en_grids, &daylight, daylight_steps).unwrap();

    let mut v = serde_json::to_value(&leed).unwrap();
    for (gv, g) in v["grids"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .zip(&leed.grids)
    {
        gv["da"] = json!(g.da);
        gv["ase_hours"] = json!(g.ase_hours);
        gv["fail_hoys"] = json!(g.fail_steps.iter().map(|s| sun_up[*s]).collect::<Vec<_>>());
    }
    let schedule: serde_json::Map<String, Value> = leed
        .blinds
        .groups
        .iter()
        .zip(&leed.blinds.shaded)
        .map(|(g, s)| {
            (
                g.clone(),
                json!(s.iter().map(|b| u8::from(*b)).collect::<Vec<_>>()),
            )
        })
        .collect();
    let out = json!({"leed": v, "schedule": schedule, "en17037": en});
    std::fs::write(case.join("daystep.json"), out.to_string()).unwrap();
    eprintln!(
        "{}: daystep LEED in {:.3} s",
        case.file_name().unwrap().to_string_lossy(),
        leed_time.as_secs_f64()
    );
}

fn main() {
    // `cargo bench` passes `--bench`; the first other argument is the folder.
    let dir = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with("--"))
        .expect("usage: cargo bench --bench postprocess_peer -- DIR");
    let mut cases: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("results").is_dir())
        .collect();
    cases.sort();
    for c in &cases {
        run_case(c);
    }
}
