//! A real editor against `shadec lsp` (issue 21): Neovim headless, its
//! built-in LSP client, and `editors/nvim/test.lua` (open, diagnostics, fix,
//! hover, rename). Fails — never skips — when `CI=true` and `nvim` is
//! missing (`.ci/run` installs Debian's package); elsewhere it says it
//! skipped.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The document the script opens: a typo (`Ligth`) to fix, a lookup to
/// hover, a `let` to rename. It names no target: the script's client sets
/// `shadec.target = geforce3` in its initializationOptions.
const PROGRAM: &str = "\
vector N : normal;
vector Light : light(0);
const kd : rgb = (0.8, 0.6, 0.4);
texture T : 2d rgba8 = image(\"brick.png\");
let base = T δu x;
shader p : s → c = kd * max(0, N·Ligth);
C δπx ← base ⊕ (δ p s x);
";

fn nvim_available() -> bool {
    Command::new("nvim")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn neovim_opens_hovers_and_renames() {
    if !nvim_available() {
        assert_ne!(
            std::env::var("CI").as_deref(),
            Ok("true"),
            "nvim is not installed: in CI it must be (`apt-get install neovim`, as .ci/run does)"
        );
        eprintln!("SKIPPED: nvim is not installed (in CI this test fails instead)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // A space and an umlaut in the path: the URIs Neovim and the server exchange are encoded.
    let sub = dir.path().join("a b");
    std::fs::create_dir(&sub).unwrap();
    let file = sub.join("bümp.shd");
    std::fs::write(&file, PROGRAM).unwrap();
    // The image the program reads (a missing one is an error, as in `shadec check`).
    image::RgbaImage::new(1, 1).save(sub.join("brick.png")).unwrap();
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/editors/nvim/test.lua");
    let mut child = Command::new("nvim")
        .args(["--headless", "--clean", "-c"])
        .arg(format!("luafile {script}"))
        .env("SHADEC_BIN", env!("CARGO_BIN_EXE_shadec"))
        .env("SHADEC_TEST_FILE", &file)
        .env("XDG_STATE_HOME", dir.path())
        .env("XDG_DATA_HOME", dir.path())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("nvim starts");
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if Instant::now() > deadline {
            child.kill().unwrap();
            panic!("nvim did not finish in 120 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(status.success(), "the Neovim script failed:\n{stderr}");
    assert!(stderr.contains("0 failure(s)"), "{stderr}");
}
