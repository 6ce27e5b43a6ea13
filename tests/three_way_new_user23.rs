//! Held-out user programs of the twenty-third session
//! (`tests/data/heldout_twentythird/`), written as a new user would and
//! not among the examples: image-editing blends (screen, darken,
//! difference, overlay, contrast, brighten, invert, a channel swap),
//! Valve's half-Lambert, GL's RGB_SCALE 2, a grey and a sepia screen pass,
//! Schlick's Fresnel over a six-image cube map, a rim light, two-sided
//! diffuse, a gamma-encoded output, day and night textures blended by the
//! light, the GL material sum, height fog, the brighter of two lights,
//! three-band cel shading, a toon highlight, a soft terminator, three
//! textures multiplied, a decal blended over a lit surface and coloured
//! light by its intensity. Each renders alike on the CPU, wgpu and the
//! independent reference on every target its header names, and is refused
//! where its header says (`three_way_heldout::renders_alike_everywhere_in`).

use crate::three_way_heldout::{held_out_everywhere_in, program_in};
use shadec::diag::{Diagnostic, Severity};

held_out_everywhere_in!("heldout_twentythird":
    brighten_add,
    channel_swap,
    colored_lights,
    contrast,
    darken_min,
    decal_over,
    desaturate,
    difference_blend,
    emissive_sum,
    fresnel_env,
    gamma_out,
    half_lambert,
    hard_specular,
    height_fog,
    invert_lit,
    lerp_by_light,
    modulate2x,
    overlay_blend,
    rim_power,
    screen_blend,
    sepia,
    soft_terminator,
    three_band_cel,
    three_textures,
    two_lights_max,
    two_sided_abs,
);

/// The program of this session's folder ([`program_in`]).
fn program(name: &str) -> String {
    program_in("heldout_twentythird", name)
}

/// Every diagnostic `check` gives `source` on `target`.
fn checked(source: &str, target: &str) -> Vec<Diagnostic> {
    shadec::verdict::check(source, Some(target)).unwrap().diagnostics
}

/// The diagnostics of `source` on `target` that are errors or
/// approximations: none for a program the target computes exactly.
fn inexact(source: &str, target: &str) -> Vec<Diagnostic> {
    checked(source, target)
        .into_iter()
        .filter(|d| {
            d.severity == Severity::Error
                || d.code == "approximation" && !d.message.contains("`range_compression`")
        })
        .collect()
}

/// `min(a, b)` of two colours is `1 − ((1 − b) + max(0, b − a))` and
/// `max(a, b)` is `b + max(0, a − b)`, the `max(0, ·)` an unsigned input
/// mapping's clamp (Kilgard 2000, Table 3): a darken blend plans exactly on
/// both combiner targets in two general combiners. Before, "`min` cannot
/// be computed by the register combiners" refused it on both (the mux
/// selects whole scalars only).
#[test]
fn min_and_max_of_two_colours_are_an_unsigned_mapping_s_clamp() {
    let lighten = program("darken_min").replace("min(", "max(");
    for target in ["geforce256", "geforce3"] {
        for source in [program("darken_min"), lighten.clone()] {
            assert_eq!(inexact(&source, target), [], "{target}: {source}");
        }
    }
}

/// `abs(a − b)` is the sum of its halves `max(0, a − b) + max(0, b − a)`,
/// which the final combiner adds (C + D): a difference blend takes two
/// general combiners, so it plans on a GeForce 256. Before, the sum took a
/// third general combiner and geforce256 refused it.
#[test]
fn the_final_combiner_adds_the_halves_of_an_absolute_value() {
    assert_eq!(inexact(&program("difference_blend"), "geforce256"), []);
}

/// `saturate(1.5·(t − ½) + ½)` is `saturate(1.5·(t − ⅙))`: both offsets
/// added before one scale, the scale 1.5 a combiner's `scale_by_two` of
/// 0.75 (Kilgard 2000, Section 4.2). A contrast plans on a GeForce 256.
/// Before, the clamp rule took only a scale of 2 or 4 and a plain `x`, and
/// the value as written needed three general combiners.
#[test]
fn a_clamped_contrast_takes_both_offsets_inside_one_scale() {
    assert_eq!(inexact(&program("contrast"), "geforce256"), []);
    let steeper =
        "texture T : 2d rgb8 bilinear repeat = image(\"missing.png\");\nC δπx ← saturate(3 * T δu x - 1);\n";
    assert_eq!(inexact(steeper, "geforce256"), []);
}

/// A `step` of each channel of a colour is refused for the true reason:
/// the mux selects on one scalar. Before, the reason read "needs `step`
/// per fragment", though a scalar step is the mux.
#[test]
fn a_step_of_a_colour_is_refused_as_one_per_channel() {
    let refused = checked(&program("overlay_blend"), "geforce3");
    let error = refused.iter().find(|d| d.severity == Severity::Error).unwrap();
    assert!(error.message.contains("`step` of each channel of a vector"), "{}", error.message);
}

/// `max(x, k)` and `min(x, k)` with a constant are the same clamps, and
/// `clamp(x, lo, hi)` is `min(max(x, lo), hi)`: light clamped to a band
/// (`heldout_twentysecond/clamp_band`) plans exactly on geforce3 (was per
/// vertex), an ambient floor `max(t, 0.2)` on both combiner targets (was
/// "`max` cannot be computed by the register combiners").
#[test]
fn a_constant_floor_or_ceiling_is_a_clamp_too() {
    let band = program_in("heldout_twentysecond", "clamp_band");
    assert_eq!(inexact(&band, "geforce3"), []);
    let texture = "texture T : 2d rgb8 bilinear repeat = image(\"missing.png\");\n";
    for value in ["max(T δu x, 0.2)", "min(0.8, T δu x)"] {
        let source = format!("{texture}C δπx ← {value};\n");
        for target in ["geforce256", "geforce3"] {
            assert_eq!(inexact(&source, target), [], "{target}: {value}");
        }
    }
}
