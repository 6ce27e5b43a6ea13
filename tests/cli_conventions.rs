//! One command-line convention: `-o/--output` on every command that writes
//! (the older `--out` and `--out-dir` still accepted, and hidden), `fmt
//! --check` and `fmt -w`, compile's diagnostics and plan formats as two
//! flags, and no Mesa complaint about XDG_RUNTIME_DIR from `--backend wgpu`.

use std::path::Path;

use crate::common::{shadec, shadec_in};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn png(dir: &Path, name: &str, px: [u8; 4]) -> String {
    let path = dir.join(name);
    image::RgbaImage::from_pixel(4, 3, image::Rgba(px)).save(&path).unwrap();
    path.display().to_string()
}

/// Runs `args` once with each spelling of the output flag and checks that
/// each wrote `what` at the path given (a file, or a folder's `front.md`).
fn writes_with_each_spelling(dir: &Path, args: &[&str], spellings: &[&str], what: &str) {
    for (i, flag) in spellings.iter().enumerate() {
        let out = dir.join(format!("{}-{i}-{}", args[0], flag.trim_start_matches('-')));
        let out_text = out.display().to_string();
        let mut all: Vec<&str> = args.to_vec();
        all.extend([*flag, out_text.as_str()]);
        let r = shadec_in(dir, &all);
        assert_eq!(r.code, 0, "{all:?}\n{}\n{}", r.stdout, r.stderr);
        let written = if what == "front.md" { out.join("front.md") } else { out.clone() };
        let meta = std::fs::metadata(&written)
            .unwrap_or_else(|e| panic!("{all:?} wrote no {}: {e}", written.display()));
        assert!(meta.len() > 0, "{all:?}: {} is empty", written.display());
    }
}

#[test]
fn every_command_that_writes_takes_dash_o_and_dash_dash_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let shd = format!("{ROOT}/examples/gouraud.shd");
    let rc = format!("{ROOT}/tests/data/combiners/appendix_g.rc");
    let tex = png(d, "t.png", [200, 100, 50, 255]);
    let both = ["-o", "--output"];
    writes_with_each_spelling(d, &["check", &shd], &both, "file");
    writes_with_each_spelling(d, &["compile", &shd, "--emit", "plan"], &both, "file");
    writes_with_each_spelling(d, &["fmt", &shd], &both, "file");
    writes_with_each_spelling(d, &["translate", &rc], &both, "file");
    writes_with_each_spelling(d, &["emulate", &rc, "--tex0", &tex, "--tex1", &tex], &both, "file");
    writes_with_each_spelling(d, &["render", "--size", "24x16"], &both, "file");
    writes_with_each_spelling(d, &["bench", "--program", &shd, "--target", "wgsl"], &both, "front.md");
    // The older spellings still work.
    writes_with_each_spelling(d, &["render", "--size", "24x16"], &["--out"], "file");
    writes_with_each_spelling(d, &["emulate", &rc, "--tex0", &tex, "--tex1", &tex], &["--out"], "file");
    writes_with_each_spelling(
        d,
        &["bench", "--program", &shd, "--target", "wgsl"],
        &["--out-dir"],
        "front.md",
    );
}

/// `check -o` writes what standard output would show; diagnostics stay on
/// standard error.
#[test]
fn check_output_holds_the_report() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.shd"), "C δπx ← normalise(1);\n").unwrap();
    let r = shadec_in(dir.path(), &["check", "bad.shd", "-o", "report.txt"]);
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stdout.is_empty(), "{}", r.stdout);
    assert!(r.stderr.contains("error[unknown-name]"), "{}", r.stderr);
    let report = std::fs::read_to_string(dir.path().join("report.txt")).unwrap();
    assert!(report.contains("checked 1 file: 0 clean, 1 error, 0 warnings"), "{report}");
    let r = shadec_in(dir.path(), &["check", "--format", "json", "bad.shd", "-o", "report.json"]);
    assert_eq!(r.code, 1);
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap()).unwrap();
    assert_eq!(doc["summary"]["errors"], 1);
}

/// The old spellings are accepted but not advertised: `--help` shows one
/// convention.
#[test]
fn old_spellings_are_hidden_from_help() {
    for (command, old) in
        [("render", "--out "), ("emulate", "--out "), ("bench", "--out-dir"), ("compile", "--format ")]
    {
        let r = shadec(&[command, "--help"]);
        assert_eq!(r.code, 0);
        assert!(r.stdout.contains("-o, --output"), "{command}: {}", r.stdout);
        let flags: Vec<&str> = r.stdout.lines().filter(|l| l.trim_start().starts_with('-')).collect();
        assert!(!flags.iter().any(|l| l.contains(old)), "{command} --help lists {old}: {flags:?}");
    }
}

/// `compile --diagnostics-format` and `--plan-format` are independent; the
/// old `--format json` still gives JSON for both.
#[test]
fn compile_formats_are_two_flags() {
    let shd = "examples/fragment_lighting.shd";
    let plan = |extra: &[&str]| {
        let mut args = vec!["compile", shd, "--emit", "plan", "--target", "geforce3"];
        args.extend(extra);
        let r = shadec(&args);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
        r.stdout
    };
    let json = |s: &str| serde_json::from_str::<serde_json::Value>(s).is_ok();
    assert!(!json(&plan(&[])), "RON by default");
    assert!(json(&plan(&["--plan-format", "json"])));
    assert!(!json(&plan(&["--diagnostics-format", "json"])), "diagnostics JSON leaves the plan RON");
    assert!(json(&plan(&["--format", "json"])), "the older flag still gives a JSON plan");
    assert!(!json(&plan(&["--format", "json", "--plan-format", "ron"])), "the new flag wins");
    // Diagnostics in JSON with the plan format untouched.
    let r = shadec(&["compile", "tests/data/does-not-parse.shd", "--diagnostics-format", "json"]);
    assert_eq!(r.code, 2, "a missing file is an I/O error: {}", r.stderr);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bad.shd"), "C δπx ← normalise(1);\n").unwrap();
    let r = shadec_in(dir.path(), &["compile", "bad.shd", "--diagnostics-format", "json"]);
    assert_eq!(r.code, 1);
    let doc: serde_json::Value = serde_json::from_str(&r.stderr).expect("stderr is LSP JSON");
    assert!(doc.to_string().contains("unknown-name"), "{doc}");
    let r = shadec_in(dir.path(), &["compile", "bad.shd", "--diagnostics-format", "short"]);
    assert!(r.stderr.starts_with("bad.shd:1:"), "{}", r.stderr);
}

#[test]
fn fmt_check_and_write() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let canonical = shadec(&["fmt", "examples/fragment_lighting.shd"]);
    assert_eq!(canonical.code, 0, "{}", canonical.stderr);
    std::fs::write(d.join("good.shd"), &canonical.stdout).unwrap();
    // The same program with its spacing disturbed on line 3 onwards.
    let messy: String = canonical
        .stdout
        .lines()
        .enumerate()
        .map(|(i, l)| if i >= 2 && l.contains('←') { l.replace('←', "  ←") } else { l.to_string() } + "\n")
        .collect();
    assert_ne!(messy, canonical.stdout, "the test needs a statement to disturb");
    let first = messy.lines().zip(canonical.stdout.lines()).position(|(a, b)| a != b).unwrap() + 1;
    std::fs::write(d.join("messy.shd"), &messy).unwrap();

    let r = shadec_in(d, &["fmt", "--check", "good.shd"]);
    assert_eq!((r.code, r.stdout.as_str()), (0, ""), "{}", r.stderr);
    let r = shadec_in(d, &["fmt", "--check", "good.shd", "messy.shd"]);
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains(&format!("messy.shd:{first}: not in canonical form")), "{}", r.stderr);
    let (found, wanted) =
        (messy.lines().nth(first - 1).unwrap(), canonical.stdout.lines().nth(first - 1).unwrap());
    assert!(r.stderr.contains(&format!("  found: {found}\n  canonical: {wanted}\n")), "{}", r.stderr);
    assert!(!r.stderr.contains("good.shd"), "{}", r.stderr);
    assert_eq!(std::fs::read_to_string(d.join("messy.shd")).unwrap(), messy, "--check writes nothing");

    // -w: in place, then --check passes; a canonical file is left alone.
    let before = std::fs::metadata(d.join("good.shd")).unwrap().modified().unwrap();
    let r = shadec_in(d, &["fmt", "-w", "good.shd", "messy.shd"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(std::fs::read_to_string(d.join("messy.shd")).unwrap(), canonical.stdout);
    assert_eq!(std::fs::metadata(d.join("good.shd")).unwrap().modified().unwrap(), before);
    assert_eq!(shadec_in(d, &["fmt", "--check", "messy.shd"]).code, 0);
    let leftovers: Vec<_> = std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(leftovers.len(), 2, "no temporary file left: {leftovers:?}");

    // --ascii applies to --check and -w too.
    let r = shadec_in(d, &["fmt", "--ascii", "--check", "messy.shd"]);
    assert_eq!(r.code, 1, "Unicode text is not the ASCII canonical form");

    // Syntax errors: exit 1, the file untouched.
    std::fs::write(d.join("broken.shd"), "C δπx ← (;\n").unwrap();
    let r = shadec_in(d, &["fmt", "-w", "broken.shd"]);
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains("broken.shd:1:"), "{}", r.stderr);
    assert_eq!(std::fs::read_to_string(d.join("broken.shd")).unwrap(), "C δπx ← (;\n");

    // Several files need --check or -w; -w and -o do not mix.
    assert_eq!(shadec_in(d, &["fmt", "good.shd", "messy.shd"]).code, 2);
    assert_eq!(shadec_in(d, &["fmt", "-w", "good.shd", "-o", "x.shd"]).code, 2);
    assert_eq!(shadec_in(d, &["fmt", "--check", "missing.shd"]).code, 2);
}

/// Mesa's drivers print "error: XDG_RUNTIME_DIR is invalid or not set in
/// the environment." when it is missing; shadec gives them a private one
/// first, so `--backend wgpu` prints no error that is not shadec's.
#[cfg(feature = "gpu")]
#[test]
fn wgpu_runs_print_no_xdg_runtime_dir_complaint() {
    if crate::common::gpu::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for xdg in [None, Some("/nonexistent/run/user")] {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_shadec"));
        cmd.args(["render", "--backend", "wgpu", "--size", "24x16", "-o", "x.png"]).current_dir(dir.path());
        match xdg {
            None => cmd.env_remove("XDG_RUNTIME_DIR"),
            Some(v) => cmd.env("XDG_RUNTIME_DIR", v),
        };
        let out = cmd.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        assert!(!stderr.contains("XDG_RUNTIME_DIR"), "XDG_RUNTIME_DIR={xdg:?}:\n{stderr}");
    }
}
