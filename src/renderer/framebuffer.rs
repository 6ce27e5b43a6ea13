//! Framebuffers (colour RGBA8 or f32, depth f32, stencil u8) and the
//! per-fragment operations of the GL pipeline that the pass planner relies on
//! (Pipeline Grammar, Section 3, multipass (9)-(10): C ← C ⊕ …): stencil test, depth
//! test, blending with the GL blend-factor pairs, and a colour write mask.
//!
//! Storage is tiled: the image is cut into `TILE`×`TILE` tiles and every tile
//! owns its colour, depth and stencil texels contiguously, so the rasterizer
//! can hand each tile to one rayon task with no sharing.

use std::path::Path;

use serde::{Deserialize, Serialize};

use rayon::prelude::*;

use super::{BlendState, FragmentResult, RenderError};

/// Edge length of a framebuffer tile in pixels.
pub const TILE: usize = 64;

/// How colour is stored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ColorFormat {
    /// 8 bits per channel, unsigned normalized: values clamp to [0, 1] and
    /// round to the nearest 1/255 on every write (GL fixed-point framebuffer).
    Rgba8,
    /// 32-bit float per channel, no clamping.
    F32,
    /// A fixed-point (`rgba8`) framebuffer or texture in float arithmetic:
    /// 32-bit floats, not rounded, and whatever is read back — by a later
    /// pass ([`Framebuffer::read_back`]), as a blend's destination, as a
    /// rendered texture — clamped to [0, 1], as GL clamps what a
    /// fixed-point colour buffer stores (§2.13.9, §4.1.8). The last value
    /// written is kept as computed, so that the exact reference keeps the
    /// range of its final picture (a picture is clamped when it is shown).
    Unorm,
    /// 16-bit float per channel (what the WGSL target renders 16-bit and
    /// float textures into, `Rgba16Float`): every write rounds to the
    /// nearest half; no clamping.
    F16,
}

/// Colour texels of one tile.
#[derive(Clone, Debug)]
pub(crate) enum ColorTile {
    Rgba8(Vec<[u8; 4]>),
    F32(Vec<[f32; 4]>),
    /// Values as written, clamped where read back ([`ColorFormat::Unorm`]).
    Unorm(Vec<[f32; 4]>),
    /// Values already rounded to half precision.
    F16(Vec<[f32; 4]>),
}

/// One tile's buffers, `TILE*TILE` texels each, row-major inside the tile.
#[derive(Clone, Debug)]
pub(crate) struct TileBuffers {
    pub(crate) color: ColorTile,
    pub(crate) depth: Vec<f32>,
    pub(crate) stencil: Vec<u8>,
}

impl TileBuffers {
    /// What [`Framebuffer::new`] puts in a tile: colour 0, depth 1, stencil 0.
    pub(crate) fn clear(&mut self) {
        match &mut self.color {
            ColorTile::Rgba8(v) => v.fill([0; 4]),
            ColorTile::F32(v) | ColorTile::F16(v) | ColorTile::Unorm(v) => v.fill([0.0; 4]),
        }
        self.depth.fill(1.0);
        self.stencil.fill(0);
    }
}

/// The nearest half-precision value (ties to even), as an `f32`.
#[inline]
pub fn round_f16(v: f32) -> f32 {
    half::f16::from_f32(v).to_f32()
}

/// `v` as a fixed-point buffer holds it, unrounded: clamped to [0, 1], NaN 0.
#[inline]
fn unorm(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

/// A colour channel as GL's fixed-point buffers store it: clamped to [0, 1],
/// rounded to the nearest of 256 steps (NaN to 0).
#[inline]
pub fn quantize_unorm8(v: f32) -> u8 {
    // NaN maps to 0 (`as` saturates NaN to 0).
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// How a pass writes its colours, resolved once per pass from its blend
/// state ([`Writer::of`]): the two states the plans use most — no blending
/// (a first pass) and `C ← C + src` (Pipeline Grammar, multipass (9)-(10):
/// the passes summed) — written without the per-channel factor `match` of
/// [`BlendState::blend`]; every other state through it. Each computes what
/// [`TileBuffers::blend_color`] computes, bit for bit (`src · 1 = src`,
/// `dst · 1 = dst` in IEEE arithmetic).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Writer {
    /// `C ← src`, every channel written.
    Replace,
    /// `C ← C + src` (ONE, ONE, add), every channel written.
    Add,
    /// Any other state: [`BlendState::blend`] per fragment.
    General,
}

impl Writer {
    /// The writer of `blend`.
    pub(crate) fn of(blend: &BlendState) -> Writer {
        if *blend == BlendState::REPLACE {
            Writer::Replace
        } else if *blend == BlendState::ADD {
            Writer::Add
        } else {
            Writer::General
        }
    }
}

impl TileBuffers {
    #[inline]
    pub(crate) fn read_color(&self, idx: usize) -> [f32; 4] {
        match &self.color {
            ColorTile::Rgba8(c) => {
                let p = c[idx];
                [p[0] as f32 / 255.0, p[1] as f32 / 255.0, p[2] as f32 / 255.0, p[3] as f32 / 255.0]
            }
            ColorTile::F32(c) | ColorTile::F16(c) | ColorTile::Unorm(c) => c[idx],
        }
    }

    /// Blends `out[k]` into texel `pixels[k].0` for every `k` whose
    /// result is [`FragmentResult::Keep`], as [`TileBuffers::blend_color`]
    /// does one at a time, with the format and the blend state (`writer`,
    /// resolved once per pass) matched once per batch.
    pub(crate) fn blend_kept(
        &mut self,
        pixels: &[(usize, f32)],
        out: &[[f32; 4]],
        results: &[FragmentResult],
        blend: &BlendState,
        writer: Writer,
    ) {
        let kept = pixels
            .iter()
            .zip(out)
            .zip(results)
            .filter(|(_, r)| **r == FragmentResult::Keep)
            .map(|((&(idx, _), c), _)| (idx, c));
        if writer == Writer::General {
            kept.for_each(|(i, s)| self.blend_color(i, s, blend));
            return;
        }
        let add = |s: [f32; 4], d: [f32; 4]| [s[0] + d[0], s[1] + d[1], s[2] + d[2], s[3] + d[3]];
        let replace = writer == Writer::Replace;
        match &mut self.color {
            ColorTile::F32(c) if replace => kept.for_each(|(i, s)| c[i] = *s),
            ColorTile::Unorm(c) if replace => kept.for_each(|(i, s)| c[i] = *s),
            ColorTile::F16(c) if replace => kept.for_each(|(i, s)| c[i] = s.map(round_f16)),
            ColorTile::Rgba8(c) if replace => kept.for_each(|(i, s)| c[i] = s.map(quantize_unorm8)),
            ColorTile::F32(c) => kept.for_each(|(i, s)| c[i] = add(*s, c[i])),
            ColorTile::F16(c) => kept.for_each(|(i, s)| c[i] = add(*s, c[i]).map(round_f16)),
            ColorTile::Unorm(c) => kept.for_each(|(i, s)| c[i] = add(s.map(unorm), c[i].map(unorm))),
            ColorTile::Rgba8(c) => kept.for_each(|(i, s)| {
                let d = c[i].map(|p| p as f32 / 255.0);
                c[i] = add(s.map(|x| x.clamp(0.0, 1.0)), d).map(quantize_unorm8);
            }),
        }
    }

    /// Blends `src` into texel `idx` (src is clamped first for RGBA8 targets,
    /// as GL clamps fragment colours for fixed-point buffers).
    #[inline]
    pub(crate) fn blend_color(&mut self, idx: usize, src: &[f32; 4], blend: &BlendState) {
        let half = matches!(self.color, ColorTile::F16(_));
        match &mut self.color {
            ColorTile::Rgba8(c) => {
                let s = [
                    src[0].clamp(0.0, 1.0),
                    src[1].clamp(0.0, 1.0),
                    src[2].clamp(0.0, 1.0),
                    src[3].clamp(0.0, 1.0),
                ];
                let p = c[idx];
                let d = [p[0] as f32 / 255.0, p[1] as f32 / 255.0, p[2] as f32 / 255.0, p[3] as f32 / 255.0];
                let out = blend.blend(&s, &d);
                for ch in 0..4 {
                    if blend.write_mask[ch] {
                        c[idx][ch] = quantize_unorm8(out[ch]);
                    }
                }
            }
            ColorTile::Unorm(c) => {
                // The destination is what the buffer holds, clamped; a
                // blended source is clamped first, as GL clamps it on a
                // fixed-point buffer (§4.1.8), as a blend the program
                // writes means it (`planner::blended_as_gl`).
                let s = if *blend == BlendState::REPLACE { *src } else { src.map(unorm) };
                let out = blend.blend(&s, &c[idx].map(unorm));
                for ch in 0..4 {
                    if blend.write_mask[ch] {
                        c[idx][ch] = out[ch];
                    }
                }
            }
            ColorTile::F32(c) | ColorTile::F16(c) => {
                let out = blend.blend(src, &c[idx]);
                for ch in 0..4 {
                    if blend.write_mask[ch] {
                        c[idx][ch] = if half { round_f16(out[ch]) } else { out[ch] };
                    }
                }
            }
        }
    }
}

/// A render target: colour, depth and stencil of the same size.
#[derive(Clone, Debug)]
pub struct Framebuffer {
    width: u32,
    height: u32,
    format: ColorFormat,
    tiles_x: usize,
    tiles_y: usize,
    pub(crate) tiles: Tiles,
}

/// A framebuffer's tiles, and which of them still hold what
/// [`Framebuffer::new`] puts there: [`Framebuffer::reset`] clears only the
/// others, so a frame clears the tiles the last frame wrote, not the whole
/// target (the clear was 5 % of a frame of Kilgard's torus at 1024²,
/// BENCHMARKS.md, thirteenth session). Any mutable access through `Deref`
/// marks every tile written (conservative: the adaptive writers and
/// `set_color` go through it); the tiled rasterizer marks only the tiles it
/// has triangles for ([`Tiles::writing`]).
///
/// A clear may also be deferred ([`Framebuffer::reset_deferred`]): the
/// tiles to clear are marked `stale` and cleared by the tiled rasterizer's
/// worker just before it first writes them ([`Tiles::writing_fused`]), in
/// cache, instead of by a pass over the whole target whose lines the
/// rasterizer then reads back from memory. A stale tile is never seen:
/// every mutable access clears the stale tiles first, and the holder of a
/// framebuffer reset so settles it ([`Framebuffer::settle`]) before any
/// shared access (checked in debug builds).
#[derive(Clone, Debug)]
pub(crate) struct Tiles {
    buffers: Vec<TileBuffers>,
    /// Per tile: nothing written since it was last cleared.
    clean: Vec<bool>,
    /// Per tile: to be cleared before it is used ([`Framebuffer::reset_deferred`]).
    stale: Vec<bool>,
    /// Whether any tile is stale.
    any_stale: bool,
}

impl Tiles {
    /// The tiles, to write those where `written(t)` (they lose their clean
    /// mark; the others must not be written).
    pub(crate) fn writing(&mut self, written: impl Fn(usize) -> bool) -> &mut [TileBuffers] {
        self.settle();
        for (t, c) in self.clean.iter_mut().enumerate() {
            *c &= !written(t);
        }
        &mut self.buffers
    }

    /// [`Tiles::writing`] with the deferred clear fused into the writer:
    /// the stale tiles that are not written are cleared here (in
    /// parallel); those written are returned marked (`true` at their
    /// index), and the caller must clear each ([`TileBuffers::clear`])
    /// before it reads or writes it.
    pub(crate) fn writing_fused(
        &mut self,
        written: impl Fn(usize) -> bool + Sync,
    ) -> (&mut [TileBuffers], Vec<bool>) {
        let mut fresh = vec![false; self.buffers.len()];
        if self.any_stale {
            self.buffers.par_iter_mut().zip(self.stale.par_iter()).enumerate().for_each(|(t, (b, &s))| {
                if s && !written(t) {
                    b.clear();
                }
            });
            for (t, (f, s)) in fresh.iter_mut().zip(&mut self.stale).enumerate() {
                *f = *s && written(t);
                *s = false;
            }
            self.any_stale = false;
        }
        for (t, c) in self.clean.iter_mut().enumerate() {
            *c &= !written(t);
        }
        (&mut self.buffers, fresh)
    }

    /// Clears the stale tiles (in parallel).
    fn settle(&mut self) {
        if !self.any_stale {
            return;
        }
        self.buffers.par_iter_mut().zip(self.stale.par_iter_mut()).filter(|(_, s)| **s).for_each(|(b, s)| {
            b.clear();
            *s = false;
        });
        self.any_stale = false;
    }

    /// How many tiles are marked clean (for tests).
    #[cfg(test)]
    pub(crate) fn clean_count(&self) -> usize {
        self.clean.iter().filter(|&&c| c).count()
    }
}

impl std::ops::Deref for Tiles {
    type Target = Vec<TileBuffers>;
    fn deref(&self) -> &Vec<TileBuffers> {
        debug_assert!(
            !self.any_stale,
            "a framebuffer reset with its clear deferred read before it was settled"
        );
        &self.buffers
    }
}

impl std::ops::DerefMut for Tiles {
    fn deref_mut(&mut self) -> &mut Vec<TileBuffers> {
        self.settle();
        self.clean.fill(false);
        &mut self.buffers
    }
}

impl Framebuffer {
    /// A cleared framebuffer: colour 0, depth 1, stencil 0.
    /// Errors on a zero or absurd size (more than 16384 on a side).
    pub fn new(width: u32, height: u32, format: ColorFormat) -> Result<Framebuffer, RenderError> {
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(RenderError::BadSize { width, height });
        }
        let tiles_x = (width as usize).div_ceil(TILE);
        let tiles_y = (height as usize).div_ceil(TILE);
        let n = TILE * TILE;
        let color = match format {
            ColorFormat::Rgba8 => ColorTile::Rgba8(vec![[0; 4]; n]),
            ColorFormat::F32 => ColorTile::F32(vec![[0.0; 4]; n]),
            ColorFormat::F16 => ColorTile::F16(vec![[0.0; 4]; n]),
            ColorFormat::Unorm => ColorTile::Unorm(vec![[0.0; 4]; n]),
        };
        let tile = TileBuffers { color, depth: vec![1.0; n], stencil: vec![0; n] };
        let n = tiles_x * tiles_y;
        let tiles =
            Tiles { buffers: vec![tile; n], clean: vec![true; n], stale: vec![false; n], any_stale: false };
        Ok(Framebuffer { width, height, format, tiles_x, tiles_y, tiles })
    }

    /// Whether this framebuffer has that size and colour format (so that
    /// [`Framebuffer::reset`] makes it what [`Framebuffer::new`] would).
    pub fn fits(&self, width: u32, height: u32, format: ColorFormat) -> bool {
        (self.width, self.height, self.format) == (width, height, format)
    }

    /// Clears it to what [`Framebuffer::new`] makes (colour 0, depth 1,
    /// stencil 0), in parallel over the tiles: a frame renders into the
    /// buffers of an earlier one instead of allocating and faulting in
    /// tens of megabytes per frame. Only the tiles written since their last
    /// clear are cleared (the framebuffer keeps a mark per tile).
    pub fn reset(&mut self) {
        self.reset_deferred();
        self.settle();
    }

    /// [`Framebuffer::reset`] with the clear deferred: the tiles to clear
    /// are only marked, and cleared by the tiled rasterizer just before it
    /// first writes each (in cache), or by any mutable access, or by
    /// [`Framebuffer::settle`] — which the caller must call before any
    /// shared access if it does not draw first.
    pub(crate) fn reset_deferred(&mut self) {
        let Tiles { clean, stale, any_stale, .. } = &mut self.tiles;
        for (c, s) in clean.iter_mut().zip(stale.iter_mut()) {
            if !*c {
                (*c, *s) = (true, true);
                *any_stale = true;
            }
        }
    }

    /// Clears the tiles whose clear [`Framebuffer::reset_deferred`]
    /// deferred (nothing when none is).
    pub(crate) fn settle(&mut self) {
        self.tiles.settle();
    }

    /// Whether every tile is marked clean (nothing written since its last
    /// clear, made or deferred): every pixel holds what
    /// [`Framebuffer::new`] makes, depth 1 included, without reading them.
    pub(crate) fn is_cleared(&self) -> bool {
        self.tiles.clean.iter().all(|&c| c)
    }

    /// The width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// The height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// How the colour is stored (and rounded on write).
    pub fn format(&self) -> ColorFormat {
        self.format
    }
    pub(crate) fn tiles_x(&self) -> usize {
        self.tiles_x
    }
    pub(crate) fn tiles_y(&self) -> usize {
        self.tiles_y
    }

    #[inline]
    fn locate(&self, x: u32, y: u32) -> Option<(usize, usize)> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let (x, y) = (x as usize, y as usize);
        Some(((y / TILE) * self.tiles_x + x / TILE, (y % TILE) * TILE + x % TILE))
    }

    /// Colour at pixel (x, y) (row 0 is the top), as f32; `None` outside.
    pub fn color(&self, x: u32, y: u32) -> Option<[f32; 4]> {
        self.locate(x, y).map(|(t, i)| self.tiles[t].read_color(i))
    }
    /// What a later pass reads at pixel (x, y): the colour, clamped to
    /// [0, 1] where the buffer is fixed-point ([`ColorFormat::Unorm`]).
    pub fn read_back(&self, x: u32, y: u32) -> Option<[f32; 4]> {
        let c = self.color(x, y)?;
        Some(if self.format == ColorFormat::Unorm { c.map(unorm) } else { c })
    }

    /// The whole image as later passes read it (see [`Framebuffer::read_back`]).
    pub fn read_back_rgba_f32(&self) -> Vec<[f32; 4]> {
        let all = self.to_rgba_f32();
        if self.format == ColorFormat::Unorm {
            all.into_iter().map(|c| c.map(unorm)).collect()
        } else {
            all
        }
    }

    /// Depth at pixel (x, y); `None` outside.
    pub fn depth(&self, x: u32, y: u32) -> Option<f32> {
        self.locate(x, y).map(|(t, i)| self.tiles[t].depth[i])
    }
    /// Stencil value at pixel (x, y); `None` outside.
    pub fn stencil(&self, x: u32, y: u32) -> Option<u8> {
        self.locate(x, y).map(|(t, i)| self.tiles[t].stencil[i])
    }

    /// Writes a colour (rounded for RGBA8); ignores pixels outside.
    pub fn set_color(&mut self, x: u32, y: u32, c: [f32; 4]) {
        if let Some((t, i)) = self.locate(x, y) {
            self.tiles[t].blend_color(i, &c, &BlendState::REPLACE);
        }
    }
    /// Writes a stencil value; ignores pixels outside.
    pub fn set_stencil(&mut self, x: u32, y: u32, s: u8) {
        if let Some((t, i)) = self.locate(x, y) {
            self.tiles[t].stencil[i] = s;
        }
    }

    /// Sets every pixel's colour (rounded as the format stores it).
    pub fn clear_color(&mut self, c: [f32; 4]) {
        for tile in self.tiles.iter_mut() {
            match &mut tile.color {
                ColorTile::Rgba8(v) => v.fill(c.map(quantize_unorm8)),
                ColorTile::F32(v) => v.fill(c),
                ColorTile::F16(v) => v.fill(c.map(round_f16)),
                ColorTile::Unorm(v) => v.fill(c),
            }
        }
    }
    /// Sets every pixel's depth.
    pub fn clear_depth(&mut self, d: f32) {
        self.tiles.iter_mut().for_each(|t| t.depth.fill(d));
    }
    /// Sets every pixel's stencil value.
    pub fn clear_stencil(&mut self, s: u8) {
        self.tiles.iter_mut().for_each(|t| t.stencil.fill(s));
    }

    /// Row-major colour, top row first, as f32 RGBA.
    pub fn to_rgba_f32(&self) -> Vec<[f32; 4]> {
        let mut out = Vec::with_capacity(self.width as usize * self.height as usize);
        for y in 0..self.height {
            for x in 0..self.width {
                #[allow(
                    clippy::expect_used,
                    reason = "x < width and y < height: `locate` finds every such pixel"
                )]
                let (t, i) = self.locate(x, y).expect("in range");
                out.push(self.tiles[t].read_color(i));
            }
        }
        out
    }

    /// An RGBA8 framebuffer holding `rgba` (row-major, row 0 at the top):
    /// an image another executor rendered (wgpu), to compare like ours.
    pub fn from_rgba8(width: u32, height: u32, rgba: &[u8]) -> Result<Framebuffer, RenderError> {
        let mut fb = Framebuffer::new(width, height, ColorFormat::Rgba8)?;
        if rgba.len() != width as usize * height as usize * 4 {
            return Err(RenderError::Unsupported(format!(
                "an RGBA8 image of {width}×{height} has {} bytes, not {}",
                width as usize * height as usize * 4,
                rgba.len()
            )));
        }
        for (k, px) in rgba.chunks_exact(4).enumerate() {
            let (x, y) = ((k % width as usize) as u32, (k / width as usize) as u32);
            fb.set_color(x, y, [px[0], px[1], px[2], px[3]].map(|c| c as f32 / 255.0));
        }
        Ok(fb)
    }

    /// Row-major colour as RGBA8 bytes (f32 buffers are clamped and rounded).
    pub fn to_rgba8(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.width as usize * self.height as usize * 4);
        for y in 0..self.height {
            for x in 0..self.width {
                #[allow(
                    clippy::expect_used,
                    reason = "x < width and y < height: `locate` finds every such pixel"
                )]
                let (t, i) = self.locate(x, y).expect("in range");
                match &self.tiles[t].color {
                    ColorTile::Rgba8(c) => out.extend_from_slice(&c[i]),
                    ColorTile::F32(c) | ColorTile::F16(c) | ColorTile::Unorm(c) => {
                        out.extend(c[i].map(quantize_unorm8))
                    }
                }
            }
        }
        out
    }

    /// Saves the colour buffer as an RGBA8 PNG, atomically.
    pub fn save_png(&self, path: &Path) -> Result<(), RenderError> {
        let mut bytes = Vec::new();
        let encoder = image::codecs::png::PngEncoder::new(&mut bytes);
        image::ImageEncoder::write_image(
            encoder,
            &self.to_rgba8(),
            self.width,
            self.height,
            image::ExtendedColorType::Rgba8,
        )
        .map_err(|e| RenderError::Encode { path: path.display().to_string(), message: e.to_string() })?;
        crate::io::write_atomic(path, &bytes).map_err(|e| RenderError::Io(e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{BlendEquation, StencilOp, StencilState};

    #[test]
    fn blend_modes_compute_gl_formulas() {
        let src = [0.5, 0.25, 1.0, 0.5];
        let dst = [0.2, 0.4, 0.6, 0.8];
        let close = |a: [f32; 4], b: [f32; 4]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
        assert!(close(BlendState::REPLACE.blend(&src, &dst), src));
        assert!(close(BlendState::ADD.blend(&src, &dst), [0.7, 0.65, 1.6, 1.3]));
        assert!(close(BlendState::MODULATE.blend(&src, &dst), [0.1, 0.1, 0.6, 0.4]));
        assert!(close(BlendState::ALPHA_BLEND.blend(&src, &dst), [0.35, 0.325, 0.8, 0.65]));
        assert!(close(BlendState::DEST_ALPHA_MODULATE.blend(&src, &dst), [0.4, 0.2, 0.8, 0.4]));
        assert!(close(BlendState::DEST_ALPHA_ADD.blend(&src, &dst), [0.6, 0.6, 1.4, 1.2]));
        let sub = BlendState { equation: BlendEquation::ReverseSubtract, ..BlendState::ADD };
        assert!(close(sub.blend(&src, &dst), [-0.3, 0.15, -0.4, 0.3]));
    }

    #[test]
    fn from_rgba8_round_trips_and_checks_its_size() {
        let bytes: Vec<u8> = (0..2 * 3 * 4).map(|i| (i * 10) as u8).collect();
        let fb = Framebuffer::from_rgba8(2, 3, &bytes).unwrap();
        assert_eq!(fb.to_rgba8(), bytes);
        assert!(Framebuffer::from_rgba8(2, 2, &bytes).is_err());
    }

    #[test]
    fn rgba8_clamps_and_rounds() {
        let mut fb = Framebuffer::new(3, 2, ColorFormat::Rgba8).unwrap();
        fb.set_color(1, 1, [2.0, -1.0, 0.5, f32::NAN]);
        // Pixel (1, 1) of a 3-wide framebuffer is the fifth.
        assert_eq!(fb.to_rgba8()[4 * 4..5 * 4], [255, 0, 128, 0]);
    }

    #[test]
    fn f16_rounds_to_half_precision_without_clamping() {
        let mut fb = Framebuffer::new(2, 1, ColorFormat::F16).unwrap();
        fb.set_color(0, 0, [0.1, -0.7, 3.0, 1.0]);
        let c = fb.color(0, 0).unwrap();
        // 0.1 is not a half: the nearest one is 0.0999755859375.
        assert_eq!(c, [0.099_975_586, -0.700_195_3, 3.0, 1.0]);
        let mut f32_fb = Framebuffer::new(2, 1, ColorFormat::F32).unwrap();
        f32_fb.set_color(0, 0, [0.1, -0.7, 3.0, 1.0]);
        assert_eq!(f32_fb.color(0, 0).unwrap(), [0.1, -0.7, 3.0, 1.0]);
    }

    #[test]
    fn unorm_reads_back_clamped_without_rounding() {
        let mut fb = Framebuffer::new(2, 1, ColorFormat::Unorm).unwrap();
        fb.set_color(0, 0, [0.1, -0.7, 3.0, f32::NAN]);
        assert_eq!(fb.read_back(0, 0).unwrap(), [0.1, 0.0, 1.0, 0.0]);
        assert_eq!(fb.read_back_rgba_f32()[0], [0.1, 0.0, 1.0, 0.0]);
        // The last value written is kept as computed.
        assert_eq!(fb.color(0, 0).unwrap()[..3], [0.1, -0.7, 3.0]);
        // A blend reads the destination and the source clamped (§4.1.8).
        fb.tiles[0].blend_color(0, &[2.0, 0.5, -0.5, 0.0], &BlendState::ADD);
        assert_eq!(fb.color(0, 0).unwrap(), [1.1, 0.5, 1.0, 0.0]);
        // So an add and a reverse subtract of a signed term give it exactly.
        let sub = BlendState { equation: crate::pipeline::BlendEquation::ReverseSubtract, ..BlendState::ADD };
        fb.set_color(1, 0, [0.5, 0.5, 0.5, 0.5]);
        let v = [0.25f32, -0.25, 0.0, 0.0];
        fb.tiles[0].blend_color(1, &v, &BlendState::ADD);
        fb.tiles[0].blend_color(1, &v.map(|x| -x), &sub);
        assert_eq!(fb.color(1, 0).unwrap(), [0.75, 0.25, 0.5, 0.5]);
    }

    #[test]
    fn stencil_ops_respect_write_mask() {
        let s = StencilState { enabled: true, reference: 0xf0, write_mask: 0x0f, ..StencilState::DISABLED };
        let mut v = 0x33u8;
        s.update(&mut v, StencilOp::Replace);
        assert_eq!(v, 0x30);
        s.update(&mut v, StencilOp::Invert);
        assert_eq!(v, 0x3f);
    }

    /// Whether `a` and `b` hold the same colour, depth and stencil at
    /// every pixel.
    fn same_pixels(a: &Framebuffer, b: &Framebuffer) -> bool {
        (0..a.height()).all(|y| {
            (0..a.width()).all(|x| {
                a.color(x, y) == b.color(x, y)
                    && a.depth(x, y) == b.depth(x, y)
                    && a.stencil(x, y) == b.stencil(x, y)
            })
        })
    }

    /// A reset framebuffer is a new one wherever it was written — through
    /// the rasterizer's marked tiles or any other mutable access — and it
    /// clears only the tiles written since the last reset.
    #[test]
    fn reset_clears_every_written_tile_and_only_those() {
        let (w, h) = (3 * TILE as u32 - 5, 2 * TILE as u32);
        let mut fb = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
        let fresh = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
        let same = |fb: &Framebuffer| same_pixels(fb, &fresh);
        assert_eq!(fb.tiles.clean_count(), 6);
        // The rasterizer's way: tiles 1 and 4 marked, written.
        for t in [1, 4] {
            let tile = &mut fb.tiles.writing(|k| k == 1 || k == 4)[t];
            tile.depth[7] = 0.25;
            tile.stencil[9] = 3;
            tile.blend_color(11, &[1.0, 2.0, 3.0, 4.0], &BlendState::REPLACE);
        }
        assert_eq!(fb.tiles.clean_count(), 4);
        assert!(!same(&fb));
        fb.reset();
        assert!(same(&fb) && fb.tiles.clean_count() == 6);
        // Any other mutable access marks every tile.
        fb.set_color(w - 1, h - 1, [0.5; 4]);
        fb.tiles[0].depth[0] = 0.0;
        assert_eq!(fb.tiles.clean_count(), 0);
        fb.reset();
        assert!(same(&fb) && fb.tiles.clean_count() == 6);
        fb.clear_depth(0.5);
        fb.reset();
        assert!(same(&fb));
    }

    /// A deferred clear ([`Framebuffer::reset_deferred`]) leaves the
    /// framebuffer [`Framebuffer::new`]'s once its tiles are cleared as
    /// the rasterizer clears them: the written ones marked by
    /// [`Tiles::writing_fused`] cleared by the caller, the others by it;
    /// or by [`Framebuffer::settle`], or by any mutable access.
    #[test]
    fn a_deferred_clear_is_made_by_the_writer_or_when_settled() {
        let (w, h) = (3 * TILE as u32 - 5, 2 * TILE as u32);
        let fresh = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
        let same = |fb: &Framebuffer| same_pixels(fb, &fresh);
        let scribble = |fb: &mut Framebuffer| {
            // Every tile but the last (it stays clean).
            for t in 0..5 {
                let tile = &mut fb.tiles.writing(|k| k != 5)[t];
                tile.depth[7 + t] = 0.25;
                tile.stencil[9] = 3;
                tile.blend_color(11 * t, &[1.0, 2.0, 3.0, 4.0], &BlendState::REPLACE);
            }
        };
        let mut fb = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
        scribble(&mut fb);
        assert!(!same(&fb));
        fb.reset_deferred();
        let (tiles, fresh_tiles) = fb.tiles.writing_fused(|t| t == 1 || t == 5);
        // Tile 5 was clean, tile 1 is the writer's to clear.
        assert_eq!(fresh_tiles, [false, true, false, false, false, false]);
        assert!(tiles[1].depth[8] == 0.25 && tiles[0].depth[7] == 1.0);
        tiles[1].clear();
        assert!(same(&fb));
        assert_eq!(fb.tiles.clean_count(), 4);
        scribble(&mut fb);
        fb.reset_deferred();
        fb.settle();
        assert!(same(&fb) && fb.tiles.clean_count() == 6);
        scribble(&mut fb);
        fb.reset_deferred();
        fb.set_color(0, 0, [0.0; 4]);
        assert!(same(&fb));
        // Nothing deferred: nothing to clear.
        assert!(!fb.tiles.writing_fused(|_| true).1.contains(&true));
    }

    /// [`Framebuffer::is_cleared`] (what the adaptive draw's visibility
    /// takes for depth 1 everywhere without reading it) holds exactly
    /// while every depth is 1: after `new`, `reset` and a deferred reset,
    /// not after any write, however small.
    #[test]
    fn a_framebuffer_is_cleared_exactly_while_nothing_was_written_since_its_clear() {
        let (w, h) = (2 * TILE as u32 + 3, TILE as u32);
        let ones = |fb: &Framebuffer| fb.tiles.iter().all(|t| t.depth.iter().all(|&d| d == 1.0));
        let mut fb = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
        assert!(fb.is_cleared() && ones(&fb));
        fb.tiles.writing(|t| t == 2)[2].depth[5] = 0.5;
        assert!(!fb.is_cleared() && !ones(&fb));
        fb.reset();
        assert!(fb.is_cleared() && ones(&fb));
        fb.clear_depth(0.25);
        assert!(!fb.is_cleared());
        fb.reset_deferred();
        assert!(fb.is_cleared());
        fb.settle();
        assert!(ones(&fb));
        fb.set_color(0, 0, [1.0; 4]);
        assert!(!fb.is_cleared());
    }

    #[test]
    fn bad_sizes_are_errors() {
        assert!(Framebuffer::new(0, 10, ColorFormat::F32).is_err());
        assert!(Framebuffer::new(10, 100_000, ColorFormat::F32).is_err());
    }
}
