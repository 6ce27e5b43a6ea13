//! Shadow maps on the combiner targets: Williams 1978's depth
//! test, as Pipeline Grammar, Section 3.5 writes the shadow mask, planned
//! on geforce3 with a depth texture (SGIX_shadow / ARB_shadow): the light's
//! depth rendered to a texture, the test redrawn over the meshes with the
//! light's projection as per-vertex texture coordinates, the unit's
//! compare result (`r ≤ texel` → 1) read by the combiners' mux. On
//! geforce256, which had no depth textures, it plans as Kilgard's 8-bit
//! alpha-ramp approximation (rule `alpha_ramp_shadow_map`), measured
//! against the meaning, and `--no-approx` refuses it, located.

use crate::common;

use std::path::Path;

use shadec::numerics::Precision;
use shadec::pipeline::{CompareFunc, Geometry, Planned};
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;
use shadec::scene::Scene;

fn example(name: &str) -> String {
    std::fs::read_to_string(format!("{}/examples/{name}.shd", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// A ball over a floor under a point light straight above it.
fn occluder_floor() -> Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/shadow_occluder_floor.ron");
    Scene::parse(&std::fs::read_to_string(path).unwrap(), Path::new(path)).unwrap()
}

fn plan(source: &str, target: &str) -> Result<Planned, Vec<shadec::diag::Diagnostic>> {
    let profile = Profile::resolve(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default()).map(|c| c.planned)
}

/// The RGBA8 picture of `source` planned for `target`, rendered on the CPU.
fn render(source: &str, target: &str, mode: Precision) -> Vec<u8> {
    let planned = plan(source, target).unwrap_or_else(|d| panic!("{target}: {d:?}"));
    let (program, _) = shadec::parser::check(source);
    let scene = occluder_floor();
    let assets = scene.build().unwrap();
    let r = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
    let (w, h) = scene.resolution;
    r.render(mode, w, h, &mut |_, _| {}).unwrap().image.to_rgba8()
}

/// The example's statement 4 on geforce3 is a pass over the meshes (not
/// the screen), testing depth `Equal` without writing, with the light's
/// depth framebuffer `Cl` bound to a texture unit; every pass has a
/// combiner setup.
#[test]
fn shadow_map_plans_on_geforce3_as_a_depth_texture_redraw() {
    let planned = plan(&example("shadow_map"), "geforce3").unwrap_or_else(|d| panic!("{d:?}"));
    let test = planned
        .plan
        .passes
        .iter()
        .position(|p| p.statements.contains(&3))
        .expect("a pass runs the depth test");
    let pass = &planned.plan.passes[test];
    assert!(matches!(pass.geometry, Geometry::Mesh { .. }), "{:?}", pass.geometry);
    assert_eq!(pass.state.depth.func, CompareFunc::Equal);
    assert!(!pass.state.depth.write);
    assert!(pass.textures.iter().any(|t| t.texture == "Cl"), "{:?}", pass.textures);
    for (i, p) in planned.plan.passes.iter().enumerate() {
        assert!(p.baked || planned.setups[i].combiners().is_some(), "pass {} has no combiner setup", i + 1);
    }
}

/// The geforce3 plan in the combiners' fixed9 and the wgsl plan (each
/// pixel taken back through `π⁻¹`) in f32, on a ball over a floor: their
/// colours agree within 2/255 on at least 99 % of the pixels, both show
/// the shadow, and their alphas differ only where no mesh is drawn (the
/// redraw writes α where the meshes are; the screen pass also where the
/// pixel's `π⁻¹` reaches the far plane). geforce3's vertex programs clamp
/// a colour they write to [0, 1] (NV_vertex_program, Section 2.14.1.5),
/// and `p` reaches past 1: the plan interpolates its terms apart, each in
/// [0, 1], so the wgsl plan it is held to is the program as written.
#[test]
fn shadow_map_on_geforce3_renders_within_bounds_of_wgsl() {
    let source = example("shadow_map");
    let gf3 = render(&source, "geforce3", Precision::Fixed9);
    let wgsl = render(&source, "wgsl", Precision::F32);
    let lit_source = source.replace("α C xs ← (z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b;", "α C xs ← 0;");
    assert_ne!(lit_source, source);
    let lit = render(&lit_source, "wgsl", Precision::F32);
    let n = gf3.len() / 4;
    let diff = |i: usize| (0..3).map(|c| gf3[4 * i + c].abs_diff(wgsl[4 * i + c])).max().unwrap();
    let over = (0..n).filter(|&i| diff(i) > 2).count();
    let max = (0..n).map(diff).max().unwrap();
    let covered = |i: usize| lit[4 * i + 3] == 255;
    let alpha_off = (0..n).filter(|&i| gf3[4 * i + 3] != wgsl[4 * i + 3]).collect::<Vec<_>>();
    let shadow =
        |img: &[u8]| (0..n).filter(|&i| covered(i) && lit[4 * i] as i32 - img[4 * i] as i32 > 40).count();
    let (on_gf3, on_wgsl) = (shadow(&gf3), shadow(&wgsl));
    eprintln!(
        "geforce3 vs wgsl: rgb max {max}/255, {over} of {n} pixels over 2/255; alpha differs on {} pixels; shadow {on_gf3} vs {on_wgsl} pixels",
        alpha_off.len()
    );
    assert!(on_wgsl > 300 && on_gf3 > 300, "the ball's shadow: {on_gf3} (geforce3), {on_wgsl} (wgsl) pixels");
    assert!(on_gf3.abs_diff(on_wgsl) * 20 <= on_wgsl, "shadows differ: {on_gf3} vs {on_wgsl}");
    assert!(over * 100 <= n, "{over} of {n} pixels differ by more than 2/255 (max {max}/255)");
    assert!(alpha_off.iter().all(|&i| !covered(i)), "alpha differs on a pixel a mesh covers");
}

/// The combiner setup of every pass as `compile --emit combiners` writes
/// it for geforce3: the depth-test pass has a `!!TS1.0` program whose unit
/// 0 is `texture_2d()` (the projective lookup the compare runs on) and a
/// mux on that unit's alpha.
#[test]
fn shadow_map_geforce3_setup_snapshot() {
    let run = common::shadec(&[
        "compile",
        "--emit",
        "combiners",
        "--target",
        "geforce3",
        "examples/shadow_map.shd",
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(run.stdout.contains("!!TS1.0"), "{}", run.stdout);
    insta::assert_snapshot!("shadow_map_geforce3_combiners", run.stdout);
}

/// The example planned for geforce256 on the occluder scene through the
/// one verdict (`check`, `compile`, `render`): the plan, its warnings and
/// the error it measured against the meaning.
fn judged_on_geforce256(
    source: &str,
    scene: &Scene,
    assets: &shadec::scene::SceneAssets,
) -> shadec::verdict::Judged {
    let front = shadec::driver::front(source);
    let module = front.module.as_ref().expect("lowered");
    let profile = Profile::resolve("geforce256").unwrap();
    let judging = shadec::verdict::Judging {
        plan: shadec::driver::PlanOptions {
            scene: Some(shadec::driver::ForScene::specialized(scene, assets)),
            ..Default::default()
        },
        ..Default::default()
    };
    shadec::verdict::judge(module, &front.program, &profile, source, &judging)
        .unwrap_or_else(|d| panic!("{d:?}"))
}

/// GeForce 256 had no depth textures: Williams's test plans there as
/// Kilgard's alpha-ramp approximation (rule `alpha_ramp_shadow_map`), with
/// one located warning at the test. The plan: the ramp baked by the
/// compiler, a light pass writing the ramp's texel into `Cl`'s alpha, and
/// the test redrawn over the meshes (depth `Equal`, no write) with the
/// ramp and `Cl` on the two texture units and two general combiners.
#[test]
fn shadow_map_plans_on_geforce256_with_the_alpha_ramp_warning() {
    let source = example("shadow_map");
    let front = shadec::verdict::check(&source, Some("geforce256")).unwrap();
    let errors: Vec<_> = front.diagnostics.iter().filter(|d| d.is_error()).collect();
    assert!(errors.is_empty(), "{errors:?}");
    let warnings: Vec<_> = front.diagnostics.iter().filter(|d| d.code == "approximation").collect();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].message.contains("alpha_ramp_shadow_map"), "{}", warnings[0].message);
    let at = shadec::span::LineIndex::new(&source).line_col(&source, warnings[0].primary.span.start as usize);
    assert_eq!((at.line, at.col), (35, 10), "{:?}", warnings[0]);

    let planned = plan(&source, "geforce256").unwrap_or_else(|d| panic!("{d:?}"));
    let rules: Vec<&str> = planned.plan.approximations.iter().map(|a| a.rule.as_str()).collect();
    assert_eq!(rules, ["alpha_ramp_shadow_map"]);
    let test = planned
        .plan
        .passes
        .iter()
        .position(|p| p.textures.iter().any(|t| t.texture == "Cl"))
        .expect("a pass reads Cl");
    let pass = &planned.plan.passes[test];
    assert!(matches!(pass.geometry, Geometry::Mesh { .. }), "{:?}", pass.geometry);
    assert_eq!(pass.state.depth.func, CompareFunc::Equal);
    assert!(!pass.state.depth.write);
    let units: Vec<&str> = pass.textures.iter().map(|t| t.texture.as_str()).collect();
    assert_eq!(units, ["alpha_ramp", "Cl"]);
    let stages = planned.setups[test].combiners().expect("a combiner setup").stages();
    assert!(stages <= 2, "{stages} general combiners");
    let light = planned
        .plan
        .passes
        .iter()
        .position(
            |p| matches!(&p.target, shadec::pipeline::RenderTarget::Framebuffer { name, .. } if name == "Cl"),
        )
        .expect("a light pass");
    assert!(light < test);
    assert_eq!(planned.plan.passes[light].textures.len(), 1);
    for (i, p) in planned.plan.passes.iter().enumerate() {
        assert!(p.baked || planned.setups[i].combiners().is_some(), "pass {} has no combiner setup", i + 1);
    }
}

/// The alpha-ramp plan against the program's meaning on a ball over a
/// floor: the verdict's measured error (both in f32) is small — the ramp
/// loses a shadow only where the depths are within one step (1/256) past
/// the bias: 10/255 at a few pixels of the shadow's edge, as wgpu renders
/// the plan (its 8-bit steps sampled nearest, each stored in 8 bits; the
/// CPU sampled the ramp bilinearly once, which blended its steps into a
/// finer encoding, 0.8/255, and with the 8-bit store 174/255 of acne) —
/// and the plan's f32 render is within it; in the combiners'
/// fixed9 the plan agrees with the wgsl plan within 2/255 on 99 % of the
/// pixels and both shade the same floor pixels in shadow.
#[test]
fn shadow_map_alpha_ramp_renders_within_its_measured_error() {
    let source = example("shadow_map");
    let scene = occluder_floor();
    let assets = scene.build().unwrap();
    let judged = judged_on_geforce256(&source, &scene, &assets);
    let measured = judged.planned.plan.measured.clone().expect("measured on the scene");
    eprintln!(
        "alpha ramp on geforce256: measured {:.2}/255 (RMSE {:.5}) from the meaning",
        measured.max_abs * 255.0,
        measured.rmse
    );
    assert!(measured.max_abs <= 12.0 / 255.0 && measured.rmse < 0.002, "{measured:?}");
    let help = judged.warnings[0].help.as_deref().unwrap_or("");
    assert!(help.contains(&format!("measured {:.1}/255", measured.max_abs * 255.0)), "{help}");

    let front = shadec::driver::front(&source);
    let meaning = shadec::meaning::plan(front.module.as_ref().unwrap(), 1).unwrap();
    let (program, _) = shadec::parser::check(&source);
    let (w, h) = scene.resolution;
    let draw = |p: &Planned, mode| {
        PlanRenderer::new(p, &program, &scene, &assets)
            .unwrap()
            .render(mode, w, h, &mut |_, _| {})
            .unwrap()
            .image
            .to_rgba8()
    };
    let reference = draw(&meaning, Precision::F32);
    let ramp = draw(&judged.planned, Precision::F32);
    let rgb_max =
        |a: &[u8], b: &[u8]| (0..a.len()).filter(|i| i % 4 != 3).map(|i| a[i].abs_diff(b[i])).max().unwrap();
    let f32_error = rgb_max(&reference, &ramp);
    assert!(
        f32::from(f32_error) <= (measured.max_abs * 255.0).ceil() as f32,
        "{f32_error}/255 over {measured:?}"
    );

    let gf256 = render(&source, "geforce256", Precision::Fixed9);
    let wgsl = render(&source, "wgsl", Precision::F32);
    let n = gf256.len() / 4;
    let diff = |i: usize| (0..3).map(|c| gf256[4 * i + c].abs_diff(wgsl[4 * i + c])).max().unwrap();
    let over = (0..n).filter(|&i| diff(i) > 2).count();
    let lit_source = source.replace("α C xs ← (z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b;", "α C xs ← 0;");
    let lit = render(&lit_source, "wgsl", Precision::F32);
    let shadow = |img: &[u8]| {
        (0..n).filter(|&i| lit[4 * i + 3] == 255 && lit[4 * i] as i32 - img[4 * i] as i32 > 40).count()
    };
    let (on_gf256, on_wgsl) = (shadow(&gf256), shadow(&wgsl));
    eprintln!(
        "geforce256 fixed9 vs wgsl: rgb max {}/255, {over} of {n} pixels over 2/255; shadow {on_gf256} vs {on_wgsl} pixels",
        (0..n).map(diff).max().unwrap()
    );
    assert!(on_wgsl > 300, "the ball's shadow: {on_wgsl} pixels");
    assert_eq!(on_gf256, on_wgsl, "the shadows differ");
    assert!(over * 100 <= n, "{over} of {n} pixels differ by more than 2/255");
}

/// `--no-approx` forbids the alpha ramp: the test is refused at its
/// statement, naming the rule that would plan it and what geforce256
/// lacked.
#[test]
fn shadow_map_no_approx_refuses_the_alpha_ramp_on_geforce256() {
    let source = example("shadow_map");
    let profile = Profile::resolve("geforce256").unwrap();
    let options = shadec::driver::PlanOptions {
        lowering: shadec::lowering::LowerOptions { approximate: false, ..Default::default() },
        ..Default::default()
    };
    let Err(err) = shadec::driver::compile(&source, &profile, &options) else {
        panic!("planned with --no-approx")
    };
    assert_eq!(err.len(), 1, "{err:?}");
    let at = shadec::span::LineIndex::new(&source).line_col(&source, err[0].primary.span.start as usize);
    assert_eq!(at.line, 35, "{err:?}");
    assert!(err[0].message.contains("a per-pixel depth comparison"), "{}", err[0].message);
    let help = err[0].help.as_deref().unwrap_or("");
    assert!(help.contains("geforce256 has no depth textures"), "{help}");
    assert!(help.contains("`alpha_ramp_shadow_map`, which --no-approx refuses"), "{help}");
    let run = common::shadec(&["check", "--no-approx", "--target", "geforce256", "examples/shadow_map.shd"]);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert!(
        run.stdout.contains("shadow_map.shd:35:") || run.stderr.contains("shadow_map.shd:35:"),
        "{}{}",
        run.stdout,
        run.stderr
    );
}

/// The printed shadow mask compares the camera's depth with the light's,
/// which no alpha ramp of the light's depth encodes: geforce256 keeps a
/// located refusal, and its help says what plans instead, in sentences
/// (no garbled phrase).
#[test]
fn printed_shadow_mask_is_refused_on_geforce256_with_a_true_help() {
    let source = example("shadow_mask");
    let Err(err) = plan(&source, "geforce256") else { panic!("planned on geforce256") };
    assert_eq!(err.len(), 1, "{err:?}");
    let at = shadec::span::LineIndex::new(&source).line_col(&source, err[0].primary.span.start as usize);
    assert_eq!(at.line, 31, "{err:?}");
    let help = err[0].help.as_deref().unwrap_or("");
    assert!(!help.contains("there no form"), "{help}");
    assert!(help.contains("Williams's test plans there only as an approximation"), "{help}");
    assert!(help.contains("(z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b"), "{help}");
}

/// The camera's depth compared with the light's plus a bias: a depth
/// texture compares only the r/q of the coordinates it is read at, and the
/// depth-replacing redraw (`tests/shadow_mask.rs`) runs only the printed
/// test, so geforce3 refuses it, located, pointing at Williams's test.
#[test]
fn printed_shadow_mask_is_refused_on_geforce3_pointing_at_williams() {
    let source = example("shadow_mask")
        .replace("(z C xs) > (z Cl πl π⁻¹ xs);", "(z C xs) > (z Cl πl π⁻¹ xs) + 0.002;");
    let Err(err) = plan(&source, "geforce3") else { panic!("planned on geforce3") };
    assert_eq!(err.len(), 1, "{err:?}");
    let at = shadec::span::LineIndex::new(&source).line_col(&source, err[0].primary.span.start as usize);
    assert_eq!(at.line, 31, "{err:?}");
    assert!(err[0].help.as_deref().unwrap_or("").contains("(z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b"));
}

/// The geforce3 plan on wgpu: each pass's combiner setup run as WGSL
/// (`Precision::Fixed9`, the hardware fidelity: the compare unit's
/// register loaded with the comparison, as the CPU loads it) against the
/// CPU's fixed9 of the same plan, and the shadow on both.
#[cfg(feature = "gpu")]
#[test]
fn shadow_map_geforce3_plan_on_wgpu_agrees_with_cpu() {
    use shadec::gpu::runner::Target;
    use shadec::gpu::scene_run::ScenePlan;
    let Some(gpu) = common::gpu::gpu() else { return };
    let source = example("shadow_map");
    let planned = plan(&source, "geforce3").unwrap_or_else(|d| panic!("{d:?}"));
    let (program, _) = shadec::parser::check(&source);
    let scene = occluder_floor();
    let assets = scene.build().unwrap();
    let (w, h) = scene.resolution;
    let plan = ScenePlan::new(&planned, &program, Some(&source), Precision::Fixed9, &scene, &assets)
        .unwrap_or_else(|e| panic!("{e}"));
    let wgpu = plan.render_into(&gpu, &Target::new(w, h)).unwrap_or_else(|e| panic!("{e}")).into_raw();
    let cpu = render(&source, "geforce3", Precision::Fixed9);
    let n = cpu.len() / 4;
    let diff = |i: usize| (0..4).map(|c| cpu[4 * i + c].abs_diff(wgpu[4 * i + c])).max().unwrap();
    let over = (0..n).filter(|&i| diff(i) > 2).count();
    let max = (0..n).map(diff).max().unwrap();
    let ambient = |img: &[u8]| (0..n).filter(|&i| img[4 * i + 3] == 255 && img[4 * i] < 45).count();
    eprintln!("geforce3 plan, wgpu vs CPU fixed9: max {max}/255, {over} pixels over 2/255; ambient-only pixels {} vs {}", ambient(&wgpu), ambient(&cpu));
    assert!(ambient(&wgpu) > 300, "no shadow on wgpu");
    assert!(over * 100 <= n, "{over} of {n} pixels differ by more than 2/255 (max {max}/255)");
}

/// The shadow test written the lit way round, `(z δπl x) ≤ (z Cl δπl x) + b
/// ? lit : ambient` (or with its sides exchanged), is the texture unit's
/// compare too: it plans on geforce3 (it was refused as "a per-pixel depth
/// comparison") and renders what the `>` form renders, in fixed9.
#[test]
fn a_shadow_test_written_lit_side_first_plans_on_geforce3_as_the_greater_form() {
    let program = |test: &str| {
        format!(
            "vector N : normal;\nvector L : light;\nshader p : s → c = max(0, N·L);\nframebuffer Cl : depth;\nCl δπl x ← δ x;\nC δπx ← 0.15 + ({test});\n"
        )
    };
    let greater =
        render(&program("(z δπl x) > (z Cl δπl x) + 0.002 ? 0 : δ p s x"), "geforce3", Precision::Fixed9);
    for test in [
        "(z δπl x) ≤ (z Cl δπl x) + 0.002 ? δ p s x : 0",
        "(z Cl δπl x) + 0.002 ≥ (z δπl x) ? δ p s x : 0",
        "(z Cl δπl x) + 0.002 < (z δπl x) ? 0 : δ p s x",
    ] {
        let picture = render(&program(test), "geforce3", Precision::Fixed9);
        let differ = picture.chunks(4).zip(greater.chunks(4)).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{test}: pixels that differ from the `>` form");
    }
    let reds: std::collections::BTreeSet<u8> = greater.chunks(4).map(|p| p[0]).collect();
    assert!(
        greater.chunks(4).any(|p| p[0] > 100) && greater.chunks(4).any(|p| p[0] < 60),
        "lit and shadowed pixels: {reds:?}"
    );
}

/// A shadow test in the first pass over `C` (no earlier statement draws
/// the meshes there) draws its fragments: the pass kept its own depth test.
/// It tested depth `Equal` against the cleared buffer and drew nothing, on
/// every target, on the CPU and on wgpu alike; only the independent
/// reference saw it (every covered pixel off, up to 255/255).
#[test]
fn a_shadow_test_in_the_first_pass_over_c_draws_and_agrees_with_the_reference() {
    let source = "vector N : normal;\nvector L : light;\nshader p : s → c = max(0, N·L);\nframebuffer Cl : depth;\nCl δπl x ← δ x;\nC δπx ← 0.15 + ((z δπl x) > (z Cl δπl x) + 0.002 ? 0 : δ p s x);\n";
    let g = crate::common::gpu::gpu();
    for (target, precision) in [("wgsl", Precision::F32), ("geforce3", Precision::Fixed9)] {
        let p = crate::three_way::render_three(source, target, &occluder_floor(), precision, g.as_ref())
            .unwrap_or_else(|e| panic!("{target}: {e}"));
        let verdict = match precision {
            Precision::Fixed9 => crate::three_way_generated::fixed9_verdict(&p, &mut 0),
            _ => crate::three_way::verdict(&p),
        };
        verdict.unwrap_or_else(|e| panic!("{target}: {e}"));
        assert!(p.cpu.chunks(4).filter(|px| px[0] > 100).count() > 100, "{target}: lit pixels drawn");
    }
}

/// The alpha-ramp plan in `exact` arithmetic on the Kilgard torus (what
/// `shadec render examples/shadow_map.shd --target geforce256 --precision
/// exact` draws): within the ramp's error of the meaning, as in f32. The
/// ramp's value at the point's own depth was evaluated in f64 and compared
/// with the same value stored in the light pass's framebuffer in f32, at
/// `½·(a + 1 − c) < ½` whose equality is the lit side: the torus shadowed
/// itself in bands, one a ramp step, 216.8/255 from the meaning.
#[test]
fn the_alpha_ramp_plan_in_exact_arithmetic_is_as_close_to_the_meaning_as_in_f32() {
    let source = example("shadow_map");
    let scene = crate::three_way::scene("kilgard_torus.ron");
    let assets = scene.build().unwrap();
    let judged = judged_on_geforce256(&source, &scene, &assets);
    let rules: Vec<&str> = judged.planned.plan.approximations.iter().map(|a| a.rule.as_str()).collect();
    assert_eq!(rules, ["alpha_ramp_shadow_map"]);
    let front = shadec::driver::front(&source);
    let meaning = shadec::meaning::plan(front.module.as_ref().unwrap(), 1).unwrap();
    let draw = |p: &Planned, mode| {
        PlanRenderer::new(p, &front.program, &scene, &assets)
            .unwrap()
            .render(mode, 160, 120, &mut |_, _| {})
            .unwrap()
            .image
            .to_rgba8()
    };
    let reference = draw(&meaning, Precision::Exact);
    let rgb = |a: &[u8], b: &[u8]| {
        let off = (0..a.len()).filter(|i| i % 4 != 3 && a[*i].abs_diff(b[*i]) > 12).count();
        ((0..a.len()).filter(|i| i % 4 != 3).map(|i| a[i].abs_diff(b[i])).max().unwrap(), off)
    };
    let (in_f32, _) = rgb(&reference, &draw(&judged.planned, Precision::F32));
    let (in_exact, off) = rgb(&reference, &draw(&judged.planned, Precision::Exact));
    eprintln!("alpha ramp on the torus: f32 {in_f32}/255, exact {in_exact}/255 ({off} channels over 12/255)");
    assert!(in_f32 <= 12, "f32: {in_f32}/255 from the meaning");
    assert!(in_exact <= 12, "exact: {in_exact}/255 from the meaning, {off} channels over 12/255");
}
