//! Coordinate spaces: from the source's texture-space and clip conventions
//! to wgpu's (y down in texture space, z in [0, 1]), rendering into a
//! texture by its coordinates (Pipeline Grammar, eq. (13)), and projective
//! texture coordinates.

use super::*;

impl Gen<'_> {
    /// `(½ x/w + ½, ½ − ½ y/w)` of a clip-space position.
    pub(super) fn projective_uv(&mut self, b: &mut Body, p: NH) -> NH {
        let x = b.emit(Expression::AccessIndex { base: p, index: 0 });
        let y = b.emit(Expression::AccessIndex { base: p, index: 1 });
        let w = b.emit(Expression::AccessIndex { base: p, index: 3 });
        let half = b.lit(0.5);
        let xw = self.binop(b, naga::BinaryOperator::Divide, x, w);
        let yw = self.binop(b, naga::BinaryOperator::Divide, y, w);
        let xh = self.binop(b, naga::BinaryOperator::Multiply, xw, half);
        let u = self.binop(b, naga::BinaryOperator::Add, xh, half);
        let yh = self.binop(b, naga::BinaryOperator::Multiply, yw, half);
        let v = self.binop(b, naga::BinaryOperator::Subtract, half, yh);
        let vec2 = self.vec_ty(2);
        b.emit(Expression::Compose { ty: vec2, components: vec![u, v] })
    }
}

/// Rendering into a texture by its coordinates (Pipeline Grammar, eq. (13)): the clip
/// position (2u − 1, 1 − 2v, 0, 1).
pub(super) fn texture_space_clip(b: &mut Body, v: NH, vec4: naga::Handle<Type>) -> NH {
    let u = b.emit(Expression::AccessIndex { base: v, index: 0 });
    let vv = b.emit(Expression::AccessIndex { base: v, index: 1 });
    let (two, one, zero) = (b.lit(2.0), b.lit(1.0), b.lit(0.0));
    let u2 = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: u, right: two });
    let x = b.emit(Expression::Binary { op: naga::BinaryOperator::Subtract, left: u2, right: one });
    let v2 = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: vv, right: two });
    let y = b.emit(Expression::Binary { op: naga::BinaryOperator::Subtract, left: one, right: v2 });
    b.emit(Expression::Compose { ty: vec4, components: vec![x, y, zero, one] })
}

/// GL clip z (−w..w) → wgpu (0..w): z′ = ½z + ½w.
pub(super) fn wgpu_clip(b: &mut Body, clip: NH, vec4: naga::Handle<Type>) -> NH {
    let xy = b.emit(Expression::Swizzle {
        size: VectorSize::Bi,
        vector: clip,
        pattern: [COMP[0], COMP[1], COMP[0], COMP[0]],
    });
    let z = b.emit(Expression::AccessIndex { base: clip, index: 2 });
    let w = b.emit(Expression::AccessIndex { base: clip, index: 3 });
    let half = b.lit(0.5);
    let zw = b.emit(Expression::Binary { op: naga::BinaryOperator::Add, left: z, right: w });
    let z2 = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: zw, right: half });
    b.emit(Expression::Compose { ty: vec4, components: vec![xy, z2, w] })
}

/// A screen or texel pass's texture coordinate from its rectangle:
/// (½x + ½, ½ − ½y), v = 0 at the top row.
pub(super) fn texel_uv(b: &mut Body, q: NH, vec4: naga::Handle<Type>) -> NH {
    let x = b.emit(Expression::AccessIndex { base: q, index: 0 });
    let y = b.emit(Expression::AccessIndex { base: q, index: 1 });
    let (half, zero) = (b.lit(0.5), b.lit(0.0));
    let xh = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: x, right: half });
    let u = b.emit(Expression::Binary { op: naga::BinaryOperator::Add, left: xh, right: half });
    let yh = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: y, right: half });
    let v = b.emit(Expression::Binary { op: naga::BinaryOperator::Subtract, left: half, right: yh });
    b.emit(Expression::Compose { ty: vec4, components: vec![u, v, zero, zero] })
}
