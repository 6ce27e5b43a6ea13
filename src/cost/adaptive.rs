//! `--adaptive auto`: whether adaptive sample shading (Adaptive Sample
//! Shading, Section 2.1) pays for a plan on an executor, decided before
//! rendering from the plan and the scene's geometry.
//!
//! Adaptive shading saves the shading of the fragments it interpolates and
//! pays for a sparse frame and a classification (on wgpu) or for the
//! sample bookkeeping and the samples themselves (on the CPU). On wgpu a
//! crossover decides, in the plan's own measure of a fragment
//! ([`crate::pipeline::FragmentWork::operations`]): the fewest operations
//! at which `bench --adaptive-scenes --backend wgpu` never measured
//! adaptive shading slower on the scenes of `scenes/` (the sweep of
//! `bench --gpu-check`, `bench::adaptive_crossover`, measures one sphere). On the CPU a
//! cost model ([`CpuModel`]) prices both frames: full shading per covered
//! pixel, adaptive shading per frame pixel and covered pixel plus the
//! samples it shades — a fraction of the interior and, along each object's
//! outline, a band whose length the covered area bounds from below — and
//! adaptive is chosen where the model predicts a clear gain
//! ([`CPU_MARGIN`]). Its constants are fitted to `bench --adaptive-scenes`
//! (every scene of `scenes/`, full against adaptive, in the same run).
//!
//! Interpolating between samples 16 pixels apart also smooths what a
//! texture adds between them (a bump map, a brick pattern): the paper
//! shades smooth Phong lighting. A plan whose passes into the picture
//! sample a texture is therefore shaded in full. So is a frame whose
//! passes cover few pixels ([`MIN_PIXELS`]): there the samples along the
//! edges and the fixed costs outweigh what is saved.

use super::Workload;
use crate::pipeline::{PassPlan, RenderTarget};

/// Where the plan runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Executor {
    Cpu,
    Wgpu,
}

/// Operations per fragment from which adaptive shading was not slower on
/// wgpu on any scene of `scenes/` whose largest pass covers
/// [`MIN_PIXELS_WGPU`], measured on lavapipe by `bench --adaptive-scenes
/// --backend wgpu` at the scenes' sizes and at 1024² (two runs each): 104
/// operations 1.01-2.59×; 56 operations 0.77-2.19×, the one-light cube
/// 0.77-0.97× and the spotlight 0.85-0.88× among them. On a GPU the
/// check's sweep measures its own.
pub const WGPU_CROSSOVER: usize = 104;

/// The fewest pixels (at the rendered size) the largest pass into the
/// picture must cover on the CPU: two small spheres at 256²
/// (`scenes/lights_two_spots.ron`, 5 800 pixels a pass) rendered at 0.56×
/// adaptively, a 39 000-pixel sphere at 1.5×.
pub const MIN_PIXELS: u64 = 32_768;

/// The same on wgpu, whose sparse frame and full-screen classification
/// cost the same whatever is shaded: the 4-light sphere at 512² (about
/// 110 000 pixels a pass) was slower adaptively even at 104 operations
/// (0.78-1.00×), at 1024² (about 590 000) faster at 104 (1.37-1.55×).
pub const MIN_PIXELS_WGPU: u64 = 262_144;

/// The decision and its reason, for `render` to print.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AutoChoice {
    pub adaptive: bool,
    pub why: String,
}

/// Whether `--adaptive auto` shades `plan` adaptively on `executor`, the
/// frame being `workload` (its scene) rendered at `size`.
pub fn choose(plan: &PassPlan, workload: &Workload, size: (u32, u32), executor: Executor) -> AutoChoice {
    let full = |why: String| AutoChoice { adaptive: false, why };
    let picture: Vec<(usize, &crate::pipeline::Pass)> = plan
        .passes
        .iter()
        .enumerate()
        .filter(|(_, p)| matches!(p.target, RenderTarget::Framebuffer { .. }) && !p.baked)
        .collect();
    if picture.is_empty() {
        return full("no pass draws into the picture".into());
    }
    if let Some((i, _)) = picture.iter().find(|(_, p)| !p.textures.is_empty()) {
        return full(format!(
            "pass {} samples a texture, whose detail between samples interpolation would lose",
            i + 1
        ));
    }
    let scale = f64::from(size.0) * f64::from(size.1)
        / (f64::from(workload.resolution.0) * f64::from(workload.resolution.1)).max(1.0);
    let pixels = picture.iter().map(|(_, p)| workload.pass_load(p).pixels).max().unwrap_or(0) as f64 * scale;
    let least = if executor == Executor::Wgpu { MIN_PIXELS_WGPU } else { MIN_PIXELS };
    if pixels < least as f64 {
        return full(format!(
            "its largest pass covers about {pixels:.0} pixels, fewer than the {least} adaptive shading needs to pay"
        ));
    }
    match executor {
        Executor::Cpu => cpu_choice(&picture, workload, size, scale),
        Executor::Wgpu => {
            let operations = picture.iter().map(|(_, p)| p.fragment.operations).max().unwrap_or(0);
            if operations < WGPU_CROSSOVER {
                return full(format!(
                    "{operations} operations per fragment is below the crossover of {WGPU_CROSSOVER} measured on wgpu"
                ));
            }
            AutoChoice {
                adaptive: true,
                why: format!(
                    "{operations} operations per fragment is at or above the crossover of {WGPU_CROSSOVER} measured on wgpu"
                ),
            }
        }
    }
}

/// The CPU renderer's costs, in units of one lane-executor operation of one
/// fragment, fitted to the table of `shadec bench --adaptive-scenes`
/// (BENCHMARKS.md, "`--adaptive auto` on every scene"); [`CpuModel::predict`]
/// prices a frame both ways with them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpuModel {
    /// A fragment of full shading besides its operations: rasterization,
    /// interpolation, depth test and blending.
    pub fragment: f64,
    /// A covered pixel, per adaptive draw: visibility, the columns'
    /// interpolation and the write-through.
    pub covered_pixel: f64,
    /// A pixel of the frame, per adaptive draw: surface keys, the edge map
    /// and the refinement's scan run over the whole frame.
    pub frame_pixel: f64,
    /// A shaded sample besides its operations: its fragment's set-up, and
    /// batches the subdivision's levels and the refinement's waves fill
    /// only in part.
    pub sample: f64,
    /// The fraction of covered pixels shaded away from silhouettes
    /// (regular samples, subdivision, refinement): what the shading decides,
    /// which the plan does not tell; the most measured on `scenes/` (the
    /// tori at 13 operations shade 13-18 % in all, their silhouettes
    /// included).
    pub interior: f64,
    /// Samples per silhouette pixel: edge pixels, and the subdivision that
    /// starts at them.
    pub per_silhouette_pixel: f64,
}

/// The model fitted on this project's machine, refitted to the adaptive
/// frames made cheaper by the visibility over covered spans and the first
/// wave inside the bands: four runs of `bench --adaptive-scenes` (least
/// squares in the logarithm of the speed-up, full shading's `fragment`
/// kept), with every program of 13 operations and the two tori at 32 kept
/// below [`CPU_MARGIN`], which some run measured slower adaptively.
pub const CPU_MODEL: CpuModel = CpuModel {
    fragment: 8.0,
    covered_pixel: 4.0,
    frame_pixel: 4.0,
    sample: 130.0,
    interior: 0.10,
    per_silhouette_pixel: 4.0,
};

/// Adaptive shading is chosen when the model predicts it at least this much
/// faster: the margin keeps frames near the crossover, whose measured
/// speed-up the machine's load moves by tens of percent, on full shading.
pub const CPU_MARGIN: f64 = 1.15;

/// One pass into the picture as the model sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassShape {
    /// Pixels its objects cover (front faces for back-face culling).
    pub pixels: f64,
    /// The length of their outlines, in pixels: each object's as a disc's
    /// of its area (2·√(π·area)), the shortest outline an area can have.
    pub silhouette: f64,
    pub operations: usize,
}

/// A frame's predicted cost each way on the CPU renderer (in the model's
/// units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpuPrediction {
    pub full: f64,
    pub adaptive: f64,
}

impl CpuPrediction {
    /// How many times faster adaptive shading is predicted than full shading.
    pub fn speedup(&self) -> f64 {
        self.full / self.adaptive.max(1e-9)
    }
}

impl CpuModel {
    /// The fraction of a pass's covered pixels adaptive shading is taken to
    /// shade (at most all of them).
    pub fn shaded(&self, pass: &PassShape) -> f64 {
        (self.interior + self.per_silhouette_pixel * pass.silhouette / pass.pixels.max(1.0)).min(1.0)
    }

    /// Prices `passes` on a frame of `frame_pixels`.
    pub fn predict(&self, passes: &[PassShape], frame_pixels: f64) -> CpuPrediction {
        let mut prediction = CpuPrediction { full: 0.0, adaptive: 0.0 };
        for pass in passes {
            let operations = pass.operations as f64;
            prediction.full += pass.pixels * (self.fragment + operations);
            prediction.adaptive += frame_pixels * self.frame_pixel
                + pass.pixels * self.covered_pixel
                + pass.pixels * self.shaded(pass) * (self.sample + operations);
        }
        prediction
    }
}

/// What `pass` draws of `workload`, at `scale` times the workload's
/// pixels.
pub fn pass_shape(workload: &Workload, pass: &crate::pipeline::Pass, scale: f64) -> PassShape {
    let mut shape = PassShape { pixels: 0.0, silhouette: 0.0, operations: pass.fragment.operations };
    for (i, o) in workload.objects.iter().enumerate() {
        if pass.objects.as_ref().is_some_and(|only| !only.contains(&i)) {
            continue;
        }
        let pixels = scale
            * match pass.state.cull {
                crate::pipeline::CullMode::Back => o.front_pixels,
                crate::pipeline::CullMode::Front => o.back_pixels,
                crate::pipeline::CullMode::None => o.front_pixels + o.back_pixels,
            };
        shape.pixels += pixels;
        shape.silhouette += 2.0 * (std::f64::consts::PI * pixels).sqrt();
    }
    shape
}

/// The CPU's choice from [`CPU_MODEL`]: adaptive where it predicts a
/// speed-up of at least [`CPU_MARGIN`].
fn cpu_choice(
    picture: &[(usize, &crate::pipeline::Pass)],
    workload: &Workload,
    size: (u32, u32),
    scale: f64,
) -> AutoChoice {
    // Screen and texel passes are shaded in full either way.
    let passes: Vec<PassShape> = picture
        .iter()
        .filter(|(_, p)| matches!(p.geometry, crate::pipeline::Geometry::Mesh { .. }))
        .map(|(_, p)| pass_shape(workload, p, scale))
        .collect();
    let predicted = CPU_MODEL.predict(&passes, f64::from(size.0) * f64::from(size.1));
    let speedup = predicted.speedup();
    let operations = passes.iter().map(|p| p.operations).max().unwrap_or(0);
    let shaded = passes.iter().map(|p| CPU_MODEL.shaded(p)).fold(0.0, f64::max);
    let why = format!(
        "the CPU cost model predicts {speedup:.2}× the speed of full shading ({operations} operations per fragment, {} passes into the picture, at most {:.0} % shaded; adaptive needs {CPU_MARGIN:.2}×)",
        passes.len(),
        100.0 * shaded
    );
    AutoChoice { adaptive: speedup >= CPU_MARGIN, why }
}

#[cfg(test)]
mod tests {
    /// The model's prediction follows its parts: more operations favour
    /// adaptive shading, a longer outline (more samples) full shading.
    #[test]
    fn the_cpu_model_grows_with_operations_and_outline() {
        let pass = |operations, silhouette| PassShape { pixels: 100_000.0, silhouette, operations };
        let speedup = |p: PassShape| CPU_MODEL.predict(&[p], 262_144.0).speedup();
        assert!(speedup(pass(13, 1_000.0)) < speedup(pass(56, 1_000.0)));
        assert!(speedup(pass(56, 1_000.0)) < speedup(pass(104, 1_000.0)));
        assert!(speedup(pass(56, 10_000.0)) < speedup(pass(56, 1_000.0)));
        assert!(speedup(pass(13, 1_000.0)) < CPU_MARGIN, "13 operations never pay on the CPU");
    }

    use super::*;
    use crate::driver::{compile, PlanOptions};
    use crate::profile::Profile;

    fn plan(source: &str, target: &str) -> PassPlan {
        let profile = Profile::resolve(target).unwrap();
        compile(source, &profile, &PlanOptions::default()).unwrap().planned.plan
    }

    /// The nominal workload (a screen-filling mesh) at its own size.
    fn auto(plan: &PassPlan, executor: Executor) -> AutoChoice {
        let workload = Workload::nominal();
        choose(plan, &workload, workload.resolution, executor)
    }

    const PHONG: &str = "vector N : normal;\nvector L : light(0);\nvector V : view;\nshader p : s → c {\n    let Nn = normalize(N);\n    let Hn = normalize(normalize(L) + normalize(V));\n    max(0, Nn·normalize(L)) * 0.5 + max(0, Nn·Hn)^40 * 0.5 + max(0, Nn·Hn)^8 * 0.25\n}\nC δπx ← p δ s x;\n";

    /// Thirty-two Phong lobes: 137 operations per fragment, above both
    /// executors' crossovers (sixteen give 73).
    fn costly() -> String {
        let lobes: Vec<String> = (0..32)
            .map(|i| format!("max(0, Nn·Hn)^{} * 0.05 + max(0, Nn·normalize(L)) * 0.01", 8 + 4 * i))
            .collect();
        PHONG.replace(
            "max(0, Nn·normalize(L)) * 0.5 + max(0, Nn·Hn)^40 * 0.5 + max(0, Nn·Hn)^8 * 0.25",
            &lobes.join(" + "),
        )
    }

    #[test]
    fn a_textured_plan_is_shaded_in_full() {
        let choice =
            auto(&plan(include_str!("../../examples/kilgard_bump_mapping.shd"), "wgsl"), Executor::Cpu);
        assert!(!choice.adaptive);
        assert!(choice.why.contains("samples a texture"), "{}", choice.why);
    }

    #[test]
    fn cheap_phong_is_shaded_in_full_below_the_crossover() {
        let plan = plan(PHONG, "wgsl");
        let choice = auto(&plan, Executor::Wgpu);
        assert!(!choice.adaptive && choice.why.contains("below the crossover"), "{}", choice.why);
        let choice = auto(&plan, Executor::Cpu);
        assert!(!choice.adaptive && choice.why.contains("cost model predicts"), "{}", choice.why);
    }

    #[test]
    fn a_costly_shader_on_a_large_frame_is_adaptive() {
        let plan = plan(&costly(), "wgsl");
        for executor in [Executor::Cpu, Executor::Wgpu] {
            assert!(auto(&plan, executor).adaptive, "{:?}", auto(&plan, executor));
        }
    }

    #[test]
    fn a_small_frame_is_shaded_in_full() {
        let plan = plan(PHONG, "wgsl");
        let choice = choose(&plan, &Workload::nominal(), (128, 128), Executor::Cpu);
        assert!(!choice.adaptive && choice.why.contains("pixels"), "{}", choice.why);
    }
}
