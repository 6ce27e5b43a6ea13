//! Does a value fit one pass of a profile? Texture units (lookups plus
//! framebuffers read as textures), interpolants, constant colours, and the
//! fragment stage's capacity: register-combiner stages on geforce256 /
//! geforce3, one ⊕ per texture unit on the OpenGL 1.2.1 texture
//! environment, anything on a programmable stage.
//!
//! The combiner capacity is first *bounded* (Kilgard 2000, Section 4.2): every
//! general combiner portion (RGB and alpha) computes two products or dot
//! products and their sum or mux — three IR operations, six per stage —
//! and the final combiner `A·B + (1 − A)·C + D` and `E·F` — at most eight;
//! range mappings (`expand`, `half_bias`, `saturate`, `max(0, ·)`) and
//! scales ride on inputs and outputs for free; `x^n` by repeated squaring
//! costs ⌈log₂ n⌉ products. A value within the bound (operations at most
//! `6 · general + 8`, which no setup exceeds) fits only when the combiner code
//! generator realizes it under the profile's own limits (a setup the
//! Appendix B validator accepts): a pass the target cannot run is split
//! further or refused, never planned.

use rustc_hash::FxHashMap as HashMap;
use std::cell::RefCell;

use super::realize::Realizer;
use super::split::{Dest, FitCheck, Overflow, Piece};
use crate::ir::{BinaryOp, Expr, Handle, MathFunction, Module, Ty, Usage};
use crate::pipeline::BlendMode;
use crate::profile::{FragmentStage, Profile};

/// Whether a value fits one pass of a profile: its units, interpolants, constants and fragment
/// stage (the combiners through the realizer).
pub struct ProfileFit<'p> {
    pub profile: &'p Profile,
    /// The target's fixed-function stage (the combiner code generator);
    /// `None` on a programmable stage.
    realizer: Option<&'p dyn Realizer>,
    /// The generator's verdicts by value: the arena only grows, so a
    /// handle's value never changes while the planner runs.
    /// Ok holds the general combiner stages the setup uses.
    generated: RefCell<HashMap<Handle<Expr>, Result<u32, Overflow>>>,
    /// Every verdict of [`FitCheck::fits`] by value, for the same reason:
    /// the splitter asks about the same sub-values many times.
    verdicts: RefCell<HashMap<Handle<Expr>, Result<(), Overflow>>>,
    /// Texture samples per value, for [`FitCheck::piece_ns`],
    /// measured once like the verdicts.
    samples: RefCell<HashMap<Handle<Expr>, u32>>,
    /// Texture units per value, for [`FitCheck::texture_units`].
    units: RefCell<HashMap<Handle<Expr>, usize>>,
}

impl<'p> ProfileFit<'p> {
    /// The fit of `profile`, whose fixed-function stage `realizer` judges (none for a
    /// programmable one).
    pub fn new(profile: &'p Profile, realizer: Option<&'p dyn Realizer>) -> ProfileFit<'p> {
        ProfileFit {
            profile,
            realizer,
            generated: RefCell::default(),
            verdicts: RefCell::default(),
            samples: RefCell::default(),
            units: RefCell::default(),
        }
    }

    /// Whether the combiner code generator realizes `value` as one pass,
    /// its texture units bound as the plan binds them (lookups, then
    /// framebuffers read as textures).
    fn generates(&self, module: &Module, value: Handle<Expr>, u: &Usage) -> Result<(), Overflow> {
        let (Some(realizer), FragmentStage::Combiners(_)) = (self.realizer, &self.profile.fragment) else {
            return Ok(());
        };
        if let Some(known) = self.generated.borrow().get(&value) {
            return known.clone().map(|_| ());
        }
        let units: Vec<Handle<Expr>> = u.lookups.iter().chain(&u.framebuffer_reads).copied().collect();
        // A dependent lookup the texture shader does not perform first:
        // its own reason, not the combiners'.
        let shaders = self.profile.texture_shaders.is_some();
        let verdict = match realizer.dependent_lookups(module, &units, shaders) {
            Err(e) => Err((e.reason.clone(), e)),
            Ok(()) => realizer.realize(module, value, &units).map_err(|e| {
                (format!("has no register-combiner setup the code generator can build: {}", e.reason), e)
            }),
        };
        let verdict = verdict.map(|r| r.general_combiners).map_err(|(resource, e)| {
            let at = e.span.and_then(|span| {
                module.reachable(&[value]).into_iter().rev().find(|h| module.span(*h) == span)
            });
            Overflow { resource, need: 0, have: 0, at, help: Some(e.help) }
        });
        self.generated.borrow_mut().insert(value, verdict.clone());
        verdict.map(|_| ())
    }
}

impl FitCheck for ProfileFit<'_> {
    fn texture_units(&self, module: &Module, value: Handle<Expr>) -> usize {
        *self.units.borrow_mut().entry(value).or_insert_with(|| Usage::texture_units_of(module, value))
    }

    fn fits(&self, module: &Module, value: Handle<Expr>) -> Result<(), Overflow> {
        if let Some(known) = self.verdicts.borrow().get(&value) {
            return known.clone();
        }
        let verdict = self.measure(module, value);
        self.verdicts.borrow_mut().insert(value, verdict.clone());
        verdict
    }

    /// The pass on the target's cost model: its texture units,
    /// the general combiner stages the generator used for it, whether its
    /// blend reads the framebuffer and whether it renders to a temporary.
    fn piece_ns(&self, module: &Module, piece: &Piece) -> u64 {
        let Some(model) = &self.profile.cost else { return 0 };
        let samples = *self.samples.borrow_mut().entry(piece.value).or_insert_with(|| {
            let u = Usage::units_of_reached(module, &module.reachable(&[piece.value]));
            (u.texture_units() + framebuffer_textures(module, &u)) as u32
        });
        let stages = match self.generated.borrow().get(&piece.value) {
            Some(Ok(n)) => *n,
            _ => 0,
        };
        let fragment = crate::cost::FragmentLoad {
            samples,
            stages,
            reads_destination: piece.blend != BlendMode::Replace,
            depth_tested: true,
        };
        crate::cost::nominal_pass_ns(model, &fragment, piece.dest != Dest::Main)
    }
}

impl ProfileFit<'_> {
    /// The verdict for `value`, computed: resources first, then the
    /// fragment stage's capacity.
    fn measure(&self, module: &Module, value: Handle<Expr>) -> Result<(), Overflow> {
        let p = self.profile;
        let nodes = module.reachable(&[value]);
        let over = |resource: &str, need: usize, have: usize, at: Option<Handle<Expr>>| {
            Err(Overflow { resource: resource.to_string(), need, have, at, help: None })
        };
        // The texture units first, from the lookups alone: most values
        // measured while splitting fail here.
        let bound = Usage::units_of_reached(module, &nodes);
        let units = bound.texture_units()
            + framebuffer_textures(module, &bound)
            + super::hilo::extra_units(module, &bound.lookups);
        if units > p.texture_units as usize {
            return over("texture units", units, p.texture_units as usize, bound.lookups.last().copied());
        }
        let u = Usage::of_reached(module, &nodes);
        if u.interpolants.len() > p.interpolants as usize {
            return over(
                "interpolants",
                u.interpolants.len(),
                p.interpolants as usize,
                u.interpolants.last().copied(),
            );
        }
        if let Some(have) = p.constant_registers() {
            if u.constants.len() > have as usize {
                return over(
                    "constant colours",
                    u.constants.len(),
                    have as usize,
                    u.constants.last().copied(),
                );
            }
        }
        match &p.fragment {
            FragmentStage::Programmable => Ok(()),
            FragmentStage::Combiners(c) => {
                // The combiners read an interpolated colour as the primary
                // or secondary colour, clamped at the vertex as GL clamps it
                // (NV_vertex_program, Section 2.14.1.5, on geforce3 alike).
                wide_vertex_colour(module, &u, &combine_operands(module, value))?;
                let shader = super::hilo::texture_shader_nodes(module, value, p);
                let ops = combiner_operations_except(module, value, &shader).map_err(|h| Overflow {
                    resource: format!("{} per fragment", operation_name(module, h)),
                    need: 1,
                    have: 0,
                    at: Some(h),
                    help: None,
                })?;
                let have = 6 * c.general_combiners + 8;
                if ops > have {
                    over(
                        "combiner operations (at most six per general combiner, eight in the final one)",
                        ops,
                        have,
                        None,
                    )
                } else {
                    self.generates(module, value, &u)
                }
            }
            FragmentStage::TextureEnv => {
                wide_vertex_colour(module, &u, &[])?;
                wide_scalar_colour(module, &u, value)?;
                stage_result_clamped(module, value)?;
                let ops = combines(module, value);
                let have = (p.texture_units as usize).max(1);
                if ops > have {
                    over("texture-environment stages", ops, have, None)
                } else {
                    Ok(())
                }
            }
        }
    }
}

/// Framebuffers a pass reads (at a position other than a blend's own):
/// each is bound as a texture (render-to-texture of that framebuffer).
fn framebuffer_textures(module: &Module, u: &Usage) -> usize {
    let mut ids: Vec<u32> = u
        .framebuffer_reads
        .iter()
        .filter_map(|h| match module.exprs[*h] {
            Expr::FramebufferRead { framebuffer, .. } => Some(framebuffer),
            _ => None,
        })
        .collect();
    ids.sort();
    ids.dedup();
    ids.len()
}

/// What an operation is called in a message.
fn operation_name(module: &Module, h: Handle<Expr>) -> String {
    match &module.exprs[h] {
        // The mux selects on one scalar, spare0.a (Kilgard 2000, Section
        // 4.2.2): a step of a colour is one per channel.
        Expr::Math { fun: MathFunction::Step, args } if module.info(args[1]).ty != crate::ir::Ty::Scalar => {
            "`step` of each channel of a vector (the mux selects on one scalar, spare0.a)".into()
        }
        Expr::Math { fun, .. } => format!("`{}`", fun.name()),
        Expr::Binary { op: BinaryOp::Div, .. } => "a division".into(),
        Expr::Binary { op: BinaryOp::Pow, .. } => "a power with a non-constant or fractional exponent".into(),
        _ => "an operation".into(),
    }
}

/// Per-sample operations a combiner program needs (see the module doc), or
/// the first operation the combiners cannot do at all (normalize, division,
/// sqrt, …: Kilgard 2000, Section 4.2 has none of them; use a normalization
/// cube map or a lookup texture).
pub fn combiner_operations(module: &Module, value: Handle<Expr>) -> Result<usize, Handle<Expr>> {
    combiner_operations_except(module, value, &Default::default())
}

/// [`combiner_operations`] but for the nodes in `texture_shader`, which
/// the texture shader computes (a HILO map's dot products, [`super::hilo`]).
fn combiner_operations_except(
    module: &Module,
    value: Handle<Expr>,
    texture_shader: &rustc_hash::FxHashSet<Handle<Expr>>,
) -> Result<usize, Handle<Expr>> {
    let mut n = 0;
    for h in module.reachable(&[value]) {
        if !module.info(h).freq.is_sample() || texture_shader.contains(&h) {
            continue;
        }
        n += match &module.exprs[h] {
            Expr::Binary { op: BinaryOp::Pow, rhs, .. } => match &module.exprs[*rhs] {
                Expr::Constant(c) if c.components[0] >= 1.0 && c.components[0].fract() == 0.0 => {
                    (c.components[0].log2().ceil() as usize).max(1)
                }
                _ => return Err(h),
            },
            // x / k: a product by the constant 1/k (`lowering::reciprocal_of_divisor`).
            Expr::Binary { op: BinaryOp::Div, .. }
                if crate::lowering::reciprocal_of_divisor(module, h).is_some() =>
            {
                1
            }
            Expr::Binary { op: BinaryOp::Div, .. } => return Err(h),
            Expr::Binary { .. } | Expr::Combine { .. } | Expr::Select { .. } => 1,
            // max(0, x) and min(1, x) are an unsigned mapping and a clamp: free.
            Expr::Math { fun: MathFunction::Max, args }
                if args.iter().any(|a| module.is_constant(*a, 0.0)) =>
            {
                0
            }
            Expr::Math { fun: MathFunction::Min, args }
                if args.iter().any(|a| module.is_constant(*a, 1.0)) =>
            {
                0
            }
            Expr::Math { fun: MathFunction::Clamp, args }
                if module.is_constant(args[1], 0.0) && module.is_constant(args[2], 1.0) =>
            {
                0
            }
            Expr::Math { fun, .. } => match fun {
                MathFunction::Expand
                | MathFunction::HalfBias
                | MathFunction::Saturate
                | MathFunction::Compress => 0,
                MathFunction::Mix | MathFunction::Abs => 1,
                // min(a, b), max(a, b): the mux after an offset, or a
                // difference and its clamp; clamp(x, lo, hi) both (codegen
                // `ops.rs`, `desugar.rs`).
                MathFunction::Max | MathFunction::Min => 2,
                MathFunction::Clamp => 4,
                // step(e, x): an offset and the mux (`lowering::no_combiner_op`).
                MathFunction::Step if !crate::lowering::no_combiner_op(module, h) => 2,
                _ => return Err(h),
            },
            _ => 0,
        };
    }
    Ok(n)
}

/// ⊕ and arithmetic nodes per sample: one texture-environment stage each.
fn combines(module: &Module, value: Handle<Expr>) -> usize {
    module
        .reachable(&[value])
        .into_iter()
        .filter(|h| {
            module.info(*h).freq.is_sample()
                && matches!(module.exprs[*h], Expr::Combine { .. } | Expr::Binary { .. })
        })
        .count()
}

/// GL clamps a vertex colour to [0, 1] (OpenGL 1.2.1, Section 2.13.9):
/// the texture environment and the register combiners read an
/// interpolated colour that may leave it clamped, not as the program
/// means. Its refusal, located. `exempt`: interpolants a `⊕` the program
/// writes takes as its incoming colour, which the language's `⊕` (GL's
/// texture environment, docs/language.md) reads clamped anyway.
fn wide_vertex_colour(module: &Module, u: &Usage, exempt: &[Handle<Expr>]) -> Result<(), Overflow> {
    let wide = u.interpolants.iter().copied().filter(|h| !exempt.contains(h)).find(|h| {
        let i = module.info(*h);
        i.ty.is_color() && (i.interval.lo < 0.0 || i.interval.hi > 1.0)
    });
    let Some(h) = wide else { return Ok(()) };
    let i = module.info(h).interval;
    Err(Overflow {
        resource: format!(
            "interpolates a colour in {}, which GL clamps to [0, 1] as a vertex colour (OpenGL 1.2.1, Section 2.13.9)",
            in_words(module, h)
        ),
        need: 0,
        have: 0,
        at: Some(h),
        help: Some(if i.hi.is_finite() {
            "split the sum inside δ into terms that stay in [0, 1], or scale it into [0, 1] and back up by a blend".into()
        } else {
            "its value has no upper bound (a light's `intensity`, a uniform with no range): clamp it with `saturate(…)` inside δ where GL's clamp is intended, or bound what it is made of".into()
        }),
    })
}

/// A scalar interpolant the texture environment reads as a value (not a
/// lookup's coordinate) is a vertex colour's channel there, which GL
/// clamps to [0, 1] as it clamps the colour (OpenGL 1.2.1, Section
/// 2.13.9): `δ(1.2·max(0, N·L))` is read as `min(1, …)`, not as the
/// program means. Its refusal, located, as [`wide_vertex_colour`]'s.
fn wide_scalar_colour(module: &Module, u: &Usage, value: Handle<Expr>) -> Result<(), Overflow> {
    let wide: Vec<Handle<Expr>> = u
        .interpolants
        .iter()
        .copied()
        .filter(|h| {
            let i = module.info(*h);
            i.ty == Ty::Scalar && (i.interval.lo < 0.0 || i.interval.hi > 1.0)
        })
        .collect();
    if wide.is_empty() {
        return Ok(());
    }
    let read = module.reachable(&[value]).into_iter().find_map(|n| match module.exprs[n] {
        Expr::Lookup { .. } => None,
        _ => module.operands(n).into_iter().find(|o| wide.contains(o)),
    });
    let Some(h) = read else { return Ok(()) };
    let i = module.info(h).interval;
    Err(Overflow {
        resource: format!(
            "interpolates a value in {}, which GL clamps to [0, 1] as a vertex colour (OpenGL 1.2.1, Section 2.13.9)",
            in_words(module, h)
        ),
        need: 0,
        have: 0,
        at: Some(h),
        help: Some(if i.hi.is_finite() {
            "keep what is interpolated in [0, 1] (a constant past 1 outside δ), or scale it into [0, 1] and back up by a blend".into()
        } else {
            "its value has no upper bound: clamp it with `saturate(…)` inside δ where GL's clamp is intended, or bound what it is made of".into()
        }),
    })
}

/// The texture environment clamps each stage's result to [0, 1] (OpenGL
/// 1.3, Section 3.8.13; ARB_texture_env_combine): a value whose
/// intermediate sum, difference or scaled product may leave [0, 1]
/// (`T4·(T5·δl + T4 + T3)`, the sum up to 3) is not what one pass of
/// stages computes. Its refusal, located at that operation; the last
/// stage's clamp is the framebuffer's (and a `saturate`'s) anyway. A `⊕`
/// the program writes is that stage itself (docs/language.md: the
/// texture environment's modes, which GL clamps and the hardware models
/// do), so only arithmetic is judged.
fn stage_result_clamped(module: &Module, value: Handle<Expr>) -> Result<(), Overflow> {
    let nodes = module.reachable(&[value]);
    // The output and what a `saturate` clamps, through widenings and
    // clamps (`saturate(rgba(x, 1))`, the source of a blend GL clamps):
    // the stage's clamp is theirs.
    let mut exempt = Vec::new();
    let mut roots = vec![value];
    for &h in &nodes {
        match &module.exprs[h] {
            Expr::Math { fun: MathFunction::Saturate, args } => roots.extend(args.iter().copied()),
            // `a + b − ½` is one ADD_SIGNED stage (ARB_texture_env_combine):
            // its sum, read nowhere else, is no stage's result.
            Expr::Binary { op: BinaryOp::Sub, lhs, rhs }
                if module.is_constant(*rhs, 0.5)
                    && matches!(module.exprs[*lhs], Expr::Binary { op: BinaryOp::Add, .. })
                    && nodes.iter().all(|&n| n == h || !module.exprs[n].operands().contains(lhs)) =>
            {
                exempt.push(*lhs);
            }
            _ => {}
        }
    }
    while let Some(mut root) = roots.pop() {
        exempt.push(root);
        loop {
            root = match &module.exprs[root] {
                Expr::Convert { value: inner, .. } => *inner,
                Expr::Math { fun: MathFunction::Saturate, args } => args[0],
                _ => break,
            };
            exempt.push(root);
        }
        exempt_partial_sums(module, root, &mut exempt);
    }
    let wide = nodes.into_iter().find(|&h| {
        let i = module.info(h);
        !exempt.contains(&h)
            && i.freq.is_sample()
            && matches!(module.exprs[h], Expr::Binary { .. })
            && (i.interval.lo < 0.0 || i.interval.hi > 1.0)
    });
    let Some(h) = wide else { return Ok(()) };
    Err(Overflow {
        resource: format!(
            "computes an intermediate result in {}, which the texture environment clamps to [0, 1] after each stage (OpenGL 1.3, Section 3.8.13)",
            in_words(module, h)
        ),
        need: 0,
        have: 0,
        at: Some(h),
        help: Some("keep each partial sum and scaled product in [0, 1] (halve it and double it back by a blend), or target a programmable stage".into()),
    })
}

/// Partial sums of terms ≥ 0 on the way to a clamped result: the clamp of
/// one is the result's, min(1, min(1, a) + b) = min(1, a + b) for a,
/// b ≥ 0 (as between passes). Added to `exempt`.
fn exempt_partial_sums(module: &Module, root: Handle<Expr>, exempt: &mut Vec<Handle<Expr>>) {
    let mut stack = vec![root];
    while let Some(h) = stack.pop() {
        if let Expr::Binary { op: BinaryOp::Add, lhs, rhs } = module.exprs[h] {
            if module.info(lhs).interval.lo >= 0.0 && module.info(rhs).interval.lo >= 0.0 {
                for o in [lhs, rhs] {
                    if !exempt.contains(&o) {
                        exempt.push(o);
                        stack.push(o);
                    }
                }
            }
        }
    }
}

/// The interpolants a `⊕` takes directly as an operand (through a
/// widening to rgba): GL's incoming fragment colour.
fn combine_operands(module: &Module, value: Handle<Expr>) -> Vec<Handle<Expr>> {
    let through = |h: Handle<Expr>| match module.exprs[h] {
        Expr::Convert { value, .. } => value,
        _ => h,
    };
    module
        .reachable(&[value])
        .into_iter()
        .filter_map(|h| match module.exprs[h] {
            Expr::Combine { lhs, rhs, .. } => Some([through(lhs), through(rhs)]),
            _ => None,
        })
        .flatten()
        .filter(|h| matches!(module.exprs[*h], Expr::Interpolate { .. }))
        .collect()
}

/// `h`'s range as a refusal prints it, `[0, 1.8]` (`∞` where unbounded).
fn in_words(module: &Module, h: Handle<Expr>) -> String {
    let i = module.info(h).interval;
    let bound =
        |x: f64| if x.is_finite() { format!("{}", (x * 100.0).round() / 100.0) } else { "∞".into() };
    format!("[{}, {}]", bound(i.lo), bound(i.hi))
}
