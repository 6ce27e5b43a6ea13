//! The Adaptive Sample Shading table of `shadec bench` (Adaptive
//! Sample Shading, Section 2.1 and Table 1): on the paper's scenes, for each
//! threshold, the share of pixels shaded, the speed-up over full per-pixel
//! shading measured in the same run, and the error against it.
//!
//! The shading is the native multi-light Phong stage with per-polygon light
//! relevance (`renderer::lights`), the paper's "full per pixel shading with
//! local light analysis"; regular samples every 16 pixels, edges between
//! different objects (the paper's smooth-mesh case, `EdgeMode::Pass`).

use std::path::Path;
use std::time::{Duration, Instant};

use super::{median, BenchError, BenchOptions};
use crate::renderer::lights::LitScene;
use crate::renderer::{image_error, AdaptiveSettings, ColorFormat, EdgeMode, Framebuffer};
use crate::scene::Scene;

/// The paper's scenes, with the share of pixels it reports as shaded at
/// threshold 8.5 % where it gives one.
pub const SCENES: [(&str, &str, Option<f64>); 4] = [
    ("adaptive_sphere_4lights", include_str!("../../scenes/adaptive_sphere_4lights.ron"), Some(0.1925)),
    ("adaptive_cube_1light", include_str!("../../scenes/adaptive_cube_1light.ron"), Some(0.0512)),
    ("adaptive_cube_2lights", include_str!("../../scenes/adaptive_cube_2lights.ron"), None),
    ("adaptive_cube_4lights", include_str!("../../scenes/adaptive_cube_4lights.ron"), None),
];

/// Regular samples every 16 pixels (Adaptive Sample Shading, Section 2.1).
pub const SPACING: u32 = 16;

/// One scene and threshold of the adaptive-shading benchmark (Adaptive Sample Shading, Section
/// 2.1): the fraction shaded, the times, and the error against full shading.
#[derive(Clone, Debug)]
pub struct AdaptiveRow {
    pub scene: &'static str,
    pub threshold: f32,
    pub fraction_shaded: f64,
    pub full_time: Duration,
    pub adaptive_time: Duration,
    pub max_abs: f32,
    pub psnr: f64,
    pub paper_fraction: Option<f64>,
}

impl AdaptiveRow {
    /// How many times faster adaptive shading ran than full shading.
    pub fn speedup(&self) -> f64 {
        self.full_time.as_secs_f64() / self.adaptive_time.as_secs_f64().max(1e-9)
    }
}

fn target(size: (u32, u32)) -> Result<Framebuffer, BenchError> {
    Framebuffer::new(size.0, size.1, ColorFormat::F32).map_err(|e| BenchError::Io(e.to_string()))
}

/// Measures every scene the options select at every threshold.
pub fn measure(
    options: &BenchOptions,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<Vec<AdaptiveRow>, BenchError> {
    let scenes: Vec<_> = SCENES.iter().filter(|(name, ..)| options.wants(name)).collect();
    let mut rows = Vec::new();
    for (i, (name, ron, paper)) in scenes.iter().enumerate() {
        let err = |e: &dyn std::fmt::Display| super::failed(name, e);
        let mut scene = Scene::parse(ron, Path::new("")).map_err(|e| err(&e))?;
        // The paper's images are square; the bench's size applies.
        scene.resolution = options.size;
        let assets = scene.build().map_err(|e| err(&e))?;
        let lit = LitScene::new(&scene, &assets, Some(0.5 / 255.0));
        let mut full_times = Vec::new();
        let mut reference = Vec::new();
        for _ in 0..=options.runs.max(1) {
            let mut fb = target(options.size)?;
            let start = Instant::now();
            lit.draw_full(&mut fb).map_err(|e| err(&e))?;
            full_times.push(start.elapsed());
            reference = fb.to_rgba_f32();
        }
        full_times.remove(0); // the warm-up
        let full_time = median(&mut full_times);
        for &threshold in &options.thresholds {
            let settings = AdaptiveSettings::new(SPACING, threshold, EdgeMode::Pass);
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..=options.runs.max(1) {
                let mut fb = target(options.size)?;
                let start = Instant::now();
                let stats = lit.draw_adaptive(&mut fb, &settings).map_err(|e| err(&e))?;
                times.push(start.elapsed());
                last = Some((fb.to_rgba_f32(), stats));
            }
            times.remove(0);
            #[allow(clippy::expect_used, reason = "the loop above runs `runs.max(1) + 1` ≥ 2 times")]
            let (image, stats) = last.expect("at least one run");
            let e = image_error(&reference, &image);
            rows.push(AdaptiveRow {
                scene: name,
                threshold,
                fraction_shaded: stats.fraction_shaded(),
                full_time,
                adaptive_time: median(&mut times),
                max_abs: e.max_abs,
                psnr: e.psnr,
                paper_fraction: if (threshold - 0.085).abs() < 1e-6 { *paper } else { None },
            });
        }
        progress(i + 1, scenes.len(), name);
    }
    Ok(rows)
}
