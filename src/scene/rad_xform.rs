//! The arguments of an `!xform` command line: transforms, arrays, `-n`, `-m`, `-I` and the
//! files it reads (semantics of Radiance's xform(1) man page: `[xf0] [-a n1 xf1 ..] [-i 1
//! xff] file ..`; transforms apply in the order written; after `-a n` the following
//! transforms make n copies, copy k having them applied k times, k = 0 … n − 1; several
//! `-a` nest).

use crate::error::{Error, Result};
use glam::{DAffine3, DVec3};
use std::path::Path;

/// Most copies one `!xform` may make (arrays multiply).
pub(crate) const MAX_COPIES: usize = 100_000;

/// What an `!xform` line asks for.
#[derive(Clone, Debug)]
pub(crate) struct Xform {
    /// One transform per copy (model frame, point → point).
    pub copies: Vec<DAffine3>,
    /// `-n name`: identifiers become `name.identifier`.
    pub name: Option<String>,
    /// `-m mod`: modifier replacing every surface's own.
    pub modifier: Option<String>,
    /// `-I`: surfaces inverted.
    pub invert: bool,
    /// The files to read (relative to the including file), in order.
    pub files: Vec<String>,
}

/// Parses the words after `!xform` (`args` excludes the command name); `path` and `line`
/// name the including file in errors.
///
/// # Errors
/// [`Error::Input`] for an unknown or incomplete option, a non-finite number, an array count
/// below 1, more than [`MAX_COPIES`] copies, or no file (xform would read standard input).
pub(crate) fn parse(path: &Path, line: usize, args: &[String]) -> Result<Xform> {
    let err = |v: &str, m: &str| Error::input(path, Some(line), Some(v), format!("!xform: {m}"));
    // The transforms before any -a or -i apply once to the one copy.
    let mut stages: Vec<Stage> = vec![Stage {
        n: 1,
        iterate: true,
        t: DAffine3::IDENTITY,
    }];
    let mut out = Xform {
        copies: Vec::new(),
        name: None,
        modifier: None,
        invert: false,
        files: Vec::new(),
    };
    let mut i = 0;
    let num = |i: usize| -> Result<f64> {
        let w = args
            .get(i)
            .ok_or_else(|| err(&args[..i].join(" "), "option needs more numbers"))?;
        w.parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| err(w, "expected a finite number"))
    };
    while i < args.len() {
        let a = args[i].as_str();
        let mut apply = |t: DAffine3| {
            if let Some(last) = stages.last_mut() {
                last.t = t * last.t;
            }
        };
        match a {
            "-t" => {
                apply(DAffine3::from_translation(DVec3::new(
                    num(i + 1)?,
                    num(i + 2)?,
                    num(i + 3)?,
                )));
                i += 4;
            }
            "-rx" => {
                apply(DAffine3::from_rotation_x(num(i + 1)?.to_radians()));
                i += 2;
            }
            "-ry" => {
                apply(DAffine3::from_rotation_y(num(i + 1)?.to_radians()));
                i += 2;
            }
            "-rz" => {
                apply(DAffine3::from_rotation_z(num(i + 1)?.to_radians()));
                i += 2;
            }
            "-s" => {
                let s = num(i + 1)?;
                if s == 0.0 {
                    return Err(err(&args[i + 1], "scale must not be zero"));
                }
                apply(DAffine3::from_scale(DVec3::splat(s)));
                i += 2;
            }
            "-mx" => {
                apply(DAffine3::from_scale(DVec3::new(-1.0, 1.0, 1.0)));
                i += 1;
            }
            "-my" => {
                apply(DAffine3::from_scale(DVec3::new(1.0, -1.0, 1.0)));
                i += 1;
            }
            "-mz" => {
                apply(DAffine3::from_scale(DVec3::new(1.0, 1.0, -1.0)));
                i += 1;
            }
            "-a" | "-i" => {
                let n = num(i + 1)?;
                if !(1.0..=MAX_COPIES as f64).contains(&n) || n.fract() != 0.0 {
                    return Err(err(
                        &args[i + 1],
                        &format!("the count must be a whole number in [1, {MAX_COPIES}]"),
                    ));
                }
                // `-a n`: n copies, copy k with the following transforms applied k times;
                // `-i n`: one copy, with them applied n times.
                stages.push(Stage {
                    n: n as usize,
                    iterate: a == "-i",
                    t: DAffine3::IDENTITY,
                });
                i += 2;
            }
            "-n" | "-m" => {
                let v = args
                    .get(i + 1)
                    .ok_or_else(|| err(a, "option needs a word"))?;
                if a == "-n" {
                    out.name = Some(v.clone());
                } else {
                    out.modifier = Some(v.clone());
                }
                i += 2;
            }
            "-I" => {
                out.invert = true;
                i += 1;
            }
            "-c" => i += 1,
            w if w.starts_with('-') && w.len() > 1 => {
                return Err(err(w, "option not supported by daystep"));
            }
            _ => {
                out.files.push(args[i].clone());
                i += 1;
            }
        }
    }
    if out.files.is_empty() {
        return Err(err(
            &args.join(" "),
            "no file given (xform would read standard input, which a scene file cannot give)",
        ));
    }
    let mut copies = vec![DAffine3::IDENTITY];
    for stage in &stages {
        if stage.iterate {
            let mut p = DAffine3::IDENTITY;
            for _ in 0..stage.n {
                p = stage.t * p;
            }
            copies.iter_mut().for_each(|c| *c = p * *c);
            continue;
        }
        if copies.len().saturating_mul(stage.n) > MAX_COPIES {
            return Err(err(
                &stage.n.to_string(),
                &format!("arrays make more than {MAX_COPIES} copies"),
            ));
        }
        let mut next = Vec::with_capacity(copies.len() * stage.n);
        for c in &copies {
            let mut p = *c;
            for _ in 0..stage.n {
                next.push(p);
                p = stage.t * p;
            }
        }
        copies = next;
    }
    out.copies = copies;
    Ok(out)
}

/// The transforms written before the first `-a`/`-i` (n = 1), or after one of them.
struct Stage {
    /// Count of the `-a` or `-i`.
    n: usize,
    /// `-i`: one copy, `t` applied `n` times.
    iterate: bool,
    /// The stage's transforms composed in the order written (point → point).
    t: DAffine3,
}
