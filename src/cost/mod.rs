//! The cost model: how long a pass plan takes on the hardware it
//! was made for, predicted from the plan and the target profile's
//! [`CostModel`] — the speed the papers report (GeForce3 Phong, Section 5.4,
//! Kilgard 2000, Section 5), not the CPU interpreter's milliseconds.
//!
//! # The model (docs/cost-model.md gives each number's source)
//!
//! A pass is a pipeline: vertex work, triangle setup and fill overlap, so
//! the pass takes as long as its slowest stage, plus a fixed overhead:
//!
//! ```text
//! pass  = max(vertex, setup, fill) + overhead (+ the copy of a render-to-texture target)
//! vertex = vertices · ops · vertex_clocks_per_op / clock
//! setup  = triangles · setup_clocks_per_triangle / clock
//! fill   = max(pixels · clocks_per_pixel / (pipes · clock), pixels · bytes_per_pixel / bandwidth)
//! clocks_per_pixel = max(1, ⌈samples / samples_per_clock⌉) + stages · clocks_per_general_combiner
//! frame = clear + Σ pass
//! ```
//!
//! `samples` counts bilinear samples (a trilinear lookup is two, Kilgard 2000
//! Section 5.3's mipmapped normal maps); `stages` are the general combiner
//! stages the code generator used for the pass. A `bake` table's pass is
//! the compiler's and costs nothing on the target.

pub mod adaptive;
pub mod vertex;
pub mod workload;

use serde::{Deserialize, Serialize};

use crate::ir::Module;
use crate::pipeline::{
    BlendState, CompareFunc, FramePrediction, Pass, PassPlan, PassPrediction, RenderTarget,
};
use crate::profile::CostModel;
pub use workload::{PassLoad, Workload};

/// What limits a pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Bound {
    /// Vertex work (transform, lighting, texgen: the vertex program).
    Vertex,
    /// Triangle setup.
    Setup,
    /// Pixel clocks: texture samples and combiner stages.
    Fill,
    /// Framebuffer, depth and texel bytes.
    Memory,
    /// Nothing drawn: a `bake` table, computed by the compiler.
    Compiler,
}

/// The predicted time of one pass (µs), and why.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassTime {
    /// The pass's total.
    pub us: f64,
    pub vertex_us: f64,
    pub setup_us: f64,
    pub fill_us: f64,
    /// Copying a render-to-texture target into its texture.
    #[serde(default)]
    pub copy_us: f64,
    pub bound: Bound,
    /// Pixel clocks per fragment (texture samples, combiner stages).
    pub clocks_per_pixel: f64,
    /// Fragments rasterized.
    pub pixels: u64,
}

/// The predicted time of a whole plan on its target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Prediction {
    /// What was assumed drawn: the scene, or the nominal workload.
    pub workload: String,
    /// Clearing colour and depth at the start of the frame.
    pub clear_us: f64,
    pub passes: Vec<PassTime>,
    /// `clear_us` + every pass.
    pub total_us: f64,
}

impl Prediction {
    /// The predicted frame time in milliseconds.
    pub fn total_ms(&self) -> f64 {
        self.total_us / 1000.0
    }
}

/// The predicted time of `plan` (its IR `module`) on a target with `model`,
/// drawing `workload`.
pub fn predict(plan: &PassPlan, module: &Module, model: &CostModel, workload: &Workload) -> Prediction {
    let trilinear = Trilinear::of(module);
    let passes: Vec<PassTime> =
        plan.passes.iter().map(|p| pass_time(p, module, &trilinear, model, workload)).collect();
    let (w, h) = workload.resolution;
    let clear_us = f64::from(w) * f64::from(h) * model.clear_bytes_per_pixel / bytes_per_us(model);
    let total_us = clear_us + passes.iter().map(|p| p.us).sum::<f64>();
    Prediction { workload: workload.name.clone(), clear_us, passes, total_us }
}

fn clocks_per_us(model: &CostModel) -> f64 {
    model.clock_mhz
}

fn bytes_per_us(model: &CostModel) -> f64 {
    model.memory_gb_per_s * 1000.0
}

/// One pass: the slowest of vertex, setup and fill, plus its overhead.
pub fn pass_time(
    pass: &Pass,
    module: &Module,
    trilinear: &Trilinear,
    model: &CostModel,
    workload: &Workload,
) -> PassTime {
    let load = workload.pass_load(pass);
    if pass.baked {
        return PassTime {
            us: 0.0,
            vertex_us: 0.0,
            setup_us: 0.0,
            fill_us: 0.0,
            copy_us: 0.0,
            bound: Bound::Compiler,
            clocks_per_pixel: 0.0,
            pixels: 0,
        };
    }
    let clock = clocks_per_us(model);
    let ops = vertex::ops_per_vertex(pass, module);
    let vertex_us = load.vertices as f64 * ops * model.vertex_clocks_per_op / clock;
    let setup_us = load.triangles as f64 * model.setup_clocks_per_triangle / clock;
    let fragment = FragmentLoad {
        samples: texture_samples(pass, trilinear),
        stages: pass.fragment.general_combiners.unwrap_or(0),
        reads_destination: !same_factors(&pass.state.blend, &BlendState::REPLACE),
        depth_tested: pass.state.depth.func != CompareFunc::Always || pass.state.depth.write,
    };
    let clocks_per_pixel = pixel_clocks(model, fragment.samples, fragment.stages);
    let (shade_us, memory_us) = fill(model, load.pixels as f64, &fragment);
    let fill_us = shade_us.max(memory_us);
    let copy_us = match pass.target {
        RenderTarget::Temporary { .. } | RenderTarget::Texture { .. } => {
            copy(model, load.target_pixels as f64)
        }
        RenderTarget::Framebuffer { .. } => 0.0,
    };
    let (slowest, bound) = [
        (vertex_us, Bound::Vertex),
        (setup_us, Bound::Setup),
        (shade_us, Bound::Fill),
        (memory_us, Bound::Memory),
    ]
    .into_iter()
    .fold((0.0, Bound::Fill), |best, c| if c.0 > best.0 { c } else { best });
    PassTime {
        us: slowest + model.pass_overhead_us + copy_us,
        vertex_us,
        setup_us,
        fill_us,
        copy_us,
        bound,
        clocks_per_pixel,
        pixels: load.pixels,
    }
}

/// Pixel clocks of one fragment: its texture trips (a pipe fetches
/// `samples_per_clock` bilinear samples per clock and loops back for more),
/// then its general combiner stages.
pub fn pixel_clocks(model: &CostModel, samples: u32, stages: u32) -> f64 {
    let per_clock = model.samples_per_clock.max(1);
    let trips = samples.div_ceil(per_clock).max(1);
    f64::from(trips) + f64::from(stages) * model.clocks_per_general_combiner
}

/// Bilinear samples a fragment of the pass fetches: one per texture unit,
/// two for a trilinear (mipmapped) texture, which reads two levels.
pub fn texture_samples(pass: &Pass, trilinear: &Trilinear) -> u32 {
    pass.textures.iter().map(|b| if trilinear.0.contains(b.texture.as_str()) { 2 } else { 1 }).sum()
}

/// The names of a module's trilinear textures, looked up once per plan
/// (a plan of 30 000 passes has as many temporaries).
pub struct Trilinear<'m>(rustc_hash::FxHashSet<&'m str>);

impl<'m> Trilinear<'m> {
    /// The textures of `module` sampled trilinearly (mipmapped), which cost more fetches per
    /// lookup.
    pub fn of(module: &'m Module) -> Trilinear<'m> {
        Trilinear(
            module
                .textures
                .iter()
                .filter(|t| t.sampling.filter == crate::textures::Filter::Trilinear)
                .map(|t| t.name.as_str())
                .collect(),
        )
    }
}

/// What one fragment of a pass costs the fill: its bilinear samples, its
/// general combiner stages, whether the blend reads the destination and
/// whether the depth buffer is tested.
pub struct FragmentLoad {
    pub samples: u32,
    pub stages: u32,
    pub reads_destination: bool,
    pub depth_tested: bool,
}

/// The fill of `pixels` such fragments (µs): pixel clocks over the pipes,
/// and memory bytes (colour written, and read when blending; depth; texels
/// after the cache) over the bandwidth.
fn fill(model: &CostModel, pixels: f64, f: &FragmentLoad) -> (f64, f64) {
    let shade_us =
        pixels * pixel_clocks(model, f.samples, f.stages) / (f64::from(model.pixel_pipes) * model.clock_mhz);
    let colour = if f.reads_destination { 8.0 } else { 4.0 };
    let depth = if f.depth_tested { model.depth_bytes_per_pixel } else { 0.0 };
    let bytes = colour + depth + f64::from(f.samples) * model.texel_bytes_per_sample;
    (shade_us, pixels * bytes / bytes_per_us(model))
}

/// Copying a rendered target into its texture (glCopyTexSubImage2D):
/// every pixel read and written.
fn copy(model: &CostModel, pixels: f64) -> f64 {
    pixels * 8.0 / bytes_per_us(model)
}

fn same_factors(a: &BlendState, b: &BlendState) -> bool {
    (a.src_rgb, a.dst_rgb, a.src_alpha, a.dst_alpha, a.equation)
        == (b.src_rgb, b.dst_rgb, b.src_alpha, b.dst_alpha, b.equation)
}

/// Writes the prediction of `workload` into `plan` (its total, and each
/// pass's time and bound), where `model` is the target's; what `compile
/// --emit plan` shows.
pub fn annotate(plan: &mut PassPlan, module: &Module, model: &CostModel, workload: &Workload) {
    let prediction = predict(plan, module, model, workload);
    for (pass, time) in plan.passes.iter_mut().zip(&prediction.passes) {
        pass.predicted = Some(PassPrediction {
            us: nanoseconds(time.us),
            bound: time.bound.name().into(),
            clocks_per_pixel: time.clocks_per_pixel,
            pixels: time.pixels,
        });
    }
    plan.predicted = Some(FramePrediction {
        workload: prediction.workload,
        total_us: nanoseconds(prediction.total_us),
        clear_us: nanoseconds(prediction.clear_us),
    });
}

/// µs rounded to the nanosecond: what a plan document shows.
fn nanoseconds(us: f64) -> f64 {
    (us * 1000.0).round() / 1000.0
}

impl Bound {
    /// The bound's name, as the plan's prediction reports it.
    pub fn name(self) -> &'static str {
        match self {
            Bound::Vertex => "vertex",
            Bound::Setup => "setup",
            Bound::Fill => "fill",
            Bound::Memory => "memory",
            Bound::Compiler => "compiler",
        }
    }
}

/// The time of one pass on the nominal workload (ns, rounded), for the
/// planner's comparison of plans that fit: fill (texture
/// trips, combiner stages), memory (a blend reading the destination), a
/// render-to-texture copy, the pass overhead. Vertex work is left out: every
/// piece of one statement draws the same mesh.
pub fn nominal_pass_ns(model: &CostModel, fragment: &FragmentLoad, to_texture: bool) -> u64 {
    let (w, h) = Workload::nominal().resolution;
    let pixels = f64::from(w) * f64::from(h);
    let (shade_us, memory_us) = fill(model, pixels, fragment);
    let copy_us = if to_texture { copy(model, pixels) } else { 0.0 };
    ((shade_us.max(memory_us) + copy_us + model.pass_overhead_us) * 1000.0).round() as u64
}
