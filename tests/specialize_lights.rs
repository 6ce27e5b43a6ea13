//! Scene-driven specialization with one pass per light and light culling
//! (issue 7 parts 1, 2 and 5): specialization never changes the image
//! beyond 1/255, light culling never drops a light that changes a pixel by
//! more than its threshold, and the removal report (snapshotted).

use std::path::{Path, PathBuf};
use std::process::Command;

use shadec::driver::{plan_pair, removal_report, ForScene, PlanOptions};
use shadec::pipeline::Planned;
use shadec::planner::DEFAULT_CULL_THRESHOLD;
use shadec::profile::Profile;
use shadec::renderer::plan::{compare, Mode, PlanRenderer};
use shadec::scene::Scene;

const SIZE: u32 = 64;
const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn files(dir: &str, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(Path::new(ROOT).join(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

fn scene(path: &Path) -> Scene {
    let text = std::fs::read_to_string(path).unwrap();
    // Anchored where no image files are: the stand-ins are used, as in CI.
    Scene::parse(&text, &Path::new("/nonexistent-shadec-scene").join(path.file_name().unwrap())).unwrap()
}

fn phong() -> String {
    std::fs::read_to_string(Path::new(ROOT).join("tests/data/lights/phong_lights.shd")).unwrap()
}

/// The program's own target, else wgsl.
fn profile_of(source: &str) -> Profile {
    let target = source
        .lines()
        .find_map(|l| l.trim().strip_prefix("target ").map(|t| t.trim_end_matches(';').trim().to_string()))
        .unwrap_or_else(|| "wgsl".into());
    Profile::resolve(&target).unwrap()
}

/// Renders a plan; `None` when the CPU renderer does not run it.
fn render(
    planned: &Planned,
    source: &str,
    scene: &Scene,
    mode: Mode,
) -> Option<shadec::renderer::Framebuffer> {
    let (program, _) = shadec::parser::check(source);
    let assets = scene.build().ok()?;
    let r = PlanRenderer::new(planned, &program, scene, &assets).ok()?;
    r.render(mode, SIZE, SIZE, &mut |_, _| {}).ok().map(|f| f.image)
}

/// Specialization (one pass per light in both; uniforms folded, zero terms
/// and culled lights removed in one) never changes the image beyond 1/255,
/// in f32 and fixed9, for every example on every scene it renders on.
#[test]
fn specialization_never_changes_an_example_scene_beyond_one_step() {
    let mut programs: Vec<(String, String)> = files("examples", "shd")
        .into_iter()
        .map(|p| {
            (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    programs.push(("tests/data/lights/phong_lights.shd".into(), phong()));
    let (mut compared, mut with_removals, mut with_culls) = (0, 0, 0);
    let mut worst = (0.0f32, String::new());
    for scene_path in files("scenes", "ron") {
        let sc = scene(&scene_path);
        for (name, source) in &programs {
            let profile = profile_of(source);
            let Ok((before, after)) = plan_pair(source, &profile, &sc, DEFAULT_CULL_THRESHOLD) else {
                continue;
            };
            for mode in [Mode::F32, Mode::Fixed9] {
                let Some(a) = render(&before, source, &sc, mode) else { continue };
                let b = render(&after, source, &sc, mode).unwrap_or_else(|| {
                    panic!("{name} on {}: the specialized plan does not render", scene_path.display())
                });
                let e = compare(&a, &b);
                let what = format!(
                    "{name} on {} ({})",
                    scene_path.file_name().unwrap().to_string_lossy(),
                    mode.name()
                );
                if e.max_abs > worst.0 {
                    worst = (e.max_abs, what.clone());
                }
                assert!(
                    e.max_abs <= 1.0 / 255.0 + 1e-6,
                    "{what}: specialization changed a pixel by {} (> 1/255); removed: {:#?}",
                    e.max_abs * 255.0,
                    after.plan.removed
                );
                compared += 1;
            }
            if !after.plan.removed.iter().all(|r| r.kind == "note") {
                with_removals += 1;
            }
            if after.plan.removed.iter().any(|r| r.kind == "light") {
                with_culls += 1;
            }
        }
    }
    eprintln!("{compared} renders compared; {with_removals} program × scene pairs with removals, {with_culls} with culled lights; worst {:.2}/255 ({})", worst.0 * 255.0, worst.1);
    assert!(compared >= 100, "most examples render on most scenes: only {compared} comparisons");
    assert!(
        with_removals >= 3 && with_culls >= 2,
        "removal actually happens: {with_removals} pairs with removals, {with_culls} with culled lights"
    );
}

/// Culling at a threshold changes no pixel by more than that threshold
/// (f32: the bound is exact arithmetic, clamping only shrinks a change),
/// and at larger thresholds more is culled.
#[test]
fn light_culling_never_drops_a_light_that_changes_a_pixel_by_more_than_the_threshold() {
    let source = phong();
    let profile = Profile::resolve("wgsl").unwrap();
    let (program, _) = shadec::parser::check(&source);
    let (module, _) = shadec::ir::lower(&program);
    for name in [
        "lights_matte_floor.ron",
        "lights_two_spots.ron",
        "adaptive_sphere_4lights.ron",
        "adaptive_cube_4lights.ron",
        "adaptive_spot_cutoff.ron",
    ] {
        let sc = scene(&Path::new(ROOT).join("scenes").join(name));
        let assets = sc.build().unwrap();
        let plan = |cull_threshold: Option<f64>| {
            let scene = ForScene { cull_threshold, ..ForScene::specialized(&sc, &assets) };
            let options = PlanOptions { scene: Some(scene), ..Default::default() };
            shadec::driver::plan(&module, &program, &profile, Some(&source), &options).unwrap()
        };
        let full = plan(None);
        let reference = render(&full, &source, &sc, Mode::F32).unwrap();
        let mut culled_before = 0;
        for threshold in [DEFAULT_CULL_THRESHOLD, 4.0 / 255.0, 0.05] {
            let culled = plan(Some(threshold));
            let n = culled.plan.removed.iter().filter(|r| r.kind == "light").count();
            let e = compare(&reference, &render(&culled, &source, &sc, Mode::F32).unwrap());
            eprintln!(
                "{name} at {threshold:.4}: {n} light × object pairs culled, max change {:.5}",
                e.max_abs
            );
            assert!(
                (e.max_abs as f64) <= threshold + 1e-5,
                "{name}: culling at {threshold} changed a pixel by {}",
                e.max_abs
            );
            assert!(n >= culled_before, "a larger threshold culls no less");
            culled_before = n;
        }
        if name == "lights_matte_floor.ron" {
            assert!(culled_before >= 5, "the floor scene has lights that cannot reach its objects");
        }
    }
}

/// The floor scene: the spot pointing away and the attenuated far light go
/// entirely, the light under the floor is drawn only for the ball, the
/// matte material loses its specular terms.
#[test]
fn floor_scene_removes_the_lights_that_cannot_reach() {
    let sc = scene(&Path::new(ROOT).join("scenes/lights_matte_floor.ron"));
    let profile = Profile::resolve("wgsl").unwrap();
    let (before, after) = plan_pair(&phong(), &profile, &sc, DEFAULT_CULL_THRESHOLD).unwrap();
    assert_eq!(
        before.plan.passes.iter().map(|p| p.light).collect::<Vec<_>>(),
        vec![Some(0), Some(1), Some(2), Some(3)],
        "one pass per light"
    );
    assert_eq!(
        after.plan.passes.iter().map(|p| (p.light, p.objects.clone())).collect::<Vec<_>>(),
        vec![(Some(0), None), (Some(2), Some(vec![1]))]
    );
    let culled: Vec<&str> =
        after.plan.removed.iter().filter(|r| r.kind == "light").map(|r| r.what.as_str()).collect();
    assert!(
        culled.iter().any(|w| w.starts_with("light 1 (spot)"))
            && culled.iter().any(|w| w.starts_with("light 3 (point)")),
        "{culled:?}"
    );
    let why = |prefix: &str| {
        after
            .plan
            .removed
            .iter()
            .find(|r| r.what.starts_with(prefix))
            .map(|r| r.why.clone())
            .unwrap_or_default()
    };
    assert!(why("light 2 (point) for object 0").contains("behind every face"));
    assert!(why("light 1 (spot) for object 1").contains("spot's cone"));
    assert!(why("light 3 (point) for object 1").contains("distance attenuation"));
    assert!(after.plan.removed.iter().any(|r| r.kind == "uniform" && r.what == "ks"));
}

#[test]
fn removal_report_snapshot() {
    let profile = Profile::resolve("wgsl").unwrap();
    let mut out = String::new();
    for name in ["lights_matte_floor.ron", "lights_two_spots.ron"] {
        let sc = scene(&Path::new(ROOT).join("scenes").join(name));
        let r = removal_report(&phong(), &profile, &sc).unwrap();
        out += &format!("## phong_lights.shd on {name}\n\n{}\n", r.to_markdown());
    }
    insta::assert_snapshot!(out);
}

#[test]
fn compile_with_scene_prints_the_culled_lights() {
    let out = Command::new(env!("CARGO_BIN_EXE_shadec"))
        .args([
            "compile",
            "tests/data/lights/phong_lights.shd",
            "--scene",
            "scenes/lights_matte_floor.ron",
            "--emit",
            "plan",
        ])
        .current_dir(ROOT)
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("light 1 (spot) for object 1 (sphere, material `matte`)"), "{err}");
    assert!(err.contains("light 3 (light culling)") || err.contains("statement 1 (light 3)"), "{err}");
    let plan = shadec::pipeline::PassPlan::from_ron(&String::from_utf8_lossy(&out.stdout)).unwrap();
    assert_eq!(plan.passes.len(), 2);
}
