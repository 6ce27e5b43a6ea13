//! Held-out user programs of the sixteenth session
//! (`tests/data/heldout_sixteenth/`), written as a new user would and not
//! among the examples: Gooch shading with a smoothstep rim, procedural
//! stripes (`fract`, `step`), a decal laid by `⊕[decal]` over lit wood,
//! textured Blinn-Phong, exponential fog per vertex, a light-0 program on
//! four lights, dot3 with a normalization cube map under `⊕`, two-sided
//! light with `sign`/`abs`, uniforms scaling a detail map at 2×, paper
//! `⊕[interpolate]` over wood plus an accumulated ambient, a computed
//! sphere-map reflection, three fixed-function layers (`⊕[add_signed]`, a
//! light map on the second coordinate set), a shadow map written `≤`, and
//! two explicit lights over a texture, two framebuffers composited by
//! alpha in a screen pass, lit values rendered into a texture and read
//! back, a stencil from a decal's alpha, a gloss map under `pow`, a
//! `.bgr` swizzle with luminance, and planar texgen from a position
//! vector, and two projections accumulated at half weight (`C δπ* x`
//! over `C δπx`: the `π*` pass draws the surface the `π` pass left in the
//! depth buffer, `Equal`, as the executors do not jitter `π*`). Each renders alike on the CPU, wgpu
//! and the independent reference on every target its header names
//! (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::held_out_everywhere_in;

held_out_everywhere_in!("heldout_sixteenth":
    gooch,
    stripes,
    decal_mode,
    blinn_tex,
    exp_fog,
    lights4_highlight,
    dot3_env,
    sign_abs,
    uniform_tint,
    paper_interp,
    mirror_sphere,
    layers3,
    shadow_lit,
    four_lights_tex,
    composite,
    rtt_blur,
    stencil_two,
    spec_gloss_pow,
    swizzle_bgr,
    texgen_planar,
    accum_blur,
);

/// `layers3`'s `Lm ⊕ (Layer ⊕[add_signed] Base)` plans on the combiner
/// targets (it was refused: "this value (range [0, 2]) may leave [−1, 1]"
/// on geforce3, "3 texture units" on geforce256): the stage computing the
/// sum applies `add_signed`'s −½ as its output bias, and GL's clamp of the
/// texture environment is the combiners' own. One pass on geforce3.
#[test]
fn a_fixed_function_add_signed_layer_plans_on_the_combiner_targets() {
    let source =
        std::fs::read_to_string(crate::three_way_heldout::data("heldout_sixteenth").join("layers3.shd"))
            .unwrap();
    for (target, passes) in [("geforce3", 1), ("geforce256", 2)] {
        let profile = shadec::profile::Profile::resolve(target).unwrap();
        let compiled = shadec::driver::compile(&source, &profile, &Default::default())
            .unwrap_or_else(|d| panic!("{target}: {:?}", d.iter().map(|d| &d.message).collect::<Vec<_>>()));
        assert_eq!(compiled.planned.plan.passes.len(), passes, "{target}");
    }
}

/// `rtt_blur`'s `Lit δu ← δ p s x` (a per-vertex value interpolated into a
/// texture) rasterizes the mesh in texture space, as `s δu` on the surface
/// does: it was planned as a quad over the texels, which has no vertices,
/// and the CPU executor panicked reading the interpolant.
#[test]
fn an_interpolated_value_rendered_into_a_texture_rasterizes_the_mesh() {
    let (_, compiled) = rtt_blur_on_wgsl();
    let first = &compiled.planned.plan.passes[0];
    assert!(matches!(first.geometry, shadec::pipeline::Geometry::Mesh { .. }), "{:?}", first.geometry);
}

/// The plan validator (`shadec::pipeline::validate`) refuses a pass over
/// texels or the screen — one rectangle, no vertices — whose fragment
/// stage reads an interpolant, located at the interpolated value; the CPU
/// executor and the wgpu scene runner refuse it too (the CPU executor
/// panicked indexing its empty varyings). The plan is `rtt_blur`'s with its
/// first pass (`Lit δu ← δ p s x`, which rasterizes the mesh in texture
/// space) turned into a quad over the texels, as the planner made it before.
#[test]
fn the_plan_validator_refuses_an_interpolant_on_a_quad() {
    use shadec::pipeline::Geometry;
    let (source, compiled) = rtt_blur_on_wgsl();
    let mut planned = compiled.planned;
    planned.validate().unwrap_or_else(|d| panic!("the planner's plan is valid: {:?}", d[0].message));
    for geometry in [Geometry::Texels, Geometry::Screen] {
        let first = &mut planned.plan.passes[0];
        first.geometry = geometry.clone();
        first.vertex.position = None;
        let errors = planned.validate().unwrap_err();
        assert_eq!(
            errors.len(),
            1,
            "{geometry:?}: {:?}",
            errors.iter().map(|d| &d.message).collect::<Vec<_>>()
        );
        let e = &errors[0];
        assert_eq!(e.code, "invalid-plan");
        assert!(e.message.contains("pass 1") && e.message.contains("no vertices"), "{}", e.message);
        // Located at the interpolated value of `Lit δu ← δ p s x`.
        let at = &source[e.primary.span.start as usize..e.primary.span.end as usize];
        assert!(at.contains("p s x"), "{geometry:?}: located at `{at}`");
        let sc = crate::three_way::scene("kilgard_torus.ron");
        let assets = sc.build().unwrap();
        let cpu = shadec::renderer::plan::PlanRenderer::new(&planned, &compiled.program, &sc, &assets);
        assert!(
            cpu.as_ref().is_err_and(|e| e.to_string().contains("no vertices")),
            "{geometry:?}: the CPU runs it"
        );
        let gpu = shadec::gpu::scene_run::ScenePlan::new(
            &planned,
            &compiled.program,
            Some(&source),
            shadec::numerics::Precision::F32,
            &sc,
            &assets,
        );
        assert!(
            gpu.as_ref().is_err_and(|e| e.to_string().contains("no vertices")),
            "{geometry:?}: wgpu runs it"
        );
    }
}

/// `rtt_blur`'s text, and it compiled for wgsl.
fn rtt_blur_on_wgsl() -> (String, shadec::driver::Compilation) {
    let source =
        std::fs::read_to_string(crate::three_way_heldout::data("heldout_sixteenth").join("rtt_blur.shd"))
            .unwrap();
    let profile = shadec::profile::Profile::resolve("wgsl").unwrap();
    let compiled = shadec::driver::compile(&source, &profile, &Default::default())
        .map_err(|d| d[0].message.clone())
        .unwrap();
    (source, compiled)
}
