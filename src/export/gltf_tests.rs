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
