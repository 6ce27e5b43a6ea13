//! Step 1 of the generator, *sources*: each IR node read through one of
//! the eight input mappings of Kilgard 2000, Table 3 (texels, interpolated
//! colours, constants, `expand`, negation, `1 − x`, `max(0, x)`), or the
//! refusal that says why it cannot be read.
//!
//! Kept apart from `ops` because a source costs no stage: everything here
//! answers "which register component, through which mapping".

use super::*;

impl Gen<'_> {
    /// `h` (its `part`) as a source. `sat`: the consumer clamps the value to
    /// [0, 1], so a result the combiners clamp to [−1, 1] is still exact.
    pub(super) fn src(&mut self, h: Handle<Expr>, part: Part, sat: bool) -> R<Src> {
        let part = self.norm(h, part);
        if let Some(s) = self.cache.get(&(h, part)).copied() {
            if matches!(s.base, Base::V(_)) && !sat && !self.in_unit(h) {
                return Err(self.range(h));
            }
            return Ok(s);
        }
        let s = self.src_uncached(h, part, sat)?;
        self.cache.insert((h, part), s);
        Ok(s)
    }

    pub(super) fn range(&self, h: Handle<Expr>) -> CodegenError {
        let i = self.m.info(h).interval;
        // To six decimals: the bound's float noise (1.2800000000000002) is no help.
        let i = crate::ir::Interval { lo: (i.lo * 1e6).round() / 1e6, hi: (i.hi * 1e6).round() / 1e6 };
        // An infinite bound is "no bound known", not a range to print.
        let what = match (i.lo.is_finite(), i.hi.is_finite()) {
            (true, true) => format!("this value (range [{}, {}])", i.lo, i.hi),
            (true, false) => format!("this value (at least {}, with no upper bound)", i.lo),
            (false, true) => format!("this value (at most {}, with no lower bound)", i.hi),
            (false, false) => "this value (no bound on its range is known)".to_string(),
        };
        CodegenError::Range { span: self.m.span(h), what }
    }

    pub(super) fn src_uncached(&mut self, h: Handle<Expr>, part: Part, sat: bool) -> R<Src> {
        let span = self.m.span(h);
        match self.expr(h).clone() {
            Expr::Constant(c) => self.constant_src(h, &c, part),
            // `(0, 0, 1)·v` is v's blue, as `v.z` (a tangent-space N·L with the
            // unperturbed normal, seeds/003 Appendix G): no constant register.
            Expr::Binary { op: BinaryOp::Dot, lhs, rhs } if self.is_z_axis(lhs) || self.is_z_axis(rhs) => {
                let v = if self.is_z_axis(lhs) { rhs } else { lhs };
                let s = self.src(v, Part::Rgb, sat)?;
                Ok(match s.comp {
                    Comp::Rgb => Src { comp: Comp::Blue, ..s },
                    _ => s,
                })
            }
            // `x · 1` in this part (the alpha 1 of a widened rgb): `x`, no operation.
            Expr::Binary { op: BinaryOp::Mul, lhs, rhs } if self.is_one(lhs, part) || self.is_one(rhs, part) => {
                let x = if self.is_one(lhs, part) { rhs } else { lhs };
                self.src(x, part, sat)
            }
            Expr::Uniform(id) => self.uniform_src(h, id, part),
            Expr::Lookup { .. } | Expr::FramebufferRead { channel: FbChannel::Color | FbChannel::Alpha, .. } if self.units.contains(&h) || matches!(self.expr(h), Expr::Lookup { .. }) => {
                self.texture_src(h, part, span)
            }
            Expr::Interpolate { .. } => self.interpolant_src(h, part, sat),
            Expr::Swizzle { value, pattern, len, .. } => self.swizzle_src(h, value, &pattern, len, sat, span),
            Expr::Convert { value, to } => self.convert_src(value, to, part, sat, span),
            Expr::Compose { .. } => match self.part_node(h, part) {
                Some(Some(inner)) => self.src(inner, Part::Rgb, sat),
                Some(None) => Ok(Src::ONE),
                None => Err(unsupported(
                    span,
                    "a vector built from separate components",
                    "the combiners compute rgb as a whole: only `rgba(c, a)` of an rgb and a scalar maps (rgb portion and alpha portion)",
                )),
            },
            Expr::Math { fun: fun @ (MathFunction::Expand | MathFunction::HalfBias), ref args } => {
                self.mapped_src(h, fun, args[0], part, sat)
            }
            Expr::Unary { op: UnaryOp::Neg, value } => self.negated_src(h, value, part, sat),
            Expr::Math { fun: MathFunction::Saturate, ref args } => {
                let s = self.src(args[0], part, true)?;
                self.unsigned(s, span)
            }
            Expr::Math { fun: MathFunction::Clamp, ref args }
                if self.constant(args[1]) == Some(0.0) && self.constant(args[2]) == Some(1.0) =>
            {
                let s = self.src(args[0], part, true)?;
                self.unsigned(s, span)
            }
            Expr::Math { fun: MathFunction::Max, ref args }
                if self.constant(args[0]) == Some(0.0) || self.constant(args[1]) == Some(0.0) =>
            {
                let x = if self.constant(args[0]) == Some(0.0) { args[1] } else { args[0] };
                // max(0, x) = max(0, clamp(x, −1, 1)) when x ≤ 1 or the consumer clamps to 1.
                let s = self.src(x, part, sat)?;
                self.unsigned(s, span)
            }
            Expr::Math { fun: MathFunction::Abs, ref args } => self.abs_src(args[0], part, sat, span),
            Expr::Binary { op: BinaryOp::Pow, lhs, rhs } => {
                let k = self.pow2_exponent(rhs).ok_or_else(|| self.pow_error(h))?;
                self.pow_src(lhs, part, k)
            }
            Expr::Binary { op: BinaryOp::Sub, lhs, rhs } if self.constant(lhs) == Some(1.0) => {
                // 1 − x: UNSIGNED_INVERT when x ∈ [0, 1].
                let s = self.src(rhs, part, false)?;
                if self.lo(rhs) >= 0.0 && self.hi(rhs) <= 1.0 && matches!(s.map, UnsignedIdentity | SignedIdentity) {
                    Ok(Src { map: UnsignedInvert, ..s })
                } else {
                    self.materialise(h, part, sat)
                }
            }
            Expr::Binary { op: BinaryOp::Mul | BinaryOp::Add | BinaryOp::Sub | BinaryOp::Dot, .. }
            | Expr::Binary { op: BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge, .. }
            | Expr::Select { reject: Some(_), .. }
            | Expr::Math { fun: MathFunction::Mix | MathFunction::Compress | MathFunction::Step, .. } => {
                self.materialise(h, part, sat)
            }
            // min and max: the mux or a clamp (`extremum_src`).
            Expr::Math { fun, ref args } if self.is_extremum(fun, args) => self.extremum_src(h, fun, args, part, sat),
            other => match self.host_constant(h) {
                // A per-object value the combiners cannot compute
                // (`normalize(Ld)` of a uniform direction): computed once
                // on the host, as GL programs set constant colours.
                Some(c) => self.constant_src(h, &c, part).map_err(|_| self.unsupported_node(h, &other)),
                None => Err(self.unsupported_node(h, &other)),
            },
        }
    }

    /// A `min` or `max` ([`Gen::extremum_spec`]); a `min` by a clamp is read
    /// through its UNSIGNED_INVERT, no stage of its own.
    fn extremum_src(
        &mut self,
        h: Handle<Expr>,
        fun: MathFunction,
        args: &[Handle<Expr>],
        part: Part,
        sat: bool,
    ) -> R<Src> {
        if fun == MathFunction::Min && !self.both_scalar_compared(args) {
            let scalar = self.scalar(h, part);
            if let Some(s) = self.min_by_clamp(args[0], args[1], part, scalar, self.m.span(h))? {
                return Ok(s);
            }
        }
        self.materialise(h, part, sat)
    }

    /// The value of a per-object node (constants and uniforms at their
    /// values, `uniform_src`'s), computed on the host; `None` for a value
    /// per vertex or per sample, or one that is not finite.
    fn host_constant(&self, h: Handle<Expr>) -> Option<Constant> {
        if self.m.info(h).freq > crate::ir::Frequency::Uniform {
            return None;
        }
        let ty = self.ty(h);
        let v = self.host_value(h)?;
        Some(Constant::new(ty, &v[..ty.width().min(4)]))
    }

    fn host_value(&self, h: Handle<Expr>) -> Option<crate::ir::eval::Value> {
        use crate::ir::eval;
        let v = match self.expr(h) {
            Expr::Constant(c) => eval::value(c),
            Expr::Uniform(id) => eval::value(self.m.uniforms[*id as usize].default.as_ref()?),
            e if eval::is_computation(e) => {
                let operands: Option<Vec<_>> = e.operands().iter().map(|&o| self.host_value(o)).collect();
                eval::apply(self.m, e, self.ty(h), &operands?)
            }
            _ => return None,
        };
        v.iter().all(|x| x.is_finite()).then_some(v)
    }

    /// A texel or framebuffer read bound to a texture unit of the pass: its
    /// texture register, read signed where the texel is.
    fn texture_src(&self, h: Handle<Expr>, part: Part, span: Span) -> R<Src> {
        let unit = self.units.iter().position(|u| *u == h).ok_or_else(|| {
            unsupported(
                span,
                "a texture lookup not bound to a texture unit of this pass",
                "list it in the pass's texture units",
            )
        })?;
        if crate::planner::hilo::is_hilo_unit(self.m, self.units, h) {
            return Err(unsupported(
                span,
                "a HILO texel read by the combiners",
                "a HILO map reaches the combiners only through the texture shader's dot products (docs/hilo.md)",
            ));
        }
        let unit = crate::planner::hilo::hardware_unit(self.m, self.units, unit);
        let reg = u8::try_from(unit).ok().and_then(Register::texture).ok_or_else(|| {
            unsupported(
                span,
                "a texture lookup on a fifth texture unit",
                "split the pass: the combiners read four texture registers",
            )
        })?;
        let comp = match (self.ty(h), part) {
            (Ty::Scalar, _) => Comp::Alpha,
            (_, Part::Alpha) => Comp::Alpha,
            _ => Comp::Rgb,
        };
        // A signed texel (a HILO normalization map, seeds/000
        // Section 5.1) reaches the combiners as it is: unsigned
        // identity would clamp its negative components to 0.
        let map = if self.lo(h) < 0.0 { SignedIdentity } else { UnsignedIdentity };
        Ok(Src { base: Base::Reg(reg), comp, map })
    }

    /// A uniform: a constant colour holding its value (its default, or what the caller supplies).
    pub(super) fn uniform_src(&mut self, h: Handle<Expr>, id: crate::ir::UniformId, part: Part) -> R<Src> {
        let u = &self.m.uniforms[id as usize];
        let color = u.default.map(|c| to_color(&c)).unwrap_or([0.0; 4]);
        let comp = match (u.ty, part) {
            (Ty::Scalar, _) | (_, Part::Alpha) => Comp::Alpha,
            _ => Comp::Rgb,
        };
        let k = self.konst(h, color, u.default.is_some(), comp)?;
        Ok(Src { base: Base::K(k), comp, map: UnsignedIdentity })
    }

    /// `δ v` in the primary or secondary colour (Kilgard 2000, Table 2): unsigned,
    /// so a value in [0, 1] (or clamped by its consumer) only.
    pub(super) fn interpolant_src(&mut self, h: Handle<Expr>, part: Part, sat: bool) -> R<Src> {
        let span = self.m.span(h);
        let info = self.m.info(h);
        if info.interval.hi > 1.0
            && info.interval.lo >= 0.0
            && matches!(info.ty, Ty::Rgb | Ty::Rgba | Ty::Scalar)
            && !sat
        {
            // GL clamps vertex colours to [0, 1]: exact only where the consumer clamps too.
            return Err(self.range(h));
        }
        // A vector range-compressed into [0, 1] (Kilgard's `L·0.5 + 0.5`
        // per vertex, seeds/003 Section 5) is three colour channels too.
        let colour = matches!(info.ty, Ty::Rgb | Ty::Rgba | Ty::Scalar)
            || (info.ty == Ty::Vec3 && info.interval.hi <= 1.0);
        if !colour || info.interval.lo < 0.0 {
            return Err(unsupported(
                span,
                format!("an interpolated {} outside [0, 1]", info.ty.name()),
                "the primary and secondary colours are unsigned (Kilgard 2000, Table 2): interpolate a direction as texture coordinates into a normalization cube map and `expand` the lookup (Section 5.2)",
            ));
        }
        let reg = match self.colors.iter().position(|c| *c == Some(h)) {
            Some(0) => Register::Primary,
            Some(_) => Register::Secondary,
            None => match self.colors.iter().position(Option::is_none) {
                Some(0) => {
                    self.colors[0] = Some(h);
                    Register::Primary
                }
                Some(_) => {
                    self.colors[1] = Some(h);
                    Register::Secondary
                }
                None => return Err(CodegenError::OutOfColors { span }),
            },
        };
        let comp = match (info.ty, part) {
            (Ty::Scalar, _) | (_, Part::Alpha) => Comp::Alpha,
            _ => Comp::Rgb,
        };
        Ok(Src { base: Base::Reg(reg), comp, map: UnsignedIdentity })
    }

    /// A component selection: rgb, alpha, or blue (Kilgard 2000, B.4); red or
    /// green of an rgb as the dot product with a unit constant colour,
    /// `v · (1, 0, 0)`, which a stage smears over rgb (Section 4.2.2) — a
    /// stage and a constant register for a selection the inputs cannot make.
    pub(super) fn swizzle_src(
        &mut self,
        h: Handle<Expr>,
        value: Handle<Expr>,
        pattern: &[u8; 4],
        len: u8,
        sat: bool,
        span: Span,
    ) -> R<Src> {
        let p = &pattern[..len as usize];
        let vty = self.ty(value);
        if p == [0, 1, 2] {
            self.src(value, Part::Rgb, sat)
        } else if p == [3] && vty == Ty::Rgba {
            self.src(value, Part::Alpha, sat)
        } else if p == [2] && vty.width() >= 3 {
            let s = self.src(value, Part::Rgb, sat)?;
            Ok(match s.comp {
                Comp::Rgb => Src { comp: Comp::Blue, ..s },
                _ => s,
            })
        } else if matches!(p, [0] | [1]) && vty.width() >= 3 {
            let v = self.src(value, Part::Rgb, sat)?;
            let mut unit = [0.0f32; 4];
            unit[p[0] as usize] = 1.0;
            let konst = self.konst(h, unit, true, Comp::Rgb)?;
            let unit = Src { base: Base::K(konst), comp: Comp::Rgb, map: UnsignedIdentity };
            self.emit(Spec::single(Term { a: v, b: unit, dot: true }, true), span)
        } else if len == 3 && p.iter().all(|c| *c < 3) && vty.width() >= 3 {
            self.permutation_src(h, value, p, sat, span)
        } else {
            Err(unsupported(
                span,
                "this component selection",
                "the combiners read a register's rgb, its alpha, or (in an alpha portion) its blue (Kilgard 2000, B.4), red or green alone of an rgb by a dot product with a unit colour, and three components of an rgb in another order (`.bgr`) by such dot products summed: use `.rgb`, `.a`, `.r`, `.g`, `.b` or a permutation of `rgb`, or a lookup texture that stores the component in alpha",
            ))
        }
    }

    /// Three components of an rgb in another order (`.bgr`, `.grb`, `.rrg`):
    /// each component that moves read as the dot product with its unit
    /// colour, which a stage smears over rgb (Kilgard 2000, Section
    /// 4.2.2), masked by the unit colours of the places it goes; the
    /// components that stay masked in place (`v · (0, 1, 0)`); the terms
    /// summed two to a stage (`AB + CD`). `.bgr` is `v·(0, 1, 0) +
    /// (v · e_b)·(1, 0, 0) + (v · e_r)·(0, 0, 1)`: three stages and three
    /// constant colours, which a target without per-stage constants (two in
    /// all, B.3) does not have.
    fn permutation_src(
        &mut self,
        h: Handle<Expr>,
        value: Handle<Expr>,
        p: &[u8],
        sat: bool,
        span: Span,
    ) -> R<Src> {
        let v = self.src(value, Part::Rgb, sat)?;
        let mask = |places: &[usize]| {
            let mut m = [0.0f32; 4];
            for &j in places {
                m[j] = 1.0;
            }
            m
        };
        let mut terms: Vec<Term> = Vec::new();
        let mut stay: Vec<usize> = Vec::new();
        for c in 0..3usize {
            let places: Vec<usize> = (0..3).filter(|&j| p[j] as usize == c).collect();
            if places.is_empty() {
                continue;
            }
            if places == [c] {
                stay.push(c);
                continue;
            }
            let unit = self.konst(h, mask(&[c]), true, Comp::Rgb)?;
            let unit = Src { base: Base::K(unit), comp: Comp::Rgb, map: UnsignedIdentity };
            let smeared = self.emit(Spec::single(Term { a: v, b: unit, dot: true }, true), span)?;
            let to = self.konst(h, mask(&places), true, Comp::Rgb)?;
            let to = Src { base: Base::K(to), comp: Comp::Rgb, map: UnsignedIdentity };
            terms.push(Term { a: smeared, b: to, dot: false });
        }
        if !stay.is_empty() {
            let kept = self.konst(h, mask(&stay), true, Comp::Rgb)?;
            let kept = Src { base: Base::K(kept), comp: Comp::Rgb, map: UnsignedIdentity };
            terms.insert(0, Term { a: v, b: kept, dot: false });
        }
        let mut terms = terms.into_iter();
        let Some(first) = terms.next() else { return self.src(value, Part::Rgb, sat) };
        let mut sum = self.emit(Spec { cd: terms.next(), ..Spec::single(first, false) }, span)?;
        for t in terms {
            sum = self.emit(Spec { cd: Some(t), ..Spec::single(Term::times_one(sum), false) }, span)?;
        }
        Ok(sum)
    }

    /// `rgb → rgba` (alpha one) or a splat: the value as the part reads it.
    pub(super) fn convert_src(
        &mut self,
        value: Handle<Expr>,
        to: Ty,
        part: Part,
        sat: bool,
        span: Span,
    ) -> R<Src> {
        let vty = self.ty(value);
        if vty == Ty::Rgb && to == Ty::Rgba {
            if part == Part::Alpha {
                Ok(Src::ONE)
            } else {
                self.src(value, Part::Rgb, sat)
            }
        } else if vty == Ty::Scalar || vty == to {
            self.src(value, Part::Rgb, sat)
        } else {
            Err(unsupported(span, format!("a conversion from {} to {}", vty.name(), to.name()), LOOKUP_HELP))
        }
    }

    /// `expand(x)` or `half_bias(x)` as an input mapping of x's source
    /// (Kilgard 2000, Table 3), else computed in a stage.
    pub(super) fn mapped_src(
        &mut self,
        h: Handle<Expr>,
        fun: MathFunction,
        arg: Handle<Expr>,
        part: Part,
        sat: bool,
    ) -> R<Src> {
        // A sum past [−1, 1] (`half_bias(t + f)`, GL's `add_signed`) is no
        // register to map: the stage computing it applies the bias itself
        // (`mapped_spec`), and a saturating consumer clamps what leaves.
        if !self.in_unit(arg)
            && matches!(self.expr(arg), Expr::Binary { op: BinaryOp::Add | BinaryOp::Sub, .. })
        {
            return self.materialise(h, part, sat);
        }
        let s = self.src(arg, part, false)?;
        let map = match (fun, s.map) {
            (MathFunction::Expand, UnsignedIdentity) => Some(ExpandNormal),
            (MathFunction::Expand, UnsignedInvert) => Some(ExpandNegate),
            (MathFunction::HalfBias, UnsignedIdentity) => Some(HalfBiasNormal),
            (MathFunction::HalfBias, UnsignedInvert) => Some(HalfBiasNegate),
            (_, SignedIdentity) if self.lo(arg) >= 0.0 => {
                Some(if fun == MathFunction::Expand { ExpandNormal } else { HalfBiasNormal })
            }
            _ => None,
        };
        match map {
            Some(map) => Ok(Src { map, ..s }),
            None => self.materialise(h, part, sat),
        }
    }

    /// `−x` as a negating input mapping, else computed in a stage.
    pub(super) fn negated_src(
        &mut self,
        h: Handle<Expr>,
        value: Handle<Expr>,
        part: Part,
        sat: bool,
    ) -> R<Src> {
        let s = self.src(value, part, false)?;
        let map = match s.map {
            UnsignedIdentity if self.lo(value) >= 0.0 => Some(SignedNegate),
            m => negated(m),
        };
        match map {
            Some(map) => Ok(Src { map, ..s }),
            None => self.materialise(h, part, sat),
        }
    }

    /// `abs(x)` as `max(0, x) + max(0, −x)`: two unsigned mappings summed in
    /// one stage (Kilgard 2000, Section 4.2.1, Table 3). No input mapping
    /// negates and clamps at once, so `−x` is copied to a register first
    /// when its mapping has no negated twin. Registers hold [−1, 1], so `x`
    /// must stay there unless the consumer clamps to 1 anyway (`sat`), as
    /// for `max(0, x)`.
    fn abs_src(&mut self, x: Handle<Expr>, part: Part, sat: bool, span: Span) -> R<Src> {
        let (positive, negative, scalar) = self.abs_halves(x, part, sat, span)?;
        let spec =
            Spec { cd: Some(Term::times_one(negative)), ..Spec::single(Term::times_one(positive), scalar) };
        self.emit(spec, span)
    }

    /// `abs(x)` as the sources of its two halves, `max(0, x)` and
    /// `max(0, −x)` (UNSIGNED_IDENTITY of `x` and of its negation, Kilgard
    /// 2000, Table 3), whose sum it is; and whether `x` is a scalar.
    pub(super) fn abs_halves(
        &mut self,
        x: Handle<Expr>,
        part: Part,
        sat: bool,
        span: Span,
    ) -> R<(Src, Src, bool)> {
        if !sat && (self.lo(x) < -1.0 || self.hi(x) > 1.0) {
            return Err(unsupported(
                span,
                "`abs` of a value that leaves [−1, 1]",
                "the combiners' registers hold [−1, 1]: scale the argument into it, or compute `abs` on a target with float arithmetic (wgsl)",
            ));
        }
        let s = self.src(x, part, false)?;
        let scalar = s.comp != Comp::Rgb;
        let negative = match negated(s.map) {
            Some(map) => self.copy(Src { map, ..s }, span)?,
            None => {
                let v = self.copy(s, span)?;
                let negate = negated(v.map).ok_or_else(|| {
                    unsupported(
                        span,
                        "`abs` of this value",
                        "please report this: its copy has no negated mapping",
                    )
                })?;
                self.copy(Src { map: negate, ..v }, span)?
            }
        };
        Ok((self.unsigned(s, span)?, self.unsigned(negative, span)?, scalar))
    }

    pub(super) fn unsupported_node(&self, h: Handle<Expr>, e: &Expr) -> CodegenError {
        let span = self.m.span(h);
        match e {
            Expr::Binary { op: BinaryOp::Div, .. } => unsupported(span, "a division", format!("there is no divider in the combiners; {LOOKUP_HELP}")),
            Expr::Binary { op: BinaryOp::Pow, .. } => self.pow_error(h),
            Expr::Math { fun: MathFunction::Normalize, .. } => unsupported(
                span,
                "`normalize`",
                "normalize per fragment with a normalization cube map: look the interpolated vector up in `normalize_cube(n)` and `expand` the texel (Kilgard 2000, Section 5.2, Appendix D)",
            ),
            Expr::Math { fun, .. } => unsupported(span, format!("`{}`", fun.name()), LOOKUP_HELP),
            Expr::Select { reject: None, .. } => unsupported(
                span,
                "a selection that keeps the destination",
                "keeping the destination is a framebuffer test (alpha or stencil test), not a combiner operation",
            ),
            Expr::Binary { op, .. } => unsupported(span, format!("the operation {op:?}"), LOOKUP_HELP),
            Expr::FramebufferRead { .. } => unsupported(
                span,
                "a framebuffer read",
                "the combiners cannot read the framebuffer: blend with it (⊕) after the pass, or copy it to a texture",
            ),
            _ => unsupported(span, "this value", "only texels, interpolated colours and constants reach the combiners (Kilgard 2000, Table 2)"),
        }
    }

    /// Whether `h` reads a framebuffer's depth channel.
    pub(super) fn reads_depth(&self, h: Handle<Expr>) -> bool {
        self.m
            .reachable(&[h])
            .into_iter()
            .any(|x| matches!(self.m.exprs[x], Expr::FramebufferRead { channel: FbChannel::Depth, .. }))
    }

    pub(super) fn pow_error(&self, h: Handle<Expr>) -> CodegenError {
        unsupported(
            self.m.span(h),
            "a power with an exponent that is not a constant power of two",
            format!("the combiners square by multiplying a value with itself, so x^2, x^4, x^8, … map (Kilgard 2000, Appendix H); {LOOKUP_HELP}"),
        )
    }

    pub(super) fn pow2_exponent(&self, h: Handle<Expr>) -> Option<u32> {
        let n = self.constant(h)?;
        ((2.0..=256.0).contains(&n) && n.fract() == 0.0 && (n as u32).is_power_of_two())
            .then(|| (n as u32).trailing_zeros())
    }

    /// `x^(2^k)` by repeated squaring in general combiners.
    pub(super) fn pow_src(&mut self, x: Handle<Expr>, part: Part, k: u32) -> R<Src> {
        if k == 0 {
            return self.src(x, part, false);
        }
        let part = self.norm(x, part);
        if let Some(s) = self.pow_cache.get(&(x, part, k)) {
            return Ok(*s);
        }
        let p = self.pow_src(x, part, k - 1)?;
        let scalar = self.ty(x) == Ty::Scalar || part == Part::Alpha;
        let mut spec = Spec::single(Term { a: p, b: p, dot: false }, scalar);
        spec.alpha_only = part == Part::Alpha;
        let s = self.emit(spec, self.m.span(x))?;
        self.pow_cache.insert((x, part, k), s);
        Ok(s)
    }

    /// A source whose value is max(0, s), readable with an unsigned mapping.
    pub(super) fn unsigned(&mut self, s: Src, span: Span) -> R<Src> {
        match s.map {
            UnsignedIdentity | UnsignedInvert => Ok(s),
            SignedIdentity => Ok(Src { map: UnsignedIdentity, ..s }),
            _ => {
                let v = self.copy(s, span)?;
                Ok(Src { map: UnsignedIdentity, ..v })
            }
        }
    }

    /// A constant with components of both signs, each in [−1, 1] (a light
    /// direction given as a constant): stored range-compressed, (v + 1)/2,
    /// and read through the EXPAND_NORMAL input mapping, as Kilgard stores
    /// signed vectors in unsigned colours (Kilgard 2000, Section 5.2, Table
    /// 3). The register's 8 bits put each component within 1/255.
    fn expanded_constant(&mut self, h: Handle<Expr>, values: &[f64], ty: Ty, part: Part) -> R<Src> {
        let mut color = [0.5f32; 4];
        for (slot, v) in color.iter_mut().zip(values) {
            *slot = ((v + 1.0) / 2.0) as f32;
        }
        if ty == Ty::Rgba && part == Part::Alpha {
            color[3] = color[0];
        }
        let comp = if values.len() == 1 || part == Part::Alpha { Comp::Alpha } else { Comp::Rgb };
        let k = self.konst(h, color, true, comp)?;
        Ok(Src { base: Base::K(k), comp, map: ExpandNormal })
    }

    /// Copies a mapped source into a virtual register (`dest = s * one`).
    pub(super) fn copy(&mut self, s: Src, span: Span) -> R<Src> {
        let scalar = s.comp != Comp::Rgb;
        self.emit(Spec::single(Term::times_one(s), scalar), span)
    }

    pub(super) fn constant_src(&mut self, h: Handle<Expr>, c: &Constant, part: Part) -> R<Src> {
        let span = self.m.span(h);
        let values: Vec<f64> = match (c.ty, part) {
            (Ty::Rgba, Part::Alpha) => vec![c.components[3]],
            (Ty::Rgba, Part::Rgb) => c.components[..3].to_vec(),
            _ => c.values().to_vec(),
        };
        if values.iter().all(|v| *v == values[0]) {
            let special = match values[0] {
                0.0 => Some(Src::ZERO),
                1.0 => Some(Src::ONE),
                0.5 => Some(Src::zero_mapped(HalfBiasNegate)),
                -0.5 => Some(Src::zero_mapped(HalfBiasNormal)),
                -1.0 => Some(Src::zero_mapped(ExpandNormal)),
                _ => None,
            };
            if let Some(s) = special {
                return Ok(s);
            }
        }
        let (negate, mags): (bool, Vec<f64>) = if values.iter().all(|v| *v <= 0.0) {
            (true, values.iter().map(|v| -v).collect())
        } else if values.iter().all(|v| *v >= 0.0) {
            (false, values.clone())
        } else if values.iter().all(|v| v.abs() <= 1.0) {
            return self.expanded_constant(h, &values, c.ty, part);
        } else {
            return Err(unsupported(span, "a constant with components of both signs outside [−1, 1]", "constant colours are unsigned (Kilgard 2000, Table 2): rescale it into [−1, 1], which is stored as (v + 1)/2 and read through `expand`"));
        };
        if mags.iter().any(|v| *v > 1.0) {
            return Err(unsupported(
                span,
                "a constant outside [−1, 1]",
                "constant colours hold [0, 1]; a constant up to 8 that multiplies the rest of a product becomes an output scale (`kd * 2 * x`); elsewhere, rescale it into [0, 1]",
            ));
        }
        let mut color = [0.0f32; 4];
        let scalar_like = mags.len() == 1;
        for (i, slot) in color.iter_mut().enumerate() {
            let v = if scalar_like {
                mags[0]
            } else if c.ty == Ty::Rgba {
                c.components[i].abs()
            } else {
                mags.get(i).copied().unwrap_or(0.0)
            };
            *slot = v as f32;
        }
        let comp = if scalar_like || part == Part::Alpha { Comp::Alpha } else { Comp::Rgb };
        let k = self.konst(h, color, true, comp)?;
        Ok(Src { base: Base::K(k), comp, map: if negate { SignedNegate } else { UnsignedIdentity } })
    }
}
