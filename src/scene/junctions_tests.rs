use super::*;

fn tri(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> Triangle {
    Triangle {
        v: [DVec3::from(a), DVec3::from(b), DVec3::from(c)],
        material: 0,
        group: 0,
    }
}

/// A 4 m × 4 m floor at z = 0 facing up, as two triangles sharing the diagonal.
fn floor() -> Vec<Triangle> {
    vec![
        tri([0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [4.0, 4.0, 0.0]),
        tri([0.0, 0.0, 0.0], [4.0, 4.0, 0.0], [0.0, 4.0, 0.0]),
    ]
}

/// A wall in the plane x = `x` from y0 to y1, z from `z0` to `z1` (two triangles, the
/// first holding the foot y0–y1 at z0).
fn wall(x: f64, y0: f64, y1: f64, z0: f64, z1: f64) -> Vec<Triangle> {
    vec![
        tri([x, y0, z0], [x, y1, z0], [x, y1, z1]),
        tri([x, y0, z0], [x, y1, z1], [x, y0, z1]),
    ]
}

fn area(ts: &[Triangle]) -> f64 {
    ts.iter().map(|t| t.area()).sum()
}

/// The floor's pieces (the triangles with an upward normal).
fn floor_pieces(ts: &[Triangle]) -> Vec<Triangle> {
    ts.iter().filter(|t| t.normal().z > 0.99).copied().collect()
}

#[test]
fn a_partition_cuts_the_floor_along_its_foot_and_the_pieces_tile_it() {
    let mut input = floor();
    input.extend(wall(1.5, 0.0, 3.0, 0.0, 3.0));
    let (out, report) = split_at_junctions(input, false);
    let pieces = floor_pieces(&out);
    assert!(pieces.len() > 2, "{pieces:?}");
    assert_eq!(report.added, out.len() - 4);
    assert_eq!(report.cut, 2);
    assert!((area(&pieces) - 16.0).abs() < 1e-12, "{}", area(&pieces));
    for p in &pieces {
        // Each piece is on one side of x = 1.5, and keeps the upward winding.
        let (lo, hi) =
            p.v.iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                    (l.min(v.x), h.max(v.x))
                });
        assert!(hi <= 1.5 + 1e-12 || lo >= 1.5 - 1e-12, "{p:?}");
        assert!(p.normal().z > 0.999_999, "{p:?}");
    }
}

#[test]
fn pieces_sharing_an_edge_get_the_same_crossing_point_to_the_bit() {
    // The foot crosses the floor's diagonal at (1.5, 1.5, 0): both triangles must hold
    // exactly the same vertex there, or the cut leaves a crack.
    let mut input = floor();
    input.extend(wall(1.5, 0.0, 4.0, 0.0, 3.0));
    let (out, _) = split_at_junctions(input, false);
    let on_diagonal: Vec<DVec3> = floor_pieces(&out)
        .iter()
        .flat_map(|t| t.v)
        .filter(|v| (v.x - v.y).abs() < 1e-9 && v.x > 0.1 && v.x < 3.9)
        .collect();
    assert!(on_diagonal.len() >= 2, "{on_diagonal:?}");
    assert!(
        on_diagonal.iter().all(|v| *v == on_diagonal[0]),
        "{on_diagonal:?}"
    );
}

#[test]
fn low_objects_walls_beside_and_walls_along_an_edge_do_not_cut() {
    for standing in [
        wall(1.5, 0.0, 3.0, 0.0, 0.75), // a desk's side
        wall(5.0, 0.0, 3.0, 0.0, 3.0),  // beside the floor
        wall(4.0, 0.0, 4.0, 0.0, 3.0),  // along the floor's edge
        wall(1.5, 0.0, 3.0, 0.01, 3.0), // floating 1 cm above it
        wall(1.5, 1.0, 1.4, 0.0, 2.1),  // a door's jamb
    ] {
        let mut input = floor();
        input.extend(standing.iter().copied());
        let (out, report) = split_at_junctions(input.clone(), false);
        assert_eq!(out, input, "{standing:?}");
        assert_eq!(report, JunctionReport::default());
    }
}

#[test]
fn a_wall_behind_a_one_sided_surface_cuts_it_only_when_both_sides_reflect() {
    // The wall hangs below the floor: it stands on the floor's back.
    let mut input = floor();
    input.extend(
        wall(1.5, 0.0, 3.0, -3.0, 0.0)
            .iter()
            .map(|t| tri(t.v[2].to_array(), t.v[1].to_array(), t.v[0].to_array())),
    );
    let (front, _) = split_at_junctions(input.clone(), false);
    assert_eq!(front, input);
    let (both, report) = split_at_junctions(input, true);
    assert!(report.added > 0 && both.len() > 4);
}

#[test]
fn a_wall_with_a_door_cuts_once_and_materials_and_groups_are_kept() {
    let mut input: Vec<Triangle> = floor()
        .into_iter()
        .map(|t| Triangle {
            material: 3,
            group: 7,
            ..t
        })
        .collect();
    // Two wall segments on one line with a door between y = 1 and y = 2.
    input.extend(wall(2.5, 0.0, 1.0, 0.0, 3.0));
    input.extend(wall(2.5, 2.0, 4.0, 0.0, 3.0));
    let (out, _) = split_at_junctions(input, false);
    let pieces = floor_pieces(&out);
    assert!((area(&pieces) - 16.0).abs() < 1e-12);
    assert!(pieces.iter().all(|p| p.material == 3 && p.group == 7));
    // One line: every piece lies on one side of it.
    for p in &pieces {
        let left = p.v.iter().all(|v| v.x <= 2.5 + 1e-12);
        let right = p.v.iter().all(|v| v.x >= 2.5 - 1e-12);
        assert!(left || right, "{p:?}");
    }
}

#[test]
fn a_slab_cuts_a_facade_drawn_as_one_polygon() {
    // A 7 m high façade in y = 0 facing +y, and a slab at z = 3.5 reaching 5 m into the
    // building: the façade's elements must not span two storeys.
    let facade = vec![
        tri([0.0, 0.0, 0.0], [0.0, 0.0, 7.0], [6.0, 0.0, 7.0]),
        tri([0.0, 0.0, 0.0], [6.0, 0.0, 7.0], [6.0, 0.0, 0.0]),
    ];
    let mut input = facade.clone();
    input.push(tri([0.0, 0.0, 3.5], [6.0, 0.0, 3.5], [6.0, 5.0, 3.5]));
    assert!(input[0].normal().y > 0.99);
    let (out, report) = split_at_junctions(input, false);
    assert!(report.added > 0);
    for p in out.iter().filter(|t| t.normal().y > 0.99) {
        let below = p.v.iter().all(|v| v.z <= 3.5 + 1e-12);
        let above = p.v.iter().all(|v| v.z >= 3.5 - 1e-12);
        assert!(below || above, "{p:?}");
    }
    assert!((area(&out[..out.len() - 1]) - 42.0).abs() < 1e-12);
}

#[test]
fn short_feet_on_one_line_add_up_to_a_wall() {
    // A wall drawn as four 0.3 m strips on one line cuts; one strip alone does not.
    let mut input = floor();
    for k in 0..4 {
        let y = 0.5 + 0.3 * k as f64;
        input.extend(wall(1.5, y, y + 0.3, 0.0, 3.0));
    }
    let (out, report) = split_at_junctions(input, false);
    assert!(report.added > 0);
    for p in floor_pieces(&out) {
        let left = p.v.iter().all(|v| v.x <= 1.5 + 1e-12);
        let right = p.v.iter().all(|v| v.x >= 1.5 - 1e-12);
        assert!(left || right, "{p:?}");
    }
}
