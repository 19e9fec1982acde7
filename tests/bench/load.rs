//! Model load time and memory (`cargo bench --bench load`, issue 24): a generated HBJSON of
//! about 100 000 faces (box rooms on a grid, each with a window and a sensor grid of 4
//! points) and a Radiance scene of 100 000 polygons (the same rooms as `polygon`s), each
//! loaded by `Scene::load` in a child process of this bench, three times: median wall
//! time, and the child's peak resident memory (VmHWM). `-- --faces N` sets the size.
//! Prints figures; asserts nothing about time.

use daystep::scene::Scene;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// Rooms of 4 m × 4 m × 3 m on a grid; 6 faces each (one wall with a window).
fn room_corners(k: usize, side: usize) -> [f64; 2] {
    [(k % side) as f64 * 5.0, (k / side) as f64 * 5.0]
}

fn box_faces(x: f64, y: f64) -> Vec<(&'static str, Vec<[f64; 3]>)> {
    let (x1, y1, h) = (x + 4.0, y + 4.0, 3.0);
    vec![
        (
            "Floor",
            vec![[x, y, 0.0], [x, y1, 0.0], [x1, y1, 0.0], [x1, y, 0.0]],
        ),
        (
            "RoofCeiling",
            vec![[x, y, h], [x1, y, h], [x1, y1, h], [x, y1, h]],
        ),
        (
            "Wall",
            vec![[x, y, 0.0], [x1, y, 0.0], [x1, y, h], [x, y, h]],
        ),
        (
            "Wall",
            vec![[x1, y, 0.0], [x1, y1, 0.0], [x1, y1, h], [x1, y, h]],
        ),
        (
            "Wall",
            vec![[x1, y1, 0.0], [x, y1, 0.0], [x, y1, h], [x1, y1, h]],
        ),
        (
            "Wall",
            vec![[x, y1, 0.0], [x, y, 0.0], [x, y, h], [x, y1, h]],
        ),
    ]
}

fn pts(v: &[[f64; 3]]) -> String {
    let inner: Vec<String> = v
        .iter()
        .map(|p| format!("[{}, {}, {}]", p[0], p[1], p[2]))
        .collect();
    format!("[{}]", inner.join(", "))
}

/// An HBJSON Model of `rooms` box rooms (6 faces, 1 aperture on the south wall).
fn hbjson(rooms: usize) -> String {
    let side = (rooms as f64).sqrt().ceil() as usize;
    let mut s = String::from(
        "{\"type\": \"Model\", \"identifier\": \"Load_Bench\", \"units\": \"Meters\", \
         \"tolerance\": 0.001, \"properties\": {\"type\": \"ModelProperties\", \"radiance\": \
         {\"type\": \"ModelRadianceProperties\", \"sensor_grids\": [",
    );
    for k in 0..rooms {
        let [x, y] = room_corners(k, side);
        let sensors: Vec<String> = [(1.0, 1.0), (3.0, 1.0), (1.0, 3.0), (3.0, 3.0)]
            .iter()
            .map(|(a, b)| {
                format!(
                    "{{\"pos\": [{}, {}, 0.8], \"dir\": [0, 0, 1]}}",
                    x + a,
                    y + b
                )
            })
            .collect();
        let _ = write!(
            s,
            "{}{{\"type\": \"SensorGrid\", \"identifier\": \"Room_{k}_Grid\", \
             \"room_identifier\": \"Room_{k}\", \"sensors\": [{}]}}",
            if k > 0 { ", " } else { "" },
            sensors.join(", ")
        );
    }
    s.push_str("]}}, \"rooms\": [");
    for k in 0..rooms {
        let [x, y] = room_corners(k, side);
        let _ = write!(
            s,
            "{}{{\"type\": \"Room\", \"identifier\": \"Room_{k}\", \"properties\": {{\"type\": \
             \"RoomProperties\"}}, \"faces\": [",
            if k > 0 { ", " } else { "" }
        );
        for (i, (kind, v)) in box_faces(x, y).into_iter().enumerate() {
            let bc = if kind == "Floor" {
                "Ground"
            } else {
                "Outdoors"
            };
            let aperture = if i == 2 {
                let a = [
                    [x + 1.0, y, 0.8],
                    [x + 3.0, y, 0.8],
                    [x + 3.0, y, 2.2],
                    [x + 1.0, y, 2.2],
                ];
                format!(
                    ", \"apertures\": [{{\"type\": \"Aperture\", \"identifier\": \
                     \"Room_{k}_Glz\", \"geometry\": {{\"type\": \"Face3D\", \"boundary\": {}}}, \
                     \"boundary_condition\": {{\"type\": \"Outdoors\"}}, \"properties\": \
                     {{\"type\": \"AperturePropertiesAbridged\"}}}}]",
                    pts(&a)
                )
            } else {
                String::new()
            };
            let _ = write!(
                s,
                "{}{{\"type\": \"Face\", \"identifier\": \"Room_{k}_F{i}\", \"face_type\": \
                 \"{kind}\", \"geometry\": {{\"type\": \"Face3D\", \"boundary\": {}}}, \
                 \"boundary_condition\": {{\"type\": \"{bc}\"}}, \"properties\": {{\"type\": \
                 \"FacePropertiesAbridged\"}}{aperture}}}",
                if i > 0 { ", " } else { "" },
                pts(&v)
            );
        }
        s.push_str("]}");
    }
    s.push_str("]}\n");
    s
}

/// A Radiance scene of `polygons` polygons: the same rooms, walls as plain polygons.
fn rad(polygons: usize) -> String {
    let rooms = polygons.div_ceil(6);
    let side = (rooms as f64).sqrt().ceil() as usize;
    let mut s = String::from("void plastic wall\n0\n0\n5 0.5 0.5 0.5 0 0\n\n");
    let mut n = 0;
    'rooms: for k in 0..rooms {
        let [x, y] = room_corners(k, side);
        for (i, (_, v)) in box_faces(x, y).into_iter().enumerate() {
            if n == polygons {
                break 'rooms;
            }
            let coords: Vec<String> = v
                .iter()
                .map(|p| format!("{} {} {}", p[0], p[1], p[2]))
                .collect();
            let _ = writeln!(
                s,
                "wall polygon room_{k}_{i}\n0\n0\n12 {}\n",
                coords.join(" ")
            );
            n += 1;
        }
    }
    s
}

fn vm_hwm_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    // Child: load one scene, print seconds and peak memory.
    if let Some(i) = args.iter().position(|a| a == "--child") {
        let t0 = Instant::now();
        let scene = Scene::load(Path::new(&args[i + 1])).expect("load");
        let secs = t0.elapsed().as_secs_f64();
        println!(
            "{secs} {} {} {}",
            vm_hwm_mb(),
            scene.input_triangles,
            scene.sensors.len()
        );
        return;
    }
    let faces: usize = args
        .iter()
        .position(|a| a == "--faces")
        .and_then(|i| args.get(i + 1)?.parse().ok())
        .unwrap_or(100_000);
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let site = "[site]\nlatitude = 36.1\nlongitude = -79.95\nutc_offset_h = -5\n";
    let rooms = faces.div_ceil(6);
    std::fs::write(d.join("model.hbjson"), hbjson(rooms)).unwrap();
    std::fs::write(
        d.join("hb.toml"),
        format!("geometry = \"model.hbjson\"\n{site}"),
    )
    .unwrap();
    std::fs::write(d.join("model.rad"), rad(faces)).unwrap();
    std::fs::write(
        d.join("rad.toml"),
        format!("geometry = \"model.rad\"\n{site}"),
    )
    .unwrap();
    println!("| model | faces | file MB | triangles | sensors | load s (min / median / max of 3) | peak MB |");
    println!("|---|---|---|---|---|---|---|");
    for (name, toml, file, n) in [
        ("HBJSON", "hb.toml", "model.hbjson", rooms * 7),
        (".rad", "rad.toml", "model.rad", faces),
    ] {
        let mut secs = Vec::new();
        let mut peak = 0.0f64;
        let mut counts = (0, 0);
        for _ in 0..3 {
            let o = std::process::Command::new(&args[0])
                .args(["--child", d.join(toml).to_str().unwrap()])
                .output()
                .expect("child");
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let text = String::from_utf8_lossy(&o.stdout);
            let v: Vec<&str> = text.split_whitespace().collect();
            secs.push(v[0].parse::<f64>().unwrap());
            peak = peak.max(v[1].parse().unwrap());
            counts = (v[2].parse().unwrap(), v[3].parse().unwrap());
        }
        secs.sort_by(f64::total_cmp);
        let mb = std::fs::metadata(d.join(file)).unwrap().len() as f64 / 1e6;
        println!(
            "| {name} | {n} | {mb:.1} | {} | {} | {:.2} / {:.2} / {:.2} | {peak:.0} |",
            counts.0, counts.1, secs[0], secs[1], secs[2]
        );
    }
}
