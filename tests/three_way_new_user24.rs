//! Held-out user programs of the twenty-fourth session
//! (`tests/data/heldout_twentyfourth/`), written as a porting engineer
//! would write the fixed-function set-ups of other hardware: the Nintendo
//! 64's colour combiner `(A − B)·C + D` in one and two cycles, Direct3D's
//! texture-stage operations (ADDSIGNED, ADDSIGNED2X, MODULATE4X,
//! MODULATEALPHA_ADDCOLOR, MODULATEINVALPHA_ADDCOLOR, MULTIPLYADD, LERP),
//! NV_texture_env_combine4's `A·B + C·D`, the PlayStation 2's alpha blend
//! `(Cs − Cd)·As + Cd` (by the source alpha, additive, and by a fixed
//! alpha), the first PlayStation's semi-transparency modes, the
//! Dreamcast's MODULATE_ALPHA, the Xbox final combiner's fog and GL's
//! separate colour and alpha combine. Each renders alike on the CPU, wgpu
//! and the independent reference on every target its header names, and is
//! refused where its header says
//! (`three_way_heldout::renders_alike_everywhere_in`).

use crate::three_way_heldout::{held_out_everywhere_in, program_in};
use shadec::diag::{Diagnostic, Severity};

held_out_everywhere_in!("heldout_twentyfourth":
    combine4,
    d3d_addsigned,
    d3d_addsigned2x,
    d3d_blendfactoralpha,
    d3d_lerp3,
    d3d_modalpha_addcolor,
    d3d_modcolor_addalpha,
    d3d_modinvalpha_addcolor,
    d3d_multiplyadd,
    d3d_premultiplied,
    dc_modulate_alpha,
    gba_alpha_blend,
    gba_brighten,
    gba_darken,
    gba_uneven_blend,
    genesis_highlight,
    gouraud_alpha_replace,
    modulate4x,
    n64_env_decal,
    n64_lerp_shade,
    n64_prim_env,
    n64_two_cycle,
    ps1_quarter_add,
    ps1_subtract,
    ps2_additive,
    ps2_alpha_blend,
    ps2_fix_half,
    pvr_offset,
    q3_filter_2x,
    q3_soft_add,
    q3_three_stages,
    snes_half_add,
    tev_stage,
    xbox_final_fog,
);

/// The program of this session's folder ([`program_in`]).
fn program(name: &str) -> String {
    program_in("heldout_twentyfourth", name)
}

/// The diagnostics of `source` on `target` that are errors or
/// approximations: none for a program the target computes exactly.
fn inexact(source: &str, target: &str) -> Vec<Diagnostic> {
    shadec::verdict::check(source, Some(target))
        .unwrap()
        .diagnostics
        .into_iter()
        .filter(|d| {
            d.severity == Severity::Error
                || d.code == "approximation" && !d.message.contains("`range_compression`")
        })
        .collect()
}

/// The blend of each pass of `source`'s plan on `target`, by name.
fn blends(source: &str, target: &str) -> Vec<&'static str> {
    let profile = shadec::profile::Profile::resolve(target).unwrap();
    let judged = shadec::verdict::compile(source, &profile, &Default::default()).unwrap();
    judged.planned.plan.passes.iter().map(|p| p.blend.name()).collect()
}

/// The PlayStation 2's `(Cs − Cd)·As + Cd` over a lit surface is GL's
/// alpha blending (GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA) of `rgba(Cs, As)`:
/// two passes on a GeForce 256, exact. Before, the colour read as
/// `C δπx.rgb` hid the blend ("the framebuffer's colour is used
/// non-linearly"), and the two statements were fused with the lit term per
/// vertex, 10.9/255 from the meaning; with the read seen, the blend was a
/// modulation and an addition, three passes. Also with a fixed alpha ½
/// (the GS's FIX register), which folds into a constant coefficient.
#[test]
fn a_blend_by_the_source_alpha_written_as_arithmetic_is_alpha_blending() {
    for name in ["ps2_alpha_blend", "ps2_fix_half"] {
        let source = program(name);
        assert_eq!(inexact(&source, "geforce256"), [], "{name}");
        assert_eq!(blends(&source, "geforce256"), ["replace", "alpha_blend"], "{name}");
    }
    // A coefficient that is not one minus the added term's weight is no
    // alpha blend: the modulation and the addition stay.
    let other = program("ps2_fix_half").replace(") * 0.5 + C", ") * 0.5 + 0.9 * C");
    assert_ne!(blends(&other, "geforce256").last(), Some(&"alpha_blend"), "{other}");
}

/// `lerp(a, b, f)` by a colour `f` — Direct3D's D3DTOP_LERP with the third
/// texture a splat mask — is `a·(1 − f) + b·f` channel by channel, two
/// passes of two texture units each on a GeForce 256. Before, only a
/// scalar weight was written out, and the lerp of three textures was
/// refused ("a part that cannot be divided further needs 3 texture units")
/// though the same value written `a + (b − a)·f` planned.
#[test]
fn a_lerp_by_a_colour_weight_is_written_out_per_channel() {
    let source = program("d3d_lerp3");
    assert_eq!(inexact(&source, "geforce256"), [], "{source}");
    assert_eq!(blends(&source, "geforce256").len(), 2);
}

/// `a + b − ½` is one ADD_SIGNED stage of the texture environment
/// (ARB_texture_env_combine; Direct3D's D3DTOP_ADDSIGNED), which clamps
/// only its result: a detail texture added signed plans on `multitexture`
/// exactly, as `⊕[add_signed]` does. Before, the sum `a + b` (up to 2)
/// was judged a stage's result the environment clamps, and refused. Any
/// other offset is still such a sum.
#[test]
fn a_signed_add_written_as_arithmetic_is_one_texture_environment_stage() {
    let source = program("d3d_addsigned");
    assert_eq!(inexact(&source, "multitexture"), [], "{source}");
    let quarter = source.replace("− 0.5", "− 0.25");
    assert!(inexact(&quarter, "multitexture").iter().any(|d| d.severity == Severity::Error), "{quarter}");
}

/// `saturate(C − 0.5·T)` into an 8-bit framebuffer is the blend
/// GL_FUNC_REVERSE_SUBTRACT (EXT_blend_subtract) with GL's own clamp of
/// the blended result (OpenGL 1.2.1 §4.1.8): two exact passes on a GeForce
/// 256, as the same statement without `saturate` planned. Before, the
/// `saturate` hid the framebuffer read from the blend, and the pair was
/// fused with the lit term per vertex.
#[test]
fn a_saturate_of_a_blend_is_the_framebuffer_s_own_clamp() {
    let source = program("ps1_subtract");
    assert_eq!(inexact(&source, "geforce256"), [], "{source}");
    assert_eq!(blends(&source, "geforce256"), ["replace", "reverse_subtract"]);
}

/// Quake III's filter stage `blendFunc GL_DST_COLOR GL_SRC_COLOR`,
/// `2·C·T`, written with the colour read as `C δπx.rgb`: the blender's 2×
/// modulate of `T` (GL_DST_COLOR, GL_SRC_COLOR), exact. Before, the
/// coefficient `rgba(2·T, 1)` was halved as a whole (`rgba(2·T, 1)·½`,
/// whose constant 2 no combiner holds), and the pair fell back per vertex.
#[test]
fn a_doubled_modulation_of_the_colour_read_is_the_blender_s_2x_modulate() {
    let source = program("q3_filter_2x");
    assert_eq!(inexact(&source, "geforce256"), [], "{source}");
    assert_eq!(blends(&source, "geforce256"), ["replace", "modulate_2x"]);
}

/// The SNES's halved colour math `(C + T)/2` is affine in `C` through the
/// division (`C·½ + T/2`): a modulation and an addition, exact; and the
/// Game Boy Advance's uneven blend `saturate(¾·T + ½·C)` through the
/// `saturate` under the widening to rgba. Before, both were "used
/// non-linearly" and fell back per vertex.
#[test]
fn a_halved_or_clamped_sum_with_the_colour_read_is_a_blend() {
    for name in ["snes_half_add", "gba_uneven_blend"] {
        let source = program(name);
        assert_eq!(inexact(&source, "geforce256"), [], "{name}");
        assert_eq!(blends(&source, "geforce256"), ["replace", "modulate", "add"], "{name}");
    }
}

/// A GameCube TEV stage `2·(konst + lerp(a, b, c) − ¼)`: the two
/// constants in one register, so the lerp is one general combiner and the
/// sum with its scale the second — a GeForce 256's two. Before, the
/// constants took a combiner each and the pass needed three.
#[test]
fn constants_of_one_sum_share_one_combiner_register() {
    let source = program("tev_stage");
    assert_eq!(inexact(&source, "geforce256"), [], "{source}");
}
