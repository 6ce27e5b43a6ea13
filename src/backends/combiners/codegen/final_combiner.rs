//! The output value covered by the final combiner (`A·B + (1 − A)·C + D`,
//! `E·F`, `G`; Kilgard 2000, Appendix B.4): products of up to three
//! non-negative factors (`A · EF`), powers by repeated squaring, lerps and
//! sums of two. What it cannot take goes to the general stages.

use super::*;

impl Gen<'_> {
    pub(super) fn final_combiner(&mut self, value: Handle<Expr>) -> R<FinalSpec> {
        let mut fin = FinalSpec {
            a: FinalVal::Src(Src::ZERO),
            b: FinalVal::Src(Src::ZERO),
            c: FinalVal::Src(Src::ZERO),
            d: FinalVal::Src(Src::ZERO),
            e: Src::ZERO,
            f: Src::ZERO,
            g: Src::ONE,
        };
        let ty = self.ty(value);
        if !matches!(ty, Ty::Rgb | Ty::Rgba | Ty::Scalar | Ty::Vec3) {
            return Err(unsupported(
                self.span,
                format!("a pass whose value is a {}", ty.name()),
                "a pass outputs a colour",
            ));
        }
        // rgb part.
        let (rgb, rgb_part) = match self.part_node(value, Part::Rgb) {
            Some(Some(n)) => (n, Part::Rgb),
            _ => (value, Part::Rgb),
        };
        self.final_rgb(rgb, rgb_part, &mut fin)?;
        // alpha part (G).
        if ty == Ty::Rgba {
            let alpha = match self.part_node(value, Part::Alpha) {
                Some(Some(n)) => Some((n, Part::Rgb)),
                Some(None) => None,
                None => Some((value, Part::Alpha)),
            };
            if let Some((n, part)) = alpha {
                let s = self.src(n, part, true)?;
                fin.g = self.final_alpha(s, self.m.span(n))?;
            }
        }
        Ok(fin)
    }

    pub(super) fn flatten(&self, h: Handle<Expr>, op: BinaryOp, out: &mut Vec<Handle<Expr>>) {
        out.extend(self.m.chain_operands(h, |e| matches!(e, Expr::Binary { op: o, .. } if *o == op)));
    }

    pub(super) fn nonneg_unit(&self, h: Handle<Expr>) -> bool {
        self.lo(h) >= 0.0 && self.hi(h) <= 1.0
    }

    /// out.rgb = A·B + (1 − A)·C + D, clamped to [0, 1] by the 8-bit output.
    pub(super) fn final_rgb(&mut self, v: Handle<Expr>, part: Part, fin: &mut FinalSpec) -> R<()> {
        let v = match self.expr(v) {
            Expr::Convert { value, .. } if self.ty(*value) == Ty::Scalar => *value,
            _ => v,
        };
        // abs(x) = max(0, x) + max(0, −x): the final combiner adds the two
        // halves (C + D), a general combiner fewer than the sum in a stage.
        if let Expr::Math { fun: MathFunction::Abs, ref args } = *self.expr(v) {
            let (positive, negative, _) = self.abs_halves(args[0], part, false, self.m.span(v))?;
            fin.c = FinalVal::Src(self.final_src(positive, self.m.span(v))?);
            fin.d = FinalVal::Src(self.final_src(negative, self.m.span(v))?);
            return Ok(());
        }
        let mut addends = Vec::new();
        self.flatten(v, BinaryOp::Add, &mut addends);
        // Every addend ≥ 0: the output's clamp to 1 makes each addend's own
        // clamp to 1 exact (once one reaches 1 the sum is 1 anyway), so an
        // addend beyond 1 (`4·(F·D ⊕ G)`, a stage scaled by four) is read
        // clamped, as its stage's output is (Kilgard 2000, Section 4.2.2).
        let simple = addends.iter().all(|a| self.lo(*a) >= 0.0);
        if !simple {
            // Computed in general combiners; the output saturates it.
            let s = self.src(v, part, true)?;
            fin.d = FinalVal::Src(self.final_src(s, self.m.span(v))?);
            return Ok(());
        }
        // Classify: the one A·B (or lerp) term, and the plain sources.
        let mut product = None;
        let mut leaves = Vec::new();
        for a in addends {
            if product.is_none() && self.is_final_product(a) {
                product = Some(a);
            } else {
                leaves.push(a);
            }
        }
        // Leaves first (they take the constant colours in source order).
        // Beyond what the final combiner adds (C + D, or A·B + D), trailing
        // addends are summed in general combiners. Those partial sums clamp
        // at 1, which is exact here: every addend is ≥ 0, so once a partial
        // sum reaches 1 the saturated output is 1 anyway.
        let room = if product.is_some() { 1 } else { 2 };
        let mut leaf_srcs = Vec::new();
        let extra = if leaves.len() > room { leaves.split_off(room - 1) } else { Vec::new() };
        for l in &leaves {
            let s = self.src(*l, part, !self.nonneg_unit(*l))?;
            let s = if self.nonneg_unit(*l) { s } else { self.unsigned(s, self.m.span(*l))? };
            leaf_srcs.push(self.final_src(s, self.m.span(*l))?);
        }
        if let (Some(first), Some(last)) = (extra.first(), extra.last()) {
            let span = self.m.span(*first).join(self.m.span(*last));
            let s = self.summed_addends(&extra, part, span)?;
            leaf_srcs.push(self.final_src(s, span)?);
        }
        match (product, leaf_srcs.as_slice()) {
            (None, [x]) => fin.d = FinalVal::Src(*x),
            (None, [x, y]) => {
                // A = 0: C + D.
                fin.c = FinalVal::Src(*x);
                fin.d = FinalVal::Src(*y);
            }
            (Some(p), rest) => {
                if let Some(d) = rest.first() {
                    fin.d = FinalVal::Src(*d);
                }
                self.final_product(p, part, fin)?;
            }
            _ => unreachable!("one or two addends"),
        }
        Ok(())
    }

    /// The trailing addends of an output sum, beyond what the final
    /// combiner adds, summed in general combiners (`extra` is not empty).
    fn summed_addends(&mut self, extra: &[Handle<Expr>], part: Part, span: Span) -> R<Src> {
        let scalar = extra.iter().all(|h| self.scalar(*h, part));
        let mut terms = Vec::new();
        for h in extra {
            terms.push(match self.nonneg_unit(*h) {
                true => self.sum_term(*h, part)?,
                false => {
                    let s = self.src(*h, part, true)?;
                    Term::times_one(self.unsigned(s, self.m.span(*h))?)
                }
            });
        }
        while terms.len() > 1 {
            let (Some(y), Some(x)) = (terms.pop(), terms.pop()) else { break };
            let s = self.emit(
                Spec { cd: Some(y), alpha_only: part == Part::Alpha, ..Spec::single(x, scalar) },
                span,
            )?;
            terms.push(Term::times_one(s));
        }
        Ok(terms[0].a)
    }

    /// Whether an addend goes to A·B (a product of factors in [0, 1], a
    /// power, a lerp).
    pub(super) fn is_final_product(&self, h: Handle<Expr>) -> bool {
        match self.expr(h) {
            Expr::Binary { op: BinaryOp::Mul, .. } => {
                let mut f = Vec::new();
                self.flatten(h, BinaryOp::Mul, &mut f);
                f.iter().all(|x| self.nonneg_unit(*x))
            }
            Expr::Binary { op: BinaryOp::Pow, lhs, rhs } => {
                self.pow2_exponent(*rhs).is_some() && self.nonneg_unit(*lhs)
            }
            Expr::Select { accept, reject: Some(r), .. } => {
                self.constant(*r) == Some(0.0)
                    && matches!(self.expr(*accept), Expr::Binary { op: BinaryOp::Pow, .. })
                    && self.is_final_product(*accept)
            }
            Expr::Math { fun: MathFunction::Mix, args } => args.iter().all(|a| self.nonneg_unit(*a)),
            _ => false,
        }
    }

    pub(super) fn final_product(&mut self, p: Handle<Expr>, part: Part, fin: &mut FinalSpec) -> R<()> {
        let span = self.m.span(p);
        match self.expr(p).clone() {
            Expr::Math { fun: MathFunction::Mix, args } => {
                // mix(a, b, t) = t·b + (1 − t)·a: A = t, B = b, C = a.
                let t = self.src(args[2], part, false)?;
                let b = self.src(args[1], part, false)?;
                let a = self.src(args[0], part, false)?;
                fin.a = FinalVal::Src(self.final_src(t, span)?);
                fin.b = FinalVal::Src(self.final_src(b, span)?);
                fin.c = FinalVal::Src(self.final_src(a, span)?);
                Ok(())
            }
            Expr::Binary { op: BinaryOp::Pow, lhs, rhs } => {
                let k = self.pow2_exponent(rhs).ok_or_else(|| self.pow_error(p))?;
                let m = k.min(2);
                let base = self.pow_src(lhs, part, k - m)?;
                self.final_power(base, m, span, fin)
            }
            Expr::Select { cond, accept, reject: Some(reject) } => {
                self.final_selected_power(p, [cond, accept, reject], part, fin)
            }
            _ => self.final_factors(p, part, fin),
        }
    }

    /// `c ? x^(2^k) : 0` in the final combiner: `(c ? x^(2^(k−m)) : 0)^(2^m)`,
    /// the final combiner squaring twice (EF, then EF·EF), the mux stage
    /// once (Appendix H). `[cond, accept, reject]` are the select's operands.
    fn final_selected_power(
        &mut self,
        p: Handle<Expr>,
        [cond, accept, reject]: [Handle<Expr>; 3],
        part: Part,
        fin: &mut FinalSpec,
    ) -> R<()> {
        let span = self.m.span(p);
        let Expr::Binary { op: BinaryOp::Pow, lhs: x, rhs } = self.expr(accept).clone() else {
            return Err(self.pow_error(accept));
        };
        let k = self.pow2_exponent(rhs).ok_or_else(|| self.pow_error(accept))?;
        let m = k.min(2);
        let acc = if k - m >= 1 {
            let y = self.pow_src(x, part, k - m - 1)?;
            Term { a: y, b: y, dot: false }
        } else {
            Term::times_one(self.src(x, part, false)?)
        };
        let rej = self.plain_term(reject, part)?;
        let rej = if rej.a == Src::ZERO { Term { a: Src::ZERO, b: Src::ZERO, dot: false } } else { rej };
        let (sel, high) = self.condition(cond)?;
        let (ab, cd) = if high { (rej, acc) } else { (acc, rej) };
        let scalar = self.scalar(p, part);
        let s = self.emit(
            Spec {
                cd: Some(cd),
                mux: Some(sel),
                alpha_only: part == Part::Alpha,
                ..Spec::single(ab, scalar)
            },
            span,
        )?;
        self.final_power(s, m, span, fin)
    }

    /// A product of up to three factors as A·B or A·EF; more factors are
    /// multiplied in general combiners first.
    fn final_factors(&mut self, p: Handle<Expr>, part: Part, fin: &mut FinalSpec) -> R<()> {
        let span = self.m.span(p);
        let mut factors = Vec::new();
        self.flatten(p, BinaryOp::Mul, &mut factors);
        let mut srcs = Vec::new();
        for f in factors {
            let s = self.src(f, part, false)?;
            srcs.push(s);
        }
        // More than three factors: multiply the trailing ones in general combiners.
        while srcs.len() > 3 {
            let (Some(b), Some(a)) = (srcs.pop(), srcs.pop()) else { break };
            let scalar = a.comp != Comp::Rgb && b.comp != Comp::Rgb;
            let a = self.unsigned(a, span)?;
            let b = self.unsigned(b, span)?;
            let v = self.emit(
                Spec { alpha_only: part == Part::Alpha, ..Spec::single(Term { a, b, dot: false }, scalar) },
                span,
            )?;
            srcs.push(v);
        }
        let mut fs = Vec::new();
        for s in srcs {
            fs.push(self.final_src(s, span)?);
        }
        match fs.len() {
            1 => fin.d = FinalVal::Src(fs[0]),
            2 => {
                fin.a = FinalVal::Src(fs[0]);
                fin.b = FinalVal::Src(fs[1]);
            }
            _ => {
                // A = a scalar factor (read as alpha) if there is one; B = E·F.
                let ai = fs.iter().position(|s| s.comp == Comp::Alpha).unwrap_or(0);
                let a = fs.remove(ai);
                fin.a = FinalVal::Src(a);
                fin.b = FinalVal::Ef;
                fin.e = fs[0];
                fin.f = fs[1];
            }
        }
        Ok(())
    }

    /// `s^(2^m)` for m ≤ 2 in the final combiner: A·B = s·s, or E = F = s
    /// and A = B = EF.
    pub(super) fn final_power(&mut self, s: Src, m: u32, span: Span, fin: &mut FinalSpec) -> R<()> {
        let s = self.final_src(s, span)?;
        match m {
            0 => fin.d = FinalVal::Src(s),
            1 => {
                fin.a = FinalVal::Src(s);
                fin.b = FinalVal::Src(s);
            }
            _ => {
                fin.e = s;
                fin.f = s;
                fin.a = FinalVal::Ef;
                fin.b = FinalVal::Ef;
            }
        }
        Ok(())
    }

    /// A source the final combiner can read: rgb or alpha, unsigned mapping
    /// (final inputs are clamped to ≥ 0, Section 4.2.3). Callers guarantee
    /// the value is ≥ 0 or that the output's clamp makes max(0, ·) exact.
    pub(super) fn final_src(&mut self, s: Src, span: Span) -> R<Src> {
        let s = match s.comp {
            Comp::Blue => self.blue_to_alpha(s, span)?,
            _ => s,
        };
        let s = self.unsigned(s, span)?;
        self.final_read(s, span)
    }

    /// A source the final combiner reads. It reads the two global constant
    /// colours only; with per-stage constants a third constant is copied
    /// into a register by a general stage, which has its own two
    /// (NV_register_combiners2). A uniform the caller supplies must stay
    /// global, so it counts against the final combiner's two as well.
    pub(super) fn final_read(&mut self, s: Src, span: Span) -> R<Src> {
        let Base::K(k) = s.base else { return Ok(s) };
        if self.final_konsts.contains(&k) || !self.limits.per_stage_constants {
            return Ok(s);
        }
        let supplied = (0..self.konsts.len())
            .filter(|i| !self.konsts[*i].known && !self.final_konsts.contains(i) && *i != k)
            .count();
        if self.final_konsts.len() + supplied >= 2 {
            let v = self.copy(s, span)?;
            return Ok(Src { map: UnsignedIdentity, ..v });
        }
        self.final_konsts.push(k);
        Ok(s)
    }

    /// G reads alpha.
    pub(super) fn final_alpha(&mut self, s: Src, span: Span) -> R<Src> {
        let s = match s.comp {
            Comp::Alpha => s,
            Comp::Blue | Comp::Bcast => self.blue_to_alpha(Src { comp: Comp::Blue, ..s }, span)?,
            Comp::Rgb => {
                return Err(unsupported(
                    span,
                    "an alpha made of a vector",
                    "G reads an alpha (Kilgard 2000, B.5)",
                ))
            }
        };
        let s = self.unsigned(s, span)?;
        self.final_read(s, span)
    }
}
