//! HDR image skies against closed forms and against the analytic sky they were made from:
//! a uniform image gives E = πL; an image of daystep's own CIE overcast sky, in both
//! mappings, gives the analytic sky's sensor values.

use crate::util::*;
use daystep::photometry::Rgb;
use daystep::sequence::{Quality, SkySpec};
use daystep::sky::image::{ImageSky, Mapping};
use daystep::sky::Sky;
use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// Unit direction at the centre of pixel (col, row) of a `w × h` image in `mapping`, by
/// the mapping's documented convention (sky::image), written out here independently.
fn pixel_direction(mapping: Mapping, w: usize, h: usize, col: usize, row: usize) -> Option<DVec3> {
    let (x, y) = ((col as f64 + 0.5) / w as f64, (row as f64 + 0.5) / h as f64);
    let (theta, phi) = match mapping {
        Mapping::Equirect => (PI * y, 2.0 * PI * x),
        Mapping::Angular => {
            let (ax, ay) = ((x - 0.5) * PI, (0.5 - y) * PI);
            let r = (ax * ax + ay * ay).sqrt();
            if r > FRAC_PI_2 {
                return None;
            }
            (r, (-ax).atan2(ay))
        }
    };
    Some(DVec3::new(
        theta.sin() * phi.sin(),
        theta.sin() * phi.cos(),
        theta.cos(),
    ))
}

fn image_of(sky: &Sky, mapping: Mapping, w: usize, h: usize) -> ImageSky {
    let mut rgb = vec![Rgb::ZERO; w * h];
    for row in 0..h {
        for col in 0..w {
            if let Some(d) = pixel_direction(mapping, w, h, col, row) {
                rgb[row * w + col] = sky.radiance(d);
            }
        }
    }
    ImageSky::new(w, h, rgb, mapping, 0.0)
}

fn sensors_scene() -> daystep::scene::Scene {
    let mut b = Builder::new();
    b.sensor(DVec3::ZERO, DVec3::Z);
    b.sensor(DVec3::ZERO, DVec3::X);
    b.sensor(DVec3::ZERO, DVec3::new(0.0, -1.0, 1.0));
    b.build()
}

#[test]
fn a_uniform_image_sky_gives_pi_l_on_a_horizontal_sensor() {
    let l = 7.0;
    for (mapping, w, h) in [(Mapping::Equirect, 256, 128), (Mapping::Angular, 200, 200)] {
        let img = ImageSky::new(w, h, vec![Rgb::splat(l); w * h], mapping, 0.0);
        let sky = sky_of(Some(Box::new(img)), None, 0.0);
        let r = run(&sensors_scene(), &sky, &Quality::default());
        let e = lux_of(PI * l);
        eprintln!(
            "{mapping:?}: {:+.3} %",
            100.0 * (r.sensors[0].lux / e - 1.0)
        );
        assert_close(
            &format!("{mapping:?} horizontal"),
            r.sensors[0].lux,
            e,
            5e-3 * e,
        );
    }
}

#[test]
fn an_image_of_the_cie_overcast_sky_gives_the_analytic_values_in_both_mappings() {
    let site = daystep::site::Site::default();
    let (utc, local) = daystep::site::parse_time("2024-03-21T12:00", site.utc_offset_h).unwrap();
    let sun = daystep::site::solar_position::solar_position(utc, &site);
    let spec = SkySpec::CieOvercast { dhi: 100.0 };
    use chrono::Datelike;
    let analytic = daystep::sequence::sky::build_sky(&spec, &sun, local.ordinal(), 0.2).unwrap();
    let room = crate::physics::roof_opening_room(2.0, None);
    let q = Quality::default();
    let mut open = sensors_scene();
    // Both scenes: the open sensors and the one under the roof opening.
    let expect_open = run(&open, &analytic, &q).sensors;
    let expect_room = run(&room, &analytic, &q).sensors;
    for (mapping, w, h) in [(Mapping::Equirect, 720, 360), (Mapping::Angular, 512, 512)] {
        let sky = Sky {
            distribution: Some(Box::new(image_of(&analytic, mapping, w, h))),
            sun: None,
            ground_radiance: analytic.ground_radiance,
            description: format!("image {mapping:?}"),
            warnings: Vec::new(),
        };
        for (scene, expect) in [(&mut open, &expect_open), (&mut room.clone(), &expect_room)] {
            let got = run(scene, &sky, &q).sensors;
            for (k, (g, e)) in got.iter().zip(expect.iter()).enumerate() {
                eprintln!(
                    "{mapping:?} sensor {k}: {:+.3} %",
                    100.0 * (g.lux / e.lux - 1.0)
                );
                assert_close(
                    &format!("{mapping:?} sensor {k}"),
                    g.lux,
                    e.lux,
                    0.01 * e.lux,
                );
            }
        }
    }
}

#[test]
fn instant_reads_an_image_sky_and_refuses_bad_pixels_naming_the_file() {
    use daystep::render::{Image, Quantity};
    let dir = tempfile::tempdir().unwrap();
    let mut img = Image::new(64, 32, Quantity::Radiance);
    img.rgb.iter_mut().for_each(|p| *p = Rgb::splat(10.0));
    let hdr = dir.path().join("sky.hdr");
    daystep::render::rgbe::write_hdr(&hdr, &img, None).unwrap();
    let out = dir.path().join("out");
    let scene = office();
    let args = |image: &str| {
        vec![
            "instant".to_string(),
            scene.to_str().unwrap().into(),
            "--time".into(),
            "2024-03-21T12:00".into(),
            "--sky".into(),
            "image".into(),
            "--image".into(),
            image.into(),
            "--quality".into(),
            "draft".into(),
            "--no-cache".into(),
            "--out".into(),
            out.to_str().unwrap().into(),
        ]
    };
    let a = args(hdr.to_str().unwrap());
    let o = daystep(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("sensors.csv")).unwrap();
    let lux: Vec<f64> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(4).unwrap().parse().unwrap())
        .collect();
    assert!(lux.iter().all(|v| v.is_finite() && *v > 0.0));
    // A NaN pixel: exit 1, naming the file and the pixel.
    img.rgb[100] = Rgb::new(f64::NAN, 1.0, 1.0);
    let exr = dir.path().join("bad.exr");
    daystep::render::exr::write_exr(&exr, &img).unwrap();
    let a = args(exr.to_str().unwrap());
    let o = daystep(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("bad.exr") && stderr(&o).contains("pixel (36, 1)"),
        "{}",
        stderr(&o)
    );
}
