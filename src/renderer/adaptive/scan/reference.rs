//! The whole-frame computations the span-restricted ones replace, kept as
//! they were (the thirteenth session's `visibility.rs`) to check those
//! against: every pixel scan converted one by one over each triangle's
//! bounding box, every map computed at every pixel of the frame.

use super::super::visibility::{EMPTY, MIXED, PLAIN};
use super::super::{EdgeMode, NONE};
use crate::pipeline::DepthState;
use crate::renderer::framebuffer::TILE;
use crate::renderer::raster::{PassSetup, SUB};

/// The visible triangle's id and the depth at every pixel, from `depth`;
/// whether some fragment failed its depth test by being equal.
pub fn visible(
    w: usize,
    mut depth: Vec<f32>,
    states: &[DepthState],
    setups: &[PassSetup],
    offsets: &[usize],
) -> (Vec<u32>, Vec<f32>, bool) {
    let mut ids = vec![NONE; depth.len()];
    let mut ties = false;
    for (band, (ids, depth)) in ids.chunks_mut(TILE * w).zip(depth.chunks_mut(TILE * w)).enumerate() {
        let y0 = (band * TILE) as i32;
        let y1 = y0 + (ids.len() / w) as i32 - 1;
        for (p, setup) in setups.iter().enumerate() {
            ties |= visibility(ids, depth, w, (y0, y1), states[p], setup, offsets[p] as u32);
        }
    }
    (ids, depth, ties)
}

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

pub fn surface_keys(ids: &[u32], offsets: &[usize], edges: EdgeMode) -> Vec<u32> {
    ids.iter()
        .map(|&id| match edges {
            _ if id == NONE => NONE,
            EdgeMode::Triangle => id,
            EdgeMode::Pass => (offsets.partition_point(|&o| o <= id as usize) - 1) as u32,
        })
        .collect()
}

pub fn edge_map(keys: &[u32], w: usize, h: usize) -> Vec<bool> {
    (0..w * h)
        .map(|i| {
            let (x, y, k) = (i % w, i / w, keys[i]);
            (x > 0 && keys[i - 1] != k)
                || (x + 1 < w && keys[i + 1] != k)
                || (y > 0 && keys[i - w] != k)
                || (y + 1 < h && keys[i + w] != k)
        })
        .collect()
}

pub fn row_spans(keys: &[u32], w: usize) -> Vec<(usize, usize)> {
    keys.chunks(w)
        .map(|row| match row.iter().position(|&k| k != NONE) {
            None => (0, 0),
            Some(x0) => (x0, w - row.iter().rev().position(|&k| k != NONE).unwrap_or(0)),
        })
        .collect()
}

pub fn band_columns(keys: &[u32], edges: &[bool], (w, h): (usize, usize), spacing: usize) -> Vec<u8> {
    let bands = (h - 1).div_ceil(spacing.max(1));
    let mut columns = vec![EMPTY; bands * w];
    for (k, band) in columns.chunks_mut(w).enumerate() {
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
    }
    columns
}
