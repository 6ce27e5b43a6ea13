//! The same input gives the same bytes (issue 40): `check`'s renderings,
//! `compile`'s plans and the language server's diagnostics of every
//! example and of generated programs — among them ties for "did you mean"
//! (`h` and `H` for `h8`), which hash order used to decide — are equal
//! across 20 runs in one process (each run's hash maps have new random
//! keys) and across runs of the binary (each process has its own).

use std::path::PathBuf;
use std::process::Command;

use shadec::diag::SourceFile;
use shadec::driver::{self, PlanOptions};
use shadec::profile::Profile;

const RUNS: usize = 20;

fn examples() -> Vec<(String, String)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "shd"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 20, "examples/ has {} programs", paths.len());
    paths
        .into_iter()
        .map(|p| {
            (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&p).unwrap())
        })
        .collect()
}

/// Programs whose diagnostics have ties and many names: misspellings with
/// two equally close candidates, differing in case or not, unused and
/// duplicate declarations, unknown names in shaders.
fn generated() -> Vec<(String, String)> {
    let mut out = vec![
        ("tie_case".to_string(), "const h = 1;\nconst H = 2;\nC δπx ← h8 * H8;\n".to_string()),
        (
            "tie_letters".to_string(),
            "const ab = 1;\nconst ba = 2;\nconst aa = 3;\nconst bb = 4;\nC δπx ← ax + bx + xa + xb;\n"
                .to_string(),
        ),
    ];
    for n in [10usize, 200, 1000] {
        let mut s = String::from("vector N : normal;\nvector L : light(0);\n");
        for i in 0..n {
            s.push_str(&format!("const c{i} = 0.5;\nconst C{i}x = 0.25;\n"));
        }
        for i in 0..n {
            // `c{i}y` is one edit from `c{i}`, `C{i}x` (ignoring case) and
            // others: the stated order decides.
            s.push_str(&format!("C δπx ← c{i}y * max(0, N·L);\n"));
        }
        s.push_str("shader p : s → c { let q = N·L; qq * undefined_thing }\n");
        s.push_str("const c0 = 1;\n");
        out.push((format!("many_{n}"), s));
    }
    out
}

/// Everything a run reports on one program, as text: the human and LSP
/// renderings of `check`, for each target; the server's analysis; the
/// plans `compile` makes, as JSON.
fn report(name: &str, text: &str) -> String {
    let file = SourceFile::new(name, text);
    let mut out = String::new();
    for target in [None, Some("geforce256"), Some("geforce3"), Some("multitexture"), Some("wgsl")] {
        match shadec::verdict::check(text, target) {
            Ok(front) => {
                out.push_str(&file.render(&front.diagnostics, false));
                out.push_str(
                    &serde_json::to_string(&file.to_lsp("file:///x.shd", &front.diagnostics)).unwrap(),
                );
            }
            Err(e) => out.push_str(&e.to_string()),
        }
        if let Some(t) = target {
            let profile = Profile::resolve(t).unwrap();
            match driver::compile(text, &profile, &PlanOptions::default()) {
                Ok(c) => out.push_str(&serde_json::to_string(&c.planned.plan).unwrap()),
                Err(d) => out.push_str(&file.render(&d, false)),
            }
        }
    }
    let analysis = shadec::lsp::analysis::analyze(name, text, None);
    out.push_str(&serde_json::to_string(&file.to_lsp("file:///x.shd", &analysis.diagnostics)).unwrap());
    out
}

#[test]
fn diagnostics_and_plans_are_the_same_on_every_run() {
    for (name, text) in examples().into_iter().chain(generated()) {
        let first = report(&name, &text);
        for run in 1..RUNS {
            let again = report(&name, &text);
            assert!(again == first, "{name}: run {run} differs from run 0");
        }
    }
}

#[test]
fn the_tie_is_broken_by_the_stated_order() {
    let front = shadec::verdict::check("const h = 1;\nconst H = 2;\nC δπx ← h8 * H8;\n", None).unwrap();
    let helps: Vec<&str> = front.diagnostics.iter().filter_map(|d| d.help.as_deref()).collect();
    assert!(helps.contains(&"did you mean `h`?"), "{helps:?}");
    assert!(helps.contains(&"did you mean `H`?"), "{helps:?}");
}

/// `shadec check --format json` over the examples and the generated
/// programs: the same stdout from separate processes.
#[test]
fn check_prints_the_same_bytes_in_every_process() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in generated() {
        std::fs::write(dir.path().join(format!("{name}.shd")), text).unwrap();
    }
    let examples = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let run = |format: &str| {
        let out = Command::new(env!("CARGO_BIN_EXE_shadec"))
            .args(["check", "--format", format])
            .arg(&examples)
            .arg(dir.path())
            .output()
            .unwrap();
        (out.stdout, out.stderr)
    };
    for format in ["json", "human"] {
        let first = run(format);
        assert!(!first.0.is_empty() || !first.1.is_empty());
        for _ in 1..5 {
            assert!(run(format) == first, "`check --format {format}` printed something else");
        }
    }
}
