//! The pass planner: turns a lowered program into rendering
//! passes a target can run.
//!
//! 1. **Capabilities first.** `profile::fit` errors (a dependent lookup on
//!    geforce256, arithmetic on the texture environment) cannot be split
//!    away: the plan fails with them.
//! 2. **Specialization** (`specialize.rs`): constant folding happened in
//!    lowering; terms whose coefficient is exactly zero go, with the
//!    textures and passes only they used.
//! 3. **Statements to blends.** A statement `C δπx ← (C δπx) ⊕ e` is `e`
//!    blended into C (Pipeline Grammar, eq. (9)); `classify` reads the blend off the
//!    value's affine form in the framebuffer's own colour (and its alpha:
//!    Kilgard's GL_DST_ALPHA passes, Kilgard 2000, Section 5.5).
//! 4. **Fusion.** Consecutive statements on the same framebuffer and
//!    geometry are fused (the later one reading the earlier one's value)
//!    when the fused value plans into fewer passes — Kilgard's three passes
//!    collapse on geforce3.
//! 5. **Splitting** (`split.rs`): a value that does not fit one pass is split
//!    by framebuffer blending or render-to-texture, minimizing passes, then
//!    texture fetches.
//!
//! Texgen statements (`u x ← …`, Pipeline Grammar, eq. (7)) are no pass: they are vertex
//! work of every pass that reads the coordinates.

pub mod affine;
pub mod algebra;
mod alpha_test;
mod assemble;
mod clamps;
mod copy;
pub mod fit;
mod form;
pub mod hilo;
pub mod lights;
mod piece;
pub mod realize;
pub mod relevance;
mod rendered;
mod rewrite;
pub mod shadow_map;
pub mod shadow_mask;
pub mod shadow_volumes;
pub mod specialize;
pub mod split;
mod stencil;
pub mod storage;

use rustc_hash::FxHashMap as HashMap;

use crate::pipeline::{
    BlendMode, FragmentWork, Geometry, Pass, PassPlan, Planned, Removed, RenderTarget, TextureBinding, Value,
    VertexWork,
};
pub use realize::{Realized, Realizer, Refusal};
pub use split::{FitCheck, Overflow};

use affine::Builder;
use split::{Dest, Piece, SplitCache, Splitter, Storage};

pub use assemble::depth_key;
use assemble::*;
use form::*;
pub use form::{blended_as_gl, clamped_blend_source, classify, substitute, whole_form};
use rewrite::*;

use crate::diag::Diagnostic;
use crate::ir::{self, BinaryOp, Expr, FbChannel, Frequency, Handle, Module, Statement, Table, Usage};
use crate::parser::ast::CombineMode;
use crate::pipeline::{AlphaTest, BlendState, CullMode, DepthState, RenderState, StencilOp, StencilState};
use crate::profile::{FragmentStage, Profile};
use crate::span::{LineIndex, Span};

/// At most this many consecutive statements are fused into one value (the
/// fusion search is quadratic in the run; eight is more than any pass of
/// the papers combines).
pub const MAX_FUSE: usize = 8;

/// A planned (possibly fused) statement: its statements, form, passes and reason.
type Chosen = (Vec<usize>, Form, Vec<Piece>, String);

/// How a (possibly fused) statement meets its target.
#[derive(Clone, Debug, PartialEq)]
pub struct Form {
    pub blend: BlendMode,
    /// What the fragment stage computes.
    pub value: Handle<Expr>,
    /// `c ? a` with no `:`: discard where `c` is zero.
    pub condition: Option<Handle<Expr>>,
    /// A stencil test or a stencil write replaces colour work.
    pub stencil: Option<StencilState>,
    pub depth: Option<DepthState>,
    /// Channels written: `rgba`, `a`, `stencil`, `none`.
    pub channels: &'static str,
    /// A blend needing two passes (`C ← C·m + s`): the second value.
    pub then_add: Option<Handle<Expr>>,
    /// The geometry rasterized when it is not the statement's own index:
    /// the shadow volume `δπx′` whose depth a stencil update compares.
    pub drawn_at: Option<Handle<Expr>>,
}

/// How splits are searched.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Search {
    /// Memoized, exact subset DP for chains, greedy for long ones.
    #[default]
    Planner,
    /// Brute force over every set partition (the optimality test's reference;
    /// exponential: for programs of a few dozen operations at most).
    Exhaustive,
}

/// What a plan is asked for, besides the module and the profile. Build one
/// through [`crate::driver`], which supplies the realizer a target needs.
#[derive(Clone, Copy, Default)]
pub struct Request<'a> {
    /// The program's text: the plan's positions are its `line:col`.
    pub source: Option<&'a str>,
    pub search: Search,
    /// Plan for one scene ([`SceneSpecialization`]); `None`: for any scene.
    pub scene: Option<&'a SceneSpecialization<'a>>,
    /// The target's fixed-function fragment stage, which decides whether a
    /// value fits one pass (the combiner code generator on geforce256 and
    /// geforce3); required on those targets.
    pub realizer: Option<&'a dyn Realizer>,
    /// What the lowering may do when the program as written does not plan
    /// (`--no-approx`, `--max-error`).
    pub lowering: crate::lowering::LowerOptions,
}

/// Scene-driven specialization.
pub struct SceneSpecialization<'s> {
    pub scene: &'s crate::scene::Scene,
    /// The scene's meshes (`Scene::build`): light relevance is per object.
    pub assets: &'s crate::scene::SceneAssets,
    /// The program's texture declarations (`scene::bind::texture_decls`):
    /// normalization cube maps keep the cone of their coordinates.
    pub textures: &'s [crate::scene::bind::TextureDecl],
    /// Fold the uniforms the scene sets (and drop the terms they zero).
    pub fold_uniforms: bool,
    /// Cull lights whose terms add at most this much to any pixel of an
    /// object (summed over the culled lights); `None`: no culling.
    pub cull_threshold: Option<f64>,
}

/// The light culling threshold of `compile --scene`: half an 8-bit step,
/// so that an RGBA8 framebuffer rounds to the same pixel.
pub const DEFAULT_CULL_THRESHOLD: f64 = 0.5 / 255.0;

/// Per statement of the expanded module: its light, the objects it is
/// drawn for, and its source statement.
#[derive(Clone, Debug, Default)]
struct PerLight {
    light: Vec<Option<u32>>,
    objects: Vec<Option<Vec<usize>>>,
    source: Vec<usize>,
}

/// The module made ready for planning: what specialization removed, the
/// statements' lights and names, and the statements culled for every object.
struct Prepared {
    removed: Vec<Removed>,
    per_light: PerLight,
    culled: Vec<usize>,
    names: Vec<String>,
}

/// The two fits a run of statements is planned with: the target's, and the
/// compiler's own for a `bake` table's texel pass, which runs on the CPU
/// with no fragment-stage limits.
struct Fits<'p> {
    target: fit::ProfileFit<'p>,
    compiler: fit::ProfileFit<'p>,
    cache: SplitCache,
    compiler_cache: SplitCache,
    /// Statement values rewritten into their canonical form so that the
    /// target could run them at all: their other forms compete too.
    canonical: Vec<Handle<Expr>>,
}

impl Fits<'_> {
    /// The fit a statement is planned under: the compiler's for a `bake`
    /// table (computed on the CPU), else the target's.
    fn fit(&self, baked: bool) -> &dyn split::FitCheck {
        if baked {
            &self.compiler
        } else {
            &self.target
        }
    }
}

/// Plans `module` for `profile` (the numbered steps of this module's doc).
/// With a scene in `request`: one pass per light for a program written for
/// light 0 ([`lights`]), then — as the specialization asks — the scene's
/// uniforms folded with their zero terms, textures and passes, and the
/// lights that cannot reach an object culled for it ([`relevance`]).
///
/// The program as written first; only when that does not plan, lowered
/// ([`crate::lowering`]) — each choice of rules, most accurate
/// first, until one plans within `request.lowering`; with `--max-error`
/// every choice within the bound is planned and the one the target's cost
/// model predicts fastest is taken; the program's own refusal
/// when none plans.
pub fn plan(module: &Module, profile: &Profile, request: &Request) -> Result<Planned, Vec<Diagnostic>> {
    let written = plan_as_written(module, profile, request);
    // The exhaustive search is the optimality test's reference for the
    // splits; a lowered program's long products would make it explode.
    if written.is_ok() || !request.lowering.approximate || request.search == Search::Exhaustive {
        return written;
    }
    let (fitting, tried) = plan_lowerings(module, profile, request);
    if let Some(planned) = fastest_lowering(fitting, profile) {
        return Ok(planned);
    }
    written.map_err(|errors| match tried {
        Some(tried) => refusal_after_lowering(errors, &tried),
        None => errors,
    })
}

/// A lowering that did not make the program plan: the names of the rules
/// it applied, and the lowered program's refusal.
struct Tried {
    rules: Vec<String>,
    refusal: Vec<Diagnostic>,
}

/// The program lowered by each choice of rules ([`crate::lowering`], most
/// accurate first) and planned as written: the plans that fit — only the
/// first without `--max-error`, every one within the bound with it — and
/// the first choice that did not plan.
fn plan_lowerings(module: &Module, profile: &Profile, request: &Request) -> (Vec<Planned>, Option<Tried>) {
    let index = request.source.map(|s| (LineIndex::new(s), s));
    let at = |span: Span| at_text(&index, span);
    let mut tried: Option<Tried> = None;
    let mut fitting: Vec<Planned> = Vec::new();
    let choices = match request.lowering.only {
        Some(only) => vec![only],
        None => crate::lowering::choices(profile),
    };
    for choice in choices {
        let bounds = request.scene.and_then(|s| crate::lowering::solid::Bounds::of_meshes(&s.assets.meshes));
        let lowered = crate::lowering::lower_for(module, profile, choice, &at, bounds);
        let within = request.lowering.only.is_some() || lowered.within(&request.lowering);
        // A by-term fall-back that split no sum is the whole-sum one.
        if lowered.approximations.is_empty() || !within || (choice.by_term && lowered.split_sums == 0) {
            continue;
        }
        match plan_as_written(&lowered.module, profile, request) {
            Ok(mut planned) => {
                planned.plan.approximations = lowered.approximations;
                fitting.push(planned);
                if request.lowering.max_error.is_none() {
                    break; // the most accurate that plans
                }
            }
            Err(refusal) => {
                let mut rules: Vec<String> = lowered.approximations.iter().map(|a| a.rule.clone()).collect();
                rules.dedup();
                tried.get_or_insert(Tried { rules, refusal });
            }
        }
    }
    (fitting, tried)
}

/// The program's own refusal (`errors`, as written) when no lowering made
/// it plan either, saying what the lowering `tried` so that the refusal
/// does not read as if the first obstacle were the only one.
fn refusal_after_lowering(mut errors: Vec<Diagnostic>, tried: &Tried) -> Vec<Diagnostic> {
    let Tried { rules, refusal: lowered } = tried;
    // A missing capability the lowering supplied (signed textures) is
    // not why the program is refused: the ones it left are.
    let left: Vec<Diagnostic> = errors
        .iter()
        .filter(|d| d.code != "unsupported-by-target" || lowered.iter().any(|l| l.message == d.message))
        .cloned()
        .collect();
    if !left.is_empty() {
        errors = left;
    }
    // The lowering removed the first obstacle (`normalize` became a cube
    // map) but not the program's refusal: what it left is the reason,
    // and the obstacle it removed is named in the help, not as the
    // reason (a refusal for `normalize` would read as if lowering it
    // were the user's work).
    let removed = errors.first().is_some_and(|d| lowered.iter().all(|l| l.message != d.message));
    if let (true, Some(written)) = (removed, errors.first().filter(|d| d.code == "cannot-split")) {
        if !lowered.is_empty() {
            return lowered_refusal_naming_the_removed_obstacle(written, tried);
        }
    }
    let message = lowered.first().map_or(String::new(), |d| d.message.clone());
    if let Some(d) = errors.first_mut().filter(|d| d.message != message) {
        let tried = format!("the lowering ({}) does not make it plan either: {message}", rules.join(", "));
        d.help = Some(match d.help.take() {
            Some(help) if !help.is_empty() => format!("{help}; {tried}"),
            _ => tried,
        });
    }
    errors
}

/// The lowered program's refusal, its help naming the obstacle of the
/// program as `written` (a part that cannot be split) that the lowering
/// removed. `tried.refusal` is not empty.
fn lowered_refusal_naming_the_removed_obstacle(written: &Diagnostic, tried: &Tried) -> Vec<Diagnostic> {
    let Tried { rules, refusal: lowered } = tried;
    let Some(first) = lowered.first() else { return Vec::new() };
    let written = written.message.clone();
    let mut d = first.clone();
    // "… further needs `normalize` per fragment, which …" → "needs `normalize` per fragment".
    let tail = written.split(": ").last().unwrap_or(&written);
    let what = tail.trim_start_matches("a part that cannot be divided further ");
    let what = what.split(", which").next().unwrap_or(what);
    let note = match what.strip_prefix("needs ") {
        Some(need) => {
            format!("as written it also needs {need}, which the lowering ({}) supplies", rules.join(", "))
        }
        None => format!(
            "the lowering ({}) removes another obstacle of the program as written: {what}",
            rules.join(", ")
        ),
    };
    d.help = Some(match d.help.take() {
        Some(help) if !help.is_empty() => format!("{help}; {note}"),
        _ => note,
    });
    let mut out = vec![d];
    out.extend(lowered.iter().skip(1).cloned());
    out
}

/// Of lowered plans that fit, the one the target's cost model predicts
/// fastest on the nominal workload (the first, the most accurate, on a tie
/// or without a model); its first approximation says so when it beat
/// another.
fn fastest_lowering(fitting: Vec<Planned>, profile: &Profile) -> Option<Planned> {
    let Some(model) = &profile.cost else { return fitting.into_iter().next() };
    let nominal = crate::cost::Workload::nominal();
    let mut timed: Vec<(f64, Planned)> = fitting
        .into_iter()
        .map(|p| (crate::cost::predict(&p.plan, &p.module, model, &nominal).total_ms(), p))
        .collect();
    let best = (0..timed.len()).min_by(|&a, &b| timed[a].0.total_cmp(&timed[b].0).then(a.cmp(&b)))?;
    // Choices that came to the same rules are one plan, not a rival.
    let others: Vec<String> = timed
        .iter()
        .enumerate()
        .filter(|(i, (ms, p))| {
            *i != best && *ms > timed[best].0 && rule_names(&p.plan) != rule_names(&timed[best].1.plan)
        })
        .map(|(_, (ms, p))| format!("{:.3} ms with {}", ms, rule_names(&p.plan)))
        .collect();
    let (ms, mut planned) = timed.swap_remove(best);
    if let (Some(first), false) = (planned.plan.approximations.first_mut(), others.is_empty()) {
        first.why += &format!(
            "; the fastest lowering within --max-error: predicted {ms:.3} ms against {}",
            others.join(", ")
        );
    }
    Some(planned)
}

fn rule_names(plan: &PassPlan) -> String {
    let mut rules: Vec<&str> = plan.approximations.iter().map(|a| a.rule.as_str()).collect();
    rules.dedup();
    rules.join(" + ")
}

/// `line:col` of `span`, `-` without a source or for a built node.
fn at_text(index: &Option<(LineIndex, &str)>, span: Span) -> String {
    match (index, span == Span::DETACHED) {
        (Some((ix, text)), false) => {
            let lc = ix.line_col(text, span.start as usize);
            format!("{}:{}", lc.line, lc.col)
        }
        _ => "-".to_string(),
    }
}

/// The program as written planned for `profile` (steps 1-6 of this
/// module's doc, no lowering), or its refusal.
fn plan_as_written(
    module: &Module,
    profile: &Profile,
    request: &Request,
) -> Result<Planned, Vec<Diagnostic>> {
    let mut m = module.clone();
    shadow_map::depth_tests_as_greater(&mut m);
    shadow_map::redraw_over_geometry(&mut m, profile);
    let depth_replaced = shadow_mask::redraw_with_replaced_depth(&mut m, profile);
    let copies = copy::read_own_colour_through_a_copy(&mut m);
    let canonical = canonical_when_unfit(&mut m, profile)?;
    if matches!(profile.fragment, FragmentStage::Combiners(_)) && request.realizer.is_none() {
        let what = "planned for a register-combiner target without its code generator";
        return Err(vec![Diagnostic::error("internal-error", what, Span::DETACHED, "").with_help(
            "plan through `shadec::driver`, which passes the target's generator to the planner",
        )]);
    }
    let index = request.source.map(|s| (LineIndex::new(s), s));
    let at = |span: Span| at_text(&index, span);
    let mut prepared = prepare(&mut m, request.scene, &at)?;
    copy::renumber(&copies, &mut prepared);
    let compiler = Profile { fragment: FragmentStage::Programmable, ..profile.clone() };
    let mut fits = Fits {
        target: fit::ProfileFit::new(profile, request.realizer),
        compiler: fit::ProfileFit::new(&compiler, None),
        cache: SplitCache::default(),
        compiler_cache: SplitCache::default(),
        canonical,
    };
    let (mut chosen, mut diags) = choose(&mut m, profile, request.search, &mut fits, &prepared);
    diags.extend(reused_projection(&m));
    diags.extend(crate::planner::shadow_volumes::unbound_uses(&m));
    if !diags.is_empty() {
        return Err(diags);
    }
    // Texgen statements by the coordinate set they write.
    let texgen: HashMap<u32, String> = m
        .statements
        .iter()
        .filter_map(|st| match st.table {
            Table::TexCoords(id) => Some((id, m.texcoord_sets[id as usize].name.clone())),
            _ => None,
        })
        .collect();
    let routed = alpha_test::route(&mut m, profile, request.realizer, &mut chosen)?;
    let ctx = AssembleCtx { profile, realizer: request.realizer, texgen: &texgen, at: &at };
    let (mut plan, mut stages) = assemble(&m, &ctx, &chosen, prepared);
    // One pass per piece, in order: each takes its piece's alpha test.
    for (pass, (test, masked)) in plan.passes.iter_mut().zip(routed) {
        pass.state.alpha_test = test;
        pass.state.blend.write_mask[3] &= !masked;
    }
    shadow_map::equal_depth(&m, &mut plan.passes);
    depth_replacing(&m, &ctx, &depth_replaced, &mut plan, &mut stages);
    assemble::depth_prepasses(&mut m, &ctx, &mut plan, &mut stages);
    if let Some(d) = storage::float_framebuffer_read_back(module, &plan, profile) {
        return Err(vec![d]);
    }
    // Counting the volume by facing may draw one pass twice (one-sided
    // stencil): each copy runs its original's fragment setup.
    let origins =
        crate::planner::shadow_volumes::count_by_facing(&m, &mut plan.passes, profile.two_sided_stencil);
    let stages: Vec<_> = origins.iter().filter_map(|&i| stages.get(i).cloned()).collect();
    let stages = runnable_stages(stages)?;
    let setups = crate::pipeline::setup::resolve_all(&m, &plan, stages);
    let planned = Planned {
        module: m,
        plan,
        combiners: profile.combiner_limits(),
        vertex_programs: profile.vertex_programs,
        setups,
    };
    planned.validate().map(|()| planned)
}

/// The shadow mask's redraws (`shadow_mask`): their passes replace the
/// fragment's depth and read the light's map on unit 0, so their combiner
/// setup is made again with that unit, and the plan lists the new values.
fn depth_replacing(
    m: &Module,
    ctx: &AssembleCtx,
    replaced: &[shadow_mask::DepthReplaced],
    plan: &mut PassPlan,
    stages: &mut [assemble::Stage],
) {
    let changed = shadow_mask::depth_replacing_passes(m, plan, replaced);
    for &k in &changed {
        let value = Handle::new(plan.passes[k].fragment.output as usize);
        let stage = assemble::combiner_setup(m, ctx.realizer, value, &plan.passes[k].textures);
        plan.passes[k].fragment.general_combiners = stage.as_ref().ok().and_then(|s| match s {
            crate::pipeline::FragmentSetup::Combiners(p) => Some(p.stages()),
            _ => None,
        });
        stages[k].1 = stage;
    }
    if !changed.is_empty() {
        let mut roots: Vec<Handle<Expr>> = plan.values.iter().map(|v| Handle::new(v.id as usize)).collect();
        roots.extend(replaced.iter().flat_map(|r| [r.read, r.depth]));
        plan.values = assemble::plan_values(m, &roots, ctx.at);
    }
}

/// The statements' values rewritten into their canonical forms
/// ([`algebra`]) when the program as written needs what the target lacks:
/// the lack may be only how it is written (a `lerp` on the texture
/// environment is a sum of products it has). The rewritten values, to
/// compete with their other forms; none when the program fits as written;
/// the target's refusal when the canonical forms leave a missing capability.
fn canonical_when_unfit(m: &mut Module, profile: &Profile) -> Result<Vec<Handle<Expr>>, Vec<Diagnostic>> {
    let errors: Vec<Diagnostic> =
        crate::profile::fit(m, profile).into_iter().filter(|d| d.is_error()).collect();
    if errors.is_empty() {
        return Ok(Vec::new());
    }
    let changed = algebra::canonical_statements(m, |m, i| {
        let st = m.statements[i].clone();
        if !matches!(st.table, Table::Framebuffer { channel: FbChannel::Color, .. }) {
            return None;
        }
        whole_form(m, &st, st.value).ok().and_then(|f| framebuffer_clamped(m, &st, &f))
    });
    if changed.is_empty() || crate::profile::fit(m, profile).iter().any(|d| d.is_error()) {
        return Err(errors);
    }
    Ok(changed.iter().map(|&i| m.statements[i].value).collect())
}

/// The fragment setup of every pass, or the refusals of the passes the
/// target cannot run: such a pass is refused here, never planned (a pass
/// the target cannot run is not representable in `Planned`).
fn runnable_stages(
    stages: Vec<Stage>,
) -> Result<Vec<(Span, crate::pipeline::FragmentSetup)>, Vec<Diagnostic>> {
    let mut refused = Vec::new();
    let stages: Vec<_> = stages
        .into_iter()
        .map(|(span, stage)| {
            (
                span,
                stage.unwrap_or_else(|d| {
                    refused.push(*d);
                    crate::pipeline::FragmentSetup::Programmable
                }),
            )
        })
        .collect();
    if refused.is_empty() {
        Ok(stages)
    } else {
        Err(refused)
    }
}

/// Steps 1-2 for a scene: lights expanded and culled, the scene's uniforms
/// bound, zero terms removed.
fn prepare(
    m: &mut Module,
    spec: Option<&SceneSpecialization>,
    at: &dyn Fn(Span) -> String,
) -> Result<Prepared, Vec<Diagnostic>> {
    let n = m.statements.len();
    let mut prepared = Prepared {
        removed: Vec::new(),
        per_light: PerLight { light: vec![None; n], objects: vec![None; n], source: (0..n).collect() },
        culled: Vec::new(),
        names: (1..=n).map(|i| i.to_string()).collect(),
    };
    if let Some(spec) = spec {
        expand_lights(m, spec, &mut prepared, at);
        algebra::bound_intensities(m, &spec.scene.lights);
        if spec.fold_uniforms {
            bind_scene_uniforms(m, &spec.scene.constants, &mut prepared.removed, at)?;
        }
    }
    rendered::bound_rendered_reads(m);
    prepared.removed.extend(specialize::specialize(m, at));
    let noops = noop_statements(m, &prepared, at);
    prepared.removed.extend(noops);
    Ok(prepared)
}

/// One pass per scene light, then the lights culled per object.
fn expand_lights(
    m: &mut Module,
    spec: &SceneSpecialization,
    prepared: &mut Prepared,
    at: &dyn Fn(Span) -> String,
) {
    let expansion = lights::expand(m, spec.scene.lights.len(), at);
    prepared.removed.extend(expansion.notes.iter().cloned());
    let n = m.statements.len();
    let mut per_light =
        PerLight { light: vec![None; n], objects: vec![None; n], source: Vec::with_capacity(n) };
    for i in 0..n {
        per_light.source.push(expansion.source.get(i).copied().unwrap_or(i));
        per_light.light[i] = expansion.light_of(i);
    }
    prepared.names = (0..n)
        .map(|i| match per_light.light[i] {
            Some(l) if spec.scene.lights.len() > 1 => format!("{} (light {l})", per_light.source[i] + 1),
            _ => (per_light.source[i] + 1).to_string(),
        })
        .collect();
    if let Some(threshold) = spec.cull_threshold {
        let culled = relevance::cull(m, spec, &expansion, threshold, &prepared.names, at);
        prepared.removed.extend(culled.removed);
        prepared.culled = culled.statements;
        for (i, objects) in culled.objects {
            per_light.objects[i] = Some(objects);
        }
    }
    prepared.per_light = per_light;
}

/// The scene's values for the program's uniforms, folded; a value of the
/// wrong size is an error at the uniform's declaration.
fn bind_scene_uniforms(
    m: &mut Module,
    values: &std::collections::BTreeMap<String, Vec<f32>>,
    removed: &mut Vec<Removed>,
    at: &dyn Fn(Span) -> String,
) -> Result<(), Vec<Diagnostic>> {
    let (bound, mismatched) = specialize::bind_uniforms(m, values, at);
    if mismatched.is_empty() {
        removed.extend(bound);
        return Ok(());
    }
    Err(mismatched
        .into_iter()
        .map(|what| {
            let name = what.split('`').nth(1).unwrap_or_default().to_string();
            let span = m.uniforms.iter().find(|u| u.name == name).map_or(Span::DETACHED, |u| u.span);
            Diagnostic::error(
                "scene-value",
                format!("the scene's value does not fit: {what}"),
                span,
                "declared here",
            )
            .with_help("give one number, or one per component, in the scene's `constants`")
        })
        .collect())
}

/// Steps 3-5 over the live statements: each run of fusable statements
/// planned by [`plan_run`]; what cannot be planned is a diagnostic.
fn choose(
    m: &mut Module,
    profile: &Profile,
    search: Search,
    fits: &mut Fits,
    prepared: &Prepared,
) -> (Vec<Chosen>, Vec<Diagnostic>) {
    let live: Vec<usize> = (0..m.statements.len())
        .filter(|&i| {
            !matches!(m.statements[i].table, Table::TexCoords(_))
                && !specialize::is_noop(m, &m.statements[i])
                && !prepared.culled.contains(&i)
        })
        .collect();
    let mut chosen = Vec::new();
    let mut diags = Vec::new();
    let mut k = 0;
    while k < live.len() {
        let run = fusable_run(m, &live[k..], &prepared.per_light);
        match plan_run(m, profile, search, fits, &run, &prepared.names) {
            Ok(v) => chosen.extend(v),
            Err(d) => diags.push(d),
        }
        k += run.len();
    }
    (chosen, diags)
}

/// The statements a statement may be fused with: a run of fusable
/// statements from `live[0]`, at most [`MAX_FUSE`]; a light after the first
/// keeps its own passes.
fn fusable_run(m: &Module, live: &[usize], per_light: &PerLight) -> Vec<usize> {
    let own_pass = |i: usize| per_light.light[i].is_some_and(|l| l > 0);
    let mut run = vec![live[0]];
    while run.len() < MAX_FUSE
        && run.len() < live.len()
        && !own_pass(run[run.len() - 1])
        && !own_pass(live[run.len()])
        && fusable(m, &m.statements[run[run.len() - 1]], &m.statements[live[run.len()]])
    {
        run.push(live[run.len()]);
    }
    run
}

/// The statements live but not planned: left unchanged after specialization.
fn noop_statements(m: &Module, prepared: &Prepared, at: &dyn Fn(Span) -> String) -> Vec<Removed> {
    (0..m.statements.len())
        .filter(|&i| {
            !prepared.culled.contains(&i)
                && !matches!(m.statements[i].table, Table::TexCoords(_))
                && specialize::is_noop(m, &m.statements[i])
        })
        .map(|i| Removed {
            kind: "pass".into(),
            what: format!("statement {}", prepared.names[i]),
            why: "after specialization it leaves its target unchanged".into(),
            at: at(m.statements[i].span),
        })
        .collect()
}

/// Why a candidate group of statements has no plan.
enum Unplanned {
    /// Its value is no blend the framebuffer can do.
    Form(Diagnostic),
    /// It does not fit (fused: one pass; alone: any split).
    Overflow(Overflow),
}

/// Plans one group of statements, `fused` their value ([`fuse`]): its
/// blend form and the passes of its split.
fn candidate(
    m: &mut Module,
    search: Search,
    fits: &mut Fits,
    baked: bool,
    stmts: &[usize],
    fused: Handle<Expr>,
    storage: Storage,
) -> Result<(Form, Vec<Piece>), Unplanned> {
    let (fit, cache) =
        if baked { (&fits.compiler, &mut fits.compiler_cache) } else { (&fits.target, &mut fits.cache) };
    let st = m.statements[stmts[0]].clone();
    // Statements are fused only into one pass: a fused value that must be
    // split again saves nothing the separate statements' blends do not
    // already give, and searching its splits is what would make planning cubic.
    if stmts.len() > 1 {
        if let Err(o) = fit.fits(m, fused) {
            return Err(Unplanned::Overflow(o));
        }
    }
    let form = match classify(m, &st, fused) {
        Ok(f) => f,
        Err(d) => return Err(Unplanned::Form(d)),
    };
    match plan_form(m, fit, cache, &st, &form, storage, search) {
        Ok(pieces) => Ok((form, pieces)),
        Err(o) => Err(Unplanned::Overflow(o)),
    }
}

fn passes_word(n: usize) -> &'static str {
    if n == 1 {
        "pass"
    } else {
        "passes"
    }
}

/// Why a statement was kept apart from the one before (named `a`), when
/// fused they would take `n` passes at `fused` cost against `apart`: no
/// fewer passes, or — the target's cost model deciding — fewer
/// passes predicted slower.
fn not_fused_reason(
    a: &str,
    n: usize,
    fused: split::Cost,
    apart: Option<split::Cost>,
    profile: &Profile,
) -> String {
    match apart {
        Some(apart) if fused.1 < apart.1 && fused.0 > apart.0 => format!(
            "fused with statement {a} it fits {n} {} on {}, but the cost model predicts that slower than apart \
             ({:.3} ms against {:.3} ms)",
            passes_word(n),
            profile.name,
            fused.0 as f64 / 1e6,
            apart.0 as f64 / 1e6
        ),
        _ => format!("fused with statement {a} it needs {n} {} on {}, no fewer than apart", passes_word(n), profile.name),
    }
}

/// What [`plan_run`] learns of a run's groups besides their cost: the first
/// refusal (the run's own when no grouping plans), why a statement was not
/// fused with the one before it, and the statements planned in an
/// equivalent form, with why — each group's reason in the plan says so.
#[derive(Default)]
struct RunNotes {
    first_error: Option<Diagnostic>,
    not_fused: HashMap<usize, String>,
    rewrites: HashMap<usize, String>,
}

impl RunNotes {
    /// Notes why group `stmts` has no plan: a lone statement's form is the
    /// run's refusal; a pair's is why its second statement stays apart
    /// from the first (named `pair_with`).
    fn unplanned(&mut self, why: &Unplanned, stmts: &[usize], pair_with: Option<&str>) {
        match (why, stmts.len(), pair_with) {
            (Unplanned::Form(d), 1, _) => {
                self.first_error.get_or_insert(d.clone());
            }
            (Unplanned::Form(d), _, Some(a)) => {
                self.not_fused.entry(stmts[1]).or_insert(format!("fused with statement {a}, {}", d.message));
            }
            (Unplanned::Overflow(o), _, Some(a)) => {
                self.not_fused.entry(stmts[1]).or_insert(format!("fused with statement {a} it {o}"));
            }
            _ => {}
        }
    }

    /// The reason the plan gives for a chosen group of `passes` passes:
    /// fused, rewritten into an equivalent form, or as written (and why
    /// not fused with the statement before).
    fn reason(&self, stmts: &[usize], passes: usize, names: &[String], profile: &Profile) -> String {
        if stmts.len() > 1 {
            format!(
                "statements {} fused: together they fit {} {} on {}",
                stmts.iter().map(|s| names[*s].clone()).collect::<Vec<_>>().join(", "),
                passes,
                passes_word(passes),
                profile.name
            )
        } else if let Some(note) = self.rewrites.get(&stmts[0]) {
            format!("statement {} {note}", names[stmts[0]])
        } else {
            match self.not_fused.get(&stmts[0]) {
                Some(why) => format!("statement {} as written: {why}", names[stmts[0]]),
                None => format!("statement {} as written", names[stmts[0]]),
            }
        }
    }
}

/// The refusal of a run no grouping plans and no form refused: `st`, its
/// first statement, needs more than the target has.
fn cannot_plan(st: &Statement, profile: &Profile) -> Diagnostic {
    Diagnostic::error(
        "cannot-plan",
        format!("cannot plan this statement for {}", profile.name),
        st.span,
        "here",
    )
    .with_help("simplify the statement or target a profile with more resources")
}

/// Steps 4-5 for one run of fusable statements: the cheapest grouping
/// (fewest passes, then fetches) by dynamic programming over its prefixes,
/// each group with the reason it was fused or kept as written.
fn plan_run(
    m: &mut Module,
    profile: &Profile,
    search: Search,
    fits: &mut Fits,
    run: &[usize],
    names: &[String],
) -> Result<Vec<Chosen>, Diagnostic> {
    let baked = m.is_baked(&m.statements[run[0]]);
    // best[j]: the cheapest plan of run[..j].
    let mut best: Vec<Option<(split::Cost, Vec<Chosen>)>> = vec![None; run.len() + 1];
    best[0] = Some(((0, 0, 0), vec![]));
    let mut notes = RunNotes::default();
    // fused[i]: the fused value of run[i..j] for the last j it was made
    // for, so that run[i..j + 1] is one `fuse_next` from it (the same
    // nodes `fuse` would intern again, found without walking the prefix).
    let mut fused: Vec<Option<(usize, Handle<Expr>)>> = vec![None; run.len()];
    for j in 1..=run.len() {
        // Each statement alone first: its cost bounds the fused candidates.
        for i in (0..j).rev() {
            let Some((base_cost, base)) = best[i].clone() else { continue };
            let stmts: Vec<usize> = run[i..j].to_vec();
            let pair_with = (stmts.len() == 2).then(|| names[stmts[0]].clone());
            let value = match fused[i] {
                Some((k, prefix)) if k + 1 == j => fuse_next(m, prefix, run[j - 1]),
                _ => fuse(m, &stmts),
            };
            let Some(value) = value else { continue };
            fused[i] = Some((j, value));
            // A pair fused in an equivalent form only where the second
            // statement alone did not plan as written (cheap where
            // programs fit): refused, or planned only in a form of its
            // own, whose passes the fused pass then competes with on cost
            // — a rewrite never costs the pair its fusion.
            let fused_forms =
                stmts.len() == 2 && (best[j].is_none() || notes.rewrites.contains_key(&run[j - 1]));
            let (form, pieces) = match planned_or_rewritten(
                m,
                profile,
                search,
                fits,
                baked,
                &stmts,
                value,
                &mut notes.rewrites,
                fused_forms,
            ) {
                Ok(planned) => planned,
                Err(Err(refusal)) => {
                    notes.first_error.get_or_insert(refusal);
                    continue;
                }
                Err(Ok(why)) => {
                    notes.unplanned(&why, &stmts, pair_with.as_deref());
                    continue;
                }
            };
            let c = split::cost(m, fits.fit(baked), &pieces);
            let total = split::add(base_cost, c);
            if let Some(a) = &pair_with {
                let apart = best[j].as_ref().map(|(b, _)| *b);
                notes.not_fused.entry(stmts[1]).or_insert(not_fused_reason(
                    a,
                    pieces.len(),
                    total,
                    apart,
                    profile,
                ));
            }
            // On a tie, keep statements as written (more, smaller groups).
            if best[j].as_ref().is_none_or(|(b, v)| total < *b || (total == *b && base.len() + 1 > v.len())) {
                let mut v = base;
                v.push((stmts, form, pieces, String::new()));
                best[j] = Some((total, v));
            }
        }
    }
    let Some((_, groups)) = best[run.len()].take() else {
        return Err(notes.first_error.unwrap_or_else(|| cannot_plan(&m.statements[run[0]], profile)));
    };
    Ok(groups
        .into_iter()
        .map(|(stmts, form, pieces, _)| {
            let mut reason = notes.reason(&stmts, pieces.len(), names, profile);
            if let ([_, _, ..], [one]) = (stmts.as_slice(), pieces.as_slice()) {
                if let Some(what) = one.why.split("; ").next().and_then(|w| w.strip_prefix(rewrite::FUSED_IN))
                {
                    reason += &format!(",{what} (as written they do not)");
                }
            }
            (stmts, form, pieces, reason)
        })
        .collect())
}

/// operations in statements of ten, accumulated into one framebuffer the way
/// multipass lighting is (Pipeline Grammar, eq. (9)), over eight textures and four lights.
#[doc(hidden)]
pub fn generated_program(ops: usize) -> String {
    let mut s = String::from("vector N : normal in tangent;\n");
    for l in 0..4 {
        s += &format!("vector L{l} : light({l}) in tangent;\n");
    }
    for t in 0..8 {
        s += &format!("texture T{t} : 2d rgba8;\n");
    }
    s += "texture Ncube : cube rgb8;\nframebuffer C : rgba8, depth;\nconst kd : rgb = (0.7, 0.6, 0.5);\n";
    s += "C δπx ← T0 δu x;\n";
    let statements = (ops / 10).max(1);
    for i in 0..statements {
        let (t, l) = (i % 8, i % 4);
        // A distinct constant per statement: no two statements are the same DAG.
        s += &format!(
            "C δπx ← (C δπx) ⊕[add] ({:.6} * kd * T{t} δu x * max(0, expand(Ncube δ L{l} s x) · expand(T{} δu x).rgb) * (T{} δu x).a);\n",
            1.0 - i as f64 / (2 * statements) as f64,
            (t + 1) % 8,
            (t + 3) % 8
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::{Approximation, ApproximationCost};

    fn planned(source: &str, profile: &Profile, rule: &str) -> Planned {
        let mut p = crate::driver::compile(source, profile, &Default::default()).unwrap().planned;
        p.plan.approximations = vec![Approximation {
            rule: rule.into(),
            at: "1:1".into(),
            span: Span::new(0, 1),
            why: format!("lowered by {rule}"),
            cost: ApproximationCost::default(),
            error_bound: Some(0.01),
            output_bound: Some(0.01),
        }];
        p
    }

    /// With `--max-error`, of the lowerings that fit the faster is taken,
    /// whatever its place in the accuracy order, and it says so.
    #[test]
    fn the_fastest_lowering_within_the_error_budget_is_taken() {
        let source = include_str!("../../examples/kilgard_bump_mapping.shd");
        let geforce3 = Profile::builtin("geforce3").unwrap();
        let mut slow = geforce3.clone();
        slow.cost.as_mut().unwrap().clocks_per_general_combiner = 2.0;
        let fused = planned(source, &geforce3, "first_rule");
        let apart = planned(source, &slow, "second_rule");
        assert_eq!((fused.plan.passes.len(), apart.plan.passes.len()), (1, 3));
        let chosen = fastest_lowering(vec![fused.clone(), apart], &slow).unwrap();
        assert_eq!(chosen.plan.approximations[0].rule, "second_rule");
        assert!(chosen.plan.approximations[0].why.contains("the fastest lowering within --max-error"));
        // On the real GeForce3 the fused pass is faster: the first is kept.
        let again = planned(source, &slow, "second_rule");
        let chosen = fastest_lowering(vec![fused, again], &geforce3).unwrap();
        assert_eq!(chosen.plan.approximations[0].rule, "first_rule");
    }
}
