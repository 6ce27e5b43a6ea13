//! A solid texture's lookup (rule `solid_texture_3d`, docs/solid-textures.md):
//! the 3-D texture the compiler bakes is rendered as its slices tiled in
//! one 2-D grid (`textures::solid`), so the unit is a 2-D texture and the
//! trilinear filter is the two slices around the coordinate, each sampled
//! bilinearly inside its tile (the coordinate clamped to the tile's
//! outer texel centres, so no neighbour tile bleeds in), blended by the
//! fraction along z — what `textures::solid::sample` computes on the CPU.

use super::*;
use crate::textures::solid::{SIDE, SLICES, TILES};

impl Gen<'_> {
    /// Unit `unit`, a tiled 3-D texture, sampled trilinearly at the vec3 `c`.
    pub(super) fn solid_sample(&mut self, b: &mut Body, unit: usize, c: NH, level: naga::SampleLevel) -> NH {
        use naga::{BinaryOperator as B, MathFunction as F};
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
}
