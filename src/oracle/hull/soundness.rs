//! Soundness of the hull's functions on affine forms (`functions.rs`,
//! `forms.rs`) and intervals (`interval.rs`), sampled: for forms whose
//! symbols take random values in [−1, 1], the function's true value lies
//! within the result's form at those values, its fresh symbols anywhere
//! in [−1, 1] — the property Stolfi and de Figueiredo 1997 ask of every
//! affine operation — and for random boxes, every point's value inside
//! the interval.

use std::f64::consts::TAU;

use proptest::prelude::*;

use super::affine::{Affine, Symbols};
use super::{forms, functions, interval};
use crate::ir::MathFunction;

/// An argument `x = c + r₀·ε₀ + r₁·ε₁` (two symbols shared with whatever
/// else names them) and its range.
fn argument(c: f64, r0: f64, r1: f64) -> Affine {
    Affine { center: c, terms: vec![(0, r0), (1, r1)] }
}

/// The value of `f` at the symbols `eps` (by index), and the reach of its
/// other symbols (the fresh ones).
fn at(f: &Affine, eps: &[f64]) -> (f64, f64) {
    f.terms.iter().fold((f.center, 0.0), |(v, r), &(s, k)| match eps.get(s as usize) {
        Some(e) => (v + k * e, r),
        None => (v, r + k.abs()),
    })
}

/// `truth` lies within `f` at `eps`, up to the rounding of f64.
fn within(f: &Affine, eps: &[f64], truth: f64) -> Result<(), TestCaseError> {
    let (v, reach) = at(f, eps);
    let slack = 1e-9 * (1.0 + v.abs() + reach + f.radius());
    prop_assert!((truth - v).abs() <= reach + slack, "{truth} outside {v} ± {reach} ({f:?} at {eps:?})");
    Ok(())
}

/// Symbols 2 and up are fresh: the arguments name 0 and 1 (and 2 for a
/// second argument's own).
fn symbols() -> Symbols {
    let mut s = Symbols::default();
    for _ in 0..3 {
        s.fresh();
    }
    s
}

fn eps() -> impl Strategy<Value = [f64; 3]> {
    [-1.0..=1.0f64, -1.0..=1.0f64, -1.0..=1.0f64]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// `exp`, `log`, `sin`, `cos` and `smoothstep` over the argument's
    /// own range.
    #[test]
    fn one_variable_functions_hold_their_value(
        c in -4.0..4.0f64, r0 in 0.0..2.0f64, r1 in -1.0..1.0f64, e in eps(),
        e0 in -1.0..1.0f64, span in prop_oneof![-2.0..-0.01f64, 0.01..2.0f64],
    ) {
        let x = argument(c, r0, r1);
        let t = at(&x, &e).0;
        let range = x.range();
        let mut s = symbols();
        if let Some(f) = functions::exp(&x, range, &mut s) { within(&f, &e, t.exp())?; }
        else { prop_assert!(false, "no exp on {range:?}"); }
        prop_assert!(functions::sin(&x, range, &mut s).is_some() && functions::cos(&x, range, &mut s).is_some());
        within(&functions::sin(&x, range, &mut s).unwrap_or_default(), &e, t.sin())?;
        within(&functions::cos(&x, range, &mut s).unwrap_or_default(), &e, t.cos())?;
        let step = |v: f64| { let u = ((v - e0) / span).clamp(0.0, 1.0); u * u * (3.0 - 2.0 * u) };
        let f = functions::smoothstep(&x, range, (e0, e0 + span), &mut s);
        prop_assert!(f.is_some());
        within(&f.unwrap_or_default(), &e, step(t))?;
        // ln over the argument moved above 0.
        let y = x.scale(1.0, 4.5 - range.0.min(4.0));
        let (ty, yr) = (at(&y, &e).0, y.range());
        let f = functions::log(&y, yr, &mut s);
        prop_assert!(f.is_some(), "no log on {yr:?}");
        within(&f.unwrap_or_default(), &e, ty.ln())?;
    }

    /// `max` and `min` of two moving values sharing a symbol, `clamp`
    /// between moving ends (two of them in turn), and `pow` of a moving
    /// base above 0 to a moving exponent.
    #[test]
    fn two_moving_values_hold_their_value(
        c in -1.0..1.0f64, r0 in 0.0..1.0f64, r1 in -1.0..1.0f64,
        d in -1.0..1.0f64, k0 in -1.0..1.0f64, k2 in 0.0..1.0f64, e in eps(),
    ) {
        let x = argument(c, r0, r1);
        let y = Affine { center: d, terms: vec![(0, k0), (2, k2)] };
        let (tx, ty) = (at(&x, &e).0, at(&y, &e).0);
        let mut s = symbols();
        for low in [true, false] {
            let f = forms::two_sided((&x, x.range()), (&y, y.range()), low, &mut s);
            prop_assert!(f.is_some());
            let (f, (lo, hi)) = f.unwrap_or_default();
            let truth = if low { tx.max(ty) } else { tx.min(ty) };
            within(&f, &e, truth)?;
            prop_assert!(lo <= truth + 1e-12 && truth <= hi + 1e-12, "{truth} outside {lo}..{hi}");
        }
        // pow(x, y) for x in [0.05, 2.05].
        let base = x.scale(0.5, 1.05 - 0.5 * c);
        let tb = at(&base, &e).0;
        let o = [std::array::from_fn(|_| base.clone()), std::array::from_fn(|_| y.clone())];
        let r = [base.range(), y.range()].map(|i| ([i.0; 4], [i.1; 4]));
        let p = forms::power(&o[0], &o[1], &r, 1, &mut s);
        prop_assert!(p.is_some());
        within(&p.unwrap_or_default()[0], &e, tb.powf(ty))?;
    }

    /// `smoothstep` between moving edges — a moving span, and edges a
    /// constant distance apart — on forms and on intervals, and a power
    /// of a base reaching 0 to a moving exponent.
    #[test]
    fn moving_edges_and_exponents_hold_their_value(
        c in -1.0..1.0f64, r0 in 0.0..1.0f64, r1 in -1.0..1.0f64,
        d in -1.0..1.0f64, k0 in -0.5..0.5f64, k2 in 0.0..0.5f64, gap in 0.0..1.0f64, e in eps(),
    ) {
        let x = argument(c, r0, r1);
        let e0 = Affine { center: d, terms: vec![(0, k0), (2, k2)] };
        let moving = e0.add(&Affine { center: gap + 0.3, terms: vec![(1, 0.25 * gap), (2, -0.1)] });
        let mut s = symbols();
        let step = |v: f64, a: f64, b: f64| { let u = ((v - a) / (b - a)).clamp(0.0, 1.0); u * u * (3.0 - 2.0 * u) };
        for e1 in [moving, e0.scale(1.0, 0.4)] {
            let (tx, t0, t1) = (at(&x, &e).0, at(&e0, &e).0, at(&e1, &e).0);
            let o = [&e0, &e1, &x].map(|a| std::array::from_fn(|_| a.clone()));
            let r = [e0.range(), e1.range(), x.range()].map(|i| ([i.0; 4], [i.1; 4]));
            let f = forms::transcendental(MathFunction::Smoothstep, &o, &r, 0, &mut s);
            prop_assert!(f.is_some(), "no smoothstep between {e0:?} and {e1:?}");
            within(&f.unwrap_or_default(), &e, step(tx, t0, t1))?;
            let i = interval::math(MathFunction::Smoothstep, &r, 1);
            prop_assert!(i.is_ok());
            let (lo, hi) = interval::lane(&i.unwrap_or_default(), 0);
            let truth = step(tx, t0, t1);
            prop_assert!(lo - 1e-12 <= truth && truth <= hi + 1e-12, "{truth} outside {lo}..{hi}");
        }
        // pow(b, y) for b in [0, h], reaching 0, and y in [1, 3] ± 0.75.
        let base = x.scale(0.5, -0.5 * x.range().0);
        let y = Affine { center: 2.0 + d, terms: vec![(0, 0.5 * k0), (2, k2)] };
        let (tb, ty) = (at(&base, &e).0.max(0.0), at(&y, &e).0);
        let o = [std::array::from_fn(|_| base.clone()), std::array::from_fn(|_| y.clone())];
        let r = [(0.0, base.range().1), y.range()].map(|i| ([i.0; 4], [i.1; 4]));
        let p = forms::power(&o[0], &o[1], &r, 1, &mut s);
        prop_assert!(p.is_some(), "no power of {base:?} to {y:?}");
        within(&p.unwrap_or_default()[0], &e, tb.powf(ty))?;
    }

    /// `normalize` over a box, the length reaching 0 or not, and `sin`,
    /// `cos` over an interval: every point's value inside.
    #[test]
    fn normalize_and_waves_hold_every_point_of_a_box(
        lo in [-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64],
        w in [0.0..1.0f64, 0.0..1.0f64, 0.0..1.0f64],
        t in [0.0..=1.0f64, 0.0..=1.0f64, 0.0..=1.0f64],
        a in -10.0..10.0f64, width in 0.0..7.0f64,
    ) {
        let hi: [f64; 3] = std::array::from_fn(|k| lo[k] + w[k]);
        let r = ([lo[0], lo[1], lo[2], 0.0], [hi[0], hi[1], hi[2], 0.0]);
        let p: [f64; 3] = std::array::from_fn(|k| lo[k] + t[k] * w[k]);
        let n = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        for (c, x) in p.into_iter().enumerate() {
            let (l, h) = interval::normalized(&r, c, 3);
            let v = if n == 0.0 { 0.0 } else { x / n };
            prop_assert!(l - 1e-12 <= v && v <= h + 1e-12, "lane {c}: {v} outside {l}..{h} on {r:?}");
        }
        let x = a + t[0] * width;
        let (sl, sh) = interval::wave((a, a + width), f64::sin, std::f64::consts::FRAC_PI_2);
        prop_assert!(sl - 1e-12 <= x.sin() && x.sin() <= sh + 1e-12);
        let (cl, ch) = interval::wave((a, a + width), f64::cos, 0.0);
        prop_assert!(cl - 1e-12 <= x.cos() && x.cos() <= ch + 1e-12);
        prop_assert!(width >= TAU || sh - sl < 2.0 || ch - cl < 2.0 || width > 3.0);
    }
}
