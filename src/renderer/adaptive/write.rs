//! The last step of [`super::draw_adaptive`]: the frame's colours, exact
//! and interpolated, written through each pass's depth and blend state.
//!
//! Where every pass of the draw blends the same way (a plan's draw is one
//! pass over its objects), the blend is resolved once
//! ([`Writer`](crate::renderer::framebuffer::Writer)), as the full draw
//! resolves it, and a tile row's colours are written together; otherwise
//! each pixel blends by its own pass's state.

use rayon::prelude::*;

use super::{Ctx, DISCARD_BIT, NONE, UNKNOWN};
use crate::renderer::framebuffer::{ColorTile, TileBuffers, Writer, TILE};
use crate::renderer::{FragmentResult, Framebuffer};

impl Ctx<'_> {
    /// Writes the shaded and interpolated pixels into `target`, tiles in
    /// parallel (each pixel belongs to one tile), with the depth after the
    /// draw where the pass writes depth.
    pub(super) fn write_through(
        &self,
        target: &mut Framebuffer,
        depth: &[f32],
        color: &[[f32; 4]],
        state: &[u8],
    ) {
        let first = self.passes[0].state;
        let uniform = self
            .passes
            .iter()
            .all(|p| p.state.blend == first.blend && p.state.depth.write == first.depth.write);
        let tiles_x = target.tiles_x();
        target.tiles.par_iter_mut().enumerate().for_each(|(t, tile)| {
            let origin = ((t % tiles_x) * TILE, (t / tiles_x) * TILE);
            if uniform {
                self.write_tile(tile, origin, depth, color, state);
            } else {
                self.write_tile_per_pass(tile, origin, depth, color, state);
            }
        });
    }

    /// Whether pixel `i` is written: it shows a triangle and was shaded or
    /// interpolated, not discarded.
    fn written(&self, i: usize, state: &[u8]) -> bool {
        self.ids[i] != NONE && state[i] != UNKNOWN && state[i] & DISCARD_BIT == 0
    }

    /// One tile of a draw whose passes all blend and write depth alike:
    /// row by row, the blend resolved once.
    fn write_tile(
        &self,
        tile: &mut TileBuffers,
        (x0, y0): (usize, usize),
        depth: &[f32],
        color: &[[f32; 4]],
        state: &[u8],
    ) {
        let pass = self.passes[0].state;
        let writer = Writer::of(&pass.blend);
        if writer == Writer::Replace {
            if let ColorTile::F32(texels) | ColorTile::Unorm(texels) = &mut tile.color {
                let depth_out = pass.depth.write.then_some(&mut tile.depth);
                return self.replace_tile(texels, depth_out, (x0, y0), depth, color, state);
            }
        }
        let x1 = (x0 + TILE).min(self.w);
        let mut pixels = [(0usize, 0.0f32); TILE];
        let mut results = [FragmentResult::Discard; TILE];
        for y in y0..(y0 + TILE).min(self.h) {
            // The covered span of the row within the tile.
            let (a, b) = (self.spans[y].0.max(x0), self.spans[y].1.min(x1));
            if a >= b {
                continue;
            }
            let (row, n) = (y * self.w + a, b - a);
            let base = (y - y0) * TILE + (a - x0);
            for k in 0..n {
                let st = state[row + k];
                pixels[k] = (base + k, depth[row + k]);
                results[k] = if kept(st) { FragmentResult::Keep } else { FragmentResult::Discard };
            }
            if pass.depth.write {
                for k in (0..n).filter(|&k| results[k] == FragmentResult::Keep) {
                    tile.depth[pixels[k].0] = pixels[k].1;
                }
            }
            tile.blend_kept(&pixels[..n], &color[row..row + n], &results[..n], &pass.blend, writer);
        }
    }

    /// [`Ctx::write_tile`] for `REPLACE` into float texels, which stores
    /// each kept colour as it is (what `TileBuffers::blend_kept` does for
    /// it): a row whose covered span was written whole (the common case)
    /// is copied, colours and depths, the others pixel by pixel.
    fn replace_tile(
        &self,
        texels: &mut [[f32; 4]],
        mut depth_out: Option<&mut Vec<f32>>,
        (x0, y0): (usize, usize),
        depth: &[f32],
        color: &[[f32; 4]],
        state: &[u8],
    ) {
        let x1 = (x0 + TILE).min(self.w);
        for y in y0..(y0 + TILE).min(self.h) {
            let (a, b) = (self.spans[y].0.max(x0), self.spans[y].1.min(x1));
            if a >= b {
                continue;
            }
            let (row, n) = (y * self.w + a, b - a);
            let base = (y - y0) * TILE + (a - x0);
            if state[row..row + n].iter().all(|&st| kept(st)) {
                texels[base..base + n].copy_from_slice(&color[row..row + n]);
                if let Some(d) = depth_out.as_deref_mut() {
                    d[base..base + n].copy_from_slice(&depth[row..row + n]);
                }
                continue;
            }
            for k in (0..n).filter(|&k| kept(state[row + k])) {
                texels[base + k] = color[row + k];
                if let Some(d) = depth_out.as_deref_mut() {
                    d[base + k] = depth[row + k];
                }
            }
        }
    }

    /// One tile, each pixel through its own pass's state.
    fn write_tile_per_pass(
        &self,
        tile: &mut TileBuffers,
        (x0, y0): (usize, usize),
        depth: &[f32],
        color: &[[f32; 4]],
        state: &[u8],
    ) {
        for y in y0..(y0 + TILE).min(self.h) {
            for x in x0..(x0 + TILE).min(self.w) {
                let i = y * self.w + x;
                if !self.written(i, state) {
                    continue;
                }
                let pass = &self.passes[self.pass_of(self.ids[i])];
                let idx = (y - y0) * TILE + (x - x0);
                if pass.state.depth.write {
                    tile.depth[idx] = depth[i];
                }
                tile.blend_color(idx, &color[i], &pass.state.blend);
            }
        }
    }
}

/// Whether a pixel's state says its fragment was shaded and kept.
fn kept(st: u8) -> bool {
    st != UNKNOWN && st & DISCARD_BIT == 0
}
