//! Adaptive sample shading on the paper's 4-light sphere (seeds/004
//! Fig. 10-12): the fraction shaded and the error against full shading.

use std::path::Path;

use shadec::renderer::lights::LitScene;
use shadec::renderer::{image_error, AdaptiveSettings, ColorFormat, EdgeMode, Framebuffer};
use shadec::scene::Scene;

fn lit(name: &str, cull: Option<f32>) -> (Scene, LitScene) {
    let scene = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)).unwrap();
    let assets = scene.build().unwrap();
    let lit = LitScene::new(&scene, &assets, cull);
    (scene, lit)
}

fn target(scene: &Scene) -> Framebuffer {
    Framebuffer::new(scene.resolution.0, scene.resolution.1, ColorFormat::F32).unwrap()
}

#[test]
fn probe() {
    let (scene, lit) = lit("adaptive_sphere_4lights.ron", None);
    let mut full = target(&scene);
    lit.draw_full(&mut full).unwrap();
    full.save_png(Path::new("/tmp/sphere_full.png")).unwrap();
    for edges in [EdgeMode::Pass, EdgeMode::Triangle] {
        for t in [0.01, 0.02, 0.04, 0.085, 0.16] {
            let mut fb = target(&scene);
            let stats = lit.draw_adaptive(&mut fb, &AdaptiveSettings::new(16, t, edges)).unwrap();
            let e = image_error(&full.to_rgba_f32(), &fb.to_rgba_f32());
            println!("{edges:?} {t}: {:.2}% {stats:?} max {:.4} psnr {:.2}", 100.0 * stats.fraction_shaded(), e.max_abs, e.psnr);
        }
    }
}
