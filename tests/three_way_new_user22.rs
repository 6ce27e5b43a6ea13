//! Held-out user programs of the twenty-second session
//! (`tests/data/heldout_twentysecond/`), written as a new user would and
//! not among the examples: a rim light shaped by `smoothstep`, two-tone toon
//! and a hard terminator by `step`, stripes by `fract`, a directional light
//! given as a uniform or a constant direction, diffuse light clamped to a
//! band, GL's INTERPOLATE, SUBTRACT and BLEND texture environments, Phong in
//! ASCII, a logarithmic tone curve over a float framebuffer, colour bands by
//! a sine, a mask in C's alpha read by a screen pass, DOT3 against the
//! compressed light vector, attenuation by `rsqrt`, two lights by their
//! intensities, a panorama's reflection mixed over a lit texture, a decal
//! cut out by its alpha, a glow pass, a light map baked from a gradient,
//! hemisphere ambient light, a marble solid texture, a gloss map in alpha,
//! two statements from a static viewpoint, sphere-map texgen by hand, two
//! framebuffers mixed on screen and wrap lighting. Each
//! renders alike on the CPU, wgpu and the independent reference on every
//! target its header names, and is refused where its header says
//! (`three_way_heldout::renders_alike_everywhere_in`).

use crate::three_way_heldout::{held_out_everywhere_in, program_in};
use shadec::diag::{Diagnostic, Severity};

held_out_everywhere_in!("heldout_twentysecond":
    alpha_mask_pass,
    alpha_test_cutout,
    ascii_phong,
    blend_mode,
    clamp_band,
    const_dir,
    cube_reflect_mix,
    dot3_rgba,
    glow_pass,
    gradient_bake,
    hemi_ambient,
    interp_mode,
    log_tone,
    marble_solid,
    rsqrt_atten,
    sin_waves,
    smooth_rim,
    spec_alpha_gloss,
    static_view,
    step_shadow,
    step_toon,
    stripes_fract,
    subtract_mode,
    texgen_sphere_env,
    two_framebuffers_mix,
    two_intensity,
    uniform_dir,
    uniform_dir_normalized,
    wrap_diffuse_tex,
);

/// The program of this session's folder ([`program_in`]).
fn program(name: &str) -> String {
    program_in("heldout_twentysecond", name)
}

/// Every diagnostic `check` gives `source` on `target`.
fn checked(source: &str, target: &str) -> Vec<Diagnostic> {
    shadec::verdict::check(source, Some(target)).unwrap().diagnostics
}

/// The rules of the approximations `check` warns about (`per_vertex`, …);
/// panics on an error.
fn approximations(source: &str, target: &str) -> Vec<String> {
    let all = checked(source, target);
    let errors: Vec<_> = all.iter().filter(|d| d.severity == Severity::Error).collect();
    assert!(errors.is_empty(), "{target}: {errors:#?}");
    all.iter()
        .filter(|d| d.code == "approximation")
        .filter_map(|d| d.message.split('`').nth(1).map(String::from))
        .collect()
}

/// `step(e, x)` is the comparison `x ≥ e`, which the combiners' mux
/// selects (Kilgard 2000, Section 4.2.2): a two-tone toon and a hard
/// terminator plan per fragment on geforce3, only the signed vectors
/// range-compressed. Before, `step` was a function the combiners cannot
/// compute, so both fell back per vertex and were refused over the
/// budget (108 and 181/255 on the torus).
#[test]
fn step_is_a_comparison_the_combiners_mux_selects() {
    for name in ["step_toon", "step_shadow"] {
        let rules = approximations(&program(name), "geforce3");
        assert!(rules.iter().all(|r| r == "range_compression"), "{name}: {rules:?}");
    }
    // An edge that may be negative is no HALF_BIAS_NEGATE input: a table or
    // the fall-back, as before, and no panic.
    let negative_edge = "vector N : normal;\nvector L : light;\nvector V : view;\n\
                         shader t : s → scalar = step(N·V, N·L);\nC δπx ← t δ s x;\n";
    let verdict = checked(negative_edge, "geforce3");
    let inexact = verdict.iter().any(|d| {
        d.severity == Severity::Error
            || d.code == "approximation" && !d.message.contains("`range_compression`")
    });
    assert!(inexact, "an edge in [−1, 1] is no mux input as it is, so not exact: {verdict:#?}");
}

/// A constant direction with components of both signs is stored
/// range-compressed in a constant colour and read through `expand`
/// (Kilgard 2000, Section 5.2, Table 3). Before, "a constant with
/// components of both signs" sent the light per vertex.
#[test]
fn a_constant_direction_of_both_signs_is_an_expanded_constant_colour() {
    for target in ["geforce256", "geforce3"] {
        let rules = approximations(&program("const_dir"), target);
        assert_eq!(rules, ["range_compression"], "{target}");
    }
}

/// `normalize(Ld)` of a uniform direction is a value per object: computed
/// once on the host into a constant colour, not per fragment. Before, the
/// combiners' missing `normalize` sent the whole diffuse term per vertex.
/// The unnormalized uniform, unbounded, is told to read it so — and that
/// advice plans per fragment.
#[test]
fn a_uniform_direction_normalized_is_computed_once_on_the_host() {
    for target in ["geforce256", "geforce3"] {
        let rules = approximations(&program("uniform_dir_normalized"), target);
        assert_eq!(rules, ["range_compression"], "{target}");
        let unbounded = checked(&program("uniform_dir"), target);
        let warned = unbounded.iter().find(|d| d.code == "approximation").unwrap();
        let help = warned.help.as_deref().unwrap_or_default();
        assert!(help.contains("read it as `normalize(Ld)`"), "{target}: {help}");
    }
}

/// `δ (kd * max(0, N·L)) s x`: a parenthesized value applied to the
/// shading parameters is told to become a shader, and the help's program
/// checks clean. Before, the help said "to multiply, write `*` between
/// them", which does not give a program that means this.
#[test]
fn a_parenthesized_value_applied_to_the_shading_parameters_is_told_to_be_a_shader() {
    let written = "vector N : normal;\nvector L : light;\n\
                   C δπx ← δ (rgb(0.9, 0.8, 0.6) * max(0, N·L)) s x;\n";
    let errors = checked(written, "wgsl");
    assert_eq!(errors.len(), 1, "{errors:#?}");
    let help = errors[0].help.as_deref().unwrap_or_default();
    let declared = "shader p : s → c = (rgb(0.9, 0.8, 0.6) * max(0, N·L));";
    assert!(help.contains(declared) && help.contains("`p s x`"), "{help}");
    let fixed = format!("vector N : normal;\nvector L : light;\n{declared}\nC δπx ← δ p s x;\n");
    assert!(checked(&fixed, "wgsl").iter().all(|d| d.severity != Severity::Error));
    // A parenthesized value applied to a value is still told to multiply.
    let product = checked("C δπx ← (0.5) (0.2);\n", "wgsl");
    assert!(product[0].help.as_deref().unwrap_or_default().contains("write `*`"));
}

/// `x / k` for a constant `k` is the product `x · (1/k)`, and a constant
/// times a sum that leaves [−1, 1] is distributed into one portion, AB + CD
/// (Kilgard 2000, Section 4.2.2): wrap lighting `max(0, (N·L + ½)/1.5)`
/// plans exactly on both combiner targets. Before, the division sent it to
/// a table over an argument computed per vertex.
#[test]
fn a_division_by_a_constant_is_a_product_the_combiners_distribute() {
    for target in ["geforce256", "geforce3"] {
        let rules = approximations(&program("wrap_diffuse_tex"), target);
        assert!(rules.iter().all(|r| r == "range_compression"), "{target}: {rules:?}");
    }
}

/// `g(fract(t))` with `t` affine in interpolants (stripes `step(0.5,
/// fract(4·x))` of a position) is one period of `g` in a table read with
/// REPEAT wrap at `t`, interpolated exactly: stripes plan on geforce3 with
/// no per-vertex part, and the CPU reads the table repeating as wgpu and
/// the reference do (`stripes_fract` above). Before, `fract` of a
/// position went per vertex (175/255 from the meaning, refused), and the
/// CPU clamped a table the lowering made whatever its wrap.
#[test]
fn a_fractional_part_is_one_period_of_a_table_read_with_repeat() {
    let rules = approximations(&program("stripes_fract"), "geforce3");
    assert!(rules.contains(&"periodic_table".to_string()), "{rules:?}");
    assert!(rules.iter().all(|r| r == "periodic_table" || r == "range_compression"), "{rules:?}");
}

/// A bound where a value is computed is not stated as a bound at the
/// output when a step reads the value (contour lines: the periodic table
/// is within 1/255, the line's edge moves a whole step). Before, the
/// warning said "at most 1.0/255 at the output" beside a render 198/255
/// from the meaning at the lines' edges.
#[test]
fn a_bound_where_a_value_is_computed_is_not_stated_at_the_output_past_a_step() {
    let source = crate::three_way_heldout::program_in("heldout_twentyfirst", "contour_lines");
    let warned = checked(&source, "geforce3");
    let table = warned.iter().find(|d| d.message.contains("`periodic_table`")).unwrap();
    let help = table.help.as_deref().unwrap_or_default();
    assert!(help.contains("no bound at the output") && help.contains("measured"), "{help}");
    assert!(!help.contains("at the output: the rule's stated bound"), "{help}");
}
