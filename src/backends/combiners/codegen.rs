//! IR → register-combiner configuration for one pass.
//!
//! The pass computes one per-fragment colour, `PassInput::value`, from the
//! texels its texture units fetch, the interpolated primary and secondary
//! colours, and constants. The generator covers the IR sub-DAG below `value`
//! with what Kilgard 2000, Section 4.2 and Appendix B offer, in three steps:
//!
//! 1. **Selection.** A tree-covering selector turns each node into a
//!    *source* (a register component read through one of the eight input
//!    mappings of Table 3: `expand` is `EXPAND_NORMAL`, `-x` a negate
//!    mapping, `1 − x` `UNSIGNED_INVERT`, `max(0, x)` / `saturate` an
//!    unsigned mapping, the scalars 0, 1, ±½, −1 are `zero` under a
//!    mapping) or, where a mapping is not enough, into a general-combiner
//!    *operation* (`A·B`, `A·B + C·D`, `A•B`, mux, with output scale and
//!    bias) whose result lives in a virtual register. The output value is
//!    covered by the final combiner (`A·B + (1 − A)·C + D`, `E·F`, `G`)
//!    where it can be: products of up to three non-negative factors
//!    (`A · EF`), `x⁴` as `EF · EF` (repeated squaring), lerps, sums of two.
//!    Constants and uniforms become *virtual constants*.
//! 2. **Scheduling.** Operations go, in dependency order, to the first
//!    general stage after their operands' in which the RGB or alpha portion
//!    they need is free (the two portions of a stage work in parallel) and,
//!    with per-stage constants, whose constant colours, with the
//!    operation's, are at most two.
//! 3. **Constant registers.** Without per-stage constants (geforce256) the
//!    pass has the two global ones (Kilgard 2000, B.3). With them (geforce3,
//!    NV_register_combiners2) each general stage has its own two and the
//!    final combiner reads the global two: see `Gen::assign_constants`.
//! 4. **Register allocation.** Virtual registers get `spare0`, `spare1`, or
//!    a texture/colour register whose own value is no longer read, by live
//!    interval; the mux's select value is pinned to `spare0.a`.
//!
//! docs/combiners.md, "Code generation", has the mapping table.

use std::collections::HashMap;

use thiserror::Error;

use crate::diag::Diagnostic;
use crate::ir::{BinaryOp, Constant, Expr, FbChannel, Handle, MathFunction, Module, Ty, UnaryOp};
use crate::parser::ast::CombineMode;
use crate::planner::{Realized, Realizer, Refusal};
use crate::span::Span;

use super::config::{
    Bias, Color, CombinerConfig, CombinerLimits, ComponentUsage, FinalCombiner, FinalInput, FinalSource,
    GeneralInput, GeneralPortion, GeneralStage, InputMapping, Register, Scale,
};
use super::validate::{validate, ValidationError};

use InputMapping::*;

/// The input mapping that reads the negation of what `map` reads (Table 3
/// pairs each signed mapping with its negate), if there is one.
fn negated(map: InputMapping) -> Option<InputMapping> {
    match map {
        SignedIdentity => Some(SignedNegate),
        SignedNegate => Some(SignedIdentity),
        ExpandNormal => Some(ExpandNegate),
        ExpandNegate => Some(ExpandNormal),
        HalfBiasNormal => Some(HalfBiasNegate),
        HalfBiasNegate => Some(HalfBiasNormal),
        _ => None,
    }
}

/// What one pass binds: texture unit `i` holds the per-fragment lookup node
/// `units[i]`; `value` is the fragment colour the pass outputs (rgb, rgba or
/// scalar: a scalar broadcasts to rgb; rgb and scalar outputs get alpha 1).
pub struct PassInput<'a> {
    pub module: &'a Module,
    pub value: Handle<Expr>,
    pub units: &'a [Handle<Expr>],
}

/// A generated configuration and what the caller must bind for it.
#[derive(Clone, Debug)]
pub struct Generated {
    pub config: CombinerConfig,
    /// The interpolated (`Interpolate`) IR node feeding the primary colour.
    pub primary: Option<Handle<Expr>>,
    /// The interpolated IR node feeding the secondary colour.
    pub secondary: Option<Handle<Expr>>,
    /// The constant or uniform IR node held by the global constant colours
    /// 0 and 1 (`config.constant0/1`). Without per-stage constants these are
    /// all the pass's constants. With them (geforce3), the global ones are
    /// what the final combiner reads, plus what general stages share when a
    /// pass needs more than two constants (see `stage_constants`); a stage
    /// that does not set its own constant reads the global one (nvparse's
    /// `SetUnusedLocalConsts`, the emulator's `Plan::new`). A uniform with
    /// no default leaves `config.constantN` unset: the caller supplies it
    /// (`emulator::Inputs::constant0/1`); such a uniform always goes to a
    /// global constant, never to a stage's own.
    pub constants: [Option<Handle<Expr>>; 2],
    /// Per general stage (`config.general[k]`): the node held by that
    /// stage's own constant 0 and 1 (`config.general[k].constant0/1`,
    /// NV_register_combiners2), `None` where the stage reads the global one.
    /// One entry per general stage; all `[None, None]` without per-stage
    /// constants, and when the pass reads no more than two constants (they
    /// are then all global, as on geforce256). The colours are in the config
    /// (always known: a stage's own constant is never a uniform the caller
    /// supplies). A constant the generator made is `None` here too, but its
    /// colour is set.
    pub stage_constants: Vec<[Option<Handle<Expr>>; 2]>,
    /// General combiner stages used (`config.general.len()`).
    pub stages: usize,
    /// Where each general-combiner operation went, by the source span of
    /// the value it computes: what the language server's hover shows for
    /// an expression. What no operation computes is a register
    /// input or the final combiner's work (Kilgard 2000, §4.2).
    pub placements: Vec<Placement>,
}

/// One general-combiner operation: the span of the value it computes, its
/// stage (0-based) and portion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    pub span: Span,
    pub stage: usize,
    pub alpha: bool,
}

#[derive(Clone, Debug, Error, PartialEq)]
pub enum CodegenError {
    /// An operation the register combiners cannot compute.
    #[error("{what} cannot be computed by the register combiners")]
    Unsupported { span: Span, what: String, help: String },
    /// An intermediate value outside the combiners' [−1, 1] range.
    #[error("{what} may leave [−1, 1], and the general combiners clamp every result to [−1, 1]")]
    Range { span: Span, what: String },
    /// More general combiner stages than the target has (the pass planner
    /// splits the pass).
    #[error("the pass needs {needed} general combiners, the target has {available}")]
    OutOfStages { needed: usize, available: usize },
    /// More distinct constant colours than a combiner can read: two for the
    /// whole pass without per-stage constants (Kilgard 2000, B.3), else two per
    /// general stage and two (the global ones) for the final combiner
    /// (NV_register_combiners2). `place` says which combiner, `constants`
    /// which constants compete (the last one did not fit); `span` is a node
    /// reading the last one.
    #[error("{place} needs more than {} constant colours: {}", if place.starts_with("the pass") { "the two" } else { "its two" }, list(constants))]
    OutOfConstants { span: Span, place: String, constants: Vec<String> },
    #[error("the pass needs more than the two interpolated colours (primary and secondary)")]
    OutOfColors { span: Span },
    #[error("the pass needs more registers than spare0, spare1 and the free texture registers")]
    OutOfRegisters { span: Span },
    /// A bug in the generator: the config it built breaks an Appendix B rule.
    #[error("internal error: the generated setup is invalid: {}", .0.first().map(ToString::to_string).unwrap_or_default())]
    Invalid(Vec<ValidationError>),
}

/// `a`, `a and b`, `a, b and c`.
fn list(items: &[String]) -> String {
    match items {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    }
}

impl CodegenError {
    pub fn span(&self) -> Option<Span> {
        match self {
            CodegenError::Unsupported { span, .. }
            | CodegenError::Range { span, .. }
            | CodegenError::OutOfConstants { span, .. }
            | CodegenError::OutOfColors { span }
            | CodegenError::OutOfRegisters { span } => Some(*span),
            _ => None,
        }
    }

    pub fn help(&self) -> String {
        match self {
            CodegenError::Unsupported { help, .. } => help.clone(),
            CodegenError::Range { .. } => "clamp it with `saturate(…)` where the clamp is intended, or rescale it into [−1, 1] (Kilgard 2000, Section 4.2.2)".into(),
            CodegenError::OutOfStages { .. } => "split the pass: blend partial results in the framebuffer, or target a profile with more general combiners".into(),
            CodegenError::OutOfConstants { .. } => "fold constants together, or split the pass (a target with per-stage constants, NV_register_combiners2, gives every general combiner two of its own)".into(),
            CodegenError::OutOfColors { .. } => "pass further per-vertex values as texture coordinates (a lookup texture), or split the pass".into(),
            CodegenError::OutOfRegisters { .. } => "split the pass".into(),
            CodegenError::Invalid(_) => "please report this".into(),
        }
    }

    pub fn code(&self) -> &'static str {
        match self {
            CodegenError::Unsupported { .. } => "combiner-unsupported",
            CodegenError::Range { .. } => "combiner-range",
            CodegenError::OutOfStages { .. } => "combiner-stages",
            CodegenError::OutOfConstants { .. } => "combiner-constants",
            CodegenError::OutOfColors { .. } => "combiner-colors",
            CodegenError::OutOfRegisters { .. } => "combiner-registers",
            CodegenError::Invalid(_) => "combiner-internal",
        }
    }

    pub fn to_diagnostic(&self) -> Diagnostic {
        let span = self.span().unwrap_or(Span::DETACHED);
        Diagnostic::error(self.code(), self.to_string(), span, "here").with_help(self.help())
    }
}

// ---------------------------------------------------------------------------
// Selection data.

/// Which part of a value: the rgb (or vec3, or scalar) part, or the alpha of
/// an rgba value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Part {
    Rgb,
    Alpha,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Base {
    Reg(Register),
    /// A virtual register: the result of operation `ops[vregs[i].op]`.
    V(usize),
    /// A virtual constant colour, `konsts[i]`: which constant register
    /// holds it is decided after scheduling (`assign_constants`), per stage
    /// where the target has per-stage constants.
    K(usize),
}

/// Which components a source reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Comp {
    /// An rgb vector.
    Rgb,
    /// A scalar held in all three rgb components (a dot product, a scalar
    /// computed in an RGB portion): read as rgb, or as blue in an alpha portion.
    Bcast,
    Alpha,
    /// The blue component (alpha portions only; elsewhere copied to alpha).
    Blue,
}

/// A value a combiner variable can read: `map(comp(base))`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Src {
    base: Base,
    comp: Comp,
    map: InputMapping,
}

impl Src {
    fn zero_mapped(map: InputMapping) -> Src {
        Src { base: Base::Reg(Register::Zero), comp: Comp::Alpha, map }
    }
    const ZERO: Src = Src { base: Base::Reg(Register::Zero), comp: Comp::Alpha, map: UnsignedIdentity };
    const ONE: Src = Src { base: Base::Reg(Register::Zero), comp: Comp::Alpha, map: UnsignedInvert };
}

/// One product (or dot product) of a portion.
#[derive(Clone, Copy, Debug)]
struct Term {
    a: Src,
    b: Src,
    dot: bool,
}

impl Term {
    fn times_one(a: Src) -> Term {
        Term { a, b: Src::ONE, dot: false }
    }
}

/// A portion's computation before it has a stage and registers.
#[derive(Clone, Copy, Debug)]
struct Spec {
    ab: Term,
    cd: Option<Term>,
    /// Mux on this select value (placed in spare0.a) instead of AB + CD.
    mux: Option<Src>,
    scale: Scale,
    bias: Bias,
    /// The result is one number (may live in either portion).
    scalar: bool,
    /// An alpha part must be computed in the alpha portion.
    alpha_only: bool,
}

impl Spec {
    fn single(ab: Term, scalar: bool) -> Spec {
        Spec { ab, cd: None, mux: None, scale: Scale::One, bias: Bias::Zero, scalar, alpha_only: false }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Lane {
    Rgb,
    Alpha,
}

#[derive(Clone, Debug)]
struct Op {
    lane: Lane,
    ab: Term,
    cd: Option<Term>,
    mux: Option<Src>,
    scale: Scale,
    bias: Bias,
    out: usize,
    stage: usize,
    /// The operation is one product in the CD half of a portion whose AB
    /// half holds another (two independent products or dot products of one
    /// portion, each to its own output: Appendix B.4, Table 4).
    in_cd: bool,
    span: Span,
}

/// What a general combiner portion (RGB or alpha of one stage) holds so far.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Portion {
    Free,
    /// Operation `ops[i]`, a single product in AB: its CD half can take
    /// another independent product with the same output scale and bias.
    Ab(usize),
    Full,
}

#[derive(Clone, Debug)]
struct VReg {
    lane: Lane,
    op: usize,
    pin: Option<Register>,
    reg: Option<Register>,
}

/// What a final-combiner variable reads before registers are known.
#[derive(Clone, Copy, Debug)]
enum FinalVal {
    Src(Src),
    Ef,
}

/// A constant colour before it has a register: a folded constant or a
/// uniform, with the colour the register holds (magnitudes: a negative
/// constant is read through `signed_negate`).
#[derive(Clone, Debug)]
struct VConst {
    color: Color,
    node: Handle<Expr>,
    /// The colour is known (a constant, or a uniform's default); otherwise
    /// the caller supplies it, which it can only do for the global constants.
    known: bool,
}

/// Where the constants went: the global `constant0/1` (read by the final
/// combiner, and by every stage that does not set its own) and each general
/// stage's own (NV_register_combiners2; `None`: the stage reads the global).
#[derive(Clone, Debug, Default)]
struct ConstAssignment {
    global: [Option<usize>; 2],
    local: Vec<[Option<usize>; 2]>,
}

struct FinalSpec {
    a: FinalVal,
    b: FinalVal,
    c: FinalVal,
    d: FinalVal,
    e: Src,
    f: Src,
    g: Src,
}

struct Gen<'a> {
    m: &'a Module,
    units: &'a [Handle<Expr>],
    limits: CombinerLimits,
    ops: Vec<Op>,
    vregs: Vec<VReg>,
    stage_used: Vec<[Portion; 2]>,
    /// Whether an independent product may take a portion's free CD half.
    pairing: bool,
    cache: HashMap<(Handle<Expr>, Part), Src>,
    pow_cache: HashMap<(Handle<Expr>, Part, u32), Src>,
    /// Every constant colour the pass reads, in order of first use.
    konsts: Vec<VConst>,
    /// Per general stage: the constants its operations read (at most two
    /// with per-stage constants; the scheduler keeps it so).
    stage_konsts: Vec<Vec<usize>>,
    /// Constants the final combiner reads (through `final_read`).
    final_konsts: Vec<usize>,
    assigned: ConstAssignment,
    colors: [Option<Handle<Expr>>; 2],
    span: Span,
}

type R<T> = Result<T, CodegenError>;

/// Generates the register-combiner configuration for one pass.
pub fn generate(input: &PassInput, limits: &CombinerLimits) -> Result<Generated, CodegenError> {
    // A depth-only statement (`Cl δπl x ← δ x`, seeds/001 Section 3.5: the
    // light's depth map, the rasterizer's depth of the position) writes no
    // colour: the setup that writes zero.
    let depth_only = matches!(input.module.exprs[input.value], Expr::Depth(_))
        || input.module.info(input.value).ty == crate::ir::Ty::Position;
    if depth_only {
        let mut m = input.module.clone();
        let zero = crate::ir::Constant::new(crate::ir::Ty::Rgba, &[0.0; 4]);
        let span = m.span(input.value);
        let value = m
            .intern(Expr::Constant(zero), span)
            .map_err(|_| unsupported(span, "this value", "a depth-only pass"))?;
        return generate(&PassInput { module: &m, value, units: &[] }, limits);
    }
    // Two products in one portion save stages but hold two results at once:
    // where that runs out of registers, the unpaired schedule may still fit.
    // Other refusals (range, unsupported operations, constants, stages) do
    // not depend on pairing, so the planner's many refused values are
    // generated once, not twice.
    match generate_with(input, limits, true) {
        Err(CodegenError::OutOfRegisters { .. } | CodegenError::Invalid(_)) => {
            generate_with(input, limits, false)
        }
        r => r,
    }
}

/// [`generate`], with independent products paired in one portion (AB and
/// CD to two outputs) or not.
fn generate_with(
    input: &PassInput,
    limits: &CombinerLimits,
    pairing: bool,
) -> Result<Generated, CodegenError> {
    let original = input.module.exprs.len();
    let desugared = desugar(input.module, input.value)?;
    let (m, value) = match &desugared {
        Some((m, v)) => (m, *v),
        None => (input.module, input.value),
    };
    let span = m.span(value);
    if input.units.len() > usize::from(limits.texture_units.min(4)) {
        return Err(CodegenError::Unsupported {
            span,
            what: format!("a pass with {} texture units", input.units.len()),
            help: format!("the target has {} texture units: split the pass", limits.texture_units),
        });
    }
    let mut g = Gen {
        m,
        units: input.units,
        limits: *limits,
        ops: Vec::new(),
        vregs: Vec::new(),
        stage_used: Vec::new(),
        pairing,
        cache: HashMap::new(),
        pow_cache: HashMap::new(),
        konsts: Vec::new(),
        stage_konsts: Vec::new(),
        final_konsts: Vec::new(),
        assigned: ConstAssignment::default(),
        colors: [None, None],
        span,
    };
    let fin = g.final_combiner(value)?;
    let stages = g.stage_used.len();
    if stages > limits.general_combiners {
        return Err(CodegenError::OutOfStages { needed: stages, available: limits.general_combiners });
    }
    g.assign_constants(&fin)?;
    g.allocate(&fin)?;
    let config = g.build(&fin);
    validate(&config, limits).map_err(CodegenError::Invalid)?;
    Ok(Generated {
        config,
        primary: g.colors[0],
        secondary: g.colors[1],
        // A constant the generator made (folded, or from a desugared ⊕) is
        // not a node of the caller's module; its colour is in the config.
        constants: g.assigned.global.map(|k| k.map(|k| g.konsts[k].node).filter(|h| h.index() < original)),
        stage_constants: g
            .assigned
            .local
            .iter()
            .map(|l| l.map(|k| k.map(|k| g.konsts[k].node).filter(|h| h.index() < original)))
            .collect(),
        stages,
        placements: g
            .ops
            .iter()
            .map(|op| Placement { span: op.span, stage: op.stage, alpha: op.lane == Lane::Alpha })
            .collect(),
    })
}

/// Rewrites the per-sample `⊕` nodes below `value` into the arithmetic they
/// stand for (`crate::ir::eval::combine`, the OpenGL 1.2.1 texture
/// environment of Pipeline Grammar, Section 3.6), so that the selector sees
/// products, sums, lerps and dot products. `None` when there is no `⊕`.
/// The rewritten nodes are appended to a copy of the module: every handle
/// of the original (lookups, interpolants, uniforms) keeps its meaning.
fn desugar(module: &Module, value: Handle<Expr>) -> R<Option<(Module, Handle<Expr>)>> {
    let reach = module.reachable(&[value]);
    let is_combine = |h: &Handle<Expr>| {
        matches!(module.exprs[*h], Expr::Combine { .. }) && module.info(*h).freq.is_sample()
    };
    let floats_a_scale = |h: &Handle<Expr>| {
        module.info(*h).freq.is_sample() && scale_to_float(module, &module.exprs[*h]).is_some()
    };
    if !reach.iter().any(|h| is_combine(h) || floats_a_scale(h)) {
        return Ok(None);
    }
    let mut m = module.clone();
    let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::new();
    for h in reach {
        let e = module.exprs[h].clone();
        // Leaves for the combiners: texture units, interpolants, per-object values.
        if !module.info(h).freq.is_sample()
            || matches!(e, Expr::Lookup { .. } | Expr::FramebufferRead { .. } | Expr::Interpolate { .. })
        {
            continue;
        }
        let span = module.span(h);
        let e = e.map_operands(|o| map.get(&o).copied().unwrap_or(o));
        let new = match e {
            Expr::Combine { mode, lhs, rhs } => match scaled_modulate(&m, mode, lhs, rhs) {
                // `(k·y) ⊕ z`: the scale is the stage's output mapping, applied
                // after the product and clamped there, as the hardware does
                // (seeds/003 Section 4.2.2) — not `saturate(k·y)·z`.
                Some((k, y, z)) => {
                    let (y, z) = (gl_colour(&mut m, y, span)?, gl_colour(&mut m, z, span)?);
                    let inner = intern(&mut m, Expr::Binary { op: BinaryOp::Mul, lhs: y, rhs: z }, span)?;
                    intern(&mut m, Expr::Binary { op: BinaryOp::Mul, lhs: k, rhs: inner }, span)?
                }
                None => {
                    let Expr::Combine { lhs: t, rhs: f, .. } = module.exprs[h] else { unreachable!("a ⊕") };
                    let clamped = [t, f].map(|o| !written_arithmetic(module, o));
                    let result = combine_expr(&mut m, mode, [lhs, rhs], clamped, module.info(h).ty, span)?;
                    // GL clamps a texture-environment result to [0, 1]
                    // (§3.8.9): where arithmetic reads it (`T + (T ⊕[dot3] I)`),
                    // the combiners read it clamped too. The pass's own
                    // value is clamped by the output.
                    if h == value {
                        result
                    } else {
                        gl_colour(&mut m, result, span)?
                    }
                }
            },
            e => match scale_to_float(&m, &e) {
                Some((k, y, z)) => {
                    let inner = intern(&mut m, Expr::Binary { op: BinaryOp::Mul, lhs: y, rhs: z }, span)?;
                    intern(&mut m, Expr::Binary { op: BinaryOp::Mul, lhs: k, rhs: inner }, span)?
                }
                None => intern(&mut m, e, span)?,
            },
        };
        if new != h {
            map.insert(h, new);
        }
    }
    let v = map.get(&value).copied().unwrap_or(value);
    Ok(Some((m, v)))
}

/// `(k · y) · z` or `z · (k · y)` with `k` an output scale (½, 2, 4, 8):
/// `(k, y, z)`, to be rewritten `k · (y · z)` so that the scale lands on the
/// stage's output mapping whatever the order written (Kilgard 2000, Section
/// 4.2.2: scale_by_two() applies to a stage's output, so
/// `2 * L * B` maps as `L * B * 2` does).
fn scale_to_float(m: &Module, e: &Expr) -> Option<(Handle<Expr>, Handle<Expr>, Handle<Expr>)> {
    let Expr::Binary { op: BinaryOp::Mul, lhs, rhs } = *e else { return None };
    let scale = |h: Handle<Expr>| matches!(&m.exprs[h], Expr::Constant(c) if { let v = c.values(); !v.is_empty() && v.iter().all(|x| *x == v[0]) && [0.5, 2.0, 4.0, 8.0].contains(&v[0]) });
    let scaled = |h: Handle<Expr>| match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Mul, lhs: a, rhs: b } if scale(a) && !scale(b) => Some((a, b)),
        Expr::Binary { op: BinaryOp::Mul, lhs: a, rhs: b } if scale(b) && !scale(a) => Some((b, a)),
        _ => None,
    };
    if scale(lhs) || scale(rhs) {
        return None;
    }
    scaled(lhs).map(|(k, y)| (k, y, rhs)).or_else(|| scaled(rhs).map(|(k, y)| (k, y, lhs)))
}

/// `(k · y) ⊕ z` or `z ⊕ (k · y)` in modulate mode, `k` an output scale and
/// `y` a colour in [0, 1]: `(k, y, z)`.
fn scaled_modulate(
    m: &Module,
    mode: CombineMode,
    lhs: Handle<Expr>,
    rhs: Handle<Expr>,
) -> Option<(Handle<Expr>, Handle<Expr>, Handle<Expr>)> {
    if mode != CombineMode::Modulate {
        return None;
    }
    let (k, y, z) = scale_to_float(m, &Expr::Binary { op: BinaryOp::Mul, lhs, rhs })?;
    let i = m.info(y).interval;
    (i.lo >= 0.0 && i.hi <= 1.0).then_some((k, y, z))
}

/// Whether the `⊕` operand `o` is arithmetic the program writes (`T + T`,
/// `k · x`), not a colour GL hands the texture environment (a texel, an
/// interpolated colour, the framebuffer, another `⊕`'s result): the
/// program means its value unclamped, and the combiners compute it so
/// (registers hold [−1, 1], the sums reordered to stay there).
fn written_arithmetic(m: &Module, o: Handle<Expr>) -> bool {
    m.info(o).freq.is_sample() && matches!(m.exprs[o], Expr::Binary { .. } | Expr::Unary { .. })
}

/// `h` clamped to [0, 1] where its range leaves it (see [`combine_expr`]).
fn gl_colour(m: &mut Module, h: Handle<Expr>, span: Span) -> R<Handle<Expr>> {
    let i = m.info(h).interval;
    if i.lo >= 0.0 && i.hi <= 1.0 {
        return Ok(h);
    }
    intern(m, Expr::Math { fun: MathFunction::Saturate, args: vec![h] }, span)
}

fn intern(m: &mut Module, e: Expr, span: Span) -> R<Handle<Expr>> {
    m.intern(e, span).map_err(|t| {
        unsupported(
            span,
            format!("this value ({})", t.message),
            "please report this: rewriting ⊕ for the combiners failed",
        )
    })
}

/// `t ⊕[mode] f` of type `ty` as IR arithmetic: `crate::ir::eval::combine`
/// node for node (TEXTURE_ENV_COLOR is 0, so `blend` is f·(1 − t)).
///
/// Each operand enters as GL gives it to the texture environment or the
/// blender: a colour in [0, 1] (OpenGL 1.2.1 Sections 2.13.6 and 4.1.7:
/// fragment colours are clamped, texels and fixed-point framebuffer values
/// are in range). Such an operand (`clamped`) whose range leaves [0, 1] is
/// therefore `saturate`d here — what the as-written plan does on the
/// hardware, where the operand is the fragment colour a blend clamps
/// (Kilgard's `C ⊕ rgba(diffuse, s_self)`, `diffuse` in [0.1, 1.1], fused
/// into one pass). Arithmetic written as an operand (`(T + T) ⊕ T`) is
/// not a colour GL clamps: it keeps its value ([`written_arithmetic`]).
/// The IR itself keeps ⊕ unclamped (docs/language.md).
fn combine_expr(
    m: &mut Module,
    mode: CombineMode,
    [t, f]: [Handle<Expr>; 2],
    clamped: [bool; 2],
    ty: Ty,
    span: Span,
) -> R<Handle<Expr>> {
    let bin = |m: &mut Module, op: BinaryOp, lhs: Handle<Expr>, rhs: Handle<Expr>| {
        intern(m, Expr::Binary { op, lhs, rhs }, span)
    };
    let konst = |m: &mut Module, v: f64| intern(m, Expr::Constant(Constant::scalar(v)), span);
    let lhs_rgb = matches!(m.exprs[t], Expr::Convert { value, to: Ty::Rgba } if m.info(value).ty == Ty::Rgb);
    let colour = |m: &mut Module, h, clamped| if clamped { gl_colour(m, h, span) } else { Ok(h) };
    let (t, f) = (colour(m, t, clamped[0])?, colour(m, f, clamped[1])?);
    let rgba = ty == Ty::Rgba;
    // Component selections of a value (a scalar operand splats).
    let rgb_of = |m: &mut Module, h: Handle<Expr>| -> R<Handle<Expr>> {
        match m.info(h).ty {
            Ty::Rgba => {
                intern(m, Expr::Swizzle { value: h, pattern: [0, 1, 2, 0], len: 3, ty: Ty::Rgb }, span)
            }
            _ => Ok(h),
        }
    };
    let alpha_of = |m: &mut Module, h: Handle<Expr>| -> R<Handle<Expr>> {
        match m.info(h).ty {
            Ty::Rgba => {
                intern(m, Expr::Swizzle { value: h, pattern: [3, 0, 0, 0], len: 1, ty: Ty::Scalar }, span)
            }
            Ty::Scalar => Ok(h),
            _ => konst(m, 1.0),
        }
    };
    let compose = |m: &mut Module, c: Handle<Expr>, a: Handle<Expr>| {
        intern(m, Expr::Compose { ty: Ty::Rgba, components: vec![c, a] }, span)
    };
    Ok(match mode {
        CombineMode::Modulate => bin(m, BinaryOp::Mul, t, f)?,
        CombineMode::Add => bin(m, BinaryOp::Add, t, f)?,
        CombineMode::Subtract => bin(m, BinaryOp::Sub, t, f)?,
        CombineMode::AddSigned => {
            let sum = bin(m, BinaryOp::Add, t, f)?;
            intern(m, Expr::Math { fun: MathFunction::HalfBias, args: vec![sum] }, span)?
        }
        // Without alpha, At = 1: decal, replace and interpolate give t.
        CombineMode::Decal | CombineMode::Replace | CombineMode::Interpolate if !rgba => t,
        // rgb = f·(1 − At) + t·At, alpha = Af.
        CombineMode::Decal => {
            let (tc, fc, fa) = (rgb_of(m, t)?, rgb_of(m, f)?, alpha_of(m, f)?);
            let c = if lhs_rgb {
                tc
            } else {
                let at = alpha_of(m, t)?;
                intern(m, Expr::Math { fun: MathFunction::Mix, args: vec![fc, tc, at] }, span)?
            };
            compose(m, c, fa)?
        }
        CombineMode::Replace => {
            let tc = rgb_of(m, t)?;
            let a = if lhs_rgb { alpha_of(m, f)? } else { alpha_of(m, t)? };
            compose(m, tc, a)?
        }
        CombineMode::Interpolate => {
            let at = alpha_of(m, t)?;
            intern(m, Expr::Math { fun: MathFunction::Mix, args: vec![f, t, at] }, span)?
        }
        // rgb = f·(1 − t) (+ Cc·t, Cc = 0), alpha = At·Af.
        CombineMode::Blend => {
            let one = konst(m, 1.0)?;
            let (tc, fc) = (rgb_of(m, t)?, rgb_of(m, f)?);
            let inv = bin(m, BinaryOp::Sub, one, tc)?;
            let c = bin(m, BinaryOp::Mul, fc, inv)?;
            if rgba {
                let (ta, fa) = (alpha_of(m, t)?, alpha_of(m, f)?);
                let a = bin(m, BinaryOp::Mul, ta, fa)?;
                compose(m, c, a)?
            } else {
                c
            }
        }
        // 4·Σ(t − ½)(f − ½) = expand(t)·expand(f), on every channel (dot3_rgba)
        // or rgb with alpha At·Af (dot3_rgb).
        CombineMode::Dot3Rgb | CombineMode::Dot3Rgba => {
            let (tc, fc) = (rgb_of(m, t)?, rgb_of(m, f)?);
            let et = intern(m, Expr::Math { fun: MathFunction::Expand, args: vec![tc] }, span)?;
            let ef = intern(m, Expr::Math { fun: MathFunction::Expand, args: vec![fc] }, span)?;
            let op = if m.info(tc).ty == Ty::Scalar { BinaryOp::Mul } else { BinaryOp::Dot };
            let d = bin(m, op, et, ef)?;
            match (mode, ty) {
                (_, Ty::Scalar) => d,
                (CombineMode::Dot3Rgb, Ty::Rgba) => {
                    let c = intern(m, Expr::Convert { value: d, to: Ty::Rgb }, span)?;
                    let (ta, fa) = (alpha_of(m, t)?, alpha_of(m, f)?);
                    let a = bin(m, BinaryOp::Mul, ta, fa)?;
                    compose(m, c, a)?
                }
                (_, ty) => intern(m, Expr::Convert { value: d, to: ty }, span)?,
            }
        }
    })
}

/// At most this many addends are reordered ([`Gen::reassociated_sum`]).
const MAX_ADDENDS: usize = 6;

/// An order of addends (their ranges) whose partial sums, from the first
/// two to all but the last, stay in a register's [−1, 1]; depth-first, the
/// order written first. `None` when none does (or fewer than three).
fn order_within_a_register(ranges: &[(f64, f64)]) -> Option<Vec<usize>> {
    fn extend(ranges: &[(f64, f64)], order: &mut Vec<usize>, lo: f64, hi: f64) -> bool {
        if order.len() + 1 >= ranges.len() {
            return true;
        }
        for i in 0..ranges.len() {
            if order.contains(&i) {
                continue;
            }
            let (l, h) = (lo + ranges[i].0, hi + ranges[i].1);
            if !order.is_empty() && (l < -1.0 || h > 1.0) {
                continue;
            }
            order.push(i);
            if extend(ranges, order, l, h) {
                return true;
            }
            order.pop();
        }
        false
    }
    if ranges.len() < 3 || ranges.len() > MAX_ADDENDS {
        return None;
    }
    let mut order = Vec::new();
    extend(ranges, &mut order, 0.0, 0.0).then(|| {
        let rest = (0..ranges.len()).filter(|i| !order.contains(i));
        order.extend(rest.collect::<Vec<_>>());
        order
    })
}

fn unsupported(span: Span, what: impl Into<String>, help: impl Into<String>) -> CodegenError {
    CodegenError::Unsupported { span, what: what.into(), help: help.into() }
}

const LOOKUP_HELP: &str = "precompute it into a lookup texture indexed by its per-vertex inputs (Kilgard 2000, Section 5.2 does this for normalization), or compute it per vertex";

impl Gen<'_> {
    fn expr(&self, h: Handle<Expr>) -> &Expr {
        &self.m.exprs[h]
    }

    fn ty(&self, h: Handle<Expr>) -> Ty {
        self.m.info(h).ty
    }

    fn lo(&self, h: Handle<Expr>) -> f64 {
        self.m.info(h).interval.lo
    }

    fn hi(&self, h: Handle<Expr>) -> f64 {
        self.m.info(h).interval.hi
    }

    fn in_unit(&self, h: Handle<Expr>) -> bool {
        self.lo(h) >= -1.0 && self.hi(h) <= 1.0
    }

    fn norm(&self, h: Handle<Expr>, part: Part) -> Part {
        if self.ty(h) == Ty::Rgba {
            part
        } else {
            Part::Rgb
        }
    }

    /// The node holding `part` of `h` when `h` is composed (`rgba(c, a)`,
    /// an rgb widened to rgba); `Ok(None)` for the alpha 1 of a widened rgb.
    fn part_node(&self, h: Handle<Expr>, part: Part) -> Option<Option<Handle<Expr>>> {
        match (self.expr(h), part) {
            (Expr::Compose { ty: Ty::Rgba, components }, _)
                if components.len() == 2 && self.ty(components[0]).width() == 3 =>
            {
                Some(Some(if part == Part::Rgb { components[0] } else { components[1] }))
            }
            (Expr::Convert { value, to: Ty::Rgba }, Part::Rgb) if self.ty(*value) == Ty::Rgb => {
                Some(Some(*value))
            }
            (Expr::Convert { value, to: Ty::Rgba }, Part::Alpha) if self.ty(*value) == Ty::Rgb => Some(None),
            // A scalar splatted to rgba: every component is the scalar.
            (Expr::Convert { value, to: Ty::Rgba }, _) if self.ty(*value) == Ty::Scalar => Some(Some(*value)),
            _ => None,
        }
    }

    /// `h` is the constant vector (0, 0, 1).
    fn is_z_axis(&self, h: Handle<Expr>) -> bool {
        matches!(self.expr(h), Expr::Constant(c) if c.values() == [0.0, 0.0, 1.0])
    }

    /// `h`'s `part` is the number 1.
    fn is_one(&self, h: Handle<Expr>, part: Part) -> bool {
        self.constant(h) == Some(1.0)
            || (self.norm(h, part) == Part::Alpha && self.part_node(h, part) == Some(None))
    }

    fn constant(&self, h: Handle<Expr>) -> Option<f64> {
        match self.expr(h) {
            Expr::Constant(c) => {
                let v = c.values();
                (!v.is_empty() && v.iter().all(|x| *x == v[0])).then(|| v[0])
            }
            _ => None,
        }
    }

    // -----------------------------------------------------------------------
    // Sources.

    /// `h` (its `part`) as a source. `sat`: the consumer clamps the value to
    /// [0, 1], so a result the combiners clamp to [−1, 1] is still exact.
    fn src(&mut self, h: Handle<Expr>, part: Part, sat: bool) -> R<Src> {
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

    fn range(&self, h: Handle<Expr>) -> CodegenError {
        let i = self.m.info(h).interval;
        // An infinite bound is "no bound known", not a range to print.
        let what = match (i.lo.is_finite(), i.hi.is_finite()) {
            (true, true) => format!("this value (range [{}, {}])", i.lo, i.hi),
            (true, false) => format!("this value (at least {}, with no upper bound)", i.lo),
            (false, true) => format!("this value (at most {}, with no lower bound)", i.hi),
            (false, false) => "this value (no bound on its range is known)".to_string(),
        };
        CodegenError::Range { span: self.m.span(h), what }
    }

    fn src_uncached(&mut self, h: Handle<Expr>, part: Part, sat: bool) -> R<Src> {
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
                let unit = self.units.iter().position(|u| *u == h).ok_or_else(|| {
                    unsupported(span, "a texture lookup not bound to a texture unit of this pass", "list it in the pass's texture units")
                })?;
                let reg = Register::texture(unit as u8).expect("at most four units, checked");
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
            | Expr::Math { fun: MathFunction::Mix | MathFunction::Compress, .. } => self.materialise(h, part, sat),
            other => Err(self.unsupported_node(h, &other)),
        }
    }

    /// A uniform: a constant colour holding its value (its default, or what the caller supplies).
    fn uniform_src(&mut self, h: Handle<Expr>, id: crate::ir::UniformId, part: Part) -> R<Src> {
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
    fn interpolant_src(&mut self, h: Handle<Expr>, part: Part, sat: bool) -> R<Src> {
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
    fn swizzle_src(
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
        } else {
            Err(unsupported(
                span,
                "this component selection",
                "the combiners read a register's rgb, its alpha, or (in an alpha portion) its blue (Kilgard 2000, B.4), and red or green alone of an rgb by a dot product with a unit colour: use `.rgb`, `.a`, `.r`, `.g` or `.b`, or a lookup texture that stores the component in alpha",
            ))
        }
    }

    /// `rgb → rgba` (alpha one) or a splat: the value as the part reads it.
    fn convert_src(&mut self, value: Handle<Expr>, to: Ty, part: Part, sat: bool, span: Span) -> R<Src> {
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
    fn mapped_src(
        &mut self,
        h: Handle<Expr>,
        fun: MathFunction,
        arg: Handle<Expr>,
        part: Part,
        sat: bool,
    ) -> R<Src> {
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
    fn negated_src(&mut self, h: Handle<Expr>, value: Handle<Expr>, part: Part, sat: bool) -> R<Src> {
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

    fn unsupported_node(&self, h: Handle<Expr>, e: &Expr) -> CodegenError {
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
    fn reads_depth(&self, h: Handle<Expr>) -> bool {
        self.m
            .reachable(&[h])
            .into_iter()
            .any(|x| matches!(self.m.exprs[x], Expr::FramebufferRead { channel: FbChannel::Depth, .. }))
    }

    fn pow_error(&self, h: Handle<Expr>) -> CodegenError {
        unsupported(
            self.m.span(h),
            "a power with an exponent that is not a constant power of two",
            format!("the combiners square by multiplying a value with itself, so x^2, x^4, x^8, … map (Kilgard 2000, Appendix H); {LOOKUP_HELP}"),
        )
    }

    fn pow2_exponent(&self, h: Handle<Expr>) -> Option<u32> {
        let n = self.constant(h)?;
        ((2.0..=256.0).contains(&n) && n.fract() == 0.0 && (n as u32).is_power_of_two())
            .then(|| (n as u32).trailing_zeros())
    }

    /// `x^(2^k)` by repeated squaring in general combiners.
    fn pow_src(&mut self, x: Handle<Expr>, part: Part, k: u32) -> R<Src> {
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
    fn unsigned(&mut self, s: Src, span: Span) -> R<Src> {
        match s.map {
            UnsignedIdentity | UnsignedInvert => Ok(s),
            SignedIdentity => Ok(Src { map: UnsignedIdentity, ..s }),
            _ => {
                let v = self.copy(s, span)?;
                Ok(Src { map: UnsignedIdentity, ..v })
            }
        }
    }

    /// Copies a mapped source into a virtual register (`dest = s * one`).
    fn copy(&mut self, s: Src, span: Span) -> R<Src> {
        let scalar = s.comp != Comp::Rgb;
        self.emit(Spec::single(Term::times_one(s), scalar), span)
    }

    fn constant_src(&mut self, h: Handle<Expr>, c: &Constant, part: Part) -> R<Src> {
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
        } else {
            return Err(unsupported(span, "a constant with components of both signs", "constant colours are unsigned (Kilgard 2000, Table 2): add a signed part with `expand` of an unsigned constant"));
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

    /// The virtual constant holding `color` for node `h`, read as `comp`
    /// (its rgb, or its alpha). Constant registers are read-only (Kilgard 2000
    /// Table 2), so one register serves every read of a colour: a read
    /// shares the constant of the same node, or of a folded constant equal
    /// on the components read (a uniform with a default shares a folded
    /// constant's; a folded constant never a uniform's, which the caller may
    /// rebind). Without per-stage constants the whole pass has two (B.3),
    /// so the third distinct one is an error here; with them, the scheduler
    /// and `assign_constants` place them per stage.
    fn konst(&mut self, h: Handle<Expr>, color: Color, known: bool, comp: Comp) -> R<usize> {
        let same = |a: &Color, b: &Color| match comp {
            Comp::Alpha => a[3] == b[3],
            _ => a[..3] == b[..3],
        };
        let is_constant = |g: &Self, n: Handle<Expr>| matches!(g.expr(n), Expr::Constant(_));
        for (i, k) in self.konsts.iter().enumerate() {
            let same_node = k.node == h && (!is_constant(self, h) || same(&k.color, &color));
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

    fn out_of_constants(&self, span: Span, place: String, ks: &[usize]) -> CodegenError {
        CodegenError::OutOfConstants {
            span,
            place,
            constants: ks.iter().map(|k| self.describe_konst(*k)).collect(),
        }
    }

    /// A constant as the user wrote it: `uniform I_light`, or its value.
    fn describe_konst(&self, k: usize) -> String {
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
    fn konsts_of(srcs: impl IntoIterator<Item = Src>) -> Vec<usize> {
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

    // -----------------------------------------------------------------------
    // Operations.

    fn materialise(&mut self, h: Handle<Expr>, part: Part, sat: bool) -> R<Src> {
        if !sat && !self.in_unit(h) {
            return Err(self.range(h));
        }
        let spec = self.spec(h, part)?.ok_or_else(|| {
            let e = self.expr(h).clone();
            self.unsupported_node(h, &e)
        })?;
        self.emit(spec, self.m.span(h))
    }

    fn scalar(&self, h: Handle<Expr>, part: Part) -> bool {
        self.ty(h) == Ty::Scalar || self.norm(h, part) == Part::Alpha
    }

    /// The portion computation of an operation node, or `None` for a node
    /// that is a source.
    fn spec(&mut self, h: Handle<Expr>, part: Part) -> R<Option<Spec>> {
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
                let (sel, high) = self.condition(h)?;
                let (one, zero) = (Term::times_one(Src::ONE), Term::times_one(Src::ZERO));
                let (ab, cd) = if high { (zero, one) } else { (one, zero) };
                Spec { cd: Some(cd), mux: Some(sel), ..Spec::single(ab, true) }
            }
            Expr::Select { cond, accept, reject: Some(reject) } => {
                let (sel, high) = self.condition(cond)?;
                let acc = self.plain_term(accept, part)?;
                let rej = self.plain_term(reject, part)?;
                let (ab, cd) = if high { (rej, acc) } else { (acc, rej) };
                Spec { cd: Some(cd), mux: Some(sel), ..Spec::single(ab, scalar) }
            }
            Expr::Math { fun: MathFunction::Mix, ref args } => self.mix_spec(args, part, scalar, span)?,
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
    fn product_spec(
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
    /// clamp it) and `a`, `b`, `c` sources: `a·c ± b·c` in one portion,
    /// AB + CD (Kilgard 2000, Section 4.2.2). `None` otherwise.
    fn distributed_product(
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
        if !self.sum_beyond_a_register(sum, part) || !plain(self, a) || !plain(self, b) || !plain(self, c) {
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
    fn above_one(&mut self, h: Handle<Expr>, part: Part) -> Option<(f64, Src)> {
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
    fn mix_spec(&mut self, args: &[Handle<Expr>], part: Part, scalar: bool, span: Span) -> R<Spec> {
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
    fn mapped_spec(&mut self, fun: MathFunction, x: Handle<Expr>, part: Part, scalar: bool) -> R<Spec> {
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
    fn spec_or_source(&mut self, h: Handle<Expr>, part: Part) -> R<Spec> {
        let scalar = self.scalar(h, part);
        // Sources first: a lookup or a mapped register is not an operation.
        match self.spec_if_operation(h, part)? {
            Some(s) => Ok(s),
            None => Ok(Spec::single(Term::times_one(self.src(h, part, false)?), scalar)),
        }
    }

    /// `spec` for nodes `src` would materialise; `None` for sources.
    fn spec_if_operation(&mut self, h: Handle<Expr>, part: Part) -> R<Option<Spec>> {
        if self.cache.contains_key(&(h, self.norm(h, part))) || self.is_source(h) {
            return Ok(None);
        }
        self.spec(h, part)
    }

    /// Nodes `src` turns into a source without a new operation.
    fn is_source(&self, h: Handle<Expr>) -> bool {
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
    fn scaled(&mut self, mut inner: Spec, k: f64, x: Option<Handle<Expr>>, part: Part) -> R<Spec> {
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
    fn sum_beyond_a_register(&self, o: Handle<Expr>, part: Part) -> bool {
        matches!(
            self.expr(o),
            Expr::Binary { op: BinaryOp::Add | BinaryOp::Sub, .. } | Expr::Unary { op: UnaryOp::Neg, .. }
        ) && !self.in_unit(o)
            && !self.cache.contains_key(&(o, self.norm(o, part)))
    }

    /// The addends of a sum not yet computed, each with whether it is
    /// subtracted: `(a + b) − c` is `[(a, +), (b, +), (c, −)]`.
    fn signed_addends(&self, h: Handle<Expr>, part: Part, minus: bool, out: &mut Vec<(Handle<Expr>, bool)>) {
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
    fn reassociated_sum(&mut self, h: Handle<Expr>, part: Part, scalar: bool, span: Span) -> R<Option<Spec>> {
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
    fn sum_term(&mut self, h: Handle<Expr>, part: Part) -> R<Term> {
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
    fn plain_term(&mut self, h: Handle<Expr>, part: Part) -> R<Term> {
        if let Expr::Binary { op: BinaryOp::Pow, lhs, rhs } = self.expr(h).clone() {
            if let Some(k) = self.pow2_exponent(rhs) {
                let p = self.pow_src(lhs, part, k - 1)?;
                return Ok(Term { a: p, b: p, dot: false });
            }
        }
        self.sum_term(h, part)
    }

    fn negate(&mut self, t: Term, h: Handle<Expr>, part: Part) -> R<Term> {
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
    fn condition(&mut self, cond: Handle<Expr>) -> R<(Src, bool)> {
        let span = self.m.span(cond);
        let bad = || {
            unsupported(
                span,
                "this condition",
                "the mux tests spare0.a ≥ ½ (Kilgard 2000, Section 4.2.2): compare a value with 0 or 0.5, e.g. `Hn.z ≥ 0` (Appendix H), or use a lookup texture",
            )
        };
        let Expr::Binary { op, lhs, rhs } = self.expr(cond).clone() else { return Err(bad()) };
        if self.reads_depth(cond) {
            // A depth texture's compare (issue 39): the unit's register holds 1 where lit.
            if let Some(k) = crate::planner::shadow_map::compare_unit(self.m, self.units, cond) {
                let reg = Register::texture(k as u8).expect("at most four units, checked");
                return Ok((Src { base: Base::Reg(reg), comp: Comp::Alpha, map: UnsignedIdentity }, false));
            }
            // The shadow-mask test (seeds/001 Section 3.5) in another form.
            return Err(unsupported(
                span,
                "a per-pixel depth comparison (a shadow-map test)",
                crate::planner::shadow_map::REFUSAL_HELP,
            ));
        }
        let (x, k, high) = match (self.constant(lhs), self.constant(rhs), op) {
            (_, Some(k), BinaryOp::Ge | BinaryOp::Gt) => (lhs, k, true),
            (_, Some(k), BinaryOp::Lt | BinaryOp::Le) => (lhs, k, false),
            (Some(k), _, BinaryOp::Le | BinaryOp::Lt) => (rhs, k, true),
            (Some(k), _, BinaryOp::Ge | BinaryOp::Gt) => (rhs, k, false),
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
        } else {
            return Err(bad());
        };
        Ok((sel, high))
    }

    /// Adds an operation: picks its portion, fixes up component reads the
    /// portion cannot make, and schedules it. Returns the result's source.
    fn emit(&mut self, mut spec: Spec, span: Span) -> R<Src> {
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

    /// The portion an operation runs in: RGB for dot products and vectors,
    /// alpha for scalars that read alpha or blue (Kilgard 2000, B.4).
    fn lane_of(&self, spec: &Spec) -> Lane {
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
    fn schedule(&mut self, spec: &Spec, lane: Lane, span: Span) -> R<(usize, bool)> {
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

    fn is_const_reg(&self, s: &Src) -> bool {
        matches!(s.base, Base::Reg(Register::Zero))
    }

    /// Blue-to-alpha: an alpha portion copies a blue component into an
    /// alpha register, where an RGB portion (or the final combiner) can read it.
    fn blue_to_alpha(&mut self, s: Src, span: Span) -> R<Src> {
        let copy = Spec { alpha_only: true, ..Spec::single(Term::times_one(s), true) };
        self.emit(copy, span)
    }

    /// The mux reads spare0.a: the select value is computed into a virtual
    /// register pinned there (Appendix H: `spare0.a = unsigned(tex1.b) * one`).
    fn pin_select(&mut self, sel: Src, span: Span) -> R<Src> {
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

    // -----------------------------------------------------------------------
    // The final combiner.

    fn final_combiner(&mut self, value: Handle<Expr>) -> R<FinalSpec> {
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

    fn flatten(&self, h: Handle<Expr>, op: BinaryOp, out: &mut Vec<Handle<Expr>>) {
        match self.expr(h) {
            Expr::Binary { op: o, lhs, rhs } if *o == op => {
                self.flatten(*lhs, op, out);
                self.flatten(*rhs, op, out);
            }
            _ => out.push(h),
        }
    }

    fn nonneg_unit(&self, h: Handle<Expr>) -> bool {
        self.lo(h) >= 0.0 && self.hi(h) <= 1.0
    }

    /// out.rgb = A·B + (1 − A)·C + D, clamped to [0, 1] by the 8-bit output.
    fn final_rgb(&mut self, v: Handle<Expr>, part: Part, fin: &mut FinalSpec) -> R<()> {
        let v = match self.expr(v) {
            Expr::Convert { value, .. } if self.ty(*value) == Ty::Scalar => *value,
            _ => v,
        };
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
        if !extra.is_empty() {
            let scalar = extra.iter().all(|h| self.scalar(*h, part));
            let span = self.m.span(extra[0]).join(self.m.span(*extra.last().expect("non-empty")));
            let mut terms = Vec::new();
            for h in &extra {
                terms.push(match self.nonneg_unit(*h) {
                    true => self.sum_term(*h, part)?,
                    false => {
                        let s = self.src(*h, part, true)?;
                        Term::times_one(self.unsigned(s, self.m.span(*h))?)
                    }
                });
            }
            while terms.len() > 1 {
                let y = terms.pop().expect("len > 1");
                let x = terms.pop().expect("len > 1");
                let s = self.emit(
                    Spec { cd: Some(y), alpha_only: part == Part::Alpha, ..Spec::single(x, scalar) },
                    span,
                )?;
                terms.push(Term::times_one(s));
            }
            let s = terms[0].a;
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

    /// Whether an addend goes to A·B (a product of factors in [0, 1], a
    /// power, a lerp).
    fn is_final_product(&self, h: Handle<Expr>) -> bool {
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

    fn final_product(&mut self, p: Handle<Expr>, part: Part, fin: &mut FinalSpec) -> R<()> {
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
                return Ok(());
            }
            Expr::Binary { op: BinaryOp::Pow, lhs, rhs } => {
                let k = self.pow2_exponent(rhs).expect("checked");
                let m = k.min(2);
                let base = self.pow_src(lhs, part, k - m)?;
                return self.final_power(base, m, span, fin);
            }
            Expr::Select { cond, accept, reject: Some(reject) } => {
                // c ? x^(2^k) : 0 = (c ? x^(2^(k−m)) : 0)^(2^m): the final combiner
                // squares twice (EF, then EF·EF), the mux stage once (Appendix H).
                let Expr::Binary { op: BinaryOp::Pow, lhs: x, rhs } = self.expr(accept).clone() else {
                    unreachable!("checked")
                };
                let k = self.pow2_exponent(rhs).expect("checked");
                let m = k.min(2);
                let acc = if k - m >= 1 {
                    let y = self.pow_src(x, part, k - m - 1)?;
                    Term { a: y, b: y, dot: false }
                } else {
                    Term::times_one(self.src(x, part, false)?)
                };
                let rej = self.plain_term(reject, part)?;
                let rej =
                    if rej.a == Src::ZERO { Term { a: Src::ZERO, b: Src::ZERO, dot: false } } else { rej };
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
                return self.final_power(s, m, span, fin);
            }
            _ => {}
        }
        let mut factors = Vec::new();
        self.flatten(p, BinaryOp::Mul, &mut factors);
        let mut srcs = Vec::new();
        for f in factors {
            let s = self.src(f, part, false)?;
            srcs.push(s);
        }
        // More than three factors: multiply the trailing ones in general combiners.
        while srcs.len() > 3 {
            let b = srcs.pop().expect("len > 3");
            let a = srcs.pop().expect("len > 3");
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
    fn final_power(&mut self, s: Src, m: u32, span: Span, fin: &mut FinalSpec) -> R<()> {
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
    fn final_src(&mut self, s: Src, span: Span) -> R<Src> {
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
    fn final_read(&mut self, s: Src, span: Span) -> R<Src> {
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
    fn final_alpha(&mut self, s: Src, span: Span) -> R<Src> {
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

    // -----------------------------------------------------------------------
    // Constant registers.

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
    fn assign_constants(&mut self, fin: &FinalSpec) -> R<()> {
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

    // -----------------------------------------------------------------------
    // Register allocation.

    fn allocate(&mut self, fin: &FinalSpec) -> R<()> {
        let n = self.stage_used.len();
        let lane_of = |s: &Src| match s.comp {
            Comp::Alpha => Lane::Alpha,
            _ => Lane::Rgb,
        };
        // Last read of every virtual register and of every input register lane.
        let mut last = vec![0usize; self.vregs.len()];
        let mut phys: HashMap<(Register, Lane), usize> = HashMap::new();
        let mut read = |s: &Src, stage: usize, last: &mut Vec<usize>| match s.base {
            Base::V(v) => last[v] = last[v].max(stage),
            // Constant registers are read-only: nothing to allocate.
            Base::K(_) => {}
            Base::Reg(r) => {
                let e = phys.entry((r, lane_of(s))).or_insert(stage);
                *e = (*e).max(stage);
            }
        };
        for op in &self.ops {
            let mut srcs = vec![op.ab.a, op.ab.b];
            if let Some(cd) = op.cd {
                srcs.extend([cd.a, cd.b]);
            }
            srcs.extend(op.mux);
            for s in &srcs {
                read(s, op.stage, &mut last);
            }
        }
        for v in [fin.a, fin.b, fin.c, fin.d] {
            if let FinalVal::Src(s) = v {
                read(&s, n, &mut last);
            }
        }
        for s in [fin.e, fin.f, fin.g] {
            read(&s, n, &mut last);
        }
        let def: Vec<usize> = self.vregs.iter().map(|v| self.ops[v.op].stage).collect();
        for (i, l) in last.iter_mut().enumerate() {
            *l = (*l).max(def[i] + 1);
        }
        let mut candidates = vec![Register::Spare0, Register::Spare1];
        for u in 0..self.limits.texture_units.min(4) {
            candidates.push(Register::texture(u).expect("unit < 4"));
        }
        candidates.extend([Register::Primary, Register::Secondary]);
        let mut order: Vec<usize> = (0..self.vregs.len()).collect();
        order.sort_by_key(|&v| (self.vregs[v].pin.is_none(), def[v], v));
        let mut taken: Vec<(Register, Lane, usize, usize)> = Vec::new();
        for v in order {
            let lane = self.vregs[v].lane;
            let (d, l) = (def[v], last[v]);
            let free = |r: Register| {
                let phys_ok = match r {
                    Register::Spare0 | Register::Spare1 => true,
                    _ => phys.get(&(r, lane)).is_none_or(|&u| u <= d),
                };
                phys_ok && taken.iter().all(|&(tr, tl, td, tu)| tr != r || tl != lane || tu <= d || l <= td)
            };
            let reg = match self.vregs[v].pin {
                Some(p) if free(p) => p,
                Some(_) => {
                    return Err(CodegenError::OutOfRegisters { span: self.ops[self.vregs[v].op].span })
                }
                None => *candidates
                    .iter()
                    .find(|r| free(**r))
                    .ok_or(CodegenError::OutOfRegisters { span: self.ops[self.vregs[v].op].span })?,
            };
            taken.push((reg, lane, d, l));
            self.vregs[v].reg = Some(reg);
        }
        Ok(())
    }

    // -----------------------------------------------------------------------
    // The config.

    /// The register a source reads in general stage `stage` (`None`: the
    /// final combiner, which reads the global constants).
    fn register(&self, s: &Src, stage: Option<usize>) -> Register {
        match s.base {
            Base::Reg(r) => r,
            Base::V(v) => self.vregs[v].reg.expect("allocated"),
            Base::K(k) => {
                let a = &self.assigned;
                let slot = |j: usize| match stage.and_then(|st| a.local.get(st).and_then(|l| l[j])) {
                    Some(local) => local == k,
                    None => a.global[j] == Some(k),
                };
                [Register::Constant0, Register::Constant1][(0..2).find(|j| slot(*j)).expect("assigned")]
            }
        }
    }

    fn general_input(&self, s: &Src, lane: Lane, stage: usize) -> GeneralInput {
        let usage = match (lane, s.comp) {
            (Lane::Rgb, Comp::Rgb | Comp::Bcast) => ComponentUsage::Rgb,
            (_, Comp::Alpha) => ComponentUsage::Alpha,
            (Lane::Alpha, _) => ComponentUsage::Blue,
            (Lane::Rgb, Comp::Blue) => unreachable!("fixed up by emit"),
        };
        GeneralInput::new(self.register(s, Some(stage)), s.map, usage)
    }

    fn final_input(&self, v: FinalVal) -> FinalInput {
        match v {
            FinalVal::Ef => FinalInput::new(FinalSource::EfProduct, UnsignedIdentity, ComponentUsage::Rgb),
            FinalVal::Src(s) => {
                let usage = if s.comp == Comp::Alpha { ComponentUsage::Alpha } else { ComponentUsage::Rgb };
                FinalInput::new(FinalSource::Register(self.register(&s, None)), s.map, usage)
            }
        }
    }

    fn build(&self, fin: &FinalSpec) -> CombinerConfig {
        let color = |k: Option<usize>| k.map(|k| &self.konsts[k]).filter(|k| k.known).map(|k| k.color);
        let mut general: Vec<GeneralStage> = (0..self.stage_used.len())
            .map(|st| {
                let local = self.assigned.local.get(st).copied().unwrap_or([None, None]);
                GeneralStage {
                    rgb: GeneralPortion::discard_all(),
                    alpha: GeneralPortion::discard_all(),
                    constant0: color(local[0]),
                    constant1: color(local[1]),
                }
            })
            .collect();
        for op in &self.ops {
            let zero = GeneralInput::new(Register::Zero, UnsignedIdentity, ComponentUsage::Alpha);
            let out = self.vregs[op.out].reg;
            if op.in_cd {
                let portion = match op.lane {
                    Lane::Rgb => &mut general[op.stage].rgb,
                    Lane::Alpha => &mut general[op.stage].alpha,
                };
                portion.c = self.general_input(&op.ab.a, op.lane, op.stage);
                portion.d = self.general_input(&op.ab.b, op.lane, op.stage);
                portion.cd_dot = op.ab.dot;
                portion.cd_output = out;
                continue;
            }
            let (c, d, cd_dot) = match op.cd {
                Some(t) => (
                    self.general_input(&t.a, op.lane, op.stage),
                    self.general_input(&t.b, op.lane, op.stage),
                    t.dot,
                ),
                None => (zero, zero, false),
            };
            let combined = op.cd.is_some() || op.mux.is_some();
            let portion = GeneralPortion {
                a: self.general_input(&op.ab.a, op.lane, op.stage),
                b: self.general_input(&op.ab.b, op.lane, op.stage),
                c,
                d,
                ab_output: if combined { None } else { out },
                cd_output: None,
                sum_output: if combined { out } else { None },
                ab_dot: op.ab.dot,
                cd_dot,
                mux_sum: op.mux.is_some(),
                scale: op.scale,
                bias: op.bias,
            };
            let stage = &mut general[op.stage];
            match op.lane {
                Lane::Rgb => stage.rgb = portion,
                Lane::Alpha => stage.alpha = portion,
            }
        }
        let g = self.final_input(FinalVal::Src(fin.g));
        let final_combiner = FinalCombiner {
            a: self.final_input(fin.a),
            b: self.final_input(fin.b),
            c: self.final_input(fin.c),
            d: self.final_input(fin.d),
            e: self.final_input(FinalVal::Src(fin.e)),
            f: self.final_input(FinalVal::Src(fin.f)),
            g: FinalInput { usage: ComponentUsage::Alpha, ..g },
            color_sum_clamp: true,
        };
        CombinerConfig {
            constant0: color(self.assigned.global[0]),
            constant1: color(self.assigned.global[1]),
            general,
            final_combiner,
            // Dependent lookups (EMBM's offset) as a `!!TS1.0` program.
            texture_shader: super::ts1::lower::program(self.m, self.units),
        }
    }
}

fn to_color(c: &Constant) -> Color {
    let v = c.values();
    let mut out = [0.0f32; 4];
    for (i, o) in out.iter_mut().enumerate() {
        *o = if v.len() == 1 { v[0] as f32 } else { v.get(i).copied().unwrap_or(0.0) as f32 };
    }
    out
}

/// The code generator as the planner's [`Realizer`]: a value
/// fits one pass of a register-combiner target when a setup for it is
/// generated under the target's own limits (an Appendix B-valid setup).
pub struct CombinerRealizer {
    pub limits: CombinerLimits,
}

impl Realizer for CombinerRealizer {
    fn realize(
        &self,
        module: &Module,
        value: Handle<Expr>,
        units: &[Handle<Expr>],
    ) -> Result<Realized, Refusal> {
        let input = PassInput { module, value, units };
        generate(&input, &self.limits)
            .map(|g| Realized { general_combiners: g.config.general.len() as u32 })
            .map_err(|e| Refusal { reason: e.to_string(), span: e.span(), help: e.help() })
    }

    fn setup(
        &self,
        module: &Module,
        value: Handle<Expr>,
        units: &[Handle<Expr>],
    ) -> Result<crate::pipeline::CombinerProgram, Refusal> {
        let input = PassInput { module, value, units };
        generate(&input, &self.limits)
            .map(|g| crate::pipeline::CombinerProgram::new(g.config.general.len() as u32, g))
            .map_err(|e| Refusal { reason: e.to_string(), span: e.span(), help: e.help() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir;

    fn module(value: &str) -> (Module, Handle<Expr>, Vec<Handle<Expr>>) {
        let src = format!(
            "texture A : 2d rgba8 = image(\"a.png\");\ntexture B : 2d rgba8 = image(\"b.png\");\nframebuffer C : rgba8;\nlet a = A δu x;\nlet b = B δu x;\nC δπx ← {value};\n"
        );
        let (program, d) = crate::parser::check(&src);
        assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
        let (m, d) = ir::lower(&program);
        assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
        let mut v = m.statements[0].value;
        if let Expr::Convert { value, .. } = m.exprs[v] {
            if m.info(value).ty == Ty::Scalar {
                v = value;
            }
        }
        let units: Vec<_> = m
            .exprs
            .arena()
            .iter()
            .filter(|(_, e)| matches!(e, Expr::Lookup { .. }))
            .map(|(h, _)| h)
            .collect();
        (m, v, units)
    }

    fn gen(value: &str) -> Result<Generated, CodegenError> {
        let (m, v, units) = module(value);
        generate(&PassInput { module: &m, value: v, units: &units }, &CombinerLimits::GEFORCE3)
    }

    #[test]
    fn a_texel_needs_no_general_combiner() {
        let g = gen("a").unwrap();
        assert_eq!(g.stages, 0);
        assert_eq!(g.config.final_combiner.d.source, FinalSource::Register(Register::Texture0));
        assert_eq!(g.config.final_combiner.g.source, FinalSource::Register(Register::Texture0));
    }

    #[test]
    fn expand_and_negation_are_input_mappings() {
        let g = gen("-expand(a.rgb) * b.rgb").unwrap();
        assert_eq!(g.stages, 1);
        let rgb = g.config.general[0].rgb;
        assert_eq!((rgb.a.mapping, rgb.b.mapping), (ExpandNegate, UnsignedIdentity));
    }

    #[test]
    fn eight_times_is_a_doubled_sum_scaled_by_four() {
        let g = gen("saturate(8 * expand(b.b))").unwrap();
        let alpha = g.config.general[0].alpha;
        assert_eq!(alpha.scale, Scale::Four);
        assert_eq!(alpha.a, alpha.c);
        assert_eq!(alpha.a.usage, ComponentUsage::Blue);
        assert!(alpha.sum_output.is_some());
    }

    #[test]
    fn independent_operations_share_a_stage() {
        // A dot product (RGB portion) and an alpha product (alpha portion).
        let g =
            gen("rgba(max(0, expand(a.rgb) · expand(b.rgb)) * a.rgb, expand(a.a) * expand(b.a))").unwrap();
        assert_eq!(g.stages, 1, "{}", super::super::rc1::print(&g.config));
        assert!(g.config.general[0].rgb.ab_dot);
        assert!(
            g.config.general[0].alpha.ab_output.is_some() || g.config.general[0].alpha.sum_output.is_some()
        );
    }

    #[test]
    fn the_mux_select_lands_in_spare0_alpha() {
        let g = gen("a.a ≥ 0.5 ? expand(a.rgb) * b.rgb : b.rgb").unwrap();
        let mux = g.config.general.iter().find(|s| s.rgb.mux_sum).expect("a mux");
        let select_writer = g.config.general.iter().find(|s| {
            s.alpha.ab_output == Some(Register::Spare0) || s.alpha.sum_output == Some(Register::Spare0)
        });
        assert!(select_writer.is_some() && mux.rgb.sum_output.is_some());
    }

    #[test]
    fn division_is_unsupported_at_its_span() {
        let (m, v, units) = module("a / 2");
        let e = generate(&PassInput { module: &m, value: v, units: &units }, &CombinerLimits::GEFORCE3)
            .unwrap_err();
        assert!(matches!(e, CodegenError::Unsupported { .. }));
        assert!(e.to_diagnostic().help.is_some_and(|h| h.contains("lookup texture")));
    }
}
