//! Parser properties ([`super`]): views: `--view` option strings and `.vf` files.

use super::*;

// Views: `--view` option strings and `.vf` files

/// A view file as rvu saves it, with a comment and a second line overriding the first.
const VF_SAMPLE: &str = "\
# saved by rvu
rvu -vtv -vp 2.5 3 1.2 -vd 0 -1 0 -vu 0 0 1 -vh 60 -vv 45 -vo 0 -va 0 -vs 0 -vl 0
-vta -vh 180 -vv 180 -vd 0 0 1 -vu 0 1 0
";

fn view_format() -> Format {
    Format::new(
        Sep::Whitespace,
        "-vtv -vta -vth -vtl -vtc -vt -vp -vd -vu -vh -vv -vs -vl -vo -va -vf -v rvu rpict \
         VIEW= 180 179.99999999 360 360.0000001 1e9 1000000001 1000 -1000 1000.5 1e-320 \
         -1e-320 1e300 -1e300 2e9 0.0 -0.0",
        "\
rvu
-vtl -vh 1e9 -vv 1e9 -vp 1e9 -1e9 1e9
-vth -vh 180 -vv 180
-vtv -vh 179.99999999999997
-vd 0 0 0
-vd 1e308 1e308 1e308 -vu -1e308 1e308 0
-vd 1e-320 0 0 -vu 0 1e-320 0
-vu 0 -1 0
-vs 1000 -vl -1000
-vo 1
-va 0
-vtx
# only a comment
VIEW= -vta -vh 360 -vv 360",
    )
}

/// What a parsed view promises: finite numbers within their ranges, unit `vd` and `vu`
/// not along each other, and a finite ray with a unit direction (or none, outside a
/// fisheye's circle) through every image position.
fn check_view(v: &View) -> CaseResult {
    let finite = |x: f64| x.is_finite();
    prop_assert!(
        v.vp.is_finite() && v.vp.abs().max_element() <= MAX_COORDINATE_M,
        "{v:?}"
    );
    prop_assert!(unit(v.vd) && unit(v.vu), "{v:?}");
    prop_assert!(v.vd.cross(v.vu).length() >= 1e-9, "{v:?}");
    let max = match v.kind {
        ViewType::Perspective => 180.0,
        ViewType::Angular => 360.0,
        ViewType::Hemispherical => 180.0,
        ViewType::Parallel => MAX_COORDINATE_M,
    };
    for s in [v.vh, v.vv] {
        prop_assert!(finite(s) && s > 0.0 && s <= max, "{v:?}");
        if v.kind == ViewType::Perspective {
            prop_assert!(s < 180.0, "{v:?}");
        }
    }
    for s in [v.vs, v.vl] {
        prop_assert!(finite(s) && s.abs() <= MAX_SHIFT, "{v:?}");
    }
    for i in 0..=4 {
        for j in 0..=4 {
            let (x, y) = (f64::from(i) / 4.0, f64::from(j) / 4.0);
            if let Some((o, d)) = guarded(|| v.ray(x, y))? {
                prop_assert!(o.is_finite() && unit(d), "ray ({x}, {y}) of {v:?}: {o} {d}");
            }
        }
    }
    // What the view says of itself reads back as the same view.
    let back = View::default().with_options(&v.options(), Path::new("<options>"), None);
    prop_assert_eq!(back.ok(), Some(*v));
    Ok(())
}

/// Parses `text` as `--view` options (guarded) and checks the outcome.
fn parse_view(text: &str) -> CaseResult {
    let source = Path::new("<view>");
    match guarded(|| View::default().with_options(text, source, None))? {
        Ok(v) => check_view(&v),
        Err(Error::Input { path, message, .. }) => {
            prop_assert_eq!(path.as_path(), source);
            prop_assert!(!message.is_empty());
            Ok(())
        }
        Err(e) => Err(TestCaseError::fail(format!("not an input error: {e}"))),
    }
}

/// Reads `text` as a `.vf` file (guarded) and checks the outcome.
fn read_view_file(f: &Folder, text: &str) -> CaseResult {
    let p = f.write("view.vf", text.as_bytes());
    match guarded(|| View::read_file(&p))? {
        Ok(v) => check_view(&v),
        Err(e) => check_error(
            &e,
            &Naming {
                files: std::slice::from_ref(&p),
                whole_file: &["bad view file"],
                value_on_line: true,
            },
        ),
    }
}

/// Option-like text: view options with numbers of every size, other options and words.
fn view_like() -> impl Strategy<Value = String> {
    regex(
        "((-vt[vahlcs]?|-v[pdu]( [-+]?[0-9.e]{1,5}| nan| inf){0,3}|-v[hvslaof]( [-+]?[0-9.e]{1,5}\
         | nan| 1e400)?|rvu|-x [0-9]{1,3}|[a-z=]{1,4}) ){0,10}",
    )
}

#[test]
fn view_options_arbitrary_text() {
    check(2048, prop_oneof![any_text(), view_like()], |text| {
        parse_view(&text)
    });
}

#[test]
fn view_option_mutations() {
    let sample = VF_SAMPLE.lines().nth(1).expect("the rvu line");
    parse_view(sample).expect("the sample parses");
    let format = view_format();
    check(4096, mutations(), |m| {
        // One line: the mutations' inserted lines become more options.
        parse_view(&mutate_text(sample, &m, &format).replace('\n', " "))
    });
}

#[test]
fn view_file_arbitrary_text() {
    let f = Folder::office();
    check(1024, prop_oneof![any_text(), view_like()], |text| {
        read_view_file(&f, &text)
    });
}

#[test]
fn view_file_mutations() {
    let f = Folder::office();
    read_view_file(&f, VF_SAMPLE).expect("the sample reads");
    let format = view_format();
    check(4096, mutations(), |m| {
        read_view_file(&f, &mutate_text(VF_SAMPLE, &m, &format))
    });
}

/// Views of every type with numbers across their whole range (and past it), written as
/// options: a view that parses reads back from [`View::options`] as exactly itself.
#[test]
fn view_options_round_trip() {
    let number = prop_oneof![
        8 => -2.0..2.0f64,
        4 => -1e3..1e3f64,
        1 => -2e9..2e9f64,
        1 => any::<f64>(),
        1 => Just(0.0),
        1 => Just(-0.0),
        1 => Just(180.0),
        1 => Just(360.0),
    ];
    let kind = prop::sample::select(vec!["v", "a", "h", "l"]);
    let view = (kind, prop::collection::vec(number, 13));
    let parsed = std::sync::atomic::AtomicUsize::new(0);
    check(4096, view, |(t, n)| {
        let text = format!(
            "-vt{t} -vp {} {} {} -vd {} {} {} -vu {} {} {} -vh {} -vv {} -vs {} -vl {}",
            n[0],
            n[1],
            n[2],
            n[3],
            n[4],
            n[5],
            n[6],
            n[7],
            n[8],
            n[9].abs(),
            n[10].abs(),
            n[11],
            n[12]
        );
        if View::default()
            .with_options(&text, Path::new("<view>"), None)
            .is_ok()
        {
            parsed.fetch_add(1, Ordering::Relaxed);
        }
        parse_view(&text)
    });
    // Enough of them are views for the round trip to mean something.
    let parsed = parsed.into_inner();
    assert!(parsed >= 400, "only {parsed} of 4096 parsed");
}
