//! The language's operations on affine forms (`affine.rs`), where they
//! are affine in their operands or a product of them: `ops::compute`'s
//! arithmetic with the noise symbols kept, and the functions
//! `functions.rs` linearizes (`sqrt`, `rsqrt`, powers, `length`,
//! `normalize`, `exp`, `log`, `sin`, `cos`, `smoothstep`, and `min`,
//! `max`, `clamp` and `abs` the operands' ranges leave open). Every other
//! operation — a selection the ranges leave open, a `normalize` whose
//! length may reach 0 — is taken on intervals (`interval.rs`) and its
//! result given fresh symbols (`mod.rs`).

use super::affine::{Affine, Form, Symbols};
use super::functions;
use super::interval::{self, lane, I, R};
use crate::ir::{BinaryOp, Expr, MathFunction, Module, Ty, UnaryOp};
use crate::parser::ast::CombineMode;

/// Whether every lane of `f` is one value.
pub fn is_point(f: &Form) -> bool {
    f.iter().all(Affine::is_constant)
}

fn lanes(f: impl FnMut(usize) -> Affine) -> Form {
    std::array::from_fn(f)
}

fn splat(a: Affine) -> Form {
    [a.clone(), a.clone(), a.clone(), a]
}

fn constant(x: f64) -> Affine {
    Affine::constant(x)
}

/// `f` laid out for `ty` (`ops::shape`): a scalar splatted, lanes past
/// the width zero.
pub fn shape(ty: Ty, f: Form) -> Form {
    match ty.width() {
        1 => splat(f[0].clone()),
        w @ 2..=4 => {
            let mut f = f;
            for lane in f.iter_mut().skip(w) {
                *lane = constant(0.0);
            }
            f
        }
        _ => splat(constant(f64::NAN)),
    }
}

/// `Σ aᶜ·bᶜ` over the first `width` lanes.
fn dot(a: &Form, b: &Form, width: usize, s: &mut Symbols) -> Affine {
    (0..width.min(4)).fold(constant(0.0), |sum, c| sum.add(&a[c].mul(&b[c], s.fresh())))
}

/// A computing node on forms, where it is affine, a product or a function
/// `functions.rs` linearizes over the operands' ranges `r` (each the
/// intersection of its form's range and its interval); `None` where it
/// is not (the caller takes it on intervals). `Some(None)` for `c ? a`
/// with `c` surely false (the destination kept).
pub fn compute(m: &Module, e: &Expr, ty: Ty, o: &[Form], r: &[R], s: &mut Symbols) -> Option<Option<Form>> {
    let f = match e {
        Expr::Unary { op: UnaryOp::Neg, .. } => lanes(|c| o[0][c].scale(-1.0, 0.0)),
        Expr::Binary { op: BinaryOp::Pow, lhs, .. } => power(&o[0], &o[1], r, m.info(*lhs).ty.width(), s)?,
        Expr::Binary { op, lhs, .. } => binary(*op, &o[0], &o[1], m.info(*lhs).ty.width(), s)?,
        Expr::Combine { mode, lhs, .. } => {
            let widened = matches!(&m.exprs[*lhs], Expr::Convert { value, to: Ty::Rgba } if m.info(*value).ty == Ty::Rgb);
            texture_env(*mode, ty.width(), &o[0], &o[1], widened, s)
        }
        Expr::Math { fun: MathFunction::Sqrt | MathFunction::Rsqrt, args } => {
            let (width, root) =
                (m.info(args[0]).ty.width(), matches!(e, Expr::Math { fun: MathFunction::Sqrt, .. }));
            every_lane(width, &mut |c| {
                let range = lane(&r[0], c);
                if root {
                    functions::sqrt(&o[0][c], range, s)
                } else {
                    functions::rsqrt(&o[0][c], range, s)
                }
            })?
        }
        Expr::Math { fun: MathFunction::Length, args } => {
            let width = m.info(args[0]).ty.width();
            let (d, range) = squared_length(&o[0], &r[0], width, s);
            splat(functions::sqrt(&d, range, s)?)
        }
        Expr::Math { fun: MathFunction::Normalize, args } => {
            normalize(&o[0], &r[0], m.info(args[0]).ty.width(), s)?
        }
        Expr::Math { fun: fun @ (MathFunction::Exp | MathFunction::Log | MathFunction::Sin), .. }
        | Expr::Math { fun: fun @ (MathFunction::Cos | MathFunction::Smoothstep), .. } => {
            every_lane(ty.width(), &mut |c| transcendental(*fun, o, r, c, s))?
        }
        Expr::Math { fun, .. } => math(*fun, o, r, s)?,
        Expr::Swizzle { pattern, len, .. } => {
            let mut f: Form = Default::default();
            for (k, &i) in pattern[..*len as usize].iter().enumerate() {
                f[k] = o[0][usize::from(i) & 3].clone();
            }
            f
        }
        Expr::Compose { components, .. } => {
            let all: Vec<&Affine> = components
                .iter()
                .zip(o)
                .flat_map(|(h, v)| v[..m.info(*h).ty.width().min(4)].iter())
                .collect();
            lanes(|i| all.get(i).map_or(constant(0.0), |a| (*a).clone()))
        }
        Expr::Convert { value, to } => {
            let mut f = o[0].clone();
            if m.info(*value).ty == Ty::Rgb && *to == Ty::Rgba {
                f[3] = constant(1.0);
            }
            f
        }
        Expr::Select { reject, .. } => {
            let (lo, hi) = o[0][0].range();
            match (lo > 0.0 || hi < 0.0, lo == 0.0 && hi == 0.0, reject) {
                (true, _, _) => o[1].clone(),
                (false, true, Some(_)) => o[2].clone(),
                (false, true, None) => return Some(None),
                _ => return None,
            }
        }
        _ => return None,
    };
    Some(Some(shape(ty, f)))
}

/// `f(c)` for each lane `c` below `width` (the lanes past it 0, as
/// `shape` leaves them); `None` where a lane has none.
fn every_lane(width: usize, f: &mut dyn FnMut(usize) -> Option<Affine>) -> Option<Form> {
    let mut out: Form = Default::default();
    for (c, lane) in out.iter_mut().enumerate().take(width.clamp(1, 4)) {
        *lane = f(c)?;
    }
    Some(out)
}

/// `x^p` lane by lane: where the exponent `p` is one value on the lane,
/// `functions::pow` over the lane's range `r`; where it moves too and
/// `x` stays above 0, `exp(p·ln x)` (as GLSL defines `pow`), each
/// function its line and the product its rest — three fresh symbols;
/// where `x` may reach 0 (`max(0, n·H)^gloss`), the power to the
/// exponent's middle and how far the ends move it
/// (`functions::pow_over_exponents`).
pub(super) fn power(x: &Form, p: &Form, r: &[R], width: usize, s: &mut Symbols) -> Option<Form> {
    every_lane(width, &mut |c| {
        let (p, range) = (&p[c], lane(&r[0], c));
        if p.is_constant() {
            return functions::pow(&x[c], range, p.center, s);
        }
        if range.0 <= 0.0 {
            return functions::pow_over_exponents(&x[c], range, within(p, lane(&r[1], c)), s);
        }
        let ln = functions::log(&x[c], range, s)?;
        let ln_range = (range.0.ln(), range.1.ln());
        let y = p.mul(&ln, s.fresh());
        let (lo, hi) = y.range();
        let corners = interval::mul(lane(&r[1], c), ln_range);
        functions::exp(&y, (lo.max(corners.0), hi.min(corners.1)), s)
    })
}

/// `exp`, `log`, `sin`, `cos` of lane `c`, and `smoothstep` between
/// edges that are one value on it: `functions.rs`'s lines over the lane's
/// range.
pub(super) fn transcendental(
    fun: MathFunction,
    o: &[Form],
    r: &[R],
    c: usize,
    s: &mut Symbols,
) -> Option<Affine> {
    let (x, range) = (&o[0][c], lane(&r[0], c));
    match fun {
        MathFunction::Exp => functions::exp(x, range, s),
        MathFunction::Log => functions::log(x, range, s),
        MathFunction::Sin => functions::sin(x, range, s),
        MathFunction::Cos => functions::cos(x, range, s),
        MathFunction::Smoothstep => {
            let (e0, e1) = (&o[0][c], &o[1][c]);
            if e0.is_constant() && e1.is_constant() {
                return functions::smoothstep(&o[2][c], lane(&r[2], c), (e0.center, e1.center), s);
            }
            let quotient =
                moving_quotient((&o[2][c], lane(&r[2], c)), (e0, lane(&r[0], c)), (e1, lane(&r[1], c)), s)?;
            functions::smoothstep(&quotient.0, quotient.1, (0.0, 1.0), s)
        }
        _ => None,
    }
}

/// The range of form `f` within the interval `i`, or `i` where they do
/// not meet (rounding).
fn within(f: &Affine, i: I) -> I {
    let (lo, hi) = f.range();
    let r = (lo.max(i.0), hi.min(i.1));
    if r.0 <= r.1 {
        r
    } else {
        i
    }
}

/// `t = (x − e₀)/(e₁ − e₀)` of `smoothstep(e₀, e₁, x)` whose edges move
/// (each with its range), and its range: the numerator and the span on
/// forms, so what `x` and the edges share cancels (edges a constant
/// distance apart make `t` affine in `x − e₀`, exactly); a moving span
/// through its reciprocal's Chebyshev line (`x^−1`) and a product.
/// `None` unless the span stays above 0 (GLSL leaves the result
/// undefined where the edges meet or cross).
fn moving_quotient(
    x: (&Affine, I),
    e0: (&Affine, I),
    e1: (&Affine, I),
    s: &mut Symbols,
) -> Option<(Affine, I)> {
    let span = e1.0.sub(e0.0);
    let span_range = within(&span, interval::sub(e1.1, e0.1));
    if !(span_range.0 > 0.0 && span_range.1.is_finite()) {
        return None;
    }
    let d = x.0.sub(e0.0);
    let d_range = within(&d, interval::sub(x.1, e0.1));
    let t = if span.is_constant() {
        d.scale(span.center.recip(), 0.0)
    } else {
        let inverse = functions::pow(&span, span_range, -1.0, s)?;
        d.mul(&inverse, s.fresh())
    };
    let range = within(&t, interval::div(d_range, span_range));
    Some((t, range))
}

/// `max(x, y)` (`low`) or `min(x, y)` of two values that both move, the
/// ranges leaving the choice open: `y + max(x − y, 0)` (or `min`), the
/// difference on forms — its symbols shared, so `max(x, x + 0.1)` is
/// exact — and clamped on one side (`functions::clamped`) over its range
/// within the intervals' difference. With the range it takes: its form's
/// within the operands' maxima (minima).
pub(super) fn two_sided(x: (&Affine, I), y: (&Affine, I), low: bool, s: &mut Symbols) -> Option<(Affine, I)> {
    let d = x.0.sub(y.0);
    let ((lo, hi), apart) = (d.range(), interval::sub(x.1, y.1));
    let range = if lo.max(apart.0) <= hi.min(apart.1) { (lo.max(apart.0), hi.min(apart.1)) } else { apart };
    let ends = if low { (0.0, f64::INFINITY) } else { (f64::NEG_INFINITY, 0.0) };
    let f = y.0.add(&functions::clamped(&d, range, ends, s)?);
    let bounds =
        if low { (x.1 .0.max(y.1 .0), x.1 .1.max(y.1 .1)) } else { (x.1 .0.min(y.1 .0), x.1 .1.min(y.1 .1)) };
    let (lo, hi) = f.range();
    let within = (lo.max(bounds.0), hi.min(bounds.1));
    Some((f, if within.0 <= within.1 { within } else { bounds }))
}

/// `x·x` over the first `width` lanes and its range: the form's, within
/// the sum of the lanes' squares on the intervals `r` (never below 0).
fn squared_length(x: &Form, r: &R, width: usize, s: &mut Symbols) -> (Affine, I) {
    let d = dot(x, x, width, s);
    let squares =
        (0..width.min(4)).fold((0.0, 0.0), |sum, c| interval::add(sum, interval::square(lane(r, c))));
    let (lo, hi) = d.range();
    (d, (lo.max(squares.0), hi.min(squares.1)))
}

/// `normalize(x)` as `x·rsqrt(x·x)`, lane by lane (each product one more
/// symbol); `None` where `x·x` may be 0 (`normalize(0) = 0` is not
/// continuous there).
fn normalize(x: &Form, r: &R, width: usize, s: &mut Symbols) -> Option<Form> {
    let (d, range) = squared_length(x, r, width, s);
    let inverse = functions::rsqrt(&d, range, s)?;
    every_lane(width, &mut |c| Some(x[c].mul(&inverse, s.fresh())))
}

fn binary(op: BinaryOp, a: &Form, b: &Form, width: usize, s: &mut Symbols) -> Option<Form> {
    Some(match op {
        BinaryOp::Dot => splat(dot(a, b, width, s)),
        BinaryOp::Add => lanes(|c| a[c].add(&b[c])),
        BinaryOp::Sub => lanes(|c| a[c].sub(&b[c])),
        BinaryOp::Mul => lanes(|c| a[c].mul(&b[c], s.fresh())),
        BinaryOp::Div if b.iter().all(|l| l.is_constant() && l.center != 0.0) => {
            lanes(|c| a[c].scale(1.0 / b[c].center, 0.0))
        }
        _ => return None,
    })
}

/// A lane's value where the ranges decide which of `candidates` (each
/// with the condition that picks it) it is; `None` where they do not.
fn decided<'f>(candidates: &[(bool, &'f Affine)]) -> Option<&'f Affine> {
    candidates.iter().find(|c| c.0).map(|c| c.1)
}

/// `max(x, k)` (`low`) or `min(x, k)` of lane `c` where one operand is a
/// constant `k` and the ranges leave the choice open: the other clamped
/// on one side (`functions::clamped`).
fn one_sided(o: &[Form], r: &[R], c: usize, low: bool, s: &mut Symbols) -> Option<Affine> {
    let (x, k, range) = if o[1][c].is_constant() {
        (&o[0][c], o[1][c].center, lane(&r[0], c))
    } else if o[0][c].is_constant() {
        (&o[1][c], o[0][c].center, lane(&r[1], c))
    } else {
        return None;
    };
    let ends = if low { (k, f64::INFINITY) } else { (f64::NEG_INFINITY, k) };
    functions::clamped(x, range, ends, s)
}

fn math(fun: MathFunction, o: &[Form], r: &[R], s: &mut Symbols) -> Option<Form> {
    use MathFunction::*;
    let a = &o[0];
    let each = |f: &dyn Fn(&Affine) -> Affine| lanes(|c| f(&a[c]));
    // max(x, y) per lane where one surely is not below the other.
    let larger = |x: &Affine, y: &Affine| {
        let (p, q) = (x.range(), y.range());
        decided(&[(p.0 >= q.1, x), (q.0 >= p.1, y)]).cloned()
    };
    let smaller = |x: &Affine, y: &Affine| {
        let (p, q) = (x.range(), y.range());
        decided(&[(p.1 <= q.0, x), (q.1 <= p.0, y)]).cloned()
    };
    let every = |f: &mut dyn FnMut(usize) -> Option<Affine>| -> Option<Form> {
        let v: [Option<Affine>; 4] = std::array::from_fn(f);
        v.iter().all(Option::is_some).then(|| v.map(Option::unwrap_or_default))
    };
    // A clamp between constant ends the ranges leave open.
    let clamped = |c: usize, ends: I, s: &mut Symbols| functions::clamped(&a[c], lane(&r[0], c), ends, s);
    let ends =
        |c: usize| (o[1][c].is_constant() && o[2][c].is_constant()).then(|| (o[1][c].center, o[2][c].center));
    let operand = |k: usize, c: usize| (&o[k][c], lane(&r[k], c));
    Some(match fun {
        Expand => each(&|x| x.scale(2.0, -1.0)),
        HalfBias => each(&|x| x.scale(1.0, -0.5)),
        Compress => each(&|x| x.scale(0.5, 0.5)),
        Max | Min => every(&mut |c| {
            let low = fun == Max;
            let decided = if low { larger(&a[c], &o[1][c]) } else { smaller(&a[c], &o[1][c]) };
            let both = |s: &mut Symbols| two_sided(operand(0, c), operand(1, c), low, s).map(|f| f.0);
            decided.or_else(|| one_sided(o, r, c, low, s)).or_else(|| both(s))
        })?,
        Clamp => every(&mut |c| {
            let low = larger(&a[c], &o[1][c]);
            let moving = |s: &mut Symbols| {
                let (f, range) = two_sided(operand(0, c), operand(1, c), true, s)?;
                two_sided((&f, range), operand(2, c), false, s).map(|f| f.0)
            };
            low.and_then(|x| smaller(&x, &o[2][c])).or_else(|| clamped(c, ends(c)?, s)).or_else(|| moving(s))
        })?,
        Saturate => every(&mut |c| {
            let low = larger(&a[c], &constant(0.0));
            low.and_then(|x| smaller(&x, &constant(1.0))).or_else(|| clamped(c, (0.0, 1.0), s))
        })?,
        Abs => every(&mut |c| {
            let (lo, hi) = a[c].range();
            decided(&[(lo >= 0.0, &a[c])])
                .cloned()
                .or_else(|| (hi <= 0.0).then(|| a[c].scale(-1.0, 0.0)))
                .or_else(|| functions::abs(&a[c], lane(&r[0], c), s))
        })?,
        Mix => lanes(|c| a[c].add(&o[1][c].sub(&a[c]).mul(&o[2][c], s.fresh()))),
        Reflect => {
            let twice = dot(&o[1], a, 3, s).scale(2.0, 0.0);
            lanes(|c| a[c].sub(&twice.mul(&o[1][c], s.fresh())))
        }
        Cross => {
            let mut term =
                |i: usize, j: usize| a[i].mul(&o[1][j], s.fresh()).sub(&a[j].mul(&o[1][i], s.fresh()));
            let (c0, c1, c2) = (term(1, 2), term(2, 0), term(0, 1));
            [c0, c1, c2, constant(0.0)]
        }
        _ => return None,
    })
}

/// `t ⊕[mode] f` on forms (`ops::texture_env`, GL 1.2.1 Table 3.22 and
/// the combine extension, unclamped): products and sums of the operands.
fn texture_env(mode: CombineMode, width: usize, t: &Form, f: &Form, widened: bool, s: &mut Symbols) -> Form {
    let alpha = width == 4;
    let at = if alpha { t[3].clone() } else { constant(1.0) };
    let with_alpha = |mut c: Form, a: Affine| {
        if alpha {
            c[3] = a;
        }
        c
    };
    let blend =
        |c: usize, s: &mut Symbols| t[c].mul(&at, s.fresh()).add(&f[c].mul(&at.scale(-1.0, 1.0), s.fresh()));
    match mode {
        CombineMode::Modulate => lanes(|c| t[c].mul(&f[c], s.fresh())),
        CombineMode::Add => lanes(|c| t[c].add(&f[c])),
        CombineMode::AddSigned => lanes(|c| t[c].linear(1.0, &f[c], 1.0, -0.5)),
        CombineMode::Subtract => lanes(|c| t[c].sub(&f[c])),
        CombineMode::Decal => {
            let rgb = lanes(|c| blend(c, s));
            with_alpha(rgb, f[3].clone())
        }
        CombineMode::Interpolate => lanes(|c| blend(c, s)),
        CombineMode::Blend => {
            let rgb = lanes(|c| f[c].mul(&t[c].scale(-1.0, 1.0), s.fresh()));
            with_alpha(rgb, t[3].mul(&f[3], s.fresh()))
        }
        CombineMode::Replace => with_alpha(t.clone(), if widened { f[3].clone() } else { t[3].clone() }),
        CombineMode::Dot3Rgb | CombineMode::Dot3Rgba => {
            let n = if width == 1 { 1 } else { 3 };
            let centred = |x: &Form| lanes(|c| x[c].scale(1.0, -0.5));
            let d = dot(&centred(t), &centred(f), n, s).scale(4.0, 0.0);
            if mode == CombineMode::Dot3Rgb {
                with_alpha(splat(d), t[3].mul(&f[3], s.fresh()))
            } else {
                splat(d)
            }
        }
    }
}
