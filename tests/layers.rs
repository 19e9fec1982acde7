//! The layer rule (lib.rs): a module uses only lower layers, never a higher one, and
//! siblings in one layer only where the table allows. Uses are found as `crate::a` paths,
//! `crate::{a::…, b::…}` groups (every module in the group) and `super::` paths that climb
//! out of their top-level module (resolved against the file's and its inline modules'
//! path), in code and in comments alike.

use std::collections::HashMap;
use std::path::Path;

/// The top-level modules of `src/` by layer, lowest first (lib.rs's table). A new module
/// goes into its layer's list.
const LAYERS: &[&[&str]] = &[
    &[
        "error",
        "files",
        "math",
        "photometry",
        "memory",
        "allocator",
    ],
    &["site", "scene", "weather"],
    &["sky", "sources"],
    &["hierarchy"],
    &["projection"],
    &["transfer", "cache", "trace"],
    &["sensors", "radiosity"],
    &["metrics", "export", "render"],
    &["sequence"],
    &["cli"],
];

/// Same-layer uses the table allows: (user, used).
const SIBLINGS: &[(&str, &str)] = &[
    ("files", "error"),
    ("math", "error"),
    ("photometry", "error"),
    ("memory", "error"),
    ("scene", "site"),
    ("weather", "site"),
    ("export", "metrics"),
    ("sources", "sky"),
    ("sensors", "radiosity"),
];

fn layer_of(module: &str) -> Option<u32> {
    LAYERS
        .iter()
        .position(|l| l.contains(&module))
        .map(|l| l as u32)
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// `text` with comments and string and character literals blanked (same length in chars,
/// newlines kept), so that braces in them do not disturb the module structure.
fn blank_comments_and_literals(text: &str) -> Vec<char> {
    let c: Vec<char> = text.chars().collect();
    let mut out = c.clone();
    let blank = |out: &mut Vec<char>, from: usize, to: usize| {
        for ch in &mut out[from..to.min(c.len())] {
            if *ch != '\n' {
                *ch = ' ';
            }
        }
    };
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            let end = (i..c.len()).find(|&k| c[k] == '\n').unwrap_or(c.len());
            blank(&mut out, i, end);
            i = end;
        } else if c[i] == '/' && next == Some('*') {
            let (mut depth, mut k) = (1, i + 2);
            while k < c.len() && depth > 0 {
                if c[k] == '/' && c.get(k + 1) == Some(&'*') {
                    depth += 1;
                    k += 1;
                } else if c[k] == '*' && c.get(k + 1) == Some(&'/') {
                    depth -= 1;
                    k += 1;
                }
                k += 1;
            }
            blank(&mut out, i, k);
            i = k;
        } else if c[i] == 'r'
            && (i == 0 || !is_ident(c[i - 1]))
            && matches!(next, Some('"') | Some('#'))
        {
            // A raw string r"…" or r#"…"#, if that is what follows.
            let hashes = c[i + 1..].iter().take_while(|&&h| h == '#').count();
            if c.get(i + 1 + hashes) == Some(&'"') {
                let close: Vec<char> = std::iter::once('"')
                    .chain(std::iter::repeat_n('#', hashes))
                    .collect();
                let body = i + 2 + hashes;
                let end = (body..c.len())
                    .find(|&k| c[k..].starts_with(&close))
                    .map_or(c.len(), |k| k + close.len());
                blank(&mut out, i, end);
                i = end;
            } else {
                i += 1;
            }
        } else if c[i] == '"' {
            let mut k = i + 1;
            while k < c.len() && c[k] != '"' {
                k += if c[k] == '\\' { 2 } else { 1 };
            }
            blank(&mut out, i, k + 1);
            i = k + 1;
        } else if c[i] == '\'' {
            // A character literal ('x', '\n', '\u{7b}'), not a lifetime ('a).
            let end = if next == Some('\\') {
                (i + 2..c.len()).find(|&k| c[k] == '\'')
            } else if c.get(i + 2) == Some(&'\'') {
                Some(i + 2)
            } else {
                None
            };
            match end {
                Some(e) => {
                    blank(&mut out, i, e + 1);
                    i = e + 1;
                }
                None => i += 1,
            }
        } else {
            i += 1;
        }
    }
    out
}

/// Inline modules (`mod name { … }`) of blanked code: (name, index of `{`, index of `}`).
fn inline_modules(code: &[char]) -> Vec<(String, usize, usize)> {
    let mut out = Vec::new();
    let mut open: Vec<(Option<String>, usize)> = Vec::new();
    let mut i = 0;
    while i < code.len() {
        let word_start = i == 0 || !is_ident(code[i - 1]);
        if word_start && code[i..].starts_with(&['m', 'o', 'd']) {
            let mut k = i + 3;
            if k < code.len() && code[k].is_whitespace() {
                while k < code.len() && code[k].is_whitespace() {
                    k += 1;
                }
                let name: String = code[k..].iter().take_while(|&&ch| is_ident(ch)).collect();
                k += name.chars().count();
                while k < code.len() && code[k].is_whitespace() {
                    k += 1;
                }
                if !name.is_empty() && code.get(k) == Some(&'{') {
                    open.push((Some(name), k));
                    i = k + 1;
                    continue;
                }
            }
        }
        match code[i] {
            '{' => open.push((None, i)),
            '}' => {
                if let Some((Some(name), start)) = open.pop() {
                    out.push((name, start, i));
                }
            }
            _ => {}
        }
        i += 1;
    }
    out
}

/// The first path segment of every item of the `{…}` group opening at `text[at]`, with its
/// index: `{a::x, b::{y, z}, c}` gives a, b, c.
fn group_heads(text: &[char], at: usize) -> Vec<(usize, String)> {
    let mut heads = Vec::new();
    let (mut depth, mut k, mut expect_head) = (0, at, true);
    while k < text.len() {
        match text[k] {
            '{' => {
                depth += 1;
                if depth > 1 {
                    expect_head = false;
                }
            }
            '}' => {
                depth -= 1;
                if depth == 0 {
                    break;
                }
            }
            ',' if depth == 1 => expect_head = true,
            ch if expect_head && is_ident(ch) => {
                let head: String = text[k..].iter().take_while(|&&ch| is_ident(ch)).collect();
                heads.push((k, head.clone()));
                k += head.chars().count();
                expect_head = false;
                continue;
            }
            _ => {}
        }
        k += 1;
    }
    heads
}

/// The top-level modules a path starting at `text[at]` names, with their indices: one
/// identifier, or the heads of a group.
fn heads_at(text: &[char], at: usize) -> Vec<(usize, String)> {
    match text.get(at) {
        Some('{') => group_heads(text, at),
        _ => {
            let head: String = text[at..].iter().take_while(|&&ch| is_ident(ch)).collect();
            if head.is_empty() {
                vec![]
            } else {
                vec![(at, head)]
            }
        }
    }
}

/// The top-level modules the file at `rel` (its path under `src/`, e.g. `a/b/c.rs`) uses,
/// each with its 1-based line: `crate::` paths and groups, and `super::` paths that reach
/// the crate root from the file's module (or from an inline module within it).
fn uses_in(rel: &Path, text: &str) -> Vec<(usize, String)> {
    let mut module: Vec<String> = rel
        .iter()
        .map(|c| c.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if module.last().is_some_and(|m| m == "mod") {
        module.pop();
    }
    let raw: Vec<char> = text.chars().collect();
    let inline = inline_modules(&blank_comments_and_literals(text));
    let line_of = |i: usize| raw[..i].iter().filter(|&&ch| ch == '\n').count() + 1;
    let word_at = |i: usize, w: &str| {
        (i == 0 || !is_ident(raw[i - 1])) && raw[i..].starts_with(&w.chars().collect::<Vec<_>>())
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < raw.len() {
        if word_at(i, "crate::") {
            for (at, head) in heads_at(&raw, i + 7) {
                out.push((line_of(at), head));
            }
            i += 7;
        } else if word_at(i, "super::") {
            let mut path = module.clone();
            for (name, open, close) in &inline {
                if *open < i && i < *close {
                    path.push(name.clone());
                }
            }
            let mut k = i;
            let mut climbed_out = false;
            while word_at(k, "super::") {
                climbed_out |= path.pop().is_none();
                k += 7;
            }
            if path.is_empty() && !climbed_out {
                for (at, head) in heads_at(&raw, k) {
                    out.push((line_of(at), head));
                }
            }
            i = k;
        } else {
            i += 1;
        }
    }
    out
}

/// Checks `files` ((path under `src/`, text)): the violations, and how many uses were
/// checked per top-level module.
fn check(files: &[(std::path::PathBuf, String)]) -> (Vec<String>, HashMap<String, usize>) {
    let mut violations = Vec::new();
    let mut checked: HashMap<String, usize> = HashMap::new();
    for (rel, text) in files {
        let first = rel.iter().next().unwrap().to_string_lossy();
        // A top-level module's tests in `x_tests.rs` (`#[path]`) belong to module `x`.
        let module = first
            .trim_end_matches(".rs")
            .trim_end_matches("_tests")
            .to_string();
        let Some(own) = layer_of(&module) else {
            continue;
        };
        for (line, used) in uses_in(rel, text) {
            *checked.entry(module.clone()).or_default() += 1;
            let Some(l) = layer_of(&used) else { continue };
            let ok =
                used == module || l < own || SIBLINGS.contains(&(module.as_str(), used.as_str()));
            if !ok {
                let shown = text.lines().nth(line - 1).unwrap_or("").trim();
                violations.push(format!(
                    "{}:{line}: {module} (L{own}) uses {used} (L{l}): {shown}",
                    rel.display(),
                ));
            }
        }
    }
    (violations, checked)
}

fn visit(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            visit(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn lower_layers_never_use_higher_ones() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut paths = Vec::new();
    visit(&src, &mut paths);
    let files: Vec<_> = paths
        .iter()
        .map(|f| {
            let text = std::fs::read_to_string(f).unwrap();
            (f.strip_prefix(&src).unwrap().to_path_buf(), text)
        })
        .collect();
    let (violations, checked) = check(&files);
    assert!(
        checked.len() > 5,
        "the test saw too few modules: {checked:?}"
    );
    assert!(
        violations.is_empty(),
        "layer violations:\n{}",
        violations.join("\n")
    );
}

#[test]
fn the_checker_reports_each_kind_of_violation() {
    let file = |p: &str, t: &str| (std::path::PathBuf::from(p), t.to_string());
    let files = [
        // A plain path, in code and in a doc comment.
        file(
            "math/a.rs",
            "use crate::sequence::Run;\n/// See [`crate::cli::main`].\nfn f() {}\n",
        ),
        // Groups, one item per module, over lines and nested; lower layers pass.
        file(
            "scene/b.rs",
            "use crate::{\n    error::Result,\n    math::{bvh::Bvh, frame},\n    sky::Sky,\n};\n\
             use crate::{site::Site, export::{a, b}};\n",
        ),
        // super:: out of the top-level module: from a nested file, and from its mod.rs.
        file(
            "sky/x/y.rs",
            "use super::super::super::sequence::S;\nuse super::super::z::Fine;\n",
        ),
        file("sources/mod.rs", "use super::{math::M, radiosity::R};\n"),
        // Inside an inline module one more super:: is needed to climb out.
        file(
            "hierarchy/h.rs",
            "fn g() { let s = \"{\"; let c = '}'; }\n\
             #[cfg(test)]\nmod tests {\n    use super::super::Ok;\n    use super::super::super::cli::C;\n}\n",
        ),
        // Allowed: the own module, a listed sibling, a crate-root item, super:: within the
        // module.
        file(
            "weather/w.rs",
            "use crate::weather::x;\nuse crate::{site::Site, Error};\nuse super::files::F;\n",
        ),
    ];
    let (violations, _) = check(&files);
    let shown = violations.join("\n");
    let expected = [
        "math/a.rs:1: math (L0) uses sequence (L8)",
        "math/a.rs:2: math (L0) uses cli (L9)",
        "scene/b.rs:4: scene (L1) uses sky (L2)",
        "scene/b.rs:6: scene (L1) uses export (L7)",
        "sky/x/y.rs:1: sky (L2) uses sequence (L8)",
        "sources/mod.rs:1: sources (L2) uses radiosity (L6)",
        "hierarchy/h.rs:5: hierarchy (L3) uses cli (L9)",
    ];
    for e in expected {
        assert!(shown.contains(e), "missing {e:?} in:\n{shown}");
    }
    assert_eq!(violations.len(), expected.len(), "{shown}");
}
