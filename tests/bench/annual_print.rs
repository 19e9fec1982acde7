//! The annual bench's tables: daystep's cold and warm runs beside Radiance's 2-phase
//! (times, ratios, peaks), the annual metrics of each, Radiance's stages, daystep's runs.

use super::*;

fn show_daystep(label: &str, r: &DsRun) {
    let rep = &r.v["report"];
    let dirs = &rep["directions"];
    println!(
        "| {label} | {} | {} | {} | {} built, {} from cache, {} reused | {} / {} | {:.1} | {:.1} | {:.0} | {:.2} % / {:.2} % |",
        rep["steps"], rep["computed"], rep["sun_steps"], dirs["built"], dirs["from_cache"],
        dirs["reused"], rep["cache"]["writes"], rep["cache"]["evictions"],
        r.report("total_seconds"), r.f("load_seconds"), r.f("peak_rss_mb"),
        100.0 * r.report("median_relative_err"), 100.0 * r.report("p95_relative_err")
    );
    let split: Vec<String> = rep["stage_seconds"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|s| {
                    format!(
                        "{} {:.2}",
                        s[0].as_str().unwrap_or("?"),
                        s[1].as_f64().unwrap_or(f64::NAN)
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    println!(
        "|   stages (s, summed over threads) | {} |",
        split.join(", ")
    );
}

pub(super) struct SceneResult {
    pub(super) name: String,
    pub(super) triangles: u64,
    pub(super) sensors: u64,
    pub(super) steps: u64,
    pub(super) cold: DsRun,
    pub(super) warm: DsRun,
    pub(super) rad: Option<RadRun>,
}

fn ratio(a: f64, b: f64) -> String {
    if b > 0.0 && a.is_finite() && b.is_finite() {
        format!("{:.2}", a / b)
    } else {
        "—".into()
    }
}

pub(super) fn print_results(results: &[SceneResult], period: Period, o: &Opts, rad_note: &str) {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let threads = results
        .first()
        .map_or(0, |r| r.cold.v["threads"].as_u64().unwrap_or(0));
    let rad_opts = o.radiance_opts.as_deref().unwrap_or(RADIANCE_OPTS);
    println!(
        "\n## Annual cost: daystep against Radiance 2-phase ({})\n",
        period.label()
    );
    println!(
        "{cores} cores; daystep {} default quality, {threads} threads; {rad_note}",
        env!("CARGO_PKG_VERSION")
    );
    if let Some(r) = results.iter().find_map(|r| r.rad.as_ref()) {
        println!(
            "Radiance: {} (pyradiance {}), `rfluxmtx -n {} {rad_opts}`, sky `gendaymtx -m 1` \
             (145 patches + ground) of `epw2wea`'s WEA; daystep reads the EPW itself (its \
             dew point; gendaymtx assumes 11 °C).",
            r.v["radiance"].as_str().unwrap_or("?"),
            r.v["pyradiance"].as_str().unwrap_or("?"),
            o.radiance_nproc
        );
    }
    println!(
        "\nTimes are wall seconds of each whole run (daystep: the child process, scene and \
         weather reading included; Radiance: its programs, the Python scene conversion not \
         counted). Ratios are daystep ÷ Radiance (below 1: daystep faster). Peak memory: \
         daystep's VmHWM; Radiance's summed over its processes (rfluxmtx, rcontrib × n), \
         sampled every 0.1 s, with its largest process in brackets.\n"
    );
    println!(
        "| scene | steps | triangles | sensors | daystep cold s | daystep warm s | Radiance 2-phase s \
         | cold / Radiance | warm / Radiance | peak MB: cold / warm / Radiance |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for r in results {
        let (rs, rmem) = match &r.rad {
            Some(x) => (
                format!("{:.1}", x.f("radiance_seconds")),
                format!("{:.0} ({:.0})", x.f("rss_tree_mb"), x.f("rss_process_mb")),
            ),
            None => ("—".into(), "—".into()),
        };
        let rsec = r.rad.as_ref().map_or(f64::NAN, |x| x.f("radiance_seconds"));
        println!(
            "| {} | {} | {} | {} | {:.1} | {:.1} | {rs} | {} | {} | {:.0} / {:.0} / {rmem} |",
            r.name,
            r.steps,
            r.triangles,
            r.sensors,
            r.cold.wall_s,
            r.warm.wall_s,
            ratio(r.cold.wall_s, rsec),
            ratio(r.warm.wall_s, rsec),
            r.cold.f("peak_rss_mb"),
            r.warm.f("peak_rss_mb"),
        );
    }
    println!(
        "\nAnnual metrics (occupied: steps starting 8:00–17:59 local standard time, every day; \
         means over sensors):\n"
    );
    println!("| scene | tool | DA300 mean | sDA300/50 % | UDI100-3000 mean | mean occupied lux |");
    println!("|---|---|---|---|---|---|");
    for r in results {
        for (label, run) in [("daystep, cold", &r.cold), ("daystep, warm", &r.warm)] {
            println!(
                "| {} | {label} | {:.1} % | {:.1} % | {:.1} % | {:.0} |",
                r.name,
                run.metric("mean_da"),
                run.metric("sda_percent"),
                run.metric("mean_udi_within"),
                run.metric("mean_lux")
            );
        }
        if let Some(x) = &r.rad {
            println!(
                "| {} | Radiance 2-phase | {:.1} % | {:.1} % | {:.1} % | {:.0} |",
                r.name,
                x.metric("DA300 mean"),
                x.metric("sDA300/50%"),
                x.metric("UDI100-3000 mean"),
                x.metric("mean occupied lux")
            );
        }
    }
    for r in results {
        if let Some(x) = &r.rad {
            match hourly(&r.cold, x) {
                Some((mean, rms, n)) => println!(
                    "\n{}: daystep (cold) − Radiance over {n} occupied sensor-hours with Radiance \
                     > 100 lx: mean {mean:+.1} %, RMS {rms:.1} % (relative).",
                    r.name
                ),
                None => println!(
                    "\n{}: hour-by-hour rows do not line up: not compared.",
                    r.name
                ),
            }
        }
    }
    if results.iter().any(|r| r.rad.is_some()) {
        println!("\nRadiance stages (wall s):\n");
        println!(
            "| scene | epw2wea | gendaymtx | rfluxmtx | dctimestep | rmtxop | total | scene \
             conversion (Python, not in total) | validate.py process |"
        );
        println!("|---|---|---|---|---|---|---|---|---|");
        for r in results {
            if let Some(x) = &r.rad {
                println!(
                    "| {} | {:.2} | {:.2} | {:.1} | {:.2} | {:.2} | {:.1} | {:.2} | {:.1} |",
                    r.name,
                    x.stage("epw2wea"),
                    x.stage("gendaymtx"),
                    x.stage("rfluxmtx"),
                    x.stage("dctimestep"),
                    x.stage("rmtxop"),
                    x.f("radiance_seconds"),
                    x.f("convert_seconds"),
                    x.process_s
                );
            }
        }
        if let Some(x) = results.iter().find_map(|r| r.rad.as_ref()) {
            println!(
                "\nRadiance commands (in its work folder, e.g. {}):\n",
                x.v["work"].as_str().unwrap_or("?")
            );
            for c in x.v["commands"].as_array().into_iter().flatten() {
                println!("- `{}`", c.as_str().unwrap_or("?"));
            }
        }
    }
    println!("\ndaystep runs:\n");
    println!(
        "| run | steps | computed | sun steps | directions | cache writes / evictions | run_annual s | load s | peak MB | stated error median / p95 |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for r in results {
        show_daystep(&format!("{}, cold cache", r.name), &r.cold);
        show_daystep(&format!("{}, warm cache", r.name), &r.warm);
    }
    for r in results {
        println!(
            "{}: cold/warm ratio {:.1}",
            r.name,
            r.cold.wall_s / r.warm.wall_s
        );
    }
}
