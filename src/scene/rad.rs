//! Radiance scene files (`.rad`, `.mat`) as a geometry source (docs/models.md, "Radiance
//! scene files").
//!
//! Files are read in the order given, as `oconv` takes them: a modifier must be defined
//! before it is used, and one defined in an earlier file is visible in later ones.
//! Surfaces: `polygon`. Materials: `plastic`, `metal`, `glass`, `light`, `glow` and `trans`
//! without transmission, converted exactly as the HBJSON reader converts honeybee's
//! modifiers of the same type (one conversion for both readers). Also `void`, `alias`,
//! `!xform` (transforms, arrays, `-n`, `-m`, `-I`) and `!cat file`. A `source` is skipped
//! with a warning (daystep makes its own sun and sky). Everything else is an error naming
//! file, line and word: daystep runs no shell command and does not guess what an
//! unsupported primitive means.

use super::hbjson_modifiers::convert;
use super::hbjson_schema::{AnyJ, EmitterJ, GlassJ, ModifierJ, ReflectorJ, TransJ};
use super::polygon::{triangulate, PolygonIssue};
use super::rad_lexer::{lex, Item};
use super::rad_xform;
use super::{Material, Triangle};
use crate::error::{Error, Result};
use crate::files;
use glam::{DAffine3, DVec3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Deepest nesting of `!xform`/`!cat` inclusions.
pub const MAX_DEPTH: usize = 16;
/// Most file inclusions one scene may make in all (arrays of inclusions multiply).
pub const MAX_INCLUSIONS: usize = 1_000_000;
/// Most primitives one scene may give in all, counting each copy of an array.
pub const MAX_PRIMITIVES: usize = 20_000_000;
/// Planarity tolerance handed to the triangulator, m.
const PLANARITY_M: f64 = 1e-3;

/// What [`load`] reads: the same four parts as [`super::obj::ObjContents`].
#[derive(Clone, Debug, Default)]
pub struct RadContents {
    /// Triangles in the model frame (metres, Z up), counter-clockwise about the polygon's
    /// right-hand (Radiance front) normal; `material` indexes `materials`, `group` `groups`.
    pub triangles: Vec<Triangle>,
    /// Materials in order of first use by a surface (glass: [`Material::is_glazing`]).
    pub materials: Vec<Material>,
    /// One group per polygon identifier (`-n` names prefixed), in order of first use.
    pub groups: Vec<String>,
    /// Approximations made and primitives left out, each once, naming file and line.
    pub warnings: Vec<String>,
}

/// True for the extensions read as Radiance scene files: `.rad` and `.mat`.
pub fn is_rad(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("rad") || e.eq_ignore_ascii_case("mat"))
}

/// Loads Radiance scene files in order, as one scene.
///
/// # Errors
/// [`Error::Input`] naming file, line and word: an unterminated string, a wrong argument
/// count, a number that is not finite, an unsupported primitive type or command, a
/// modifier used before its definition, a material daystep cannot model, a recursive or too
/// deep inclusion, a scene beyond [`MAX_INCLUSIONS`] or [`MAX_PRIMITIVES`]. [`Error::Io`]
/// when a file cannot be read.
pub fn load(paths: &[PathBuf]) -> Result<RadContents> {
    let mut r = Reader::default();
    for p in paths {
        r.file(p, &Context::default(), None)?;
    }
    Ok(r.finish())
}

/// Reads Radiance scene text already in memory; `path` names it in errors and anchors
/// the files its `!xform` and `!cat` lines include. Errors as [`load`].
pub fn parse(path: &Path, text: &str) -> Result<RadContents> {
    let mut r = Reader::default();
    let items = Rc::new(lex(path, text)?);
    r.items(path, &items, &Context::default())?;
    Ok(r.finish())
}

/// A modifier known by name.
#[derive(Clone, Debug)]
enum Modifier {
    /// Index into `Reader::defs`.
    Material(usize),
    /// `void` (or an alias of it): surfaces using it are left out.
    Void,
}

/// Transform, renaming and modifier override in force while reading one file.
#[derive(Clone)]
struct Context {
    xf: DAffine3,
    invert: bool,
    /// `-n` names, each followed by a period.
    prefix: String,
    modifier: Option<String>,
}

impl Default for Context {
    fn default() -> Self {
        Context {
            xf: DAffine3::IDENTITY,
            invert: false,
            prefix: String::new(),
            modifier: None,
        }
    }
}

#[derive(Default)]
struct Reader {
    /// Every material defined, aliases included.
    defs: Vec<Material>,
    mods: HashMap<String, Modifier>,
    /// `defs` index → `out.materials` index, for materials in use.
    used: HashMap<usize, u32>,
    group_index: HashMap<String, u32>,
    out: RadContents,
    /// The files being read, outermost first (canonical paths).
    chain: Vec<PathBuf>,
    /// Files already lexed, so arrays of inclusions read each once.
    lexed: HashMap<PathBuf, Rc<Vec<Item>>>,
    inclusions: usize,
    primitives: usize,
}

/// One primitive as written: `modifier type identifier` and its three argument lists.
struct Primitive<'a> {
    line: usize,
    modifier: &'a str,
    kind: &'a str,
    id: &'a str,
    strings: Vec<&'a str>,
    ints: Vec<&'a str>,
    reals: Vec<f64>,
}

impl Reader {
    fn finish(mut self) -> RadContents {
        let mut seen = std::collections::HashSet::new();
        self.out.warnings.retain(|w| seen.insert(w.clone()));
        self.out
    }

    /// Reads one file; `from` is the including file and line (for errors).
    fn file(&mut self, path: &Path, ctx: &Context, from: Option<(&Path, usize)>) -> Result<()> {
        let (at, at_line) = from.unwrap_or((path, 0));
        let at_line = Some(at_line).filter(|&l| l > 0);
        let shown = path.display().to_string();
        if from.is_some() && !path.is_file() {
            return Err(Error::input(
                at,
                at_line,
                Some(&shown),
                "included file not found",
            ));
        }
        let key = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        let recursive = self.chain.contains(&key);
        if recursive || self.chain.len() >= MAX_DEPTH {
            let chain: Vec<String> = self
                .chain
                .iter()
                .chain(std::iter::once(&key))
                .map(|c| c.display().to_string())
                .collect();
            let why = if recursive {
                "recursive inclusion: a file includes itself".to_string()
            } else {
                format!("inclusions nested deeper than {MAX_DEPTH}")
            };
            return Err(Error::input(
                at,
                at_line,
                Some(&shown),
                format!("{why} ({})", chain.join(" → ")),
            ));
        }
        self.inclusions += 1;
        if self.inclusions > MAX_INCLUSIONS {
            return Err(Error::input(
                at,
                at_line,
                Some(&shown),
                format!("the scene includes files more than {MAX_INCLUSIONS} times"),
            ));
        }
        let items = match self.lexed.get(&key) {
            Some(items) => Rc::clone(items),
            None => {
                let items = Rc::new(lex(path, &files::read_text(path)?)?);
                self.lexed.insert(key.clone(), Rc::clone(&items));
                items
            }
        };
        self.chain.push(key);
        let r = self.items(path, &items, ctx);
        self.chain.pop();
        r
    }

    fn items(&mut self, path: &Path, items: &[Item], ctx: &Context) -> Result<()> {
        let mut i = 0;
        while i < items.len() {
            let line = match &items[i] {
                Item::Command(words, line) => {
                    self.command(path, *line, words, ctx)?;
                    i += 1;
                    continue;
                }
                Item::Word(_, line) => *line,
            };
            self.primitives += 1;
            if self.primitives > MAX_PRIMITIVES {
                return Err(Error::input(
                    path,
                    Some(line),
                    None,
                    format!("the scene has more than {MAX_PRIMITIVES} primitives"),
                ));
            }
            let word = |k: usize| -> Result<&str> {
                match items.get(i + k) {
                    Some(Item::Word(w, _)) => Ok(w.as_str()),
                    _ => Err(Error::input(
                        path,
                        Some(line),
                        None,
                        "incomplete primitive: expected `modifier type identifier` and its \
                         three argument counts and lists",
                    )),
                }
            };
            let (modifier, kind, id) = (word(0)?, word(1)?, word(2)?);
            if kind == "alias" {
                self.alias(path, line, modifier, id, word(3)?, ctx)?;
                i += 4;
                continue;
            }
            let mut k = 3;
            let mut lists: Vec<Vec<&str>> = Vec::with_capacity(3);
            for what in ["string", "integer", "real"] {
                let n_word = word(k)?;
                let n = n_word
                    .parse::<usize>()
                    .ok()
                    .filter(|&n| n <= items.len() - (i + k + 1))
                    .ok_or_else(|| {
                        Error::input(
                            path,
                            Some(line),
                            Some(n_word),
                            format!(
                                "{kind} {id}: expected the number of {what} arguments (a whole \
                                 number no larger than what the file still holds)"
                            ),
                        )
                    })?;
                let list = (0..n)
                    .map(|j| word(k + 1 + j))
                    .collect::<Result<Vec<_>>>()?;
                k += 1 + n;
                lists.push(list);
            }
            let reals = parse_reals(path, line, kind, id, &lists.pop().unwrap_or_default())?;
            let ints = lists.pop().unwrap_or_default();
            let strings = lists.pop().unwrap_or_default();
            let p = Primitive {
                line,
                modifier,
                kind,
                id,
                strings,
                ints,
                reals,
            };
            self.primitive(path, &p, ctx)?;
            i += k;
        }
        Ok(())
    }

    fn command(&mut self, path: &Path, line: usize, words: &[String], ctx: &Context) -> Result<()> {
        let dir = path.parent().unwrap_or(Path::new(""));
        let cmd = words.first().map(String::as_str).unwrap_or("");
        let plain = |w: &String| !w.is_empty() && !w.contains(['|', '<', '>', ';', '&', '`', '$']);
        match cmd {
            "xform" if words.iter().all(plain) => {
                let x = rad_xform::parse(path, line, &words[1..])?;
                let prefix = match &x.name {
                    Some(n) => format!("{}{n}.", ctx.prefix),
                    None => ctx.prefix.clone(),
                };
                for f in &x.files {
                    for c in &x.copies {
                        let inner = Context {
                            xf: ctx.xf * *c,
                            invert: ctx.invert ^ x.invert,
                            prefix: prefix.clone(),
                            modifier: x.modifier.clone().or_else(|| ctx.modifier.clone()),
                        };
                        self.file(&dir.join(f), &inner, Some((path, line)))?;
                    }
                }
                Ok(())
            }
            "cat"
                if words.len() > 1
                    && words[1..].iter().all(|w| plain(w) && !w.starts_with('-')) =>
            {
                for f in &words[1..] {
                    self.file(&dir.join(f), ctx, Some((path, line)))?;
                }
                Ok(())
            }
            _ => {
                let hint = if cmd.starts_with("gensky") || cmd.starts_with("gendaylit") {
                    "daystep makes its own sky: remove the line"
                } else {
                    "run the command yourself and list its output file in `geometry`"
                };
                Err(Error::input(
                    path,
                    Some(line),
                    Some(&format!("!{}", words.join(" "))),
                    format!(
                        "command not run: daystep runs no shell command, it only reads \
                         `!xform` (with files, no pipes) and `!cat file` as inclusions; {hint}"
                    ),
                ))
            }
        }
    }

    fn alias(
        &mut self,
        path: &Path,
        line: usize,
        m: &str,
        id: &str,
        old: &str,
        ctx: &Context,
    ) -> Result<()> {
        if !matches!(m, "void" | "inherit") {
            return Err(Error::input(
                path,
                Some(line),
                Some(&format!("{m} alias {id} {old}")),
                format!(
                    "alias {id} is given modifier `{m}` (a pattern, texture or mixture), which \
                     daystep cannot model; use `void alias {id} {old}`"
                ),
            ));
        }
        let target = self.lookup(path, line, old, ctx)?;
        let name = format!("{}{id}", ctx.prefix);
        let target = match target {
            Modifier::Material(k) => {
                let mut copy = self.defs[k].clone();
                copy.name = name.clone();
                self.defs.push(copy);
                Modifier::Material(self.defs.len() - 1)
            }
            Modifier::Void => Modifier::Void,
        };
        self.mods.insert(name, target);
        Ok(())
    }

    fn lookup(&self, path: &Path, line: usize, name: &str, ctx: &Context) -> Result<Modifier> {
        if name == "void" {
            return Ok(Modifier::Void);
        }
        let name = match (name, &ctx.modifier) {
            ("inherit", Some(m)) => m.as_str(),
            ("inherit", None) => {
                return Err(Error::input(
                    path,
                    Some(line),
                    Some(name),
                    "modifier `inherit` outside an `!xform -m` that gives one",
                ))
            }
            _ => name,
        };
        if name == "void" {
            return Ok(Modifier::Void);
        }
        self.mods.get(name).cloned().ok_or_else(|| {
            Error::input(
                path,
                Some(line),
                Some(name),
                "modifier used before it is defined (list the .mat files first in `geometry`, \
                 in oconv's order)",
            )
        })
    }

    fn primitive(&mut self, path: &Path, p: &Primitive, ctx: &Context) -> Result<()> {
        let (line, t, id) = (p.line, p.kind, p.id);
        let bad = |msg: String| {
            Error::input(
                path,
                Some(line),
                Some(&format!("{} {t} {id}", p.modifier)),
                msg,
            )
        };
        if t == "polygon" {
            return self.polygon(path, p, ctx);
        }
        if t == "source" {
            self.out.warnings.push(format!(
                "{}:{line}: source {id} left out: daystep makes its own sun and sky",
                path.display()
            ));
            return Ok(());
        }
        let r = |k: usize| p.reals.get(k).copied().unwrap_or(0.0);
        let modifier = (p.modifier != "void").then(|| serde_json::Value::from(p.modifier));
        let reflector = || ReflectorJ {
            r_reflectance: r(0),
            g_reflectance: r(1),
            b_reflectance: r(2),
            specularity: r(3),
            modifier: modifier.clone(),
        };
        let emitter = || EmitterJ {
            r_emittance: r(0),
            g_emittance: r(1),
            b_emittance: r(2),
            max_radius: r(3),
            modifier: modifier.clone(),
        };
        let (reals, parsed): (&[usize], ModifierJ) = match t {
            "plastic" => (&[5], ModifierJ::Plastic(reflector())),
            "metal" => (&[5], ModifierJ::Metal(reflector())),
            "trans" => (
                &[7],
                ModifierJ::Trans(TransJ {
                    r_reflectance: r(0),
                    g_reflectance: r(1),
                    b_reflectance: r(2),
                    specularity: r(3),
                    // Radiance's trans: A6 of what is not reflected is transmitted.
                    transmitted_diff: r(5),
                    modifier: modifier.clone(),
                }),
            ),
            "mirror" => (&[3], ModifierJ::Mirror(AnyJ {})),
            "glass" => (
                &[3, 4],
                ModifierJ::Glass(GlassJ {
                    r_transmissivity: r(0),
                    g_transmissivity: r(1),
                    b_transmissivity: r(2),
                    refraction_index: p.reals.get(3).copied(),
                    modifier: modifier.clone(),
                }),
            ),
            "light" => (&[3], ModifierJ::Light(emitter())),
            "glow" => (&[4], ModifierJ::Glow(emitter())),
            _ => {
                return Err(bad(format!(
                    "primitive type `{t}` is not read by daystep (surfaces: polygon; \
                     materials: plastic, metal, glass, light, glow, trans without transmission; \
                     also alias, and source, which is left out); convert the object to \
                     polygons or the material to one of these"
                )))
            }
        };
        if !p.strings.is_empty() || !p.ints.is_empty() || !reals.contains(&p.reals.len()) {
            let want: Vec<String> = reals.iter().map(|n| n.to_string()).collect();
            return Err(bad(format!(
                "`{t}` takes 0 strings, 0 integers and {} reals; found {}, {} and {}",
                want.join(" or "),
                p.strings.len(),
                p.ints.len(),
                p.reals.len()
            )));
        }
        let name = format!("{}{id}", ctx.prefix);
        let (material, warning) =
            convert(&name, parsed).map_err(|msg| bad(format!("{t} {id} {msg}")))?;
        if let Some(w) = warning {
            self.out
                .warnings
                .push(format!("{}:{line}: modifier `{name}` {w}", path.display()));
        }
        self.defs.push(material);
        self.mods
            .insert(name, Modifier::Material(self.defs.len() - 1));
        Ok(())
    }

    fn polygon(&mut self, path: &Path, p: &Primitive, ctx: &Context) -> Result<()> {
        let (line, id) = (p.line, p.id);
        if !p.strings.is_empty()
            || !p.ints.is_empty()
            || p.reals.len() < 9
            || p.reals.len() % 3 != 0
        {
            return Err(Error::input(
                path,
                Some(line),
                Some(&format!("{} polygon {id}", p.modifier)),
                format!(
                    "polygon takes 0 strings, 0 integers and 3n reals (n ≥ 3 vertices); found \
                     {}, {} and {}",
                    p.strings.len(),
                    p.ints.len(),
                    p.reals.len()
                ),
            ));
        }
        let m = ctx.modifier.as_deref().unwrap_or(p.modifier);
        let k = match self.lookup(path, line, m, ctx)? {
            Modifier::Void => {
                self.out.warnings.push(format!(
                    "{}:{line}: polygon {id} has modifier void (it would be invisible in \
                     Radiance) and is left out",
                    path.display()
                ));
                return Ok(());
            }
            Modifier::Material(k) => k,
        };
        // A transform that mirrors turns the vertex order; xform reverses it back so the
        // surface keeps facing the same side of the geometry, and -I reverses it again.
        let mirror = ctx.xf.matrix3.determinant() < 0.0;
        let mut pts: Vec<DVec3> = p
            .reals
            .chunks_exact(3)
            .map(|c| ctx.xf.transform_point3(DVec3::new(c[0], c[1], c[2])))
            .collect();
        if mirror ^ ctx.invert {
            pts.reverse();
        }
        let tri = triangulate(&pts, &[], PLANARITY_M);
        for issue in &tri.issues {
            let what = match issue {
                PolygonIssue::ZeroArea => "has zero area and is left out".to_string(),
                PolygonIssue::NonPlanar { deviation_m } => {
                    format!("is not planar ({deviation_m:.4} m off its plane), triangulated as is")
                }
                PolygonIssue::SelfIntersecting => {
                    "intersects itself; its triangles may not cover it as meant".to_string()
                }
            };
            self.out
                .warnings
                .push(format!("{}:{line}: polygon {id} {what}", path.display()));
        }
        if tri.triangles.is_empty() {
            return Ok(());
        }
        let next = self.out.materials.len() as u32;
        let material = *self.used.entry(k).or_insert(next);
        if material == next {
            self.out.materials.push(self.defs[k].clone());
        }
        let gname = format!("{}{id}", ctx.prefix);
        let ng = self.out.groups.len() as u32;
        let group = *self.group_index.entry(gname.clone()).or_insert(ng);
        if group == ng {
            self.out.groups.push(gname);
        }
        self.out
            .triangles
            .extend(
                tri.triangles
                    .into_iter()
                    .map(|v| Triangle { v, material, group }),
            );
        Ok(())
    }
}

/// The real arguments as finite numbers.
fn parse_reals(path: &Path, line: usize, t: &str, id: &str, words: &[&str]) -> Result<Vec<f64>> {
    words
        .iter()
        .map(|w| {
            w.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    Error::input(
                        path,
                        Some(line),
                        Some(w),
                        format!("{t} {id}: real arguments must be finite numbers"),
                    )
                })
        })
        .collect()
}

#[cfg(test)]
#[path = "rad_tests.rs"]
mod tests;
