//! Tokens of NVIDIA's `!!RC1.0` text format (nvparse's `rc1.0_tokens.l`):
//! names with an optional `.rgb` / `.a` / `.b` selector glued on, numbers,
//! punctuation, and `#`, `//` and `/* */` comments — the shared reader
//! scanner ([`crate::backends::readers::lex`]) under this dialect.

use crate::backends::readers::lex::{Dialect, Numbers};

pub use crate::backends::readers::lex::Tok;

pub static RC1: Dialect = Dialect {
    format: "!!RC1.0",
    punctuation: b"{}();,.*-+=",
    numbers: Numbers::Unsigned,
    selectors: &["rgb", "a", "b"],
    alphabet: "!!RC1.0 uses names, numbers, `{ } ( ) ; , . * - + =` and `#`, `//`, `/* */` comments",
    end: "end of program",
    semi_label: "statement ends here",
};
