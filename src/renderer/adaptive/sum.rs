//! Additive passes over the same geometry drawn as one adaptive draw.
//!
//! A plan with one pass per light (Kilgard 2000, Section 5; Pipeline
//! Grammar, multipass (9)-(10)) draws the same triangles once per light:
//! the first pass replaces the colour and writes depth, each later pass is
//! `Equal` without depth writes and adds its colour (`C ← C + src`). Drawn
//! one adaptive draw per pass, every pass pays for the interpolation, the
//! refinement's scan and the write-through over every covered pixel;
//! drawn as one, the sum of the passes is sampled, interpolated and
//! written once.
//!
//! # When the fused draw is the passes' draws
//!
//! [`draw_adaptive_sum`] fuses passes `P0, P1, …, Pn` (each a list of
//! draws, one per object) only where all of these hold, and returns `None`
//! (drawing nothing) otherwise:
//!
//! 1. every draw of `P0` blends `REPLACE` and writes depth, and every draw
//!    of `P1..Pn` blends `ADD` (ONE, ONE, every channel) and tests `Equal`
//!    without depth writes; no draw uses the stencil or replaces its depth;
//! 2. the target stores `F32`, `F16`, `Unorm` or `Rgba8` colour;
//! 3. every `Pk` has, draw by draw, the triangles of `P0` in window
//!    coordinates bit for bit (the same mesh through the same clip
//!    positions);
//! 4. no fragment of `P0` failed its depth test by being equal to the
//!    depth it met (each `Pk` then sees, pixel by pixel, the triangle `P0`
//!    left: [`super::visibility::Visibility::repeatable`]);
//! 5. no sample of `P0` is discarded (its depth would then not be written,
//!    and a later `Equal` pass would test against another depth): the
//!    fused draw finds this out while shading and gives up before it
//!    writes anything.
//!
//! Under these, at a pixel shaded exactly the fused colour is, bit for
//! bit, what the passes leave: `v0 = store(c0)`, `vk = store(vk−1 + ck)`
//! with the format's own write (`F16` rounds each sum to a half, `Unorm`
//! clamps source and destination to [0, 1] before adding, `Rgba8` clamps
//! the source and rounds each sum to the nearest 1/255, as
//! `framebuffer::TileBuffers::blend_kept` does), a fragment of `Pk` (k ≥ 1)
//! that discards adding nothing; the sum is then written with `P0`'s
//! `REPLACE`, which stores `vn` unchanged. Between samples the fused draw
//! interpolates `vn`, where the per-pass draws interpolate each `ck`: the
//! two differ only by the interpolation's own error (both are exact at
//! their samples, and the samples themselves differ because the fused
//! draw's subdivision compares sums).

use super::{check_adaptive, draw_with, setup_passes, visibility, AdaptiveSettings, AdaptiveStats, Ctx};
use crate::pipeline::DepthState;
use crate::renderer::framebuffer::{quantize_unorm8, round_f16};
use crate::renderer::raster::PassSetup;
use crate::renderer::{
    BlendState, ColorFormat, Fragment, FragmentResult, Framebuffer, Pass, RenderError, BATCH,
};

/// A pass added to a fused draw's first: its draws and their setups.
pub(super) struct Follower<'a> {
    pub passes: &'a [Pass<'a>],
    pub setups: Vec<PassSetup>,
}

/// Draws the additive passes `members` (each a list of draws, one per
/// object, in the same order) as one adaptive draw of their sum: `Some`
/// with the draw's counters (each sample counted once, though every
/// member shades it), or `None`, with `target` untouched, where the
/// conditions of the module's documentation do not hold — the caller then
/// draws the members one by one.
pub fn draw_adaptive_sum(
    target: &mut Framebuffer,
    members: &[&[Pass]],
    settings: &AdaptiveSettings,
) -> Result<Option<AdaptiveStats>, RenderError> {
    let Some((head, rest)) = members.split_first() else { return Ok(Some(AdaptiveStats::default())) };
    if rest.is_empty() {
        return super::draw_adaptive(target, head, settings).map(Some);
    }
    for member in members {
        check_adaptive(member, settings)?;
    }
    if !fusable(target.format(), head, rest) {
        return Ok(None);
    }
    let (w, h) = (target.width() as usize, target.height() as usize);
    let (setups, offsets) = setup_passes(head, w, h)?;
    let mut followers = Vec::with_capacity(rest.len());
    for passes in rest {
        let (theirs, their_offsets) = setup_passes(passes, w, h)?;
        if their_offsets != offsets || !visibility::same_setups(&setups, &theirs) {
            return Ok(None);
        }
        followers.push(Follower { passes, setups: theirs });
    }
    Ok(draw_with(target, head, (&setups, &offsets), &followers, settings))
}

/// Conditions 1 and 2 of the module's documentation, and the same number
/// of draws in every member.
fn fusable(format: ColorFormat, head: &[Pass], rest: &[&[Pass]]) -> bool {
    let plain = |p: &Pass| !p.state.stencil.enabled && !p.fragment.replaces_depth();
    let first = |p: &Pass| plain(p) && p.state.blend == BlendState::REPLACE && p.state.depth.write;
    let added = |p: &Pass| {
        plain(p) && p.state.blend == BlendState::ADD && p.state.depth == DepthState::EQUAL_NO_WRITE
    };
    matches!(format, ColorFormat::F32 | ColorFormat::F16 | ColorFormat::Unorm | ColorFormat::Rgba8)
        && head.iter().all(first)
        && rest.iter().all(|m| m.len() == head.len() && m.iter().all(added))
}

/// `v` as a write of `format` stores it (the first pass's `REPLACE`).
pub(super) fn stored(format: ColorFormat, v: [f32; 4]) -> [f32; 4] {
    match format {
        ColorFormat::F16 => v.map(round_f16),
        ColorFormat::Rgba8 => v.map(rounded8),
        ColorFormat::F32 | ColorFormat::Unorm => v,
    }
}

/// A channel as an 8-bit buffer stores it, as a float: `k/255`, clamped
/// and rounded as [`quantize_unorm8`] writes it and read back as
/// `framebuffer::TileBuffers::read_color` reads it.
fn rounded8(v: f32) -> f32 {
    f32::from(quantize_unorm8(v)) / 255.0
}

/// What `C ← C + src` leaves in a buffer of `format` holding `dst`, as
/// `framebuffer::TileBuffers::blend_kept` computes it.
pub(super) fn added(format: ColorFormat, src: [f32; 4], dst: [f32; 4]) -> [f32; 4] {
    let unorm = |x: f32| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let add = |s: [f32; 4], d: [f32; 4]| [s[0] + d[0], s[1] + d[1], s[2] + d[2], s[3] + d[3]];
    match format {
        ColorFormat::F16 => add(src, dst).map(round_f16),
        ColorFormat::Unorm => add(src.map(unorm), dst.map(unorm)),
        ColorFormat::Rgba8 => add(src.map(|x| x.clamp(0.0, 1.0)), dst).map(rounded8),
        ColorFormat::F32 => add(src, dst),
    }
}

impl<'a> Ctx<'a> {
    /// `out`, the first pass's colours at `pixels` (which show triangles
    /// of draw `p`), becomes what every follower leaves added to it: each
    /// follower shades the same pixels through its own setup.
    pub(super) fn add_followers(
        &self,
        p: usize,
        pixels: &[usize],
        out: &mut [[f32; 4]],
        fragments: &mut Vec<Fragment<'a>>,
        varyings: &mut Vec<f32>,
    ) {
        let n = pixels.len();
        let mut colour = [[0.0f32; 4]; BATCH];
        let mut kept = [FragmentResult::Keep; BATCH];
        for v in out.iter_mut() {
            *v = stored(self.format, *v);
        }
        for follower in self.followers {
            self.gather(&follower.setups[p], p, pixels, fragments, varyings);
            let (colour, kept) = (&mut colour[..n], &mut kept[..n]);
            follower.passes[p].fragment.shade_batch(fragments, varyings, colour, kept);
            for ((v, c), r) in out.iter_mut().zip(colour.iter()).zip(kept.iter()) {
                if *r == FragmentResult::Keep {
                    *v = added(self.format, *c, *v);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{added, stored};
    use crate::renderer::framebuffer::Writer;
    use crate::renderer::{BlendState, ColorFormat, FragmentResult, Framebuffer};

    /// What the passes leave in a one-pixel `format` buffer: `colours[0]`
    /// written with `REPLACE`, every later one with `ADD`, through the
    /// framebuffer's own write.
    fn through_the_framebuffer(format: ColorFormat, colours: &[[f32; 4]]) -> [f32; 4] {
        let mut fb = Framebuffer::new(1, 1, format).unwrap();
        for (k, c) in colours.iter().enumerate() {
            let blend = if k == 0 { BlendState::REPLACE } else { BlendState::ADD };
            let tile = &mut fb.tiles[0];
            tile.blend_kept(&[(0, 0.5)], &[*c], &[FragmentResult::Keep], &blend, Writer::of(&blend));
        }
        fb.tiles[0].read_color(0)
    }

    #[test]
    fn the_sum_stores_what_the_added_passes_leave_in_every_fused_format() {
        let colours = [
            [0.3, 0.9, -0.2, 1.0],
            [0.8, 0.4, 0.1, 0.0],
            [0.123_456_7, -0.6, 2.5, 0.25],
            [1e-4, 0.333_333_34, 0.7, f32::NAN],
        ];
        for format in [ColorFormat::F32, ColorFormat::F16, ColorFormat::Unorm, ColorFormat::Rgba8] {
            for n in 1..=colours.len() {
                let want = through_the_framebuffer(format, &colours[..n]);
                let got = colours[1..n].iter().fold(stored(format, colours[0]), |v, c| added(format, *c, v));
                assert_eq!(want.map(f32::to_bits), got.map(f32::to_bits), "{format:?}, {n} passes");
            }
        }
    }
}
