//! The layer rule (lib.rs): a module uses only lower layers, never a higher one, and
//! siblings in one layer only where the table allows.

use std::collections::HashMap;
use std::path::Path;

fn layer_of(module: &str) -> Option<u32> {
    Some(match module {
        "error" | "files" | "math" | "photometry" => 0,
        "site" | "scene" | "weather" => 1,
        "sky" | "sources" => 2,
        "hierarchy" => 3,
        "projection" => 4,
        "transfer" | "cache" | "trace" => 5,
        "sensors" | "radiosity" => 6,
        "metrics" | "export" | "render" => 7,
        "sequence" => 8,
        "cli" => 9,
        _ => return None,
    })
}

/// Same-layer uses the table allows: (user, used).
const SIBLINGS: &[(&str, &str)] = &[
    ("files", "error"),
    ("math", "error"),
    ("photometry", "error"),
    ("scene", "site"),
    ("weather", "site"),
    ("export", "metrics"),
    ("sources", "sky"),
    ("sensors", "radiosity"),
];

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
    let mut files = Vec::new();
    visit(&src, &mut files);
    let mut violations = Vec::new();
    let mut checked: HashMap<String, usize> = HashMap::new();
    for f in files {
        let rel = f.strip_prefix(&src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let module = first.trim_end_matches(".rs").to_string();
        let Some(own) = layer_of(&module) else {
            continue;
        };
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line) in text.lines().enumerate() {
            let mut rest = line;
            while let Some(i) = rest.find("crate::") {
                rest = &rest[i + 7..];
                let used: String = rest
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                *checked.entry(module.clone()).or_default() += 1;
                let Some(l) = layer_of(&used) else { continue };
                let ok = used == module
                    || l < own
                    || SIBLINGS.contains(&(module.as_str(), used.as_str()));
                if !ok {
                    violations.push(format!(
                        "{}:{}: {module} (L{own}) uses {used} (L{l}): {}",
                        rel.display(),
                        n + 1,
                        line.trim()
                    ));
                }
            }
        }
    }
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
