//! The last step of [`super::draw_adaptive`]: the frame's colours, exact
//! and interpolated, written through each pass's depth and blend state.
//!
//! Where every pass of the draw blends the same way (a plan's draw is one
//! pass over its objects), the blend is resolved once
//! ([`Writer`](crate::renderer::framebuffer::Writer)), as the full draw
//! resolves it, and a tile row's colours are written together; otherwise
//! each pixel blends by its own pass's state.
//!
//! Where the draw only stores colours (`REPLACE` into float texels) and no
//! stage can drop a fragment ([`FragmentStage::may_discard`]), the
//! write-through is fused into the bands instead ([`Ctx::band_outputs`]):
//! each band's rows are written as soon as its columns are done, while they
//! are in the cache, from a buffer of the band's own; the refinement then
//! reads and writes the target's texels ([`TileColors`]).
//!
//! [`FragmentStage::may_discard`]: crate::renderer::FragmentStage::may_discard

use rayon::prelude::*;

use super::lines::Colors;
use super::{Ctx, DISCARD_BIT, NONE, UNKNOWN};
use crate::renderer::framebuffer::{ColorTile, TileBuffers, Writer, TILE};
use crate::renderer::{ColorFormat, FragmentResult, Framebuffer};

/// The target's rows of one band for the fused write-through: per row, per
/// tile of the row, that tile's texels (and depths) of the row.
pub(super) struct BandOut<'t> {
    tiles_x: usize,
    color: Vec<&'t mut [[f32; 4]]>,
    /// Empty where the passes do not write depth.
    depth: Vec<&'t mut [f32]>,
}

/// A target's float texels by the frame's pixel index.
pub(super) struct TileColors<'t> {
    tiles: &'t mut [TileBuffers],
    tiles_x: usize,
    w: usize,
}

impl TileColors<'_> {
    /// The tile of pixel `i` and its index in the tile.
    #[inline(always)]
    fn texel(&self, i: usize) -> (usize, usize) {
        let (x, y) = (i % self.w, i / self.w);
        ((y / TILE) * self.tiles_x + x / TILE, (y % TILE) * TILE + x % TILE)
    }
}

impl Colors for TileColors<'_> {
    fn get(&self, i: usize) -> [f32; 4] {
        let (t, k) = self.texel(i);
        match &self.tiles[t].color {
            ColorTile::F32(v) | ColorTile::Unorm(v) => v[k],
            // Never made for another format (`Ctx::band_outputs`).
            _ => [f32::NAN; 4],
        }
    }
    fn set(&mut self, i: usize, c: [f32; 4]) {
        let (t, k) = self.texel(i);
        if let ColorTile::F32(v) | ColorTile::Unorm(v) = &mut self.tiles[t].color {
            v[k] = c;
        }
    }
}

#[cfg(test)]
thread_local! {
    /// Tests draw with the fusion off to compare ([`Ctx::band_outputs`]).
    pub(super) static UNFUSED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// How many draws on this thread wrote through their bands.
    pub(super) static FUSED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

#[cfg(test)]
mod tests;

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
        let uniform = self.uniform();
        let tiles_x = target.tiles_x();
        let covered = self.covered_tiles(tiles_x, target.tiles_y());
        target.tiles.writing(|t| covered[t]).par_iter_mut().enumerate().for_each(|(t, tile)| {
            let origin = ((t % tiles_x) * TILE, (t / tiles_x) * TILE);
            if uniform {
                self.write_tile(tile, origin, depth, color, state);
            } else {
                self.write_tile_per_pass(tile, origin, depth, color, state);
            }
        });
    }

    /// Whether every pass blends and writes depth as the first.
    fn uniform(&self) -> bool {
        let first = self.passes[0].state;
        self.passes.iter().all(|p| p.state.blend == first.blend && p.state.depth.write == first.depth.write)
    }

    /// Per tile of the target (`tiles_x` by `tiles_y`): whether a row's
    /// covered span reaches it (the only tiles the draw may write).
    fn covered_tiles(&self, tiles_x: usize, tiles_y: usize) -> Vec<bool> {
        let mut covered = vec![false; tiles_x * tiles_y];
        for (y, &(a, b)) in self.spans.iter().enumerate().filter(|(_, &(a, b))| a < b) {
            covered[(y / TILE) * tiles_x..][a / TILE..=(b - 1) / TILE].fill(true);
        }
        covered
    }

    /// The target's rows split band by band for the fused write-through
    /// (band k of `bands`: rows k·n up to the next band's first row, n the
    /// spacing, the last band to the frame's last row), the tiles the draw
    /// reaches marked written; `None` where it cannot be fused: a pass that
    /// blends, writes depth unlike the others or may drop a fragment, a
    /// colour format that is not stored as it is, no bands.
    pub(super) fn band_outputs<'t>(
        &self,
        target: &'t mut Framebuffer,
        bands: usize,
    ) -> Option<Vec<Option<BandOut<'t>>>> {
        #[cfg(test)]
        if UNFUSED.with(|u| u.get()) {
            return None;
        }
        let pass = self.passes[0].state;
        let may_discard = self
            .passes
            .iter()
            .chain(self.followers.iter().flat_map(|f| f.passes))
            .any(|p| p.fragment.may_discard());
        if bands == 0
            || may_discard
            || !self.uniform()
            || Writer::of(&pass.blend) != Writer::Replace
            || !matches!(target.format(), ColorFormat::F32 | ColorFormat::Unorm)
        {
            return None;
        }
        let (tiles_x, n) = (target.tiles_x(), self.settings.spacing as usize);
        let covered = self.covered_tiles(tiles_x, target.tiles_y());
        let (mut color, mut depth) = (Vec::with_capacity(self.h * tiles_x), Vec::new());
        for tile_row in target.tiles.writing(|t| covered[t]).chunks_mut(tiles_x) {
            let mut parts = Vec::with_capacity(tiles_x);
            for tile in tile_row {
                let TileBuffers { color: ColorTile::F32(texels) | ColorTile::Unorm(texels), depth, .. } =
                    tile
                else {
                    return None;
                };
                parts.push((texels.chunks_mut(TILE), depth.chunks_mut(TILE)));
            }
            for _ in 0..TILE {
                for (c, d) in &mut parts {
                    color.extend(c.next());
                    depth.extend(d.next().filter(|_| pass.depth.write));
                }
            }
        }
        color.truncate(self.h * tiles_x);
        depth.truncate(self.h * tiles_x);
        #[cfg(test)]
        FUSED.with(|f| f.set(f.get() + 1));
        let (mut color, mut depth) = (color.into_iter(), depth.into_iter());
        let outs = (0..bands)
            .map(|k| {
                let rows = if k + 1 == bands { self.h - k * n } else { n };
                let color = color.by_ref().take(rows * tiles_x).collect();
                let depth = depth.by_ref().take(if pass.depth.write { rows * tiles_x } else { 0 }).collect();
                Some(BandOut { tiles_x, color, depth })
            })
            .collect();
        Some(outs)
    }

    /// The fused write-through of the band starting at row `top` (`c`/`s`
    /// start there, its columns done): each row's covered span, copied as
    /// [`Ctx::replace_tile`] copies it, with the depths of `depth` (the frame's).
    pub(super) fn write_band(&self, out: &mut BandOut, top: usize, c: &[[f32; 4]], s: &[u8], depth: &[f32]) {
        let (w, tiles_x) = (self.w, out.tiles_x);
        let rows = out.color.len() / tiles_x;
        for r in 0..rows {
            let (a, b) = self.spans[top + r];
            let mut x = a;
            while x < b {
                let (t, end) = (x / TILE, (x / TILE * TILE + TILE).min(b));
                let (l, i, o) = (r * w + x, (top + r) * w + x, x % TILE);
                let m = end - x;
                let texels = &mut out.color[r * tiles_x + t][o..o + m];
                let mut depth_out = out.depth.get_mut(r * tiles_x + t).map(|d| &mut d[o..o + m]);
                if s[l..l + m].iter().all(|&st| kept(st)) {
                    texels.copy_from_slice(&c[l..l + m]);
                    if let Some(d) = depth_out {
                        d.copy_from_slice(&depth[i..i + m]);
                    }
                } else {
                    for k in (0..m).filter(|&k| kept(s[l + k])) {
                        texels[k] = c[l + k];
                        if let Some(d) = depth_out.as_deref_mut() {
                            d[k] = depth[i + k];
                        }
                    }
                }
                x = end;
            }
        }
    }

    /// The target's texels as the frame's colours, for the refinement
    /// after the bands wrote through (every pixel it reads was written).
    pub(super) fn tile_colors<'t>(&self, target: &'t mut Framebuffer) -> TileColors<'t> {
        let tiles_x = target.tiles_x();
        // Every pixel lies on a covered span: its tile is marked already.
        TileColors { tiles: target.tiles.writing(|_| false), tiles_x, w: self.w }
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
