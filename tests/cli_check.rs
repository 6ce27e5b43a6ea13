//! `shadec check` and `shadec fmt` through the binary: exit codes, the
//! per-file summary, the LSP-shaped JSON document, atomic output.

use crate::common;

use common::{shadec, shadec_in};

#[test]
fn check_examples_is_clean_with_a_summary_per_file() {
    // The examples ship the images they read (tools/example-images.py).
    let r = shadec(&["check", "examples"]);
    assert_eq!(r.code, 0, "{}\n{}", r.stdout, r.stderr);
    let n = common::examples().len();
    assert!(n >= 25);
    assert_eq!(
        r.stdout.lines().filter(|l| l.starts_with("examples/") && l.contains(" ok")).count(),
        n,
        "{}",
        r.stdout
    );
    assert!(r.stdout.contains(&format!("checked {n} files: {n} clean, 0 errors")), "{}", r.stdout);
    // The only warnings are the approximations of the examples that
    // declare a target.
    assert!(
        r.stderr
            .lines()
            .filter(|l| l.starts_with("warning["))
            .all(|l| l.starts_with("warning[approximation]")),
        "{}",
        r.stderr
    );
    // Away from its image, a missing image is a located error, and
    // --stand-ins takes procedural bricks instead.
    let dir = tempfile::tempdir().unwrap();
    let program = dir.path().join("texture.shd");
    std::fs::copy("examples/texture.shd", &program).unwrap();
    let path = program.to_str().unwrap();
    let r = shadec(&["check", "--format", "short", path]);
    assert_eq!(r.code, 1, "{}", r.stdout);
    assert!(r.stdout.contains("texture.shd:") && r.stdout.contains("error[missing-image]"), "{}", r.stdout);
    let r = shadec(&["check", "--stand-ins", path]);
    assert_eq!(r.code, 0, "{}\n{}", r.stdout, r.stderr);
}

#[test]
fn json_is_one_document_of_lsp_diagnostics() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("bad.shd"),
        "vector N : normal;\nC δπx ← N·normalise(N);\nC δπx ← 𝑇 = 1;\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("good.shd"), "C δπx ← 1;\n").unwrap();
    let r = shadec_in(dir.path(), &["check", "--format", "json", "bad.shd", "good.shd"]);
    assert_eq!(r.code, 1);
    let doc: serde_json::Value = serde_json::from_str(&r.stdout).expect("stdout is one JSON document");
    assert_eq!(doc["summary"]["files"], 2);
    assert_eq!(doc["summary"]["errors"], 2);
    let files = doc["files"].as_array().unwrap();
    assert!(
        files[0]["uri"].as_str().unwrap().starts_with("file:///")
            && files[0]["uri"].as_str().unwrap().ends_with("/bad.shd")
    );
    let diags = files[0]["diagnostics"].as_array().unwrap();
    assert_eq!(diags.len(), 2);
    let d = &diags[0];
    // Stable field order, as the LSP specification lists them.
    let keys: Vec<&String> = d.as_object().unwrap().keys().collect();
    assert_eq!(keys, ["range", "severity", "code", "source", "message", "relatedInformation"]);
    assert_eq!(d["severity"], 1);
    assert_eq!(d["code"], "unknown-name");
    assert_eq!(d["source"], "shadec");
    // `normalise` on line 2 (0-based 1): after "C δπx ← N·" = 10 UTF-16 units.
    assert_eq!(d["range"]["start"], serde_json::json!({"line": 1, "character": 10}));
    assert_eq!(d["range"]["end"], serde_json::json!({"line": 1, "character": 19}));
    // `𝑇` is outside the BMP: two UTF-16 units, so `=` sits at character 11.
    assert_eq!(diags[1]["range"]["start"], serde_json::json!({"line": 2, "character": 11}));
    assert!(files[1]["diagnostics"].as_array().unwrap().is_empty());
}

#[test]
fn short_format_is_one_line_per_diagnostic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("a.shd"), "C xs ← a;\nC xs = b;\n").unwrap();
    let r = shadec_in(dir.path(), &["check", "--format", "short", "a.shd"]);
    assert_eq!(r.code, 1);
    let lines: Vec<&str> = r.stdout.lines().collect();
    assert_eq!(
        lines,
        [
            "a.shd:1:8: error[unknown-name]: unknown name `a`",
            "a.shd:2:6: error[syntax]: expected an expression or `←` (or `<-`), found `=`",
            "checked 1 file: 0 clean, 2 errors, 0 warnings",
        ]
    );
}

#[test]
fn warnings_pass_unless_denied() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("w.shd"), "const k = 1;\nC xs ← 0;\n").unwrap();
    assert_eq!(shadec_in(dir.path(), &["check", "w.shd"]).code, 0);
    assert_eq!(shadec_in(dir.path(), &["check", "--deny-warnings", "w.shd"]).code, 1);
}

#[test]
fn fmt_writes_atomically_and_refuses_broken_input_without_touching_the_output() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("a.shd"),
        "C delta pi x <- T delta u x (+)[add] (delta p s x);\ntexture T : 2d;\nshader p : s -> c = 1;\n",
    )
    .unwrap();
    let r = shadec_in(dir.path(), &["fmt", "a.shd", "-o", "out.shd"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let out = std::fs::read_to_string(dir.path().join("out.shd")).unwrap();
    assert_eq!(out.lines().next().unwrap(), "C δπx ← T δu x ⊕[add] δ p s x;");
    let r = shadec_in(dir.path(), &["fmt", "--ascii", "out.shd"]);
    assert!(r.stdout.starts_with("C delta pi x <- T delta u x (+)[add] delta p s x;"), "{}", r.stdout);
    std::fs::write(dir.path().join("broken.shd"), "C xs ← ;").unwrap();
    let r = shadec_in(dir.path(), &["fmt", "broken.shd", "-o", "out.shd"]);
    assert_eq!(r.code, 1);
    assert!(r.stderr.contains("nothing was written"));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("out.shd")).unwrap(),
        out,
        "a failed run keeps the old output"
    );
}
