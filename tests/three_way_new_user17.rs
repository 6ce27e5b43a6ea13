//! Held-out user programs of the seventeenth session
//! (`tests/data/heldout_seventeenth/`), written as a new user would and
//! not among the examples: cel shading through a baked ramp indexed by
//! half-Lambert, wrap lighting, detail texturing at 2×, a light map plus a
//! dynamic light over one base, two spot lights with their intensity,
//! a rim term beside a light-0 diffuse on four lights, hemisphere ambient
//! in world space, lights 0 and 1 named, gloss in a texture's alpha, two
//! framebuffers cross-faded in a screen pass, Kilgard's bump-mapped
//! diffuse with its self-shadowing term, and linear fog over two spots.
//! Each renders alike on the CPU, wgpu and the independent reference on
//! every target its header names (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::held_out_everywhere_in;

held_out_everywhere_in!("heldout_seventeenth":
    toon_ramp,
    wrap_light,
    detail_2x,
    lightmap_plus_dynamic,
    spot_intensity,
    rim_four,
    hemisphere,
    two_lights_named,
    gloss_alpha_mt,
    crossfade,
    self_shadow_bump,
    fog_linear_two,
);

/// Kilgard's self-shadowing term `saturate(8·L.z)` (Kilgard 2000, Section
/// 2.4.1) beside the same interpolated `δ L` indexing a normalization cube
/// map plans per fragment on the combiner targets: the combiners read `L.z`
/// range-compressed while the cube map keeps its float coordinates. It was
/// refused ("an interpolated vec3 outside [0, 1] cannot be computed by the
/// register combiners") and fell back to per-vertex shading over the
/// budget: one interpolant read both ways was compressed for neither.
#[test]
fn a_light_vector_indexing_a_cube_map_and_read_as_a_value_plans_per_fragment() {
    let source = std::fs::read_to_string(
        crate::three_way_heldout::data("heldout_seventeenth").join("self_shadow_bump.shd"),
    )
    .unwrap();
    for target in ["geforce256", "geforce3"] {
        let profile = shadec::profile::Profile::resolve(target).unwrap();
        let compiled = shadec::driver::compile(&source, &profile, &Default::default())
            .unwrap_or_else(|d| panic!("{target}: {:?}", d.iter().map(|d| &d.message).collect::<Vec<_>>()));
        let rules: Vec<&str> = compiled.planned.plan.approximations.iter().map(|a| a.rule.as_str()).collect();
        assert_eq!(rules, ["range_compression"], "{target}: only the light vector's compression");
    }
}
