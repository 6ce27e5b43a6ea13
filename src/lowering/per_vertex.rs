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

/// `x`'s per-vertex counterpart: every `δ v` in it replaced by `v`;
/// `None` when `x` reads anything per sample but interpolants (a texture,
/// a framebuffer, the pixel).
pub fn at_vertex(m: &mut Module, x: Handle<Expr>) -> Option<Handle<Expr>> {
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
            let mut ok = true;
            let mut ops = Vec::new();
            for o in e.operands() {
                match at_vertex(m, o) {
                    Some(v) => ops.push(v),
                    None => ok = false,
                }
            }
            if !ok {
                return None;
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
            let v = at_vertex(m, coords)?;
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
pub fn gouraud(r: &mut Rewriter, value: Handle<Expr>) -> Handle<Expr> {
    let value = vertex_terms_grouped(&mut r.m, value);
    r.top_down(value, &mut |r, h| apply(r, h, "this part of the statement", r.m.span(h)))
}

/// `h` with each sum's per-sample terms that [`at_vertex`] can compute
/// gathered into one sum of their own, after the other terms.
fn vertex_terms_grouped(m: &mut Module, h: Handle<Expr>) -> Handle<Expr> {
    let mut done: rustc_hash::FxHashMap<Handle<Expr>, Handle<Expr>> = Default::default();
    for n in m.reachable(&[h]) {
        let e = m.exprs[n].map_operands(|o| *done.get(&o).unwrap_or(&o));
        let rebuilt = if e == m.exprs[n] { n } else { m.intern(e, m.span(n)).unwrap_or(n) };
        let grouped = match m.exprs[rebuilt] {
            Expr::Binary { op: BinaryOp::Add, .. } => regrouped(m, rebuilt),
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
    let mut terms = Vec::new();
    let mut stack = vec![h];
    while let Some(x) = stack.pop() {
        match m.exprs[x] {
            Expr::Binary { op: BinaryOp::Add, lhs, rhs } => stack.extend([rhs, lhs]),
            _ => terms.push(x),
        }
    }
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
