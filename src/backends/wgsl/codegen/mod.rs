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

mod arith;
mod body;
mod depth;
mod fixed9;
mod interface;
mod names;
mod resources;
mod solid;
mod space;
mod texel;

use body::*;
use names::*;
use space::*;
pub use texel::SceneBindings;
use texel::UnitRead;

/// The name of every pass's vertex entry point.
pub const VERTEX_ENTRY: &str = "vs_main";
/// The name of every pass's fragment entry point.
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
    /// What the pass reads and writes, as the plan decided it.
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
    /// The shader, as naga IR.
    pub module: naga::Module,
    /// naga's validation of `module`, which the writers need.
    pub info: naga::valid::ModuleInfo,
}

/// A copy of the pass's target framebuffer, read by the shader at the
/// fragment's own pixel (`textureLoad`), bound at `binding` (group 0).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TargetCopy {
    /// The binding (group 0) of the copy.
    pub binding: u32,
    /// The framebuffer copied.
    pub framebuffer: String,
    /// The depth buffer (in `.x`), else the colour buffer.
    pub depth: bool,
    /// The stencil buffer instead, as s/255 in `.x` (`σ C xs` read in the
    /// shader, Pipeline Grammar, Section 3.5; `depth` is false).
    pub stencil: bool,
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
    generate_bound(planned, source, precision, &SceneBindings::default())
}

/// [`generate`] for a plan bound to a scene whose bindings change the
/// shader ([`SceneBindings`]: a scene's dual-paraboloid map in place of a
/// declared texture).
pub fn generate_bound(
    planned: &Planned,
    source: Option<&str>,
    precision: Precision,
    bindings: &SceneBindings,
) -> Result<Vec<PassShader>, Vec<Diagnostic>> {
    let names = source_names(planned, source);
    let mut out = Vec::new();
    let mut errors = Vec::new();
    for i in 0..planned.plan.passes.len() {
        match generate_pass(planned, i, (source, bindings), &names, precision) {
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
    (source, bindings): (Option<&str>, &SceneBindings),
    names: &HashMap<ir::Handle<Expr>, String>,
    precision: Precision,
) -> Result<PassShader, Diagnostic> {
    let pass = &planned.plan.passes[index];
    let span = planned.setup(index).span;
    let interface = PassInterface::of(planned, index);
    // A `bake` table is computed by the compiler, in float (issue 18).
    let precision = if pass.baked { Precision::F32 } else { precision };
    let mut g = Gen::new(planned, index, interface.clone(), names, precision);
    g.bindings = bindings.clone();
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
    let info = super::validate::validate(&module).map_err(|e| internal(span, &error_chain(&e)))?;
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
    /// Lookups of fat textures: (unit, coordinate, level, and whether the
    /// shader filters it, [`UnitRead::Float`]); their members are sampled
    /// by [`Expr::FatMember`].
    fat: HashMap<ir::Handle<Expr>, (usize, NH, naga::SampleLevel, bool)>,
    /// Texels loaded at the fragment's pixel, by texture ([`Gen::load_at_pixel`]).
    loads: HashMap<naga::Handle<GlobalVariable>, NH>,
    /// The boolean behind a 0/1 value (comparisons, logic), so that a
    /// condition uses it directly.
    bools: HashMap<NH, NH>,
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
    /// How each unit is read ([`UnitRead`]).
    unit_reads: Vec<UnitRead>,
    /// What the scene binds that changes the shader.
    bindings: SceneBindings,
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
            unit_reads: vec![],
            bindings: SceneBindings::default(),
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
