//! A scalar over a sum inside δ kept outside the interpolants when the sum
//! is split across δ (the canonical form, [`super::canonical`]).

use super::{binary, node, rebuilt_bottom_up, simplify, sum_terms};
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
    scale_kept_out_of(m, h, inner, (retype, splat, to), span, (channels, false))
}

/// [`scale_kept_out`], also over one term where `any` (`δ(k·x)` =
/// `k·δx`).
fn scale_kept_out_of(
    m: &mut Module,
    h: Handle<Expr>,
    inner: Handle<Expr>,
    (retype, splat, to): (Option<Ty>, Option<Ty>, Frequency),
    span: Span,
    (channels, any): (bool, bool),
) -> Option<Handle<Expr>> {
    let Expr::Binary { op: BinaryOp::Mul, lhs, rhs } = m.exprs[inner] else { return None };
    for (k, x) in [(lhs, rhs), (rhs, lhs)] {
        let scalar = matches!(&m.exprs[k], Expr::Constant(c) if c.ty == Ty::Scalar);
        let constant = matches!(m.exprs[x], Expr::Constant(_));
        if !scalar || constant || (!any && sum_terms(m, x).len() < 2) {
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

/// What a δ of `value` reads: through a shader's vec3 result read as a
/// colour (`.rgb`, the type it is read as) and a scalar splat to a colour
/// (the type splat to), as (the value inside, the retyping, the splat).
pub(super) fn read_through(m: &Module, value: Handle<Expr>) -> (Handle<Expr>, Option<Ty>, Option<Ty>) {
    match m.exprs[value] {
        Expr::Swizzle { value: v, pattern: [0, 1, 2, _], len: 3, ty } if m.info(v).ty.width() == 3 => {
            (v, Some(ty), None)
        }
        Expr::Convert { value: v, to } if m.info(v).ty == Ty::Scalar => (v, None, Some(to)),
        _ => (value, None, None),
    }
}

/// `h` with every constant scale of a δ's one term kept outside it,
/// `δ(k·x)` = `k·δx` (interpolation is linear; Pipeline Grammar, eq.
/// (1)): a light scaled in a shader of its own (`δ(0.8·l₀)`) is then a
/// like term of the same light elsewhere (`0.7·δl₀`, a sum of lights
/// split across δ), which a multiplied-out form collects (`1.5·δl₀`), as
/// the program multiplied out by hand is. `None` when no δ has one.
pub(super) fn scales_outside(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    rebuilt_bottom_up(m, h, |m, n, span| match m.exprs[n] {
        Expr::Interpolate { value, to } if matches!(m.info(value).ty, Ty::Rgb | Ty::Rgba | Ty::Scalar) => {
            let (inner, retype, splat) = read_through(m, value);
            scale_kept_out_of(m, n, inner, (retype, splat, to), span, (false, true))
        }
        _ => None,
    })
    .filter(|c| m.info(*c).ty == m.info(h).ty)
}
