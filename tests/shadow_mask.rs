//! The shadow mask as Pipeline Grammar, Section 3.5 prints it
//! (`examples/shadow_mask.shd`): its test compares the camera's depth
//! `z C xs` with the light's, `(z C xs) > (z Cl πl π⁻¹ xs)`. A GeForce3's
//! depth textures compare only the r/q of the coordinates they are read
//! at, so the comparison is the depth test's: the meshes drawn again, each
//! fragment's depth replaced by the light's depth at its light coordinates
//! (NV_texture_shader's `DOT_PRODUCT_DEPTH_REPLACE_NV`, the light's depth
//! stored as two bytes), tested `GEQUAL` against the camera's depth buffer
//! and writing α C = 0 where the test fails. GeForce 256 had no texture
//! shaders and no depth textures: it refuses the printed form, located,
//! and plans Williams 1978's test only as the alpha-ramp approximation.

use std::path::Path;

use shadec::backends::combiners::ts1;
use shadec::numerics::Precision;
use shadec::pipeline::{CompareFunc, Geometry, Planned};
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;
use shadec::scene::Scene;

fn printed() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/shadow_mask.shd")).unwrap()
}

const PRINTED_TEST: &str = "α C xs ← (z C xs) > (z Cl πl π⁻¹ xs);";

/// The printed test replaced by the form the help names.
fn williams() -> String {
    let source = printed();
    assert!(source.contains(PRINTED_TEST));
    source.replace(PRINTED_TEST, "α C xs ← (z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + 0.002;")
}

fn plan(source: &str, target: &str) -> Result<Planned, Vec<shadec::diag::Diagnostic>> {
    let profile = Profile::resolve(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default()).map(|c| c.planned)
}

fn line_col(source: &str, d: &shadec::diag::Diagnostic) -> (u32, u32) {
    let at = shadec::span::LineIndex::new(source).line_col(source, d.primary.span.start as usize);
    (at.line as u32, at.col as u32)
}

/// A ball over a floor under a point light straight above it.
fn occluder_floor() -> Scene {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/shadow_occluder_floor.ron");
    Scene::parse(&std::fs::read_to_string(path).unwrap(), Path::new(path)).unwrap()
}

/// `planned` rendered on the CPU on the ball over the floor, RGBA8.
fn render(planned: &Planned, source: &str, mode: Precision) -> Vec<u8> {
    let (program, _) = shadec::parser::check(source);
    let scene = occluder_floor();
    let assets = scene.build().unwrap();
    let r = PlanRenderer::new(planned, &program, &scene, &assets).unwrap();
    let (w, h) = scene.resolution;
    r.render(mode, w, h, &mut |_, _| {}).unwrap().image.to_rgba8()
}

/// The program's meaning (`shadec::meaning`, the unsplit statements
/// rendered exactly): the reference, independent of any target's plan.
fn meaning(source: &str) -> Vec<u8> {
    let (program, _) = shadec::parser::check(source);
    let (written, _) = shadec::ir::lower(&program);
    let meaning = shadec::meaning::plan(&written, occluder_floor().lights.len()).unwrap();
    render(&meaning, source, Precision::Exact)
}

/// The pass that runs the printed test on geforce3.
fn test_pass(planned: &Planned) -> usize {
    planned.plan.passes.iter().position(|p| p.statements == [3]).expect("a pass runs the test")
}

/// geforce3: the printed form plans (it was refused before the depth
/// replace was built): statement 4 is a redraw over the meshes testing
/// `GEQUAL` without writing, its fragment's depth replaced, the light's
/// map `Cl` on unit 0, writing only α.
#[test]
fn shadow_mask_printed_form_plans_on_geforce3_as_a_depth_replacing_redraw() {
    let planned = plan(&printed(), "geforce3").unwrap_or_else(|e| panic!("the printed form: {e:?}"));
    let k = test_pass(&planned);
    let pass = &planned.plan.passes[k];
    assert!(matches!(pass.geometry, Geometry::Mesh { .. }), "{:?}", pass.geometry);
    assert_eq!(pass.state.depth.func, CompareFunc::GreaterEqual);
    assert!(!pass.state.depth.write);
    assert!(pass.fragment.depth.is_some(), "{:?}", pass.fragment);
    assert_eq!(pass.textures.len(), 1, "{:?}", pass.textures);
    assert_eq!(pass.textures[0].texture, "Cl");
    assert!(
        matches!(&pass.target, shadec::pipeline::RenderTarget::Framebuffer { name, channels } if name == "C" && channels == "a"),
        "{:?}",
        pass.target
    );
    for (i, p) in planned.plan.passes.iter().enumerate() {
        assert!(p.baked || planned.setups[i].combiners().is_some(), "pass {} has no combiner setup", i + 1);
    }
    // Williams's test, the help's form, still plans as the depth-texture redraw.
    let williams = plan(&williams(), "geforce3").unwrap_or_else(|e| panic!("the help's form: {e:?}"));
    assert!(williams.plan.passes.iter().all(|p| p.fragment.depth.is_none()));
}

/// The pass's `!!TS1.0`: `texture_2d` on the light's map, then the two
/// depth-replace dot products reading unit 0; printed and read back
/// through the `!!TS1.0` reader to the same program, and consistent.
#[test]
fn shadow_mask_geforce3_texture_shader_reads_back() {
    let planned = plan(&printed(), "geforce3").unwrap_or_else(|e| panic!("{e:?}"));
    let k = test_pass(&planned);
    let generated = shadec::backends::combiners::setup::of(&planned, k).unwrap_or_else(|e| panic!("{e}"));
    let program = generated.config.texture_shader.clone().expect("a texture shader program");
    let text = ts1::print(&program);
    assert_eq!(
        text,
        "!!TS1.0\ntexture_2d();\ndot_product_depth_replace_1of2(tex0);\ndot_product_depth_replace_2of2(tex0);\n"
    );
    let read = ts1::parse_file(&text).unwrap_or_else(|e| panic!("{e:?}"));
    assert_eq!(read, program);
    assert!(ts1::validate(&program).is_empty(), "{:?}", ts1::validate(&program));
    // The CLI writes the same program.
    let run = crate::common::shadec(&[
        "compile",
        "--emit",
        "combiners",
        "--target",
        "geforce3",
        "examples/shadow_mask.shd",
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(run.stdout.contains("dot_product_depth_replace_2of2(tex0);"), "{}", run.stdout);
}

/// The program with its last statement writing the mask α C as a grey
/// image (the printed C and C′ are the same image: the mask is what the
/// test decides).
fn mask(source: &str) -> String {
    let masked = source.replace(
        "C xs ← (α C xs)*(C xs) + (1 – α C xs)*(C′ xs);",
        "const white : rgba = (1, 1, 1, 1);\nC xs ← (α C xs) * white;",
    );
    assert_ne!(masked, source);
    masked
}

/// Pixels (of `n`) whose colour differs by more than 2/255 in a channel.
fn over(a: &[u8], b: &[u8]) -> (usize, u8) {
    let n = a.len() / 4;
    let diff = |i: usize| (0..3).map(|c| a[4 * i + c].abs_diff(b[4 * i + c])).max().unwrap();
    ((0..n).filter(|&i| diff(i) > 2).count(), (0..n).map(diff).max().unwrap_or(0))
}

/// The geforce3 plan (fixed9: the combiners' arithmetic, the light's depth
/// from 16 bits, every fragment depth-tested) against the wgsl plan (f32,
/// each pixel taken back through `π⁻¹`) and against the program's meaning
/// (exact), on the ball over the floor. Bounds: on covered pixels, at most
/// 1 % of the pixels' colours differ by more than 2/255 from either, and
/// the mask (α, before the last statement blends: the pixels where the
/// ambient image shows) agrees on at least 99 % of the covered pixels.
#[test]
fn shadow_mask_on_geforce3_renders_within_bounds_of_wgsl_and_the_meaning() {
    let source = printed();
    let gf3 = render(&plan(&source, "geforce3").unwrap(), &source, Precision::Fixed9);
    // geforce3's vertex programs clamp the colour they write to [0, 1]
    // (NV_vertex_program 2.14.1.5), and `p` reaches past 1: the plan
    // interpolates its terms apart, each in [0, 1], so the colours are
    // compared with the program as written.
    let wgsl = render(&plan(&source, "wgsl").unwrap(), &source, Precision::F32);
    let exact = meaning(&source);
    let mask_source = mask(&source);
    let lit_source = source.replace(PRINTED_TEST, "α C xs ← 0;");
    let lit = render(&plan(&lit_source, "wgsl").unwrap(), &lit_source, Precision::F32);
    let n = gf3.len() / 4;
    let covered: Vec<usize> = (0..n).filter(|&i| lit[4 * i + 3] == 255).collect();
    let masks = [
        render(&plan(&mask_source, "geforce3").unwrap(), &mask_source, Precision::Fixed9),
        render(&plan(&mask_source, "wgsl").unwrap(), &mask_source, Precision::F32),
        meaning(&mask_source),
    ];
    let set = |img: &[u8], i: usize| img[4 * i] > 127;
    let mask_off = |other: &[u8]| covered.iter().filter(|&&i| set(&masks[0], i) != set(other, i)).count();
    let (off_wgsl, off_meaning) = (mask_off(&masks[1]), mask_off(&masks[2]));
    let in_shadow = covered.iter().filter(|&&i| set(&masks[2], i)).count();
    // Which way the redraw errs: clearing α where the meaning keeps it (a
    // hidden surface passing the depth test), or keeping it where the
    // meaning clears it (the light's depth rounded down to 16 bits).
    let cleared = covered.iter().filter(|&&i| !set(&masks[0], i) && set(&masks[2], i)).count();
    let kept = covered.iter().filter(|&&i| set(&masks[0], i) && !set(&masks[2], i)).count();
    let on_covered =
        |img: &[u8]| covered.iter().flat_map(|&i| img[4 * i..4 * i + 4].to_vec()).collect::<Vec<u8>>();
    let (over_wgsl, max_wgsl) = over(&on_covered(&gf3), &on_covered(&wgsl));
    let (over_meaning, max_meaning) = over(&on_covered(&gf3), &on_covered(&exact));
    eprintln!(
        "geforce3 shadow mask on {} covered of {n} pixels ({in_shadow} with the mask set in the meaning): mask differs from wgsl on {off_wgsl}, from the meaning on {off_meaning}; colour over 2/255 from wgsl on {over_wgsl} (max {max_wgsl}/255), from the meaning on {over_meaning} (max {max_meaning}/255)",
        covered.len()
    );
    eprintln!("against the meaning: α cleared on {cleared} pixels it keeps, kept on {kept} it clears");
    assert!(in_shadow > 300, "the meaning's mask is set on only {in_shadow} pixels");
    assert_eq!(cleared + kept, off_meaning);
    assert!(off_wgsl * 100 <= covered.len(), "mask differs from wgsl on {off_wgsl} pixels");
    assert!(off_meaning * 100 <= covered.len(), "mask differs from the meaning on {off_meaning} pixels");
    assert!(over_wgsl * 100 <= covered.len(), "{over_wgsl} pixels over 2/255 from wgsl (max {max_wgsl})");
    assert!(over_meaning * 100 <= covered.len(), "{over_meaning} pixels over 2/255 from the meaning");
}

/// A form the depth test cannot run — a bias added to the light's depth —
/// is still refused on geforce3 at the test's statement, naming Williams's
/// test, which plans.
#[test]
fn shadow_mask_with_a_bias_on_the_cameras_depth_is_refused_on_geforce3() {
    let source = printed().replace(PRINTED_TEST, "α C xs ← (z C xs) > (z Cl πl π⁻¹ xs) + 0.002;");
    let Err(errors) = plan(&source, "geforce3") else { panic!("the biased form planned on geforce3") };
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert_eq!(line_col(&source, &errors[0]), (31, 1));
    let help = errors[0].help.as_deref().unwrap_or("");
    assert!(help.contains("(z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b"), "{help}");
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

/// The `!!TS1.0` emulator's depth replace: the fragment's depth is z/w of
/// the two dot products of unit 0's texel, clamped to [0, 1], 1 where
/// w = 0; both stages' registers are 0. The expectation is computed in
/// reals from the coordinate bytes' meaning.
#[test]
fn texture_shader_emulator_replaces_depth_by_z_over_w() {
    use ts1::emulate::{replaced_depth, shade, Image, TextureInputs, COORD_ONE};
    assert_eq!(replaced_depth(5, 0), COORD_ONE);
    assert_eq!(replaced_depth(COORD_ONE / 4, COORD_ONE), COORD_ONE / 4);
    assert_eq!(replaced_depth(-COORD_ONE / 4, -COORD_ONE), COORD_ONE / 4);
    assert_eq!(replaced_depth(3 * COORD_ONE, COORD_ONE), COORD_ONE);
    assert_eq!(replaced_depth(-5, COORD_ONE), 0);
    let texel = [200u8, 17, 255, 255];
    // Directions, as dot-product stages read coordinate bytes: (2b − 255)/255.
    let (c1, c2) = ([255u8, 128, 128, 255], [128u8, 128, 255, 255]);
    let inputs = TextureInputs {
        width: 1,
        height: 1,
        textures: [Some(Image { width: 1, height: 1, rgba: &texel }), None, None, None],
        coords: [None, Some(&c1), Some(&c2), None],
    };
    let shaded = shade(&ts1::lower::depth_replace(), &inputs).unwrap();
    let d = shaded.depth[0].expect("a replaced depth") as f64 / COORD_ONE as f64;
    let c = |b: u8| (2.0 * b as f64 - 255.0) / 255.0;
    let k = |b: u8| b as f64 / 255.0;
    let dot = |cs: [u8; 4]| (0..3).map(|i| c(cs[i]) * k(texel[i])).sum::<f64>();
    let want = dot(c1) / dot(c2);
    assert!((d - want).abs() <= 4.0 / 65536.0, "{d} vs {want}");
    assert_eq!(shaded.textures[1], vec![0; 4]);
    assert_eq!(shaded.textures[2], vec![0; 4]);
}

/// The geforce3 plan on wgpu: the redraw's WGSL writes the replaced depth
/// to `frag_depth` and the pipeline tests it `GEQUAL`; its mask against
/// the CPU's (fixed9, the depth replaced before the CPU's depth test)
/// differs on at most 0.5 % of the pixels, and the mask is set on both.
#[cfg(feature = "gpu")]
#[test]
fn shadow_mask_geforce3_plan_on_wgpu_agrees_with_cpu() {
    use shadec::gpu::runner::Target;
    use shadec::gpu::scene_run::ScenePlan;
    let Some(gpu) = crate::common::gpu::gpu() else { return };
    let source = mask(&printed());
    let planned = plan(&source, "geforce3").unwrap_or_else(|d| panic!("{d:?}"));
    let (program, _) = shadec::parser::check(&source);
    let scene = occluder_floor();
    let assets = scene.build().unwrap();
    let (w, h) = scene.resolution;
    let run = ScenePlan::new(&planned, &program, Some(&source), Precision::Fixed9, &scene, &assets)
        .unwrap_or_else(|e| panic!("{e}"));
    let wgpu = run.render_into(&gpu, &Target::new(w, h)).unwrap_or_else(|e| panic!("{e}")).into_raw();
    let cpu = render(&planned, &source, Precision::Fixed9);
    let n = cpu.len() / 4;
    let set = |img: &[u8], i: usize| img[4 * i] > 127;
    let off = (0..n).filter(|&i| set(&cpu, i) != set(&wgpu, i)).count();
    let (on_cpu, on_wgpu) =
        ((0..n).filter(|&i| set(&cpu, i)).count(), (0..n).filter(|&i| set(&wgpu, i)).count());
    eprintln!("geforce3 shadow mask, wgpu vs CPU: {off} of {n} pixels differ; set on {on_wgpu} (wgpu), {on_cpu} (CPU)");
    assert!(on_cpu > 300 && on_wgpu > 300, "mask set on {on_cpu} (CPU), {on_wgpu} (wgpu)");
    assert!(off * 200 <= n, "{off} of {n} pixels differ");
}
