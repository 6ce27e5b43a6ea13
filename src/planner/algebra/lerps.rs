//! A lerp of sums written as a sum of lerps ([`super::forms`]):
//! `lerp(x₁ + x₂, y₁ + y₂, f)` = `lerp(x₁, y₁, f) + lerp(x₂, y₂, f)` (the
//! weights `1 − f` and `f` distribute over each operand's terms). A lerp
//! is one operation the texture environment and the combiners compute
//! whole, but a lerp of sums needs every interpolant and lookup of both
//! sums in one pass; as a sum of lerps, blending adds the lerps one pass
//! (or one temporary's pass) at a time. A multiplied-out sum read back
//! around its weights (`x·(1 − a) + … + y·a + …`) is one lerp of two sums
//! ([`super::lerps_recovered`]), where the program written may have been
//! the sum of two lerps.

use super::{binary, node, product_factors, sum_terms};
use crate::ir::{BinaryOp, Expr, Handle, MathFunction, Module, Ty};
use crate::span::Span;

/// Most terms both operands may have together: the groupings tried are
/// 2ⁿ⁻¹ of them.
const MAX_OPERAND_TERMS: usize = 12;

/// `h` with every `lerp` whose operands are sums (one at least) written as
/// the sum of two lerps, each of a group of their terms
/// (`split_lerp`), also a lerp a sum inside `h` holds written out
/// (`x·(1 − f) + y·f`). `None` when no lerp is one of sums.
pub fn lerps_of_sums_split(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    super::rebuilt_bottom_up(m, h, |m, rebuilt, span| {
        match m.exprs[rebuilt] {
            Expr::Math { fun: MathFunction::Mix, .. } => split_lerp(m, rebuilt, span),
            // A sum under a product read back as lerps first: `C·(a·(T4 +
            // T5) + p·(1 − a))` holds `lerp(p, T4 + T5, a)` only so (the
            // forms read lerps back at a sum's top).
            // Only the lerps so recovered are split (not the sum walked
            // again): a split leaves `x·(1 − f) + y·f` terms, which would
            // be read back as the lerp just split.
            Expr::Binary { op: BinaryOp::Add, .. } => {
                super::lerps_recovered(m, rebuilt).and_then(|r| split_terms(m, r, span))
            }
            _ => None,
        }
    })
    .filter(|c| m.info(*c).ty == m.info(h).ty)
}

/// The sum `h` with each lerp of sums that is one of its terms' factors
/// split ([`split_lerp`]); `None` when none is.
fn split_terms(m: &mut Module, h: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let mut found = false;
    let mut sum: Option<Handle<Expr>> = None;
    for t in sum_terms(m, h) {
        let mut product: Option<Handle<Expr>> = None;
        for f in product_factors(m, t) {
            let f = match m.exprs[f] {
                Expr::Math { fun: MathFunction::Mix, .. } => match split_lerp(m, f, span) {
                    Some(split) => {
                        found = true;
                        split
                    }
                    None => f,
                },
                _ => f,
            };
            product = Some(match product {
                None => f,
                Some(p) => binary(m, BinaryOp::Mul, p, f, span)?,
            });
        }
        let product = product?;
        sum = Some(match sum {
            None => product,
            Some(s) => binary(m, BinaryOp::Add, s, product, span)?,
        });
    }
    sum.filter(|s| found && m.info(*s).ty == m.info(h).ty)
}

/// What a grouping is judged by in one term (or the weight): the
/// interpolants and lookups it reads, and its range.
struct Reads {
    interpolants: Vec<Handle<Expr>>,
    lookups: Vec<Handle<Expr>>,
    lo: f64,
    hi: f64,
}

fn reads(m: &Module, h: Handle<Expr>) -> Reads {
    let nodes = m.reachable(&[h]);
    let of = |keep: fn(&Expr) -> bool| nodes.iter().copied().filter(|n| keep(&m.exprs[*n])).collect();
    let i = m.info(h).interval;
    Reads {
        interpolants: of(|e| matches!(e, Expr::Interpolate { .. })),
        lookups: of(|e| matches!(e, Expr::Lookup { .. })),
        lo: i.lo,
        hi: i.hi,
    }
}

/// `lerp(x, y, f)` with `x` or `y` a sum, as `lerp(x₁, y₁, f) + lerp(x₂,
/// y₂, f)` (a group with no `y` term is `x₁·(1 − f)`, one with no `x`
/// term `y₁·f`). Of the groupings of the terms into two, the one whose
/// sum may be halved into [0, 1] (its bound at most 2, what a 2×
/// modulation doubles back), then whose lerps each read the fewest
/// interpolants, then lookups, then of the least bound: what one pass of
/// a fixed-function target holds decides, and a sum of lerps past 2 no
/// temporary stores halved. `None` for another value.
fn split_lerp(m: &mut Module, h: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let Expr::Math { fun: MathFunction::Mix, args } = m.exprs[h].clone() else { return None };
    let [x, y, f] = args[..] else { return None };
    if m.info(f).ty != Ty::Scalar {
        return None;
    }
    let (xs, ys) = (sum_terms(m, x), sum_terms(m, y));
    let n = xs.len() + ys.len();
    if xs.len().max(ys.len()) < 2 || n > MAX_OPERAND_TERMS {
        return None;
    }
    let terms: Vec<(bool, Handle<Expr>)> =
        xs.iter().map(|t| (false, *t)).chain(ys.iter().map(|t| (true, *t))).collect();
    let term_reads: Vec<Reads> = terms.iter().map(|(_, t)| reads(m, *t)).collect();
    let mask = best_grouping(&terms, &term_reads, &reads(m, f))?;
    let one = node(m, Expr::Constant(crate::ir::Constant::scalar(1.0)), span)?;
    let keep = binary(m, BinaryOp::Sub, one, f, span)?;
    let mut sum: Option<Handle<Expr>> = None;
    for group in [false, true] {
        let side = |second: bool| -> Vec<Handle<Expr>> {
            terms
                .iter()
                .enumerate()
                .filter(|(i, (y, _))| (mask >> i & 1 == 1) == group && *y == second)
                .map(|(_, (_, t))| *t)
                .collect()
        };
        let (gx, gy) = (added(m, &side(false), span)?, added(m, &side(true), span)?);
        let lerp = match (gx, gy) {
            (Some(a), Some(b)) => node(m, Expr::Math { fun: MathFunction::Mix, args: vec![a, b, f] }, span)?,
            (Some(a), None) => binary(m, BinaryOp::Mul, a, keep, span)?,
            (None, Some(b)) => binary(m, BinaryOp::Mul, b, f, span)?,
            (None, None) => continue,
        };
        sum = Some(match sum {
            None => lerp,
            Some(s) => binary(m, BinaryOp::Add, s, lerp, span)?,
        });
    }
    sum.filter(|s| m.info(*s).ty == m.info(h).ty)
}

/// The grouping [`split_lerp`] takes of `terms` (each marked `true` when
/// it is the second operand's), as a mask: bit i puts term i in the
/// second lerp; the first term stays in the first (the groupings
/// mirrored are the same). `None` for fewer than two terms.
fn best_grouping(terms: &[(bool, Handle<Expr>)], term_reads: &[Reads], weight: &Reads) -> Option<u32> {
    let n = terms.len();
    if n < 2 {
        return None;
    }
    let mut best: Option<((bool, usize, usize, f64), u32)> = None;
    for mask in 0..(1u32 << (n - 1)) {
        let mask = mask << 1;
        if mask == 0 {
            continue;
        }
        let mut score = (false, 0, 0, 0.0);
        for group in [false, true] {
            let (mut interpolants, mut lookups) = (weight.interpolants.clone(), weight.lookups.clone());
            let (mut x_hi, mut y_hi) = (0.0, 0.0);
            for (i, r) in term_reads.iter().enumerate() {
                if (mask >> i & 1 == 1) != group {
                    continue;
                }
                interpolants.extend(&r.interpolants);
                lookups.extend(&r.lookups);
                if terms[i].0 {
                    y_hi += r.hi.max(0.0);
                } else {
                    x_hi += r.hi.max(0.0);
                }
            }
            interpolants.sort();
            interpolants.dedup();
            lookups.sort();
            lookups.dedup();
            score.1 = score.1.max(interpolants.len());
            score.2 = score.2.max(lookups.len());
            score.3 += f64::max(x_hi, y_hi);
        }
        score.0 = score.3 > 2.0 || term_reads.iter().any(|r| r.lo < 0.0);
        let better = match &best {
            None => true,
            Some((s, _)) => {
                (score.0, score.1, score.2) < (s.0, s.1, s.2)
                    || ((score.0, score.1, score.2) == (s.0, s.1, s.2) && score.3 < s.3)
            }
        };
        if better {
            best = Some((score, mask));
        }
    }
    best.map(|(_, mask)| mask)
}

/// The sum of `terms` (`Some(None)` for none; `None` when ill-typed).
fn added(m: &mut Module, terms: &[Handle<Expr>], span: Span) -> Option<Option<Handle<Expr>>> {
    let mut sum: Option<Handle<Expr>> = None;
    for t in terms {
        sum = Some(match sum {
            None => *t,
            Some(s) => binary(m, BinaryOp::Add, s, *t, span)?,
        });
    }
    Some(sum)
}
