//! Signed textures as declared: `bumps()` in `signed16` is stored at 16 bits
//! (k/32767, the texture shader's signed HILO16 channels), in `signed8` at 8
//! (Kilgard's bytes expanded, (2b − 255)/255) — not both at 8.

use std::collections::BTreeMap;
use std::path::Path;

use shadec::scene::bind::{self, TextureQuality};
use shadec::textures::Texture;

const SCENE: &str =
    "(camera: (eye: (0.0, 0.0, 3.0), target: (0.0, 0.0, 0.0), up: (0.0, 1.0, 0.0)), objects: [])";

/// Every signed component of the stored `bumps(8)` of `format`.
fn stored_components(format: &str) -> Vec<f32> {
    let source =
        format!("texture B : 2d {format} = bumps(8);\nC δπx ← rgb(vec3((B δu x).x, (B δu x).y, 0));\n");
    let (program, diags) = shadec::parser::check(&source);
    assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
    let scene = shadec::scene::Scene::parse(SCENE, Path::new("")).unwrap();
    let decls = bind::texture_decls(&shadec::ir::lower(&program).0, &BTreeMap::new());
    let textures = bind::load_textures(&decls, &scene, TextureQuality::Stored, &mut Vec::new()).unwrap();
    let Texture::Flat(t) = &textures["B"].texture else { panic!("a 2-D texture") };
    t.levels[0].texels.iter().flat_map(|c| c[..3].to_vec()).collect()
}

fn on_grid(c: f32, steps: f32) -> bool {
    ((c * steps).round() - c * steps).abs() < 1e-3
}

#[test]
fn bumps_declared_signed16_are_stored_at_16_bits() {
    let wide = stored_components("signed16");
    assert!(wide.iter().any(|c| *c < -0.05), "signed: some components negative");
    assert!(wide.iter().all(|c| on_grid(*c, 32767.0)), "every component is k/32767");
    // 8-bit texels expand to (2b − 255)/255: a grid of 1/255.
    let off_8_bits = wide.iter().filter(|c| !on_grid(**c, 255.0)).count();
    assert!(off_8_bits * 2 > wide.len(), "{off_8_bits} of {} components finer than 8 bits", wide.len());
    // The same declaration in signed8 stays on the 8-bit grid.
    let narrow = stored_components("signed8");
    assert!(narrow.iter().all(|c| on_grid(*c, 255.0)));
    // And the two agree within the 8-bit format's step.
    let worst = wide.iter().zip(&narrow).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(worst <= 1.5 / 127.0, "worst difference {worst}");
}
