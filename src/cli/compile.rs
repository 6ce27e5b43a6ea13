//! `shadec compile FILE --emit ir|plan|wgsl|spirv|glsl`: lower a program and
//! print the IR, plan it for a target and print the pass plan (RON or JSON),
//! or compile the plan's passes to shaders through naga.

use std::process::ExitCode;

use shadec::diag::SourceFile;

use super::args::{CompileArgs, CompileFormat, Emit, FidelityArg};
use super::check::color_stderr;
use super::{EXIT_SOURCE_ERRORS, EXIT_USAGE_OR_IO};

pub fn run(args: &CompileArgs) -> ExitCode {
    let text = match shadec::io::read_text(&args.file) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_USAGE_OR_IO);
        }
    };
    let (program, mut diagnostics) = shadec::parser::check(&text);
    let mut module = None;
    let mut plan = None;
    let scene = match &args.scene {
        None => None,
        Some(path) => match shadec::scene::Scene::load(path) {
            Ok(s) => Some(s),
            Err(e) => {
                eprintln!("error: {e}");
                let missing = matches!(e, shadec::scene::SceneError::Io(_));
                return ExitCode::from(if missing { EXIT_USAGE_OR_IO } else { EXIT_SOURCE_ERRORS });
            }
        },
    };
    let lowering = shadec::lowering::LowerOptions { approximate: !args.no_approx, max_error: args.max_error };
    if diagnostics.iter().all(|d| !d.is_error()) {
        let (m, lower_diags) = shadec::ir::lower(&program);
        diagnostics.extend(lower_diags);
        let shaders = matches!(args.emit, Emit::Wgsl | Emit::Spirv | Emit::Glsl);
        let mut target = args.target.clone().or_else(|| m.target.as_ref().map(|t| t.value.clone()));
        if shaders && args.target.is_none() {
            // Shaders are for modern hardware: plan on the wgsl profile
            // unless --target says otherwise.
            target = Some("wgsl".to_string());
        }
        if args.emit == Emit::Plan && target.is_none() {
            target = Some("wgsl".to_string());
        }
        if let Some(name) = target {
            match shadec::profile::Profile::resolve(&name) {
                Ok(p) if diagnostics.iter().all(|d| !d.is_error()) => {
                    if args.emit == Emit::Plan || shaders {
                        let planned = match &scene {
                            // One pass per light, the scene's uniforms folded, lights culled per object.
                            Some(sc) => match sc.build() {
                                Ok(assets) => {
                                    let textures =
                                        shadec::scene::bind::texture_decls(&program, &sc.constants);
                                    let spec = shadec::planner::SceneSpecialization {
                                        scene: sc,
                                        assets: &assets,
                                        textures: &textures,
                                        fold_uniforms: true,
                                        cull_threshold: Some(shadec::planner::DEFAULT_CULL_THRESHOLD),
                                    };
                                    shadec::planner::plan_lowered(&m, &p, Some(&text), Some(&spec), &lowering)
                                }
                                Err(e) => {
                                    eprintln!("error: {e}");
                                    return ExitCode::from(EXIT_SOURCE_ERRORS);
                                }
                            },
                            None => shadec::planner::plan_lowered(&m, &p, Some(&text), None, &lowering),
                        };
                        match planned {
                            Ok(planned) => {
                                if scene.is_some() {
                                    report_removed(&planned.plan);
                                }
                                plan = Some(planned)
                            }
                            Err(ds) => diagnostics.extend(ds),
                        }
                    } else {
                        diagnostics.extend(shadec::profile::fit(&m, &p));
                    }
                }
                Ok(_) => {}
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(EXIT_USAGE_OR_IO);
                }
            }
        }
        module = Some(m);
    }
    diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
    let file = SourceFile::new(args.file.display().to_string(), text.clone());
    report(args, &file, &diagnostics);
    let module = match module {
        Some(m) if diagnostics.iter().all(|d| !d.is_error()) => m,
        _ => return ExitCode::from(EXIT_SOURCE_ERRORS),
    };
    let out = match (args.emit, plan) {
        (Emit::Ir, _) => shadec::ir::dump::dump(&module, Some(&text)),
        (Emit::Plan, Some(p)) if args.format == CompileFormat::Json => p.plan.to_json() + "\n",
        (Emit::Plan, Some(p)) => p.plan.to_ron() + "\n",
        (Emit::Wgsl | Emit::Spirv | Emit::Glsl, Some(p)) => return shaders_out(args, &file, &text, &p),
        (_, None) => return ExitCode::from(EXIT_SOURCE_ERRORS),
    };
    super::write_output(args.output.as_deref(), &out)
}

/// Prints diagnostics the way `--format` asks.
fn report(args: &CompileArgs, file: &SourceFile, diagnostics: &[shadec::diag::Diagnostic]) {
    match args.format {
        CompileFormat::Human | CompileFormat::Ron => eprint!("{}", file.render(diagnostics, color_stderr())),
        CompileFormat::Short => eprint!("{}", file.render_short(diagnostics)),
        CompileFormat::Json => {
            let uri = format!("file://{}", args.file.display());
            eprintln!(
                "{}",
                serde_json::to_string_pretty(&file.to_lsp(&uri, diagnostics)).expect("diagnostics serialize")
            );
        }
    }
}

/// `--emit wgsl|spirv|glsl` in a build without naga.
#[cfg(not(feature = "wgsl"))]
fn shaders_out(_: &CompileArgs, _: &SourceFile, _: &str, _: &shadec::pipeline::Planned) -> ExitCode {
    let _ = FidelityArg::Exact;
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
    use shadec::backends::wgsl::{codegen, emit};
    let fidelity = match args.fidelity {
        FidelityArg::Exact => codegen::Fidelity::Exact,
        FidelityArg::Hardware => codegen::Fidelity::Hardware,
    };
    let passes = match codegen::generate(planned, Some(text), fidelity) {
        Ok(p) => p,
        Err(ds) => {
            report(args, file, &ds);
            return ExitCode::from(EXIT_SOURCE_ERRORS);
        }
    };
    let name = args.file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let title = format!(
        "{name} on {}, fidelity {}",
        planned.plan.target,
        if fidelity == codegen::Fidelity::Exact { "exact" } else { "hardware" }
    );
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
