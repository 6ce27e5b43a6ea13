//! Rule `power_by_passes`: `x^n` per fragment, an integer power the
//! target's general combiners cannot square out in one pass (⌈log₂ n⌉
//! stages, GeForce3 Phong, Section 4.2.2) or not a power of two (the code
//! generator only squares), becomes the product `x^k · x^k · …`
//! of powers that fit (k = 2^(stages − 1), small, so that the planner's
//! product split packs as many factors into each pass as its generated
//! setup holds — three x² on a GeForce 256), which the planner splits into passes that multiply in
//! the framebuffer (Pipeline Grammar, eq. (9), `C ← C ⊕ …` with GL_DST_COLOR).
//!
//! Exact in arithmetic; the error is the framebuffer's rounding, ½ of an
//! 8-bit step per pass that multiplies, bounded by that sum (each factor
//! is at most 1).
//!
//! A power whose squarings and products fit the stages, or whose base may
//! be negative (which no 8-bit framebuffer holds), is computed in one pass
//! instead by `by_squaring` (rule `power_by_squaring`).

use super::Rewriter;
use crate::ir::{BinaryOp, Constant, Expr, Handle};
use crate::pipeline::ApproximationCost;
use crate::span::Span;

/// The largest power one pass computes on `stages` general combiners.
pub fn per_pass(stages: usize) -> u32 {
    1 << stages.saturating_sub(1).clamp(1, 5)
}

/// `x^k · … · x^r` for `x^n`, or `None` when `x^n` needs no more stages
/// than the target has, or is not an integer power.
pub fn apply(r: &mut Rewriter, h: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let stages = r.profile.combiner_limits()?.general_combiners;
    let Expr::Binary { op: BinaryOp::Pow, lhs: x, rhs } = r.m.exprs[h] else { return None };
    let Expr::Constant(c) = r.m.exprs[rhs] else { return None };
    let n = c.components[0];
    if n.fract() != 0.0 || !(2.0..=1024.0).contains(&n) {
        return None;
    }
    let (n, k) = (n as u32, per_pass(stages));
    if n <= k && n.is_power_of_two() {
        return None;
    }
    let iv = r.m.info(x).interval;
    if squarings(n) <= stages || iv.lo < 0.0 || iv.hi > 1.0 {
        // A signed base cannot cross the 8-bit framebuffer: one pass.
        return by_squaring(r, x, n, span);
    }
    // Powers of two only: the generator squares (seeds/000 Section 4.2.2).
    let mut parts = Vec::new();
    let mut rest = n;
    while rest > 0 {
        let p = (1u32 << (31 - rest.leading_zeros())).min(k);
        parts.push(pow(r, x, p, span)?);
        rest -= p;
    }
    let factors = parts.len() as u32;
    let mut product = parts[0];
    for f in &parts[1..] {
        product = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: product, rhs: *f }, span)?;
    }
    r.record(
        "power_by_passes",
        span,
        Some(product),
        format!("x^{n} is the product of {factors} powers of two of at most x^{k}, which the combiners square and the planner can multiply in the framebuffer"),
        ApproximationCost { texture_units: 0, passes: factors - 1, general_combiners: stages as u32, texels: 0 },
        Some((factors - 1) as f64 * 0.5 / 255.0),
    );
    Some(product)
}

/// The general combiners `x^n` takes as squarings and products in one
/// pass: ⌊log₂ n⌋ squarings and a product per further set bit of n.
fn squarings(n: u32) -> usize {
    (31 - n.leading_zeros() + n.count_ones() - 1) as usize
}

/// Rule `power_by_squaring`: `x^n` in one pass as the product of the
/// squarings n's set bits name (`x^6 = x^4 · x^2`, `x^4 = (x^2)^2`), so
/// that every power is a square the code generator builds (GeForce3 Phong
/// Section 4.2.2) and each squaring is shared. Exact in arithmetic; each
/// product rounds by at most ½ of a 9-bit register step.
fn by_squaring(r: &mut Rewriter, x: Handle<Expr>, n: u32, span: Span) -> Option<Handle<Expr>> {
    let mut square = x;
    let mut product: Option<Handle<Expr>> = None;
    for bit in 0..(32 - n.leading_zeros()) {
        if bit > 0 {
            square = pow(r, square, 2, span)?;
        }
        if n & (1 << bit) != 0 {
            product = Some(match product {
                None => square,
                Some(p) => r.node(Expr::Binary { op: BinaryOp::Mul, lhs: square, rhs: p }, span)?,
            });
        }
    }
    let product = product?;
    let steps = squarings(n) as u32;
    r.record(
        "power_by_squaring",
        span,
        Some(product),
        format!(
            "x^{n} is computed as {steps} squarings and products in one pass (the combiners only multiply)"
        ),
        ApproximationCost { texture_units: 0, passes: 0, general_combiners: steps, texels: 0 },
        Some(steps as f64 * 0.5 / 255.0),
    );
    Some(product)
}

fn pow(r: &mut Rewriter, x: Handle<Expr>, k: u32, span: Span) -> Option<Handle<Expr>> {
    if k == 1 {
        return Some(x);
    }
    let e = r.node(Expr::Constant(Constant::scalar(k as f64)), span)?;
    r.node(Expr::Binary { op: BinaryOp::Pow, lhs: x, rhs: e }, span)
}
