//! Site context of any size (issue 13): the sample office on its 60 m ground, on a 1 km ×
//! 1 km ground and inside a ring of context blocks 200–400 m away. The room's element
//! sizes, line spacing and projections follow the region of interest (the sensors plus a
//! margin), so its sensors must read the same within the two runs' stated errors. The
//! physics differs only slightly: ground beyond 60 m replaces the ground glow of equal
//! reflectance, and the blocks subtend less than 9° above the horizon, mostly outside the
//! window's view.

use crate::scenes::{office_on_site, OfficeSite};
use daystep::sequence::{run_instant, Quality, SkySpec};
use daystep::site::local_to_utc;

fn lux(site: OfficeSite) -> (Vec<(f64, f64)>, usize) {
    let scene = office_on_site(site).build("<office on a site>").unwrap();
    let local = chrono::NaiveDate::from_ymd_opt(2024, 3, 21)
        .unwrap()
        .and_hms_opt(11, 30, 0)
        .unwrap();
    let utc = local_to_utc(local, scene.site.utc_offset_h);
    let spec = SkySpec::Perez {
        dni: 978.0,
        dhi: 86.0,
        dew_point_c: Some(-5.0),
    };
    let r = run_instant(&scene, utc, local, &spec, &Quality::default()).unwrap();
    let rows = r.transport.as_ref().map_or(0, |(t, _)| t.rows());
    (r.sensors.iter().map(|s| (s.lux, s.lux_err)).collect(), rows)
}

fn agree(site: OfficeSite) {
    let (a, rows_a) = lux(OfficeSite::Sample);
    let (b, rows_b) = lux(site);
    let mut worst: f64 = 0.0;
    for (k, ((la, ea), (lb, eb))) in a.iter().zip(&b).enumerate() {
        let ratio = (la - lb).abs() / (ea + eb);
        worst = worst.max(ratio);
        assert!(
            ratio <= 1.0,
            "{site:?}: sensor {k} reads {lb:.1} ± {eb:.1} lx, the 60 m site {la:.1} ± {ea:.1}"
        );
    }
    eprintln!("{site:?}: worst |Δ|/(err_a + err_b) = {worst:.2}; rows {rows_a} → {rows_b}");
}

#[test]
fn office_on_a_kilometre_ground_reads_as_on_its_own_site() {
    agree(OfficeSite::KilometreGround);
}

#[test]
fn office_in_a_ring_of_context_blocks_reads_as_on_its_own_site() {
    agree(OfficeSite::ContextRing);
}

/// Writes the office on a 1 km ground and in its ring of blocks as scene files, for the
/// CLI and the Radiance bench: `cargo test --release --test integration -- --ignored
/// write_office_sites` → `target/bench-sites/{kilometre,ring}/scene.toml`.
#[test]
#[ignore = "writes bench scenes"]
fn write_office_sites() {
    for (name, site) in [
        ("kilometre", OfficeSite::KilometreGround),
        ("ring", OfficeSite::ContextRing),
    ] {
        let scene = office_on_site(site).build(name).unwrap();
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("target/bench-sites")
            .join(name);
        std::fs::create_dir_all(&dir).unwrap();
        crate::scenes::write_obj(&scene, &dir, "site").unwrap();
    }
}

/// A source's projection drops the fragments beyond its window's box
/// ([`daystep::projection::Reader::Source`]). Its records must be those of LDIs that keep
/// them ([`daystep::projection::Reader::SourceUncut`]), to the bit, on the windowed 1 km
/// ground and the ring of blocks; sun and sky resolutions, directions from the zenith down
/// to grazing (where the cut came nearest to a read fragment: an element smaller than a
/// pixel at a window's edge is read at the pixel holding its centroid) and below the
/// horizon (ground glow).
#[test]
fn source_projections_drop_only_fragments_nothing_reads() {
    use daystep::projection::{project, project_reading, ProjectionScene, Reader};
    let p = daystep::sequence::Quality::default().projection;
    for site in [OfficeSite::KilometreGround, OfficeSite::ContextRing] {
        let scene = office_on_site(site).build("<office on a site>").unwrap();
        let ps = ProjectionScene::with_region(&scene, p.margin_m);
        assert!(ps.windows.len() > 1, "{site:?}: no windows to cut");
        let (mut leaves, mut kept, mut held) = (0, 0, 0);
        for elevation in [90.0f64, 40.0, 8.0, 1.9, 1.3, 0.4, 0.1, -0.4, -20.0] {
            for azimuth in [10.0f64, 97.0, 190.0, 263.0, 331.0] {
                let (e, a) = (elevation.to_radians(), azimuth.to_radians());
                let d = glam::DVec3::new(e.cos() * a.sin(), e.cos() * a.cos(), e.sin());
                for res in [p.resolution_for(true), p.resolution_for(false)] {
                    let cut = project(&ps, d, res, &p);
                    let all = project_reading(&ps, d, res, &p, Reader::SourceUncut);
                    assert!(cut.stats.fragments <= all.stats.fragments);
                    kept += cut.stats.fragments;
                    held += all.stats.fragments;
                    assert_eq!(
                        cut.leaves.len(),
                        all.leaves.len(),
                        "{site:?} {d:?} at {res}"
                    );
                    for (x, y) in cut.leaves.iter().zip(&all.leaves) {
                        assert!(
                            x.key == y.key && x.weight == y.weight,
                            "{site:?} {d:?} at {res}: {:?} {:?} against {:?} {:?}",
                            x.key,
                            x.weight,
                            y.key,
                            y.weight
                        );
                    }
                    leaves += cut.leaves.len();
                }
            }
        }
        eprintln!("{site:?}: {leaves} leaves the same from {kept} of {held} fragments");
        assert!(kept < held, "{site:?}: nothing was dropped");
    }
}
