//! `--adaptive auto`: whether adaptive sample shading (Adaptive Sample
//! Shading, Section 2.1) pays for a plan on an executor, decided before
//! rendering from the plan alone.
//!
//! Adaptive shading saves the shading of the fragments it interpolates and
//! pays for a sparse frame and a classification (on wgpu) or the sample
//! bookkeeping (on the CPU); it wins when a fragment's shading costs more
//! than that overhead. `bench --gpu-check`'s crossover sweep
//! (`bench::adaptive_crossover`) measures where: Phong shaders of growing
//! cost, full against adaptive. The crossovers below are those
//! measurements, in the plan's own measure of a fragment
//! ([`crate::pipeline::FragmentWork::operations`]), rounded up.
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

/// Operations per fragment from which adaptive shading was faster on the
/// CPU renderer: the diffuse term alone (5 operations) was 0.9-1.2× at
/// 1024², a one-lobe Phong shader (14 operations) 2.7-4× (BENCHMARKS.md);
/// between them the speed-up depends on the scene, so the threshold is the
/// first clear win.
pub const CPU_CROSSOVER: usize = 14;

/// The fewest pixels (at the rendered size) the largest pass into the
/// picture must cover: two small spheres at 256² (`scenes/lights_two_spots.ron`,
/// 5 800 pixels a pass) rendered at 0.56× adaptively on the CPU, a
/// 39 000-pixel sphere at 1.5×.
pub const MIN_PIXELS: u64 = 32_768;

/// Operations per fragment from which adaptive shading was faster on wgpu:
/// measured on lavapipe between 32 (0.8×) and 104 (2.5-3.4×) operations,
/// interpolated at about 42 (BENCHMARKS.md); on a GPU the check's sweep
/// measures its own.
pub const WGPU_CROSSOVER: usize = 48;

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
    if pixels < MIN_PIXELS as f64 {
        return full(format!(
            "its largest pass covers about {pixels:.0} pixels, fewer than the {MIN_PIXELS} adaptive shading needs to pay"
        ));
    }
    let (crossover, name) = match executor {
        Executor::Cpu => (CPU_CROSSOVER, "the CPU renderer"),
        Executor::Wgpu => (WGPU_CROSSOVER, "wgpu"),
    };
    let operations = picture.iter().map(|(_, p)| p.fragment.operations).max().unwrap_or(0);
    if operations < crossover {
        return full(format!(
            "{operations} operations per fragment is below the crossover of {crossover} measured on {name}"
        ));
    }
    AutoChoice {
        adaptive: true,
        why: format!("{operations} operations per fragment is at or above the crossover of {crossover} measured on {name}"),
    }
}

#[cfg(test)]
mod tests {
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

    #[test]
    fn a_textured_plan_is_shaded_in_full() {
        let choice =
            auto(&plan(include_str!("../../examples/kilgard_bump_mapping.shd"), "wgsl"), Executor::Cpu);
        assert!(!choice.adaptive);
        assert!(choice.why.contains("samples a texture"), "{}", choice.why);
    }

    #[test]
    fn cheap_phong_is_adaptive_on_the_cpu_and_full_on_wgpu() {
        let plan = plan(PHONG, "wgsl");
        assert!(auto(&plan, Executor::Cpu).adaptive, "{:?}", auto(&plan, Executor::Cpu));
        let gpu = auto(&plan, Executor::Wgpu);
        assert!(!gpu.adaptive && gpu.why.contains("below the crossover"), "{}", gpu.why);
    }

    #[test]
    fn a_small_frame_is_shaded_in_full() {
        let plan = plan(PHONG, "wgsl");
        let choice = choose(&plan, &Workload::nominal(), (128, 128), Executor::Cpu);
        assert!(!choice.adaptive && choice.why.contains("pixels"), "{}", choice.why);
    }
}
