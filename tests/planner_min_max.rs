//! `max` and `min` beyond a pass, split by GL's MAX and MIN blend
//! equations (EXT_blend_minmax, the GL 1.2 imaging subset's; GeForce 256
//! and GeForce3 have them, WebGPU's `max`/`min` blend operations too):
//! `C ← max(C, f)`, factors ignored. A `max` (`min`) chain is associative
//! and commutative, so it splits across passes as a sum does with ADD
//! blending: the first group replaces, the others are blended in. On an
//! 8-bit framebuffer it is exact, since the max of values clamped to
//! [0, 1] is the clamp of their max. Before, every program here was refused
//! on geforce256 (and the five-layer one and the sum past 1 on geforce3)
//! with "a part that cannot be divided further needs 3 texture units"
//! and a help saying blending splits only sums and products.
//!
//! The programs of `tests/data/min_max/` render alike on the CPU, wgpu
//! (lavapipe: the MAX/MIN blend state) and the independent reference on
//! every target their header names, and are refused on `multitexture`,
//! whose OpenGL 1.2.1 has no imaging subset.

use shadec::pipeline::Planned;
use shadec::profile::Profile;
use shadec::renderer::plan::compare;

use crate::planner_algebra::{f32_render, scene};
use crate::three_way_heldout::{held_out_everywhere_in, program_in};

held_out_everywhere_in!("min_max":
    brightest_of_three,
    darkest_of_five,
    base_under_brightest_light,
    max_of_a_sum_past_one,
);

fn program(name: &str) -> String {
    program_in("min_max", name)
}

pub(crate) fn compile(source: &str, target: &str) -> Result<Planned, Vec<shadec::diag::Diagnostic>> {
    let profile = Profile::builtin(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default()).map(|c| c.planned)
}

/// The blend of each pass of `source` planned on `target`.
fn blends(source: &str, target: &str) -> Vec<&'static str> {
    let planned = compile(source, target).unwrap_or_else(|e| panic!("refused on {target}: {e:#?}"));
    planned.plan.passes.iter().map(|p| p.blend.name()).collect()
}

/// Every pass realized on `target` (the plan validator), and the f32
/// render of its plan within 2/255 of the program's meaning and of the
/// `wgsl` plan's render (one pass there).
fn renders_as_the_meaning_and_wgsl(source: &str, target: &str) {
    let sc = scene("kilgard_torus.ron");
    let planned = compile(source, target).unwrap_or_else(|e| panic!("refused on {target}: {e:#?}"));
    let profile = Profile::builtin(target).unwrap();
    crate::differential::validate_plan(&planned, &profile).unwrap_or_else(|e| panic!("{target}: {e}"));
    let (program, _) = shadec::parser::check(source);
    let (written, _) = shadec::ir::lower(&program);
    let meaning = shadec::meaning::plan(&written, sc.lights.len()).unwrap();
    let wgsl = compile(source, "wgsl").unwrap();
    assert_eq!(wgsl.plan.passes.len(), 1, "one pass on wgsl");
    let image = f32_render(&planned, source, &sc);
    for (what, reference) in [("meaning", &meaning), ("wgsl plan", &wgsl)] {
        let e = compare(&f32_render(reference, source, &sc), &image);
        assert!(
            e.max_abs <= 2.0 / 255.0,
            "{target}: {:.1}/255 from the {what} over {} passes",
            e.max_abs * 255.0,
            planned.plan.passes.len()
        );
    }
    // Not a blank picture: the textures were read.
    let lit = image.to_rgba8().chunks_exact(4).filter(|p| p[..3].iter().any(|&c| c > 8)).count();
    assert!(lit > 100, "{target}: {lit} lit pixels");
}

/// Three light maps on a GeForce 256's two units: `max(L0, L1)` in one
/// pass, `L2` blended in by GL_MAX; one pass on a GeForce3.
#[test]
fn a_max_of_three_textures_splits_by_the_max_blend_on_geforce256() {
    let source = program("brightest_of_three");
    assert_eq!(blends(&source, "geforce256"), ["replace", "max"]);
    assert_eq!(blends(&source, "geforce3"), ["replace"]);
    renders_as_the_meaning_and_wgsl(&source, "geforce256");
    let planned = compile(&source, "geforce256").unwrap();
    assert!(planned.plan.approximations.is_empty(), "exact: no approximation");
    let state = planned.plan.passes[1].state.blend;
    assert_eq!(state.equation, shadec::pipeline::BlendEquation::Max);
    assert!(planned.plan.passes[1].reason.contains("split the max of 3 terms into 2 passes"));
}

/// Five layers: two passes on a GeForce3's four units (`min` of four,
/// then GL_MIN of the fifth), three on a GeForce 256.
#[test]
fn a_min_of_five_textures_splits_by_the_min_blend_on_both_geforces() {
    let source = program("darkest_of_five");
    assert_eq!(blends(&source, "geforce3"), ["replace", "min"]);
    assert_eq!(blends(&source, "geforce256"), ["replace", "min", "min"]);
    for target in ["geforce3", "geforce256"] {
        renders_as_the_meaning_and_wgsl(&source, target);
    }
}

/// A chain of seven: ⌈7/2⌉ passes on geforce256, ⌈7/4⌉ on geforce3,
/// however the chain nests.
#[test]
fn a_longer_max_chain_takes_one_pass_per_group_of_units() {
    let names = ["base", "brick", "paper", "wood", "layer", "decal", "lightmap"];
    let mut source = String::new();
    for (i, n) in names.iter().enumerate() {
        source += &format!("texture T{i} : 2d rgb8 bilinear repeat = image(\"examples/{n}.png\");\n");
    }
    source += "C δπx ← max(max(T0 δu x, max(T1 δu x, T2 δu x)), max(max(T3 δu x, T4 δu x), max(T5 δu x, T6 δu x)));\n";
    assert_eq!(blends(&source, "geforce256"), ["replace", "max", "max", "max"]);
    assert_eq!(blends(&source, "geforce3"), ["replace", "max"]);
    renders_as_the_meaning_and_wgsl(&source, "geforce256");
}

/// `Base · max(L0, L1, L2)`: the max split into two passes, then the base
/// modulated in (the product's head planned on its own).
#[test]
fn a_product_with_a_max_beyond_the_units_plans_the_max_first() {
    let source = program("base_under_brightest_light");
    assert_eq!(blends(&source, "geforce256"), ["replace", "max", "modulate"]);
    renders_as_the_meaning_and_wgsl(&source, "geforce256");
}

/// `max(A + B, D·E)`: the sum reaches 2 and is stored clamped; GL_MAX of
/// what is clamped is the clamp of the max, so the split is exact (the
/// meaning clamps once, at the end). The combiners compute no `max` of a
/// value past 1, so a GeForce3 takes two passes as well.
#[test]
fn a_max_split_is_exact_through_the_framebuffer_clamp() {
    let source = program("max_of_a_sum_past_one");
    for target in ["geforce256", "geforce3"] {
        assert_eq!(blends(&source, target), ["replace", "max"], "{target}");
        renders_as_the_meaning_and_wgsl(&source, target);
    }
}

/// A target whose blender has no MIN/MAX equations still refuses, and says
/// why: `multitexture` (OpenGL 1.2.1 without the imaging subset) has no
/// `max` in its texture environment and none in its blender.
#[test]
fn a_target_without_min_max_blending_refuses_saying_so() {
    let profile = Profile::builtin("multitexture").unwrap();
    assert!(!profile.blend_modes.iter().any(|b| b == "max" || b == "min"));
    for target in ["geforce256", "geforce3", "wgsl"] {
        let p = Profile::builtin(target).unwrap();
        assert!(["min", "max"].iter().all(|m| p.blend_modes.iter().any(|b| b == m)), "{target}");
    }
    let source = program("brightest_of_three");
    let refused = compile(&source, "multitexture").expect_err("multitexture has no max");
    let help = refused[0].help.clone().unwrap_or_default();
    assert!(help.contains("EXT_blend_minmax") && help.contains("multitexture does not have"), "{help}");
    let human = shadec::diag::SourceFile::new("brightest_of_three.shd", &source).render(&refused[..1], false);
    insta::assert_snapshot!("min_max_refused_on_multitexture", human);
}

/// A combiner target whose blender lacks MIN/MAX (a profile written
/// without them) refuses the chain as before, and its help says that the
/// blend equations would split it.
#[test]
fn a_combiner_profile_without_min_max_refuses_with_a_true_help() {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/geforce256.ron"))
        .unwrap()
        .replace(", \"min\", \"max\"]", "]")
        .replace("name: \"geforce256\"", "name: \"geforce256-no-minmax\"");
    let profile = Profile::from_ron(&text, "geforce256-no-minmax.ron").unwrap();
    assert!(!profile.blend_modes.iter().any(|b| b == "max"));
    let source = program("brightest_of_three");
    let refused =
        shadec::driver::compile(&source, &profile, &Default::default()).err().expect("no MAX blend: refused");
    let help = refused[0].help.clone().unwrap_or_default();
    assert!(
        help.contains("a `max` or `min` splits only with the MIN/MAX blend equations (EXT_blend_minmax)"),
        "{help}"
    );
    // The same profile plans a sum of three textures: only the max lacks.
    let sum = source.replace("max(max(L0 δu x, L1 δu x), L2 δu x)", "L0 δu x + L1 δu x + L2 δu x");
    assert!(shadec::driver::compile(&sum, &profile, &Default::default()).is_ok());
}

/// Light maps kept brightest and darkest by statements that blend what
/// `C` holds: `C ← L0·L1; C ← max(C, L2); C ← min(L0, C)`.
const BLENDED_BY_STATEMENTS: &str = "\
texture L0 : 2d rgb8 bilinear repeat = image(\"examples/lightmap.png\");
texture L1 : 2d rgb8 bilinear repeat = image(\"examples/decal.png\");
texture L2 : 2d rgb8 bilinear repeat = image(\"examples/layer.png\");
C δπx ← L0 δu x * L1 δu x;
C δπx ← max(C δπx, L2 δu x);
C δπx ← min(L0 δu x, C δπx);
";

/// A statement that writes the blend itself, `C ← max(C, f)` (`min`, the
/// framebuffer's colour either operand), is GL's MAX (MIN) blend equation
/// of `f` where the blender has it, as a `max` chain split across passes
/// is. Refused before on every target: "the framebuffer's colour is used
/// non-linearly" (blending computes `C·m + s`). Each statement its own
/// pass on geforce256 (`replace`, `max`, `min`: its two units hold no two
/// of them fused), rendering the program's meaning; refused on
/// multitexture, which has no MIN/MAX blend equations.
#[test]
fn a_statement_writing_max_of_the_framebuffer_plans_as_the_max_blend() {
    let sc = scene("kilgard_torus.ron");
    let (program, _) = shadec::parser::check(BLENDED_BY_STATEMENTS);
    let (written, _) = shadec::ir::lower(&program);
    let meaning = shadec::meaning::plan(&written, sc.lights.len()).unwrap();
    for target in ["geforce256", "geforce3", "wgsl"] {
        let planned = compile(BLENDED_BY_STATEMENTS, target).unwrap_or_else(|e| panic!("{target}: {e:#?}"));
        let profile = Profile::builtin(target).unwrap();
        crate::differential::validate_plan(&planned, &profile).unwrap_or_else(|e| panic!("{target}: {e}"));
        assert!(planned.plan.approximations.is_empty(), "{target}: exact");
        let e = compare(
            &f32_render(&meaning, BLENDED_BY_STATEMENTS, &sc),
            &f32_render(&planned, BLENDED_BY_STATEMENTS, &sc),
        );
        assert!(e.max_abs <= 2.0 / 255.0, "{target}: {:.1}/255 from the meaning", e.max_abs * 255.0);
    }
    assert_eq!(blends(BLENDED_BY_STATEMENTS, "geforce256"), ["replace", "max", "min"]);
    let planned = compile(BLENDED_BY_STATEMENTS, "geforce256").unwrap();
    let equations: Vec<_> = planned.plan.passes.iter().map(|p| p.state.blend.equation).collect();
    use shadec::pipeline::BlendEquation as E;
    assert_eq!(equations[1..], [E::Max, E::Min]);
    assert!(compile(BLENDED_BY_STATEMENTS, "multitexture").is_err(), "no MIN/MAX blend equations");
}
