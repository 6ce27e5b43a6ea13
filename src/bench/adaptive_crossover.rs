//! The adaptive crossover (Adaptive Sample Shading, Section 2.1): the
//! shading cost per fragment above which adaptive shading beats full
//! shading, measured on both executors. The programs are Phong shaders of
//! `k` lobes each (`k` = 1, 2, 4, …: two powers per lobe, so that nothing
//! folds), on the paper's 4-light sphere, planned for the scene (one pass
//! per light) on wgsl; the cost is the plan's own measure of a fragment,
//! [`crate::pipeline::FragmentWork::operations`]. Each row times full and
//! adaptive frames of the same plan in the same run (median of `runs`
//! after a warm-up) and gives adaptive's error against full shading.
//! [`crate::cost::adaptive`] holds the crossovers `--adaptive auto` uses.

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use crate::driver::{ForScene, PlanOptions};
use crate::gpu::adaptive::{adaptive_passes, GpuAdaptive};
use crate::gpu::runner::{Frame, Gpu, Target};
use crate::gpu::scene_run::ScenePlan;
use crate::numerics::Precision;
use crate::profile::Profile;
use crate::renderer::plan::{compare, PlanRenderer};
use crate::renderer::{AdaptiveSettings, EdgeMode, Framebuffer};
use crate::scene::{Scene, SceneAssets};

/// The threshold and spacing of the paper's figures (8.5 %, every 16 pixels).
pub const THRESHOLD: f32 = 0.085;
/// The sample spacing of the paper's figures, in pixels.
pub const SPACING: u32 = 16;

/// One program of the sweep on one executor.
#[derive(Clone, Debug)]
pub struct CrossoverRow {
    pub executor: &'static str,
    pub lobes: usize,
    /// Operations per fragment of a pass into the picture.
    pub operations: usize,
    pub size: u32,
    pub full: Duration,
    pub adaptive: Duration,
    /// Adaptive against full shading of the same plan.
    pub psnr_db: f64,
}

impl CrossoverRow {
    /// How many times faster adaptive shading ran than full shading.
    pub fn speedup(&self) -> f64 {
        self.full.as_secs_f64() / self.adaptive.as_secs_f64().max(1e-9)
    }
}

/// A Phong shader of `lobes` lobes (light 0, planned per light for a
/// scene); 0 lobes: the diffuse term alone, the cheapest lit shader.
pub fn phong_lobes(lobes: usize) -> String {
    if lobes == 0 {
        return "vector N : normal;\nvector L : light(0);\n\nshader p : s → c {\n    (0.5, 0.4, 0.3) * max(0, normalize(N)·normalize(L))\n}\n\nC δπx ← p δ s x;\n".into();
    }
    let k = lobes as f64;
    let mut text = String::from(
        "vector N : normal;\nvector L : light(0);\nvector V : view;\n\nshader p : s → c {\n    let Nn = normalize(N);\n    let Ln = normalize(L);\n    let Hn = normalize(Ln + normalize(V));\n    ",
    );
    let terms: Vec<String> = (0..lobes.max(1))
        .map(|i| {
            format!(
                "({:.4}, {:.4}, {:.4}) * max(0, Nn·Ln)^{:.2} + ({:.4}, {:.4}, {:.4}) * max(0, Nn·Hn)^{}",
                0.5 / k,
                0.4 / k,
                0.3 / k,
                1.0 + 0.25 * i as f64,
                0.6 / k,
                0.6 / k,
                0.6 / k,
                8 + 4 * i
            )
        })
        .collect();
    text += &terms.join("\n    + ");
    text += "\n}\n\nC δπx ← p δ s x;\n";
    text
}

fn median(mut times: Vec<Duration>) -> Duration {
    times.sort();
    times[times.len() / 2]
}

fn timed<T>(runs: usize, mut f: impl FnMut() -> Result<T, String>) -> Result<(Duration, T), String> {
    let mut last = f()?;
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs.max(1) {
        let start = Instant::now();
        last = f()?;
        times.push(start.elapsed());
    }
    Ok((median(times), last))
}

/// The sweep on the CPU renderer (f32) and, where `gpu` is given, on wgpu.
pub fn sweep(
    gpu: Option<&Gpu>,
    (scene, assets): (&Scene, &SceneAssets),
    lobes: &[usize],
    size: u32,
    runs: usize,
) -> Result<Vec<CrossoverRow>, String> {
    let profile = Profile::resolve("wgsl").map_err(|e| e.to_string())?;
    let options = PlanOptions { scene: Some(ForScene::specialized(scene, assets)), ..Default::default() };
    let mut rows = Vec::new();
    for &k in lobes {
        let source = phong_lobes(k);
        let compiled = crate::driver::compile(&source, &profile, &options)
            .map_err(|d| d.first().map(|d| d.message.clone()).unwrap_or_default())?;
        let (planned, program) = (&compiled.planned, &compiled.program);
        let operations = planned.plan.passes.iter().map(|p| p.fragment.operations).max().unwrap_or(0);
        let renderer = PlanRenderer::new(planned, program, scene, assets).map_err(|e| e.to_string())?;
        let settings = AdaptiveSettings::new(SPACING, THRESHOLD, EdgeMode::Pass);
        let render = |adaptive: bool| {
            let frame = if adaptive {
                // Each frame rasterizes its own visibility, as one of a moving camera would.
                crate::renderer::adaptive::forget_visibility();
                renderer.render_adaptive(Precision::F32, size, size, &settings, &mut |_, _| {})
            } else {
                renderer.render(Precision::F32, size, size, &mut |_, _| {})
            };
            frame.map(|f| f.image).map_err(|e| e.to_string())
        };
        let (full, full_image) = timed(runs, || render(false))?;
        let (adaptive, image) = timed(runs, || render(true))?;
        let psnr_db = compare(&full_image, &image).psnr;
        rows.push(CrossoverRow { executor: "CPU", lobes: k, operations, size, full, adaptive, psnr_db });
        if let Some(gpu) = gpu {
            let plan = ScenePlan::new(planned, program, Some(&source), Precision::F32, scene, assets)
                .map_err(|e| e.to_string())?;
            rows.push(gpu_row(gpu, &plan, (k, operations), size, runs)?);
        }
    }
    Ok(rows)
}

fn gpu_row(
    gpu: &Gpu,
    plan: &ScenePlan,
    (lobes, operations): (usize, usize),
    size: u32,
    runs: usize,
) -> Result<CrossoverRow, String> {
    let target = Target::new(size, size);
    let passes = plan.passes_in(&target).map_err(|e| e.to_string())?;
    let settings = GpuAdaptive { spacing: SPACING, threshold: THRESHOLD };
    let (sparse, notes) = adaptive_passes(&passes, &target, settings);
    if let Some(note) = notes.first() {
        return Err(note.clone());
    }
    let draw = |passes: &[crate::gpu::runner::RunPass]| -> Result<(Duration, Framebuffer), String> {
        let frame = Frame::prepare(gpu, &target, passes).map_err(|e| e.to_string())?;
        let timed = frame.draw_median(gpu, runs).map_err(|e| e.to_string())?;
        let image = Framebuffer::from_rgba8(size, size, timed.image.as_raw()).map_err(|e| e.to_string())?;
        Ok((timed.time(), image))
    };
    let (full, full_image) = draw(&passes)?;
    let (adaptive, image) = draw(&sparse)?;
    let psnr_db = compare(&full_image, &image).psnr;
    Ok(CrossoverRow { executor: "wgpu", lobes, operations, size, full, adaptive, psnr_db })
}

/// The least operations per fragment at which adaptive shading is faster
/// on `executor`, interpolated between the sweep's rows (log of the
/// speed-up against operations); `None` when no row is faster.
pub fn crossover(rows: &[CrossoverRow], executor: &str) -> Option<f64> {
    let mine: Vec<&CrossoverRow> = rows.iter().filter(|r| r.executor == executor).collect();
    let first = mine.iter().position(|r| r.speedup() >= 1.0)?;
    if first == 0 {
        return Some(mine[0].operations as f64);
    }
    let (a, b) = (mine[first - 1], mine[first]);
    let (la, lb) = (a.speedup().ln(), b.speedup().ln());
    let t = if lb > la { -la / (lb - la) } else { 1.0 };
    Some(a.operations as f64 + t * (b.operations as f64 - a.operations as f64))
}

/// The sweep as a markdown table, with each executor's crossover.
pub fn markdown(rows: &[CrossoverRow]) -> String {
    let mut md = String::from(
        "| executor | lobes | operations per fragment | size | full ms | adaptive ms | speed-up | PSNR against full |\n|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {}² | {:.2} | {:.2} | {:.2}× | {:.1} dB |",
            r.executor,
            r.lobes,
            r.operations,
            r.size,
            r.full.as_secs_f64() * 1e3,
            r.adaptive.as_secs_f64() * 1e3,
            r.speedup(),
            r.psnr_db
        );
    }
    for executor in ["CPU", "wgpu"] {
        if rows.iter().any(|r| r.executor == executor) {
            let _ = match crossover(rows, executor) {
                Some(ops) => writeln!(
                    md,
                    "\n{executor}: adaptive is faster from about {ops:.0} operations per fragment."
                ),
                None => writeln!(md, "\n{executor}: adaptive was faster for none of these programs."),
            };
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(executor: &'static str, operations: usize, full_ms: u64, adaptive_ms: u64) -> CrossoverRow {
        CrossoverRow {
            executor,
            lobes: 1,
            operations,
            size: 64,
            full: Duration::from_millis(full_ms),
            adaptive: Duration::from_millis(adaptive_ms),
            psnr_db: 50.0,
        }
    }

    #[test]
    fn the_crossover_lies_between_the_rows_that_bracket_a_speed_up_of_one() {
        let rows = [row("wgpu", 14, 10, 20), row("wgpu", 104, 20, 10), row("CPU", 14, 20, 10)];
        let ops = crossover(&rows, "wgpu").unwrap();
        assert!((ops - 59.0).abs() < 1.0, "{ops}");
        assert_eq!(crossover(&rows, "CPU"), Some(14.0));
        assert_eq!(crossover(&[row("wgpu", 14, 10, 20)], "wgpu"), None);
    }

    #[test]
    fn every_lobe_count_gives_a_program_that_plans() {
        for k in [0, 1, 3] {
            let profile = Profile::resolve("wgsl").unwrap();
            let compiled = crate::driver::compile(&phong_lobes(k), &profile, &PlanOptions::default());
            assert!(compiled.is_ok(), "{k} lobes:\n{}", phong_lobes(k));
        }
    }
}
