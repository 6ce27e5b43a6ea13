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

mod lines;
mod scan;
mod sum;
mod visibility;
mod write;

use super::raster::{setup_pass, PassSetup};
use super::{ColorFormat, Framebuffer, Pass, RenderError};
pub use sum::draw_adaptive_sum;

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

/// A draw's colour and state buffers, one entry per pixel, and those of
/// its regular rows (packed).
type Buffers = ((Vec<[f32; 4]>, Vec<u8>), (Vec<[f32; 4]>, Vec<u8>));

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
    let drawn = draw_with(target, passes, (&setups, &offsets), &[], settings);
    // Without followers nothing makes the draw give up.
    drawn.ok_or_else(|| RenderError::Unsupported("internal: an adaptive draw gave up".into()))
}

/// The steps of an adaptive draw of `passes` (set up as `setups`, ids
/// from `offsets`) and of the `followers` added to it ([`draw_adaptive_sum`]);
/// `None`, with `target` untouched, where the followers cannot be fused.
fn draw_with(
    target: &mut Framebuffer,
    passes: &[Pass],
    (setups, offsets): (&[PassSetup], &[usize]),
    followers: &[sum::Follower],
    settings: &AdaptiveSettings,
) -> Option<AdaptiveStats> {
    let (w, h) = (target.width() as usize, target.height() as usize);
    // 1. Visibility, keys and edges: the last draw's where it drew the same.
    let shape = (settings.edges, settings.spacing as usize);
    let vis = visibility::visibility_of(target, passes, setups, offsets, shape);
    if !followers.is_empty() && !vis.repeatable {
        return None;
    }
    let ctx = Ctx {
        passes,
        setups,
        offsets,
        followers,
        format: target.format(),
        ids: &vis.maps.ids,
        keys: vis.keys(),
        edges: &vis.maps.edges,
        spans: &vis.maps.spans,
        columns: &vis.maps.columns,
        w,
        h,
        settings: *settings,
    };

    // 2. Scanlines: every `spacing`-th row and the last one, packed.
    let regular_rows: Vec<usize> = (0..h).filter(|&y| ctx.is_regular_row(y)).collect();
    // Where nothing can be dropped, each band is written through as it is
    // done (step 3), and the frame's colours are then the target's.
    let outs = ctx.band_outputs(target, regular_rows.len().saturating_sub(1));
    let written = outs.is_some();
    let ((mut color, mut state), (mut reg_color, mut reg_state)) =
        buffers(regular_rows.len() * w, w * h, !written);
    let row_stats = ctx.scanlines(&regular_rows, &mut reg_color, &mut reg_state);
    for (r, &y) in regular_rows.iter().enumerate() {
        if !written {
            color[y * w..(y + 1) * w].copy_from_slice(&reg_color[r * w..(r + 1) * w]);
        }
        state[y * w..(y + 1) * w].copy_from_slice(&reg_state[r * w..(r + 1) * w]);
    }

    // 3. Columns between consecutive regular rows.
    let frame = (!written).then_some(&mut color[..]);
    let (column_stats, first_wave) = ctx.columns(
        &regular_rows,
        (frame, &reg_color),
        &mut state,
        outs.unwrap_or_default(),
        &vis.maps.depth,
    );
    let mut stats = row_stats + column_stats;
    if settings.threshold > 0.0 {
        if written {
            ctx.refine(&mut ctx.tile_colors(target), &mut state, &mut stats, first_wave);
        } else {
            ctx.refine(&mut color[..], &mut state, &mut stats, first_wave);
        }
    }
    stats.covered = vis.covered;
    // A fused draw whose first pass dropped a fragment is not the passes' sum
    // (written through already only where no stage may drop one).
    let fused = followers.is_empty() || stats.discarded == 0;
    debug_assert!(!written || stats.discarded == 0, "a stage that may not discard dropped a fragment");
    if !written && fused {
        ctx.write_through(target, &vis.maps.depth, &color, &state);
    }
    SCRATCH.with(|s| s.set(Some(((color, state), (reg_color, reg_state)))));
    fused.then_some(stats)
}

/// The last draw's buffers (see [`Buffers`]) for `regular` pixels of
/// regular rows and `pixels` of the frame (colours only where `colors`),
/// every state unknown. The colour of a pixel is read only once it is known
/// (shaded or interpolated): a buffer of the right size is not cleared.
fn buffers(regular: usize, pixels: usize, colors: bool) -> Buffers {
    let ((mut color, mut state), (mut reg_color, mut reg_state)) =
        SCRATCH.with(|s| s.take()).unwrap_or_default();
    if reg_color.len() != regular {
        reg_color = vec![[0.0; 4]; regular];
    }
    if colors && color.len() != pixels {
        color = vec![[0.0; 4]; pixels];
    }
    for (states, n) in [(&mut reg_state, regular), (&mut state, pixels)] {
        states.clear();
        states.resize(n, UNKNOWN);
    }
    ((color, state), (reg_color, reg_state))
}

/// Forgets the visibility the last adaptive draw on this thread kept, so
/// that the next draw rasterizes its own even where its inputs are the
/// same: a benchmark of identical frames measures then what a frame of a
/// moving camera costs (the kept visibility is the same bit for bit, only
/// the time differs).
pub fn forget_visibility() {
    visibility::forget();
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

struct Ctx<'a> {
    passes: &'a [Pass<'a>],
    setups: &'a [PassSetup],
    offsets: &'a [usize],
    /// Passes added to these at every pixel ([`draw_adaptive_sum`]); empty
    /// for a draw of its own.
    followers: &'a [sum::Follower<'a>],
    /// The target's colour format, which the sum stores as it would each pass.
    format: ColorFormat,
    ids: &'a [u32],
    /// Per pixel: the surface key ([`EdgeMode`]) and whether it is an edge.
    keys: &'a [u32],
    edges: &'a [bool],
    /// Per row the covered columns' span, per band the columns' kinds ([`visibility::Visibility`]).
    spans: &'a [(usize, usize)],
    columns: &'a [u8],
    w: usize,
    h: usize,
    settings: AdaptiveSettings,
}

impl Ctx<'_> {
    /// Whether row `y` is a scanline: every `spacing`-th row and the last one.
    fn is_regular_row(&self, y: usize) -> bool {
        y % self.settings.spacing as usize == 0 || y == self.h - 1
    }

    fn pass_of(&self, id: u32) -> usize {
        // offsets is sorted; the pass is the last offset ≤ id.
        self.offsets.partition_point(|&o| o <= id as usize) - 1
    }
}
