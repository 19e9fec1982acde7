//! Tests of the command line: every numeric flag, found by walking the whole command,
//! refuses non-finite and out-of-range values.

use super::*;
use clap::builder::Resettable;
use clap::error::ErrorKind;
use clap::{Arg, Command as ClapCommand, CommandFactory, FromArgMatches};
use std::any::TypeId;

/// Integer flags whose every value is meaningful, so their parser may be clap's own:
/// a seed is any `u64`, and port 0 means any free port.
const FULL_RANGE: [&str; 2] = ["seed", "port"];

/// Every argument that takes a value, with the subcommand names that lead to it.
fn value_args() -> Vec<(Vec<String>, Arg)> {
    fn walk(cmd: &ClapCommand, path: &[String], out: &mut Vec<(Vec<String>, Arg)>) {
        for a in cmd.get_arguments() {
            if a.get_action().takes_values() {
                out.push((path.to_vec(), a.clone()));
            }
        }
        for sub in cmd.get_subcommands() {
            let mut p = path.to_vec();
            p.push(sub.get_name().to_string());
            walk(sub, &p, out);
        }
    }
    let mut out = Vec::new();
    walk(&Cli::command(), &[], &mut out);
    out
}

fn type_of(a: &Arg) -> clap::builder::ValueParser {
    a.get_value_parser().clone()
}

fn is_real(a: &Arg) -> bool {
    let t = type_of(a).type_id();
    t == TypeId::of::<f64>() || t == TypeId::of::<f32>() || t == TypeId::of::<Exposure>()
}

fn is_integer(a: &Arg) -> bool {
    let t = type_of(a).type_id();
    [
        TypeId::of::<u8>(),
        TypeId::of::<u16>(),
        TypeId::of::<u32>(),
        TypeId::of::<u64>(),
        TypeId::of::<u128>(),
        TypeId::of::<usize>(),
        TypeId::of::<i8>(),
        TypeId::of::<i16>(),
        TypeId::of::<i32>(),
        TypeId::of::<i64>(),
        TypeId::of::<i128>(),
        TypeId::of::<isize>(),
    ]
    .iter()
    .any(|id| t == *id)
}

/// The largest value of an integer flag's type, as text.
fn type_max(a: &Arg) -> String {
    let t = type_of(a).type_id();
    let maxima: [(TypeId, String); 12] = [
        (TypeId::of::<u8>(), u8::MAX.to_string()),
        (TypeId::of::<u16>(), u16::MAX.to_string()),
        (TypeId::of::<u32>(), u32::MAX.to_string()),
        (TypeId::of::<u64>(), u64::MAX.to_string()),
        (TypeId::of::<u128>(), u128::MAX.to_string()),
        (TypeId::of::<usize>(), usize::MAX.to_string()),
        (TypeId::of::<i8>(), i8::MAX.to_string()),
        (TypeId::of::<i16>(), i16::MAX.to_string()),
        (TypeId::of::<i32>(), i32::MAX.to_string()),
        (TypeId::of::<i64>(), i64::MAX.to_string()),
        (TypeId::of::<i128>(), i128::MAX.to_string()),
        (TypeId::of::<isize>(), isize::MAX.to_string()),
    ];
    maxima.into_iter().find(|(id, _)| t == *id).unwrap().1
}

/// `--name=value` or `-x=value` (the `=` keeps clap from reading "-inf" as flags).
fn spelled(a: &Arg, value: &str) -> String {
    match (a.get_long(), a.get_short()) {
        (Some(l), _) => format!("--{l}={value}"),
        (None, Some(s)) => format!("-{s}={value}"),
        (None, None) => value.to_string(),
    }
}

/// Parses the real command line `daystep PATH… FLAG=value`: `Err` with the rendered
/// message when clap refused the value itself; `Ok` when it took it (the line may still
/// lack other arguments).
fn parse_value(path: &[String], a: &Arg, value: &str) -> Result<(), String> {
    let mut line = vec!["daystep".to_string()];
    line.extend(path.iter().cloned());
    line.push(spelled(a, value));
    match Cli::command().try_get_matches_from(&line) {
        Err(e)
            if matches!(
                e.kind(),
                ErrorKind::ValueValidation | ErrorKind::InvalidValue
            ) =>
        {
            Err(e.to_string())
        }
        _ => Ok(()),
    }
}

#[test]
fn real_flags_refuse_nan_infinities_and_overflow() {
    let reals: Vec<_> = value_args()
        .into_iter()
        .filter(|(_, a)| is_real(a))
        .collect();
    // --dni, --dhi, --turbidity, --dew-point, --rotate three times over, --scale,
    // --glare-threshold, --exposure, --target, six metric thresholds twice over.
    assert!(
        reals.len() >= 25,
        "the walk found {} real flags",
        reals.len()
    );
    for (path, a) in &reals {
        let flag = spelled(a, "");
        let flag = flag.trim_end_matches('=');
        for bad in [
            "NaN", "nan", "inf", "-inf", "+inf", "infinity", "1e400", "-1e400",
        ] {
            match parse_value(path, a, bad) {
                Ok(()) => panic!("daystep {} {flag} {bad} was accepted", path.join(" ")),
                Err(shown) => assert!(
                    shown.contains(flag) && shown.contains(bad),
                    "{flag} {bad}: {shown}"
                ),
            }
        }
    }
}

#[test]
fn integer_flags_refuse_values_past_their_range() {
    let ints: Vec<_> = value_args()
        .into_iter()
        .filter(|(_, a)| is_integer(a))
        .collect();
    assert!(
        ints.len() >= 15,
        "the walk found {} integer flags",
        ints.len()
    );
    let mut full_range = Vec::new();
    for (path, a) in &ints {
        let id = a.get_id().as_str();
        for bad in ["NaN", "inf", "1e400", "1.5", "-1"] {
            assert!(
                parse_value(path, a, bad).is_err(),
                "daystep {} {id} {bad} was accepted",
                path.join(" ")
            );
        }
        // clap's own integer parser takes the whole type; every flag that is not
        // meaningful over all of it must say its range.
        let max = type_max(a);
        if FULL_RANGE.contains(&id) {
            full_range.push(id);
            assert!(parse_value(path, a, &max).is_ok(), "{id} {max}");
        } else {
            let shown = parse_value(path, a, &max).err().unwrap_or_else(|| {
                panic!(
                    "daystep {} {id} {max} was accepted: an integer flag without a range",
                    path.join(" ")
                )
            });
            assert!(shown.contains("expected a whole number from"), "{shown}");
        }
    }
    full_range.sort_unstable();
    full_range.dedup();
    assert_eq!(full_range, ["port", "seed"], "the full-range list is stale");
}

#[test]
fn negative_numbers_reach_every_numeric_flags_parser() {
    // Without `allow_negative_numbers` clap read `--udi-max -1` as an unknown flag -1.
    let mut n = 0;
    for (path, a) in value_args() {
        if !(is_real(&a) || is_integer(&a)) || a.is_positional() {
            continue;
        }
        let flag = spelled(&a, "");
        let flag = flag.trim_end_matches('=').to_string();
        let mut line = vec!["daystep".to_string()];
        line.extend(path.iter().cloned());
        line.extend([flag.clone(), "-1e9".to_string()]);
        let e = Cli::command()
            .try_get_matches_from(&line)
            .expect_err("-1e9 is in no flag's range");
        assert!(
            matches!(
                e.kind(),
                ErrorKind::ValueValidation | ErrorKind::InvalidValue
            ),
            "{line:?}: {e}"
        );
        n += 1;
    }
    assert!(n >= 40, "{n} numeric flags");
}

/// A command line that gives every argument of every subcommand a value it takes, with
/// `required`, `requires` and `conflicts_with` lifted, so that every field of the
/// derived structs is filled from its parser's value.
#[test]
fn every_value_parser_yields_its_fields_type() {
    fn relax(c: ClapCommand) -> ClapCommand {
        c.mut_args(|a| {
            a.required(false)
                .requires(Resettable::Reset)
                .conflicts_with(Resettable::Reset)
        })
        .mut_subcommands(relax)
    }
    fn line(cmd: &ClapCommand, out: &mut Vec<String>) {
        let mut opts = Vec::new();
        for a in cmd.get_arguments() {
            if !a.get_action().takes_values() {
                continue;
            }
            let value = if is_real(a) || is_integer(a) {
                ["1", "2"]
                    .into_iter()
                    .find(|v| {
                        let probe = ClapCommand::new("p").arg(
                            a.clone()
                                .required(false)
                                .requires(Resettable::Reset)
                                .conflicts_with(Resettable::Reset)
                                .global(false),
                        );
                        probe
                            .try_get_matches_from(["p".to_string(), spelled(a, v)])
                            .is_ok()
                    })
                    .expect("a small value in range")
                    .to_string()
            } else if let Some(v) = a.get_possible_values().first() {
                v.get_name().to_string()
            } else {
                "x".to_string()
            };
            if a.is_positional() {
                out.push(value);
            } else {
                opts.push(spelled(a, &value));
            }
        }
        out.extend(opts);
    }
    let root = relax(Cli::command());
    let mut n = 0;
    for sub in root.get_subcommands() {
        let leaves: Vec<&ClapCommand> = if sub.get_subcommands().next().is_some() {
            sub.get_subcommands().collect()
        } else {
            vec![sub]
        };
        for leaf in leaves {
            let mut args = vec!["daystep".to_string()];
            line(&root, &mut args);
            args.push(sub.get_name().into());
            if leaf.get_name() != sub.get_name() {
                line(sub, &mut args);
                args.push(leaf.get_name().into());
            }
            line(leaf, &mut args);
            let m = root
                .clone()
                .try_get_matches_from(&args)
                .unwrap_or_else(|e| panic!("{args:?}: {e}"));
            // A parser yielding another type than the field panics here.
            Cli::from_arg_matches(&m).unwrap_or_else(|e| panic!("{args:?}: {e}"));
            n += 1;
        }
    }
    assert!(n >= 10, "{n} command lines");
}

#[test]
fn ranges_say_what_they_take() {
    assert_eq!(IRRADIANCE.describe(), "a finite number in [0, 2000] W/m²");
    assert_eq!(DEW_POINT.describe(), "a finite number in (-70, 70) °C");
    assert_eq!(FRACTION.describe(), "a finite number in (0, 1]");
    assert_eq!(LUX.describe(), "a finite number ≥ 0 lux");
    assert!(FRACTION.contains(1.0) && !FRACTION.contains(0.0));
    assert!(!DEW_POINT.contains(70.0) && DEW_POINT.contains(-69.9));
    let p = real(IRRADIANCE);
    assert_eq!(p(" 800 "), Ok(800.0));
    assert!(p("2000.5").is_err() && p("-0.1").is_err() && p("8e2x").is_err());
    let w = whole(1u32, 15, "");
    assert_eq!(w("15"), Ok(15));
    assert!(w("16").is_err() && w("0").is_err());
}

#[test]
fn exposure_reads_multipliers_and_pfilt_stops() {
    assert_eq!(exposure("auto"), Ok(Exposure::Auto));
    assert_eq!(exposure("2"), Ok(Exposure::Given(2.0)));
    assert_eq!(exposure("0.25"), Ok(Exposure::Given(0.25)));
    // pfilt -e: a sign makes it stops, powers of two.
    assert_eq!(exposure("+2"), Ok(Exposure::Given(4.0)));
    assert_eq!(exposure("-1"), Ok(Exposure::Given(0.5)));
    assert_eq!(exposure("-0"), Ok(Exposure::Given(1.0)));
    for bad in [
        "0", "1e-21", "1e21", "+67", "-67", "NaN", "inf", "+inf", "x", "",
    ] {
        assert!(exposure(bad).is_err(), "{bad}");
    }
}
