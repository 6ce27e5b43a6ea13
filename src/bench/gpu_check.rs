//! `shadec bench --gpu-check`: the CPU renderer against wgpu on the adapter
//! wgpu finds, compared under the texture unit's model and the latitude
//! the specifications leave it (`textures::unit`, "What the specifications
//! leave open"), and the two executors timed; one report, `gpu-check.md`,
//! and a montage of the worst differences, `gpu-check.png`
//! (docs/gpu-check.md).
//!
//! # What is compared
//!
//! Every example (`examples/*.shd`) planned for `wgsl` (the CPU's `f32`
//! against exact fidelity into a float target) and for `geforce3` and
//! `geforce256` (`fixed9` against hardware fidelity into RGBA8) where it
//! plans, and a sample of generated programs ([`generated_program`]) on
//! `wgsl`, all on Kilgard's torus with the binder's procedural stand-in
//! textures, at the check's size.
//!
//! # The bound, per pixel
//!
//! Pixels whose 3×3 neighbourhood holds more than one triangle (the edge
//! mask) are left out: which triangle covers a pixel there, and the
//! derivatives of a 2×2 quad that straddles two, are the rasterizers'
//! (as `tests/wgsl_agreement.rs` does). Elsewhere a GPU channel is *within
//! the model* when it lies in [lo − 1, hi + 1]/255, [lo, hi] the range of
//! the CPU's pictures at that pixel:
//!
//! 1. the model's picture;
//! 2. the model with each rounding's tie moved by float noise
//!    ([`TIES`]: the executors' interpolated values, dot products and
//!    derivatives differ by ~10⁻⁴ of an 8-bit step; a rounding whose input
//!    lies that near its tie may go either way);
//! 3. for a *filtered* case, the renders of `Latitude::ENVELOPE`: every
//!    λ and sub-texel weight a conforming texture unit may take.
//!
//! The ±1/255: each executor rounds its value to 8 bits once, from values
//! the hull brackets. An *exact* case — every texture `nearest` and
//! without mipmaps, or none: nearest sampling, unfiltered lookups,
//! combiner arithmetic, blending — has no step 3: there the
//! specifications leave nothing open, and the report also says whether
//! the two pictures are equal bit for bit. Pictures 2 and 3 are rendered
//! only where the ones before leave pixels beyond the bound.
//!
//! Where the plan draws shadow volumes, the pixels whose stencil count a
//! conforming rasterizer may get otherwise — each volume vertex snapped on
//! its own to as little as 1/16 pixel, where a volume triangle's depth
//! test against the surface can then go either way — are left out as the
//! edge mask's are, and counted per case ([`volume_ties`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use image::RgbaImage;

use super::{failed, median, BenchError};
use crate::driver::{ForScene, PlanOptions};
use crate::gpu::runner::{
    run_passes, Frame, Gpu, PassTarget, RunPass, RunShader, ShaderSource, Target, VertexData,
};
use crate::gpu::scene_run::{ScenePlan, SceneRunError};
use crate::numerics::Precision;
use crate::profile::Profile;
use crate::renderer::plan::{PlanRenderer, RoundingBias};
use crate::renderer::{BlendState, CompareFunc, CullMode, DepthState, RenderState, StencilState};
use crate::scene::bind::{light_view_projection, BoundObject};
use crate::scene::{Scene, SceneAssets};
use crate::textures::unit::Latitude;
use crate::textures::Filter;

pub mod volume_ties;

/// Float noise between the executors, as (1/255 register steps, 1/256
/// texture-unit quanta, comparison ulps, shadow-volume depth in 2⁻²⁴
/// steps), each tried ±: the distances `tests/wgsl_agreement.rs` measured
/// and states (register inputs differ by up to 1.2·10⁻⁴ steps, λ by up to
/// 0.2 quanta, reprojected depths by up to 256 ulps), and a volume's depth
/// ties with the surface it grazes (`RoundingBias::volume_depth_steps`).
pub const TIES: [(f64, f32, f64, f32); 3] =
    [(1e-3, 1e-2, 8.0, 16.0), (1e-3, 5e-2, 64.0, 256.0), (1e-3, 0.2, 256.0, 4096.0)];

/// A file's name and its text, built in.
type NamedText = (&'static str, &'static str);

/// Kilgard's torus, the comparisons' scene and the default scene's.
const TORUS: (&str, &str) = ("scenes/kilgard_torus.ron", include_str!("../../scenes/kilgard_torus.ron"));
/// Adaptive Sample Shading's 4-light sphere.
const SPHERE: (&str, &str) =
    ("scenes/adaptive_sphere_4lights.ron", include_str!("../../scenes/adaptive_sphere_4lights.ron"));
const KILGARD: (&str, &str) =
    ("examples/kilgard_bump_mapping.shd", include_str!("../../examples/kilgard_bump_mapping.shd"));
const FRAGMENT_LIGHTING: (&str, &str) =
    ("examples/fragment_lighting.shd", include_str!("../../examples/fragment_lighting.shd"));

/// `--quick`'s examples: one exact (no texture), two filtered.
pub const QUICK_EXAMPLES: [&str; 3] = ["gouraud.shd", "texture.shd", "modulation.shd"];

/// How much to check.
#[derive(Clone, Debug)]
pub struct GpuCheckOptions {
    /// The comparisons' image size.
    pub size: (u32, u32),
    /// The folder of the examples (`examples/`).
    pub examples: PathBuf,
    /// Only the example files named so, or whose name contains one of
    /// these where it does not end in `.shd` (`None`: every `*.shd`).
    pub only_examples: Option<Vec<String>>,
    /// How many generated programs.
    pub generated: usize,
    /// Square sizes the timings are taken at.
    pub timing_sizes: Vec<u32>,
    /// Timed frames per executor (the median is reported), after a warm-up.
    pub runs: usize,
    /// The adaptive crossover's programs (Phong lobes each,
    /// `bench::adaptive_crossover`) and the square size they are timed at;
    /// empty: no sweep.
    pub crossover_lobes: Vec<usize>,
    pub crossover_size: u32,
}

impl GpuCheckOptions {
    /// The documented full run: 640×480 comparisons (as the agreement
    /// tests), 12 generated programs, timings at 1024² and 2048².
    pub fn full(examples: PathBuf) -> GpuCheckOptions {
        GpuCheckOptions {
            size: (640, 480),
            examples,
            only_examples: None,
            generated: 12,
            timing_sizes: vec![1024, 2048],
            runs: 5,
            crossover_lobes: vec![0, 1, 2, 4, 8, 16, 32],
            crossover_size: 1024,
        }
    }

    /// CI's run: [`QUICK_EXAMPLES`], two generated programs, 320×240 (at
    /// smaller sizes the edge mask leaves few of the torus's pixels).
    pub fn quick(examples: PathBuf) -> GpuCheckOptions {
        GpuCheckOptions {
            size: (320, 240),
            examples,
            only_examples: Some(QUICK_EXAMPLES.map(String::from).to_vec()),
            generated: 2,
            timing_sizes: vec![128],
            runs: 1,
            crossover_lobes: vec![0, 8],
            crossover_size: 128,
        }
    }
}

/// Whether the specifications leave a case's sampling open.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// Every texture `nearest` without mipmaps, or none.
    Exact,
    /// Some texture filtered or mipmapped: bounded by `Latitude::ENVELOPE`.
    Filtered,
}

/// One program on one target, compared.
#[derive(Clone, Debug)]
pub struct Case {
    pub program: String,
    pub target: &'static str,
    pub mode: Precision,
    pub outcome: Outcome,
}

/// What the check made of one program on one target.
#[derive(Clone, Debug)]
pub enum Outcome {
    /// Not compared: it does not plan for the target, or wgpu cannot run
    /// the plan yet; why.
    Refused(String),
    Compared(Comparison),
}

/// How the GPU's picture lies against the CPU's.
#[derive(Clone)]
pub struct Comparison {
    pub class: Class,
    /// Pixels off the edge mask, and those of them the CPU does not leave black.
    pub compared: usize,
    pub lit: usize,
    /// Pixels off the edge mask left out because a shadow volume's stencil
    /// count there is the rasterizer's choice under per-vertex snapping
    /// ([`volume_ties`]); 0 where the plan draws no volume.
    pub volume_ties: usize,
    /// The largest channel difference from the model's picture, in 255ths.
    pub max_diff: u8,
    /// Pixels beyond the bound of the model's picture alone, with the
    /// ties moved, and with the latitude (the verdict's count).
    pub beyond_model_picture: usize,
    pub beyond_ties: usize,
    pub beyond: usize,
    /// CPU, GPU and per pixel 0 compared / 1 masked / 2 beyond the bound,
    /// kept where the pictures differ (the montage).
    pub pictures: Option<(RgbaImage, RgbaImage, Vec<u8>)>,
}

/// The counts, without the pictures.
impl std::fmt::Debug for Comparison {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Comparison")
            .field("class", &self.class)
            .field("compared", &self.compared)
            .field("lit", &self.lit)
            .field("volume_ties", &self.volume_ties)
            .field("max_diff", &self.max_diff)
            .field("beyond_model_picture", &self.beyond_model_picture)
            .field("beyond_ties", &self.beyond_ties)
            .field("beyond", &self.beyond)
            .finish()
    }
}

impl Comparison {
    /// The comparison in words: bit for bit, within the texture unit's
    /// model or the specifications' latitude, or beyond them.
    pub fn verdict(&self) -> &'static str {
        match (self.beyond, self.max_diff, self.class) {
            (0, 0, Class::Exact) => "bit for bit",
            (0, _, _) => "within the model",
            _ => "BEYOND THE MODEL",
        }
    }
}

/// One timing: a program on a scene at a size on both executors.
#[derive(Clone, Debug)]
pub struct Timing {
    pub scene: &'static str,
    pub program: &'static str,
    pub target: &'static str,
    pub mode: Precision,
    pub size: u32,
    pub passes: usize,
    pub cpu: Duration,
    pub gpu: Duration,
    /// Whether `gpu` is from timestamp queries (else submit to read-back).
    pub timestamps: bool,
    /// Pipelines and uploads, once.
    pub prepare: Duration,
}

/// What the check found.
#[derive(Clone, Debug)]
pub struct GpuCheck {
    pub adapter: String,
    pub options: GpuCheckOptions,
    pub cases: Vec<Case>,
    pub timings: Vec<Result<Timing, String>>,
    /// The adaptive crossover sweep, or why it failed.
    pub crossover: Result<Vec<super::adaptive_crossover::CrossoverRow>, String>,
    pub elapsed: Duration,
}

impl GpuCheck {
    /// Compared cases beyond the model.
    pub fn failures(&self) -> usize {
        self.cases.iter().filter(|c| matches!(&c.outcome, Outcome::Compared(k) if k.beyond > 0)).count()
    }
}

fn io(e: impl std::fmt::Display) -> BenchError {
    BenchError::Io(e.to_string())
}

/// A scene anchored where its image files do not exist: both executors
/// bind the binder's procedural stand-ins, so the check needs no assets.
fn scene((name, ron): (&str, &str)) -> Result<(Scene, SceneAssets), BenchError> {
    let file = Path::new(name).file_name().unwrap_or_default();
    let scene =
        Scene::parse(ron, &Path::new("/nonexistent-shadec-scene").join(file)).map_err(|e| failed(name, e))?;
    let assets = scene.build().map_err(|e| failed(name, e))?;
    Ok((scene, assets))
}

/// Runs the check; `progress(done, total, what)` after each case.
pub fn run(
    options: &GpuCheckOptions,
    out_dir: &Path,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<GpuCheck, BenchError> {
    let start = Instant::now();
    // The examples first: a wrong folder is said before any adapter is sought.
    let programs = programs(options)?;
    let gpu = Gpu::new().map_err(|e| failed("wgpu", e))?;
    let setup = Setup::torus(&gpu, options.size)?;
    let mut cases = Vec::new();
    let total = programs.len() + options.timing_sizes.len();
    for (k, (name, source, targets)) in programs.iter().enumerate() {
        for &(target, mode) in *targets {
            let outcome = setup.compare(&gpu, source, target, mode);
            cases.push(Case { program: name.clone(), target, mode, outcome });
        }
        progress(k + 1, total, name);
    }
    let mut timings = Vec::new();
    for (k, &size) in options.timing_sizes.iter().enumerate() {
        for (scene_file, program, target, mode) in TIMED {
            timings.push(time_case(&gpu, scene_file, program, target, mode, size, options.runs));
        }
        progress(programs.len() + k + 1, total, &format!("timings at {size}²"));
    }
    let crossover = scene(SPHERE).map_err(|e| e.to_string()).and_then(|(scene, assets)| {
        super::adaptive_crossover::sweep(
            Some(&gpu),
            (&scene, &assets),
            &options.crossover_lobes,
            options.crossover_size,
            options.runs,
        )
    });
    let check = GpuCheck {
        adapter: gpu.to_string(),
        options: options.clone(),
        cases,
        timings,
        crossover,
        elapsed: start.elapsed(),
    };
    std::fs::create_dir_all(out_dir).map_err(io)?;
    crate::io::write_atomic(&out_dir.join("gpu-check.md"), check.markdown().as_bytes()).map_err(io)?;
    crate::io::write_atomic(&out_dir.join("gpu-check.png"), &montage(&check.cases)?).map_err(io)?;
    Ok(check)
}

/// The comparisons' targets of an example and of a generated program.
const EXAMPLE_TARGETS: &[(&str, Precision)] =
    &[("wgsl", Precision::F32), ("geforce3", Precision::Fixed9), ("geforce256", Precision::Fixed9)];
const GENERATED_TARGETS: &[(&str, Precision)] = &[("wgsl", Precision::F32)];

type Programs = Vec<(String, String, &'static [(&'static str, Precision)])>;

/// The examples (sorted by name) and the generated programs.
fn programs(options: &GpuCheckOptions) -> Result<Programs, BenchError> {
    let dir = &options.examples;
    let entries = std::fs::read_dir(dir).map_err(|e| {
        io(format!("{}: {e}; run the check from the repository root (or give --examples DIR)", dir.display()))
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "shd"))
        .collect();
    files.sort();
    if let Some(only) = &options.only_examples {
        let wanted =
            |n: &str| only.iter().any(|o| n == o || (!o.ends_with(".shd") && n.contains(o.as_str())));
        files.retain(|p| p.file_name().is_some_and(|n| wanted(&n.to_string_lossy())));
    }
    let mut programs = Programs::new();
    for path in files {
        let source = crate::io::read_text(&path).map_err(io)?;
        programs.push((
            format!("examples/{}", path.file_name().unwrap_or_default().to_string_lossy()),
            source,
            EXAMPLE_TARGETS,
        ));
    }
    for seed in 0..options.generated as u64 {
        programs.push((format!("generated #{seed}"), generated_program(seed), GENERATED_TARGETS));
    }
    Ok(programs)
}

/// A small program of the papers' forms from a seed: two textures with
/// filters drawn from every kind (every third seed `nearest` only, an
/// exact case), Gouraud shading, a constant, Kilgard's diffuse term with
/// a normalization cube map, and products, sums and blends of them.
pub fn generated_program(seed: u64) -> String {
    let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut next = |n: usize| {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 33) % n as u64) as usize
    };
    const FILTERS: [&str; 5] =
        ["nearest", "bilinear", "mipmap bilinear", "mipmap trilinear", "mipmap nearest"];
    const WRAPS: [&str; 2] = ["repeat", "clamp"];
    // The last two read the (bilinear) cube map: not in exact programs.
    const TERMS: [&str; 7] = [
        "(T0 δu x)",
        "(T1 δu x)",
        "kd",
        "(δ p s x)",
        "(0.5 * (T0 δu x) + 0.5 * (T1 δu x))",
        "(max(0, Nt·Ln) * (T0 δu x))",
        "((T1 δu x) ⊕[add] (δ p s x))",
    ];
    let exact = seed % 3 == 0;
    let terms = if exact { &TERMS[..5] } else { &TERMS[..] };
    let mut s = String::from("vector N : normal;\nvector L : light(0);\nvector Lt : light(0) in tangent;\n");
    s += "const Nt : vec3 = (0, 0, 1);\n";
    let kd = [next(10), next(10), next(10)].map(|k| 0.3 + 0.07 * k as f64);
    s += &format!("const kd : rgb = ({:.2}, {:.2}, {:.2});\n", kd[0], kd[1], kd[2]);
    s += "shader p : s → c = 0.1 + kd * max(0, N·L);\n";
    for t in 0..2 {
        let filter = if exact { FILTERS[0] } else { FILTERS[next(FILTERS.len())] };
        s += &format!("texture T{t} : 2d rgb8 {filter} {} = image(\"missing-{t}.png\");\n", WRAPS[next(2)]);
    }
    if !exact {
        s += "texture Ncube : cube rgb8 bilinear clamp = normalize_cube(32);\n";
        s += "let Ln = expand(Ncube δ Lt s x);\n";
    }
    s += &format!("C δπx ← {} * {};\n", terms[next(terms.len())], terms[next(terms.len())]);
    if next(2) == 1 {
        s += &format!("C δπx ← (C δπx) ⊕[add] (0.5 * {});\n", terms[next(terms.len())]);
    }
    s
}

/// Whether a module's sampling is left open by the specifications.
fn class_of(m: &crate::ir::Module) -> Class {
    let exact = m.textures.iter().all(|t| t.sampling.filter == Filter::Nearest && !t.sampling.mipmap);
    if exact {
        Class::Exact
    } else {
        Class::Filtered
    }
}

/// The comparisons' scene, bound, at one size, with its edge mask.
pub struct Setup {
    scene: Scene,
    assets: SceneAssets,
    size: (u32, u32),
    mask: Vec<bool>,
}

impl Setup {
    /// Kilgard's torus with stand-in textures at `size`.
    pub fn torus(gpu: &Gpu, size: (u32, u32)) -> Result<Setup, BenchError> {
        let (scene, assets) = scene(TORUS)?;
        let mask = edge_mask(&triangle_ids(gpu, &scene, &assets, size)?, size);
        Ok(Setup { scene, assets, size, mask })
    }

    /// Plans `source` for `target`, renders it on both executors in
    /// `mode` and compares them (module docs).
    pub fn compare(&self, gpu: &Gpu, source: &str, target: &'static str, mode: Precision) -> Outcome {
        compare_case(gpu, &self.scene, &self.assets, &self.mask, self.size, source, target, mode)
    }
}

/// Plans, renders on both executors and compares one case.
#[allow(clippy::too_many_arguments)]
fn compare_case(
    gpu: &Gpu,
    scene: &Scene,
    assets: &SceneAssets,
    mask: &[bool],
    (w, h): (u32, u32),
    source: &str,
    target: &'static str,
    mode: Precision,
) -> Outcome {
    let profile = match Profile::resolve(target) {
        Ok(p) => p,
        Err(e) => return Outcome::Refused(e.to_string()),
    };
    let compiled = match crate::driver::compile(source, &profile, &PlanOptions::default()) {
        Ok(c) => c,
        Err(d) => {
            let first = d.iter().find(|d| d.is_error()).map(|d| d.message.clone()).unwrap_or_default();
            return Outcome::Refused(format!("does not plan: {first}"));
        }
    };
    let (planned, program) = (&compiled.planned, &compiled.program);
    let gpu_target = if mode == Precision::Fixed9 { Target::new(w, h) } else { Target::float(w, h) };
    let gpu_img = match ScenePlan::new(planned, program, Some(source), mode, scene, assets)
        .and_then(|p| p.render_into(gpu, &gpu_target))
    {
        Ok(img) => img.into_raw(),
        Err(SceneRunError::Unsupported(why)) => return Outcome::Refused(format!("wgpu: {why}")),
        Err(e) => return Outcome::Refused(format!("wgpu failed: {e}")),
    };
    let mut renderer = match PlanRenderer::new(planned, program, scene, assets) {
        Ok(r) => r,
        Err(e) => return Outcome::Refused(format!("CPU: {e}")),
    };
    // Where the plan draws shadow volumes, the pixels whose stencil count
    // is the rasterizer's choice under per-vertex snapping are left out
    // with the edge mask's, and counted (`volume_ties`).
    let (mask, volume_ties) = if planned.setups.iter().any(|s| s.draws_volumes) {
        let surface = volume_ties::Surface::of(scene, assets, (w, h));
        let ties = match volume_ties::ambiguous(scene, assets, planned, &surface) {
            Ok(t) => t,
            Err(e) => return Outcome::Refused(format!("CPU: {e}")),
        };
        let left_out = (0..mask.len()).filter(|&i| ties[i] && !mask[i]).count();
        (mask.iter().zip(&ties).map(|(&m, &t)| m || t).collect::<Vec<bool>>(), left_out)
    } else {
        (mask.to_vec(), 0)
    };
    match compare_pictures(&mut renderer, mode, (w, h), class_of(&planned.module), gpu_img, &mask) {
        Ok(c) => Outcome::Compared(Comparison { volume_ties, ..c }),
        Err(e) => Outcome::Refused(format!("CPU: {e}")),
    }
}

/// The CPU's pictures, added as the bound needs them (module docs), against `gpu`.
fn compare_pictures(
    r: &mut PlanRenderer,
    mode: Precision,
    (w, h): (u32, u32),
    class: Class,
    gpu: Vec<u8>,
    mask: &[bool],
) -> Result<Comparison, crate::renderer::RenderError> {
    let render = |r: &mut PlanRenderer| r.render(mode, w, h, &mut |_, _| {}).map(|f| f.image.to_rgba8());
    let model = render(r)?;
    let mut hull = Hull::new(&model);
    let beyond_model_picture = hull.beyond(&gpu, mask);
    if beyond_model_picture > 0 {
        for (steps, quanta, ulps, volume) in TIES {
            for sign in [1.0, -1.0] {
                r.set_rounding_bias(RoundingBias {
                    register_steps: sign * steps,
                    texel_quanta: sign as f32 * quanta,
                    comparison_ulps: sign * ulps,
                    volume_depth_steps: sign as f32 * volume,
                    volume_subpixels: [0.0; 2],
                });
                hull.add(&render(r)?);
            }
        }
        r.set_rounding_bias(RoundingBias::default());
    }
    let beyond_ties = if beyond_model_picture > 0 { hull.beyond(&gpu, mask) } else { 0 };
    if beyond_ties > 0 && class == Class::Filtered {
        for latitude in &Latitude::ENVELOPE[1..] {
            r.set_sampling_latitude(*latitude);
            hull.add(&render(r)?);
        }
        r.set_sampling_latitude(Latitude::MODEL);
    }
    let beyond =
        if beyond_ties > 0 && class == Class::Filtered { hull.beyond(&gpu, mask) } else { beyond_ties };
    let on = |i: usize| !mask[i];
    let compared = (0..mask.len()).filter(|&i| on(i)).count();
    let lit = (0..mask.len()).filter(|&i| on(i) && model[4 * i..4 * i + 3].iter().any(|&c| c > 0)).count();
    let max_diff = (0..mask.len())
        .filter(|&i| on(i))
        .flat_map(|i| (0..4).map(move |c| 4 * i + c))
        .map(|k| model[k].abs_diff(gpu[k]))
        .max()
        .unwrap_or(0);
    let pictures = (max_diff > 0).then(|| {
        let state = (0..mask.len())
            .map(|i| {
                if mask[i] {
                    1
                } else if hull.outside(&gpu, i) {
                    2
                } else {
                    0
                }
            })
            .collect();
        let image = |v: &[u8]| {
            RgbaImage::from_raw(w, h, v.to_vec()).ok_or_else(|| {
                crate::renderer::RenderError::Unsupported(format!(
                    "internal: a {w}×{h} picture of {} bytes, not w·h·4",
                    v.len()
                ))
            })
        };
        Ok::<_, crate::renderer::RenderError>((image(&model)?, image(&gpu)?, state))
    });
    let pictures = pictures.transpose()?;
    Ok(Comparison {
        class,
        compared,
        lit,
        volume_ties: 0,
        max_diff,
        beyond_model_picture,
        beyond_ties,
        beyond,
        pictures,
    })
}

/// Per pixel and channel, the range of the CPU's pictures.
struct Hull {
    lo: Vec<u8>,
    hi: Vec<u8>,
}

impl Hull {
    fn new(first: &[u8]) -> Hull {
        Hull { lo: first.to_vec(), hi: first.to_vec() }
    }

    fn add(&mut self, picture: &[u8]) {
        for (k, &v) in picture.iter().enumerate() {
            self.lo[k] = self.lo[k].min(v);
            self.hi[k] = self.hi[k].max(v);
        }
    }

    /// Whether pixel `i` of `gpu` lies outside [lo − 1, hi + 1] in a channel.
    fn outside(&self, gpu: &[u8], i: usize) -> bool {
        (4 * i..4 * i + 4)
            .any(|k| gpu[k].saturating_add(1) < self.lo[k] || gpu[k] > self.hi[k].saturating_add(1))
    }

    /// Pixels off the mask outside the bound.
    fn beyond(&self, gpu: &[u8], mask: &[bool]) -> usize {
        (0..mask.len()).filter(|&i| !mask[i] && self.outside(gpu, i)).count()
    }
}

const ID_WGSL: &str = r#"
struct VsOut { @builtin(position) pos: vec4<f32>, @location(0) id: vec4<f32> }
@vertex
fn vs_main(@location(0) pos: vec4<f32>, @location(1) id: vec4<f32>) -> VsOut {
    return VsOut(vec4<f32>(pos.xy, 0.5 * (pos.z + pos.w), pos.w), id);
}
@fragment
fn fs_main(in: VsOut) -> @location(0) vec4<f32> { return in.id; }
"#;

/// Triangle IDs per pixel (0: background), drawn on the GPU with the
/// binder's camera clip matrices and a depth test: with [`edge_mask`],
/// the pixels where executors may own a shared edge differently (GL
/// §3.5.1), which every CPU-against-GPU comparison leaves out.
pub fn triangle_ids(
    gpu: &Gpu,
    scene: &Scene,
    assets: &SceneAssets,
    (w, h): (u32, u32),
) -> Result<Vec<u32>, BenchError> {
    let (center, radius) = assets.bounding_sphere();
    let light = light_view_projection(scene.lights.first(), center, radius);
    let state = RenderState {
        cull: CullMode::None,
        depth: DepthState { func: CompareFunc::Less, write: true },
        stencil: StencilState::DISABLED,
        blend: BlendState::REPLACE,
        alpha_test: crate::pipeline::AlphaTest::DISABLED,
    };
    let mut next = 1u32;
    let mut passes = Vec::new();
    for (mesh, model) in &assets.meshes {
        let object = BoundObject::new(scene, mesh, *model, w as f32 / h as f32, light);
        let mut floats = Vec::new();
        for tri in &mesh.triangles {
            let id = [0, 8, 16].map(|s| ((next >> s) & 255) as f32 / 255.0);
            next += 1;
            for &v in tri {
                let p = object.camera_clip * mesh.positions[v as usize].extend(1.0);
                floats.extend_from_slice(&p.to_array());
                floats.extend_from_slice(&[id[0], id[1], id[2], 1.0]);
            }
        }
        let n = floats.len() as u32 / 8;
        passes.push(RunPass {
            label: "triangle ids".into(),
            shader: RunShader {
                source: ShaderSource::Wgsl(ID_WGSL.into()),
                vertex_entry: "vs_main".into(),
                fragment_entry: "fs_main".into(),
            },
            vertices: VertexData { floats, components: vec![4, 4] },
            indices: (0..n).collect(),
            textures: vec![],
            uniforms: None,
            state,
            target: PassTarget::Main,
            loaded: vec![],
            outputs: 1,
        });
    }
    let img = run_passes(gpu, &Target::new(w, h), &passes).map_err(|e| failed("triangle ids", e))?;
    Ok(img.pixels().map(|p| p.0[0] as u32 | (p.0[1] as u32) << 8 | (p.0[2] as u32) << 16).collect())
}

/// Pixels whose 3×3 neighbourhood has more than one triangle ID.
pub fn edge_mask(ids: &[u32], (w, h): (u32, u32)) -> Vec<bool> {
    let (w, h) = (w as i64, h as i64);
    let id = |x: i64, y: i64| (x >= 0 && y >= 0 && x < w && y < h).then(|| ids[(y * w + x) as usize]);
    (0..h * w)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let c = ids[i as usize];
            (-1..=1).any(|dy| (-1..=1).any(|dx| id(x + dx, y + dy).is_some_and(|n| n != c)))
        })
        .collect()
}

/// What is timed: the default scene (Kilgard's bump mapping on the
/// torus: three passes on geforce256, one on wgsl) and Adaptive Sample
/// Shading's 4-light sphere (one pass per light), in full.
const TIMED: [(NamedText, NamedText, &str, Precision); 3] = [
    (TORUS, KILGARD, "geforce256", Precision::Fixed9),
    (TORUS, KILGARD, "wgsl", Precision::F32),
    (SPHERE, FRAGMENT_LIGHTING, "wgsl", Precision::F32),
];

/// One program on one scene at `size`² on both executors, planned as
/// `render` plans it (for the scene).
fn time_case(
    gpu: &Gpu,
    scene_file: (&'static str, &'static str),
    (program_name, source): (&'static str, &'static str),
    target: &'static str,
    mode: Precision,
    size: u32,
    runs: usize,
) -> Result<Timing, String> {
    let (scene, assets) = scene(scene_file).map_err(|e| e.to_string())?;
    let profile = Profile::resolve(target).map_err(|e| e.to_string())?;
    let options = PlanOptions { scene: Some(ForScene::specialized(&scene, &assets)), ..Default::default() };
    let compiled = crate::driver::compile(source, &profile, &options)
        .map_err(|d| d.first().map(|d| d.message.clone()).unwrap_or_default())?;
    let (planned, program) = (&compiled.planned, &compiled.program);
    let renderer = PlanRenderer::new(planned, program, &scene, &assets).map_err(|e| e.to_string())?;
    let cpu_frame = || -> Result<Duration, String> {
        let start = Instant::now();
        renderer.render(mode, size, size, &mut |_, _| {}).map_err(|e| e.to_string())?;
        Ok(start.elapsed())
    };
    cpu_frame()?;
    let mut times = (0..runs.max(1)).map(|_| cpu_frame()).collect::<Result<Vec<_>, _>>()?;
    let cpu = median(&mut times);
    let plan =
        ScenePlan::new(planned, program, Some(source), mode, &scene, &assets).map_err(|e| e.to_string())?;
    let target_image = Target::new(size, size);
    let start = Instant::now();
    let passes = plan.passes_in(&target_image).map_err(|e| e.to_string())?;
    let frame = Frame::prepare(gpu, &target_image, &passes).map_err(|e| e.to_string())?;
    let prepare = start.elapsed();
    let timed = frame.draw_median(gpu, runs).map_err(|e| e.to_string())?;
    Ok(Timing {
        scene: scene_file.0,
        program: program_name,
        target,
        mode,
        size,
        passes: planned.plan.passes.len(),
        cpu,
        gpu: timed.time(),
        timestamps: timed.gpu.is_some(),
        prepare,
    })
}

/// The montage's cases, the worst first: most pixels beyond the bound,
/// then the largest difference; only cases whose pictures differ.
fn worst(cases: &[Case]) -> Vec<(&Case, &Comparison)> {
    let mut worst: Vec<(&Case, &Comparison)> = cases
        .iter()
        .filter_map(|c| match &c.outcome {
            Outcome::Compared(k) if k.pictures.is_some() => Some((c, k)),
            _ => None,
        })
        .collect();
    worst.sort_by_key(|(_, k)| std::cmp::Reverse((k.beyond, k.max_diff)));
    worst.truncate(MONTAGE_ROWS);
    worst
}

/// Up to this many cases in the montage, the worst first.
const MONTAGE_ROWS: usize = 6;
/// A difference of one 8-bit step shows as this grey level in the montage.
const MONTAGE_SCALE: u32 = 32;

/// CPU | GPU | difference for the worst cases (most pixels beyond the
/// bound, then the largest difference): the difference grey, ×
/// [`MONTAGE_SCALE`] per step, red beyond the bound, dark blue masked.
fn montage(cases: &[Case]) -> Result<Vec<u8>, BenchError> {
    let worst: Vec<&Comparison> = worst(cases).into_iter().map(|(_, k)| k).collect();
    let (w, h) = worst.first().and_then(|k| k.pictures.as_ref()).map_or((1, 1), |p| p.0.dimensions());
    let mut out = RgbaImage::from_pixel(3 * w, h * worst.len().max(1) as u32, image::Rgba([0, 0, 0, 255]));
    for (row, k) in worst.iter().enumerate() {
        let Some((cpu, gpu, state)) = &k.pictures else { continue };
        let y0 = row as u32 * h;
        for (i, s) in state.iter().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            let (a, b) = (cpu.get_pixel(x, y).0, gpu.get_pixel(x, y).0);
            let d = (0..4).map(|c| a[c].abs_diff(b[c]) as u32).max().unwrap_or(0);
            let g = (d * MONTAGE_SCALE).min(255) as u8;
            let diff = match s {
                1 => [0, 0, 90, 255],
                2 => [255, 0, 0, 255],
                _ => [g, g, g, 255],
            };
            out.put_pixel(x, y0 + y, image::Rgba([a[0], a[1], a[2], 255]));
            out.put_pixel(w + x, y0 + y, image::Rgba([b[0], b[1], b[2], 255]));
            out.put_pixel(2 * w + x, y0 + y, image::Rgba(diff));
        }
    }
    let mut bytes = Vec::new();
    out.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).map_err(io)?;
    Ok(bytes)
}

impl GpuCheck {
    /// `gpu-check.md`.
    pub fn markdown(&self) -> String {
        let o = &self.options;
        let mut md = String::from("# GPU check\n\n");
        let _ = writeln!(md, "Adapter: **{}**.\n", self.adapter);
        let _ = writeln!(
            md,
            "Comparisons at {}×{} on `{}` (procedural stand-in textures), {} case(s); timings at {} (median of {} frame(s) after a warm-up); {:.1} s in all. The bound is the texture unit's model with its stated latitude (`textures::unit`; docs/gpu-check.md): a pixel off the edge mask is within the model when every channel lies within 1/255 of the range of the CPU's pictures (the model; the model with float-noise ties moved; for filtered cases every λ and sub-texel weight choice the specifications allow).\n",
            o.size.0,
            o.size.1,
            TORUS.0,
            self.cases.len(),
            o.timing_sizes.iter().map(|s| format!("{s}²")).collect::<Vec<_>>().join(", "),
            o.runs,
            self.elapsed.as_secs_f64()
        );
        let _ = writeln!(md, "**{} compared case(s) beyond the model.**\n", self.failures());
        md += &self.cases_table();
        md += &self.timings_table();
        md += &self.crossover_section();
        md += "\nMontage: `gpu-check.png`, the worst cases (most pixels beyond the model, then the largest difference), one per row: CPU | GPU | difference (grey, ×32 per 8-bit step; red: beyond the model; dark blue: edge mask). Rows:";
        for (row, (c, k)) in worst(&self.cases).iter().enumerate() {
            let _ = write!(
                md,
                " {}. {} on {} ({}/255, {} beyond);",
                row + 1,
                c.program,
                c.target,
                k.max_diff,
                k.beyond
            );
        }
        md.pop();
        md += ".\n";
        md
    }

    fn cases_table(&self) -> String {
        let mut md = String::from(
            "## Comparisons\n\n| program | target | mode | class | compared (lit; left out at volume ties) | max diff | beyond: model picture / + ties / + latitude | verdict |\n|---|---|---|---|---|---|---|---|\n",
        );
        let mut refused = String::new();
        for c in &self.cases {
            match &c.outcome {
                Outcome::Compared(k) => {
                    let _ = writeln!(
                        md,
                        "| {} | {} | {} | {} | {} ({}; {}) | {}/255 | {} / {} / {} | {} |",
                        c.program,
                        c.target,
                        c.mode.name(),
                        if k.class == Class::Exact { "exact" } else { "filtered" },
                        k.compared,
                        k.lit,
                        k.volume_ties,
                        k.max_diff,
                        k.beyond_model_picture,
                        k.beyond_ties,
                        if k.class == Class::Exact { "—".to_string() } else { k.beyond.to_string() },
                        k.verdict()
                    );
                }
                Outcome::Refused(why) => {
                    let _ = writeln!(refused, "- {} on {}: {}", c.program, c.target, why.replace('\n', " "));
                }
            }
        }
        if !refused.is_empty() {
            md += "\nNot compared (does not plan, or wgpu cannot run the plan yet):\n\n";
            md += &refused;
        }
        md
    }

    fn crossover_section(&self) -> String {
        let mut md = String::from("\n## Adaptive crossover\n\n");
        match &self.crossover {
            Ok(rows) if rows.is_empty() => return String::new(),
            Ok(rows) => {
                md += "Phong shaders of k lobes on the 4-light sphere, planned per light on wgsl, f32; full and adaptive shading (threshold 8.5 %, samples every 16 pixels) of the same plan in the same run, median frames (`bench::adaptive_crossover`, docs/gpu-check.md).\n\n";
                md += &super::adaptive_crossover::markdown(rows);
            }
            Err(e) => {
                let _ = writeln!(md, "The sweep failed: {e}");
            }
        }
        md
    }

    fn timings_table(&self) -> String {
        let mut md = String::from(
            "\n## Timings\n\n| scene | program | target | mode | passes | size | CPU ms | GPU ms | clock | CPU / GPU | prepare ms |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
        );
        for t in &self.timings {
            match t {
                Ok(t) => {
                    let _ = writeln!(
                        md,
                        "| {} | {} | {} | {} | {} | {}² | {:.2} | {:.3} | {} | {:.1}× | {:.1} |",
                        t.scene,
                        t.program,
                        t.target,
                        t.mode.name(),
                        t.passes,
                        t.size,
                        t.cpu.as_secs_f64() * 1e3,
                        t.gpu.as_secs_f64() * 1e3,
                        if t.timestamps { "timestamps" } else { "wall" },
                        t.cpu.as_secs_f64() / t.gpu.as_secs_f64().max(1e-9),
                        t.prepare.as_secs_f64() * 1e3
                    );
                }
                Err(e) => {
                    let _ = writeln!(md, "| failed: {} | | | | | | | | | | |", e.replace('|', "/"));
                }
            }
        }
        md += "\nCPU and GPU times are medians of the timed frames (GPU: timestamp queries around the frame's passes where the adapter has them, else submit to read-back); prepare is pipelines and uploads, once per scene.\n";
        md
    }
}
