//! The generated test and benchmark scenes, built with
//! [`daystep::scene::synthetic::SceneBuilder`]: the bundled side-lit office sample
//! ([`side_lit_office`], written to `scenes/office` by [`write_obj`]) and a scalable
//! multi-storey office building ([`multi_storey_building`]). Shared by the integration
//! tests (`mod scenes;` in `tests/main.rs`; their own tests are `tests/generated_scenes.rs`)
//! and the benches (`#[path = "../scenes/mod.rs"] mod scenes;`).
//!
//! All coordinates are metres in the model frame (x east, y north, z up).

// Each bench uses a few of these.
#![allow(dead_code)]

use daystep::files::write_atomic;
use daystep::photometry::Rgb;
use daystep::scene::synthetic::{Face, Opening, Rect, RoomMaterials, SceneBuilder};
use daystep::scene::Scene;
use daystep::site::Site;
use daystep::Result;
use glam::{DVec2, DVec3};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

/// Greensboro, NC (TMY3 station 723170): 36.100 N, 79.950 W, UTC−5, 273 m.
pub fn greensboro() -> Site {
    Site {
        latitude: 36.1,
        longitude: -79.95,
        utc_offset_h: -5.0,
        elevation_m: 273.0,
    }
}

/// The sample office's window in the south wall (y = 0 inner plane), model frame, m:
/// x range, z range.
pub const OFFICE_WINDOW: Rect = Rect {
    a: [1.0, 5.0],
    b: [0.9, 2.4],
};
/// Thickness of the sample office's walls, floor and ceiling, m.
pub const OFFICE_WALL: f64 = 0.2;
/// The plane of the sample office's glazing (mid-wall), y in m.
pub const OFFICE_GLAZING_Y: f64 = -0.5 * OFFICE_WALL;

/// The materials both generated offices share, in this order: floor 0.2, wall 0.5,
/// ceiling 0.8, exterior 0.35, ground 0.2 (diffuse reflectance).
fn add_office_palette(b: &mut SceneBuilder) -> [u32; 5] {
    [
        b.add_opaque("floor", 0.2),
        b.add_opaque("wall", 0.5),
        b.add_opaque("ceiling", 0.8),
        b.add_opaque("exterior", 0.35),
        b.add_opaque("ground", 0.2),
    ]
}

/// The bundled sample scene as a builder (see [`side_lit_office`]).
pub fn side_lit_office_builder() -> SceneBuilder {
    office_on_site(OfficeSite::Sample)
}

/// The site around the sample office: its own 60 m ground, the same office on a 1 km ×
/// 1 km ground, or on its 60 m ground inside a ring of context blocks 200–400 m away
/// (issue 13: the room's results must not depend on the site's extent).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OfficeSite {
    /// 60 m × 60 m ground (the bundled sample).
    Sample,
    /// 1 km × 1 km ground centred on the room.
    KilometreGround,
    /// The sample's ground plus twelve 30 m tall blocks, 40 m × 40 m, whose centres lie
    /// 200, 300 and 400 m from the room in turn, every 30°.
    ContextRing,
}

/// The sample office on `site` (see [`OfficeSite`]).
pub fn office_on_site(site: OfficeSite) -> SceneBuilder {
    let mut b = SceneBuilder::new();
    let [floor, wall, ceiling, exterior, ground] = add_office_palette(&mut b);
    let obstruction = b.add_opaque("obstruction", 0.3);
    let glass = b.add_glazing("glass", 0.88);

    let (lo, hi) = (DVec3::ZERO, DVec3::new(6.0, 8.0, 3.0));
    let t = OFFICE_WALL;
    let window = Opening {
        face: Face::South,
        rect: OFFICE_WINDOW,
        glazing: None,
    };
    // Inner faces, one group each so they are easy to pick out.
    let none = [None; 6];
    let mut walls = none;
    walls[..4].copy_from_slice(&[Some(wall); 4]);
    b.add_shell("walls", lo, hi, true, walls, &[window]);
    let mut m = none;
    m[Face::Bottom as usize] = Some(floor);
    b.add_shell("floor", lo, hi, true, m, &[]);
    let mut m = none;
    m[Face::Top as usize] = Some(ceiling);
    b.add_shell("ceiling", lo, hi, true, m, &[]);
    // Outer faces of the 0.2 m thick envelope.
    let (olo, ohi) = (lo - DVec3::splat(t), hi + DVec3::splat(t));
    b.add_shell("exterior", olo, ohi, false, [Some(exterior); 6], &[window]);
    // The reveal, split at the mid-wall pane: room side in wall material, outside exterior.
    b.add_reveal(
        "reveal",
        wall,
        Face::South,
        0.0,
        OFFICE_GLAZING_Y,
        OFFICE_WINDOW,
    );
    b.add_reveal(
        "reveal",
        exterior,
        Face::South,
        OFFICE_GLAZING_Y,
        -t,
        OFFICE_WINDOW,
    );
    b.add_rect(
        "glazing",
        glass,
        Face::South,
        OFFICE_GLAZING_Y,
        OFFICE_WINDOW,
    );
    // Obstruction across the street: 20 m wide (centred on the room), 10 m deep, 10 m tall,
    // its north face 12 m from the façade; standing on the ground, so no bottom face.
    let (blo, bhi) = (
        DVec3::new(-7.0, -t - 22.0, 0.0),
        DVec3::new(13.0, -t - 12.0, 10.0),
    );
    let mut m = [Some(obstruction); 6];
    m[Face::Bottom as usize] = None;
    b.add_shell("obstruction", blo, bhi, false, m, &[]);
    // Ground at the floor's level, 60 m × 60 m around the room, with the building's and the
    // obstruction's footprints cut out so nothing overlaps.
    let ground_rect = match site {
        OfficeSite::KilometreGround => Rect::new([-497.0, 503.0], [-496.0, 504.0]),
        _ => Rect::new([-27.0, 33.0], [-26.0, 34.0]),
    };
    if site == OfficeSite::ContextRing {
        let block = b.add_opaque("context", 0.3);
        for k in 0..12 {
            let a = (k as f64 * 30.0).to_radians();
            let r = 200.0 + 100.0 * (k % 3) as f64;
            let c = DVec3::new(3.0 + r * a.cos(), 4.0 + r * a.sin(), 0.0);
            let mut m = [Some(block); 6];
            m[Face::Bottom as usize] = None;
            b.add_shell(
                "context",
                c - DVec3::new(20.0, 20.0, 0.0),
                c + DVec3::new(20.0, 20.0, 30.0),
                false,
                m,
                &[],
            );
        }
    }
    b.add_rect_with_holes(
        "ground",
        ground,
        Face::Top,
        0.0,
        ground_rect,
        &[
            Rect::new([olo.x, ohi.x], [olo.y, ohi.y]),
            Rect::new([blo.x, bhi.x], [blo.y, bhi.y]),
        ],
    );
    b.add_sensor_grid(DVec2::new(0.5, 0.5), DVec2::new(5.5, 7.5), 0.8, 0.5);
    b.set_site(greensboro());
    b.set_north_deg(0.0);
    b.set_ground_reflectance(0.2);
    b
}

/// The bundled sample scene (`scenes/office`): a 6 m (east–west) × 8 m (north–south) × 3 m
/// side-lit office, interior x∈[0,6], y∈[0,8], z∈[0,3] (model frame, m), 0.2 m thick
/// envelope with separate inner and outer faces, one 4 m × 1.5 m south window (sill 0.9 m)
/// glazed mid-wall with `glass` (Tf 0.88), a lined reveal, a 60 m × 60 m ground at z = 0,
/// a 10 m tall, 20 m wide block 12 m south of the façade, and 165 upward sensors at 0.8 m
/// on a 0.5 m grid. Site Greensboro NC, north along +y.
pub fn side_lit_office() -> Scene {
    side_lit_office_builder()
        .build("<synthetic side_lit_office>")
        .expect("the generated office is valid input")
}

// Layout constants of [`multi_storey_building`], m.
const BAY: f64 = 3.0;
/// Storey height of [`multi_storey_building`] (floor to floor), m.
pub const STOREY: f64 = 3.5;
/// Clear height of a storey of [`multi_storey_building`] (floor to ceiling), m.
pub const CLEAR: f64 = 3.2;
const WALL: f64 = 0.2;
const SENSOR_SPACING: f64 = 2.4;
/// Triangles of one desk of [`multi_storey_building`].
pub const DESK_TRIS: usize = 10;

/// Exact triangle count of the building without desks (see [`add_building`]).
pub fn building_base_triangles(floors: usize, nx: usize, ny: usize) -> usize {
    let s = nx + ny;
    let partitions = (nx - 1) / 2;
    // Per storey: room 4s + 28, reveals and glazing 20s, partitions 12 per line; outer
    // shell 4F(s + 4) + 12; ground with the footprint cut out 8.
    floors * (24 * s + 28 + 12 * partitions) + 4 * floors * (s + 4) + 12 + 8
}

/// Adds the building of `floors` storeys on `nx` × `ny` bays with `desks[i]` desks on floor
/// i (see [`multi_storey_building`]).
pub fn add_building(b: &mut SceneBuilder, floors: usize, nx: usize, ny: usize, desks: &[usize]) {
    add_building_with(b, floors, nx, ny, desks, false);
}

/// Width of the doors from the rooms into the corridor of [`corridor_building`], m.
pub const DOOR_W: f64 = 0.9;
/// Height of those doors, m.
pub const DOOR_H: f64 = 2.1;

/// [`add_building`], and with `corridor_walls` the corridor closed off from the rooms by
/// 0.1 m walls on both sides, each room (between two partitions) opening onto it by one
/// 0.9 m × 2.1 m door in its middle: the corridor is then lit only through doors. The
/// floors and ceilings stay one polygon per storey under and over every wall, as
/// modellers draw them.
pub fn add_building_with(
    b: &mut SceneBuilder,
    floors: usize,
    nx: usize,
    ny: usize,
    desks: &[usize],
    corridor_walls: bool,
) {
    let [floor, wall, ceiling, exterior, ground] = add_office_palette(b);
    let partition = b.add_opaque("partition", 0.6);
    let furniture = b.add_opaque("furniture", 0.4);
    let glass = b.add_glazing("glass", 0.88);
    let (w, d) = (nx as f64 * BAY, ny as f64 * BAY);
    let height = floors as f64 * STOREY;
    // One window per bay on every façade, sill 0.9 m, 1.8 m × 1.5 m.
    let windows_on = |face: Face, z0: f64| -> Vec<Opening> {
        let n = if face.axis() == 0 { ny } else { nx };
        (0..n)
            .map(|j| Opening {
                face,
                rect: Rect::new(
                    [j as f64 * BAY + 0.6, j as f64 * BAY + 2.4],
                    [z0 + 0.9, z0 + 2.4],
                ),
                glazing: None,
            })
            .collect()
    };
    let facades = [Face::West, Face::East, Face::South, Face::North];
    let mut all_windows = Vec::new();
    let mut obstacles: Vec<(DVec3, DVec3)> = Vec::new();
    for (i, &n_desks) in desks.iter().enumerate().take(floors) {
        let z0 = i as f64 * STOREY;
        let windows: Vec<Opening> = facades.iter().flat_map(|&f| windows_on(f, z0)).collect();
        let (lo, hi) = (DVec3::new(0.0, 0.0, z0), DVec3::new(w, d, z0 + CLEAR));
        let room = RoomMaterials {
            floor,
            walls: wall,
            ceiling,
        };
        b.add_room("rooms", lo, hi, room, &windows);
        for o in &windows {
            let f = o.face;
            let inner = if f.sign() > 0.0 {
                hi[f.axis()]
            } else {
                lo[f.axis()]
            };
            let outer = inner + f.sign() * WALL;
            b.add_reveal("reveals", exterior, f, inner, outer, o.rect);
            let mid = inner + f.sign() * 0.5 * WALL;
            b.add_rect("glazing", glass, f, mid, o.rect);
        }
        all_windows.extend(windows);
        // Partitions every second bay line, from each long façade to a 0.2·d corridor;
        // three faces (the end against the wall and top/bottom are hidden).
        for k in 1..=(nx - 1) / 2 {
            let x = 2.0 * k as f64 * BAY;
            // With corridor walls, partitions end at the walls' faces (and their ends are
            // hidden against them).
            let c = if corridor_walls { 0.05 } else { 0.0 };
            for (y0, y1, open_end) in [
                (0.0, 0.4 * d - c, Face::North),
                (0.6 * d + c, d, Face::South),
            ] {
                let plo = DVec3::new(x - 0.05, y0, z0);
                let phi = DVec3::new(x + 0.05, y1, z0 + CLEAR);
                let mut m = [None; 6];
                m[Face::West as usize] = Some(partition);
                m[Face::East as usize] = Some(partition);
                if !corridor_walls {
                    m[open_end as usize] = Some(partition);
                }
                b.add_shell("partitions", plo, phi, false, m, &[]);
                obstacles.push((plo, phi));
            }
        }
        if corridor_walls {
            let doors: Vec<f64> = room_spans(nx).map(|(x0, x1)| 0.5 * (x0 + x1)).collect();
            for y in [0.4 * d, 0.6 * d] {
                add_wall_with_doors(b, partition, y, 0.0, w, z0, &doors);
                obstacles.push((
                    DVec3::new(0.0, y - 0.05, z0),
                    DVec3::new(w, y + 0.05, z0 + CLEAR),
                ));
            }
        }
        // Desks (1.4 × 0.6 × 0.75 m, no bottom face): two slots per bay cell, filled
        // cell by cell so a few desks spread over the floor.
        let cells = nx * ny;
        for k in 0..n_desks.min(2 * cells) {
            let (cell, slot) = (k % cells, k / cells);
            let cx = (cell % nx) as f64 * BAY + 1.5;
            let cy = (cell / nx) as f64 * BAY + 1.5 + if slot == 0 { -0.35 } else { 0.35 };
            let dlo = DVec3::new(cx - 0.7, cy - 0.3, z0);
            let dhi = DVec3::new(cx + 0.7, cy + 0.3, z0 + 0.75);
            let mut m = [Some(furniture); 6];
            m[Face::Bottom as usize] = None;
            b.add_shell("furniture", dlo, dhi, false, m, &[]);
        }
    }
    let olo = DVec3::new(-WALL, -WALL, -0.3);
    let ohi = DVec3::new(w + WALL, d + WALL, height);
    b.add_shell(
        "exterior",
        olo,
        ohi,
        false,
        [Some(exterior); 6],
        &all_windows,
    );
    b.add_rect_with_holes(
        "ground",
        ground,
        Face::Top,
        0.0,
        Rect::new([-30.0, w + 30.0], [-30.0, d + 30.0]),
        &[Rect::new([olo.x, ohi.x], [olo.y, ohi.y])],
    );
    // Sensors at 0.8 m on every floor, skipping any inside a partition.
    for i in 0..floors {
        let z = i as f64 * STOREY + 0.8;
        let mut y = 0.5;
        while y <= d - 0.5 + 1e-9 {
            let mut x = 0.5;
            while x <= w - 0.5 + 1e-9 {
                let p = DVec3::new(x, y, z);
                let inside = obstacles
                    .iter()
                    .any(|(lo, hi)| p.cmpge(*lo - 0.01).all() && p.cmple(*hi + 0.01).all());
                if !inside {
                    b.add_sensor(p, DVec3::Z);
                }
                x += SENSOR_SPACING;
            }
            y += SENSOR_SPACING;
        }
    }
}

/// The x ranges (m) of the rooms between partitions of a building `nx` bays wide (see
/// [`add_building`]: partitions every second bay line).
fn room_spans(nx: usize) -> impl Iterator<Item = (f64, f64)> {
    let w = nx as f64 * BAY;
    let mut cuts: Vec<f64> = (1..=(nx - 1) / 2).map(|k| 2.0 * k as f64 * BAY).collect();
    cuts.insert(0, 0.0);
    cuts.push(w);
    (0..cuts.len() - 1).map(move |k| (cuts[k], cuts[k + 1]))
}

/// A 0.1 m wall across the building at `y` (x from `x0` to `x1`, storey at `z0`, clear
/// height), its two faces with a [`DOOR_W`] × [`DOOR_H`] door centred at each of `doors`
/// (x, m), and jambs and head lining each door (no sill: the floor runs through).
fn add_wall_with_doors(
    b: &mut SceneBuilder,
    material: u32,
    y: f64,
    x0: f64,
    x1: f64,
    z0: f64,
    doors: &[f64],
) {
    let holes: Vec<Rect> = doors
        .iter()
        .map(|x| Rect::new([x - 0.5 * DOOR_W, x + 0.5 * DOOR_W], [z0, z0 + DOOR_H]))
        .collect();
    let whole = Rect::new([x0, x1], [z0, z0 + CLEAR]);
    let (ys, yn) = (y - 0.05, y + 0.05);
    b.add_rect_with_holes("corridor walls", material, Face::South, ys, whole, &holes);
    b.add_rect_with_holes("corridor walls", material, Face::North, yn, whole, &holes);
    for h in &holes {
        // Jambs face into the opening; the head faces down.
        b.add_rect(
            "corridor walls",
            material,
            Face::East,
            h.a[0],
            Rect::new([ys, yn], h.b),
        );
        b.add_rect(
            "corridor walls",
            material,
            Face::West,
            h.a[1],
            Rect::new([ys, yn], h.b),
        );
        b.add_rect(
            "corridor walls",
            material,
            Face::Bottom,
            h.b[1],
            Rect::new(h.a, [ys, yn]),
        );
    }
}

/// [`multi_storey_building`] with its corridors walled off from the rooms, lit only
/// through one door per room ([`add_building_with`]); sensors as there, those inside
/// the new walls left out. The bench scene of issue 23.
pub fn corridor_building(target_triangles: usize) -> Scene {
    corridor_builder(target_triangles)
        .build(&format!("<synthetic corridor_building {target_triangles}>"))
        .expect("the generated building is valid input")
}

/// [`corridor_building`] as a builder (the model as drawn).
pub fn corridor_builder(target_triangles: usize) -> SceneBuilder {
    let (floors, nx, ny, desks) = building_plan(target_triangles);
    let mut b = SceneBuilder::new();
    add_building_with(&mut b, floors, nx, ny, &desks, true);
    b.set_site(greensboro());
    b.set_ground_reflectance(0.2);
    b
}

/// A generated office building for benchmarks: storeys of 3.5 m (3.2 m clear, 0.3 m
/// slabs) on a grid of 3 m bays, one glazed 1.8 m × 1.5 m window per bay on all four façades
/// (lined reveals, mid-wall glazing), 0.2 m walls with inner and outer faces, partitions,
/// desks, and a ground at z = 0 reaching 30 m around it. The numbers of floors, bays and
/// desks are chosen so the triangle count is within 10 % of `target_triangles` for targets
/// of 200 and above (the smallest building has 176). Sensors face up 0.8 m above every
/// floor on a 2.4 m grid (1 620 for 10 000 triangles). Deterministic. Site Greensboro NC.
pub fn multi_storey_building(target_triangles: usize) -> Scene {
    multi_storey_builder(target_triangles)
        .build(&format!(
            "<synthetic multi_storey_building {target_triangles}>"
        ))
        .expect("the generated building is valid input")
}

/// [`multi_storey_building`] as a builder: the model as a modeller would export it, with
/// `target_triangles` counted before the scene cuts surfaces where walls stand on them.
pub fn multi_storey_builder(target_triangles: usize) -> SceneBuilder {
    let (floors, nx, ny, desks) = building_plan(target_triangles);
    let mut b = SceneBuilder::new();
    add_building(&mut b, floors, nx, ny, &desks);
    b.set_site(greensboro());
    b.set_ground_reflectance(0.2);
    b
}

/// Floors, bays (x, y) and desks per floor of [`multi_storey_building`] for a triangle
/// target.
fn building_plan(target_triangles: usize) -> (usize, usize, usize, Vec<usize>) {
    let target = target_triangles.max(1);
    let mut floors = ((target as f64).sqrt() / 10.0).round().clamp(1.0, 50.0) as usize;
    // Small targets: fewer floors, so that the smallest plan (2 × 2 bays) still fits.
    while floors > 1 && building_base_triangles(floors, 2, 2) > target {
        floors -= 1;
    }
    // Bays: the base (everything but desks) near 70 % of the target, desks filling the rest.
    let mut best: Option<(f64, usize, usize)> = None;
    for nx in 2..=200usize {
        let ny = nx.div_ceil(2).max(2);
        let base = building_base_triangles(floors, nx, ny);
        let capacity = base + DESK_TRIS * 2 * nx * ny * floors;
        let feasible = base <= target && capacity >= target;
        let score = (base as f64 / target as f64 - 0.7).abs() + if feasible { 0.0 } else { 10.0 };
        if best.is_none_or(|(s, _, _)| score < s) {
            best = Some((score, nx, ny));
        }
    }
    let (_, nx, ny) = best.expect("at least one candidate");
    let base = building_base_triangles(floors, nx, ny);
    let total_desks = (target.saturating_sub(base) + DESK_TRIS / 2) / DESK_TRIS;
    let desks: Vec<usize> = (0..floors)
        .map(|i| total_desks / floors + usize::from(i < total_desks % floors))
        .collect();
    (floors, nx, ny, desks)
}

/// Formats a model-frame coordinate: values within rounding of a multiple of 1e-9 m are
/// snapped to it, so `model − origin + origin` prints as the model value (−0.2, not
/// −0.20000000000000018); everything else prints in full (`{}` round-trips f64).
fn coord(x: f64) -> f64 {
    let r = (x * 1e9).round() / 1e9;
    if (r - x).abs() <= 1e-12 * x.abs().max(1.0) {
        r
    } else {
        x
    }
}

/// Writes `scene` in daystep's on-disk scene format into `dir`:
/// `<stem>.obj` (one `g` per group run, `usemtl` per material, shared vertices),
/// `<stem>.mtl` (`Kd`, plus `Tf`/`Ke` where non-zero), `<stem>.pts` (x y z dx dy dz per
/// sensor) and `scene.toml` (relative paths, `up = "z"`, `north_deg = 0`, ground
/// reflectance, `[site]`). Coordinates are in the true-north (ENU) model frame: the scene's
/// origin is added back and, since a [`Scene`] is already rotated to true north, the file
/// says `north_deg = 0`. Every file is written atomically.
///
/// # Errors
/// [`daystep::Error::Io`] when a file cannot be written.
pub fn write_obj(scene: &Scene, dir: &Path, stem: &str) -> Result<()> {
    let o = scene.origin;
    let name = |s: &str| s.replace(char::is_whitespace, "_");
    // OBJ.
    let mut obj = String::new();
    let _ = writeln!(obj, "# daystep synthetic scene {}", scene.path.display());
    let _ = writeln!(obj, "# metres, z up, x east, y north");
    let _ = writeln!(obj, "mtllib {stem}.mtl");
    let mut index: HashMap<[u64; 3], usize> = HashMap::new();
    let mut faces = String::new();
    let mut current: Option<(u32, u32)> = None;
    // The model's own triangles: back faces are made again when the OBJ is loaded.
    for t in &scene.triangles[..scene.input_triangles] {
        if current != Some((t.group, t.material)) {
            let group = scene
                .groups
                .get(t.group as usize)
                .map_or("default", String::as_str);
            let _ = writeln!(faces, "g {}", name(group));
            let _ = writeln!(
                faces,
                "usemtl {}",
                name(&scene.materials[t.material as usize].name)
            );
            current = Some((t.group, t.material));
        }
        let mut ids = [0usize; 3];
        for (k, v) in t.v.iter().enumerate() {
            let p = [coord(v.x + o.x), coord(v.y + o.y), coord(v.z + o.z)];
            let key = p.map(f64::to_bits);
            let next = index.len() + 1;
            ids[k] = *index.entry(key).or_insert_with(|| {
                let _ = writeln!(obj, "v {} {} {}", p[0], p[1], p[2]);
                next
            });
        }
        let _ = writeln!(faces, "f {} {} {}", ids[0], ids[1], ids[2]);
    }
    obj.push_str(&faces);
    // MTL.
    let mut mtl =
        String::from("# daystep synthetic materials: Kd reflectance, Tf glazing transmittance\n");
    for m in &scene.materials {
        let _ = writeln!(mtl, "\nnewmtl {}", name(&m.name));
        let _ = writeln!(mtl, "Kd {} {} {}", m.kd.x, m.kd.y, m.kd.z);
        if m.tf != Rgb::ZERO {
            let _ = writeln!(mtl, "Tf {} {} {}", m.tf.x, m.tf.y, m.tf.z);
        }
        if m.ke != Rgb::ZERO {
            let _ = writeln!(mtl, "Ke {} {} {}", m.ke.x, m.ke.y, m.ke.z);
        }
    }
    // Sensors.
    let mut pts = String::new();
    for s in &scene.sensors {
        let p = s.position + o;
        let n = s.normal;
        let _ = writeln!(
            pts,
            "{} {} {} {} {} {}",
            coord(p.x),
            coord(p.y),
            coord(p.z),
            coord(n.x),
            coord(n.y),
            coord(n.z)
        );
    }
    // Scene file; `{:?}` keeps a decimal point so TOML reads floats.
    let site = &scene.site;
    let toml = format!(
        "# daystep scene: {}\ngeometry = \"{stem}.obj\"\nsensors = \"{stem}.pts\"\nup = \"z\"\n\
         north_deg = 0.0\nground_reflectance = {:?}\n\n[site]\nlatitude = {:?}\n\
         longitude = {:?}\nutc_offset_h = {:?}\nelevation_m = {:?}\n",
        scene.path.display(),
        scene.ground_reflectance,
        site.latitude,
        site.longitude,
        site.utc_offset_h,
        site.elevation_m,
    );
    write_atomic(&dir.join(format!("{stem}.obj")), obj.as_bytes())?;
    write_atomic(&dir.join(format!("{stem}.mtl")), mtl.as_bytes())?;
    write_atomic(&dir.join(format!("{stem}.pts")), pts.as_bytes())?;
    write_atomic(&dir.join("scene.toml"), toml.as_bytes())?;
    Ok(())
}
