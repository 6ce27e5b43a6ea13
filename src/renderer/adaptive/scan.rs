//! The scan conversion of step 1 of [`super::draw_adaptive`] and the maps
//! the later steps read of it (each pixel's surface key and whether it is
//! an edge sample, Adaptive Sample Shading, Section 2.1.3; each row's
//! covered span; each band's column kinds), over the covered spans only.
//!
//! A frame is mostly background or the inside of one surface: computing
//! the keys, edges and column kinds at every pixel of the frame cost more
//! than the scan conversion itself. Here each triangle's covered pixels of
//! a row are found by solving its three edge functions for the row (each
//! is affine in x, so its inside is a ray; the three rays meet in one
//! interval), their depths are computed eight at a time with the formula
//! of the per-pixel test, and the maps are computed inside each row's
//! covered span, everything outside it being known (nothing shows there).
//! The results are, bit for bit, what a pixel-by-pixel scan of the whole
//! frame computes (`tests` compares the two on generated scenes), except
//! that an uncovered pixel is never an edge sample: no step reads the edge
//! flag of a pixel that shows nothing.

use rayon::prelude::*;

use super::visibility::{EMPTY, MIXED, PLAIN};
use super::{EdgeMode, NONE};
use crate::pipeline::{CompareFunc, DepthState};
use crate::renderer::framebuffer::TILE;
use crate::renderer::raster::{PassSetup, Tri};
use crate::renderer::tile::row_span;

#[cfg(test)]
mod reference;
#[cfg(test)]
mod tests;

/// The buffers of one visibility, reused from frame to frame (fresh
/// megabytes each frame cost their page faults every time).
#[derive(Default)]
pub(super) struct Maps {
    pub ids: Vec<u32>,
    pub depth: Vec<f32>,
    /// Empty in [`EdgeMode::Triangle`], where the keys are the ids.
    pub keys: Vec<u32>,
    pub edges: Vec<bool>,
    pub spans: Vec<(usize, usize)>,
    pub columns: Vec<u8>,
}

/// What [`scan`] draws: the passes' depth states and setups, each pass's
/// first triangle id, and the surfaces' edge mode and the band height.
pub(super) struct Input<'a> {
    pub states: &'a [DepthState],
    pub setups: &'a [PassSetup],
    pub offsets: &'a [usize],
    pub edges: EdgeMode,
    pub spacing: usize,
}

/// Scan-converts `scene` over `start` (the target's depth, row after row,
/// or one depth everywhere) into `maps` (their buffers reused, every entry
/// rewritten) for a frame of `w`×`h`; returns the covered pixels and
/// whether some fragment failed its depth test by being equal to the
/// depth it met.
pub(super) fn scan(scene: &Input, start: Start, (w, h): (usize, usize), maps: &mut Maps) -> (u64, bool) {
    let n = w * h;
    maps.ids.resize(n, NONE);
    maps.depth.resize(n, 0.0);
    maps.spans.resize(h, (0, 0));
    let triangle_keys = scene.edges == EdgeMode::Triangle;
    maps.keys.resize(if triangle_keys { 0 } else { n }, NONE);
    let keys_out = &mut maps.keys;
    let (covered, ties) = maps
        .ids
        .par_chunks_mut(TILE * w)
        .zip(maps.depth.par_chunks_mut(TILE * w))
        .zip(maps.spans.par_chunks_mut(TILE))
        .zip(keys_chunks(keys_out, TILE * w, h.div_ceil(TILE)))
        .enumerate()
        .map(|(band, (((ids, depth), spans), keys))| {
            match start {
                Start::Uniform(d) => depth.fill(d),
                Start::Rows(rows) => depth.copy_from_slice(&rows[band * TILE * w..][..depth.len()]),
            }
            ids.fill(NONE);
            let y0 = (band * TILE) as i32;
            let mut rows = Rows { ids, depth, spans, w, y0 };
            let ties = scene_band(scene, &mut rows);
            (band_keys(scene, &rows, keys), ties)
        })
        .reduce(|| (0, false), |a, b| (a.0 + b.0, a.1 || b.1));
    let keys = if triangle_keys { &maps.ids } else { &maps.keys };
    edges_and_columns(keys, &maps.spans, (w, h), scene.spacing, (&mut maps.edges, &mut maps.columns));
    (covered, ties)
}

/// The target's depth before a draw.
#[derive(Clone, Copy)]
pub(super) enum Start<'a> {
    /// One depth at every pixel (a cleared target).
    Uniform(f32),
    /// Row after row.
    Rows(&'a [f32]),
}

/// The chunks of `keys` a band writes: `None` where it is empty (the keys are the ids).
fn keys_chunks(
    keys: &mut [u32],
    size: usize,
    bands: usize,
) -> impl IndexedParallelIterator<Item = Option<&mut [u32]>> {
    let have = if keys.is_empty() { 0 } else { bands };
    keys.par_chunks_mut(size.max(1)).map(Some).chain(rayon::iter::repeat_n((), bands - have).map(|_| None))
}

/// A band of TILE rows from row `y0`: its ids, depths and covered spans.
struct Rows<'a> {
    ids: &'a mut [u32],
    depth: &'a mut [f32],
    spans: &'a mut [(usize, usize)],
    w: usize,
    y0: i32,
}

/// Every pass of `scene` into `rows`, then each row's span of visible
/// pixels; whether some fragment tied with the depth it failed against.
fn scene_band(scene: &Input, rows: &mut Rows) -> bool {
    let w = rows.w;
    // The union of the triangles' covered pixels per row bounds the visible ones.
    for s in rows.spans.iter_mut() {
        *s = (w, 0);
    }
    let mut ties = false;
    for (p, setup) in scene.setups.iter().enumerate() {
        ties |= pass_band(rows, scene.states[p], setup, scene.offsets[p] as u32);
    }
    for (r, span) in rows.spans.iter_mut().enumerate() {
        let row = &rows.ids[r * w..(r + 1) * w];
        let (a, b) = *span;
        *span = match row[a.min(b)..b].iter().position(|&id| id != NONE) {
            None => (0, 0),
            Some(i) => {
                let x0 = a + i;
                (x0, b - row[x0..b].iter().rev().position(|&id| id != NONE).unwrap_or(0))
            }
        };
    }
    ties
}

/// One pass's triangles into `rows` (their depth test `state`, ids from
/// `offset`); whether some fragment tied with the depth it failed against.
fn pass_band(rows: &mut Rows, state: DepthState, setup: &PassSetup, offset: u32) -> bool {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU has the features the function is compiled for.
        return unsafe { pass_band_avx2(rows, state, setup, offset) };
    }
    pass_band_body(rows, state, setup, offset)
}

/// [`pass_band`] compiled for 8-lane vectors (the same values: no
/// operation is contracted into a fused one).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn pass_band_avx2(rows: &mut Rows, state: DepthState, setup: &PassSetup, offset: u32) -> bool {
    pass_band_body(rows, state, setup, offset)
}

#[inline(always)]
fn pass_band_body(rows: &mut Rows, state: DepthState, setup: &PassSetup, offset: u32) -> bool {
    let write = state.write;
    match state.func {
        CompareFunc::Never => tris_band(rows, setup, offset, write, |_, _| false),
        CompareFunc::Less => tris_band(rows, setup, offset, write, |z, d| z < d),
        CompareFunc::LessEqual => tris_band(rows, setup, offset, write, |z, d| z <= d),
        CompareFunc::Equal => tris_band(rows, setup, offset, write, |z, d| z == d),
        CompareFunc::Greater => tris_band(rows, setup, offset, write, |z, d| z > d),
        CompareFunc::GreaterEqual => tris_band(rows, setup, offset, write, |z, d| z >= d),
        CompareFunc::NotEqual => tris_band(rows, setup, offset, write, |z, d| z != d),
        CompareFunc::Always => tris_band(rows, setup, offset, write, |_, _| true),
    }
}

/// Pixels of a row whose depths are computed together.
const LANES: usize = 8;

/// The scan loop of one pass over one band, its depth test `test`.
#[inline(always)]
fn tris_band(
    rows: &mut Rows,
    setup: &PassSetup,
    offset: u32,
    write: bool,
    test: impl Fn(f32, f32) -> bool,
) -> bool {
    let (w, y0) = (rows.w, rows.y0);
    let y1 = y0 + rows.spans.len() as i32 - 1;
    let mut ties = false;
    for (ti, tri) in setup.tris.iter().enumerate() {
        let id = offset + ti as u32;
        for y in tri.y0.max(y0)..=tri.y1.min(y1) {
            let Some((xa, xb)) = covered_span(tri, y) else { continue };
            let r = (y - y0) as usize;
            let span = &mut rows.spans[r];
            *span = (span.0.min(xa as usize), span.1.max(xb as usize + 1));
            let at = r * w + xa as usize;
            let n = (xb - xa + 1) as usize;
            let (ids, depth) = (&mut rows.ids[at..at + n], &mut rows.depth[at..at + n]);
            for (c, (ids, depth)) in ids.chunks_mut(LANES).zip(depth.chunks_mut(LANES)).enumerate() {
                let z = depths(tri, xa + (c * LANES) as i32, y);
                for ((id_out, d), &z) in ids.iter_mut().zip(depth.iter_mut()).zip(&z) {
                    if test(z, *d) {
                        if write {
                            *d = z;
                        }
                        *id_out = id;
                    } else if z == *d {
                        ties = true;
                    }
                }
            }
        }
    }
    ties
}

/// The window depths of [`LANES`] pixels of row `y` from column `x` on,
/// each as the per-pixel scan computes it (`Tri::weights_at`, then the
/// weighted vertex depths clamped to [0, 1]).
#[inline(always)]
fn depths(tri: &Tri, x: i32, y: i32) -> [f32; LANES] {
    let py = y as f32 + 0.5;
    let [w0, w1, w2] = tri.weights;
    std::array::from_fn(|j| {
        let px = (x + j as i32) as f32 + 0.5;
        let l = [
            w0[0] * px + w0[1] * py + w0[2],
            w1[0] * px + w1[1] * py + w1[2],
            w2[0] * px + w2[1] * py + w2[2],
        ];
        (l[0] * tri.z[0] + l[1] * tri.z[1] + l[2] * tri.z[2]).clamp(0.0, 1.0)
    })
}

/// The pixels `xa..=xb` of row `y` that `tri` covers by the top-left fill
/// rule (`Tri::covers` at each pixel centre), `None` where none is: the
/// tiled rasterizer's solver ([`row_span`]) over the triangle's columns.
#[inline(always)]
pub(super) fn covered_span(tri: &Tri, y: i32) -> Option<(i32, i32)> {
    row_span(tri, (tri.x0, tri.x1), y)
}

/// The surface keys of a band's rows inside their spans ([`NONE`] outside),
/// into `keys` where it is given; the band's covered pixels.
fn band_keys(scene: &Input, rows: &Rows, keys: Option<&mut [u32]>) -> u64 {
    let w = rows.w;
    let mut covered = 0;
    let mut keys = keys;
    // One pass: every covered pixel's key is 0.
    let one = scene.offsets.len() == 2;
    for (r, &(a, b)) in rows.spans.iter().enumerate() {
        let ids = &rows.ids[r * w..(r + 1) * w];
        covered += ids[a..b].iter().filter(|&&id| id != NONE).count() as u64;
        if let Some(keys) = keys.as_deref_mut() {
            let row = &mut keys[r * w..(r + 1) * w];
            row[..a].fill(NONE);
            row[b.max(a)..].fill(NONE);
            // Pass mode (a Triangle mode's keys are its ids).
            for (k, &id) in row[a..b].iter_mut().zip(&ids[a..b]) {
                *k = match id {
                    NONE => NONE,
                    _ if one => 0,
                    _ => (scene.offsets.partition_point(|&o| o <= id as usize) - 1) as u32,
                };
            }
        }
    }
    covered
}

/// Each pixel's edge flag (a covered pixel whose 4-neighbour shows another
/// surface, Section 2.1.3) and each band's column kinds
/// (see [`super::visibility::Visibility`]), band by band in parallel,
/// each over its rows' covered spans.
fn edges_and_columns(
    keys: &[u32],
    spans: &[(usize, usize)],
    (w, h): (usize, usize),
    spacing: usize,
    (edges, columns): (&mut Vec<bool>, &mut Vec<u8>),
) {
    let spacing = spacing.max(1);
    let bands = (h - 1).div_ceil(spacing);
    edges.resize(w * h, false);
    columns.resize(bands * w, EMPTY);
    let chunks = h.div_ceil(spacing);
    edges
        .par_chunks_mut(spacing * w)
        .zip(
            columns
                .par_chunks_mut(w)
                .map(Some)
                .chain(rayon::iter::repeat_n((), chunks - bands).map(|_| None)),
        )
        .enumerate()
        .for_each(|(k, (edges, band))| band_edges_and_kinds(keys, spans, (w, h), (k, spacing), edges, band));
}

/// Band `k`'s rows' edge flags (`edges`) and, where it has one, its column
/// kinds (`band`): with AVX2 where the CPU has it (the same code compiled
/// for 8-lane vectors: comparisons only, so the same flags), else as built.
fn band_edges_and_kinds(
    keys: &[u32],
    spans: &[(usize, usize)],
    (w, h): (usize, usize),
    (k, spacing): (usize, usize),
    edges: &mut [bool],
    band: Option<&mut [u8]>,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has the feature the function is compiled for.
        return unsafe { band_edges_and_kinds_avx2(keys, spans, (w, h), (k, spacing), edges, band) };
    }
    band_edges_and_kinds_body(keys, spans, (w, h), (k, spacing), edges, band)
}

/// [`band_edges_and_kinds`] compiled for 8-lane vectors.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn band_edges_and_kinds_avx2(
    keys: &[u32],
    spans: &[(usize, usize)],
    (w, h): (usize, usize),
    (k, spacing): (usize, usize),
    edges: &mut [bool],
    band: Option<&mut [u8]>,
) {
    band_edges_and_kinds_body(keys, spans, (w, h), (k, spacing), edges, band)
}

#[inline(always)]
fn band_edges_and_kinds_body(
    keys: &[u32],
    spans: &[(usize, usize)],
    (w, h): (usize, usize),
    (k, spacing): (usize, usize),
    edges: &mut [bool],
    band: Option<&mut [u8]>,
) {
    let top = k * spacing;
    for (r, row) in edges.chunks_mut(w).enumerate() {
        edge_row(keys, spans[top + r], (w, h), top + r, row);
    }
    if let Some(band) = band {
        let bottom = ((k + 1) * spacing).min(h - 1);
        band_kinds(keys, edges, spans, (w, top, bottom), band);
    }
}

/// Row `y`'s edge flags, `out`; inside its span `a..b` only. The columns
/// with both neighbours in one straight loop without branches (vector
/// code: a missing row above or below is the row itself, which never
/// differs), the first and last column of the frame one by one: the
/// flags of the per-pixel formula ([`edge_at`]).
#[inline(always)]
fn edge_row(keys: &[u32], (a, b): (usize, usize), (w, h): (usize, usize), y: usize, out: &mut [bool]) {
    out[..a].fill(false);
    out[b.max(a)..].fill(false);
    if a >= b {
        return;
    }
    let at = y * w;
    let row = &keys[at..at + w];
    let up = if y > 0 { &keys[at - w..at] } else { row };
    let down = if y + 1 < h { &keys[at + w..at + 2 * w] } else { row };
    let (lo, hi) = (a.max(1), b.min(w - 1));
    if lo < hi {
        let n = hi - lo;
        let (left, right) = (&row[lo - 1..][..n], &row[lo + 1..][..n]);
        let (here, up, down) = (&row[lo..hi], &up[lo..hi], &down[lo..hi]);
        let out = &mut out[lo..hi];
        for x in 0..n {
            let k = here[x];
            out[x] = (k != NONE) & ((left[x] != k) | (right[x] != k) | (up[x] != k) | (down[x] != k));
        }
    }
    for x in (a..lo).chain(hi.max(a)..b) {
        out[x] = edge_at(keys, (w, h), x, y);
    }
}

/// Pixel (x, y)'s edge flag: covered, and some 4-neighbour in the frame
/// shows another surface.
#[inline(always)]
fn edge_at(keys: &[u32], (w, h): (usize, usize), x: usize, y: usize) -> bool {
    let (i, k) = (y * w + x, keys[y * w + x]);
    k != NONE
        && ((x > 0 && keys[i - 1] != k)
            || (x + 1 < w && keys[i + 1] != k)
            || (y > 0 && keys[i - w] != k)
            || (y + 1 < h && keys[i + w] != k))
}

/// Band `top..=bottom`'s column kinds, `out`: [`EMPTY`] outside the union
/// of its rows' spans (nothing shows there), else as the whole frame's
/// computation: plain while every row shows the top row's surface and no
/// row between the two regular rows is an edge. `edges` holds the rows
/// from `top` on (those of rows `top + 1..bottom` are read).
#[inline(always)]
fn band_kinds(
    keys: &[u32],
    edges: &[bool],
    spans: &[(usize, usize)],
    (w, top, bottom): (usize, usize, usize),
    out: &mut [u8],
) {
    let (mut a, mut b) = (w, 0);
    for &(x0, x1) in spans[top..=bottom].iter().filter(|s| s.0 < s.1) {
        (a, b) = (a.min(x0), b.max(x1));
    }
    out.fill(EMPTY);
    if a >= b {
        return;
    }
    let first = &keys[top * w + a..top * w + b];
    for (c, &key) in out[a..b].iter_mut().zip(first) {
        *c = if key == NONE { EMPTY } else { PLAIN };
    }
    for y in top + 1..=bottom {
        let row = &keys[y * w + a..y * w + b];
        let e = (y - top) * w;
        // Without branches (vector code): plain stays plain where the row
        // shows the top row's surface (off an edge, but on the bottom row,
        // whose edge flags are the next band's and not read), empty stays
        // empty where it shows nothing, anything else is mixed.
        let next = |c: &mut u8, key: u32, first: u32, edge: bool| {
            let same = (key == first) & !edge;
            let (plain, empty) = ((*c == PLAIN) & same, (*c == EMPTY) & (key == NONE));
            *c = if plain {
                PLAIN
            } else if empty {
                EMPTY
            } else {
                MIXED
            };
        };
        let cells = out[a..b].iter_mut().zip(row).zip(first);
        if y == bottom {
            cells.for_each(|((c, &key), &first)| next(c, key, first, false));
        } else {
            cells
                .zip(&edges[e + a..e + b])
                .for_each(|(((c, &key), &first), &edge)| next(c, key, first, edge));
        }
    }
}
