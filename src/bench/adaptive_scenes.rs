//! `--adaptive auto` on every scene of `scenes/`: for each scene and each
//! program, auto's choice ([`crate::cost::adaptive::choose`]) and full
//! against adaptive shading of the same plan measured in the same run —
//! the two frames interleaved, each repetition alternating which goes
//! first, medians — on the CPU renderer and, where a GPU is given, on
//! wgpu. What auto costs a frame is then the full frame's time over the
//! chosen frame's: 1 where auto chose full shading, the measured speed-up
//! where it chose adaptive shading (Adaptive Sample Shading, Section 2.1).

use std::fmt::Write as _;
use std::path::Path;
use std::time::{Duration, Instant};

use crate::bench::adaptive_crossover::phong_lobes;
use crate::cost::adaptive::{choose, AutoChoice, Executor};
use crate::cost::Workload;
use crate::driver::{ForScene, PlanOptions};
use crate::numerics::Precision;
use crate::profile::Profile;
use crate::renderer::plan::{compare, PlanRenderer};
use crate::renderer::{AdaptiveSettings, EdgeMode, Framebuffer};
use crate::scene::{Scene, SceneAssets};

/// The threshold and spacing `--adaptive auto` renders with.
const THRESHOLD: f32 = 0.085;
const SPACING: u32 = 16;

/// One scene, one program, one executor.
#[derive(Clone, Debug)]
pub struct SceneRow {
    pub scene: String,
    pub program: String,
    pub executor: Executor,
    /// Operations per fragment of the costliest pass into the picture.
    pub operations: usize,
    pub size: (u32, u32),
    pub choice: AutoChoice,
    pub full: Duration,
    pub adaptive: Duration,
    /// Fraction of covered fragments adaptive shading shaded (CPU only).
    pub shaded: Option<f64>,
    pub psnr_db: f64,
    /// What timed the frames: the CPU's clock, or on wgpu the adapter's
    /// timestamp queries where it has them, else submit to read-back.
    pub clock: &'static str,
}

impl SceneRow {
    /// Adaptive shading's speed-up over full shading.
    pub fn speedup(&self) -> f64 {
        self.full.as_secs_f64() / self.adaptive.as_secs_f64().max(1e-9)
    }
    /// What auto's choice made of the frame's speed: 1 for full shading.
    pub fn auto_speedup(&self) -> f64 {
        if self.choice.adaptive {
            self.speedup()
        } else {
            1.0
        }
    }
    /// Auto's speed over the faster of full and adaptive shading: 1 where
    /// auto chose the faster, below 1 by what its choice lost.
    pub fn auto_over_best(&self) -> f64 {
        self.auto_speedup() / self.speedup().max(1.0)
    }
}

/// What `run_all` measures: repetitions, executors, and the size (each
/// scene's own resolution where `None`).
#[derive(Clone, Copy, Debug)]
pub struct Measure {
    pub runs: usize,
    pub cpu: bool,
    pub gpu: bool,
    pub size: Option<(u32, u32)>,
}

fn median(mut times: Vec<Duration>) -> Duration {
    times.sort();
    times[times.len() / 2]
}

/// Times `full` and `adaptive` interleaved, `runs` times each after one
/// warm-up of each, alternating which goes first; medians, and the last
/// outputs.
fn interleaved<T>(
    runs: usize,
    mut full: impl FnMut() -> Result<T, String>,
    mut adaptive: impl FnMut() -> Result<T, String>,
) -> Result<(Duration, Duration, T, T), String> {
    let (mut f_out, mut a_out) = (full()?, adaptive()?);
    let (mut f_times, mut a_times) = (Vec::new(), Vec::new());
    for r in 0..runs.max(1) {
        for first in [r % 2 == 0, r % 2 != 0] {
            let start = Instant::now();
            if first {
                f_out = full()?;
                f_times.push(start.elapsed());
            } else {
                a_out = adaptive()?;
                a_times.push(start.elapsed());
            }
        }
    }
    Ok((median(f_times), median(a_times), f_out, a_out))
}

/// The scenes of `dir` (`*.ron`), sorted by name.
pub fn scene_files(dir: &Path) -> Result<Vec<std::path::PathBuf>, String> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .collect();
    files.sort();
    Ok(files)
}

/// Plans `source` for the scene on wgsl (specialized, as `render` does).
fn plan(source: &str, scene: &Scene, assets: &SceneAssets) -> Result<crate::driver::Compilation, String> {
    let profile = Profile::resolve("wgsl").map_err(|e| e.to_string())?;
    let options = PlanOptions { scene: Some(ForScene::specialized(scene, assets)), ..Default::default() };
    crate::driver::compile(source, &profile, &options)
        .map_err(|d| d.first().map(|d| d.message.clone()).unwrap_or_default())
}

/// One row on the CPU renderer (f32): `program` is `(name, source)`.
pub fn cpu_row(
    (name, scene, assets, size): (&str, &Scene, &SceneAssets, (u32, u32)),
    (program, source): (&str, &str),
    runs: usize,
) -> Result<SceneRow, String> {
    let compiled = plan(source, scene, assets)?;
    let planned = &compiled.planned;
    let workload = Workload::of_scene(scene, &assets.meshes, name);
    let choice = choose(&planned.plan, &workload, size, Executor::Cpu);
    let renderer = PlanRenderer::new(planned, &compiled.program, scene, assets).map_err(|e| e.to_string())?;
    let settings = AdaptiveSettings::new(SPACING, THRESHOLD, EdgeMode::Pass);
    let (w, h) = size;
    let (full, adaptive, f, a) = interleaved(
        runs,
        || renderer.render(Precision::F32, w, h, &mut |_, _| {}).map_err(|e| e.to_string()),
        || {
            // Each frame rasterizes its own visibility, as one of a moving camera would.
            crate::renderer::adaptive::forget_visibility();
            renderer
                .render_adaptive(Precision::F32, w, h, &settings, &mut |_, _| {})
                .map_err(|e| e.to_string())
        },
    )?;
    Ok(SceneRow {
        scene: name.into(),
        program: program.into(),
        executor: Executor::Cpu,
        operations: operations(&planned.plan),
        size,
        choice,
        full,
        adaptive,
        shaded: a.adaptive.map(|s| s.fraction_shaded()),
        psnr_db: compare(&f.image, &a.image).psnr,
        clock: "wall",
    })
}

/// Operations per fragment of the costliest pass.
fn operations(plan: &crate::pipeline::PassPlan) -> usize {
    plan.passes.iter().map(|p| p.fragment.operations).max().unwrap_or(0)
}

/// One row on wgpu: the plan's passes against `gpu::adaptive`'s, frames
/// interleaved, each frame's GPU time (timestamp queries where the
/// adapter has them, else submit to read-back).
pub fn gpu_row(
    gpu: &crate::gpu::runner::Gpu,
    (name, scene, assets, size): (&str, &Scene, &SceneAssets, (u32, u32)),
    (program, source): (&str, &str),
    runs: usize,
) -> Result<SceneRow, String> {
    use crate::gpu::adaptive::{adaptive_passes, GpuAdaptive};
    use crate::gpu::runner::{Frame, Target};
    let compiled = plan(source, scene, assets)?;
    let planned = &compiled.planned;
    let workload = Workload::of_scene(scene, &assets.meshes, name);
    let choice = choose(&planned.plan, &workload, size, Executor::Wgpu);
    let run = crate::gpu::scene_run::ScenePlan::new(
        planned,
        &compiled.program,
        Some(source),
        Precision::F32,
        scene,
        assets,
    )
    .map_err(|e| e.to_string())?;
    let target = Target::new(size.0, size.1);
    let passes = run.passes_in(&target).map_err(|e| e.to_string())?;
    let (sparse, notes) =
        adaptive_passes(&passes, &target, GpuAdaptive { spacing: SPACING, threshold: THRESHOLD });
    if let Some(note) = notes.first() {
        return Err(note.clone());
    }
    let full_frame = Frame::prepare(gpu, &target, &passes).map_err(|e| e.to_string())?;
    let sparse_frame = Frame::prepare(gpu, &target, &sparse).map_err(|e| e.to_string())?;
    let stamped = std::cell::Cell::new(true);
    let draw = |frame: &Frame| {
        let start = Instant::now();
        let (image, time) = frame.draw_timed(gpu).map_err(|e| e.to_string())?;
        stamped.set(stamped.get() && time.is_some());
        let time = time.unwrap_or_else(|| start.elapsed());
        Ok::<_, String>((time, image))
    };
    let (mut f_times, mut a_times) = (Vec::new(), Vec::new());
    let (_, mut f_image) = draw(&full_frame)?;
    let (_, mut a_image) = draw(&sparse_frame)?;
    for r in 0..runs.max(1) {
        for first in [r % 2 == 0, r % 2 != 0] {
            if first {
                let (t, image) = draw(&full_frame)?;
                f_times.push(t);
                f_image = image;
            } else {
                let (t, image) = draw(&sparse_frame)?;
                a_times.push(t);
                a_image = image;
            }
        }
    }
    let image =
        |i: &image::RgbaImage| Framebuffer::from_rgba8(size.0, size.1, i.as_raw()).map_err(|e| e.to_string());
    Ok(SceneRow {
        scene: name.into(),
        program: program.into(),
        executor: Executor::Wgpu,
        operations: operations(&planned.plan),
        size,
        choice,
        full: median(f_times),
        adaptive: median(a_times),
        shaded: None,
        psnr_db: compare(&image(&f_image)?, &image(&a_image)?).psnr,
        clock: if stamped.get() { "GPU timestamps" } else { "submit to read-back" },
    })
}

/// Loads a scene and builds its assets.
pub fn load(path: &Path) -> Result<(Scene, SceneAssets), String> {
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let assets = scene.build().map_err(|e| e.to_string())?;
    Ok((scene, assets))
}

/// The rows as a markdown table: auto's choice, full and adaptive
/// medians, the speed-up adaptive shading would give, what auto gave.
pub fn markdown(rows: &[SceneRow]) -> String {
    let mut md = String::from(
        "| executor (clock) | scene | program (ops) | size | auto chose | full ms | adaptive ms | adaptive / full speed | auto's speed | auto / best | shaded | PSNR |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} ({}) | {} | {} ({}) | {}×{} | {} | {:.1} | {:.1} | {:.2}× | {:.2}× | {:.2} | {} | {:.1} dB |",
            if r.executor == Executor::Cpu { "CPU" } else { "wgpu" },
            r.clock,
            r.scene,
            r.program,
            r.operations,
            r.size.0,
            r.size.1,
            if r.choice.adaptive { "adaptive" } else { "full" },
            r.full.as_secs_f64() * 1e3,
            r.adaptive.as_secs_f64() * 1e3,
            r.speedup(),
            r.auto_speedup(),
            r.auto_over_best(),
            r.shaded.map_or("—".into(), |f| format!("{:.1} %", 100.0 * f)),
            r.psnr_db
        );
    }
    md
}

/// The programs of the table: `examples/fragment_lighting.shd` (under
/// `root`) and Phong shaders of each of `lobes` lobes.
pub fn programs(root: &Path, lobes: &[usize]) -> Result<Vec<(String, String)>, String> {
    let path = root.join("examples/fragment_lighting.shd");
    let mut programs = vec![(
        "fragment_lighting".to_string(),
        std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?,
    )];
    for &k in lobes {
        programs.push((format!("{k} lobes"), phong_lobes(k)));
    }
    Ok(programs)
}

/// Every scene of `dir` whose name contains one of `only` (all if empty)
/// with every program, on the executors `measure` names, at its size;
/// `progress` hears of each row. A row that cannot be measured is
/// reported through `progress` and left out.
pub fn run_all(
    dir: &Path,
    programs: &[(String, String)],
    measure: &Measure,
    only: &[String],
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<SceneRow>, String> {
    let device =
        if measure.gpu { Some(crate::gpu::runner::Gpu::new().map_err(|e| e.to_string())?) } else { None };
    if let Some(gpu) = &device {
        let info = gpu.adapter_info();
        progress(&format!(
            "adapter: {} ({:?}, {:?}, driver {})",
            info.name, info.backend, info.device_type, info.driver
        ));
    }
    let mut rows = Vec::new();
    for path in scene_files(dir)? {
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        if !only.is_empty() && !only.iter().any(|o| name.contains(o.as_str())) {
            continue;
        }
        let (scene, assets) = load(&path)?;
        let size = measure.size.unwrap_or(scene.resolution);
        for (program, source) in programs {
            let at = (name.as_str(), &scene, &assets, size);
            let mut measured = Vec::new();
            if measure.cpu {
                measured.push(cpu_row(at, (program, source), measure.runs));
            }
            if let Some(gpu) = &device {
                measured.push(gpu_row(gpu, at, (program, source), measure.runs));
            }
            for row in measured {
                match row {
                    Ok(row) => {
                        progress(&format!(
                            "{name} {program} {}: {:.2}× (auto chose {}, {:.2} of the best)",
                            if row.executor == Executor::Cpu { "CPU" } else { "wgpu" },
                            row.speedup(),
                            if row.choice.adaptive { "adaptive" } else { "full" },
                            row.auto_over_best()
                        ));
                        rows.push(row);
                    }
                    Err(e) => progress(&format!("{name} {program}: {e}")),
                }
            }
        }
    }
    Ok(rows)
}

/// `shadec bench --adaptive-scenes`: the table over `root`'s `scenes/`
/// (programs: fragment lighting and Phong shaders of each of `lobes`
/// lobes), progress on standard error; on the CPU renderer, or with
/// `measure.gpu` on wgpu.
pub fn report(root: &Path, measure: &Measure, lobes: &[usize], only: Option<&str>) -> Result<String, String> {
    let programs = programs(root, lobes)?;
    let only: Vec<String> = only.map(|o| o.split(',').map(str::to_string).collect()).unwrap_or_default();
    let rows = run_all(&root.join("scenes"), &programs, measure, &only, &mut |line| eprintln!("{line}"))?;
    Ok(markdown(&rows))
}
