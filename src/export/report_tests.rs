//! `report.html` and its plan maps: self-contained, one map section per grid in the order
//! of the tables, point colours on the legend's classes, outlines that are the sample
//! rooms' floors (dimensions from the samples' READMEs and generator).

use super::*;
use crate::export::plan_map::{self, floor_triangles, in_triangle, map_svg, nice_ceil};
use glam::DVec2;
use std::path::Path;

fn load(rel: &str) -> Scene {
    Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)).unwrap()
}

/// Metrics with DA and UDI-within `f(k)` % and ASE `g(k)` h for sensor k.
fn metrics(n: usize, f: impl Fn(usize) -> f64, g: impl Fn(usize) -> f64) -> Vec<SensorMetrics> {
    (0..n)
        .map(|k| SensorMetrics {
            da: f(k),
            cda: f(k),
            udi_below: 0.0,
            udi_within: f(k),
            udi_above: 100.0 - f(k),
            ase_hours: g(k),
            mean_lux: 500.0,
            occupied_hours: 3650.0,
        })
        .collect()
}

fn page(scene: &Scene, m: &[SensorMetrics]) -> String {
    report_html(&ReportInputs {
        title: "t <&>".into(),
        scene,
        metrics: m,
        params: &MetricParams::default(),
        leed: None,
        leed_times: &[],
        en17037: None,
    })
    .unwrap()
}

/// Values of attribute `name` in the elements starting with `tag`, in page order.
fn attrs<'a>(text: &'a str, tag: &str, name: &str) -> Vec<&'a str> {
    text.match_indices(tag)
        .filter_map(|(i, _)| {
            let rest = &text[i..];
            let end = rest.find('>')?;
            let key = format!(" {name}=\"");
            let a = rest[..end].find(&key)? + key.len();
            let b = rest[a..].find('"')?;
            Some(&rest[a..a + b])
        })
        .collect()
}

#[test]
fn page_is_self_contained() {
    let s = load("scenes/office/scene.toml");
    let html = page(&s, &metrics(s.sensors.len(), |k| k as f64 % 100.0, |_| 0.0));
    assert!(html.contains(&format!(
        "<meta http-equiv=\"Content-Security-Policy\" content=\"{CSP}\">"
    )));
    assert!(CSP.starts_with("default-src 'none';"));
    let lower = html.to_lowercase();
    for bad in [
        "http:", "https:", "//", "src=", "url(", "<script", "@import", "<link",
    ] {
        assert!(!lower.contains(bad), "page holds {bad}");
    }
    for href in attrs(&html, "<a ", "href") {
        assert!(href.starts_with('#'), "link {href} leaves the page");
    }
    // The title is escaped.
    assert!(html.contains("<title>t &lt;&amp;&gt;</title>"));
}

#[test]
fn every_grid_has_its_table_row_and_maps_in_order() {
    let s = load("scenes/honeybee/scene.toml");
    assert!(s.grids.len() >= 2, "the sample has a grid per room");
    let html = page(&s, &metrics(s.sensors.len(), |k| k as f64 % 100.0, |_| 0.0));
    let ids: Vec<&str> = s.grids.iter().map(|g| g.identifier.as_str()).collect();
    let rows = attrs(&html, "<tr data-grid", "data-grid");
    let maps = attrs(&html, "<section class=\"grid-maps\"", "data-grid");
    assert_eq!(rows, ids);
    assert_eq!(maps, ids);
    for (i, part) in html
        .split("<section class=\"grid-maps\"")
        .skip(1)
        .enumerate()
    {
        let part = &part[..part.find("</section>").unwrap()];
        assert_eq!(part.matches("<svg class=\"map\"").count(), 3);
        // Every sensor of the grid is a point of each map.
        let n = s.grids[i].sensors.len();
        assert_eq!(part.matches("<rect class=\"pt\"").count(), 3 * n);
        assert!(html.contains(&format!("href=\"#map-{i}\"")));
    }
}

#[test]
fn point_colours_are_their_legend_class() {
    let s = load("scenes/office/scene.toml");
    // Sensor k sits in the middle of class k % 10 for DA and UDI; ASE k % 7 h on a scale
    // to nice_ceil(6) = 10 h → class (k % 7) exactly (1 h per class).
    let m = metrics(
        s.sensors.len(),
        |k| 10.0 * (k % 10) as f64 + 5.0,
        |k| (k % 7) as f64,
    );
    let html = page(&s, &m);
    let maps: Vec<&str> = html.split("<svg class=\"map\"").skip(1).collect();
    assert_eq!(maps.len(), 3);
    for (which, map) in maps.iter().enumerate() {
        let swatches = attrs(map, "<rect class=\"swatch\"", "fill");
        assert_eq!(swatches.len(), 10);
        let distinct: std::collections::HashSet<_> = swatches.iter().collect();
        assert_eq!(distinct.len(), 10, "legend colours differ");
        let fills = attrs(map, "<rect class=\"pt\"", "fill");
        assert_eq!(fills.len(), s.sensors.len());
        for (k, fill) in fills.iter().enumerate() {
            let class = if which == 2 { k % 7 } else { k % 10 };
            assert_eq!(*fill, swatches[class], "map {which}, sensor {k}");
        }
    }
    // Viridis and cividis darken to lighten: the legend's luminance rises class by class.
    let lum = |hex: &str| {
        let c = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).unwrap() as f64;
        0.2126 * c(1) + 0.7152 * c(3) + 0.0722 * c(5)
    };
    for map in &maps {
        let l: Vec<f64> = attrs(map, "<rect class=\"swatch\"", "fill")
            .iter()
            .map(|h| lum(h))
            .collect();
        assert!(l.windows(2).all(|w| w[1] > w[0]), "{l:?}");
    }
}

#[test]
fn classes_are_half_open_with_the_top_included() {
    let [da, _, ase] = scales(&metrics(1, |_| 0.0, |_| 260.0), &MetricParams::default());
    assert_eq!(da.class_of(0.0), Some(0));
    assert_eq!(da.class_of(9.999), Some(0));
    assert_eq!(da.class_of(10.0), Some(1));
    assert_eq!(da.class_of(100.0), Some(9));
    assert_eq!(da.class_of(-1.0), Some(0));
    assert_eq!(da.class_of(f64::NAN), None);
    assert_eq!(ase.hi, 500.0);
    assert_eq!(nice_ceil(3.0, 1.0), 5.0);
    assert_eq!(nice_ceil(250.0, 1.0), 250.0);
    assert_eq!(nice_ceil(251.0, 1.0), 500.0);
    assert_eq!(nice_ceil(0.0, 1.0), 1.0);
    assert_eq!(nice_ceil(0.13, 0.01), 0.2);
}

fn area(t: &[plan_map::PlanTriangle]) -> f64 {
    t.iter()
        .map(|t| 0.5 * (t[1] - t[0]).perp_dot(t[2] - t[0]).abs())
        .sum()
}

/// Every sensor lies on the outline's floor, and the floor is the room's: `area` m² within
/// `lo … hi`.
fn check_outline(s: &Scene, sensors: &[usize], room: Option<&str>, a: f64, lo: DVec2, hi: DVec2) {
    let tris = floor_triangles(s, sensors, room);
    assert!(!tris.is_empty());
    assert!((area(&tris) - a).abs() < 1e-6, "floor area {}", area(&tris));
    for t in &tris {
        for p in t {
            assert!(p.cmpge(lo - 1e-9).all() && p.cmple(hi + 1e-9).all(), "{p}");
        }
    }
    for &k in sensors {
        let p = s.sensors[k].position.truncate();
        assert!(tris.iter().any(|t| in_triangle(p, t, 1e-9)), "sensor {k}");
    }
    // The boundary of a rectangle is its four sides (however triangulated), length 2(w+h).
    let len: f64 = plan_map::boundary_edges(&tris)
        .iter()
        .map(|e| e[0].distance(e[1]))
        .sum();
    assert!(
        (len - 2.0 * (hi - lo).element_sum()).abs() < 1e-6,
        "outline {len} m"
    );
}

#[test]
fn office_outline_is_its_floor_not_the_ground() {
    // README: interior x ∈ [0, 6], y ∈ [0, 8], floor at z = 0, the 60 m ground coplanar.
    let s = load("scenes/office/scene.toml");
    let all: Vec<usize> = (0..s.sensors.len()).collect();
    let o = s.origin.truncate();
    check_outline(&s, &all, None, 48.0, -o, DVec2::new(6.0, 8.0) - o);
}

#[test]
fn honeybee_outlines_are_each_rooms_floor() {
    // make_model.py: two 6 × 5 m rooms from (0, 0) and (6, 0), one grid each.
    let s = load("scenes/honeybee/scene.toml");
    for g in &s.grids {
        let sensors: Vec<usize> = g.sensors.clone().collect();
        let x0 = if g.room.as_deref() == Some("Room_West") {
            0.0
        } else {
            6.0
        };
        let (lo, hi) = (DVec2::new(x0, 0.0), DVec2::new(x0 + 6.0, 5.0));
        let lo = lo - s.origin.truncate();
        let hi = hi - s.origin.truncate();
        check_outline(&s, &sensors, g.room.as_deref(), 30.0, lo, hi);
    }
}

/// Points are squares at least 2 px wide that do not overlap their neighbours, from 10 to
/// 10 000 sensors on a regular grid.
#[test]
fn points_stay_readable_from_ten_to_ten_thousand() {
    for (nx, ny) in [(5, 2), (100, 100)] {
        let step = 0.5;
        let pts: Vec<DVec2> = (0..nx * ny)
            .map(|k| DVec2::new((k % nx) as f64 * step, (k / nx) as f64 * step))
            .collect();
        let labels: Vec<usize> = (0..pts.len()).collect();
        let v = vec![50.0; pts.len()];
        let [da, _, _] = scales(&metrics(1, |_| 0.0, |_| 0.0), &MetricParams::default());
        let svg = map_svg(&pts, &labels, &v, &da, &[]);
        let w: Vec<f64> = attrs(&svg, "<rect class=\"pt\"", "width")
            .iter()
            .map(|w| w.parse().unwrap())
            .collect();
        assert_eq!(w.len(), nx * ny);
        let px_per_m = plan_map::map_px(nx * ny) / ((nx.max(ny) - 1) as f64 * step + step);
        for w in w {
            assert!(w >= if nx * ny > 1000 { 5.0 } else { 2.0 }, "{w} px");
            assert!(w <= step * px_per_m + 0.1, "{w} px overlaps");
        }
    }
}

#[test]
fn leed_en17037_tables_and_blind_heat_map() {
    use crate::metrics::en17037::{en17037, En17037Grid};
    use crate::metrics::leed::{leed_option_one, LeedGrid, LeedPeriod, LightPath, Shade};
    let s = load("scenes/office/scene.toml");
    let n = s.sensors.len();
    // Three hourly steps on 21 June; at 11:30 every sensor gets 2000 lx of direct sun
    // (100 % over-lit > 2 %): the group is shaded then, open at 10:30 and 12:30 (no sun).
    let direct: Vec<f32> = (0..3 * n)
        .map(|i| if i / n == 1 { 2000.0 } else { 0.0 })
        .collect();
    let total: Vec<f32> = direct.iter().map(|d| d + 400.0).collect();
    let occupied = [true; 3];
    let g = LeedGrid {
        name: "all sensors",
        sensors: n,
        areas: None,
        paths: vec![LightPath {
            name: "south",
            total: &total,
            direct: &direct,
            shade: Shade::Transmittance(0.05),
        }],
    };
    let leed = leed_option_one(
        &[g],
        &LeedPeriod {
            occupied: &occupied,
            total_occupied_steps: 3,
            hours_per_step: 1.0,
        },
    )
    .unwrap();
    assert_eq!(leed.blinds.shaded, [vec![false, true, false]]);
    let en = en17037(
        &[En17037Grid {
            name: "all sensors",
            sensors: n,
            areas: None,
            total: &total,
        }],
        &occupied,
        crate::metrics::en17037::DAYLIGHT_HOURS,
    )
    .unwrap();
    let times: Vec<_> = [10, 11, 12]
        .iter()
        .map(|h| {
            chrono::NaiveDate::from_ymd_opt(2021, 6, 21)
                .unwrap()
                .and_hms_opt(*h, 30, 0)
                .unwrap()
        })
        .collect();
    let m = metrics(n, |_| 50.0, |_| 0.0);
    let html = report_html(&ReportInputs {
        title: "leed".into(),
        scene: &s,
        metrics: &m,
        params: &MetricParams::default(),
        leed: Some(&leed),
        leed_times: &times,
        en17037: Some(&en),
    })
    .unwrap();
    // LEED: every sensor has 400 lx or more at every step: DA 100 %, sDA 100 %; ASE 1 h.
    let leed_part = &html[html.find("<table id=\"leed\"").unwrap()..];
    let leed_part = &leed_part[..leed_part.find("</table>").unwrap()];
    assert!(leed_part
        .contains("<tr data-grid=\"all sensors\"><td class=\"l\">all sensors</td><td>100.0</td>"));
    assert!(html.contains(&format!("<b>Points: {}</b>", leed.points)));
    // EN 17037: three rows over all grids and three for the grid; 3 of 4380 daylight hours
    // meet nothing for half the time: every level fails both ways.
    let en_part = &html[html.find("<table id=\"en17037\"").unwrap()..];
    let en_part = &en_part[..en_part.find("</table>").unwrap()];
    assert_eq!(en_part.matches("<tr").count(), 1 + 6);
    assert_eq!(en_part.matches("class=\"fail\"").count(), 12);
    // Heat map: one day column, hours 10 and 11 and 12 filled, 11 shaded.
    let svg = &html[html
        .find("<svg class=\"blinds\" data-group=\"south\"")
        .unwrap()..];
    let svg = &svg[..svg.find("</svg>").unwrap()];
    let fills = attrs(svg, "<rect", "fill");
    assert_eq!(fills, [OPEN, SHADED, OPEN]);
    let ys: Vec<f64> = attrs(svg, "<rect", "y")
        .iter()
        .map(|y| y.parse().unwrap())
        .collect();
    assert!(ys.windows(2).all(|w| w[1] > w[0]), "hours run down");
}
