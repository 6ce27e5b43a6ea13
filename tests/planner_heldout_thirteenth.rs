//! Held-out programs of the thirteenth session (issue 34): realistic
//! programs written for this battery, not copies of `examples/` — light
//! maps detail-mapped with three maps a term, cloud shadows and grime as
//! sums of three-map products modulated in, several vertex lights summed
//! inside one δ with a gloss map, fog lerped over a product, cutouts by
//! `==`, `!=`, `AND` and `OR` on the combiner targets, and a cutout at an
//! alpha level the 8-bit test cannot hold (refused, located). Each file
//! in `tests/data/planner_heldout_thirteenth/` declares its target
//! (`// target: X`), which must be one its `// expect X: plans` lines
//! name, and is held to those lines as `planner_heldout` holds its own:
//! planned, validated pass by pass, rendered in f32 (and fixed9 on the
//! combiner targets) against the independent reference within bounds,
//! or refused with the stated code at the stated place, with a help line.

use crate::planner_heldout::{cases_in, header, outcomes_of, Case, Expect};

const FOLDER: &str = "tests/data/planner_heldout_thirteenth";

fn case(name: &str) -> Case {
    cases_in(FOLDER)
        .into_iter()
        .find(|c| c.name == name)
        .unwrap_or_else(|| panic!("no held-out program `{name}`"))
}

/// The failures of `case` against its header, each target's row printed.
fn failures(case: &Case) -> Vec<String> {
    let declared =
        header(&case.source, "target:").pop().unwrap_or_else(|| panic!("{}: no `// target:`", case.name));
    let mut failures = Vec::new();
    if !case.expect.iter().any(|(t, e)| *t == declared && matches!(e, Expect::Plans)) {
        failures.push(format!(
            "{}: its declared target {declared} has no `// expect {declared}: plans`",
            case.name
        ));
    }
    for (target, outcome) in outcomes_of(case) {
        match outcome {
            Ok(row) => eprintln!("| {} | {target} | {row} |", case.name),
            Err(e) => failures.push(format!("{} on {target}: {e}", case.name)),
        }
    }
    failures
}

fn holds(name: &str) {
    let f = failures(&case(name));
    assert!(f.is_empty(), "{}", f.join("\n"));
}

/// Every program of the folder does what its header says.
#[test]
fn thirteenth_held_out_programs_plan_on_their_declared_targets() {
    let cases = cases_in(FOLDER);
    assert!(cases.len() >= 8, "{} programs", cases.len());
    let all: Vec<String> = cases.iter().flat_map(failures).collect();
    assert!(all.is_empty(), "{}", all.join("\n"));
}

/// Two detail-mapped, light-mapped layers (three maps a term) summed on
/// geforce256: each product in two passes, the second through a temporary.
#[test]
fn detail_mapped_light_maps_with_three_maps_a_term_plan_on_geforce256() {
    holds("detail_mapped_light_maps");
}

/// `C ← (C) ⊕ (A·B·D + E·F·G)` on geforce256: the sum halved into one
/// temporary, its second product through another (was refused with
/// "the splits that fit would store a value outside [0, 1]", untrue: the
/// second temporary holds at most ½).
#[test]
fn cloud_shadows_as_a_sum_of_three_map_products_modulate_on_geforce256() {
    holds("cloud_shadows_over_lit");
}

/// `C ← C·(A·B·D + E·F·G)`, arithmetic up to 2, on geforce256.
#[test]
fn grime_layers_multiply_through_nested_temporaries_on_geforce256() {
    holds("darkened_by_two_grime_layers");
}

/// Three lights inside one δ times a colour map, plus gloss·highlight.
#[test]
fn three_vertex_lights_in_one_delta_and_a_gloss_map_plan() {
    holds("three_vertex_lights_and_gloss");
}

/// Fog lerped over a product of three maps on geforce256.
#[test]
fn fog_lerped_over_a_three_map_product_plans_on_geforce256() {
    holds("fog_over_three_map_product");
}

/// `(Leaf).a == 1 ? …` and `(Grille).a != 0 ? Grille`: GL_EQUAL 1 and
/// GL_NOTEQUAL 0.
#[test]
fn cutouts_by_equality_plan_with_the_equal_and_not_equal_alpha_tests() {
    holds("leaf_cutout_equal_one");
    holds("holes_not_equal_zero");
}

/// `a AND b`, `a OR b` of two mask comparisons with ½: planned on
/// geforce3 (the 0/1 values' product or clamped sum in alpha); refused on
/// geforce256, located at the condition, whose 2 general combiners do not
/// hold the 5 stages the code generator needs.
#[test]
fn cutouts_by_and_and_or_of_two_masks_plan_on_geforce3_and_are_refused_located_on_geforce256() {
    holds("two_masks_and");
    holds("two_masks_or");
}

/// `(Bands).a == 0.3 ? …`: refused on the combiner targets at the
/// condition, the reason saying the 8-bit steps do not hold 0.3.
#[test]
fn a_cutout_at_an_alpha_level_between_steps_is_refused_at_the_condition() {
    holds("banded_cutout_refused");
    let c = case("banded_cutout_refused");
    let profile = shadec::profile::Profile::builtin("geforce3").unwrap();
    let Err(errors) = shadec::driver::compile(&c.source, &profile, &Default::default()) else {
        panic!("planned, expected a refusal")
    };
    let d = errors.iter().find(|d| d.is_error()).expect("an error");
    assert!(d.message.contains("8-bit steps") && d.message.contains("77 of 255"), "{}", d.message);
    let human = shadec::diag::SourceFile::new("banded_cutout_refused.shd", &c.source)
        .render(std::slice::from_ref(d), false);
    insta::assert_snapshot!("planner_refusal_alpha_equal_between_steps", human);
}
