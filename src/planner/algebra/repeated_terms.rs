//! Like terms of a sum collected by their counts: `a + a` = `2·a`.
//!
//! Hash-consing makes a value named once and read twice one node, so
//! `let a₁ = a₀ + a₀; let a₂ = a₁ + a₁; …` is `n` nodes whose sum, written
//! out, has `2ⁿ` terms, each `a₀`: past `ir::chain`'s limit the planner
//! can divide it no further. Counted over the graph
//! ([`Module::chain_counted`]) it is `2ⁿ·a₀`, which blending splits (a
//! scale past 1, one doubling a pass) and which `T + T + T` shares with
//! `3·T`: one combiner stage where its terms written apart take a pass
//! each.

use rustc_hash::{FxHashMap, FxHashSet};

use super::{binary, node};
use crate::ir::{BinaryOp, Constant, Expr, Handle, Module};

fn is_sum(e: &Expr) -> bool {
    matches!(e, Expr::Binary { op: BinaryOp::Add, .. })
}

/// Whether a sum in `h` repeats a term (`T0 + T1 + T0`): written out it
/// takes an operation (or a pass) per repeat, counted one scale.
pub fn repeats_a_term(m: &Module, h: Handle<Expr>) -> bool {
    let nodes = m.reachable(&[h]);
    let roots = sum_roots(m, h, &nodes);
    roots.into_iter().any(|r| m.chain_counted(r, is_sum).is_some_and(|t| t.iter().any(|(_, k)| *k > 1.0)))
}

/// The sums among `nodes` (those `h` reaches) a chain starts at: `h`, and
/// those read by something other than a sum.
fn sum_roots(m: &Module, h: Handle<Expr>, nodes: &[Handle<Expr>]) -> FxHashSet<Handle<Expr>> {
    let mut roots: FxHashSet<Handle<Expr>> = FxHashSet::default();
    roots.extend(Some(h).filter(|h| is_sum(&m.exprs[*h])));
    for &n in nodes {
        if !is_sum(&m.exprs[n]) {
            roots.extend(m.exprs[n].operands().into_iter().filter(|o| is_sum(&m.exprs[*o])));
        }
    }
    roots
}

/// `h` with each sum's repeated terms written once, times their count
/// (`T0 + T1 + T0` = `2·T0 + T1`), at every depth; `None` when no sum
/// repeats a term, or a count is past what an `f64` holds.
pub fn repeated_terms_counted(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    let nodes = m.reachable(&[h]);
    let roots = sum_roots(m, h, &nodes);
    // Operands before what reads them (handles are interned in that order).
    let mut done: FxHashMap<Handle<Expr>, Handle<Expr>> = FxHashMap::default();
    let mut collected = false;
    for n in nodes {
        let span = m.span(n);
        let rebuilt = if !is_sum(&m.exprs[n]) {
            let e = m.exprs[n].map_operands(|o| *done.get(&o).unwrap_or(&o));
            if e == m.exprs[n] {
                n
            } else {
                node(m, e, span)?
            }
        } else if roots.contains(&n) {
            let terms = m.chain_counted(n, is_sum)?;
            collected |= terms.iter().any(|(_, k)| *k > 1.0);
            let unchanged = terms.iter().all(|(t, k)| *k == 1.0 && done.get(t).is_none_or(|d| d == t));
            if unchanged {
                n
            } else {
                counted_sum(m, &terms, &done, span)?
            }
        } else {
            continue;
        };
        done.insert(n, rebuilt);
    }
    done.get(&h).copied().filter(|c| collected && *c != h)
}

/// `Σ kᵢ·tᵢ` of `terms` (`(tᵢ, kᵢ)`), each `tᵢ` as `done` rebuilt it.
fn counted_sum(
    m: &mut Module,
    terms: &[(Handle<Expr>, f64)],
    done: &FxHashMap<Handle<Expr>, Handle<Expr>>,
    span: crate::span::Span,
) -> Option<Handle<Expr>> {
    let mut sum: Option<Handle<Expr>> = None;
    for &(t, k) in terms {
        let t = *done.get(&t).unwrap_or(&t);
        let term = if k == 1.0 {
            t
        } else {
            let k = node(m, Expr::Constant(Constant::scalar(k)), span)?;
            binary(m, BinaryOp::Mul, k, t, span)?
        };
        sum = Some(match sum {
            None => term,
            Some(s) => binary(m, BinaryOp::Add, s, term, span)?,
        });
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::ir::lower::lowered as module;

    #[test]
    fn a_sum_doubled_forty_times_is_one_term_scaled() {
        let mut src = String::from("texture A : 2d rgba8;\nlet a0 = A δu x;\n");
        for i in 1..=40 {
            src += &format!("let a{i} = a{} + a{};\n", i - 1, i - 1);
        }
        let mut m = module(&(src + "C δπx ← a40;\n"));
        let v = m.statements[0].value;
        let c = repeated_terms_counted(&mut m, v).expect("collected");
        let Expr::Binary { op: BinaryOp::Mul, lhs, rhs } = m.exprs[c] else { panic!("{:?}", m.exprs[c]) };
        assert!(m.is_constant(lhs, 2f64.powi(40)));
        assert!(matches!(m.exprs[rhs], Expr::Lookup { .. }));
    }

    #[test]
    fn a_sum_without_repeats_is_left() {
        let mut m = module("texture A : 2d rgba8;\ntexture B : 2d rgba8;\nC δπx ← A δu x + B δu x;\n");
        let v = m.statements[0].value;
        assert_eq!(repeated_terms_counted(&mut m, v), None);
    }
}
