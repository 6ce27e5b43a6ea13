//! One-variable functions on affine forms: `sqrt`, `rsqrt`, a power by a
//! constant, and with them `length` and `normalize`. Each is replaced
//! over its argument's range by its Chebyshev (minimax) line, and the
//! line's error by one fresh noise symbol (Stolfi and de Figueiredo 1997,
//! §3.4, "the Chebyshev approximation" of a function that is convex or
//! concave on the range): the argument's symbols pass through scaled, so
//! `normalize` of a minified normal map keeps what its channels share
//! (their λ), where an interval per channel did not.

use super::affine::{Affine, Symbols};
use super::interval::I;

/// `f(x)` on the range `(a, b)` of `x` — the caller's, which may be
/// narrower than the form's own (an intersection with the interval) —
/// as `α·x + ζ ± δ`: `α` the chord's slope, `ζ ± δ` the least and the
/// greatest of `f(t) − α·t` over `[a, b]`. Where `f` is convex or
/// concave there, those lie at `a`, `b` and the point `u` where
/// `f′(u) = α` (`stationary`, the inverse of `f′`, clamped into the
/// range): for whatever slope rounding gives, not only the exact one. A
/// function linear between kinks (`max(x, c)`, `saturate`) has them at
/// `a`, `b` and its kinks, which `stationary` names instead.
/// `None` where the range or the line is not finite.
fn chebyshev(
    x: &Affine,
    (a, b): I,
    f: impl Fn(f64) -> f64,
    stationary: impl Fn(f64) -> Vec<f64>,
    s: &mut Symbols,
) -> Option<Affine> {
    if x.is_constant() {
        return Some(Affine::constant(f(x.center)));
    }
    if !(a.is_finite() && b.is_finite() && a < b) {
        return None;
    }
    let (fa, fb) = (f(a), f(b));
    let slope = (fb - fa) / (b - a);
    let error = |u: f64| {
        let u = if u.is_nan() { a } else { u.clamp(a, b) };
        f(u) - slope * u
    };
    let errors = [fa - slope * a, fb - slope * b].into_iter().chain(stationary(slope).into_iter().map(error));
    let (lo, hi) = errors.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), e| (l.min(e), h.max(e)));
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    // The rounding of the f64 arithmetic above: far below any width the
    // reference reports.
    let slack = 1e-9 * (hi - lo) + 1e-12 * (fa.abs() + fb.abs() + (slope * a).abs() + (slope * b).abs());
    let (centre, radius) = (0.5 * (lo + hi), 0.5 * (hi - lo) + slack);
    if !(slope.is_finite() && centre.is_finite() && radius.is_finite()) {
        return None;
    }
    let mut out = x.scale(slope, centre);
    if radius > 0.0 {
        out.terms.push((s.fresh(), radius));
    }
    Some(out)
}

/// `√x` for `x` in `range` (concave; `None` where the range reaches
/// below 0).
pub fn sqrt(x: &Affine, range: I, s: &mut Symbols) -> Option<Affine> {
    if range.0 < 0.0 {
        return None;
    }
    // f′(u) = 1/(2√u) = α.
    chebyshev(x, range, f64::sqrt, |slope| vec![0.25 / (slope * slope)], s)
}

/// `1/√x` for `x` in `range` (convex; `None` unless the range is above 0).
pub fn rsqrt(x: &Affine, range: I, s: &mut Symbols) -> Option<Affine> {
    if range.0 <= 0.0 {
        return None;
    }
    // f′(u) = −½·u^(−3/2) = α.
    chebyshev(x, range, |t| t.sqrt().recip(), |slope| vec![(-2.0 * slope).powf(-2.0 / 3.0)], s)
}

/// `x^p` for a constant `p` and `x` in `range`, where the power is
/// convex or concave: `x ≥ 0` (`x > 0` for `p < 0`). `p = 0` is 1 and
/// `p = 1` is `x` (as `powf` gives them); `None` elsewhere.
pub fn pow(x: &Affine, range: I, p: f64, s: &mut Symbols) -> Option<Affine> {
    if p == 0.0 {
        return Some(Affine::constant(1.0));
    }
    if p == 1.0 {
        return Some(x.clone());
    }
    if range.0 < 0.0 || (p < 0.0 && range.0 == 0.0) || !p.is_finite() {
        return None;
    }
    // f′(u) = p·u^(p−1) = α.
    chebyshev(x, range, |t| t.powf(p), |slope| vec![(slope / p).powf(1.0 / (p - 1.0))], s)
}

/// `x^p` for `x` in `range` (at least 0, reaching it: `ln x` has no
/// line there) and an exponent that moves within `exponents`, above 0:
/// the Chebyshev line of `x^m` at the middle exponent `m`, and one fresh
/// symbol for how far `x^p` may lie from `x^m` — for each `x` the power
/// is monotone in `p`, so between `x^p₀ − x^m` and `x^p₁ − x^m`, and
/// `|u^a − u^b|` is greatest over the range at its ends or where its
/// derivative vanishes, `u = (a/b)^(1/(b − a))`. `x`'s symbols pass
/// through; the exponent's do not. `None` for an exponent that may reach
/// 0 or is not finite.
pub fn pow_over_exponents(x: &Affine, range: I, (p0, p1): I, s: &mut Symbols) -> Option<Affine> {
    if !(range.0 >= 0.0 && p0 > 0.0 && p1.is_finite() && p0 <= p1) {
        return None;
    }
    let m = 0.5 * (p0 + p1);
    let line = pow(x, range, m, s)?;
    let apart = |a: f64, b: f64| {
        let (a, b) = (a.min(b), a.max(b));
        let inner = if b > a { (a / b).powf((b - a).recip()) } else { range.0 };
        [range.0, range.1, inner.clamp(range.0, range.1)]
            .into_iter()
            .map(|u| (u.powf(a) - u.powf(b)).abs())
            .fold(0.0, f64::max)
    };
    let error = apart(p0, m).max(apart(m, p1));
    if !error.is_finite() {
        return None;
    }
    let mut out = line;
    if error > 0.0 {
        out.terms.push((s.fresh(), error * (1.0 + 1e-9) + 1e-12));
    }
    Some(out)
}

/// `x` clamped to `[low, high]` (either end may be infinite: `max(x,
/// low)`, `min(x, high)`) for `x` in `range`: linear between its two
/// kinks, so its Chebyshev line's error is largest at the range's ends
/// or at a kink. Where the range lies on one side of both kinks the
/// caller has already decided it.
pub fn clamped(x: &Affine, range: I, (low, high): I, s: &mut Symbols) -> Option<Affine> {
    if low.is_nan() || high.is_nan() || low > high {
        return None;
    }
    chebyshev(x, range, |t| t.max(low).min(high), |_| vec![low, high], s)
}

/// `|x|` for `x` in `range`: convex, its kink at 0.
pub fn abs(x: &Affine, range: I, s: &mut Symbols) -> Option<Affine> {
    chebyshev(x, range, f64::abs, |_| vec![0.0], s)
}

/// `eˣ` for `x` in `range` (convex; `f′(u) = eᵘ = α`).
pub fn exp(x: &Affine, range: I, s: &mut Symbols) -> Option<Affine> {
    chebyshev(x, range, f64::exp, |slope| vec![slope.ln()], s)
}

/// `ln x` for `x` in `range` (concave; `None` unless the range is above
/// 0; `f′(u) = 1/u = α`).
pub fn log(x: &Affine, range: I, s: &mut Symbols) -> Option<Affine> {
    if range.0 <= 0.0 {
        return None;
    }
    chebyshev(x, range, f64::ln, |slope| vec![slope.recip()], s)
}

/// The widest range `sin` and `cos` are linearized over: four turns (the
/// line is no better than [−1, 1] well before).
const TURNS: f64 = 4.0 * std::f64::consts::TAU;

/// Every `u + 2πk` in `(a, b)` widened by a turn, for each `u` of
/// `roots` (`NaN` ones dropped): the points of a periodic function where
/// its derivative takes one value.
fn periodic(roots: [f64; 2], (a, b): I) -> Vec<f64> {
    let tau = std::f64::consts::TAU;
    let (first, last) = ((a / tau).floor() - 1.0, (b / tau).ceil() + 1.0);
    let turns = (last - first).max(0.0) as usize;
    roots
        .into_iter()
        .filter(|u| u.is_finite())
        .flat_map(|u| (0..=turns).map(move |k| u + tau * (first + k as f64)))
        .collect()
}

/// `sin x` for `x` in `range`, no wider than four turns: neither convex
/// nor concave across a multiple of π, so the line's error is taken at
/// every point of the range where `cos u = α` (`±acos α` a turn apart),
/// not only one.
pub fn sin(x: &Affine, range: I, s: &mut Symbols) -> Option<Affine> {
    if range.1 - range.0 > TURNS {
        return None;
    }
    chebyshev(x, range, f64::sin, |slope| periodic([slope.acos(), -slope.acos()], range), s)
}

/// `cos x` for `x` in `range`, no wider than four turns: its error at
/// every point where `−sin u = α`.
pub fn cos(x: &Affine, range: I, s: &mut Symbols) -> Option<Affine> {
    if range.1 - range.0 > TURNS {
        return None;
    }
    chebyshev(
        x,
        range,
        f64::cos,
        |slope| periodic([(-slope).asin(), std::f64::consts::PI - (-slope).asin()], range),
        s,
    )
}

/// `smoothstep(e₀, e₁, x)` for constant edges and `x` in `range`:
/// `t²(3 − 2t)` of `t = (x − e₀)/(e₁ − e₀)` clamped to [0, 1], continuous
/// with its derivative; the line's error is taken at the edges and where
/// `6t(1 − t)/(e₁ − e₀) = α`, `t = ½ ± √(¼ − α(e₁ − e₀)/6)`. `None` for
/// equal edges (the quotient is not a number).
pub fn smoothstep(x: &Affine, range: I, (e0, e1): I, s: &mut Symbols) -> Option<Affine> {
    let span = e1 - e0;
    if span == 0.0 || !span.is_finite() || !e0.is_finite() {
        return None;
    }
    let f = move |v: f64| {
        let t = ((v - e0) / span).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    };
    let stationary = move |slope: f64| {
        let root = (0.25 - slope * span / 6.0).sqrt();
        [0.5 - root, 0.5 + root].into_iter().map(|t| e0 + t * span).chain([e0, e1]).collect()
    };
    chebyshev(x, range, f, stationary, s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The form of a function over a range holds the function at every
    /// point of it, the form's symbol running with the point.
    fn holds(f: impl Fn(f64) -> f64, g: impl Fn(&Affine, I, &mut Symbols) -> Option<Affine>, (a, b): I) {
        let mut s = Symbols::default();
        let x = Affine { center: 0.5 * (a + b), terms: vec![(s.fresh(), 0.5 * (b - a))] };
        let y = g(&x, (a, b), &mut s).unwrap_or_else(|| panic!("no form on {a}..{b}"));
        let sym = x.terms[0].0;
        let slope = y.terms.iter().find(|t| t.0 == sym).map_or(0.0, |t| t.1);
        let error: f64 = y.terms.iter().filter(|t| t.0 != sym).map(|t| t.1.abs()).sum();
        for k in 0..=1000 {
            let e = -1.0 + 0.002 * f64::from(k);
            let t = x.center + x.terms[0].1 * e;
            let line = y.center + slope * e;
            assert!((f(t) - line).abs() <= error, "{t}: {} off the line {line} by more than {error}", f(t));
        }
    }

    #[test]
    fn each_function_lies_within_its_line_and_error() {
        for range in [(0.0, 1.0), (0.25, 0.5), (0.9, 1.1), (1e-3, 3.0), (2.0, 2.0 + 1e-9)] {
            holds(f64::sqrt, sqrt, range);
            holds(|t| t.powf(16.0), |x, r, s| pow(x, r, 16.0, s), range);
            holds(|t| t.powf(2.0), |x, r, s| pow(x, r, 2.0, s), range);
            holds(|t| t.powf(1.0 / 2.2), |x, r, s| pow(x, r, 1.0 / 2.2, s), range);
            for (low, high) in [(0.0, f64::INFINITY), (f64::NEG_INFINITY, 0.5), (0.3, 0.6), (0.0, 1.0)] {
                holds(|t| t.max(low).min(high), |x, r, s| clamped(x, r, (low, high), s), range);
            }
            holds(|t| (t - 0.4).abs(), |x, r, s| abs(&x.scale(1.0, -0.4), (r.0 - 0.4, r.1 - 0.4), s), range);
            if range.0 > 0.0 {
                holds(|t| t.sqrt().recip(), rsqrt, range);
                holds(|t| t.powf(-1.5), |x, r, s| pow(x, r, -1.5, s), range);
            }
        }
    }

    /// Where the argument is narrow beside its size, the line is nearly
    /// the whole of it: `√x` on [0.9, 1.1] has an error under 10⁻³, where
    /// the range is 0.1 wide.
    #[test]
    fn the_error_is_small_where_the_function_is_nearly_straight() {
        let mut s = Symbols::default();
        let x = Affine { center: 1.0, terms: vec![(s.fresh(), 0.1)] };
        let y = sqrt(&x, (0.9, 1.1), &mut s).unwrap();
        assert!(y.terms[1].1 < 1e-3, "{y:?}");
    }

    #[test]
    fn ranges_outside_the_domain_are_left_to_the_intervals() {
        let mut s = Symbols::default();
        let x = Affine { center: 0.0, terms: vec![(s.fresh(), 1.0)] };
        assert!(sqrt(&x, (-1.0, 1.0), &mut s).is_none());
        assert!(rsqrt(&x, (0.0, 1.0), &mut s).is_none());
        assert!(pow(&x, (-1.0, 1.0), 3.0, &mut s).is_none());
        assert_eq!(pow(&x, (-1.0, 1.0), 0.0, &mut s), Some(Affine::constant(1.0)));
    }
}
