//! `Body`, the function under construction: emitting naga expressions into
//! its current block, reading the already computed value of an IR node, and
//! the small vector helpers (`size`, `width`, swizzle components) every
//! emitter uses.

use super::*;

impl Body {
    pub(super) fn new(name: &str, stage: Stage) -> Body {
        Body {
            f: Function { name: Some(name.to_string()), ..Default::default() },
            stage,
            vals: HashMap::new(),
            args: vec![],
            frag_coord: None,
            texel_uv: None,
            fat: HashMap::new(),
            loads: HashMap::new(),
            bools: HashMap::new(),
        }
    }
    /// A computed expression, covered by its own `Emit`.
    pub(super) fn emit(&mut self, e: Expression) -> NH {
        let start = self.f.expressions.len();
        let h = self.f.expressions.append(e, naga::Span::UNDEFINED);
        self.f.body.push(Statement::Emit(self.f.expressions.range_from(start)), naga::Span::UNDEFINED);
        h
    }
    /// An expression that must not be emitted (literals, arguments, globals).
    pub(super) fn plain(&mut self, e: Expression) -> NH {
        self.f.expressions.append(e, naga::Span::UNDEFINED)
    }
    /// The f32 constant `v`. WGSL has no literal for an infinity or a NaN
    /// (a constant beyond f32's range, such as `x^1e40`, folds to one), so
    /// those are their bits reinterpreted, the value the CPU computes.
    pub(super) fn lit(&mut self, v: f32) -> NH {
        if v.is_finite() {
            return self.plain(Expression::Literal(Literal::F32(v)));
        }
        let bits = self.plain(Expression::Literal(Literal::U32(v.to_bits())));
        self.emit(Expression::As { expr: bits, kind: naga::ScalarKind::Float, convert: None })
    }
    /// The value of node `h`, computed earlier in this body.
    pub(super) fn val(&self, h: ir::Handle<Expr>) -> R<NH> {
        self.vals
            .get(&h)
            .copied()
            .ok_or_else(|| GenError::Internal(format!("value %{} used before it is computed", h.index())))
    }
    /// The fragment stage, where values are per sample.
    pub(super) fn per_sample(&self) -> bool {
        self.stage == Stage::Fragment
    }
    /// Loads member `index` of the uniform block `var`.
    pub(super) fn load_member(&mut self, var: naga::Handle<GlobalVariable>, index: u32) -> NH {
        let g = self.plain(Expression::GlobalVariable(var));
        let p = self.emit(Expression::AccessIndex { base: g, index });
        self.emit(Expression::Load { pointer: p })
    }
    /// Samples `image` with `sampler` at `coordinate` (in `array_index`'s layer).
    pub(super) fn sample(
        &mut self,
        image: NH,
        sampler: NH,
        coordinate: NH,
        array_index: Option<NH>,
        level: naga::SampleLevel,
    ) -> NH {
        self.emit(Expression::ImageSample {
            image,
            sampler,
            gather: None,
            coordinate,
            array_index,
            offset: None,
            level,
            depth_ref: None,
            clamp_to_edge: false,
        })
    }
    pub(super) fn name(&mut self, h: NH, name: &str) {
        let needs_emit = !matches!(
            self.f.expressions[h],
            Expression::Literal(_)
                | Expression::Constant(_)
                | Expression::FunctionArgument(_)
                | Expression::GlobalVariable(_)
                | Expression::LocalVariable(_)
                | Expression::CallResult(_)
                | Expression::ZeroValue(_)
        );
        if needs_emit {
            self.f.named_expressions.entry(h).or_insert_with(|| name.to_string());
        }
    }
}

/// `value`, or 0 where `tested` is NaN (0/0, √−x, ∞−∞), as the CPU's
/// `fixed9` makes it: tested on the bits (exponent all ones, mantissa not
/// zero), since WGSL lets a compiler assume no NaN in float comparisons —
/// and `clamp` of NaN is the implementation's (lavapipe gives −1: a black
/// highlight).
pub(super) fn nan_to_zero(b: &mut Body, tested: NH, value: NH, w: usize) -> NH {
    let splat =
        |b: &mut Body, l: NH| if w == 1 { l } else { b.emit(Expression::Splat { size: size(w), value: l }) };
    let u = |b: &mut Body, v: u32| {
        let l = b.plain(Expression::Literal(Literal::U32(v)));
        splat(b, l)
    };
    let bits = b.emit(Expression::As { expr: tested, kind: naga::ScalarKind::Uint, convert: None });
    let magnitude = u(b, 0x7fff_ffff);
    let bits = b.emit(Expression::Binary { op: naga::BinaryOperator::And, left: bits, right: magnitude });
    let infinity = u(b, 0x7f80_0000);
    let nan = b.emit(Expression::Binary { op: naga::BinaryOperator::Greater, left: bits, right: infinity });
    let zero = b.lit(0.0);
    let zero = splat(b, zero);
    b.emit(Expression::Select { condition: nan, accept: zero, reject: value })
}

pub(super) fn size(w: usize) -> VectorSize {
    match w {
        2 => VectorSize::Bi,
        3 => VectorSize::Tri,
        _ => VectorSize::Quad,
    }
}

pub(super) const COMP: [SwizzleComponent; 4] =
    [SwizzleComponent::X, SwizzleComponent::Y, SwizzleComponent::Z, SwizzleComponent::W];

/// The width of a value of type `ty` in the shader (1..=4).
pub(super) fn width(ty: Ty) -> usize {
    match ty {
        Ty::Position => 4,
        t => t.width().clamp(1, 4),
    }
}
