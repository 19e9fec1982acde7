//! The annual bench's `--scaling` mode: daystep only, cold and warm, over one week,
//! across sensor counts and triangle counts; a table, and a log–log plot of seconds
//! against each.

use super::*;

struct Point {
    sweep: &'static str,
    sensors: usize,
    triangles: usize,
    cold: DsRun,
    warm: DsRun,
}

pub(super) fn scaling(root: &Path, o: &Opts, work: &Path, tmp: &Path) {
    let period = Period::resolve(o);
    let epw = root.join("scenes/office/weather.epw");
    // (sweep, target triangles, target sensors); (10 000, 1 000) is in both sweeps; the
    // large point runs only when `--point` names it.
    let plan: [(&str, usize, usize); 6] = [
        ("sensors", 10_000, 100),
        ("both", 10_000, 1_000),
        ("sensors", 10_000, 10_000),
        ("triangles", 1_000, 1_000),
        ("triangles", 100_000, 1_000),
        ("large", 100_000, 10_000),
    ];
    let mut points = Vec::new();
    for (sweep, tris, sensors) in plan {
        if tris > o.max_triangles
            || sensors > o.max_sensors
            || !((o.points.is_empty() && sweep != "large") || o.points.contains(&(tris, sensors)))
        {
            eprintln!("skipping {tris} triangles × {sensors} sensors (--max-… or --point)");
            continue;
        }
        let name = format!("building-{tris}-s{sensors}");
        let scene = with_sensor_grid(scenes::multi_storey_building(tris), sensors);
        let toml = write_scene(&scene, &work.join("scenes").join(&name), "building");
        let cache = tmp.join(format!("cache-{name}"));
        let (cold, warm) = cold_and_warm(&name, &toml, &epw, period, &cache, tmp);
        let _ = std::fs::remove_dir_all(&cache);
        points.push(Point {
            sweep,
            sensors: cold.v["sensors"].as_u64().unwrap_or(0) as usize,
            triangles: cold.v["triangles"].as_u64().unwrap_or(0) as usize,
            cold,
            warm,
        });
    }
    let threads = points
        .first()
        .map_or(0, |p| p.cold.v["threads"].as_u64().unwrap_or(0));
    println!(
        "\n## Scaling: daystep annual over {} (default quality, {threads} threads)\n",
        period.label()
    );
    println!(
        "The generated building (`multi_storey_building(n)`) with a regular sensor grid at 0.8 m \
         on every floor; sensors swept on the 10 000-triangle building, triangles with ≈ 1 000 \
         sensors (`both`: the point the two sweeps share). Wall seconds of the child process \
         (scene and weather reading included).\n"
    );
    println!(
        "| sweep | sensors | triangles | steps | cold s | warm s | cold / warm | peak MB cold | peak MB warm | cache evictions cold / warm |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for p in &points {
        println!(
            "| {} | {} | {} | {} | {:.1} | {:.1} | {:.1} | {:.0} | {:.0} | {} / {} |",
            p.sweep,
            p.sensors,
            p.triangles,
            p.cold.v["report"]["steps"],
            p.cold.wall_s,
            p.warm.wall_s,
            p.cold.wall_s / p.warm.wall_s,
            p.cold.f("peak_rss_mb"),
            p.warm.f("peak_rss_mb"),
            p.cold.v["report"]["cache"]["evictions"],
            p.warm.v["report"]["cache"]["evictions"]
        );
    }
    let svg = root.join("target/bench-annual-scaling.svg");
    match plot(&svg, &points, &period.label()) {
        Ok(()) => println!("\nplot: {}", svg.display()),
        Err(e) => println!("\nplot failed: {e}"),
    }
}

/// A log axis's label: only at 1, 2 and 5 × 10^k, without a trailing ".0".
fn log_label(v: &f64) -> String {
    let e = v.log10().floor();
    let lead = (v / 10f64.powf(e)).round() as i64;
    if [1, 2, 5].contains(&lead) {
        let x = lead as f64 * 10f64.powf(e);
        format!("{:.*}", (-e).max(0.0) as usize, x)
    } else {
        String::new()
    }
}

/// Log–log plot: cold and warm seconds against sensors (left) and triangles (right).
fn plot(path: &Path, points: &[Point], period: &str) -> Result<(), String> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (1200, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let (left, right) = root.split_horizontally(600);
    let panels = [
        (
            left,
            "sensors",
            format!("10 000-triangle building, {period}"),
            "sensors",
        ),
        (
            right,
            "triangles",
            format!("≈ 1 000 sensors, {period}"),
            "triangles",
        ),
    ];
    for (area, sweep, title, xdesc) in panels {
        let mut sel: Vec<&Point> = points
            .iter()
            .filter(|p| p.sweep == sweep || p.sweep == "both")
            .collect();
        let x = |p: &Point| {
            if sweep == "sensors" {
                p.sensors as f64
            } else {
                p.triangles as f64
            }
        };
        sel.sort_by(|a, b| x(a).total_cmp(&x(b)));
        if sel.is_empty() {
            continue;
        }
        let xs: Vec<f64> = sel.iter().map(|p| x(p)).collect();
        let ys: Vec<f64> = sel
            .iter()
            .flat_map(|p| [p.cold.wall_s, p.warm.wall_s])
            .collect();
        let (x0, x1) = (xs[0], xs[xs.len() - 1]);
        let y0 = ys.iter().copied().fold(f64::INFINITY, f64::min).max(1e-3);
        let y1 = ys.iter().copied().fold(0.0, f64::max).max(y0 * 2.0);
        let mut chart = ChartBuilder::on(&area)
            .caption(title, ("sans-serif", 18))
            .margin(14)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(
                (x0 * 0.6..x1 * 1.6).log_scale(),
                (y0 * 0.6..y1 * 1.6).log_scale(),
            )
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc(xdesc)
            .y_desc("wall time, s")
            .x_label_formatter(&log_label)
            .y_label_formatter(&log_label)
            .draw()
            .map_err(|e| e.to_string())?;
        for (label, color, warm) in [("cold cache", RED, false), ("warm cache", BLUE, true)] {
            let line: Vec<(f64, f64)> = sel
                .iter()
                .map(|p| (x(p), if warm { p.warm.wall_s } else { p.cold.wall_s }))
                .collect();
            chart
                .draw_series(LineSeries::new(line.clone(), color.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart
                .draw_series(line.iter().map(|p| Circle::new(*p, 4, color.filled())))
                .map_err(|e| e.to_string())?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
    }
    root.present().map_err(|e| e.to_string())
}
