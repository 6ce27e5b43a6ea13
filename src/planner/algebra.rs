//! Equivalent forms of a value the planner tries before it refuses one for
//! resources: exact algebra, no approximation.
//!
//! Framebuffer blending splits sums and products (Pipeline Grammar,
//! eq. (9)); a value written another way may hold the same sum of products
//! in a shape blending cannot divide, or in one whose parts leave [0, 1]
//! where a pass clamps them. The forms, each equal to the value for every
//! input:
//!
//! - **canonical**: a channel read off a tuple is that component
//!   (`(a, b, 0).r` = `a`; a shader returning a tuple read by `.r` and
//!   `.g` plans as two scalar shaders would); `lerp(a, b, f)` =
//!   `a·(1 − f) + b·f` (affine in `a` and `b`); a sum inside δ is split
//!   across it, δ(a + b) = δa + δb — interpolation is linear (Pipeline
//!   Grammar, eq. (1)), so this is exact, and each light of GL's
//!   per-vertex lighting becomes an interpolant of its own, in [0, 1]
//!   where their sum was not;
//! - **multiplied out**: the canonical form with every product distributed
//!   over its sums, a flat sum of products whose terms blending adds one
//!   pass (or one group) at a time — `base · light · lerp(fog, 2·detail, f)`
//!   becomes `base·light·fog·(1 − f) + base·light·(2·detail)·f`;
//! - **factored**: a sum whose terms share a factor, that factor taken out
//!   once (`a·b + a·c` = `a·(b + c)`): fewer operations and fetches where
//!   the sum fits but its terms, written apart, do not;
//! - each of these with **sums of interpolants merged** into one δ,
//!   `δa + δb` = `δ(a + b)`, where the merged one stays in [0, 1];
//! - each with its **lerps of sums split** into sums of two lerps,
//!   `lerp(x₁ + x₂, y₁ + y₂, f)` = `lerp(x₁, y₁, f) + lerp(x₂, y₂, f)`
//!   ([`lerps_of_sums_split`]): a lerp read back from a multiplied-out sum
//!   pairs all its terms, where the program may have been two lerps that
//!   blending adds one pass at a time.
//!
//! Multiplied out, like terms are collected (`ab + ba` = `2·ab`: the
//! square of a sum has one cross term) and a term's constants go into its
//! δ (`δa·0.6` = `δ(0.6·a)`), where they cost no combiner stage.
//!
//! The planner plans each form that differs from the one written and keeps
//! the cheapest by its cost model (`split::cost`); nothing here runs for a
//! statement that plans as written.

use rustc_hash::FxHashMap as HashMap;

use crate::ir::{BinaryOp, Expr, Frequency, Handle, MathFunction, Module, Ty};
use crate::parser::ast::CombineMode;
use crate::span::Span;

mod clamp;
mod delta;
mod factored;
mod lerps;
mod repeated_terms;
use factored::Terms;
pub use factored::{factor, factor_nth, lerps_recovered, product_by_groups, product_of_sums};
pub use lerps::lerps_of_sums_split;
pub use repeated_terms::{repeated_terms_counted, repeats_a_term};

/// At most this many terms in a multiplied-out form: beyond it the search
/// over their groupings is greedy, and the form is not worth its passes.
pub const MAX_TERMS: usize = 12;

/// The canonical form, in the words of a plan's reason.
pub const CANONICAL: &str = "with tuples read by channel, lerps and sums inside δ written out";

/// A form with sums of interpolants merged into one δ, in a reason's words.
const MERGED: &str = "with sums of interpolants merged into one δ";

/// A form with its constant scale applied last, in a reason's words.
const SCALED: &str = "with its constant scale applied last";

/// The forms of a multiplied-out `sum` with a constant scale past 1
/// taken out and applied last ([`factored::scales_taken_out`]): the sum
/// inside as it is and in its factored forms, each times the scale (under
/// `sum`'s rgba widening).
fn scaled_forms(m: &mut Module, sum: Handle<Expr>) -> Vec<Handle<Expr>> {
    let (value, widened) = match m.exprs[sum] {
        Expr::Convert { value, to: Ty::Rgba }
            if matches!(m.info(value).ty, Ty::Rgb | Ty::Vec3 | Ty::Scalar) =>
        {
            (value, true)
        }
        _ => (sum, false),
    };
    let span = m.span(sum);
    let mut out = Vec::new();
    for (inner, k) in factored::scales_taken_out(m, value) {
        let mut found = vec![Some(inner)];
        factored_forms(m, inner, &mut |v, _| found.push(v));
        for v in found.into_iter().flatten() {
            let scaled = binary(m, BinaryOp::Mul, v, k, span);
            let w = match (scaled, widened) {
                (Some(s), true) => node(m, Expr::Convert { value: s, to: Ty::Rgba }, span),
                (s, _) => s,
            };
            if let Some(w) = w.filter(|w| m.info(*w).ty == m.info(sum).ty && !out.contains(w)) {
                out.push(w);
            }
        }
    }
    out
}

/// One equivalent form of a value and what made it.
#[derive(Clone, Debug, PartialEq)]
pub struct Form {
    pub value: Handle<Expr>,
    /// In the words of a plan's reason: "multiplied out", ….
    pub what: &'static str,
}

/// The forms of `h` other than `h` itself, in the order of the module's
/// doc (canonical, multiplied out, factored), without repeats.
pub fn forms(m: &mut Module, h: Handle<Expr>, max_terms: usize) -> Vec<Form> {
    let mut out: Vec<Form> = Vec::new();
    let push = |out: &mut Vec<Form>, value: Option<Handle<Expr>>, what| {
        if let Some(value) = value.filter(|v| *v != h && out.iter().all(|f| f.value != *v)) {
            out.push(Form { value, what });
        }
    };
    let canon = canonical(m, h);
    push(&mut out, canon, CANONICAL);
    // A sum of repeated terms as each term times its count (`a + a`
    // doubled forty times is `2⁴⁰·a`, one value blending scales).
    let collected = repeated_terms_counted(m, h);
    push(&mut out, collected, "with like terms collected");
    // And its counts kept outside δ (`δ(2⁴⁰·l)` = `2⁴⁰·δl`): GL clamps what
    // it interpolates as a colour to [0, 1].
    let counted_out = collected.and_then(|c| delta::scales_outside(m, c));
    push(&mut out, counted_out, "with like terms collected");
    // Also with a channel of an interpolated tuple read as its own
    // interpolant (`(δ v).r` = `δ(v.r)`): a form, not the statement's
    // rewrite, since some plans need the tuple's one interpolant.
    let channels = canonical_with(m, h, true).filter(|c| Some(*c) != canon);
    push(&mut out, channels, CANONICAL);
    // And with a constant scale inside a δ of one term kept outside it
    // (`δ(0.8·l₀)` = `0.8·δl₀`): a like term of the same light elsewhere.
    let scaled_out = delta::scales_outside(m, canon.unwrap_or(h)).filter(|c| Some(*c) != canon);
    push(&mut out, scaled_out, CANONICAL);
    for base in [canon.unwrap_or(h)].into_iter().chain(channels).chain(scaled_out) {
        let expanded = multiply_out(m, base, max_terms);
        push(&mut out, expanded, "multiplied out");
        // Like terms kept apart too: `T0·T0 + T0·T1 + T1·T0 + T1·T1` groups
        // back into `(T0 + T1)²`, its collected `T0² + 2·T0·T1 + T1²` does not.
        let apart = multiplied_out(m, base, max_terms, false, true).filter(|a| Some(*a) != expanded);
        push(&mut out, apart, "multiplied out");
        // And its constants kept out of the interpolants: a constant several
        // terms share (`0.2·δ(p.r)·(1 − a) + 0.2·T5·a`) is then a common
        // factor, where moved into one δ it is not.
        let kept = multiplied_out(m, base, max_terms, true, false)
            .filter(|k| Some(*k) != expanded && Some(*k) != apart);
        push(&mut out, kept, "multiplied out");
        // And the value itself, a sum multiplied out with its constants
        // outside its δs (its `kept` form, `None`), factored and merged.
        let sum_inside = match m.exprs[base] {
            Expr::Convert { value, to: Ty::Rgba } => value,
            _ => base,
        };
        let itself =
            (expanded.is_some() && kept.is_none() && sum_terms(m, sum_inside).len() > 1).then_some(base);
        for sum in [expanded.unwrap_or(base)].into_iter().chain(apart).chain(kept).chain(itself) {
            factored_forms(m, sum, &mut |v, what| push(&mut out, v, what));
            // And factored after its interpolants are merged around the
            // cofactor they share: `δa·(1 − f) + δb·(1 − f) + T·f` reads
            // back as `lerp(δ(a + b), T, f)` only once the two lights are
            // one term (a lerp pairs two terms).
            if let Some(merged) = delta_sums_merged(m, sum) {
                factored_forms(m, merged, &mut |v, _| push(&mut out, v, MERGED));
            }
            for v in scaled_forms(m, sum) {
                push(&mut out, Some(v), SCALED);
            }
        }
    }
    // A product whose factors all repeat, as the square it is: `x·2·y·x·2·y`
    // = `(x·y·2)²`, one squaring of what the first factors computed.
    // Also with a constant past 1 applied last (`2·T1·T1·T1·T1` =
    // `(T1·T1)²·2`, the combiners' output scale), where `√2·T1·T1` would
    // leave the [−1, 1] the general combiners clamp to.
    for scale_last in [false, true] {
        let square = squared(m, h, scale_last);
        push(&mut out, square, "with its repeated factors squared");
    }
    // Each form so far (and the value) with its sums of interpolants
    // merged back into one δ where an 8-bit interpolant holds the sum.
    let merged: Vec<Option<Handle<Expr>>> =
        std::iter::once(h).chain(out.iter().map(|f| f.value)).map(|v| delta_sums_merged(m, v)).collect();
    for v in merged {
        push(&mut out, v, MERGED);
    }
    // Each form so far with its lerps of sums written as sums of lerps:
    // a multiplied-out sum read back around its weights is one lerp of
    // two sums, where the program may have been written as two lerps.
    let split: Vec<Option<Handle<Expr>>> =
        std::iter::once(h).chain(out.iter().map(|f| f.value)).map(|v| lerps_of_sums_split(m, v)).collect();
    for v in split {
        push(&mut out, v, "with its lerp of sums written as a sum of lerps");
    }
    out
}

/// A product in which every factor but its scalar constants occurs an even
/// number of times, written as the square of one of each pair, its
/// constants' product `k > 0` as `√k` scaled in last: `T4·2·T0·T4·2·T0` =
/// `(T4·T0·2)²`, what a texture environment computes in three stages (the
/// second squares the first's result) where the product as written takes
/// one stage a factor. With `scale_last`, `k > 1` multiplies the square
/// instead (`2·T1⁴` = `(T1·T1)²·2`: two general combiners, the second
/// with its output scale; `(T1·T1·√2)²` leaves [−1, 1] in between).
/// Under an rgba conversion too. `None` for another value.
fn squared(m: &mut Module, h: Handle<Expr>, scale_last: bool) -> Option<Handle<Expr>> {
    if let Expr::Convert { value, to: Ty::Rgba } = m.exprs[h] {
        let inner = squared(m, value, scale_last)?;
        return node(m, Expr::Convert { value: inner, to: Ty::Rgba }, m.span(h));
    }
    let factors = product_factors(m, h);
    if factors.len() < 2 {
        return None;
    }
    let mut k = 1.0;
    let mut counted: Vec<(Handle<Expr>, usize)> = Vec::new();
    for f in factors {
        match &m.exprs[f] {
            Expr::Constant(c) if c.ty == Ty::Scalar => k *= c.components[0],
            _ => match counted.iter_mut().find(|(g, _)| *g == f) {
                Some((_, n)) => *n += 1,
                None => counted.push((f, 1)),
            },
        }
    }
    if counted.is_empty() || counted.iter().any(|(_, n)| n % 2 != 0) || k <= 0.0 || (scale_last && k <= 1.0) {
        return None;
    }
    let span = m.span(h);
    let mut half: Option<Handle<Expr>> = None;
    for (f, n) in counted {
        for _ in 0..n / 2 {
            half = Some(match half {
                None => f,
                Some(p) => binary(m, BinaryOp::Mul, p, f, span)?,
            });
        }
    }
    let mut half = half?;
    if k != 1.0 && !scale_last {
        let root = node(m, Expr::Constant(crate::ir::Constant::scalar(k.sqrt())), span)?;
        half = binary(m, BinaryOp::Mul, half, root, span)?;
    }
    let mut square = binary(m, BinaryOp::Mul, half, half, span)?;
    if scale_last {
        let scale = node(m, Expr::Constant(crate::ir::Constant::scalar(k)), span)?;
        square = binary(m, BinaryOp::Mul, square, scale, span)?;
    }
    (m.info(square).ty == m.info(h).ty).then_some(square)
}

/// The factored forms of a multiplied-out `sum`, each given to `push`.
fn factored_forms(
    m: &mut Module,
    sum: Handle<Expr>,
    push: &mut dyn FnMut(Option<Handle<Expr>>, &'static str),
) {
    for nth in 0..3 {
        let factored = factor_nth(m, sum, nth);
        push(factored, "with a common factor taken out");
        // Then its lerps read back around what was taken out:
        // `T5·(1 − a) + 0.4·T2·T0·a + δl·T0·a` is `mix(T5, T0·(0.4·T2 +
        // δl), a)` once `T0·a` is one factor of one term.
        if let Some(f) = factored {
            push(lerps_recovered(m, f), "with its lerps written as lerps");
        }
    }
    for distribute_common in [false, true] {
        push(product_of_sums(m, sum, distribute_common), "factored into a product of sums");
    }
    push(product_by_groups(m, sum), "factored into a product of sums");
    push(lerps_recovered(m, sum), "with its lerps written as lerps");
}

/// `h` with every sum of two or more interpolants of one frequency and
/// type merged into one, `δa + δb` = `δ(a + b)` (interpolation is
/// linear; Pipeline Grammar, eq. (1)), where the merged value stays in
/// [0, 1] as each was: one interpolant and one add fewer per fragment. The
/// inverse of splitting a sum across δ: a program written multiplied out
/// (`δl0·(1 − f) + δl1·(1 − f)`) factors back to its compact form
/// (`(1 − f)·δ(l0 + l1)`) only so. `None` when nothing merges.
pub fn delta_sums_merged(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    rebuilt_bottom_up(m, h, |m, n, span| match m.exprs[n] {
        Expr::Binary { op: BinaryOp::Add, .. } => merge_interpolants(m, n, span),
        _ => None,
    })
    .filter(|c| m.info(*c).ty == m.info(h).ty)
}

/// `h` rebuilt from its leaves up: each node, its operands replaced by
/// what they became, is replaced by what `step` makes of it (itself where
/// `step` gives `None`). `None` when a node cannot be built, or when the
/// result is `h` itself.
fn rebuilt_bottom_up(
    m: &mut Module,
    h: Handle<Expr>,
    mut step: impl FnMut(&mut Module, Handle<Expr>, Span) -> Option<Handle<Expr>>,
) -> Option<Handle<Expr>> {
    let mut done: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::default();
    for n in m.reachable(&[h]) {
        let e = m.exprs[n].map_operands(|o| *done.get(&o).unwrap_or(&o));
        let span = m.span(n);
        let rebuilt = if e == m.exprs[n] { n } else { node(m, e, span)? };
        let replaced = step(m, rebuilt, span).unwrap_or(rebuilt);
        done.insert(n, replaced);
    }
    done.get(&h).copied().filter(|c| *c != h)
}

/// The sum at `h` with its interpolant terms of one frequency and type
/// merged ([`delta_sums_merged`]), also where they share a cofactor:
/// `δa·X + δb·X` = `δ(a + b)·X` (a sum of lights inside one δ, modulating
/// a texture, multiplied out: `0.7·δl0·T3 + 0.7·δl2·T3`, each light's
/// term bounded by the hull of its colour where the merged one is bounded
/// channel by channel, as written). `None` when fewer than two merge.
fn merge_interpolants(m: &mut Module, h: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let terms = sum_terms(m, h);
    // (the cofactors, sorted; the frequency; the δ's type; the values inside δ)
    type Group = (Vec<Handle<Expr>>, Frequency, Ty, Vec<Handle<Expr>>);
    let mut groups: Vec<Group> = Vec::new();
    let mut rest = Vec::new();
    for t in terms {
        match interpolant_term(m, t, span) {
            Some((value, to, ty, cofactors)) => {
                match groups.iter_mut().find(|g| g.0 == cofactors && g.1 == to && g.2 == ty) {
                    Some(g) => g.3.push(value),
                    None => groups.push((cofactors, to, ty, vec![value])),
                }
            }
            None => rest.push(t),
        }
    }
    if groups.iter().all(|g| g.3.len() < 2) {
        return None;
    }
    let mut merged_terms = Vec::new();
    for (cofactors, to, ty, values) in groups {
        let mut value = values[0];
        for v in &values[1..] {
            value = binary(m, BinaryOp::Add, value, *v, span)?;
        }
        let merged = node(m, Expr::Interpolate { value, to }, span)?;
        if !unit(m.info(merged).interval) || m.info(merged).ty != ty {
            return None;
        }
        let mut term = merged;
        for c in cofactors {
            term = binary(m, BinaryOp::Mul, term, c, span)?;
        }
        merged_terms.push(term);
    }
    let mut sum = merged_terms[0];
    for t in merged_terms[1..].iter().chain(&rest) {
        sum = binary(m, BinaryOp::Add, sum, *t, span)?;
    }
    (m.info(sum).ty == m.info(h).ty).then_some(sum)
}

/// What [`interpolant_term`] reads off a term.
type InterpolantTerm = (Handle<Expr>, Frequency, Ty, Vec<Handle<Expr>>);

/// A term with one interpolant factor `δv` and constant factors `k`, as
/// (`k·v`, its frequency, the type of `δ(k·v)`, the other factors sorted),
/// where `δ(k·v)` stays in [0, 1] and the product keeps the term's type:
/// `k·δv·X` = `δ(k·v)·X` (interpolation is linear), so that
/// `0.6·δl0 + 0.6·δl1` merges as `δl0 + δl1` does.
fn interpolant_term(m: &mut Module, t: Handle<Expr>, span: Span) -> Option<InterpolantTerm> {
    let factors = product_factors(m, t);
    let mut delta: Option<(Handle<Expr>, Handle<Expr>, Frequency)> = None;
    let mut constants = Vec::new();
    let mut cofactors = Vec::new();
    for f in factors {
        match m.exprs[f] {
            Expr::Interpolate { value, to } if delta.is_none() => delta = Some((f, value, to)),
            Expr::Constant(_) => constants.push(f),
            _ => cofactors.push(f),
        }
    }
    let (d, mut value, to) = delta?;
    for k in constants {
        value = binary(m, BinaryOp::Mul, k, value, span)?;
    }
    let ty = m.info(d).ty;
    let scaled = node(m, Expr::Interpolate { value, to }, span)?;
    if m.info(scaled).ty != ty || !unit(m.info(scaled).interval) {
        return None;
    }
    // The term rebuilt so must keep its type (an rgb δ times a scalar
    // cofactor is rgb either way; a scalar δ times an rgb is too).
    let mut product = scaled;
    for c in &cofactors {
        product = binary(m, BinaryOp::Mul, product, *c, span)?;
    }
    if m.info(product).ty != m.info(t).ty {
        return None;
    }
    cofactors.sort();
    Some((value, to, ty, cofactors))
}

/// Interns `e` at `span`; `None` when it is ill-typed.
fn node(m: &mut Module, e: Expr, span: Span) -> Option<Handle<Expr>> {
    m.intern(e, span).ok()
}

fn binary(
    m: &mut Module,
    op: BinaryOp,
    lhs: Handle<Expr>,
    rhs: Handle<Expr>,
    span: Span,
) -> Option<Handle<Expr>> {
    let one = |m: &Module, h| m.is_constant(h, 1.0) && m.info(h).ty == Ty::Scalar;
    let zero = |m: &Module, h| m.is_constant(h, 0.0) && m.info(h).ty == Ty::Scalar;
    match op {
        BinaryOp::Mul if one(m, lhs) => Some(rhs),
        BinaryOp::Mul if one(m, rhs) => Some(lhs),
        BinaryOp::Add if zero(m, lhs) => Some(rhs),
        BinaryOp::Add if zero(m, rhs) => Some(lhs),
        _ => node(m, Expr::Binary { op, lhs, rhs }, span),
    }
}

/// The canonical form of `h` (tuples read by channel, lerps, sums inside
/// δ); `None` when that is `h` itself or cannot be built.
pub fn canonical(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    canonical_with(m, h, false)
}

/// [`canonical`], with a channel of an interpolated tuple read as the
/// interpolant of that channel where `channels` is set.
fn canonical_with(m: &mut Module, h: Handle<Expr>, channels: bool) -> Option<Handle<Expr>> {
    rebuilt_bottom_up(m, h, |m, n, span| simplify(m, n, span, channels))
}

/// One canonical step at `h`, its operands already canonical.
fn simplify(m: &mut Module, h: Handle<Expr>, span: Span, channels: bool) -> Option<Handle<Expr>> {
    match m.exprs[h].clone() {
        Expr::Swizzle { value, pattern, len, ty } => {
            read_channel(m, value, (pattern, len, ty), span, channels)
        }
        // x / k = x · (1/k) for a scalar constant k: a scale the
        // combiners and the blender have, where a division per fragment
        // is not (`3·T / 3`, the help's scaling of a float framebuffer).
        Expr::Binary { op: BinaryOp::Div, lhs, rhs } => match m.exprs[rhs].clone() {
            Expr::Constant(c) if c.ty == Ty::Scalar && c.components[0] != 0.0 => {
                let inverse =
                    node(m, Expr::Constant(crate::ir::Constant::scalar(1.0 / c.components[0])), span)?;
                binary(m, BinaryOp::Mul, lhs, inverse, span)
            }
            _ => None,
        },
        // rgba(x, 1)·rgba(y, 1) = rgba(x·y, 1): a colour written as rgba
        // times another (a fused `C ← T; C ← C·x`) is multiplied out as
        // the colours' product.
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } => {
            let rgb = |m: &Module, h: Handle<Expr>| match m.exprs[h] {
                Expr::Convert { value, to: Ty::Rgba } if m.info(value).ty == Ty::Rgb => Some(value),
                _ => None,
            };
            let (x, y) = (rgb(m, lhs)?, rgb(m, rhs)?);
            let product = binary(m, BinaryOp::Mul, x, y, span)?;
            node(m, Expr::Convert { value: product, to: Ty::Rgba }, span)
        }
        Expr::Math { fun: MathFunction::Mix, args }
            if matches!(m.info(args[2]).ty, Ty::Scalar | Ty::Rgb | Ty::Rgba) =>
        {
            // lerp(a, b, f) = a·(1 − f) + b·f (as `ir::eval` defines it; per channel for a colour f).
            let one = node(m, Expr::Constant(crate::ir::Constant::scalar(1.0)), span)?;
            let keep = binary(m, BinaryOp::Sub, one, args[2], span)?;
            let a = binary(m, BinaryOp::Mul, args[0], keep, span)?;
            let b = binary(m, BinaryOp::Mul, args[1], args[2], span)?;
            let sum = binary(m, BinaryOp::Add, a, b, span)?;
            // `lerp(rgb, scalar, f)` is an rgb: so is its sum.
            (m.info(sum).ty == m.info(h).ty).then_some(sum)
        }
        // Colours and scalars only: a direction's sum (`δ(L + V)`) is a
        // cube map's coordinate, which must stay one interpolant.
        Expr::Interpolate { value, to } if matches!(m.info(value).ty, Ty::Rgb | Ty::Rgba | Ty::Scalar) => {
            // A shader's vec3 result read as a colour (`.rgb`) is its sum's
            // too; a scalar sum returned as a colour (`s → c = 0.7·a +
            // 0.4·b`, splat to rgb) is the sum of its terms splat.
            let (inner, retype, splat) = delta::read_through(m, value);
            if let Some(scaled) = delta::scale_kept_out(m, h, inner, (retype, splat, to), span, channels) {
                return Some(scaled);
            }
            // `δ(kd·(a + b))`: the product multiplied out first.
            let expanded = multiply_out(m, inner, MAX_TERMS).unwrap_or(inner);
            let terms = sum_terms(m, expanded);
            if terms.len() < 2 {
                return None;
            }
            let mut acc: Option<Handle<Expr>> = None;
            for t in terms {
                let t = match retype {
                    Some(ty) if m.info(t).ty.width() == 3 && m.info(t).ty != ty => {
                        node(m, Expr::Swizzle { value: t, pattern: [0, 1, 2, 0], len: 3, ty }, span)?
                    }
                    _ => t,
                };
                let t = match splat {
                    Some(to) => node(m, Expr::Convert { value: t, to }, span)?,
                    None => t,
                };
                // δ of a constant is the constant.
                let d = if m.info(t).freq <= Frequency::Uniform {
                    t
                } else {
                    node(m, Expr::Interpolate { value: t, to }, span)?
                };
                acc = Some(match acc {
                    None => d,
                    Some(a) => binary(m, BinaryOp::Add, a, d, span)?,
                });
            }
            acc.filter(|s| m.info(*s).ty == m.info(h).ty)
        }
        // saturate(k·x + b) = saturate(k·(x + b/k)): a combiner's scale.
        Expr::Math { fun: MathFunction::Saturate, .. } => clamp::scale_outside_offset(m, h, span),
        _ => None,
    }
}

/// `value.pattern` simplified: a swizzle of a swizzle is one swizzle, one
/// channel of a tuple is that component.
fn read_channel(
    m: &mut Module,
    value: Handle<Expr>,
    (pattern, len, ty): ([u8; 4], u8, Ty),
    span: Span,
    channels: bool,
) -> Option<Handle<Expr>> {
    match m.exprs[value].clone() {
        Expr::Swizzle { value: inner, pattern: p, .. } => {
            let mut q = [0u8; 4];
            for i in 0..len as usize {
                q[i] = *p.get(pattern[i] as usize)?;
            }
            let once = node(m, Expr::Swizzle { value: inner, pattern: q, len, ty }, span)?;
            Some(read_channel(m, inner, (q, len, ty), span, channels).unwrap_or(once))
        }
        // A channel of an interpolated tuple is the interpolant of that
        // channel, `(δ v).r` = `δ(v.r)` (interpolation is linear,
        // component by component): one scalar interpolant, where the
        // channel of an rgb one costs a combiner to extract.
        Expr::Interpolate { value: inner, to } if channels && len == 1 && tuple(m, inner) => {
            let once = node(m, Expr::Swizzle { value: inner, pattern, len, ty }, span)?;
            let c = read_channel(m, inner, (pattern, len, ty), span, channels).unwrap_or(once);
            let d = if m.info(c).freq <= Frequency::Uniform {
                c
            } else {
                node(m, Expr::Interpolate { value: c, to }, span)?
            };
            (m.info(d).ty == ty).then_some(d)
        }
        Expr::Compose { components, .. } if len == 1 => {
            let mut at = pattern[0] as usize;
            for c in components {
                let w = m.info(c).ty.width();
                if at < w {
                    return if w == 1 {
                        (m.info(c).ty == ty).then_some(c)
                    } else {
                        node(m, Expr::Swizzle { value: c, pattern: [at as u8, 0, 0, 0], len: 1, ty }, span)
                    };
                }
                at -= w;
            }
            None
        }
        _ => None,
    }
}

/// Whether `h` is a tuple, `(a, b, c)` or its `.rgb`: what a shader
/// returning several values gives.
fn tuple(m: &Module, h: Handle<Expr>) -> bool {
    match m.exprs[h] {
        Expr::Compose { .. } => true,
        Expr::Swizzle { value, .. } => matches!(m.exprs[value], Expr::Compose { .. }),
        _ => false,
    }
}

/// The terms of a sum (`+`, `⊕[add]`) rooted at `h`; `[h]` for anything else.
fn sum_terms(m: &Module, h: Handle<Expr>) -> Vec<Handle<Expr>> {
    m.chain_operands(h, |e| {
        matches!(e, Expr::Binary { op: BinaryOp::Add, .. } | Expr::Combine { mode: CombineMode::Add, .. })
    })
}

/// The factors of a product (`*`, `⊕` modulate) rooted at `h`; `[h]` else.
fn product_factors(m: &Module, h: Handle<Expr>) -> Vec<Handle<Expr>> {
    m.chain_operands(h, |e| {
        matches!(
            e,
            Expr::Binary { op: BinaryOp::Mul, .. } | Expr::Combine { mode: CombineMode::Modulate, .. }
        )
    })
}

/// `h` as a sum of products, each term its factors in the order written;
/// `None` past `max` terms.
fn expansion(m: &Module, h: Handle<Expr>, max: usize) -> Option<Vec<Vec<Handle<Expr>>>> {
    let terms = sum_terms(m, h);
    if terms.len() > 1 {
        let mut out = Vec::new();
        for t in terms {
            out.extend(expansion(m, t, max)?);
            if out.len() > max {
                return None;
            }
        }
        return Some(out);
    }
    let factors = product_factors(m, h);
    if factors.len() == 1 {
        return Some(vec![vec![h]]);
    }
    let mut out: Vec<Vec<Handle<Expr>>> = vec![vec![]];
    for f in factors {
        let sub = expansion(m, f, max)?;
        if out.len() * sub.len() > max {
            return None;
        }
        if let [one] = &sub[..] {
            // A factor that is no sum: appended in place (a long product
            // copied per factor was quadratic in its length).
            out.iter_mut().for_each(|a| a.extend_from_slice(one));
        } else {
            out = out.iter().flat_map(|a| sub.iter().map(move |b| [a.clone(), b.clone()].concat())).collect();
        }
    }
    Some(out)
}

/// `h` multiplied out (every product distributed over its sums), under an
/// rgba conversion too (`rgba(x, 1)` of a sum: the colour multiplied out);
/// `None` when nothing distributes, past `max` terms, or ill-typed.
pub fn multiply_out(m: &mut Module, h: Handle<Expr>, max: usize) -> Option<Handle<Expr>> {
    multiplied_out(m, h, max, true, true)
}

/// [`multiply_out`], with like terms collected or each kept apart: `X + X`
/// splits into two passes of `X` where `2·X` may leave [0, 1] in a
/// temporary (`T0⁴·(δg + δg)`, `δg` in [0, 0.6]).
fn multiplied_out(
    m: &mut Module,
    h: Handle<Expr>,
    max: usize,
    collect: bool,
    into_delta: bool,
) -> Option<Handle<Expr>> {
    if let Expr::Convert { value, to: Ty::Rgba } = m.exprs[h] {
        if matches!(m.info(value).ty, Ty::Rgb | Ty::Vec3 | Ty::Scalar) {
            let inner = multiplied_out(m, value, max, collect, into_delta)?;
            return node(m, Expr::Convert { value: inner, to: Ty::Rgba }, m.span(h));
        }
    }
    let terms = expansion(m, h, max)?;
    let span = m.span(h);
    let mut sum: Option<Handle<Expr>> = None;
    let terms = if collect { like_terms_collected(m, terms, span)? } else { terms };
    for factors in terms {
        let factors = if into_delta { constants_into_delta(m, factors, span)? } else { factors };
        let factors = constants_folded(m, factors, span)?;
        let factors = scales_last(m, factors);
        let mut product = factors[0];
        for f in &factors[1..] {
            product = binary(m, BinaryOp::Mul, product, *f, span)?;
        }
        sum = Some(match sum {
            None => product,
            Some(s) => binary(m, BinaryOp::Add, s, product, span)?,
        });
    }
    sum.filter(|s| *s != h && m.info(*s).ty == m.info(h).ty)
}

/// A term's scalar constants (those left outside its δ) folded into one,
/// in the place of the first: `T3·0.9·0.4` is `T3·0.36`, one texture
/// environment stage and one combiner constant where the product as
/// written takes two. A term with at most one is as it was.
fn constants_folded(m: &mut Module, factors: Vec<Handle<Expr>>, span: Span) -> Option<Vec<Handle<Expr>>> {
    let scalar = |m: &Module, f: Handle<Expr>| match &m.exprs[f] {
        Expr::Constant(c) if c.ty == Ty::Scalar => Some(c.components[0]),
        _ => None,
    };
    let constants: Vec<f64> = factors.iter().filter_map(|f| scalar(m, *f)).collect();
    if constants.len() < 2 || factors.len() == constants.len() {
        return Some(factors);
    }
    let k = node(m, Expr::Constant(crate::ir::Constant::scalar(constants.iter().product())), span)?;
    let mut out = Vec::with_capacity(factors.len());
    let mut placed = false;
    for f in factors {
        match scalar(m, f) {
            Some(_) if placed => {}
            Some(_) => {
                out.push(k);
                placed = true;
            }
            None => out.push(f),
        }
    }
    Some(out)
}

/// A term's scalar constants past 1 moved after its other factors, in
/// order: `3·(δp).r·T1·T1` is computed `((δp).r·T1·T1)·3`, the scale
/// applied last (a combiner's output scale), where `3·(δp).r` first would
/// leave [−1, 1] and be clamped by the general combiners before `T1`
/// brings it down — as `3·mix(…)` written so is.
fn scales_last(m: &Module, mut factors: Vec<Handle<Expr>>) -> Vec<Handle<Expr>> {
    let past_one = |h: &Handle<Expr>| matches!(&m.exprs[*h], Expr::Constant(c) if c.ty == Ty::Scalar && c.components[0] > 1.0);
    if factors.len() > 1 {
        factors.sort_by_key(past_one);
    }
    factors
}

/// The terms of a sum of products with like terms collected: terms with
/// the same factors (in any order) but for scalar constants are one term,
/// their coefficients added — `ab + ba` = `2·ab`, what the square of a sum
/// multiplied out needs (`(T0·T1 + T2·T3)²` has one cross term `2·T0·T1·T2·T3`,
/// one product to split, not two). Terms without like terms are kept as
/// written.
fn like_terms_collected(m: &mut Module, terms: Terms, span: Span) -> Option<Terms> {
    let scalar = |m: &Module, f: Handle<Expr>| match &m.exprs[f] {
        Expr::Constant(c) if c.ty == Ty::Scalar => Some(c.components[0]),
        _ => None,
    };
    // (the other factors sorted, the coefficient, the term as written, how many)
    type Like = (Vec<Handle<Expr>>, f64, Vec<Handle<Expr>>, usize);
    let mut like: Vec<Like> = Vec::new();
    for t in terms {
        let mut key: Vec<Handle<Expr>> = t.iter().copied().filter(|f| scalar(m, *f).is_none()).collect();
        key.sort();
        let k: f64 = t.iter().filter_map(|f| scalar(m, *f)).product();
        match like.iter_mut().find(|l| l.0 == key && !key.is_empty()) {
            Some(l) => {
                l.1 += k;
                l.3 += 1;
            }
            None => like.push((key, k, t, 1)),
        }
    }
    let mut out = Vec::with_capacity(like.len());
    for (_, k, written, n) in like {
        if n == 1 {
            out.push(written);
            continue;
        }
        let others: Vec<Handle<Expr>> = written.into_iter().filter(|f| scalar(m, *f).is_none()).collect();
        if k == 0.0 {
            continue;
        }
        let c = node(m, Expr::Constant(crate::ir::Constant::scalar(k)), span)?;
        out.push([vec![c], others].concat());
    }
    if out.is_empty() {
        out.push(vec![node(m, Expr::Constant(crate::ir::Constant::scalar(0.0)), span)?]);
    }
    Some(out)
}

/// A constant factor written just before a δ moved inside it:
/// `k·δv` = `δ(k·v)` (interpolation is linear), which spends no constant
/// register and no combiner stage on `k` per fragment, and keeps equal
/// interpolants one interpolant (`(0.3·δa)·(0.3·δa)` reads one colour).
/// Constants elsewhere in the term (`δa·0.6·(1 − f)·T`, the `1 − 0.4` of
/// an outer `lerp` multiplied out after the δ) go into its last δ before
/// them, or its first ([`constant_into_delta`]).
fn constants_into_delta(m: &mut Module, factors: Vec<Handle<Expr>>, span: Span) -> Option<Vec<Handle<Expr>>> {
    let mut out: Vec<Handle<Expr>> = Vec::with_capacity(factors.len());
    let mut i = 0;
    while i < factors.len() {
        let f = factors[i];
        let next = factors.get(i + 1).map(|n| m.exprs[*n].clone());
        if let (Expr::Constant(_), Some(Expr::Interpolate { value, to })) = (&m.exprs[f], next) {
            let k = binary(m, BinaryOp::Mul, f, value, span)?;
            let moved = node(m, Expr::Interpolate { value: k, to }, span)?;
            // Not where it would leave the [0, 1] an 8-bit interpolant
            // holds (`2·δ(0.8·l)`: the 2 is a combiner's output scale).
            let (was, now) = (m.info(factors[i + 1]).interval, m.info(moved).interval);
            if m.info(moved).ty == m.info(factors[i + 1]).ty && (unit(now) || !unit(was)) {
                out.push(moved);
                i += 2;
                continue;
            }
        }
        out.push(f);
        i += 1;
    }
    let mut i = 0;
    while i < out.len() {
        if matches!(m.exprs[out[i]], Expr::Constant(_)) && out.len() > 1 {
            if let Some(at) = constant_into_delta(m, &mut out, i, span) {
                out.remove(at);
                continue;
            }
        }
        i += 1;
    }
    Some(out)
}

/// Whether every value of `i` lies in [0, 1] (what an 8-bit interpolant holds).
fn unit(i: crate::ir::Interval) -> bool {
    i.lo >= 0.0 && i.hi <= 1.0
}

/// The constant `factors[k]` moved into the term's last δ before it (else
/// its first after), `δv·k` = `δ(k·v)`, where the δ keeps its type and
/// stays in [0, 1] if it was (an 8-bit interpolant holds it; `2·δv` may
/// leave it, and is left to the fragment); the index to remove, or `None`.
fn constant_into_delta(m: &mut Module, factors: &mut [Handle<Expr>], k: usize, span: Span) -> Option<usize> {
    let before = (0..k).rev();
    let after = k + 1..factors.len();
    for d in before.chain(after) {
        let Expr::Interpolate { value, to } = m.exprs[factors[d]] else { continue };
        let scaled = binary(m, BinaryOp::Mul, factors[k], value, span)?;
        let moved = node(m, Expr::Interpolate { value: scaled, to }, span)?;
        let (was, now) = (m.info(factors[d]).interval, m.info(moved).interval);
        if m.info(moved).ty == m.info(factors[d]).ty && (unit(now) || !unit(was)) {
            factors[d] = moved;
            return Some(k);
        }
        return None;
    }
    None
}

/// The greatest intensity light `i` of `lights` delivers anywhere: its
/// colour's largest component over the constant attenuation (GL 1.2.1
/// §2.13.1: colour · spot / (k_c + k_l·d + k_q·d²), the spot factor ≤ 1);
/// 0 for a light the scene lacks (it is black on every executor); `None`
/// when the attenuation can grow (a negative or zero coefficient).
fn greatest_intensity(lights: &[crate::scene::Light], i: usize) -> Option<f64> {
    use crate::scene::Light;
    let Some(light) = lights.get(i) else { return Some(0.0) };
    let (color, attenuation) = match light {
        Light::Directional { color, .. } => (*color, crate::scene::light::Attenuation::default()),
        Light::Point { color, attenuation, .. } | Light::Spot { color, attenuation, .. } => {
            (*color, *attenuation)
        }
    };
    let grows = attenuation.constant <= 0.0 || attenuation.linear < 0.0 || attenuation.quadratic < 0.0;
    (!grows).then(|| f64::from(color.max_element().max(0.0)) / f64::from(attenuation.constant))
}

/// Every `intensity(i)` of `m`'s statements bounded by what the scene's
/// light `i` delivers (`greatest_intensity`): `min(I, b)`, equal to `I`
/// on the scene, with the range [0, b] where the declaration's was
/// [0, ∞). A sum of lights scaled by their intensities then fits the
/// target's 8-bit interpolants where the scene's lights are dim enough
/// (the planner splits it across δ), instead of being refused for an
/// unbounded range. The statements changed.
pub fn bound_intensities(m: &mut Module, lights: &[crate::scene::Light]) -> Vec<usize> {
    use crate::parser::ast::VectorKind;
    let roots: Vec<Handle<Expr>> = m.statements.iter().map(|s| s.value).collect();
    let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::default();
    for h in m.reachable(&roots) {
        let Expr::Vector { vector, .. } = m.exprs[h] else { continue };
        let d = &m.vectors[vector as usize];
        if d.kind != Some(VectorKind::Intensity) || m.info(h).interval.hi.is_finite() {
            continue;
        }
        let Some(b) = greatest_intensity(lights, d.index.unwrap_or(0) as usize) else { continue };
        let span = m.span(h);
        let bound = node(m, Expr::Constant(crate::ir::Constant::scalar(b)), span);
        if let Some(min) =
            bound.and_then(|b| node(m, Expr::Math { fun: MathFunction::Min, args: vec![h, b] }, span))
        {
            map.insert(h, min);
        }
    }
    let mut changed = Vec::new();
    if map.is_empty() {
        return changed;
    }
    for i in 0..m.statements.len() {
        let v = m.statements[i].value;
        if let Some(nv) = super::substitute(m, v, &map).filter(|nv| *nv != v) {
            m.statements[i].value = nv;
            changed.push(i);
        }
    }
    changed
}

/// Rewrites every statement of `m` into its canonical form (what a target
/// without arithmetic beyond the texture environment needs of a `lerp`),
/// a `saturate` written whole into an 8-bit framebuffer left to its clamp
/// (`clamped` says where: `rgba(saturate(x), 1)` → `rgba(x, 1)`); the
/// statements changed.
pub fn canonical_statements(
    m: &mut Module,
    clamped: impl Fn(&mut Module, usize) -> Option<Handle<Expr>>,
) -> Vec<usize> {
    let mut changed = Vec::new();
    for i in 0..m.statements.len() {
        let unclamped = clamped(m, i);
        let v = unclamped.unwrap_or(m.statements[i].value);
        if let Some(c) = canonical(m, v).or(unclamped) {
            m.statements[i].value = c;
            changed.push(i);
        }
    }
    changed
}

#[cfg(test)]
mod tests;
