//! Held-out user programs of the eighteenth session
//! (`tests/data/heldout_eighteenth/`), written as a new user would and not
//! among the examples: Blinn-Phong through a normalization cube map, GL's
//! separate specular colour, a grey and a sepia screen pass, two-sided
//! diffuse, squared-exponential fog, the texture environment's decal and
//! signed-add modes, DOT3 bump mapping in the texture environment, three
//! named lights with their intensities, diffuse light from a panorama
//! indexed by the normal, a specular power through a baked 1-D table, a
//! translucent second draw, colour uniforms, a stencil window, two spot
//! lights per vertex, a baked checkerboard, a tinted cube-map reflection,
//! Phong's reflection-vector highlight per pixel and two lights
//! accumulated over one texture; then a soft two-tone by `smoothstep`,
//! `reflect()` into a panorama, a band chosen by two conditions, a
//! uniform exponent, top-level lets, four lights into a float framebuffer
//! tone-mapped in a screen pass, `min`/`clamp` of two lights, a 16-bit
//! texture with gloss in alpha, strand lighting from the tangent and
//! alpha written then read in a screen pass.
//! Each renders alike on the CPU, wgpu and the independent reference on
//! every target its header names (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::held_out_everywhere_in;

held_out_everywhere_in!("heldout_eighteenth":
    accum_two_lights_tex,
    blinn_ncube,
    checker_procedural,
    decal_mode,
    dot3_env,
    exponent_lookup,
    fog_exp2,
    glass_blend,
    grayscale_post,
    irradiance_env,
    reflect_tint,
    separate_specular,
    sepia,
    signed_detail,
    specular_power_pp,
    spot_cone,
    stencil_window,
    three_lights,
    two_sided,
    uniform_colour,
    alpha_out,
    cross_tangent,
    float_accum,
    min_clamp,
    reflect_fn,
    rgba16_tex,
    select_band,
    smooth_toon,
    top_lets,
    uniform_power,
    grey_in_place,
    contrast_in_place,
    toon_threshold,
);

/// `abs(N·L)` per fragment on geforce3: `max(0, x) + max(0, −x)`, two
/// unsigned mappings summed in one general combiner stage after `−x` is
/// copied to a register (Kilgard 2000, Table 3). It was refused per
/// fragment ("geforce3 cannot compute this per fragment") and computed per
/// vertex, 54.7/255 off the meaning on `lights_matte_floor.ron`, over the
/// per-vertex budget. The three-way test `two_sided` renders it.
#[test]
fn abs_of_a_dot_product_plans_per_fragment_on_geforce3() {
    let rules = geforce3_rules("two_sided.shd", &|s| s).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(rules.iter().all(|r| r == "range_compression"), "{rules:?}");
    // An argument the registers cannot hold is not exact per fragment.
    let wide = geforce3_rules("two_sided.shd", &|s| s.replace("abs(N·L)", "0.25 * abs(4 * (N·L))"));
    if let Ok(rules) = wide {
        assert!(
            rules.iter().any(|r| r != "range_compression"),
            "abs(4·N·L) cannot be exact per fragment: {rules:?}"
        );
    }
}

/// A screen pass reading its own framebuffer other than as a blend
/// (`C xs ← (C xs) * (C xs)`, a grey conversion in place) was refused on
/// every target ("framebuffer blending cannot express this: the
/// framebuffer's colour is used non-linearly"), though each pixel's new
/// value is a function of its old one. It now reads a copy: a pass
/// `C° xs ← C xs`, then the statement reading `C°`. The three-way tests
/// `contrast_in_place`, `grey_in_place` and `alpha_out` render it.
#[test]
fn a_screen_pass_reading_its_own_target_non_linearly_reads_a_copy() {
    let source = std::fs::read_to_string(
        crate::three_way_heldout::data("heldout_eighteenth").join("contrast_in_place.shd"),
    )
    .unwrap();
    for target in ["wgsl", "geforce3"] {
        let profile = shadec::profile::Profile::resolve(target).unwrap();
        let compiled = shadec::driver::compile(&source, &profile, &Default::default())
            .unwrap_or_else(|d| panic!("{target}: {:?}", d.iter().map(|d| &d.message).collect::<Vec<_>>()));
        let plan = &compiled.planned.plan;
        let targets: Vec<String> = plan
            .passes
            .iter()
            .map(|p| match &p.target {
                shadec::pipeline::RenderTarget::Framebuffer { name, .. } => name.clone(),
                other => format!("{other:?}"),
            })
            .collect();
        let reasons: Vec<&str> = plan.passes.iter().map(|p| p.reason.as_str()).collect();
        assert_eq!(
            reasons[1..],
            ["statement 2 (copy of C) as written", "statement 2 as written"],
            "{target}"
        );
        assert_eq!(targets.len(), 3, "{target}: {targets:?}");
        assert!(targets[1].starts_with("C°"), "{target}: the copy first: {targets:?}");
    }
    // A pass that blending expresses is not copied.
    let blend = source.replace("C xs ← (C xs) * (C xs);", "C xs ← 0.5 * (C xs);");
    let profile = shadec::profile::Profile::resolve("wgsl").unwrap();
    let compiled = shadec::driver::compile(&blend, &profile, &Default::default()).unwrap();
    assert_eq!(compiled.planned.plan.passes.len(), 2);
}

/// A select on a threshold other than 0 or ½ (`(d s > 0.3) ? a : b`, a
/// two-tone cel shade) per fragment on geforce3: the mux tests
/// `spare0.a ≥ ½`, so `x ≥ k` is `x + (½ − k) ≥ ½`, the offset a constant
/// colour (Kilgard 2000, Section 4.2.2). Only 0 and ½ were taken: the
/// statement fell back per vertex, 177/255 off on the torus, refused.
/// The three-way test `toon_threshold` renders it.
#[test]
fn a_threshold_select_plans_per_fragment_on_geforce3() {
    let rules = geforce3_rules("toon_threshold.shd", &|s| s).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(rules.iter().all(|r| r == "range_compression"), "{rules:?}");
}

/// The approximation rules of `name` (in `heldout_eighteenth`, rewritten by
/// `edit`) planned on geforce3 through `driver::compile`; `Err` with the
/// messages when it is refused.
fn geforce3_rules(name: &str, edit: &dyn Fn(String) -> String) -> Result<Vec<String>, Vec<String>> {
    let source =
        std::fs::read_to_string(crate::three_way_heldout::data("heldout_eighteenth").join(name)).unwrap();
    let profile = shadec::profile::Profile::resolve("geforce3").unwrap();
    shadec::driver::compile(&edit(source), &profile, &Default::default())
        .map(|c| c.planned.plan.approximations.iter().map(|a| a.rule.clone()).collect())
        .map_err(|d| d.iter().map(|d| d.message.clone()).collect())
}
