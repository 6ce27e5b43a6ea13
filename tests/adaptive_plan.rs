//! Adaptive sample shading of a plan with one pass per light, end to end
//! (Adaptive Sample Shading, Section 2.1): the passes that draw the same
//! triangles over the same depth share one visibility, key and edge pass,
//! which must change nothing in the picture.

use crate::adaptive_common;

use std::path::Path;

use adaptive_common::{lit, target};
use shadec::driver::{compile, Compilation, ForScene, PlanOptions};
use shadec::numerics::Precision;
use shadec::renderer::plan::{compare, PlanRenderer};
use shadec::renderer::{draw, draw_adaptive, AdaptiveSettings, BlendState, DepthState, EdgeMode};
use shadec::scene::{Scene, SceneAssets};

/// `phong_lights.shd` planned for the 4-light sphere (one pass per light).
fn sphere_plan() -> (Scene, SceneAssets, Compilation) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = Scene::load(&root.join("scenes/adaptive_sphere_4lights.ron")).unwrap();
    let assets = scene.build().unwrap();
    let source = std::fs::read_to_string(root.join("tests/data/lights/phong_lights.shd")).unwrap();
    let profile = shadec::profile::Profile::builtin("wgsl").unwrap();
    let options = PlanOptions { scene: Some(ForScene::specialized(&scene, &assets)), ..Default::default() };
    let compiled = compile(&source, &profile, &options).unwrap();
    (scene, assets, compiled)
}

#[test]
fn four_light_plan_at_1024_is_within_40_db_of_full_shading() {
    let (scene, assets, compiled) = sphere_plan();
    assert_eq!(compiled.planned.plan.passes.len(), 4, "one pass per light");
    let renderer = PlanRenderer::new(&compiled.planned, &compiled.program, &scene, &assets).unwrap();
    let settings = AdaptiveSettings::new(16, 0.085, EdgeMode::Pass);
    let full = renderer.render(Precision::F32, 1024, 1024, &mut |_, _| {}).unwrap();
    let adaptive = renderer.render_adaptive(Precision::F32, 1024, 1024, &settings, &mut |_, _| {}).unwrap();
    let stats = adaptive.adaptive.unwrap();
    let e = compare(&full.image, &adaptive.image);
    println!(
        "plan sphere 1024²: {:.2} % shaded, PSNR {:.2} dB, {stats:?}",
        100.0 * stats.fraction_shaded(),
        e.psnr
    );
    assert!(e.psnr >= 40.0, "PSNR {:.2} dB < 40 dB", e.psnr);
    assert!(stats.fraction_shaded() < 0.05, "{stats:?}");
    assert_eq!(stats.shaded() + stats.interpolated, stats.covered);
    // The four passes, one per light, are one adaptive draw of their sum:
    // the sphere's pixels (those whose depth the first pass wrote) counted once.
    let image = &adaptive.image;
    let drawn = (0..1024).flat_map(|y| (0..1024).map(move |x| (x, y)));
    let written = drawn.filter(|&(x, y)| image.depth(x, y).is_some_and(|d| d < 1.0)).count();
    assert_eq!(stats.covered, written as u64, "{stats:?}");
}

#[test]
fn four_light_plan_at_threshold_zero_equals_full_shading_exactly() {
    let (scene, assets, compiled) = sphere_plan();
    let renderer = PlanRenderer::new(&compiled.planned, &compiled.program, &scene, &assets).unwrap();
    let settings = AdaptiveSettings::new(16, 0.0, EdgeMode::Pass);
    for _ in 0..2 {
        // Twice: the second frame's first pass must not take the last
        // frame's visibility (its depth buffer starts cleared again).
        let full = renderer.render(Precision::F32, 200, 150, &mut |_, _| {}).unwrap();
        let adaptive = renderer.render_adaptive(Precision::F32, 200, 150, &settings, &mut |_, _| {}).unwrap();
        assert!(
            full.image.to_rgba_f32() == adaptive.image.to_rgba_f32(),
            "{:?}",
            compare(&full.image, &adaptive.image)
        );
    }
}

#[test]
fn later_passes_equal_and_added_match_full_shading_exactly() {
    // A first pass `Less` with write, then two `Equal` passes added over
    // it (Kilgard 2000, Section 5): the third draws what the second drew,
    // the picture is full shading's bit for bit at threshold 0.
    let (scene, lit) = lit("adaptive_sphere_4lights.ron", None);
    let mut passes = lit.passes();
    let first = passes.remove(0);
    let mut later = lit.passes().remove(0);
    later.state.depth = DepthState::EQUAL_NO_WRITE;
    later.state.blend = BlendState::ADD;
    let (mut full, mut adaptive) = (target(&scene), target(&scene));
    let settings = AdaptiveSettings::new(8, 0.0, EdgeMode::Pass);
    let mut covered = Vec::new();
    for pass in [&first, &later, &later] {
        draw(&mut full, pass).unwrap();
        let stats = draw_adaptive(&mut adaptive, std::slice::from_ref(pass), &settings).unwrap();
        covered.push(stats.covered);
    }
    assert!(covered[0] > 0 && covered.iter().all(|&c| c == covered[0]), "{covered:?}");
    assert!(full.to_rgba_f32() == adaptive.to_rgba_f32());
}

#[test]
fn the_same_triangles_over_another_depth_are_not_taken_for_the_last_draw() {
    // The same pass twice: over a cleared depth buffer it covers the
    // sphere; over a depth buffer at 0 nothing passes `Less`, whatever the
    // last draw saw.
    let (scene, lit) = lit("adaptive_sphere_4lights.ron", None);
    let settings = AdaptiveSettings::new(16, 0.085, EdgeMode::Pass);
    let mut fb = target(&scene);
    let seen = draw_adaptive(&mut fb, &lit.passes(), &settings).unwrap();
    assert!(seen.covered > 10_000, "{seen:?}");
    let mut hidden = target(&scene);
    hidden.clear_depth(0.0);
    hidden.clear_color([0.25; 4]);
    let stats = draw_adaptive(&mut hidden, &lit.passes(), &settings).unwrap();
    assert_eq!(stats.covered, 0, "{stats:?}");
    assert!(hidden.to_rgba_f32().iter().all(|p| *p == [0.25; 4]));
    // And over a cleared one again, the first draw's picture.
    let mut again = target(&scene);
    let stats = draw_adaptive(&mut again, &lit.passes(), &settings).unwrap();
    assert_eq!(stats, seen);
    assert!(again.to_rgba_f32() == fb.to_rgba_f32());
}
