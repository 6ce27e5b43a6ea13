//! The one way from a program's text to a pass plan: parse,
//! check names, lower to the IR, plan for a target profile. The CLI,
//! `bench`, the tests and the language server all compile through here, so
//! a program means the same thing to each of them.
//!
//! The driver is also where the layers meet: the planner decides whether a
//! value fits one pass of a register-combiner target by asking the
//! combiner code generator, which sits above it (backends); the driver
//! hands the generator to the planner as its [`Realizer`].
//!
//! ```
//! use shadec::driver::{compile, PlanOptions};
//! use shadec::profile::Profile;
//!
//! let source = "texture T : 2d rgba8 = image(\"wood.png\");\nC δπx ← T δu x;\n";
//! let geforce256 = Profile::builtin("geforce256").unwrap();
//! let compilation = compile(source, &geforce256, &PlanOptions::default()).unwrap();
//! assert_eq!(compilation.planned.plan.passes.len(), 1);
//! ```

use crate::backends::combiners::CombinerRealizer;
use crate::backends::combiners::Generated;
use crate::cost::Workload;
use crate::diag::Diagnostic;
use crate::ir::Module;
use crate::parser::ast::Program;
use crate::pipeline::{Planned, SetupRefusal};
use crate::planner::specialize::{draws, RemovalReport};
use crate::planner::{self, Realizer, Request, SceneSpecialization, Search};
use crate::profile::Profile;
use crate::scene::{Scene, SceneAssets};
use crate::span::Span;
use std::path::{Path, PathBuf};

/// Every problem found in a program, each with its location.
pub type Diagnostics = Vec<Diagnostic>;

/// How to plan, besides the target.
#[derive(Clone, Copy, Default)]
pub struct PlanOptions<'a> {
    /// How splits are searched (the dynamic programme; exhaustive for tests).
    pub search: Search,
    /// Plan for this scene (`compile --scene`, `render`); `None`: for any scene.
    pub scene: Option<ForScene<'a>>,
    /// What the target lacks may be lowered into approximations.
    pub lowering: crate::lowering::LowerOptions,
    /// The arithmetic the plan is drawn in (`render --precision`): on a
    /// scene, its lowerings are rendered in it when they are measured
    /// (`accuracy`), so that the one chosen is chosen — and held to its
    /// budget — by the error it shows; `None`: f32 (`check`, `compile`).
    pub drawn_in: Option<crate::numerics::Precision>,
}

/// A plan made for one scene: one pass per light for a program
/// written for light 0, then the scene's uniforms folded and lights
/// culled per object as asked.
#[derive(Clone, Copy)]
pub struct ForScene<'a> {
    /// The scene: lights, constants, textures.
    pub scene: &'a Scene,
    /// The scene's meshes (`Scene::build`): light relevance is per object.
    pub assets: &'a SceneAssets,
    /// Fold the uniforms the scene sets (and drop the terms they zero).
    pub fold_uniforms: bool,
    /// Cull lights whose terms add at most this much to any pixel of an
    /// object; `None`: keep every light.
    pub cull_threshold: Option<f64>,
}

impl<'a> ForScene<'a> {
    /// What `render` and `compile --scene` do: the scene's uniforms folded,
    /// lights culled below half an 8-bit step
    /// ([`planner::DEFAULT_CULL_THRESHOLD`]).
    pub fn specialized(scene: &'a Scene, assets: &'a SceneAssets) -> ForScene<'a> {
        ForScene { scene, assets, fold_uniforms: true, cull_threshold: Some(planner::DEFAULT_CULL_THRESHOLD) }
    }

    /// One pass per light and nothing else: the plan a specialized one is
    /// compared with.
    pub fn unspecialized(scene: &'a Scene, assets: &'a SceneAssets) -> ForScene<'a> {
        ForScene { scene, assets, fold_uniforms: false, cull_threshold: None }
    }
}

/// A program compiled for a target.
pub struct Compilation {
    /// The syntax tree.
    pub program: Program,
    /// The lowered program, before planning: what the program means
    /// (`meaning::plan`) and what `--emit ir` prints.
    pub module: Module,
    /// The pass plan with the IR its value ids refer to.
    pub planned: Planned,
    /// The warnings of the front end (unused names, …).
    pub warnings: Diagnostics,
}

/// The front end's result: the AST, the IR when lowering ran, and every
/// diagnostic (warnings too), in source order.
pub struct Front {
    /// The syntax tree.
    pub program: Program,
    /// `None` when the program has errors before lowering.
    pub module: Option<Module>,
    /// Every diagnostic of parsing, name resolution and lowering.
    pub diagnostics: Diagnostics,
}

impl Front {
    /// Whether the front end found an error.
    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(Diagnostic::is_error)
    }

    pub(crate) fn errors(&self) -> Diagnostics {
        self.diagnostics.iter().filter(|d| d.is_error()).cloned().collect()
    }
}

/// Parse, check names, and lower. A program with errors before lowering
/// is still lowered, so that `check` reports every error at once: the
/// lowering's errors are kept for the items that have no error of their
/// own (a missing `;` does not hide a wrong arity three lines down), and
/// its module is dropped.
pub fn front(source: &str) -> Front {
    let (program, mut diagnostics) = crate::parser::check(source);
    let (module, lower_diags) = crate::ir::lower(&program);
    let module = if diagnostics.iter().any(Diagnostic::is_error) {
        let errors_of_clean_items = errors_in_clean_items(source, &program, &diagnostics, lower_diags);
        diagnostics.extend(errors_of_clean_items);
        None
    } else {
        diagnostics.extend(lower_diags);
        Some(module)
    };
    diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
    Front { program, module, diagnostics }
}

/// The lowering's errors located in items free of earlier errors, and of
/// names declared by items with errors ([`crate::parser::poison`]). An
/// error of the whole program (no location) may be the broken item's.
fn errors_in_clean_items(
    source: &str,
    program: &Program,
    earlier: &[Diagnostic],
    lowered: Diagnostics,
) -> Diagnostics {
    let errors: Vec<Span> = earlier.iter().filter(|d| d.is_error()).map(|d| d.primary.span).collect();
    let poisoned = crate::parser::poison::poisoned_items(source, program, &errors);
    let clean: Vec<Span> =
        program.items.iter().zip(poisoned).filter(|(_, p)| !p).map(|(i, _)| i.span).collect();
    let holds = |item: Span, at: Span| item.start <= at.start && at.start < item.end;
    lowered
        .into_iter()
        .filter(|d| d.is_error() && d.primary.span != Span::DETACHED)
        .filter(|d| clean.iter().any(|&item| holds(item, d.primary.span)))
        .collect()
}

/// A clean program the front end did not lower: a compiler bug, said as
/// one rather than a panic (`front` lowers every program without errors).
pub(crate) fn unlowered() -> Diagnostic {
    Diagnostic::error("internal-error", "a program without errors was not lowered", Span::DETACHED, "")
        .with_help("this is a bug in shadec: please report it with the program")
}

/// Compiles `source` for `profile`: the front end, then the planner's plan.
/// `Err` holds every error found (warnings are in
/// [`Compilation::warnings`]). The plan is not vetted: a per-vertex
/// fall-back beyond its error budget, which `check` and `shadec compile`
/// refuse, is planned here; [`crate::verdict::compile`] (and
/// [`crate::compile`]) give the verdict the CLI gives.
pub fn compile(source: &str, profile: &Profile, options: &PlanOptions) -> Result<Compilation, Diagnostics> {
    let front = front(source);
    if front.has_errors() {
        return Err(front.errors());
    }
    let Front { program, module, diagnostics } = front;
    let Some(module) = module else { return Err(vec![unlowered()]) };
    let planned = plan(&module, &program, profile, Some(source), options)?;
    Ok(Compilation { program, module, planned, warnings: diagnostics })
}

/// A refusal of a statement that reads a uniform with no bound (a scalar
/// or vector the scene may set to anything) says so: the ranges the
/// refusal speaks of are unbounded because of it, and declared a colour
/// (`: c`, `: rgb`) it holds [0, 1], as a constant colour register does.
fn name_unbounded_uniforms(module: &Module, mut diagnostics: Diagnostics) -> Diagnostics {
    for d in diagnostics.iter_mut().filter(|d| d.code == "cannot-split") {
        let Some(st) = module.statements.iter().find(|st| st.span == d.primary.span) else { continue };
        let mut unbounded: Vec<&crate::ir::Uniform> = Vec::new();
        for h in module.reachable(&[st.value]) {
            if let crate::ir::Expr::Uniform(id) = module.exprs[h] {
                let u = &module.uniforms[id as usize];
                if module.info(h).interval.class() == crate::ir::Range::Unbounded
                    && !unbounded.iter().any(|v| v.name == u.name)
                {
                    unbounded.push(u);
                }
            }
        }
        let Some(&first_uniform) = unbounded.first() else { continue };
        let first = &first_uniform.name;
        let list = unbounded.iter().map(|u| format!("`{}`", u.name)).collect::<Vec<_>>().join(", ");
        // A colour declaration bounds a factor of a colour, but a scalar
        // compared with a scalar would then be an rgb: clamped where read.
        let bound = match first_uniform.ty {
            crate::ir::Ty::Scalar => format!("declare it a colour, `uniform {first} : c = …;`, where it scales a colour, or read it as `saturate({first})` (a comparison, a coordinate), to keep it in [0, 1]"),
            // A direction: its length is what is unbounded, computed once on the host.
            crate::ir::Ty::Vec3 => format!("read it as `normalize({first})` (a direction, computed once per object) to keep it in [−1, 1], or declare it a colour, `uniform {first} : c = …;`, to keep it in [0, 1]"),
            _ => format!("declare it a colour, `uniform {first} : c = …;`, to keep it in [0, 1]"),
        };
        let help = format!(
            "{}; {list} {} a uniform with no bound (the scene may set any value), which leaves every range it enters unbounded: {bound}, or render with a scene that sets it (`render` folds the scene's value)",
            d.help.clone().unwrap_or_default(),
            if unbounded.len() == 1 { "is" } else { "are" },
        );
        d.help = Some(help);
    }
    diagnostics
}

/// Plans a lowered module of `program` for `profile`, with the target's
/// fragment stage as the planner's realizer. `source` gives the plan its
/// `line:col` positions. The module carries the program's texture
/// declarations ([`crate::ir::declared`]); `_program` is no longer read,
/// kept so that callers stay unchanged until they drop it.
pub fn plan(
    module: &Module,
    _program: &Program,
    profile: &Profile,
    source: Option<&str>,
    options: &PlanOptions,
) -> Result<Planned, Diagnostics> {
    let realizer = profile.combiner_limits().map(|limits| CombinerRealizer { limits });
    let textures;
    let spec;
    let scene = match &options.scene {
        Some(s) => {
            textures = crate::scene::bind::texture_decls(module, &s.scene.constants);
            spec = SceneSpecialization {
                scene: s.scene,
                assets: s.assets,
                textures: &textures,
                fold_uniforms: s.fold_uniforms,
                cull_threshold: s.cull_threshold,
            };
            Some(&spec)
        }
        None => None,
    };
    let request = Request {
        source,
        search: options.search,
        scene,
        realizer: realizer.as_ref().map(|r| r as &dyn Realizer),
        lowering: options.lowering,
    };
    let mut planned =
        planner::plan(module, profile, &request).map_err(|d| name_unbounded_uniforms(module, d))?;
    if let Some(model) = &profile.cost {
        let workload = workload(options.scene.as_ref());
        crate::cost::annotate(&mut planned.plan, &planned.module, model, &workload);
    }
    Ok(planned)
}

/// The register-combiner setup of pass `index` as the `fixed9` model runs
/// it (`--emit combiners`, the hover): the one the plan was assembled with
/// on a combiner target, else a GeForce 3's, generated once on first use.
pub fn combiners_of(planned: &Planned, index: usize) -> Result<&Generated, SetupRefusal> {
    crate::backends::combiners::setup::of(planned, index)
}

/// The per-vertex part of pass `index` as `--emit combiners` prints it:
/// its `!!VP1.0` program where the target has vertex programs (the one its
/// setup keeps, emitted once), else what the host computes per vertex.
pub fn vertex_program_text(planned: &Planned, index: usize, source: Option<&str>, title: &str) -> String {
    crate::backends::vertex_program::emit::pass_text(planned, index, source, title)
}

/// Every pass of `planned` as WGSL shaders (`--emit wgsl|spirv|glsl`),
/// `source` placing their diagnostics.
#[cfg(feature = "wgsl")]
pub fn shaders(
    planned: &Planned,
    source: Option<&str>,
    precision: crate::numerics::Precision,
) -> Result<Vec<crate::backends::wgsl::PassShader>, Diagnostics> {
    crate::backends::wgsl::generate(planned, source, precision)
}

/// What a plan's time is predicted on: the scene planned for, or
/// GeForce3 Phong, Section 5.4's screen-filling mesh.
pub fn workload(scene: Option<&ForScene>) -> Workload {
    match scene {
        Some(s) => {
            let name =
                s.scene.path.file_name().map_or("the scene".into(), |f| f.to_string_lossy().into_owned());
            Workload::of_scene(s.scene, &s.assets.meshes, &name)
        }
        None => Workload::nominal(),
    }
}

/// Where a target came from. The order of the variants is the one
/// precedence every command and the language server apply
/// ([`choose_target`]): what the user says for this run, then what the
/// file says, then a configured default, then the built-in one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum TargetSource {
    /// `--target` on the command line.
    Flag,
    /// The program's own `target geforce3;` declaration.
    Declaration,
    /// A `// target: geforce3` comment (the language server).
    Comment,
    /// The editor's `shadec.target` setting: a default for the workspace,
    /// weaker than what a file declares.
    Client,
    /// Nothing said: the command's own default (`wgsl` for a plan).
    Default,
}

/// The one choice of a target: of the names said, the one whose source
/// comes first in [`TargetSource`]'s order (`--target` > the program's
/// `target X;` > a `// target:` comment > the editor's setting > the
/// command's default). `None` when nothing names one.
pub fn choose_target<'a>(
    said: impl IntoIterator<Item = (TargetSource, Option<&'a str>)>,
) -> Option<(String, TargetSource)> {
    said.into_iter()
        .filter_map(|(source, name)| name.map(|n| (source, n)))
        .min_by_key(|(source, _)| *source)
        .map(|(source, name)| (name.to_string(), source))
}

/// The profile a program's `target X;` declaration names.
pub fn declared_target(program: &Program) -> Option<&str> {
    program.items.iter().find_map(|i| match &i.kind {
        crate::parser::ast::ItemKind::Target(t) => Some(t.profile.value.as_str()),
        _ => None,
    })
}

/// The target of a command: `--target` (`flag`), else the program's
/// declaration, else the command's `default` ([`choose_target`]).
pub fn target_for(flag: Option<&str>, program: &Program, default: Option<&str>) -> Option<String> {
    choose_target([
        (TargetSource::Flag, flag),
        (TargetSource::Declaration, declared_target(program)),
        (TargetSource::Default, default),
    ])
    .map(|(name, _)| name)
}

/// The located errors of the cube-map images `program` declares
/// (`scene::cube_image::diagnose` over the program's typed declarations,
/// [`crate::ir::declared`]), each file found as [`image_path`] finds it; a
/// declaration whose every name is a texture of `scene` is not read.
pub fn cube_image_errors(program: &Program, dir: &Path, scene: Option<&Scene>) -> Diagnostics {
    let replaced = |name: &str| scene.is_some_and(|s| s.textures.contains_key(name));
    let resolve = |file: &str| image_path(file, dir, scene);
    crate::scene::cube_image::diagnose(&crate::ir::declared::read(program), &resolve, &replaced)
}

/// Where a program's `image("…")` or `height("…")` file is read: on a
/// scene, beside the program and then beside the scene
/// ([`Scene::resolve_program_file`]); without one, in `dir` (the program's
/// folder).
pub fn image_path(file: &str, dir: &Path, scene: Option<&Scene>) -> PathBuf {
    match scene {
        Some(s) => s.resolve_program_file(file),
        None if Path::new(file).is_absolute() => file.into(),
        None => dir.join(file),
    }
}

/// Every `image("…")` and `height("…")` file of `program` that is not where
/// [`image_path`] looks (nor replaced by a texture of `scene` of the same
/// name): an error at the file's name, whose help names `--stand-ins`.
pub fn missing_images(program: &Program, dir: &Path, scene: Option<&Scene>) -> Diagnostics {
    let mut out = Vec::new();
    for f in crate::scene::bind::image_files(&crate::ir::declared::read(program)) {
        if scene.is_some_and(|s| s.textures.contains_key(&f.texture)) {
            continue;
        }
        let path = image_path(&f.file, dir, scene);
        if path.is_file() {
            continue;
        }
        let message = format!("texture `{}`: image file `{}` not found", f.texture, path.display());
        out.push(Diagnostic::error("missing-image", message, f.span, "no such file").with_help(format!(
            "put the image at {}, give the scene a texture `{}`, or pass --stand-ins to render a procedural stand-in (a brick checkerboard; dimples for a height field)",
            path.display(),
            f.texture
        )));
    }
    out
}

/// The plan of `source` on `scene` for `profile` before and after
/// specialization (both with one pass per light; after: the scene's
/// uniforms folded and lights culled at `threshold`): what the removal
/// report and the tests compare.
pub fn plan_pair(
    source: &str,
    profile: &Profile,
    scene: &Scene,
    threshold: f64,
) -> Result<(Planned, Planned), Diagnostics> {
    let front = front(source);
    if front.has_errors() {
        return Err(front.errors());
    }
    let Some(module) = front.module.as_ref() else { return Err(vec![unlowered()]) };
    let assets = scene.build().map_err(|e| {
        vec![Diagnostic::error("scene-error", format!("the scene cannot be built: {e}"), Span::DETACHED, "")
            .with_help("fix the scene file (its meshes and textures must load)")]
    })?;
    let plan_for = |scene: ForScene| {
        plan(
            module,
            &front.program,
            profile,
            Some(source),
            &PlanOptions { scene: Some(scene), ..Default::default() },
        )
    };
    let before = plan_for(ForScene::unspecialized(scene, &assets))?;
    let after =
        plan_for(ForScene { cull_threshold: Some(threshold), ..ForScene::specialized(scene, &assets) })?;
    Ok((before, after))
}

/// What scene-driven specialization removes from `source` on `scene` for
/// `profile`, lights culled at
/// [`planner::DEFAULT_CULL_THRESHOLD`].
pub fn removal_report(source: &str, profile: &Profile, scene: &Scene) -> Result<RemovalReport, Diagnostics> {
    let (before, after) = plan_pair(source, profile, scene, planner::DEFAULT_CULL_THRESHOLD)?;
    let objects = scene.objects.len();
    Ok(RemovalReport {
        target: after.plan.target.clone(),
        lights: scene.lights.len(),
        objects,
        passes_before: before.plan.passes.len(),
        passes_after: after.plan.passes.len(),
        draws_before: draws(&before.plan, objects),
        draws_after: draws(&after.plan, objects),
        lights_culled: after.plan.removed.iter().filter(|r| r.kind == "light").count(),
        removed: after.plan.removed.clone(),
    })
}
