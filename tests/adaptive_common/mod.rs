//! Helpers of the adaptive-shading tests: load a scene, render it fully and adaptively.

#![allow(dead_code)]

use std::path::Path;

use shadec::renderer::lights::LitScene;
use shadec::renderer::{AdaptiveSettings, AdaptiveStats, ColorFormat, Framebuffer};
use shadec::scene::Scene;

pub fn lit(name: &str, cull: Option<f32>) -> (Scene, LitScene) {
    let scene = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)).unwrap();
    let assets = scene.build().unwrap();
    let lit = LitScene::new(&scene, &assets, cull);
    (scene, lit)
}

pub fn target(scene: &Scene) -> Framebuffer {
    Framebuffer::new(scene.resolution.0, scene.resolution.1, ColorFormat::F32).unwrap()
}

pub fn full(scene: &Scene, lit: &LitScene) -> Vec<[f32; 4]> {
    let mut fb = target(scene);
    lit.draw_full(&mut fb).unwrap();
    fb.to_rgba_f32()
}

pub fn adaptive(
    scene: &Scene,
    lit: &LitScene,
    settings: &AdaptiveSettings,
) -> (Vec<[f32; 4]>, AdaptiveStats) {
    let mut fb = target(scene);
    let stats = lit.draw_adaptive(&mut fb, settings).unwrap();
    (fb.to_rgba_f32(), stats)
}

pub fn max_diff(a: [f32; 4], b: [f32; 4]) -> f32 {
    (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max)
}
