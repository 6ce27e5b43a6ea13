//! NVIDIA nvparse's `!!RC1.0` text format for register combiners, both ways:
//! [`parse`] (after nvparse's `rc1.0_grammar.y` and its validator, with spans
//! and better messages) and [`print()`]. See docs/combiners.md for the syntax.

// `Diagnostic` is the error type by design (errors are rare and rich).
#![allow(clippy::result_large_err)]

mod lexer;
mod parser;
mod printer;

pub use parser::{parse, Parsed};
pub use printer::print;

use crate::diag::Diagnostic;

use super::config::{CombinerConfig, CombinerLimits};
use super::ts1;
use super::validate::validate;

/// Parses and validates a program against `limits`: the config, or every
/// error as a diagnostic with a span into `text`.
pub fn parse_and_validate(text: &str, limits: &CombinerLimits) -> Result<CombinerConfig, Vec<Diagnostic>> {
    let parsed = parse(text).map_err(|d| vec![d])?;
    let mut diagnostics: Vec<Diagnostic> = match &parsed.config.texture_shader {
        Some(ts) => {
            let fallback = crate::span::Span::new(0, 0);
            ts1::validate(ts)
                .iter()
                .map(|e| e.to_diagnostic(&parsed.texture_shader_spans, fallback))
                .collect()
        }
        None => Vec::new(),
    };
    if let Err(errors) = validate(&parsed.config, limits) {
        diagnostics.extend(errors.iter().map(|e| e.to_diagnostic(&|place| parsed.span_of(place))));
    }
    if diagnostics.is_empty() {
        Ok(parsed.config)
    } else {
        Err(diagnostics)
    }
}
