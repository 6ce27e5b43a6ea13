//! The dependency rules of ARCHITECTURE.md, checked (issue 17): data flows
//! one way — parser → ir → plan contract → planner → backends → executors,
//! with the CLI on top — so a module may use only modules of a lower layer.
//! The test reads every `crate::…` path in `src/` (comments and unit-test
//! modules aside) and fails on an import of the same or a higher layer.

use std::collections::BTreeSet;
use std::path::Path;

/// The layers, bottom first: a module may use modules of lower layers only.
const LAYERS: &[&[&str]] = &[
    &["span", "numerics"],
    &["diag", "io", "textures"],
    &["parser"],
    &["ir"],
    &["profile", "scene"],
    // The independent reference sits beside the plan contract's inputs: it
    // may read the IR and the scene, never the executors it checks.
    &["oracle"],
    &["pipeline"],
    &["cost"],
    &["lowering"],
    &["planner"],
    &["backends"],
    &["driver"],
    &["renderer"],
    &["gpu"],
    &["meaning"],
    &["accuracy"],
    // The one verdict of `check --target`, `compile` and `render`: it plans
    // (driver) and measures (accuracy).
    &["verdict"],
    &["bench"],
    &["lsp"],
];

/// Upward imports not yet removed, each with why it is still there. The
/// test fails when one disappears too, so the list only shrinks.
const KNOWN: &[(&str, &str, &str)] = &[];

fn layer(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

/// The code of a file without comments and without its `mod tests`.
fn code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]\nmod tests") {
        Some(i) => &text[..i],
        None => text,
    };
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Every (from, to) module edge of `src/` but the crate root and the CLI.
fn edges() -> BTreeSet<(String, String, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut edges = BTreeSet::new();
    for path in files {
        let rel = path.strip_prefix(&src).unwrap().to_string_lossy().replace('\\', "/");
        let from = rel.split('/').next().unwrap().trim_end_matches(".rs").to_string();
        if matches!(from.as_str(), "lib" | "main" | "cli") {
            continue;
        }
        let text = code(&std::fs::read_to_string(&path).unwrap());
        for (i, _) in text.match_indices("crate::") {
            let to: String = text[i + 7..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            if to != from {
                edges.insert((from.clone(), to, rel.clone()));
            }
        }
    }
    edges
}

#[test]
fn every_module_has_a_layer() {
    for (from, to, file) in edges() {
        assert!(layer(&from).is_some(), "module `{from}` ({file}) has no layer in LAYERS");
        assert!(layer(&to).is_some(), "`{file}` uses `crate::{to}`, which has no layer in LAYERS");
    }
}

#[test]
fn no_module_uses_its_own_layer_or_a_higher_one() {
    let mut broken = Vec::new();
    let mut known_seen = BTreeSet::new();
    for (from, to, file) in edges() {
        let (Some(a), Some(b)) = (layer(&from), layer(&to)) else { continue };
        if b < a {
            continue;
        }
        if KNOWN.iter().any(|(f, t, _)| *f == from && *t == to) {
            known_seen.insert((from.clone(), to.clone()));
            continue;
        }
        broken.push(format!("{file}: `{from}` uses `crate::{to}`, which is not below it"));
    }
    assert!(
        broken.is_empty(),
        "dependency rules broken (ARCHITECTURE.md, Invariants):\n{}",
        broken.join("\n")
    );
    for (from, to, why) in KNOWN {
        assert!(
            known_seen.contains(&(from.to_string(), to.to_string())),
            "`{from}` no longer uses `{to}`: remove it from KNOWN ({why})"
        );
    }
}

#[test]
fn the_checker_sees_an_upward_import() {
    // The reading itself: a path in code counts, one in a comment or a
    // unit-test module does not.
    let text = "use crate::ir::Module; // crate::gpu\nfn f() { crate::renderer::x(); }\n#[cfg(test)]\nmod tests { use crate::bench; }\n";
    let code = code(text);
    assert!(code.contains("crate::renderer") && code.contains("crate::ir"));
    assert!(!code.contains("crate::gpu") && !code.contains("crate::bench"));
}
