//! Constructs the independent reference once refused, now evaluated from
//! the papers and the GL specification and held to `three_way`'s bound
//! against the CPU and wgpu:
//!
//! - fat textures (Pipeline Grammar, Section 3.3, eq. (5)-(6), and
//!   Section 3.7, eq. (14)-(15)): a bundle of shading parameters written
//!   into a texture, one image per member, read back member by member;
//! - a scene's dual-paraboloid environment map (Heidrich & Seidel 1999,
//!   Section 4.1): the reference builds both faces from the
//!   parameterization itself (the environment's radiance is the scene's
//!   data) and looks them up by direction.

use std::path::Path;

use shadec::numerics::Precision;
use shadec::scene::Scene;

use crate::three_way::{render_three, scene, verdict, Pictures};

fn example(name: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples").join(name)).unwrap()
}

/// Covered pixels whose reference colour is not black: a picture that
/// says something.
fn lit(p: &Pictures) -> usize {
    let compared = p.compared_mask();
    (0..compared.len()).filter(|&i| compared[i] && p.oracle[4 * i..4 * i + 3].iter().any(|&c| c > 8)).count()
}

/// Renders `source` three ways on wgsl in f32 and holds the verdict, on a
/// picture mostly lit; the pictures for more checks.
fn agrees(source: &str, sc: &Scene) -> Pictures {
    let g = crate::common::gpu::gpu();
    let p = render_three(source, "wgsl", sc, Precision::F32, g.as_ref()).unwrap_or_else(|e| panic!("{e}"));
    if let Some(why) = &p.gpu_refused {
        panic!("wgpu does not run it: {why}");
    }
    verdict(&p).unwrap_or_else(|e| panic!("{e}\n{source}"));
    assert!(lit(&p) * 2 >= p.compared(), "{} of {} compared pixels lit", lit(&p), p.compared());
    p
}

/// Deferred shading (`examples/deferred_shading.shd`): the four vectors
/// `N, L, V, H` rasterized into a float fat framebuffer `T δπx ← δ s x`,
/// then one screen pass `C xs ← p T xs` shading each pixel from its fat
/// texel. The reference stores each member's image and reads the members
/// the shader names; a picture with the highlight's member moved fails.
#[test]
fn deferred_shading_through_a_fat_framebuffer_agrees_three_ways() {
    let source = example("deferred_shading.shd");
    let mut p = agrees(&source, &scene("kilgard_torus.ron"));
    // The specular term alone moved: the comparison sees it.
    let other = source.replace("max(0, N·H)^24", "max(0, N·L)^24");
    let g = crate::common::gpu::gpu();
    let q = render_three(&other, "wgsl", &scene("kilgard_torus.ron"), Precision::F32, g.as_ref()).unwrap();
    p.cpu = q.cpu;
    assert!(verdict(&p).is_err(), "a picture shading with L for H passed");
}

/// A fat texture map (`examples/fat_texture_map.shd`): the vectors
/// shaded into a 256² float fat texture over the mesh's texture
/// coordinates (`T δu x ← δ s x`, eq. (15)), read back bilinearly at each
/// fragment and shaded there (`C δπx ← p T δu x`, eq. (14)).
#[test]
fn fat_texture_map_agrees_three_ways() {
    agrees(&example("fat_texture_map.shd"), &scene("kilgard_torus.ron"));
}

/// The torus with a scene texture `Env`: a dual-paraboloid map of the
/// procedural sky, `size`² per face.
fn paraboloid_scene(size: u32) -> Scene {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron"))
        .unwrap()
        .replace(
            "    objects: [",
            &format!("    textures: {{ \"Env\": DualParaboloid(size: {size}, sun: (0.3, 0.8, 0.5)) }},\n    objects: ["),
        );
    assert!(text.contains("DualParaboloid"), "the torus scene changed its layout");
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene/env.ron")).unwrap()
}

/// A scene's dual-paraboloid map bound to a program's cube texture and
/// looked up by the eye-space reflection vector, both filters, alone and
/// under a diffuse term: the reference's faces (its own parameterization,
/// eq. 5-7) agree with the CPU's and wgpu's. The map read at the normal
/// instead of the reflection fails the comparison.
#[test]
fn a_scenes_dual_paraboloid_map_agrees_three_ways() {
    let sc = paraboloid_scene(64);
    for filter in ["bilinear", "nearest"] {
        let source = format!(
            "vector R : reflection in eye;\nvector N : normal;\nvector L : light(0);\n\
             texture Env : cube rgb8 {filter} clamp = image(\"sky.png\");\n\
             shader d : s → scalar = 0.2 + 0.8 * max(0, N·L);\n\
             C δπx ← 0.3 * (δ d s x) + 0.7 * (Env δR s x);\n"
        );
        let p = agrees(&source, &sc);
        eprintln!("{filter}: {} of {} pixels compared", p.compared(), p.covered.len());
    }
    // The map read at the normal instead: the comparison sees it.
    let flipped = "vector R : normal in eye;\n\
        texture Env : cube rgb8 bilinear clamp = image(\"sky.png\");\n\
        C δπx ← Env δR s x;\n";
    let straight = "vector R : reflection in eye;\n\
        texture Env : cube rgb8 bilinear clamp = image(\"sky.png\");\n\
        C δπx ← Env δR s x;\n";
    let g = crate::common::gpu::gpu();
    let mut p = render_three(straight, "wgsl", &sc, Precision::F32, g.as_ref()).unwrap();
    verdict(&p).unwrap();
    p.cpu = render_three(flipped, "wgsl", &sc, Precision::F32, g.as_ref()).unwrap().cpu;
    assert!(verdict(&p).is_err(), "a map read at the normal passed");
}

/// The same map on the combiner targets in fixed9, where they plan the
/// lookup (a texture unit's cube lookup by the reflection vector).
#[test]
fn a_scenes_dual_paraboloid_map_agrees_in_fixed9() {
    let sc = paraboloid_scene(64);
    let source = "vector R : reflection in eye;\n\
        texture Env : cube rgb8 bilinear clamp = image(\"sky.png\");\n\
        C δπx ← Env δR s x;\n";
    let g = crate::common::gpu::gpu();
    for target in ["geforce3", "geforce256"] {
        let p = render_three(source, target, &sc, Precision::Fixed9, g.as_ref())
            .unwrap_or_else(|e| panic!("{target}: {e}"));
        assert!(lit(&p) * 2 >= p.compared(), "{target}: {} of {} lit", lit(&p), p.compared());
        crate::three_way_generated::fixed9_verdict(&p, &mut 0).unwrap_or_else(|e| panic!("{target}: {e}"));
    }
}

/// A fat texture declared `mipmap trilinear`, shaded over the torus's
/// texels and minified: each member's chain box filtered (the reference's
/// own, the CPU's and wgpu's `runner::mips` per array layer). On wgpu's GL
/// backend every level below 0 of the array's layers was black (the mip
/// pass read a layer through a 2-D view, which GL binds as the whole
/// array): wgpu was the odd one out by up to 162/255 on 95 % of the torus.
#[test]
fn a_mipmapped_fat_texture_agrees_three_ways() {
    let source = "vector N : normal in object;\nvector L : light(0) in object;\n\
        texture F : 2d rgba16f mipmap trilinear clamp;\n\
        shader p : s → c = (0.8, 0.7, 0.5) * (0.2 + 0.8 * max(0, N·L));\n\
        F δu x ← δ s x;\nC δπx ← p F δu x;\n";
    let p = agrees(source, &scene("kilgard_torus.ron"));
    assert!(p.ranged > 0, "no pixel compared against a level-of-detail range: not minified");
}

/// A G-buffer declared `rgba8` holds what an unsigned 8-bit texture holds:
/// the vectors' negative components clamp to 0 (the reference, and the
/// wgsl plan on the CPU and wgpu, agree). On geforce3 the planner split
/// the fat texture per member and range-compressed each, `(v + 1)/2`,
/// keeping the negative components: the same program rendered up to
/// 87/255 apart on 66 % of the torus there (CPU and wgpu agreed; the
/// reference was the odd one out). The split now stores the members of an
/// unsigned fat texture clamped, as the declaration says.
#[test]
fn an_rgba8_g_buffer_means_the_same_on_geforce3_as_on_wgsl() {
    let source = "vector N : normal in eye;\nvector L : light(0) in eye;\nvector V : view in eye;\n\
        vector H = normalize(L + V);\ntexture G : 2d rgba8 nearest clamp;\n\
        shader p : s → c = (0.7, 0.6, 0.5) * max(0, N·L) + (0.4, 0.4, 0.4) * max(0, N·H)^16;\n\
        G δπx ← δ s x;\nC xs ← p G xs;\n";
    let sc = scene("kilgard_torus.ron");
    agrees(source, &sc);
    let g = crate::common::gpu::gpu();
    let p = render_three(source, "geforce3", &sc, Precision::Fixed9, g.as_ref()).unwrap();
    crate::three_way_generated::fixed9_verdict(&p, &mut 0).unwrap_or_else(|e| panic!("geforce3: {e}"));
}
