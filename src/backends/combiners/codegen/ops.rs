//! Step 1 of the generator, *operations*: the general-combiner portion
//! computations (`A·B`, `A·B + C·D`, `A•B`, mux, with output scale and bias,
//! Kilgard 2000, Section 4.2) that cover the nodes a source cannot read.
//!
//! The specs built here are placed by `schedule` and read through `select`.

use super::*;

/// What a condition the mux cannot test is told.
fn bad_condition(span: Span) -> CodegenError {
    unsupported(
        span,
        "this condition",
        "the mux tests spare0.a ≥ ½ (Kilgard 2000, Section 4.2.2): compare a scalar with a constant, e.g. `Hn.z ≥ 0` (Appendix H), or with a scalar that stays at or above 0, or use a lookup texture",
    )
}

/// A condition's select (`Gen::condition`) as a value: 1 where it holds,
/// 0 elsewhere, by the mux (spare0.a ≥ ½ selects CD).
fn one_where((sel, high): (Src, bool)) -> Spec {
    let (one, zero) = (Term::times_one(Src::ONE), Term::times_one(Src::ZERO));
    let (ab, cd) = if high { (zero, one) } else { (one, zero) };
    Spec { cd: Some(cd), mux: Some(sel), ..Spec::single(ab, true) }
}

impl Gen<'_> {
    pub(super) fn materialise(&mut self, h: Handle<Expr>, part: Part, sat: bool) -> R<Src> {
        if !sat && !self.in_unit(h) {
            return Err(self.range(h));
        }
        let spec = self.spec(h, part)?.ok_or_else(|| {
            let e = self.expr(h).clone();
            self.unsupported_node(h, &e)
        })?;
        self.emit(spec, self.m.span(h))
    }

    pub(super) fn scalar(&self, h: Handle<Expr>, part: Part) -> bool {
        self.ty(h) == Ty::Scalar || self.norm(h, part) == Part::Alpha
    }

    /// The portion computation of an operation node, or `None` for a node
    /// that is a source.
    pub(super) fn spec(&mut self, h: Handle<Expr>, part: Part) -> R<Option<Spec>> {
        let part = self.norm(h, part);
        let scalar = self.scalar(h, part);
        let alpha_only = part == Part::Alpha;
        let span = self.m.span(h);
        let spec = match self.expr(h).clone() {
            Expr::Binary { op: BinaryOp::Mul, lhs, rhs } => {
                let (spec, scaled) = self.product_spec(lhs, rhs, part, scalar)?;
                if scaled {
                    return Ok(Some(spec));
                }
                spec
            }
            Expr::Binary { op: BinaryOp::Dot, lhs, rhs } => {
                if self.ty(lhs).width() != 3 || self.is_z_axis(lhs) || self.is_z_axis(rhs) {
                    return Ok(None);
                }
                Spec::single(
                    Term {
                        a: self.src(lhs, Part::Rgb, false)?,
                        b: self.src(rhs, Part::Rgb, false)?,
                        dot: true,
                    },
                    true,
                )
            }
            Expr::Binary { op: op @ (BinaryOp::Add | BinaryOp::Sub), lhs, rhs } => {
                if let Some(spec) = self.reassociated_sum(h, part, scalar, span)? {
                    return Ok(Some(Spec { alpha_only, ..spec }));
                }
                let ab = self.sum_term(lhs, part)?;
                let mut cd = self.sum_term(rhs, part)?;
                if op == BinaryOp::Sub {
                    cd = self.negate(cd, rhs, part)?;
                }
                Spec { cd: Some(cd), ..Spec::single(ab, scalar) }
            }
            Expr::Binary { op: BinaryOp::Pow, lhs, rhs } => {
                let k = self.pow2_exponent(rhs).ok_or_else(|| self.pow_error(h))?;
                let p = self.pow_src(lhs, part, k - 1)?;
                Spec::single(Term { a: p, b: p, dot: false }, scalar)
            }
            Expr::Binary { op: BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge, .. } => {
                one_where(self.condition(h)?)
            }
            Expr::Select { cond, accept, reject: Some(reject) } => {
                let (sel, high) = self.condition(cond)?;
                let acc = self.plain_term(accept, part)?;
                let rej = self.plain_term(reject, part)?;
                let (ab, cd) = if high { (rej, acc) } else { (acc, rej) };
                Spec { cd: Some(cd), mux: Some(sel), ..Spec::single(ab, scalar) }
            }
            // step(e, x) is `x ≥ e`: 1 or 0 by the mux, as the comparison.
            Expr::Math { fun: MathFunction::Step, ref args } => {
                one_where(self.comparison(h, BinaryOp::Ge, args[1], args[0])?)
            }
            Expr::Math { fun: MathFunction::Mix, ref args } => self.mix_spec(args, part, scalar, span)?,
            Expr::Math { fun: fun @ (MathFunction::Min | MathFunction::Max), ref args }
                if self.is_extremum(fun, args) =>
            {
                let Some(spec) = self.extremum_spec(fun, args, part, scalar, span)? else { return Ok(None) };
                spec
            }
            Expr::Math {
                fun: fun @ (MathFunction::Expand | MathFunction::HalfBias | MathFunction::Compress),
                ref args,
            } => self.mapped_spec(fun, args[0], part, scalar)?,
            Expr::Unary { op: UnaryOp::Neg, value } => {
                let t = self.plain_term(value, part)?;
                Spec::single(self.negate(t, value, part)?, scalar)
            }
            _ => return Ok(None),
        };
        Ok(Some(Spec { alpha_only, ..spec }))
    }

    /// `a · b` as one product, or with a scale of ½, 2, 4 or 8 moved onto
    /// the portion's output; `true` when scaled (the spec is final).
    pub(super) fn product_spec(
        &mut self,
        lhs: Handle<Expr>,
        rhs: Handle<Expr>,
        part: Part,
        scalar: bool,
    ) -> R<(Spec, bool)> {
        let scale = |g: &Self, k: Handle<Expr>| g.constant(k).filter(|k| [0.5, 2.0, 4.0, 8.0].contains(k));
        if let Some((k, x)) =
            scale(self, lhs).map(|k| (k, rhs)).or_else(|| scale(self, rhs).map(|k| (k, lhs)))
        {
            let inner = self.spec_or_source(x, part)?;
            return Ok((self.scaled(inner, k, Some(x), part)?, true));
        }
        // `(k · y) · z` where `k · y` is a per-object value seen
        // through the part it contributes (a uniform colour times a
        // constant, widened to rgba): `k · (y · z)`, the scale on
        // the output (issue 16 item 5; Heidrich-Seidel's
        // `I_light * g_scale * (F·D ⊕ G)`).
        let scaled_operand = |g: &Self, o: Handle<Expr>| {
            let node = match g.part_node(o, part) {
                Some(Some(n)) => n,
                Some(None) => return None,
                None => o,
            };
            match *g.expr(node) {
                Expr::Binary { op: BinaryOp::Mul, lhs: a, rhs: b } if !g.m.info(node).freq.is_sample() => {
                    scale(g, a).map(|k| (k, b)).or_else(|| scale(g, b).map(|k| (k, a)))
                }
                _ => None,
            }
        };
        if let Some((k, y, z)) = scaled_operand(self, lhs)
            .map(|(k, y)| (k, y, rhs))
            .or_else(|| scaled_operand(self, rhs).map(|(k, y)| (k, y, lhs)))
        {
            let term = Term { a: self.src(y, part, false)?, b: self.src(z, part, false)?, dot: false };
            return Ok((self.scaled(Spec::single(term, scalar), k, None, part)?, true));
        }
        // A constant above 1 that a scale folded into (`kd * 2 * x` is
        // `(1.8, 1.6, 1.4) * x`): the constant over the smallest output
        // scale that brings it into [0, 1], times the rest, scaled.
        if let Some((k, c, z)) = self
            .above_one(lhs, part)
            .map(|(k, c)| (k, c, rhs))
            .or_else(|| self.above_one(rhs, part).map(|(k, c)| (k, c, lhs)))
        {
            let term = Term { a: c, b: self.src(z, part, false)?, dot: false };
            return Ok((self.scaled(Spec::single(term, scalar), k, None, part)?, true));
        }
        if let Some(spec) = self.distributed_product(lhs, rhs, part, scalar)? {
            return Ok((spec, false));
        }
        Ok((
            Spec::single(
                Term { a: self.src(lhs, part, false)?, b: self.src(rhs, part, false)?, dot: false },
                scalar,
            ),
            false,
        ))
    }

    /// `(a ± b)·c` with `a ± b` beyond a register's [−1, 1] (which would
    /// clamp it), `a` and `b` sources or values within [−1, 1] and `c` a
    /// source: `a·c ± b·c` in one portion, AB + CD (Kilgard 2000, Section
    /// 4.2.2). `None` otherwise.
    pub(super) fn distributed_product(
        &mut self,
        lhs: Handle<Expr>,
        rhs: Handle<Expr>,
        part: Part,
        scalar: bool,
    ) -> R<Option<Spec>> {
        let (sum, c) = if self.sum_beyond_a_register(lhs, part) { (lhs, rhs) } else { (rhs, lhs) };
        let Expr::Binary { op: op @ (BinaryOp::Add | BinaryOp::Sub), lhs: a, rhs: b } = *self.expr(sum)
        else {
            return Ok(None);
        };
        let plain = |g: &Self, h: Handle<Expr>| g.is_source(h) || g.cache.contains_key(&(h, g.norm(h, part)));
        // An addend within [−1, 1] computed first (`(N·L + ½)·⅔`, wrap
        // lighting: the dot product in its own portion) is a register.
        let addend = |g: &Self, h: Handle<Expr>| plain(g, h) || g.in_unit(h);
        if !self.sum_beyond_a_register(sum, part) || !addend(self, a) || !addend(self, b) || !plain(self, c) {
            return Ok(None);
        }
        let cs = self.src(c, part, false)?;
        let ab = Term { a: self.src(a, part, false)?, b: cs, dot: false };
        let mut cd = Term { a: self.src(b, part, false)?, b: cs, dot: false };
        if op == BinaryOp::Sub {
            cd = self.negate(cd, b, part)?;
        }
        Ok(Some(Spec { cd: Some(cd), ..Spec::single(ab, scalar) }))
    }

    /// A non-negative constant `h` whose largest component read by `part`
    /// is in (1, 8]: the smallest scale 2, 4 or 8 that brings it into
    /// [0, 1], and a constant register holding it divided by that scale.
    pub(super) fn above_one(&mut self, h: Handle<Expr>, part: Part) -> Option<(f64, Src)> {
        let Expr::Constant(c) = self.expr(h).clone() else { return None };
        let values: Vec<f64> = match (c.ty, part) {
            (Ty::Rgba, Part::Alpha) => vec![c.components[3]],
            (Ty::Rgba, Part::Rgb) => c.components[..3].to_vec(),
            _ => c.values().to_vec(),
        };
        let max = values.iter().copied().fold(0.0, f64::max);
        if values.iter().any(|v| *v < 0.0 || !v.is_finite()) || max <= 1.0 {
            return None;
        }
        let k = [2.0, 4.0, 8.0].into_iter().find(|k| max / k <= 1.0)?;
        let scalar_like = values.len() == 1;
        let mut color = [0.0f32; 4];
        for (i, slot) in color.iter_mut().enumerate() {
            let v = if scalar_like { values[0] } else { values.get(i).copied().unwrap_or(0.0) };
            *slot = (v / k) as f32;
        }
        let comp = if scalar_like || part == Part::Alpha { Comp::Alpha } else { Comp::Rgb };
        let konst = self.konst(h, color, true, comp).ok()?;
        Some((k, Src { base: Base::K(konst), comp, map: UnsignedIdentity }))
    }

    /// `mix(a, b, t)` = a·(1 − t) + b·t, t in [0, 1] (UNSIGNED_INVERT).
    pub(super) fn mix_spec(
        &mut self,
        args: &[Handle<Expr>],
        part: Part,
        scalar: bool,
        span: Span,
    ) -> R<Spec> {
        let (a, b, t) = (args[0], args[1], args[2]);
        if self.lo(t) < 0.0 || self.hi(t) > 1.0 {
            return Err(unsupported(span, "`mix` with a weight outside [0, 1]", "saturate the weight"));
        }
        let ts = self.src(t, part, false)?;
        let ts = self.unsigned(ts, span)?;
        let inv = Src { map: if ts.map == UnsignedInvert { UnsignedIdentity } else { UnsignedInvert }, ..ts };
        let ab = Term { a: self.src(a, part, false)?, b: inv, dot: false };
        let cd = Term { a: self.src(b, part, false)?, b: ts, dot: false };
        Ok(Spec { cd: Some(cd), ..Spec::single(ab, scalar) })
    }

    /// `expand`, `half_bias` or `compress` of a computed value: the
    /// portion's output bias and scale (Kilgard 2000, Table 5).
    pub(super) fn mapped_spec(
        &mut self,
        fun: MathFunction,
        x: Handle<Expr>,
        part: Part,
        scalar: bool,
    ) -> R<Spec> {
        let mut inner = self.spec_or_source(x, part)?;
        match fun {
            MathFunction::Compress => {
                // (x + 1) · ½
                if inner.cd.is_some()
                    || inner.mux.is_some()
                    || inner.ab.dot
                    || inner.scale != Scale::One
                    || inner.bias != Bias::Zero
                {
                    inner = Spec::single(Term::times_one(self.src(x, part, false)?), scalar);
                }
                inner.cd = Some(Term::times_one(Src::ONE));
                inner.scale = Scale::OneHalf;
            }
            _ => {
                // expand: (x − ½) · 2; half_bias: x − ½ (bias before scale).
                if inner.scale != Scale::One || inner.bias != Bias::Zero {
                    inner = Spec::single(Term::times_one(self.src(x, part, false)?), scalar);
                }
                inner.bias = Bias::NegativeOneHalf;
                if fun == MathFunction::Expand {
                    inner.scale = Scale::Two;
                }
            }
        }
        inner.scalar = scalar;
        Ok(inner)
    }

    /// The node as a portion computation, or its source times one.
    pub(super) fn spec_or_source(&mut self, h: Handle<Expr>, part: Part) -> R<Spec> {
        let scalar = self.scalar(h, part);
        // Sources first: a lookup or a mapped register is not an operation.
        match self.spec_if_operation(h, part)? {
            Some(s) => Ok(s),
            None => Ok(Spec::single(Term::times_one(self.src(h, part, false)?), scalar)),
        }
    }

    /// `spec` for nodes `src` would materialise; `None` for sources.
    pub(super) fn spec_if_operation(&mut self, h: Handle<Expr>, part: Part) -> R<Option<Spec>> {
        if self.cache.contains_key(&(h, self.norm(h, part))) || self.is_source(h) {
            return Ok(None);
        }
        self.spec(h, part)
    }

    /// Nodes `src` turns into a source without a new operation.
    pub(super) fn is_source(&self, h: Handle<Expr>) -> bool {
        match self.expr(h) {
            Expr::Binary { op: BinaryOp::Dot, lhs, rhs } if self.is_z_axis(*lhs) || self.is_z_axis(*rhs) => {
                true
            }
            Expr::Math { fun: MathFunction::Expand | MathFunction::HalfBias, args } => {
                self.is_source(args[0])
            }
            Expr::Unary { op: UnaryOp::Neg, value } => self.is_source(*value),
            Expr::Binary {
                op: BinaryOp::Mul | BinaryOp::Add | BinaryOp::Sub | BinaryOp::Dot | BinaryOp::Pow,
                ..
            }
            | Expr::Binary { op: BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge, .. }
            | Expr::Select { .. }
            | Expr::Math { .. } => false,
            _ => true,
        }
    }

    /// `k · spec`: the output scale, or AB + AB for 8 (Kilgard 2000, Appendix G's
    /// `4 · (Lz + Lz)`).
    /// `x` is the node `inner` computes, read again when the scale cannot
    /// join `inner`'s portion; `None` when `inner` is one fresh product
    /// (which any scale joins).
    pub(super) fn scaled(&mut self, mut inner: Spec, k: f64, x: Option<Handle<Expr>>, part: Part) -> R<Spec> {
        let scalar = inner.scalar;
        let (span, original) = (self.span, inner);
        let fresh = |g: &mut Self| -> R<Spec> {
            let s = match x {
                Some(x) => g.src(x, part, false)?,
                None => g.emit(original, span)?,
            };
            Ok(Spec::single(Term::times_one(s), scalar))
        };
        if inner.scale != Scale::One || inner.mux.is_some() {
            inner = fresh(self)?;
        }
        if k == 8.0 {
            if inner.cd.is_some() || inner.ab.dot {
                inner = fresh(self)?;
            }
            inner.cd = Some(inner.ab);
            inner.scale = Scale::Four;
            return Ok(inner);
        }
        if k == 0.5 && inner.bias != Bias::Zero {
            inner = fresh(self)?;
        }
        inner.scale = match k {
            0.5 => Scale::OneHalf,
            2.0 => Scale::Two,
            _ => {
                if inner.bias != Bias::Zero {
                    inner = fresh(self)?;
                }
                Scale::Four
            }
        };
        Ok(inner)
    }

    /// Whether `o` is a sum (or difference, or negation) not yet computed
    /// whose range leaves a register's [−1, 1].
    pub(super) fn sum_beyond_a_register(&self, o: Handle<Expr>, part: Part) -> bool {
        matches!(
            self.expr(o),
            Expr::Binary { op: BinaryOp::Add | BinaryOp::Sub, .. } | Expr::Unary { op: UnaryOp::Neg, .. }
        ) && !self.in_unit(o)
            && !self.cache.contains_key(&(o, self.norm(o, part)))
    }

    /// The addends of a sum not yet computed, each with whether it is
    /// subtracted: `(a + b) − c` is `[(a, +), (b, +), (c, −)]`.
    pub(super) fn signed_addends(
        &self,
        h: Handle<Expr>,
        part: Part,
        minus: bool,
        out: &mut Vec<(Handle<Expr>, bool)>,
    ) {
        let fresh = !self.cache.contains_key(&(h, self.norm(h, part))) && out.len() < MAX_ADDENDS;
        match *self.expr(h) {
            Expr::Binary { op: op @ (BinaryOp::Add | BinaryOp::Sub), lhs, rhs } if fresh => {
                self.signed_addends(lhs, part, minus, out);
                self.signed_addends(rhs, part, minus ^ (op == BinaryOp::Sub), out);
            }
            Expr::Unary { op: UnaryOp::Neg, value } if fresh => self.signed_addends(value, part, !minus, out),
            _ => out.push((h, minus)),
        }
    }

    /// A sum whose written grouping holds a partial sum beyond [−1, 1] in
    /// a register, which clamps it (Kilgard 2000, Section 4.2.2:
    /// registers hold [−1, 1]): `(T + T) − T` would compute `min(2T, 1) − T`.
    /// Its addends in an order whose every partial sum fits — `(T − T) + T`
    /// — one stage per addend after the first two; `None` when the
    /// grouping as written fits, or no order does.
    pub(super) fn reassociated_sum(
        &mut self,
        h: Handle<Expr>,
        part: Part,
        scalar: bool,
        span: Span,
    ) -> R<Option<Spec>> {
        let Expr::Binary { lhs, rhs, .. } = *self.expr(h) else { return Ok(None) };
        if !self.sum_beyond_a_register(lhs, part) && !self.sum_beyond_a_register(rhs, part) {
            return Ok(None);
        }
        let mut addends = Vec::new();
        self.signed_addends(h, part, false, &mut addends);
        let ranges: Vec<(f64, f64)> = addends
            .iter()
            .map(|&(t, minus)| {
                let i = self.m.info(t).interval;
                if minus {
                    (-i.hi, -i.lo)
                } else {
                    (i.lo, i.hi)
                }
            })
            .collect();
        let Some(order) = order_within_a_register(&ranges) else { return Ok(None) };
        let mut terms = Vec::with_capacity(order.len());
        for i in order {
            let (t, minus) = addends[i];
            let term = self.sum_term(t, part)?;
            terms.push(if minus { self.negate(term, t, part)? } else { term });
        }
        let mut spec = Spec { cd: Some(terms[1]), ..Spec::single(terms[0], scalar) };
        for term in &terms[2..] {
            let partial = self.emit(Spec { alpha_only: part == Part::Alpha, ..spec }, span)?;
            spec = Spec { cd: Some(*term), ..Spec::single(Term::times_one(partial), scalar) };
        }
        Ok(Some(spec))
    }

    /// An addend of AB + CD: a product of two sources, or a source times one.
    pub(super) fn sum_term(&mut self, h: Handle<Expr>, part: Part) -> R<Term> {
        if let Expr::Binary { op: BinaryOp::Mul, lhs, rhs } = self.expr(h).clone() {
            let is_scale = |k: Option<f64>| k.is_some_and(|k| k.abs() > 1.0);
            if !is_scale(self.constant(lhs))
                && !is_scale(self.constant(rhs))
                && !self.cache.contains_key(&(h, self.norm(h, part)))
            {
                return Ok(Term {
                    a: self.src(lhs, part, false)?,
                    b: self.src(rhs, part, false)?,
                    dot: false,
                });
            }
        }
        Ok(Term::times_one(self.src(h, part, false)?))
    }

    /// A term for a mux input: like `sum_term`, but `x^2` squares in place
    /// (Appendix H's `spare0 · spare0`).
    pub(super) fn plain_term(&mut self, h: Handle<Expr>, part: Part) -> R<Term> {
        if let Expr::Binary { op: BinaryOp::Pow, lhs, rhs } = self.expr(h).clone() {
            if let Some(k) = self.pow2_exponent(rhs) {
                let p = self.pow_src(lhs, part, k - 1)?;
                return Ok(Term { a: p, b: p, dot: false });
            }
        }
        self.sum_term(h, part)
    }

    pub(super) fn negate(&mut self, t: Term, h: Handle<Expr>, part: Part) -> R<Term> {
        for flip_a in [false, true] {
            let s = if flip_a { t.a } else { t.b };
            let map = negated(s.map);
            // UNSIGNED_INVERT of zero is one; its negation is −1 = EXPAND_NORMAL of zero.
            let map = map.or_else(|| (s == Src::ONE).then_some(ExpandNormal));
            if let Some(map) = map {
                let s = Src { map, ..s };
                return Ok(if flip_a { Term { a: s, ..t } } else { Term { b: s, ..t } });
            }
        }
        // Materialise the term, then negate it.
        let v = self.emit(Spec::single(t, self.scalar(h, part)), self.m.span(h))?;
        Ok(Term::times_one(Src { map: SignedNegate, ..v }))
    }

    /// A condition as (the value to place in spare0.a, whether the condition
    /// holds when that value is ≥ ½). The mux selects CD when spare0.a ≥ ½
    /// (Kilgard 2000, Section 4.2.2).
    pub(super) fn condition(&mut self, cond: Handle<Expr>) -> R<(Src, bool)> {
        let span = self.m.span(cond);
        let bad = || bad_condition(span);
        let Expr::Binary { op, lhs, rhs } = self.expr(cond).clone() else { return Err(bad()) };
        if !self.reads_depth(cond) {
            return self.comparison(cond, op, lhs, rhs);
        }
        // A depth texture's compare (issue 39): the unit's register holds 1 where lit.
        if let Some(k) = crate::planner::shadow_map::compare_unit(self.m, self.units, cond) {
            let Some(reg) = u8::try_from(k).ok().and_then(Register::texture) else {
                return Err(unsupported(
                    span,
                    "a depth comparison read on a texture unit past the fourth",
                    "the register combiners have registers for texture units 0 to 3 only (Kilgard 2000): read fewer textures in this statement",
                ));
            };
            return Ok((Src { base: Base::Reg(reg), comp: Comp::Alpha, map: UnsignedIdentity }, false));
        }
        // The shadow-mask test (seeds/001 Section 3.5) in another form.
        Err(unsupported(
            span,
            "a per-pixel depth comparison (a shadow-map test)",
            crate::planner::shadow_map::REFUSAL_HELP,
        ))
    }

    /// `lhs op rhs` (`op` one of `< ≤ > ≥`) as the mux's select: the
    /// source tested against ½, and whether the comparison holds on its high
    /// side. `node` keys the offset constant a comparison with a constant
    /// other than 0 or ½ needs.
    pub(super) fn comparison(
        &mut self,
        node: Handle<Expr>,
        op: BinaryOp,
        lhs: Handle<Expr>,
        rhs: Handle<Expr>,
    ) -> R<(Src, bool)> {
        let span = self.m.span(node);
        let bad = || bad_condition(span);
        let (x, k, high) = match (self.constant(lhs), self.constant(rhs), op) {
            (_, Some(k), BinaryOp::Ge | BinaryOp::Gt) => (lhs, k, true),
            (_, Some(k), BinaryOp::Lt | BinaryOp::Le) => (lhs, k, false),
            (Some(k), _, BinaryOp::Le | BinaryOp::Lt) => (rhs, k, true),
            (Some(k), _, BinaryOp::Ge | BinaryOp::Gt) => (rhs, k, false),
            (None, None, BinaryOp::Ge | BinaryOp::Gt) => {
                return self.compared(lhs, rhs, span)?.ok_or_else(bad)
            }
            (None, None, BinaryOp::Le | BinaryOp::Lt) => {
                return self.compared(rhs, lhs, span)?.ok_or_else(bad)
            }
            _ => return Err(bad()),
        };
        let s = self.src(x, Part::Rgb, false)?;
        let sel = if k == 0.5 {
            match s.map {
                UnsignedIdentity | SignedIdentity => Src { map: UnsignedIdentity, ..s },
                _ => self.copy(s, span)?,
            }
        } else if k == 0.0 {
            match s.map {
                // expand(b) ≥ 0 ⟺ b ≥ ½; half_bias(b) ≥ 0 ⟺ b ≥ ½.
                ExpandNormal | HalfBiasNormal => Src { map: UnsignedIdentity, ..s },
                _ => {
                    // x + ½ ≥ ½ ⟺ x ≥ 0 (the write rounds ties up, so x = 0 gives 128/255).
                    let t = Term::times_one(s);
                    let half = Term::times_one(Src::zero_mapped(HalfBiasNegate));
                    self.emit(Spec { cd: Some(half), ..Spec::single(t, true) }, span)?
                }
            }
        } else if (-0.5..=1.5).contains(&k) {
            // x ≥ k ⟺ x + (½ − k) ≥ ½: the offset is a constant colour (or
            // its negation), the sum clamped to [−1, 1], which keeps its
            // side of ½ (Kilgard 2000, Section 4.2.2).
            let offset = self.constant_src(node, &Constant::scalar(0.5 - k), Part::Alpha)?;
            let t = Term::times_one(s);
            self.emit(Spec { cd: Some(Term::times_one(offset)), ..Spec::single(t, true) }, span)?
        } else {
            return Err(bad());
        };
        Ok((sel, high))
    }

    /// Whether `args` are two values neither of which is a constant: a
    /// `min` or `max` of them selects by the mux (a `max` with 0 is an
    /// input mapping, `select::src_uncached`).
    pub(super) fn two_computed(&self, args: &[Handle<Expr>]) -> bool {
        args.len() == 2 && args.iter().all(|&a| self.constant(a).is_none())
    }

    /// min(a, b) and max(a, b) of two computed scalars pick one by the mux:
    /// `a ≥ b` selects CD ([`Gen::compared`]); other pairs (colours, a `b`
    /// below 0, a constant) by an unsigned mapping's clamp.
    fn extremum_spec(
        &mut self,
        fun: MathFunction,
        args: &[Handle<Expr>],
        part: Part,
        scalar: bool,
        span: Span,
    ) -> R<Option<Spec>> {
        Ok(match self.compared(args[0], args[1], span)? {
            Some((sel, _)) => {
                let (a, b) = (self.plain_term(args[0], part)?, self.plain_term(args[1], part)?);
                let (ab, cd) = if fun == MathFunction::Max { (b, a) } else { (a, b) };
                Some(Spec { cd: Some(cd), mux: Some(sel), ..Spec::single(ab, scalar) })
            }
            None if fun == MathFunction::Max => self.max_by_clamp(args[0], args[1], part, scalar, span)?,
            None => self
                .min_by_clamp(args[0], args[1], part, scalar, span)?
                .map(|min| Spec::single(Term::times_one(min), scalar)),
        })
    }

    /// `a − b` in a register, exact where it stays within the register's
    /// [−1, 1] on the positive side (`None` otherwise): below −1 it clamps,
    /// which the `max(0, ·)` reading it forgets anyway.
    fn clamped_difference(
        &mut self,
        a: Handle<Expr>,
        b: Handle<Expr>,
        part: Part,
        scalar: bool,
        span: Span,
    ) -> R<Option<Src>> {
        if !self.in_unit(a) || !self.in_unit(b) || self.hi(a) - self.lo(b) > 1.0 {
            return Ok(None);
        }
        let ta = self.plain_term(a, part)?;
        let tb = self.plain_term(b, part)?;
        let minus_b = self.negate(tb, b, part)?;
        self.emit(Spec { cd: Some(minus_b), ..Spec::single(ta, scalar) }, span).map(Some)
    }

    /// max(a, b) channel by channel as `b + max(0, a − b)`, the `max(0, ·)`
    /// the clamp of an UNSIGNED_IDENTITY input mapping (Kilgard 2000,
    /// Table 3): two general combiners, exact, for colours as for scalars.
    pub(super) fn max_by_clamp(
        &mut self,
        a: Handle<Expr>,
        b: Handle<Expr>,
        part: Part,
        scalar: bool,
        span: Span,
    ) -> R<Option<Spec>> {
        let Some(d) = self.clamped_difference(a, b, part, scalar, span)? else { return Ok(None) };
        let tb = self.plain_term(b, part)?;
        let clamped = Term::times_one(Src { map: UnsignedIdentity, ..d });
        Ok(Some(Spec { cd: Some(clamped), ..Spec::single(tb, scalar) }))
    }

    /// min(a, b) of values in [0, 1], channel by channel, as the source
    /// `1 − ((1 − b) + max(0, b − a))`: the register holds max(1 − a, 1 − b)
    /// (UNSIGNED_INVERT of `b` plus UNSIGNED_IDENTITY of `b − a`, Kilgard
    /// 2000, Table 3) and its reader's UNSIGNED_INVERT turns it back. Two
    /// general combiners, exact; `None` outside [0, 1].
    pub(super) fn min_by_clamp(
        &mut self,
        a: Handle<Expr>,
        b: Handle<Expr>,
        part: Part,
        scalar: bool,
        span: Span,
    ) -> R<Option<Src>> {
        if [a, b].iter().any(|&h| self.lo(h) < 0.0 || self.hi(h) > 1.0) {
            return Ok(None);
        }
        let Some(d) = self.clamped_difference(b, a, part, scalar, span)? else { return Ok(None) };
        let sb = match self.src(b, part, false)? {
            s @ Src { map: UnsignedIdentity | SignedIdentity, .. } => s,
            s => self.copy(s, span)?,
        };
        let inverted_b = Term::times_one(Src { map: UnsignedInvert, ..sb });
        let clamped = Term::times_one(Src { map: UnsignedIdentity, ..d });
        let r = self.emit(Spec { cd: Some(clamped), ..Spec::single(inverted_b, scalar) }, span)?;
        Ok(Some(Src { map: UnsignedInvert, ..r }))
    }

    /// Whether `fun` of `args` is a `min` or `max` computed here: of two
    /// computed values, or by a clamp with one constant.
    pub(super) fn is_extremum(&self, fun: MathFunction, args: &[Handle<Expr>]) -> bool {
        matches!(fun, MathFunction::Min | MathFunction::Max)
            && (self.two_computed(args) || self.extremum_by_clamp(fun, args))
    }

    /// Whether `min` or `max` of `args` with one constant is left to
    /// [`Gen::max_by_clamp`] or [`Gen::min_by_clamp`]: not `max(0, x)`,
    /// which is an input mapping (`select::src_uncached`).
    pub(super) fn extremum_by_clamp(&self, fun: MathFunction, args: &[Handle<Expr>]) -> bool {
        let constants = args.iter().filter(|&&a| self.constant(a).is_some()).count();
        let zero = args.iter().any(|&a| self.constant(a) == Some(0.0));
        args.len() == 2 && constants == 1 && !(fun == MathFunction::Max && zero)
    }

    /// Whether [`Gen::compared`] tests `args[0] ≥ args[1]`: two scalars, the
    /// second not below 0.
    pub(super) fn both_scalar_compared(&self, args: &[Handle<Expr>]) -> bool {
        let scalar = |h: Handle<Expr>| self.m.info(h).ty == Ty::Scalar;
        args.len() == 2 && self.lo(args[1]) >= 0.0 && scalar(args[0]) && scalar(args[1])
    }

    /// `a ≥ b` of two computed values, as the mux's select: `a + (½ − b)`,
    /// with `½ − b` the input mapping HALF_BIAS_NEGATE of `b` (Kilgard
    /// 2000, Table 3), is ≥ ½ exactly when `a ≥ b`, and the register's
    /// clamp to [−1, 1] keeps it on its side of ½. The mapping first clamps
    /// its input to [0, 1], so `b` must not go below 0 (`None` otherwise:
    /// the caller refuses). A tie selects the `≥` side, as the comparisons
    /// with a constant do.
    fn compared(&mut self, a: Handle<Expr>, b: Handle<Expr>, span: Span) -> R<Option<(Src, bool)>> {
        if !self.both_scalar_compared(&[a, b]) {
            return Ok(None);
        }
        let sa = self.src(a, Part::Rgb, false)?;
        let sb = match self.src(b, Part::Rgb, false)? {
            s @ Src { map: UnsignedIdentity | SignedIdentity, .. } => s,
            s => self.copy(s, span)?,
        };
        let minus_b = Term::times_one(Src { map: HalfBiasNegate, ..sb });
        let sel = self.emit(Spec { cd: Some(minus_b), ..Spec::single(Term::times_one(sa), true) }, span)?;
        Ok(Some((sel, true)))
    }

    /// Adds an operation: picks its portion, fixes up component reads the
    /// portion cannot make, and schedules it. Returns the result's source.
    pub(super) fn emit(&mut self, mut spec: Spec, span: Span) -> R<Src> {
        let lane = self.lane_of(&spec);
        // A dot product forbids the sum output (B.4): materialise it first.
        if spec.cd.is_some() || spec.mux.is_some() {
            if spec.ab.dot {
                let v = self.emit(Spec::single(spec.ab, true), span)?;
                spec.ab = Term::times_one(v);
            }
            if let Some(cd) = spec.cd.filter(|t| t.dot) {
                let v = self.emit(Spec::single(cd, true), span)?;
                spec.cd = Some(Term::times_one(v));
            }
        }
        let fix = |g: &mut Self, s: Src| -> R<Src> {
            Ok(match (lane, s.comp) {
                (Lane::Rgb, Comp::Blue) => g.blue_to_alpha(s, span)?,
                (Lane::Alpha, Comp::Bcast) => Src { comp: Comp::Blue, ..s },
                (Lane::Alpha, Comp::Rgb) if g.is_const_reg(&s) => Src { comp: Comp::Alpha, ..s },
                (Lane::Alpha, Comp::Rgb) => {
                    return Err(unsupported(
                        span,
                        "a vector in an alpha computation",
                        "the alpha portion reads alpha or blue (Kilgard 2000, B.4)",
                    ))
                }
                _ => s,
            })
        };
        spec.ab.a = fix(self, spec.ab.a)?;
        spec.ab.b = fix(self, spec.ab.b)?;
        if let Some(mut cd) = spec.cd {
            cd.a = fix(self, cd.a)?;
            cd.b = fix(self, cd.b)?;
            spec.cd = Some(cd);
        }
        if let Some(sel) = spec.mux {
            spec.mux = Some(self.pin_select(sel, span)?);
        }
        let (stage, in_cd) = self.schedule(&spec, lane, span)?;
        let out = self.vregs.len();
        self.vregs.push(VReg { lane, op: self.ops.len(), pin: None, reg: None });
        self.ops.push(Op {
            lane,
            ab: spec.ab,
            cd: spec.cd,
            mux: spec.mux,
            scale: spec.scale,
            bias: spec.bias,
            out,
            stage,
            in_cd,
            span,
        });
        let comp = match lane {
            Lane::Alpha => Comp::Alpha,
            Lane::Rgb if spec.scalar => Comp::Bcast,
            Lane::Rgb => Comp::Rgb,
        };
        Ok(Src { base: Base::V(out), comp, map: SignedIdentity })
    }
}
