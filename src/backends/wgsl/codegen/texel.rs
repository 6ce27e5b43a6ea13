//! Texels the shader filters itself, where the CPU renderer's sampler is
//! not the texture unit's model and the unit would not agree with it:
//!
//! - **Rendered textures in hardware precision.** The CPU's `fixed9`
//!   samples a texture the plan renders (a `bake` table, a fat texel's
//!   member, a texture shaded over its texels) at level 0 in float
//!   (`textures::sampling`, GL's bilinear), where an 8-bit texture unit
//!   filters in 8.8 fixed point with 8-bit results (lavapipe; the
//!   GeForces). A power after the lookup magnifies that step: the fat
//!   texture map's `(N·H)^16` was 13/255 off on 6% of its pixels. So the
//!   shader loads the four texels and weighs them in f32, as
//!   `Level::sample_bilinear` does (clamped to the edge: a texture
//!   declared `clamp`; one declared `repeat` is read through the unit's
//!   sampler, which wraps it as the CPU does).
//! - **A scene's dual-paraboloid map** (Heidrich & Seidel 1999, Section
//!   4.1) bound to a program's texture and looked up by direction: the
//!   two faces are the layers of a 2-D array (front, back), the direction
//!   picks the face and the coordinates as `textures::paraboloid_uv` does,
//!   and the texel is filtered at level 0 in float as above
//!   (`DualParaboloid::sample`).

use std::collections::BTreeSet;

use super::*;
use crate::textures::Filter;

/// What the scene binds that changes the shader (`gpu::scene_run`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SceneBindings {
    /// Textures bound to a scene's dual-paraboloid map (`DualParaboloid`),
    /// by name: read by direction from a two-layer array (front, back).
    pub dual_paraboloid: BTreeSet<String>,
}

/// How a texture unit is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum UnitRead {
    /// Through the unit's sampler.
    Sampler,
    /// At level 0, filtered in f32 by the shader (a texture the plan renders,
    /// in hardware precision), at texture coordinates.
    Float(Filter),
    /// A dual-paraboloid map by direction, then filtered as [`UnitRead::Float`].
    DualParaboloid(Filter),
}

impl Gen<'_> {
    /// How the unit of `lookup` is read: see the module docs.
    pub(super) fn unit_read(&self, lookup: ir::Handle<Expr>) -> UnitRead {
        let Some(Expr::Lookup { texture, .. }) = self.m.exprs.arena().get(lookup) else {
            return UnitRead::Sampler;
        };
        let tex = &self.m.textures[*texture as usize];
        // Level 0 only, so trilinear is bilinear there (`Texture2D::sample`).
        let filter = if tex.sampling.filter == Filter::Nearest { Filter::Nearest } else { Filter::Bilinear };
        if self.bindings.dual_paraboloid.contains(&tex.name) {
            return UnitRead::DualParaboloid(filter);
        }
        let rendered = self
            .planned
            .plan
            .passes
            .iter()
            .any(|p| matches!(&p.target, RenderTarget::Texture { name } if *name == tex.name));
        let flat = matches!(tex.kind, TextureKind::Tex1d | TextureKind::Tex2d);
        // Clamped to the edge, as this filter reads; a texture declared
        // `repeat` wraps through the unit's sampler (as the CPU wraps it).
        let clamped = tex.sampling.wrap == crate::textures::Wrap::ClampToEdge;
        if self.precision == Precision::Fixed9 && rendered && flat && !tex.sampling.mipmap && clamped {
            UnitRead::Float(filter)
        } else {
            UnitRead::Sampler
        }
    }

    /// The filter the shader applies to `unit` at coordinates of type `ct`,
    /// if it filters it ([`UnitRead::Float`]; the CPU reads a rendered
    /// texture at a position or by a 3-D coordinate otherwise).
    pub(super) fn shader_filter(&self, unit: usize, ct: Ty) -> Option<Filter> {
        match self.unit_reads.get(unit) {
            Some(UnitRead::Float(f)) if matches!(ct, Ty::Scalar | Ty::Vec2) => Some(*f),
            _ => None,
        }
    }

    /// A dual-paraboloid lookup of unit `unit` by direction `c` (of width
    /// `wc`; fewer than three components are padded with zeros), as the
    /// CPU's `DualParaboloid::sample`: the non-finite components 0, the
    /// direction normalized ((0, 0, 1) when it has no length), the front
    /// face where z ≥ 0, (u, v) = ½((x, y)/(1 + |z|) + 1) on it.
    pub(super) fn dual_paraboloid_sample(&mut self, b: &mut Body, unit: usize, c: NH, wc: usize) -> R<NH> {
        use naga::BinaryOperator as B;
        let UnitRead::DualParaboloid(filter) = self.unit_reads[unit] else {
            return Err(GenError::Internal(format!("unit {unit} is not a dual-paraboloid map")));
        };
        let d = if wc >= 3 {
            self.narrow(b, c, wc, 3)
        } else {
            let padded = self.widen_zero(b, c, wc);
            self.narrow(b, padded, 4, 3)
        };
        let d = self.finite_or_zero(b, d, 3);
        let len = self.math(b, naga::MathFunction::Dot, &[d, d]);
        let len = self.math(b, naga::MathFunction::Sqrt, &[len]);
        let zero = b.lit(0.0);
        let positive = self.binop(b, B::Greater, len, zero);
        let finite = self.is_finite(b, len);
        let ok = self.binop(b, B::LogicalAnd, positive, finite);
        let len3 = b.emit(Expression::Splat { size: VectorSize::Tri, value: len });
        let unit_d = self.binop(b, B::Divide, d, len3);
        let vec3 = self.vec_ty(3);
        let one = b.lit(1.0);
        let z_axis = b.emit(Expression::Compose { ty: vec3, components: vec![zero, zero, one] });
        let n = b.emit(Expression::Select { condition: ok, accept: unit_d, reject: z_axis });
        let z = b.emit(Expression::AccessIndex { base: n, index: 2 });
        let front = self.binop(b, B::GreaterEqual, z, zero);
        let abs_z = self.math(b, naga::MathFunction::Abs, &[z]);
        let denom = self.binop(b, B::Add, one, abs_z);
        let denom = b.emit(Expression::Splat { size: VectorSize::Bi, value: denom });
        let xy = self.narrow(b, n, 3, 2);
        let xy = self.binop(b, B::Divide, xy, denom);
        let one2 = b.emit(Expression::Splat { size: VectorSize::Bi, value: one });
        let xy = self.binop(b, B::Add, xy, one2);
        let half = b.lit(0.5);
        let half2 = b.emit(Expression::Splat { size: VectorSize::Bi, value: half });
        let uv = self.binop(b, B::Multiply, half2, xy);
        let (front_layer, back_layer) =
            (b.plain(Expression::Literal(Literal::I32(0))), b.plain(Expression::Literal(Literal::I32(1))));
        let layer = b.emit(Expression::Select { condition: front, accept: front_layer, reject: back_layer });
        Ok(self.float_filtered(b, unit, uv, Some(layer), filter))
    }

    /// `textureLoad`s of unit `unit` (in `layer` of an array) at 2-D
    /// coordinates `uv`, weighed in f32 as the CPU's `Level::sample_nearest`
    /// and `sample_bilinear` do, clamped to the edge: f = u·size − ½ (no ½
    /// for nearest), its floor the first texel, its fraction the weight.
    pub(super) fn float_filtered(
        &mut self,
        b: &mut Body,
        unit: usize,
        uv: NH,
        layer: Option<NH>,
        filter: Filter,
    ) -> NH {
        use naga::BinaryOperator as B;
        let (tv, _, _, _) = self.units[unit];
        let image = b.plain(Expression::GlobalVariable(tv));
        let level = b.plain(Expression::Literal(Literal::I32(0)));
        let size_u =
            b.emit(Expression::ImageQuery { image, query: naga::ImageQuery::Size { level: Some(level) } });
        let size_f = b.emit(Expression::As { expr: size_u, kind: ScalarKind::Float, convert: Some(4) });
        let size_i = b.emit(Expression::As { expr: size_u, kind: ScalarKind::Sint, convert: Some(4) });
        let ivec = |b: &mut Body, v: i32| {
            let l = b.plain(Expression::Literal(Literal::I32(v)));
            b.emit(Expression::Splat { size: VectorSize::Bi, value: l })
        };
        let (zero_i, one_i) = (ivec(b, 0), ivec(b, 1));
        let last = self.binop(b, B::Subtract, size_i, one_i);
        let mut f = self.binop(b, B::Multiply, uv, size_f);
        if filter != Filter::Nearest {
            let half = b.lit(0.5);
            let half = b.emit(Expression::Splat { size: VectorSize::Bi, value: half });
            f = self.binop(b, B::Subtract, f, half);
        }
        // `finite_or_zero`: a non-finite coordinate is 0, the rest within ±1e9.
        let f = self.finite_or_zero(b, f, 2);
        let (lo, hi) = (b.lit(-1e9), b.lit(1e9));
        let (lo, hi) = (
            b.emit(Expression::Splat { size: VectorSize::Bi, value: lo }),
            b.emit(Expression::Splat { size: VectorSize::Bi, value: hi }),
        );
        let f = self.math(b, naga::MathFunction::Clamp, &[f, lo, hi]);
        let x0 = self.math(b, naga::MathFunction::Floor, &[f]);
        let i0 = b.emit(Expression::As { expr: x0, kind: ScalarKind::Sint, convert: Some(4) });
        let c0 = self.math(b, naga::MathFunction::Clamp, &[i0, zero_i, last]);
        let load = |b: &mut Body, at: NH| {
            b.emit(Expression::ImageLoad {
                image,
                coordinate: at,
                array_index: layer,
                sample: None,
                level: Some(level),
            })
        };
        if filter == Filter::Nearest {
            return load(b, c0);
        }
        let a = self.binop(b, B::Subtract, f, x0);
        let i1 = self.binop(b, B::Add, i0, one_i);
        let c1 = self.math(b, naga::MathFunction::Clamp, &[i1, zero_i, last]);
        let ivec2 = self.ty(TypeInner::Vector { size: VectorSize::Bi, scalar: Scalar::I32 });
        let component = |b: &mut Body, v: NH, i: u32| b.emit(Expression::AccessIndex { base: v, index: i });
        let (x0i, y0i, x1i, y1i) =
            (component(b, c0, 0), component(b, c0, 1), component(b, c1, 0), component(b, c1, 1));
        let c10 = b.emit(Expression::Compose { ty: ivec2, components: vec![x1i, y0i] });
        let c01 = b.emit(Expression::Compose { ty: ivec2, components: vec![x0i, y1i] });
        let (t00, t10, t01, t11) = (load(b, c0), load(b, c10), load(b, c01), load(b, c1));
        let ax = component(b, a, 0);
        let ay = component(b, a, 1);
        let ax = b.emit(Expression::Splat { size: VectorSize::Quad, value: ax });
        let ay = b.emit(Expression::Splat { size: VectorSize::Quad, value: ay });
        let top = self.lerp(b, t00, t10, ax);
        let bottom = self.lerp(b, t01, t11, ax);
        self.lerp(b, top, bottom, ay)
    }

    /// `p + t·(q − p)`, the CPU's order of operations.
    fn lerp(&mut self, b: &mut Body, p: NH, q: NH, t: NH) -> NH {
        use naga::BinaryOperator as B;
        let d = self.binop(b, B::Subtract, q, p);
        let d = self.binop(b, B::Multiply, t, d);
        self.binop(b, B::Add, p, d)
    }

    /// Whether scalar `x` is finite, from its bits (WGSL lets a compiler
    /// assume no infinities or NaN in float comparisons).
    fn is_finite(&mut self, b: &mut Body, x: NH) -> NH {
        let bits = b.emit(Expression::As { expr: x, kind: ScalarKind::Uint, convert: None });
        let magnitude = b.plain(Expression::Literal(Literal::U32(0x7fff_ffff)));
        let bits = self.binop(b, naga::BinaryOperator::And, bits, magnitude);
        let infinity = b.plain(Expression::Literal(Literal::U32(0x7f80_0000)));
        self.binop(b, naga::BinaryOperator::Less, bits, infinity)
    }

    /// `v` (width `w` ≥ 2) with each non-finite component 0, tested on the bits.
    fn finite_or_zero(&mut self, b: &mut Body, v: NH, w: usize) -> NH {
        let splat_u = |b: &mut Body, x: u32| {
            let l = b.plain(Expression::Literal(Literal::U32(x)));
            b.emit(Expression::Splat { size: size(w), value: l })
        };
        let bits = b.emit(Expression::As { expr: v, kind: ScalarKind::Uint, convert: None });
        let magnitude = splat_u(b, 0x7fff_ffff);
        let bits = self.binop(b, naga::BinaryOperator::And, bits, magnitude);
        let infinity = splat_u(b, 0x7f80_0000);
        let finite = self.binop(b, naga::BinaryOperator::Less, bits, infinity);
        let zero = b.lit(0.0);
        let zero = b.emit(Expression::Splat { size: size(w), value: zero });
        b.emit(Expression::Select { condition: finite, accept: v, reject: zero })
    }
}
