//! The fuzz targets' corpora, replayed as ordinary tests (so CI runs them
//! without a fuzzer): every file of `fuzz/corpus/TARGET/`, and the seeds a
//! campaign starts from (the examples, the scenes, the appendices'
//! `!!RC1.0` programs), through the property that `cargo fuzz run TARGET`
//! checks (`fuzz/src/lib.rs`, included here as it is).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

#[path = "../fuzz/src/lib.rs"]
#[allow(dead_code)]
mod checks;

fn files(dir: &str, ext: Option<&str>) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let Ok(entries) = std::fs::read_dir(&dir) else { return Vec::new() };
    let mut out: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && ext.is_none_or(|x| p.extension().is_some_and(|e| e == x)))
        .collect();
    out.sort();
    out
}

/// Runs `check` on every file of the target's corpus and of `seeds`,
/// naming the file that fails; returns how many ran.
fn replay(target: &str, seeds: &[(&str, Option<&str>)], check: fn(&[u8])) -> usize {
    let mut all = files(&format!("fuzz/corpus/{target}"), None);
    for (dir, ext) in seeds {
        all.extend(files(dir, *ext));
    }
    let mut failed = Vec::new();
    for path in &all {
        let data = std::fs::read(path).unwrap();
        if let Err(panic) = catch_unwind(AssertUnwindSafe(|| check(&data))) {
            let why = panic
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()));
            failed.push(format!("{}: {}", path.display(), why.unwrap_or_default()));
        }
    }
    assert!(
        failed.is_empty(),
        "{target}: {} of {} inputs fail:\n{}",
        failed.len(),
        all.len(),
        failed.join("\n")
    );
    all.len()
}

const EXAMPLES: (&str, Option<&str>) = ("examples", Some("shd"));

#[test]
fn parser_corpus() {
    assert!(replay("parser", &[EXAMPLES], checks::parser) > 20);
}

#[test]
fn rc1_corpus() {
    assert!(replay("rc1", &[("tests/data/combiners", Some("rc"))], checks::rc1) > 2);
}

#[test]
fn ts1_corpus() {
    assert!(replay("ts1", &[], checks::ts1) > 2);
}

#[test]
fn vp1_corpus() {
    assert!(replay("vp1", &[], checks::vp1) > 8);
}

#[test]
fn scene_corpus() {
    assert!(replay("scene", &[("scenes", Some("ron"))], checks::scene) > 4);
}

#[test]
fn pipeline_corpus() {
    assert!(replay("pipeline", &[EXAMPLES], checks::pipeline) > 20);
}

#[test]
fn lsp_corpus() {
    assert!(replay("lsp", &[EXAMPLES], checks::lsp) > 20);
}
