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

/// The code of every file under `src/<dir>` (comments and unit tests aside).
fn code_under(dir: &str) -> Vec<(String, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    let root = src.join(dir);
    if root.is_dir() {
        rust_files(&root, &mut files);
    } else {
        files.push(root.with_extension("rs"));
    }
    files
        .into_iter()
        .map(|p| {
            let rel = p.strip_prefix(&src).unwrap().to_string_lossy().replace('\\', "/");
            (rel, code(&std::fs::read_to_string(&p).unwrap()))
        })
        .collect()
}

/// What only the driver calls (issue 35): the planner, the lowering, the
/// code generators and the setups they make, and the reading of texture
/// declarations (`ir::declared`, the cube-map images' checks). The CLI and the language
/// server sit above it and read its `Planned`.
const BELOW_THE_DRIVER: &[&str] = &[
    "planner::",
    "lowering::lower(",
    "lowering::choices(",
    "codegen::generate",
    "combiners::generate",
    "combiners::setup",
    "wgsl::generate",
    "generate_for_pass",
    "vertex_program::emit::",
    "ir::lower(",
    "ir::declared",
    "cube_image::diagnose",
    "cost::annotate",
];

#[test]
fn nothing_above_the_driver_calls_the_planner_the_lowering_or_a_code_generator() {
    let mut broken = Vec::new();
    for dir in ["cli", "lsp", "main"] {
        for (file, text) in code_under(dir) {
            for call in BELOW_THE_DRIVER {
                if text.contains(call) {
                    broken.push(format!("{file} calls `{call}`: go through `driver`"));
                }
            }
        }
    }
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}

/// The combiner code generator runs in two places only: the planner's
/// realizer (`CombinerRealizer`, which the driver hands it) and the one
/// `fixed9` model of a pass (`combiners::setup`); every setup kept is a
/// `CombinerProgram` made there, which is what the counting test
/// (`tests/contract.rs`) counts.
#[test]
fn the_combiner_generator_is_called_by_the_realizer_and_the_setup_only() {
    let mut broken = Vec::new();
    for (file, text) in code_under("") {
        let allowed =
            ["backends/combiners/codegen/mod.rs", "backends/combiners/setup.rs"].contains(&file.as_str());
        let calls = ["combiners::generate(", "generate(&input", "generate(&PassInput"];
        for call in calls.iter().chain(&["CombinerProgram::new("]) {
            if !allowed && text.contains(call) && !(file == "pipeline/setup.rs" && call.starts_with("Comb")) {
                broken.push(format!("{file} calls `{call}`: read the pass's setup (`Planned::setups`)"));
            }
        }
    }
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}

/// Whether `text` reads a `line:col` back: a `split(':')` followed by a
/// number parse, or a human line and column turned into a byte offset
/// (`LineIndex::offset(text, line, col)`, three arguments; the language
/// server's `offset(position)` takes the protocol's own position).
fn reads_line_col_back(text: &str) -> bool {
    let split = ["split_once(':')", "split(':')", "rsplit_once(':')"].iter().any(|pat| {
        text.match_indices(pat).any(|(i, _)| {
            let after: String = text[i..].chars().take(300).collect();
            after.contains("parse::<usize>") || after.contains("parse::<u32>")
        })
    });
    let offset = text.match_indices(".offset(").any(|(i, _)| {
        let (mut depth, mut commas) = (0, 0);
        for c in text[i + 8..].chars() {
            match c {
                '(' | '[' => depth += 1,
                ')' | ']' if depth == 0 => break,
                ')' | ']' => depth -= 1,
                ',' if depth == 0 => commas += 1,
                _ => {}
            }
        }
        commas == 2
    });
    split || offset
}

/// Positions travel as `Span`s (issue 35): no module turns a `line:col`
/// text back into a position; the plan's `at` is text for people, never
/// read back. `span.rs`, which defines the conversion, aside.
#[test]
fn no_module_parses_a_line_col_string() {
    let broken: Vec<String> = code_under("")
        .into_iter()
        .filter(|(file, text)| file != "span.rs" && reads_line_col_back(text))
        .map(|(file, _)| format!("{file} reads a line:col back into a position"))
        .collect();
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}

#[test]
fn the_line_col_checker_sees_a_read_back() {
    let parse = "fn span_at(at: &str) { let (l, c) = at.split_once(':')?; l.parse::<usize>() }";
    let offset = "fn f(s: &str) { index.offset(s, line, col) }";
    assert!(reads_line_col_back(parse) && reads_line_col_back(offset));
    let lsp = "fn f(d: &Document) { d.offset(pos); let (k, v) = l.split_once(':'); }";
    assert!(!reads_line_col_back(lsp));
}

/// The longest a source file may be (issue 35): past it a file holds more
/// than one concept, and is split along them (ARCHITECTURE.md, § Code map).
const MAX_FILE_LINES: usize = 1000;

/// The files of `src/` longer than [`MAX_FILE_LINES`], with their lengths.
fn files_over(dir: &Path, limit: usize) -> Vec<(String, usize)> {
    let mut files = Vec::new();
    rust_files(dir, &mut files);
    let mut over: Vec<(String, usize)> = files
        .into_iter()
        .map(|path| {
            let lines = std::fs::read_to_string(&path).unwrap().lines().count();
            (path.strip_prefix(dir).unwrap().to_string_lossy().replace('\\', "/"), lines)
        })
        .filter(|(_, lines)| *lines > limit)
        .collect();
    over.sort();
    over
}

#[test]
fn no_file_in_src_is_over_1000_lines() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let over = files_over(&src, MAX_FILE_LINES);
    assert!(
        over.is_empty(),
        "split these along their concepts (at most {MAX_FILE_LINES} lines a file): {over:?}"
    );
}

#[test]
fn the_file_length_checker_sees_a_long_file() {
    let dir = std::env::temp_dir().join(format!("shadec-layering-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("short.rs"), "fn f() {}\n".repeat(3)).unwrap();
    std::fs::write(dir.join("long.rs"), "fn f() {}\n".repeat(MAX_FILE_LINES + 1)).unwrap();
    let over = files_over(&dir, MAX_FILE_LINES);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(over, vec![("long.rs".to_string(), MAX_FILE_LINES + 1)]);
}

/// Whether `text` reads the syntax tree: it names the parser or its AST.
fn reads_the_syntax_tree(text: &str) -> bool {
    text.contains("parser::") || text.contains("ast::")
}

/// Texture declarations are read once (issue 35): the lowering types them
/// (`ir::declared`), and the scene binder builds textures from the module's
/// declarations, never from the syntax tree.
#[test]
fn the_scene_does_not_read_the_syntax_tree() {
    let broken: Vec<String> = code_under("scene")
        .into_iter()
        .filter(|(_, text)| reads_the_syntax_tree(text))
        .map(|(file, _)| {
            format!("{file} reads `parser::ast`: read the module's declarations (`ir::declared`)")
        })
        .collect();
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}

#[test]
fn the_syntax_tree_checker_sees_a_read() {
    assert!(reads_the_syntax_tree("use crate::parser::ast::{self, ExprKind};"));
    assert!(reads_the_syntax_tree("use crate::parser::{ast, check};"));
    assert!(reads_the_syntax_tree("fn f(e: &ast::Expr) {}"));
    assert!(!reads_the_syntax_tree("use crate::ir::declared::{DeclaredSource, TextureKind};"));
}
