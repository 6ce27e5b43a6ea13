//! NV_vertex_program's `!!VP1.0` vertex programs (NVIDIA 2001; Lindholm,
//! Kilgard and Moreton 2001, "A User-Programmable Vertex Engine"): the
//! program as data ([`program`]), [`parse_file`] with located errors, the
//! load-time rules ([`validate()`]), [`print()`], a CPU interpreter in IEEE
//! f32 ([`emulate`]), a WGSL vertex stage ([`wgsl`]), and the generator of a
//! pass's per-vertex part on the GeForce3 ([`emit`]).
//! docs/vertex-programs.md records the conventions.

// `Diagnostic` is the error type by design (errors are rare and rich).
#![allow(clippy::result_large_err)]

pub mod emit;
pub mod emulate;
mod lexer;
mod parser;
mod printer;
pub mod program;
pub mod validate;
#[cfg(feature = "wgsl")]
pub mod wgsl;

pub use parser::{parse, InstructionSpans, Parsed};
pub use printer::{instruction, print};
pub use program::{Dest, DstReg, Instruction, Opcode, Output, Source, SrcReg, Version, VertexProgram};
pub use validate::{validate, VpError};

use crate::diag::Diagnostic;
use crate::span::Span;

/// A whole `!!VP1.0` (or `!!VP1.1`, `!!VSP1.0`) file, header included: the program, or
/// every error, located.
pub fn parse_file(text: &str) -> Result<VertexProgram, Vec<Diagnostic>> {
    let parsed = read(text).map_err(|d| vec![d])?;
    let errors = validate(&parsed.program);
    if errors.is_empty() {
        return Ok(parsed.program);
    }
    Err(errors.iter().map(|e| e.to_diagnostic(&parsed.spans, parsed.header)).collect())
}

/// The header and the grammar, without the load-time rules.
pub fn read(text: &str) -> Result<Parsed, Diagnostic> {
    let lead = text.len() - text.trim_start().len();
    let rest = &text[lead..];
    let found =
        [Version::V10, Version::V11, Version::Vsp10].into_iter().find(|v| rest.starts_with(v.header()));
    let Some(version) = found else {
        let end = rest.find(char::is_whitespace).map_or(text.len(), |e| lead + e);
        let (message, help) = if rest.starts_with("!!ARBvp1.0") {
            (
                "an ARB_vertex_program (`!!ARBvp1.0`) is not an NV_vertex_program",
                "shadec reads NV_vertex_program's `!!VP1.0`, `!!VP1.1` and `!!VSP1.0`".to_string(),
            )
        } else {
            let help =
                crate::backends::readers::comment_before_header(rest, &["!!VP1.0", "!!VP1.1", "!!VSP1.0"]);
            let help =
                help.unwrap_or_else(|| "put `!!VP1.0` (or `!!VP1.1`, `!!VSP1.0`) on the first line".into());
            ("expected the `!!VP1.0` header", help)
        };
        return Err(Diagnostic::error(
            "syntax",
            message,
            Span::new(lead, end.max(lead)),
            "a vertex program starts with `!!VP1.0`",
        )
        .with_help(help));
    };
    let start = lead + version.header().len();
    let header = Span::new(lead, start);
    parse(&text[start..], start, version, header)
}
