//! `shadec fmt`: the canonical printer.

use std::process::ExitCode;

use shadec::diag::SourceFile;
use shadec::parser::{self, print};

use super::args::FmtArgs;
use super::{EXIT_SOURCE_ERRORS, EXIT_USAGE_OR_IO};

pub fn run(args: &FmtArgs) -> ExitCode {
    let text = match shadec::io::read_text(&args.file) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_USAGE_OR_IO);
        }
    };
    let (program, diagnostics) = parser::parse(&text);
    let file = SourceFile::new(args.file.display().to_string(), text);
    if diagnostics.iter().any(|d| d.is_error()) {
        eprint!("{}", file.render(&diagnostics, super::check::color_stderr()));
        eprintln!(
            "error: {} was not printed: it has syntax errors (nothing was written)",
            args.file.display()
        );
        return ExitCode::from(EXIT_SOURCE_ERRORS);
    }
    let style = if args.ascii { print::Style::Ascii } else { print::Style::Unicode };
    let out = print::program(&program, style);
    super::write_output(args.output.as_deref(), &out)
}
