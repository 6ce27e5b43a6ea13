//! Per-object light culling on wgpu (Adaptive Sample Shading, Section 2.2):
//! a light's pass that the planner keeps only for the objects the light can
//! reach (`Pass::objects`) draws only those objects on wgpu, as on the CPU.
//! The wgpu scene runner drew every object in every light's pass before.

use std::path::Path;

use shadec::driver::{ForScene, PlanOptions};
use shadec::gpu::scene_run::ScenePlan;
use shadec::numerics::Precision;
use shadec::pipeline::{Geometry, Planned};
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;
use shadec::scene::Scene;

use crate::three_way::{difference, scene, PIXEL_TOLERANCE};

const SIZE: u32 = 64;

fn phong() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/lights/phong_lights.shd"))
        .unwrap()
}

/// Phong with one pass per light on `scene`, culled at `threshold`.
fn plan(source: &str, scene: &Scene, threshold: Option<f64>) -> Planned {
    let (program, _) = shadec::parser::check(source);
    let (module, _) = shadec::ir::lower(&program);
    let assets = scene.build().unwrap();
    let for_scene = ForScene { cull_threshold: threshold, ..ForScene::specialized(scene, &assets) };
    let options = PlanOptions { scene: Some(for_scene), ..Default::default() };
    shadec::driver::plan(&module, &program, &Profile::resolve("wgsl").unwrap(), Some(source), &options)
        .unwrap()
}

/// The mesh draws the plan asks for: per mesh pass, its kept objects.
fn draws_wanted(planned: &Planned, objects: usize) -> usize {
    planned
        .plan
        .passes
        .iter()
        .filter(|p| matches!(p.geometry, Geometry::Mesh { .. }))
        .map(|p| p.objects.as_ref().map_or(objects, Vec::len))
        .sum()
}

#[test]
fn wgpu_draws_a_culled_light_pass_only_for_the_objects_it_reaches() {
    let gpu = crate::common::gpu::gpu().expect("no wgpu adapter: the suite needs lavapipe (see .ci/run)");
    let source = phong();
    let (program, _) = shadec::parser::check(&source);
    let mut culled_scenes = 0;
    for name in ["lights_matte_floor.ron", "lights_two_spots.ron", "adaptive_spot_cutoff.ron"] {
        let scene = scene(name);
        let assets = scene.build().unwrap();
        let planned = plan(&source, &scene, Some(0.05));
        let objects = scene.objects.len();
        let wanted = draws_wanted(&planned, objects);
        let plan_gpu =
            ScenePlan::new(&planned, &program, Some(&source), Precision::F32, &scene, &assets).unwrap();
        let passes = plan_gpu.passes(SIZE, SIZE).unwrap();
        let mesh_draws = passes.len()
            - planned.plan.passes.iter().filter(|p| !matches!(p.geometry, Geometry::Mesh { .. })).count();
        assert_eq!(mesh_draws, wanted, "{name}: wgpu's mesh draws against the plan's kept objects");
        if planned.plan.passes.iter().any(|p| p.objects.as_ref().is_some_and(|k| k.len() < objects)) {
            culled_scenes += 1;
        }
        // The pictures: wgpu = CPU, both culled.
        let cpu = PlanRenderer::new(&planned, &program, &scene, &assets)
            .unwrap()
            .render(Precision::F32, SIZE, SIZE, &mut |_, _| {})
            .unwrap()
            .image
            .to_rgba8();
        let wgpu = plan_gpu.render(&gpu, SIZE, SIZE).unwrap().into_raw();
        let d = difference(&cpu, &wgpu, &vec![true; (SIZE * SIZE) as usize]);
        eprintln!("{name}: {mesh_draws} mesh draws (the plan keeps {wanted}); CPU/wgpu {d:?}");
        assert!(d.within(), "{name}: CPU and wgpu differ: {d:?} (tolerance {PIXEL_TOLERANCE}/255)");
    }
    assert!(culled_scenes >= 1, "no scene culled a light from an object: not a test");
}
