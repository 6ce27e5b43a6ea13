//! Adaptive sample shading (seeds/004) against full per-pixel shading, in
//! the same run: for the paper-like scenes and thresholds 1-16 %, the
//! fraction shaded, the time, the speed-up and the error (max abs, PSNR).
//! Writes the table to `BENCHMARKS-adaptive.md`, then runs criterion on the
//! 4-light sphere at 8.5 %.
//!
//! Timing of the table: median of `RUNS` draws each (after one warm-up),
//! all threads of the current rayon pool.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use criterion::{criterion_group, Criterion};
use shadec::renderer::lights::LitScene;
use shadec::renderer::{image_error, AdaptiveSettings, ColorFormat, EdgeMode, Framebuffer};
use shadec::scene::Scene;

const RUNS: usize = 7;
const SCENES: [&str; 4] = [
    "adaptive_sphere_4lights.ron",
    "adaptive_cube_1light.ron",
    "adaptive_cube_2lights.ron",
    "adaptive_cube_4lights.ron",
];
const THRESHOLDS: [f32; 5] = [0.01, 0.02, 0.04, 0.085, 0.16];

fn load(name: &str, cull: Option<f32>) -> (Scene, LitScene) {
    let scene = Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)).unwrap();
    let assets = scene.build().unwrap();
    let lit = LitScene::new(&scene, &assets, cull);
    (scene, lit)
}

fn median_ms(mut f: impl FnMut()) -> f64 {
    f();
    let runs = std::env::var("SHADEC_BENCH_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(RUNS).max(1);
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let s = Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(|a, b| a.partial_cmp(b).unwrap());
    t[runs / 2]
}

/// The CPU time of this process so far, every thread: user + system from
/// `/proc/self/stat`, in ticks of 10 ms (as `benches/wgpu_vs_cpu.rs`). On a
/// machine shared with other work the wall time is mostly waiting for a
/// core; the CPU time is what a frame cost.
fn cpu_time_ms() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat[stat.rfind(')')? + 2..].split(' ').collect();
    // Fields 14 and 15 (utime, stime); the slice starts at field 3.
    let ticks: u64 = fields.get(11)?.parse::<u64>().ok()? + fields.get(12)?.parse::<u64>().ok()?;
    Some(ticks as f64 * 10.0)
}

/// [`median_ms`] of `f`, and the process's CPU time per call (warm-up included).
fn median_and_cpu_ms(mut f: impl FnMut()) -> (f64, f64) {
    let runs = std::env::var("SHADEC_BENCH_RUNS").ok().and_then(|v| v.parse().ok()).unwrap_or(RUNS).max(1);
    let before = cpu_time_ms();
    let wall = median_ms(&mut f);
    let cpu = cpu_time_ms().zip(before).map_or(f64::NAN, |(a, b)| (a - b) / (runs + 1) as f64);
    (wall, cpu)
}

fn table() -> String {
    let mut out = String::new();
    let threads = rayon::current_num_threads();
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into());
    writeln!(out, "# Adaptive sample shading (seeds/004) — measured\n").unwrap();
    writeln!(out, "Command: `cargo bench --bench adaptive -- --quick` (release, `[profile.release]`).  ")
        .unwrap();
    writeln!(out, "Machine: {cpu}, {threads} rayon threads (shared machine; timings are noisy).  ").unwrap();
    writeln!(
        out,
        "Images 512×512, f32 colour; regular samples every 16 pixels, subdivision to single pixels; "
    )
    .unwrap();
    writeln!(out, "time = median of {RUNS} draws; speed-up = full time / adaptive time in the same run; error vs full per-pixel Phong (RGB in [0, 1]).  ").unwrap();
    writeln!(out, "Edges `pass`: only silhouettes and object boundaries are edge samples; `triangle`: every pixel next to another triangle (the paper's edge samples).  ").unwrap();
    writeln!(out, "Culling: per-polygon light relevance (seeds/004 §2.2) with tolerance 1 % (total culling error < 1 %).\n").unwrap();
    writeln!(out, "Paper (seeds/004 §4.1, threshold 8.5 %): sphere 19.25 %, cube 1 light 5.12 %, 2 lights 17.32 %, 4 lights 18.01 % shaded (no timings, no error figures).\n").unwrap();
    writeln!(out, "| scene | edges | culling | threshold | shaded % | full ms | adaptive ms | speed-up | max abs | PSNR dB | terms skipped % |").unwrap();
    writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|").unwrap();
    for name in SCENES {
        let (scene, lit) = load(name, None);
        let (_, culled) = load(name, Some(0.01));
        let (w, h) = scene.resolution;
        let mut fb = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
        let full_ms = median_ms(|| {
            fb = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
            lit.draw_full(&mut fb).unwrap();
        });
        let reference = fb.to_rgba_f32();
        let full_culled_ms = median_ms(|| {
            let mut f = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
            culled.draw_full(&mut f).unwrap();
        });
        {
            let mut f = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
            culled.take_term_counts();
            culled.draw_full(&mut f).unwrap();
            let c = culled.take_term_counts();
            let e = image_error(&reference, &f.to_rgba_f32());
            let skipped = 100.0 * c.skipped as f64 / (c.skipped + c.evaluated).max(1) as f64;
            writeln!(
                out,
                "| {name} | – | on | full | 100.00 | {full_ms:.2} | {full_culled_ms:.2} | {:.2} | {:.4} | {:.1} | {skipped:.1} |",
                full_ms / full_culled_ms,
                e.max_abs,
                e.psnr
            )
            .unwrap();
        }
        for edges in [EdgeMode::Pass, EdgeMode::Triangle] {
            for cull in [false, true] {
                let l = if cull { &culled } else { &lit };
                for t in THRESHOLDS {
                    let settings = AdaptiveSettings::new(16, t, edges);
                    let mut f = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
                    l.take_term_counts();
                    let stats = l.draw_adaptive(&mut f, &settings).unwrap();
                    let c = l.take_term_counts();
                    let e = image_error(&reference, &f.to_rgba_f32());
                    let ms = median_ms(|| {
                        let mut f = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
                        l.draw_adaptive(&mut f, &settings).unwrap();
                    });
                    let skipped = 100.0 * c.skipped as f64 / (c.skipped + c.evaluated).max(1) as f64;
                    writeln!(
                        out,
                        "| {name} | {} | {} | {:.1} % | {:.2} | {full_ms:.2} | {ms:.2} | {:.2} | {:.4} | {:.1} | {skipped:.1} |",
                        if edges == EdgeMode::Pass { "pass" } else { "triangle" },
                        if cull { "on" } else { "off" },
                        100.0 * t,
                        100.0 * stats.fraction_shaded(),
                        full_ms / ms,
                        e.max_abs,
                        e.psnr
                    )
                    .unwrap();
                }
            }
        }
    }
    out
}

fn criterion_sphere(c: &mut Criterion) {
    let (scene, lit) = load("adaptive_sphere_4lights.ron", None);
    let (w, h) = scene.resolution;
    let mut g = c.benchmark_group("sphere_4lights");
    g.bench_function("full", |b| {
        b.iter(|| {
            let mut f = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
            lit.draw_full(&mut f).unwrap();
        })
    });
    let settings = AdaptiveSettings::new(16, 0.085, EdgeMode::Pass);
    g.bench_function("adaptive_8.5%", |b| {
        b.iter(|| {
            let mut f = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
            lit.draw_adaptive(&mut f, &settings).unwrap();
        })
    });
    g.finish();
}

/// Issue 22 item 3: the same plan (tests/data/lights/phong_lights.shd on
/// wgsl, one pass per light, f32) end to end — full shading against
/// adaptive shading of the plan's own fragment stage, as `shadec render
/// --adaptive 0.085` runs it.
/// `phong_lights.shd` planned on wgsl for the 4-light sphere, specialized
/// to it: the plan every plan-renderer row of this bench draws.
fn sphere_plan() -> (Scene, shadec::scene::SceneAssets, shadec::driver::Compilation) {
    use shadec::driver::{compile, ForScene, PlanOptions};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = Scene::load(&root.join("scenes/adaptive_sphere_4lights.ron")).unwrap();
    let assets = scene.build().unwrap();
    let source = std::fs::read_to_string(root.join("tests/data/lights/phong_lights.shd")).unwrap();
    let profile = shadec::profile::Profile::builtin("wgsl").unwrap();
    let options = PlanOptions { scene: Some(ForScene::specialized(&scene, &assets)), ..Default::default() };
    let compiled = compile(&source, &profile, &options).unwrap();
    (scene, assets, compiled)
}

fn criterion_plan_sphere(c: &mut Criterion) {
    use shadec::numerics::Precision;
    use shadec::renderer::plan::PlanRenderer;
    let (scene, assets, compiled) = sphere_plan();
    let renderer = PlanRenderer::new(&compiled.planned, &compiled.program, &scene, &assets).unwrap();
    let (w, h) = scene.resolution;
    let mut g = c.benchmark_group("plan_sphere_4lights");
    g.sample_size(20);
    g.bench_function("full", |b| b.iter(|| renderer.render(Precision::F32, w, h, &mut |_, _| {}).unwrap()));
    let settings = AdaptiveSettings::new(16, 0.085, EdgeMode::Pass);
    g.bench_function("adaptive_8.5%", |b| {
        b.iter(|| renderer.render_adaptive(Precision::F32, w, h, &settings, &mut |_, _| {}).unwrap())
    });
    g.finish();
}

criterion_group!(benches, criterion_sphere, criterion_plan_sphere);

/// Issue 37: the plan sphere end to end at 512² and 1024² (or
/// `SHADEC_BENCH_SIZES`), full against adaptive shading (8.5 %, spacing 16)
/// in the same run, plain timer (median of `SHADEC_BENCH_RUNS`, default 7,
/// after one warm-up) and the process's CPU time per frame (user + system
/// of every thread over the warm-up and the runs), with the error of the adaptive frame against the
/// full one; each first with every frame recycled into the next, then with
/// every frame dropped. `SHADEC_BENCH_PLAN_ONLY=1` prints only this table.
fn plan_sphere_table() {
    use shadec::numerics::Precision;
    use shadec::renderer::plan::{compare, PlanRenderer};
    let (scene, assets, compiled) = sphere_plan();
    let renderer = PlanRenderer::new(&compiled.planned, &compiled.program, &scene, &assets).unwrap();
    let sizes: Vec<u32> = std::env::var("SHADEC_BENCH_SIZES")
        .unwrap_or_else(|_| "512,1024".into())
        .split(',')
        .filter_map(|s| s.trim().parse().ok())
        .collect();
    let settings = AdaptiveSettings::new(16, 0.085, EdgeMode::Pass);
    println!(
        "plan sphere (phong_lights.shd, wgsl plan, 4 passes, f32), {} threads",
        rayon::current_num_threads()
    );
    println!("| size | full ms | adaptive ms | speed-up | full CPU ms | adaptive CPU ms | CPU speed-up | shaded % | PSNR dB | max abs |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for side in sizes {
        let full = renderer.render(Precision::F32, side, side, &mut |_, _| {}).unwrap();
        let adaptive =
            renderer.render_adaptive(Precision::F32, side, side, &settings, &mut |_, _| {}).unwrap();
        let e = compare(&full.image, &adaptive.image);
        let shaded = adaptive.adaptive.map_or(f64::NAN, |s| 100.0 * s.fraction_shaded());
        // "recycled": every frame, full and adaptive alike, gives its image
        // back (`PlanRenderer::recycle`, as a swap chain does) and the next
        // clears only the tiles written; "dropped": every frame allocates
        // and faults in a fresh target, the bench before.
        for recycled in [true, false] {
            let finish = |frame: shadec::renderer::plan::Frame| {
                if recycled {
                    renderer.recycle(frame);
                }
            };
            let (full_ms, full_cpu) = median_and_cpu_ms(|| {
                finish(renderer.render(Precision::F32, side, side, &mut |_, _| {}).unwrap())
            });
            // Each frame draws the same triangles over the same cleared depth, so
            // a frame could take the last frame's visibility; "cold" forgets it
            // first, as a frame of a moving camera would have to, "kept" does not.
            for kept in [false, true] {
                let (adaptive_ms, adaptive_cpu) = median_and_cpu_ms(|| {
                    if !kept {
                        shadec::renderer::adaptive::forget_visibility();
                    }
                    finish(
                        renderer
                            .render_adaptive(Precision::F32, side, side, &settings, &mut |_, _| {})
                            .unwrap(),
                    )
                });
                println!(
                    "| {side}² {}, {} | {full_ms:.1} | {adaptive_ms:.1} | {:.2}× | {full_cpu:.0} | {adaptive_cpu:.0} | {:.2}× | {shaded:.2} | {:.1} | {:.4} |",
                    if kept { "kept" } else { "cold" },
                    if recycled { "recycled" } else { "dropped" },
                    full_ms / adaptive_ms,
                    full_cpu / adaptive_cpu,
                    e.psnr,
                    e.max_abs
                );
            }
        }
    }
}

/// `SHADEC_BENCH_PROFILE=N`: only N cold adaptive frames (recycled) of the plan sphere
/// at the first of `SHADEC_BENCH_SIZES` (default 1024), nothing else — a
/// run for a profiler.
fn profile_cold(frames: usize) {
    use shadec::numerics::Precision;
    use shadec::renderer::plan::PlanRenderer;
    let (scene, assets, compiled) = sphere_plan();
    let renderer = PlanRenderer::new(&compiled.planned, &compiled.program, &scene, &assets).unwrap();
    let side: u32 = std::env::var("SHADEC_BENCH_SIZES")
        .ok()
        .and_then(|s| s.split(',').next().and_then(|s| s.trim().parse().ok()))
        .unwrap_or(1024);
    let settings = AdaptiveSettings::new(16, 0.085, EdgeMode::Pass);
    let (wall, cpu) = median_and_cpu_ms(|| {
        for _ in 0..frames {
            shadec::renderer::adaptive::forget_visibility();
            renderer.recycle(
                renderer.render_adaptive(Precision::F32, side, side, &settings, &mut |_, _| {}).unwrap(),
            );
        }
    });
    println!(
        "{frames} cold adaptive frames at {side}²: {wall:.1} ms wall, {cpu:.0} ms CPU (median of the runs)"
    );
}

fn main() {
    if let Some(frames) = std::env::var("SHADEC_BENCH_PROFILE").ok().and_then(|v| v.parse().ok()) {
        profile_cold(frames);
        return;
    }
    plan_sphere_table();
    if std::env::var("SHADEC_BENCH_PLAN_ONLY").is_ok_and(|v| v == "1") {
        return;
    }
    let md = table();
    print!("{md}");
    std::fs::write(Path::new(env!("CARGO_MANIFEST_DIR")).join("BENCHMARKS-adaptive.md"), md).unwrap();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
