//! The planner's temporaries on wgpu: a render-to-texture split (a part
//! rendered into a frame-sized texture first, then read back at the pixel
//! and blended in, Kilgard 2000, Section 5) runs on the wgpu scene runner as
//! on the CPU, so the three-way comparison holds wgpu to such plans too.

use shadec::numerics::Precision;

use crate::three_way::{difference, render_three, scene, verdict};

/// A sum of two three-texture products on geforce256 (two texture units):
/// one product goes into a temporary (`a_temporary_keeps_its_term` in the
/// differential suite). The wgpu runner refused the plan before.
const TWO_PRODUCTS: &str = "texture A, B, D, G, H, I : 2d rgb8 = image(\"layer.png\");\n\
    C δπx ← (A δu x) * (B δu x) * (D δu x) + (G δu x) * (H δu x) * (I δu x);\n";

#[test]
fn a_plan_with_a_temporary_runs_on_wgpu_and_agrees_with_the_cpu() {
    let gpu = crate::common::gpu::gpu();
    let Some(gpu) = gpu.as_ref() else {
        panic!("no wgpu adapter: the suite needs lavapipe (see .ci/run)");
    };
    let profile = shadec::profile::Profile::builtin("geforce256").unwrap();
    let planned = shadec::driver::compile(TWO_PRODUCTS, &profile, &Default::default()).unwrap().planned;
    assert!(
        planned
            .plan
            .passes
            .iter()
            .any(|p| matches!(p.target, shadec::pipeline::RenderTarget::Temporary { .. })),
        "the plan renders into a temporary"
    );
    for precision in [Precision::Fixed9, Precision::F32] {
        let p = render_three(TWO_PRODUCTS, "geforce256", &scene("kilgard_torus.ron"), precision, Some(gpu))
            .unwrap();
        assert!(p.gpu_refused.is_none(), "{precision:?}: wgpu refused: {:?}", p.gpu_refused);
        let gpu_picture = p.gpu.as_ref().unwrap();
        let cg = difference(&p.cpu, gpu_picture, &p.covered);
        assert!(cg.within(), "{precision:?}: wgpu and the CPU differ: {cg:?}");
        verdict(&p).unwrap_or_else(|e| panic!("{precision:?}: {e}"));
    }
}
