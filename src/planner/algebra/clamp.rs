//! A clamped affine value with its scale taken outside its offset
//! (the canonical form, [`super::canonical`]).

use super::{binary, node};
use crate::ir::{BinaryOp, Constant, Expr, Handle, MathFunction, Module, Ty};
use crate::span::Span;

/// `saturate(k·x + b)` = `saturate(k·(x + b/k))` at `h` (`b + k·x`, `x·k`,
/// `k·x − b` too), for `k` a scalar constant above 1 and `b` a constant: the
/// offset is added before the scale, in one general combiner with
/// `scale_by_two` or `scale_by_four` (Kilgard 2000, Section 4.2, the output
/// mapping; a `k` between them is `(k/4)·4` or `(k/2)·2`), where `k·x`
/// alone may leave [−1, 1] before the offset brings it back — Kilgard's
/// self-shadowing term `saturate(4·(N·L) + 0.5)` was tabulated. An `x`
/// that is itself `y ± c` (a contrast, `saturate(1.5·(t − ½) + ½)`) takes
/// both offsets as one, `k·(y + (±c + b/k))`. The sum may pass 1 where
/// `k·(…)` passes 1 anyway, which the clamp takes. `None` for another
/// value.
pub(super) fn scale_outside_offset(m: &mut Module, h: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let Expr::Math { fun: MathFunction::Saturate, args } = m.exprs[h].clone() else { return None };
    let [value] = args[..] else { return None };
    let (lhs, rhs, sign) = match m.exprs[value] {
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } => (lhs, rhs, 1.0),
        // k·x − b: the offset −b (`b − k·x` is left as written).
        Expr::Binary { op: BinaryOp::Sub, lhs, rhs } if constant(m, lhs).is_none() => (lhs, rhs, -1.0),
        _ => return None,
    };
    for (product, offset) in [(lhs, rhs), (rhs, lhs)] {
        let Some(b) = constant(m, offset) else { continue };
        let b = Constant::new(b.ty, &b.components.map(|v| sign * v)[..b.ty.width()]);
        let Expr::Binary { op: BinaryOp::Mul, lhs: p, rhs: q } = m.exprs[product] else { continue };
        for (k, x) in [(p, q), (q, p)] {
            let Some(k) = constant(m, k).filter(|k| k.ty == Ty::Scalar) else { continue };
            let scale = k.components[0];
            if scale <= 1.0 || !scale.is_finite() {
                continue;
            }
            let (y, c) = offset_of(m, x);
            let total = Constant::new(b.ty, &b.components.map(|v| v / scale + c)[..b.ty.width()]);
            let total = node(m, Expr::Constant(total), span)?;
            let inner = binary(m, BinaryOp::Add, y, total, span)?;
            let k = node(m, Expr::Constant(Constant::scalar(scale)), span)?;
            let scaled = binary(m, BinaryOp::Mul, k, inner, span)?;
            let clamped = node(m, Expr::Math { fun: MathFunction::Saturate, args: vec![scaled] }, span)?;
            return (m.info(clamped).ty == m.info(h).ty).then_some(clamped);
        }
    }
    None
}

fn constant(m: &Module, h: Handle<Expr>) -> Option<Constant> {
    match &m.exprs[h] {
        Expr::Constant(c) => Some(*c),
        _ => None,
    }
}

/// `x` as `y + c`: `y ± c` with `c` a scalar constant split apart, any
/// other value with `c` = 0.
fn offset_of(m: &Module, x: Handle<Expr>) -> (Handle<Expr>, f64) {
    if let Expr::Binary { op: op @ (BinaryOp::Add | BinaryOp::Sub), lhs, rhs } = m.exprs[x] {
        let scalar = |h| constant(m, h).filter(|c| c.ty == Ty::Scalar).map(|c| c.components[0]);
        match (scalar(lhs), scalar(rhs), op) {
            (_, Some(c), BinaryOp::Add) => return (lhs, c),
            (_, Some(c), BinaryOp::Sub) => return (lhs, -c),
            (Some(c), None, BinaryOp::Add) => return (rhs, c),
            _ => {}
        }
    }
    (x, 0.0)
}
