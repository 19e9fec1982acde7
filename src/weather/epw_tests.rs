//! Unit tests of the EPW reader ([`super`]): the bundled file against its own text, leap
//! and sub-hourly files, missing values, truncation, and errors naming line and value.

use super::*;
use crate::error::input_parts;
use crate::weather::temp_file;
use chrono::NaiveDateTime;

fn t(s: &str) -> NaiveDateTime {
    NaiveDateTime::parse_from_str(s, "%Y-%m-%dT%H:%M:%S").unwrap()
}

/// The 8 header lines of a synthetic EPW: Boulder-like site, `per_hour` rows per hour,
/// data period `start`–`end` (m/d).
fn header(per_hour: u32, start: &str, end: &str) -> String {
    let mut s = String::from("LOCATION,Test,CO,USA,synthetic,000000,40.000,-105.250,-7.0,1650.0\n");
    for l in [
        "DESIGN CONDITIONS,0",
        "TYPICAL/EXTREME PERIODS,0",
        "GROUND TEMPERATURES,0",
        "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0",
        "COMMENTS 1,synthetic",
        "COMMENTS 2,synthetic",
    ] {
        s.push_str(l);
        s.push('\n');
    }
    s.push_str(&format!(
        "DATA PERIODS,1,{per_hour},Data,Sunday,{start},{end}\n"
    ));
    s
}

/// One 35-field data row with the given dew point, DNI and DHI fields.
fn row(
    year: i32,
    (month, day, hour, minute): (u32, u32, u32, u32),
    dew: &str,
    dni: &str,
    dhi: &str,
) -> String {
    let mut f: Vec<String> = vec![
        year.to_string(),
        month.to_string(),
        day.to_string(),
        hour.to_string(),
        minute.to_string(),
        "A7A7".into(),
        "10.0".into(),
        dew.into(),
    ];
    while f.len() < 35 {
        f.push("0".into());
    }
    f[DNI] = dni.into();
    f[DHI] = dhi.into();
    f.join(",") + "\n"
}

/// A one-day (1 January) hourly file whose row for hour h has DNI 10·h, DHI h.
fn one_day() -> String {
    let mut s = header(1, "1/1", "1/1");
    for h in 1..=24 {
        s.push_str(&row(
            2021,
            (1, 1, h, 60),
            "-5.0",
            &(10 * h).to_string(),
            &h.to_string(),
        ));
    }
    s
}

#[test]
fn bundled_greensboro_file() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/office/weather.epw");
    let text = std::fs::read_to_string(&path).unwrap();
    let w = read(&path).unwrap();

    // The site is the header's fields 6–9 as written (EPW is east-positive already).
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    assert_eq!(head[7], "-79.950");
    assert_eq!(w.site.latitude, head[6].parse::<f64>().unwrap());
    assert_eq!(w.site.longitude, head[7].parse::<f64>().unwrap());
    assert_eq!(w.site.utc_offset_h, head[8].parse::<f64>().unwrap());
    assert_eq!(w.site.elevation_m, head[9].parse::<f64>().unwrap());

    assert_eq!(w.records.len(), 8760);
    assert_eq!(w.interval_minutes, 60);
    assert_eq!(w.format, WeatherFormat::Epw);
    // Hour-ending 1 of 1 January, evaluated at the middle of the hour, reference year.
    assert_eq!(w.records[0].time, t("2021-01-01T00:30:00"));
    assert_eq!(w.records[0].line, 9);
    assert_eq!(w.records[8759].time, t("2021-12-31T23:30:00"));

    // 21 March, hour-ending 12 (the README's record): find its line by splitting text.
    let (i, line) = text
        .lines()
        .enumerate()
        .find(|(_, l)| {
            let f: Vec<&str> = l.split(',').collect();
            f.len() > 15 && f[1] == "3" && f[2] == "21" && f[3] == "12"
        })
        .unwrap();
    let f: Vec<&str> = line.split(',').collect();
    let r = w.records.iter().find(|r| r.line == i + 1).unwrap();
    assert_eq!(r.time, t("2021-03-21T11:30:00"));
    assert_eq!(r.year, f[0].parse::<i32>().unwrap());
    assert_eq!(r.dni, f[14].parse::<f64>().unwrap());
    assert_eq!(r.dhi, f[15].parse::<f64>().unwrap());
    assert_eq!(r.dew_point_c, Some(f[7].parse::<f64>().unwrap()));
    assert_eq!(
        r.diffuse_illuminance_lux,
        Some(f[18].parse::<f64>().unwrap())
    );
    assert!(r.dni > 0.0 && !r.missing);
    // TMY rows come from many years; times still run monotonically through 2021.
    assert!(w.records.windows(2).all(|p| p[1].time > p[0].time));
}

#[test]
fn leap_year_file_keeps_29_february() {
    let mut s = header(1, "1/1", "12/31");
    for m in 1..=12 {
        for d in 1..=days_in_month(m, true) {
            for h in 1..=24 {
                s.push_str(&row(2020, (m, d, h, 60), "1.0", "100", "50"));
            }
        }
    }
    let (_d, p) = temp_file("leap.epw", &s);
    let w = read(&p).unwrap();
    assert_eq!(w.records.len(), 366 * 24);
    // Jan (31 d) + 28 d of Feb = 59 days before 29 Feb: record 59·24 + 12 is its hour 13.
    let r = &w.records[59 * 24 + 12];
    assert_eq!((r.month, r.day, r.year), (2, 29, 2020));
    assert_eq!(r.time, t("2020-02-29T12:30:00"));
    assert_eq!(w.records.last().unwrap().time, t("2020-12-31T23:30:00"));
    assert!(w.warnings.is_empty(), "{:?}", w.warnings);

    // The same file claiming 2021 for 29 February is rejected at that row's line:
    // 8 header lines + 59·24 rows before it.
    let bad = s.replace("2020,2,29,1,", "2021,2,29,1,");
    let (_d, p) = temp_file("leap.epw", &bad);
    let (_, _, line, value) = input_parts(read(&p).unwrap_err());
    assert_eq!(
        (line, value.as_deref()),
        (Some(8 + 59 * 24 + 1), Some("2021"))
    );
}

#[test]
fn sub_hourly_rows_are_evaluated_mid_interval() {
    // 4 rows per hour → 15-minute intervals; hour-ending 1, rows end 00:15 … 01:00.
    let mut s = header(4, " 1/ 1", " 1/ 1");
    for h in 1..=24 {
        for m in [15, 30, 45, 60] {
            s.push_str(&row(2021, (1, 1, h, m), "0", "1", "1"));
        }
    }
    let (_d, p) = temp_file("q.epw", &s);
    let w = read(&p).unwrap();
    assert_eq!((w.records.len(), w.interval_minutes), (96, 15));
    assert_eq!(w.records[0].time, t("2021-01-01T00:07:30"));
    assert_eq!(w.records[3].time, t("2021-01-01T00:52:30"));
    assert_eq!(w.records[4].time, t("2021-01-01T01:07:30"));
    assert_eq!(w.records[95].time, t("2021-01-01T23:52:30"));
}

#[test]
fn missing_values_are_flagged_once() {
    let mut s = one_day();
    // Line 12 = hour 4: DNI missing; line 15 = hour 7: DHI blank; dew point 99.9.
    let lines: Vec<String> = s.lines().map(str::to_owned).collect();
    let mut l = lines.clone();
    l[11] = row(2021, (1, 1, 4, 60), "99.9", "9999", "4")
        .trim_end()
        .into();
    l[14] = row(2021, (1, 1, 7, 60), "", "70", "").trim_end().into();
    s = l.join("\n") + "\n";
    let (_d, p) = temp_file("m.epw", &s);
    let w = read(&p).unwrap();
    let r4 = &w.records[3];
    assert_eq!(
        (r4.line, r4.dni, r4.dhi, r4.missing, r4.dew_point_c),
        (12, 0.0, 4.0, true, None)
    );
    let r7 = &w.records[6];
    assert_eq!(
        (r7.line, r7.dni, r7.dhi, r7.missing, r7.dew_point_c),
        (15, 70.0, 0.0, true, None)
    );
    assert_eq!(w.records[0].dew_point_c, Some(-5.0));
    assert_eq!(w.missing_count(), 2);
    assert_eq!(w.warnings.len(), 1, "{:?}", w.warnings);
    assert!(
        w.warnings[0].contains("2 records") && w.warnings[0].contains("line 12"),
        "{}",
        w.warnings[0]
    );
}

#[test]
fn truncated_files_name_the_last_line() {
    // 20 of the 24 rows: the file's last line is 8 + 20 = 28.
    let s: String = one_day()
        .lines()
        .take(28)
        .map(|l| format!("{l}\n"))
        .collect();
    let (_d, p) = temp_file("t.epw", &s);
    let (shown, path, line, _) = input_parts(read(&p).unwrap_err());
    assert_eq!((path, line), (p, Some(28)));
    assert!(shown.contains("20 of the 24"), "{shown}");

    // A row cut after its 10th field (line 9 + 5 = 14).
    let mut l: Vec<String> = one_day().lines().map(str::to_owned).collect();
    l[13] = l[13].split(',').take(10).collect::<Vec<_>>().join(",");
    let (_d, p) = temp_file("t.epw", &(l.join("\n") + "\n"));
    let (shown, _, line, _) = input_parts(read(&p).unwrap_err());
    assert_eq!(line, Some(14));
    assert!(shown.contains("truncated"), "{shown}");

    // Only a header.
    let (_d, p) = temp_file("t.epw", "LOCATION,a,b,c,d,0,1,2,3,4\nDESIGN CONDITIONS,0\n");
    let (_, _, line, _) = input_parts(read(&p).unwrap_err());
    assert_eq!(line, Some(2));
}

#[test]
fn bad_fields_name_line_and_value() {
    let cases: [(usize, String, &str); 6] = [
        // (line, replacement row, offending field as written)
        (10, row(2021, (1, 1, 2, 60), "0", "NaN", "2"), "NaN"),
        (11, row(2021, (1, 1, 3, 60), "0", "30", "-1"), "-1"),
        (12, row(2021, (1, 1, 4, 60), "0", "abc", "4"), "abc"),
        (13, row(2021, (13, 1, 5, 60), "0", "50", "5"), "13"),
        (14, row(2021, (1, 1, 0, 60), "0", "60", "6"), "0"),
        (15, row(2021, (1, 1, 7, 60), "inf", "70", "7"), "inf"),
    ];
    for (line, replacement, value) in cases {
        let mut l: Vec<String> = one_day().lines().map(str::to_owned).collect();
        l[line - 1] = replacement.trim_end().into();
        let (_d, p) = temp_file("b.epw", &(l.join("\n") + "\n"));
        let (shown, path, got_line, got_value) = input_parts(read(&p).unwrap_err());
        assert_eq!(
            (path, got_line, got_value.as_deref()),
            (p, Some(line), Some(value)),
            "{shown}"
        );
    }
    // A row out of calendar order (hour 5 where hour 3 belongs, line 11).
    let mut l: Vec<String> = one_day().lines().map(str::to_owned).collect();
    l[10] = row(2021, (1, 1, 5, 60), "0", "0", "0").trim_end().into();
    let (_d, p) = temp_file("b.epw", &(l.join("\n") + "\n"));
    let (shown, _, line, value) = input_parts(read(&p).unwrap_err());
    assert_eq!(
        (line, value.as_deref()),
        (Some(11), Some("2021,1,1,5")),
        "{shown}"
    );
}

#[test]
fn diffuse_illuminance_is_optional_and_checked() {
    // Field 19: a value, EPW's missing code, blank, absent (a row cut after DHI), NaN.
    let with = |v: Option<&str>| {
        let mut l: Vec<String> = one_day().lines().map(str::to_owned).collect();
        let mut f: Vec<String> = l[9].split(',').map(str::to_owned).collect();
        match v {
            Some(v) => f[DIFFUSE_ILLUMINANCE] = v.into(),
            None => f.truncate(DHI + 1),
        }
        l[9] = f.join(",");
        if v.is_none() {
            // Every row as short, so the file is consistent.
            for r in l.iter_mut().skip(8) {
                let f: Vec<&str> = r.split(',').take(DHI + 1).collect();
                *r = f.join(",");
            }
        }
        let (_d, p) = temp_file("i.epw", &(l.join("\n") + "\n"));
        read(&p).map(|w| w.records[1].diffuse_illuminance_lux)
    };
    assert_eq!(with(Some("1234.5")).unwrap(), Some(1234.5));
    assert_eq!(with(Some("999999")).unwrap(), None);
    assert_eq!(with(Some("")).unwrap(), None);
    assert_eq!(with(None).unwrap(), None);
    let (_, _, line, value) = input_parts(with(Some("NaN")).unwrap_err());
    assert_eq!((line, value.as_deref()), (Some(10), Some("NaN")));
}

#[test]
fn wrong_header_names_line_one() {
    let s = one_day().replacen("LOCATION", "LOKATION", 1);
    let (_d, p) = temp_file("h.epw", &s);
    let (_, _, line, value) = input_parts(read(&p).unwrap_err());
    assert_eq!(line, Some(1));
    assert!(value.unwrap().starts_with("LOKATION"));
    // A bad latitude is named by value.
    let s = one_day().replacen("40.000", "95.0", 1);
    let (_d, p) = temp_file("h.epw", &s);
    let (_, _, line, value) = input_parts(read(&p).unwrap_err());
    assert_eq!((line, value.as_deref()), (Some(1), Some("95.0")));
}
