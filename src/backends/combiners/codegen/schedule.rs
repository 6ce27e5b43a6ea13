//! Step 2 of the generator: operations go, in dependency order, to the
//! first general stage after their operands' where the RGB or alpha portion
//! they need is free and (with per-stage constants) whose constant colours,
//! with the operation's, are at most two.

use super::*;

impl Gen<'_> {
    /// The portion an operation runs in: RGB for dot products and vectors,
    /// alpha for scalars that read alpha or blue (Kilgard 2000, B.4).
    pub(super) fn lane_of(&self, spec: &Spec) -> Lane {
        let mut all = vec![spec.ab.a, spec.ab.b];
        if let Some(cd) = spec.cd {
            all.extend([cd.a, cd.b]);
        }
        if spec.ab.dot || spec.cd.is_some_and(|t| t.dot) {
            Lane::Rgb
        } else if spec.alpha_only {
            Lane::Alpha
        } else if !spec.scalar {
            Lane::Rgb
        } else if all.iter().any(|s| s.comp == Comp::Blue) {
            Lane::Alpha
        } else if all.iter().any(|s| matches!(s.comp, Comp::Bcast | Comp::Rgb) && !self.is_const_reg(s)) {
            Lane::Rgb
        } else {
            Lane::Alpha
        }
    }

    /// The earliest general combiner stage after the operation's inputs
    /// whose portion is free (or pairs with a lone product of the same
    /// scale and bias) and whose constant colours fit: its index, and
    /// whether the operation takes the CD products of a shared portion.
    pub(super) fn schedule(&mut self, spec: &Spec, lane: Lane, span: Span) -> R<(usize, bool)> {
        let srcs = |s: &Spec| {
            let mut v = vec![s.ab.a, s.ab.b];
            if let Some(cd) = s.cd {
                v.extend([cd.a, cd.b]);
            }
            v
        };
        let mut earliest = 0;
        for s in srcs(spec).into_iter().chain(spec.mux) {
            if let Base::V(v) = s.base {
                earliest = earliest.max(self.ops[self.vregs[v].op].stage + 1);
            }
        }
        let li = if lane == Lane::Rgb { 0 } else { 1 };
        // With per-stage constants a stage's two portions share its two
        // constant colours (NV_register_combiners2): an operation goes to a
        // stage whose constants, with its own, are at most two. Without them
        // all constants are global, at most two in all (checked by `konst`).
        let ks = Self::konsts_of(srcs(spec).into_iter().chain(spec.mux));
        let per_stage = self.limits.per_stage_constants;
        if per_stage && ks.len() > 2 {
            return Err(self.out_of_constants(span, "this general combiner operation".into(), &ks));
        }
        let fits = |g: &Self, stage: usize| {
            !per_stage
                || g.stage_konsts[stage]
                    .iter()
                    .chain(ks.iter().filter(|k| !g.stage_konsts[stage].contains(k)))
                    .count()
                    <= 2
        };
        let single = spec.cd.is_none() && spec.mux.is_none();
        let takes = |g: &Self, stage: usize| match g.stage_used[stage][li] {
            Portion::Free => true,
            Portion::Ab(o) => {
                g.pairing && single && g.ops[o].scale == spec.scale && g.ops[o].bias == spec.bias
            }
            Portion::Full => false,
        };
        let mut stage = earliest;
        while stage < self.stage_used.len() && !(takes(self, stage) && fits(self, stage)) {
            stage += 1;
        }
        if stage == self.stage_used.len() {
            self.stage_used.push([Portion::Free; 2]);
            self.stage_konsts.push(Vec::new());
        }
        let in_cd = matches!(self.stage_used[stage][li], Portion::Ab(_));
        self.stage_used[stage][li] =
            if single && !in_cd { Portion::Ab(self.ops.len()) } else { Portion::Full };
        for k in ks {
            if !self.stage_konsts[stage].contains(&k) {
                self.stage_konsts[stage].push(k);
            }
        }
        Ok((stage, in_cd))
    }

    pub(super) fn is_const_reg(&self, s: &Src) -> bool {
        matches!(s.base, Base::Reg(Register::Zero))
    }

    /// Blue-to-alpha: an alpha portion copies a blue component into an
    /// alpha register, where an RGB portion (or the final combiner) can read it.
    pub(super) fn blue_to_alpha(&mut self, s: Src, span: Span) -> R<Src> {
        let copy = Spec { alpha_only: true, ..Spec::single(Term::times_one(s), true) };
        self.emit(copy, span)
    }

    /// The mux reads spare0.a: the select value is computed into a virtual
    /// register pinned there (Appendix H: `spare0.a = unsigned(tex1.b) * one`).
    pub(super) fn pin_select(&mut self, sel: Src, span: Span) -> R<Src> {
        if let Base::V(v) = sel.base {
            if self.vregs[v].lane == Lane::Alpha
                && self.vregs[v].pin.is_none()
                && matches!(sel.map, UnsignedIdentity | SignedIdentity)
            {
                self.vregs[v].pin = Some(Register::Spare0);
                return Ok(sel);
            }
        }
        let v = self.emit(Spec { alpha_only: true, ..Spec::single(Term::times_one(sel), true) }, span)?;
        let Base::V(i) = v.base else { unreachable!("emit returns a virtual register") };
        self.vregs[i].pin = Some(Register::Spare0);
        Ok(v)
    }
}
