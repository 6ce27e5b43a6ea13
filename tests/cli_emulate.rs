//! `shadec emulate` end to end: images in, image out, and the exit codes
//! (0 ok, 1 bad config with file:line:col, 2 usage or I/O).

use std::path::{Path, PathBuf};
use std::process::Command;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/combiners").join(name)
}

fn png(dir: &Path, name: &str, w: u32, h: u32, px: [u8; 4]) -> PathBuf {
    let path = dir.join(name);
    image::RgbaImage::from_pixel(w, h, image::Rgba(px)).save(&path).unwrap();
    path
}

fn shadec(args: &[&std::ffi::OsStr]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shadec")).arg("emulate").args(args).output().unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

macro_rules! args {
    ($($a:expr),* $(,)?) => { &[$(std::ffi::OsStr::new($a)),*] };
}

#[test]
fn runs_appendix_h_on_images() {
    let dir = tempfile::tempdir().unwrap();
    let t0 = png(dir.path(), "n.png", 3, 2, [128, 128, 255, 255]);
    let t1 = png(dir.path(), "h.png", 3, 2, [218, 128, 218, 255]);
    let out = dir.path().join("out.png");
    for (config, precision) in [("appendix_h.rc", "fixed9"), ("appendix_h.ron", "f32")] {
        let cfg = data(config);
        let (code, err) =
            shadec(args![&cfg, "--tex0", &t0, "--tex1", &t1, "--precision", precision, "--out", &out]);
        assert_eq!(code, 0, "{err}");
        let img = image::open(&out).unwrap().to_rgba8();
        assert_eq!(img.dimensions(), (3, 2));
        assert!(img.pixels().all(|p| p.0 == [17, 17, 17, 0]), "{config} {precision}");
    }
}

#[test]
fn program_constants_override_command_line_ones() {
    let dir = tempfile::tempdir().unwrap();
    let prim = png(dir.path(), "p.png", 1, 1, [0, 0, 0, 0]);
    let cfg = dir.path().join("c.rc");
    std::fs::write(&cfg, "!!RC1.0\nconst0 = (1, 0, 0, 1);\nout.rgb = const0 + const1;\nout.a = fog;\n")
        .unwrap();
    let out = dir.path().join("out.png");
    let (code, err) = shadec(args![
        &cfg,
        "--primary",
        &prim,
        "--const0",
        "0,0,1,1",
        "--const1",
        "0,1,0,1",
        "--fog",
        "0,0,0,0.5",
        "--out",
        &out
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(image::open(&out).unwrap().to_rgba8().get_pixel(0, 0).0, [255, 255, 0, 128]);
}

#[test]
fn mismatched_sizes_are_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let a = png(dir.path(), "a.png", 4, 4, [0; 4]);
    let b = png(dir.path(), "b.png", 4, 3, [0; 4]);
    let out = dir.path().join("out.png");
    let (code, err) = shadec(args![&data("appendix_g.rc"), "--tex0", &a, "--tex1", &b, "--out", &out]);
    assert_eq!(code, 2);
    assert!(
        err.contains("input images differ in size") && err.contains("is 4x4 but") && err.contains("is 4x3"),
        "{err}"
    );
    assert!(!out.exists(), "no output on failure");
}

#[test]
fn missing_files_are_io_errors() {
    let dir = tempfile::tempdir().unwrap();
    let a = png(dir.path(), "a.png", 2, 2, [0; 4]);
    let out = dir.path().join("out.png");
    let (code, err) = shadec(args![&dir.path().join("nope.rc"), "--tex0", &a, "--out", &out]);
    assert_eq!(code, 2);
    assert!(err.contains("nope.rc: cannot read"), "{err}");
    let (code, err) =
        shadec(args![&data("appendix_g.rc"), "--tex0", &dir.path().join("gone.png"), "--out", &out]);
    assert_eq!(code, 2);
    assert!(err.contains("gone.png: cannot read"), "{err}");
    let not_png = dir.path().join("x.png");
    std::fs::write(&not_png, "hello").unwrap();
    let (code, err) = shadec(args![&data("appendix_g.rc"), "--tex0", &not_png, "--out", &out]);
    assert_eq!(code, 2);
    assert!(err.contains("not a readable PNG"), "{err}");
    let (code, _) =
        shadec(args![&data("appendix_g.rc"), "--tex0", &a, "--out", &dir.path().join("no/such/dir/o.png")]);
    assert_eq!(code, 2);
    let (code, err) = shadec(args![&data("appendix_g.rc"), "--out", &out]);
    assert_eq!(code, 2);
    assert!(err.contains("no input image"), "{err}");
}

#[test]
fn malformed_configs_name_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let a = png(dir.path(), "a.png", 2, 2, [0; 4]);
    let out = dir.path().join("out.png");
    let rc = dir.path().join("bad.rc");
    std::fs::write(&rc, "!!RC1.0\n{\n  rgb { spare0 = tex0 * tex9; }\n}\nout.rgb = spare0;\n").unwrap();
    let (code, err) = shadec(args![&rc, "--tex0", &a, "--out", &out]);
    assert_eq!(code, 1);
    assert!(
        err.contains("bad.rc:3:25") && err.contains("unknown register `tex9`") && err.contains("help:"),
        "{err}"
    );
    let ron = dir.path().join("bad.ron");
    std::fs::write(&ron, "(\n  general: [],\n  final: oops,\n)").unwrap();
    let (code, err) = shadec(args![&ron, "--tex0", &a, "--out", &out]);
    assert_eq!(code, 1);
    assert!(err.contains("bad.ron:3:"), "{err}");
    // A valid-looking RON config that breaks an Appendix B rule: named by stage/portion/variable.
    let mut config = shadec::backends::combiners::CombinerConfig::default();
    config.general[0].alpha.ab_dot = true;
    config.general[0].alpha.sum_output = None;
    std::fs::write(&ron, config.to_ron()).unwrap();
    let (code, err) = shadec(args![&ron, "--tex0", &a, "--out", &out]);
    assert_eq!(code, 1);
    assert!(err.contains("error[dot-in-alpha]: general combiner 0, alpha portion, AB output"), "{err}");
    assert!(!out.exists());
}

#[test]
fn profile_limits_the_number_of_general_combiners() {
    let dir = tempfile::tempdir().unwrap();
    let a = png(dir.path(), "a.png", 1, 1, [0; 4]);
    let rc = dir.path().join("three.rc");
    std::fs::write(&rc, "!!RC1.0\n{ rgb { spare0 = tex0; } }\n{ rgb { spare0 = tex0; } }\n{ rgb { spare0 = tex0; } }\nout.rgb = spare0;\n").unwrap();
    let out = dir.path().join("out.png");
    let (code, err) = shadec(args![&rc, "--tex0", &a, "--profile", "geforce256", "--out", &out]);
    assert_eq!(code, 1);
    assert!(err.contains("three.rc:4:1") && err.contains("too-many-stages"), "{err}");
    let (code, err) = shadec(args![&rc, "--tex0", &a, "--out", &out]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn bad_arguments_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.png");
    let (code, err) = shadec(args![&data("appendix_g.rc"), "--const0", "1,2,3", "--out", &out]);
    assert_eq!(code, 2);
    assert!(err.contains("expected four numbers"), "{err}");
    let (code, _) = shadec(args![&data("appendix_g.rc"), "--precision", "f16", "--out", &out]);
    assert_eq!(code, 2);
}

/// Issue 20, item 5: NV2A's dot product in the alpha portion is refused by
/// default (as nvparse refuses it) and run with `--permissive`, as the
/// product of the two alpha inputs (the one-component dot product).
#[test]
fn permissive_mode_runs_alpha_dot_products_and_is_off_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cfg = d.join("alpha_dot.rc");
    std::fs::write(
        &cfg,
        "!!RC1.0\n{ alpha { spare0.a = tex0.b . tex1.b; } }\nout.rgb = spare0.a;\nout.a = one;\n",
    )
    .unwrap();
    let t0 = png(d, "a.png", 2, 2, [10, 20, 200, 40]);
    let t1 = png(d, "b.png", 2, 2, [50, 60, 100, 80]);
    let out = d.join("out.png");
    let (code, err) = shadec(args![&cfg, "--tex0", &t0, "--tex1", &t1, "--out", &out]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("alpha_dot.rc:2:11")
            && err.contains("error[dot-in-alpha]")
            && err.contains("--permissive"),
        "{err}"
    );
    assert!(!out.exists());
    let (code, err) = shadec(args![&cfg, "--tex0", &t0, "--tex1", &t1, "--permissive", "--out", &out]);
    assert_eq!(code, 0, "{err}");
    // 200/255 · 100/255 = 0.3076 → 78.4/255, one rounding to nearest: 78.
    let img = image::open(&out).unwrap().to_rgba8();
    assert!(img.pixels().all(|p| p.0 == [78, 78, 78, 255]), "{:?}", img.get_pixel(0, 0));
    // translate: refused by default, accepted with the flag.
    let translate = |extra: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_shadec"))
            .arg("translate")
            .arg(&cfg)
            .args(extra)
            .output()
            .unwrap();
        (o.status.code().unwrap_or(-1), String::from_utf8_lossy(&o.stdout).into_owned())
    };
    assert_eq!(translate(&[]).0, 1);
    let (code, wgsl) = translate(&["--permissive"]);
    assert_eq!(code, 0);
    assert!(wgsl.contains("let alpha_ab = alpha_a * alpha_b;"), "{wgsl}");
}
