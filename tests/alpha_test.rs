//! A discard `c ? a` on the register-combiner targets, as GL 1.x makes it
//! (`planner::alpha_test`): the condition is brought into the fragment's
//! alpha (the final combiner's G input, NV_register_combiners) and the
//! alpha test (`glAlphaFunc`, OpenGL 1.2.1, Section 4.1.4) drops the
//! fragments. The emitted setup says so; the `fixed9` executors — the CPU's
//! combiner emulator and wgpu's `--precision hardware` — drop by that test
//! on the alpha the emulated combiners compute, not by the IR's condition.

use shadec::numerics::Precision;
use shadec::pipeline::{AlphaTest, CompareFunc, Planned};
use shadec::profile::Profile;

const W: u32 = 96;
const H: u32 = 72;

/// Kilgard's torus lit by one light, its diffuse term a vertex colour.
const HEAD: &str = "vector N : normal;\nvector L : light(0);\ntexture Dec : 2d rgba8 bilinear clamp = image(\"missing-decal.png\");\nshader d : s → c = (0.8, 0.8, 0.8) * max(0, N·L);\n";

/// A colour-only framebuffer: the alpha carries the condition as written.
fn rgb8(body: &str) -> String {
    format!("framebuffer C : rgb8, depth;\n{HEAD}{body}")
}

fn scene_text() -> String {
    std::fs::read_to_string(format!("{}/scenes/kilgard_torus.ron", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

fn prepared(source: &str, target: &str) -> shadec::bench::Prepared {
    shadec::bench::Prepared::new("alpha", source, target, &scene_text())
        .unwrap_or_else(|e| panic!("{target}: {e}\n{source}"))
}

fn plan(source: &str, target: &str) -> Result<Planned, Vec<shadec::diag::Diagnostic>> {
    let profile = Profile::resolve(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default()).map(|c| c.planned)
}

fn cpu(p: &shadec::bench::Prepared, mode: Precision) -> Vec<u8> {
    p.renderer().unwrap().render(mode, W, H, &mut |_, _| {}).unwrap().image.to_rgba8()
}

/// Pixels not black (the background is cleared to 0).
fn drawn(rgba: &[u8]) -> Vec<bool> {
    rgba.chunks_exact(4).map(|p| p[..3].iter().any(|&c| c > 0)).collect()
}

fn count(v: &[bool]) -> usize {
    v.iter().filter(|b| **b).count()
}

/// The discard of a texture channel compared with a constant.
const DECAL_DISCARD: &str = "C δπx ← ((Dec δu x).g > 0.5) ? (Dec δu x).rgb * δ d s x;\n";

#[test]
fn a_discard_on_geforce3_emits_an_alpha_test() {
    for target in ["geforce3", "geforce256"] {
        let planned = plan(&rgb8(DECAL_DISCARD), target).unwrap_or_else(|d| panic!("{target}: {d:?}"));
        let pass = &planned.plan.passes[0];
        assert!(pass.fragment.condition.is_some(), "{target}");
        assert_eq!(
            pass.state.alpha_test,
            AlphaTest { func: CompareFunc::Greater, reference: 0.5 },
            "{target}"
        );
        // The alpha carries the condition, which the statement does not write.
        assert!(!pass.state.blend.write_mask[3], "{target}");
        // What a card is given: the setup and the test beside it.
        let dir = std::env::temp_dir().join(format!("shadec-alpha-{}-{target}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("discard.shd");
        // The CLI reads images: a generated texture stands in for the file.
        std::fs::write(&file, rgb8(DECAL_DISCARD).replace("image(\"missing-decal.png\")", "bumps(4)"))
            .unwrap();
        let run = crate::common::shadec(&[
            "compile",
            file.to_str().unwrap(),
            "--target",
            target,
            "--emit",
            "combiners",
        ]);
        assert_eq!(run.code, 0, "{target}: {}", run.stderr);
        assert!(
            run.stdout.contains("# glEnable(GL_ALPHA_TEST); glAlphaFunc(GL_GREATER, 0.5);"),
            "{target}:\n{}",
            run.stdout
        );
        // The final combiner's alpha is not the constant it was: it is the green the test reads.
        assert!(!run.stdout.contains("out.a = one;"), "{target}:\n{}", run.stdout);
        let rc1: String = run.stdout.split("!!VP1.0").next().unwrap().to_string();
        if target == "geforce3" {
            insta::assert_snapshot!("alpha_test_geforce3_decal_discard", rc1);
        }
        // The plan dump shows the state too.
        let ron =
            crate::common::shadec(&["compile", file.to_str().unwrap(), "--target", target, "--emit", "plan"]);
        assert!(
            ron.stdout.contains("alpha_test: AlphaTest(") && ron.stdout.contains("func: Greater"),
            "{}",
            ron.stdout
        );
    }
    // A programmable target keeps its discard in the shader: no alpha test.
    let wgsl = plan(&rgb8(DECAL_DISCARD), "wgsl").unwrap();
    assert!(wgsl.plan.passes[0].state.alpha_test.is_disabled());
    assert!(wgsl.plan.passes[0].fragment.condition.is_some());
}

/// The forms of a condition and the test each becomes: the constant on
/// either side, negated, a difference of two values.
#[test]
fn each_comparison_form_becomes_the_alpha_test_that_keeps_the_same_fragments() {
    let cases = [
        ("(Dec δu x).a > 0.25", CompareFunc::Greater, 0.25),
        ("(Dec δu x).a ≥ 0.75", CompareFunc::GreaterEqual, 0.75),
        ("0.25 < (Dec δu x).a", CompareFunc::Greater, 0.25),
        ("(Dec δu x).a < 0.5", CompareFunc::Less, 0.5),
        ("!((Dec δu x).a > 0.25)", CompareFunc::LessEqual, 0.25),
        // Out of [0, 1], or `≥ 0`: the clamped alpha cannot tell, a difference can.
        ("(Dec δu x).a ≥ 0", CompareFunc::LessEqual, 0.0),
        ("(Dec δu x).a > (Dec δu x).g", CompareFunc::Greater, 0.0),
    ];
    for (condition, func, reference) in cases {
        let source = rgb8(&format!("C δπx ← ({condition}) ? δ d s x;\n"));
        let planned = plan(&source, "geforce3").unwrap_or_else(|d| panic!("{condition}: {d:?}"));
        let pass = &planned.plan.passes[0];
        assert_eq!(pass.state.alpha_test, AlphaTest { func, reference }, "{condition}");
    }
}

/// Equalities with 0 or 1 are `GL_EQUAL`/`GL_NOTEQUAL` (negated, the
/// other one); two conditions joined by `AND`/`OR` are their 0/1 values'
/// product or clamped sum in alpha, kept above 0 — on both combiner
/// targets where the generator fits it (geforce3 here; geforce256 takes
/// the equalities, its 2 general combiners not the joined comparisons).
#[test]
fn equalities_and_joined_conditions_become_alpha_tests() {
    let cases = [
        ("(Dec δu x).a == 1", CompareFunc::Equal, 1.0, true),
        ("(Dec δu x).a != 0", CompareFunc::NotEqual, 0.0, true),
        ("0 == (Dec δu x).a", CompareFunc::Equal, 0.0, true),
        ("!((Dec δu x).a == 1)", CompareFunc::NotEqual, 1.0, true),
        ("(Dec δu x).g ≥ 0.5 AND (Dec δu x).r ≥ 0.5", CompareFunc::Greater, 0.0, false),
        ("(Dec δu x).g ≥ 0.5 OR (Dec δu x).r < 0.5", CompareFunc::Greater, 0.0, false),
    ];
    for (condition, func, reference, on_geforce256) in cases {
        let source = rgb8(&format!("C δπx ← ({condition}) ? δ d s x;\n"));
        let mut targets = vec!["geforce3"];
        if on_geforce256 {
            targets.push("geforce256");
        }
        for target in targets {
            let planned = plan(&source, target).unwrap_or_else(|d| panic!("{target}: {condition}: {d:?}"));
            let pass = &planned.plan.passes[0];
            assert_eq!(pass.state.alpha_test, AlphaTest { func, reference }, "{target}: {condition}");
        }
    }
}

/// The fixed9 render of a joined condition keeps about what f32 (which
/// evaluates the condition) keeps, and draws something but not all.
#[test]
fn a_joined_condition_drops_in_fixed9_what_f32_drops() {
    for c in ["(Dec δu x).g ≥ 0.5 AND (Dec δu x).r ≥ 0.5", "(Dec δu x).g ≥ 0.5 OR (Dec δu x).r ≥ 0.5"]
    {
        let p = prepared(&rgb8(&format!("C δπx ← ({c}) ? δ d s x;\n")), "geforce3");
        let (fixed9, float) = (drawn(&cpu(&p, Precision::Fixed9)), drawn(&cpu(&p, Precision::F32)));
        let all = drawn(&cpu(&prepared(&rgb8("C δπx ← δ d s x;\n"), "geforce3"), Precision::F32));
        assert!(count(&float) > 0, "{c}: draws nothing");
        if c.contains("AND") {
            assert!(count(&float) < count(&all), "{c}: {} of {}", count(&float), count(&all));
        }
        let differ = fixed9.iter().zip(&float).filter(|(a, b)| a != b).count();
        assert!(differ * 50 < count(&float), "{c}: {differ} pixels differ from f32's {}", count(&float));
    }
}

/// Two thresholds joined by `AND`/`OR` on geforce256: computed as 0/1
/// values and multiplied (or added) they need more general combiners than
/// its two, and were refused; one selects by the mux, the other's value
/// is tested (`a ? x : 0`, kept where `x` passes the test `b` is), so
/// they plan where the mux reads its value in one stage (a texel's alpha
/// or blue, which the alpha portion reads), each pass with its alpha
/// test, and the fixed9 render keeps about what f32 (which evaluates the
/// condition) keeps. Of the green and red channels it still needs more
/// than two general combiners (each moved into alpha through a dot
/// product first): refused, located, saying so.
#[test]
fn joined_conditions_plan_on_geforce256_through_one_mux() {
    let rg = rgb8("C δπx ← ((Dec δu x).g ≥ 0.5 AND (Dec δu x).r ≥ 0.5) ? δ d s x;\n");
    let Err(errors) = plan(&rg, "geforce256") else { panic!("planned, expected a refusal") };
    let d = errors.iter().find(|d| d.is_error()).unwrap();
    assert_eq!(d.code, "unsupported-discard");
    assert_ne!(d.primary.span, shadec::span::Span::DETACHED);
    assert!(d.message.contains("general combiners, the target has 2"), "{}", d.message);
    for c in ["(Dec δu x).a ≥ 0.5 AND (Dec δu x).b ≥ 0.3", "(Dec δu x).a < 0.5 OR (Dec δu x).b > 0.6"]
    {
        let source = rgb8(&format!("C δπx ← ({c}) ? δ d s x;\n"));
        let planned = plan(&source, "geforce256").unwrap_or_else(|d| panic!("{c}: {d:?}"));
        for pass in &planned.plan.passes {
            assert!(!pass.state.alpha_test.is_disabled(), "{c}");
        }
        let p = prepared(&source, "geforce256");
        let (fixed9, float) = (drawn(&cpu(&p, Precision::Fixed9)), drawn(&cpu(&p, Precision::F32)));
        let all = drawn(&cpu(&prepared(&rgb8("C δπx ← δ d s x;\n"), "geforce256"), Precision::F32));
        assert!(
            count(&float) > 0 && count(&float) < count(&all),
            "{c}: {} of {}",
            count(&float),
            count(&all)
        );
        let differ = fixed9.iter().zip(&float).filter(|(a, b)| a != b).count();
        assert!(differ * 50 < count(&float), "{c}: {differ} pixels differ from f32's {}", count(&float));
    }
}

/// An equality with a level between 0 and 1 is refused at the condition:
/// the 8-bit steps round 0.3 to 77/255, which the program's arithmetic
/// does not equal.
#[test]
fn an_equality_between_8_bit_steps_is_refused_located() {
    let source = rgb8("C δπx ← ((Dec δu x).a == 0.3) ? δ d s x;\n");
    for target in ["geforce3", "geforce256"] {
        let Err(errors) = plan(&source, target) else { panic!("{target}: planned, expected a refusal") };
        let d = errors.iter().find(|d| d.is_error()).unwrap();
        assert_eq!(d.code, "unsupported-discard", "{target}");
        assert_ne!(d.primary.span, shadec::span::Span::DETACHED, "{target}");
        assert!(d.message.contains("77 of 255"), "{target}: {}", d.message);
    }
    assert!(plan(&source, "wgsl").is_ok());
}

/// The alpha test, not the IR condition, decides in `fixed9`: the plan's
/// test changed to `GL_NEVER` draws nothing and to `GL_ALWAYS` draws the
/// whole torus, though the condition in the plan is the same; `f32`, which
/// evaluates the condition, does not change.
#[test]
fn the_emulated_alpha_decides_the_discard() {
    let mut p = prepared(&rgb8(DECAL_DISCARD), "geforce3");
    let as_planned = drawn(&cpu(&p, Precision::Fixed9));
    let float = drawn(&cpu(&p, Precision::F32));
    let state = p.planned.plan.passes[0].state.alpha_test;
    p.planned.plan.passes[0].state.alpha_test = AlphaTest { func: CompareFunc::Never, ..state };
    assert_eq!(count(&drawn(&cpu(&p, Precision::Fixed9))), 0, "GL_NEVER drops every fragment");
    assert_eq!(drawn(&cpu(&p, Precision::F32)), float, "f32 evaluates the condition");
    p.planned.plan.passes[0].state.alpha_test = AlphaTest { func: CompareFunc::Always, ..state };
    let everything = drawn(&cpu(&p, Precision::Fixed9));
    // The test as planned keeps part of the torus, and about what f32 keeps.
    assert!(
        count(&as_planned) > 0 && count(&as_planned) < count(&everything),
        "{} of {}",
        count(&as_planned),
        count(&everything)
    );
    let differ = as_planned.iter().zip(&float).filter(|(a, b)| a != b).count();
    assert!(differ * 50 < count(&float), "{differ} pixels differ from f32's {}", count(&float));
}

/// At the boundary the 8-bit alpha decides as the card does: `g > 0.3`
/// of the interpolated diffuse colour. 0.3·255 = 76.5, so the reference
/// is 77 steps and a fragment passes where its 8-bit green is 78 or more;
/// a green in (0.3, 77.5/255) passes the condition in f32 and fails the
/// test. The reference is the f32 picture: what it keeps, its green rounded.
#[test]
fn the_alpha_test_compares_in_8_bit_steps() {
    let source = rgb8("C δπx ← ((δ d s x).g > 0.3) ? δ d s x;\n");
    let p = prepared(&source, "geforce3");
    assert_eq!(
        p.planned.plan.passes[0].state.alpha_test,
        AlphaTest { func: CompareFunc::Greater, reference: 0.3 }
    );
    assert_eq!(p.planned.plan.passes[0].state.alpha_test.reference_steps(), 77);
    let float = cpu(&p, Precision::F32);
    let fixed9 = cpu(&p, Precision::Fixed9);
    let expected: Vec<bool> = float.chunks_exact(4).map(|px| px[1] > 77).collect();
    let got = drawn(&fixed9);
    let boundary = float.chunks_exact(4).filter(|px| px[1] == 77).count();
    assert!(boundary > 0, "the picture has fragments at the boundary");
    let differ = expected.iter().zip(&got).filter(|(a, b)| a != b).count();
    assert!(
        differ * 20 <= boundary,
        "{differ} pixels differ from the 8-bit prediction ({boundary} at the boundary)"
    );
    // f32 keeps the boundary fragments: the two executors differ exactly there.
    assert!(count(&drawn(&float)) >= count(&got) + boundary / 2);
}

/// An rgb value written as rgba (alpha 1): the combiners compute the
/// condition, 0 or 1, into alpha (their mux), and the test passes 1 — the
/// alpha written is the 1 the statement writes.
#[test]
fn an_rgb_discard_into_rgba_carries_the_condition_as_0_or_1() {
    let source = format!("framebuffer C : rgba8, depth;\n{HEAD}C δπx ← ((Dec δu x).g ≥ 0.5) ? δ d s x;\n");
    let p = prepared(&source, "geforce3");
    let pass = &p.planned.plan.passes[0];
    assert_eq!(pass.state.alpha_test, AlphaTest { func: CompareFunc::Greater, reference: 0.0 });
    assert!(pass.state.blend.write_mask[3]);
    let fixed9 = cpu(&p, Precision::Fixed9);
    let kept: Vec<&[u8]> = fixed9.chunks_exact(4).filter(|px| px[..3].iter().any(|&c| c > 0)).collect();
    assert!(!kept.is_empty());
    assert!(kept.iter().all(|px| px[3] == 255), "the kept fragments write alpha 1");
    let float = drawn(&cpu(&p, Precision::F32));
    let differ = drawn(&fixed9).iter().zip(&float).filter(|(a, b)| a != b).count();
    assert!(differ * 50 < count(&float), "{differ} of {}", count(&float));
}

/// A stencil write where a condition holds is a discard with no colour:
/// one alpha test state for both.
#[test]
fn a_stencil_write_on_combiner_targets_drops_by_the_alpha_test() {
    let source = format!(
        "framebuffer C : rgba8, depth, stencil;\n{HEAD}C δπx ← δ d s x;\nσ C δπx ← (σ C δπx) OR ((Dec δu x).g > 0.5);\n"
    );
    for target in ["geforce3", "geforce256"] {
        let planned = plan(&source, target).unwrap();
        let pass = &planned.plan.passes[1];
        assert_eq!(pass.state.blend.write_mask, [false; 4]);
        assert_eq!(
            pass.state.alpha_test,
            AlphaTest { func: CompareFunc::Greater, reference: 0.5 },
            "{target}"
        );
    }
    assert!(plan(&source, "wgsl").unwrap().plan.passes[1].state.alpha_test.is_disabled());
}

/// Where the statement writes the alpha itself (an rgba texel times a
/// colour) and the condition is another value, one alpha cannot hold both:
/// refused, located at the condition, with forms that plan.
#[test]
fn a_discard_whose_alpha_is_written_is_refused_located() {
    let source = format!(
        "framebuffer C : rgba8, depth, stencil;\n{HEAD}C δπx ← ((Dec δu x).g > 0.5) ? (Dec δu x * δ d s x);\n"
    );
    let dir = std::env::temp_dir().join(format!("shadec-alpha-refused-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("refused.shd");
    std::fs::write(&file, source.replace("image(\"missing-decal.png\")", "bumps(4)")).unwrap();
    let run = crate::common::shadec(&["check", file.to_str().unwrap(), "--target", "geforce3"]);
    assert_eq!(run.code, 1, "{}{}", run.stdout, run.stderr);
    let out = format!("{}{}", run.stdout, run.stderr).replace(dir.to_str().unwrap(), "DIR");
    let Some(at) = out.find("error[unsupported-discard]") else { panic!("{out}") };
    assert!(out.contains("refused.shd:6:9"), "{out}");
    insta::assert_snapshot!("alpha_test_refused_written_alpha", &out[at..]);
    // Each form the help names plans on the same target.
    let forms = [
        "framebuffer C : rgb8, depth;\nFB C δπx ← ((Dec δu x).g > 0.5) ? (Dec δu x * δ d s x);\n",
        "framebuffer C : rgba8, depth;\nFB C δπx ← ((Dec δu x).g ≥ 0.5) ? (Dec δu x).rgb;\n",
    ];
    for form in forms {
        let (fb, body) = form.split_once("FB ").unwrap();
        plan(&format!("{fb}{HEAD}{body}"), "geforce3").unwrap_or_else(|d| panic!("{form}: {d:?}"));
    }
    // The help's stencil form plans on the same target.
    let marked = format!(
        "framebuffer C : rgba8, depth, stencil;\n{HEAD}σ C δπx ← (σ C δπx) OR ((Dec δu x).g > 0.5);\nC δπx ← (σ C δπx) ? (Dec δu x * δ d s x);\n"
    );
    let planned = plan(&marked, "geforce3").unwrap();
    assert!(!planned.plan.passes[0].state.alpha_test.is_disabled());
    // The value's own alpha is the compared one: the alpha-tested decal plans.
    let own = format!("framebuffer C : rgba8, depth;\n{HEAD}C δπx ← ((Dec δu x).a > 0.5) ? Dec δu x;\n");
    let planned = plan(&own, "geforce3").unwrap();
    assert_eq!(
        planned.plan.passes[0].state.alpha_test,
        AlphaTest { func: CompareFunc::Greater, reference: 0.5 }
    );
    assert!(planned.plan.passes[0].state.blend.write_mask[3]);
}

/// The alpha-tested decal lit by an rgb shader, `((T).a > k) ? T * δ d s x`:
/// the value's alpha is `T.a · 1`, the compared alpha, so the first way
/// applies (it was refused, "the fragment's alpha is needed", because the
/// value's alpha was read as an opaque `(T * δ d s x).a`). It plans on
/// both combiner targets with `GL_GREATER 0.5` and the alpha written, and
/// the three executors keep the same fragments in fixed9.
#[test]
fn a_lit_alpha_tested_decal_tests_its_own_alpha() {
    let body = "C δπx ← ((Dec δu x).a > 0.5) ? (Dec δu x * δ d s x);\n";
    let source = format!("framebuffer C : rgba8, depth;\n{HEAD}{body}")
        .replace("missing-decal.png", concat!(env!("CARGO_MANIFEST_DIR"), "/examples/decal.png"));
    let gpu = crate::common::gpu::gpu();
    for target in ["geforce3", "geforce256"] {
        let planned = plan(&source, target).unwrap_or_else(|d| panic!("{target}: {d:?}"));
        let pass = &planned.plan.passes[0];
        assert_eq!(
            pass.state.alpha_test,
            AlphaTest { func: CompareFunc::Greater, reference: 0.5 },
            "{target}"
        );
        assert!(pass.state.blend.write_mask[3], "{target}");
        let scene = crate::three_way::scene("kilgard_torus.ron");
        let p = crate::three_way::render_three(&source, target, &scene, Precision::Fixed9, gpu.as_ref())
            .unwrap_or_else(|e| panic!("{target}: {e}"));
        crate::three_way::verdict(&p).unwrap_or_else(|e| panic!("{target}: {e}"));
        // The decal's alpha varies: the test drops some covered fragments, keeps others.
        let kept = drawn(&p.cpu).iter().zip(&p.covered).filter(|(d, c)| **d && **c).count();
        assert!(kept > 0 && kept < count(&p.covered), "{target}: {kept} of {} kept", count(&p.covered));
    }
}

/// The CPU's `fixed9` and wgpu's `--precision hardware` run the same setup
/// and the same test: they keep the same fragments.
#[test]
fn cpu_fixed9_and_wgpu_agree_on_a_discard() {
    let Some(gpu) = crate::common::gpu::gpu() else {
        panic!("no wgpu adapter: the suite needs lavapipe (see .ci/run)")
    };
    for (name, source) in [
        ("rgb8", rgb8(DECAL_DISCARD)),
        ("boundary", rgb8("C δπx ← ((δ d s x).g > 0.3) ? δ d s x;\n")),
        (
            "rgba 0/1",
            format!("framebuffer C : rgba8, depth;\n{HEAD}C δπx ← ((Dec δu x).g ≥ 0.5) ? δ d s x;\n"),
        ),
    ] {
        let p = prepared(&source, "geforce3");
        let cpu_image = cpu(&p, Precision::Fixed9);
        let plan = shadec::gpu::scene_run::ScenePlan::new(
            &p.planned,
            &p.program,
            Some(&source),
            Precision::Fixed9,
            &p.scene,
            &p.assets,
        )
        .unwrap();
        let frame = shadec::gpu::runner::Target::new(W, H);
        let gpu_image = plan.render_into(&gpu, &frame).unwrap().into_raw();
        let (a, b) = (drawn(&cpu_image), drawn(&gpu_image));
        let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
        assert!(count(&a) > 0, "{name}");
        assert!(
            differ * 100 <= count(&a),
            "{name}: {differ} of {} pixels kept by one and not the other",
            count(&a)
        );
    }
}

mod generated {
    use super::*;
    use proptest::prelude::*;

    fn condition() -> impl Strategy<Value = String> {
        let x = prop_oneof![
            Just("(Dec δu x).a".to_string()),
            Just("(Dec δu x).g".to_string()),
            Just("(δ d s x).r".to_string()),
            Just("max(0, N·L)".to_string()),
        ];
        let op = prop_oneof![Just(">"), Just("≥"), Just("<"), Just("≤"), Just("=="), Just("!=")];
        let k = prop_oneof![Just(0.0), Just(0.25), Just(0.5), Just(1.0), Just(-0.5), Just(1.5)];
        (x, op, k, any::<bool>(), any::<bool>()).prop_map(|(x, op, k, flip, negate)| {
            let c = if flip { format!("{k} {op} {x}") } else { format!("{x} {op} {k}") };
            if negate {
                format!("!({c})")
            } else {
                c
            }
        })
    }

    /// A comparison, or two joined by `AND`/`OR`.
    fn joined() -> impl Strategy<Value = String> {
        prop_oneof![
            2 => condition(),
            1 => (condition(), condition(), prop_oneof![Just("AND"), Just("OR")])
                .prop_map(|(a, b, j)| format!("({a}) {j} ({b})")),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]
        /// No pass on a combiner target keeps a discard without its alpha
        /// test: each plans with one, or is refused, located, as
        /// `unsupported-discard` (or another located refusal).
        #[test]
        fn no_combiner_pass_discards_without_an_alpha_test(c in joined(), rgba in any::<bool>()) {
            let fb = if rgba { "rgba8" } else { "rgb8" };
            let source = format!("framebuffer C : {fb}, depth;\n{HEAD}C δπx ← ({c}) ? δ d s x;\n");
            for target in ["geforce3", "geforce256"] {
                match plan(&source, target) {
                    Ok(planned) => {
                        for pass in &planned.plan.passes {
                            prop_assert!(
                                pass.fragment.condition.is_none() || !pass.state.alpha_test.is_disabled(),
                                "{target}: {source}"
                            );
                        }
                    }
                    Err(ds) => {
                        for d in &ds {
                            prop_assert!(d.primary.span != shadec::span::Span::DETACHED, "{target}: unlocated {:?}", d);
                        }
                    }
                }
            }
        }
    }
}
