//! The CPU rasterizer — the δπx of the pipeline grammar (Pipeline Grammar, Section 2:
//! δ interpolates per-vertex values across a primitive, π projects it, x is
//! the pixel): clipping (near/far plane and a guard band), a fixed-point
//! top-left fill rule, perspective-correct interpolation of N varyings,
//! back-face culling, stencil and depth tests (including the `Equal` test
//! that re-rendering passes use, Kilgard 2000, Section 5), GL blending into RGBA8
//! or f32 colour, tiled (`TILE`×`TILE`) and parallel over tiles with rayon.
//!
//! A pass is a [`Pass`]: triangle indices, a [`VertexStage`] that turns a
//! vertex index into a clip-space position plus N f32 varyings, a
//! [`FragmentStage`] that turns the interpolated varyings of one pixel into an
//! RGBA colour or a discard, and the fixed-function [`RenderState`]. The
//! fragment interface is allocation-free: varyings arrive as a `&[f32]` slice
//! owned by the tile's worker.

pub mod adaptive;
mod framebuffer;
pub mod lights;
pub mod plan;
mod raster;
mod tile;
pub mod vertex_program;

/// The fixed-function state the rasterizer applies is the plan contract's.
pub use crate::pipeline::{
    AlphaTest, BlendEquation, BlendFactor, BlendState, CompareFunc, CullMode, DepthState, RenderState,
    StencilOp, StencilState,
};
pub use adaptive::{draw_adaptive, image_error, AdaptiveSettings, AdaptiveStats, EdgeMode, ImageError};
pub use framebuffer::{quantize_unorm8, ColorFormat, Framebuffer, TILE};
pub use raster::{Fragment, SUBPIXEL_BITS};

use thiserror::Error;

/// Why the CPU renderer could not draw: each message says what to change.
#[derive(Debug, Error)]
pub enum RenderError {
    #[error("framebuffer size {width}x{height} is not usable; use 1..=16384 pixels on each side")]
    BadSize { width: u32, height: u32 },
    #[error("triangle {triangle} uses vertex {index}, but the vertex stage has only {n_vertices} vertices; check the mesh's index buffer")]
    IndexOutOfRange { triangle: usize, index: u32, n_vertices: usize },
    #[error("{path}: cannot encode image: {message}")]
    Encode { path: String, message: String },
    #[error("{0}")]
    Io(String),
    #[error("{0}")]
    Unsupported(String),
    /// An error of pass `pass` (0-based) of a plan: callers with the
    /// source locate it at the pass's statement (`shadec render` does).
    #[error("pass {}: {source}", pass + 1)]
    InPass { pass: usize, source: Box<RenderError> },
}

impl RenderError {
    /// This error, as one of pass `pass` (0-based) of a plan.
    pub fn in_pass(self, pass: usize) -> RenderError {
        match self {
            e @ RenderError::InPass { .. } => e,
            e => RenderError::InPass { pass, source: Box::new(e) },
        }
    }
}

/// The per-vertex stage of a pass: `clip position + N varyings` per vertex.
pub trait VertexStage: Sync {
    /// How many vertices may be referenced by the pass's indices.
    fn n_vertices(&self) -> usize;
    /// How many f32 varyings each vertex produces (and each fragment receives).
    fn n_varyings(&self) -> usize;
    /// Writes the varyings of vertex `index` into `varyings` (length
    /// `n_varyings()`) and returns its clip-space position (x, y, z, w), GL
    /// conventions: visible where −w ≤ x, y, z ≤ w.
    fn shade_vertex(&self, index: u32, varyings: &mut [f32]) -> [f32; 4];
}

/// What a fragment stage decided for one pixel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FragmentResult {
    /// Write (blend) the colour left in `out`.
    Keep,
    /// Drop the fragment: no colour, depth or stencil update.
    Discard,
}

/// The per-fragment stage of a pass.
pub trait FragmentStage: Sync {
    /// Shades one pixel: `varyings` are the perspective-correct interpolated
    /// vertex varyings; `fragment` gives the pixel position, depth, facing and
    /// screen-space derivatives; `out` receives RGBA.
    fn shade(&self, fragment: &Fragment, varyings: &[f32], out: &mut [f32; 4]) -> FragmentResult;

    /// Shades fragments of one tile together, at most [`BATCH`], of one
    /// triangle or of several (`varyings`: the same number per fragment, in
    /// order), as [`FragmentStage::shade`] would one at a time: the
    /// rasterizer has already tested them, and each writes a different pixel.
    fn shade_batch(
        &self,
        fragments: &[Fragment],
        varyings: &[f32],
        out: &mut [[f32; 4]],
        results: &mut [FragmentResult],
    ) {
        shade_each(self, fragments, varyings, out, results)
    }

    /// [`FragmentStage::shade_batch`] with the varyings stored by component
    /// (the tiled rasterizer's batches): value `c` of fragment `i` at
    /// `rows[c * row + i]`, `per` values a fragment. The default copies them
    /// out by fragment ([`shade_rows_by_fragment`]).
    fn shade_batch_rows(
        &self,
        fragments: &[Fragment],
        (rows, per, row): (&[f32], usize, usize),
        out: &mut [[f32; 4]],
        results: &mut [FragmentResult],
    ) {
        shade_rows_by_fragment(self, fragments, (rows, per, row), out, results)
    }

    /// Whether the stage gives each fragment a depth of its own, which the
    /// depth test then takes in place of the interpolated one
    /// (NV_texture_shader's `DOT_PRODUCT_DEPTH_REPLACE_NV`, WGSL's
    /// `frag_depth`). Such a stage is shaded before the depth test.
    fn replaces_depth(&self) -> bool {
        false
    }

    /// Whether the stage may drop a fragment ([`FragmentResult::Discard`]).
    /// `false` is a promise: an adaptive draw then writes its pixels as it
    /// interpolates them, before the refinement has shaded them all. The
    /// default, `true`, is always right.
    fn may_discard(&self) -> bool {
        true
    }

    /// [`FragmentStage::shade`], and the fragment's depth: the replaced one
    /// where the stage replaces it ([`FragmentStage::replaces_depth`]), else
    /// the interpolated `fragment.depth`.
    fn shade_with_depth(
        &self,
        fragment: &Fragment,
        varyings: &[f32],
        out: &mut [f32; 4],
    ) -> (FragmentResult, f32) {
        (self.shade(fragment, varyings, out), fragment.depth)
    }
}

/// [`FragmentStage::shade_batch`] as [`FragmentStage::shade`] of each
/// fragment in turn.
pub fn shade_each<S: FragmentStage + ?Sized>(
    stage: &S,
    fragments: &[Fragment],
    varyings: &[f32],
    out: &mut [[f32; 4]],
    results: &mut [FragmentResult],
) {
    let per = varyings.len().checked_div(fragments.len()).unwrap_or(0);
    for (i, fragment) in fragments.iter().enumerate() {
        results[i] = stage.shade(fragment, &varyings[i * per..(i + 1) * per], &mut out[i]);
    }
}

/// [`FragmentStage::shade_batch_rows`] through [`FragmentStage::shade_batch`]:
/// the varyings copied out by fragment first.
pub fn shade_rows_by_fragment<S: FragmentStage + ?Sized>(
    stage: &S,
    fragments: &[Fragment],
    (rows, per, row): (&[f32], usize, usize),
    out: &mut [[f32; 4]],
    results: &mut [FragmentResult],
) {
    let n = fragments.len();
    let mut varyings = vec![0.0f32; n * per];
    for (i, v) in varyings.chunks_exact_mut(per.max(1)).enumerate().take(n) {
        for (c, x) in v.iter_mut().enumerate() {
            *x = rows[c * row + i];
        }
    }
    stage.shade_batch(fragments, &varyings, out, results)
}

/// The most fragments [`FragmentStage::shade_batch`] receives at once.
pub const BATCH: usize = 32;

/// One rendering pass over one mesh.
pub struct Pass<'a> {
    /// Triangle list: three vertex indices per triangle.
    pub triangles: &'a [[u32; 3]],
    pub vertex: &'a dyn VertexStage,
    pub fragment: &'a dyn FragmentStage,
    pub state: RenderState,
}

/// Counters of one draw, for tests and the speed report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DrawStats {
    pub triangles_in: usize,
    /// Triangles after clipping (a clipped triangle may become several).
    pub triangles_setup: usize,
    pub culled: usize,
    /// Zero-area after snapping, or non-finite positions.
    pub degenerate: usize,
    /// Fragments that passed coverage and reached the tests.
    pub fragments: u64,
    /// Fragments whose fragment stage ran.
    pub shaded: u64,
    /// Fragments that passed all tests and were written.
    pub written: u64,
}

/// Draws one pass into `target` using the current rayon thread pool
/// (wrap in `ThreadPool::install` to choose the thread count).
pub fn draw(target: &mut Framebuffer, pass: &Pass) -> Result<DrawStats, RenderError> {
    let setup = raster::setup_pass(pass, target.width(), target.height())?;
    let mut stats = tile::rasterize(target, pass, &setup);
    stats.triangles_in = pass.triangles.len();
    stats.triangles_setup = setup.n_triangles();
    stats.culled = setup.culled;
    stats.degenerate = setup.degenerate;
    Ok(stats)
}
