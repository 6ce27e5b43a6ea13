//! `shadec compile FILE --emit ir`: lower a program and print the IR.

use std::process::ExitCode;

use shadec::diag::SourceFile;

use super::args::{CompileArgs, Emit, Format};
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
    if diagnostics.iter().all(|d| !d.is_error()) {
        let (m, lower_diags) = shadec::ir::lower(&program);
        diagnostics.extend(lower_diags);
        let target = args.target.clone().or_else(|| m.target.as_ref().map(|t| t.value.clone()));
        if let Some(name) = target {
            match shadec::profile::Profile::resolve(&name) {
                Ok(p) if diagnostics.iter().all(|d| !d.is_error()) => diagnostics.extend(shadec::profile::fit(&m, &p)),
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
        Format::Human => eprint!("{}", file.render(&diagnostics, color_stderr())),
        Format::Short => eprint!("{}", file.render_short(&diagnostics)),
        Format::Json => {
            let uri = format!("file://{}", args.file.display());
            eprintln!("{}", serde_json::to_string_pretty(&file.to_lsp(&uri, &diagnostics)).expect("diagnostics serialize"));
        }
    }
    let module = match module {
        Some(m) if diagnostics.iter().all(|d| !d.is_error()) => m,
        _ => return ExitCode::from(EXIT_SOURCE_ERRORS),
    };
    let out = match args.emit {
        Emit::Ir => shadec::ir::dump::dump(&module, Some(&text)),
    };
    super::write_output(args.output.as_deref(), &out)
}
