//! The pass contract (issue 35): every pass is resolved once into a typed
//! `pipeline::PassSetup` that `driver::plan` returns in `Planned`, and
//! every consumer reads it. The combiner setup of a pass is generated
//! once — when the plan is assembled on a combiner target, on first use of
//! the `fixed9` model elsewhere — and `compile`, `--emit combiners`, the
//! CPU renderer's `fixed9`, WGSL's `--fidelity hardware` and the language
//! server's hover all read that one (counted by
//! `pipeline::setup::generated_setups`, which every kept setup passes
//! through; `tests/layering.rs` checks that nothing else calls the
//! generator).

use std::path::Path;

use shadec::driver;
use shadec::numerics::Precision;
use shadec::pipeline::setup::generated_setups;
use shadec::pipeline::{Extent, Planned, TargetFormat, TargetKind, RENDERED_TEXTURE_SIZE};
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;
use shadec::scene::Scene;

fn kilgard() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/kilgard_bump_mapping.shd"))
        .unwrap()
}

fn scene() -> Scene {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap()
}

/// Every consumer of a pass's combiner setup, once each: `--emit
/// combiners`, a `fixed9` render on the CPU, the WGSL shaders in `fixed9`,
/// and a hover over every value of the program.
fn consume(planned: &Planned, source: &str) {
    for i in 0..planned.plan.passes.len() {
        let _ = driver::combiners_of(planned, i);
    }
    let (program, _) = shadec::parser::check(source);
    let scene = scene();
    let assets = scene.build().unwrap();
    PlanRenderer::new(planned, &program, &scene, &assets)
        .unwrap()
        .render(Precision::Fixed9, 32, 24, &mut |_, _| {})
        .unwrap();
    let _ = shadec::backends::wgsl::generate(planned, Some(source), Precision::Fixed9);
    for h in planned.module.exprs.arena().iter().map(|(h, _)| h) {
        let _ = shadec::lsp::hover::placement(planned, h, &planned.plan.target);
    }
}

#[test]
fn the_combiner_generator_runs_once_per_pass_for_compile_render_and_hover() {
    let source = kilgard();
    let geforce256 = Profile::builtin("geforce256").unwrap();
    let before = generated_setups();
    let planned = driver::compile(&source, &geforce256, &Default::default()).unwrap().planned;
    let passes = planned.plan.passes.iter().filter(|p| !p.baked).count();
    assert!(passes >= 2, "Kilgard's program plans into several passes on geforce256: {passes}");
    assert_eq!(generated_setups() - before, passes, "compile: one setup per pass");
    consume(&planned, &source);
    consume(&planned, &source);
    assert_eq!(generated_setups() - before, passes, "render, emit and hover generate nothing more");
    for (i, s) in planned.setups.iter().enumerate() {
        let stages = s.combiners().map(|c| c.stages());
        assert_eq!(stages, planned.plan.passes[i].fragment.general_combiners, "the document is the setup's");
        assert!(stages.is_some(), "pass {i}: a combiner target's pass has its setup");
    }
}

#[test]
fn a_target_without_combiners_generates_the_fixed9_model_once_on_first_use() {
    let source = kilgard();
    let wgsl = Profile::builtin("wgsl").unwrap();
    let before = generated_setups();
    let planned = driver::compile(&source, &wgsl, &Default::default()).unwrap().planned;
    assert_eq!(generated_setups(), before, "a programmable target generates no combiner setup to plan");
    assert!(planned.setups.iter().all(|s| s.combiners().is_none()));
    consume(&planned, &source);
    let models =
        (0..planned.plan.passes.len()).filter(|&i| driver::combiners_of(&planned, i).is_ok()).count();
    assert!(models > 0);
    assert_eq!(generated_setups() - before, models, "the GeForce 3 model, once per pass");
    consume(&planned, &source);
    assert_eq!(generated_setups() - before, models, "and never again");
}

/// The target of a pass is decided once: a texture rendered over its
/// texels is a square grid of the one size, in the texture's format; a
/// framebuffer is frame-sized.
#[test]
fn a_pass_setup_holds_its_target_extent_format_and_units_by_id() {
    let source = "texture N : 2d rgba16f;\ntexture T : 2d rgba8 = image(\"wood.png\");\nframebuffer C : rgba8;\nN δu ← (δu, 0, 1);\nC δπx ← T δu x;\n";
    let wgsl = Profile::builtin("wgsl").unwrap();
    let compiled = driver::compile(source, &wgsl, &Default::default()).unwrap_or_else(|d| panic!("{d:?}"));
    let planned = compiled.planned;
    let m = &planned.module;
    let texel = planned.setups.iter().find(|s| matches!(s.target.kind, TargetKind::Texture(_))).unwrap();
    assert_eq!(texel.target.extent, Extent::Texels(RENDERED_TEXTURE_SIZE));
    assert_eq!(texel.target.format, TargetFormat::Half, "rgba16f keeps half floats");
    let TargetKind::Texture(id) = texel.target.kind else { unreachable!() };
    assert_eq!(m.textures[id as usize].name, "N");
    let last = planned.setups.last().unwrap();
    assert!(matches!(last.target.kind, TargetKind::Framebuffer(_)));
    assert_eq!((last.target.extent, last.target.format), (Extent::Frame, TargetFormat::Unorm8));
    assert_eq!(last.units.len(), 1);
    assert!(
        matches!(last.units[0].source, shadec::pipeline::UnitSource::Texture(t) if m.textures[t as usize].name == "T")
    );
    let at = &source[last.span.start as usize..last.span.end as usize];
    assert!(at.starts_with("C δπx ← T δu x"), "the pass is placed at its statement: {at:?}");
}

/// The same for the per-vertex part: on geforce3 each pass's `!!VP1.0`
/// program (NV_vertex_program) is emitted once, on first use, and kept in
/// its setup; `--emit combiners` and a `render` through the vertex programs
/// read that one (counted by `emit::emitted_programs`, which every
/// emission passes through).
#[test]
fn the_vertex_program_emitter_runs_once_per_pass_for_emit_and_render() {
    use shadec::backends::vertex_program::emit::emitted_programs;
    let source = kilgard();
    let geforce3 = Profile::builtin("geforce3").unwrap();
    let planned = driver::compile(&source, &geforce3, &Default::default()).unwrap().planned;
    assert!(planned.vertex_programs, "geforce3 has vertex programs");
    let before = emitted_programs();
    let passes: Vec<usize> =
        (0..planned.plan.passes.len()).filter(|&i| !planned.plan.passes[i].baked).collect();
    for _ in 0..2 {
        for &i in &passes {
            let text = driver::vertex_program_text(&planned, i, Some(&source), "# pass\n");
            assert!(text.starts_with("!!VP1.0"), "pass {i} has a vertex program: {text}");
        }
        let (program, _) = shadec::parser::check(&source);
        let scene = scene();
        let assets = scene.build().unwrap();
        PlanRenderer::new(&planned, &program, &scene, &assets)
            .unwrap()
            .render(Precision::Fixed9, 32, 24, &mut |_, _| {})
            .unwrap();
    }
    assert_eq!(emitted_programs() - before, passes.len(), "one program per pass, however often it is read");
}
