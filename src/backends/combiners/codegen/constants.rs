//! Virtual constants and the constant registers they get: `konst` records
//! a constant colour as it is read, `assign_constants` gives each one a
//! global `constant0/1` (Kilgard 2000, B.3) or, with per-stage constants
//! (NV_register_combiners2), a stage's own pair.
//!
//! The scheduler counts constants per stage while placing operations, so the
//! bookkeeping both steps share lives in one file.

use super::*;

impl Gen<'_> {
    /// The virtual constant holding `color` for node `h`, read as `comp`
    /// (its rgb, or its alpha). Constant registers are read-only (Kilgard 2000
    /// Table 2), so one register serves every read of a colour: a read
    /// shares the constant of the same node, or of a folded constant equal
    /// on the components read (a uniform with a default shares a folded
    /// constant's; a folded constant never a uniform's, which the caller may
    /// rebind). Without per-stage constants the whole pass has two (B.3),
    /// so the third distinct one is an error here; with them, the scheduler
    /// and `assign_constants` place them per stage.
    pub(super) fn konst(&mut self, h: Handle<Expr>, color: Color, known: bool, comp: Comp) -> R<usize> {
        let same = |a: &Color, b: &Color| match comp {
            Comp::Alpha => a[3] == b[3],
            _ => a[..3] == b[..3],
        };
        let is_constant = |g: &Self, n: Handle<Expr>| matches!(g.expr(n), Expr::Constant(_));
        for (i, k) in self.konsts.iter().enumerate() {
            // One node may need several known colours (the unit colours of
            // a permutation, `select::permutation_src`): one each.
            let same_node =
                k.node == h && (!(is_constant(self, h) || known && k.known) || same(&k.color, &color));
            let same_color = known && k.known && is_constant(self, k.node) && same(&k.color, &color);
            if same_node || same_color {
                return Ok(i);
            }
        }
        self.konsts.push(VConst { color, node: h, known });
        let i = self.konsts.len() - 1;
        if !self.limits.per_stage_constants && self.konsts.len() > 2 {
            let all: Vec<usize> = (0..self.konsts.len()).collect();
            return Err(self.out_of_constants(self.m.span(h), "the pass".into(), &all));
        }
        Ok(i)
    }

    pub(super) fn out_of_constants(&self, span: Span, place: String, ks: &[usize]) -> CodegenError {
        CodegenError::OutOfConstants {
            span,
            place,
            constants: ks.iter().map(|k| self.describe_konst(*k)).collect(),
        }
    }

    /// A constant as the user wrote it: `uniform I_light`, or its value.
    pub(super) fn describe_konst(&self, k: usize) -> String {
        let node = self.konsts[k].node;
        match self.expr(node) {
            Expr::Uniform(id) => format!("uniform `{}`", self.m.uniforms[*id as usize].name),
            Expr::Constant(c) => match c.values() {
                [v] => format!("{v}"),
                vs => format!("({})", vs.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(", ")),
            },
            _ => format!("{:?}", self.konsts[k].color),
        }
    }

    /// The virtual constants a source list reads, each once, in order.
    pub(super) fn konsts_of(srcs: impl IntoIterator<Item = Src>) -> Vec<usize> {
        let mut out = Vec::new();
        for s in srcs {
            if let Base::K(k) = s.base {
                if !out.contains(&k) {
                    out.push(k);
                }
            }
        }
        out
    }
}

impl Gen<'_> {
    /// Gives every virtual constant a constant register, once operations
    /// have their stages. Without per-stage constants, or when the pass
    /// reads at most two, they are the global `constant0/1` in order of
    /// first use (Kilgard 2000, B.3; `konst` refused a third). Otherwise
    /// (NV_register_combiners2) the final combiner reads the global two and
    /// each general stage its own two, which default to the global ones
    /// (nvparse copies the global constants into the stages that set none;
    /// so does the emulator). The global constants are then: those the
    /// final combiner reads and the uniforms the caller supplies (which can
    /// only be global), then those read by the most stages; a stage sets
    /// its own constant for anything else it reads, in a slot whose global
    /// constant it does not read. The scheduler kept every stage at two.
    pub(super) fn assign_constants(&mut self, fin: &FinalSpec) -> R<()> {
        let n = self.stage_used.len();
        let all = self.konsts.len();
        let mut a = ConstAssignment { global: [None, None], local: vec![[None, None]; n] };
        if !self.limits.per_stage_constants || all <= 2 {
            for (j, slot) in a.global.iter_mut().enumerate().take(all) {
                *slot = Some(j);
            }
            self.assigned = a;
            return Ok(());
        }
        let mut final_reads = vec![fin.e, fin.f, fin.g];
        for v in [fin.a, fin.b, fin.c, fin.d] {
            if let FinalVal::Src(s) = v {
                final_reads.push(s);
            }
        }
        let final_ks = Self::konsts_of(final_reads);
        let mut global: Vec<usize> =
            (0..all).filter(|k| final_ks.contains(k) || !self.konsts[*k].known).collect();
        if global.len() > 2 {
            let place = if global.iter().all(|k| final_ks.contains(k)) {
                "the final combiner".to_string()
            } else {
                "the final combiner, with the uniforms the caller supplies (no default: they stay global),"
                    .to_string()
            };
            let span = self.m.span(self.konsts[global[2]].node);
            return Err(self.out_of_constants(span, place, &global));
        }
        let readers = |k: usize| self.stage_konsts.iter().filter(|s| s.contains(&k)).count();
        let mut rest: Vec<usize> = (0..all).filter(|k| !global.contains(k)).collect();
        rest.sort_by_key(|k| (std::cmp::Reverse(readers(*k)), *k));
        global.extend(rest.into_iter().take(2 - global.len()));
        global.sort_unstable();
        for (j, k) in global.iter().enumerate() {
            a.global[j] = Some(*k);
        }
        for st in 0..n {
            let reads = &self.stage_konsts[st];
            let mut kept = [false; 2];
            for k in reads {
                if let Some(j) = a.global.iter().position(|g| *g == Some(*k)) {
                    kept[j] = true;
                }
            }
            for &k in reads.iter().filter(|k| !global.contains(k)) {
                let Some(j) = (0..2).find(|j| !kept[*j]) else {
                    let span = self.ops.iter().find(|op| op.stage == st).map_or(self.span, |op| op.span);
                    return Err(self.out_of_constants(span, format!("general combiner {st}"), reads));
                };
                a.local[st][j] = Some(k);
                kept[j] = true;
            }
        }
        self.assigned = a;
        Ok(())
    }
}
