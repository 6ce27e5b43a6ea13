//! The one verdict on a program for a target: what `shadec check
//! --target`, `compile` and `render` all run, and the language server with
//! them, so that the three commands accept and refuse the same programs
//! for the same reasons. It sits above the driver (which plans) and
//! `accuracy` (which measures what an approximation costs).

use std::path::Path;

use crate::driver::{front, missing_images, target_for, unlowered, Diagnostics, Front, PlanOptions};
use crate::ir::Module;
use crate::parser::ast::Program;
use crate::pipeline::Planned;
use crate::profile::{Profile, ProfileError};

/// What `check`, `compile` and `render` ask of a program besides its text
/// and target — the same for the three, so that they reach the same
/// verdict ([`judge`]).
#[derive(Clone, Copy, Default)]
pub struct Judging<'a> {
    /// The scene planned for (`render`, `compile --scene`) and the
    /// lowering options (`--no-approx`, `--max-error`).
    pub plan: PlanOptions<'a>,
    /// The folder `image("…")` files are looked for in (a scene's, else the
    /// program's); `None`: files are not looked for (the library's plans).
    pub images: Option<&'a Path>,
    /// `--stand-ins`: a missing image file binds a procedural stand-in
    /// instead of being an error.
    pub stand_ins: bool,
    /// The scene whose folder image files are also looked in when the plan
    /// is not made for it (`render --no-specialize`); else the planned
    /// scene's ([`PlanOptions::scene`]).
    pub rendered_on: Option<&'a crate::scene::Scene>,
}

impl Judging<'_> {
    /// The scene beside which image files are looked for after `images`.
    fn image_scene(&self) -> Option<&crate::scene::Scene> {
        self.plan.scene.map(|s| s.scene).or(self.rendered_on)
    }
}

/// A plan and what it costs in quality.
pub struct Judged {
    pub planned: Planned,
    /// One warning per approximation the plan takes, located, with its
    /// bound or measured error and the options that forbid it.
    pub warnings: Diagnostics,
    /// On a scene: every lowering measured there (`render` lists them).
    pub candidates: Vec<crate::accuracy::Candidate>,
}

/// The one verdict on a program for a target: its image files, then the
/// plan — on a scene, the lowerings measured there (`accuracy::choose`,
/// `accuracy::most_accurate`) —, then every approximation vetted
/// (`accuracy::vet`: a per-vertex fall-back only within its budget) and
/// reported. `check --target`, `compile` and `render` all call this.
pub fn judge(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    judging: &Judging,
) -> Result<Judged, Diagnostics> {
    let missing = match judging.images {
        Some(dir) if !judging.stand_ins => missing_images(program, dir, judging.image_scene()),
        _ => Vec::new(),
    };
    if !missing.is_empty() {
        return Err(missing);
    }
    let options = &judging.plan;
    let images = judging.images.unwrap_or(Path::new(""));
    let (mut planned, candidates) =
        crate::accuracy::plan_measured(module, program, profile, source, options, images)?;
    let measuring = crate::accuracy::vet(&mut planned, module, program, source, options, images)
        .map_err(|refused| why_not_per_fragment(refused, module, program, profile, source, options))?;
    let mut warnings = crate::accuracy::warnings(&planned, module, source, &measuring);
    say_why_per_vertex(&mut warnings, module, program, profile, source, options);
    Ok(Judged { planned, warnings, candidates })
}

/// A per-vertex fall-back refused over its budget says why the target
/// cannot compute the part per fragment: the refusal of the plan that
/// takes every bounded approximation but not the fall-back (three signed
/// vectors where the combiners interpolate two colours, …), so that the
/// help names the real obstacle, not only another target.
fn why_not_per_fragment(
    mut refused: Diagnostics,
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
) -> Diagnostics {
    let Some(d) = refused.iter_mut().find(|d| d.code == "per-vertex-over-budget") else { return refused };
    if let Some(why) = per_fragment_refusal(module, program, profile, source, options) {
        let help = d.help.take().unwrap_or_default();
        d.help = Some(format!("{help}; {why}"));
    }
    refused
}

/// A per-vertex fall-back taken within its budget says why per fragment
/// was refused too, as the refusal over it does: quality dropped for a
/// reason the user may remove (an unbounded `uniform`, a third signed
/// vector), and the warning is where they look.
fn say_why_per_vertex(
    warnings: &mut Diagnostics,
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
) {
    let marker = format!("(`{}`)", crate::accuracy::PER_VERTEX);
    let mut fall_backs = warnings.iter_mut().filter(|d| d.message.contains(&marker)).peekable();
    if fall_backs.peek().is_none() {
        return;
    }
    let Some(why) = per_fragment_refusal(module, program, profile, source, options) else { return };
    for d in fall_backs {
        let help = d.help.take().unwrap_or_default();
        d.help = Some(format!("{why}; {help}"));
    }
}

/// Why `profile` refuses the program per fragment: the first refusal of the
/// plan with every bounded approximation allowed and no per-vertex
/// fall-back, with the remedies its help names (the planner's general
/// clause about framebuffer blending left out); `None` when that plan
/// succeeds.
fn per_fragment_refusal(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    options: &PlanOptions,
) -> Option<String> {
    let bounded = crate::lowering::LowerOptions { max_error: Some(f64::INFINITY), ..options.lowering };
    let exact = PlanOptions { lowering: bounded, ..*options };
    let why = crate::driver::plan(module, program, profile, Some(source), &exact).err()?;
    let first = why.first()?;
    let reason = first.message.split(": ").last().unwrap_or(&first.message);
    let remedy: Vec<&str> = first
        .help
        .as_deref()
        .unwrap_or_default()
        .split("; ")
        .filter(|clause| !clause.starts_with("framebuffer blending can only split"))
        .collect();
    Some(format!("per fragment {} refuses it ({reason}): {}", profile.name, remedy.join("; ")))
}

/// Compiles `source` for `profile` as `shadec compile` does: the front end,
/// then [`judge`] — the plan with every approximation vetted, so that a
/// library caller is refused what `check` refuses (a per-vertex fall-back
/// beyond its budget) and gets the same warnings. `driver::compile` is the
/// planner's plan alone, without the vetting.
pub fn compile(source: &str, profile: &Profile, judging: &Judging) -> Result<Judged, Diagnostics> {
    let front = front(source);
    if front.has_errors() {
        return Err(front.errors());
    }
    let Some(module) = &front.module else { return Err(vec![unlowered()]) };
    judge(module, &front.program, profile, source, judging)
}

/// What `check` reports for one program: every diagnostic of the front end
/// and, when a target is known (`target`, else the program's own
/// `target X;`: [`target_for`]) and the program is clean, the verdict of
/// [`judge`] — what `compile` and `render` refuse for the program is an
/// error here too, with the same message, and every approximation the plan
/// takes a warning. Errors only for an unknown target.
pub fn check(source: &str, target: Option<&str>) -> Result<Front, ProfileError> {
    check_with(source, target, &Judging::default())
}

/// [`check`] with the options `compile` and `render` take (`--no-approx`,
/// `--max-error`, `--stand-ins`) and the folder image files are in.
pub fn check_with(source: &str, target: Option<&str>, judging: &Judging) -> Result<Front, ProfileError> {
    let mut front = front(source);
    let (Some(module), false) = (&front.module, front.has_errors()) else { return Ok(front) };
    let Some(name) = target_for(target, &front.program, None) else {
        if let (Some(dir), false) = (judging.images, judging.stand_ins) {
            let missing = missing_images(&front.program, dir, judging.image_scene());
            front.diagnostics.extend(missing);
        }
        return Ok(front);
    };
    let profile = Profile::resolve(&name)?;
    let found = verdict(module, &front.program, &profile, source, judging).1;
    front.diagnostics.extend(found);
    front.diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
    Ok(front)
}

/// The profile's fit and [`judge`]'s verdict as diagnostics, with the plan
/// when there is one: what `check --target` and the language server report.
/// The planner's verdict replaces the fit's "it will be split" warnings
/// when it refuses, and its refusals are the errors (a capability the
/// lowering supplies is not one).
pub fn verdict(
    module: &Module,
    program: &Program,
    profile: &Profile,
    source: &str,
    judging: &Judging,
) -> (Option<Judged>, Diagnostics) {
    let mut found: Diagnostics =
        crate::profile::fit(module, profile).into_iter().filter(|d| !d.is_error()).collect();
    match judge(module, program, profile, source, judging) {
        Ok(judged) => {
            found.extend(judged.warnings.iter().cloned());
            (Some(judged), found)
        }
        Err(errors) => {
            found.retain(|d| d.code != "does-not-fit");
            found.extend(errors);
            (None, found)
        }
    }
}
