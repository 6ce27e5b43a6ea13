//! `shadec fmt`: the canonical printer; `--check` says whether files are in
//! canonical form, `-w` rewrites them in place.

use std::path::Path;
use std::process::ExitCode;

use shadec::diag::SourceFile;
use shadec::parser::{self, print};

use super::args::FmtArgs;
use super::{EXIT_SOURCE_ERRORS, EXIT_USAGE_OR_IO};

/// What became of one file.
enum Outcome {
    /// In canonical form already (with --check or -w), or printed.
    Done,
    /// Not in canonical form (--check): reported.
    Unformatted,
    /// Syntax errors (reported), exit 1.
    Errors,
    /// An I/O error (reported), exit 2.
    Io,
}

/// `shadec fmt`: the canonical printing, shown, checked or written.
pub fn run(args: &FmtArgs) -> ExitCode {
    if args.files.len() > 1 && !(args.check || args.write) {
        eprintln!(
            "error: {} files given: `shadec fmt` prints one file; give --check or -w to format several",
            args.files.len()
        );
        return ExitCode::from(EXIT_USAGE_OR_IO);
    }
    let style = if args.ascii { print::Style::Ascii } else { print::Style::Unicode };
    let mut worst = 0u8;
    let mut unformatted = 0;
    for path in &args.files {
        let code = match one(args, path, style) {
            Outcome::Done => 0,
            Outcome::Unformatted => {
                unformatted += 1;
                EXIT_SOURCE_ERRORS
            }
            Outcome::Errors => EXIT_SOURCE_ERRORS,
            Outcome::Io => EXIT_USAGE_OR_IO,
        };
        worst = worst.max(code);
    }
    if args.check && unformatted > 0 {
        let s = if unformatted == 1 { "" } else { "s" };
        eprintln!(
            "{unformatted} file{s} not in canonical form: run `shadec fmt -w` on {}",
            if unformatted == 1 { "it" } else { "them" }
        );
    }
    ExitCode::from(worst)
}

fn one(args: &FmtArgs, path: &Path, style: print::Style) -> Outcome {
    let text = match shadec::io::read_text(path) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return Outcome::Io;
        }
    };
    let (program, diagnostics) = parser::parse(&text);
    let file = SourceFile::new(path.display().to_string(), text);
    if diagnostics.iter().any(|d| d.is_error()) {
        eprint!("{}", file.render(&diagnostics, super::check::color_stderr()));
        eprintln!("error: {} was not formatted: it has syntax errors (nothing was written)", path.display());
        return Outcome::Errors;
    }
    let out = print::program(&program, style);
    if args.check {
        return match first_difference(&file.text, &out) {
            None => Outcome::Done,
            Some(line) => {
                let at = |text: &str| text.lines().nth(line - 1).unwrap_or("(end of file)").to_string();
                eprintln!("{}:{line}: not in canonical form (first difference on this line)", path.display());
                eprintln!("  found: {}", at(&file.text));
                eprintln!("  canonical: {}", at(&out));
                Outcome::Unformatted
            }
        };
    }
    if args.write {
        if out == file.text {
            return Outcome::Done;
        }
        return match shadec::io::write_atomic(path, out.as_bytes()) {
            Ok(()) => {
                eprintln!("formatted {}", path.display());
                Outcome::Done
            }
            Err(e) => {
                eprintln!("error: {e}");
                Outcome::Io
            }
        };
    }
    if super::write_output(args.output.as_deref(), &out) == ExitCode::SUCCESS {
        Outcome::Done
    } else {
        Outcome::Io
    }
}

/// The 1-based line where `a` and `b` first differ, `None` when equal.
fn first_difference(a: &str, b: &str) -> Option<usize> {
    if a == b {
        return None;
    }
    let mut left = a.split_inclusive('\n');
    let mut right = b.split_inclusive('\n');
    let mut line = 1;
    loop {
        match (left.next(), right.next()) {
            (Some(x), Some(y)) if x == y => line += 1,
            _ => return Some(line),
        }
    }
}
