//! `shadec compile --emit ir` and `shadec check --target`: output and exit codes.

use std::process::Command;

fn shadec(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shadec"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn compile_emits_ir() {
    let (code, out, err) = shadec(&["compile", "--stand-ins", "examples/gouraud.shd", "--emit", "ir"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.starts_with("module\n"), "{out}");
    assert!(out.contains("δ %"), "{out}");
    assert!(out.contains("statements:"), "{out}");
}

#[test]
fn compile_writes_atomically_to_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.ir");
    let (code, out, err) =
        shadec(&["compile", "--stand-ins", "examples/texture.shd", "-o", path.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.is_empty());
    assert!(std::fs::read_to_string(&path).unwrap().contains("lookup T"));
}

#[test]
fn compile_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.shd");
    std::fs::write(
        &bad,
        "texture T : 2d rgba8 = image(\"t.png\");\nconst kd : rgb = (1, 0, 0);\nC δπx ← T kd;\n",
    )
    .unwrap();
    let (code, _, err) = shadec(&["compile", "--stand-ins", bad.to_str().unwrap()]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("error[bad-index]"), "{err}");
    assert!(err.contains("bad.shd:3:9"), "{err}");
    let (code, _, _) = shadec(&["compile", "--stand-ins", "no/such/file.shd"]);
    assert_eq!(code, 2);
    let (code, _, err) = shadec(&["compile", "--stand-ins", "examples/texture.shd", "--target", "voodoo2"]);
    assert_eq!(code, 2);
    assert!(err.contains("unknown target profile `voodoo2`"), "{err}");
}

#[test]
fn check_target_reports_overflow_as_warning() {
    let (code, _, err) = shadec(&[
        "check",
        "--stand-ins",
        "--target",
        "geforce256",
        "--format",
        "short",
        "examples/chained_multitexture.shd",
    ]);
    assert_eq!(code, 0, "a warning does not fail the check: {err}");
    let (_, out, _) = shadec(&[
        "check",
        "--stand-ins",
        "--target",
        "geforce256",
        "--format",
        "short",
        "examples/chained_multitexture.shd",
    ]);
    assert!(
        out.contains("examples/chained_multitexture.shd:15:1: warning[does-not-fit]: does not fit in one pass on geforce256: needs 4 texture units; it has 2"),
        "{out}"
    );
    let (code, out, _) = shadec(&[
        "check",
        "--stand-ins",
        "--target",
        "geforce3",
        "--format",
        "short",
        "examples/chained_multitexture.shd",
    ]);
    assert_eq!(code, 0);
    assert!(!out.contains("does-not-fit"), "{out}");
    let (code, _, _) = shadec(&[
        "check",
        "--stand-ins",
        "--target",
        "geforce256",
        "--deny-warnings",
        "examples/chained_multitexture.shd",
    ]);
    assert_eq!(code, 1);
}

#[test]
fn check_target_from_a_ron_file_and_missing_capabilities() {
    let (code, out, _) = shadec(&[
        "check",
        "--stand-ins",
        "--target",
        "profiles/geforce256.ron",
        "--format",
        "short",
        "examples/embm.shd",
    ]);
    assert_eq!(code, 1);
    assert!(out.contains("error[unsupported-by-target]: geforce256 cannot do this: a texture indexed by another texture's result"), "{out}");
}

#[test]
fn check_uses_the_programs_target_line() {
    // kilgard_bump_mapping says `target geforce256;` and fits it, pass by pass.
    let (code, out, err) =
        shadec(&["check", "--stand-ins", "--format", "short", "examples/kilgard_bump_mapping.shd"]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(!out.contains("warning["), "{out}");
}

#[test]
fn compile_with_an_overflowing_target_warns_and_still_emits() {
    let (code, out, err) =
        shadec(&["compile", "--stand-ins", "examples/chained_multitexture.shd", "--target", "geforce256"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("warning[does-not-fit]"), "{err}");
    assert!(out.contains("texture units 4"), "{out}");
}
