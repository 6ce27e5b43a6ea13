//! Frame time of Kilgard's bump-mapped torus (`scenes/kilgard_torus.ron`,
//! the wgsl plan: one pass) at 512×512: wgpu on whatever adapter wgpu picks
//! (lavapipe where there is no GPU) against the CPU plan renderer in f32 and
//! fixed9 modes. A simple timer (median of `SHADEC_BENCH_RUNS`, default 15,
//! after 2 warm-up frames), printed as a table for BENCHMARKS.md.
//! `cargo bench --bench wgpu_vs_cpu`.

#[path = "common/timing.rs"]
mod timing;

use std::path::Path;
use std::time::Duration;

use shadec::backends::wgsl::codegen::Fidelity;
use shadec::gpu::runner::{run_passes, Gpu, Target};
use shadec::gpu::scene_run::ScenePlan;
use shadec::renderer::plan::{Mode, PlanRenderer};
use shadec::scene::Scene;

const W: u32 = 512;
const H: u32 = 512;

/// Median of 15 runs (`SHADEC_BENCH_RUNS`) after two warm-ups.
fn median(f: impl FnMut()) -> Duration {
    timing::median(15, 2, f)
}

fn main() {
    let src =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/kilgard_bump_mapping.shd"))
            .unwrap()
            .replace("target geforce256;", "");
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    let scene = Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap();
    let assets = scene.build().unwrap();
    let profile = shadec::profile::Profile::resolve("wgsl").unwrap();
    let planned = shadec::driver::compile(&src, &profile, &Default::default()).map(|c| c.planned).unwrap();
    let (program, _) = shadec::parser::check(&src);
    let gpu = match Gpu::new() {
        Ok(g) => g,
        Err(e) => {
            eprintln!("no GPU adapter: {e}; nothing to compare");
            return;
        }
    };
    let plan = ScenePlan::new(&planned, &program, Some(&src), Fidelity::Exact, &scene, &assets).unwrap();
    let cpu = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
    let passes = plan.passes(W, H).unwrap();
    let target = Target::new(W, H);
    let gpu_full = median(|| {
        plan.render(&gpu, W, H).unwrap();
    });
    let gpu_draw = median(|| {
        run_passes(&gpu, &target, &passes).unwrap();
    });
    let f32_ = median(|| {
        cpu.render(Mode::F32, W, H, &mut |_, _| {}).unwrap();
    });
    let fixed9 = median(|| {
        cpu.render(Mode::Fixed9, W, H, &mut |_, _| {}).unwrap();
    });
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!("adapter: {gpu}");
    println!("Kilgard torus, wgsl plan ({} pass), {W}×{H}, median frame time", planned.plan.passes.len());
    println!("| path | ms/frame | CPU time / wgpu frame |");
    println!("|---|---|---|");
    println!(
        "| wgpu, whole frame (bind vertices + upload + draw + readback) | {:.2} | 1.00× |",
        ms(gpu_full)
    );
    println!(
        "| wgpu, draw + readback only (prepared passes) | {:.2} | {:.2}× |",
        ms(gpu_draw),
        ms(gpu_draw) / ms(gpu_full)
    );
    println!("| CPU plan renderer, f32 | {:.2} | {:.2}× |", ms(f32_), ms(f32_) / ms(gpu_full));
    println!("| CPU plan renderer, fixed9 | {:.2} | {:.2}× |", ms(fixed9), ms(fixed9) / ms(gpu_full));
}
