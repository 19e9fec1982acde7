//! The generated scenes: the office's areas, normals and closure, the building's triangle
//! target and sensor placement, the OBJ writer, and the bundled `scenes/office` against
//! its generator.

use crate::scenes::*;
use daystep::math::bvh::Bvh;
use daystep::scene::synthetic::SceneBuilder;
use daystep::scene::{Scene, Triangle};
use glam::DVec3;
use std::collections::HashMap;
use std::path::Path;

fn model(scene: &Scene, p: DVec3) -> DVec3 {
    p + scene.origin
}

fn group_of<'a>(scene: &'a Scene, t: &Triangle) -> &'a str {
    &scene.groups[t.group as usize]
}

#[test]
fn office_counts_areas_and_normals() {
    let s = side_lit_office();
    assert_eq!(s.dropped_degenerate, 0);
    assert_eq!(s.sensors.len(), 11 * 15);
    assert!(
        (50..1000).contains(&s.input_triangles),
        "{}",
        s.input_triangles
    );
    assert_eq!(s.site, greensboro());
    let room_centre = DVec3::new(3.0, 4.0, 1.5);
    let building_centre = room_centre;
    let block_centre = DVec3::new(3.0, -17.2, 5.0);
    let window_axis = |p: DVec3| DVec3::new(3.0, p.y, 1.65);
    let mut area_by_group: HashMap<&str, f64> = HashMap::new();
    for t in &s.triangles[..s.input_triangles] {
        assert!(t.area() > 1e-3, "{t:?}");
        let n = t.normal();
        let c = model(&s, t.centroid());
        let g = group_of(&s, t);
        *area_by_group.entry(g).or_default() += t.area();
        let ok = match g {
            "floor" => (n - DVec3::Z).length() < 1e-12,
            "ceiling" => (n + DVec3::Z).length() < 1e-12,
            "walls" => (room_centre - c).dot(n) > 0.0,
            "exterior" => (c - building_centre).dot(n) > 0.0,
            "reveal" => (window_axis(c) - c).dot(n) > 0.0,
            "glazing" => (n + DVec3::Y).length() < 1e-12,
            "ground" => (n - DVec3::Z).length() < 1e-12,
            "obstruction" => (c - block_centre).dot(n) > 0.0,
            other => panic!("unexpected group {other}"),
        };
        assert!(ok, "group {g}: normal {n} at {c}");
    }
    let near = |g: &str, want: f64| {
        let a = area_by_group[g];
        assert!((a - want).abs() < 1e-9, "{g}: {a} vs {want}");
    };
    near("floor", 48.0);
    near("ceiling", 48.0);
    near("glazing", 6.0);
    near("walls", 2.0 * 3.0 * (6.0 + 8.0) - 6.0);
    near("reveal", 2.0 * 0.2 * (4.0 + 1.5));
    near("ground", 3600.0 - 6.4 * 8.4 - 200.0);
}

/// Unit directions spread over the sphere (Fibonacci lattice).
fn sphere_dirs(n: usize) -> Vec<DVec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

#[test]
fn office_room_is_closed_except_through_the_glazing() {
    let s = side_lit_office();
    let tris: Vec<[DVec3; 3]> = s.triangles[..s.input_triangles]
        .iter()
        .map(|t| t.v)
        .collect();
    let bvh = Bvh::build(&tris);
    let glass = s.materials.iter().position(|m| m.name == "glass").unwrap() as u32;
    let w = OFFICE_WINDOW;
    let mut origins = vec![DVec3::new(3.0, 4.0, 1.5), DVec3::new(0.3, 0.2, 2.9)];
    origins.extend(s.sensors.iter().step_by(7).map(|x| model(&s, x.position)));
    let mut dirs = sphere_dirs(4000);
    let mut through_glass = 0;
    for (i, &o) in origins.iter().enumerate() {
        if i < 2 {
            // Aim exactly at the window's corners and edges, where leaks would show.
            for (x, z) in [
                (w.a[0], w.b[0]),
                (w.a[1], w.b[1]),
                (3.0, w.b[0]),
                (w.a[0], 1.65),
            ] {
                for y in [0.0, OFFICE_GLAZING_Y, -OFFICE_WALL] {
                    dirs.push((DVec3::new(x, y, z) - o).normalize());
                }
            }
        }
        let o_scene = o - s.origin;
        for &d in &dirs {
            let h = bvh
                .closest_hit(o_scene, d, 1e-9, f64::INFINITY)
                .unwrap_or_else(|| panic!("ray from {o} along {d} escapes"));
            let t = &s.triangles[h.triangle as usize];
            let p = model(&s, o_scene + h.t * d);
            if t.material == glass {
                through_glass += 1;
                assert!((p.y - OFFICE_GLAZING_Y).abs() < 1e-9, "{p}");
                assert!(
                    p.x >= w.a[0] - 1e-9
                        && p.x <= w.a[1] + 1e-9
                        && p.z >= w.b[0] - 1e-9
                        && p.z <= w.b[1] + 1e-9,
                    "glazing hit outside the window at {p}"
                );
            } else {
                let g = group_of(&s, t);
                assert!(
                    matches!(g, "floor" | "ceiling" | "walls" | "reveal"),
                    "ray from {o} along {d} first meets {g} at {p}"
                );
                assert!(h.cos < 0.0, "seen from behind: {g} at {p}");
            }
        }
    }
    assert!(through_glass > 100, "{through_glass}");
}

#[test]
fn building_hits_its_triangle_target() {
    for target in [200, 300, 600, 1_000, 3_000, 10_000, 25_000, 100_000] {
        let b = multi_storey_builder(target);
        let n = b.triangle_count();
        let s = b.build("<building>").unwrap();
        // The scene cuts floors, ceilings and walls where partitions and slabs stand on
        // them: more triangles, never fewer.
        assert!(
            s.input_triangles > n,
            "target {target}: {}",
            s.input_triangles
        );
        assert!(
            (n as f64 - target as f64).abs() <= 0.1 * target as f64,
            "target {target}: {n}"
        );
        assert_eq!(s.dropped_degenerate, 0);
        assert!(s.has_glazing());
        if target == 10_000 {
            assert!(
                (1500..=1700).contains(&s.sensors.len()),
                "{}",
                s.sensors.len()
            );
        }
    }
}

#[test]
fn building_base_count_formula_matches_geometry() {
    for (floors, nx, ny) in [(1, 2, 2), (2, 5, 3), (3, 8, 4)] {
        let mut b = SceneBuilder::new();
        add_building(&mut b, floors, nx, ny, &vec![0; floors]);
        assert_eq!(b.triangle_count(), building_base_triangles(floors, nx, ny));
        let mut b = SceneBuilder::new();
        add_building(&mut b, floors, nx, ny, &vec![3; floors]);
        assert_eq!(
            b.triangle_count(),
            building_base_triangles(floors, nx, ny) + 3 * floors * DESK_TRIS
        );
    }
}

#[test]
fn building_sensors_see_a_ceiling_above_and_a_floor_or_desk_below() {
    let s = multi_storey_building(3_000);
    let tris: Vec<[DVec3; 3]> = s.triangles[..s.input_triangles]
        .iter()
        .map(|t| t.v)
        .collect();
    let bvh = Bvh::build(&tris);
    for x in &s.sensors {
        let up = bvh
            .closest_hit(x.position, DVec3::Z, 0.0, f64::INFINITY)
            .unwrap();
        let t = &s.triangles[up.triangle as usize];
        assert_eq!(s.materials[t.material as usize].name, "ceiling");
        assert!((up.t - (CLEAR - 0.8)).abs() < 1e-9);
        let down = bvh
            .closest_hit(x.position, -DVec3::Z, 0.0, f64::INFINITY)
            .unwrap();
        let name = &s.materials[s.triangles[down.triangle as usize].material as usize].name;
        assert!(name == "floor" || name == "furniture", "{name}");
        assert!(down.cos < 0.0);
    }
}

/// Minimal OBJ reader for the test (the real parser lives elsewhere): triangles only.
fn read_obj_triangles(text: &str) -> Vec<[DVec3; 3]> {
    let mut v = Vec::new();
    let mut out = Vec::new();
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let c: Vec<f64> = it.map(|x| x.parse().unwrap()).collect();
                v.push(DVec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let i: Vec<usize> = it.map(|x| x.parse().unwrap()).collect();
                assert_eq!(i.len(), 3);
                out.push([v[i[0] - 1], v[i[1] - 1], v[i[2] - 1]]);
            }
            _ => {}
        }
    }
    out
}

#[test]
fn write_obj_round_trips_counts_and_coordinates() {
    let s = side_lit_office();
    let dir = tempfile::tempdir().unwrap();
    write_obj(&s, dir.path(), "office").unwrap();
    let read = |n: &str| std::fs::read_to_string(dir.path().join(n)).unwrap();
    let obj = read("office.obj");
    let tris = read_obj_triangles(&obj);
    assert_eq!(tris.len(), s.input_triangles);
    for (a, b) in tris.iter().zip(&s.triangles[..s.input_triangles]) {
        for (p, q) in a.iter().zip(b.v) {
            assert!((*p - model(&s, q)).length() < 1e-9);
        }
    }
    assert!(obj.contains("\ng glazing\nusemtl glass\n"));
    let pts = read("office.pts");
    assert_eq!(pts.lines().count(), s.sensors.len());
    assert_eq!(pts.lines().next().unwrap(), "0.5 0.5 0.8 0 0 1");
    let mtl = read("office.mtl");
    assert_eq!(mtl.matches("newmtl ").count(), s.materials.len());
    assert!(mtl.contains("newmtl glass\nKd 0 0 0\nTf 0.88 0.88 0.88\n"));
    assert!(mtl.contains("newmtl ceiling\nKd 0.8 0.8 0.8\n"));
    let toml: toml::Value = toml::from_str(&read("scene.toml")).unwrap();
    assert_eq!(toml["geometry"].as_str(), Some("office.obj"));
    assert_eq!(toml["sensors"].as_str(), Some("office.pts"));
    assert_eq!(toml["up"].as_str(), Some("z"));
    assert_eq!(toml["north_deg"].as_float(), Some(0.0));
    assert_eq!(toml["ground_reflectance"].as_float(), Some(0.2));
    assert_eq!(toml["site"]["latitude"].as_float(), Some(36.1));
    assert_eq!(toml["site"]["longitude"].as_float(), Some(-79.95));
    assert_eq!(toml["site"]["utc_offset_h"].as_float(), Some(-5.0));
    assert_eq!(toml["site"]["elevation_m"].as_float(), Some(273.0));
}

fn bundled_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office")
}

#[test]
fn bundled_office_matches_the_generator() {
    let s = side_lit_office();
    let dir = tempfile::tempdir().unwrap();
    write_obj(&s, dir.path(), "office").unwrap();
    for name in ["scene.toml", "office.obj", "office.mtl", "office.pts"] {
        let fresh = std::fs::read(dir.path().join(name)).unwrap();
        let bundled = std::fs::read(bundled_dir().join(name)).unwrap_or_default();
        assert!(
            fresh == bundled,
            "scenes/office/{name} is stale: run `cargo test --test integration -- \
             --ignored generated_scenes::write_bundled_office`"
        );
    }
}

/// Prints BVH build and per-ray timings on `multi_storey_building(10_000)` (run with
/// `cargo test --test integration -- --ignored --nocapture bvh_timing_report`; no asserts).
#[test]
#[ignore]
fn bvh_timing_report() {
    let s = multi_storey_building(10_000);
    let tris: Vec<[DVec3; 3]> = s.triangles[..s.input_triangles]
        .iter()
        .map(|t| t.v)
        .collect();
    let t0 = std::time::Instant::now();
    let bvh = Bvh::build(&tris);
    let build = t0.elapsed();
    let dirs = sphere_dirs(256);
    let up: Vec<DVec3> = dirs
        .iter()
        .map(|d| DVec3::new(d.x, d.y, d.z.abs()))
        .collect();
    let (mut rays, mut hits, mut found) = (0usize, 0usize, 0usize);
    let t0 = std::time::Instant::now();
    for x in &s.sensors {
        for &d in &up {
            rays += 1;
            // Stop at the first opaque hit, as sensor visibility does.
            bvh.hits_in_order(x.position, d, 1e-6, f64::INFINITY, |h| {
                hits += 1;
                s.materials[s.triangles[h.triangle as usize].material as usize].is_glazing()
            });
        }
    }
    let ordered = t0.elapsed();
    let t0 = std::time::Instant::now();
    for x in &s.sensors {
        for &d in &up {
            found += usize::from(bvh.any_hit(x.position, d, 1e-6, f64::INFINITY));
        }
    }
    let any = t0.elapsed();
    println!(
        "{} triangles, {} sensors: build {:?}; hits_in_order {:.2} µs/ray ({} rays, {:.2} \
         hits/ray); any_hit {:.2} µs/ray ({found} blocked)",
        s.input_triangles,
        s.sensors.len(),
        build,
        ordered.as_secs_f64() * 1e6 / rays as f64,
        rays,
        hits as f64 / rays as f64,
        any.as_secs_f64() * 1e6 / rays as f64,
    );
    let o = side_lit_office();
    println!(
        "office: {} triangles, {} sensors",
        o.input_triangles,
        o.sensors.len()
    );
}

/// Regenerates the bundled sample `scenes/office` (run explicitly with `--ignored`).
#[test]
#[ignore]
fn write_bundled_office() {
    write_obj(&side_lit_office(), &bundled_dir(), "office").unwrap();
}

/// Writes the bench scene of issue 23 to `target/bench-building` (run explicitly with
/// `--ignored`): [`corridor_building`]`(10_000)` as drawn (floors and ceilings one polygon
/// under and over the walls: the scene cuts them when it reads the file), with the sensors
/// of its second storey only, for `tests/bench/radiance/run.sh --scene
/// target/bench-building/scene.toml`.
#[test]
#[ignore]
fn write_corridor_building() {
    let drawn = corridor_builder(10_000);
    let mut s = corridor_building(10_000);
    let origin = s.origin;
    s.triangles = drawn
        .triangles()
        .iter()
        .map(|t| Triangle {
            v: t.v.map(|v| v - origin),
            ..*t
        })
        .collect();
    s.input_triangles = s.triangles.len();
    s.sensors
        .retain(|x| (x.input_position.z - (STOREY + 0.8)).abs() < 1e-6);
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/bench-building");
    std::fs::create_dir_all(&dir).unwrap();
    write_obj(&s, &dir, "building").unwrap();
    println!(
        "{} triangles as drawn, {} sensors, in {}",
        s.input_triangles,
        s.sensors.len(),
        dir.display()
    );
}
