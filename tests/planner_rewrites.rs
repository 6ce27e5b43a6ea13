//! Refusals the hardware could plan (issue 34, the twelfth session): each
//! program is a held-out-style file in `tests/data/planner_heldout/`
//! (its header names the scene and what must happen per target), planned,
//! validated pass by pass and rendered against the independent reference
//! (`shadec::oracle`) in f32 and, on the combiner targets, in fixed9 —
//! as `planner_heldout` holds every program of the battery.

use crate::planner_heldout::outcomes;

fn holds(file: &str) {
    let failures: Vec<String> = outcomes(file)
        .into_iter()
        .filter_map(|(target, o)| match o {
            Ok(row) => {
                eprintln!("| {file} | {target} | {row} |");
                None
            }
            Err(e) => Some(format!("{file} on {target}: {e}")),
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// `4·Base·Detail·Lmap` on geforce256 (2 texture units): `Base·Detail`,
/// then a 2× modulation by `Lmap`, then by 1 — the scale after every
/// factor that brings the value down, where the clamps leave it exact
/// (was refused: "every split that fits is changed by the clamps").
#[test]
fn a_constant_past_two_times_three_maps_is_scaled_in_last() {
    holds("constant_times_three_maps.shd");
}

/// `3·Base·Detail·Lmap` into a framebuffer other than `C`, shown by a
/// screen pass: the scale 3 as 2, then 1.5.
#[test]
fn a_scaled_product_into_another_framebuffer_is_scaled_in_last() {
    holds("other_framebuffer_product.shd");
}

/// `C ← (C) ⊕ (A0·A1·A2 + B0·B1·B2)`: the blend's source is clamped (GL),
/// the sum of two multi-pass products is computed into a temporary, read
/// back saturated (an f32 temporary keeps what an 8-bit one clamps), and
/// modulated in, on geforce3 (`C ← (C) ⊕ (T1·T2·T3 + T3·T4·T5)` was
/// refused there and on geforce256). On geforce256 with six distinct
/// maps the sum is halved into one temporary and its second product goes
/// through another, nested (was refused with "the splits that fit would
/// store a value outside [0, 1]": the second temporary's read-back was
/// bounded by a texture's [0, 1], not by the ½ it holds).
#[test]
fn a_modulation_by_a_sum_of_multi_pass_products_goes_through_a_temporary() {
    holds("modulate_by_two_layer_products.shd");
}

/// `C ← C·(A0·A1·A2 + B0·B1·B2)` (arithmetic, up to 2): the temporary
/// holds half of each product, the blender modulates by twice it
/// (geforce3, and geforce256 through nested temporaries).
#[test]
fn a_product_with_a_sum_past_one_of_multi_pass_products_is_halved_into_a_temporary() {
    holds("multiply_by_two_layer_products.shd");
}

/// Further held-out-style programs: detail texturing doubled, a `mix`
/// inside a doubled product, four lights summed in a product plus gloss,
/// a product over a sum with a constant below 1.
#[test]
fn doubled_products_lerps_in_products_and_sums_of_lights_plan() {
    for file in [
        "detail_doubled_lit.shd",
        "mix_in_product_scaled.shd",
        "four_lights_and_gloss.shd",
        "product_over_sum_halved.shd",
    ] {
        holds(file);
    }
}

/// `C xs ← (C xs) * (p G xs)` with `G` a float G-buffer written only with
/// `δ s x` (a normal and a light direction): refused on wgsl, "its passes
/// would blend a term outside [0, 1]", while geforce3 planned it — the
/// lookups of an `rgba16f` texture were unbounded by their format, where
/// geforce3's lowering stores each member range-compressed in [−1, 1].
/// What the program reads back is bounded by what it wrote there (and
/// the 0 it was cleared to): `p` is in [0, 0.8], and the modulation is
/// exact on both.
#[test]
fn a_g_buffer_read_back_is_bounded_by_what_was_written() {
    holds("deferred_modulated_by_g_buffer.shd");
}

/// The bound is what was written, not a guess: a float texture written
/// with `4·T` modulates `C` by up to 4, which the blend's clamped source
/// cannot do exactly — still refused on wgsl, and planned once the
/// written value stays in [0, 1].
#[test]
fn a_texture_read_back_past_one_is_still_refused() {
    let source = |k: &str| {
        format!(
            "texture T : 2d rgb8;\ntexture G : 2d rgba16f nearest clamp;\n\
             G δπx ← rgba({k} * T δu x, 1);\nC δπx ← T δu x;\nC xs ← (C xs) * (G xs);\n"
        )
    };
    let wgsl = shadec::profile::Profile::builtin("wgsl").unwrap();
    assert!(shadec::compile(&source("4"), &wgsl).is_err());
    shadec::compile(&source("0.5"), &wgsl).unwrap_or_else(|d| panic!("{d:?}"));
}
