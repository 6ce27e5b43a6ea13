//! The write-through fused into the bands (`Ctx::band_outputs`) against
//! the draw's own write-through after the refinement, bit for bit, on
//! generated scenes: several passes and meshes, frames that do not divide
//! into tiles or bands, every spacing and edge mode, thresholds that
//! interpolate and refine, targets with colours and depths of their own,
//! and fused sums of passes.

use super::{FUSED, UNFUSED};
use crate::pipeline::{CompareFunc, DepthState};
use crate::renderer::adaptive::{
    draw_adaptive, draw_adaptive_sum, AdaptiveSettings, AdaptiveStats, EdgeMode,
};
use crate::renderer::{
    BlendState, ColorFormat, CullMode, Fragment, FragmentResult, FragmentStage, Framebuffer, Pass,
    RenderState, VertexStage,
};

/// Clip positions, and three varyings per vertex.
struct Mesh(Vec<([f32; 4], [f32; 3])>);

impl VertexStage for Mesh {
    fn n_vertices(&self) -> usize {
        self.0.len()
    }
    fn n_varyings(&self) -> usize {
        3
    }
    fn shade_vertex(&self, index: u32, out: &mut [f32]) -> [f32; 4] {
        let (position, varyings) = self.0[index as usize];
        out.copy_from_slice(&varyings);
        position
    }
}

/// Stripes and spots of `k` periods over the varyings: features the
/// regular samples miss, which the refinement then finds. Never discards.
struct Wavy(f32);

impl FragmentStage for Wavy {
    fn shade(&self, _: &Fragment, v: &[f32], out: &mut [f32; 4]) -> FragmentResult {
        let k = self.0;
        *out = [
            0.5 + 0.5 * (k * v[0]).sin(),
            v[1],
            0.5 + 0.5 * (k * (v[0] * v[0] + v[2] * v[2])).sin(),
            1.0 - v[2],
        ];
        FragmentResult::Keep
    }
    fn may_discard(&self) -> bool {
        false
    }
}

/// A xorshift generator in [0, 1).
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 >> 8) as f32 / (1u32 << 24) as f32
    }
}

/// `n` triangles, large, small and slivers, some past the frame's edges.
fn mesh(rng: &mut Rng, n: usize) -> Mesh {
    let mut vertices = Vec::with_capacity(3 * n);
    for t in 0..n {
        let size = [2.6, 0.7, 0.1, 1.4][t % 4];
        let (cx, cy, z) = (rng.next() * 2.4 - 1.2, rng.next() * 2.4 - 1.2, rng.next() * 1.6 - 0.8);
        for _ in 0..3 {
            let position =
                [cx + (rng.next() - 0.5) * size, cy + (rng.next() - 0.5) * size, z + rng.next() * 0.1, 1.0];
            vertices.push((position, [rng.next(), rng.next(), rng.next()]));
        }
    }
    Mesh(vertices)
}

fn indices(m: &Mesh) -> Vec<[u32; 3]> {
    (0..m.0.len() as u32 / 3).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect()
}

/// A target of its own colours and depths (what a draw must leave where it
/// writes nothing).
fn target(rng: &mut Rng, (w, h): (usize, usize), format: ColorFormat) -> Framebuffer {
    let mut fb = Framebuffer::new(w as u32, h as u32, format).unwrap();
    fb.clear_color([0.25, 0.5, 0.75, 1.0]);
    fb.clear_depth(if rng.next() < 0.5 { 1.0 } else { 0.9 });
    for y in (0..h).step_by(3) {
        for x in (0..w).step_by(5) {
            fb.set_color(x as u32, y as u32, [rng.next(), rng.next(), rng.next(), rng.next()]);
        }
    }
    fb
}

/// Every colour channel and depth of `fb`, as bits.
fn bits(fb: &Framebuffer) -> (Vec<[u32; 4]>, Vec<u32>) {
    let (w, h) = (fb.width(), fb.height());
    let colour = fb.to_rgba_f32().iter().map(|c| c.map(f32::to_bits)).collect();
    let depth =
        (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| fb.depth(x, y).unwrap().to_bits());
    (colour, depth.collect())
}

/// Draws with the fusion on and off into copies of `start`: the same pixels,
/// depths and counters; returns whether the fused draw wrote through the bands.
fn compare(start: &Framebuffer, draw: impl Fn(&mut Framebuffer) -> Option<AdaptiveStats>, at: &str) -> bool {
    let before = FUSED.with(|f| f.get());
    let mut fused = start.clone();
    let fused_stats = draw(&mut fused);
    let was_fused = FUSED.with(|f| f.get()) > before;
    UNFUSED.with(|u| u.set(true));
    let mut plain = start.clone();
    let plain_stats = draw(&mut plain);
    UNFUSED.with(|u| u.set(false));
    assert_eq!(fused_stats, plain_stats, "counters, {at}");
    let (a, b) = (bits(&fused), bits(&plain));
    assert!(a.0 == b.0, "colours, {at}");
    assert!(a.1 == b.1, "depths, {at}");
    was_fused
}

#[test]
fn band_write_through_equals_the_write_after_the_refinement_bit_for_bit() {
    let mut rng = Rng(0x9e37_79b9);
    let sizes = [(1, 1), (7, 3), (64, 64), (65, 70), (130, 129), (200, 67), (33, 150)];
    let (mut fused, mut refined) = (0, 0);
    for round in 0..28 {
        let (w, h) = sizes[round % sizes.len()];
        let n_passes = 1 + round % 3;
        let meshes: Vec<Mesh> = (0..n_passes).map(|_| mesh(&mut rng, 4 + round % 7)).collect();
        let tris: Vec<Vec<[u32; 3]>> = meshes.iter().map(indices).collect();
        let stages: Vec<Wavy> = (0..n_passes).map(|p| Wavy(6.0 + 11.0 * p as f32 + round as f32)).collect();
        let depth = [
            DepthState::LESS_WRITE,
            DepthState { func: CompareFunc::Less, write: false },
            DepthState { func: CompareFunc::Always, write: true },
        ][round % 3];
        let state = RenderState { cull: CullMode::None, depth, ..RenderState::default() };
        assert_eq!(state.blend, BlendState::REPLACE);
        let passes: Vec<Pass> = (0..n_passes)
            .map(|p| Pass { triangles: &tris[p], vertex: &meshes[p], fragment: &stages[p], state })
            .collect();
        let format = [ColorFormat::F32, ColorFormat::Unorm, ColorFormat::F32, ColorFormat::F16][round % 4];
        let start = target(&mut rng, (w, h), format);
        for spacing in [1, 3, 16, 64] {
            for edges in [EdgeMode::Pass, EdgeMode::Triangle] {
                for threshold in [0.0, 0.02, 0.085] {
                    let settings = AdaptiveSettings::new(spacing, threshold, edges);
                    let at = format!(
                        "round {round}, {w}×{h}, {format:?}, spacing {spacing}, {edges:?}, t {threshold}"
                    );
                    let draw = |fb: &mut Framebuffer| Some(draw_adaptive(fb, &passes, &settings).unwrap());
                    let was_fused = compare(&start, draw, &at);
                    // Where the draw can fuse, it does.
                    let can = h > 1 && matches!(format, ColorFormat::F32 | ColorFormat::Unorm);
                    assert_eq!(was_fused, can, "{at}");
                    fused += usize::from(was_fused);
                    // Every tile written is marked: clearing those leaves a cleared target.
                    let mut fb = Framebuffer::new(w as u32, h as u32, format).unwrap();
                    let stats = draw_adaptive(&mut fb, &passes, &settings).unwrap();
                    refined += usize::from(was_fused && stats.adaptive > 0 && threshold > 0.0);
                    fb.reset();
                    assert!(
                        bits(&fb) == bits(&Framebuffer::new(w as u32, h as u32, format).unwrap()),
                        "{at}"
                    );
                }
            }
        }
    }
    assert!(fused > 300 && refined > 100, "{fused} fused draws, {refined} of them refined");
}

/// The fused sum of additive passes (one per light) writes through the bands
/// as the sum's own write-through does.
#[test]
fn band_write_through_of_a_fused_sum_equals_the_write_after_the_refinement() {
    let mut rng = Rng(0x2545_f491);
    let mut fused = 0;
    for round in 0..8 {
        let (w, h) = [(130, 129), (70, 200), (64, 65), (9, 2)][round % 4];
        let m = mesh(&mut rng, 3 + round);
        let tris = indices(&m);
        let stages: Vec<Wavy> = (0..3).map(|k| Wavy(5.0 + 7.0 * k as f32 + round as f32)).collect();
        let first =
            RenderState { cull: CullMode::None, depth: DepthState::LESS_WRITE, ..RenderState::default() };
        let added = RenderState { depth: DepthState::EQUAL_NO_WRITE, blend: BlendState::ADD, ..first };
        let members: Vec<Vec<Pass>> = (0..3)
            .map(|k| {
                let state = if k == 0 { first } else { added };
                vec![Pass { triangles: &tris, vertex: &m, fragment: &stages[k], state }]
            })
            .collect();
        let members: Vec<&[Pass]> = members.iter().map(Vec::as_slice).collect();
        let format = [ColorFormat::F32, ColorFormat::Unorm][round % 2];
        let start = target(&mut rng, (w, h), format);
        for spacing in [3, 16] {
            let settings = AdaptiveSettings::new(spacing, 0.085, EdgeMode::Pass);
            let at = format!("sum, round {round}, {w}×{h}, {format:?}, spacing {spacing}");
            let draw = |fb: &mut Framebuffer| draw_adaptive_sum(fb, &members, &settings).unwrap();
            fused += usize::from(compare(&start, draw, &at));
        }
    }
    assert!(fused >= 12, "{fused} fused sums");
}
