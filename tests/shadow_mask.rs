//! The shadow mask as Pipeline Grammar, Section 3.5 prints it
//! (`examples/shadow_mask.shd`): its test compares the camera's depth
//! `z C xs` with the light's. GeForce3's depth textures compare only the
//! r/q of the coordinates they are read at (the point's own depth from the
//! light, with the light's q), so the printed form is refused there,
//! located, and the help's form (Williams 1978's test) plans; GeForce 256
//! had no depth textures: it refuses the printed form and plans Williams's
//! only as the alpha-ramp approximation.

use shadec::profile::Profile;

fn printed() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/shadow_mask.shd")).unwrap()
}

/// The printed test replaced by the form the help names.
fn williams() -> String {
    let source = printed();
    let from = "α C xs ← (z C xs) > (z Cl πl π⁻¹ xs);";
    assert!(source.contains(from));
    source.replace(from, "α C xs ← (z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + 0.002;")
}

fn plan(source: &str, target: &str) -> Result<shadec::pipeline::Planned, Vec<shadec::diag::Diagnostic>> {
    let profile = Profile::resolve(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default()).map(|c| c.planned)
}

fn line_col(source: &str, d: &shadec::diag::Diagnostic) -> (u32, u32) {
    let at = shadec::span::LineIndex::new(source).line_col(source, d.primary.span.start as usize);
    (at.line as u32, at.col as u32)
}

/// geforce3: refused at the test's statement; the help says why the
/// camera's depth cannot be compared and names Williams's test, which
/// then plans.
#[test]
fn shadow_mask_printed_form_is_refused_on_geforce3_and_the_helps_form_plans() {
    let source = printed();
    let Err(errors) = plan(&source, "geforce3") else { panic!("the printed form planned on geforce3") };
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(line_col(&source, &errors[0]), (31, 1));
    let help = errors[0].help.as_deref().unwrap_or("");
    assert!(help.contains("never the camera's depth `z C xs`"), "{help}");
    assert!(help.contains("(z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b"), "{help}");
    let planned = plan(&williams(), "geforce3").unwrap_or_else(|e| panic!("the help's form: {e:?}"));
    assert!(planned.plan.passes.len() >= 4, "{:#?}", planned.plan.passes);
}

/// geforce256: the printed form refused at its statement, the help
/// saying it had no depth textures and that Williams's test plans there
/// only as an approximation; Williams's form then plans, as the alpha
/// ramp (`alpha_ramp_shadow_map`, tests/shadow_map.rs).
#[test]
fn shadow_mask_printed_form_is_refused_on_geforce256_located() {
    let source = printed();
    let Err(errors) = plan(&source, "geforce256") else { panic!("planned on geforce256") };
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(line_col(&source, &errors[0]), (31, 1));
    let help = errors[0].help.as_deref().unwrap_or("");
    assert!(
        help.contains("geforce256 has no depth textures")
            && help.contains("Williams's test plans there only as an approximation"),
        "{help}"
    );
    let planned = plan(&williams(), "geforce256").unwrap_or_else(|e| panic!("Williams's form: {e:?}"));
    let rules: Vec<&str> = planned.plan.approximations.iter().map(|a| a.rule.as_str()).collect();
    assert_eq!(rules, ["alpha_ramp_shadow_map"]);
}
