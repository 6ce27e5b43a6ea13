//! Arithmetic nodes: constants, uniforms, unary and binary operators,
//! powers, the math functions, swizzles, construction, conversion,
//! selection and the per-sample `⊕` (Pipeline Grammar, Section 3.6), each
//! IR node turned into naga expressions of the matching width.

use super::*;

impl Gen<'_> {
    /// `v` (width `from`) as width `to`: a scalar splats.
    pub(super) fn splat(&mut self, b: &mut Body, v: NH, from: usize, to: usize) -> R<NH> {
        if from == to {
            Ok(v)
        } else if from == 1 {
            Ok(b.emit(Expression::Splat { size: size(to), value: v }))
        } else {
            Err(GenError::Internal(format!("cannot widen a {from}-vector to {to}")))
        }
    }

    /// The first `to` components of `v`.
    pub(super) fn narrow(&mut self, b: &mut Body, v: NH, from: usize, to: usize) -> NH {
        if from == to {
            v
        } else if to == 1 {
            b.emit(Expression::AccessIndex { base: v, index: 0 })
        } else {
            b.emit(Expression::Swizzle { size: size(to), vector: v, pattern: COMP })
        }
    }

    /// `v` (width `w`) padded with zeros to a vec4.
    pub(super) fn widen_zero(&mut self, b: &mut Body, v: NH, w: usize) -> NH {
        if w == 4 {
            return v;
        }
        let vec4 = self.vec_ty(4);
        let mut comps = vec![v];
        for _ in w..4 {
            let z = b.lit(0.0);
            comps.push(z);
        }
        b.emit(Expression::Compose { ty: vec4, components: comps })
    }

    /// A constant; a `register` value (hardware precision, per fragment, not
    /// only an address, within ±1) is quantized as a constant register
    /// holds it. Constants beyond ±1 are scale factors (the combiners' ×2,
    /// ×4, repeated) and stay exact, as do texture addresses.
    pub(super) fn constant(&mut self, b: &mut Body, c: &ir::Constant, q: bool) -> NH {
        let w = width(c.ty);
        let vals: Vec<f32> = c.values().iter().map(|v| if q { q9_value(*v) } else { *v as f32 }).collect();
        if w == 1 || vals.iter().all(|v| v.to_bits() == vals[0].to_bits()) {
            let l = b.lit(vals[0]);
            return if w == 1 { l } else { b.emit(Expression::Splat { size: size(w), value: l }) };
        }
        let ty = self.vec_ty(w);
        let comps: Vec<NH> = vals.iter().map(|v| b.lit(*v)).collect();
        b.emit(Expression::Compose { ty, components: comps })
    }
}

impl Gen<'_> {
    /// `normalize(x)` is undefined in WGSL for x = 0 (NaN on lavapipe); the
    /// IR defines it as the zero vector (`ir::eval`, docs/numerics.md:
    /// the half vector of L = −V, a zero-length interpolated normal), so
    /// the shader selects 0 where `dot(x, x)` is 0.
    pub(super) fn zero_if_no_direction(&mut self, b: &mut Body, x: NH, unit: NH, w: usize) -> NH {
        let len2 = self.math(b, naga::MathFunction::Dot, &[x, x]);
        let zero = b.lit(0.0);
        let has_direction = self.binop(b, naga::BinaryOperator::Greater, len2, zero);
        let ty = self.vec_ty(w);
        let zero_vector = b.plain(Expression::ZeroValue(ty));
        b.emit(Expression::Select { condition: has_direction, accept: unit, reject: zero_vector })
    }

    pub(super) fn binop(&mut self, b: &mut Body, op: naga::BinaryOperator, l: NH, r: NH) -> NH {
        b.emit(Expression::Binary { op, left: l, right: r })
    }

    pub(super) fn math(&mut self, b: &mut Body, fun: naga::MathFunction, args: &[NH]) -> NH {
        b.emit(Expression::Math {
            fun,
            arg: args[0],
            arg1: args.get(1).copied(),
            arg2: args.get(2).copied(),
            arg3: None,
        })
    }

    /// A float from a boolean: 1.0 or 0.0.
    pub(super) fn bool_to_float(&mut self, b: &mut Body, c: NH) -> NH {
        let one = b.lit(1.0);
        let zero = b.lit(0.0);
        let v = b.emit(Expression::Select { condition: c, accept: one, reject: zero });
        b.bools.insert(v, c);
        v
    }

    pub(super) fn truthy(&mut self, b: &mut Body, v: NH) -> NH {
        if let Some(c) = b.bools.get(&v) {
            return *c;
        }
        let zero = b.lit(0.0);
        b.emit(Expression::Binary { op: naga::BinaryOperator::NotEqual, left: v, right: zero })
    }

    /// The alpha of a colour operand (1 for rgb, itself for a scalar).
    pub(super) fn alpha_of(&mut self, b: &mut Body, v: NH, ty: Ty) -> NH {
        match ty {
            Ty::Rgba | Ty::Position => b.emit(Expression::AccessIndex { base: v, index: 3 }),
            Ty::Scalar => v,
            _ => b.lit(1.0),
        }
    }

    /// The colour channels of an operand as width `w` (≤ 3).
    pub(super) fn color_of(&mut self, b: &mut Body, v: NH, ty: Ty, w: usize) -> R<NH> {
        let vw = width(ty);
        if vw == 1 {
            return self.splat(b, v, 1, w);
        }
        Ok(self.narrow(b, v, vw, w.min(vw)))
    }

    /// Computes node `n` in `b` (its operands are done), records it.
    pub(super) fn node(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<()> {
        if b.vals.contains_key(&n) || b.fat.contains_key(&n) {
            return Ok(());
        }
        let Some(Computed { value, arith }) = self.compute(b, n)? else {
            return Ok(());
        };
        b.vals.insert(n, value);
        self.finish(b, n, value, self.width_of(n), arith)
    }

    /// The value of node `n`, by kind of expression; `None` for a node read
    /// only through others (a fat lookup, an unused pixel, a bundle).
    pub(super) fn compute(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<Option<Computed>> {
        let m = self.m;
        let computed = match &m.exprs[n] {
            Expr::Constant(c) => self.constant_node(b, n, c),
            Expr::Uniform(u) => Computed::plain(self.uniform_value(b, n, *u)?),
            Expr::VertexPosition(_) | Expr::TexCoord { .. } | Expr::Vector { .. } => {
                Computed::plain(self.vertex_input(b, n)?)
            }
            Expr::TexelCoord => match b.texel_uv {
                Some(uv) => Computed::plain(uv),
                None => return self.unsupported("the texel coordinate δu outside a texel pass", Some(n)),
            },
            Expr::Pixel { .. } => return Ok(self.pixel_value(b, n)?.map(Computed::plain)),
            Expr::Project { projection, value } => Computed::plain(self.project(b, n, projection, *value)?),
            Expr::Interpolate { .. } => {
                return Err(GenError::Internal(format!(
                    "δ node %{} is not a varying of this pass",
                    n.index()
                )));
            }
            Expr::Lookup { texture, coords } => return self.lookup(b, n, *texture, *coords),
            Expr::FramebufferRead { framebuffer, channel, position } => {
                Computed::plain(self.framebuffer_read(b, n, *framebuffer, *channel, *position)?)
            }
            Expr::Depth(p) => Computed::plain(self.depth(b, *p)?),
            Expr::FatMember { texel, member } => Computed::plain(self.fat_member(b, n, *texel, *member)?),
            // Written by the fragment stage as one output per member (`fragment`).
            Expr::Bundle(_) => return Ok(None),
            Expr::Unary { op, value } => self.unary(b, *op, *value)?,
            Expr::Binary { op, lhs, rhs } => self.binary(b, n, *op, *lhs, *rhs)?,
            Expr::Combine { mode, lhs, rhs } => {
                let (x, y) = (b.val(*lhs)?, b.val(*rhs)?);
                let (tx, ty) = (m.info(*lhs).ty, m.info(*rhs).ty);
                // An rgb texture widened to rgba is still an RGB texture
                // to GL's `replace` (Table 3.22: the fragment's alpha
                // kept), as `ir::eval::combine` and the reference read it.
                let widened = match &m.exprs[*lhs] {
                    Expr::Convert { value, to: Ty::Rgba } => m.info(*value).ty == Ty::Rgb,
                    _ => false,
                };
                Computed::arith(self.combine(b, *mode, (x, tx, widened), y, ty, m.info(n).ty)?)
            }
            Expr::Math { fun, args } => self.math_call(b, n, *fun, args)?,
            Expr::Swizzle { value, pattern, len, .. } => self.swizzle(b, *value, pattern, *len)?,
            Expr::Compose { components, .. } => self.compose(b, n, components)?,
            Expr::Convert { value, to } => self.convert(b, n, *value, *to)?,
            Expr::Select { cond, accept, reject } => self.select(b, n, *cond, *accept, *reject)?,
        };
        Ok(Some(computed))
    }

    /// The shader width of node `h` (1..=4).
    pub(super) fn width_of(&self, h: ir::Handle<Expr>) -> usize {
        width(self.m.info(h).ty)
    }

    /// A constant. In hardware precision one of magnitude ≤ 1 read per sample
    /// sits in a register: it is rounded, and so on the grid.
    pub(super) fn constant_node(&mut self, b: &mut Body, n: ir::Handle<Expr>, c: &ir::Constant) -> Computed {
        let register = self.precision == Precision::Fixed9
            && b.per_sample()
            && !self.addresses_only(n)
            && c.values().iter().all(|v| v.abs() <= 1.0);
        if register {
            self.on_grid.insert(n);
        }
        Computed::plain(self.constant(b, c, register))
    }

    /// Uniform `u`, loaded from the uniform block (after the projections).
    pub(super) fn uniform_value(&mut self, b: &mut Body, n: ir::Handle<Expr>, u: ir::UniformId) -> R<NH> {
        let Some(var) = self.uniforms_var else {
            return Err(GenError::Internal("uniform without a block".into()));
        };
        let idx = self
            .iface
            .uniforms
            .iter()
            .position(|x| *x == u)
            .ok_or_else(|| GenError::Internal("uniform not in the interface".into()))?;
        let l = b.load_member(var, (self.iface.projections.len() + idx) as u32);
        // As the CPU's fixed9 reads a uniform: as given (what is
        // computed from it is folded, `finish`).
        let w = self.width_of(n);
        Ok(self.narrow(b, l, 4, w))
    }
}

impl Gen<'_> {
    /// `−x` (arithmetic) or `!x` (1 where x is 0).
    pub(super) fn unary(&mut self, b: &mut Body, op: UnaryOp, value: ir::Handle<Expr>) -> R<Computed> {
        let x = b.val(value)?;
        Ok(match op {
            UnaryOp::Neg => {
                Computed::arith(b.emit(Expression::Unary { op: naga::UnaryOperator::Negate, expr: x }))
            }
            UnaryOp::Not => {
                let zero = b.lit(0.0);
                let c = self.binop(b, naga::BinaryOperator::Equal, x, zero);
                Computed::plain(self.bool_to_float(b, c))
            }
        })
    }

    /// A binary operator: arithmetic (a hardware register quotient included),
    /// dot, power, or a comparison or logic as 1 or 0.
    pub(super) fn binary(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        op: BinaryOp,
        lhs: ir::Handle<Expr>,
        rhs: ir::Handle<Expr>,
    ) -> R<Computed> {
        use naga::BinaryOperator as B;
        let (x, y) = (b.val(lhs)?, b.val(rhs)?);
        let (wx, wy) = (self.width_of(lhs), self.width_of(rhs));
        let w = self.width_of(n);
        Ok(match op {
            BinaryOp::Div if self.register_write(n, b.per_sample()) => {
                let x = self.splat(b, x, wx, w)?;
                let y = self.splat(b, y, wy, w)?;
                self.on_grid.insert(n);
                Computed::plain(self.quotient(b, x, y, w))
            }
            BinaryOp::Add | BinaryOp::Sub | BinaryOp::Mul | BinaryOp::Div => {
                let x = self.splat(b, x, wx, w)?;
                let y = self.splat(b, y, wy, w)?;
                let o = match op {
                    BinaryOp::Add => B::Add,
                    BinaryOp::Sub => B::Subtract,
                    BinaryOp::Mul => B::Multiply,
                    _ => B::Divide,
                };
                Computed::arith(self.binop(b, o, x, y))
            }
            BinaryOp::Dot => Computed::arith(if wx == 1 {
                self.binop(b, B::Multiply, x, y)
            } else {
                self.math(b, naga::MathFunction::Dot, &[x, y])
            }),
            BinaryOp::Pow => self.power(b, n, x, y, wy)?,
            BinaryOp::Lt
            | BinaryOp::Le
            | BinaryOp::Gt
            | BinaryOp::Ge
            | BinaryOp::Eq
            | BinaryOp::Ne
            | BinaryOp::And
            | BinaryOp::Or => Computed::plain(self.predicate(b, op, x, y)),
        })
    }

    /// `x^y`. In hardware precision a constant integer power is repeated
    /// squaring, a register write after each product (`x^1` is x, written
    /// once).
    pub(super) fn power(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        x: NH,
        y: NH,
        wy: usize,
    ) -> R<Computed> {
        let w = self.width_of(n);
        let sample = b.per_sample();
        let squarings = ir::squaring_exponent(self.m, n).filter(|_| self.register_write(n, sample));
        match squarings {
            Some(k) => {
                let value = ir::power_by_squaring(x, k, |a, c| {
                    let p = self.binop(b, naga::BinaryOperator::Multiply, a, c);
                    self.quantize(b, p, w)
                });
                Ok(Computed { value, arith: k == 1 })
            }
            None => {
                let y = self.splat(b, y, wy, w)?;
                Ok(Computed::arith(self.signed_pow(b, n, x, y, w)))
            }
        }
    }

    /// `pow(x, y)`, for a negative `x` too where `y` is a constant integer:
    /// WGSL's `pow` is `exp2(y·log2(x))`, undefined (NaN) for x < 0, where
    /// the IR's `powf` gives ±|x|^y. So an integer power is taken of `|x|`
    /// and negated where x < 0 and y is odd (the same bits as `pow(x, y)`
    /// for x ≥ 0), unless the base's range (`ir::valid`) is non-negative. Found on the silhouette's baked table, whose last texel
    /// took `(1 − 1.0000001)^6`: NaN, then −1 after lavapipe's clamp.
    fn signed_pow(&mut self, b: &mut Body, n: ir::Handle<Expr>, x: NH, y: NH, w: usize) -> NH {
        let Expr::Binary { lhs, rhs, .. } = self.m.exprs[n] else {
            return self.math(b, naga::MathFunction::Pow, &[x, y]);
        };
        // A base that cannot be negative (`max(0, N·H)^16`) needs nothing.
        let integers = self.m.info(lhs).interval.lo < 0.0
            && match &self.m.exprs[rhs] {
                Expr::Constant(c) => c.values().iter().all(|k| k.fract() == 0.0 && k.abs() < 16_777_216.0),
                _ => false,
            };
        if !integers {
            return self.math(b, naga::MathFunction::Pow, &[x, y]);
        }
        let odd: Vec<bool> = match &self.m.exprs[rhs] {
            Expr::Constant(c) => c.values().iter().map(|k| k.rem_euclid(2.0) == 1.0).collect(),
            _ => vec![],
        };
        let magnitude = self.math(b, naga::MathFunction::Abs, &[x]);
        let p = self.math(b, naga::MathFunction::Pow, &[magnitude, y]);
        if !odd.iter().any(|o| *o) {
            return p;
        }
        if !odd.iter().all(|o| *o) {
            // Mixed parities per component: `pow` as written.
            return self.math(b, naga::MathFunction::Pow, &[x, y]);
        }
        let zero = b.lit(0.0);
        let zero = self.splat(b, zero, 1, w).unwrap_or(zero);
        let negative = self.binop(b, naga::BinaryOperator::Less, x, zero);
        let minus = b.emit(Expression::Unary { op: naga::UnaryOperator::Negate, expr: p });
        b.emit(Expression::Select { condition: negative, accept: minus, reject: p })
    }

    /// A comparison or logic operator, as 1.0 or 0.0.
    pub(super) fn predicate(&mut self, b: &mut Body, op: BinaryOp, x: NH, y: NH) -> NH {
        use naga::BinaryOperator as B;
        let c = match op {
            BinaryOp::And | BinaryOp::Or => {
                let (cx, cy) = (self.truthy(b, x), self.truthy(b, y));
                let o = if op == BinaryOp::And { B::LogicalAnd } else { B::LogicalOr };
                self.binop(b, o, cx, cy)
            }
            _ => {
                let o = match op {
                    BinaryOp::Lt => B::Less,
                    BinaryOp::Le => B::LessEqual,
                    BinaryOp::Gt => B::Greater,
                    BinaryOp::Ge => B::GreaterEqual,
                    BinaryOp::Eq => B::Equal,
                    _ => B::NotEqual,
                };
                self.binop(b, o, x, y)
            }
        };
        self.bool_to_float(b, c)
    }

    /// A math function: naga's builtin (arguments splatted to the result's
    /// width where it takes equal widths), or a range mapping.
    pub(super) fn math_call(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        fun: MathFunction,
        args: &[ir::Handle<Expr>],
    ) -> R<Computed> {
        let arith = !matches!(fun, MathFunction::Step);
        let w = self.width_of(n);
        let xs: Vec<NH> = args.iter().map(|a| b.val(*a)).collect::<R<_>>()?;
        let ws: Vec<usize> = args.iter().map(|a| self.width_of(*a)).collect();
        let Some((f, splat_all)) = naga_math(fun) else {
            let value = self.range_mapping(b, fun, xs[0], w)?;
            return Ok(Computed { value, arith });
        };
        let xs: Vec<NH> = if splat_all {
            let mut out = Vec::new();
            for (x, wx) in xs.iter().zip(&ws) {
                out.push(self.splat(b, *x, *wx, w)?);
            }
            out
        } else {
            xs
        };
        if matches!(fun, MathFunction::Cross | MathFunction::Reflect) && ws.iter().any(|x| *x != 3) {
            return self.unsupported(format!("`{}` of non-3-component values", fun.name()), Some(n));
        }
        let v = self.math(b, f, &xs);
        let value = if fun == MathFunction::Normalize && w > 1 {
            self.zero_if_no_direction(b, xs[0], v, w)
        } else {
            v
        };
        Ok(Computed { value, arith })
    }

    /// `expand` (2x − 1), `half_bias` (x − ½) or `compress` (½(x + 1)) of `x`.
    pub(super) fn range_mapping(&mut self, b: &mut Body, fun: MathFunction, x: NH, w: usize) -> R<NH> {
        use naga::BinaryOperator as B;
        Ok(match fun {
            MathFunction::Expand => self.expand(b, x, w),
            MathFunction::HalfBias => {
                let h = b.lit(0.5);
                let h = self.splat(b, h, 1, w)?;
                self.binop(b, B::Subtract, x, h)
            }
            _ => {
                let one = b.lit(1.0);
                let one = self.splat(b, one, 1, w)?;
                let s = self.binop(b, B::Add, x, one);
                let h = b.lit(0.5);
                self.binop(b, B::Multiply, s, h)
            }
        })
    }

    /// `x.pattern`: a component, a splat of a scalar, or a swizzle (none for
    /// the identity).
    pub(super) fn swizzle(
        &mut self,
        b: &mut Body,
        value: ir::Handle<Expr>,
        pattern: &[u8; 4],
        len: u8,
    ) -> R<Computed> {
        let arith = !self.on_grid.contains(&value);
        let x = b.val(value)?;
        let wx = self.width_of(value);
        let len = len as usize;
        let v = if wx == 1 {
            self.splat(b, x, 1, len)?
        } else if len == 1 {
            b.emit(Expression::AccessIndex { base: x, index: pattern[0] as u32 })
        } else if len <= 4 && pattern[..len].iter().all(|&i| (i as usize) < wx) {
            let mut pat = [SwizzleComponent::X; 4];
            for (p, &i) in pat.iter_mut().zip(&pattern[..len]) {
                *p = COMP[i as usize];
            }
            if len == wx && pattern[..len].iter().enumerate().all(|(k, &i)| k == i as usize) {
                x
            } else {
                b.emit(Expression::Swizzle { size: size(len), vector: x, pattern: pat })
            }
        } else {
            return Err(GenError::Internal("bad swizzle".into()));
        };
        Ok(Computed { value: v, arith })
    }

    /// A vector composed of components (one is itself).
    pub(super) fn compose(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        components: &[ir::Handle<Expr>],
    ) -> R<Computed> {
        let arith = !components.iter().all(|c| self.on_grid.contains(c));
        let xs: Vec<NH> = components.iter().map(|a| b.val(*a)).collect::<R<_>>()?;
        let value = if xs.len() == 1 {
            xs[0]
        } else {
            let ty = self.vec_ty(self.width_of(n));
            b.emit(Expression::Compose { ty, components: xs })
        };
        Ok(Computed { value, arith })
    }

    /// A conversion: same width, a splatted scalar, or rgb to rgba (alpha 1).
    pub(super) fn convert(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        value: ir::Handle<Expr>,
        to: Ty,
    ) -> R<Computed> {
        let arith = !self.on_grid.contains(&value);
        let w = self.width_of(n);
        let x = b.val(value)?;
        let from = self.m.info(value).ty;
        let v = if from == to || width(from) == width(to) {
            x
        } else if width(from) == 1 {
            self.splat(b, x, 1, w)?
        } else if width(from) == 3 && w == 4 {
            let one = b.lit(1.0);
            let vec4 = self.vec_ty(4);
            b.emit(Expression::Compose { ty: vec4, components: vec![x, one] })
        } else {
            return Err(GenError::Internal(format!("conversion {} → {}", from.name(), to.name())));
        };
        Ok(Computed { value: v, arith })
    }

    /// `c ? a : r`, or `c ? a` (per sample: the fragment is discarded where
    /// c fails, so the destination is kept).
    pub(super) fn select(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        cond: ir::Handle<Expr>,
        accept: ir::Handle<Expr>,
        reject: Option<ir::Handle<Expr>>,
    ) -> R<Computed> {
        let arith = !(self.on_grid.contains(&accept) && reject.is_none_or(|r| self.on_grid.contains(&r)));
        let w = self.width_of(n);
        let c = b.val(cond)?;
        let a = b.val(accept)?;
        let a = self.splat(b, a, self.width_of(accept), w)?;
        let v = match reject {
            Some(r) => {
                let rv = b.val(r)?;
                let rv = self.splat(b, rv, self.width_of(r), w)?;
                let t = self.truthy(b, c);
                b.emit(Expression::Select { condition: t, accept: a, reject: rv })
            }
            None if b.per_sample() => {
                // `c ? a`: the destination is kept where c fails.
                self.discard_unless(b, c);
                a
            }
            None => return self.unsupported("`c ? a` without `:` per vertex", Some(n)),
        };
        Ok(Computed { value: v, arith })
    }

    /// Quantizes (hardware precision) and names a computed node.
    pub(super) fn finish(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        v: NH,
        w: usize,
        arith: bool,
    ) -> R<()> {
        // Named before quantization: a call result cannot carry a name.
        // Leaves are named by their arguments.
        let leaf =
            matches!(self.m.exprs[n], Expr::VertexPosition(_) | Expr::TexCoord { .. } | Expr::Vector { .. });
        if let Some(name) = self.value_name(n).filter(|_| !leaf) {
            b.name(v, &name);
        }
        // A register write, as the CPU's per-operation fixed9 model rounds
        // every per-fragment operation but those that only address textures.
        let regroup = matches!(
            self.m.exprs[n],
            Expr::Swizzle { .. } | Expr::Convert { .. } | Expr::Compose { .. } | Expr::Select { .. }
        );
        if regroup && !arith {
            // Rearranges values already on the grid.
            self.on_grid.insert(n);
        }
        let sample = self.m.info(n).freq.is_sample();
        let clamps = self.register_reads.get(n.index()).copied().unwrap_or(true)
            || ir::squaring_exponent(self.m, n).is_some()
            || matches!(self.m.exprs[n], Expr::Binary { op: ir::BinaryOp::Div, .. });
        // A rearrangement of values on the grid needs no rounding, but a
        // register read of one still clamps: its inputs may be sums kept
        // unclamped (the CPU clamps every register read).
        let register = (arith || (regroup && sample && clamps)) && !self.addresses_only(n);
        let v = if register && sample && clamps {
            self.on_grid.insert(n);
            self.quantize(b, v, w)
        } else if register && self.precision == Precision::Fixed9 && b.stage == Stage::Fragment {
            // A sum or scale on its way into a product (rounded, not
            // clamped: `ir::register_reads`), or a uniform subexpression,
            // which the compiler folds into a constant register times an
            // output scale: rounded to 1/255, keeping its magnitude (the
            // CPU's `fixed9_folded`).
            self.on_grid.insert(n);
            self.fold(b, v, w)?
        } else {
            v
        };
        b.vals.insert(n, v);
        Ok(())
    }

    pub(super) fn expand(&mut self, b: &mut Body, x: NH, w: usize) -> NH {
        let two = b.lit(2.0);
        let d = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: x, right: two });
        let one = b.lit(1.0);
        let one = if w == 1 { one } else { b.emit(Expression::Splat { size: size(w), value: one }) };
        b.emit(Expression::Binary { op: naga::BinaryOperator::Subtract, left: d, right: one })
    }
}

impl Gen<'_> {
    /// `⊕[dot3_rgb]` and `⊕[dot3_rgba]` of colours `[ct, cf]` (width `cw`)
    /// and alphas `[at, af]`: `4·((ct − ½)·(cf − ½))` in every colour
    /// component, and in alpha too for `dot3_rgba`.
    fn combine_dot3(
        &mut self,
        b: &mut Body,
        mode: CombineMode,
        [ct, cf]: [NH; 2],
        [at, af]: [NH; 2],
        cw: usize,
    ) -> R<(NH, NH)> {
        use naga::BinaryOperator as B;
        let half = b.lit(0.5);
        let hs = self.splat(b, half, 1, cw)?;
        let a = self.binop(b, B::Subtract, ct, hs);
        let c = self.binop(b, B::Subtract, cf, hs);
        let d = if cw == 1 {
            self.binop(b, B::Multiply, a, c)
        } else {
            self.math(b, naga::MathFunction::Dot, &[a, c])
        };
        let four = b.lit(4.0);
        // Unclamped, as every ⊕ mode (the IR's `combine`): GL's
        // clamp belongs to the hardware models; a saturate here
        // made `0.9 · (T ⊕[dot3] T′)` differ from the CPU and the
        // reference by 25/255 (issue 33).
        let d = self.binop(b, B::Multiply, d, four);
        let rgb = self.splat(b, d, 1, cw)?;
        let alpha = if mode == CombineMode::Dot3Rgba { d } else { self.binop(b, B::Multiply, af, at) };
        Ok((rgb, alpha))
    }

    /// `a ⊕[mode] b` (see the module doc).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn combine(
        &mut self,
        b: &mut Body,
        mode: CombineMode,
        (x, tx, widened): (NH, Ty, bool),
        y: NH,
        ty_y: Ty,
        out: Ty,
    ) -> R<NH> {
        use naga::BinaryOperator as B;
        let w = width(out);
        let wx = width(tx);
        let wy = width(ty_y);
        match mode {
            CombineMode::Modulate | CombineMode::Add | CombineMode::Subtract | CombineMode::AddSigned => {
                let xs = self.splat(b, x, wx, w)?;
                let ys = self.splat(b, y, wy, w)?;
                let op = match mode {
                    CombineMode::Modulate => B::Multiply,
                    CombineMode::Subtract => B::Subtract,
                    _ => B::Add,
                };
                let r = self.binop(b, op, xs, ys);
                if mode == CombineMode::AddSigned {
                    let h = b.lit(0.5);
                    let h = self.splat(b, h, 1, w)?;
                    Ok(self.binop(b, B::Subtract, r, h))
                } else {
                    Ok(r)
                }
            }
            _ => {
                // Colour part (width cw ≤ 3) and alpha, then reassemble.
                let cw = w.min(3);
                let ct = self.color_of(b, x, tx, cw)?;
                let cf = self.color_of(b, y, ty_y, cw)?;
                let at = self.alpha_of(b, x, tx);
                let af = self.alpha_of(b, y, ty_y);
                let one = b.lit(1.0);
                let (rgb, alpha) = match mode {
                    CombineMode::Decal | CombineMode::Interpolate => {
                        let omat = self.binop(b, B::Subtract, one, at);
                        let a = self.binop(b, B::Multiply, cf, omat);
                        let c = self.binop(b, B::Multiply, ct, at);
                        let rgb = self.binop(b, B::Add, a, c);
                        let alpha = if mode == CombineMode::Decal {
                            af
                        } else {
                            let p = self.binop(b, B::Multiply, af, omat);
                            let q = self.binop(b, B::Multiply, at, at);
                            self.binop(b, B::Add, p, q)
                        };
                        (rgb, alpha)
                    }
                    CombineMode::Blend => {
                        let ones = self.splat(b, one, 1, cw)?;
                        let omct = self.binop(b, B::Subtract, ones, ct);
                        let rgb = self.binop(b, B::Multiply, cf, omct);
                        (rgb, self.binop(b, B::Multiply, af, at))
                    }
                    CombineMode::Replace => (ct, if tx == Ty::Rgba && !widened { at } else { af }),
                    CombineMode::Dot3Rgb | CombineMode::Dot3Rgba => {
                        self.combine_dot3(b, mode, [ct, cf], [at, af], cw)?
                    }
                    _ => unreachable!(),
                };
                if w == 4 {
                    let vec4 = self.vec_ty(4);
                    Ok(b.emit(Expression::Compose { ty: vec4, components: vec![rgb, alpha] }))
                } else {
                    Ok(rgb)
                }
            }
        }
    }
}
