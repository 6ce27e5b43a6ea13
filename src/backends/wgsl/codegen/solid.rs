//! A solid texture's lookup (rule `solid_texture_3d`, docs/solid-textures.md):
//! the 3-D texture the compiler bakes is rendered as its slices tiled in
//! one 2-D grid (`textures::solid`), so the unit is a 2-D texture and the
//! trilinear filter is the two slices around the coordinate, each sampled
//! bilinearly inside its tile (the coordinate clamped to the tile's
//! outer texel centres, so no neighbour tile bleeds in), blended by the
//! fraction along z — what `textures::solid::sample` computes on the CPU.
//! A texture declared `repeat` wraps the texel indices instead (GL 1.2
//! §3.8.7): the slices around z modulo their number, and within a slice
//! the four texels around (x, y), each sampled at its centre (its own
//! value), blended here. A texture declared `nearest` reads the nearest
//! texel of the nearest slice (the trilinear blend along z was taken for
//! it too).

use super::*;
use crate::ir::Sampling;
use crate::textures::solid::{SIDE, SLICES, TILES};
use crate::textures::{Filter, Wrap};

impl Gen<'_> {
    /// Unit `unit`, a tiled 3-D texture, sampled trilinearly at the vec3 `c`.
    pub(super) fn solid_sample(
        &mut self,
        b: &mut Body,
        (unit, sampling): (usize, Sampling),
        c: NH,
        level: naga::SampleLevel,
    ) -> NH {
        use naga::{BinaryOperator as B, MathFunction as F};
        if sampling.wrap == Wrap::Repeat || sampling.filter == Filter::Nearest {
            return self.solid_sample_repeated(b, unit, c, sampling, level);
        }
        let side = SIDE as f32;
        let (lo, hi) = (b.lit(0.5 / side), b.lit(1.0 - 0.5 / side));
        let x = b.emit(Expression::AccessIndex { base: c, index: 0 });
        let y = b.emit(Expression::AccessIndex { base: c, index: 1 });
        let z = b.emit(Expression::AccessIndex { base: c, index: 2 });
        let x = self.math(b, F::Clamp, &[x, lo, hi]);
        let y = self.math(b, F::Clamp, &[y, lo, hi]);
        let (n, half, zero, last) =
            (b.lit(SLICES as f32), b.lit(0.5), b.lit(0.0), b.lit(SLICES as f32 - 1.0));
        let zf = self.binop(b, B::Multiply, z, n);
        let zf = self.binop(b, B::Subtract, zf, half);
        let zf = self.math(b, F::Clamp, &[zf, zero, last]);
        let z0 = self.math(b, F::Floor, &[zf]);
        let a = self.binop(b, B::Subtract, zf, z0);
        let one = b.lit(1.0);
        let z1 = self.binop(b, B::Add, z0, one);
        let z1 = self.math(b, F::Min, &[z1, last]);
        let s0 = self.tile_sample(b, unit, x, y, z0, level);
        let s1 = self.tile_sample(b, unit, x, y, z1, level);
        let d = self.binop(b, B::Subtract, s1, s0);
        let d = self.binop(b, B::Multiply, d, a);
        self.binop(b, B::Add, s0, d)
    }

    /// Slice `z` (a whole number as a float) of the tiled grid at (x, y).
    fn tile_sample(
        &mut self,
        b: &mut Body,
        unit: usize,
        x: NH,
        y: NH,
        z: NH,
        level: naga::SampleLevel,
    ) -> NH {
        use naga::{BinaryOperator as B, MathFunction as F};
        let (tiles, inv) = (b.lit(TILES as f32), b.lit(1.0 / TILES as f32));
        let row = self.binop(b, B::Multiply, z, inv);
        let row = self.math(b, F::Floor, &[row]);
        let rows = self.binop(b, B::Multiply, row, tiles);
        let column = self.binop(b, B::Subtract, z, rows);
        let u = self.binop(b, B::Add, column, x);
        let u = self.binop(b, B::Multiply, u, inv);
        let v = self.binop(b, B::Add, row, y);
        let v = self.binop(b, B::Multiply, v, inv);
        let vec2 = self.vec_ty(2);
        let uv = b.emit(Expression::Compose { ty: vec2, components: vec![u, v] });
        self.sample_unit(b, unit, uv, None, level)
    }

    /// `solid_sample` for a texture declared `repeat` (module docs), or
    /// `nearest`: the nearest texel of the nearest slice, its indices
    /// clamped or wrapped, as `textures::solid::sample`.
    fn solid_sample_repeated(
        &mut self,
        b: &mut Body,
        unit: usize,
        c: NH,
        Sampling { filter, wrap, .. }: Sampling,
        level: naga::SampleLevel,
    ) -> NH {
        use naga::{BinaryOperator as B, MathFunction as F};
        let (x, y, z) = (
            b.emit(Expression::AccessIndex { base: c, index: 0 }),
            b.emit(Expression::AccessIndex { base: c, index: 1 }),
            b.emit(Expression::AccessIndex { base: c, index: 2 }),
        );
        if filter == Filter::Nearest {
            let n = b.lit(SLICES as f32);
            let k = self.binop(b, B::Multiply, z, n);
            let k = self.math(b, F::Floor, &[k]);
            let k = self.index(b, k, SLICES, wrap);
            let side = b.lit(SIDE as f32);
            let (i, j) = (self.binop(b, B::Multiply, x, side), self.binop(b, B::Multiply, y, side));
            let (i, j) = (self.math(b, F::Floor, &[i]), self.math(b, F::Floor, &[j]));
            let (i, j) = (self.index(b, i, SIDE, wrap), self.index(b, j, SIDE, wrap));
            let (cx, cy) = (self.texel_centre(b, i), self.texel_centre(b, j));
            return self.tile_sample(b, unit, cx, cy, k, level);
        }
        // Along z: the two slices around z·n − ½, wrapped, and the fraction.
        let (n, half, one) = (b.lit(SLICES as f32), b.lit(0.5), b.lit(1.0));
        let zf = self.binop(b, B::Multiply, z, n);
        let zf = self.binop(b, B::Subtract, zf, half);
        let z0 = self.math(b, F::Floor, &[zf]);
        let a = self.binop(b, B::Subtract, zf, z0);
        let z1 = self.binop(b, B::Add, z0, one);
        let (z0, z1) = (self.wrapped(b, z0, SLICES), self.wrapped(b, z1, SLICES));
        let s0 = self.slice_repeated(b, unit, (x, y, z0), level);
        let s1 = self.slice_repeated(b, unit, (x, y, z1), level);
        let d = self.binop(b, B::Subtract, s1, s0);
        let d = self.binop(b, B::Multiply, d, a);
        self.binop(b, B::Add, s0, d)
    }

    /// A whole number `i` modulo `n`, in [0, n).
    fn wrapped(&mut self, b: &mut Body, i: NH, n: u32) -> NH {
        use naga::{BinaryOperator as B, MathFunction as F};
        let (n, inv) = (b.lit(n as f32), b.lit(1.0 / n as f32));
        let q = self.binop(b, B::Multiply, i, inv);
        let q = self.math(b, F::Floor, &[q]);
        let q = self.binop(b, B::Multiply, q, n);
        self.binop(b, B::Subtract, i, q)
    }

    /// A whole-number texel index `i` of an axis of `n` texels, clamped
    /// to [0, n − 1] or wrapped.
    fn index(&mut self, b: &mut Body, i: NH, n: u32, wrap: Wrap) -> NH {
        match wrap {
            Wrap::Repeat => self.wrapped(b, i, n),
            Wrap::ClampToEdge => {
                let (zero, last) = (b.lit(0.0), b.lit(n as f32 - 1.0));
                self.math(b, naga::MathFunction::Clamp, &[i, zero, last])
            }
        }
    }

    /// The centre of texel `i` (wrapped) of a slice's side, in [0, 1].
    fn texel_centre(&mut self, b: &mut Body, i: NH) -> NH {
        use naga::BinaryOperator as B;
        let i = self.wrapped(b, i, SIDE);
        let (half, inv) = (b.lit(0.5), b.lit(1.0 / SIDE as f32));
        let c = self.binop(b, B::Add, i, half);
        self.binop(b, B::Multiply, c, inv)
    }

    /// Slice `z` at (x, y), repeated: the four texels around (x, y)
    /// wrapped, each read at its centre and blended bilinearly.
    fn slice_repeated(
        &mut self,
        b: &mut Body,
        unit: usize,
        (x, y, z): (NH, NH, NH),
        level: naga::SampleLevel,
    ) -> NH {
        use naga::{BinaryOperator as B, MathFunction as F};
        let side = b.lit(SIDE as f32);
        let half = b.lit(0.5);
        let one = b.lit(1.0);
        let fx = self.binop(b, B::Multiply, x, side);
        let fx = self.binop(b, B::Subtract, fx, half);
        let fy = self.binop(b, B::Multiply, y, side);
        let fy = self.binop(b, B::Subtract, fy, half);
        let (i0, j0) = (self.math(b, F::Floor, &[fx]), self.math(b, F::Floor, &[fy]));
        let (ax, ay) = (self.binop(b, B::Subtract, fx, i0), self.binop(b, B::Subtract, fy, j0));
        let (i1, j1) = (self.binop(b, B::Add, i0, one), self.binop(b, B::Add, j0, one));
        let (x0, x1) = (self.texel_centre(b, i0), self.texel_centre(b, i1));
        let (y0, y1) = (self.texel_centre(b, j0), self.texel_centre(b, j1));
        let s00 = self.tile_sample(b, unit, x0, y0, z, level);
        let s10 = self.tile_sample(b, unit, x1, y0, z, level);
        let s01 = self.tile_sample(b, unit, x0, y1, z, level);
        let s11 = self.tile_sample(b, unit, x1, y1, z, level);
        let lerp = |g: &mut Self, b: &mut Body, p: NH, q: NH, t: NH| {
            let d = g.binop(b, B::Subtract, q, p);
            let d = g.binop(b, B::Multiply, d, t);
            g.binop(b, B::Add, p, d)
        };
        let top = lerp(self, b, s00, s10, ax);
        let bottom = lerp(self, b, s01, s11, ax);
        lerp(self, b, top, bottom, ay)
    }
}
