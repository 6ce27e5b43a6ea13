//! Held-out user programs of the seventeenth session
//! (`tests/data/heldout_seventeenth/`), written as a new user would and
//! not among the examples: cel shading through a baked ramp indexed by
//! half-Lambert, wrap lighting, detail texturing at 2×, a light map plus a
//! dynamic light over one base, two spot lights with their intensity,
//! a rim term beside a light-0 diffuse on four lights, hemisphere ambient
//! in world space, lights 0 and 1 named, gloss in a texture's alpha, two
//! framebuffers cross-faded in a screen pass, Kilgard's bump-mapped
//! diffuse with its self-shadowing term, linear fog over two spots, an
//! exposure colour uniform, Schlick's Fresnel over an equirectangular
//! environment, an ambient pass then lights added, an alpha-tested cutout,
//! stencil shadow volumes drawn `¬σ`, a rendered frame overlaid in a
//! screen pass, a projected cookie, a shadow mask choosing a darker image
//! where shadowed, deferred shading with a rim, a toon outline and two
//! accumulated textures on four lights.
//! Each renders alike on the CPU, wgpu and the independent reference on
//! every target its header names (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::held_out_everywhere_in;
use shadec::numerics::Precision;

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
    exposure,
    env_fresnel,
    ambient_then_lights,
    cutout,
    shadow_vol,
    rtt_overlay,
    cookie_floor,
    mask_dark,
    deferred_rim,
    outline,
    accum_textures,
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

/// Gouraud shading (`δ p s x`, a diffuse and a white highlight summed per
/// vertex, up to 1.8) on the combiner targets: GL clamps the interpolated
/// colour at each vertex (OpenGL 1.2.1, Section 2.13.9; on geforce3 the
/// vertex program's colour results, NV_vertex_program 2.14.1.5), so one
/// interpolant of the sum is not the program's meaning. The planner now
/// refuses such an interpolant on the register combiners as on the texture
/// environment, and the algebra splits the sum across δ: two interpolants
/// (the primary and secondary colours), each in [0, 1]. Before, geforce3
/// rendered the floor under the light 41/255 off the reference on 26 % of
/// pixels (CPU and wgpu alike, through the vertex program), while
/// geforce256's CPU path interpolated the sum unclamped.
#[test]
fn a_gouraud_sum_past_one_is_two_interpolants_on_the_combiner_targets() {
    let source = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/gouraud.shd"),
    )
    .unwrap();
    let scene = crate::three_way::scene("shadow_occluder_floor.ron");
    let g = crate::common::gpu::gpu();
    for target in ["geforce3", "geforce256"] {
        let profile = shadec::profile::Profile::resolve(target).unwrap();
        let compiled = shadec::driver::compile(&source, &profile, &Default::default()).unwrap();
        assert_eq!(compiled.planned.plan.passes.len(), 1, "{target}");
        assert_eq!(compiled.planned.plan.passes[0].vertex.interpolants.len(), 2, "{target}");
        for precision in [Precision::F32, Precision::Fixed9] {
            let p = crate::three_way::render_three(&source, target, &scene, precision, g.as_ref())
                .unwrap_or_else(|e| panic!("{target}: {e}"));
            let verdict = match precision {
                Precision::Fixed9 => crate::three_way_generated::fixed9_verdict(&p, &mut 0),
                _ => crate::three_way::verdict(&p),
            };
            verdict.unwrap_or_else(|e| panic!("{target} {precision:?}: {e}"));
        }
    }
}

/// A shadow mask that chooses *another* image where the mask is set,
/// `C xs ← (α C xs)*(C′ xs) + (1 − α C xs)*(C xs)`, is one blend
/// (GL_DST_ALPHA, GL_ONE_MINUS_DST_ALPHA), as the other way round
/// (`(α C)·C + (1 − α C)·C′`, GL_ONE_MINUS_DST_ALPHA, GL_DST_ALPHA) is. It
/// was refused on every target ("the framebuffer's alpha scales its own
/// colour"); `mask_dark` renders it alike three ways.
#[test]
fn a_mask_choosing_another_image_where_set_is_one_blend() {
    let source =
        std::fs::read_to_string(crate::three_way_heldout::data("heldout_seventeenth").join("mask_dark.shd"))
            .unwrap();
    for target in ["wgsl", "geforce3"] {
        let profile = shadec::profile::Profile::resolve(target).unwrap();
        let compiled = shadec::driver::compile(&source, &profile, &Default::default())
            .unwrap_or_else(|d| panic!("{target}: {:?}", d.iter().map(|d| &d.message).collect::<Vec<_>>()));
        let last = compiled.planned.plan.passes.last().unwrap();
        assert_eq!(last.blend, shadec::pipeline::BlendMode::DstAlphaLerp, "{target}");
    }
}
