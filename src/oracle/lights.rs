//! A program written for light 0 on a scene of several lights, restated
//! from the language's definition (docs/language.md, "For each light"),
//! not from the planner's rewrite: a colour statement on a mesh is read as
//! a sum of products through `+`, `−`, `*`, `⊕[add]`, `⊕[subtract]` and
//! `⊕` (modulate), a product distributed over a sum only where one of its
//! factors depends on light 0's vectors (`light`, `half`, `intensity`);
//! the terms that depend on them are its light terms. The statement runs
//! as written for light 0, then for every other light i its light terms,
//! with light 0 read as light i, are added into the framebuffer —
//! Pipeline Grammar's multipass accumulation, eq. (9), "a separate pass
//! for each light source" (Section 3.4): each pass stored, so an 8-bit
//! framebuffer clamps after each light.
//!
//! Light 0 only (as written): every statement that is not a colour
//! statement at the fragments (stencil and alpha writes, textures rendered
//! or shaded, screen passes); a light term that reads the statement's own
//! framebuffer (a modulation `C ← C · d(L)` does not distribute over
//! lights); a framebuffer read other than the framebuffer itself added
//! (`C ← 0.5 · C + d(L)` is no replacement or addition); a light term
//! under a ⊕ mode that is not linear in it or under a selection.

use crate::ir::{BinaryOp, Expr, FbChannel, Frequency, Handle, Module, Statement, Table, UnaryOp};
use crate::parser::ast::{CombineMode, VectorKind};

use super::ops::V;
use super::program::{At, Evaluator, Memo};
use super::Unsupported;

/// A product of factors with a sign.
type Term = (f64, Vec<Handle<Expr>>);

/// Past this many products the statement is not split (a reference need
/// not multiply out what no user writes).
const MAX_TERMS: usize = 256;

/// The light terms of a colour statement into framebuffer `fb`; `None`
/// where the statement runs for light 0 only.
pub(super) fn light_terms(m: &Module, st: &Statement) -> Result<Option<Vec<Term>>, Unsupported> {
    let Table::Framebuffer { id: fb, channel: FbChannel::Color } = st.table else { return Ok(None) };
    if st.freq != Frequency::Fragment || !lit(m, st.value) {
        return Ok(None);
    }
    let mut value = st.value;
    if let Expr::Convert { value: inner, .. } = m.exprs[value] {
        value = inner; // the widening's alpha 1 is added with each light
    }
    let mut terms = Vec::new();
    if !expand(m, value, 1.0, &mut terms)? {
        return Ok(None);
    }
    let reads_own = |factors: &[Handle<Expr>]| {
        m.reachable(factors)
            .into_iter()
            .any(|h| matches!(m.exprs[h], Expr::FramebufferRead { framebuffer, .. } if framebuffer == fb))
    };
    let bare_own = |factors: &[Handle<Expr>]| {
        matches!(factors, [f] if matches!(m.exprs[*f], Expr::FramebufferRead { framebuffer, channel: FbChannel::Color, position }
            if framebuffer == fb && position == st.index))
    };
    let mut light = Vec::new();
    for (k, factors) in terms {
        if factors.iter().any(|&f| lit(m, f)) {
            if reads_own(&factors) {
                return Ok(None);
            }
            light.push((k, factors));
        } else if reads_own(&factors) && !(k > 0.0 && bare_own(&factors)) {
            return Ok(None);
        }
    }
    Ok(Some(light))
}

/// `h` as a sum of signed products, appended to `out`: a product
/// distributed over its lit factor's terms where only one factor is lit,
/// one term otherwise. `false` where a lit node sits under a ⊕ mode that
/// is not linear in it or under a selection (light 0 only).
fn expand(m: &Module, h: Handle<Expr>, sign: f64, out: &mut Vec<Term>) -> Result<bool, Unsupported> {
    if !lit(m, h) {
        out.push((sign, vec![h]));
        return Ok(true);
    }
    match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } | Expr::Combine { mode: CombineMode::Add, lhs, rhs } => {
            Ok(expand(m, lhs, sign, out)? && expand(m, rhs, sign, out)?)
        }
        Expr::Binary { op: BinaryOp::Sub, lhs, rhs }
        | Expr::Combine { mode: CombineMode::Subtract, lhs, rhs } => {
            Ok(expand(m, lhs, sign, out)? && expand(m, rhs, -sign, out)?)
        }
        Expr::Unary { op: UnaryOp::Neg, value } => expand(m, value, -sign, out),
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
        | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs }
            if lit(m, lhs) != lit(m, rhs) =>
        {
            let (factor, lit_side) = if lit(m, lhs) { (rhs, lhs) } else { (lhs, rhs) };
            let mut inner = Vec::new();
            if !expand(m, lit_side, 1.0, &mut inner)? {
                return Ok(false);
            }
            if out.len() + inner.len() > MAX_TERMS {
                return Err(Unsupported::new("a light statement of more than 256 products"));
            }
            for (k, factors) in inner {
                out.push((sign * k, std::iter::once(factor).chain(factors).collect()));
            }
            Ok(true)
        }
        Expr::Combine { mode, .. } if mode != CombineMode::Modulate => Ok(false),
        Expr::Select { .. } => Ok(false),
        _ => {
            out.push((sign, vec![h]));
            Ok(true)
        }
    }
}

/// Whether `h` depends on light 0's vectors.
fn lit(m: &Module, h: Handle<Expr>) -> bool {
    m.reachable(&[h]).into_iter().any(|n| match m.exprs[n] {
        Expr::Vector { vector, .. } => matches!(
            m.vectors[vector as usize].kind,
            Some(VectorKind::Light | VectorKind::Half | VectorKind::Intensity)
        ),
        _ => false,
    })
}

/// The light terms at `at`, light 0 read as the evaluator's first light.
pub(super) fn value(ev: &Evaluator, terms: &[Term], at: At) -> Result<V, Unsupported> {
    let mut memo = Memo::new();
    let mut sum = [0.0; 4];
    for (k, factors) in terms {
        let mut product = [*k; 4];
        for &f in factors {
            let v = ev
                .value(f, at, 0, &mut memo)?
                .ok_or_else(|| Unsupported::new("a light term that keeps the destination"))?;
            product = std::array::from_fn(|c| product[c] * v[c]);
        }
        sum = std::array::from_fn(|c| sum[c] + product[c]);
    }
    Ok(sum)
}
