//! `shadec render [SCENE.ron] [--shader FILE.shd] [--target X] [--precision
//! fixed9|f32|exact] [--size WxH] [-o IMG.png]`: plan a program for a
//! target, run the plan on the CPU for a scene, write the picture, and print
//! the pass plan, the time per frame and the error against the exact
//! reference. With no arguments: Kilgard's bump-mapped torus on geforce256.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use shadec::diag::{Diagnostic, SourceFile};
use shadec::numerics::Precision;
use shadec::renderer::plan::{compare, Frame, PlanRenderer};
use shadec::renderer::{AdaptiveSettings, EdgeMode, RenderError};
use shadec::scene::Scene;

use super::check::color_stderr;
use super::{EXIT_SOURCE_ERRORS, EXIT_USAGE_OR_IO};

/// The built-in default program and scene.
pub const DEFAULT_SHADER: &str = include_str!("../../examples/kilgard_bump_mapping.shd");
/// The built-in scene `render` uses without `--scene`.
pub const DEFAULT_SCENE: &str = shadec::accuracy::DEFAULT_SCENE;

#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// The scene (RON). Without it, the built-in torus of
    /// `scenes/kilgard_torus.ron`.
    pub scene: Option<PathBuf>,
    /// The shading program. Without it, `examples/kilgard_bump_mapping.shd`
    /// (built in).
    #[arg(long, value_name = "FILE.shd")]
    pub shader: Option<PathBuf>,
    /// Target profile (built-in name or `.ron` file); defaults to the
    /// program's `target X;` line, else `wgsl`.
    #[arg(long, value_name = "PROFILE")]
    pub target: Option<String>,
    /// How the plan's arithmetic is modelled: `fixed9` (8-bit textures and
    /// framebuffer, 9-bit combiner maths: what the old hardware showed),
    /// `f32`, or `exact` (the f64 reference). Defaults to the target's own
    /// arithmetic: `fixed9` on the 8-bit hardware targets (register combiners,
    /// the texture environment), `f32` on a programmable one (`wgsl`).
    /// `--mode` is an older name.
    #[arg(long, visible_alias = "mode", value_enum)]
    pub precision: Option<Precision>,
    /// Image size; defaults to the scene's resolution.
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// Where to write the picture (PNG, written atomically). `--out` is an
    /// older name.
    #[arg(short, long, alias = "out", value_name = "IMG.png", default_value = "shadec-out.png")]
    pub output: PathBuf,
    /// Adaptive sample shading (Adaptive Sample Shading, Section 2.1): shade exactly every
    /// SPACING pixels (default 16) and at edges, subdivide where neighbouring
    /// samples differ by more than THRESHOLD (a fraction, `0.085`, or a
    /// percentage, `8.5%`), interpolate the rest. Reports the pixels shaded
    /// and the error against full per-pixel shading of the same plan.
    /// `auto`: 8.5 % every 16 pixels where the plan's shading costs more
    /// per fragment than the crossover measured on the backend, full
    /// shading elsewhere (docs/adaptive.md).
    #[arg(long, value_name = "THRESHOLD[,SPACING]|auto")]
    pub adaptive: Option<String>,
    /// Plan the program without the scene: no per-light passes (light 0
    /// only), no uniform folding, no light culling (`compile --scene`).
    #[arg(long)]
    pub no_specialize: bool,
    /// Where the plan runs: `cpu` (the CPU renderer) or `wgpu` (the plan's
    /// WGSL on whatever adapter there is: a GPU, or Mesa's lavapipe).
    #[arg(long, value_enum, default_value_t = Backend::Cpu)]
    pub backend: Backend,
    #[command(flatten)]
    pub quality: super::args::Quality,
}

/// The executor `render` runs the plan on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Backend {
    /// The CPU renderer (tiled, batched, every precision).
    Cpu,
    /// The plan's WGSL on the adapter wgpu finds: a GPU, or Mesa's lavapipe.
    Wgpu,
}

/// `--adaptive auto`: the paper's threshold and spacing, where
/// `cost::adaptive::choose` says adaptive shading pays.
fn auto_adaptive(
    plan: &shadec::pipeline::PassPlan,
    (scene, assets): (&Scene, &shadec::scene::SceneAssets),
    size: (u32, u32),
    backend: Backend,
) -> Option<AdaptiveSettings> {
    use shadec::cost::{adaptive::choose, adaptive::Executor, Workload};
    let executor = if backend == Backend::Wgpu { Executor::Wgpu } else { Executor::Cpu };
    let workload = Workload::of_scene(scene, &assets.meshes, "the scene");
    let choice = choose(plan, &workload, size, executor);
    let what = if choice.adaptive { "adaptive shading (8.5 %, every 16 pixels)" } else { "full shading" };
    println!("adaptive auto: {what}: {}", choice.why);
    choice.adaptive.then(|| AdaptiveSettings::new(16, 0.085, EdgeMode::Pass))
}

/// `--adaptive THRESHOLD[,SPACING]`: `0.085`, `8.5%`, `8.5%,8`.
fn parse_adaptive(text: &str) -> Result<AdaptiveSettings, String> {
    let bad = |why: &str| {
        format!(
            "--adaptive {text}: {why}; expected THRESHOLD[,SPACING] such as `8.5%` or `0.085,16`, or `auto`"
        )
    };
    let (t, spacing) = match text.split_once(',') {
        Some((t, sp)) => (
            t.trim(),
            sp.trim()
                .parse::<u32>()
                .ok()
                .filter(|n| (1..=256).contains(n))
                .ok_or_else(|| bad("the spacing is a whole number of pixels from 1 to 256"))?,
        ),
        None => (text.trim(), 16),
    };
    let threshold = match t.strip_suffix('%') {
        Some(p) => p.trim().parse::<f32>().map(|v| v / 100.0),
        None => t.parse::<f32>(),
    }
    .ok()
    .filter(|v| v.is_finite() && (0.0..=1.0).contains(v))
    .ok_or_else(|| bad("the threshold is a fraction of full intensity from 0 to 1 (or 0% to 100%)"))?;
    Ok(AdaptiveSettings::new(spacing, threshold, EdgeMode::Pass))
}

fn usage(message: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(EXIT_USAGE_OR_IO)
}

fn input(message: impl std::fmt::Display) -> ExitCode {
    eprintln!("error: {message}");
    ExitCode::from(EXIT_SOURCE_ERRORS)
}

/// `WxH` → (W, H).
pub fn parse_size(s: &str) -> Option<(u32, u32)> {
    let (w, h) = s.split_once(['x', 'X', '×'])?;
    let (w, h) = (w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?);
    ((1..=16384).contains(&w) && (1..=16384).contains(&h)).then_some((w, h))
}

/// `shadec render`: a program's plan rendered for a scene into an image.
pub fn run(args: &RenderArgs) -> ExitCode {
    match render(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(code) => code,
    }
}

/// The scene: the file given, else the built-in torus. The program's own
/// image files are looked for next to the program first, as `check` does,
/// then next to the scene (`Scene::resolve_program_file`).
fn load_scene(args: &RenderArgs) -> Result<Scene, ExitCode> {
    let program_dir = args.shader.as_deref().map(|s| s.parent().unwrap_or(Path::new("")).to_path_buf());
    let mut scene = match (&args.scene, &program_dir) {
        (None, Some(dir)) => {
            shadec::accuracy::default_scene(dir).map_err(|e| input(format!("the built-in scene: {e}")))?
        }
        _ => scene_from(args.scene.as_deref())?,
    };
    scene.program_dir = program_dir;
    Ok(scene)
}

/// The scene at `path`, else the built-in torus (`render`, `bench --program`).
pub fn scene_from(path: Option<&Path>) -> Result<Scene, ExitCode> {
    let Some(path) = path else {
        return Scene::parse(DEFAULT_SCENE, Path::new(""))
            .map_err(|e| input(format!("the built-in scene: {e}")));
    };
    // A folder goes on to `Scene::load`, which says it is one (issue 40).
    if !path.exists() {
        return Err(usage(format!(
            "{}: scene file not found; give the path of a RON scene such as scenes/kilgard_torus.ron",
            path.display()
        )));
    }
    Scene::load(path).map_err(|e| match e {
        shadec::scene::SceneError::Io(e) => usage(e),
        e => input(e),
    })
}

/// The program's name and text: the file given, else Kilgard's.
fn load_program(args: &RenderArgs) -> Result<(String, String), ExitCode> {
    match &args.shader {
        Some(path) => shadec::io::read_text(path).map(|t| (path.display().to_string(), t)).map_err(usage),
        None => Ok(("examples/kilgard_bump_mapping.shd (built in)".to_string(), DEFAULT_SHADER.to_string())),
    }
}

/// The program compiled for the target the arguments name (`--target`,
/// the program's `target X;`, else `wgsl`: `driver::target_for`) and judged
/// as `check --target` and `compile` judge it (`driver::judge`),
/// specialized for the scene unless `--no-specialize`. Its warnings (one
/// per approximation) are printed, and where the plan is not the one
/// `compile` prints, why.
fn compile(
    args: &RenderArgs,
    file: &SourceFile,
    scene: &Scene,
    assets: &shadec::scene::SceneAssets,
) -> Result<(shadec::driver::Compilation, shadec::profile::Profile), ExitCode> {
    use shadec::driver::{ForScene, PlanOptions};
    use shadec::verdict::Judging;
    let source = &file.text;
    let front = shadec::driver::front(source);
    let refused = |errors: &[Diagnostic]| {
        eprint!("{}", file.render(errors, color_stderr()));
        ExitCode::from(EXIT_SOURCE_ERRORS)
    };
    let mut errors: Vec<Diagnostic> = front.diagnostics.iter().filter(|d| d.is_error()).cloned().collect();
    // Where a plan without the scene (`--no-specialize`) looks for them.
    let images = scene.program_dir.clone().unwrap_or_else(|| shadec::scene::bind::scene_dir(scene));
    errors.extend(shadec::driver::cube_image_errors(&front.program, &images, Some(scene)));
    let Some(module) = front.module.as_ref().filter(|_| errors.is_empty()) else {
        return Err(refused(&errors));
    };
    let target = shadec::driver::target_for(args.target.as_deref(), &front.program, Some("wgsl"));
    let profile = shadec::profile::Profile::resolve(target.as_deref().unwrap_or("wgsl")).map_err(usage)?;
    // Only what this scene needs: a pass per light that reaches the
    // objects, the scene's uniforms folded, zeroed terms removed.
    let for_scene = (!args.no_specialize).then(|| ForScene::specialized(scene, assets));
    let lowering = args.quality.lowering();
    // The lowerings are measured in the arithmetic the plan is drawn in.
    let drawn = drawn_in(args, &profile);
    let options = PlanOptions { scene: for_scene, lowering, drawn_in: Some(drawn), ..Default::default() };
    // The built-in program names images nobody has: its stand-ins are the
    // default, said once (the binder's notes).
    let stand_ins = args.quality.stand_ins || args.shader.is_none();
    let judging = Judging { plan: options, images: Some(&images), stand_ins, rendered_on: Some(scene) };
    let judged = shadec::verdict::judge(module, &front.program, &profile, source, &judging)
        .map_err(|errors| refused(&errors))?;
    for c in &judged.candidates {
        println!(
            "lowering {}: {:.1}/255 max, RMSE {:.5} from the meaning on the scene ({}){}{}",
            c.rules,
            c.error.max_abs * 255.0,
            c.error.rmse,
            shadec::accuracy::rendered_in(Some(drawn)),
            c.predicted_ms.map_or(String::new(), |t| format!(", predicted {t:.3} ms")),
            if c.chosen {
                " — chosen"
            } else if c.within {
                ""
            } else {
                " — over --max-error"
            }
        );
    }
    if !judged.warnings.is_empty() {
        eprint!("{}", file.render(&judged.warnings, color_stderr()));
    }
    if let Some(why) = differs_from_compile(args, module, &front.program, &profile, source, &judged, &images)
    {
        println!("note: {why}");
    }
    let shadec::driver::Front { program, module, diagnostics } = front;
    let Some(module) = module else { return Err(refused(&[])) }; // lowered: checked above
    let planned = judged.planned;
    Ok((shadec::driver::Compilation { program, module, planned, warnings: diagnostics }, profile))
}

/// The arithmetic `render` draws in: `--precision`, else the target's own —
/// the combiners' fixed9 on the old hardware, f32 on a modern target.
fn drawn_in(args: &RenderArgs, profile: &shadec::profile::Profile) -> Precision {
    args.precision.unwrap_or(if matches!(profile.fragment, shadec::profile::FragmentStage::Programmable) {
        Precision::F32
    } else {
        Precision::Fixed9
    })
}

/// Why the plan `render` runs is not the one `shadec compile --target T
/// --emit plan` prints for the same program and flags, or `None` when it
/// is: the scene (one pass per light, its uniforms folded, lights culled)
/// and the lowerings measured on it (the most accurate there, or the
/// fastest within `--max-error`).
fn differs_from_compile(
    args: &RenderArgs,
    module: &shadec::ir::Module,
    program: &shadec::parser::ast::Program,
    profile: &shadec::profile::Profile,
    source: &str,
    judged: &shadec::verdict::Judged,
    images: &std::path::Path,
) -> Option<String> {
    let options = shadec::driver::PlanOptions { lowering: args.quality.lowering(), ..Default::default() };
    let (compiled, _) =
        shadec::accuracy::plan_measured(module, program, profile, source, &options, images).ok()?;
    let shape = |p: &shadec::pipeline::PassPlan| {
        let mut rules: Vec<&str> = p.approximations.iter().map(|a| a.rule.as_str()).collect();
        rules.dedup();
        let rules = if rules.is_empty() { "no approximation".to_string() } else { rules.join(" + ") };
        (p.passes.len(), rules)
    };
    let (ours, theirs) = (shape(&judged.planned.plan), shape(&compiled.plan));
    if ours == theirs {
        return None;
    }
    let mut why = Vec::new();
    let specialized = specialization(&judged.planned.plan);
    if !specialized.is_empty() {
        why.push(format!(
            "the plan is specialized for this scene ({}; --no-specialize plans without it)",
            specialized.join(", ")
        ));
    }
    if judged.candidates.iter().any(|c| c.chosen) {
        let drawn = match drawn_in(args, profile) {
            Precision::F32 => "f32".to_string(),
            p => format!("{} (the arithmetic drawn; `compile` measures in f32)", p.name()),
        };
        why.push(match args.quality.max_error {
            Some(e) => format!(
                "of the lowerings measured on this scene in {drawn}, the fastest within --max-error {e} was chosen"
            ),
            None => format!("of the lowerings measured on this scene in {drawn}, the most accurate there was chosen"),
        });
    }
    Some(format!(
        "this plan ({} pass{}, {}) is not the one `shadec compile --target {}` prints ({} pass{}, {}): {}",
        ours.0,
        if ours.0 == 1 { "" } else { "es" },
        ours.1,
        profile.name,
        theirs.0,
        if theirs.0 == 1 { "" } else { "es" },
        theirs.1,
        why.join("; ")
    ))
}

/// What specialization for the scene did to `plan`, as the plan records
/// it: passes for lights after light 0, uniforms folded, terms, textures
/// or passes removed, lights culled for objects. Empty where it changed
/// nothing — a plan whose passes differ from `compile`'s only by the
/// lowering measured on the scene is not said to be specialized.
fn specialization(plan: &shadec::pipeline::PassPlan) -> Vec<String> {
    let mut did = Vec::new();
    let lights = plan
        .passes
        .iter()
        .filter_map(|p| p.light)
        .filter(|&l| l > 0)
        .collect::<std::collections::BTreeSet<_>>();
    if !lights.is_empty() {
        did.push(format!(
            "a pass per light, {} light{} after light 0",
            lights.len(),
            if lights.len() == 1 { "" } else { "s" }
        ));
    }
    let count = |kinds: &[&str]| plan.removed.iter().filter(|r| kinds.contains(&r.kind.as_str())).count();
    if count(&["uniform"]) > 0 {
        did.push("its uniforms folded".to_string());
    }
    let removed = count(&["term", "texture", "pass"]);
    if removed > 0 {
        did.push(format!("terms, textures or passes removed ({removed})"));
    }
    if count(&["light"]) > 0 || plan.passes.iter().any(|p| p.objects.is_some()) {
        did.push("lights culled".to_string());
    }
    did
}

/// A render failure: a pass the CPU cannot render is reported at its statement.
fn failed(planned: &shadec::pipeline::Planned, file: &SourceFile, e: RenderError) -> ExitCode {
    if let RenderError::InPass { pass, source } = &e {
        if let Some(&k) = planned.plan.passes.get(*pass).and_then(|p| p.statements.first()) {
            let d = Diagnostic::error("cpu-unsupported", format!("the CPU renderer cannot render pass {} of this statement: {source}", pass + 1), planned.module.statements[k].span, "this statement's pass")
                .with_help("this is a limit of the CPU renderer (README, Status), not an error in the program: `shadec compile --target wgsl` still compiles it; or change the statement as the message says");
            eprint!("{}", file.render(&[d], color_stderr()));
            return ExitCode::from(EXIT_SOURCE_ERRORS);
        }
    }
    input(format!("{}: {e}", file.name))
}

/// The frames a render compares: the plan's, the program's meaning in
/// exact arithmetic, and — with adaptive shading — the plan shaded fully.
struct Frames {
    frame: Frame,
    reference: Frame,
    full: Option<Frame>,
}

fn render(args: &RenderArgs) -> Result<(), ExitCode> {
    let scene = load_scene(args)?;
    let (shader_name, source) = load_program(args)?;
    let size = match &args.size {
        None => scene.resolution,
        Some(s) => parse_size(s).ok_or_else(|| {
            usage(format!("--size {s}: expected WxH with 1..=16384 pixels per side, such as 640x480"))
        })?,
    };
    let auto = args.adaptive.as_deref().is_some_and(|a| a.trim() == "auto");
    let adaptive = match args.adaptive.as_deref() {
        Some(text) if !auto => Some(parse_adaptive(text).map_err(usage)?),
        _ => None,
    };
    let assets = scene.build().map_err(input)?;
    let file = SourceFile::new(shader_name.clone(), source);
    let (compiled, profile) = compile(args, &file, &scene, &assets)?;
    let planned = &compiled.planned;
    let renderer = PlanRenderer::new(planned, &compiled.program, &scene, &assets)
        .map_err(|e| failed(planned, &file, e))?;
    let mode = drawn_in(args, &profile);
    println!(
        "shadec render: {} with {}, {} on {}, {}×{}",
        args.scene.as_ref().map_or("the built-in torus scene".to_string(), |p| p.display().to_string()),
        shader_name,
        mode.name(),
        profile.name,
        size.0,
        size.1
    );
    for note in &renderer.notes {
        println!("note: {note}");
    }
    // The approximations were the warnings above: listed once.
    let mut shown = planned.plan.clone();
    shown.approximations.clear();
    print!("{}", shown.summary());
    let adaptive =
        if auto { auto_adaptive(&planned.plan, (&scene, &assets), size, args.backend) } else { adaptive };
    if args.backend == Backend::Wgpu {
        return render_on_wgpu(args, &compiled, &file, (&scene, &assets), mode, size, adaptive.as_ref());
    }
    let progress = Progress::new();
    let frames = render_frames(&renderer, mode, size, adaptive.as_ref(), &progress);
    progress.finish();
    let (frame, full) = frames.map_err(|e| failed(planned, &file, e))?;
    let lights = if args.no_specialize { 1 } else { scene.lights.len() };
    let reference = meaning_frame(&compiled, &file, (&scene, &assets), lights, size)?;
    let frames = Frames { frame, reference, full };
    save_opaque_png(&frames.frame.image, &args.output).map_err(usage)?;
    print_report(planned, &frames, mode, size, adaptive.as_ref());
    println!("wrote {}", args.output.display());
    Ok(())
}

/// Renders the plan, and full shading when adaptive (what adaptive shading
/// is measured against: the same plan and mode).
fn render_frames(
    renderer: &PlanRenderer,
    mode: Precision,
    size: (u32, u32),
    adaptive: Option<&AdaptiveSettings>,
    progress: &Progress,
) -> Result<(Frame, Option<Frame>), RenderError> {
    let (w, h) = size;
    let frame = match adaptive {
        Some(settings) => {
            renderer.render_adaptive(mode, w, h, settings, &mut |d, t| progress.tick("adaptive", d, t))
        }
        None => renderer.render(mode, w, h, &mut |d, t| progress.tick(mode.name(), d, t)),
    }?;
    let full = match adaptive {
        Some(_) => Some(renderer.render(mode, w, h, &mut |d, t| progress.tick("full shading", d, t))?),
        None => None,
    };
    Ok((frame, full))
}

/// Time, shading, and the error against the meaning (and against full
/// shading when adaptive).
fn print_report(
    planned: &shadec::pipeline::Planned,
    frames: &Frames,
    mode: Precision,
    size: (u32, u32),
    adaptive: Option<&AdaptiveSettings>,
) {
    let frame = &frames.frame;
    let secs = frame.time.as_secs_f64().max(1e-9);
    let mpix = (size.0 as f64 * size.1 as f64) / secs / 1e6;
    let n = planned.plan.passes.len();
    println!(
        "frame: {:.1} ms on the CPU ({mpix:.2} Mpixel/s at {}×{}, {} threads), {} fragments shaded over {n} pass{}{}",
        secs * 1e3,
        size.0,
        size.1,
        rayon::current_num_threads(),
        frame.adaptive.map_or(frame.stats.shaded, |a| a.shaded()),
        if n == 1 { "" } else { "es" },
        predicted(&planned.plan)
    );
    if mode == Precision::Fixed9 {
        for (i, how) in frame.shading.iter().enumerate() {
            println!("pass {}: {}", i + 1, how.describe());
        }
    }
    if let (Some(full), Some(a), Some(settings)) = (&frames.full, frame.adaptive, adaptive) {
        let e = compare(&full.image, &frame.image);
        let speedup = full.time.as_secs_f64() / secs;
        println!(
            "adaptive (threshold {:.1} %, spacing {}): {:.2} % of {} covered fragments shaded ({} regular, {} edge, {} subdivided), {} interpolated; {speedup:.2}× the speed of full shading ({:.1} ms)",
            100.0 * settings.threshold,
            settings.spacing,
            100.0 * a.fraction_shaded(),
            a.covered,
            a.regular,
            a.edge,
            a.adaptive,
            a.interpolated,
            full.time.as_secs_f64() * 1e3
        );
        print_error(mode, "full shading", e);
    }
    let e = compare(&frames.reference.image, &frame.image);
    print_error(mode, MEANING, e);
    println!("{}", summary_line(&planned.plan, mode, e));
}

/// What the error is measured against: the program's meaning rendered in
/// exact (f64) arithmetic, every statement one unsplit pass.
const MEANING: &str = "the program's meaning (exact, unsplit)";

/// The one line a render ends with: target, passes, precision, the error
/// against the meaning, PSNR, and what that PSNR means to the eye.
fn summary_line(
    plan: &shadec::pipeline::PassPlan,
    mode: Precision,
    e: shadec::renderer::plan::ErrorReport,
) -> String {
    let n = plan.passes.len();
    format!(
        "summary: {} in {n} pass{}, {} arithmetic; against the program's meaning (exact): largest channel difference {:.1}/255, PSNR {} — {}",
        plan.target,
        if n == 1 { "" } else { "es" },
        mode.name(),
        e.max_abs * 255.0,
        psnr(e.psnr),
        psnr_word(e.psnr)
    )
}

/// What a PSNR against the meaning says to the eye (the usual reading of
/// 8-bit image PSNR: above 40 dB differences are not seen, below 30 dB they are).
fn psnr_word(p: f64) -> &'static str {
    if p.is_infinite() {
        "identical"
    } else if p >= 40.0 {
        "visually indistinguishable (≥ 40 dB)"
    } else if p >= 30.0 {
        "close: differences visible on close inspection (30–40 dB)"
    } else if p >= 20.0 {
        "visibly different (20–30 dB)"
    } else {
        "far from the meaning (< 20 dB)"
    }
}

/// The program's meaning rendered exactly on the CPU: the reference both
/// backends are measured against.
fn meaning_frame(
    compiled: &shadec::driver::Compilation,
    file: &SourceFile,
    (scene, assets): (&Scene, &shadec::scene::SceneAssets),
    lights: usize,
    size: (u32, u32),
) -> Result<Frame, ExitCode> {
    let meaning = shadec::meaning::plan(&compiled.module, lights).map_err(|errors| {
        eprint!("{}", file.render(&errors, color_stderr()));
        ExitCode::from(EXIT_SOURCE_ERRORS)
    })?;
    let progress = Progress::new();
    let frame = PlanRenderer::new(&meaning, &compiled.program, scene, assets)
        .and_then(|r| r.render(Precision::Exact, size.0, size.1, &mut |d, t| progress.tick("meaning", d, t)));
    progress.finish();
    frame.map_err(|e| failed(&meaning, file, e))
}

/// `--backend wgpu`: the plan's WGSL on the adapter wgpu finds,
/// in f32 or, with `--precision fixed9`, the register combiners' integer
/// model; the same error report as the CPU's. With `--adaptive`, a sparse
/// frame, a classification and the plan's passes under a depth mask
/// (`gpu::adaptive`), measured against full shading of the same plan.
#[cfg(feature = "gpu")]
fn render_on_wgpu(
    args: &RenderArgs,
    compiled: &shadec::driver::Compilation,
    file: &SourceFile,
    (scene, assets): (&Scene, &shadec::scene::SceneAssets),
    mode: Precision,
    size: (u32, u32),
    adaptive: Option<&AdaptiveSettings>,
) -> Result<(), ExitCode> {
    use shadec::gpu::{runner::Gpu, scene_run::ScenePlan};
    let gpu = Gpu::new().map_err(usage)?;
    let info = gpu.adapter_info();
    println!("adapter: {} ({:?}, {:?}, driver {})", info.name, info.backend, info.device_type, info.driver);
    if mode == Precision::Exact {
        println!("note: a GPU has no f64: `--precision exact` runs the f32 shader");
    }
    let planned = &compiled.planned;
    let gpu_failed = |e: shadec::gpu::scene_run::SceneRunError| input(format!("{}: {e}", file.name));
    let plan = ScenePlan::new(planned, &compiled.program, Some(&file.text), mode, scene, assets)
        .map_err(gpu_failed)?;
    for note in &plan.notes {
        println!("note: {note}");
    }
    let target = shadec::gpu::runner::Target::new(size.0, size.1);
    let passes = plan.passes_in(&target).map_err(gpu_failed)?;
    let full = timed_on_wgpu(&gpu, &target, &passes).map_err(|e| gpu_failed(e.into()))?;
    let frame = match adaptive {
        None => full.clone(),
        Some(settings) => {
            let sparse = shadec::gpu::adaptive::GpuAdaptive {
                spacing: settings.spacing,
                threshold: settings.threshold,
            };
            let (passes, notes) = shadec::gpu::adaptive::adaptive_passes(&passes, &target, sparse);
            for note in notes {
                println!("note: {note}");
            }
            timed_on_wgpu(&gpu, &target, &passes).map_err(|e| gpu_failed(e.into()))?
        }
    };
    let image = shadec::renderer::Framebuffer::from_rgba8(size.0, size.1, frame.timed.image.as_raw())
        .map_err(input)?;
    let lights = if args.no_specialize { 1 } else { scene.lights.len() };
    let reference = meaning_frame(compiled, file, (scene, assets), lights, size)?;
    save_opaque_png(&image, &args.output).map_err(usage)?;
    let n = planned.plan.passes.len();
    println!(
        "frame: {} on wgpu, {} pass{}; pipelines and uploads made once for the scene: {:.1} ms{}",
        frame.timing(),
        n,
        if n == 1 { "" } else { "es" },
        frame.made.as_secs_f64() * 1e3,
        predicted(&planned.plan)
    );
    if let Some(settings) = adaptive {
        let full_image = shadec::renderer::Framebuffer::from_rgba8(size.0, size.1, full.timed.image.as_raw())
            .map_err(input)?;
        println!(
            "adaptive (threshold {:.1} %, spacing {}): a sparse frame, a classification, and the plan's passes where neighbouring samples differ (a depth mask skips the rest); {:.2}× the speed of full shading ({})",
            100.0 * settings.threshold,
            settings.spacing,
            full.time().as_secs_f64() / frame.time().as_secs_f64().max(1e-9),
            full.timing()
        );
        print_error(mode, "full shading", compare(&full_image, &image));
    }
    let e = compare(&reference.image, &image);
    print_error(mode, MEANING, e);
    println!("{}", summary_line(&planned.plan, mode, e));
    println!("wrote {}", args.output.display());
    Ok(())
}

/// One frame on wgpu, timed, and how long its objects took to make.
#[cfg(feature = "gpu")]
#[derive(Clone)]
struct GpuFrame {
    timed: shadec::gpu::runner::TimedFrame,
    made: std::time::Duration,
}

#[cfg(feature = "gpu")]
impl GpuFrame {
    fn time(&self) -> std::time::Duration {
        self.timed.time()
    }
    fn timing(&self) -> String {
        let wall = self.timed.wall.as_secs_f64() * 1e3;
        match self.timed.gpu {
            Some(t) => format!(
                "{:.2} ms GPU time (timestamp queries; {wall:.1} ms submit to read-back)",
                t.as_secs_f64() * 1e3
            ),
            None => {
                format!("{wall:.1} ms submit to read-back wall time (the adapter has no timestamp queries)")
            }
        }
    }
}

/// Pipelines, bind groups, uploads and targets made once; a warm-up
/// frame, then the median of five timed ones.
#[cfg(feature = "gpu")]
fn timed_on_wgpu(
    gpu: &shadec::gpu::runner::Gpu,
    target: &shadec::gpu::runner::Target,
    passes: &[shadec::gpu::runner::RunPass],
) -> Result<GpuFrame, shadec::gpu::runner::GpuError> {
    let made = Instant::now();
    let frame = shadec::gpu::runner::Frame::prepare(gpu, target, passes)?;
    let made = made.elapsed();
    Ok(GpuFrame { timed: frame.draw_median(gpu, 5)?, made })
}

#[cfg(not(feature = "gpu"))]
fn render_on_wgpu(
    _: &RenderArgs,
    _: &shadec::driver::Compilation,
    _: &SourceFile,
    _: (&Scene, &shadec::scene::SceneAssets),
    _: Precision,
    _: (u32, u32),
    _: Option<&AdaptiveSettings>,
) -> Result<(), ExitCode> {
    Err(usage(
        "this shadec was built without the `gpu` feature: rebuild with default features for --backend wgpu",
    ))
}

/// `; predicted on geforce3: 2.356 ms` where the target has a cost model
///, at the scene's resolution.
fn predicted(plan: &shadec::pipeline::PassPlan) -> String {
    plan.predicted.as_ref().map_or(String::new(), |p| {
        format!("; predicted on {}: {:.3} ms at the scene's resolution", plan.target, p.total_us / 1000.0)
    })
}

/// One error figure, naming the render's precision and its reference.
fn print_error(mode: Precision, against: &str, e: shadec::renderer::plan::ErrorReport) {
    println!(
        "error against {against} of this {} render: max abs {:.4} ({:.1}/255), RMSE {:.5}, PSNR {}",
        mode.name(),
        e.max_abs,
        e.max_abs * 255.0,
        e.rmse,
        psnr(e.psnr)
    );
}

fn psnr(p: f64) -> String {
    if p.is_infinite() {
        "∞ dB (identical)".into()
    } else {
        format!("{p:.2} dB")
    }
}

/// Saves the colour buffer as an opaque RGBA8 PNG (destination alpha is an
/// intermediate of the plan, not coverage), atomically.
pub fn save_opaque_png(fb: &shadec::renderer::Framebuffer, path: &Path) -> Result<(), String> {
    let mut rgba = fb.to_rgba8();
    for px in rgba.chunks_exact_mut(4) {
        px[3] = 255;
    }
    let mut bytes = Vec::new();
    let encoder = image::codecs::png::PngEncoder::new(&mut bytes);
    image::ImageEncoder::write_image(
        encoder,
        &rgba,
        fb.width(),
        fb.height(),
        image::ExtendedColorType::Rgba8,
    )
    .map_err(|e| format!("{}: cannot encode PNG: {e}", path.display()))?;
    shadec::io::write_atomic(path, &bytes).map_err(|e| e.to_string())
}

/// A progress bar that appears only once the work has taken over a second
/// (and only on a terminal: indicatif hides it otherwise).
pub(super) struct Progress {
    start: Instant,
    bar: indicatif::ProgressBar,
    shown: std::cell::Cell<bool>,
}

impl Progress {
    pub(super) fn new() -> Progress {
        Progress::counting("passes·objects")
    }

    /// A bar counting `unit`s (shown after a second, on a terminal).
    pub(super) fn counting(unit: &str) -> Progress {
        let bar = indicatif::ProgressBar::hidden();
        let template = format!("{{msg:>16}} [{{bar:40}}] {{pos}}/{{len}} {unit}, {{elapsed}}");
        bar.set_style(
            indicatif::ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        Progress { start: Instant::now(), bar, shown: std::cell::Cell::new(false) }
    }

    pub(super) fn tick(&self, what: &str, done: usize, total: usize) {
        self.bar.set_length(total as u64);
        self.bar.set_position(done as u64);
        self.bar.set_message(what.to_string());
        if !self.shown.get() && self.start.elapsed() > Duration::from_secs(1) {
            self.shown.set(true);
            self.bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
    }

    pub(super) fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
