//! The three executors on what `render` shows (issue 33, the twenty-first
//! session): an 8-bit render target stores 8-bit values on the CPU in f32
//! as on wgpu and in the reference (GL §2.13.9, §4.1.8: a colour written to
//! a fixed-point buffer is clamped and converted with round-to-nearest),
//! and the three-way runner compares the plan `render` draws — picked by
//! the one verdict on the scene —, not the planner's first plan.

use shadec::numerics::Precision;
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;

use crate::three_way::{largest, render_three, rendered_plan, scene, verdict, H, W};

/// A first pass writes 0.499 into an `rgba8` framebuffer, which stores
/// 127/255 (0.49804); a second pass reads it back and amplifies its
/// distance from 0.49 forty times: 40·(127/255 − 0.49) = 0.3216 (82/255),
/// where the unrounded value gives 0.36 (92/255). The CPU in f32 kept the
/// 8-bit target unrounded (92/255) where wgpu and the reference store 8
/// bits (82/255): 10/255 apart. Now the three agree within 1/255.
#[test]
fn a_second_pass_amplifying_an_8_bit_target_agrees_with_wgpu_and_the_reference() {
    let source = "framebuffer F : rgba8, depth;\nF δπx ← 0.499;\nC xs ← 40 * ((F xs) - 0.49);\n";
    let g = crate::common::gpu::gpu();
    let p = render_three(source, "wgsl", &scene("kilgard_torus.ron"), Precision::F32, g.as_ref()).unwrap();
    let compared = p.compared_mask();
    p.enough_compared().unwrap();
    let red = |img: &[u8]| (0..compared.len()).find(|&i| compared[i]).map(|i| img[4 * i]);
    eprintln!(
        "red: CPU {:?}, reference {:?}, wgpu {:?}",
        red(&p.cpu),
        red(&p.oracle),
        p.gpu.as_deref().map(red)
    );
    assert_eq!(red(&p.oracle), Some(82), "the reference stores 127/255 in F");
    let cpu = largest(&p.cpu, &p.oracle, &compared);
    assert!(cpu <= 1, "the CPU in f32 is {cpu}/255 from the reference");
    if let Some(gpu) = &p.gpu {
        assert!(p.gpu_refused.is_none());
        let apart = largest(&p.cpu, gpu, &compared);
        assert!(apart <= 1, "the CPU in f32 and wgpu are {apart}/255 apart");
    }
    verdict(&p).unwrap();
}

/// `render` plans `fragment_lighting.shd` on geforce256 by measuring its
/// lowerings on the scene: per-vertex shading (41/255 from the meaning on
/// the Kilgard torus) beats normalization cube maps with the power by
/// passes (56/255), which `driver::compile` without the scene takes (the
/// first lowering that plans). The three-way runner's `render_three`
/// renders — and the verdict compares — the plan `render` draws: its CPU
/// picture is that plan's, not the planner's first.
#[test]
fn the_three_way_runner_compares_the_plan_render_draws() {
    let source =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/fragment_lighting.shd"))
            .unwrap();
    let sc = scene("kilgard_torus.ron");
    let assets = sc.build().unwrap();
    let profile = Profile::resolve("geforce256").unwrap();
    let rules = |p: &shadec::pipeline::Planned| {
        let mut r: Vec<String> = p.plan.approximations.iter().map(|a| a.rule.clone()).collect();
        r.sort();
        r.dedup();
        r
    };
    let compiled = shadec::driver::compile(&source, &profile, &Default::default()).unwrap();
    let (rendered, program, _) = rendered_plan(&source, &profile, &sc, &assets, Precision::F32).unwrap();
    eprintln!("compile: {:?}; render: {:?}", rules(&compiled.planned), rules(&rendered));
    assert_ne!(rules(&compiled.planned), rules(&rendered), "the two plans are the same here");
    assert_eq!(rules(&rendered), ["per_vertex"]);

    let g = crate::common::gpu::gpu();
    let p = render_three(&source, "geforce256", &sc, Precision::F32, g.as_ref()).unwrap();
    let mut taken = p.rules.clone();
    taken.sort();
    taken.dedup();
    assert_eq!(taken, rules(&rendered));
    let draw = |planned: &shadec::pipeline::Planned| {
        PlanRenderer::new(planned, &program, &sc, &assets)
            .unwrap()
            .render(Precision::F32, W, H, &mut |_, _| {})
            .unwrap()
            .image
            .to_rgba8()
    };
    assert!(p.cpu == draw(&rendered), "the CPU picture is not the rendered plan's");
    assert!(p.cpu != draw(&compiled.planned), "the planner's first plan draws the same picture");
    verdict(&p).unwrap();
}

fn fragment_lighting() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/fragment_lighting.shd")).unwrap()
}

/// `render` draws a combiner target in fixed9, and measures the lowerings
/// it chooses among in the arithmetic it draws in. Per-fragment Blinn-Phong
/// (`fragment_lighting.shd`) on geforce3: in f32 Taylor renormalization is
/// the closest to the meaning (0.2/255 on the torus), but in fixed9 its
/// signed, range-compressed vectors lose bits a normalization cube map
/// keeps (35/255 against 24/255). Chosen by its f32 error and shown in
/// fixed9, the plan was further from the meaning than another `render`
/// could have drawn; now the plan drawn in fixed9 is the closest in fixed9
/// of those measured, and its recorded error says fixed9.
#[test]
fn render_in_fixed9_draws_the_lowering_closest_in_fixed9() {
    let source = fragment_lighting();
    let sc = scene("kilgard_torus.ron");
    let assets = sc.build().unwrap();
    let profile = Profile::resolve("geforce3").unwrap();
    let (in_f32, program, module) = rendered_plan(&source, &profile, &sc, &assets, Precision::F32).unwrap();
    let (in_fixed9, ..) = rendered_plan(&source, &profile, &sc, &assets, Precision::Fixed9).unwrap();
    let rules = |p: &shadec::pipeline::Planned| {
        let mut r: Vec<String> = p.plan.approximations.iter().map(|a| a.rule.clone()).collect();
        r.sort();
        r.dedup();
        r
    };
    eprintln!("f32: {:?}; fixed9: {:?}", rules(&in_f32), rules(&in_fixed9));
    assert_ne!(rules(&in_f32), rules(&in_fixed9), "the same lowering in f32 and fixed9");
    let error = |p: &shadec::pipeline::Planned| {
        crate::three_way::measured_error(p, &program, &module, (&sc, &assets), Precision::Fixed9).unwrap()
    };
    let (e32, e9) = (error(&in_f32), error(&in_fixed9));
    eprintln!(
        "in fixed9 at {W}×{H}: the f32 choice {:.1}/255, the fixed9 choice {:.1}/255",
        e32 * 255.0,
        e9 * 255.0
    );
    assert!(e9 < e32, "the plan chosen in fixed9 is no closer in fixed9 ({e9} ≥ {e32})");
    let measured = in_fixed9.plan.measured.as_ref().expect("the choice records its error");
    assert_eq!(measured.precision, Some(Precision::Fixed9));
    assert!(in_f32.plan.measured.as_ref().is_some_and(|m| m.precision.is_none()));
}

/// The three-way check in fixed9 compares the plan `render` draws in
/// fixed9 and holds it to its error measured in fixed9: chosen by its f32
/// error, `fragment_lighting.shd`'s plan on geforce3 (Taylor
/// renormalization, a per-vertex part) was held to its f32 error (under
/// 1/255) and drawn 35/255 from the meaning in fixed9.
#[test]
fn fragment_lighting_as_rendered_in_fixed9_agrees_three_ways() {
    let g = crate::common::gpu::gpu();
    let sc = scene("kilgard_torus.ron");
    let p = render_three(&fragment_lighting(), "geforce3", &sc, Precision::Fixed9, g.as_ref()).unwrap();
    eprintln!("rules {:?}, measured {:?}/255", p.rules, p.measured_error.map(|e| e * 255.0));
    crate::three_way_generated::fixed9_verdict(&p, &mut 0).unwrap();
}
