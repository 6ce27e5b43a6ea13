//! A program written for light 0 on a scene of several lights, restated
//! from the language's definition (docs/language.md, "For each light"),
//! not from the planner's rewrite: a colour statement on a mesh is a sum
//! of products through `+`, `−`, `*`, `⊕[add]`, `⊕[subtract]` and `⊕`
//! (modulate); the products that depend on light 0's vectors (`light`,
//! `half`, `intensity`) are its light terms. The statement runs as written
//! for light 0, then for every other light i its light terms, with light
//! 0 read as light i, are added into the framebuffer — Pipeline Grammar's
//! multipass accumulation, eq. (9), "a separate pass for each light
//! source" (Section 3.4): each pass stored, so an 8-bit framebuffer
//! clamps after each light.
//!
//! Light 0 only (as written): a light term that reads the statement's own
//! framebuffer (a modulation `C ← C · d(L)` does not distribute over
//! lights), or a light factor under a ⊕ mode that is not linear in it or
//! under a selection.

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
    expand(m, value, 1.0, &mut terms)?;
    let mut light = Vec::new();
    for (k, factors) in terms {
        if !factors.iter().any(|&f| lit(m, f)) {
            continue;
        }
        let own = m
            .reachable(&factors)
            .into_iter()
            .any(|h| matches!(m.exprs[h], Expr::FramebufferRead { framebuffer, .. } if framebuffer == fb));
        if own || factors.iter().any(|&f| lit(m, f) && !linear(m, f)) {
            return Ok(None);
        }
        light.push((k, factors));
    }
    Ok(Some(light))
}

/// `h` as a sum of signed products, appended to `out`.
fn expand(m: &Module, h: Handle<Expr>, sign: f64, out: &mut Vec<Term>) -> Result<(), Unsupported> {
    match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } | Expr::Combine { mode: CombineMode::Add, lhs, rhs } => {
            expand(m, lhs, sign, out)?;
            expand(m, rhs, sign, out)
        }
        Expr::Binary { op: BinaryOp::Sub, lhs, rhs }
        | Expr::Combine { mode: CombineMode::Subtract, lhs, rhs } => {
            expand(m, lhs, sign, out)?;
            expand(m, rhs, -sign, out)
        }
        Expr::Unary { op: UnaryOp::Neg, value } => expand(m, value, -sign, out),
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
        | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs } => {
            let (mut a, mut b) = (Vec::new(), Vec::new());
            expand(m, lhs, 1.0, &mut a)?;
            expand(m, rhs, 1.0, &mut b)?;
            if out.len() + a.len() * b.len() > MAX_TERMS {
                return Err(Unsupported::new("a light statement of more than 256 products"));
            }
            for (ka, fa) in &a {
                for (kb, fb) in &b {
                    out.push((sign * ka * kb, fa.iter().chain(fb).copied().collect()));
                }
            }
            Ok(())
        }
        _ => {
            out.push((sign, vec![h]));
            Ok(())
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

/// Whether a light factor is read once per light: not under a ⊕ mode
/// that is not linear in it, nor a selection.
fn linear(m: &Module, f: Handle<Expr>) -> bool {
    !m.reachable(&[f]).into_iter().any(|n| match m.exprs[n] {
        Expr::Select { .. } => true,
        Expr::Combine { mode, .. } => {
            !matches!(mode, CombineMode::Add | CombineMode::Subtract | CombineMode::Modulate)
        }
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
