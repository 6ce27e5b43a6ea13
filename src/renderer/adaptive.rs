//! Adaptive Sample Shading (Adaptive Sample Shading, Section 2.1) for any [`FragmentStage`](crate::renderer::FragmentStage):
//! shade exactly at regular samples and at edges, subdivide where
//! neighbouring samples differ by more than a threshold, interpolate the rest.
//!
//! [`draw_adaptive`] works in three steps over the whole frame:
//!
//! 1. **Visibility.** Every pass is set up as by [`super::draw`] and scan
//!    converted (same fill rule, same depth test) into a buffer of
//!    primitive ids: which triangle of which pass is visible at each pixel.
//!    Nothing is shaded yet.
//! 2. **Scanlines** (Section 2.1, Fig. 1). On every `spacing`-th row (and the
//!    last row), each run of pixels of the same surface is shaded exactly at
//!    its ends, at every `spacing`-th column and at its edge pixels — the
//!    paper's *regular samples*. Between two neighbouring samples whose
//!    colours differ by more than `threshold` in some channel, a sample is
//!    shaded half-way (Section 2.1.2, binary subdivision, at most
//!    `max_depth` levels); where they do not, the pixels between are
//!    interpolated linearly.
//! 3. **Columns** (two-dimensional, Fig. 11). Every column between two
//!    regular rows is processed the same way, with the regular rows' values
//!    (exact or interpolated) and the edge pixels as its samples.
//!
//! 4. **Refinement** (beyond the paper): interpolated pixels that differ by
//!    more than the threshold from a neighbour are shaded exactly, and the
//!    search follows the feature from there (see `Ctx::refine`).
//!
//! An *edge pixel* is a covered pixel whose 4-neighbour is uncovered or
//! belongs to another surface; it is always shaded exactly, so colours are
//! never interpolated across a silhouette. What counts as the same surface
//! is [`EdgeMode`]: the same triangle (the paper's edge samples), or the same
//! pass (interpolation across the inner edges of a smooth mesh).
//!
//! A threshold ≤ 0 shades every pixel exactly (no interpolation). Limits:
//! the stencil test is not supported (the draw returns
//! [`RenderError::Unsupported`]); a fragment discarded at a sample is not
//! written and counts as black for its neighbours' interpolation;
//! interpolated pixels cannot discard.

use rayon::prelude::*;

mod lines;

use super::framebuffer::TILE;
use super::raster::{setup_pass, PassSetup, SUB};
use super::{Framebuffer, Pass, RenderError};

/// What counts as one surface for edge detection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeMode {
    /// Every triangle is its own surface: pixels next to another triangle
    /// are shaded exactly (the paper's edge samples, Fig. 9).
    Triangle,
    /// A pass (one mesh, one fragment stage) is one surface: only
    /// silhouettes and boundaries between passes are edges. Right for
    /// smooth meshes, whose varyings are continuous across triangles.
    Pass,
}

/// The knobs of Section 2.1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// Distance between regular samples in pixels (the paper uses 8 or 16).
    pub spacing: u32,
    /// Largest per-channel colour difference between neighbouring samples
    /// that is interpolated, in the colour's units (0.085 = 8.5 % of 1.0).
    pub threshold: f32,
    /// Most levels of binary subdivision; log2(spacing) reaches single pixels.
    pub max_depth: u32,
    pub edges: EdgeMode,
}

impl AdaptiveSettings {
    /// Subdivision down to single pixels.
    pub fn new(spacing: u32, threshold: f32, edges: EdgeMode) -> AdaptiveSettings {
        AdaptiveSettings {
            spacing,
            threshold,
            max_depth: spacing.max(1).next_power_of_two().trailing_zeros(),
            edges,
        }
    }
}

/// Counters of one adaptive draw. `regular + edge + adaptive` pixels were
/// shaded exactly; `interpolated` were not.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AdaptiveStats {
    /// Pixels covered by some visible triangle.
    pub covered: u64,
    /// Regular samples (every `spacing` pixels, ends of runs).
    pub regular: u64,
    /// Pixels at edges (next to another surface or an uncovered pixel).
    pub edge: u64,
    /// Samples added by binary subdivision.
    pub adaptive: u64,
    pub interpolated: u64,
    /// Samples whose fragment stage discarded.
    pub discarded: u64,
}

impl AdaptiveStats {
    /// Pixels whose fragment stage ran.
    pub fn shaded(&self) -> u64 {
        self.regular + self.edge + self.adaptive
    }
    /// Shaded / covered, in [0, 1].
    pub fn fraction_shaded(&self) -> f64 {
        if self.covered == 0 {
            0.0
        } else {
            self.shaded() as f64 / self.covered as f64
        }
    }
}

/// The counters of two draws together.
impl std::ops::Add for AdaptiveStats {
    type Output = AdaptiveStats;

    fn add(self, o: AdaptiveStats) -> AdaptiveStats {
        AdaptiveStats {
            covered: self.covered + o.covered,
            regular: self.regular + o.regular,
            edge: self.edge + o.edge,
            adaptive: self.adaptive + o.adaptive,
            interpolated: self.interpolated + o.interpolated,
            discarded: self.discarded + o.discarded,
        }
    }
}

/// How far one image is from another, over the RGB channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    pub max_abs: f32,
    /// 10·log10(1/MSE) in dB for colours in [0, 1]; infinite when equal.
    pub psnr: f64,
}

/// Compares two images of the same size (e.g. [`Framebuffer::to_rgba_f32`]).
pub fn image_error(reference: &[[f32; 4]], test: &[[f32; 4]]) -> ImageError {
    assert_eq!(reference.len(), test.len(), "images of different sizes");
    let mut max_abs = 0.0f32;
    let mut sum = 0.0f64;
    for (a, b) in reference.iter().zip(test) {
        for c in 0..3 {
            let d = (a[c] - b[c]).abs();
            max_abs = max_abs.max(d);
            sum += (d as f64) * (d as f64);
        }
    }
    let mse = sum / (3 * reference.len().max(1)) as f64;
    ImageError { max_abs, psnr: if mse == 0.0 { f64::INFINITY } else { 10.0 * (1.0 / mse).log10() } }
}

const NONE: u32 = u32::MAX;

// Pixel states.
const UNKNOWN: u8 = 0;
const REGULAR: u8 = 1;
const EDGE: u8 = 2;
const ADAPTIVE: u8 = 3;
const INTERPOLATED: u8 = 4;
/// Set on top of a state when the fragment stage discarded.
const DISCARD_BIT: u8 = 0x80;

/// A draw's colour and state buffers, one entry per pixel.
type Buffers = (Vec<[f32; 4]>, Vec<u8>);

thread_local! {
    /// The colour and state buffers of the last draw on this thread, reused
    /// by the next (a plan draws one adaptive pass per light): fresh
    /// megabytes per pass cost their page faults every time.
    static SCRATCH: std::cell::Cell<Option<Buffers>> = const { std::cell::Cell::new(None) };
}

/// Draws `passes` in order with adaptive sample shading. Depth testing,
/// culling and blending follow each pass's state; the stencil must be disabled.
pub fn draw_adaptive(
    target: &mut Framebuffer,
    passes: &[Pass],
    settings: &AdaptiveSettings,
) -> Result<AdaptiveStats, RenderError> {
    check_adaptive(passes, settings)?;
    let (w, h) = (target.width() as usize, target.height() as usize);
    let (setups, offsets) = setup_passes(passes, w, h)?;

    // 1. Visibility, in bands of TILE rows.
    let (ids, depth) = visible(target, passes, &setups, &offsets);

    let keys = surface_keys(&ids, &offsets, settings.edges);
    let edges = edge_map(&keys, w, h);
    let ctx = Ctx {
        passes,
        setups: &setups,
        offsets: &offsets,
        ids: &ids,
        keys: &keys,
        edges: &edges,
        w,
        h,
        settings: *settings,
    };

    // 2. Scanlines: every `spacing`-th row and the last one, packed.
    let regular_rows: Vec<usize> = (0..h).filter(|&y| ctx.is_regular_row(y)).collect();
    let mut reg_color = vec![[0.0f32; 4]; regular_rows.len() * w];
    let mut reg_state = vec![UNKNOWN; regular_rows.len() * w];
    let row_stats = ctx.scanlines(&regular_rows, &mut reg_color, &mut reg_state);
    let (mut color, mut state) = SCRATCH.with(|s| s.take()).unwrap_or_default();
    color.clear();
    color.resize(w * h, [0.0; 4]);
    state.clear();
    state.resize(w * h, UNKNOWN);
    for (r, &y) in regular_rows.iter().enumerate() {
        color[y * w..(y + 1) * w].copy_from_slice(&reg_color[r * w..(r + 1) * w]);
        state[y * w..(y + 1) * w].copy_from_slice(&reg_state[r * w..(r + 1) * w]);
    }

    // 3. Columns between consecutive regular rows.
    let column_stats = ctx.columns(&regular_rows, (&reg_color, &reg_state), &mut color, &mut state);
    let mut stats = row_stats + column_stats;
    if settings.threshold > 0.0 {
        ctx.refine(&mut color, &mut state, &mut stats);
    }
    stats.covered = ids.iter().filter(|&&id| id != NONE).count() as u64;

    ctx.write_through(target, &depth, &color, &state);
    SCRATCH.with(|s| s.set(Some((color, state))));
    Ok(stats)
}

/// Refuses what adaptive shading cannot draw: a stencil test, a spacing of 0.
fn check_adaptive(passes: &[Pass], settings: &AdaptiveSettings) -> Result<(), RenderError> {
    for pass in passes {
        if pass.state.stencil.enabled {
            return Err(RenderError::Unsupported(
                "adaptive shading does not support the stencil test; draw the pass with renderer::draw"
                    .into(),
            ));
        }
    }
    if settings.spacing == 0 {
        return Err(RenderError::Unsupported(
            "adaptive shading needs a sample spacing of at least 1 pixel".into(),
        ));
    }
    Ok(())
}

/// Each pass's triangle setup, and the offsets of each pass's triangles in
/// the draw's triangle ids (one more: the total).
fn setup_passes(passes: &[Pass], w: usize, h: usize) -> Result<(Vec<PassSetup>, Vec<usize>), RenderError> {
    let mut setups = Vec::with_capacity(passes.len());
    let mut offsets = Vec::with_capacity(passes.len() + 1);
    let mut total = 0usize;
    for pass in passes {
        let setup = setup_pass(pass, w as u32, h as u32)?;
        offsets.push(total);
        total += setup.n_triangles();
        setups.push(setup);
    }
    offsets.push(total);
    if total >= NONE as usize {
        return Err(RenderError::Unsupported("more than 2^32 - 1 triangles in one adaptive draw".into()));
    }
    Ok((setups, offsets))
}

/// The visible triangle's id and depth at every pixel, starting from the
/// target's depth, in bands of TILE rows.
fn visible(
    target: &Framebuffer,
    passes: &[Pass],
    setups: &[PassSetup],
    offsets: &[usize],
) -> (Vec<u32>, Vec<f32>) {
    let (w, h) = (target.width() as usize, target.height() as usize);
    let mut ids = vec![NONE; w * h];
    let mut depth: Vec<f32> = (0..w * h)
        .into_par_iter()
        .map(|i| target.depth((i % w) as u32, (i / w) as u32).unwrap_or(1.0))
        .collect();
    ids.par_chunks_mut(TILE * w).zip(depth.par_chunks_mut(TILE * w)).enumerate().for_each(
        |(band, (ids, depth))| {
            let y0 = (band * TILE) as i32;
            let y1 = y0 + (ids.len() / w) as i32 - 1;
            for (p, (pass, setup)) in passes.iter().zip(setups).enumerate() {
                visibility(ids, depth, w, (y0, y1), pass, setup, offsets[p] as u32);
            }
        },
    );
    (ids, depth)
}

/// Band k of [`between_rows`]: k, and its colours and states.
type Band<'c> = (usize, &'c mut [[f32; 4]], &'c mut [u8]);

/// The rows strictly between regular rows k and k + 1 of `color` and
/// `state`, as band k (disjoint, so the bands fill in parallel).
fn between_rows<'c>(
    color: &'c mut [[f32; 4]],
    state: &'c mut [u8],
    w: usize,
    regular_rows: &[usize],
) -> Vec<Band<'c>> {
    let mut bands: Vec<Band> = Vec::with_capacity(regular_rows.len());
    let (mut c_rest, mut s_rest) = (color, state);
    let mut consumed = 0;
    for k in 0..regular_rows.len().saturating_sub(1) {
        let (top, bottom) = (regular_rows[k], regular_rows[k + 1]);
        let skip = (top + 1 - consumed) * w;
        let take = (bottom - top - 1) * w;
        let (_, c) = std::mem::take(&mut c_rest).split_at_mut(skip);
        let (_, s) = std::mem::take(&mut s_rest).split_at_mut(skip);
        let (c_band, c_tail) = c.split_at_mut(take);
        let (s_band, s_tail) = s.split_at_mut(take);
        bands.push((k, c_band, s_band));
        c_rest = c_tail;
        s_rest = s_tail;
        consumed = bottom;
    }
    bands
}
/// Scan-converts one pass into the id and depth buffers of rows `y0..=y1`.
fn visibility(
    ids: &mut [u32],
    depth: &mut [f32],
    w: usize,
    rows: (i32, i32),
    pass: &Pass,
    setup: &PassSetup,
    offset: u32,
) {
    let func = pass.state.depth.func;
    for (ti, tri) in setup.tris.iter().enumerate() {
        let y0 = tri.y0.max(rows.0);
        let y1 = tri.y1.min(rows.1);
        if y0 > y1 {
            continue;
        }
        let step_x = tri.dy.map(|d| -d * SUB);
        let px0 = tri.x0 as i64 * SUB + SUB / 2;
        for y in y0..=y1 {
            let py = y as i64 * SUB + SUB / 2;
            let mut e = tri.edges_at(px0, py);
            let row = (y - rows.0) as usize * w;
            for x in tri.x0..=tri.x1 {
                if tri.covers(&e) {
                    let l = tri.weights_at(x, y);
                    let z = (l[0] * tri.z[0] + l[1] * tri.z[1] + l[2] * tri.z[2]).clamp(0.0, 1.0);
                    let idx = row + x as usize;
                    if func.test(z, depth[idx]) {
                        // Later passes test against this depth even without depth writes,
                        // as the tiled rasterizer would see it only with writes: keep GL's
                        // behaviour by updating the test depth only when the pass writes.
                        if pass.state.depth.write {
                            depth[idx] = z;
                        }
                        ids[idx] = offset + ti as u32;
                    }
                }
                for k in 0..3 {
                    e[k] += step_x[k];
                }
            }
        }
    }
}

/// The surface key of every pixel's visible primitive (see [`EdgeMode`]),
/// computed once: every later step compares keys of neighbours.
fn surface_keys(ids: &[u32], offsets: &[usize], edges: EdgeMode) -> Vec<u32> {
    ids.par_iter()
        .map(|&id| match edges {
            _ if id == NONE => NONE,
            EdgeMode::Triangle => id,
            EdgeMode::Pass => (offsets.partition_point(|&o| o <= id as usize) - 1) as u32,
        })
        .collect()
}

/// Whether each pixel is an edge sample: a 4-neighbour shows another
/// surface (Section 2.1.3), computed once per draw.
fn edge_map(keys: &[u32], w: usize, h: usize) -> Vec<bool> {
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y, k) = (i % w, i / w, keys[i]);
            (x > 0 && keys[i - 1] != k)
                || (x + 1 < w && keys[i + 1] != k)
                || (y > 0 && keys[i - w] != k)
                || (y + 1 < h && keys[i + w] != k)
        })
        .collect()
}

struct Ctx<'a> {
    passes: &'a [Pass<'a>],
    setups: &'a [PassSetup],
    offsets: &'a [usize],
    ids: &'a [u32],
    /// Per pixel: the surface key ([`surface_keys`]) and whether it is an edge.
    keys: &'a [u32],
    edges: &'a [bool],
    w: usize,
    h: usize,
    settings: AdaptiveSettings,
}

impl Ctx<'_> {
    /// Whether row `y` is a scanline: every `spacing`-th row and the last one.
    fn is_regular_row(&self, y: usize) -> bool {
        y % self.settings.spacing as usize == 0 || y == self.h - 1
    }

    /// Writes the shaded pixels through each pass's depth and blend state,
    /// tiles in parallel (each pixel belongs to one tile).
    fn write_through(&self, target: &mut Framebuffer, depth: &[f32], color: &[[f32; 4]], state: &[u8]) {
        let tiles_x = target.tiles_x();
        target.tiles.par_iter_mut().enumerate().for_each(|(t, tile)| {
            let (x0, y0) = ((t % tiles_x) * TILE, (t / tiles_x) * TILE);
            for y in y0..(y0 + TILE).min(self.h) {
                for x in x0..(x0 + TILE).min(self.w) {
                    let i = y * self.w + x;
                    let id = self.ids[i];
                    if id == NONE || state[i] & DISCARD_BIT != 0 || state[i] == UNKNOWN {
                        continue;
                    }
                    let pass = &self.passes[self.pass_of(id)];
                    let idx = (y - y0) * TILE + (x - x0);
                    if pass.state.depth.write {
                        tile.depth[idx] = depth[i];
                    }
                    tile.blend_color(idx, &color[i], &pass.state.blend);
                }
            }
        });
    }
    fn pass_of(&self, id: u32) -> usize {
        // offsets is sorted; the pass is the last offset ≤ id.
        self.offsets.partition_point(|&o| o <= id as usize) - 1
    }
}
