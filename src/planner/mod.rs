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
pub mod fit;
pub mod lights;
pub mod realize;
pub mod relevance;
pub mod shadow_map;
pub mod shadow_volumes;
pub mod specialize;
pub mod split;
pub mod storage;

use rustc_hash::FxHashMap as HashMap;

use crate::pipeline::{
    BlendMode, FragmentWork, Geometry, Pass, PassPlan, Planned, Removed, RenderTarget, TextureBinding, Value,
    VertexWork,
};
pub use realize::{Realized, Realizer, Refusal};
pub use split::{FitCheck, Overflow};

use affine::Builder;
use split::{Dest, Piece, SplitCache, Splitter};

use crate::diag::Diagnostic;
use crate::ir::{self, BinaryOp, Expr, FbChannel, Frequency, Handle, Module, Statement, Table, Usage};
use crate::parser::ast::CombineMode;
use crate::pipeline::{BlendState, CullMode, DepthState, RenderState, StencilOp, StencilState};
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
    let index = request.source.map(|s| (LineIndex::new(s), s));
    let at = |span: Span| at_text(&index, span);
    let mut tried: Option<(Vec<String>, Vec<Diagnostic>)> = None;
    let mut fitting: Vec<Planned> = Vec::new();
    let choices = match request.lowering.only {
        Some(only) => vec![only],
        None => crate::lowering::choices(profile),
    };
    for choice in choices {
        let lowered = crate::lowering::lower(module, profile, choice, &at);
        let within = request.lowering.only.is_some() || lowered.within(&request.lowering);
        if lowered.approximations.is_empty() || !within {
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
            Err(errors) => {
                let mut rules: Vec<String> = lowered.approximations.iter().map(|a| a.rule.clone()).collect();
                rules.dedup();
                tried.get_or_insert((rules, errors));
            }
        }
    }
    if let Some(planned) = fastest_lowering(fitting, profile) {
        return Ok(planned);
    }
    written.map_err(|mut errors| {
        let Some((rules, lowered)) = tried else { return errors };
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
        if removed && errors.first().is_some_and(|d| d.code == "cannot-split") {
            if let Some(first) = lowered.first() {
                let written = errors[0].message.clone();
                let mut d = first.clone();
                // "… further needs `normalize` per fragment, which …" → "needs `normalize` per fragment".
                let tail = written.split(": ").last().unwrap_or(&written);
                let what = tail.trim_start_matches("a part that cannot be divided further ");
                let what = what.split(", which").next().unwrap_or(what);
                let note = match what.strip_prefix("needs ") {
                    Some(need) => {
                        format!(
                            "as written it also needs {need}, which the lowering ({}) supplies",
                            rules.join(", ")
                        )
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
                return out;
            }
        }
        // What the lowering tried, so that the refusal does not read as if
        // the first obstacle were the only one.
        let message = lowered.first().map_or(String::new(), |d| d.message.clone());
        if let Some(d) = errors.first_mut().filter(|d| d.message != message) {
            let tried =
                format!("the lowering ({}) does not make it plan either: {message}", rules.join(", "));
            d.help = Some(match d.help.take() {
                Some(help) if !help.is_empty() => format!("{help}; {tried}"),
                _ => tried,
            });
        }
        errors
    })
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

fn plan_as_written(
    module: &Module,
    profile: &Profile,
    request: &Request,
) -> Result<Planned, Vec<Diagnostic>> {
    let mut m = module.clone();
    shadow_map::redraw_over_geometry(&mut m, profile);
    let errors: Vec<Diagnostic> =
        crate::profile::fit(&m, profile).into_iter().filter(|d| d.is_error()).collect();
    // What the target lacks may be only how the program is written (a
    // `lerp` on the texture environment is a sum of products it has):
    // the canonical forms (`algebra`), when they leave no missing capability.
    let mut canonical = Vec::new();
    if !errors.is_empty() {
        let changed = algebra::canonical_statements(&mut m, |m, i| {
            let st = m.statements[i].clone();
            if !matches!(st.table, Table::Framebuffer { channel: FbChannel::Color, .. }) {
                return None;
            }
            whole_form(m, &st, st.value).ok().and_then(|f| framebuffer_clamped(m, &st, &f))
        });
        if changed.is_empty() || crate::profile::fit(&m, profile).iter().any(|d| d.is_error()) {
            return Err(errors);
        }
        canonical = changed.iter().map(|&i| m.statements[i].value).collect();
    }
    if matches!(profile.fragment, FragmentStage::Combiners(_)) && request.realizer.is_none() {
        let what = "planned for a register-combiner target without its code generator";
        return Err(vec![Diagnostic::error("internal-error", what, Span::DETACHED, "").with_help(
            "plan through `shadec::driver`, which passes the target's generator to the planner",
        )]);
    }
    let index = request.source.map(|s| (LineIndex::new(s), s));
    let at = |span: Span| at_text(&index, span);
    let prepared = prepare(&mut m, request.scene, &at)?;
    let compiler = Profile { fragment: FragmentStage::Programmable, ..profile.clone() };
    let mut fits = Fits {
        target: fit::ProfileFit::new(profile, request.realizer),
        compiler: fit::ProfileFit::new(&compiler, None),
        cache: SplitCache::default(),
        compiler_cache: SplitCache::default(),
        canonical,
    };
    let (chosen, mut diags) = choose(&mut m, profile, request.search, &mut fits, &prepared);
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
    let ctx = AssembleCtx { profile, realizer: request.realizer, texgen: &texgen, at: &at };
    let (mut plan, stages) = assemble(&m, &ctx, &chosen, prepared);
    shadow_map::equal_depth(&m, &mut plan.passes);
    if let Some(d) = storage::float_framebuffer_read_back(module, &plan, profile) {
        return Err(vec![d]);
    }
    // Counting the volume by facing may draw one pass twice (one-sided
    // stencil): each copy runs its original's fragment setup.
    let origins =
        crate::planner::shadow_volumes::count_by_facing(&m, &mut plan.passes, profile.two_sided_stencil);
    let stages: Vec<_> = origins.iter().filter_map(|&i| stages.get(i).cloned()).collect();
    // A pass the target cannot run is refused here, never planned.
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
    if !refused.is_empty() {
        return Err(refused);
    }
    let setups = crate::pipeline::setup::resolve_all(&m, &plan, stages);
    Ok(Planned {
        module: m,
        plan,
        combiners: profile.combiner_limits(),
        vertex_programs: profile.vertex_programs,
        setups,
    })
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
        && !own_pass(*run.last().unwrap())
        && !own_pass(live[run.len()])
        && fusable(m, &m.statements[*run.last().unwrap()], &m.statements[live[run.len()]])
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
    float_temps: bool,
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
    match plan_form(m, fit, cache, &st, &form, float_temps, search) {
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
    let mut first_error: Option<Diagnostic> = None;
    // Why a statement was not fused with the one before it.
    let mut not_fused: HashMap<usize, String> = HashMap::default();
    // fused[i]: the fused value of run[i..j] for the last j it was made
    // for, so that run[i..j + 1] is one `fuse_next` from it (the same
    // nodes `fuse` would intern again, found without walking the prefix).
    let mut fused: Vec<Option<(usize, Handle<Expr>)>> = vec![None; run.len()];
    // Statements planned in an equivalent form: which, and why.
    let mut rewrites: HashMap<usize, String> = HashMap::default();
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
            let (form, pieces) =
                match planned_or_rewritten(m, profile, search, fits, baked, &stmts, value, &mut rewrites) {
                    Ok(planned) => planned,
                    Err(Err(refusal)) => {
                        first_error.get_or_insert(refusal);
                        continue;
                    }
                    Err(Ok(why)) => {
                        match (&why, stmts.len(), &pair_with) {
                            (Unplanned::Form(d), 1, _) => {
                                first_error.get_or_insert(d.clone());
                            }
                            (Unplanned::Form(d), _, Some(a)) => {
                                not_fused
                                    .entry(stmts[1])
                                    .or_insert(format!("fused with statement {a}, {}", d.message));
                            }
                            (Unplanned::Overflow(o), _, Some(a)) => {
                                not_fused
                                    .entry(stmts[1])
                                    .or_insert(format!("fused with statement {a} it {o}"));
                            }
                            _ => {}
                        }
                        continue;
                    }
                };
            let c = split::cost(m, fits.fit(baked), &pieces);
            let total = split::add(base_cost, c);
            if let Some(a) = &pair_with {
                let apart = best[j].as_ref().map(|(b, _)| *b);
                not_fused.entry(stmts[1]).or_insert(not_fused_reason(a, pieces.len(), total, apart, profile));
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
        return Err(first_error.unwrap_or_else(|| {
            let st = &m.statements[run[0]];
            Diagnostic::error(
                "cannot-plan",
                format!("cannot plan this statement for {}", profile.name),
                st.span,
                "here",
            )
            .with_help("simplify the statement or target a profile with more resources")
        }));
    };
    Ok(groups
        .into_iter()
        .map(|(stmts, form, pieces, _)| {
            let reason = if stmts.len() > 1 {
                format!(
                    "statements {} fused: together they fit {} {} on {}",
                    stmts.iter().map(|s| names[*s].clone()).collect::<Vec<_>>().join(", "),
                    pieces.len(),
                    passes_word(pieces.len()),
                    profile.name
                )
            } else if let Some(note) = rewrites.get(&stmts[0]) {
                format!("statement {} {note}", names[stmts[0]])
            } else {
                match not_fused.get(&stmts[0]) {
                    Some(why) => format!("statement {} as written: {why}", names[stmts[0]]),
                    None => format!("statement {} as written", names[stmts[0]]),
                }
            };
            (stmts, form, pieces, reason)
        })
        .collect())
}

/// A statement's equivalent forms: the value, the value added after a
/// modulation (`C ← C·m + s`), and what made them.
type Candidate = (Handle<Expr>, Option<Handle<Expr>>, &'static str);
/// A statement planned in an equivalent form, with what the form is; or
/// each form tried and why it does not plan.
type Rewritten = Result<(Form, Vec<Piece>, &'static str), Vec<(&'static str, Overflow)>>;

/// [`candidate`], then — for a single statement — its equivalent forms
/// ([`rewritten`]): when it does not plan as written, or when it was
/// rewritten already so that the target could run it (`Fits::canonical`)
/// and another form may be cheaper. `rewrites` records the statements
/// planned in another form, with the reason. `Err(Err(d))`: refused for
/// resources in every form, `d` saying what was tried.
#[allow(clippy::too_many_arguments)]
fn planned_or_rewritten(
    m: &mut Module,
    profile: &Profile,
    search: Search,
    fits: &mut Fits,
    baked: bool,
    stmts: &[usize],
    value: Handle<Expr>,
    rewrites: &mut HashMap<usize, String>,
) -> Result<(Form, Vec<Piece>), Result<Unplanned, Diagnostic>> {
    let single = stmts.len() == 1;
    let as_written = candidate(m, search, fits, baked, stmts, value, profile.float_textures);
    let (written_cost, why) = match &as_written {
        Ok((_, pieces)) if single && fits.canonical.contains(&value) => (
            Some(split::cost(m, fits.fit(baked), pieces)),
            format!("as written {} cannot run it", profile.name),
        ),
        Err(Unplanned::Overflow(o)) if single => (None, format!("as written it {o}")),
        _ => return as_written.map_err(Ok),
    };
    let tried = match rewritten(m, search, fits, baked, stmts[0], profile.float_textures) {
        Ok((f, mut p, what)) if written_cost.is_none_or(|c| split::cost(m, fits.fit(baked), &p) < c) => {
            let note = format!("{what} ({why})");
            note_rewrite(&mut p, &note);
            rewrites.insert(stmts[0], note);
            return Ok((f, p));
        }
        Ok(_) => Vec::new(),
        Err(tried) => tried,
    };
    match as_written {
        Ok((form, mut pieces)) => {
            // The canonical form the target runs is the cheapest.
            let note = format!("{} ({why})", algebra::CANONICAL);
            note_rewrite(&mut pieces, &note);
            rewrites.insert(stmts[0], note);
            Ok((form, pieces))
        }
        Err(Unplanned::Overflow(o)) => {
            let st = m.statements[stmts[0]].clone();
            Err(Err(cannot_split(m, &st, profile, &o, &tried)))
        }
        Err(why) => Err(Ok(why)),
    }
}

/// The first pass of a statement planned in an equivalent form says which
/// (the pass reasons of a split quote their pieces).
fn note_rewrite(pieces: &mut [Piece], note: &str) {
    if let Some(first) = pieces.first_mut() {
        let why = if first.why.is_empty() { "the part rendered first" } else { first.why.as_str() };
        first.why = format!("{note}; {why}");
    }
}

/// A single statement that does not plan as written, planned in the
/// equivalent forms of its blended value ([`algebra`]; with its clamp left
/// to the 8-bit framebuffer's, which clamps anyway): the cheapest that
/// plans by [`split::cost`] (the cost model, then passes, then fetches),
/// with what it is; else each form tried and why it does not plan.
fn rewritten(
    m: &mut Module,
    search: Search,
    fits: &mut Fits,
    baked: bool,
    s: usize,
    float_temps: bool,
) -> Rewritten {
    let st = m.statements[s].clone();
    let Ok(form) = classify(m, &st, st.value) else { return Err(Vec::new()) };
    // The exhaustive search enumerates every grouping of the terms.
    let max = if search == Search::Exhaustive { 8 } else { algebra::MAX_TERMS };
    let mut candidates: Vec<Candidate> = Vec::new();
    let adds = form.then_add.map(|a| algebra::forms(m, a, max)).unwrap_or_default();
    let add_of = |what: &str| adds.iter().find(|f| f.what == what).map(|f| f.value).or(form.then_add);
    for f in algebra::forms(m, form.value, max) {
        candidates.push((f.value, add_of(f.what), f.what));
    }
    for f in &adds {
        if candidates.iter().all(|c| c.2 != f.what) {
            candidates.push((form.value, Some(f.value), f.what));
        }
    }
    if let Some(x) = framebuffer_clamped(m, &st, &form) {
        let what = "with its clamp left to the framebuffer's";
        candidates.push((x, form.then_add, what));
        for f in algebra::forms(m, x, max) {
            candidates.push((f.value, form.then_add, what));
        }
    }
    let mut best: Option<(split::Cost, Form, Vec<Piece>, &'static str)> = None;
    let mut tried = Vec::new();
    for (value, then_add, what) in candidates {
        let f = Form { value, then_add, ..form.clone() };
        let (fit, cache) =
            if baked { (&fits.compiler, &mut fits.compiler_cache) } else { (&fits.target, &mut fits.cache) };
        match plan_form(m, fit, cache, &st, &f, float_temps, search) {
            Ok(pieces) => {
                let c = split::cost(m, fit, &pieces);
                if best.as_ref().is_none_or(|b| c < b.0) {
                    best = Some((c, f, pieces, what));
                }
            }
            Err(o) => tried.push((what, o)),
        }
    }
    best.map(|(_, f, p, what)| (f, p, what)).ok_or(tried)
}

/// `x` of a statement writing `saturate(x)` (or `rgba(saturate(x), 1)`)
/// whole into an 8-bit colour framebuffer, which stores it clamped to
/// [0, 1] anyway (Kilgard 2000, Section 5): the clamp happens there, and
/// `x` may split where `saturate(x)` cannot.
fn framebuffer_clamped(m: &mut Module, st: &Statement, form: &Form) -> Option<Handle<Expr>> {
    let Table::Framebuffer { id, channel: FbChannel::Color } = st.table else { return None };
    let float = m.framebuffers[id as usize].channels.iter().any(|c| {
        matches!(
            c,
            crate::parser::ast::FramebufferChannel::Rgba16f | crate::parser::ast::FramebufferChannel::Rgba32f
        )
    });
    if float || form.blend != BlendMode::Replace || form.channels != "rgba" {
        return None;
    }
    let saturated = |m: &Module, h: Handle<Expr>| match &m.exprs[h] {
        Expr::Math { fun: ir::MathFunction::Saturate, args } => Some(args[0]),
        _ => None,
    };
    match m.exprs[form.value] {
        Expr::Convert { value, to: ir::Ty::Rgba } => {
            let x = saturated(m, value)?;
            Builder { module: m }.node(Expr::Convert { value: x, to: ir::Ty::Rgba })
        }
        _ => saturated(m, form.value),
    }
}

fn cannot_split(
    m: &Module,
    st: &Statement,
    profile: &Profile,
    o: &Overflow,
    tried: &[(&str, Overflow)],
) -> Diagnostic {
    let span = o.at.map(|h| m.span(h)).filter(|s| *s != Span::DETACHED).unwrap_or(st.span);
    let d = cannot_split_as_written(st, profile, o, span);
    if tried.is_empty() {
        return d;
    }
    // What was tried, so that the refusal is not read as if a rewrite
    // would have planned it.
    let forms: Vec<String> = tried.iter().map(|(what, o)| format!("{what}, it {o}")).collect();
    let help = format!(
        "{}; the planner also tried the statement in its equivalent forms, and none plans: {}",
        d.help.clone().unwrap_or_default(),
        forms.join("; ")
    );
    d.with_help(help)
}

fn cannot_split_as_written(st: &Statement, profile: &Profile, o: &Overflow, span: Span) -> Diagnostic {
    Diagnostic::error(
        "cannot-split",
        format!("no split of this statement fits {}: a part that cannot be divided further {o}", profile.name),
        st.span,
        format!("{o}"),
    )
    .with_label(span, "this part".to_string())
    .with_help(if let Some(help) = o.help.as_deref().filter(|h| !h.is_empty()) {
        // The code generator's own advice for the part, then the splits'.
        format!("{help}; framebuffer blending can only split sums and products (and affine ⊕ chains) of parts that fit")
    } else if o.have == 0 {
        // Nothing the target has (`length` per fragment), not too little.
        "framebuffer blending can only split sums and products (and affine ⊕ chains); compute the part per vertex, bake it into a lookup texture (`= bake(f)`), or target `wgsl`".to_string()
    } else {
        format!("framebuffer blending can only split sums and products (and affine ⊕ chains); compute the part per vertex, bake it into a lookup texture, or target a profile with more {}", o.resource)
    })
}

/// The framebuffer read of `st`'s own target at its own position.
fn self_read(m: &Module, st: &Statement, channel: FbChannel) -> Option<Handle<Expr>> {
    match st.table {
        Table::Framebuffer { id, .. } => {
            m.exprs.find(&Expr::FramebufferRead { framebuffer: id, channel, position: st.index })
        }
        _ => None,
    }
}

/// Whether `b` can be fused after `a`: same framebuffer, colour writes,
/// same geometry, no stencil or discard.
fn fusable(m: &Module, a: &Statement, b: &Statement) -> bool {
    matches!((&a.table, &b.table), (Table::Framebuffer { id: x, channel: FbChannel::Color }, Table::Framebuffer { id: y, channel: FbChannel::Color }) if x == y)
        && a.index == b.index
        && a.freq == Frequency::Fragment
        && ![a.value, b.value].iter().any(|v| matches!(m.exprs[*v], Expr::Select { reject: None, .. }))
}

/// The value of the statements `stmts` run one after another, as one value:
/// each later statement's reads of the framebuffer replaced by the earlier
/// value.
fn fuse(m: &mut Module, stmts: &[usize]) -> Option<Handle<Expr>> {
    let mut value = m.statements[stmts[0]].value;
    for &s in &stmts[1..] {
        value = fuse_next(m, value, s)?;
    }
    Some(value)
}

/// The value of statement `s` run after `value` (the fused value of the
/// statements before it): one step of [`fuse`].
fn fuse_next(m: &mut Module, value: Handle<Expr>, s: usize) -> Option<Handle<Expr>> {
    let st = m.statements[s].clone();
    let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::default();
    let reads = [FbChannel::Color, FbChannel::Alpha].iter().any(|&c| self_read(m, &st, c).is_some());
    let value = if reads { stored(m, &st, value)? } else { value };
    if let Some(r) = self_read(m, &st, FbChannel::Color) {
        let v = widen_rgba(m, value)?;
        map.insert(r, v);
    }
    if let Some(r) = self_read(m, &st, FbChannel::Alpha) {
        let a = Builder { module: m }.alpha(value)?;
        map.insert(r, a);
    }
    substitute(m, st.value, &map)
}

/// What statement `st` reads of `value` stored into its framebuffer: a
/// fixed-point (`rgba8`) framebuffer clamps to [0, 1] (GL §2.13.9,
/// §4.1.8), so a fused value whose range leaves [0, 1] is saturated where
/// the earlier statement would have stored it (`2T³` is not `T·2T·T` on an
/// rgba8 target: `2T²` was clamped in between). Not needed where `st` only
/// adds a non-negative term to a non-negative value: `min(v, 1) + s` and
/// `v + s` are stored alike. A float framebuffer keeps the value.
fn stored(m: &mut Module, st: &Statement, value: Handle<Expr>) -> Option<Handle<Expr>> {
    use crate::parser::ast::FramebufferChannel as F;
    let Table::Framebuffer { id, .. } = st.table else { return Some(value) };
    let float = m.framebuffers[id as usize].channels.iter().any(|c| matches!(c, F::Rgba16f | F::Rgba32f));
    let range = m.info(value).interval;
    if float || range.class() == ir::Range::Unsigned || (range.lo >= 0.0 && adds_non_negative(m, st)) {
        return Some(value);
    }
    Builder { module: m }.node(Expr::Math { fun: ir::MathFunction::Saturate, args: vec![value] })
}

/// Whether `st`'s value is `C + s` with `s ≥ 0` by its range, reading no
/// destination alpha.
fn adds_non_negative(m: &mut Module, st: &Statement) -> bool {
    let Some(r) = self_read(m, st, FbChannel::Color) else { return false };
    if self_read(m, st, FbChannel::Alpha).is_some_and(|ra| split::depends_on(m, st.value, ra)) {
        return false;
    }
    match affine::affine(&mut Builder { module: m }, st.value, r) {
        Some((coef, offset)) => m.is_constant(coef, 1.0) && m.info(offset).interval.lo >= 0.0,
        None => false,
    }
}

/// An rgb value as the framebuffer holds it: alpha 1.
fn widen_rgba(m: &mut Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    match m.info(h).ty {
        ir::Ty::Rgb | ir::Ty::Vec3 => {
            Builder { module: m }.node(Expr::Convert { value: h, to: ir::Ty::Rgba })
        }
        _ => Some(h),
    }
}

/// `h` with the nodes of `map` replaced, rebuilt bottom-up.
pub fn substitute(
    m: &mut Module,
    h: Handle<Expr>,
    map: &HashMap<Handle<Expr>, Handle<Expr>>,
) -> Option<Handle<Expr>> {
    let mut done: HashMap<Handle<Expr>, Handle<Expr>> = map.clone();
    for n in m.reachable(&[h]) {
        if done.contains_key(&n) {
            continue;
        }
        let e = m.exprs[n].clone();
        let ops = e.operands();
        if ops.iter().all(|o| done.get(o).is_none_or(|x| x == o)) {
            done.insert(n, n);
            continue;
        }
        let new = e.map_operands(|o| *done.get(&o).unwrap_or(&o));
        let span = m.span(n);
        let nh = m.intern(new, span).ok()?;
        done.insert(n, nh);
    }
    done.get(&h).copied()
}

/// A statement's framebuffer operation as written, no blend read off its
/// value: the whole value replaces the target, its reads of the target are
/// the target's values before the statement. What the target channel, a
/// discard `c ? a`, a stencil test `σ C ? a` or a stencil update say is
/// taken out (Pipeline Grammar, Sections 3.4-3.5). The program's meaning
/// (`crate::meaning`) runs statements in this form; `classify` goes on to
/// read a blend.
pub fn whole_form(m: &mut Module, st: &Statement, value: Handle<Expr>) -> Result<Form, Diagnostic> {
    let mut form = Form {
        blend: BlendMode::Replace,
        value,
        condition: None,
        stencil: None,
        depth: None,
        channels: "rgba",
        then_add: None,
        drawn_at: None,
    };
    match st.table {
        Table::Texture(_) => return Ok(form),
        Table::TexCoords(_) => unreachable!("texgen statements are vertex work"),
        Table::Framebuffer { channel: FbChannel::Stencil, .. } => {
            return stencil_write(m, st, value).ok_or_else(|| unsupported_blend(st, "this stencil update (the planner knows `σ C ← (σ C) OR (depth comparison)`, Pipeline Grammar, Section 3.5)"))
        }
        Table::Framebuffer { channel: FbChannel::Depth, .. } => return Err(unsupported_blend(st, "a write to the depth channel")),
        Table::Framebuffer { channel: FbChannel::Alpha, .. } => form.channels = "a",
        Table::Framebuffer { channel: FbChannel::Color, .. } => {}
    }
    // `σ C ? a`: a stencil test; `c ? a`: a discard (also under the
    // widening to rgba lowering puts around it).
    if let Expr::Convert { value: inner, to } = m.exprs[value].clone() {
        if let Expr::Select { cond, accept, reject: None } = m.exprs[inner].clone() {
            if let Some(widened) = (Builder { module: m }).node(Expr::Convert { value: accept, to }) {
                form.value = m
                    .intern(Expr::Select { cond, accept: widened, reject: None }, m.span(inner))
                    .unwrap_or(value);
            }
        }
    }
    if let Expr::Select { cond, accept, reject: None } = m.exprs[form.value].clone() {
        // `σ C ? a` passes where the stencil is set (0 ≠ stored), `¬σ C ? a`
        // — the shadow-volume idiom, lit where no volume counted — where it
        // is clear (0 = stored): both a stencil test, for every executor.
        let stencil = self_read(m, st, FbChannel::Stencil);
        let negated = match m.exprs[cond] {
            Expr::Unary { op: crate::ir::UnaryOp::Not, value } => Some(value) == stencil,
            _ => false,
        };
        if stencil.is_some() && (Some(cond) == stencil || negated) {
            let func = if negated {
                crate::pipeline::CompareFunc::Equal
            } else {
                crate::pipeline::CompareFunc::NotEqual
            };
            form.stencil = Some(StencilState { enabled: true, func, reference: 0, ..StencilState::DISABLED });
        } else {
            form.condition = Some(cond);
        }
        form.value = accept;
    }
    Ok(form)
}

fn unsupported_blend(st: &Statement, what: &str) -> Diagnostic {
    Diagnostic::error("unsupported-blend", format!("framebuffer blending cannot express this: {what}"), st.span, "this statement")
        .with_help("write the statement as `C ← (C) ⊕ e`, `C ← (C) ⊕[add] e`, `C ← (C) ⊕[add] ((α C) * e)`, or compute the value without reading the framebuffer")
}

/// Reads the framebuffer operation off a statement's (possibly fused) value.
pub fn classify(m: &mut Module, st: &Statement, value: Handle<Expr>) -> Result<Form, Diagnostic> {
    let mut form = whole_form(m, st, value)?;
    if matches!(st.table, Table::Texture(_)) || form.channels == "stencil" {
        return Ok(form);
    }
    let unsupported = |what: &str| unsupported_blend(st, what);
    let r = self_read(m, st, FbChannel::Color);
    let ra = self_read(m, st, FbChannel::Alpha);
    let uses =
        |m: &Module, h: Handle<Expr>, x: Option<Handle<Expr>>| x.is_some_and(|x| split::depends_on(m, h, x));
    let v = form.value;
    if !uses(m, v, r) && !uses(m, v, ra) {
        return Ok(form);
    }
    if form.channels == "a" {
        return Err(unsupported("an alpha write that reads the framebuffer"));
    }
    if let Some(r) = r.filter(|r| split::depends_on(m, v, *r)) {
        // `T ⊕[decal] C`: alpha blending.
        if let Expr::Combine { mode: CombineMode::Decal, lhs, rhs } = m.exprs[v] {
            if rhs == r && m.info(lhs).ty == ir::Ty::Rgba && !uses(m, lhs, Some(r)) && !uses(m, lhs, ra) {
                form.blend = BlendMode::AlphaBlend;
                form.value = lhs;
                return Ok(form);
            }
        }
        let (coef, offset) = affine::affine(&mut Builder { module: m }, v, r)
            .ok_or_else(|| unsupported("the framebuffer's colour is used non-linearly"))?;
        if let Some(ra) = ra.filter(|ra| coef == *ra) {
            // Cα·C + (1 − Cα)·f
            let omr = Builder { module: m }.one_minus(ra);
            if let Some(x) = omr.and_then(|omr| alpha_factor(m, offset, omr)) {
                form.blend = BlendMode::DstAlphaMix;
                form.value = x;
                return Ok(form);
            }
        }
        if uses(m, coef, ra) {
            return Err(unsupported("the framebuffer's alpha scales its own colour"));
        }
        let one = m.is_constant(coef, 1.0);
        let zero = m.is_constant(offset, 0.0);
        if one && zero {
            form.value = offset; // C ← C: nothing to do (specialization removes it)
            form.blend = BlendMode::Add;
            return Ok(form);
        }
        if !one && uses(m, offset, ra) {
            return Err(unsupported("both a colour scale and a destination-alpha term"));
        }
        if one {
            // C + s, or C + Cα·s (GL_DST_ALPHA, GL_ONE).
            if let Some(x) = ra.and_then(|ra| alpha_factor(m, offset, ra)) {
                form.blend = BlendMode::DstAlphaAdd;
                form.value = x;
            } else if uses(m, offset, ra) {
                return Err(unsupported(
                    "the destination alpha appears other than as a factor of the added term",
                ));
            } else {
                form.blend = BlendMode::Add;
                form.value = offset;
            }
        } else if zero {
            form.blend = BlendMode::Modulate;
            form.value = coef;
        } else {
            // C·m + s: modulate, then add (two passes).
            form.blend = BlendMode::Modulate;
            form.value = coef;
            form.then_add = Some(offset);
        }
        return Ok(form);
    }
    // Only the alpha is read: `C ← (α C) · x` (GL_DST_ALPHA, GL_ZERO),
    // `rgba((α C)·x, α C)` = (α C) · rgba(x, 1) included.
    match ra.and_then(|ra| alpha_factor(m, v, ra).or_else(|| composed_alpha_factor(m, v, ra))) {
        Some(x) => {
            form.blend = BlendMode::DstAlphaModulate;
            form.value = x;
            Ok(form)
        }
        None if ra.is_some_and(|ra| widened_alpha_product(m, v, ra)) => Err(unsupported_blend(st, "the value is rgb, so the statement writes alpha 1, while a blend by the destination alpha would scale the alpha too")
            .with_help("give the alpha you mean: `rgba((α C δπx) * c, α C δπx)` keeps the alpha (one blend by destination alpha), or write the colour and the alpha in two statements")),
        None => Err(unsupported("the framebuffer's alpha is used other than as a factor")),
    }
}

/// `rgba(α·x, α)` or `rgba(α·x, α·y)` with α the destination alpha `ra`:
/// the factor `rgba(x, 1)` or `rgba(x, y)`.
fn composed_alpha_factor(m: &mut Module, h: Handle<Expr>, ra: Handle<Expr>) -> Option<Handle<Expr>> {
    let Expr::Compose { ty: ir::Ty::Rgba, ref components } = m.exprs[h] else { return None };
    let [c, a] = components[..] else { return None };
    let x = alpha_factor(m, c, ra)?;
    let y =
        if a == ra { Builder { module: m }.constant(ir::Ty::Scalar, 1.0)? } else { alpha_factor(m, a, ra)? };
    Builder { module: m }.node(Expr::Compose { ty: ir::Ty::Rgba, components: vec![x, y] })
}

/// `(α C)·x` of an rgb x, widened to rgba (alpha 1): not one blend.
fn widened_alpha_product(m: &Module, h: Handle<Expr>, ra: Handle<Expr>) -> bool {
    matches!(m.exprs[h], Expr::Convert { value, to: ir::Ty::Rgba } if alpha_factor(m, value, ra).is_some())
}

/// `h = ra · x` (either order): `x`.
fn alpha_factor(m: &Module, h: Handle<Expr>, ra: Handle<Expr>) -> Option<Handle<Expr>> {
    match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
        | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs } => {
            if lhs == ra && !split::depends_on(m, rhs, ra) {
                Some(rhs)
            } else if rhs == ra && !split::depends_on(m, lhs, ra) {
                Some(lhs)
            } else {
                None
            }
        }
        _ => None,
    }
}

/// `σ C δπx ← (σ C δπx) OR (z δπx′ > z C δπx′)` (Pipeline Grammar, Section 3.5):
/// set the stencil where the fragment's depth compares with the stored one;
/// no colour, no depth write.
fn stencil_write(m: &Module, st: &Statement, value: Handle<Expr>) -> Option<Form> {
    let Expr::Binary { op: BinaryOp::Or, lhs, rhs } = m.exprs[value] else { return None };
    let own = self_read(m, st, FbChannel::Stencil)?;
    let cmp = if lhs == own {
        rhs
    } else if rhs == own {
        lhs
    } else {
        return None;
    };
    let Expr::Binary { op, lhs: a, rhs: b } = m.exprs[cmp] else { return None };
    let stored_is_b = matches!(m.exprs[b], Expr::FramebufferRead { channel: FbChannel::Depth, .. });
    // The fragment's own depth `z δπx′`: the shadow volume x′ is what this
    // pass rasterizes (seeds/001 Section 3.5: "the shadow volume vertices
    // are x′"), not the object x of the statement's index.
    let Expr::Depth(drawn_at) = m.exprs[if stored_is_b { a } else { b }] else { return None };
    let func = match (op, stored_is_b) {
        (BinaryOp::Gt, true) | (BinaryOp::Lt, false) => crate::pipeline::CompareFunc::Greater,
        (BinaryOp::Ge, true) | (BinaryOp::Le, false) => crate::pipeline::CompareFunc::GreaterEqual,
        (BinaryOp::Lt, true) | (BinaryOp::Gt, false) => crate::pipeline::CompareFunc::Less,
        (BinaryOp::Le, true) | (BinaryOp::Ge, false) => crate::pipeline::CompareFunc::LessEqual,
        _ => return None,
    };
    Some(Form {
        blend: BlendMode::Replace,
        value,
        condition: None,
        stencil: Some(StencilState {
            enabled: true,
            func: crate::pipeline::CompareFunc::Always,
            reference: 1,
            pass: StencilOp::Replace,
            ..StencilState::DISABLED
        }),
        depth: Some(DepthState { func, write: false }),
        channels: "stencil",
        then_add: None,
        drawn_at: Some(drawn_at),
    })
}

/// The pieces of one (fused) statement.
fn plan_form(
    m: &mut Module,
    fit: &dyn FitCheck,
    cache: &mut SplitCache,
    st: &Statement,
    form: &Form,
    float_temps: bool,
    search: Search,
) -> Result<Vec<Piece>, Overflow> {
    if form.channels == "stencil" {
        // The depth test and the stencil operation of the pass state do the
        // comparison; the fragment computes nothing and reads no texture
        // (the stored depth `z C δπx′` is the depth buffer, not a unit).
        let one =
            m.intern(Expr::Constant(crate::ir::Constant::scalar(1.0)), m.span(form.value)).map_err(|_| {
                Overflow {
                    resource: "a constant stencil-pass output".into(),
                    need: 1,
                    have: 0,
                    at: None,
                    help: None,
                }
            })?;
        return Ok(vec![Piece {
            blend: BlendMode::Replace,
            value: one,
            dest: Dest::Main,
            alpha: true,
            why: String::new(),
        }]);
    }
    let overflow = fit.fits(m, form.value).err();
    let clamp_refusals = cache.clamp_refusals;
    let mut splitter = Splitter::new(m, fit, cache, st.index, float_temps);
    if search == Search::Exhaustive {
        splitter = splitter.exhaustive();
    }
    let mut pieces: Vec<Piece> = match splitter.plan(form.blend, form.value) {
        Some(p) => p.iter().cloned().collect(),
        None => {
            let o = overflow.unwrap_or(Overflow {
                resource: "has no split into passes of this target".into(),
                need: 0,
                have: 0,
                at: None,
                help: None,
            });
            return Err(if cache.clamp_refusals > clamp_refusals {
                Overflow {
                    resource: format!("{o}, and the splits that fit would store a value outside [0, 1] between passes, where the 8-bit framebuffer's clamp changes it"),
                    need: 0,
                    have: 0,
                    ..o
                }
            } else {
                o
            });
        }
    };
    if let Some(s) = form.then_add {
        let o = fit.fits(splitter.module, s).err();
        match splitter.plan(BlendMode::Add, s) {
            Some(p) => pieces.extend(p.iter().map(|q| Piece {
                why: "C ← C·m + s: the added term, after the modulation".into(),
                ..q.clone()
            })),
            None => {
                return Err(o.unwrap_or(Overflow {
                    resource: "has no split into passes of this target".into(),
                    need: 0,
                    have: 0,
                    at: None,
                    help: None,
                }))
            }
        }
    }
    Ok(pieces)
}

#[allow(clippy::too_many_arguments)]
/// What assembling passes needs besides the chosen groups.
struct AssembleCtx<'a> {
    profile: &'a Profile,
    realizer: Option<&'a dyn Realizer>,
    /// Texgen statements by the coordinate set they write.
    texgen: &'a HashMap<u32, String>,
    at: &'a dyn Fn(Span) -> String,
}

/// A pass's span and its fragment stage as the target realized it (a
/// refusal, located, when the generator makes no setup for it).
type Stage = (Span, Result<crate::pipeline::FragmentSetup, Box<Diagnostic>>);

fn assemble(m: &Module, ctx: &AssembleCtx, chosen: &[Chosen], prepared: Prepared) -> (PassPlan, Vec<Stage>) {
    let Prepared { removed, per_light, names, .. } = prepared;
    let mut passes = Vec::new();
    let mut stages = Vec::new();
    let mut drawn = Drawn::default();
    let mut roots = Vec::new();
    for (stmts, form, pieces, reason) in chosen {
        let group = Group { stmts, form, reason, n: pieces.len() };
        for (pi, piece) in pieces.iter().enumerate() {
            let (pass, drawn_at, stage) =
                assemble_pass(m, ctx, &group, piece, pi, &mut drawn, &names, &per_light);
            stages.push(stage);
            roots.extend([piece.value, m.statements[stmts[0]].index, drawn_at]);
            roots.extend(form.condition);
            passes.push(pass);
        }
    }
    let plan = PassPlan {
        target: ctx.profile.name.clone(),
        passes,
        removed,
        values: plan_values(m, &roots, ctx.at),
        approximations: Vec::new(),
        predicted: None,
        measured: None,
    };
    (plan, stages)
}

/// A planned group of statements as [`assemble`] walks it.
struct Group<'a> {
    stmts: &'a [usize],
    form: &'a Form,
    reason: &'a str,
    /// Its number of passes.
    n: usize,
}

/// What earlier passes drew, for the depth test of the next: a
/// framebuffer's geometry (its table and index) and the temporaries drawn.
#[derive(Default)]
struct Drawn {
    main: Vec<(Table, Handle<Expr>)>,
    temps: Vec<u32>,
}

/// Pass `pi` of a group: where it draws, what it binds, its state and why;
/// and the geometry it is drawn at.
#[allow(clippy::too_many_arguments)]
fn assemble_pass(
    m: &Module,
    ctx: &AssembleCtx,
    group: &Group,
    piece: &Piece,
    pi: usize,
    drawn: &mut Drawn,
    names: &[String],
    per_light: &PerLight,
) -> (Pass, Handle<Expr>, Stage) {
    let Group { stmts, form, .. } = *group;
    let st = &m.statements[stmts[0]];
    // A texel statement indexed through a vertex (`T δu x`, seeds/001
    // (15)) rasterizes the mesh in texture space.
    let in_texture_space = st.freq == Frequency::Texel
        && m.reachable(&[st.index]).iter().any(|h| m.info(*h).freq == Frequency::Vertex);
    let mesh = st.freq == Frequency::Fragment || in_texture_space;
    // seeds/001 (10), `C δxs ← (C δxs) ⊕ (δ p s x …)`: a static viewpoint —
    // the pass reuses the vertices the last mesh pass into the same
    // framebuffer projected (`reused_projection` checked there is one),
    // with its depth (equal, no write).
    let reused = (mesh && form.drawn_at.is_none() && matches!(m.exprs[st.index], Expr::Pixel { .. }))
        .then(|| drawn.main.iter().rev().find(|(t, _)| same_framebuffer(t, &st.table)).cloned())
        .flatten();
    let drawn_at = reused.as_ref().map_or(form.drawn_at.unwrap_or(st.index), |(_, h)| *h);
    let geometry = if st.freq == Frequency::Screen {
        Geometry::Screen
    } else if mesh {
        Geometry::Mesh { projection: projection_name(m, drawn_at) }
    } else {
        Geometry::Texels
    };
    let u = Usage::of_value(m, piece.value);
    let textures = texture_bindings(m, st, &u);
    let key = reused.unwrap_or((st.table.clone(), st.index));
    let state = pass_state(form, piece, &geometry, in_texture_space, drawn, key);
    // A `bake` table is the compiler's: no combiner setup to judge.
    let baked = m.is_baked(st);
    let stage = if baked {
        Ok(crate::pipeline::FragmentSetup::Baked)
    } else {
        combiner_setup(m, ctx.realizer, piece.value, &textures)
    };
    let reason = pass_reason(group, piece, pi, names, ctx.profile);
    let reached = m.reachable(&[piece.value]);
    let one = |v: &[Option<u32>]| match stmts {
        [s] => v.get(*s).copied().flatten(),
        _ => None,
    };
    let pass = Pass {
        statements: {
            let mut v: Vec<usize> =
                stmts.iter().map(|s| per_light.source.get(*s).copied().unwrap_or(*s)).collect();
            v.dedup();
            v
        },
        light: one(&per_light.light),
        objects: match stmts {
            [s] => per_light.objects.get(*s).cloned().flatten(),
            _ => None,
        },
        at: (ctx.at)(st.span),
        reason: if baked {
            format!("{reason}: a `bake` table, computed by the compiler on the CPU, which the target samples")
        } else {
            reason
        },
        target: pass_target(m, st, piece, form),
        geometry,
        vertex: VertexWork {
            position: mesh.then_some(drawn_at.index() as u32),
            interpolants: u.interpolants.iter().map(|h| h.index() as u32).collect(),
            texgen: texgen_of(m, &reached, ctx.texgen),
        },
        textures,
        fragment: FragmentWork {
            output: piece.value.index() as u32,
            operations: fragment_operations(m, &reached),
            condition: form.condition.map(|c| c.index() as u32),
            general_combiners: stage.as_ref().ok().and_then(|s| match s {
                crate::pipeline::FragmentSetup::Combiners(p) => Some(p.stages()),
                _ => None,
            }),
        },
        blend: piece.blend,
        state,
        baked,
        predicted: None,
    };
    (pass, drawn_at, (st.span, stage))
}

/// Where a pass draws: a temporary, the statement's framebuffer (with the
/// channels it writes), or its texture.
fn pass_target(m: &Module, st: &Statement, piece: &Piece, form: &Form) -> RenderTarget {
    match (piece.dest, &st.table) {
        (Dest::Temp(id), _) => RenderTarget::Temporary { name: format!("temp{id}") },
        (Dest::Main, Table::Framebuffer { id, .. }) => RenderTarget::Framebuffer {
            name: m.framebuffers[*id as usize].name.clone(),
            channels: form.channels.to_string(),
        },
        (Dest::Main, Table::Texture(id)) => {
            RenderTarget::Texture { name: m.textures[*id as usize].name.clone() }
        }
        (Dest::Main, Table::TexCoords(_)) => unreachable!("texgen statements are vertex work"),
    }
}

/// The texture units of a pass, in order: its lookups, then the other
/// framebuffers it reads as textures (its own target it reads by blending).
fn texture_bindings(m: &Module, st: &Statement, u: &Usage) -> Vec<TextureBinding> {
    let own = |h: Handle<Expr>| matches!(m.exprs[h], Expr::FramebufferRead { framebuffer, position, .. } if matches!(st.table, Table::Framebuffer { id, .. } if id == framebuffer) && position == st.index);
    let lookups = u.lookups.iter().map(|&h| {
        let Expr::Lookup { texture, coords } = m.exprs[h] else { unreachable!("a lookup") };
        (m.textures[texture as usize].name.clone(), h, coords)
    });
    let reads = u.framebuffer_reads.iter().filter(|h| !own(**h)).map(|&h| {
        let Expr::FramebufferRead { framebuffer, position, .. } = m.exprs[h] else { unreachable!("a read") };
        (m.framebuffers[framebuffer as usize].name.clone(), h, position)
    });
    lookups
        .chain(reads)
        .enumerate()
        .map(|(i, (texture, h, coords))| TextureBinding {
            unit: i as u32,
            texture,
            lookup: h.index() as u32,
            coords: coords.index() as u32,
        })
        .collect()
}

/// The texgen statements whose coordinates a pass reads.
fn texgen_of(m: &Module, reached: &[Handle<Expr>], texgen: &HashMap<u32, String>) -> Vec<String> {
    let mut gen: Vec<String> = reached
        .iter()
        .filter_map(|h| match m.exprs[*h] {
            Expr::TexCoord { set, .. } => texgen.get(&set).cloned(),
            _ => None,
        })
        .collect();
    gen.dedup();
    gen
}

/// The per-sample arithmetic of a pass's fragment value.
fn fragment_operations(m: &Module, reached: &[Handle<Expr>]) -> usize {
    reached
        .iter()
        .filter(|h| {
            m.info(**h).freq.is_sample()
                && matches!(
                    m.exprs[**h],
                    Expr::Binary { .. }
                        | Expr::Unary { .. }
                        | Expr::Math { .. }
                        | Expr::Combine { .. }
                        | Expr::Select { .. }
                )
        })
        .count()
}

/// The fixed-function state of a pass: culling, the depth test (the first
/// draw into a target tests `Less` and writes, later ones `Equal`), the
/// form's stencil, and the blend with the channels written.
fn pass_state(
    form: &Form,
    piece: &Piece,
    geometry: &Geometry,
    in_texture_space: bool,
    drawn: &mut Drawn,
    key: (Table, Handle<Expr>),
) -> RenderState {
    // A temporary has a depth buffer of its own, fresh when its first pass
    // draws: that pass tests `Less` and writes, as the first pass into a
    // framebuffer does (an `Equal` test against the cleared depth drew
    // nothing: issue 16's lost term).
    let first_draw = match piece.dest {
        Dest::Main => !drawn.main.contains(&key),
        Dest::Temp(id) => !drawn.temps.contains(&id),
    };
    let on_mesh = matches!(geometry, Geometry::Mesh { .. });
    let depth = form.depth.unwrap_or(match geometry {
        // A one-to-one u covers each texel once: no depth test.
        _ if in_texture_space => DepthState::DISABLED,
        Geometry::Mesh { .. } if !first_draw => DepthState::EQUAL_NO_WRITE,
        Geometry::Mesh { .. } => DepthState::LESS_WRITE,
        _ => DepthState::DISABLED,
    });
    if on_mesh && first_draw {
        match piece.dest {
            Dest::Main => drawn.main.push(key),
            Dest::Temp(id) => drawn.temps.push(id),
        }
    }
    let mask = match form.channels {
        "a" => [false, false, false, true],
        "stencil" => [false; 4],
        // A decal keeps the incoming alpha (GL_DECAL: A = Af), so the
        // alpha-blended texture writes colour only.
        _ => [true, true, true, piece.alpha && piece.blend != BlendMode::AlphaBlend],
    };
    RenderState {
        // In texture space the winding is the parameterization's, not a facing.
        cull: if on_mesh && !in_texture_space { CullMode::Back } else { CullMode::None },
        depth,
        stencil: form.stencil.unwrap_or(StencilState::DISABLED),
        blend: BlendState { ..piece.blend.render_state().with_write_mask(mask) },
    }
}

/// Why a pass exists: its group's reason, or which part of a split it is.
fn pass_reason(group: &Group, piece: &Piece, pi: usize, names: &[String], profile: &Profile) -> String {
    let n = group.n;
    if n == 1 {
        return group.reason.to_string();
    }
    let label = match group.stmts {
        [s] => format!("statement {}", names[*s]),
        many => format!(
            "statements {} (fused)",
            many.iter().map(|s| names[*s].clone()).collect::<Vec<_>>().join(", ")
        ),
    };
    let why = if piece.why.is_empty() { "the part rendered first" } else { piece.why.as_str() };
    format!("{label} split into {n} passes on {} (pass {} of {n}): {why}", profile.name, pi + 1)
}

/// Every value a plan's passes refer to, with its type, frequency and range.
fn plan_values(m: &Module, roots: &[Handle<Expr>], at: &dyn Fn(Span) -> String) -> Vec<Value> {
    m.reachable(roots)
        .into_iter()
        .map(|h| {
            let info = m.info(h);
            Value {
                id: h.index() as u32,
                op: ir::dump::node(m, &m.exprs[h]),
                ty: info.ty.name(),
                freq: info.freq.name().to_string(),
                range: match info.range() {
                    ir::Range::Unsigned => "[0,1]".into(),
                    ir::Range::Signed => "[-1,1]".into(),
                    ir::Range::Unbounded => "unbounded".into(),
                },
                at: at(m.span(h)),
            }
        })
        .collect()
}

/// The fragment stage of a pass: on a register-combiner profile the setup
/// the combiner code generator makes for it (kept: no consumer generates it
/// again), else a refusal located at the node the error names
/// (`CodegenError::span`), or at the pass's value for an error of the whole
/// pass (too many stages); the programmable stage elsewhere.
fn combiner_setup(
    m: &Module,
    realizer: Option<&dyn Realizer>,
    value: Handle<Expr>,
    textures: &[TextureBinding],
) -> Result<crate::pipeline::FragmentSetup, Box<Diagnostic>> {
    // Unit i holds textures[i]: a lookup, or a framebuffer read as a texture.
    let units: Vec<Handle<Expr>> = textures.iter().map(|t| Handle::new(t.lookup as usize)).collect();
    let Some(realizer) = realizer else { return Ok(crate::pipeline::FragmentSetup::Programmable) };
    realizer.setup(m, value, &units).map(crate::pipeline::FragmentSetup::Combiners).map_err(|e| {
        let span = e.span.filter(|s| *s != Span::DETACHED).unwrap_or_else(|| m.span(value));
        let message =
            format!("the register-combiner code generator makes no setup for this pass: {}", e.reason);
        Box::new(Diagnostic::error("not-generated", message, span, "in this pass").with_help(e.help))
    })
}

fn same_framebuffer(a: &Table, b: &Table) -> bool {
    matches!((a, b), (Table::Framebuffer { id: x, .. }, Table::Framebuffer { id: y, .. }) if x == y)
}

/// A statement at the pixel (`C δxs`) whose value interpolates per-vertex
/// values draws the vertices an earlier statement projected into the same
/// framebuffer (Pipeline Grammar, eq. (10): "the passes reuse the projected vertices").
/// Errors where there is none: nothing would place the mesh on the screen.
fn reused_projection(m: &Module) -> Vec<Diagnostic> {
    let mut projected: Vec<&Table> = Vec::new();
    let mut diags = Vec::new();
    for st in &m.statements {
        if !matches!(st.table, Table::Framebuffer { .. }) || st.freq != Frequency::Fragment {
            continue;
        }
        if !matches!(m.exprs[st.index], Expr::Pixel { .. }) {
            projected.push(&st.table);
        } else if !projected.iter().any(|t| same_framebuffer(t, &st.table)) {
            let name = match st.table {
                Table::Framebuffer { id, .. } => m.framebuffers[id as usize].name.as_str(),
                _ => unreachable!(),
            };
            diags.push(
                Diagnostic::error("no-projected-vertices", format!("this statement at the pixel interpolates per-vertex values, but no earlier statement projects the mesh into `{name}`"), m.span(st.index), "the vertices of an earlier pass are reused here")
                    .with_help(format!("Pipeline Grammar, eq. (10) reuses the screen positions an earlier pass computed: write a statement `{name} δπx ← …` first, or index this one by `δπx`")),
            );
        }
    }
    diags
}

/// `π`, `πl`, `π*`, or `u` for a statement's index.
fn projection_name(m: &Module, index: Handle<Expr>) -> String {
    for h in m.reachable(&[index]).into_iter().rev() {
        if let Expr::Project { projection, .. } = &m.exprs[h] {
            let mut s = String::from(if projection.inverse { "π⁻¹" } else { "π" });
            if let Some(sub) = &projection.subscript {
                s += sub;
            }
            if projection.star {
                s += "*";
            }
            return s;
        }
    }
    "u".to_string()
}

/// Generated programs for the compile-time benchmark and tests: about `ops`
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
