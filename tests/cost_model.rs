//! The cost model (issue 19): every plan on a combiner target has a
//! predicted time; seeds/000 Section 5.4's comparison holds within its
//! tolerance; Kilgard's three GeForce 256 passes cost more than one
//! GeForce3 pass; the workload's coverage agrees with geometry it did not
//! compute and with the rasterizer's fragment counts on every example's
//! mesh plan; the model is monotone in the work it charges.

use crate::common;

use proptest::prelude::*;
use shadec::bench::timing;
use shadec::cost::{pixel_clocks, Workload};
use shadec::driver::{compile, PlanOptions};
use shadec::profile::{CostModel, Profile};
use shadec::scene::mesh::Mesh;
use shadec::scene::Scene;

/// The paper's figures are read off prose ("80 %", "about half", "slightly
/// less than half"): a predicted speed within this of the figure agrees.
const TOLERANCE: f64 = 0.08;

#[test]
fn seeds000_section_5_4_speeds_relative_to_gouraud_hold() {
    let rows = timing::section_5_4().unwrap();
    let gouraud = &rows[0];
    let speed: Vec<f64> = rows.iter().map(|r| r.speed_against(gouraud)).collect();
    let table: Vec<String> = rows
        .iter()
        .zip(&speed)
        .map(|(r, s)| format!("{}: {:.3} ms, {:.2}", r.technique, r.predicted_ms, s))
        .collect();
    // "runs at 80 % of the speed of standard Gouraud shading"
    assert!((speed[1] - 0.80).abs() <= TOLERANCE, "{table:#?}");
    // "runs with about half the speed of Gouraud shading": the paper's
    // texture-shader table lookup (DOT_PRODUCT_TEXTURE_2D, N the first row,
    // the table bound as 2-D). shadec generates no such stage yet, and a plan
    // without it is one the card could not run, so the example plans by
    // squaring and its time is not the paper's technique's (docs/combiners.md).
    // When the stage is generated this fails, and the paper's 0.50 is
    // checked again.
    assert!(speed[2] > 0.50 + TOLERANCE, "row 2 is the squaring fall-back: {table:#?}");
    // "slightly less than half the speed of standard Gouraud shading"
    assert!(speed[3] < 0.50 && speed[3] >= 0.50 - TOLERANCE, "{table:#?}");
    // The ordering the paper's table shows, of the rows planned as the
    // paper ran them: each slower than the one before.
    assert!(speed[0] > speed[1] && speed[1] > speed[3], "{table:#?}");
    // "results for other triangle counts are similar": the frame is
    // fill-bound, so the triangle count does not decide the ratios.
    for r in &rows {
        assert_eq!(r.passes, 1, "{table:#?}");
        assert!(r.bounds.iter().all(|b| b == "fill"), "{}: {:?}", r.technique, r.bounds);
    }
}

#[test]
fn kilgard_three_passes_on_a_geforce256_cost_more_than_one_on_a_geforce3() {
    let [g256, g3] = timing::kilgard().unwrap();
    assert_eq!((g256.passes, g3.passes), (3, 1));
    // Three passes, each at most a quarter of the fill rate of one GeForce3
    // pass (a single texture unit per pipe at 120 MHz against two at 200):
    // together more than three times the GeForce3's frame.
    assert!(
        g256.predicted_ms > 3.0 * g3.predicted_ms,
        "{:.3} ms vs {:.3} ms",
        g256.predicted_ms,
        g3.predicted_ms
    );
}

fn plan_of(source: &str, target: &str) -> Option<shadec::pipeline::PassPlan> {
    let profile = Profile::builtin(target).unwrap();
    compile(source, &profile, &PlanOptions::default()).ok().map(|c| c.planned.plan)
}

#[test]
fn every_plan_on_a_combiner_target_has_a_predicted_time() {
    let mut planned = 0;
    for path in common::examples() {
        let source = std::fs::read_to_string(&path).unwrap();
        for target in ["geforce256", "geforce3"] {
            let Some(plan) = plan_of(&source, target) else { continue };
            planned += 1;
            let what = format!("{} on {target}", path.display());
            let frame = plan.predicted.as_ref().unwrap_or_else(|| panic!("{what}: no predicted time"));
            let mut sum = frame.clear_us;
            for pass in &plan.passes {
                let t =
                    pass.predicted.as_ref().unwrap_or_else(|| panic!("{what}: a pass has no predicted time"));
                assert!(t.us.is_finite() && t.us >= 0.0, "{what}: {t:?}");
                assert_eq!(t.us == 0.0, pass.baked, "{what}: only a `bake` table's pass is free: {t:?}");
                sum += t.us;
            }
            assert!((sum - frame.total_us).abs() < 0.01, "{what}: {sum} ≠ {}", frame.total_us);
        }
    }
    assert!(planned >= 30, "only {planned} example plans");
    // A target without a cost model predicts nothing.
    let wgsl = plan_of(&std::fs::read_to_string(&common::examples()[0]).unwrap(), "wgsl").unwrap();
    assert!(wgsl.predicted.is_none() && wgsl.passes.iter().all(|p| p.predicted.is_none()));
}

#[test]
fn a_profile_file_with_its_own_cost_model_gets_its_own_prediction() {
    let mut fast = Profile::builtin("geforce3").unwrap();
    let source = std::fs::read_to_string("examples/gouraud.shd").unwrap();
    let slow = compile(&source, &fast, &PlanOptions::default()).unwrap().planned.plan.predicted.unwrap();
    fast.name = "twice_the_clock".into();
    fast.cost.as_mut().unwrap().clock_mhz *= 2.0;
    fast.cost.as_mut().unwrap().memory_gb_per_s *= 2.0;
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("twice.ron");
    std::fs::write(&file, fast.to_ron()).unwrap();
    let loaded = Profile::load(&file).unwrap();
    let quick = compile(&source, &loaded, &PlanOptions::default()).unwrap().planned.plan.predicted.unwrap();
    let ratio = slow.total_us / quick.total_us;
    assert!((ratio - 2.0).abs() < 0.05, "twice the clock and bandwidth: {ratio:.3}× (pass overheads aside)");
    // Without `cost:` a profile still loads, and its plans carry no prediction.
    let mut bare = loaded.clone();
    bare.cost = None;
    std::fs::write(&file, bare.to_ron()).unwrap();
    let plan =
        compile(&source, &Profile::load(&file).unwrap(), &PlanOptions::default()).unwrap().planned.plan;
    assert!(plan.predicted.is_none());
}

/// The coverage the workload measures, against geometry it did not compute.
#[test]
fn the_workload_covers_what_the_geometry_covers() {
    // The §5.4 plane fills the screen exactly once.
    let scene = Scene::parse(timing::SCREEN_MESH.ron, std::path::Path::new("")).unwrap();
    let assets = scene.build().unwrap();
    let w = Workload::of_scene(&scene, &assets.meshes, "plane");
    let o = &w.objects[0];
    assert_eq!((o.vertices, o.triangles), (101 * 101, 20_000));
    let screen = 1280.0 * 1024.0;
    assert!((o.front_pixels + o.back_pixels - screen).abs() < 1e-3 * screen, "{o:?}");
    // A fine sphere: front faces cover its silhouette, a disc of the
    // projected radius; the back faces as much again.
    let mut scene = scene.clone();
    scene.camera.eye = glam::Vec3::new(0.0, 0.0, 5.0);
    scene.camera.up = glam::Vec3::Y;
    scene.resolution = (512, 512);
    let sphere = Mesh::sphere(1.0, 256, 128).unwrap();
    let w = Workload::of_scene(&scene, &[(sphere, glam::Mat4::IDENTITY)], "sphere");
    // The silhouette of a unit sphere seen from distance d is a disc of
    // angular radius asin(1/d); on the screen its radius is
    // tan(asin(1/d)) / tan(fov/2) half-heights.
    let d: f64 = 5.0;
    let r = (1.0 / d).asin().tan() / (f64::from(scene.camera.fov_y_deg) / 2.0).to_radians().tan() * 256.0;
    let disc = std::f64::consts::PI * r * r;
    let o = &w.objects[0];
    assert!((o.front_pixels - disc).abs() < 0.01 * disc, "front {} vs disc {disc}", o.front_pixels);
    assert!((o.back_pixels - o.front_pixels).abs() < 0.02 * disc, "{o:?}");
}

fn model() -> impl Strategy<Value = CostModel> {
    (1.0..500.0f64, 1..8u32, 1..4u32, 0.0..0.5f64).prop_map(|(clock, pipes, samples, stage)| CostModel {
        clock_mhz: clock,
        pixel_pipes: pipes,
        samples_per_clock: samples,
        clocks_per_general_combiner: stage,
        ..Profile::builtin("geforce3").unwrap().cost.unwrap()
    })
}

proptest! {
    /// More texture samples or more combiner stages never make a pixel
    /// cheaper, and a pixel never takes less than one clock.
    #[test]
    fn pixel_clocks_grow_with_the_work(m in model(), samples in 0..9u32, stages in 0..9u32) {
        let base = pixel_clocks(&m, samples, stages);
        prop_assert!(base >= 1.0);
        prop_assert!(pixel_clocks(&m, samples + 1, stages) >= base);
        prop_assert!(pixel_clocks(&m, samples, stages + 1) >= base);
    }
}

/// The planner minimizes the predicted time first (issue 19 item 4): on a
/// card whose combiner stages are slow, Kilgard's three statements stay
/// three passes rather than fusing into one eight-stage pass, the reason
/// says why, and the whole-frame prediction agrees that it is faster.
#[test]
fn the_planner_prefers_the_plan_the_cost_model_predicts_faster() {
    let source = std::fs::read_to_string("examples/kilgard_bump_mapping.shd").unwrap();
    let geforce3 = Profile::builtin("geforce3").unwrap();
    let mut slow = geforce3.clone();
    slow.name = "slow_combiners".into();
    slow.cost.as_mut().unwrap().clocks_per_general_combiner = 2.0;
    let fused = compile(&source, &geforce3, &PlanOptions::default()).unwrap().planned;
    let apart = compile(&source, &slow, &PlanOptions::default()).unwrap().planned;
    assert_eq!(fused.plan.passes.len(), 1);
    assert_eq!(apart.plan.passes.len(), 3, "{}", apart.plan.summary());
    assert!(
        apart.plan.passes[1].reason.contains("the cost model predicts that slower than apart"),
        "{}",
        apart.plan.passes[1].reason
    );
    let model = slow.cost.as_ref().unwrap();
    let nominal = Workload::nominal();
    let predict =
        |p: &shadec::pipeline::Planned| shadec::cost::predict(&p.plan, &p.module, model, &nominal).total_us;
    assert!(predict(&apart) < predict(&fused), "{} vs {}", predict(&apart), predict(&fused));
}

/// Where splits that fit differ in predicted time, the first pass's
/// reason names the prediction.
#[test]
fn a_split_chosen_by_the_cost_model_says_so() {
    let source = std::fs::read_to_string("examples/chained_multitexture.shd").unwrap();
    let plan = plan_of(&source, "geforce256").unwrap();
    assert!(
        plan.passes[0].reason.contains("the cost model predicts this split the fastest"),
        "{}",
        plan.summary()
    );
}

/// The fragments the cost model charges every example's plan on the torus
/// (geforce3, planned for the scene: its projected, clipped, back-face
/// culled triangles, `cost::workload`) against the fragments the CPU
/// rasterizer actually generates for the same plan — a count the model
/// does not compute. Only plans whose every pass draws the meshes into a
/// framebuffer with back faces culled (what the model's per-object
/// coverage describes).
#[test]
fn predicted_fragments_agree_with_the_rasterizer_on_every_mesh_plan() {
    use shadec::pipeline::{Geometry, RenderTarget};
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    let scene =
        Scene::parse(&text, std::path::Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap();
    let assets = scene.build().unwrap();
    let profile = Profile::builtin("geforce3").unwrap();
    let options = PlanOptions {
        scene: Some(shadec::driver::ForScene::specialized(&scene, &assets)),
        ..Default::default()
    };
    let (mut compared, mut worst) = (0, 0.0f64);
    for path in common::examples() {
        let source = std::fs::read_to_string(&path).unwrap();
        let Ok(c) = compile(&source, &profile, &options) else { continue };
        let plan = &c.planned.plan;
        let mesh_only = plan.passes.iter().all(|p| {
            matches!(p.geometry, Geometry::Mesh { .. })
                && matches!(p.target, RenderTarget::Framebuffer { .. })
                && p.state.cull == shadec::pipeline::CullMode::Back
        });
        if !mesh_only {
            continue;
        }
        let predicted: u64 =
            plan.passes.iter().map(|p| p.predicted.as_ref().expect("a prediction").pixels).sum();
        let (w, h) = scene.resolution;
        let frame = shadec::renderer::plan::PlanRenderer::new(&c.planned, &c.program, &scene, &assets)
            .and_then(|r| r.render(shadec::numerics::Precision::F32, w, h, &mut |_, _| {}))
            .unwrap();
        let counted = frame.stats.fragments;
        let (p, n) = (predicted as f64, counted as f64);
        assert!(
            (p - n).abs() <= 0.02 * n.max(1.0),
            "{}: predicted {predicted} fragments, rasterized {counted}",
            path.display()
        );
        worst = worst.max((p - n).abs() / n.max(1.0));
        compared += 1;
    }
    eprintln!("{compared} plans: predicted fragments within {:.2} % of the rasterizer's", 100.0 * worst);
    assert!(compared >= 10, "{compared} plans compared");
}
