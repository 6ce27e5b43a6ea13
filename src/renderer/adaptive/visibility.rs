//! Step 1 of [`super::draw_adaptive`], the visibility of every pixel, and
//! what the later steps read of it (each pixel's surface and whether it is
//! an edge sample, Adaptive Sample Shading, Section 2.1.3) — computed once
//! for all the draws that share it.
//!
//! A plan with one pass per light draws the same triangles four times over
//! (the later passes `Equal` against the depth the first wrote, Kilgard
//! 2000, Section 5): their visibility is the same, and so are their surface
//! keys and edges, while each light shades them differently. What a draw's
//! visibility depends on is a function of its inputs alone — the frame's
//! size, each pass's triangles in window coordinates and depth state, the
//! edge mode, and the target's depth before the draw — so the last draw's
//! result is kept with those inputs, and a draw whose inputs are bit for
//! bit the same takes it instead of rasterizing again. Nothing is guessed:
//! a draw that differs in any of them (another mesh, another depth
//! function, a depth buffer some other draw changed) computes its own.

use std::sync::Arc;

use rayon::prelude::*;

use super::EdgeMode;
use crate::pipeline::{CompareFunc, DepthState};
use crate::renderer::framebuffer::TILE;
use crate::renderer::raster::{PassSetup, Tri};

use super::scan::{scan, Input, Maps, Start};
use crate::renderer::{Framebuffer, Pass};

/// Which primitive each pixel shows, and what the later steps derive from it.
pub(super) struct Visibility {
    /// Per pixel (row after row): `ids`, the visible triangle's id (a
    /// pass's triangles follow the earlier passes'), [`NONE`](super::NONE) where nothing
    /// is; `depth`, the depth after the draw (what a pass that writes depth
    /// leaves); `keys`, the surface key ([`EdgeMode`]) of its visible
    /// primitive (empty in [`EdgeMode::Triangle`], whose keys are the ids:
    /// see [`Visibility::keys`]); `edges`, whether it is an edge sample (it
    /// shows something, and a 4-neighbour shows another surface). Per row,
    /// `spans`: the columns `x0..x1` between its first and last covered
    /// pixel (empty where none is). Per band between regular rows k and
    /// k + 1 (`spacing` apart) and per column, `columns`: what the column
    /// shows from row k·spacing to the next regular row inclusive:
    /// nothing, one surface without an edge pixel inside ([`PLAIN`]), or
    /// anything else ([`MIXED`]).
    pub maps: Maps,
    /// Pixels that show some triangle.
    pub covered: u64,
    /// Whether an `Equal` pass without depth writes over the same
    /// triangles, drawn over the depth this draw leaves, sees what this
    /// draw saw: every pass of this draw tests `Less` or `LessEqual` and
    /// writes depth, and no fragment failed its test by being equal to the
    /// depth it was tested against (each pixel's one triangle at that
    /// depth is then the one that won it, or none).
    pub repeatable: bool,
}

impl Visibility {
    /// Each pixel's surface key.
    pub fn keys(&self) -> &[u32] {
        if self.maps.keys.is_empty() {
            &self.maps.ids
        } else {
            &self.maps.keys
        }
    }
}

/// A column of a band that shows nothing.
pub(super) const EMPTY: u8 = 0;
/// A column of a band that shows one surface and whose pixels between its
/// two regular rows are no edge samples: its only first samples are its ends.
pub(super) const PLAIN: u8 = 1;
/// Any other column of a band.
pub(super) const MIXED: u8 = 2;

/// Everything a draw's [`Visibility`] is a function of.
struct Inputs {
    size: (usize, usize),
    edges: EdgeMode,
    spacing: usize,
    depth_states: Vec<DepthState>,
    offsets: Vec<usize>,
    /// Every triangle of every pass, in order.
    tris: Vec<Tri>,
    /// The target's depth before the draw.
    start_depth: StartDepth,
}

/// The target's depth before a draw, as kept.
enum StartDepth {
    /// One depth everywhere (a cleared target), its bits.
    Uniform(u32),
    /// Row after row.
    Rows(Vec<f32>),
}

thread_local! {
    /// The last draw's inputs and visibility on this thread (taken out
    /// while a draw runs, so that a draw nested on the same thread computes
    /// its own rather than finding it borrowed).
    static LAST: std::cell::Cell<Option<(Inputs, Arc<Visibility>)>> = const { std::cell::Cell::new(None) };
    /// The buffers of a visibility no draw keeps any more, for the next
    /// draw that computes its own to overwrite.
    static SPARE: std::cell::Cell<Option<Maps>> = const { std::cell::Cell::new(None) };
}

/// Drops the visibility kept on this thread ([`super::forget_visibility`]),
/// keeping its buffers for the next draw to fill.
pub(super) fn forget() {
    if let Some((_, vis)) = LAST.with(|l| l.take()) {
        recycle(vis);
    }
}

/// Keeps the buffers of `vis` for the next computed visibility, unless a draw still holds it.
fn recycle(vis: Arc<Visibility>) {
    if let Ok(vis) = Arc::try_unwrap(vis) {
        SPARE.with(|s| s.set(Some(vis.maps)));
    }
}

/// The visibility of `passes` (set up as `setups`, triangle ids starting
/// at `offsets`) over `target`: the last draw's on this thread where its
/// inputs are the same, else computed and kept for the next draw.
pub(super) fn visibility_of(
    target: &Framebuffer,
    passes: &[Pass],
    setups: &[PassSetup],
    offsets: &[usize],
    (edges, spacing): (EdgeMode, usize),
) -> Arc<Visibility> {
    let size = (target.width() as usize, target.height() as usize);
    let depth_states: Vec<DepthState> = passes.iter().map(|p| p.state.depth).collect();
    let last = LAST.with(|l| l.take());
    if let Some((inputs, vis)) = last {
        let same_shape = inputs.size == size
            && inputs.edges == edges
            && inputs.spacing == spacing
            && inputs.offsets == offsets
            && same_triangles(&inputs.tris, setups);
        if same_shape && inputs.depth_states == depth_states && inputs.start_depth.is_depth_of(target) {
            LAST.with(|l| l.set(Some((inputs, vis.clone()))));
            return vis;
        }
        // A later pass of a multipass plan (Kilgard 2000, Section 5): `Equal`
        // over the depth the last draw left, which it sees as that draw saw it.
        if same_shape
            && vis.repeatable
            && depth_states.iter().all(|d| *d == DepthState::EQUAL_NO_WRITE)
            && same_depth(&vis.maps.depth, target)
        {
            let inputs =
                Inputs { depth_states, start_depth: StartDepth::Rows(vis.maps.depth.clone()), ..inputs };
            LAST.with(|l| l.set(Some((inputs, vis.clone()))));
            return vis;
        }
        recycle(vis);
    }
    let start_depth = start_of(target);
    let start = match &start_depth {
        StartDepth::Uniform(bits) => Start::Uniform(f32::from_bits(*bits)),
        StartDepth::Rows(rows) => Start::Rows(rows),
    };
    let mut maps = SPARE.with(|s| s.take()).unwrap_or_default();
    let input = Input { states: &depth_states, setups, offsets, edges, spacing };
    let (covered, ties) = scan(&input, start, size, &mut maps);
    let repeatable = !ties
        && depth_states
            .iter()
            .all(|d| d.write && matches!(d.func, CompareFunc::Less | CompareFunc::LessEqual));
    let vis = Arc::new(Visibility { maps, covered, repeatable });
    let tris = setups.iter().flat_map(|s| s.tris.iter().cloned()).collect();
    let inputs = Inputs { size, edges, spacing, depth_states, offsets: offsets.to_vec(), tris, start_depth };
    LAST.with(|l| l.set(Some((inputs, vis.clone()))));
    vis
}

/// Whether two draws' setups have, pass by pass, the same triangles in
/// everything scan conversion and the depth test read (bit for bit).
pub(super) fn same_setups(a: &[PassSetup], b: &[PassSetup]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(a, b)| same_triangles(&a.tris, std::slice::from_ref(b)))
}

/// Whether `kept` are, in order, the triangles of `setups`, the same in
/// everything scan conversion and the depth test read (bit for bit).
fn same_triangles(kept: &[Tri], setups: &[PassSetup]) -> bool {
    let bits = |v: &[f32; 3]| v.map(f32::to_bits);
    kept.len() == setups.iter().map(|s| s.tris.len()).sum::<usize>()
        && kept.iter().zip(setups.iter().flat_map(|s| s.tris.iter())).all(|(a, b)| {
            (a.dx, a.dy, a.xa, a.ya, a.bias) == (b.dx, b.dy, b.xa, b.ya, b.bias)
                && (a.x0, a.y0, a.x1, a.y1) == (b.x0, b.y0, b.x1, b.y1)
                && bits(&a.z) == bits(&b.z)
                && a.weights.iter().zip(&b.weights).all(|(p, q)| bits(p) == bits(q))
        })
}

/// The target's depth, as kept: one value where every pixel holds the
/// same bits (a cleared target), else row after row.
fn start_of(target: &Framebuffer) -> StartDepth {
    // A cleared target holds depth 1 everywhere: its megabytes need no reading.
    if target.is_cleared() {
        return StartDepth::Uniform(1.0f32.to_bits());
    }
    let first = target.tiles.first().and_then(|t| t.depth.first()).map_or(0, |d| d.to_bits());
    let uniform = target.tiles.par_iter().all(|t| t.depth.iter().all(|d| d.to_bits() == first));
    if uniform {
        StartDepth::Uniform(first)
    } else {
        StartDepth::Rows(depth_rows(target))
    }
}

impl StartDepth {
    /// Whether the target's depth is this, bit for bit.
    fn is_depth_of(&self, target: &Framebuffer) -> bool {
        match self {
            StartDepth::Uniform(bits) if *bits == 1.0f32.to_bits() && target.is_cleared() => true,
            StartDepth::Uniform(bits) => {
                target.tiles.par_iter().all(|t| t.depth.iter().all(|d| d.to_bits() == *bits))
            }
            StartDepth::Rows(rows) => same_depth(rows, target),
        }
    }
}

/// The target's depth, row after row.
fn depth_rows(target: &Framebuffer) -> Vec<f32> {
    let w = target.width() as usize;
    let mut depth = vec![1.0f32; w * target.height() as usize];
    depth.par_chunks_mut(TILE * w).enumerate().for_each(|(band, rows)| {
        for (r, row) in rows.chunks_mut(w).enumerate() {
            for (tx, span) in row.chunks_mut(TILE).enumerate() {
                let tile = &target.tiles[band * target.tiles_x() + tx];
                span.copy_from_slice(&tile.depth[r * TILE..r * TILE + span.len()]);
            }
        }
    });
    depth
}

/// Whether the target's depth is `kept` (row after row), bit for bit.
fn same_depth(kept: &[f32], target: &Framebuffer) -> bool {
    let w = target.width() as usize;
    kept.len() == w * target.height() as usize
        && kept.par_chunks(TILE * w).enumerate().all(|(band, rows)| {
            rows.chunks(w).enumerate().all(|(r, row)| {
                row.chunks(TILE).enumerate().all(|(tx, span)| {
                    let tile = &target.tiles[band * target.tiles_x() + tx];
                    let stored = &tile.depth[r * TILE..r * TILE + span.len()];
                    stored.iter().zip(span).all(|(a, b)| a.to_bits() == b.to_bits())
                })
            })
        })
}
