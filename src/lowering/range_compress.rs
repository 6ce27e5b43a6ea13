//! Rule `range_compression`: a signed vector interpolated into the register
//! combiners (per fragment, or per texel in texture shading), `δ v` with `v` in [−1, 1], becomes `expand(δ compress(v))` —
//! `compress(v) = (v + 1)/2` per vertex, interpolated as an unsigned colour,
//! and the combiners' `expand_normal` input mapping undoing it per fragment.
//! This is how Kilgard sends the light vector to a GeForce 256 (Kilgard 2000
//! Section 5.2, Table 2: the primary and secondary colours are unsigned;
//! Table 3: `GL_EXPAND_NORMAL_NV`).
//!
//! Error: the compression is affine, so it commutes with linear
//! interpolation and is exact in real arithmetic; the colour interpolators
//! hold 8 bits, ±½/255 per component, which `expand` doubles: at most
//! 1/255 per component.
//!
//! A vector read only as a lookup's coordinates stays as it is: texture
//! coordinates are signed and interpolated in float (the caller passes only
//! values the combiners read).

use super::Rewriter;
use crate::ir::{Expr, Handle, MathFunction, Ty};
use crate::pipeline::ApproximationCost;
use crate::span::Span;

/// The bound on the rewritten value's error per component (module doc).
pub const ERROR_BOUND: f64 = 1.0 / 255.0;

/// `expand(δ compress(v))` for the interpolant `h = δ v`; `None` when `h`
/// is not a signed vector within [−1, 1] interpolated per fragment.
pub fn apply(r: &mut Rewriter, h: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let Expr::Interpolate { value, to } = r.m.exprs[h].clone() else { return None };
    let info = r.m.info(h);
    let signed_vector = info.ty == Ty::Vec3 && info.interval.lo < 0.0;
    let bounded = info.interval.lo >= -1.0 && info.interval.hi <= 1.0;
    if !to.is_sample() || !signed_vector || !bounded {
        return None;
    }
    let compressed = r.node(Expr::Math { fun: MathFunction::Compress, args: vec![value] }, span)?;
    let colour = r.node(Expr::Interpolate { value: compressed, to }, span)?;
    let out = r.node(Expr::Math { fun: MathFunction::Expand, args: vec![colour] }, span)?;
    r.record(
        "range_compression",
        span,
        Some(out),
        "a signed vector is interpolated range-compressed, (v + 1)/2 per vertex, and expanded in the combiners"
            .to_string(),
        ApproximationCost { texture_units: 0, passes: 0, general_combiners: 0, texels: 0 },
        Some(ERROR_BOUND),
    );
    Some(out)
}
