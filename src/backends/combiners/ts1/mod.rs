//! NVIDIA nvparse's `!!TS1.0` texture-shader programs (NV_texture_shader,
//! the geforce3's per-unit shader operations that compute texture0..3 for
//! the register combiners): the program as data ([`program`]), [`parse`]
//! with located errors, the consistency rules ([`validate()`]), [`print()`], and
//! the per-pixel model the emulator and `translate` share ([`emulate`]).
//! docs/combiners.md, "Texture shaders", records the conventions.

// `Diagnostic` is the error type by design (errors are rare and rich).
#![allow(clippy::result_large_err)]

pub mod emulate;
mod hilo;
mod lexer;
pub mod lower;
mod parser;
mod printer;
pub mod program;
pub mod validate;

pub use parser::{instruction_names, parse, Parsed, StageSpans};
pub use printer::{instruction, print};
pub use program::{CullCondition, DotFamily, DotMapping, Operation, TextureShader, MAX_STAGES};
pub use validate::{validate, TsError};

use crate::diag::Diagnostic;
use crate::span::Span;

/// Parses and validates the text after a `!!TS1.0` header (`base`: its byte
/// offset in the file): the program, or every error located.
pub fn parse_and_validate(text: &str, base: usize) -> Result<TextureShader, Vec<Diagnostic>> {
    let parsed = parse(text, base).map_err(|d| vec![d])?;
    let errors = validate(&parsed.program);
    if errors.is_empty() {
        return Ok(parsed.program);
    }
    let fallback = Span::new(base, base);
    Err(errors.iter().map(|e| e.to_diagnostic(&parsed.spans, fallback)).collect())
}

/// A whole `!!TS1.0` file (header included): the program, or every error.
pub fn parse_file(text: &str) -> Result<TextureShader, Vec<Diagnostic>> {
    let lead = text.len() - text.trim_start().len();
    if !text[lead..].starts_with("!!TS1.0") {
        let end = text[lead..].find(char::is_whitespace).map_or(text.len(), |e| lead + e);
        return Err(vec![Diagnostic::error(
            "syntax",
            "expected the `!!TS1.0` header",
            Span::new(lead, end),
            "a texture-shader program starts with `!!TS1.0`",
        )
        .with_help("put `!!TS1.0` on the first line")]);
    }
    let start = lead + "!!TS1.0".len();
    parse_and_validate(&text[start..], start)
}
