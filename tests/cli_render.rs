//! `shadec render`: the built-in default, and its errors.

use std::process::Command;

fn shadec() -> Command {
    Command::new(env!("CARGO_BIN_EXE_shadec"))
}

#[test]
fn no_arguments_renders_the_default_into_shadec_out_png() {
    let dir = tempfile::tempdir().unwrap();
    let out = shadec().arg("render").current_dir(dir.path()).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "stdout:\n{stdout}\nstderr:\n{stderr}");
    let png = dir.path().join("shadec-out.png");
    let img = image::open(&png).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (640, 480));
    assert!(img.pixels().any(|p| p.0[0] > 40), "the torus is visible");
    for needle in
        ["3 passes on geforce256", "pass 1:", "Mpixel/s", "max abs", "RMSE", "PSNR", "fixed9", "stand-in"]
    {
        assert!(stdout.contains(needle), "missing {needle:?} in:\n{stdout}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "only the picture is written");
}

#[test]
fn options_choose_mode_size_target_and_output() {
    let dir = tempfile::tempdir().unwrap();
    let out = shadec()
        .args(["render", "--mode", "exact", "--size", "80x60", "--target", "geforce3", "--out", "x.png"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    // Kilgard's three statements fuse into one pass on geforce3.
    assert!(stdout.contains("1 pass on geforce3"), "{stdout}");
    assert!(
        stdout.contains(
            "error against the program's meaning (exact, unsplit) of this exact render: max abs 0.0000"
        ),
        "{stdout}"
    );
    assert_eq!(image::open(dir.path().join("x.png")).unwrap().to_rgba8().dimensions(), (80, 60));
}

#[test]
fn a_missing_scene_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = shadec().args(["render", "no/such/scene.ron"]).current_dir(dir.path()).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("no/such/scene.ron") && stderr.contains("not found"), "{stderr}");
    assert!(!dir.path().join("shadec-out.png").exists());
}

#[test]
fn a_bad_size_is_a_usage_error() {
    let out = shadec().args(["render", "--size", "0x10"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("WxH"));
}

#[test]
fn a_bad_shader_is_an_input_error_with_its_location() {
    let dir = tempfile::tempdir().unwrap();
    let shader = dir.path().join("bad.shd");
    std::fs::write(&shader, "texture T : 2d rgba8 = image(\"a.png\");\n\nC δπx ← Q δu x;\n").unwrap();
    let out = shadec().args(["render", "--shader"]).arg(&shader).current_dir(dir.path()).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("bad.shd:3:"), "expected file:line:col in:\n{stderr}");
    assert!(!dir.path().join("shadec-out.png").exists());
}

/// A uniform with no default that the scene does not set is said so (it
/// would otherwise render black and "identical" to its meaning, silently);
/// using a shading vector's role as a value gets a help that declares it.
#[test]
fn an_unset_uniform_is_noted_and_a_role_used_as_a_value_is_explained() {
    let dir = tempfile::tempdir().unwrap();
    let shader = dir.path().join("tint.shd");
    std::fs::write(&shader, "vector N : normal;\nvector L : light(0);\nuniform tint : rgb;\nC δπx ← tint * max(0, N δ s x · L δ s x);\n").unwrap();
    let out = shadec()
        .args(["render", "--size", "32x24", "--shader"])
        .arg(&shader)
        .current_dir(dir.path())
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("uniform `tint` has no default and the scene does not set it"), "{stdout}");
    std::fs::write(
        &shader,
        "vector N : normal;\nvector L : light(0);\nC δπx ← intensity(0) * max(0, N δ s x · L δ s x);\n",
    )
    .unwrap();
    let out = shadec().args(["check"]).arg(&shader).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr.contains("tint.shd:3:"), "{stderr}");
    assert!(stderr.contains("`vector V : intensity(0) in eye;`"), "{stderr}");
}

/// What the CPU renderer cannot do yet (a fat texture read from an image:
/// its members have no layout) is reported at the statement whose pass it
/// is, with file:line:col and a help line, and nothing is written.
#[test]
fn a_pass_the_cpu_cannot_render_is_located_at_its_statement() {
    let dir = tempfile::tempdir().unwrap();
    let shader = dir.path().join("fat.shd");
    std::fs::write(
        &shader,
        "vector N : normal;\nvector L : light(0);\ntexture T : 2d rgba16f bilinear clamp = image(\"fat.png\");\nshader p : s → c = max(0, N·L);\n\nC δπx ← p T δu x;\n",
    )
    .unwrap();
    let out = shadec()
        .args(["render", "--stand-ins", "--size", "64x48", "--shader"])
        .arg(&shader)
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("cpu-unsupported")
            && stderr.contains("fat.shd:6:1")
            && stderr.contains("no layout yet")
            && stderr.contains("help:"),
        "{stderr}"
    );
    assert!(!dir.path().join("shadec-out.png").exists());
}

#[test]
fn a_bad_scene_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.ron");
    std::fs::write(&scene, "(camera: (eye: (0.0, 0.0, 1.0)), objects: [],, )").unwrap();
    let out = shadec().arg("render").arg(&scene).current_dir(dir.path()).output().unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("s.ron:"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A number printed after `label` (`8.50 % of`, `PSNR 49.22 dB`).
fn number_after(text: &str, label: &str) -> f64 {
    let rest = &text[text.find(label).unwrap_or_else(|| panic!("no {label:?} in:\n{text}")) + label.len()..];
    let num: String = rest.trim_start().chars().take_while(|c| c.is_ascii_digit() || *c == '.').collect();
    num.parse().unwrap_or_else(|_| panic!("no number after {label:?} in:\n{text}"))
}

#[test]
fn a_scene_with_four_lights_renders_a_pass_per_light_unless_told_not_to() {
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/adaptive_sphere_4lights.ron");
    let shader = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/fragment_lighting.shd");
    let run = |extra: &[&str]| {
        let out = shadec()
            .args(["render", scene, "--shader", shader, "--mode", "f32", "--size", "96x96"])
            .args(extra)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
        stdout
    };
    let specialized = run(&[]);
    assert!(specialized.contains("4 passes on wgsl") && specialized.contains("(light 3)"), "{specialized}");
    let plain = run(&["--no-specialize"]);
    assert!(plain.contains("1 pass on wgsl"), "{plain}");
}

#[test]
fn adaptive_shading_reports_the_pixels_shaded_and_its_error() {
    // seeds/004 Section 2.1 on the paper's 4-light sphere: far fewer pixels
    // shaded than covered, at a small error against full shading.
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/adaptive_sphere_4lights.ron");
    let shader = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/fragment_lighting.shd");
    let out = shadec()
        .args([
            "render",
            scene,
            "--shader",
            shader,
            "--mode",
            "f32",
            "--size",
            "256x256",
            "--adaptive",
            "8.5%,16",
            "--out",
            "a.png",
        ])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    let shaded = number_after(&stdout, "spacing 16):");
    assert!(shaded > 0.0 && shaded < 25.0, "{shaded} % shaded:\n{stdout}");
    let full = &stdout[stdout.find("error against full shading").unwrap()..];
    assert!(number_after(full, "PSNR") >= 40.0, "{stdout}");
    assert!(dir.path().join("a.png").exists());
}

#[test]
fn a_bad_adaptive_setting_is_a_usage_error() {
    for bad in ["200%", "0.1,0", "fast", "0.1,x"] {
        let out = shadec().args(["render", "--adaptive", bad]).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{bad}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("THRESHOLD[,SPACING]"), "{bad}");
    }
}

/// Renders the default program at 160×120 for `target` on `backend` in
/// `precision` into `dir`, returning stdout and the picture.
fn render_on(
    dir: &std::path::Path,
    target: &str,
    backend: &str,
    precision: &str,
) -> (String, image::RgbaImage) {
    let out_name = format!("{backend}-{precision}.png");
    let out = shadec()
        .args(["render", "--size", "160x120", "--target", target, "--backend", backend])
        .args(["--precision", precision, "--out", &out_name])
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .current_dir(dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{backend}: {stdout}{}", String::from_utf8_lossy(&out.stderr));
    (stdout, image::open(dir.join(out_name)).unwrap().to_rgba8())
}

/// `--backend wgpu` (issue 22) runs the same plan on the GPU (lavapipe in
/// CI): it names its adapter and reports the same error line, and its
/// picture agrees with the CPU renderer's — an executor checked against
/// an independent one: the three combiner passes in fixed9, and one f32
/// pass (the CPU's f32 keeps a float framebuffer between passes, a GPU an
/// 8-bit one, so f32 is compared on a one-pass plan).
#[test]
fn the_wgpu_backend_renders_what_the_cpu_renders() {
    let dir = tempfile::tempdir().unwrap();
    for (target, precision) in [("geforce256", "fixed9"), ("wgsl", "f32")] {
        let (gpu_out, gpu) = render_on(dir.path(), target, "wgpu", precision);
        let (_, cpu) = render_on(dir.path(), target, "cpu", precision);
        for needle in ["adapter:", ") on wgpu", "error against the program's meaning", "max abs", "PSNR"] {
            assert!(gpu_out.contains(needle), "missing {needle:?} in:\n{gpu_out}");
        }
        // GPU time where the adapter has timestamp queries (lavapipe does).
        assert!(
            gpu_out.contains("ms GPU time (timestamp queries") || gpu_out.contains("no timestamp queries"),
            "{gpu_out}"
        );
        let far = cpu
            .pixels()
            .zip(gpu.pixels())
            .filter(|(a, b)| (0..3).any(|c| (a.0[c] as i32 - b.0[c] as i32).abs() > 2))
            .count();
        // Edges of the torus may rasterize differently; the shading may not.
        let total = (cpu.width() * cpu.height()) as usize;
        assert!(far * 100 < total, "{precision}: {far} of {total} pixels differ by more than 2/255");
        assert!(gpu.pixels().any(|p| p.0[0] > 40), "{precision}: the torus is visible");
    }
}

/// The PSNR of `render`'s "error against full shading" line.
fn psnr_against_full(stdout: &str) -> f64 {
    let line = stdout.lines().find(|l| l.starts_with("error against full shading")).expect(stdout);
    match line.split("PSNR ").nth(1).and_then(|r| r.split(' ').next()) {
        Some("∞") => f64::INFINITY,
        Some(p) => p.parse().unwrap(),
        None => panic!("{line}"),
    }
}

/// `--adaptive` on wgpu: a sparse frame of the plan's own passes, a
/// classification, and the plan's passes where the depth mask leaves them;
/// against full shading of the same plan on the same adapter it stays
/// above 40 dB. Textured plans (the default program's cube maps, whose
/// `textureSample` the old in-shader branch could not skip) are adaptive
/// too (`gpu::adaptive`'s unit tests: what is left to full shading).
#[test]
fn adaptive_shading_on_wgpu_interpolates_the_plans_own_shading() {
    let dir = tempfile::tempdir().unwrap();
    let root = env!("CARGO_MANIFEST_DIR");
    let scene = format!("{root}/scenes/adaptive_sphere_4lights.ron");
    let shader = format!("{root}/examples/fragment_lighting.shd");
    let args = ["render", &scene, "--shader", &shader, "--target", "wgsl", "--backend", "wgpu"];
    let run = |extra: &[&str]| {
        let out = shadec().args(extra).current_dir(dir.path()).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
        stdout
    };
    let stdout = run(&[&args[..], &["--adaptive", "8.5%,8", "--size", "128x128"]].concat());
    assert!(psnr_against_full(&stdout) >= 40.0, "{stdout}");
    assert!(
        stdout.contains("adaptive (threshold 8.5 %, spacing 8): a sparse frame, a classification"),
        "{stdout}"
    );
    let stdout = run(&["render", "--backend", "wgpu", "--adaptive", "8%,4", "--size", "64x64"]);
    assert!(!stdout.contains("shaded in full"), "{stdout}");
    assert!(psnr_against_full(&stdout) >= 30.0, "{stdout}");
}

/// `--adaptive auto` decides from the plan before rendering, says what it
/// chose and why: a textured plan in full, an expensive shader adaptively.
#[test]
fn adaptive_auto_says_what_it_chose_and_why() {
    let dir = tempfile::tempdir().unwrap();
    let out = shadec()
        .args(["render", "--adaptive", "auto", "--size", "32x32"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(stdout.contains("adaptive auto: full shading: pass 1 samples a texture"), "{stdout}");
    assert!(!stdout.contains("error against full shading"), "{stdout}");
    let root = env!("CARGO_MANIFEST_DIR");
    let scene = format!("{root}/scenes/adaptive_sphere_4lights.ron");
    let shader = dir.path().join("lobes.shd");
    std::fs::write(&shader, shadec::bench::adaptive_crossover::phong_lobes(16)).unwrap();
    // wgpu's sparse frame and classification pay only on larger frames.
    for (backend, size) in [("cpu", "512x512"), ("wgpu", "1024x1024")] {
        let out = shadec()
            .args(["render", &scene, "--shader", shader.to_str().unwrap(), "--target", "wgsl"])
            .args(["--backend", backend, "--adaptive", "auto", "--size", size])
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{stdout}");
        // The CPU's reason is its cost model's prediction, wgpu's the crossover.
        assert!(
            stdout.contains("adaptive auto: adaptive shading (8.5 %, every 16 pixels): "),
            "{backend}: {stdout}"
        );
        assert!(stdout.contains("104 operations per fragment"), "{backend}: {stdout}");
        assert!(psnr_against_full(&stdout) >= 40.0, "{backend}: {stdout}");
    }
}

/// An example rendered on a scene of `scenes/` finds its own images beside
/// it (`examples/brick.png`), as `check` does: program files are looked
/// for beside the program, then beside the scene. It was a missing-image
/// error pointing at `scenes/brick.png` — the obvious first command ended
/// in an error. A file only beside the scene is still found, and one in
/// neither is named beside the program.
#[test]
fn an_example_on_a_scene_finds_its_images_beside_the_program() {
    let root = env!("CARGO_MANIFEST_DIR");
    let dir = tempfile::tempdir().unwrap();
    let render = |scene: &std::path::Path, shader: &std::path::Path| {
        shadec()
            .args(["render", "--size", "64x48", "--out"])
            .arg(dir.path().join("x.png"))
            .arg(scene)
            .arg("--shader")
            .arg(shader)
            .output()
            .unwrap()
    };
    let scene = std::path::Path::new(root).join("scenes/kilgard_torus.ron");
    let shader = std::path::Path::new(root).join("examples/texture.shd");
    let out = render(&scene, &shader);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(!stdout.contains("stand-in"), "{stdout}");
    // Only beside the scene: a program in another folder, the image beside a copy of the scene.
    let (programs, scenes) = (dir.path().join("programs"), dir.path().join("scenes"));
    std::fs::create_dir_all(&programs).unwrap();
    std::fs::create_dir_all(&scenes).unwrap();
    std::fs::copy(&shader, programs.join("t.shd")).unwrap();
    std::fs::copy(&scene, scenes.join("s.ron")).unwrap();
    let out = render(&scenes.join("s.ron"), &programs.join("t.shd"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let beside_program = programs.join("brick.png");
    assert!(stderr.contains(&format!("put the image at {}", beside_program.display())), "{stderr}");
    std::fs::copy(std::path::Path::new(root).join("examples/brick.png"), scenes.join("brick.png")).unwrap();
    let out = render(&scenes.join("s.ron"), &programs.join("t.shd"));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // A plan not made for the scene (`--no-specialize`) still finds it there.
    let out = shadec()
        .args(["render", "--no-specialize", "--size", "64x48", "--out"])
        .arg(dir.path().join("y.png"))
        .arg(scenes.join("s.ron"))
        .arg("--shader")
        .arg(programs.join("t.shd"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}
