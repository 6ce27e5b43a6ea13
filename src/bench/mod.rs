//! `shadec bench`: speed against error.
//!
//! Every technique variant ([`variants::groups`]) is planned for its target
//! and rendered on its scene by the CPU renderer in its precision mode; the
//! frame time is the median of several runs after a warm-up, the error is
//! measured against the group's ground truth — the *meaning* of the
//! group's reference program ([`crate::meaning`]: its statements one
//! unsplit pass each, no plan of the planner's) rendered `exact` (f64,
//! renormalized vectors, true pow, no lookup tables), so that every variant
//! of a group is compared with the same picture and a planner bug in the
//! reference cannot hide in it. [`adaptive`] adds the Adaptive Sample Shading table of
//! Adaptive Sample Shading, and [`removed_work`] what scene-driven specialization removes.
//! [`report`] writes `report.md`, the plots and the difference images.

pub mod adaptive;
#[cfg(feature = "gpu")]
pub mod adaptive_crossover;
#[cfg(feature = "gpu")]
pub mod adaptive_scenes;
pub mod front;
#[cfg(feature = "gpu")]
pub mod gpu;
#[cfg(feature = "gpu")]
pub mod gpu_check;
pub mod plot;
pub mod report;
pub mod timing;
pub mod variants;

use std::path::Path;
use std::time::Duration;

use crate::numerics::Precision;
use crate::renderer::plan::{compare, ErrorReport, Frame, PlanRenderer};
use crate::renderer::Framebuffer;
use crate::scene::Scene;

pub use variants::{groups, Group, Program, Variant};

/// How much to measure.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Image size of every variant.
    pub size: (u32, u32),
    /// Timed runs per variant (the median is reported), after one warm-up.
    pub runs: usize,
    /// Only variants (and adaptive scenes) whose name contains this.
    pub only: Option<String>,
    /// Adaptive-shading thresholds (fractions of full intensity).
    pub thresholds: Vec<f32>,
    /// What renders the variants (`bench --backend`).
    pub backend: Backend,
    /// `bench --max-error E`: a variant whose program the
    /// compiler lowers takes the fastest lowering within E measured on the
    /// group's scene (`accuracy::choose`); `None`: the most accurate.
    pub max_error: Option<f64>,
}

/// The executor `bench` times.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    /// The CPU plan renderer (`renderer::plan`).
    #[default]
    Cpu,
    /// The plan's WGSL on the adapter wgpu finds (a GPU, or lavapipe).
    Wgpu,
}

/// How a variant's time was taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Clock {
    /// The CPU renderer's wall time per frame.
    CpuWall,
    /// GPU time between the frame's first and last timestamp query.
    GpuTimestamps,
    /// wgpu without timestamp queries: submit to read-back wall time.
    WgpuWall,
}

impl Clock {
    /// The clock's name in the report.
    pub fn name(self) -> &'static str {
        match self {
            Clock::CpuWall => "CPU wall time",
            Clock::GpuTimestamps => "GPU time (timestamp queries)",
            Clock::WgpuWall => "wgpu submit to read-back wall time",
        }
    }
}

impl BenchOptions {
    /// The full settings: 512×512, 5 runs, thresholds 1 %…16 %.
    pub fn full() -> BenchOptions {
        BenchOptions {
            size: (512, 512),
            runs: 5,
            only: None,
            thresholds: vec![0.01, 0.02, 0.04, 0.085, 0.16],
            backend: Backend::Cpu,
            max_error: None,
        }
    }
    /// A quick look (tests, CI): 128×128, one run, three thresholds.
    pub fn quick() -> BenchOptions {
        BenchOptions {
            size: (128, 128),
            runs: 1,
            only: None,
            thresholds: vec![0.02, 0.085, 0.16],
            backend: Backend::Cpu,
            max_error: None,
        }
    }
    pub(crate) fn wants(&self, name: &str) -> bool {
        self.only.as_deref().is_none_or(|p| name.contains(p))
    }
}

/// One measured variant.
#[derive(Clone, Debug)]
pub struct Measured {
    pub group: &'static str,
    pub variant: Variant,
    pub passes: usize,
    /// Median time of one frame, taken by [`Measured::clock`].
    pub time: Duration,
    pub clock: Clock,
    pub error: ErrorReport,
    /// The frame time the target's cost model predicts on the group's scene
    /// at the bench size; `None` on a target without one.
    pub predicted_ms: Option<f64>,
    /// How each pass was shaded (fixed9: the generated combiner setup or
    /// the per-operation fallback, and why).
    pub shading: Vec<crate::renderer::plan::PassShading>,
    /// The rendered picture and the group's truth, for the difference image.
    pub image: Framebuffer,
    pub truth: std::sync::Arc<Framebuffer>,
}

/// What went wrong, with the variant it went wrong in.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error("{what}: {message}")]
    Variant { what: String, message: String },
    #[error("{0}")]
    Io(String),
}

pub(crate) fn failed(what: &str, message: impl std::fmt::Display) -> BenchError {
    BenchError::Variant { what: what.to_string(), message: message.to_string() }
}

/// A program planned for a target and bound to a scene, ready to render.
pub struct Prepared {
    pub planned: crate::pipeline::Planned,
    /// The lowered program, before planning: what [`Prepared::meaning`] reads.
    pub module: crate::ir::Module,
    pub program: crate::parser::ast::Program,
    pub scene: Scene,
    pub assets: crate::scene::SceneAssets,
}

impl Prepared {
    /// Parses, lowers and plans `source` for `target` on the scene's text.
    pub fn new(name: &str, source: &str, target: &str, scene_ron: &str) -> Result<Prepared, BenchError> {
        Prepared::within(name, source, target, scene_ron, None)
    }

    /// [`Prepared::new`]; with `max_error`, a lowering is chosen by its
    /// error measured on the scene (`accuracy::choose`).
    pub fn within(
        name: &str,
        source: &str,
        target: &str,
        scene_ron: &str,
        max_error: Option<f64>,
    ) -> Result<Prepared, BenchError> {
        let scene = Scene::parse(scene_ron, Path::new("")).map_err(|e| failed(name, e))?;
        let assets = scene.build().map_err(|e| failed(name, e))?;
        let profile = crate::profile::Profile::resolve(target).map_err(|e| failed(name, e))?;
        let first_error =
            |d: &[crate::diag::Diagnostic]| d.first().map(|d| d.message.clone()).unwrap_or_default();
        let refused =
            |d: Vec<crate::diag::Diagnostic>| failed(&format!("{name} on {target}"), first_error(&d));
        let front = crate::driver::front(source);
        let (program, module) = match (front.has_errors(), front.module) {
            (false, Some(module)) => (front.program, module),
            _ => return Err(refused(front.diagnostics)),
        };
        let planned = match max_error {
            None => crate::driver::plan(&module, &program, &profile, Some(source), &Default::default()),
            Some(e) => {
                let for_scene = crate::driver::ForScene::unspecialized(&scene, &assets);
                let options = crate::driver::PlanOptions { scene: Some(for_scene), ..Default::default() };
                crate::accuracy::choose(&module, &program, &profile, source, &options, e, 1).map(|(p, _)| p)
            }
        }
        .map_err(refused)?;
        Ok(Prepared { planned, module, program, scene, assets })
    }

    /// The program's meaning on this scene ([`crate::meaning::plan`]),
    /// rendered by [`PlanRenderer`] like a plan. One light: the bench plans
    /// without a scene, so its plans shade light 0 as written.
    pub fn meaning(&self) -> Result<Prepared, BenchError> {
        let planned = crate::meaning::plan(&self.module, 1)
            .map_err(|d| failed("the meaning", d.first().map(|d| d.message.clone()).unwrap_or_default()))?;
        Ok(Prepared {
            planned,
            module: self.module.clone(),
            program: self.program.clone(),
            scene: self.scene.clone(),
            assets: self.assets.clone(),
        })
    }

    /// The frame time `target`'s cost model predicts for this plan on its
    /// scene at `size`.
    pub fn predicted_ms(&self, target: &str, size: (u32, u32)) -> Option<f64> {
        let profile = crate::profile::Profile::resolve(target).ok()?;
        let model = profile.cost.as_ref()?;
        let mut scene = self.scene.clone();
        scene.resolution = size;
        let for_scene = crate::driver::ForScene::unspecialized(&scene, &self.assets);
        let workload = crate::driver::workload(Some(&for_scene));
        Some(crate::cost::predict(&self.planned.plan, &self.planned.module, model, &workload).total_ms())
    }

    /// The CPU renderer bound to the variant's scene.
    pub fn renderer(&self) -> Result<PlanRenderer<'_>, BenchError> {
        PlanRenderer::new(&self.planned, &self.program, &self.scene, &self.assets)
            .map_err(|e| failed("binding", e))
    }
}

/// Renders `runs` times after a warm-up; the last frame and the median time.
pub fn timed(
    renderer: &PlanRenderer,
    mode: Precision,
    size: (u32, u32),
    runs: usize,
) -> Result<(Frame, Duration), crate::renderer::RenderError> {
    let mut frame = renderer.render(mode, size.0, size.1, &mut |_, _| {})?;
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs.max(1) {
        frame = renderer.render(mode, size.0, size.1, &mut |_, _| {})?;
        times.push(frame.time);
    }
    Ok((frame, median(&mut times)))
}

/// The median of `times` (sorted in place); zero for none.
pub fn median(times: &mut [Duration]) -> Duration {
    times.sort();
    times.get(times.len() / 2).copied().unwrap_or_default()
}

/// Measures every variant the options select; `progress(done, total, name)`
/// after each.
pub fn measure(
    options: &BenchOptions,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<Vec<Measured>, BenchError> {
    measure_all(options, progress).map(|(measured, _)| measured)
}

/// [`measure`], and the variants `--max-error` refused, each with why.
/// A variant rendered and timed on the CPU renderer or on wgpu: its
/// picture, median frame time, the clock that took it, and (CPU) how each
/// pass was shaded.
fn run_variant(
    gpu: Option<&Executor>,
    prepared: &Prepared,
    variant: &Variant,
    options: &BenchOptions,
    what: &str,
) -> Result<(Framebuffer, Duration, Clock, Vec<crate::renderer::plan::PassShading>), BenchError> {
    match gpu {
        None => {
            // The error of the variant's arithmetic, not of the 8-bit
            // framebuffer every variant shares (`set_unrounded_targets`).
            let mut renderer = prepared.renderer()?;
            renderer.set_unrounded_targets(true);
            let (frame, time) =
                timed(&renderer, variant.mode, options.size, options.runs).map_err(|e| failed(what, e))?;
            Ok((frame.image, time, Clock::CpuWall, frame.shading))
        }
        #[cfg(feature = "gpu")]
        Some(gpu) => {
            let (image, time, clock) =
                gpu::timed(gpu, prepared, variant.program.source, variant.mode, options.size, options.runs)
                    .map_err(|e| failed(what, e))?;
            Ok((image, time, clock, Vec::new()))
        }
        #[cfg(not(feature = "gpu"))]
        Some(never) => match *never {},
    }
}

/// Every wanted variant of every group rendered and timed against its
/// group's exact truth, with progress; and, with `--max-error`, the
/// variants refused because no lowering is within it.
pub fn measure_all(
    options: &BenchOptions,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<(Vec<Measured>, Vec<String>), BenchError> {
    let groups: Vec<Group> =
        groups().into_iter().filter(|g| g.variants.iter().any(|v| options.wants(v.name))).collect();
    let total = groups.iter().map(|g| g.variants.iter().filter(|v| options.wants(v.name)).count()).sum();
    let mut done = 0;
    let mut out = Vec::new();
    let mut refused = Vec::new();
    let gpu = executor(options.backend)?;
    for group in &groups {
        let truth = Prepared::new(group.truth.name, group.truth.source, group.truth_target, group.scene.ron)?
            .meaning()?;
        let truth_frame = truth
            .renderer()?
            .render(Precision::Exact, options.size.0, options.size.1, &mut |_, _| {})
            .map_err(|e| failed(group.truth.name, e))?;
        let truth_image = std::sync::Arc::new(truth_frame.image);
        for variant in group.variants.iter().filter(|v| options.wants(v.name)) {
            let what = format!(
                "{} ({} on {}, {})",
                variant.name,
                variant.program.name,
                variant.target,
                variant.mode.name()
            );
            let prepared = match Prepared::within(
                &what,
                variant.program.source,
                variant.target,
                group.scene.ron,
                options.max_error,
            ) {
                Ok(p) => p,
                Err(e) if options.max_error.is_some() => {
                    refused.push(e.to_string());
                    done += 1;
                    progress(done, total, variant.name);
                    continue;
                }
                Err(e) => return Err(e),
            };
            let (image, time, clock, shading) =
                run_variant(gpu.as_ref(), &prepared, variant, options, &what)?;
            out.push(Measured {
                group: group.name,
                variant: *variant,
                passes: prepared.planned.plan.passes.len(),
                time,
                clock,
                error: compare(&truth_image, &image),
                predicted_ms: prepared.predicted_ms(variant.target, options.size),
                shading,
                image,
                truth: truth_image.clone(),
            });
            done += 1;
            progress(done, total, variant.name);
        }
    }
    Ok((out, refused))
}

/// What `bench --backend wgpu` renders on: a wgpu adapter.
#[cfg(feature = "gpu")]
type Executor = crate::gpu::runner::Gpu;
/// Without the `gpu` feature there is no wgpu executor.
#[cfg(not(feature = "gpu"))]
type Executor = std::convert::Infallible;

/// The adapter `bench --backend wgpu` runs on; `None` for the CPU.
#[cfg(feature = "gpu")]
fn executor(backend: Backend) -> Result<Option<Executor>, BenchError> {
    match backend {
        Backend::Cpu => Ok(None),
        Backend::Wgpu => crate::gpu::runner::Gpu::new().map(Some).map_err(|e| failed("wgpu", e)),
    }
}

#[cfg(not(feature = "gpu"))]
fn executor(backend: Backend) -> Result<Option<Executor>, BenchError> {
    match backend {
        Backend::Cpu => Ok(None),
        Backend::Wgpu => Err(failed("wgpu", "this shadec was built without the `gpu` feature")),
    }
}

/// Runs the whole bench and writes `report.md`, `speed_vs_error.png`,
/// `adaptive.png` and `diff/*.png` into `out_dir`.
pub fn run(
    options: &BenchOptions,
    out_dir: &Path,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<report::Report, BenchError> {
    let (measured, refused) = measure_all(options, progress)?;
    let adaptive = adaptive::measure(options, progress)?;
    let removed = removed_work()?;
    let hardware = report::Hardware { section_5_4: timing::section_5_4()?, kilgard: timing::kilgard()? };
    let report = report::Report {
        options: options.clone(),
        measured,
        refused,
        adaptive,
        removed,
        hardware: Some(hardware),
    };
    report.write(out_dir)?;
    Ok(report)
}

/// What scene-driven specialization removes, for the
/// scenes where it matters: `planner::specialize::removal_report` in
/// Markdown, one section per (program, scene).
pub fn removed_work() -> Result<String, BenchError> {
    let cases: [(&str, &str, &str, &str, &str); 2] = [
        (
            "tests/data/lights/phong_lights.shd",
            include_str!("../../tests/data/lights/phong_lights.shd"),
            "scenes/lights_matte_floor.ron",
            include_str!("../../scenes/lights_matte_floor.ron"),
            "wgsl",
        ),
        (
            "examples/fragment_lighting.shd",
            include_str!("../../examples/fragment_lighting.shd"),
            "scenes/adaptive_sphere_4lights.ron",
            include_str!("../../scenes/adaptive_sphere_4lights.ron"),
            "wgsl",
        ),
    ];
    let mut md = String::new();
    for (program, source, scene_name, scene_ron, target) in cases {
        let scene = Scene::parse(scene_ron, Path::new("")).map_err(|e| failed(scene_name, e))?;
        let profile = crate::profile::Profile::resolve(target).map_err(|e| failed(target, e))?;
        let report = crate::driver::removal_report(source, &profile, &scene)
            .map_err(|d| failed(program, d.first().map(|d| d.message.clone()).unwrap_or_default()))?;
        md.push_str(&format!("### `{program}` on `{scene_name}` ({target})\n\n{}\n", report.to_markdown()));
    }
    Ok(md)
}
