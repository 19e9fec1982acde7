//! Tests of the glTF frames' sun altitude (what the viewer opens on).

use super::*;

/// `asset.extras.daystep.frames` of a `.glb`.
fn frames_json(glb: &[u8]) -> Vec<serde_json::Value> {
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let root: serde_json::Value = serde_json::from_slice(&glb[20..20 + len]).unwrap();
    root["asset"]["extras"]["daystep"]["frames"]
        .as_array()
        .unwrap()
        .clone()
}

fn one_triangle() -> SolutionGeometry {
    let corners = [DVec3::ZERO, DVec3::X, DVec3::Y];
    SolutionGeometry::new(
        &[(corners, DVec3::Z, 0.5, 0)],
        vec![GltfMaterial {
            name: "floor".into(),
            kd: DVec3::splat(0.5),
            glazing: false,
        }],
        DVec3::ZERO,
    )
}

fn frame(label: &str) -> GltfFrame {
    GltfFrame {
        label: label.into(),
        radiance: vec![DVec3::splat(10.0)],
        irradiance: vec![DVec3::splat(60.0)],
        sensor_lux: vec![],
    }
}

/// At solar noon of an equinox the sun stands at 90° − latitude (declination ≈ 0). The
/// office's site (36.1° N, 79.95° W, UTC−5): local mean noon is 12:19:48 standard time and
/// the equation of time on 20 March 2021 is −7.5 min, so solar noon is 12:27 (±1 min).
#[test]
fn frames_at_local_times_carry_the_suns_altitude() {
    let site = Site {
        latitude: 36.1,
        longitude: -79.95,
        utc_offset_h: -5.0,
        elevation_m: 0.0,
    };
    let labels = [
        "2021-03-20T09:27",
        "2021-03-20T12:27",
        "2021-03-20T15:27:00",
        "frame 3",
    ];
    let frames: Vec<GltfFrame> = labels.iter().map(|l| frame(l)).collect();
    let glb = one_triangle().with_site(site).encode(&frames, &[]).unwrap();
    let f = frames_json(&glb);
    let alt = |k: usize| f[k]["sun_altitude_deg"].as_f64();
    let noon = alt(1).unwrap();
    assert!((noon - (90.0 - 36.1)).abs() < 0.5, "noon altitude {noon}");
    // Three hours either side of solar noon the sun is lower, and equally so (the
    // declination moves by under 0.05° in those hours).
    let (am, pm) = (alt(0).unwrap(), alt(2).unwrap());
    assert!(am < noon - 10.0 && (am - pm).abs() < 0.3, "{am} {pm}");
    // A label that is no time carries none; nor does any frame without a site.
    assert_eq!(alt(3), None);
    let bare = frames_json(&one_triangle().encode(&frames, &[]).unwrap());
    assert!(bare.iter().all(|f| f.get("sun_altitude_deg").is_none()));
}

/// Whether any vertex lies strictly inside an edge of a triangle of `p` (within 10 µm of
/// the segment, over 10 µm from both ends): a T-junction. Brute force, independent of the
/// splitter's grid.
fn t_junctions(p: &Primitive) -> usize {
    let at = |i: u32| {
        let v = p.positions[i as usize];
        DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
    };
    let mut n = 0;
    for t in p.indices.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (at(t[k]), at(t[(k + 1) % 3]));
            for v in 0..p.positions.len() as u32 {
                let q = at(v);
                let s = (q - a).dot(b - a) / (b - a).length_squared();
                let off = (a + (b - a) * s).distance(q);
                if off < 1e-5 && q.distance(a) > 1e-5 && q.distance(b) > 1e-5 && s > 0.0 && s < 1.0
                {
                    n += 1;
                }
            }
        }
    }
    n
}

fn area(p: &Primitive) -> f64 {
    let at = |i: u32| {
        let v = p.positions[i as usize];
        DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)
    };
    p.indices
        .chunks_exact(3)
        .map(|t| (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0])).length() / 2.0)
        .sum()
}

/// A large triangle beside two small ones whose shared corner (1, 1) lies on its long edge:
/// the large one is split through that corner, no T-junction is left, the area is kept,
/// and the new centre vertex carries the mean of the large triangle's corners.
#[test]
fn a_vertex_on_a_neighbours_edge_splits_that_edge() {
    let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
    let rows = [
        ([p(0.0, 0.0), p(2.0, 0.0), p(0.0, 2.0)], DVec3::Z, 2.0, 0),
        ([p(2.0, 0.0), p(2.0, 2.0), p(1.0, 1.0)], DVec3::Z, 1.0, 0),
        ([p(1.0, 1.0), p(2.0, 2.0), p(0.0, 2.0)], DVec3::Z, 1.0, 0),
    ];
    let material = GltfMaterial {
        name: "floor".into(),
        kd: DVec3::splat(0.5),
        glazing: false,
    };
    let g = SolutionGeometry::new(&rows, vec![material], DVec3::ZERO);
    let prim = &g.primitives[0];
    assert_eq!(t_junctions(prim), 0);
    assert!((area(prim) - 4.0).abs() < 1e-9, "{}", area(prim));
    // 5 welded corners and the split triangle's centre; the large triangle becomes a fan
    // of 4 (its 3 corners and the one on its edge), the small ones stay: 6 triangles.
    assert_eq!(prim.positions.len(), 6);
    assert_eq!(prim.indices.len(), 3 * 6);
    // The mesh without the splitting has one T-junction: the check can fail.
    let mut unsplit = prim.clone();
    unsplit.indices = rows
        .iter()
        .flat_map(|r| r.0)
        .map(|c| {
            let q = to_gltf(c);
            prim.positions.iter().position(|v| *v == q).unwrap() as u32
        })
        .collect();
    assert_eq!(t_junctions(&unsplit), 1);
    let per_row = [DVec3::splat(3.0), DVec3::splat(9.0), DVec3::splat(6.0)];
    let values = g.vertex_values(prim, &per_row);
    let corner = |x: f64, y: f64| {
        let q = to_gltf(p(x, y));
        values[prim.positions.iter().position(|v| *v == q).unwrap()]
    };
    let mean = (corner(0.0, 0.0) + corner(2.0, 0.0) + corner(0.0, 2.0)) / 3.0;
    assert!(
        (values[5] - mean).length() < 1e-12,
        "{} vs {}",
        values[5],
        mean
    );
}
