//! Stencil writes as GL makes them (`planner::stencil`): a constant through
//! `GL_REPLACE`/`GL_ZERO`, and a condition through the fragments the alpha
//! test keeps (OpenGL 1.2.1, Section 4.1). A program that marks the stencil
//! where a condition holds and then draws where it is set must render what
//! the same program written with a discard renders — two mechanisms, one
//! picture — on the CPU, on wgpu and in the meaning.

use shadec::numerics::Precision;
use shadec::renderer::{CompareFunc, StencilOp};

const W: u32 = 96;
const H: u32 = 72;

const HEAD: &str = "vector N : normal;\nvector L : light(0);\nframebuffer C : rgba8, depth, stencil;\ntexture Dec : 2d rgba8 bilinear clamp = image(\"missing-decal.png\");\nshader d : s → c = (0.8, 0.8, 0.8) * max(0, N·L);\nC δπx ← δ d s x;\n";
const CONDITION: &str = "(Dec δu x).g > 0.5";

fn scene_text() -> String {
    std::fs::read_to_string(format!("{}/scenes/kilgard_torus.ron", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

fn prepared(body: &str, target: &str) -> shadec::bench::Prepared {
    let source = format!("{HEAD}{body}");
    shadec::bench::Prepared::new("stencil", &source, target, &scene_text())
        .unwrap_or_else(|e| panic!("{target}: {e}\n{source}"))
}

fn cpu(p: &shadec::bench::Prepared, mode: Precision) -> Vec<u8> {
    p.renderer().unwrap().render(mode, W, H, &mut |_, _| {}).unwrap().image.to_rgba8()
}

fn largest_difference(a: &[u8], b: &[u8]) -> u8 {
    a.iter().zip(b).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0)
}

/// The stencil pass of statement 2 (the first pass draws `d`).
fn stencil_pass(body: &str, target: &str) -> shadec::pipeline::Pass {
    let p = prepared(body, target);
    let pass = p.planned.plan.passes[1].clone();
    assert_eq!(pass.state.blend.write_mask, [false; 4], "{target}: no colour");
    assert!(pass.state.stencil.enabled, "{target}");
    pass
}

#[test]
fn stencil_writes_are_one_pass_each_on_every_target() {
    for target in ["wgsl", "geforce3", "geforce256"] {
        let one = stencil_pass("σ C δπx ← 1;\n", target);
        assert_eq!(
            (one.state.stencil.pass, one.state.stencil.reference),
            (StencilOp::Replace, 1),
            "{target}"
        );
        assert_eq!(one.state.stencil.func, CompareFunc::Always);
        assert!(one.fragment.condition.is_none());
        let zero = stencil_pass("σ C δπx ← 0;\n", target);
        assert_eq!(zero.state.stencil.pass, StencilOp::Zero, "{target}");
        let or = stencil_pass(&format!("σ C δπx ← (σ C δπx) OR ({CONDITION});\n"), target);
        assert_eq!((or.state.stencil.pass, or.state.stencil.reference), (StencilOp::Replace, 1), "{target}");
        assert!(or.fragment.condition.is_some(), "{target}: the condition keeps the fragments");
        assert!(!or.textures.is_empty(), "{target}: the condition's texture is bound");
        let and = stencil_pass(&format!("σ C δπx ← (σ C δπx) AND ({CONDITION});\n"), target);
        assert_eq!(and.state.stencil.pass, StencilOp::Zero, "{target}");
        assert!(and.fragment.condition.is_some(), "{target}");
        // Drawn before by statement 1: only the visible fragment writes.
        assert_eq!(and.state.depth.func, CompareFunc::Equal, "{target}");
    }
}

/// Marking where the condition holds and then drawing where the stencil is
/// set is a discard by the same condition.
#[test]
fn a_condition_written_to_the_stencil_selects_what_a_discard_selects() {
    let stencil = format!("σ C δπx ← {CONDITION};\nC δπx ← (σ C δπx) ? (Dec δu x * δ d s x);\n");
    let discard = format!("C δπx ← ({CONDITION}) ? (Dec δu x * δ d s x);\n");
    let cleared = format!(
        "σ C δπx ← 1;\nσ C δπx ← (σ C δπx) AND ({CONDITION});\nC δπx ← (σ C δπx) ? (Dec δu x * δ d s x);\n"
    );
    let reference = cpu(&prepared(&discard, "wgsl"), Precision::F32);
    for body in [&stencil, &cleared] {
        let p = prepared(body, "wgsl");
        assert_eq!(largest_difference(&cpu(&p, Precision::F32), &reference), 0, "CPU:\n{body}");
        let meaning = p.meaning().unwrap();
        let exact = cpu(&meaning, Precision::Exact);
        assert!(largest_difference(&exact, &reference) <= 1, "meaning:\n{body}");
        let Some(gpu) = crate::common::gpu::gpu() else { continue };
        let source = format!("{HEAD}{body}");
        let plan = shadec::gpu::scene_run::ScenePlan::new(
            &p.planned,
            &p.program,
            Some(&source),
            Precision::F32,
            &p.scene,
            &p.assets,
        )
        .unwrap();
        let image = plan.render(&gpu, W, H).unwrap();
        assert!(largest_difference(image.as_raw(), &reference) <= 1, "wgpu:\n{body}");
    }
    // The marked region is neither empty nor everything: the test can fail.
    let plain = cpu(&prepared("", "wgsl"), Precision::F32);
    assert_ne!(plain, reference);
}

/// A stencil value GL cannot store, and a condition written where the
/// stencil may already hold something, are refused by `check` at the
/// statement (file:line:col), with the forms that plan.
#[test]
fn stencil_writes_gl_cannot_make_are_refused_located() {
    let cases = [
        ("half", "σ C δπx ← 0.5;\n", ":7:1"),
        ("after_a_write", &*format!("σ C δπx ← 1;\nσ C δπx ← {CONDITION};\n"), ":8:1"),
    ];
    let dir = std::env::temp_dir().join(format!("shadec-stencil-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, body, at) in cases {
        let file = dir.join(format!("{name}.shd"));
        // `check` reads images: a generated texture stands in for the file.
        let head = HEAD.replace("image(\"missing-decal.png\")", "bumps(4)");
        std::fs::write(&file, format!("{head}{body}")).unwrap();
        let run = crate::common::shadec(&["check", file.to_str().unwrap(), "--target", "wgsl"]);
        let out = format!("{}{}", run.stdout, run.stderr);
        assert_eq!(run.code, 1, "{out}");
        assert!(out.contains("error[unsupported-stencil]: the stencil cannot be written so"), "{out}");
        assert!(out.contains(&format!("{name}.shd{at}")), "{at} in {out}");
        assert!(out.contains("help: write a constant"), "{out}");
    }
}
