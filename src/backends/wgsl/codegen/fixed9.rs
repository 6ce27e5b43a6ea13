//! The fixed9 path: emulating the register combiners' 9-bit arithmetic
//! (Kilgard 2000, Table 2) in WGSL. Register writes are quantized with
//! `q9`, register inputs rounded as the combiners load them, and a fixed9
//! combiner setup runs as the `rc1` translation of its `!!RC1.0` program.
//!
//! Apart because only `Precision::Fixed9` reaches it; float passes never do.

use super::*;

impl Gen<'_> {
    /// `--precision hardware` with a generated setup: the fragment stage
    /// computes, in f32, only what loads the registers — the texels of the
    /// units and the interpolated primary and secondary colours — rounds
    /// each to 8 bits as the machine's inputs are, and calls the setup as
    /// `rc1::combiners_function` writes it (i32 arithmetic, bit-exact with
    /// the emulator), already in the module (`combiners_module`). The result is widened as the CPU renderer's
    /// `fixed9` widens it (a scalar splatted, rgb with alpha 1).
    pub(super) fn fragment_combiners(
        &mut self,
        b: &mut Body,
        g: &crate::backends::combiners::Generated,
    ) -> R<NH> {
        let pass = &self.planned.plan.passes[self.pass_index];
        // A discard the plan routed to the alpha test (planner::alpha_test)
        // is decided on the combiners' alpha, not on the IR condition.
        let alpha_test = Some(pass.state.alpha_test).filter(|t| !t.is_disabled());
        let condition = self.iface.condition.filter(|_| alpha_test.is_none());
        let output = self.planned.handle(pass.fragment.output);
        // A depth texture's unit returns its comparison (ARB_shadow), as the CPU loads it.
        let unit = |h| crate::planner::shadow_map::compare_node(&self.planned.module, output, h).unwrap_or(h);
        // A HILO map's dot-product stages take units of their own (planner::hilo).
        let lookups: Vec<ir::Handle<Expr>> =
            pass.textures.iter().map(|t| self.planned.handle(t.lookup)).collect();
        let mut registers: Vec<Option<ir::Handle<Expr>>> =
            crate::planner::hilo::hardware_units(&self.planned.module, &lookups)
                .into_iter()
                .map(|u| u.map(unit))
                .collect();
        registers.resize(4, None);
        registers.push(g.primary);
        registers.push(g.secondary);
        let unset = [g.config.constant0.is_none(), g.config.constant1.is_none()];
        let constants: Vec<Option<ir::Handle<Expr>>> =
            (0..2).map(|k| g.constants[k].filter(|_| unset[k])).collect();
        let mut roots: Vec<ir::Handle<Expr>> =
            registers.iter().chain(&constants).flatten().copied().collect();
        roots.extend(condition.into_iter().chain(self.iface.depth));
        // The registers' sources in float, unrounded (as the CPU's fixed9 loads them).
        let precision = std::mem::replace(&mut self.precision, Precision::F32);
        self.pass_nodes = self.fragment_nodes(&roots);
        let built: R<()> = self.pass_nodes.clone().into_iter().try_for_each(|n| self.node(b, n));
        self.precision = precision;
        built?;
        if let Some(c) = condition {
            let cv = b.vals[&c];
            self.discard_unless(b, cv);
        }
        let args = self.combiner_arguments(b, &registers, &constants);
        // The setup's function, parsed into the module before the pass was
        // built on it (`combiners_module`).
        let f = self
            .module
            .functions
            .iter()
            .find(|(_, f)| f.name.as_deref() == Some(super::super::rc1::COMBINERS_FUNCTION))
            .map(|(h, _)| h)
            .ok_or_else(|| GenError::Internal("the module has no register-combiner function".into()))?;
        let result = b.plain(Expression::CallResult(f));
        b.f.body.push(
            Statement::Call { function: f, arguments: args, result: Some(result) },
            naga::Span::UNDEFINED,
        );
        b.name(result, "combiners");
        if let Some(t) = alpha_test {
            alpha_test_kill(b, result, t);
        }
        let ty = self.m.info(self.iface.output).ty;
        let vec4 = self.vec_ty(4);
        Ok(match width(ty) {
            1 => {
                let x = b.emit(Expression::AccessIndex { base: result, index: 0 });
                b.emit(Expression::Splat { size: VectorSize::Quad, value: x })
            }
            2 | 3 => {
                let n = width(ty);
                let pattern =
                    [SwizzleComponent::X, SwizzleComponent::Y, SwizzleComponent::Z, SwizzleComponent::W];
                let v = b.emit(Expression::Swizzle { size: size(n), vector: result, pattern });
                let one = b.lit(1.0);
                if n == 3 {
                    b.emit(Expression::Compose { ty: vec4, components: vec![v, one] })
                } else {
                    let zero = b.lit(0.0);
                    b.emit(Expression::Compose { ty: vec4, components: vec![v, zero, one] })
                }
            }
            _ => result,
        })
    }
}

impl Gen<'_> {
    /// The arguments of the setup's function: the registers' values as the
    /// machine loads them (integers 0..255), the unset constants, and fog.
    fn combiner_arguments(
        &mut self,
        b: &mut Body,
        registers: &[Option<ir::Handle<Expr>>],
        constants: &[Option<ir::Handle<Expr>>],
    ) -> Vec<NH> {
        let vec4 = self.vec_ty(4);
        let ivec4 = self.ty(TypeInner::Vector { size: VectorSize::Quad, scalar: Scalar::I32 });
        // A value as the machine's RGBA: texels keep alpha 1 beside rgb, other values alpha 0.
        let as_rgba = |this: &mut Self, b: &mut Body, h: ir::Handle<Expr>| -> NH {
            let v = b.vals[&h];
            let ty = this.m.info(h).ty;
            let texel = matches!(this.m.exprs[h], Expr::Lookup { .. } | Expr::FramebufferRead { .. });
            match width(ty) {
                1 => b.emit(Expression::Splat { size: VectorSize::Quad, value: v }),
                2 => {
                    let zero = b.lit(0.0);
                    b.emit(Expression::Compose { ty: vec4, components: vec![v, zero, zero] })
                }
                3 => {
                    let a = b.lit(if texel { 1.0 } else { 0.0 });
                    b.emit(Expression::Compose { ty: vec4, components: vec![v, a] })
                }
                _ => v,
            }
        };
        let mut args = Vec::new();
        for (k, r) in registers.iter().enumerate() {
            args.push(match r {
                Some(h) => {
                    let v = as_rgba(self, b, *h);
                    // Texture registers 0-3 keep a signed texel's sign (a HILO
                    // or signed8 map); primary and secondary are colours.
                    register_input(b, v, if k < 4 { -1.0 } else { 0.0 })
                }
                None => b.plain(Expression::ZeroValue(ivec4)),
            });
        }
        for c in constants {
            args.push(match c {
                Some(h) => as_rgba(self, b, *h),
                None => b.plain(Expression::ZeroValue(vec4)),
            });
        }
        args.push(b.plain(Expression::ZeroValue(vec4))); // fog
        args
    }

    /// A register write in hardware precision: `q9(v)`.
    pub(super) fn quantize(&mut self, b: &mut Body, v: NH, w: usize) -> NH {
        if self.precision != Precision::Fixed9 || b.stage != Stage::Fragment {
            return v;
        }
        let f = self.q9_function(w, false);
        let r = b.plain(Expression::CallResult(f));
        b.f.body.push(
            Statement::Call { function: f, arguments: vec![v], result: Some(r) },
            naga::Span::UNDEFINED,
        );
        r
    }

    /// Whether node `n` only addresses a texture or framebuffer
    /// (`ir::address_only`): never rounded.
    pub(super) fn addresses_only(&self, n: ir::Handle<Expr>) -> bool {
        self.address.get(n.index()).copied().unwrap_or(false)
    }

    /// Whether node `n`, computed in the fragment stage (`sample`), is a
    /// register write of hardware precision: per fragment, not only an
    /// address (the CPU's `Step::quantize`).
    pub(super) fn register_write(&self, n: ir::Handle<Expr>, sample: bool) -> bool {
        self.precision == Precision::Fixed9
            && sample
            && self.m.info(n).freq.is_sample()
            && !self.addresses_only(n)
    }

    /// `floor(v * 255 + 0.5) / 255`, unclamped (a folded constant register
    /// and its scale).
    pub(super) fn fold(&mut self, b: &mut Body, v: NH, w: usize) -> R<NH> {
        let c255 = b.lit(255.0);
        let c255 = self.splat(b, c255, 1, w)?;
        let half = b.lit(0.5);
        let half = self.splat(b, half, 1, w)?;
        let s = self.binop(b, naga::BinaryOperator::Multiply, v, c255);
        let s = self.binop(b, naga::BinaryOperator::Add, s, half);
        let s = self.math(b, naga::MathFunction::Floor, &[s]);
        let s = self.binop(b, naga::BinaryOperator::Divide, s, c255);
        Ok(nan_to_zero(b, v, s, w))
    }

    /// `x / y` written to a register in hardware precision: `divide_*(x, y)`.
    pub(super) fn quotient(&mut self, b: &mut Body, x: NH, y: NH, w: usize) -> NH {
        let f = self.q9_function(w, true);
        let r = b.plain(Expression::CallResult(f));
        b.f.body.push(
            Statement::Call { function: f, arguments: vec![x, y], result: Some(r) },
            naga::Span::UNDEFINED,
        );
        r
    }

    /// `fn quantize_*(x) = clamp(floor(x * 255 + 0.5), -255, 255) / 255`, and
    /// 0 for NaN; with `quotient`, `fn divide_*(a, b)` the same of a / b in
    /// 1/255 steps taken as `(round(a·255)·255) / round(b·255)`: the
    /// quotient of the registers' integers k₁·255/k₂, exact where it is a
    /// tie m + ½ (k₁/k₂ reaches those, unlike products), so that the
    /// tie rounds up on every executor instead of by float noise
    /// (`renderer::plan::fixed9_quotient` computes the same).
    pub(super) fn q9_function(&mut self, w: usize, quotient: bool) -> naga::Handle<Function> {
        if let Some(f) = self.q9[quotient as usize][w - 1] {
            return f;
        }
        let ty = self.vec_ty(w);
        let name = if quotient {
            ["divide_x", "divide_xy", "divide_xyz", "divide_xyzw"]
        } else {
            ["quantize_x", "quantize_xy", "quantize_xyz", "quantize_xyzw"]
        }[w - 1];
        let mut b = Body::new(name, Stage::Vertex);
        let arguments: &[&str] = if quotient { &["a", "b"] } else { &["x"] };
        for a in arguments {
            b.f.arguments.push(FunctionArgument { name: Some(a.to_string()), ty, binding: None });
        }
        b.f.result = Some(FunctionResult { ty, binding: None });
        let k = |b: &mut Body, v: f32| {
            let l = b.lit(v);
            if w == 1 {
                l
            } else {
                b.emit(Expression::Splat { size: size(w), value: l })
            }
        };
        let c255 = k(&mut b, 255.0);
        let ch = k(&mut b, 0.5);
        let lo = k(&mut b, -255.0);
        let x = b.plain(Expression::FunctionArgument(0));
        let steps = |b: &mut Body, v: NH| {
            b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: v, right: c255 })
        };
        // The value in 1/255 steps, and what is NaN when it is.
        let (s, tested) = if quotient {
            let y = b.plain(Expression::FunctionArgument(1));
            let (n, d) = (steps(&mut b, x), steps(&mut b, y));
            let n = b.emit(Expression::Math {
                fun: naga::MathFunction::Round,
                arg: n,
                arg1: None,
                arg2: None,
                arg3: None,
            });
            let d = b.emit(Expression::Math {
                fun: naga::MathFunction::Round,
                arg: d,
                arg1: None,
                arg2: None,
                arg3: None,
            });
            let n = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: n, right: c255 });
            let t = b.emit(Expression::Binary { op: naga::BinaryOperator::Divide, left: n, right: d });
            (t, t)
        } else {
            (steps(&mut b, x), x)
        };
        let s = b.emit(Expression::Binary { op: naga::BinaryOperator::Add, left: s, right: ch });
        let s = b.emit(Expression::Math {
            fun: naga::MathFunction::Floor,
            arg: s,
            arg1: None,
            arg2: None,
            arg3: None,
        });
        let s = b.emit(Expression::Math {
            fun: naga::MathFunction::Clamp,
            arg: s,
            arg1: Some(lo),
            arg2: Some(c255),
            arg3: None,
        });
        let s = b.emit(Expression::Binary { op: naga::BinaryOperator::Divide, left: s, right: c255 });
        let s = nan_to_zero(&mut b, tested, s, w);
        b.f.body.push(Statement::Return { value: Some(s) }, naga::Span::UNDEFINED);
        let f = self.module.functions.append(b.f, naga::Span::UNDEFINED);
        self.q9[quotient as usize][w - 1] = Some(f);
        f
    }

    /// `round_to_half(x)`: each component rounded to the nearest half float
    /// (ties to even), as the CPU's `ColorFormat::F16` stores it. A pass
    /// into an `Rgba16Float` texture writes this, so the target's own
    /// conversion is exact: Vulkan lets a driver round a colour write
    /// toward zero (lavapipe does), which makes every N·H of a G-buffer
    /// one half-float step short, a bias `^24` magnifies to 3/255.
    pub(super) fn round_to_half(&mut self, b: &mut Body, v: NH) -> NH {
        let f = match self.half {
            Some(f) => f,
            None => {
                let f = self.round_to_half_function();
                self.half = Some(f);
                f
            }
        };
        let r = b.plain(Expression::CallResult(f));
        b.f.body.push(
            Statement::Call { function: f, arguments: vec![v], result: Some(r) },
            naga::Span::UNDEFINED,
        );
        r
    }

    /// `fn round_to_half(x: vec4<f32>) -> vec4<f32>`: with E the binary
    /// exponent of x (from its bits) and k = max(E − 10, −24) the exponent
    /// of a half float's step there (10 mantissa bits; below 2⁻¹⁴ the
    /// subnormals' fixed step 2⁻²⁴), `ldexp(round(ldexp(x, −k)), k)` —
    /// scalings by powers of two are exact and WGSL's `round` takes ties to
    /// even. (WGSL's `quantizeToF16` would need the f16 capability, and its
    /// rounding direction is the implementation's choice.)
    pub(super) fn round_to_half_function(&mut self) -> naga::Handle<Function> {
        let vec4 = self.vec_ty(4);
        let mut b = Body::new("round_to_half", Stage::Vertex);
        b.f.arguments.push(FunctionArgument { name: Some("x".into()), ty: vec4, binding: None });
        b.f.result = Some(FunctionResult { ty: vec4, binding: None });
        let x = b.plain(Expression::FunctionArgument(0));
        let splat = |b: &mut Body, l: Literal| {
            let l = b.plain(Expression::Literal(l));
            b.emit(Expression::Splat { size: VectorSize::Quad, value: l })
        };
        let bits = b.emit(Expression::As { expr: x, kind: naga::ScalarKind::Uint, convert: None });
        let c23 = splat(&mut b, Literal::U32(23));
        let c255 = splat(&mut b, Literal::U32(255));
        let biased = self.binop(&mut b, naga::BinaryOperator::ShiftRight, bits, c23);
        let biased = self.binop(&mut b, naga::BinaryOperator::And, biased, c255);
        let biased = b.emit(Expression::As { expr: biased, kind: naga::ScalarKind::Sint, convert: Some(4) });
        let bias = splat(&mut b, Literal::I32(127 + 10));
        let k = self.binop(&mut b, naga::BinaryOperator::Subtract, biased, bias);
        let lowest = splat(&mut b, Literal::I32(-24));
        let k = self.math(&mut b, naga::MathFunction::Max, &[k, lowest]);
        let minus_k = b.emit(Expression::Unary { op: naga::UnaryOperator::Negate, expr: k });
        let scaled = self.math(&mut b, naga::MathFunction::Ldexp, &[x, minus_k]);
        let rounded = self.math(&mut b, naga::MathFunction::Round, &[scaled]);
        let back = self.math(&mut b, naga::MathFunction::Ldexp, &[rounded, k]);
        b.f.body.push(Statement::Return { value: Some(back) }, naga::Span::UNDEFINED);
        self.module.functions.append(b.f, naga::Span::UNDEFINED)
    }
}

/// round(clamp(v, lo, 1) · 255) as integers: the register input of the
/// combiners (Kilgard 2000, Table 2) — `lo` = −1 for a texture register, which
/// holds a signed texel's sign, 0 for the colour registers — as the CPU's
/// fixed9 loads them.
pub(super) fn register_input(b: &mut Body, v: NH, lo: f32) -> NH {
    let (zero, one, k255, half) = (b.lit(lo), b.lit(1.0), b.lit(255.0), b.lit(0.5));
    let (zero, one) = (
        b.emit(Expression::Splat { size: VectorSize::Quad, value: zero }),
        b.emit(Expression::Splat { size: VectorSize::Quad, value: one }),
    );
    let c = b.emit(Expression::Math {
        fun: naga::MathFunction::Clamp,
        arg: v,
        arg1: Some(zero),
        arg2: Some(one),
        arg3: None,
    });
    let c = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: c, right: k255 });
    let half = b.emit(Expression::Splat { size: VectorSize::Quad, value: half });
    let c = b.emit(Expression::Binary { op: naga::BinaryOperator::Add, left: c, right: half });
    let c = b.emit(Expression::Math {
        fun: naga::MathFunction::Floor,
        arg: c,
        arg1: None,
        arg2: None,
        arg3: None,
    });
    b.emit(Expression::As { expr: c, kind: ScalarKind::Sint, convert: Some(4) })
}

/// `glAlphaFunc`'s test on the combiners' alpha (OpenGL 1.2.1, Section
/// 4.1.4): the alpha in 1/255 steps (the function returns steps / 255;
/// `round` undoes the division's error) against the reference's steps,
/// the fragment killed where it fails — as the CPU's `fixed9` tests it.
fn alpha_test_kill(b: &mut Body, combiners: NH, t: crate::pipeline::AlphaTest) {
    use crate::pipeline::CompareFunc;
    use naga::BinaryOperator as Op;
    let a = b.emit(Expression::AccessIndex { base: combiners, index: 3 });
    let c255 = b.lit(255.0);
    let steps = b.emit(Expression::Binary { op: Op::Multiply, left: a, right: c255 });
    let steps = b.emit(Expression::Math {
        fun: naga::MathFunction::Round,
        arg: steps,
        arg1: None,
        arg2: None,
        arg3: None,
    });
    let reference = b.lit(f32::from(t.reference_steps()));
    // The failing comparison: the negation of the test.
    let fails = match t.func {
        CompareFunc::Never => None,
        CompareFunc::Less => Some(Op::GreaterEqual),
        CompareFunc::LessEqual => Some(Op::Greater),
        CompareFunc::Equal => Some(Op::NotEqual),
        CompareFunc::Greater => Some(Op::LessEqual),
        CompareFunc::GreaterEqual => Some(Op::Less),
        CompareFunc::NotEqual => Some(Op::Equal),
        CompareFunc::Always => return,
    };
    let fails = match fails {
        Some(op) => b.emit(Expression::Binary { op, left: steps, right: reference }),
        None => b.plain(Expression::Literal(naga::Literal::Bool(true))),
    };
    let mut accept = naga::Block::new();
    accept.push(Statement::Kill, naga::Span::UNDEFINED);
    b.f.body
        .push(Statement::If { condition: fails, accept, reject: naga::Block::new() }, naga::Span::UNDEFINED);
}
