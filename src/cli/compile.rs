//! `shadec compile FILE --emit ir|plan`: lower a program and print the IR,
//! or plan it for a target and print the pass plan (RON or JSON).

use std::process::ExitCode;

use shadec::diag::SourceFile;

use super::args::{CompileArgs, CompileFormat, Emit};
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
    if diagnostics.iter().all(|d| !d.is_error()) {
        let (m, lower_diags) = shadec::ir::lower(&program);
        diagnostics.extend(lower_diags);
        let mut target = args.target.clone().or_else(|| m.target.as_ref().map(|t| t.value.clone()));
        if args.emit == Emit::Plan && target.is_none() {
            target = Some("wgsl".to_string());
        }
        if let Some(name) = target {
            match shadec::profile::Profile::resolve(&name) {
                Ok(p) if diagnostics.iter().all(|d| !d.is_error()) => {
                    if args.emit == Emit::Plan {
                        match shadec::planner::plan(&m, &p, Some(&text)) {
                            Ok(planned) => plan = Some(planned.plan),
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
    match args.format {
        CompileFormat::Human | CompileFormat::Ron => eprint!("{}", file.render(&diagnostics, color_stderr())),
        CompileFormat::Short => eprint!("{}", file.render_short(&diagnostics)),
        CompileFormat::Json => {
            let uri = format!("file://{}", args.file.display());
            eprintln!("{}", serde_json::to_string_pretty(&file.to_lsp(&uri, &diagnostics)).expect("diagnostics serialize"));
        }
    }
    let module = match module {
        Some(m) if diagnostics.iter().all(|d| !d.is_error()) => m,
        _ => return ExitCode::from(EXIT_SOURCE_ERRORS),
    };
    let out = match (args.emit, plan) {
        (Emit::Ir, _) => shadec::ir::dump::dump(&module, Some(&text)),
        (Emit::Plan, Some(plan)) if args.format == CompileFormat::Json => plan.to_json() + "\n",
        (Emit::Plan, Some(plan)) => plan.to_ron() + "\n",
        (Emit::Plan, None) => return ExitCode::from(EXIT_SOURCE_ERRORS),
    };
    super::write_output(args.output.as_deref(), &out)
}
