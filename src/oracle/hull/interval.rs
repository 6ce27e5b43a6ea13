//! Interval arithmetic over the operations of the language (Moore 1966):
//! each operation maps its operands' intervals to one holding every value
//! it takes on them — sums, products at their corners, monotone functions
//! at their ends, clamps, dot products, comparisons decided or left open.
//! The hull falls back to it (`mod.rs`) where an operation is not affine
//! in its operands (`affine.rs`).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use super::super::ops::{self, V};
use super::super::program::uv;
use super::super::Unsupported;
use crate::ir::{BinaryOp, Expr, MathFunction, Module, Ty, UnaryOp};
use crate::parser::ast::CombineMode;

/// Per channel, the least and the greatest value.
pub type R = (V, V);

/// One interval.
pub type I = (f64, f64);

pub(super) fn point(v: V) -> R {
    (v, v)
}

pub(super) fn is_point(r: &R) -> bool {
    (0..4).all(|c| r.0[c].to_bits() == r.1[c].to_bits() || r.0[c] == r.1[c])
}

pub(super) fn lane(r: &R, c: usize) -> I {
    (r.0[c], r.1[c])
}

pub(super) fn lanes(f: impl Fn(usize) -> I) -> R {
    let v: [I; 4] = std::array::from_fn(f);
    (v.map(|i| i.0), v.map(|i| i.1))
}

pub(super) fn splat(i: I) -> R {
    ([i.0; 4], [i.1; 4])
}

pub(super) fn hull_of(values: impl IntoIterator<Item = f64>) -> I {
    values.into_iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)))
}

pub(super) fn add(a: I, b: I) -> I {
    (a.0 + b.0, a.1 + b.1)
}

pub(super) fn sub(a: I, b: I) -> I {
    (a.0 - b.1, a.1 - b.0)
}

pub(super) fn mul(a: I, b: I) -> I {
    hull_of([a.0 * b.0, a.0 * b.1, a.1 * b.0, a.1 * b.1])
}

pub(super) fn div(a: I, b: I) -> I {
    if b.0 > 0.0 || b.1 < 0.0 {
        mul(a, (1.0 / b.1, 1.0 / b.0))
    } else {
        (f64::NEG_INFINITY, f64::INFINITY)
    }
}

pub(super) fn square(a: I) -> I {
    if a.0 >= 0.0 {
        (a.0 * a.0, a.1 * a.1)
    } else if a.1 <= 0.0 {
        (a.1 * a.1, a.0 * a.0)
    } else {
        (0.0, (a.0 * a.0).max(a.1 * a.1))
    }
}

pub(super) fn increasing(a: I, f: impl Fn(f64) -> f64) -> I {
    (f(a.0), f(a.1))
}

pub(super) fn constant(x: f64) -> I {
    (x, x)
}

/// The truth of a value (non-zero) as an interval of 0 and 1.
pub(super) fn truth(a: I) -> I {
    if a.0 > 0.0 || a.1 < 0.0 {
        (1.0, 1.0)
    } else if a.0 == 0.0 && a.1 == 0.0 {
        (0.0, 0.0)
    } else {
        (0.0, 1.0)
    }
}

/// A comparison decided where the intervals say so, else open.
fn decided(surely: bool, surely_not: bool) -> I {
    match (surely, surely_not) {
        (true, _) => (1.0, 1.0),
        (false, true) => (0.0, 0.0),
        _ => (0.0, 1.0),
    }
}

fn dot(a: &R, b: &R, width: usize) -> I {
    (0..width.min(4)).fold(constant(0.0), |s, c| add(s, mul(lane(a, c), lane(b, c))))
}

/// The hull of a computing node from its operands' hulls (`ops::compute`'s
/// arithmetic, on intervals). `None` for `c ? a` where `c` is surely false.
pub(super) fn compute(m: &Module, e: &Expr, ty: Ty, o: &[R]) -> Result<Option<R>, Unsupported> {
    if o.iter().all(is_point) {
        let values: Vec<V> = o.iter().map(|r| r.0).collect();
        return Ok(ops::compute(m, e, ty, &values).map(point));
    }
    // Operations that move each lane by lanes alone, never decreasing.
    let monotone = || -> Result<Option<R>, Unsupported> {
        let (lo, hi): (Vec<V>, Vec<V>) = o.iter().copied().unzip();
        Ok(ops::compute(m, e, ty, &lo).zip(ops::compute(m, e, ty, &hi)))
    };
    let r = match e {
        Expr::Unary { op: UnaryOp::Neg, .. } => lanes(|c| (-o[0].1[c], -o[0].0[c])),
        Expr::Unary { op: UnaryOp::Not, .. } => {
            let t = truth(lane(&o[0], 0));
            splat((1.0 - t.1, 1.0 - t.0))
        }
        Expr::Binary { op, lhs, .. } => binary(*op, &o[0], &o[1], m.info(*lhs).ty.width())?,
        Expr::Combine { mode: CombineMode::Replace, .. }
        | Expr::Swizzle { .. }
        | Expr::Compose { .. }
        | Expr::Convert { .. } => return monotone(),
        Expr::Combine { mode, .. } => texture_env(*mode, ty.width(), &o[0], &o[1]),
        Expr::Math { fun, args } => math(*fun, o, m.info(args[0]).ty.width())?,
        Expr::Select { reject, .. } => {
            let c = lane(&o[0], 0);
            match (truth(c), reject) {
                ((1.0, 1.0), _) => o[1],
                ((0.0, 0.0), Some(_)) => o[2],
                ((0.0, 0.0), None) => return Ok(None),
                (_, Some(_)) => lanes(|k| hull_of([o[1].0[k], o[1].1[k], o[2].0[k], o[2].1[k]])),
                (_, None) => {
                    return Err(Unsupported::new(
                        "a condition that moves with a level of detail and keeps the destination",
                    ))
                }
            }
        }
        _ => return Err(Unsupported::new("a node of this kind over a level-of-detail range")),
    };
    Ok(Some(r))
}

fn binary(op: BinaryOp, a: &R, b: &R, width: usize) -> Result<R, Unsupported> {
    use BinaryOp::*;
    let (x, y) = (lane(a, 0), lane(b, 0));
    Ok(match op {
        Dot => splat(dot(a, b, width)),
        Add => lanes(|c| add(lane(a, c), lane(b, c))),
        Sub => lanes(|c| sub(lane(a, c), lane(b, c))),
        Mul => lanes(|c| mul(lane(a, c), lane(b, c))),
        Div => lanes(|c| div(lane(a, c), lane(b, c))),
        // x^y = exp(y ln x) for x ≥ 0: y ln x is bilinear, so its extremes
        // (and exp's) lie at the corners.
        Pow if (0..4).all(|c| a.0[c] >= 0.0) => lanes(|c| {
            let (x, y) = (lane(a, c), lane(b, c));
            hull_of([x.0.powf(y.0), x.0.powf(y.1), x.1.powf(y.0), x.1.powf(y.1)])
        }),
        Pow => {
            return Err(Unsupported::new(
                "a power of a value that may be negative over a level-of-detail range",
            ))
        }
        Lt => splat(decided(x.1 < y.0, x.0 >= y.1)),
        Le => splat(decided(x.1 <= y.0, x.0 > y.1)),
        Gt => splat(decided(x.0 > y.1, x.1 <= y.0)),
        Ge => splat(decided(x.0 >= y.1, x.1 < y.0)),
        Eq => splat(decided(false, x.1 < y.0 || y.1 < x.0)),
        Ne => splat(decided(x.1 < y.0 || y.1 < x.0, false)),
        And => {
            let (p, q) = (truth(x), truth(y));
            splat((p.0.min(q.0), p.1.min(q.1)))
        }
        Or => {
            let (p, q) = (truth(x), truth(y));
            splat((p.0.max(q.0), p.1.max(q.1)))
        }
    })
}

pub(super) fn math(fun: MathFunction, o: &[R], width: usize) -> Result<R, Unsupported> {
    use MathFunction::*;
    let a = &o[0];
    let each = |f: &dyn Fn(I) -> I| lanes(|c| f(lane(a, c)));
    let length = || {
        let s = (0..width.min(4)).fold(constant(0.0), |s, c| add(s, square(lane(a, c))));
        increasing(s, f64::sqrt)
    };
    Ok(match fun {
        Normalize => lanes(|c| if c >= width.min(4) { (-1.0, 1.0) } else { normalized(a, c, width) }),
        Length => splat(length()),
        Cross => {
            let (x, y) = (a, &o[1]);
            let term = |i: usize, j: usize| sub(mul(lane(x, i), lane(y, j)), mul(lane(x, j), lane(y, i)));
            let (c0, c1, c2) = (term(1, 2), term(2, 0), term(0, 1));
            lanes(|c| [c0, c1, c2, constant(0.0)][c])
        }
        Reflect => {
            let twice = mul(constant(2.0), dot(&o[1], a, 3));
            lanes(|c| sub(lane(a, c), mul(twice, lane(&o[1], c))))
        }
        Max => lanes(|c| (a.0[c].max(o[1].0[c]), a.1[c].max(o[1].1[c]))),
        Min => lanes(|c| (a.0[c].min(o[1].0[c]), a.1[c].min(o[1].1[c]))),
        Clamp => lanes(|c| (a.0[c].max(o[1].0[c]).min(o[2].0[c]), a.1[c].max(o[1].1[c]).min(o[2].1[c]))),
        Saturate => each(&|x| increasing(x, |v| v.clamp(0.0, 1.0))),
        Abs => each(&|x| {
            if x.0 >= 0.0 || x.1 <= 0.0 {
                hull_of([x.0.abs(), x.1.abs()])
            } else {
                (0.0, x.1.max(-x.0))
            }
        }),
        Sign => each(&|x| increasing(x, f64::signum)),
        Sqrt => each(&|x| increasing(x, f64::sqrt)),
        Rsqrt => each(&|x| (x.1.sqrt().recip(), x.0.sqrt().recip())),
        Exp => each(&|x| increasing(x, f64::exp)),
        Log => each(&|x| increasing(x, f64::ln)),
        Sin => each(&|x| wave(x, f64::sin, FRAC_PI_2)),
        Cos => each(&|x| wave(x, f64::cos, 0.0)),
        Floor => each(&|x| increasing(x, f64::floor)),
        Fract => {
            each(&|x| if x.0.floor() == x.1.floor() { increasing(x, |v| v - v.floor()) } else { (0.0, 1.0) })
        }
        Expand => each(&|x| increasing(x, |v| 2.0 * v - 1.0)),
        HalfBias => each(&|x| increasing(x, |v| v - 0.5)),
        Compress => each(&|x| increasing(x, |v| 0.5 * (v + 1.0))),
        // step(edge, x) = x ≥ edge: rising in x, falling in the edge.
        Step => lanes(|c| {
            let (edge, x) = (lane(a, c), lane(&o[1], c));
            decided(x.0 >= edge.1, x.1 < edge.0)
        }),
        // a + (b − a)·t is multilinear in (a, b, t): extremes at corners.
        Mix => {
            lanes(|c| {
                let (x, y, t) = (lane(a, c), lane(&o[1], c), lane(&o[2], c));
                hull_of([x.0, x.1].into_iter().flat_map(|p| {
                    [y.0, y.1].into_iter().flat_map(move |q| [t.0, t.1].map(|s| p + (q - p) * s))
                }))
            })
        }
        Smoothstep if is_point(a) && is_point(&o[1]) => lanes(|c| {
            let (e0, e1, x) = (a.0[c], o[1].0[c], lane(&o[2], c));
            let f = |v: f64| {
                let t = ((v - e0) / (e1 - e0)).clamp(0.0, 1.0);
                t * t * (3.0 - 2.0 * t)
            };
            hull_of([f(x.0), f(x.1)])
        }),
        // Moving edges, surely ordered (`e₀ < e₁` on every corner): the
        // clamped quotient never decreases in `x` and never increases in
        // either edge, so its extremes lie at two corners. Edges that may
        // meet or cross leave GLSL's result undefined; [0, 1] holds what
        // the formula gives for any ordered or reversed pair.
        Smoothstep => lanes(|c| {
            let (e0, e1, x) = (lane(a, c), lane(&o[1], c), lane(&o[2], c));
            let f = |e0: f64, e1: f64, v: f64| {
                let t = ((v - e0) / (e1 - e0)).clamp(0.0, 1.0);
                t * t * (3.0 - 2.0 * t)
            };
            if e0.1 < e1.0 {
                hull_of([f(e0.1, e1.1, x.0), f(e0.0, e1.0, x.1)])
            } else {
                (0.0, 1.0)
            }
        }),
    })
}

/// Lane `c` of `normalize(x)` over the box `a` of its first `width`
/// lanes: `g(x, ρ) = x/√(x² + ρ)`, `ρ` the sum of the other lanes'
/// squares, never decreases in `x` (`∂g/∂x = ρ/(x² + ρ)^(3/2)`; at `ρ = 0`
/// it is `sign x`, with `g(0, 0) = 0` as the language defines
/// `normalize(0)`) and is monotone in `ρ` for each `x` (falling where
/// `x > 0`, rising where `x < 0`): its least lies at the lane's least and an
/// end of `ρ`, its greatest at the lane's greatest and an end of `ρ` —
/// whether or not the length may reach 0.
pub(super) fn normalized(a: &R, c: usize, width: usize) -> I {
    let rest = (0..width.min(4)).filter(|&k| k != c).fold(constant(0.0), |s, k| add(s, square(lane(a, k))));
    let g = |x: f64, rho: f64| {
        let n = (x * x + rho).sqrt();
        if n == 0.0 {
            0.0
        } else {
            x / n
        }
    };
    let x = lane(a, c);
    (g(x.0, rest.0).min(g(x.0, rest.1)), g(x.1, rest.0).max(g(x.1, rest.1)))
}

/// `sin` or `cos` (`f`, its crest at `crest`, its trough half a turn
/// before) over `x`: its ends, and ±1 where the interval holds a crest or
/// a trough (plus any number of turns); [−1, 1] for an interval a turn or
/// wider, or not finite.
pub(super) fn wave(x: I, f: fn(f64) -> f64, crest: f64) -> I {
    let narrow = x.1 - x.0 < TAU;
    if !narrow {
        return (-1.0, 1.0);
    }
    let holds = |u: f64| u + TAU * ((x.0 - u) / TAU).ceil() <= x.1;
    let (lo, hi) = hull_of([f(x.0), f(x.1)]);
    (if holds(crest - PI) { -1.0 } else { lo }, if holds(crest) { 1.0 } else { hi })
}

/// `t ⊕[mode] f` on intervals (`ops::texture_env`; `replace` is monotone
/// and taken apart). The texture's alpha in `decal` and `interpolate` is
/// taken as a variable of its own: a corner hull of a multilinear form.
fn texture_env(mode: CombineMode, width: usize, t: &R, f: &R) -> R {
    let alpha = width == 4;
    let at = if alpha { lane(t, 3) } else { constant(1.0) };
    let with_alpha = |r: R, a: I| if alpha { lanes(|c| if c == 3 { a } else { lane(&r, c) }) } else { r };
    let blend = |c: usize| {
        let (x, y) = (lane(t, c), lane(f, c));
        hull_of([x.0, x.1].into_iter().flat_map(|p| {
            [y.0, y.1].into_iter().flat_map(move |q| [at.0, at.1].map(|s| p * s + q * (1.0 - s)))
        }))
    };
    let dot3 = || {
        let n = if width == 1 { 1 } else { 3 };
        let half = constant(0.5);
        let s = (0..n).fold(constant(0.0), |s, c| add(s, mul(sub(lane(t, c), half), sub(lane(f, c), half))));
        mul(constant(4.0), s)
    };
    match mode {
        CombineMode::Modulate => lanes(|c| mul(lane(t, c), lane(f, c))),
        CombineMode::Add => lanes(|c| add(lane(t, c), lane(f, c))),
        CombineMode::AddSigned => lanes(|c| sub(add(lane(t, c), lane(f, c)), constant(0.5))),
        CombineMode::Subtract => lanes(|c| sub(lane(t, c), lane(f, c))),
        CombineMode::Decal => with_alpha(lanes(blend), lane(f, 3)),
        CombineMode::Interpolate => lanes(blend),
        CombineMode::Blend => with_alpha(
            lanes(|c| mul(lane(f, c), sub(constant(1.0), lane(t, c)))),
            mul(lane(t, 3), lane(f, 3)),
        ),
        CombineMode::Dot3Rgb => with_alpha(splat(dot3()), mul(lane(t, 3), lane(f, 3))),
        CombineMode::Dot3Rgba => splat(dot3()),
        // Monotone: taken apart in `compute`.
        CombineMode::Replace => lanes(|c| lane(t, c)),
    }
}

/// The box of texture coordinates a coordinate hull `c` of type `ty`
/// spans (`program::uv`: a position divided by its w, an interval).
pub(super) fn uv_box(c: &R, ty: Ty) -> [I; 2] {
    if is_point(c) {
        let [u, v] = uv(c.0, ty);
        return [constant(u), constant(v)];
    }
    match ty {
        Ty::Scalar => [lane(c, 0), constant(0.5)],
        Ty::Position => {
            let w = lane(c, 3);
            let (x, y) = (div(lane(c, 0), w), div(lane(c, 1), w));
            [increasing(x, |x| 0.5 * x + 0.5), (0.5 - 0.5 * y.1, 0.5 - 0.5 * y.0)]
        }
        _ => [lane(c, 0), lane(c, 1)],
    }
}
