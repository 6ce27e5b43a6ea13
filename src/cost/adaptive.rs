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
/// CPU renderer (the lane executor, quiet machine, BENCHMARKS.md): 32
/// operations 0.98-1.11× at 512²-2048², 56 operations 1.31-1.59×, 20
/// operations 0.83-0.91×.
pub const CPU_CROSSOVER: usize = 32;

/// Operations per fragment from which adaptive shading was faster on wgpu,
/// measured on lavapipe: 56 operations 0.98-1.01× at 1024², 1.52× at
/// 2048²; on a GPU the check's sweep measures its own.
pub const WGPU_CROSSOVER: usize = 56;

/// The fewest pixels (at the rendered size) the largest pass into the
/// picture must cover on the CPU: two small spheres at 256²
/// (`scenes/lights_two_spots.ron`, 5 800 pixels a pass) rendered at 0.56×
/// adaptively, a 39 000-pixel sphere at 1.5×.
pub const MIN_PIXELS: u64 = 32_768;

/// The same on wgpu, whose sparse frame and full-screen classification
/// cost the same whatever is shaded: the 4-light sphere at 512² (about
/// 110 000 pixels a pass) was slower adaptively even at 104 operations
/// (0.78×), at 1024² (about 590 000) faster from 56.
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

    /// Sixteen Phong lobes: 104 operations per fragment.
    fn costly() -> String {
        let lobes: Vec<String> = (0..16)
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
        for executor in [Executor::Cpu, Executor::Wgpu] {
            let choice = auto(&plan, executor);
            assert!(!choice.adaptive && choice.why.contains("below the crossover"), "{}", choice.why);
        }
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
