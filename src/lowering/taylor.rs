//! Rule `taylor_renormalization`: `normalize(δ v)` per fragment becomes
//! `w + ½ w (1 − w·w)` with `w = δ(v/|v|)` — GeForce3 Phong, Section 4.2.3,
//! Formula 6 (the Taylor series of Formula 5 cut after the linear term),
//! as `examples/phong_taylor_renormalized.shd` writes it by hand. It needs
//! no texture unit, two general combiner stages per vector.
//!
//! Error: for an interpolated unit vector of length l the result's length
//! is l(3 − l²)/2, off by (1 − l)²(2 + l)/2; l ≥ cos(θ/2) for vertex
//! vectors θ apart, which only a scene knows — so the rule states no
//! bound of its own.

use super::{per_vertex, Rewriter};
use crate::ir::{BinaryOp, Constant, Expr, Frequency, Handle, MathFunction, Ty};
use crate::pipeline::ApproximationCost;
use crate::span::Span;

/// `w + ½ w (1 − w·w)` for `normalize(x)`, `w` the interpolation of `x`
/// normalized per vertex; `None` when `x` is not a function of
/// interpolated values.
pub fn apply(r: &mut Rewriter, x: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let to = r.m.info(x).freq;
    if to != Frequency::Fragment {
        return None;
    }
    let v = per_vertex::at_vertex(&mut r.m, x)?;
    let unit = r.node(Expr::Math { fun: MathFunction::Normalize, args: vec![v] }, span)?;
    let w = r.node(Expr::Interpolate { value: unit, to }, span)?;
    let ww = r.node(Expr::Binary { op: BinaryOp::Dot, lhs: w, rhs: w }, span)?;
    let one = r.node(Expr::Constant(Constant::scalar(1.0)), span)?;
    let half = r.node(Expr::Constant(Constant::scalar(0.5)), span)?;
    let defect = r.node(Expr::Binary { op: BinaryOp::Sub, lhs: one, rhs: ww }, span)?;
    let scaled = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: half, rhs: w }, span)?;
    let step = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: scaled, rhs: defect }, span)?;
    let out = r.node(Expr::Binary { op: BinaryOp::Add, lhs: w, rhs: step }, span)?;
    debug_assert!(matches!(r.m.info(out).ty, Ty::Vec3 | Ty::Rgb));
    if !super::is_interpolant(&r.m, x) {
        r.record(
            "per_vertex",
            span,
            Some(out),
            "the vector renormalized here is computed per vertex and interpolated".into(),
            ApproximationCost::default(),
            None,
        );
    }
    r.record(
        "taylor_renormalization",
        span,
        Some(out),
        "`normalize` per fragment is the interpolated vertex unit vector renormalized by \
         w + ½w(1 − w·w) in the combiners (GeForce3 Phong, Formula 6)"
            .into(),
        ApproximationCost { texture_units: 0, passes: 0, general_combiners: 2, texels: 0 },
        None,
    );
    Some(out)
}
