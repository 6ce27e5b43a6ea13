//! `bench --backend wgpu`: a variant's plan run on the adapter
//! wgpu finds, through the same scene binder as the CPU renderer
//! (`gpu::scene_run`); pipelines and uploads made once per variant, then a
//! warm-up frame and the timed ones. The time is the GPU's, from timestamp
//! queries, where the adapter has them; else submit-to-read-back wall time.

use std::time::Duration;

use super::{failed, BenchError, Clock, Prepared};
use crate::gpu::runner::{Frame, Gpu, Target};
use crate::gpu::scene_run::ScenePlan;
use crate::numerics::Precision;
use crate::renderer::Framebuffer;

/// The last frame, the median time of `runs` frames and how it was taken.
pub fn timed(
    gpu: &Gpu,
    prepared: &Prepared,
    source: &str,
    mode: Precision,
    size: (u32, u32),
    runs: usize,
) -> Result<(Framebuffer, Duration, Clock), BenchError> {
    let what = "wgpu";
    let plan = ScenePlan::new(
        &prepared.planned,
        &prepared.program,
        Some(source),
        mode,
        &prepared.scene,
        &prepared.assets,
    )
    .map_err(|e| failed(what, e))?;
    let target = Target::new(size.0, size.1);
    let passes = plan.passes_in(&target).map_err(|e| failed(what, e))?;
    let frame = Frame::prepare(gpu, &target, &passes).map_err(|e| failed(what, e))?;
    let timed = frame.draw_median(gpu, runs).map_err(|e| failed(what, e))?;
    let clock = if timed.gpu.is_some() { Clock::GpuTimestamps } else { Clock::WgpuWall };
    let framebuffer =
        Framebuffer::from_rgba8(size.0, size.1, timed.image.as_raw()).map_err(|e| failed(what, e))?;
    Ok((framebuffer, timed.time(), clock))
}
