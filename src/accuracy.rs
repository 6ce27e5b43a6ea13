//! `--max-error E` on a scene: among the lowerings a
//! program has for a target, the one the cost model predicts fastest whose
//! render stays within E of the program's meaning **on that scene** — so
//! that an approximation without a stated bound (per-vertex shading,
//! Taylor renormalization) is judged by what it does to this picture,
//! not refused for having no bound.
//!
//! Each candidate (every choice of rules that plans, `lowering::choices`)
//! is rendered by the CPU plan renderer in the arithmetic it is drawn in
//! (`PlanOptions::drawn_in`: `render`'s `--precision`; f32 for `check` and
//! `compile`) and compared with the f32 render of the program's meaning (`meaning::plan`: every statement one
//! unsplit pass, `normalize`, `sqrt`, `pow` themselves), through the same
//! texture units and rasterizer, so that what differs is the lowering and
//! the planner's splits. The error is the largest channel difference (as
//! `bench` reports it), at the scene's resolution up to 256 pixels a side.

use crate::diag::Diagnostic;
use crate::driver::{Diagnostics, PlanOptions};
use crate::ir::Module;
use crate::lowering::LowerOptions;
use crate::numerics::Precision;
use crate::parser::ast::Program;
use crate::pipeline::{MeasuredError, Planned};
use crate::profile::Profile;
use crate::renderer::plan::{compare, ErrorReport, PlanRenderer};
use crate::span::Span;

/// Largest side the candidates are rendered at.
const MAX_SIDE: u32 = 256;

/// One lowering tried, with its measured error.
#[derive(Clone, Debug)]
pub struct Candidate {
    /// Its rules, `normalization_cube_map + power_by_passes`.
    pub rules: String,
    pub error: ErrorReport,
    /// Predicted frame time on the scene (ms), where the target has a model.
    pub predicted_ms: Option<f64>,
    pub passes: usize,
    pub within: bool,
    /// The one kept (`choose`, `most_accurate`).
    pub chosen: bool,
}

/// Plans `module` for `profile` on `options.scene` with the lowering whose
/// measured error is within `max_error`, predicted fastest; the plan
/// carries its [`MeasuredError`]. A program that plans as written is
/// returned as planned; without a scene in `options`, the stated bounds
/// decide. `lights`: the lights the meaning shades.
pub fn choose(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
    max_error: f64,
    lights: usize,
) -> Result<(Planned, Vec<Candidate>), Diagnostics> {
    let Some(scene) = options.scene.as_ref() else {
        // No scene to measure on: the stated bounds decide, as `compile`.
        let bounded = LowerOptions { max_error: Some(max_error), ..options.lowering };
        let planned = plan_with(module, program, profile, source, options, bounded)?;
        return Ok((planned, Vec::new()));
    };
    let first = plan_with(module, program, profile, source, options, LowerOptions::default())?;
    if first.plan.approximations.is_empty() {
        return Ok((first, Vec::new()));
    }
    pick_on(module, program, profile, source, options, (scene, &scene_name(scene)), lights, Some(max_error))
}

/// Without `--max-error`, on a scene: the plan whose render is closest to
/// the program's meaning there (RMSE, then the largest channel
/// difference, then the predicted frame) — "the most accurate
/// plan that fits", measured on the picture rather than assumed from the
/// rules' order (on the Kilgard torus, `fragment_lighting.shd`'s per-vertex
/// shading on geforce256 beats the 8-bit cube maps raised to the 32nd
/// power). RMSE first: the largest difference of a program with a step
/// (`floor`, `step`, a toon ramp) is one pixel on either side of the step,
/// which every approximation moves; the RMSE says how much of the picture
/// is wrong. A program that plans as written is returned as planned.
pub fn most_accurate(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
    lights: usize,
) -> Result<(Planned, Vec<Candidate>), Diagnostics> {
    let first = crate::driver::plan(module, program, profile, Some(source), options)?;
    let Some(scene) = options.scene.as_ref().filter(|_| !first.plan.approximations.is_empty()) else {
        return Ok((first, Vec::new()));
    };
    pick_on(module, program, profile, source, options, (scene, &scene_name(scene)), lights, None)
}

/// The lowerings of `module` planned with `options`, each rendered on `at`
/// (a scene and its name) against the program's meaning: with `max_error`,
/// the fastest within it (none: refused); without, the most accurate
/// (RMSE, then the largest difference, then the predicted frame) of those
/// that are not a per-vertex fall-back beyond [`PER_VERTEX_BUDGET`] (when
/// every one is, the most accurate, which [`vet`] refuses).
#[allow(clippy::too_many_arguments)]
fn pick_on(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
    (at, name): (&crate::driver::ForScene, &str),
    lights: usize,
    max_error: Option<f64>,
) -> Result<(Planned, Vec<Candidate>), Diagnostics> {
    let size = measuring_size(at.scene.resolution);
    let mut candidates = measure_on(module, program, profile, source, options, at, lights)?;
    for (_, c) in &mut candidates {
        c.within = max_error.is_none_or(|e| f64::from(c.error.max_abs) <= e);
    }
    let best = match max_error {
        Some(_) => (0..candidates.len()).filter(|&i| candidates[i].1.within).min_by(|&a, &b| {
            let t = |i: usize| candidates[i].1.predicted_ms.unwrap_or(0.0);
            t(a).total_cmp(&t(b)).then(a.cmp(&b))
        }),
        None => {
            let over = |c: &Candidate| {
                c.rules.contains(PER_VERTEX) && f64::from(c.error.max_abs) > PER_VERTEX_BUDGET
            };
            let key = |c: &Candidate| {
                (over(c), c.error.rmse, f64::from(c.error.max_abs), c.predicted_ms.unwrap_or(0.0))
            };
            (0..candidates.len()).min_by(|&a, &b| {
                let (x, y) = (key(&candidates[a].1), key(&candidates[b].1));
                x.0.cmp(&y.0)
                    .then(x.1.total_cmp(&y.1))
                    .then(x.2.total_cmp(&y.2))
                    .then(x.3.total_cmp(&y.3))
                    .then(a.cmp(&b))
            })
        }
    };
    let Some(best) = best else {
        let e = max_error.unwrap_or(PER_VERTEX_BUDGET);
        return Err(vec![refusal(&candidates, profile, source, (name, measuring_precision(options)), e)]);
    };
    candidates[best].1.chosen = true;
    let report: Vec<Candidate> = candidates.iter().map(|(_, c)| c.clone()).collect();
    Ok((with_measured(candidates.swap_remove(best), name, size, options), report))
}

/// The chosen plan, its measured error recorded.
fn with_measured(
    (mut planned, chosen): (Planned, Candidate),
    scene: &str,
    size: (u32, u32),
    options: &PlanOptions,
) -> Planned {
    planned.plan.measured = Some(MeasuredError {
        scene: scene.to_string(),
        width: size.0,
        height: size.1,
        max_abs: f64::from(chosen.error.max_abs),
        rmse: chosen.error.rmse,
        precision: shown_precision(options),
    });
    planned
}

/// The arithmetic a plan's lowerings are measured in: the one it is drawn
/// in (`PlanOptions::drawn_in`), else f32.
pub fn measuring_precision(options: &PlanOptions) -> Precision {
    options.drawn_in.unwrap_or(Precision::F32)
}

/// [`measuring_precision`] where it is not f32 (recorded in the plan).
fn shown_precision(options: &PlanOptions) -> Option<Precision> {
    Some(measuring_precision(options)).filter(|&p| p != Precision::F32)
}

/// How both renders of a measured error were made, for messages: `both
/// rendered in f32`, or the precision the plan was drawn in.
pub fn rendered_in(precision: Option<Precision>) -> String {
    match precision {
        None | Some(Precision::F32) => "both rendered in f32".to_string(),
        Some(p) => format!("the plan rendered in {}, the meaning in f32", p.name()),
    }
}

/// How a measured error was made, for messages: `f32`, or the precision the
/// plan was drawn in against the meaning in f32.
fn measured_in(precision: Option<Precision>) -> String {
    match precision {
        None | Some(Precision::F32) => "f32".to_string(),
        Some(p) => format!("the plan in {}, the meaning in f32", p.name()),
    }
}

/// Every plan `module` has for `profile` on `options.scene` — as written,
/// when it plans, then each choice of lowering rules that plans (one per
/// distinct set of rules) — with its error against the program's meaning
/// on the scene and its predicted frame: the points of the Pareto front
/// of passes and error (`shadec bench --program`).
/// `within` is left `true`; `lights`: the lights the meaning shades.
pub fn measure(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
    lights: usize,
) -> Result<Vec<(Planned, Candidate)>, Diagnostics> {
    let Some(scene) = options.scene.as_ref() else {
        let what = "measuring a plan's error needs a scene".to_string();
        return Err(vec![Diagnostic::error("max-error", what, Span::DETACHED, "")
            .with_help("give the scene the plans are measured on")]);
    };
    measure_on(module, program, profile, source, options, scene, lights)
}

/// [`measure`], the plans made with `options` (for its scene, or for any)
/// and rendered on `at`.
fn measure_on(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
    at: &crate::driver::ForScene,
    lights: usize,
) -> Result<Vec<(Planned, Candidate)>, Diagnostics> {
    let scene = at;
    let size = measuring_size(scene.scene.resolution);
    let reference = render(&crate::meaning::plan(module, lights)?, program, scene, size, Precision::F32)?;
    let drawn = measuring_precision(options);
    let exact = LowerOptions { approximate: false, ..Default::default() };
    let written = plan_with(module, program, profile, source, options, exact);
    let lowered = crate::lowering::choices(profile).into_iter().filter_map(|choice| {
        let only = LowerOptions { only: Some(choice), ..Default::default() };
        plan_with(module, program, profile, source, options, only).ok()
    });
    let mut candidates: Vec<(Planned, Candidate)> = Vec::new();
    for planned in written.into_iter().chain(lowered) {
        let rules = rule_names(&planned);
        // One candidate per plan of distinct approximations (a sum split
        // across δ and the whole sum fall back by the same rule).
        if candidates
            .iter()
            .any(|(p, c)| c.rules == rules && p.plan.approximations == planned.plan.approximations)
        {
            continue;
        }
        let error = compare(&reference, &render(&planned, program, scene, size, drawn)?);
        let predicted_ms = planned.plan.predicted.as_ref().map(|p| p.total_us / 1000.0);
        let passes = planned.plan.passes.len();
        candidates
            .push((planned, Candidate { rules, error, predicted_ms, passes, within: true, chosen: false }));
    }
    Ok(candidates)
}

/// `module` planned with `options` and `lowering` in place of its own.
fn plan_with(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
    lowering: LowerOptions,
) -> Result<Planned, Diagnostics> {
    crate::driver::plan(module, program, profile, Some(source), &PlanOptions { lowering, ..*options })
}

/// The scene's resolution, scaled down to at most [`MAX_SIDE`] a side.
fn measuring_size((w, h): (u32, u32)) -> (u32, u32) {
    let k = (MAX_SIDE as f64 / w.max(h).max(1) as f64).min(1.0);
    (((w as f64 * k).round() as u32).max(1), ((h as f64 * k).round() as u32).max(1))
}

fn render(
    planned: &Planned,
    program: &Program,
    scene: &crate::driver::ForScene,
    (w, h): (u32, u32),
    precision: Precision,
) -> Result<crate::renderer::Framebuffer, Diagnostics> {
    // A lowering's error, not the 8-bit stores every plan makes alike
    // (fixed9 keeps its 8-bit framebuffer: the hardware's).
    PlanRenderer::new(planned, program, scene.scene, scene.assets)
        .and_then(|mut r| {
            r.set_unrounded_targets(true);
            r.render(precision, w, h, &mut |_, _| {})
        })
        .map(|f| f.image)
        .map_err(|e| {
            let what = format!("the program's lowerings cannot be measured on the scene: {e}");
            vec![Diagnostic::error("scene", what, Span::DETACHED, "").with_help(
                "the renderer cannot draw this program on this scene (the message says why); `shadec compile` without `--scene` plans without measuring",
            )]
        })
}

/// The rules a plan used, `normalization_cube_map + power_by_passes`, or
/// `as written`.
fn rule_names(planned: &Planned) -> String {
    let mut rules: Vec<&str> = Vec::new();
    for a in &planned.plan.approximations {
        if !rules.contains(&a.rule.as_str()) {
            rules.push(&a.rule);
        }
    }
    if rules.is_empty() {
        return "as written".into();
    }
    rules.join(" + ")
}

fn scene_name(scene: &crate::driver::ForScene) -> String {
    scene.scene.path.file_name().map_or("the scene".into(), |f| f.to_string_lossy().into_owned())
}

/// No lowering within `max_error`: located at the closest one's first
/// approximation, with the error it would need.
fn refusal(
    candidates: &[(Planned, Candidate)],
    profile: &Profile,
    source: &str,
    (scene, drawn): (&str, Precision),
    max_error: f64,
) -> Diagnostic {
    let closest = candidates.iter().min_by(|a, b| a.1.error.max_abs.total_cmp(&b.1.error.max_abs));
    let (message, help, span) = match closest {
        Some((planned, c)) => (
            format!(
                "no lowering for {} is within --max-error {max_error} on {}: the closest ({}) is {:.4} ({:.1}/255) from the program's meaning ({})",
                profile.name,
                scene,
                c.rules,
                c.error.max_abs,
                c.error.max_abs * 255.0,
                measured_in(Some(drawn))
            ),
            format!(
                "raise --max-error to {:.4} or more, or target a profile that computes this per fragment (wgsl)",
                c.error.max_abs
            ),
            planned.plan.approximations.first().map_or(Span::DETACHED, |a| one_char(source, a.span)),
        ),
        None => (
            format!("no lowering for {} plans", profile.name),
            "target a profile that computes this per fragment (wgsl)".to_string(),
            Span::DETACHED,
        ),
    };
    Diagnostic::error("max-error", message, span, "approximated here").with_help(help)
}

/// The one character where `span` starts (an approximation's place).
fn one_char(source: &str, span: Span) -> Span {
    let start = span.start as usize;
    if span == Span::DETACHED || !source.is_char_boundary(start) {
        return Span::DETACHED;
    }
    let end = source[start..].chars().next().map_or(start, |c| start + c.len_utf8());
    Span::new(start, end)
}

/// The rule name of a per-vertex fall-back (`lowering::per_vertex`).
pub const PER_VERTEX: &str = "per_vertex";

/// The error budget within which a per-vertex fall-back is taken by
/// default: its plan's largest channel difference from the program's
/// meaning, rendered in f32 on the scene (or, without one, on the built-in
/// torus), at most 48/255 ≈ 0.188. Per-vertex (Gouraud) shading of a
/// specular term moves a highlight by up to a triangle; on the Kilgard
/// torus the per-fragment Phong of `examples/fragment_lighting.shd` is
/// 41.2/255 from its meaning on geforce256 per vertex (its cube maps'
/// lowering: 56.8/255), which the budget takes; a highlight lost between the vertices of a large polygon, or a sharp
/// `^64` over four textures (85/255), is refused. `--max-error E` replaces
/// the budget with E (and measures it the same way); `--no-approx` refuses
/// every approximation.
pub const PER_VERTEX_BUDGET: f64 = 48.0 / 255.0;

/// The built-in scene (Kilgard's bump-mapped torus): what `render` draws
/// without a scene file, and where an approximation without a stated bound
/// is measured when no scene is given.
pub const DEFAULT_SCENE: &str = include_str!("../scenes/kilgard_torus.ron");

/// The built-in scene's name in figures.
pub const DEFAULT_SCENE_NAME: &str = "the built-in torus (scenes/kilgard_torus.ron)";

/// The built-in scene, its image files looked for in `dir`.
pub fn default_scene(dir: &std::path::Path) -> Result<crate::scene::Scene, crate::scene::SceneError> {
    crate::scene::Scene::parse(DEFAULT_SCENE, &dir.join("kilgard_torus.ron"))
}

/// What [`vet`] found out about a plan's per-vertex fall-backs.
#[derive(Clone, Debug, Default)]
pub struct Vetting {
    /// The budget they were held to (`--max-error`, else [`PER_VERTEX_BUDGET`]).
    pub budget: f64,
    /// Why the error could not be measured (it is then unbounded).
    pub unmeasured: Option<String>,
}

/// The plan `check`, `compile` and `render` judge: on a scene, the
/// lowerings measured there (the fastest within `--max-error`, else the
/// most accurate, a per-vertex one only within [`PER_VERTEX_BUDGET`]);
/// without one, the planner's, unless it takes an approximation without a
/// stated bound: then the lowerings are measured on the built-in torus and
/// chosen the same way (under `--max-error`, a per-vertex fall-back the
/// planner refused for having no bound is let through to be measured).
pub fn plan_measured(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
    images: &std::path::Path,
) -> Result<(Planned, Vec<Candidate>), Diagnostics> {
    let max_error = options.lowering.max_error;
    if !options.lowering.approximate {
        return Ok((crate::driver::plan(module, program, profile, Some(source), options)?, Vec::new()));
    }
    if let Some(s) = options.scene.as_ref() {
        let lights = s.scene.lights.len();
        return match max_error {
            Some(e) => choose(module, program, profile, source, options, e, lights),
            None => most_accurate(module, program, profile, source, options, lights),
        };
    }
    let first = match (crate::driver::plan(module, program, profile, Some(source), options), max_error) {
        (Ok(p), _) => p,
        (Err(errors), None) => return Err(errors),
        (Err(errors), Some(e)) => {
            // A per-vertex fall-back has no stated bound: let it through to be measured.
            let free = LowerOptions { max_error: None, ..options.lowering };
            match plan_with(module, program, profile, source, options, free) {
                Ok(p) if only_measurable_beyond(&p, e) => p,
                _ => return Err(errors),
            }
        }
    };
    if first.plan.approximations.iter().all(|a| a.rule != PER_VERTEX && a.output_bound.is_some()) {
        return Ok((first, Vec::new()));
    }
    // An approximation without a stated bound (per-vertex shading, Taylor
    // renormalization): without a scene, the lowerings are measured on the
    // built-in torus, as `render` without a scene file measures them (its
    // image files looked for in `images`, where `render` looks for them).
    let scene = default_scene(images);
    let Some((scene, assets)) = scene.ok().and_then(|s| s.build().ok().map(|a| (s, a))) else {
        return Ok((first, Vec::new())); // `vet` says it is unbounded
    };
    let at = crate::driver::ForScene::unspecialized(&scene, &assets);
    match pick_on(module, program, profile, source, options, (&at, DEFAULT_SCENE_NAME), 1, max_error) {
        Ok(picked) => Ok(picked),
        // Refused within --max-error: located at the closest lowering.
        Err(refused) if refused.iter().any(|d| d.code == "max-error") => Err(refused),
        // The torus cannot draw it: `vet` tries the plan itself, else says "unbounded".
        Err(_) => Ok((first, Vec::new())),
    }
}

/// `planned` falls back to per-vertex shading, and its other
/// approximations are within `max_error` or have no stated bound: [`vet`]
/// then measures the whole plan against `max_error`.
fn only_measurable_beyond(planned: &Planned, max_error: f64) -> bool {
    let a = &planned.plan.approximations;
    a.iter().any(|a| a.rule == PER_VERTEX)
        && a.iter().all(|a| a.rule == PER_VERTEX || a.output_bound.is_none_or(|b| b <= max_error))
}

/// Holds a plan's per-vertex fall-backs to their budget (`--max-error`,
/// else [`PER_VERTEX_BUDGET`]): measured on the scene planned for, else on
/// the built-in torus (the measure is then recorded in the plan); beyond
/// the budget the program is refused at the fall-back. Repeated
/// approximation records (one per light's pass) are kept once.
pub fn vet(
    planned: &mut Planned,
    module: &Module,
    program: &Program,
    source: &str,
    options: &PlanOptions,
    images: &std::path::Path,
) -> Result<Vetting, Diagnostics> {
    let mut seen = std::collections::HashSet::new();
    planned.plan.approximations.retain(|a| seen.insert((a.rule.clone(), a.at.clone(), a.why.clone())));
    let budget = options.lowering.max_error.unwrap_or(PER_VERTEX_BUDGET);
    let mut vetting = Vetting { budget, unmeasured: None };
    let Some(at) = planned.plan.approximations.iter().find(|a| a.rule == PER_VERTEX).map(|a| a.span) else {
        return Ok(vetting);
    };
    if planned.plan.measured.is_none() {
        match measure_plan(planned, module, program, options, images) {
            Ok(m) => planned.plan.measured = Some(m),
            Err(why) => vetting.unmeasured = Some(why),
        }
    }
    match &planned.plan.measured {
        Some(m) if m.max_abs > budget => {
            Err(vec![per_vertex_refusal(planned, module, source, at, m, options)])
        }
        _ => Ok(vetting),
    }
}

/// `planned`'s error against the program's meaning (rendered in f32), the
/// plan rendered in the arithmetic it is drawn in ([`measuring_precision`]),
/// on the scene planned for, else on the built-in torus.
fn measure_plan(
    planned: &Planned,
    module: &Module,
    program: &Program,
    options: &PlanOptions,
    images: &std::path::Path,
) -> Result<MeasuredError, String> {
    let text = |d: Diagnostics| d.first().map_or_else(String::new, |d| d.message.clone());
    let measure = |scene: &crate::driver::ForScene, lights: usize, name: String| {
        let size = measuring_size(scene.scene.resolution);
        let meaning = crate::meaning::plan(module, lights).map_err(text)?;
        let reference = render(&meaning, program, scene, size, Precision::F32).map_err(text)?;
        let drawn = render(planned, program, scene, size, measuring_precision(options)).map_err(text)?;
        let e = compare(&reference, &drawn);
        Ok(MeasuredError {
            scene: name,
            width: size.0,
            height: size.1,
            max_abs: f64::from(e.max_abs),
            rmse: e.rmse,
            precision: shown_precision(options),
        })
    };
    if let Some(s) = &options.scene {
        return measure(s, s.scene.lights.len(), scene_name(s));
    }
    let scene = default_scene(images).map_err(|e| e.to_string())?;
    let assets = scene.build().map_err(|e| e.to_string())?;
    measure(&crate::driver::ForScene::unspecialized(&scene, &assets), 1, DEFAULT_SCENE_NAME.to_string())
}

/// A per-vertex fall-back measured beyond its budget: refused at the
/// fall-back, naming its error and the flag that accepts it.
fn per_vertex_refusal(
    planned: &Planned,
    module: &Module,
    source: &str,
    at: Span,
    m: &MeasuredError,
    options: &PlanOptions,
) -> Diagnostic {
    let budget = match options.lowering.max_error {
        Some(e) => format!("--max-error {e}"),
        None => format!("the per-vertex budget of {:.1}/255", PER_VERTEX_BUDGET * 255.0),
    };
    let message = format!(
        "{} cannot compute this per fragment, and computing it per vertex (the `per_vertex` fall-back) is {:.1}/255 (largest channel difference, {}) from the program's meaning on {}, beyond {budget}",
        planned.plan.target,
        m.max_abs * 255.0,
        measured_in(m.precision),
        m.scene
    );
    Diagnostic::error("per-vertex-over-budget", message, expr_span(module, source, at), "computed per vertex here")
        .with_help(format!(
            "accept it with --max-error {:.3} (or more), or target a profile that computes this per fragment (wgsl)",
            (m.max_abs * 1000.0).ceil() / 1000.0
        ))
}

/// What is said of an approximation with no bound at the output: its
/// rule's bound where the value is computed, if it has one.
fn no_output_bound(at_site: Option<f64>) -> String {
    match at_site {
        Some(b) => format!(
            "at most {b:.4} ({:.1}/255) where it is computed, but no bound at the output (a step, a condition or a coordinate reads it)",
            b * 255.0
        ),
        None => "no stated bound".into(),
    }
}

/// One warning per approximation `planned` takes, at the expression it
/// replaces, with its stated bound or its measured error (precision and
/// reference named) and the options that forbid it.
pub fn warnings(planned: &Planned, module: &Module, source: &str, vetting: &Vetting) -> Diagnostics {
    let plan = &planned.plan;
    plan.approximations
        .iter()
        .map(|a| {
            // A bound where the value is computed is not one at the output
            // when what reads it has no first-order bound (a step, a
            // condition, a coordinate): then the scene's measurement speaks.
            let at_site = a.error_bound.filter(|_| a.output_bound.is_none());
            let figure = match (a.rule == PER_VERTEX, &plan.measured, a.output_bound) {
                (true, Some(m), _) => format!(
                    "measured {:.1}/255 (largest channel difference; RMSE {:.4}) from the program's meaning, {} at {}×{} on {}, within {}{}",
                    m.max_abs * 255.0,
                    m.rmse,
                    rendered_in(m.precision),
                    m.width,
                    m.height,
                    m.scene,
                    budget_text(vetting.budget),
                    one_light_caveat(module, m)
                ),
                (_, _, Some(bound)) => format!(
                    "at most {bound:.4} ({:.1}/255) at the output: the rule's stated bound against exact arithmetic",
                    bound * 255.0
                ),
                (_, Some(m), None) => format!(
                    "{}; measured {:.1}/255 (largest channel difference, {}) from the program's meaning on {}",
                    no_output_bound(at_site),
                    m.max_abs * 255.0,
                    measured_in(m.precision),
                    m.scene
                ),
                (_, None, None) => format!(
                    "{}, and it could not be measured ({})",
                    no_output_bound(at_site),
                    vetting.unmeasured.as_deref().unwrap_or("give a scene: `compile --scene`")
                ),
            };
            let message = format!("approximation on {} (`{}`): {}", plan.target, a.rule, a.why);
            Diagnostic::warning("approximation", message, expr_span(module, source, a.span), "approximated here")
                .with_help(format!(
                    "{figure}; --no-approx refuses every approximation, --max-error E those whose error exceeds E"
                ))
        })
        .collect()
}

/// Measured on the built-in torus, which has one light, a program that
/// names a light past light 0 was measured without those lights' terms
/// (they are zero there): said, with where to measure it instead.
fn one_light_caveat(module: &Module, m: &MeasuredError) -> &'static str {
    let names_more = module.vectors.iter().any(|v| v.index.is_some_and(|i| i > 0));
    if names_more && m.scene == DEFAULT_SCENE_NAME {
        " (the torus has one light: the terms of the lights past light 0 the program names are zero there; measure on your scene with `check --scene FILE`, `compile --scene FILE` or `render FILE`)"
    } else {
        ""
    }
}

fn budget_text(budget: f64) -> String {
    if (budget - PER_VERTEX_BUDGET).abs() < 1e-12 {
        format!("the per-vertex budget of {:.1}/255", budget * 255.0)
    } else {
        format!("--max-error {budget}")
    }
}

/// The span of the largest expression that starts where `at` does, else
/// the one character there.
pub fn expr_span(module: &Module, source: &str, at: Span) -> Span {
    let one = one_char(source, at);
    if one == Span::DETACHED {
        return one;
    }
    module
        .exprs
        .arena()
        .iter()
        .map(|(h, _)| module.span(h))
        .filter(|s| s.start == one.start && s.end as usize <= source.len())
        .max_by_key(|s| s.end - s.start)
        .unwrap_or(one)
}
