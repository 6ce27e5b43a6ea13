//! Binning and per-tile scan conversion. Triangles are binned, in submission
//! order, into the `TILE`×`TILE` tiles their bounding box touches; tiles are
//! then processed in parallel, each owning its colour, depth and stencil, so
//! blending order within a pixel is the submission order.

use rayon::prelude::*;

use super::framebuffer::{TileBuffers, TILE};
use super::raster::{Fragment, PassSetup, Tri, SUB};
use super::{DrawStats, FragmentResult, Framebuffer, Pass, StencilOp};

pub(crate) fn rasterize(target: &mut Framebuffer, pass: &Pass, setup: &PassSetup) -> DrawStats {
    let tiles_x = target.tiles_x();
    let tiles_y = target.tiles_y();
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); tiles_x * tiles_y];
    for (i, tri) in setup.tris.iter().enumerate() {
        let (tx0, tx1) = (tri.x0 as usize / TILE, tri.x1 as usize / TILE);
        let (ty0, ty1) = (tri.y0 as usize / TILE, tri.y1 as usize / TILE);
        for ty in ty0..=ty1.min(tiles_y - 1) {
            for tx in tx0..=tx1.min(tiles_x - 1) {
                bins[ty * tiles_x + tx].push(i as u32);
            }
        }
    }
    let (width, height) = (target.width() as i32, target.height() as i32);
    target
        .tiles
        .par_iter_mut()
        .zip(bins.par_iter())
        .enumerate()
        .filter(|(_, (_, bin))| !bin.is_empty())
        .map(|(t, (tile, bin))| {
            let ox = ((t % tiles_x) * TILE) as i32;
            let oy = ((t / tiles_x) * TILE) as i32;
            let rect = (ox, oy, (ox + TILE as i32).min(width) - 1, (oy + TILE as i32).min(height) - 1);
            raster_tile(tile, rect, bin, pass, setup)
        })
        .reduce(DrawStats::default, |a, b| DrawStats {
            fragments: a.fragments + b.fragments,
            shaded: a.shaded + b.shaded,
            written: a.written + b.written,
            ..DrawStats::default()
        })
}

/// Scan-converts the binned triangles over one tile; `rect` is inclusive.
fn raster_tile(
    tile: &mut TileBuffers,
    rect: (i32, i32, i32, i32),
    bin: &[u32],
    pass: &Pass,
    setup: &PassSetup,
) -> DrawStats {
    let n = setup.n_varyings;
    let mut varyings = vec![0.0f32; n];
    let mut stats = DrawStats::default();
    let state = &pass.state;
    let stencil = &state.stencil;
    let depth = &state.depth;
    for &ti in bin {
        let tri: &Tri = &setup.tris[ti as usize];
        let x0 = tri.x0.max(rect.0);
        let y0 = tri.y0.max(rect.1);
        let x1 = tri.x1.min(rect.2);
        let y1 = tri.y1.min(rect.3);
        if x0 > x1 || y0 > y1 {
            continue;
        }
        let vary = &setup.varyings[tri.varying_offset..tri.varying_offset + 3 * n];
        let gradients = &setup.gradients[tri.gradient_offset..tri.gradient_offset + 2 * (n + 1)];
        // Edge-function steps per pixel in x and y.
        let step_x = tri.dy.map(|d| -d * SUB);
        let px0 = x0 as i64 * SUB + SUB / 2;
        for y in y0..=y1 {
            let py = y as i64 * SUB + SUB / 2;
            let mut e = tri.edges_at(px0, py);
            let row = (y - rect.1) as usize * TILE;
            let lx0 = (x0 - rect.0) as usize;
            for x in x0..=x1 {
                let inside = tri.covers(&e);
                if inside {
                    let idx = row + lx0 + (x - x0) as usize;
                    let l = tri.weights_at(x, y);
                    let z = (l[0] * tri.z[0] + l[1] * tri.z[1] + l[2] * tri.z[2]).clamp(0.0, 1.0);
                    stats.fragments += 1;
                    let pw = [l[0] * tri.inv_w[0], l[1] * tri.inv_w[1], l[2] * tri.inv_w[2]];
                    let q = pw[0] + pw[1] + pw[2];
                    let fragment = Fragment {
                        x: x as u32,
                        y: y as u32,
                        depth: z,
                        front_facing: tri.front_facing,
                        inv_w: q,
                        gradients,
                    };
                    // Interpolates the varyings and runs the fragment stage.
                    let mut shade = |out: &mut [f32; 4], stats: &mut DrawStats| {
                        let inv_q = 1.0 / q;
                        let p = [pw[0] * inv_q, pw[1] * inv_q, pw[2] * inv_q];
                        for (i, v) in varyings.iter_mut().enumerate() {
                            *v = p[0] * vary[i] + p[1] * vary[n + i] + p[2] * vary[2 * n + i];
                        }
                        stats.shaded += 1;
                        pass.fragment.shade(&fragment, &varyings, out)
                    };
                    let mut color = [0.0f32; 4];
                    let stored_stencil = tile.stencil[idx];
                    if !stencil.test(stored_stencil) {
                        // A discarded fragment must not touch the stencil: shade only if it matters.
                        if stencil.fail != StencilOp::Keep
                            && shade(&mut color, &mut stats) == FragmentResult::Keep
                        {
                            stencil.update(&mut tile.stencil[idx], stencil.fail);
                        }
                    } else if !depth.func.test(z, tile.depth[idx]) {
                        if stencil.enabled
                            && stencil.depth_fail != StencilOp::Keep
                            && shade(&mut color, &mut stats) == FragmentResult::Keep
                        {
                            stencil.update(&mut tile.stencil[idx], stencil.depth_fail);
                        }
                    } else if shade(&mut color, &mut stats) == FragmentResult::Keep {
                        stencil.update(&mut tile.stencil[idx], stencil.pass);
                        if depth.write {
                            tile.depth[idx] = z;
                        }
                        tile.blend_color(idx, &color, &state.blend);
                        stats.written += 1;
                    }
                }
                for k in 0..3 {
                    e[k] += step_x[k];
                }
            }
        }
    }
    stats
}
