//! The CPU renderer's `fixed9` mode runs the register-combiner setup the
//! code generator makes for each pass (issue 6 part 3, issue 4 part 5): a
//! pass's pixels are exactly what `shadec emulate` computes from images of
//! the same registers. The registers' images are rendered separately (one
//! program per texture unit, `C δπx ← T δ… x`, a replace pass: the texel
//! lands in the RGBA8 framebuffer unchanged), then run through the image
//! emulator with the generated config; the renderer's own image must match
//! it bit for bit wherever the object covers the screen.

use std::path::Path;

use shadec::backends::combiners::{self, emulator, Inputs};
use shadec::numerics::Precision;
use shadec::pipeline::Planned;
use shadec::profile::Profile;
use shadec::renderer::plan::{compare, Frame, PassShading, PlanRenderer};
use shadec::scene::Scene;

const W: u32 = 128;
const H: u32 = 96;

fn kilgard() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/kilgard_bump_mapping.shd"))
        .unwrap()
}

/// Kilgard's declarations and `let`s, without his three statements.
fn declarations() -> String {
    kilgard().lines().filter(|l| !l.starts_with("C δπx")).collect::<Vec<_>>().join("\n")
}

fn scene() -> Scene {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap()
}

fn plan(source: &str, target: &str) -> (Planned, shadec::parser::ast::Program) {
    let profile = Profile::resolve(target).unwrap();
    let planned = shadec::driver::compile(source, &profile, &Default::default())
        .map(|c| c.planned)
        .unwrap_or_else(|d| panic!("{target}: {d:?}\n{source}"));
    let (program, _) = shadec::parser::check(source);
    (planned, program)
}

fn render(source: &str, target: &str, scene: &Scene, mode: Precision) -> (Planned, Frame) {
    let (planned, program) = plan(source, target);
    let assets = scene.build().unwrap();
    let frame = PlanRenderer::new(&planned, &program, scene, &assets)
        .unwrap()
        .render(mode, W, H, &mut |_, _| {})
        .unwrap();
    (planned, frame)
}

/// Renders `statement` (one pass) in fixed9 and checks it against the image
/// emulator run on separately rendered register images; `units` gives, per
/// texture name, the lookup expression that unit fetches.
fn check_pass(statement: &str, target: &str, units: &[(&str, &str)]) -> usize {
    let scene = scene();
    let decls = declarations();
    let (planned, frame) =
        render(&format!("{decls}\nC δπx ← {statement};\n"), target, &scene, Precision::Fixed9);
    assert_eq!(planned.plan.passes.len(), 1, "{statement}: one pass");
    let PassShading::Combiners { stages } = frame.shading[0] else {
        panic!("{statement}: not run by the combiners: {:?}", frame.shading)
    };
    // The generated config, as the renderer made it.
    let pass = &planned.plan.passes[0];
    let lookups: Vec<_> = pass.textures.iter().map(|t| planned.handle(t.lookup)).collect();
    let generated = combiners::generate(
        &combiners::PassInput {
            module: &planned.module,
            value: planned.handle(pass.fragment.output),
            units: &lookups,
        },
        &planned.combiners.unwrap(),
    )
    .unwrap();
    assert!(
        generated.primary.is_none() && generated.secondary.is_none(),
        "Kilgard's passes read textures and constants only"
    );
    // Each register's image: the texel itself, rendered by a replace pass.
    let dumps: Vec<Vec<u8>> = pass
        .textures
        .iter()
        .map(|t| {
            let (_, lookup) = units
                .iter()
                .find(|(name, _)| *name == t.texture)
                .unwrap_or_else(|| panic!("unit for {}", t.texture));
            render(&format!("{decls}\nC δπx ← {lookup};\n"), target, &scene, Precision::Fixed9)
                .1
                .image
                .to_rgba8()
        })
        .collect();
    let coverage = render(&format!("{decls}\nC δπx ← Iambient;\n"), target, &scene, Precision::Fixed9)
        .1
        .image
        .to_rgba8();
    let mut textures: [Option<&[u8]>; 4] = [None; 4];
    for (slot, d) in textures.iter_mut().zip(&dumps) {
        *slot = Some(d.as_slice());
    }
    let inputs = Inputs { width: W as usize, height: H as usize, textures, ..Inputs::default() };
    let expected = emulator::emulate(&generated.config, &inputs, Precision::Fixed9).unwrap();
    let got = frame.image.to_rgba8();
    let mut covered = 0;
    for i in 0..(W * H) as usize {
        if coverage[4 * i] == 0 {
            continue;
        }
        covered += 1;
        assert_eq!(
            got[4 * i..4 * i + 4],
            expected[4 * i..4 * i + 4],
            "{statement}: pixel ({}, {}) ({stages} stages)",
            i % W as usize,
            i / W as usize
        );
    }
    assert!(covered > 1000, "the torus covers the screen: {covered}");
    stages
}

#[test]
fn ambient_and_diffuse_pass_is_the_emulated_appendix_g_setup() {
    let stages =
        check_pass("rgba(diffuse, s_self)", "geforce256", &[("Tn", "Tn δu x"), ("Ncube", "Ncube δ L s x")]);
    assert_eq!(stages, 2, "Appendix G uses both general combiners");
}

/// The specular term written to rgb and alpha alike (a splatted scalar):
/// the alpha copy needs the whole chain again in the alpha portions, six
/// stages, so a GeForce 3.
#[test]
fn splatted_specular_runs_six_emulated_stages_on_geforce3() {
    let stages = check_pass("specular", "geforce3", &[("Tn", "Tn δu x"), ("Ncube", "Ncube δ H s x")]);
    assert_eq!(stages, 6);
}

/// The default render: every pass of Kilgard's plan runs in the emulated
/// combiners, and the picture is close to the exact reference and to f32.
#[test]
fn default_plan_runs_every_pass_in_the_combiners() {
    let scene = scene();
    let (_, fixed) = render(&kilgard(), "geforce256", &scene, Precision::Fixed9);
    let stages: Vec<usize> = fixed
        .shading
        .iter()
        .map(|s| match s {
            PassShading::Combiners { stages } => *stages,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(stages, [0, 2, 2], "decal in the final combiner alone; Appendices G and H");
    let (_, exact) = render(&kilgard(), "geforce256", &scene, Precision::Exact);
    let (_, f32_) = render(&kilgard(), "geforce256", &scene, Precision::F32);
    assert!(exact.shading.iter().chain(&f32_.shading).all(|s| *s == PassShading::Float));
    let e9 = compare(&exact.image, &fixed.image);
    let ef = compare(&exact.image, &f32_.image);
    let e9f = compare(&f32_.image, &fixed.image);
    eprintln!("fixed9 vs exact {e9:?}\nf32 vs exact {ef:?}\nfixed9 vs f32 {e9f:?}");
    assert!(
        e9.psnr > 30.0 && e9.rmse > ef.rmse,
        "fixed9 is a close picture, and worse than f32: {e9:?} vs {ef:?}"
    );
    assert!(e9f.psnr > 35.0, "the combiners' 8 bits + sign stay near the float plan: {e9f:?}");
}

/// A pass the generator cannot build is not planned for a combiner target
/// (issue 16: a plan the target cannot run is refused, located); for a
/// target without combiners, fixed9 runs the per-operation model.
#[test]
fn a_pass_the_generator_refuses_is_not_planned_and_fixed9_elsewhere_is_per_operation() {
    let refused =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/kajiya_kay_hair.shd"))
            .unwrap();
    // Without the lowering (whose last resort, per-vertex shading, plans it).
    let exact = shadec::driver::PlanOptions {
        lowering: shadec::lowering::LowerOptions { approximate: false, ..Default::default() },
        ..Default::default()
    };
    let err = shadec::driver::compile(&refused, &Profile::resolve("geforce3").unwrap(), &exact)
        .map(|c| c.planned)
        .unwrap_err();
    assert_eq!(err[0].code, "cannot-split", "{err:?}");
    assert!(err[0].primary.span.end > err[0].primary.span.start, "located: {err:?}");
    let source =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/src/bench/programs/phong_taylor.shd"))
            .unwrap();
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bench_sphere.ron")).unwrap();
    let scene = Scene::parse(&text, Path::new("scenes/bench_sphere.ron")).unwrap();
    let (_, frame) = render(&source, "wgsl", &scene, Precision::Fixed9);
    assert!(!frame.shading.is_empty());
    for (i, s) in frame.shading.iter().enumerate() {
        assert!(matches!(s, PassShading::PerOperation { .. }), "pass {}: {s:?}", i + 1);
    }
}
