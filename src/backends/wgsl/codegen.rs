//! IR → `naga::Module`: one module per pass of a [`Planned`] plan, with a
//! vertex entry point `vs_main` and a fragment entry point `fs_main`, built
//! to the binding contract of [`PassInterface`] and validated by naga here
//! (an invalid module is a compiler bug, reported as an `internal-error`
//! diagnostic on the statement).
//!
//! # Bindings (the runner's conventions, `runner.rs`)
//!
//! - Vertex input `@location(i)`: `vec4<f32>`, the pass's `vertex_leaves[i]`
//!   (a position has w = 1, a direction w = 0, coordinates z = w = 0). A pass
//!   whose geometry is not a mesh (`Screen`, `Texels`) takes one more input
//!   after the leaves, `quad`: the clip-space corner (x, y in −1..1) of the
//!   full-screen rectangle.
//! - Group 0, `@binding(0)`: the uniform block `Uniforms`, when the pass has
//!   a projection or a uniform: the projection matrices first (`mat4x4<f32>`
//!   each, model → GL clip space, in `PassInterface::projections` order; an
//!   inverse projection's slot holds the inverse matrix), then the uniforms
//!   (`vec4<f32>` each, in `PassInterface::uniforms` order). See
//!   [`uniform_bytes`].
//! - Texture unit `i`: the texture at `@binding(1 + 2i)`, its sampler at
//!   `@binding(2 + 2i)`. 1-D textures are bound as 2-D textures one texel
//!   high (sampled at v = ½); signed formats are stored range-compressed in
//!   RGBA8 (`(v + 1)/2`) and expanded in the shader. A framebuffer read at
//!   the fragment's own pixel is a `textureLoad` at the pixel.
//! - Varyings: `@location(k)` is `interpolants[k]` widened to `vec4<f32>`
//!   (zeros appended), perspective-correct; a non-mesh pass adds `texel_uv`.
//! - Output `@location(0)`: the fragment value widened to RGBA (a scalar is
//!   splatted, rgb gets alpha 1).
//! - **Fat textures** ([`fat_layers`]; Pipeline Grammar, eq. (5), (6), (14)-(16)): a
//!   texture a statement writes a shading-parameter bundle into, or whose
//!   texels a shader reads members of, is a `texture_2d_array<f32>` with
//!   one layer per member (member i in layer i's rgb). A pass writing a
//!   bundle returns `struct FatTexel` with member i at `@location(i)`
//!   ([`PassShader::outputs`]): the runner attaches layer i as colour
//!   attachment i. Read as a colour, a fat texture is its layer 0 (so a
//!   colour written into it, as (16) does, goes to layer 0).
//! - **Own-target reads**: a texture unit bound to the pass's own target
//!   (`T δu ← p T δu`, or a framebuffer read away from the pixel) reads it
//!   as it was before the pass — the runner binds a copy. A read of the
//!   target framebuffer at the fragment's own pixel that blending does not
//!   absorb (`α C xs ← (z C xs) > …`, Pipeline Grammar, Section 3.5) is a
//!   `textureLoad` from a copy taken before the pass, at the bindings after
//!   the units ([`PassShader::target_copies`]: colour, or depth in `.x`).
//! - **Framebuffer reads** away from the pixel (`z Cl πl π⁻¹ xs`) sample
//!   at the projective coordinate; outside the framebuffer they give its
//!   cleared values (colour 0, depth 1), as the CPU renderer does.
//! - **Pixels**: `xs` as a value (under `π⁻¹`) is the pixel centre in GL
//!   normalized device coordinates with the target's depth there (from the
//!   depth copy) mapped to −1..1, w = 1 — the CPU renderer's definition.
//!   `T xs` samples the texel under the pixel at level 0.
//! - **Texture space**: a pass indexed by texture coordinates (`T δu x ←`,
//!   (15), and texture shading on a mesh, (13)) rasterizes the mesh at clip
//!   `(2u − 1, 1 − 2v)`, with no depth test or culling (the planner's state).
//!
//! # Conventions
//!
//! - Clip space: the plan's matrices are GL's (z in −w..w); the vertex
//!   shader writes `z' = ½z + ½w` (wgpu's 0..w). Interpolated positions keep
//!   GL clip coordinates; their depth is `½ z/w + ½` (GL window depth).
//! - Texture coordinates: v = 0 is row 0 of the image, which is the top of a
//!   rendered image (clip y = +1). Projective lookups (`T δπl x`) use
//!   `(½ x/w + ½, ½ − ½ y/w)`; rendering into a texture by its coordinates
//!   (`T δu x ←`) puts u, v at clip `(2u − 1, 1 − 2v)`.
//! - ⊕ modes, the left operand the texture (Ct, At) over the right one (Cf,
//!   Af), as `planner/affine.rs` documents: modulate `a·b`, add `a + b`,
//!   add_signed `a + b − ½`, subtract `a − b`, decal `Cf(1 − At) + Ct·At`
//!   with alpha Af, blend `Cf(1 − Ct)` with alpha `Af·At`, replace `Ct` (alpha
//!   At for an rgba texture, else Af), interpolate `Ct·At + Cf(1 − At)` (alpha
//!   likewise), dot3 `4 (Ct − ½)·(Cf − ½)` splatted to rgb (alpha `Af·At`;
//!   dot3_rgba: to all four). At = 1 for an rgb operand. Like the IR's
//!   `combine`, no mode clamps its result (GL's clamp to [0, 1] is the
//!   hardware models', and an 8-bit framebuffer's).
//! - Comparisons and logic give 1.0 or 0.0; a condition holds where it is
//!   not 0. `c ? a` (no `:`) discards the fragment where `c` is 0.
//!
//! # Precision
//!
//! [`Precision::Exact`] and [`Precision::F32`] are f32 arithmetic with true
//! normalize and pow (a GPU has no f64: the exact reference is the CPU's).
//! [`Precision::Fixed9`] runs the register combiners (Kilgard 2000, Section
//! 4.2): a pass whose setup the combiner code generator makes
//! ([`crate::backends::combiners::setup::of`]) computes in
//! f32 only its texels and interpolated colours, rounds them to 8 bits and
//! calls the setup as integer code (`rc1::combiners_function`, parsed into
//! the module the pass is built on: `combiners_module`), bit-exact with the
//! emulator and so with the CPU
//! renderer's `fixed9`. A pass the generator refuses models the combiners
//! per operation (GeForce3 Phong, Section 5.2, `docs/combiners.md`): every
//! per-fragment arithmetic result is rounded to 1/255 (nearest, ties toward
//! +∞, as the emulator's register write), and clamped to [−1, 1] only
//! where the hardware holds it in a register ([`ir::register_reads`]:
//! `q9(x) = clamp(floor(255x + ½), −255, 255) / 255`); constants and
//! uniforms are rounded, keeping their magnitude; a constant integer power is
//! repeated squaring with a register write after each product; textures are
//! 8-bit already.

use std::collections::{BTreeSet, HashMap};

use naga::{
    AddressSpace, Binding, BuiltIn, EntryPoint, Expression, Function, FunctionArgument, FunctionResult,
    GlobalVariable, ImageClass, ImageDimension, Interpolation, Literal, ResourceBinding, Sampling, Scalar,
    ScalarKind, ShaderStage, Statement, StructMember, SwizzleComponent, Type, TypeInner, VectorSize,
};

use crate::diag::Diagnostic;
use crate::ir::{self, BinaryOp, Expr, FbChannel, Frequency, MathFunction, Ty, UnaryOp};
use crate::numerics::Precision;
use crate::parser::ast::{CombineMode, TextureFormat, TextureKind};
use crate::pipeline::{Geometry, PassInterface, Planned, RenderTarget};
use crate::span::Span;

pub const VERTEX_ENTRY: &str = "vs_main";
pub const FRAGMENT_ENTRY: &str = "fs_main";

/// A texture unit's globals: (texture, sampler), its kind and format.
type UnitBinding =
    (naga::Handle<GlobalVariable>, naga::Handle<GlobalVariable>, TextureKind, Option<TextureFormat>);

/// One pass, compiled.
#[derive(Clone, Debug)]
pub struct PassShader {
    /// Index of the pass in the plan.
    pub pass: usize,
    /// `pass 2 of 3: C.rgba ← modulate [Tn, Ncube]`.
    pub label: String,
    /// The source statement(s) the pass implements, `line:col: text`.
    pub source: Vec<String>,
    pub interface: PassInterface,
    /// The vertex stage takes the full-screen rectangle's corners as one
    /// more input after the leaves (non-mesh geometry).
    pub quad_input: bool,
    /// Colour attachments the fragment stage writes: 1, or the members of
    /// a fat texel (one array layer each, see the module docs).
    pub outputs: u32,
    /// Copies of the pass's own target the shader reads, taken before the
    /// pass (module docs, "Own-target reads").
    pub target_copies: Vec<TargetCopy>,
    pub module: naga::Module,
    pub info: naga::valid::ModuleInfo,
}

/// A copy of the pass's target framebuffer, read by the shader at the
/// fragment's own pixel (`textureLoad`), bound at `binding` (group 0).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TargetCopy {
    pub binding: u32,
    pub framebuffer: String,
    /// The depth buffer (in `.x`), else the colour buffer.
    pub depth: bool,
}

pub use crate::ir::fat_layers;

/// The uniform block's bytes for a pass: the projection matrices
/// (column-major, as WGSL stores `mat4x4<f32>`), then the uniforms.
pub fn uniform_bytes(projections: &[[f32; 16]], uniforms: &[[f32; 4]]) -> Vec<u8> {
    let mut out = Vec::with_capacity(64 * projections.len() + 16 * uniforms.len());
    for m in projections {
        for v in m {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    for u in uniforms {
        for v in u {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// Compiles every pass of `planned`. `source` (the program text) gives
/// names (`let`s) and the source lines in headers.
pub fn generate(
    planned: &Planned,
    source: Option<&str>,
    precision: Precision,
) -> Result<Vec<PassShader>, Vec<Diagnostic>> {
    let names = source_names(planned, source);
    let mut out = Vec::new();
    let mut errors = Vec::new();
    for i in 0..planned.plan.passes.len() {
        match generate_pass(planned, i, source, &names, precision) {
            Ok(s) => out.push(s),
            Err(d) => errors.push(d),
        }
    }
    if errors.is_empty() {
        Ok(out)
    } else {
        Err(errors)
    }
}

fn generate_pass(
    planned: &Planned,
    index: usize,
    source: Option<&str>,
    names: &HashMap<ir::Handle<Expr>, String>,
    precision: Precision,
) -> Result<PassShader, Diagnostic> {
    let pass = &planned.plan.passes[index];
    let span = planned.setup(index).span;
    let interface = PassInterface::of(planned, index);
    // A `bake` table is computed by the compiler, in float (issue 18).
    let precision = if pass.baked { Precision::F32 } else { precision };
    let mut g = Gen::new(planned, index, interface.clone(), names, precision);
    if precision == Precision::Fixed9 {
        g.combiners = crate::backends::combiners::setup::of(planned, index).ok().cloned();
        if let Some(generated) = &g.combiners {
            g.module = combiners_module(&generated.config).map_err(|e| internal(span, &e))?;
        }
    }
    g.build().map_err(|e| match e {
        GenError::Unsupported { what, at } => {
            let at = at.filter(|s| *s != Span::DETACHED);
            let mut d = Diagnostic::error("wgsl-unsupported", format!("the WGSL backend cannot compile this yet: {what}"), span, "in this statement");
            if let Some(at) = at {
                d = d.with_label(at, what.clone());
            }
            d.with_help("the CPU renderer (`shadec render`) or a combiner target may run it; else rewrite the part named above")
        }
        GenError::Internal(msg) => internal(span, &msg),
    })?;
    let module = std::mem::take(&mut g.module);
    let mut validator = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    );
    let info = validator.validate(&module).map_err(|e| internal(span, &error_chain(&e)))?;
    let label = pass_label(planned, index);
    let mut src = Vec::new();
    if let Some(text) = source {
        let ix = crate::span::LineIndex::new(text);
        for &s in &pass.statements {
            if let Some(st) = planned.module.statements.get(s) {
                let (a, b) = (st.span.start as usize, st.span.end as usize);
                if let Some(t) = text.get(a..b.min(text.len())) {
                    let lc = ix.line_col(text, a);
                    let one: String = t.split_whitespace().collect::<Vec<_>>().join(" ");
                    src.push(format!("{}:{}: {one}", lc.line, lc.col));
                }
            }
        }
    }
    let target_copies = g.target_copies.iter().map(|(c, _)| c.clone()).collect();
    Ok(PassShader {
        pass: index,
        label,
        source: src,
        interface,
        quad_input: g.quad,
        outputs: g.outputs,
        target_copies,
        module,
        info,
    })
}

/// The module a hardware-fidelity pass is built on: the setup as
/// one WGSL function (`rc1::combiners_function`, the integer code `shadec
/// translate` writes and the GPU tests hold bit-exact with the emulator)
/// and its helpers, parsed by naga on their own. The pass's shader is then
/// appended to this module as IR and calls the function by its handle —
/// nothing searches or splices generated text. Parsing the function's text
/// rather than building it as IR keeps one writer of the combiners' WGSL.
fn combiners_module(config: &crate::backends::combiners::CombinerConfig) -> Result<naga::Module, String> {
    use super::rc1;
    let text = format!("{}{}", rc1::combiners_function(config), rc1::combiners_helpers());
    naga::front::wgsl::parse_str(&text).map_err(|e| e.emit_to_string(&text))
}

fn internal(span: Span, msg: &str) -> Diagnostic {
    Diagnostic::error(
        "internal-error",
        format!("compiler bug: the WGSL backend built an invalid shader for this statement: {msg}"),
        span,
        "while compiling this statement",
    )
    .with_help("this is a bug in shadec, not in your program: please report it with the program")
}

fn error_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut src = e.source();
    while let Some(inner) = src {
        s += &format!(": {inner}");
        src = inner.source();
    }
    s
}

/// `pass 2 of 3: C.rgba ← modulate [Tn, Ncube]`.
pub fn pass_label(planned: &Planned, index: usize) -> String {
    let pass = &planned.plan.passes[index];
    let target = match &pass.target {
        RenderTarget::Framebuffer { name, channels } => format!("{name}.{channels}"),
        RenderTarget::Texture { name } | RenderTarget::Temporary { name } => name.clone(),
    };
    let units: Vec<&str> = pass.textures.iter().map(|t| t.texture.as_str()).collect();
    format!(
        "pass {} of {}: {target} ← {} [{}]",
        index + 1,
        planned.plan.passes.len(),
        pass.blend.name(),
        units.join(", ")
    )
}

/// Names of IR values from the source: the `let` whose value a node is.
fn source_names(planned: &Planned, source: Option<&str>) -> HashMap<ir::Handle<Expr>, String> {
    let mut by_span: HashMap<Span, String> = HashMap::new();
    if let Some(text) = source {
        let (program, _) = crate::parser::parse(text);
        for item in &program.items {
            match &item.kind {
                crate::parser::ast::ItemKind::Let(l) => {
                    by_span.insert(l.value.span, l.name.key());
                }
                // A computed vector (`vector H = normalize(L + V)`).
                crate::parser::ast::ItemKind::Vector(v) if v.names.len() == 1 => {
                    if let Some(value) = &v.value {
                        by_span.insert(value.span, v.names[0].key());
                    }
                }
                crate::parser::ast::ItemKind::Shader(s) => {
                    for l in &s.lets {
                        by_span.insert(l.value.span, l.name.key());
                    }
                }
                _ => {}
            }
        }
    }
    let m = &planned.module;
    let mut names = HashMap::new();
    let mut last: HashMap<Span, ir::Handle<Expr>> = HashMap::new();
    for (h, _) in m.exprs.arena().iter() {
        let s = m.span(h);
        if by_span.contains_key(&s) {
            last.insert(s, h); // the outermost node with the let's span
        }
    }
    for (s, h) in last {
        names.insert(h, sanitize(&by_span[&s]));
    }
    names
}

/// A WGSL identifier from a source name: primes become `p`, Greek letters
/// their names, anything else outside `[A-Za-z0-9_]` an underscore.
pub fn sanitize(name: &str) -> String {
    let mut s = String::new();
    for c in name.chars() {
        match c {
            'a'..='z' | 'A'..='Z' | '0'..='9' | '_' => s.push(c),
            '\'' | '′' | '″' | '‴' => s.push_str(if c == '″' {
                "pp"
            } else if c == '‴' {
                "ppp"
            } else {
                "p"
            }),
            '*' => s.push_str("_star"),
            'α' => s.push_str("alpha"),
            'δ' => s.push_str("delta"),
            'π' => s.push_str("pi"),
            'σ' => s.push_str("sigma"),
            _ => s.push('_'),
        }
    }
    while s.contains("__") {
        s = s.replace("__", "_");
    }
    let s = s.trim_matches('_').to_string();
    if s.is_empty() || s.starts_with(|c: char| c.is_ascii_digit()) {
        format!("v_{s}")
    } else {
        s
    }
}

enum GenError {
    Unsupported { what: String, at: Option<Span> },
    Internal(String),
}

type R<T> = Result<T, GenError>;
type NH = naga::Handle<Expression>;

/// A node's value in a body, and whether it is an arithmetic result: a
/// register write, which hardware precision rounds ([`Gen::finish`]).
#[derive(Clone, Copy)]
struct Computed {
    value: NH,
    arith: bool,
}

impl Computed {
    /// A value that is no register write of its own (an input, a texel, a 0/1).
    fn plain(value: NH) -> Computed {
        Computed { value, arith: false }
    }
    /// An arithmetic result.
    fn arith(value: NH) -> Computed {
        Computed { value, arith: true }
    }
}

/// naga's builtin for a math function, and whether its arguments are
/// splatted to the result's width; `None` for the range mappings
/// (`expand`, `half_bias`, `compress`, [`Gen::range_mapping`]).
fn naga_math(fun: MathFunction) -> Option<(naga::MathFunction, bool)> {
    use naga::MathFunction as F;
    let unary = |f| Some((f, false));
    match fun {
        MathFunction::Normalize => unary(F::Normalize),
        MathFunction::Length => unary(F::Length),
        MathFunction::Cross => unary(F::Cross),
        MathFunction::Reflect => unary(F::Reflect),
        MathFunction::Max => Some((F::Max, true)),
        MathFunction::Min => Some((F::Min, true)),
        MathFunction::Clamp => Some((F::Clamp, true)),
        MathFunction::Saturate => unary(F::Saturate),
        MathFunction::Abs => unary(F::Abs),
        MathFunction::Sign => unary(F::Sign),
        MathFunction::Sqrt => unary(F::Sqrt),
        MathFunction::Rsqrt => unary(F::InverseSqrt),
        MathFunction::Exp => unary(F::Exp),
        MathFunction::Log => unary(F::Log),
        MathFunction::Sin => unary(F::Sin),
        MathFunction::Cos => unary(F::Cos),
        MathFunction::Floor => unary(F::Floor),
        MathFunction::Fract => unary(F::Fract),
        MathFunction::Step => Some((F::Step, true)),
        MathFunction::Smoothstep => Some((F::SmoothStep, true)),
        MathFunction::Mix => Some((F::Mix, true)),
        MathFunction::Expand | MathFunction::HalfBias | MathFunction::Compress => None,
    }
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Stage {
    Vertex,
    Fragment,
}

/// A function being built.
struct Body {
    f: Function,
    stage: Stage,
    vals: HashMap<ir::Handle<Expr>, NH>,
    /// The vertex inputs (vertex stage) or the `VertexOutput` argument (fragment).
    args: Vec<NH>,
    /// Fragment stage: the varyings by interpolant index, and `position`.
    frag_coord: Option<NH>,
    texel_uv: Option<NH>,
    /// Lookups of fat textures: (unit, coordinate, level); their members
    /// are sampled by [`Expr::FatMember`].
    fat: HashMap<ir::Handle<Expr>, (usize, NH, naga::SampleLevel)>,
    /// Texels loaded at the fragment's pixel, by texture ([`Gen::load_at_pixel`]).
    loads: HashMap<naga::Handle<GlobalVariable>, NH>,
    /// The boolean behind a 0/1 value (comparisons, logic), so that a
    /// condition uses it directly.
    bools: HashMap<NH, NH>,
}

impl Body {
    fn new(name: &str, stage: Stage) -> Body {
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
    fn emit(&mut self, e: Expression) -> NH {
        let start = self.f.expressions.len();
        let h = self.f.expressions.append(e, naga::Span::UNDEFINED);
        self.f.body.push(Statement::Emit(self.f.expressions.range_from(start)), naga::Span::UNDEFINED);
        h
    }
    /// An expression that must not be emitted (literals, arguments, globals).
    fn plain(&mut self, e: Expression) -> NH {
        self.f.expressions.append(e, naga::Span::UNDEFINED)
    }
    fn lit(&mut self, v: f32) -> NH {
        self.plain(Expression::Literal(Literal::F32(v)))
    }
    /// The value of node `h`, computed earlier in this body.
    fn val(&self, h: ir::Handle<Expr>) -> R<NH> {
        self.vals
            .get(&h)
            .copied()
            .ok_or_else(|| GenError::Internal(format!("value %{} used before it is computed", h.index())))
    }
    /// The fragment stage, where values are per sample.
    fn per_sample(&self) -> bool {
        self.stage == Stage::Fragment
    }
    /// Loads member `index` of the uniform block `var`.
    fn load_member(&mut self, var: naga::Handle<GlobalVariable>, index: u32) -> NH {
        let g = self.plain(Expression::GlobalVariable(var));
        let p = self.emit(Expression::AccessIndex { base: g, index });
        self.emit(Expression::Load { pointer: p })
    }
    /// Samples `image` with `sampler` at `coordinate` (in `array_index`'s layer).
    fn sample(
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
    fn name(&mut self, h: NH, name: &str) {
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
fn nan_to_zero(b: &mut Body, tested: NH, value: NH, w: usize) -> NH {
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

fn size(w: usize) -> VectorSize {
    match w {
        2 => VectorSize::Bi,
        3 => VectorSize::Tri,
        _ => VectorSize::Quad,
    }
}

const COMP: [SwizzleComponent; 4] =
    [SwizzleComponent::X, SwizzleComponent::Y, SwizzleComponent::Z, SwizzleComponent::W];

/// The width of a value of type `ty` in the shader (1..=4).
fn width(ty: Ty) -> usize {
    match ty {
        Ty::Position => 4,
        t => t.width().clamp(1, 4),
    }
}

struct Gen<'a> {
    planned: &'a Planned,
    m: &'a ir::Module,
    pass_index: usize,
    iface: PassInterface,
    names: &'a HashMap<ir::Handle<Expr>, String>,
    precision: Precision,
    module: naga::Module,
    uniforms_var: Option<naga::Handle<GlobalVariable>>,
    /// (texture, sampler) per unit.
    units: Vec<UnitBinding>,
    /// `quantize_*` and `divide_*` by width ([`Gen::q9_function`]).
    q9: [[Option<naga::Handle<Function>>; 4]; 2],
    /// `round_to_half`, once built.
    half: Option<naga::Handle<Function>>,
    quad: bool,
    /// The pass's fragment position (the index's Interpolate node).
    own_position: Option<ir::Handle<Expr>>,
    /// `--precision hardware`: the register-combiner setup generated for the
    /// pass, which the fragment stage runs (`rc1::combiners_function`).
    combiners: Option<crate::backends::combiners::Generated>,
    /// Per texture: its fat layers ([`fat_layers`]).
    fat: Vec<u8>,
    /// Own-target copies bound so far, with their globals.
    target_copies: Vec<(TargetCopy, naga::Handle<GlobalVariable>)>,
    /// Colour attachments written ([`PassShader::outputs`]).
    outputs: u32,
    /// The nodes the fragment stage computes ([`Gen::fragment_nodes`]).
    pass_nodes: Vec<ir::Handle<Expr>>,
    /// Per arena index: the node only addresses textures or framebuffers
    /// ([`ir::address_only`]), so hardware precision does not round it.
    address: Vec<bool>,
    /// Hardware precision: nodes whose value is already on the 8-bit grid
    /// (rounded, or a rounded constant or uniform): a swizzle, conversion,
    /// compose or select of only these needs no rounding of its own.
    on_grid: std::collections::HashSet<ir::Handle<Expr>>,
    /// Per arena index: hardware precision clamps the node's register write
    /// to [−1, 1] ([`ir::register_reads`], as the CPU's fixed9 does).
    register_reads: Vec<bool>,
}

impl<'a> Gen<'a> {
    fn new(
        planned: &'a Planned,
        pass_index: usize,
        iface: PassInterface,
        names: &'a HashMap<ir::Handle<Expr>, String>,
        precision: Precision,
    ) -> Gen<'a> {
        let pass = &planned.plan.passes[pass_index];
        Gen {
            planned,
            m: &planned.module,
            pass_index,
            own_position: pass.vertex.position.map(|p| planned.handle(p)),
            iface,
            names,
            precision,
            module: naga::Module::default(),
            uniforms_var: None,
            units: vec![],
            q9: [[None; 4]; 2],
            half: None,
            quad: false,
            combiners: None,
            fat: fat_layers(&planned.module),
            target_copies: vec![],
            outputs: 1,
            pass_nodes: vec![],
            address: vec![],
            on_grid: Default::default(),
            register_reads: Vec::new(),
        }
    }

    fn ty(&mut self, inner: TypeInner) -> naga::Handle<Type> {
        self.module.types.insert(Type { name: None, inner }, naga::Span::UNDEFINED)
    }
    fn vec_ty(&mut self, w: usize) -> naga::Handle<Type> {
        if w == 1 {
            self.ty(TypeInner::Scalar(Scalar::F32))
        } else {
            self.ty(TypeInner::Vector { size: size(w), scalar: Scalar::F32 })
        }
    }

    fn unsupported<T>(&self, what: impl Into<String>, at: Option<ir::Handle<Expr>>) -> R<T> {
        Err(GenError::Unsupported { what: what.into(), at: at.map(|h| self.m.span(h)) })
    }

    fn build(&mut self) -> R<()> {
        let pass = &self.planned.plan.passes[self.pass_index];
        let mesh = matches!(pass.geometry, Geometry::Mesh { .. });
        self.quad = !mesh || self.iface.position.is_none();
        self.globals()?;
        // The varyings struct.
        let vec4 = self.vec_ty(4);
        let mut members = vec![StructMember {
            name: Some("position".into()),
            ty: vec4,
            binding: Some(Binding::BuiltIn(BuiltIn::Position { invariant: false })),
            offset: 0,
        }];
        let loc = |location: u32| Binding::Location {
            location,
            interpolation: Some(Interpolation::Perspective),
            sampling: Some(Sampling::Center),
            blend_src: None,
            per_primitive: false,
        };
        let n_interp = self.iface.interpolants.len();
        for (k, h) in self.iface.interpolants.clone().iter().enumerate() {
            let name = self.value_name(*h).unwrap_or_else(|| format!("v{k}"));
            members.push(StructMember {
                name: Some(name),
                ty: vec4,
                binding: Some(loc(k as u32)),
                offset: 16 * (k as u32 + 1),
            });
        }
        if self.quad {
            members.push(StructMember {
                name: Some("texel_uv".into()),
                ty: vec4,
                binding: Some(loc(n_interp as u32)),
                offset: 16 * (n_interp as u32 + 1),
            });
        }
        let n_members = members.len() as u32;
        let vout = self.module.types.insert(
            Type {
                name: Some("VertexOutput".into()),
                inner: TypeInner::Struct { members, span: 16 * n_members },
            },
            naga::Span::UNDEFINED,
        );
        let vs = self.vertex(vout)?;
        let fs = self.fragment(vout)?;
        self.module.entry_points.push(EntryPoint {
            name: VERTEX_ENTRY.into(),
            stage: ShaderStage::Vertex,
            early_depth_test: None,
            workgroup_size: [0; 3],
            workgroup_size_overrides: None,
            function: vs,
            mesh_info: None,
            task_payload: None,
            incoming_ray_payload: None,
        });
        self.module.entry_points.push(EntryPoint {
            name: FRAGMENT_ENTRY.into(),
            stage: ShaderStage::Fragment,
            early_depth_test: None,
            workgroup_size: [0; 3],
            workgroup_size_overrides: None,
            function: fs,
            mesh_info: None,
            task_payload: None,
            incoming_ray_payload: None,
        });
        Ok(())
    }

    /// The name a value gets in the shader: its `let`, or a descriptive one.
    fn value_name(&self, h: ir::Handle<Expr>) -> Option<String> {
        if let Some(n) = self.names.get(&h) {
            return Some(n.clone());
        }
        let m = self.m;
        let n = match &m.exprs[h] {
            Expr::VertexPosition(v) => sanitize(m.vertices.get(*v as usize)?),
            Expr::TexCoord { set, .. } => sanitize(&m.texcoord_sets.get(*set as usize)?.name),
            Expr::Vector { vector, .. } => sanitize(&m.vectors.get(*vector as usize)?.name),
            Expr::Uniform(u) => sanitize(&m.uniforms.get(*u as usize)?.name),
            Expr::Interpolate { value, .. } => format!("{}_frag", self.value_name(*value)?),
            Expr::Project { projection, value } => {
                let p = if projection.inverse {
                    "pi_inv".to_string()
                } else {
                    format!(
                        "pi{}{}",
                        projection.subscript.as_deref().map(sanitize).unwrap_or_default(),
                        if projection.star { "_star" } else { "" }
                    )
                };
                format!("{p}_{}", self.value_name(*value)?)
            }
            Expr::Lookup { texture, .. } => {
                format!("{}_texel", sanitize(&m.textures.get(*texture as usize)?.name))
            }
            Expr::FramebufferRead { framebuffer, channel, .. } => {
                let c = match channel {
                    FbChannel::Color => "color",
                    FbChannel::Alpha => "alpha",
                    FbChannel::Depth => "depth",
                    FbChannel::Stencil => "stencil",
                };
                format!("{}_{c}", sanitize(&m.framebuffers.get(*framebuffer as usize)?.name))
            }
            Expr::Binary { op: BinaryOp::Dot, lhs, rhs } => {
                let (a, b) = (self.value_name(*lhs)?, self.value_name(*rhs)?);
                short(&a)?;
                short(&b)?;
                format!("{}_dot_{}", a.to_lowercase(), b.to_lowercase())
            }
            Expr::Math { fun: MathFunction::Normalize, args } => {
                format!("{}_unit", short(&self.value_name(args[0])?)?)
            }
            Expr::Math { fun: MathFunction::Expand, args } => {
                format!("{}_expanded", short(&self.value_name(args[0])?)?)
            }
            Expr::Binary { op: BinaryOp::Pow, lhs, .. } => format!("{}_pow", short(&self.value_name(*lhs)?)?),
            _ => return None,
        };
        Some(n)
    }

    fn globals(&mut self) -> R<()> {
        let mat4 = self.ty(TypeInner::Matrix {
            columns: VectorSize::Quad,
            rows: VectorSize::Quad,
            scalar: Scalar::F32,
        });
        let vec4 = self.vec_ty(4);
        let mut members = Vec::new();
        let mut offset = 0;
        for p in self.iface.projections.clone() {
            let name = if p.inverse {
                "pi_inv".to_string()
            } else {
                format!(
                    "pi{}{}",
                    p.subscript.as_deref().map(|s| format!("_{}", sanitize(s))).unwrap_or_default(),
                    if p.star { "_star" } else { "" }
                )
            };
            members.push(StructMember { name: Some(name), ty: mat4, binding: None, offset });
            offset += 64;
        }
        for u in self.iface.uniforms.clone() {
            let name = sanitize(&self.m.uniforms[u as usize].name);
            members.push(StructMember { name: Some(name), ty: vec4, binding: None, offset });
            offset += 16;
        }
        if !members.is_empty() {
            let ty = self.module.types.insert(
                Type { name: Some("Uniforms".into()), inner: TypeInner::Struct { members, span: offset } },
                naga::Span::UNDEFINED,
            );
            self.uniforms_var = Some(self.module.global_variables.append(
                GlobalVariable {
                    name: Some("uniforms".into()),
                    space: AddressSpace::Uniform,
                    binding: Some(ResourceBinding { group: 0, binding: 0 }),
                    ty,
                    init: None,
                    memory_decorations: Default::default(),
                },
                naga::Span::UNDEFINED,
            ));
        }
        let pass = &self.planned.plan.passes[self.pass_index];
        for t in &pass.textures {
            let node = self.planned.handle(t.lookup);
            let (kind, format, arrayed) = match self.m.exprs.arena().get(node) {
                Some(Expr::Lookup { texture, .. }) => {
                    let tex = &self.m.textures[*texture as usize];
                    let fat = self.fat[*texture as usize] > 0;
                    if fat && tex.kind != TextureKind::Tex2d {
                        return self.unsupported(
                            format!(
                                "a fat {} texture (fat texels are stored as the layers of a 2-D array)",
                                tex.kind.as_str()
                            ),
                            Some(node),
                        );
                    }
                    (tex.kind, Some(tex.format), fat)
                }
                Some(Expr::FramebufferRead { .. }) => (TextureKind::Tex2d, None, false),
                _ => return Err(GenError::Internal(format!("texture unit {} is not a lookup", t.unit))),
            };
            let dim = match kind {
                TextureKind::Tex1d | TextureKind::Tex2d => ImageDimension::D2,
                TextureKind::Tex3d => ImageDimension::D3,
                TextureKind::Cube => ImageDimension::Cube,
            };
            let ity = self.ty(TypeInner::Image {
                dim,
                arrayed,
                class: ImageClass::Sampled { kind: ScalarKind::Float, multi: false },
            });
            let sty = self.ty(TypeInner::Sampler { comparison: false });
            let name = sanitize(&t.texture);
            let tv = self.module.global_variables.append(
                GlobalVariable {
                    name: Some(name.clone()),
                    space: AddressSpace::Handle,
                    binding: Some(ResourceBinding { group: 0, binding: 1 + 2 * t.unit }),
                    ty: ity,
                    init: None,
                    memory_decorations: Default::default(),
                },
                naga::Span::UNDEFINED,
            );
            let sv = self.module.global_variables.append(
                GlobalVariable {
                    name: Some(format!("{name}_sampler")),
                    space: AddressSpace::Handle,
                    binding: Some(ResourceBinding { group: 0, binding: 2 + 2 * t.unit }),
                    ty: sty,
                    init: None,
                    memory_decorations: Default::default(),
                },
                naga::Span::UNDEFINED,
            );
            self.units.push((tv, sv, kind, format));
        }
        Ok(())
    }

    fn vertex(&mut self, vout: naga::Handle<Type>) -> R<Function> {
        let mut b = Body::new(VERTEX_ENTRY, Stage::Vertex);
        let vec4 = self.vec_ty(4);
        let leaves = self.iface.vertex_leaves.clone();
        for (i, leaf) in leaves.iter().enumerate() {
            let name = self.value_name(*leaf).unwrap_or_else(|| format!("in{i}"));
            b.f.arguments.push(FunctionArgument {
                name: Some(name),
                ty: vec4,
                binding: Some(location(i as u32)),
            });
            let arg = b.plain(Expression::FunctionArgument(i as u32));
            b.args.push(arg);
        }
        let quad = if self.quad {
            let i = leaves.len() as u32;
            b.f.arguments.push(FunctionArgument {
                name: Some("quad".into()),
                ty: vec4,
                binding: Some(location(i)),
            });
            Some(b.plain(Expression::FunctionArgument(i)))
        } else {
            None
        };
        // Per-vertex nodes, in topological order.
        let mut roots: Vec<ir::Handle<Expr>> = vec![];
        for h in &self.iface.interpolants {
            if let Expr::Interpolate { value, .. } = self.m.exprs[*h] {
                roots.push(value);
            }
        }
        roots.extend(self.iface.position);
        for n in self.m.reachable(&roots) {
            self.node(&mut b, n)?;
        }
        // The clip position.
        let clip = match (self.iface.position, quad) {
            (Some(p), _) if !self.quad => {
                let v = b.vals[&p];
                match self.m.info(p).ty {
                    Ty::Position => v,
                    Ty::Vec2 => texture_space_clip(&mut b, v, vec4),
                    t => {
                        return self
                            .unsupported(format!("a pass positioned by a {} value", t.name()), Some(p))
                    }
                }
            }
            (_, Some(q)) => q,
            _ => return Err(GenError::Internal("no clip position".into())),
        };
        let position = wgpu_clip(&mut b, clip, vec4);
        b.name(position, "clip_position");
        let mut comps = vec![position];
        for h in self.iface.interpolants.clone() {
            let Expr::Interpolate { value, .. } = self.m.exprs[h] else { unreachable!() };
            let v = b.vals[&value];
            let wv = self.widen_zero(&mut b, v, width(self.m.info(value).ty));
            comps.push(wv);
        }
        if let Some(q) = quad {
            comps.push(texel_uv(&mut b, q, vec4));
        }
        let out = b.emit(Expression::Compose { ty: vout, components: comps });
        b.f.body.push(Statement::Return { value: Some(out) }, naga::Span::UNDEFINED);
        b.f.result = Some(FunctionResult { ty: vout, binding: None });
        Ok(b.f)
    }

    /// Whether this pass renders into a texture held in half floats (a
    /// 16-bit or float format: `Rgba16Float` on wgpu, `ColorFormat::F16`
    /// on the CPU).
    fn renders_half_floats(&self) -> bool {
        self.planned.setup(self.pass_index).target.format == crate::pipeline::TargetFormat::Half
    }

    fn fragment(&mut self, vout: naga::Handle<Type>) -> R<Function> {
        let mut b = Body::new(FRAGMENT_ENTRY, Stage::Fragment);
        b.f.arguments.push(FunctionArgument { name: Some("input".into()), ty: vout, binding: None });
        let input = b.plain(Expression::FunctionArgument(0));
        let fc = b.emit(Expression::AccessIndex { base: input, index: 0 });
        b.frag_coord = Some(fc);
        for (k, h) in self.iface.interpolants.clone().into_iter().enumerate() {
            let v = b.emit(Expression::AccessIndex { base: input, index: k as u32 + 1 });
            let w = width(self.m.info(h).ty);
            let v = self.narrow(&mut b, v, 4, w);
            if let Some(n) = self.value_name(h) {
                b.name(v, &n);
            }
            b.vals.insert(h, v);
        }
        if self.quad {
            let uv4 = b.emit(Expression::AccessIndex {
                base: input,
                index: self.iface.interpolants.len() as u32 + 1,
            });
            let uv = self.narrow(&mut b, uv4, 4, 2);
            b.texel_uv = Some(uv);
        }
        let pass = &self.planned.plan.passes[self.pass_index];
        let stencil_only =
            matches!(&pass.target, RenderTarget::Framebuffer { channels, .. } if channels == "stencil");
        let vec4 = self.vec_ty(4);
        let out = if stencil_only {
            // The depth and stencil state do the work; no colour is written.
            self.combiners = None;
            b.plain(Expression::ZeroValue(vec4))
        } else if let Some(g) = self.combiners.clone() {
            self.fragment_combiners(&mut b, &g)?
        } else {
            let mut roots = vec![self.iface.output];
            roots.extend(self.iface.condition);
            let reach = ir::fragment_reach(self.m, &roots);
            self.address = ir::address_only(self.m, &reach);
            self.register_reads = ir::register_reads(self.m, &reach);
            self.pass_nodes = self.fragment_nodes(&roots);
            for n in self.pass_nodes.clone() {
                self.node(&mut b, n)?;
            }
            if let Some(c) = self.iface.condition {
                let cv = b.vals[&c];
                self.discard_unless(&mut b, cv);
            }
            let o = self.iface.output;
            let ty = self.m.info(o).ty;
            let v = if matches!(ty, Ty::Bundle(_)) { b.lit(0.0) } else { b.vals[&o] };
            match ty {
                Ty::Scalar => b.emit(Expression::Splat { size: VectorSize::Quad, value: v }),
                Ty::Vec2 => {
                    let zero = b.lit(0.0);
                    let one = b.lit(1.0);
                    b.emit(Expression::Compose { ty: vec4, components: vec![v, zero, one] })
                }
                Ty::Vec3 | Ty::Rgb => {
                    let one = b.lit(1.0);
                    b.emit(Expression::Compose { ty: vec4, components: vec![v, one] })
                }
                Ty::Rgba | Ty::Position => v,
                Ty::Bundle(_) => return self.fat_texel_output(b, o, vec4),
            }
        };
        let out = if self.renders_half_floats() { self.round_to_half(&mut b, out) } else { out };
        b.f.body.push(Statement::Return { value: Some(out) }, naga::Span::UNDEFINED);
        b.f.result = Some(FunctionResult { ty: vec4, binding: Some(location(0)) });
        Ok(b.f)
    }

    /// A fat texel (Pipeline Grammar, eq. (5), (15)): member i to colour attachment i
    /// — layer i of the fat texture — as rgb, alpha 1; the function's
    /// result is a struct of the members.
    fn fat_texel_output(
        &mut self,
        mut b: Body,
        o: ir::Handle<Expr>,
        vec4: naga::Handle<Type>,
    ) -> R<Function> {
        let Expr::Bundle(members) = self.m.exprs[o].clone() else {
            return Err(GenError::Internal("a bundle-typed value that is not a bundle".into()));
        };
        let mut comps = Vec::new();
        let mut fields = Vec::new();
        for (i, h) in members.iter().enumerate() {
            let v = b
                .vals
                .get(h)
                .copied()
                .ok_or_else(|| GenError::Internal(format!("member %{} not computed", h.index())))?;
            let one = b.lit(1.0);
            let c = match width(self.m.info(*h).ty) {
                3 => b.emit(Expression::Compose { ty: vec4, components: vec![v, one] }),
                w => self.widen_zero(&mut b, v, w),
            };
            let c = if self.renders_half_floats() { self.round_to_half(&mut b, c) } else { c };
            comps.push(c);
            let name = match &self.m.exprs[*h] {
                Expr::Interpolate { value, .. } => self.value_name(*value),
                _ => self.value_name(*h),
            }
            .unwrap_or_else(|| format!("member{i}"));
            fields.push(StructMember {
                name: Some(name),
                ty: vec4,
                binding: Some(location(i as u32)),
                offset: 16 * i as u32,
            });
        }
        let n = fields.len() as u32;
        let ty = self.module.types.insert(
            Type {
                name: Some("FatTexel".into()),
                inner: TypeInner::Struct { members: fields, span: 16 * n },
            },
            naga::Span::UNDEFINED,
        );
        let out = b.emit(Expression::Compose { ty, components: comps });
        b.f.body.push(Statement::Return { value: Some(out) }, naga::Span::UNDEFINED);
        b.f.result = Some(FunctionResult { ty, binding: None });
        self.outputs = n;
        Ok(b.f)
    }

    /// `--precision hardware` with a generated setup: the fragment stage
    /// computes, in f32, only what loads the registers — the texels of the
    /// units and the interpolated primary and secondary colours — rounds
    /// each to 8 bits as the machine's inputs are, and calls the setup as
    /// `rc1::combiners_function` writes it (i32 arithmetic, bit-exact with
    /// the emulator), already in the module (`combiners_module`). The result is widened as the CPU renderer's
    /// `fixed9` widens it (a scalar splatted, rgb with alpha 1).
    fn fragment_combiners(&mut self, b: &mut Body, g: &crate::backends::combiners::Generated) -> R<NH> {
        let pass = &self.planned.plan.passes[self.pass_index];
        let output = self.planned.handle(pass.fragment.output);
        // A depth texture's unit returns its comparison (ARB_shadow), as the CPU loads it.
        let unit = |h| crate::planner::shadow_map::compare_node(&self.planned.module, output, h).unwrap_or(h);
        let mut registers: Vec<Option<ir::Handle<Expr>>> =
            pass.textures.iter().map(|t| Some(unit(self.planned.handle(t.lookup)))).collect();
        registers.resize(4, None);
        registers.push(g.primary);
        registers.push(g.secondary);
        let unset = [g.config.constant0.is_none(), g.config.constant1.is_none()];
        let constants: Vec<Option<ir::Handle<Expr>>> =
            (0..2).map(|k| g.constants[k].filter(|_| unset[k])).collect();
        let mut roots: Vec<ir::Handle<Expr>> =
            registers.iter().chain(&constants).flatten().copied().collect();
        roots.extend(self.iface.condition);
        // The registers' sources in float, unrounded (as the CPU's fixed9 loads them).
        let precision = std::mem::replace(&mut self.precision, Precision::F32);
        self.pass_nodes = self.fragment_nodes(&roots);
        let built: R<()> = self.pass_nodes.clone().into_iter().try_for_each(|n| self.node(b, n));
        self.precision = precision;
        built?;
        if let Some(c) = self.iface.condition {
            let cv = b.vals[&c];
            self.discard_unless(b, cv);
        }
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
        for c in &constants {
            args.push(match c {
                Some(h) => as_rgba(self, b, *h),
                None => b.plain(Expression::ZeroValue(vec4)),
            });
        }
        args.push(b.plain(Expression::ZeroValue(vec4))); // fog
                                                         // The setup's function, parsed into the module before the pass was
                                                         // built on it (`combiners_module`).
        let f = self
            .module
            .functions
            .iter()
            .find(|(_, f)| f.name.as_deref() == Some(super::rc1::COMBINERS_FUNCTION))
            .map(|(h, _)| h)
            .ok_or_else(|| GenError::Internal("the module has no register-combiner function".into()))?;
        let result = b.plain(Expression::CallResult(f));
        b.f.body.push(
            Statement::Call { function: f, arguments: args, result: Some(result) },
            naga::Span::UNDEFINED,
        );
        b.name(result, "combiners");
        let ty = self.m.info(self.iface.output).ty;
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

    /// The nodes the fragment stage computes: reachable from `roots`, not
    /// looking under δ (the varyings), in topological order.
    fn fragment_nodes(&self, roots: &[ir::Handle<Expr>]) -> Vec<ir::Handle<Expr>> {
        let mut seen = BTreeSet::new();
        let mut stack = roots.to_vec();
        while let Some(n) = stack.pop() {
            if !seen.insert(n) {
                continue;
            }
            if !matches!(self.m.exprs[n], Expr::Interpolate { .. }) {
                stack.extend(self.m.operands(n));
            }
        }
        seen.into_iter().collect()
    }

    fn discard_unless(&mut self, b: &mut Body, cond: NH) {
        let fails = match b.bools.get(&cond) {
            Some(c) => b.emit(Expression::Unary { op: naga::UnaryOperator::LogicalNot, expr: *c }),
            None => {
                let zero = b.lit(0.0);
                b.emit(Expression::Binary { op: naga::BinaryOperator::Equal, left: cond, right: zero })
            }
        };
        let mut accept = naga::Block::new();
        accept.push(Statement::Kill, naga::Span::UNDEFINED);
        b.f.body.push(
            Statement::If { condition: fails, accept, reject: naga::Block::new() },
            naga::Span::UNDEFINED,
        );
    }

    /// `v` (width `from`) as width `to`: a scalar splats.
    fn splat(&mut self, b: &mut Body, v: NH, from: usize, to: usize) -> R<NH> {
        if from == to {
            Ok(v)
        } else if from == 1 {
            Ok(b.emit(Expression::Splat { size: size(to), value: v }))
        } else {
            Err(GenError::Internal(format!("cannot widen a {from}-vector to {to}")))
        }
    }

    /// The first `to` components of `v`.
    fn narrow(&mut self, b: &mut Body, v: NH, from: usize, to: usize) -> NH {
        if from == to {
            v
        } else if to == 1 {
            b.emit(Expression::AccessIndex { base: v, index: 0 })
        } else {
            b.emit(Expression::Swizzle { size: size(to), vector: v, pattern: COMP })
        }
    }

    /// `v` (width `w`) padded with zeros to a vec4.
    fn widen_zero(&mut self, b: &mut Body, v: NH, w: usize) -> NH {
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
    fn constant(&mut self, b: &mut Body, c: &ir::Constant, q: bool) -> NH {
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

    /// A register write in hardware precision: `q9(v)`.
    fn quantize(&mut self, b: &mut Body, v: NH, w: usize) -> NH {
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
    fn addresses_only(&self, n: ir::Handle<Expr>) -> bool {
        self.address.get(n.index()).copied().unwrap_or(false)
    }

    /// Whether node `n`, computed in the fragment stage (`sample`), is a
    /// register write of hardware precision: per fragment, not only an
    /// address (the CPU's `Step::quantize`).
    fn register_write(&self, n: ir::Handle<Expr>, sample: bool) -> bool {
        self.precision == Precision::Fixed9
            && sample
            && self.m.info(n).freq.is_sample()
            && !self.addresses_only(n)
    }

    /// `floor(v * 255 + 0.5) / 255`, unclamped (a folded constant register
    /// and its scale).
    fn fold(&mut self, b: &mut Body, v: NH, w: usize) -> R<NH> {
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
    fn quotient(&mut self, b: &mut Body, x: NH, y: NH, w: usize) -> NH {
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
    fn q9_function(&mut self, w: usize, quotient: bool) -> naga::Handle<Function> {
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
    fn round_to_half(&mut self, b: &mut Body, v: NH) -> NH {
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
    fn round_to_half_function(&mut self) -> naga::Handle<Function> {
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

    /// `normalize(x)` is undefined in WGSL for x = 0 (NaN on lavapipe); the
    /// IR defines it as the zero vector (`ir::eval`, docs/numerics.md:
    /// the half vector of L = −V, a zero-length interpolated normal), so
    /// the shader selects 0 where `dot(x, x)` is 0.
    fn zero_if_no_direction(&mut self, b: &mut Body, x: NH, unit: NH, w: usize) -> NH {
        let len2 = self.math(b, naga::MathFunction::Dot, &[x, x]);
        let zero = b.lit(0.0);
        let has_direction = self.binop(b, naga::BinaryOperator::Greater, len2, zero);
        let ty = self.vec_ty(w);
        let zero_vector = b.plain(Expression::ZeroValue(ty));
        b.emit(Expression::Select { condition: has_direction, accept: unit, reject: zero_vector })
    }

    fn binop(&mut self, b: &mut Body, op: naga::BinaryOperator, l: NH, r: NH) -> NH {
        b.emit(Expression::Binary { op, left: l, right: r })
    }

    fn math(&mut self, b: &mut Body, fun: naga::MathFunction, args: &[NH]) -> NH {
        b.emit(Expression::Math {
            fun,
            arg: args[0],
            arg1: args.get(1).copied(),
            arg2: args.get(2).copied(),
            arg3: None,
        })
    }

    /// A float from a boolean: 1.0 or 0.0.
    fn bool_to_float(&mut self, b: &mut Body, c: NH) -> NH {
        let one = b.lit(1.0);
        let zero = b.lit(0.0);
        let v = b.emit(Expression::Select { condition: c, accept: one, reject: zero });
        b.bools.insert(v, c);
        v
    }

    fn truthy(&mut self, b: &mut Body, v: NH) -> NH {
        if let Some(c) = b.bools.get(&v) {
            return *c;
        }
        let zero = b.lit(0.0);
        b.emit(Expression::Binary { op: naga::BinaryOperator::NotEqual, left: v, right: zero })
    }

    /// The alpha of a colour operand (1 for rgb, itself for a scalar).
    fn alpha_of(&mut self, b: &mut Body, v: NH, ty: Ty) -> NH {
        match ty {
            Ty::Rgba | Ty::Position => b.emit(Expression::AccessIndex { base: v, index: 3 }),
            Ty::Scalar => v,
            _ => b.lit(1.0),
        }
    }

    /// The colour channels of an operand as width `w` (≤ 3).
    fn color_of(&mut self, b: &mut Body, v: NH, ty: Ty, w: usize) -> R<NH> {
        let vw = width(ty);
        if vw == 1 {
            return self.splat(b, v, 1, w);
        }
        Ok(self.narrow(b, v, vw, w.min(vw)))
    }

    /// Computes node `n` in `b` (its operands are done), records it.
    fn node(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<()> {
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
    fn compute(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<Option<Computed>> {
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
                Computed::arith(self.combine(b, *mode, x, tx, y, ty, m.info(n).ty)?)
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
    fn width_of(&self, h: ir::Handle<Expr>) -> usize {
        width(self.m.info(h).ty)
    }

    /// A constant. In hardware precision one of magnitude ≤ 1 read per sample
    /// sits in a register: it is rounded, and so on the grid.
    fn constant_node(&mut self, b: &mut Body, n: ir::Handle<Expr>, c: &ir::Constant) -> Computed {
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
    fn uniform_value(&mut self, b: &mut Body, n: ir::Handle<Expr>, u: ir::UniformId) -> R<NH> {
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

    /// A per-vertex leaf (vertex position, texture coordinate, vector): its
    /// vertex input.
    fn vertex_input(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<NH> {
        let info = *self.m.info(n);
        if info.freq == Frequency::Texel {
            return self.unsupported("a shading vector as a function of the texel coordinate (texture shading, `s δu`): PassInterface binds per-vertex inputs only", Some(n));
        }
        if b.per_sample() {
            return Err(GenError::Internal(format!(
                "per-vertex value %{} read per sample without δ",
                n.index()
            )));
        }
        let i = self.iface.vertex_leaves.iter().position(|x| *x == n);
        let Some(i) = i else {
            return self.unsupported(
                format!("a {} shading value here (only per-vertex inputs are bound)", info.freq.name()),
                Some(n),
            );
        };
        let a = b.args[i];
        Ok(self.narrow(b, a, 4, width(info.ty)))
    }

    /// The pixel `xs` as a value (`π⁻¹ xs`, `xs.x`), built only if a node
    /// other than a read at the pixel uses it (those use the fragment's own
    /// coordinates).
    fn pixel_value(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<Option<NH>> {
        if !b.per_sample() {
            return self.unsupported("a pixel position per vertex", Some(n));
        }
        let m = self.m;
        let at_pixel = |e: &Expr| match e {
            Expr::FramebufferRead { position, .. } => *position == n,
            Expr::Lookup { coords, .. } => *coords == n,
            Expr::Depth(p) => *p == n && self.depth_is_fragments(n),
            _ => false,
        };
        if !self.pass_nodes.iter().any(|h| m.exprs[*h].operands().contains(&n) && !at_pixel(&m.exprs[*h])) {
            return Ok(None);
        }
        self.pixel_position(b, n).map(Some)
    }

    /// `π x`: a projection matrix times a position, or sphere-map texgen of
    /// a direction.
    fn project(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        projection: &ir::Projection,
        value: ir::Handle<Expr>,
    ) -> R<NH> {
        use naga::BinaryOperator as B;
        let x = b.val(value)?;
        match self.m.info(value).ty {
            Ty::Position => {
                let idx = self
                    .iface
                    .projections
                    .iter()
                    .position(|p| p == projection)
                    .ok_or_else(|| GenError::Internal("projection not in the interface".into()))?;
                let var = self
                    .uniforms_var
                    .ok_or_else(|| GenError::Internal("projection without a block".into()))?;
                let mat = b.load_member(var, idx as u32);
                Ok(self.binop(b, B::Multiply, mat, x))
            }
            Ty::Vec3 => Ok(self.sphere_map(b, x)),
            t => self.unsupported(format!("π of a {}", t.name()), Some(n)),
        }
    }

    /// Sphere-map texgen (Pipeline Grammar, eq. (7)): m = 2·sqrt(Rx² + Ry² + (Rz + 1)²),
    /// (s, t) = (Rx/m + ½, Ry/m + ½).
    fn sphere_map(&mut self, b: &mut Body, x: NH) -> NH {
        use naga::BinaryOperator as B;
        let one = b.lit(1.0);
        let zero = b.lit(0.0);
        let vec3 = self.vec_ty(3);
        let off = b.emit(Expression::Compose { ty: vec3, components: vec![zero, zero, one] });
        let r1 = self.binop(b, B::Add, x, off);
        let len = self.math(b, naga::MathFunction::Length, &[r1]);
        let two = b.lit(2.0);
        let mm = self.binop(b, B::Multiply, len, two);
        let xy = self.narrow(b, x, 3, 2);
        let d = self.binop(b, B::Divide, xy, mm);
        let half = b.lit(0.5);
        let h2 = b.emit(Expression::Splat { size: VectorSize::Bi, value: half });
        self.binop(b, B::Add, d, h2)
    }

    /// `z p`: the fragment's own depth, or the GL window depth `½ z/w + ½`
    /// of clip position `p`.
    fn depth(&mut self, b: &mut Body, p: ir::Handle<Expr>) -> R<NH> {
        use naga::BinaryOperator as B;
        if self.depth_is_fragments(p) {
            let fc = b.frag_coord.ok_or_else(|| GenError::Internal("no fragment position".into()))?;
            return Ok(b.emit(Expression::AccessIndex { base: fc, index: 2 }));
        }
        let pv = b.val(p)?;
        let z = b.emit(Expression::AccessIndex { base: pv, index: 2 });
        let ww = b.emit(Expression::AccessIndex { base: pv, index: 3 });
        let d = self.binop(b, B::Divide, z, ww);
        let half = b.lit(0.5);
        let d = self.binop(b, B::Multiply, d, half);
        Ok(self.binop(b, B::Add, d, half))
    }

    /// `T x`: the texture's unit sampled at `coords` (projectively for a 2D
    /// texture at a position). A fat texture whose members only are read is
    /// recorded in `b.fat` instead (`None`).
    fn lookup(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        texture: ir::TextureId,
        coords: ir::Handle<Expr>,
    ) -> R<Option<Computed>> {
        let m = self.m;
        let w = self.width_of(n);
        let sample = b.per_sample();
        let unit = self.unit_of(n)?;
        let (_, _, kind, format) = self.units[unit];
        let ct = m.info(coords).ty;
        let fat = self.fat[texture as usize] > 0;
        if matches!(m.exprs[coords], Expr::Pixel { .. }) {
            return self.lookup_at_pixel(b, n, unit, fat);
        }
        let c = b.val(coords)?;
        let coord = match (kind, ct) {
            (TextureKind::Tex1d, _) => {
                let half = b.lit(0.5);
                let vec2 = self.vec_ty(2);
                b.emit(Expression::Compose { ty: vec2, components: vec![c, half] })
            }
            (TextureKind::Tex2d, Ty::Position) => self.projective_uv(b, c),
            _ => c,
        };
        let level = if sample { naga::SampleLevel::Auto } else { naga::SampleLevel::Zero };
        if fat && !self.plain_use(n) {
            // Only its members are read (`Expr::FatMember`).
            b.fat.insert(n, (unit, coord, level));
            return Ok(None);
        }
        // A fat texture read as a colour: its first layer.
        let s = self.sample_unit(b, unit, coord, fat.then_some(0), level);
        let t = self.narrow(b, s, 4, w);
        if matches!(format, Some(TextureFormat::Signed8 | TextureFormat::Signed16)) {
            return Ok(Some(Computed::plain(self.expand(b, t, w))));
        }
        // A 2D 8-bit texture filters to 8-bit results in
        // hardware precision (`scene_run` uploads it as RGBA8).
        if self.precision == Precision::Fixed9
            && sample
            && kind != TextureKind::Cube
            && matches!(format, None | Some(TextureFormat::Rgba8 | TextureFormat::Rgb8 | TextureFormat::R8))
        {
            self.on_grid.insert(n);
        }
        Ok(Some(Computed::plain(t)))
    }

    /// `T xs` (Pipeline Grammar, eq. (6)): the texel under the pixel of a screen pass, at
    /// level 0 (a fat framebuffer is one texel per pixel).
    fn lookup_at_pixel(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        unit: usize,
        fat: bool,
    ) -> R<Option<Computed>> {
        let Some(uv) = b.texel_uv else {
            return self.unsupported("a lookup at the pixel outside a screen pass", Some(n));
        };
        if fat && !self.plain_use(n) {
            b.fat.insert(n, (unit, uv, naga::SampleLevel::Zero));
            return Ok(None);
        }
        let s = self.sample_unit(b, unit, uv, fat.then_some(0), naga::SampleLevel::Zero);
        let w = self.width_of(n);
        Ok(Some(Computed::plain(self.narrow(b, s, 4, w))))
    }

    /// Samples texture unit `unit` at `coordinate`, in array `layer` of a fat
    /// texture.
    fn sample_unit(
        &mut self,
        b: &mut Body,
        unit: usize,
        coordinate: NH,
        layer: Option<i32>,
        level: naga::SampleLevel,
    ) -> NH {
        let (tv, sv, _, _) = self.units[unit];
        let image = b.plain(Expression::GlobalVariable(tv));
        let sampler = b.plain(Expression::GlobalVariable(sv));
        let array_index = layer.map(|l| b.plain(Expression::Literal(Literal::I32(l))));
        b.sample(image, sampler, coordinate, array_index, level)
    }

    /// A framebuffer channel (`C`, `α C`, `z C`, stencil): loaded at the
    /// fragment's own pixel, else sampled at the projective coordinate.
    fn framebuffer_read(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        framebuffer: ir::FramebufferId,
        channel: FbChannel,
        position: ir::Handle<Expr>,
    ) -> R<NH> {
        let at_pixel =
            matches!(self.m.exprs[position], Expr::Pixel { .. }) || Some(position) == self.own_position;
        let (var, sv) = match self.unit_of(n) {
            Ok(unit) => {
                let (tv, sv, _, _) = self.units[unit];
                (tv, Some(sv))
            }
            Err(_) => (self.own_target_copy(n, framebuffer, channel, at_pixel)?, None),
        };
        let texel = if at_pixel {
            self.load_at_pixel(b, var)?
        } else {
            self.sample_framebuffer(b, var, sv, position, channel)?
        };
        Ok(self.framebuffer_channel(b, texel, channel))
    }

    /// The pass's own target, which blending did not absorb: a copy taken
    /// before the pass, read at the pixel.
    fn own_target_copy(
        &mut self,
        n: ir::Handle<Expr>,
        framebuffer: ir::FramebufferId,
        channel: FbChannel,
        at_pixel: bool,
    ) -> R<naga::Handle<GlobalVariable>> {
        let name = self.m.framebuffers[framebuffer as usize].name.clone();
        if !at_pixel {
            return self.unsupported(
                format!("reading the target framebuffer `{name}` away from the fragment's own pixel"),
                Some(n),
            );
        }
        if channel == FbChannel::Stencil {
            return self.unsupported(format!("reading the stencil of the target framebuffer `{name}` inside the shader (the stencil test can)"), Some(n));
        }
        Ok(self.target_copy(&name, channel == FbChannel::Depth))
    }

    /// A framebuffer sampled at projective `position`; outside it, its
    /// cleared values (colour 0, depth 1), as the CPU.
    fn sample_framebuffer(
        &mut self,
        b: &mut Body,
        var: naga::Handle<GlobalVariable>,
        sv: Option<naga::Handle<GlobalVariable>>,
        position: ir::Handle<Expr>,
        channel: FbChannel,
    ) -> R<NH> {
        let image = b.plain(Expression::GlobalVariable(var));
        let sv = sv.ok_or_else(|| GenError::Internal("a framebuffer read without a sampler".into()))?;
        let p = b.val(position)?;
        let uv = self.projective_uv(b, p);
        let sampler = b.plain(Expression::GlobalVariable(sv));
        let level = if b.per_sample() { naga::SampleLevel::Auto } else { naga::SampleLevel::Zero };
        let texel = b.sample(image, sampler, uv, None, level);
        let inside = self.inside_unit_square(b, uv);
        let clear = b.lit(if channel == FbChannel::Depth { 1.0 } else { 0.0 });
        let clear = b.emit(Expression::Splat { size: VectorSize::Quad, value: clear });
        Ok(b.emit(Expression::Select { condition: inside, accept: texel, reject: clear }))
    }

    /// Whether texture coordinate `uv` lies in the framebuffer (0..1 both).
    fn inside_unit_square(&mut self, b: &mut Body, uv: NH) -> NH {
        use naga::BinaryOperator as B;
        let (zero, one) = (b.lit(0.0), b.lit(1.0));
        let (zero2, one2) = (
            b.emit(Expression::Splat { size: VectorSize::Bi, value: zero }),
            b.emit(Expression::Splat { size: VectorSize::Bi, value: one }),
        );
        let above = self.binop(b, B::GreaterEqual, uv, zero2);
        let below = self.binop(b, B::LessEqual, uv, one2);
        let above = b.emit(Expression::Relational { fun: naga::RelationalFunction::All, argument: above });
        let below = b.emit(Expression::Relational { fun: naga::RelationalFunction::All, argument: below });
        self.binop(b, B::LogicalAnd, above, below)
    }

    /// The channel of a framebuffer texel: colour, alpha, depth (in `.x`),
    /// or the stencil value (`.x` as 0..255).
    fn framebuffer_channel(&mut self, b: &mut Body, texel: NH, channel: FbChannel) -> NH {
        match channel {
            FbChannel::Color => texel,
            FbChannel::Alpha => b.emit(Expression::AccessIndex { base: texel, index: 3 }),
            FbChannel::Depth => b.emit(Expression::AccessIndex { base: texel, index: 0 }),
            FbChannel::Stencil => {
                let r = b.emit(Expression::AccessIndex { base: texel, index: 0 });
                let k = b.lit(255.0);
                let s = self.binop(b, naga::BinaryOperator::Multiply, r, k);
                self.math(b, naga::MathFunction::Round, &[s])
            }
        }
    }

    /// Member `member` of the fat texel `texel`: layer `member`'s rgb, sampled
    /// where the fat lookup is.
    fn fat_member(
        &mut self,
        b: &mut Body,
        n: ir::Handle<Expr>,
        texel: ir::Handle<Expr>,
        member: u8,
    ) -> R<NH> {
        let Some(&(unit, coordinate, level)) = b.fat.get(&texel) else {
            return Err(GenError::Internal(format!(
                "fat member %{} of %{}, which is not a fat lookup here",
                n.index(),
                texel.index()
            )));
        };
        let s = self.sample_unit(b, unit, coordinate, Some(member as i32), level);
        let w = self.width_of(n);
        Ok(self.narrow(b, s, 4, w))
    }

    /// `−x` (arithmetic) or `!x` (1 where x is 0).
    fn unary(&mut self, b: &mut Body, op: UnaryOp, value: ir::Handle<Expr>) -> R<Computed> {
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
    fn binary(
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
    fn power(&mut self, b: &mut Body, n: ir::Handle<Expr>, x: NH, y: NH, wy: usize) -> R<Computed> {
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
                Ok(Computed::arith(self.math(b, naga::MathFunction::Pow, &[x, y])))
            }
        }
    }

    /// A comparison or logic operator, as 1.0 or 0.0.
    fn predicate(&mut self, b: &mut Body, op: BinaryOp, x: NH, y: NH) -> NH {
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
    fn math_call(
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
    fn range_mapping(&mut self, b: &mut Body, fun: MathFunction, x: NH, w: usize) -> R<NH> {
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
    fn swizzle(&mut self, b: &mut Body, value: ir::Handle<Expr>, pattern: &[u8; 4], len: u8) -> R<Computed> {
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
    fn compose(&mut self, b: &mut Body, n: ir::Handle<Expr>, components: &[ir::Handle<Expr>]) -> R<Computed> {
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
    fn convert(&mut self, b: &mut Body, n: ir::Handle<Expr>, value: ir::Handle<Expr>, to: Ty) -> R<Computed> {
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
    fn select(
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
    fn finish(&mut self, b: &mut Body, n: ir::Handle<Expr>, v: NH, w: usize, arith: bool) -> R<()> {
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

    fn expand(&mut self, b: &mut Body, x: NH, w: usize) -> NH {
        let two = b.lit(2.0);
        let d = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: x, right: two });
        let one = b.lit(1.0);
        let one = if w == 1 { one } else { b.emit(Expression::Splat { size: size(w), value: one }) };
        b.emit(Expression::Binary { op: naga::BinaryOperator::Subtract, left: d, right: one })
    }

    /// `(½ x/w + ½, ½ − ½ y/w)` of a clip-space position.
    fn projective_uv(&mut self, b: &mut Body, p: NH) -> NH {
        let x = b.emit(Expression::AccessIndex { base: p, index: 0 });
        let y = b.emit(Expression::AccessIndex { base: p, index: 1 });
        let w = b.emit(Expression::AccessIndex { base: p, index: 3 });
        let half = b.lit(0.5);
        let xw = self.binop(b, naga::BinaryOperator::Divide, x, w);
        let yw = self.binop(b, naga::BinaryOperator::Divide, y, w);
        let xh = self.binop(b, naga::BinaryOperator::Multiply, xw, half);
        let u = self.binop(b, naga::BinaryOperator::Add, xh, half);
        let yh = self.binop(b, naga::BinaryOperator::Multiply, yw, half);
        let v = self.binop(b, naga::BinaryOperator::Subtract, half, yh);
        let vec2 = self.vec_ty(2);
        b.emit(Expression::Compose { ty: vec2, components: vec![u, v] })
    }

    /// `textureLoad(var, pixel, 0)` at the fragment's pixel, once per texture.
    fn load_at_pixel(&mut self, b: &mut Body, var: naga::Handle<GlobalVariable>) -> R<NH> {
        if let Some(texel) = b.loads.get(&var) {
            return Ok(*texel);
        }
        let fc = b.frag_coord.ok_or_else(|| GenError::Internal("no fragment position".into()))?;
        let image = b.plain(Expression::GlobalVariable(var));
        let xy = self.narrow(b, fc, 4, 2);
        let ixy = b.emit(Expression::As { expr: xy, kind: ScalarKind::Sint, convert: Some(4) });
        let zero = b.plain(Expression::Literal(Literal::I32(0)));
        let texel = b.emit(Expression::ImageLoad {
            image,
            coordinate: ixy,
            array_index: None,
            sample: None,
            level: Some(zero),
        });
        b.loads.insert(var, texel);
        Ok(texel)
    }

    /// Whether `z p` is the fragment's own depth (`@builtin(position).z`):
    /// `p` is the pass's position or `δ xs`. The depth at a screen pass's
    /// pixel `xs` is the target's, from [`Self::pixel_position`].
    fn depth_is_fragments(&self, p: ir::Handle<Expr>) -> bool {
        matches!(self.m.exprs[p], Expr::Pixel { freq: Frequency::Fragment }) || Some(p) == self.own_position
    }

    /// Whether `lookup` (of a fat texture) is used as a colour, not only
    /// through its members.
    fn plain_use(&self, lookup: ir::Handle<Expr>) -> bool {
        self.iface.output == lookup
            || self.iface.condition == Some(lookup)
            || self.pass_nodes.iter().any(|h| {
                !matches!(self.m.exprs[*h], Expr::FatMember { .. })
                    && self.m.exprs[*h].operands().contains(&lookup)
            })
    }

    /// The global of the copy of the target framebuffer `name` (its depth,
    /// or colour) taken before the pass: `texture_2d<f32>` bound after the
    /// units' textures and samplers, read with `textureLoad`.
    fn target_copy(&mut self, name: &str, depth: bool) -> naga::Handle<GlobalVariable> {
        if let Some((_, var)) =
            self.target_copies.iter().find(|(c, _)| c.framebuffer == name && c.depth == depth)
        {
            return *var;
        }
        let binding = 1 + 2 * self.units.len() as u32 + self.target_copies.len() as u32;
        let ty = self.ty(TypeInner::Image {
            dim: ImageDimension::D2,
            arrayed: false,
            class: ImageClass::Sampled { kind: ScalarKind::Float, multi: false },
        });
        let var_name = format!("{}_{}before", sanitize(name), if depth { "depth_" } else { "" });
        let var = self.module.global_variables.append(
            GlobalVariable {
                name: Some(var_name),
                space: AddressSpace::Handle,
                binding: Some(ResourceBinding { group: 0, binding }),
                ty,
                init: None,
                memory_decorations: Default::default(),
            },
            naga::Span::UNDEFINED,
        );
        self.target_copies.push((TargetCopy { binding, framebuffer: name.to_string(), depth }, var));
        var
    }

    /// A pixel `xs` (`δ xs`) as a position, as the CPU renderer defines it:
    /// GL normalized device coordinates of the pixel's centre, the depth
    /// there — the target's (a copy taken before the pass) for `xs`, the
    /// fragment's for `δ xs` — mapped to −1..1, and w = 1; what `π⁻¹`
    /// takes back to model space (Pipeline Grammar, Section 3.5, shadow mask).
    fn pixel_position(&mut self, b: &mut Body, n: ir::Handle<Expr>) -> R<NH> {
        let Expr::Pixel { freq } = self.m.exprs[n] else {
            return Err(GenError::Internal(format!("%{} is not a pixel", n.index())));
        };
        let (Some(uv), Some(fc)) = (b.texel_uv, b.frag_coord) else {
            return self.unsupported("the position of a pixel outside a screen pass", Some(n));
        };
        use naga::BinaryOperator as B;
        let (one, two) = (b.lit(1.0), b.lit(2.0));
        let u = b.emit(Expression::AccessIndex { base: uv, index: 0 });
        let v = b.emit(Expression::AccessIndex { base: uv, index: 1 });
        let u2 = self.binop(b, B::Multiply, u, two);
        let x = self.binop(b, B::Subtract, u2, one);
        let v2 = self.binop(b, B::Multiply, v, two);
        let y = self.binop(b, B::Subtract, one, v2);
        let depth = if freq == Frequency::Screen {
            let target = match &self.planned.plan.passes[self.pass_index].target {
                RenderTarget::Framebuffer { name, .. } => Some(name.clone()),
                _ => None,
            };
            let with_depth = target
                .as_ref()
                .and_then(|t| self.m.framebuffers.iter().find(|f| f.name == *t))
                .is_some_and(|f| {
                    f.channels.is_empty()
                        || f.channels
                            .iter()
                            .any(|c| matches!(c, crate::parser::ast::FramebufferChannel::Depth))
                });
            match target {
                Some(t) if with_depth => {
                    let var = self.target_copy(&t, true);
                    let texel = self.load_at_pixel(b, var)?;
                    b.emit(Expression::AccessIndex { base: texel, index: 0 })
                }
                // No depth buffer: the far plane, as the CPU's cleared depth.
                _ => b.lit(1.0),
            }
        } else {
            b.emit(Expression::AccessIndex { base: fc, index: 2 })
        };
        let d2 = self.binop(b, B::Multiply, depth, two);
        let z = self.binop(b, B::Subtract, d2, one);
        let vec4 = self.vec_ty(4);
        let p = b.emit(Expression::Compose { ty: vec4, components: vec![x, y, z, one] });
        b.name(p, "pixel_position");
        Ok(p)
    }

    fn unit_of(&self, lookup: ir::Handle<Expr>) -> R<usize> {
        let pass = &self.planned.plan.passes[self.pass_index];
        pass.textures
            .iter()
            .position(|t| t.lookup as usize == lookup.index())
            .ok_or_else(|| GenError::Internal(format!("lookup %{} has no texture unit", lookup.index())))
    }

    /// `a ⊕[mode] b` (see the module doc).
    #[allow(clippy::too_many_arguments)]
    fn combine(&mut self, b: &mut Body, mode: CombineMode, x: NH, tx: Ty, y: NH, ty_y: Ty, out: Ty) -> R<NH> {
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
                    CombineMode::Replace => (ct, if tx == Ty::Rgba { at } else { af }),
                    CombineMode::Dot3Rgb | CombineMode::Dot3Rgba => {
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
                        let alpha = if mode == CombineMode::Dot3Rgba {
                            d
                        } else {
                            self.binop(b, B::Multiply, af, at)
                        };
                        (rgb, alpha)
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

fn short(s: &str) -> Option<&str> {
    (s.len() <= 12).then_some(s)
}

/// `q9` of a constant, in f32: clamp to [−1, 1], nearest k/255, ties up.
pub fn q9_value(v: f64) -> f32 {
    crate::numerics::fixed9(v) as f32
}

/// A frequency the backend treats as per sample.
#[allow(dead_code)]
fn is_sample(f: Frequency) -> bool {
    f.is_sample()
}

/// Rendering into a texture by its coordinates (Pipeline Grammar, eq. (13)): the clip
/// position (2u − 1, 1 − 2v, 0, 1).
fn texture_space_clip(b: &mut Body, v: NH, vec4: naga::Handle<Type>) -> NH {
    let u = b.emit(Expression::AccessIndex { base: v, index: 0 });
    let vv = b.emit(Expression::AccessIndex { base: v, index: 1 });
    let (two, one, zero) = (b.lit(2.0), b.lit(1.0), b.lit(0.0));
    let u2 = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: u, right: two });
    let x = b.emit(Expression::Binary { op: naga::BinaryOperator::Subtract, left: u2, right: one });
    let v2 = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: vv, right: two });
    let y = b.emit(Expression::Binary { op: naga::BinaryOperator::Subtract, left: one, right: v2 });
    b.emit(Expression::Compose { ty: vec4, components: vec![x, y, zero, one] })
}

/// GL clip z (−w..w) → wgpu (0..w): z′ = ½z + ½w.
fn wgpu_clip(b: &mut Body, clip: NH, vec4: naga::Handle<Type>) -> NH {
    let xy = b.emit(Expression::Swizzle {
        size: VectorSize::Bi,
        vector: clip,
        pattern: [COMP[0], COMP[1], COMP[0], COMP[0]],
    });
    let z = b.emit(Expression::AccessIndex { base: clip, index: 2 });
    let w = b.emit(Expression::AccessIndex { base: clip, index: 3 });
    let half = b.lit(0.5);
    let zw = b.emit(Expression::Binary { op: naga::BinaryOperator::Add, left: z, right: w });
    let z2 = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: zw, right: half });
    b.emit(Expression::Compose { ty: vec4, components: vec![xy, z2, w] })
}

/// A screen or texel pass's texture coordinate from its rectangle:
/// (½x + ½, ½ − ½y), v = 0 at the top row.
fn texel_uv(b: &mut Body, q: NH, vec4: naga::Handle<Type>) -> NH {
    let x = b.emit(Expression::AccessIndex { base: q, index: 0 });
    let y = b.emit(Expression::AccessIndex { base: q, index: 1 });
    let (half, zero) = (b.lit(0.5), b.lit(0.0));
    let xh = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: x, right: half });
    let u = b.emit(Expression::Binary { op: naga::BinaryOperator::Add, left: xh, right: half });
    let yh = b.emit(Expression::Binary { op: naga::BinaryOperator::Multiply, left: y, right: half });
    let v = b.emit(Expression::Binary { op: naga::BinaryOperator::Subtract, left: half, right: yh });
    b.emit(Expression::Compose { ty: vec4, components: vec![u, v, zero, zero] })
}

/// round(clamp(v, lo, 1) · 255) as integers: the register input of the
/// combiners (Kilgard 2000, Table 2) — `lo` = −1 for a texture register, which
/// holds a signed texel's sign, 0 for the colour registers — as the CPU's
/// fixed9 loads them.
fn register_input(b: &mut Body, v: NH, lo: f32) -> NH {
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

/// `@location(i)` with the default interpolation.
fn location(i: u32) -> Binding {
    Binding::Location {
        location: i,
        interpolation: None,
        sampling: None,
        blend_src: None,
        per_primitive: false,
    }
}
