//! Blended passes over overlapping geometry (issue 33, the seventeenth
//! session). A statement that opens a framebuffer with a blend onto it —
//! `C δπx ← (C δπx) ⊕[add] …` as the first write into C, the accumulation
//! of Pipeline Grammar, eqs. (9) and (11) — means the visible surface's
//! fragment added to what C held; drawn in the scene's triangle order with
//! depth `Less`, every fragment nearer than those drawn before it was
//! added, also those a nearer surface drawn later hides. The planner now
//! draws a depth-only pass first (colour writes off, `Less`, writing
//! depth) and the blended pass tests `Equal`; a plan whose first draw
//! replaces gets none. On `lights_matte_floor.ron` (a ball over a floor,
//! the floor drawn first) the CPU and wgpu were 132-163/255 off the
//! reference on 5-6 % of the pixels.

use shadec::numerics::Precision;
use shadec::pipeline::{BlendState, CompareFunc, DepthState, Geometry, Pass};
use shadec::profile::Profile;

use crate::three_way::{render_three, scene, verdict};

const SCENE: &str = "lights_matte_floor.ron";

fn example(name: &str) -> String {
    std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples").join(name))
        .unwrap()
}

fn plan(source: &str, target: &str) -> Vec<Pass> {
    let profile = Profile::resolve(target).unwrap();
    let compiled = shadec::driver::compile(source, &profile, &Default::default())
        .unwrap_or_else(|d| panic!("{target}: {:?}", d.iter().map(|d| &d.message).collect::<Vec<_>>()));
    compiled.planned.plan.passes
}

/// A depth-only pass: a mesh, `Less` with write, no colour written.
fn depth_only(p: &Pass) -> bool {
    matches!(p.geometry, Geometry::Mesh { .. })
        && p.state.depth == DepthState::LESS_WRITE
        && p.state.blend.write_mask == [false; 4]
}

/// The combinations `three_ways` renders: wgsl in f32, the combiner
/// targets in f32 and fixed9.
const EVERY_TARGET: [(&str, Precision); 5] = [
    ("wgsl", Precision::F32),
    ("geforce3", Precision::F32),
    ("geforce3", Precision::Fixed9),
    ("geforce256", Precision::Fixed9),
    ("multitexture", Precision::Fixed9),
];

/// `source` three ways on `lights_matte_floor.ron` for each of `targets`,
/// wgpu running every plan; `plan_check` first sees each target's program.
fn three_ways_on(
    source: &str,
    targets: &[(&str, Precision)],
    plan_check: &dyn Fn(&str, &str),
) -> Result<(), String> {
    let sc = scene(SCENE);
    let g = crate::common::gpu::gpu();
    let mut failures = Vec::new();
    for &(target, precision) in targets {
        let program = format!("target {target};\n{source}");
        plan_check(&program, target);
        let result = render_three(&program, target, &sc, precision, g.as_ref()).and_then(|p| {
            if let Some(why) = &p.gpu_refused {
                return Err(format!("wgpu does not run it: {why}"));
            }
            match precision {
                Precision::Fixed9 => crate::three_way_generated::fixed9_verdict(&p, &mut 0),
                _ => verdict(&p),
            }
        });
        if let Err(e) = result {
            failures.push(format!("{target} ({precision:?}): {e}"));
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("\n"))
    }
}

/// `source` three ways on every target of [`EVERY_TARGET`].
fn three_ways(source: &str) -> Result<(), String> {
    three_ways_on(source, &EVERY_TARGET, &|_, _| {})
}

/// Pipeline Grammar's accumulation buffer (eq. (11), `examples/accumulation_buffer.shd`)
/// adds only the visible surface: the CPU, wgpu and the reference agree.
#[test]
fn an_accumulation_into_a_fresh_framebuffer_adds_only_the_visible_surface() {
    three_ways(&example("accumulation_buffer.shd")).unwrap_or_else(|e| panic!("{e}"));
}

/// The multipass forms (9)-(10) (`examples/multipass.shd`): the first
/// statement adds onto the cleared C, the second reuses its vertices.
#[test]
fn a_multipass_accumulation_adds_only_the_visible_surface() {
    three_ways(&example("multipass.shd")).unwrap_or_else(|e| panic!("{e}"));
}

/// The plan of the accumulation buffer: a depth-only pass, then the
/// blended pass testing `Equal` without depth writes, on every target.
#[test]
fn a_blended_first_draw_is_preceded_by_a_depth_only_pass() {
    for target in ["wgsl", "geforce3", "geforce256", "multitexture"] {
        let passes = plan(&example("accumulation_buffer.shd"), target);
        assert_eq!(passes.len(), 2, "{target}");
        assert!(depth_only(&passes[0]), "{target}: {:?}", passes[0].state);
        assert!(!passes[0].state.stencil.enabled, "{target}");
        assert_eq!(passes[1].state.depth, DepthState::EQUAL_NO_WRITE, "{target}");
        assert_eq!(passes[1].state.blend, BlendState::ADD, "{target}");
        // The same geometry; nothing to discard, so no lookups and no
        // arithmetic in the depth-only pass (its colour is not written).
        assert_eq!(passes[0].vertex.position, passes[1].vertex.position, "{target}");
        assert_eq!(passes[0].geometry, passes[1].geometry, "{target}");
        assert!(passes[0].textures.is_empty() && passes[0].vertex.interpolants.is_empty(), "{target}");
        assert_eq!((passes[0].fragment.operations, passes[0].fragment.condition), (0, None), "{target}");
    }
}

/// A first draw that replaces needs no depth-only pass: the nearest
/// fragment's colour is the last one written. Nor does a later blended
/// statement over the same geometry (it tests `Equal`).
#[test]
fn a_first_draw_that_replaces_gets_no_depth_only_pass() {
    let source = "vector N : normal;\nvector L : light(0);\nshader p : s → c = max(0, N·L);\n\
                  C δπx ← 0.5 * δ p s x;\nC δπx ← (C δπx) ⊕[add] (0.25 * δ p s x);\n";
    for target in ["wgsl", "geforce3", "geforce256"] {
        let passes = plan(source, target);
        assert!(
            !passes.iter().any(depth_only),
            "{target}: {:?}",
            passes.iter().map(|p| p.state).collect::<Vec<_>>()
        );
        assert_eq!(passes[0].state.depth.func, CompareFunc::Less, "{target}");
        assert!(passes[1..].iter().all(|p| p.state.depth == DepthState::EQUAL_NO_WRITE), "{target}");
    }
}

/// Adaptive sample shading draws a plan with a depth-only pass as full
/// shading does: at threshold 0 the same picture, bit for bit (the
/// depth-only pass writes no colour, the blended pass over it tests `Equal`).
#[test]
fn a_plan_with_a_depth_only_pass_shades_adaptively_as_in_full() {
    use shadec::driver::{compile, ForScene, PlanOptions};
    use shadec::renderer::plan::{compare, PlanRenderer};
    use shadec::renderer::{AdaptiveSettings, EdgeMode};
    let sc = scene(SCENE);
    let assets = sc.build().unwrap();
    let profile = Profile::resolve("wgsl").unwrap();
    let options = PlanOptions { scene: Some(ForScene::specialized(&sc, &assets)), ..Default::default() };
    let compiled = compile(&example("accumulation_buffer.shd"), &profile, &options).unwrap();
    let passes = &compiled.planned.plan.passes;
    assert!(depth_only(&passes[0]), "{:?}", passes[0].state);
    assert!(passes[1..].iter().all(|p| p.state.depth == DepthState::EQUAL_NO_WRITE));
    let renderer = PlanRenderer::new(&compiled.planned, &compiled.program, &sc, &assets).unwrap();
    let settings = AdaptiveSettings::new(16, 0.0, EdgeMode::Pass);
    let full = renderer.render(Precision::F32, 160, 120, &mut |_, _| {}).unwrap();
    let adaptive = renderer.render_adaptive(Precision::F32, 160, 120, &settings, &mut |_, _| {}).unwrap();
    assert!(
        full.image.to_rgba_f32() == adaptive.image.to_rgba_f32(),
        "{:?}",
        compare(&full.image, &adaptive.image)
    );
}

/// Where the blended pass discards (`c ? …`), the depth-only pass discards
/// the same fragments (a dropped fragment writes no depth, so the surface
/// behind it is the visible one): it keeps the blended pass's fragment
/// stage. `tests/data/heldout_seventeenth_ref/cutout_accum.shd` renders
/// it three ways.
#[test]
fn a_depth_only_pass_discards_what_the_blended_pass_discards() {
    let folder = crate::three_way_heldout::data("heldout_seventeenth_ref");
    let source = std::fs::read_to_string(folder.join("cutout_accum.shd")).unwrap();
    let passes = plan(&source, "wgsl");
    assert_eq!(passes.len(), 2);
    assert!(depth_only(&passes[0]), "{:?}", passes[0].state);
    assert!(passes[1].fragment.condition.is_some());
    assert_eq!(passes[0].fragment, passes[1].fragment);
    assert_eq!(passes[0].textures, passes[1].textures);
}

/// The plan of `source` for `target` as `render_three` makes it on
/// `lights_matte_floor.ron` (specialized for its lights).
fn scene_plan(source: &str, target: &str) -> shadec::pipeline::PassPlan {
    use shadec::driver::{compile, ForScene, PlanOptions};
    let sc = scene(SCENE);
    let assets = sc.build().unwrap();
    let profile = Profile::resolve(target).unwrap();
    let options = PlanOptions { scene: Some(ForScene::specialized(&sc, &assets)), ..Default::default() };
    compile(source, &profile, &options).unwrap().planned.plan
}

/// Texture shading (Pipeline Grammar, eq. (13), `examples/texture_shading.shd`)
/// on geforce256, which computes `x^20` as several blended passes
/// (`power_by_passes`: a pass that writes `x`, then passes that modulate
/// by it), over a floor and a ball whose texture coordinates both span
/// [0, 1]²: each object's draw in texture space writes the same texels.
/// The statement means, per object, its whole value written (the ball,
/// drawn last, wins); drawn pass by pass, the second pass modulated what
/// the other object's first pass left (175/255 off on every pixel, the
/// CPU and wgpu alike). The plan now draws a statement split in texture
/// space object by object (`Pass::object_major`).
#[test]
fn a_statement_split_in_texture_space_is_drawn_object_by_object() {
    let source = example("texture_shading.shd");
    let targets = [("geforce256", Precision::F32), ("geforce256", Precision::Fixed9)];
    let split_in_texture_space = |program: &str, target: &str| {
        let plan = scene_plan(program, target);
        assert!(
            plan.approximations.iter().any(|a| a.rule == "power_by_passes"),
            "{target}: {:?}",
            plan.approximations.iter().map(|a| &a.rule).collect::<Vec<_>>()
        );
    };
    three_ways_on(&source, &targets, &split_in_texture_space).unwrap_or_else(|e| panic!("{e}"));
}

/// The plan says so: the passes into `T` are one object-major group, the
/// pass into C is drawn pass by pass; the draws of the two objects are all
/// of `T`'s passes for the floor, then all for the ball, then C's.
#[test]
fn the_passes_of_a_texture_space_split_form_one_object_major_group() {
    let plan = scene_plan(&format!("target geforce256;\n{}", example("texture_shading.shd")), "geforce256");
    let into_t: Vec<usize> = (0..plan.passes.len())
        .filter(|&i| matches!(&plan.passes[i].target, shadec::pipeline::RenderTarget::Texture { name } if name == "T"))
        .collect();
    assert!(into_t.len() > 1, "{}", plan.summary());
    let group = plan.passes[into_t[0]].object_major;
    assert!(group.is_some(), "{}", plan.summary());
    assert!(into_t.iter().all(|&i| plan.passes[i].object_major == group));
    assert!(plan
        .passes
        .iter()
        .filter(|p| !matches!(p.target, shadec::pipeline::RenderTarget::Texture { .. }))
        .all(|p| p.object_major.is_none()));
    let draws = plan.draws(2);
    let order: Vec<(usize, Option<Vec<usize>>)> = draws.iter().map(|d| (d.pass, d.objects.clone())).collect();
    let mut expected: Vec<(usize, Option<Vec<usize>>)> = Vec::new();
    for object in 0..2 {
        expected.extend(into_t.iter().map(|&i| (i, Some(vec![object]))));
    }
    expected.extend(
        (0..plan.passes.len()).filter(|i| !into_t.contains(i)).map(|i| (i, plan.passes[i].objects.clone())),
    );
    assert_eq!(order, expected);
    // Each pass's first draw is marked once.
    assert_eq!(draws.iter().filter(|d| d.first).count(), plan.passes.len());
}
