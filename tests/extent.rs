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
