//! Rule `per_vertex`: a per-fragment value that depends on the fragment
//! only through interpolated values is computed per vertex and
//! interpolated instead — Pipeline Grammar, eq. (1) `δ p s x` in place of (4)
//! `p δ s x` for that part. Exact at the vertices; between them the error
//! grows with how far the function bends over a triangle, so the rule
//! states no bound of its own: a scene measures it (`render`, `bench`).
//!
//! It makes the coordinates of the other rules: a normalization cube map
//! or a table is indexed by an interpolated value (texgen), which is what
//! a GeForce 256 can do without texture shaders.

use super::Rewriter;
use crate::ir::{BinaryOp, Expr, Handle, MathFunction, Module};
use crate::parser::ast::TextureFormat;
use crate::pipeline::ApproximationCost;
use crate::span::Span;
use rustc_hash::FxHashMap;

/// `x`'s per-vertex counterpart: every `δ v` in it replaced by `v`;
/// `None` when `x` reads anything per sample but interpolants (a texture,
/// a framebuffer, the pixel). Each node is rewritten once (a value read
/// twice is one node: `let a₁ = a₀·a₀; …` visited as a tree doubles per
/// level).
pub fn at_vertex(m: &mut Module, x: Handle<Expr>) -> Option<Handle<Expr>> {
    at_vertex_once(m, x, &mut FxHashMap::default())
}

fn at_vertex_once(
    m: &mut Module,
    x: Handle<Expr>,
    done: &mut FxHashMap<Handle<Expr>, Option<Handle<Expr>>>,
) -> Option<Handle<Expr>> {
    if let Some(r) = done.get(&x) {
        return *r;
    }
    let r = at_vertex_node(m, x, done);
    done.insert(x, r);
    r
}

fn at_vertex_node(
    m: &mut Module,
    x: Handle<Expr>,
    done: &mut FxHashMap<Handle<Expr>, Option<Handle<Expr>>>,
) -> Option<Handle<Expr>> {
    let info = m.info(x);
    if !info.freq.is_sample() {
        return Some(x);
    }
    match &m.exprs[x] {
        Expr::Interpolate { value, .. } => Some(*value),
        Expr::Unary { .. }
        | Expr::Binary { .. }
        | Expr::Math { .. }
        | Expr::Swizzle { .. }
        | Expr::Compose { .. }
        | Expr::Convert { .. }
        // A step (`s_self`, seeds/000 (7)) per vertex is a ramp across the
        // triangle: the smoothing Section 4.5 suggests against popping.
        | Expr::Select { reject: Some(_), .. } => {
            let e = m.exprs[x].clone();
            let mut ops = Vec::new();
            for o in e.operands() {
                ops.push(at_vertex_once(m, o, done)?);
            }
            let mut it = ops.into_iter();
            // One rewritten operand per operand, in order (`operands`).
            let e = e.map_operands(|o| it.next().unwrap_or(o));
            m.intern(e, m.span(x)).ok()
        }
        Expr::Lookup { texture, coords }
            if m.textures[*texture as usize].tabulates == Some(crate::ir::Tabulated::Normalize) =>
        {
            let (texture, coords) = (*texture, *coords);
            let v = at_vertex_once(m, coords, done)?;
            normalized_texel(m, texture, v, m.span(x))
        }
        _ => None,
    }
}

/// What a normalization cube map holds at direction `v`: `normalize(v)`,
/// compressed to [0, 1] unless the format is signed, with the texel's type.
fn normalized_texel(m: &mut Module, texture: u32, v: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let mut n = m.intern(Expr::Math { fun: MathFunction::Normalize, args: vec![v] }, span).ok()?;
    if !matches!(m.textures[texture as usize].format, TextureFormat::Signed8 | TextureFormat::Signed16) {
        n = m.intern(Expr::Math { fun: MathFunction::Compress, args: vec![n] }, span).ok()?;
    }
    super::as_texel(m, texture, n, span)
}

/// `δ(x at the vertices)`, recorded as a `per_vertex` approximation of
/// `what` at `span`; `None` when `x` cannot be computed per vertex.
pub fn apply(r: &mut Rewriter, x: Handle<Expr>, what: &str, span: Span) -> Option<Handle<Expr>> {
    let to = r.m.info(x).freq;
    let mut v = at_vertex(&mut r.m, x)?;
    // A colour leaving [0, 1] is clamped as GL clamps a vertex colour.
    let iv = r.m.info(v).interval;
    let clamped = r.m.info(v).ty.is_color() && (iv.lo < 0.0 || iv.hi > 1.0);
    if clamped {
        v = r.node(Expr::Math { fun: MathFunction::Saturate, args: vec![v] }, span)?;
    }
    let h = r.node(Expr::Interpolate { value: v, to }, span)?;
    r.record(
        "per_vertex",
        span,
        Some(h),
        format!(
            "{what} is computed per vertex and interpolated{} (the target cannot compute it per fragment)",
            if clamped { ", clamped to [0, 1] as a vertex colour" } else { "" }
        ),
        ApproximationCost::default(),
        None,
    );
    Some(h)
}

/// `value` with every maximal per-fragment part that reads nothing per
/// sample but interpolated values computed per vertex ([`apply`]): Pipeline Grammar
/// (1) for everything (1) can express — Gouraud shading, the choice of last
/// resort when no per-fragment rule makes a statement plan. Lookups,
/// framebuffer reads and the pixel stay per fragment, and so do the parts
/// of their coordinates that are interpolated values already.
///
/// The terms of a sum that can be computed per vertex are one part
/// however the sum is parenthesized (`T0 + δa + δb` is `T0 + δ(a + b)`,
/// as `T0 + (δa + δb)` is): addition is associative, and the rule's
/// verdict should not depend on how the sum was written.
///
/// An interpolated colour already in the program whose bounded range
/// passes 1 (`δ l` of a sum of lights reaching 1.04) is clamped as GL
/// clamps a vertex colour, as the same sum made here one part is: the
/// verdict should not depend on whether the sum was written inside one δ
/// or one δ a light.
pub fn gouraud(r: &mut Rewriter, value: Handle<Expr>) -> Handle<Expr> {
    let value = vertex_terms_grouped(&mut r.m, value);
    let value = r.top_down(value, &mut |r, h| apply(r, h, "this part of the statement", r.m.span(h)));
    wide_interpolants_clamped(r, value)
}

/// [`gouraud`], except that a sum of colours computable per vertex whose
/// range leaves [0, 1] is not made one part: GL clamps a vertex colour to
/// [0, 1] (OpenGL 1.2.1, Section 2.13.9), so two lights summed in one
/// vertex colour lose what passes 1 between them, where each term
/// interpolated on its own (clamped on its own, if at all) and summed per
/// fragment keeps it — the split a user would write by hand, `δ l₁ s x ⊕
/// δ l₂ s x`. Interpolation is linear, so where nothing is clamped the
/// two agree; which is closer where something is, a scene measures
/// (`accuracy`), and the planner splits the sum of interpolants into
/// passes as the target allows. Each sum split so is counted in
/// [`Rewriter::split_sums`].
pub fn gouraud_by_term(r: &mut Rewriter, value: Handle<Expr>) -> Handle<Expr> {
    let value = vertex_terms_grouped(&mut r.m, value);
    let mut terms = rustc_hash::FxHashSet::default();
    let value = r.top_down(value, &mut move |r, h| {
        if clamped_sum(&mut r.m, h) {
            r.split_sums += 1;
            terms.extend(r.m.exprs[h].operands());
            return None; // its terms, each its own part
        }
        let what = if terms.contains(&h) { "this term of a sum" } else { "this part of the statement" };
        apply(r, h, what, r.m.span(h))
    });
    wide_interpolants_clamped(r, value)
}

/// Whether `h` is a sum of colours, read per sample and computable per
/// vertex, whose range leaves [0, 1]: one vertex colour would clamp it.
fn clamped_sum(m: &mut Module, h: Handle<Expr>) -> bool {
    let i = *m.info(h);
    matches!(m.exprs[h], Expr::Binary { op: BinaryOp::Add, .. })
        && i.ty.is_color()
        && i.freq.is_sample()
        && (i.interval.lo < 0.0 || i.interval.hi > 1.0)
        && at_vertex(m, h).is_some()
}

/// `h` with each interpolated colour whose range is bounded,
/// not negative and past 1 replaced by its clamped counterpart
/// ([`apply`]).
fn wide_interpolants_clamped(r: &mut Rewriter, h: Handle<Expr>) -> Handle<Expr> {
    let mut done: rustc_hash::FxHashMap<Handle<Expr>, Handle<Expr>> = Default::default();
    for n in r.m.reachable(&[h]) {
        let e = r.m.exprs[n].map_operands(|o| *done.get(&o).unwrap_or(&o));
        let rebuilt = if e == r.m.exprs[n] { n } else { r.m.intern(e, r.m.span(n)).unwrap_or(n) };
        let i = *r.m.info(rebuilt);
        let wide = super::is_interpolant(&r.m, rebuilt)
            && i.ty.is_color()
            && i.interval.lo >= 0.0
            && i.interval.hi > 1.0
            && i.interval.hi.is_finite();
        let to = if wide {
            apply(r, rebuilt, "this interpolated colour", r.m.span(rebuilt)).unwrap_or(rebuilt)
        } else {
            rebuilt
        };
        done.insert(n, to);
    }
    done.get(&h).copied().unwrap_or(h)
}

/// `h` with each sum's per-sample terms that [`at_vertex`] can compute
/// gathered into one sum of their own, after the other terms.
fn vertex_terms_grouped(m: &mut Module, h: Handle<Expr>) -> Handle<Expr> {
    let mut done: rustc_hash::FxHashMap<Handle<Expr>, Handle<Expr>> = Default::default();
    for n in m.reachable(&[h]) {
        let e = m.exprs[n].map_operands(|o| *done.get(&o).unwrap_or(&o));
        let rebuilt = if e == m.exprs[n] { n } else { m.intern(e, m.span(n)).unwrap_or(n) };
        let grouped = match m.exprs[rebuilt] {
            Expr::Binary { op: BinaryOp::Add, .. } => {
                regrouped(m, rebuilt).or_else(|| cofactors_regrouped(m, rebuilt))
            }
            Expr::Binary { op: BinaryOp::Mul, .. } | Expr::Math { fun: MathFunction::Mix, .. } => {
                cofactors_regrouped(m, rebuilt)
            }
            _ => None,
        };
        done.insert(n, grouped.unwrap_or(rebuilt));
    }
    done.get(&h).copied().unwrap_or(h)
}

/// The sum at `h` as (its other terms) + (its terms computable per
/// vertex), where at least two are computable and one is not; `None`
/// else or when ill-typed.
fn regrouped(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    let terms = m.chain_operands(h, |e| matches!(e, Expr::Binary { op: BinaryOp::Add, .. }));
    let (vertex, others): (Vec<_>, Vec<_>) =
        terms.into_iter().partition(|t| m.info(*t).freq.is_sample() && at_vertex(m, *t).is_some());
    if vertex.len() < 2 || others.is_empty() {
        return None;
    }
    let span = m.span(h);
    let sum = |m: &mut Module, terms: &[Handle<Expr>]| -> Option<Handle<Expr>> {
        let mut s = terms[0];
        for t in &terms[1..] {
            s = m.intern(Expr::Binary { op: BinaryOp::Add, lhs: s, rhs: *t }, span).ok()?;
        }
        Some(s)
    };
    let (a, b) = (sum(m, &others)?, sum(m, &vertex)?);
    m.intern(Expr::Binary { op: BinaryOp::Add, lhs: a, rhs: b }, span).ok()
}

/// At most this many terms in [`linear_terms`]: past it the statement is
/// left as written.
const MAX_LINEAR_TERMS: usize = 12;

/// `h` as a sum of products, each term its factors: sums, `lerp`s with a
/// weight not read per fragment (`a·(1 − f) + b·f`) and scalar constants distributed
/// over them (`4·lerp(g, δl + T, 0.4)` is `4·g·0.6 + 4·δl·0.4 +
/// 4·T·0.4`); another product's factors kept whole. `None` past
/// [`MAX_LINEAR_TERMS`].
fn linear_terms(m: &mut Module, h: Handle<Expr>) -> Option<Vec<Vec<Handle<Expr>>>> {
    let constant = |m: &Module, x: Handle<Expr>| matches!(&m.exprs[x], Expr::Constant(c) if c.ty == crate::ir::Ty::Scalar);
    let out = match m.exprs[h].clone() {
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } => {
            let mut a = linear_terms(m, lhs)?;
            a.extend(linear_terms(m, rhs)?);
            a
        }
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } if constant(m, lhs) || constant(m, rhs) => {
            let (k, x) = if constant(m, lhs) { (lhs, rhs) } else { (rhs, lhs) };
            linear_terms(m, x)?.into_iter().map(|t| [vec![k], t].concat()).collect()
        }
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } => {
            let mut a = product_of(m, lhs);
            a.extend(product_of(m, rhs));
            vec![a]
        }
        // A weight read per fragment (`T3.a`) keeps the lerp one term: its
        // terms `x·(1 − a)` share no part a vertex computes.
        Expr::Math { fun: MathFunction::Mix, args }
            if m.info(args[2]).ty == crate::ir::Ty::Scalar && !m.info(args[2]).freq.is_sample() =>
        {
            let span = m.span(h);
            let one = m.intern(Expr::Constant(crate::ir::Constant::scalar(1.0)), span).ok()?;
            let keep = m.intern(Expr::Binary { op: BinaryOp::Sub, lhs: one, rhs: args[2] }, span).ok()?;
            let mut a: Vec<Vec<Handle<Expr>>> =
                linear_terms(m, args[0])?.into_iter().map(|t| [t, vec![keep]].concat()).collect();
            a.extend(linear_terms(m, args[1])?.into_iter().map(|t| [t, vec![args[2]]].concat()));
            a
        }
        _ => vec![vec![h]],
    };
    (out.len() <= MAX_LINEAR_TERMS).then_some(out)
}

/// The factors of a product rooted at `h` (`[h]` for anything else).
fn product_of(m: &Module, h: Handle<Expr>) -> Vec<Handle<Expr>> {
    m.chain_operands(h, |e| matches!(e, Expr::Binary { op: BinaryOp::Mul, .. }))
}

/// The sum, `lerp` or scaled sum at `h` ([`linear_terms`]) with the terms
/// that share their per-fragment factors (`X·δa + X·δb`, `X` none or a
/// lookup) written as those factors times the sum of the rest, which
/// [`at_vertex`] computes: `X·(δa + δb)`, one part per vertex where the
/// terms were two. The rule's verdict should not depend on whether a
/// product is written over a sum or multiplied out (`T5·(δl + (δp).g)`
/// against `T5·δl + T5·(δp).g`, `4·lerp((δp).g, δl + T1, 0.4)` against
/// its expansion). `None` when no two terms share them.
fn cofactors_regrouped(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    let terms = linear_terms(m, h)?;
    if terms.len() < 2 {
        return None;
    }
    // Per term: (its per-fragment factors, sorted; the factors computable
    // per vertex; whether one of them is read per sample).
    type Split = (Vec<Handle<Expr>>, Vec<Handle<Expr>>, bool);
    let mut split: Vec<Split> = Vec::with_capacity(terms.len());
    for t in &terms {
        let (mut key, mut vertex, mut sampled) = (Vec::new(), Vec::new(), false);
        for &f in t {
            let per_sample = m.info(f).freq.is_sample();
            // A scale past 1 stays out of the part (`3·δa + 3·δb` is
            // `3·δ(a + b)`): inside, it would take the vertex colour past
            // the [0, 1] GL clamps it to, where written it is the
            // fragment's.
            let scale = matches!(&m.exprs[f], Expr::Constant(c) if c.ty == crate::ir::Ty::Scalar && c.components[0] > 1.0);
            if !scale && (!per_sample || at_vertex(m, f).is_some()) {
                vertex.push(f);
                sampled |= per_sample;
            } else {
                key.push(f);
            }
        }
        key.sort();
        split.push((key, vertex, sampled));
    }
    let shared =
        |i: usize| split[i].2 && (0..split.len()).any(|j| j != i && split[j].2 && split[j].0 == split[i].0);
    let grouped: Vec<bool> = (0..split.len()).map(shared).collect();
    // Nothing shared, or every term one part already (`top_down` takes it).
    if !grouped.iter().any(|g| *g) || split.iter().all(|s| s.0.is_empty() && s.2) {
        return None;
    }
    let span = m.span(h);
    let product = |m: &mut Module, fs: &[Handle<Expr>]| -> Option<Handle<Expr>> {
        let mut p = *fs.first()?;
        for f in &fs[1..] {
            p = m.intern(Expr::Binary { op: BinaryOp::Mul, lhs: p, rhs: *f }, span).ok()?;
        }
        Some(p)
    };
    let add = |m: &mut Module, a: Option<Handle<Expr>>, b: Handle<Expr>| -> Option<Handle<Expr>> {
        match a {
            None => Some(b),
            Some(a) => m.intern(Expr::Binary { op: BinaryOp::Add, lhs: a, rhs: b }, span).ok(),
        }
    };
    let mut sum = None;
    for (i, t) in terms.iter().enumerate() {
        if !grouped[i] {
            let p = product(m, t)?;
            sum = Some(add(m, sum, p)?);
        }
    }
    let mut done = vec![false; split.len()];
    for i in 0..split.len() {
        if !grouped[i] || done[i] {
            continue;
        }
        let mut part = None;
        for j in i..split.len() {
            if grouped[j] && !done[j] && split[j].0 == split[i].0 {
                done[j] = true;
                let p = product(m, &split[j].1)?;
                part = Some(add(m, part, p)?);
            }
        }
        let mut term = part?;
        // Not into a part of unbounded range: no vertex colour holds it
        // (each term of it, an interpolant of its own, is refused as such).
        if !(m.info(term).interval.lo.is_finite() && m.info(term).interval.hi.is_finite()) {
            return None;
        }
        for &f in &split[i].0 {
            term = m.intern(Expr::Binary { op: BinaryOp::Mul, lhs: f, rhs: term }, span).ok()?;
        }
        sum = Some(add(m, sum, term)?);
    }
    sum.filter(|s| *s != h && m.info(*s).ty == m.info(h).ty)
}
