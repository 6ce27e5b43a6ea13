//! Values named once and read many times are one node (hash-consing), so
//! a program of `n` lets can mean a value `2ⁿ` operations long written out
//! (`let a₁ = a₀·a₀; let a₂ = a₁·a₁; …`). Every target answers such
//! programs — a plan or a located refusal — without writing them out:
//! twenty-four squarings took 61 s and 6.5 GB on geforce256 before, forty
//! would not have ended.

use shadec::profile::Profile;

const TARGETS: [&str; 4] = ["wgsl", "geforce256", "geforce3", "multitexture"];

/// `a0 = first` and `n` lets after it, each the one before combined with
/// itself by `step`.
fn repeated(first: &str, step: &str, n: usize) -> String {
    let mut s = String::from("vector N : normal;\nvector L : light(0);\nshader p : s → c = max(0, N·L);\n");
    for t in 0..8 {
        s += &format!("texture T{t} : 2d rgba8;\n");
    }
    s += &format!("let a0 = {first};\n");
    for i in 1..=n {
        let prev = format!("a{}", i - 1);
        s += &format!("let a{i} = {};\n", step.replace("$", &prev).replace("#", &(i % 8).to_string()));
    }
    s + &format!("C δπx ← a{n};\n")
}

fn compile(src: &str, target: &str) -> Result<shadec::pipeline::PassPlan, Vec<shadec::diag::Diagnostic>> {
    shadec::compile(src, &Profile::builtin(target).expect("built in"))
}

#[test]
fn a_lookup_squared_forty_times_is_answered_on_every_target() {
    let src = repeated("T0 δu x", "$ * $", 40);
    assert!(compile(&src, "wgsl").is_ok());
    for target in &TARGETS[1..] {
        let diags = compile(&src, target).expect_err(target);
        let e = diags.iter().find(|d| d.is_error()).expect("an error");
        // Located at the statement, naming the operations it would need.
        assert!(e.message.contains("40"), "{target}: {}", e.message);
        assert_ne!(e.primary.span, shadec::span::Span::DETACHED, "{target}: {}", e.message);
    }
}

#[test]
fn twelve_squarings_still_plan_on_the_combiners() {
    // 4 096 factors of one lookup: written out, as before.
    let src = repeated("T0 δu x", "$ * $", 12);
    for target in TARGETS {
        assert!(compile(&src, target).is_ok(), "{target}");
    }
}

#[test]
fn an_interpolated_value_squared_forty_times_plans_on_every_target() {
    let src = repeated("δ p s x", "$ * $", 40);
    for target in TARGETS {
        assert!(compile(&src, target).is_ok(), "{target}");
    }
}

#[test]
fn layers_nested_twelve_deep_plan_on_geforce3() {
    // The split search grows about 3.4× a level: eight levels did not end
    // in 20 s before the search budget (`SEARCH_BUDGET`), twelve plan.
    let src = repeated("T0 δu x", "lerp($, $ * T# δu x, 0.5)", 12);
    for target in ["wgsl", "geforce3"] {
        assert!(compile(&src, target).is_ok(), "{target}");
    }
}

#[test]
fn a_lookup_doubled_forty_times_plans_on_every_target() {
    // `a + a` forty times over is `2⁴⁰·T0`: counted, one term a blending
    // pass doubles at a time. Written out, seventeen doublings did not
    // end in a minute on geforce256 (every pair of 2¹⁶ terms was tried
    // as a lerp), and past 2¹⁶ terms the sum was refused.
    let src = repeated("T0 δu x", "$ + $", 40);
    for target in TARGETS {
        let plan = compile(&src, target).unwrap_or_else(|d| panic!("{target}: {d:?}"));
        assert!(plan.passes.len() <= 41, "{target}: {} passes", plan.passes.len());
    }
}

#[test]
fn a_sum_repeating_its_terms_plans_counted_not_written_out() {
    // Eight doublings written out are 256 terms, 128 passes of `T0 + T0`
    // on geforce256; counted, `256·T0`, a pass per doubling at most.
    let src = repeated("T0 δu x", "$ + $", 8);
    for target in ["geforce256", "geforce3"] {
        let plan = compile(&src, target).expect(target);
        assert!(plan.passes.len() <= 9, "{target}: {} passes", plan.passes.len());
    }
    // Three of one lookup, `3·T0`: one pass, as `3 * T0 δu x` is, where
    // written out the sum took two (on geforce256 and geforce3).
    let src = "texture T0 : 2d rgba8;\nC δπx ← T0 δu x + T0 δu x + T0 δu x;\n";
    for target in ["geforce256", "geforce3"] {
        assert_eq!(compile(src, target).expect(target).passes.len(), 1, "{target}");
    }
}

/// `p₀` a lit term and `n` shaders after it, each the one before applied
/// twice and the two combined by `op`.
fn shaders_applied_twice(op: &str, n: usize) -> String {
    let mut s =
        String::from("vector N : normal;\nvector L : light(0);\nshader p0 : s → scalar = max(0, N·L);\n");
    for i in 1..=n {
        s += &format!("shader p{i} : s → scalar = p{} s {op} p{} s;\n", i - 1, i - 1);
    }
    s + &format!("C δπx ← δ p{n} s x;\n")
}

#[test]
fn shaders_applied_twice_forty_deep_are_answered_on_every_target() {
    // Each shader inlined once per bundle: forty levels would inline 2⁴⁰
    // bodies written out (twenty took 13 s before, twenty-two 52 s).
    let src = shaders_applied_twice("*", 40);
    for target in TARGETS {
        assert!(compile(&src, target).is_ok(), "{target}");
    }
    // A sum of them, `2⁴⁰·max(0, N·L)` per vertex: answered at once (the
    // combiner targets' plans of a δ past 1 are another matter, CHANGELOG).
    let src = shaders_applied_twice("+", 40);
    assert!(compile(&src, "wgsl").is_ok());
    for target in &TARGETS[1..] {
        let _answered = compile(&src, target);
    }
}
