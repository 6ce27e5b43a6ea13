//! A clamped affine value with its scale taken outside its offset
//! (the canonical form, [`super::canonical`]).

use super::{binary, node};
use crate::ir::{BinaryOp, Constant, Expr, Handle, MathFunction, Module, Ty};
use crate::span::Span;

/// `saturate(k·x + b)` = `saturate(k·(x + b/k))` at `h` (`b + k·x`, `x·k`
/// too), for `k` one of the combiners' output scales (2, 4) and `b` a
/// constant: the offset is added before the scale, in one general
/// combiner with `scale_by_two` or `scale_by_four` (Kilgard 2000, Section
/// 4.2, the output mapping), where `k·x` alone may leave [−1, 1] before
/// the offset brings it back — Kilgard's self-shadowing term
/// `saturate(4·(N·L) + 0.5)` was tabulated. The sum `x + b/k` may pass 1
/// where `k·(x + b/k)` passes 1 anyway, which the clamp takes. `None` for
/// another value.
pub(super) fn scale_outside_offset(m: &mut Module, h: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let Expr::Math { fun: MathFunction::Saturate, args } = m.exprs[h].clone() else { return None };
    let [value] = args[..] else { return None };
    let Expr::Binary { op: BinaryOp::Add, lhs, rhs } = m.exprs[value] else { return None };
    let constant = |m: &Module, h: Handle<Expr>| match &m.exprs[h] {
        Expr::Constant(c) => Some(*c),
        _ => None,
    };
    for (product, offset) in [(lhs, rhs), (rhs, lhs)] {
        let Some(b) = constant(m, offset) else { continue };
        let Expr::Binary { op: BinaryOp::Mul, lhs: p, rhs: q } = m.exprs[product] else { continue };
        for (k, x) in [(p, q), (q, p)] {
            let Some(k) = constant(m, k).filter(|k| k.ty == Ty::Scalar) else { continue };
            let scale = k.components[0];
            if scale != 2.0 && scale != 4.0 {
                continue;
            }
            let shifted = Constant::new(b.ty, &b.components.map(|c| c / scale)[..b.ty.width()]);
            let shifted = node(m, Expr::Constant(shifted), span)?;
            let inner = binary(m, BinaryOp::Add, x, shifted, span)?;
            let k = node(m, Expr::Constant(Constant::scalar(scale)), span)?;
            let scaled = binary(m, BinaryOp::Mul, k, inner, span)?;
            let clamped = node(m, Expr::Math { fun: MathFunction::Saturate, args: vec![scaled] }, span)?;
            return (m.info(clamped).ty == m.info(h).ty).then_some(clamped);
        }
    }
    None
}
