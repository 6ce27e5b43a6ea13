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

use super::config::{CombinerConfig, CombinerLimits, Register};
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

/// The `!!RC1.0` name of each register (Kilgard 2000, Appendix B: `col0`
/// for the primary colour, `tex0` for texture 0, ...), held once for the
/// parser, which reads them, and the printer, which writes them; listed in
/// the order the parser's help names them.
pub(crate) const REGISTERS: [(&str, Register); 12] = [
    ("tex0", Register::Texture0),
    ("tex1", Register::Texture1),
    ("tex2", Register::Texture2),
    ("tex3", Register::Texture3),
    ("col0", Register::Primary),
    ("col1", Register::Secondary),
    ("spare0", Register::Spare0),
    ("spare1", Register::Spare1),
    ("fog", Register::Fog),
    ("const0", Register::Constant0),
    ("const1", Register::Constant1),
    ("zero", Register::Zero),
];

/// The `!!RC1.0` name of `register`.
pub(crate) fn register_name(register: Register) -> &'static str {
    // `REGISTERS` names every one of `Register::ALL` (a unit test holds it).
    REGISTERS.iter().find(|(_, r)| *r == register).map_or("zero", |(name, _)| name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_register_has_one_rc1_name() {
        for r in Register::ALL {
            assert_eq!(REGISTERS.iter().filter(|(_, x)| *x == r).count(), 1, "{r:?}");
        }
    }
}
