//! `shadec compile FILE --emit ir|plan|wgsl|spirv|glsl`: lower a program and
//! print the IR, plan it for a target and print the pass plan (RON or JSON),
//! or compile the plan's passes to shaders through naga.

use std::process::ExitCode;

use shadec::diag::SourceFile;

use super::args::{CompileArgs, CompileFormat, Emit, Format, PlanFormat};
use super::check::color_stderr;
use super::{EXIT_SOURCE_ERRORS, EXIT_USAGE_OR_IO};

/// `shadec compile`: the plan, or what `--emit` asks for.
pub fn run(args: &CompileArgs) -> ExitCode {
    let text = match shadec::io::read_text(&args.file) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_USAGE_OR_IO);
        }
    };
    let mut scene = match args.scene.as_deref().map(load_scene).transpose() {
        Ok(s) => s,
        Err(code) => return code,
    };
    // The program's images: beside it, then (on a scene) beside the scene.
    let dir = args.file.parent().unwrap_or(std::path::Path::new("")).to_path_buf();
    if let Some(s) = scene.as_mut() {
        s.program_dir = Some(dir.clone());
    }
    let front = shadec::driver::front(&text);
    let mut diagnostics = front.diagnostics.clone();
    diagnostics.extend(shadec::driver::cube_image_errors(&front.program, &dir, scene.as_ref()));
    let mut plan = None;
    if let (Some(m), false) = (&front.module, front.has_errors()) {
        match shadec::driver::target_for(args.target.as_deref(), &front.program, default_target(args.emit)) {
            Some(name) => {
                let profile = match shadec::profile::Profile::resolve(&name) {
                    Ok(p) => p,
                    Err(e) => {
                        eprintln!("error: {e}");
                        return ExitCode::from(EXIT_USAGE_OR_IO);
                    }
                };
                if matches!(args.emit, Emit::Ir) {
                    diagnostics.extend(shadec::profile::fit(m, &profile));
                    if !args.quality.stand_ins {
                        diagnostics.extend(shadec::driver::missing_images(
                            &front.program,
                            &dir,
                            scene.as_ref(),
                        ));
                    }
                } else {
                    match plan_for(args, &front.program, m, &profile, &text, scene.as_ref(), &dir) {
                        Ok((planned, warnings)) => {
                            plan = Some(planned);
                            diagnostics.extend(warnings);
                        }
                        Err(PlanFailure::Scene(code)) => return code,
                        Err(PlanFailure::Program(ds)) => diagnostics.extend(ds),
                    }
                }
            }
            None if !args.quality.stand_ins => {
                diagnostics.extend(shadec::driver::missing_images(&front.program, &dir, scene.as_ref()));
            }
            None => {}
        }
    }
    diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
    let file = SourceFile::new(args.file.display().to_string(), text.clone());
    report(args, &file, &diagnostics);
    let module = match front.module {
        Some(m) if diagnostics.iter().all(|d| !d.is_error()) => m,
        _ => return ExitCode::from(EXIT_SOURCE_ERRORS),
    };
    let out = match (args.emit, plan) {
        (Emit::Ir, _) => shadec::ir::dump::dump(&module, Some(&text)),
        (Emit::Plan, Some(p)) if plan_format(args) == PlanFormat::Json => p.plan.to_json() + "\n",
        (Emit::Plan, Some(p)) => p.plan.to_ron() + "\n",
        (Emit::Wgsl | Emit::Spirv | Emit::Glsl, Some(p)) => return shaders_out(args, &file, &text, &p),
        (Emit::Combiners, Some(p)) => match combiners_text(&p, &text) {
            Ok(t) => t,
            Err(message) => {
                eprintln!("error: {message}");
                return ExitCode::from(EXIT_SOURCE_ERRORS);
            }
        },
        (_, None) => return ExitCode::from(EXIT_SOURCE_ERRORS),
    };
    super::write_output(args.output.as_deref(), &out)
}

/// The command's default target, when neither `--target` nor the
/// program's `target X;` names one (`driver::target_for`): `wgsl` for a
/// plan or shaders, `geforce3` for combiner setups, none for the IR.
fn default_target(emit: Emit) -> Option<&'static str> {
    match emit {
        Emit::Plan | Emit::Wgsl | Emit::Spirv | Emit::Glsl => Some("wgsl"),
        Emit::Combiners => Some("geforce3"),
        Emit::Ir => None,
    }
}

/// Every pass's combiner setup as nvparse text, a `#` comment naming the
/// pass after its first header line (nvparse wants the header first; both
/// languages read `#` as a comment), so one pass's text is a file
/// `shadec emulate` and `translate` read. Each pass's per-vertex part
/// follows: a `!!VP1.0` program on geforce3, else what the host computes.
fn combiners_text(p: &shadec::pipeline::Planned, source: &str) -> Result<String, String> {
    if p.combiners.is_none() {
        return Err(format!(
            "target `{}` has no register combiners: emit combiners for geforce256 or geforce3 (--target)",
            p.plan.target
        ));
    }
    let n = p.plan.passes.len();
    let mut out = String::new();
    for (i, pass) in p.plan.passes.iter().enumerate() {
        let title = format!("# ==== pass {} of {n}: {} ({})\n", i + 1, pass.reason, pass.at);
        if pass.baked {
            out.push_str(&title);
            out.push_str("# a `bake` table, computed by the compiler: no combiner setup\n\n");
            continue;
        }
        let g = shadec::driver::combiners_of(p, i).map_err(|e| format!("not generated: {e}"))?;
        let text = shadec::backends::combiners::rc1::print(&g.config);
        let (header, rest) = text.split_once('\n').unwrap_or((&text, ""));
        // The fixed-function state the setup needs beside it: a discard's alpha test.
        let alpha = &pass.state.alpha_test;
        let state = if alpha.is_disabled() { String::new() } else { format!("# {};\n", alpha.gl_call()) };
        out.push_str(&format!("{header}\n{title}{state}{rest}\n"));
        out.push_str(&shadec::driver::vertex_program_text(p, i, Some(source), &title));
    }
    Ok(out)
}

fn load_scene(path: &std::path::Path) -> Result<shadec::scene::Scene, ExitCode> {
    shadec::scene::Scene::load(path).map_err(super::scene_failed)
}

enum PlanFailure {
    /// The scene's meshes did not build: reported, with this exit code.
    Scene(ExitCode),
    /// The program cannot be planned: its diagnostics.
    Program(Vec<shadec::diag::Diagnostic>),
}

/// The plan and its approximations' warnings, as `check --target` and
/// `render` judge it (`driver::judge`); with a scene, one pass per light,
/// the scene's uniforms folded and lights culled per object, the lowerings
/// measured on it, and what specialization removed listed.
fn plan_for(
    args: &CompileArgs,
    program: &shadec::parser::ast::Program,
    m: &shadec::ir::Module,
    profile: &shadec::profile::Profile,
    text: &str,
    scene: Option<&shadec::scene::Scene>,
    dir: &std::path::Path,
) -> Result<(shadec::pipeline::Planned, Vec<shadec::diag::Diagnostic>), PlanFailure> {
    use shadec::driver::{ForScene, PlanOptions};
    use shadec::verdict::Judging;
    let assets = match scene.map(|s| s.build()).transpose() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}");
            return Err(PlanFailure::Scene(ExitCode::from(EXIT_SOURCE_ERRORS)));
        }
    };
    let for_scene = scene.zip(assets.as_ref()).map(|(s, a)| ForScene::specialized(s, a));
    let options = PlanOptions { scene: for_scene, lowering: args.quality.lowering(), ..Default::default() };
    let judging =
        Judging { plan: options, images: Some(dir), stand_ins: args.quality.stand_ins, rendered_on: None };
    let judged = shadec::verdict::judge(m, program, profile, text, &judging).map_err(PlanFailure::Program)?;
    if scene.is_some() {
        report_removed(&judged.planned.plan);
    }
    Ok((judged.planned, judged.warnings))
}

/// The diagnostics' format: `--diagnostics-format`, else what the older
/// `--format` said, else `human`.
fn diagnostics_format(args: &CompileArgs) -> Format {
    args.diagnostics_format.unwrap_or(match args.format {
        None | Some(CompileFormat::Human | CompileFormat::Ron) => Format::Human,
        Some(CompileFormat::Short) => Format::Short,
        Some(CompileFormat::Json) => Format::Json,
    })
}

/// The plan's format: `--plan-format`, else JSON where the older `--format
/// json` asked for it, else RON.
fn plan_format(args: &CompileArgs) -> PlanFormat {
    args.plan_format.unwrap_or(match args.format {
        Some(CompileFormat::Json) => PlanFormat::Json,
        _ => PlanFormat::Ron,
    })
}

/// Prints diagnostics the way `--diagnostics-format` asks.
fn report(args: &CompileArgs, file: &SourceFile, diagnostics: &[shadec::diag::Diagnostic]) {
    match diagnostics_format(args) {
        Format::Human => eprint!("{}", file.render(diagnostics, color_stderr())),
        Format::Short => eprint!("{}", file.render_short(diagnostics)),
        Format::Json => {
            let uri = format!("file://{}", args.file.display());
            #[allow(clippy::expect_used, reason = "diagnostics are strings and numbers: JSON writes them")]
            let text =
                serde_json::to_string_pretty(&file.to_lsp(&uri, diagnostics)).expect("diagnostics serialize");
            eprintln!("{text}");
        }
    }
}

/// `--emit wgsl|spirv|glsl` in a build without naga.
#[cfg(not(feature = "wgsl"))]
fn shaders_out(_: &CompileArgs, _: &SourceFile, _: &str, _: &shadec::pipeline::Planned) -> ExitCode {
    eprintln!("error: this shadec was built without the `wgsl` feature: rebuild with default features to emit shaders");
    ExitCode::from(EXIT_USAGE_OR_IO)
}

/// `--emit wgsl|spirv|glsl`.
#[cfg(feature = "wgsl")]
fn shaders_out(
    args: &CompileArgs,
    file: &SourceFile,
    text: &str,
    planned: &shadec::pipeline::Planned,
) -> ExitCode {
    use shadec::backends::wgsl::emit;
    let passes = match shadec::driver::shaders(planned, Some(text), args.precision) {
        Ok(p) => p,
        Err(ds) => {
            report(args, file, &ds);
            return ExitCode::from(EXIT_SOURCE_ERRORS);
        }
    };
    let name = args.file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let title = format!("{name} on {}, precision {}", planned.plan.target, args.precision);
    let doc = match args.emit {
        Emit::Wgsl => emit::wgsl(&title, &passes),
        Emit::Glsl => emit::glsl(&title, &passes),
        _ => {
            let Some(out) = args.output.as_deref() else {
                eprintln!("error: SPIR-V is binary: give an output file with -o OUT (several passes write OUT's stem + .passN + extension)");
                return ExitCode::from(EXIT_USAGE_OR_IO);
            };
            let mut files = Vec::new();
            for p in &passes {
                let words = match emit::spirv(p) {
                    Ok(w) => w,
                    Err(d) => {
                        report(args, file, &[d]);
                        return ExitCode::from(EXIT_SOURCE_ERRORS);
                    }
                };
                let path = if passes.len() == 1 { out.to_path_buf() } else { pass_path(out, p.pass + 1) };
                files.push((path, emit::spirv_bytes(&words)));
            }
            for (path, bytes) in files {
                if let Err(e) = shadec::io::write_atomic(&path, &bytes) {
                    eprintln!("error: {e}");
                    return ExitCode::from(EXIT_USAGE_OR_IO);
                }
            }
            return ExitCode::SUCCESS;
        }
    };
    match doc {
        Ok(doc) => super::write_output(args.output.as_deref(), &doc),
        Err(d) => {
            report(args, file, &[d]);
            ExitCode::from(EXIT_SOURCE_ERRORS)
        }
    }
}

/// `dir/a.spv` → `dir/a.pass2.spv`.
#[cfg(feature = "wgsl")]
fn pass_path(out: &std::path::Path, n: usize) -> std::path::PathBuf {
    let stem = out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "shader".into());
    let name = match out.extension() {
        Some(ext) => format!("{stem}.pass{n}.{}", ext.to_string_lossy()),
        None => format!("{stem}.pass{n}"),
    };
    out.with_file_name(name)
}

/// `compile --scene`: what specialization removed for this scene, and why.
fn report_removed(plan: &shadec::pipeline::PassPlan) {
    if plan.removed.is_empty() {
        eprintln!("specialization: nothing removed for this scene");
        return;
    }
    let lights = plan.removed.iter().filter(|r| r.kind == "light").count();
    eprintln!(
        "specialization for this scene ({} passes remain; {lights} light × object pair(s) culled):",
        plan.passes.len()
    );
    for r in &plan.removed {
        eprintln!("  {:<9} {} — {} (at {})", r.kind, r.what, r.why, r.at);
    }
}
