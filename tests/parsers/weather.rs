//! Parser properties ([`super`]): EPW and WEA.

use super::*;

// EPW

/// The bundled EPW's header (its data period cut to 1–2 January) and its first 48 records.
fn epw_sample() -> String {
    let full = office("weather.epw");
    let mut out = String::new();
    for (i, line) in full.lines().take(8 + 48).enumerate() {
        if i == 7 {
            out.push_str("DATA PERIODS,1,1,Data,Sunday, 1/ 1, 1/ 2");
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    out
}

fn epw_format() -> Format {
    Format::new(
        Sep::Comma,
        // `_` stands for a space inside a value.
        "LOCATION DATA_PERIODS 1/1 12/31 2/29 2/30 13/1 0/0 1/_2 2020 2021 -9999 1988 2 61 \
         -90.0001 180.5 -12 99.9"
            .replace('_', " ")
            .as_str(),
        // The second-last line is empty.
        "\
DATA PERIODS,1,60,Data,Sunday,1/1,12/31
DATA PERIODS,1,0,Data,Sunday,1/1,1/2
DATA PERIODS,1,7,Data,Sunday,1/1,1/2
DATA PERIODS,2,1,Data,Sunday,1/1,1/2
DATA PERIODS,1,1,Data,Sunday,2/28,3/1
DATA PERIODS,1,1
LOCATION,x,x,x,x,0,NaN,0,0,0
LOCATION,x,x,x,x,0,0,0,0
2020,2,29,1,60,x,0,0,0,0,0,0,0,0,0,0,0
2021,2,29,1,60,x,0,0,0,0,0,0,0,0,0,0,0
1988,1,1,1,60,x,0,0,0,0,0,0,0,0,9999,9999,0
1988,1,1,1,60,x,0,,0,0,0,0,0,0,,,0
1988,1,1,1
1988,1,1,25,60,x,0,0,0,0,0,0,0,0,0,0,0

,,,,,,,,,,,,,,,,",
    )
}

fn parse_epw(text: String) -> CaseResult {
    let path = Path::new("fuzz/weather.epw");
    match guarded(|| epw::parse(path, &text))? {
        Ok(w) => {
            prop_assert!(!w.records.is_empty());
            check_weather(&w, &text)
        }
        Err(e) => check_text_error(&e, path, &text),
    }
}

#[test]
fn epw_arbitrary_text() {
    let header = epw_sample().lines().take(8).collect::<Vec<_>>().join("\n") + "\n";
    // Arbitrary text, and arbitrary rows (then rows of numbers) after a valid header.
    let h = header.clone();
    let rows = "([-0-9.,]{0,40}\n){0,30}".prop_map(move |r| format!("{h}{r}"));
    let numbers = "(1988,1,[0-9]{1,2},[0-9]{1,2},60,x(,[-0-9.]{0,5}){10,14}\n){0,30}"
        .prop_map(move |r| format!("{header}{r}"));
    check(2048, prop_oneof![any_text(), rows, numbers], parse_epw);
}

#[test]
fn epw_mutations() {
    let sample = epw_sample();
    let w = epw::parse(Path::new("sample.epw"), &sample).expect("the sample parses");
    assert_eq!(w.records.len(), 48);
    let format = epw_format();
    check(8192, mutations(), |m| {
        parse_epw(mutate_text(&sample, &m, &format))
    });
}

/// A header claiming 60 rows an hour for a whole year, followed by three rows: the file is
/// reported truncated at its last line, quickly, and the rows are not allocated for what the
/// header claims (525,600 rows) but for what the file holds.
#[test]
fn epw_header_claiming_a_huge_period_does_not_allocate_for_it() {
    let sample = epw_sample();
    // Three rows of hour 1: in sequence for 60 rows an hour.
    let mut lines: Vec<&str> = sample.lines().take(8).collect();
    lines[7] = "DATA PERIODS,1,60,Data,Sunday,1/1,12/31";
    let first_row = sample.lines().nth(8).expect("a record");
    lines.extend([first_row; 3]);
    let text = lines.join("\n") + "\n";
    let path = Path::new("claims.epw");
    let (r, largest, total, took) = metered(|| epw::parse(path, &text));
    let shown = r.expect_err("truncated").to_string();
    assert!(shown.starts_with("claims.epw:11:"), "{shown}");
    assert!(shown.contains("3 of the 525600 rows"), "{shown}");
    assert!(
        largest < 64 << 10 && total < 1 << 20,
        "largest allocation {largest} B, {total} B in all for a {} B file",
        text.len()
    );
    assert!(took < Duration::from_secs(2), "{took:?}");
    // A count that is not a divisor of 60 (or not a number at all) is named at line 8.
    for n in ["99999999999999999999", "7", "0", "-60"] {
        let text = text.replace("DATA PERIODS,1,60,", &format!("DATA PERIODS,1,{n},"));
        let shown = epw::parse(path, &text).unwrap_err().to_string();
        assert!(shown.starts_with("claims.epw:8:"), "{shown}");
    }
}

// ---------------------------------------------------------------------------------------
// WEA

/// A valid two-day hourly WEA (San Francisco header, readings at the half hours).
fn wea_sample() -> String {
    let mut s = String::from(
        "place San_Francisco\nlatitude 37.62\nlongitude 122.4\ntime_zone 120\n\
         site_elevation 2.0\nweather_data_file_units 1\n",
    );
    for day in 1..=2 {
        for h in 0..24 {
            let sun = (12.0 - (h as f64 + 0.5 - 12.0).abs()).max(0.0);
            s.push_str(&format!(
                "1 {day} {}.5 {} {}\n",
                h,
                (sun * 70.0).round(),
                (sun * 12.0).round()
            ));
        }
    }
    s
}

fn wea_format() -> Format {
    Format::new(
        Sep::Whitespace,
        "place latitude longitude time_zone site_elevation weather_data_file_units 23.99999 \
         23.9998 -210 180.0001",
        "\
latitude NaN
latitude
longitude 99999999999999999999
time_zone -inf
site_elevation 1e308
weather_data_file_units 2
weather_data_file_units
place
place \u{0}
2 29 12 0 0
2 30 12 0 0
1 32 12 0 0
12 31 23.99999 0 0
12 31 23.9998 0 0
1 1 -0 0 0
1 1 1e-308 0 0
1 2 12 9999 9999
1 2 12 1e308 1e308
1 2 12 0
1 2 12 0 0 0",
    )
}

fn parse_wea(text: String) -> CaseResult {
    let path = Path::new("fuzz/weather.wea");
    match guarded(|| wea::parse(path, &text))? {
        Ok(w) => check_weather(&w, &text),
        Err(e) => check_text_error(&e, path, &text),
    }
}

#[test]
fn wea_arbitrary_text() {
    let head = wea_sample().lines().take(6).collect::<Vec<_>>().join("\n") + "\n";
    let rows = "([-0-9. e]{0,30}\n){0,30}".prop_map(move |r| format!("{head}{r}"));
    check(2048, prop_oneof![any_text(), rows], parse_wea);
}

#[test]
fn wea_mutations() {
    let sample = wea_sample();
    let w = wea::parse(Path::new("sample.wea"), &sample).expect("the sample parses");
    assert_eq!(w.records.len(), 48);
    let format = wea_format();
    check(8192, mutations(), |m| {
        parse_wea(mutate_text(&sample, &m, &format))
    });
}

// ---------------------------------------------------------------------------------------
