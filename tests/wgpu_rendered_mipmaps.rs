//! Mip chains of rendered textures, on both executors: a texture declared
//! `mipmap` that a statement renders (texture shading, Pipeline Grammar,
//! eq. (13)) gets its chain box filtered from level 0 — the CPU through
//! `Texture2D::with_box_mipmaps`, wgpu through `runner::mips` — and a later
//! lookup minifies through it at the texture unit's level of detail.
//! Before, the CPU made the chain and sampled level 0, and wgpu made none.
//!
//! The reference (`shadec::oracle`) refuses rendered-texture statements, so
//! these pictures are compared between the CPU and wgpu, under the
//! three-way suite's bound.

use shadec::gpu::runner::{PassTarget, TextureData};
use shadec::gpu::scene_run::ScenePlan;
use shadec::numerics::Precision;
use shadec::pipeline::Planned;
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;

use crate::three_way::{difference, scene, PIXEL_TOLERANCE};

/// Small enough that the 256² texture is minified on most of the torus.
const W: u32 = 64;
const H: u32 = 48;

fn texture_shading() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/texture_shading.shd")).unwrap()
}

fn plan(source: &str, target: &str) -> Planned {
    let profile = Profile::resolve(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default()).unwrap().planned
}

/// The CPU's and wgpu's pictures (RGBA8), and whether wgpu sampled a chain.
fn pictures(
    source: &str,
    target: &str,
    precision: Precision,
    gpu: &shadec::gpu::runner::Gpu,
) -> (Vec<u8>, Vec<u8>, bool) {
    let planned = plan(source, target);
    let (program, _) = shadec::parser::check(source);
    let scene = scene("kilgard_torus.ron");
    let assets = scene.build().unwrap();
    let cpu = PlanRenderer::new(&planned, &program, &scene, &assets)
        .unwrap()
        .render(precision, W, H, &mut |_, _| {})
        .unwrap()
        .image
        .to_rgba8();
    let plan = ScenePlan::new(&planned, &program, Some(source), precision, &scene, &assets).unwrap();
    let passes = plan.passes(W, H).unwrap();
    let chain = passes.iter().any(|p| matches!(&p.target, PassTarget::Texture(t) if t.mip_levels > 1))
        && passes.iter().any(|p| {
            p.textures
                .iter()
                .any(|t| matches!(t.data, TextureData::Rendered { .. }) && t.sampler.mipmap.is_some())
        });
    let wgpu = plan.render(gpu, W, H).unwrap().into_raw();
    (cpu, wgpu, chain)
}

#[test]
fn a_rendered_mipmapped_texture_is_minified_through_its_chain_on_cpu_and_wgpu() {
    let gpu = crate::common::gpu::gpu().expect("no wgpu adapter: the suite needs lavapipe (see .ci/run)");
    let source = texture_shading();
    let level0 = source.replace("texture T : 2d rgba8 mipmap clamp;", "texture T : 2d rgba8 clamp;");
    assert_ne!(source, level0);
    let all = vec![true; (W * H) as usize];
    for (target, precision) in [("wgsl", Precision::F32), ("geforce3", Precision::Fixed9)] {
        let (cpu, wgpu, chain) = pictures(&source, target, precision, &gpu);
        assert!(chain, "{target}: wgpu rendered no chain, or did not sample it");
        let d = difference(&cpu, &wgpu, &all);
        // Without the chain (level 0 only), on both: the pictures differ,
        // so the chain was sampled.
        let (cpu0, wgpu0, chain0) = pictures(&level0, target, precision, &gpu);
        assert!(!chain0, "{target}: a chain for a texture not declared `mipmap`");
        let minified = difference(&cpu, &cpu0, &all);
        let minified_gpu = difference(&wgpu, &wgpu0, &all);
        eprintln!(
            "{target} {precision:?}: CPU/wgpu {d:?}; chain/level 0: CPU {minified:?}, wgpu {minified_gpu:?}"
        );
        assert!(d.within(), "{target}: the CPU and wgpu differ: {d:?} (tolerance {PIXEL_TOLERANCE}/255)");
        assert!(minified.max > PIXEL_TOLERANCE, "{target}: the CPU's chain changed nothing: {minified:?}");
        assert!(
            minified_gpu.max > PIXEL_TOLERANCE,
            "{target}: wgpu's chain changed nothing: {minified_gpu:?}"
        );
    }
}
