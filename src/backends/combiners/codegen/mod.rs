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

mod config;
mod constants;
mod desugar;
mod final_combiner;
mod ops;
mod regalloc;
mod schedule;
mod select;

use desugar::*;

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
    /// The module holding the pass's nodes.
    pub module: &'a Module,
    /// The fragment colour the pass outputs.
    pub value: Handle<Expr>,
    /// Texture unit `i` holds the lookup node `units[i]`.
    pub units: &'a [Handle<Expr>],
}

/// A generated configuration and what the caller must bind for it.
#[derive(Clone, Debug)]
pub struct Generated {
    /// The setup itself, valid under the limits it was generated for.
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
    /// The source span of the value the operation computes.
    pub span: Span,
    /// The general stage, 0-based.
    pub stage: usize,
    /// Whether the operation is in the alpha portion (else the RGB one).
    pub alpha: bool,
}

/// Why a value has no register-combiner setup under the target's limits.
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
    /// More interpolated colours than the primary and secondary ones.
    #[error("the pass needs more than the two interpolated colours (primary and secondary)")]
    OutOfColors { span: Span },
    /// More live intermediate values than the free registers hold.
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
    /// Where in the source the refusal points, when it points at a node.
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

    /// The help line: what the programmer can do instead.
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

    /// The diagnostic code of the refusal.
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

    /// The refusal as a diagnostic at its span.
    pub fn to_diagnostic(&self) -> Diagnostic {
        let span = self.span().unwrap_or(Span::DETACHED);
        Diagnostic::error(self.code(), self.to_string(), span, "here").with_help(self.help())
    }
}

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
    // A HILO map's dot-product stages take units of their own (planner::hilo).
    let hardware_units = crate::planner::hilo::hardware_units(m, input.units).len();
    if hardware_units > usize::from(limits.texture_units.min(4)) {
        return Err(CodegenError::Unsupported {
            span,
            what: format!("a pass with {hardware_units} texture units"),
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
    /// The target's combiners, which every setup must fit.
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

    fn dependent_lookups(
        &self,
        module: &Module,
        units: &[Handle<Expr>],
        texture_shaders: bool,
    ) -> Result<(), Refusal> {
        crate::backends::combiners::ts1::lower::dependent_lookups(module, units, texture_shaders)
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
    fn division_by_a_constant_is_the_product_by_its_reciprocal() {
        // a / 2 = a · ½: the output scale ½, no constant register.
        let g = gen("a / 2").unwrap();
        let halves = |p: &GeneralPortion| p.scale == Scale::OneHalf;
        assert!(g.config.general.iter().any(|s| halves(&s.rgb) || halves(&s.alpha)), "{:?}", g.config);
        assert!(g.config.constant0.is_none() && g.config.constant1.is_none());
    }

    #[test]
    fn division_is_unsupported_at_its_span() {
        let (m, v, units) = module("a.a / b.a");
        let e = generate(&PassInput { module: &m, value: v, units: &units }, &CombinerLimits::GEFORCE3)
            .unwrap_err();
        assert!(matches!(e, CodegenError::Unsupported { .. }));
        assert!(e.to_diagnostic().help.is_some_and(|h| h.contains("lookup texture")));
    }
}
