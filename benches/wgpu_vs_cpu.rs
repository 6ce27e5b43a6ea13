//! The CPU executor against its peer (issue 22 item 2): frame time of
//! Kilgard's bump-mapped torus (`scenes/kilgard_torus.ron`, the wgsl plan:
//! one pass) at `SHADEC_BENCH_SIZE` (default 1024)² — wgpu on whatever
//! adapter wgpu picks (lavapipe where there is no GPU) in exact and hardware
//! fidelity, against the CPU plan renderer in f32 and fixed9, batched (the
//! default) and one fragment at a time (the executor before it), with one
//! thread and all; then the geforce256 plan (3 passes, fixed9 runs the
//! generated combiner setups in the emulator). A plain timer (median of
//! `SHADEC_BENCH_RUNS`, default 9, after 2 warm-up frames), all in one run,
//! printed as the table of BENCHMARKS.md. `cargo bench --bench wgpu_vs_cpu`;
//! `SHADEC_BENCH_MODES=fixed9` (or `f32`) runs only that mode's CPU rows
//! `SHADEC_BENCH_PEER=0` skips wgpu, `SHADEC_BENCH_BATCHED=1` the
//! one-at-a-time executor (for a profiler).

#[path = "common/timing.rs"]
mod timing;

use std::path::Path;
use std::time::Duration;

use shadec::gpu::runner::Gpu;
use shadec::gpu::scene_run::ScenePlan;
use shadec::numerics::Precision;
use shadec::renderer::plan::PlanRenderer;
use shadec::scene::Scene;

fn median(f: impl FnMut()) -> Duration {
    timing::median(9, 2, f)
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

const SOURCE: &str = include_str!("../examples/kilgard_bump_mapping.shd");
const SCENE: &str = include_str!("../scenes/kilgard_torus.ron");

fn main() {
    let side: u32 = std::env::var("SHADEC_BENCH_SIZE").ok().and_then(|v| v.parse().ok()).unwrap_or(1024);
    let scene = Scene::parse(SCENE, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap();
    let assets = scene.build().unwrap();
    let (program, _) = shadec::parser::check(SOURCE);
    let plan_for = |target: &str| {
        let profile = shadec::profile::Profile::resolve(target).unwrap();
        shadec::driver::compile(SOURCE, &profile, &Default::default()).map(|c| c.planned).unwrap()
    };
    let wgsl = plan_for("wgsl");
    let geforce256 = plan_for("geforce256");
    let all = rayon::current_num_threads();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();

    let modes: Vec<Precision> = match std::env::var("SHADEC_BENCH_MODES") {
        Ok(list) => {
            [Precision::F32, Precision::Fixed9].into_iter().filter(|m| list.contains(m.name())).collect()
        }
        Err(_) => vec![Precision::F32, Precision::Fixed9],
    };
    let only_batched = std::env::var("SHADEC_BENCH_BATCHED").is_ok_and(|v| v == "1");
    let gpu = match std::env::var("SHADEC_BENCH_PEER").as_deref() {
        Ok("0") => Err("SHADEC_BENCH_PEER=0".to_string()),
        _ => Gpu::new().map_err(|e| e.to_string()),
    };
    let peers = match gpu {
        Ok(gpu) => {
            let frame = |mode| {
                let plan = ScenePlan::new(&wgsl, &program, Some(SOURCE), mode, &scene, &assets).unwrap();
                median(|| drop(plan.render(&gpu, side, side).unwrap()))
            };
            println!("adapter: {gpu}");
            Some([frame(Precision::F32), frame(Precision::Fixed9)])
        }
        Err(e) => {
            println!("no GPU adapter ({e}): no peer to compare with");
            None
        }
    };

    println!(
        "Kilgard torus at {side}×{side}, median whole frame; the peer: the wgsl plan on wgpu (f32: exact fidelity, fixed9: hardware fidelity)"
    );
    println!(
        "| plan | mode | executor | 1 thread: ms | {all} threads: ms | speed-up | {all} threads / wgpu |"
    );
    println!("|---|---|---|---|---|---|---|");
    if let Some([f, h]) = peers {
        println!("| wgsl (1 pass) | f32 | wgpu | | {:.1} | | 1.00× |", ms(f));
        println!("| wgsl (1 pass) | fixed9 | wgpu | | {:.1} | | 1.00× |", ms(h));
    }
    for (name, planned) in [("wgsl (1 pass)", &wgsl), ("geforce256 (3 passes)", &geforce256)] {
        let mut cpu = PlanRenderer::new(planned, &program, &scene, &assets).unwrap();
        for &mode in &modes {
            for batched in [false, true].into_iter().filter(|&b| b || !only_batched) {
                cpu.set_batched(batched);
                let frame = || drop(cpu.render(mode, side, side, &mut |_, _| {}).unwrap());
                let t1 = one.install(|| median(frame));
                let tn = median(frame);
                let peer = match (peers, mode, planned.plan.passes.len()) {
                    (Some([f, _]), Precision::F32, 1) => format!("{:.2}×", ms(tn) / ms(f)),
                    (Some([_, h]), Precision::Fixed9, 1) => format!("{:.2}×", ms(tn) / ms(h)),
                    _ => String::new(),
                };
                println!(
                    "| {name} | {} | CPU, {} | {:.1} | {:.1} | {:.2}× | {peer} |",
                    mode.name(),
                    if batched { "batched" } else { "one fragment at a time" },
                    ms(t1),
                    ms(tn),
                    ms(t1) / ms(tn),
                );
            }
        }
    }
}
