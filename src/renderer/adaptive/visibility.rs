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

use super::{EdgeMode, NONE};
use crate::pipeline::{CompareFunc, DepthState};
use crate::renderer::framebuffer::TILE;
use crate::renderer::raster::{PassSetup, Tri, SUB};
use crate::renderer::{Framebuffer, Pass};

/// Which primitive each pixel shows, and what the later steps derive from it.
pub(super) struct Visibility {
    /// The visible triangle's id (a pass's triangles follow the earlier
    /// passes'), [`NONE`] where nothing is.
    pub ids: Vec<u32>,
    /// The depth after the draw (what a pass that writes depth leaves).
    pub depth: Vec<f32>,
    /// Per pixel the surface key ([`EdgeMode`]) of its visible primitive.
    pub keys: Vec<u32>,
    /// Per pixel whether it is an edge sample (a 4-neighbour shows another surface).
    pub edges: Vec<bool>,
    /// Pixels that show some triangle.
    pub covered: u64,
    /// Whether an `Equal` pass without depth writes over the same
    /// triangles, drawn over the depth this draw leaves, sees what this
    /// draw saw: every pass of this draw tests `Less` or `LessEqual` and
    /// writes depth, and no fragment failed its test by being equal to the
    /// depth it was tested against (each pixel's one triangle at that
    /// depth is then the one that won it, or none).
    pub repeatable: bool,
    /// Per row, the columns `x0..x1` between its first and last covered
    /// pixel (empty where none is).
    pub spans: Vec<(usize, usize)>,
    /// Per band between regular rows k and k + 1 (`spacing` apart) and per
    /// column, what the column shows from row k·spacing to the next
    /// regular row inclusive: nothing, one surface without an edge pixel
    /// inside ([`PLAIN`]), or anything else ([`MIXED`]).
    pub columns: Vec<u8>,
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
    /// The target's depth before the draw, row after row.
    start_depth: Vec<f32>,
}

thread_local! {
    /// The last draw's inputs and visibility on this thread (taken out
    /// while a draw runs, so that a draw nested on the same thread computes
    /// its own rather than finding it borrowed).
    static LAST: std::cell::Cell<Option<(Inputs, Arc<Visibility>)>> = const { std::cell::Cell::new(None) };
}

/// Drops the visibility kept on this thread ([`super::forget_visibility`]).
pub(super) fn forget() {
    LAST.with(|l| drop(l.take()));
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
        if same_shape && inputs.depth_states == depth_states && same_depth(&inputs.start_depth, target) {
            LAST.with(|l| l.set(Some((inputs, vis.clone()))));
            return vis;
        }
        // A later pass of a multipass plan (Kilgard 2000, Section 5): `Equal`
        // over the depth the last draw left, which it sees as that draw saw it.
        if same_shape
            && vis.repeatable
            && depth_states.iter().all(|d| *d == DepthState::EQUAL_NO_WRITE)
            && same_depth(&vis.depth, target)
        {
            let inputs = Inputs { depth_states, start_depth: vis.depth.clone(), ..inputs };
            LAST.with(|l| l.set(Some((inputs, vis.clone()))));
            return vis;
        }
    }
    let start_depth = depth_rows(target);
    let (ids, depth, ties) = visible(target, start_depth.clone(), passes, setups, offsets);
    let keys = surface_keys(&ids, offsets, edges);
    let edge = edge_map(&keys, size.0, size.1);
    let covered = ids.par_iter().filter(|&&id| id != NONE).count() as u64;
    let spans = row_spans(&keys, size.0);
    let columns = band_columns(&keys, &edge, size, spacing);
    let repeatable = !ties
        && depth_states
            .iter()
            .all(|d| d.write && matches!(d.func, CompareFunc::Less | CompareFunc::LessEqual));
    let vis = Arc::new(Visibility { ids, depth, keys, edges: edge, covered, repeatable, spans, columns });
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

/// The visible triangle's id and the depth at every pixel, starting from
/// `depth` (the target's), in bands of TILE rows; and whether some
/// fragment failed its depth test by being equal to the depth it met.
fn visible(
    target: &Framebuffer,
    mut depth: Vec<f32>,
    passes: &[Pass],
    setups: &[PassSetup],
    offsets: &[usize],
) -> (Vec<u32>, Vec<f32>, bool) {
    let w = target.width() as usize;
    let mut ids = vec![NONE; depth.len()];
    let ties = ids
        .par_chunks_mut(TILE * w)
        .zip(depth.par_chunks_mut(TILE * w))
        .enumerate()
        .map(|(band, (ids, depth))| {
            let y0 = (band * TILE) as i32;
            let y1 = y0 + (ids.len() / w) as i32 - 1;
            let mut ties = false;
            for (p, (pass, setup)) in passes.iter().zip(setups).enumerate() {
                ties |= visibility(ids, depth, w, (y0, y1), pass.state.depth, setup, offsets[p] as u32);
            }
            ties
        })
        .reduce(|| false, |a, b| a || b);
    (ids, depth, ties)
}

/// Scan-converts one pass into the id and depth buffers of rows `y0..=y1`.
fn visibility(
    ids: &mut [u32],
    depth: &mut [f32],
    w: usize,
    rows: (i32, i32),
    state: DepthState,
    setup: &PassSetup,
    offset: u32,
) -> bool {
    let func = state.func;
    let mut ties = false;
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
                        if state.write {
                            depth[idx] = z;
                        }
                        ids[idx] = offset + ti as u32;
                    } else if z == depth[idx] {
                        ties = true;
                    }
                }
                for k in 0..3 {
                    e[k] += step_x[k];
                }
            }
        }
    }
    ties
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
/// surface (Section 2.1.3).
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

/// Per row, the columns from its first to past its last covered pixel.
fn row_spans(keys: &[u32], w: usize) -> Vec<(usize, usize)> {
    keys.par_chunks(w)
        .map(|row| match row.iter().position(|&k| k != NONE) {
            None => (0, 0),
            Some(x0) => (x0, w - row.iter().rev().position(|&k| k != NONE).unwrap_or(0)),
        })
        .collect()
}

/// [`Visibility::columns`]: band k spans rows k·spacing ..= min((k + 1)·spacing, h − 1).
fn band_columns(keys: &[u32], edges: &[bool], (w, h): (usize, usize), spacing: usize) -> Vec<u8> {
    let bands = (h - 1).div_ceil(spacing.max(1));
    let mut columns = vec![EMPTY; bands * w];
    columns.par_chunks_mut(w).enumerate().for_each(|(k, band)| {
        let top = k * spacing;
        let bottom = ((k + 1) * spacing).min(h - 1);
        let first = &keys[top * w..(top + 1) * w];
        for (c, &key) in band.iter_mut().zip(first) {
            *c = if key == NONE { EMPTY } else { PLAIN };
        }
        for y in top + 1..=bottom {
            let (row, edge) = (&keys[y * w..(y + 1) * w], &edges[y * w..(y + 1) * w]);
            for (((c, &key), &first), &edge) in band.iter_mut().zip(row).zip(first).zip(edge) {
                let same = key == first && (y == bottom || !edge);
                *c = match *c {
                    PLAIN if same => PLAIN,
                    EMPTY if key == NONE => EMPTY,
                    _ => MIXED,
                };
            }
        }
    });
    columns
}
