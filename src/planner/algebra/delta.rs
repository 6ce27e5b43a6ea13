//! A scalar over a sum inside δ kept outside the interpolants when the sum
//! is split across δ (the canonical form, [`super::canonical`]).

use super::{binary, node, simplify, sum_terms};
use crate::ir::{BinaryOp, Expr, Frequency, Handle, Module, Ty};
use crate::span::Span;

/// `δ(k·(a + b))` = `k·(δa + δb)` at `h`, whose δ reads `inner` (under a
/// `.rgb` retyping or a scalar's splat, `wrap`): the scalar `k` stays a
/// coefficient a form can halve or scale, as `0.8·δl₀ + 0.8·δl₁` written
/// by hand; folded into each light's colour it is none (`C·(T2³·δ l₀₁₂)`
/// with the lights ×0.8 fell back per vertex on geforce3 so, while its
/// expansion planned exactly). `None` when `inner` is no such product.
pub(super) fn scale_kept_out(
    m: &mut Module,
    h: Handle<Expr>,
    inner: Handle<Expr>,
    (retype, splat, to): (Option<Ty>, Option<Ty>, Frequency),
    span: Span,
    channels: bool,
) -> Option<Handle<Expr>> {
    let Expr::Binary { op: BinaryOp::Mul, lhs, rhs } = m.exprs[inner] else { return None };
    for (k, x) in [(lhs, rhs), (rhs, lhs)] {
        let scalar = matches!(&m.exprs[k], Expr::Constant(c) if c.ty == Ty::Scalar);
        if !scalar || sum_terms(m, x).len() < 2 {
            continue;
        }
        let wrapped = match (retype, splat) {
            (Some(ty), _) if m.info(x).ty.width() == 3 => {
                node(m, Expr::Swizzle { value: x, pattern: [0, 1, 2, 0], len: 3, ty }, span)?
            }
            (_, Some(to)) => node(m, Expr::Convert { value: x, to }, span)?,
            _ => x,
        };
        let d = node(m, Expr::Interpolate { value: wrapped, to }, span)?;
        let split = simplify(m, d, span, channels).unwrap_or(d);
        let scaled = binary(m, BinaryOp::Mul, k, split, span)?;
        if m.info(scaled).ty == m.info(h).ty {
            return Some(scaled);
        }
    }
    None
}
