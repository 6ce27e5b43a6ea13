//! The operands of a chain of one associative operator — a sum, a product —
//! as the planner and the combiner generator split and group them.
//!
//! Hash-consing makes a value named once and read twice one node, so a
//! chain is a graph, not a tree: `let a₁ = a₀·a₀; let a₂ = a₁·a₁; …` is
//! `n` nodes whose product, written out, has `2ⁿ` factors. Written out in
//! full, twenty squarings took 4.5 s and 0.5 GB to plan on geforce256,
//! twenty-four 61 s and 6.5 GB. [`Module::chain_operands`] counts the
//! written-out operands first (one sum per node of the graph) and writes
//! out only chains of at most [`CHAIN_LIMIT`] operands, or of no more
//! operands than the graph has nodes (every tree); a longer chain stays one
//! operand, its root, which a reader splits no further (the planner refuses
//! it, the combiner generator multiplies it out of what it has built).

use super::{Expr, Handle, Module};
use rustc_hash::FxHashMap;

/// The most operands a chain is written out into where it has more than
/// its graph has nodes: well above the 20 000-term chains the compile
/// benchmark plans, well below the 2²⁰ factors that took seconds.
pub const CHAIN_LIMIT: usize = 1 << 16;

impl Module {
    /// The operands of the maximal chain rooted at `h` whose links
    /// `is_link` accepts, in order (`[h]` where `h` is not a link, or where
    /// the chain written out is longer than `CHAIN_LIMIT` and than its
    /// graph: module docs).
    pub fn chain_operands(&self, h: Handle<Expr>, is_link: impl Fn(&Expr) -> bool) -> Vec<Handle<Expr>> {
        if !is_link(&self.exprs[h]) {
            return vec![h];
        }
        let nodes = self.reachable(&[h]);
        let mut written: FxHashMap<Handle<Expr>, usize> = FxHashMap::default();
        for &x in &nodes {
            let e = &self.exprs[x];
            let n = if is_link(e) {
                e.operands()
                    .iter()
                    .fold(0usize, |n, o| n.saturating_add(written.get(o).copied().unwrap_or(1)))
            } else {
                1
            };
            written.insert(x, n);
        }
        if written.get(&h).copied().unwrap_or(1) > CHAIN_LIMIT.max(nodes.len()) {
            return vec![h];
        }
        let mut out = Vec::new();
        let mut stack = vec![h];
        while let Some(x) = stack.pop() {
            let e = &self.exprs[x];
            if is_link(e) {
                stack.extend(e.operands().into_iter().rev());
            } else {
                out.push(x);
            }
        }
        out
    }

    /// The distinct operands of the maximal chain rooted at `h` whose
    /// links `is_link` accepts, each with how often it occurs written out,
    /// in the order written (`[(h, 1)]` where `h` is not a link): `a + a`
    /// doubled forty times is `[(a, 2⁴⁰)]`, counted over the graph's nodes
    /// without writing out its 2⁴⁰ terms. `None` where a count is past
    /// what an `f64` holds.
    pub fn chain_counted(
        &self,
        h: Handle<Expr>,
        is_link: impl Fn(&Expr) -> bool,
    ) -> Option<Vec<(Handle<Expr>, f64)>> {
        // The chain's links in post-order, its operands in the order written.
        let (mut post, mut operands) = (Vec::new(), Vec::new());
        let mut seen = rustc_hash::FxHashSet::default();
        let mut stack = vec![(h, false)];
        while let Some((x, expanded)) = stack.pop() {
            if expanded {
                post.push(x);
            } else if seen.insert(x) {
                if is_link(&self.exprs[x]) {
                    stack.push((x, true));
                    stack.extend(self.exprs[x].operands().into_iter().rev().map(|o| (o, false)));
                } else {
                    operands.push(x);
                }
            }
        }
        // Parents before children: each link passes its count to its operands.
        let mut count: FxHashMap<Handle<Expr>, f64> = FxHashMap::default();
        count.insert(h, 1.0);
        for &x in post.iter().rev() {
            let c = count.get(&x).copied().unwrap_or(0.0);
            for o in self.exprs[x].operands() {
                *count.entry(o).or_insert(0.0) += c;
            }
        }
        let counted: Vec<(Handle<Expr>, f64)> =
            operands.into_iter().map(|o| (o, count.get(&o).copied().unwrap_or(1.0))).collect();
        counted.iter().all(|(_, k)| k.is_finite()).then_some(counted)
    }
}

#[cfg(test)]
mod tests {
    use crate::ir::{BinaryOp, Expr};

    use crate::ir::lower::lowered as module;

    fn is_mul(e: &Expr) -> bool {
        matches!(e, Expr::Binary { op: BinaryOp::Mul, .. })
    }

    #[test]
    fn a_tree_is_flattened_to_its_leaves_in_order() {
        let m = module(
            "texture A : 2d rgba8;\ntexture B : 2d rgba8;\ntexture D : 2d rgba8;\n\
             C δπx ← (A δu x * B δu x) * (D δu x * A δu x);\n",
        );
        let v = m.statements[0].value;
        let ops = m.chain_operands(v, is_mul);
        assert_eq!(ops.len(), 4);
        assert_eq!(ops[0], ops[3], "the same lookup, one node");
        assert!(ops.iter().all(|o| !is_mul(&m.exprs[*o])));
    }

    #[test]
    fn repeated_squares_past_the_limit_stay_whole() {
        let squares = |n: usize| {
            let mut src = String::from("texture A : 2d rgba8;\nlet a0 = A δu x;\n");
            for i in 1..=n {
                src += &format!("let a{i} = a{} * a{};\n", i - 1, i - 1);
            }
            module(&(src + &format!("C δπx ← a{n};\n")))
        };
        // 2¹⁶ factors: written out, each the one lookup.
        let m = squares(16);
        let ops = m.chain_operands(m.statements[0].value, is_mul);
        assert_eq!(ops.len(), 1 << 16);
        assert!(ops.iter().all(|o| *o == ops[0] && !is_mul(&m.exprs[*o])));
        // 2⁴⁰ factors: the root, whole.
        let m = squares(40);
        let v = m.statements[0].value;
        assert_eq!(m.chain_operands(v, is_mul), vec![v]);
        // Counted: the one lookup, 2⁴⁰ times.
        let counted = m.chain_counted(v, is_mul).expect("finite");
        assert_eq!(counted.len(), 1);
        assert_eq!(counted[0].1, 2f64.powi(40));
        assert!(!is_mul(&m.exprs[counted[0].0]));
    }

    #[test]
    fn counted_operands_keep_their_written_order() {
        let m = module(
            "texture A : 2d rgba8;\ntexture B : 2d rgba8;\ntexture D : 2d rgba8;\n\
             let ab = A δu x + B δu x;\nC δπx ← (ab + D δu x) + ab;\n",
        );
        let v = m.statements[0].value;
        let is_add = |e: &Expr| matches!(e, Expr::Binary { op: BinaryOp::Add, .. });
        let written = m.chain_operands(v, is_add);
        let counted = m.chain_counted(v, is_add).expect("finite");
        assert_eq!(counted, vec![(written[0], 2.0), (written[1], 2.0), (written[2], 1.0)]);
    }
}
