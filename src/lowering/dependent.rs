//! A dependent lookup on a target without texture shaders (the GeForce
//! 256): a table indexed by a value that reads another texel — GeForce3 Phong
//! Figure 10's `Texp(N·H)` with `H` from a normalization cube map. Two
//! rules, the more accurate first:
//!
//! - `table_function`: the table is a generator whose function the
//!   combiners can compute (`exponent_table(n)`, n a whole number: xⁿ by
//!   repeated squaring, GeForce3 Phong, Section 5.2's alternative to the lookup)
//!   → that function of the clamped coordinate. It differs from the table
//!   the meaning samples by the table's own error: the 8-bit rounding, the
//!   linear interpolation between texels, and the clamp to the edge
//!   texel's centre near 1;
//! - `per_vertex` (the coordinate): the coordinate computed at the
//!   vertices — a normalization cube map's texel as `normalize` there — and
//!   interpolated into the table by texgen ("on geforce256 a
//!   per-vertex approximation, reported as one"), no bound.
//!
//! What neither reaches (EMBM's offset texture: no function, no vertex
//! value) keeps the planner's refusal naming the missing capability.

use super::{per_vertex, Rewriter};
use crate::ir::{BinaryOp, Constant, Expr, Handle, MathFunction, Tabulated, Ty};
use crate::pipeline::ApproximationCost;
use crate::span::Span;
use crate::textures::generators::EXPONENT_TABLE_SIZE;

/// What stands for the dependent lookup `h` (`original`: as written).
pub fn apply(r: &mut Rewriter, h: Handle<Expr>, original: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let Expr::Lookup { texture, coords } = r.m.exprs[h] else { return None };
    table_function(r, texture, coords, span).or_else(|| {
        let written = r.m.operands(original)[0];
        let coords = per_vertex::apply(r, written, "the coordinate of this lookup", span)?;
        r.node(Expr::Lookup { texture, coords }, span)
    })
}

/// The stated bound of xⁿ computed against the table of `size` texels
/// (8-bit): ½ step of rounding, the chord of linear interpolation
/// h²/8·max|f″| = n(n−1)/(8 size²), and near 1 the clamp to the last
/// texel's centre, 1 − (1 − ½/size)ⁿ.
pub fn power_bound(n: f64, size: u32) -> f64 {
    let s = size as f64;
    0.5 / 255.0 + n * (n - 1.0) / (8.0 * s * s) + 1.0 - (1.0 - 0.5 / s).powf(n)
}

/// `max(0, min(1, coords))ⁿ` for an `exponent_table(n)` with n whole.
fn table_function(r: &mut Rewriter, texture: u32, coords: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let Some(Tabulated::Power(n)) = r.m.textures[texture as usize].tabulates else { return None };
    if n.fract() != 0.0 || r.m.info(coords).ty != Ty::Scalar {
        return None;
    }
    let iv = r.m.info(coords).interval;
    let mut x = coords;
    if iv.lo < 0.0 {
        let zero = r.node(Expr::Constant(Constant::new(Ty::Scalar, &[0.0])), span)?;
        x = r.node(Expr::Math { fun: MathFunction::Max, args: vec![zero, x] }, span)?;
    }
    if iv.hi > 1.0 {
        let one = r.node(Expr::Constant(Constant::new(Ty::Scalar, &[1.0])), span)?;
        x = r.node(Expr::Math { fun: MathFunction::Min, args: vec![x, one] }, span)?;
    }
    let power = if n == 1.0 {
        x
    } else {
        let exponent = r.node(Expr::Constant(Constant::new(Ty::Scalar, &[n])), span)?;
        let power = r.node(Expr::Binary { op: BinaryOp::Pow, lhs: x, rhs: exponent }, span)?;
        // Squarings the combiners run, or a product of them (rule `power`).
        super::power::apply(r, power, span).unwrap_or(power)
    };
    let value = super::as_texel(&mut r.m, texture, power, span)?;
    let name = r.m.textures[texture as usize].name.clone();
    r.record(
        "table_function",
        span,
        Some(value),
        format!("the table `{name}` (x^{n}) is indexed by a texel's value, which the target cannot do: x^{n} is computed in the combiners instead"),
        ApproximationCost::default(),
        Some(power_bound(n, EXPONENT_TABLE_SIZE)),
    );
    Some(value)
}

/// Whether `coords` has the form of a coordinate a texture-shader stage
/// computes from an earlier unit's texel (NV_texture_shader, Section
/// 3.8.13): interpolated coordinates offset by a signed texel, scaled or
/// not (`offset_2d`, Pipeline Grammar, eq. (8)), or dot products of a texel
/// with interpolated vectors (the dot-product families). The lowering
/// leaves those to the planner and rewrites the other dependent lookups
/// on geforce3 as on a target without texture shaders; whether the
/// stages fit the pass is the planner's check (`planner::realize`).
pub fn texture_shader_form(m: &crate::ir::Module, coords: Handle<Expr>) -> bool {
    let interpolated = |h: Handle<Expr>| matches!(m.exprs[h], Expr::Interpolate { .. });
    let signed_texel = |h: Handle<Expr>| match m.exprs[h] {
        Expr::Lookup { texture, .. } => m.textures.get(texture as usize).is_some_and(|t| {
            matches!(
                t.format,
                crate::parser::ast::TextureFormat::Signed8 | crate::parser::ast::TextureFormat::Signed16
            )
        }),
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } => [(lhs, rhs), (rhs, lhs)].into_iter().any(|(c, e)| {
            matches!(m.exprs[c], Expr::Constant(_)) && matches!(m.exprs[e], Expr::Lookup { .. })
        }),
        _ => false,
    };
    match &m.exprs[coords] {
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } => {
            (interpolated(*lhs) && signed_texel(*rhs)) || (interpolated(*rhs) && signed_texel(*lhs))
        }
        Expr::Compose { components, .. } => components.iter().all(|&c| {
            matches!(m.exprs[c], Expr::Binary { op: BinaryOp::Dot, lhs, rhs } if interpolated(lhs) || interpolated(rhs))
        }),
        _ => false,
    }
}
