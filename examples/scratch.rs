use daystep::scene::synthetic;
use daystep::sequence::{run_instant, Quality, SkySpec};
fn main() {
    let b = synthetic::multi_storey_building(10_000);
    let q = Quality::preset(&std::env::args().nth(1).unwrap_or("default".into())).unwrap();
    let (utc, local) = daystep::site::parse_time("2024-06-21T15:00", b.site.utc_offset_h).unwrap();
    let r = run_instant(
        &b,
        utc,
        local,
        &SkySpec::Perez {
            dni: 750.0,
            dhi: 110.0,
            dew_point_c: None,
        },
        &q,
    )
    .unwrap();
    println!("{}", serde_json::to_string_pretty(&r.report).unwrap());
}
