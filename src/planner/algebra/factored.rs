//! The factored forms of a multiplied-out sum ([`super::forms`]): a
//! common factor taken out, a product of sums, a product grouped by
//! sub-products, lerps read back — each equal to the sum for every input,
//! and each the compact form a program written multiplied out had before.

use rustc_hash::FxHashMap as HashMap;

use super::{binary, node, product_factors, sum_terms};
use crate::ir::{BinaryOp, Expr, Handle, MathFunction, Module, Ty};
use crate::span::Span;
/// Most factors a term may have for [`product_by_groups`] to try its
/// sub-products (2ⁿ of them).
const MAX_GROUPED_FACTORS: usize = 8;

/// A sum of products that is `c·(Σ sᵢ)·(Σ xⱼ)` with the selectors `sᵢ`
/// themselves products, written so: the multiplied-out
/// `(T0·T2 + T1)·lerp(δl, T0, a)` has the selectors `T0·T2` and `T1`,
/// which no single shared factor ([`product_of_sums`]) finds. `c` is what
/// every term shares (the `C` of `C·((T0 + T1)·mix(T0, T1, a))`
/// multiplied out), taken out first. The first term's sub-products are
/// tried as the first selector; every selector times every `xⱼ` must be
/// the terms exactly (as multisets). `None` when no grouping does.
pub fn product_by_groups(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    if let Expr::Convert { value, to: Ty::Rgba } = m.exprs[h] {
        if matches!(m.info(value).ty, Ty::Rgb | Ty::Vec3 | Ty::Scalar) {
            let inner = product_by_groups(m, value)?;
            return node(m, Expr::Convert { value: inner, to: Ty::Rgba }, m.span(h));
        }
    }
    let terms: Vec<Vec<Handle<Expr>>> = sum_terms(m, h).into_iter().map(|t| product_factors(m, t)).collect();
    let common = shared_factors(&terms);
    let stripped: Terms =
        terms.iter().map(|t| common.iter().fold(t.clone(), |t, c| without(&t, *c))).collect();
    let span = m.span(h);
    // What every term shares is taken out first (the fused `T4·(T0 + T1)²`
    // is `T4·((T0 + T1)·(T0 + T1))`, not `(T4·T0 + T4·T1)·(T0 + T1)`).
    let out = if common.is_empty() { None } else { grouped(m, stripped, &common, span) }
        .or_else(|| grouped(m, terms, &[], span))?;
    (m.info(out).ty == m.info(h).ty && out != h).then_some(out)
}

/// `common·(Σ sᵢ)·(Σ xⱼ)` for the sum of `terms` ([`product_by_groups`]).
fn grouped(m: &mut Module, mut terms: Terms, common: &[Handle<Expr>], span: Span) -> Option<Handle<Expr>> {
    let first = terms.first()?.clone();
    if terms.len() < 4 || first.len() > MAX_GROUPED_FACTORS {
        return None;
    }
    terms.iter_mut().for_each(|t| t.sort());
    terms.sort();
    let ones = |m: &mut Module, t: Terms| -> Option<Terms> {
        t.into_iter()
            .map(|t| match t.is_empty() {
                true => Some(vec![node(m, Expr::Constant(crate::ir::Constant::scalar(1.0)), span)?]),
                false => Some(t),
            })
            .collect()
    };
    for mask in 1..(1usize << first.len()) - 1 {
        let (selector, rest): (Vec<(usize, &Handle<Expr>)>, Vec<_>) =
            first.iter().enumerate().partition(|(i, _)| mask & (1 << i) != 0);
        let selector: Vec<Handle<Expr>> = selector.into_iter().map(|(_, h)| *h).collect();
        let rest: Vec<Handle<Expr>> = rest.into_iter().map(|(_, h)| *h).collect();
        let Some((selectors, xs)) = groups_by(&terms, &selector).or_else(|| groups_around(&terms, &rest))
        else {
            continue;
        };
        let (selectors, xs) = (ones(m, selectors)?, ones(m, xs)?);
        let a = rebuild_sum(m, &selectors, span)?;
        let b = rebuild_sum(m, &xs, span)?;
        let mut out = binary(m, BinaryOp::Mul, a, b, span)?;
        for c in common.iter().rev() {
            out = binary(m, BinaryOp::Mul, *c, out, span)?;
        }
        return Some(out);
    }
    None
}

/// The factors every term holds (as a multiset: `a·a·b + a·a·c` shares
/// `a` twice), in the first term's order.
fn shared_factors(terms: &[Vec<Handle<Expr>>]) -> Vec<Handle<Expr>> {
    let Some(first) = terms.first() else { return Vec::new() };
    let mut rests: Vec<Vec<Handle<Expr>>> = terms.to_vec();
    let mut out = Vec::new();
    for f in first {
        if rests.iter().all(|t| t.contains(f) && t.len() > 1) {
            rests.iter_mut().for_each(|t| *t = without(t, *f));
            out.push(*f);
        }
    }
    out
}

/// A sum as its terms, each a list of factors.
pub(super) type Terms = Vec<Vec<Handle<Expr>>>;

/// `t` less the multiset `f`; `None` when `t` does not hold all of `f`.
fn cofactor(t: &[Handle<Expr>], f: &[Handle<Expr>]) -> Option<Vec<Handle<Expr>>> {
    let mut rest = t.to_vec();
    for x in f {
        let i = rest.iter().position(|y| y == x)?;
        rest.remove(i);
    }
    Some(rest)
}

/// `terms` (each sorted, the list sorted) as every selector times every
/// `x`, the `x` being the cofactors of `selector`: (selectors, xs), each
/// with at least two members; `None` when the terms are not such a product.
fn groups_by(terms: &[Vec<Handle<Expr>>], selector: &[Handle<Expr>]) -> Option<(Terms, Terms)> {
    let mut xs: Vec<Vec<Handle<Expr>>> = terms.iter().filter_map(|t| cofactor(t, selector)).collect();
    xs.sort();
    xs.dedup();
    if xs.len() < 2 || terms.len() % xs.len() != 0 {
        return None;
    }
    let mut selectors: Vec<Vec<Handle<Expr>>> = terms.iter().filter_map(|t| cofactor(t, &xs[0])).collect();
    selectors.sort();
    selectors.dedup();
    is_product(terms, selectors, xs)
}

/// [`groups_by`] where a selector's factors also occur in the `x`s
/// (`(T0 + T1)·(T0·(1 − a) + T1·a)` multiplied out: `T0` selects three
/// terms, not two): the selectors are the cofactors of `x0`, the first
/// term without its selector, and the `x`s the cofactors every selector
/// shares.
fn groups_around(terms: &[Vec<Handle<Expr>>], x0: &[Handle<Expr>]) -> Option<(Terms, Terms)> {
    let mut selectors: Vec<Vec<Handle<Expr>>> = terms.iter().filter_map(|t| cofactor(t, x0)).collect();
    selectors.sort();
    selectors.dedup();
    let mut xs: Option<Terms> = None;
    for s in &selectors {
        let of_s: Terms = terms.iter().filter_map(|t| cofactor(t, s)).collect();
        xs = Some(match xs {
            None => of_s,
            Some(xs) => xs.into_iter().filter(|x| of_s.contains(x)).collect(),
        });
    }
    let mut xs = xs?;
    xs.sort();
    xs.dedup();
    is_product(terms, selectors, xs)
}

/// `(selectors, xs)` when each has at least two members and every
/// selector times every `x` is `terms` exactly (as multisets).
fn is_product(terms: &[Vec<Handle<Expr>>], selectors: Terms, xs: Terms) -> Option<(Terms, Terms)> {
    if selectors.len() < 2 || xs.len() < 2 || selectors.len() * xs.len() != terms.len() {
        return None;
    }
    let mut product: Vec<Vec<Handle<Expr>>> = selectors
        .iter()
        .flat_map(|s| {
            xs.iter().map(move |x| {
                let mut t = [s.clone(), x.clone()].concat();
                t.sort();
                t
            })
        })
        .collect();
    product.sort();
    (product == terms).then_some((selectors, xs))
}

/// A sum of products factored back into a product of sums, as far as
/// that goes exactly: a factor in every term taken out (`c·x + c·y` =
/// `c·(x + y)`), and a factor `f` whose terms, without it, are the terms
/// without it (`f·x + f·y + x + y` = `(f + 1)·(x + y)`), then the same
/// within the sums. The multiplied-out `(T0·T1 + T0)·lerp(δl, T0, a)` is
/// its own written form again, which greedy factoring by the most shared
/// factor does not recover. With `distribute_common`, a factor common to
/// every term stays inside the first sum (`(c·f + c)·(x + y)`, the form
/// written); else it is taken out first (`c·(f + 1)·(x + y)`). `None`
/// when nothing factors so.
pub fn product_of_sums(m: &mut Module, h: Handle<Expr>, distribute_common: bool) -> Option<Handle<Expr>> {
    if let Expr::Convert { value, to: Ty::Rgba } = m.exprs[h] {
        if matches!(m.info(value).ty, Ty::Rgb | Ty::Vec3 | Ty::Scalar) {
            let inner = product_of_sums(m, value, distribute_common)?;
            return node(m, Expr::Convert { value: inner, to: Ty::Rgba }, m.span(h));
        }
    }
    let terms: Vec<Vec<Handle<Expr>>> = sum_terms(m, h).into_iter().map(|t| product_factors(m, t)).collect();
    let out = factor_terms(m, terms, distribute_common, m.span(h))?;
    (m.info(out).ty == m.info(h).ty && out != h).then_some(out)
}

/// [`product_of_sums`] on a sum given as its terms' factors.
fn factor_terms(
    m: &mut Module,
    terms: Vec<Vec<Handle<Expr>>>,
    distribute_common: bool,
    span: Span,
) -> Option<Handle<Expr>> {
    if terms.len() < 2 {
        return None;
    }
    let common = terms[0].iter().copied().find(|f| terms.iter().all(|t| t.contains(f) && t.len() > 1));
    if let (Some(c), false) = (common, distribute_common) {
        let inner: Vec<Vec<Handle<Expr>>> = terms.iter().map(|t| without(t, c)).collect();
        let rest = factor_terms(m, inner.clone(), false, span).or_else(|| rebuild_sum(m, &inner, span))?;
        return binary(m, BinaryOp::Mul, c, rest, span);
    }
    let mut seen: Vec<Handle<Expr>> = Vec::new();
    for f in terms.iter().flatten() {
        if !seen.contains(f) {
            seen.push(*f);
        }
    }
    for f in seen.into_iter().filter(|f| Some(*f) != common) {
        let (with, rest): (Vec<_>, Vec<_>) = terms.iter().partition(|t| t.contains(&f) && t.len() > 1);
        let mut cofactors: Vec<Vec<Handle<Expr>>> = with.iter().map(|t| without(t, f)).collect();
        let mut others: Vec<Vec<Handle<Expr>>> = rest.into_iter().cloned().collect();
        if cofactors.is_empty() || others.is_empty() || !same_terms(&mut cofactors, &mut others) {
            continue;
        }
        // `f·x + x` = `(f + 1)·x`, `x` the sum of the others; with the
        // common factor `c` kept in: `(c·f + c)·(x/c)`.
        let (selector, sum_terms) = match common.filter(|_| distribute_common) {
            Some(c) => {
                let cf = binary(m, BinaryOp::Mul, c, f, span)?;
                let sum = binary(m, BinaryOp::Add, cf, c, span)?;
                (sum, others.iter().map(|t| without(t, c)).collect::<Vec<_>>())
            }
            None => {
                let one = node(m, Expr::Constant(crate::ir::Constant::scalar(1.0)), span)?;
                (node(m, Expr::Binary { op: BinaryOp::Add, lhs: f, rhs: one }, span)?, others)
            }
        };
        let sum =
            factor_terms(m, sum_terms.clone(), false, span).or_else(|| rebuild_sum(m, &sum_terms, span))?;
        return binary(m, BinaryOp::Mul, selector, sum, span);
    }
    None
}

/// `t` without one occurrence of `f`.
fn without(t: &[Handle<Expr>], f: Handle<Expr>) -> Vec<Handle<Expr>> {
    let mut t = t.to_vec();
    if let Some(i) = t.iter().position(|x| *x == f) {
        t.remove(i);
    }
    t
}

/// Whether two sums have the same terms (each a multiset of factors).
fn same_terms(a: &mut [Vec<Handle<Expr>>], b: &mut [Vec<Handle<Expr>>]) -> bool {
    let key = |t: &mut Vec<Handle<Expr>>| t.sort();
    a.iter_mut().for_each(key);
    b.iter_mut().for_each(key);
    a.sort();
    b.sort();
    a == b
}

/// `f` where `h` is `1 − f` of a scalar `f`: the weight of a lerp's first
/// operand.
fn weight(m: &Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Sub, lhs, rhs }
            if m.is_constant(lhs, 1.0) && m.info(rhs).ty == Ty::Scalar =>
        {
            Some(rhs)
        }
        _ => None,
    }
}

/// The pairs `(i, j)`, `i < j`, of `terms` of which one holds a weight
/// `1 − f` ([`weight`], its first) and the other `f`: the only pairs
/// [`relerp`] can join, in the order of all pairs. Found from the terms
/// with a weight, so a long sum without one (`a + a` doubled sixteen times
/// is 65 536 terms) costs one pass over it, not one per pair.
fn lerp_pairs(m: &Module, terms: &[Vec<Handle<Expr>>]) -> Vec<(usize, usize)> {
    let mut pairs = Vec::new();
    for (i, t) in terms.iter().enumerate() {
        let Some(f) = t.iter().find_map(|h| weight(m, *h)) else { continue };
        for (j, other) in terms.iter().enumerate() {
            if j != i && other.contains(&f) {
                pairs.push((i.min(j), i.max(j)));
            }
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// `x·(1 − f) + y·f` as `lerp(x, y, f)`, one operation the texture
/// environment and the combiners compute whole (Pipeline Grammar, Section
/// 3.6: interpolate); `None` for other sums.
fn relerp(m: &mut Module, terms: &[Vec<Handle<Expr>>], span: Span) -> Option<Handle<Expr>> {
    let [a, b] = terms else { return None };
    let (keep, take) = [(a, b), (b, a)].into_iter().find_map(|(x, y)| {
        let f = x.iter().find_map(|h| weight(m, *h))?;
        y.contains(&f).then_some((x, y))
    })?;
    let f = keep.iter().find_map(|h| weight(m, *h))?;
    let one_minus = *keep.iter().find(|h| weight(m, **h) == Some(f))?;
    let (x, y) = (without(keep, one_minus), without(take, f));
    // What both sides share is taken out: `3·a·(1 − f) + 3·b·f` is
    // `3·lerp(a, b, f)`, bounded by `a` and `b` times 3.
    let shared = shared_factors(&[x.clone(), y.clone()]);
    let strip = |t: &[Handle<Expr>]| shared.iter().fold(t.to_vec(), |t, c| without(&t, *c));
    let (x, y) = if shared.is_empty() { (x, y) } else { (strip(&x), strip(&y)) };
    let x = rebuild_sum(m, &[x], span)?;
    let y = rebuild_sum(m, &[y], span)?;
    let mut mix = node(m, Expr::Math { fun: MathFunction::Mix, args: vec![x, y, f] }, span)?;
    // Of the type of the wider operand: `lerp(p.r, T4, a)`, a scalar and
    // a colour, is a colour, as `p.r·(1 − a) + T4·a` is.
    if m.info(mix).ty != m.info(x).ty && m.info(mix).ty != m.info(y).ty {
        return None;
    }
    for c in shared.iter().rev() {
        mix = binary(m, BinaryOp::Mul, *c, mix, span)?;
    }
    Some(mix)
}

/// A sum with each pair of its terms that is `x·(1 − f) + y·f` written
/// as `lerp(x, y, f)`, the other terms kept: `T0 + T0·(1 − a) + δl·a` is
/// `T0 + lerp(T0, δl, a)`, in [0, 2] where its terms' bounds add to more
/// (a lerp is bounded by its operands, each term of it is not). `None`
/// when no pair is one.
pub fn lerps_recovered(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    if let Expr::Convert { value, to: Ty::Rgba } = m.exprs[h] {
        if matches!(m.info(value).ty, Ty::Rgb | Ty::Vec3 | Ty::Scalar) {
            let inner = lerps_recovered(m, value)?;
            return node(m, Expr::Convert { value: inner, to: Ty::Rgba }, m.span(h));
        }
    }
    let span = m.span(h);
    let mut terms: Terms = sum_terms(m, h).into_iter().map(|t| product_factors(m, t)).collect();
    if terms.len() < 2 {
        return None;
    }
    let mut found = false;
    'pairs: loop {
        for (i, j) in lerp_pairs(m, &terms) {
            let Some(mix) = relerp(m, &[terms[i].clone(), terms[j].clone()], span) else { continue };
            terms[i] = product_factors(m, mix);
            terms.remove(j);
            found = true;
            continue 'pairs;
        }
        break;
    }
    let out = if found { rebuild_sum(m, &terms, span)? } else { return None };
    (m.info(out).ty == m.info(h).ty && out != h).then_some(out)
}

/// The sum of the products `terms` (a `lerp` where two terms are one).
fn rebuild_sum(m: &mut Module, terms: &[Vec<Handle<Expr>>], span: Span) -> Option<Handle<Expr>> {
    if let Some(mix) = relerp(m, terms, span) {
        return Some(mix);
    }
    let mut sum: Option<Handle<Expr>> = None;
    for t in terms {
        let mut p = *t.first()?;
        for f in &t[1..] {
            p = binary(m, BinaryOp::Mul, p, *f, span)?;
        }
        sum = Some(match sum {
            None => p,
            Some(s) => binary(m, BinaryOp::Add, s, p, span)?,
        });
    }
    sum
}

/// A sum whose terms share a factor, the factor most terms share taken
/// out, then the same within the factored sum and the rest:
/// `a·b + a·c + d` = `a·(b + c) + d`; `None` when no two terms share one.
pub fn factor(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    factor_nth(m, h, 0)
}

/// [`factor`] taking out the `nth` most shared factor first (then the most
/// shared within): greedy factoring can miss the compact form, so the
/// planner tries a few.
pub fn factor_nth(m: &mut Module, h: Handle<Expr>, nth: usize) -> Option<Handle<Expr>> {
    if let Expr::Convert { value, to: Ty::Rgba } = m.exprs[h] {
        if matches!(m.info(value).ty, Ty::Rgb | Ty::Vec3 | Ty::Scalar) {
            let inner = factor_nth(m, value, nth)?;
            return node(m, Expr::Convert { value: inner, to: Ty::Rgba }, m.span(h));
        }
    }
    let terms = sum_terms(m, h);
    if terms.len() < 2 {
        return None;
    }
    let factors: Vec<Vec<Handle<Expr>>> = terms.iter().map(|t| product_factors(m, *t)).collect();
    let mut count: HashMap<Handle<Expr>, usize> = HashMap::default();
    for fs in factors.iter().filter(|fs| fs.len() > 1) {
        let mut seen = fs.clone();
        seen.sort();
        seen.dedup();
        for f in seen {
            *count.entry(f).or_default() += 1;
        }
    }
    let mut shared: Vec<(Handle<Expr>, usize)> = count.into_iter().filter(|(_, n)| *n >= 2).collect();
    shared.sort_by_key(|(f, n)| (std::cmp::Reverse(*n), f.index()));
    let (common, _) = *shared.get(nth)?;
    let span = m.span(h);
    let (mut inner, mut rest): (Option<Handle<Expr>>, Option<Handle<Expr>>) = (None, None);
    for (t, fs) in terms.iter().zip(&factors) {
        let Some(i) = fs.iter().position(|f| *f == common).filter(|_| fs.len() > 1) else {
            rest = Some(match rest {
                None => *t,
                Some(r) => binary(m, BinaryOp::Add, r, *t, span)?,
            });
            continue;
        };
        let mut others = fs.clone();
        others.remove(i);
        let mut p = others[0];
        for f in &others[1..] {
            p = binary(m, BinaryOp::Mul, p, *f, span)?;
        }
        inner = Some(match inner {
            None => p,
            Some(s) => binary(m, BinaryOp::Add, s, p, span)?,
        });
    }
    // Then the same within what is left (a Horner-like form: the whole
    // sum of products folded back, as far as shared factors go).
    // A lerp written out under the factor (`3·T0·(1 − a) + 3·y·a`) is read
    // back as one, which holds what its operands hold.
    let inner = inner?;
    let inner_terms: Vec<Vec<Handle<Expr>>> =
        sum_terms(m, inner).iter().map(|t| product_factors(m, *t)).collect();
    let inner = relerp(m, &inner_terms, span).or_else(|| factor(m, inner)).unwrap_or(inner);
    let taken = binary(m, BinaryOp::Mul, common, inner, span)?;
    let out = match rest {
        None => taken,
        Some(r) => {
            let r = factor(m, r).unwrap_or(r);
            binary(m, BinaryOp::Add, taken, r, span)?
        }
    };
    (m.info(out).ty == m.info(h).ty && out != h).then_some(out)
}

/// A sum of products with a constant scale `k > 1` taken out, `Σ cᵢ·tᵢ`
/// = `(Σ (cᵢ/k)·tᵢ)·k`: each term's remaining constant moved into its δ
/// where the interpolant stays in [0, 1] (`2·T0·(1 − a) + 1.2·δl·(1 −
/// a)·a + 2·T5·a²` is `(T0·(1 − a) + δ(0.6·l)·(1 − a)·a + T5·a²)·2`,
/// whose lerps read back as `mix(T0, mix(δ(0.6·l), T5, a), a)`), so that
/// the scale is applied last — a blender's 2× or a texture environment's
/// last stage — where a constant past 1 inside a term would leave [0, 1]
/// mid-product and be clamped there. The scales tried, where the greatest
/// coefficient is past 1: that coefficient; the hardware's scales, 2 and
/// 4, not below it (the combiners' and the texture
/// environment's output scales, NVIDIA 1999; OpenGL 1.3, Section 3.8.13);
/// and the coefficients' sum, which leaves a convex combination inside
/// (`1.2·T4 + 2.8·T3`, `4·lerp(T4, T3, 0.7)` multiplied out, is `(0.3·T4 +
/// 0.7·T3)·4`, a lerp again, where 2.8 taken out leaves `0.43·T4 + T3`,
/// up to 1.43). Each as the sum inside and `k`, without repeats; none
/// without a coefficient past 1.
pub fn scales_taken_out(m: &mut Module, h: Handle<Expr>) -> Vec<(Handle<Expr>, Handle<Expr>)> {
    let Some(terms) = super::expansion(m, h, super::MAX_TERMS) else { return Vec::new() };
    let scalar = |m: &Module, f: Handle<Expr>| match &m.exprs[f] {
        Expr::Constant(c) if c.ty == Ty::Scalar => Some(c.components[0]),
        _ => None,
    };
    let coefficient =
        |m: &Module, t: &[Handle<Expr>]| t.iter().filter_map(|f| scalar(m, *f)).product::<f64>();
    let greatest = terms.iter().map(|t| coefficient(m, t)).fold(f64::MIN, f64::max);
    if terms.len() < 2 || greatest <= 1.0 || terms.iter().any(|t| coefficient(m, t) <= 0.0) {
        return Vec::new();
    }
    let total: f64 = terms.iter().map(|t| coefficient(m, t)).sum();
    let hardware = [2.0, 4.0].into_iter().filter(|s| *s >= greatest);
    let mut scales: Vec<f64> = Vec::new();
    for k in [greatest].into_iter().chain(hardware).chain([total]) {
        if scales.iter().all(|s| (s - k).abs() > 1e-9) {
            scales.push(k);
        }
    }
    let mut out: Vec<(Handle<Expr>, Handle<Expr>)> = Vec::new();
    for k in scales {
        for into_delta in [true, false] {
            if let Some(f) = scaled_by(m, h, &terms, k, into_delta).filter(|f| !out.contains(f)) {
                out.push(f);
            }
        }
    }
    out
}

/// [`scales_taken_out`] for one scale `k`: the sum of `terms` (of `h`)
/// each divided by `k`, and `k`. What is left of a term's constant goes
/// into its δ `into_delta`, else stays a factor of the term: a channel of
/// an interpolated tuple scaled (`4·mix((δ p).r, 0.3·(δ p).g, a)`) reads
/// the tuple's one interpolant only with its 0.3 outside.
fn scaled_by(
    m: &mut Module,
    h: Handle<Expr>,
    terms: &[Vec<Handle<Expr>>],
    k: f64,
    into_delta: bool,
) -> Option<(Handle<Expr>, Handle<Expr>)> {
    let scalar = |m: &Module, f: Handle<Expr>| match &m.exprs[f] {
        Expr::Constant(c) if c.ty == Ty::Scalar => Some(c.components[0]),
        _ => None,
    };
    let coefficient =
        |m: &Module, t: &[Handle<Expr>]| t.iter().filter_map(|f| scalar(m, *f)).product::<f64>();
    let span = m.span(h);
    let mut sum: Option<Handle<Expr>> = None;
    for t in terms {
        let c = coefficient(m, t) / k;
        let mut rest: Vec<Handle<Expr>> = t.iter().copied().filter(|f| scalar(m, *f).is_none()).collect();
        if rest.is_empty() {
            return None;
        }
        if (c - 1.0).abs() > 1e-12 {
            rest.insert(0, node(m, Expr::Constant(crate::ir::Constant::scalar(c)), span)?);
        }
        let rest = if into_delta { super::constants_into_delta(m, rest, span)? } else { rest };
        let mut product = rest[0];
        for f in &rest[1..] {
            product = binary(m, BinaryOp::Mul, product, *f, span)?;
        }
        sum = Some(match sum {
            None => product,
            Some(s) => binary(m, BinaryOp::Add, s, product, span)?,
        });
    }
    let k = node(m, Expr::Constant(crate::ir::Constant::scalar(k)), span)?;
    Some((sum?, k))
}
