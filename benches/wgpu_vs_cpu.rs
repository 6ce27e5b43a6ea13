//! The CPU executor against its peer (issue 22 item 2, issue 37): frame
//! time of Kilgard's bump-mapped torus (`scenes/kilgard_torus.ron`, the
//! wgsl plan: one pass) at each size of `SHADEC_BENCH_SIZES` (default
//! `1024,2048`) — wgpu on whatever adapter wgpu picks (lavapipe where there
//! is no GPU) in exact and hardware fidelity, against the CPU plan renderer
//! in the same run: f32 through the three lane dispatches (the compiled
//! lane kernels, the default; the same kernels compiled into closures; the
//! batch interpreter before them), fixed9 batched; then the share of the
//! rasterizer (the same scene with a fragment stage that only adds two
//! interpolated vectors). A plain timer (median of `SHADEC_BENCH_RUNS`,
//! default 9, after 2 warm-up frames), printed as the table of
//! BENCHMARKS.md, with the ratio CPU / wgpu of each row.
//!
//! The CPU renderer renders every frame into the last frame's buffers
//! (`PlanRenderer::recycle`), as a swap chain does.
//!
//! Each row also gives the process's CPU time per frame (user + system of
//! every thread, rayon's and lavapipe's, from `/proc/self/stat` in 10 ms
//! ticks, warm-ups included) and its ratio to wgpu's: on a machine shared
//! with other work the wall time is mostly waiting for a core, the CPU
//! time is what a frame cost.
//!
//! Threads: the CPU renderer runs on rayon's pool, lavapipe on its own
//! (`LP_NUM_THREADS`). For one thread on both sides run
//! `LP_NUM_THREADS=1 RAYON_NUM_THREADS=1 cargo bench --bench wgpu_vs_cpu`.
//! The peer's whole frame makes its pipelines, uploads and targets every
//! frame (`ScenePlan::render`); a second peer row, `f32` only, times the
//! same frame prepared once ([`Frame::prepare`]) and drawn and read back
//! per frame ([`Frame::draw`]), as the CPU renderer binds its textures
//! once: the difference is the peer's cost per frame that does not grow
//! with the size.
//! `SHADEC_BENCH_PEER=0` skips wgpu, `SHADEC_BENCH_MODES=f32` (or
//! `fixed9`) runs only that mode's CPU rows, `SHADEC_BENCH_DISPATCH=kernels`
//! (a comma list of `kernels`, `closures`, `interpreter`) only those f32
//! dispatches. `SHADEC_BENCH_RASTER=0` skips the rasterizer-only row (to
//! profile the lane kernels' frame alone).

#[path = "common/timing.rs"]
mod timing;

use std::path::Path;
use std::time::Duration;

use shadec::gpu::runner::{Frame, Gpu, Target};
use shadec::gpu::scene_run::ScenePlan;
use shadec::numerics::Precision;
use shadec::renderer::plan::{set_lane_dispatch, LaneDispatch, PlanRenderer};
use shadec::scene::Scene;

/// The median wall time of a frame, and the process's CPU time per frame
/// over the same frames (warm-ups included), where Linux gives it.
fn median(f: impl FnMut()) -> (Duration, Option<Duration>) {
    let runs: u32 = std::env::var("SHADEC_BENCH_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(9).max(1);
    let before = cpu_time();
    let wall = timing::median(9, 2, f);
    let per_frame = cpu_time().zip(before).map(|(after, before)| (after - before) / (runs + 2));
    (wall, per_frame)
}

/// The CPU time of this process so far, every thread (rayon's and
/// lavapipe's): user + system from `/proc/self/stat`, in ticks of 10 ms.
/// On a loaded machine it is what a frame cost, where the wall time is
/// mostly waiting for a core.
fn cpu_time() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat[stat.rfind(')')? + 2..].split(' ').collect();
    // Fields 14 and 15 (utime, stime); the slice starts at field 3.
    let ticks: u64 = fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?;
    Some(Duration::from_millis(ticks * 10))
}

/// A per-frame CPU time as a table cell.
fn cpu_ms(t: Option<Duration>) -> String {
    t.map(|t| format!("{:.0}", ms(t))).unwrap_or_default()
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

const SOURCE: &str = include_str!("../examples/kilgard_bump_mapping.shd");
const SCENE: &str = include_str!("../scenes/kilgard_torus.ron");
/// The rasterizer's share: Kilgard's two interpolated tangent-space
/// vectors added, no texture, one pass.
const RASTER_ONLY: &str = "target wgsl;
vector L : light(0) in tangent;
vector H : half(0) in tangent;
framebuffer C : rgba8, depth;
C δπx ← rgba(saturate((δ L s x) + (δ H s x)), 1);
";

fn main() {
    let sizes: Vec<u32> = std::env::var("SHADEC_BENCH_SIZES")
        .unwrap_or_else(|_| "1024,2048".into())
        .split(',')
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let scene = Scene::parse(SCENE, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap();
    let assets = scene.build().unwrap();
    let (program, _) = shadec::parser::check(SOURCE);
    let (raster_program, _) = shadec::parser::check(RASTER_ONLY);
    let plan_for = |source: &str| {
        let profile = shadec::profile::Profile::resolve("wgsl").unwrap();
        shadec::driver::compile(source, &profile, &Default::default()).map(|c| c.planned).unwrap()
    };
    let wgsl = plan_for(SOURCE);
    let raster_only = plan_for(RASTER_ONLY);
    let modes: Vec<Precision> = match std::env::var("SHADEC_BENCH_MODES") {
        Ok(list) => {
            [Precision::F32, Precision::Fixed9].into_iter().filter(|m| list.contains(m.name())).collect()
        }
        Err(_) => vec![Precision::F32, Precision::Fixed9],
    };
    let gpu = match std::env::var("SHADEC_BENCH_PEER").as_deref() {
        Ok("0") => Err("SHADEC_BENCH_PEER=0".to_string()),
        _ => Gpu::new().map_err(|e| e.to_string()),
    };
    match &gpu {
        Ok(gpu) => println!("adapter: {gpu}, LP_NUM_THREADS={:?}", std::env::var("LP_NUM_THREADS").ok()),
        Err(e) => println!("no GPU adapter ({e}): no peer to compare with"),
    }
    let threads = rayon::current_num_threads();
    println!("Kilgard torus, wgsl plan (1 pass), median whole frame, CPU on {threads} rayon threads");
    println!("| size | mode | executor | ms | CPU / wgpu | CPU time ms/frame | CPU time / wgpu's |");
    println!("|---|---|---|---|---|---|---|");
    for side in sizes {
        // The peer renders only the modes some row compares with (the
        // rasterizer-only row is `f32`'s).
        let raster_row = std::env::var("SHADEC_BENCH_RASTER").as_deref() != Ok("0");
        let peer = |mode| {
            let gpu = gpu.as_ref().ok()?;
            let compared = modes.contains(&mode) || (mode == Precision::F32 && raster_row);
            if !compared {
                return None;
            }
            let plan = ScenePlan::new(&wgsl, &program, Some(SOURCE), mode, &scene, &assets).unwrap();
            let whole = median(|| drop(plan.render(gpu, side, side).unwrap()));
            if mode == Precision::F32 {
                let target = Target::new(side, side);
                let passes = plan.passes_in(&target).unwrap();
                let frame = Frame::prepare(gpu, &target, &passes).unwrap();
                let (t, c) = median(|| drop(frame.draw(gpu).unwrap()));
                let cpu = c.zip(whole.1).map(|(c, w)| format!("{:.2}×", ms(c) / ms(w))).unwrap_or_default();
                println!(
                    "| {side}² | f32 | wgpu, prepared once (draw + read back) | {:.1} | {:.2}× | {} | {cpu} |",
                    ms(t),
                    ms(t) / ms(whole.0),
                    cpu_ms(c)
                );
            }
            Some(whole)
        };
        let peers = [peer(Precision::F32), peer(Precision::Fixed9)];
        for (mode, p) in [Precision::F32, Precision::Fixed9].into_iter().zip(peers) {
            if let Some((p, c)) = p {
                println!(
                    "| {side}² | {} | wgpu | {:.1} | 1.00× | {} | 1.00× |",
                    mode.name(),
                    ms(p),
                    cpu_ms(c)
                );
            }
        }
        let ratio =
            |(t, c): (Duration, Option<Duration>), mode| match peers[(mode == Precision::Fixed9) as usize] {
                Some((p, pc)) => {
                    let cpu = c.zip(pc).map(|(c, pc)| format!("{:.2}×", ms(c) / ms(pc))).unwrap_or_default();
                    format!("{:.2}× | {} | {cpu}", ms(t) / ms(p), cpu_ms(c))
                }
                None => format!(" | {} | ", cpu_ms(c)),
            };
        let frame = |planned, prog, mode| {
            let cpu = PlanRenderer::new(planned, prog, &scene, &assets).unwrap();
            median(|| cpu.recycle(cpu.render(mode, side, side, &mut |_, _| {}).unwrap()))
        };
        for &mode in &modes {
            let dispatches: &[(LaneDispatch, &str)] = match mode {
                Precision::F32 => &[
                    (LaneDispatch::Kernels, "CPU, lane kernels"),
                    (LaneDispatch::Closures, "CPU, lane closures"),
                    (LaneDispatch::Interpreter, "CPU, batch interpreter"),
                ],
                _ => &[(LaneDispatch::Kernels, "CPU, batched (combiner emulator)")],
            };
            let chosen = std::env::var("SHADEC_BENCH_DISPATCH").ok();
            let wanted = |d: LaneDispatch| {
                chosen.as_deref().is_none_or(|list| list.contains(&format!("{d:?}").to_lowercase()))
            };
            for &(d, name) in dispatches.iter().filter(|(d, _)| mode != Precision::F32 || wanted(*d)) {
                set_lane_dispatch(d);
                let t = frame(&wgsl, &program, mode);
                println!("| {side}² | {} | {name} | {:.1} | {} |", mode.name(), ms(t.0), ratio(t, mode));
            }
            set_lane_dispatch(LaneDispatch::Kernels);
        }
        if !raster_row {
            continue;
        }
        let t = frame(&raster_only, &raster_program, Precision::F32);
        println!(
            "| {side}² | f32 | CPU, rasterizer + interpolation only (two varyings added) | {:.1} | {} |",
            ms(t.0),
            ratio(t, Precision::F32)
        );
    }
}
