//! Solid mapping (Pipeline Grammar, Section 3.7, eq. (15)-(16), after
//! Carr et al. 2000) on geforce3: planned for a scene, the procedural
//! shader becomes a 3-D texture over the scene's object bounds, read at the
//! box-mapped position (rule `solid_texture_3d`, docs/solid-textures.md).
//! Without a scene, and on geforce256 (no 3-D textures), it is refused,
//! located.

use crate::common;

use std::path::Path;

use shadec::driver::{ForScene, PlanOptions};
use shadec::ir::Expr;
use shadec::numerics::Precision;
use shadec::parser::ast::TextureKind;
use shadec::pipeline::{Geometry, Planned};
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;
use shadec::scene::Scene;

const SCENE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bench_sphere.ron");

fn example() -> String {
    std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/solid_mapping.shd")).unwrap()
}

fn scene() -> Scene {
    Scene::parse(&std::fs::read_to_string(SCENE).unwrap(), Path::new(SCENE)).unwrap()
}

/// The plan of the example for `target`, for the bench sphere or for any scene.
fn plan(target: &str, for_scene: bool) -> Result<Planned, Vec<shadec::diag::Diagnostic>> {
    let profile = Profile::resolve(target).unwrap();
    let scene = scene();
    let assets = scene.build().unwrap();
    let options = PlanOptions {
        scene: for_scene.then(|| ForScene::specialized(&scene, &assets)),
        ..Default::default()
    };
    shadec::driver::compile(&example(), &profile, &options).map(|c| c.planned)
}

/// The line:col of each error.
fn located(errors: &[shadec::diag::Diagnostic]) -> Vec<(usize, usize)> {
    let source = example();
    let index = shadec::span::LineIndex::new(&source);
    errors
        .iter()
        .map(|d| {
            let at = index.line_col(&source, d.primary.span.start as usize);
            (at.line, at.col)
        })
        .collect()
}

/// Without a scene the positions' range is unknown: refused at (16)'s and
/// (2)'s reads of the float texture, the help naming the scene as the way.
#[test]
fn solid_mapping_without_a_scene_is_refused_on_geforce3_located() {
    let Err(errors) = plan("geforce3", false) else { panic!("planned without a scene") };
    assert_eq!(located(&errors), vec![(27, 10), (28, 9)], "{errors:?}");
    for e in &errors {
        assert!(e.message.contains("float textures"), "{}", e.message);
        let help = e.help.as_deref().unwrap_or("");
        assert!(help.contains("planned for a scene") && help.contains("3-D texture"), "{help}");
    }
}

/// For a scene (refused before rule `solid_texture_3d`): a baked 3-D
/// texture of the shader, its texel pass first, and (15) a pass reading it
/// at a vec3 coordinate interpolated from the vertices, with a combiner
/// setup; (16) is gone.
#[test]
fn solid_mapping_plans_on_geforce3_for_a_scene_as_a_3d_texture() {
    let planned = plan("geforce3", true).unwrap_or_else(|e| panic!("{e:?}"));
    let m = &planned.module;
    let solid = m.textures.iter().position(|t| t.name == "T_solid").expect("the 3-D texture");
    assert_eq!(m.textures[solid].kind, TextureKind::Tex3d);
    assert!(m.textures[solid].baked);
    let a = planned.plan.approximations.iter().find(|a| a.rule == "solid_texture_3d").expect("recorded");
    let bound = a.error_bound.expect("a measured bound");
    assert!(bound > 0.0 && bound < 0.5, "{bound}");
    assert_eq!(planned.plan.passes.len(), 3, "{:#?}", planned.plan.passes);
    assert!(matches!(planned.plan.passes[0].geometry, Geometry::Texels));
    let reads_3d = |i: usize| {
        let out = planned.plan.passes[i].fragment.output;
        m.reachable(&[shadec::ir::Handle::new(out as usize)]).into_iter().any(|h| {
            matches!(m.exprs[h], Expr::Lookup { texture, coords }
                if texture as usize == solid && m.info(coords).ty == shadec::ir::Ty::Vec3)
        })
    };
    assert!(reads_3d(1), "pass 2 reads the 3-D texture at a vec3");
    for i in 1..3 {
        shadec::driver::combiners_of(&planned, i).unwrap_or_else(|e| panic!("pass {i}: {e:?}"));
    }
}

/// The CPU renders of the geforce3 plan (fixed9) and the wgsl plan (f32)
/// on the bench sphere differ by at most the 3-D texture's measured bound
/// plus 3/255: ½/255 for `T`'s 8-bit store, ½/255 for each framebuffer's
/// rounding, and 1.5/255 for the 8-bit filter weights and 9-bit arithmetic
/// of the combiner model and wgsl's `rgba16f` store. Both read `T` at the
/// same coordinates; the wgsl texels hold `p` of the rasterized position,
/// the geforce3 ones the 3-D texture's trilinear value there.
#[test]
fn solid_mapping_geforce3_renders_within_its_bound_of_wgsl() {
    let scene = scene();
    let assets = scene.build().unwrap();
    let (program, _) = shadec::parser::check(&example());
    let render = |target: &str, mode: Precision| {
        let planned = plan(target, true).unwrap_or_else(|e| panic!("{target}: {e:?}"));
        let r = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
        let image = r.render(mode, 128, 128, &mut |_, _| {}).unwrap().image.to_rgba8();
        (planned, image)
    };
    let (g3, g3_image) = render("geforce3", Precision::Fixed9);
    let (_, wgsl_image) = render("wgsl", Precision::F32);
    let bound =
        g3.plan.approximations.iter().find(|a| a.rule == "solid_texture_3d").unwrap().error_bound.unwrap();
    let allowed = bound * 255.0 + 3.0;
    let diffs: Vec<u8> = g3_image.iter().zip(&wgsl_image).map(|(a, b)| a.abs_diff(*b)).collect();
    let max = *diffs.iter().max().unwrap() as f64;
    let mean = diffs.iter().map(|&d| d as f64).sum::<f64>() / diffs.len() as f64;
    eprintln!("solid mapping geforce3 vs wgsl: max {max}/255, mean {mean:.3}/255, allowed {allowed:.1}/255");
    assert!(max <= allowed, "max {max}/255 over {allowed:.1}/255");
    assert!(max > 1.0, "the 3-D texture's error shows: the comparison sees the two plans");
}

/// GeForce 256 had no 3-D textures: for a scene too, refused at the float
/// texture's reads, the help naming the target that has them.
#[test]
fn solid_mapping_is_refused_on_geforce256_for_a_scene() {
    assert!(!Profile::resolve("geforce256").unwrap().textures_3d);
    let Err(errors) = plan("geforce256", true) else { panic!("planned on geforce256") };
    assert_eq!(located(&errors), vec![(27, 10), (28, 9)], "{errors:?}");
    let help = errors[0].help.as_deref().unwrap_or("");
    assert!(help.contains("3-D textures (geforce3)"), "{help}");
}

/// `compile --emit combiners --scene` for geforce3: the baked texel pass
/// has no setup; (15)'s `!!VP1.0` maps the position into the box
/// per vertex and its `!!RC1.0` writes unit 0, the 3-D texture.
#[test]
fn solid_mapping_geforce3_combiners_snapshot() {
    let run = common::shadec(&[
        "compile",
        "--emit",
        "combiners",
        "--target",
        "geforce3",
        "--scene",
        "scenes/bench_sphere.ron",
        "examples/solid_mapping.shd",
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    insta::assert_snapshot!("solid_mapping_geforce3_combiners", run.stdout);
}

/// The geforce3 plan on wgpu (lavapipe here): the 3-D texture's tiled
/// slices rendered by the baked texel pass, sampled as two bilinear
/// lookups blended along z (`backends::wgsl::codegen::solid`), against the
/// CPU's fixed9 render of the same plan.
#[cfg(feature = "gpu")]
#[test]
fn solid_mapping_geforce3_plan_on_wgpu_agrees_with_cpu() {
    use shadec::gpu::runner::Target;
    use shadec::gpu::scene_run::ScenePlan;
    let Some(gpu) = common::gpu::gpu() else { return };
    let source = example();
    let planned = plan("geforce3", true).unwrap_or_else(|e| panic!("{e:?}"));
    let (program, _) = shadec::parser::check(&source);
    let scene = scene();
    let assets = scene.build().unwrap();
    let plan = ScenePlan::new(&planned, &program, Some(&source), Precision::Fixed9, &scene, &assets)
        .unwrap_or_else(|e| panic!("{e}"));
    let wgpu = plan.render_into(&gpu, &Target::new(128, 128)).unwrap_or_else(|e| panic!("{e}")).into_raw();
    let r = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
    let cpu = r.render(Precision::Fixed9, 128, 128, &mut |_, _| {}).unwrap().image.to_rgba8();
    let n = cpu.len() / 4;
    let diff = |i: usize| (0..4).map(|c| cpu[4 * i + c].abs_diff(wgpu[4 * i + c])).max().unwrap();
    let over = (0..n).filter(|&i| diff(i) > 2).count();
    let max = (0..n).map(diff).max().unwrap();
    eprintln!(
        "solid mapping geforce3 plan, wgpu vs CPU fixed9: max {max}/255, {over} of {n} pixels over 2/255"
    );
    assert!(max <= 3 && over * 100 <= n, "{over} of {n} pixels differ by more than 2/255 (max {max}/255)");
}
