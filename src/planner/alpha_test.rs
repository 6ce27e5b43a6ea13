//! A discard `c ? a` on a register-combiner target, as GL 1.x makes it:
//! the condition is brought into the fragment's alpha — the final
//! combiner's alpha output is its G input (NV_register_combiners) — and
//! the alpha test (`glAlphaFunc`, OpenGL 1.2.1, Section 4.1.4) drops the
//! fragments the program drops. The card has no other way to drop a
//! fragment in these passes: a plan whose condition is only in the IR is
//! one it cannot run. Stencil writes set or cleared where a condition
//! holds (`stencil.rs`) are such discards, with no colour written.
//!
//! Three ways, tried in order; the first the combiner code generator
//! realizes is the pass:
//!
//! | the pass | the fragment's alpha | the test |
//! |---|---|---|
//! | the value's own alpha is the compared `x` (`(T).a > k ? T`) | as written | `x FUNC k` |
//! | writes no alpha (a stencil write, a later pass of a split, `rgb8`) | `x` (or a difference, below) | `x FUNC k`, the alpha write masked |
//! | writes alpha 1 (an rgb value widened) | the condition, 0 or 1, computed by the combiners | `GL_GREATER 0` |
//!
//! `x FUNC k` keeps exactly the fragments `x > k` keeps where the alpha is
//! clamped to [0, 1] (Section 2.13.9): with `0 ≤ k < 1` for `>` and `≤`,
//! `0 < k ≤ 1` for `≥` and `<`. Another comparison `p OP q` compares a
//! difference with 0: `p > q` as `p − q > 0`, `p ≥ q` as `q − p ≤ 0`. A
//! condition no way brings into alpha is refused, located
//! (`unsupported-discard`), never planned without its test.

use super::*;
use crate::ir::{Ty, UnaryOp};
use crate::pipeline::{AlphaTest, BlendFactor, CompareFunc};

/// A pass's alpha test, and whether its alpha write is masked (the alpha
/// carries the condition, which the statement does not write).
pub(super) type Routed = (AlphaTest, bool);

/// On a register-combiner target, every discarding piece of `chosen`
/// rewritten to carry its condition in alpha; the alpha test of each
/// piece, in the order `assemble` makes passes. The refusals of the
/// pieces none of the ways above realizes.
pub(super) fn route(
    m: &mut Module,
    profile: &Profile,
    realizer: Option<&dyn Realizer>,
    chosen: &mut [Chosen],
) -> Result<Vec<Routed>, Vec<Diagnostic>> {
    let mut routed = Vec::new();
    let mut refused = Vec::new();
    let combiners = matches!(profile.fragment, FragmentStage::Combiners(_));
    for (stmts, form, pieces, _) in chosen.iter_mut() {
        let st = m.statements[stmts[0]].clone();
        let condition = form.condition.filter(|_| combiners && !m.is_baked(&st));
        for piece in pieces.iter_mut() {
            let Some(c) = condition else {
                routed.push((AlphaTest::DISABLED, false));
                continue;
            };
            match routed_piece(m, realizer, &st, form, piece, c) {
                Ok((value, test, masked)) => {
                    piece.value = value;
                    routed.push((test, masked));
                }
                Err(d) => refused.push(*d),
            }
        }
    }
    if refused.is_empty() {
        Ok(routed)
    } else {
        Err(refused)
    }
}

/// The first way of the table above the generator realizes for `piece`.
fn routed_piece(
    m: &mut Module,
    realizer: Option<&dyn Realizer>,
    st: &Statement,
    form: &Form,
    piece: &Piece,
    c: Handle<Expr>,
) -> Result<(Handle<Expr>, AlphaTest, bool), Box<Diagnostic>> {
    let (rgb, alpha) = parts(m, form, piece.value);
    let writes_alpha = super::assemble::alpha_written(form, piece) && stores_alpha(m, st, piece.dest);
    let blended_by_alpha = reads_source_alpha(piece.blend);
    let mut ways = Vec::new();
    if let Some((x, test)) = direct(m, c) {
        if alpha == Some(x) {
            ways.push((piece.value, test, false));
        } else if !writes_alpha && !blended_by_alpha {
            let value = match rgb {
                Some(rgb) => compose(m, rgb, x),
                None => m.intern(Expr::Convert { value: x, to: Ty::Rgba }, m.span(c)).ok(),
            };
            ways.extend(value.map(|v| (v, test, true)));
        }
    }
    // Two conditions joined, one selecting by the mux and the other's
    // value tested: fewer general combiners than both computed as 0 or 1.
    if alpha.is_none() || (!writes_alpha && !blended_by_alpha) {
        for (x, test) in joined_by_mux(m, c, alpha.is_none() && writes_alpha) {
            let value = match rgb {
                Some(rgb) => compose(m, rgb, x),
                None => m.intern(Expr::Convert { value: x, to: Ty::Rgba }, m.span(c)).ok(),
            };
            ways.extend(value.map(|v| (v, test, !writes_alpha)));
        }
    }
    if alpha.is_none() {
        if let Some(v) = zero_one(m, c).and_then(|c01| compose(m, rgb?, c01)) {
            ways.push((v, AlphaTest { func: CompareFunc::Greater, reference: 0.0 }, false));
        }
    }
    let mut why = None;
    for (value, test, masked) in ways {
        match realizes(m, realizer, st, value, c) {
            Ok(()) => return Ok((value, test, masked)),
            Err(r) => why = why.or(Some(r)),
        }
    }
    if let (None, Some(eq)) = (&why, inexact_equality(m, c)) {
        let d = unsupported(m, c, false, Some(eq));
        return Err(Box::new(d.with_help("compare with a level instead (`(T δu x).a ≥ 0.3 ? …`, which the alpha test keeps as the program does), test equality with 0 or 1 (`(T δu x).a == 1 ? …`), or target wgsl")));
    }
    let why = why.map(|r| r.reason);
    Err(Box::new(unsupported(m, c, alpha.is_some() || (writes_alpha && rgb.is_none()), why)))
}

/// Why an equality no way brought into alpha is not one the alpha test
/// keeps exactly (`None` for another condition).
fn inexact_equality(m: &Module, c: Handle<Expr>) -> Option<String> {
    let (p, op, q) = comparison(m, c)?;
    if !matches!(op, BinaryOp::Eq | BinaryOp::Ne) {
        return None;
    }
    let k = constant(m, q).or(constant(m, p));
    Some(match k {
        Some(k) if k != 0.0 && k != 1.0 => format!(
            "the test compares 8-bit steps, and an alpha equal to {k} in 8-bit steps ({} of 255) is not equal to it in the program's arithmetic; an equality is exact with 0 or 1",
            (k.clamp(0.0, 1.0) * 255.0).round()
        ),
        Some(_) => "the compared value may leave [0, 1], where the alpha clamps it".to_string(),
        None => "the test compares the alpha with a constant, and neither side is one".to_string(),
    })
}

/// Whether the generator makes a setup for `value` with the pass's units
/// (the lookups of the value and of the condition, as `assemble` binds them).
fn realizes(
    m: &Module,
    realizer: Option<&dyn Realizer>,
    st: &Statement,
    value: Handle<Expr>,
    c: Handle<Expr>,
) -> Result<(), Refusal> {
    let Some(realizer) = realizer else { return Ok(()) };
    let reached = m.reachable(&[value, c]);
    let textures = super::assemble::texture_bindings(m, st, &Usage::of_reached(m, &reached));
    let units: Vec<Handle<Expr>> = textures.iter().map(|t| Handle::new(t.lookup as usize)).collect();
    realizer.realize(m, value, &units).map(|_| ())
}

/// The located refusal of a discard no way brings into alpha.
fn unsupported(m: &Module, c: Handle<Expr>, alpha_used: bool, why: Option<String>) -> Diagnostic {
    let what = if alpha_used {
        "the fragment's alpha is needed for the value this statement writes"
    } else {
        "the condition cannot be brought into the fragment's alpha"
    };
    let mut message = format!("a register-combiner target drops a fragment only by the alpha test (glAlphaFunc), which tests the fragment's alpha, and {what}");
    if let Some(r) = why {
        message += &format!(": {r}");
    }
    Diagnostic::error("unsupported-discard", message, m.span(c), "this condition")
        .with_help("test the value's own alpha (`(T δu x).a > 0.5 ? T δu x`); or write no alpha (a framebuffer declared `rgb8`), or an rgb value under a comparison with 0 or ½, which the combiners compute into alpha (`(T δu x).g ≥ 0.5 ? (T δu x).rgb`); or mark the stencil where the condition holds (`σ C δπx ← (σ C δπx) OR c;`, with a `stencil` framebuffer) and draw where it is set (`C δπx ← (σ C δπx) ? …;`); or target wgsl")
}

/// A value's colour and its alpha as the pass writes them: `None` for the
/// alpha 1 of an rgb value widened; `None` for the colour of an alpha write.
fn parts(m: &mut Module, form: &Form, value: Handle<Expr>) -> (Option<Handle<Expr>>, Option<Handle<Expr>>) {
    if form.channels == "a" {
        return (None, Some(value));
    }
    let span = m.span(value);
    match (m.info(value).ty, m.exprs[value].clone()) {
        (Ty::Rgba, Expr::Convert { value: rgb, .. }) if m.info(rgb).ty.width() == 3 => (Some(rgb), None),
        (Ty::Rgba, Expr::Compose { components, .. }) if components.len() == 2 => {
            (Some(components[0]), Some(components[1]))
        }
        (Ty::Rgba, _) => {
            let swizzle = |m: &mut Module, pattern: [u8; 4], len, ty| {
                m.intern(Expr::Swizzle { value, pattern, len, ty }, span).ok()
            };
            let rgb = swizzle(m, [0, 1, 2, 0], 3, Ty::Rgb);
            let a = alpha_of(m, value, 8).unwrap_or_else(|| swizzle(m, [3, 0, 0, 0], 1, Ty::Scalar));
            (rgb, a.filter(|a| constant(m, *a) != Some(1.0)))
        }
        (Ty::Scalar, _) => (m.intern(Expr::Convert { value, to: Ty::Rgb }, span).ok(), Some(value)),
        _ => (Some(value), None),
    }
}

/// The alpha of `value` pushed through its products, `Some(None)` for 1:
/// an rgb operand widened has alpha 1 (a texture without alpha, GL 1.2.1
/// §3.8.9), a scalar operand broadcasts to it, and a product's (`*`, `⊕`
/// modulate) is the product of its operands'. So the alpha of the
/// alpha-tested decal lit by an rgb shader, `(T δu x) * δ p s x`, is the
/// `(T δu x).a` its condition compares, and the first way of the table
/// above applies. `None` past `depth` or for another form.
fn alpha_of(m: &mut Module, value: Handle<Expr>, depth: u8) -> Option<Option<Handle<Expr>>> {
    match m.info(value).ty.width() {
        1 => return Some(Some(value)),
        3 => return Some(None),
        _ => {}
    }
    let span = m.span(value);
    match m.exprs[value].clone() {
        Expr::Convert { value: v, to: Ty::Rgba } if m.info(v).ty.width() == 3 => Some(None),
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
        | Expr::Combine { mode: crate::parser::ast::CombineMode::Modulate, lhs, rhs }
            if depth > 0 =>
        {
            match (alpha_of(m, lhs, depth - 1)?, alpha_of(m, rhs, depth - 1)?) {
                (None, x) | (x, None) => Some(x),
                (Some(a), Some(b)) => {
                    m.intern(Expr::Binary { op: BinaryOp::Mul, lhs: a, rhs: b }, span).ok().map(Some)
                }
            }
        }
        _ => m
            .intern(Expr::Swizzle { value, pattern: [3, 0, 0, 0], len: 1, ty: Ty::Scalar }, span)
            .ok()
            .map(Some),
    }
}

/// `rgba(rgb, a)`.
fn compose(m: &mut Module, rgb: Handle<Expr>, a: Handle<Expr>) -> Option<Handle<Expr>> {
    let span = m.span(rgb);
    m.intern(Expr::Compose { ty: Ty::Rgba, components: vec![rgb, a] }, span).ok()
}

/// Whether the pass's target keeps an alpha: a temporary does, a
/// framebuffer declared `rgb8` does not.
fn stores_alpha(m: &Module, st: &Statement, dest: Dest) -> bool {
    match (dest, &st.table) {
        (Dest::Main, Table::Framebuffer { id, .. }) => {
            !m.framebuffers[*id as usize].channels.contains(&crate::parser::ast::FramebufferChannel::Rgb8)
        }
        _ => true,
    }
}

/// Whether a blend reads the fragment's alpha.
fn reads_source_alpha(blend: BlendMode) -> bool {
    let s = blend.render_state();
    [s.src_rgb, s.dst_rgb, s.src_alpha, s.dst_alpha].iter().any(|f| {
        matches!(f, BlendFactor::SrcAlpha | BlendFactor::OneMinusSrcAlpha | BlendFactor::SrcAlphaSaturate)
    })
}

/// A scalar constant's value.
fn constant(m: &Module, h: Handle<Expr>) -> Option<f64> {
    let Expr::Constant(k) = &m.exprs[h] else { return None };
    match k.values() {
        [v] => Some(*v),
        _ => None,
    }
}

/// A comparison under any number of `¬`: its operands and its operator,
/// the negations applied (`¬(x > k)` is `x ≤ k`).
fn comparison(m: &Module, mut c: Handle<Expr>) -> Option<(Handle<Expr>, BinaryOp, Handle<Expr>)> {
    let mut negated = false;
    while let Expr::Unary { op: UnaryOp::Not, value } = m.exprs[c] {
        c = value;
        negated = !negated;
    }
    let Expr::Binary { op, lhs, rhs } = m.exprs[c] else { return None };
    if m.info(lhs).ty != Ty::Scalar || m.info(rhs).ty != Ty::Scalar {
        return None;
    }
    let op = match (op, negated) {
        (BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge | BinaryOp::Eq | BinaryOp::Ne, false) => {
            op
        }
        (BinaryOp::Eq, true) => BinaryOp::Ne,
        (BinaryOp::Ne, true) => BinaryOp::Eq,
        (BinaryOp::Lt, true) => BinaryOp::Ge,
        (BinaryOp::Le, true) => BinaryOp::Gt,
        (BinaryOp::Gt, true) => BinaryOp::Le,
        (BinaryOp::Ge, true) => BinaryOp::Lt,
        _ => return None,
    };
    Some((lhs, op, rhs))
}

/// The alpha `x` and the test that keeps the fragments `c` keeps, as
/// the module's table says; `None` for a condition of another form.
pub(super) fn direct(m: &mut Module, c: Handle<Expr>) -> Option<(Handle<Expr>, AlphaTest)> {
    if let Expr::Binary { op: BinaryOp::And | BinaryOp::Or, .. } = m.exprs[c] {
        // Two conditions: their 0/1 values combined (below), kept above 0.
        let both = zero_one(m, c)?;
        return Some((both, AlphaTest { func: CompareFunc::Greater, reference: 0.0 }));
    }
    let Some((p, op, q)) = comparison(m, c) else {
        // A scalar that is never negative is kept where it is above 0.
        let unsigned = m.info(c).ty == Ty::Scalar && m.info(c).interval.lo >= 0.0;
        let kept = AlphaTest { func: CompareFunc::Greater, reference: 0.0 };
        return (unsigned && constant(m, c).is_none()).then_some((c, kept));
    };
    // The constant on the right: `k < x` is `x > k`.
    let (x, k, op) = match (constant(m, p), constant(m, q)) {
        (_, Some(k)) => (p, Some(k), op),
        (Some(k), None) => (q, Some(k), swapped(op)),
        _ => (p, None, op),
    };
    if matches!(op, BinaryOp::Eq | BinaryOp::Ne) {
        return equality(m, x, k?, op);
    }
    if let Some(k) = k {
        let exact = match op {
            BinaryOp::Gt | BinaryOp::Le => (0.0..1.0).contains(&k),
            _ => k > 0.0 && k <= 1.0,
        };
        if exact {
            return Some((x, AlphaTest { func: func(op), reference: k as f32 }));
        }
    }
    // A difference with 0: clamped, it is above 0 exactly where it is positive.
    let (d, f) = match op {
        BinaryOp::Gt => (difference(m, p, q)?, CompareFunc::Greater),
        BinaryOp::Ge => (difference(m, q, p)?, CompareFunc::LessEqual),
        BinaryOp::Lt => (difference(m, q, p)?, CompareFunc::Greater),
        _ => (difference(m, p, q)?, CompareFunc::LessEqual),
    };
    Some((d, AlphaTest { func: f, reference: 0.0 }))
}

/// `x == k` (`x != k`) as `GL_EQUAL` (`GL_NOTEQUAL`) against `k`: exact
/// where `k` is 0 or 1 and `x` lies in [0, 1] — the 8-bit alpha is 0 (255
/// steps) exactly where `x` is, at the ends of the range every executor
/// holds exactly. Another `k` (0.2 is 51 steps) would keep the texels the
/// 8-bit steps round to it, which the program's real arithmetic does not
/// equal: `None`, refused by the caller.
fn equality(m: &Module, x: Handle<Expr>, k: f64, op: BinaryOp) -> Option<(Handle<Expr>, AlphaTest)> {
    let range = m.info(x).interval;
    if !(k == 0.0 || k == 1.0) || range.lo < 0.0 || range.hi > 1.0 {
        return None;
    }
    let func = if op == BinaryOp::Eq { CompareFunc::Equal } else { CompareFunc::NotEqual };
    Some((x, AlphaTest { func, reference: k as f32 }))
}

/// The condition as a value 0 or 1 the combiners compute (their mux,
/// Kilgard 2000, Section 4.2.2), its `¬`s applied; `None` for another form.
/// Two conditions joined: `a AND b` is the product of their 0/1 values,
/// `a OR b` their sum clamped (the combiners' output clamp, free), so one
/// alpha test (`GL_GREATER 0`) keeps what both (either) keep.
fn zero_one(m: &mut Module, c: Handle<Expr>) -> Option<Handle<Expr>> {
    let span = m.span(c);
    if let Expr::Binary { op: op @ (BinaryOp::And | BinaryOp::Or), lhs, rhs } = m.exprs[c] {
        let (a, b) = (zero_one(m, lhs)?, zero_one(m, rhs)?);
        if op == BinaryOp::And {
            return m.intern(Expr::Binary { op: BinaryOp::Mul, lhs: a, rhs: b }, span).ok();
        }
        let sum = m.intern(Expr::Binary { op: BinaryOp::Add, lhs: a, rhs: b }, span).ok()?;
        return m.intern(Expr::Math { fun: crate::ir::MathFunction::Saturate, args: vec![sum] }, span).ok();
    }
    let (lhs, op, rhs) = comparison(m, c)?;
    if matches!(op, BinaryOp::Eq | BinaryOp::Ne) {
        return None; // the mux compares with a threshold, not for equality
    }
    m.intern(Expr::Binary { op, lhs, rhs }, span).ok()
}

/// Whether alpha `a` passes `test` (OpenGL 1.2.1, Section 4.1.4).
fn passes(test: AlphaTest, a: f32) -> bool {
    test.func.test(a, test.reference)
}

/// `a AND b` (`a OR b`) as one mux of the general combiners (Kilgard 2000,
/// Section 4.2.2) and one alpha test: `a ? x : k` with `k` a constant the
/// test drops (`a ? k′ : x`, `k′` one it keeps), tested as `b` alone is
/// (`x FUNC r`, the table above) — so the test keeps a fragment exactly
/// where both (either) hold, with one mux and `b`'s value where the 0/1
/// values of both and their product took three. Where the alpha must end
/// 1 where kept (`exact_alpha`, an rgb value widened into rgba), `x` is
/// `b`'s 0/1 value, kept above 0. Each order of the operands; the
/// generator decides which it builds.
fn joined_by_mux(m: &mut Module, c: Handle<Expr>, exact_alpha: bool) -> Vec<(Handle<Expr>, AlphaTest)> {
    let Expr::Binary { op: op @ (BinaryOp::And | BinaryOp::Or), lhs, rhs } = m.exprs[c] else {
        return Vec::new();
    };
    let span = m.span(c);
    let mut out = Vec::new();
    for (selector, tested) in [(lhs, rhs), (rhs, lhs)] {
        // The mux compares with a threshold: not an equality.
        let Some((p, sel_op, q)) = comparison(m, selector) else { continue };
        if matches!(sel_op, BinaryOp::Eq | BinaryOp::Ne) {
            continue;
        }
        let Ok(cond) = m.intern(Expr::Binary { op: sel_op, lhs: p, rhs: q }, span) else { continue };
        let (x, test) = if exact_alpha {
            let Some(x) = zero_one(m, tested) else { continue };
            (x, AlphaTest { func: CompareFunc::Greater, reference: 0.0 })
        } else {
            match direct(m, tested) {
                Some(d) => d,
                None => continue,
            }
        };
        let keep = [1.0f32, 0.0].into_iter().find(|a| passes(test, *a));
        let drop = [0.0f32, 1.0].into_iter().find(|a| !passes(test, *a));
        let Some(k) = (if op == BinaryOp::And { drop } else { keep }) else { continue };
        let Ok(k) = m.intern(Expr::Constant(crate::ir::Constant::scalar(f64::from(k))), span) else {
            continue;
        };
        let (accept, reject) = if op == BinaryOp::And { (x, k) } else { (k, x) };
        if let Ok(v) = m.intern(Expr::Select { cond, accept, reject: Some(reject) }, span) {
            out.push((v, test));
        }
    }
    out
}

/// `p − q` (`p` when q is 0, `−q` when p is 0).
fn difference(m: &mut Module, p: Handle<Expr>, q: Handle<Expr>) -> Option<Handle<Expr>> {
    let span = m.span(p);
    if constant(m, q) == Some(0.0) {
        return Some(p);
    }
    let e = if constant(m, p) == Some(0.0) {
        Expr::Unary { op: UnaryOp::Neg, value: q }
    } else {
        Expr::Binary { op: BinaryOp::Sub, lhs: p, rhs: q }
    };
    m.intern(e, span).ok()
}

fn swapped(op: BinaryOp) -> BinaryOp {
    match op {
        BinaryOp::Lt => BinaryOp::Gt,
        BinaryOp::Le => BinaryOp::Ge,
        BinaryOp::Gt => BinaryOp::Lt,
        BinaryOp::Eq | BinaryOp::Ne => op,
        _ => BinaryOp::Le,
    }
}

fn func(op: BinaryOp) -> CompareFunc {
    match op {
        BinaryOp::Lt => CompareFunc::Less,
        BinaryOp::Le => CompareFunc::LessEqual,
        BinaryOp::Gt => CompareFunc::Greater,
        _ => CompareFunc::GreaterEqual,
    }
}
