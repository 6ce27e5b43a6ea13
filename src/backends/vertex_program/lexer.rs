//! Tokens of `!!VP1.0` text: names (`MOV`, `R3`, `o`, `xyzw`), unsigned
//! integers, `[ ] , ; . + -`, and `#` comments to the end of the line (the
//! spec's only comment; `//` and `/* */`, which some tools wrote, too) —
//! the shared reader scanner ([`crate::backends::readers::lex`]) under this
//! dialect.

use crate::backends::readers::lex::{Dialect, Numbers};

pub use crate::backends::readers::lex::Tok;

pub static VP1: Dialect = Dialect {
    format: "!!VP1.0",
    punctuation: b"[],;.+-",
    numbers: Numbers::Integer,
    selectors: &[],
    alphabet:
        "!!VP1.0 has instructions such as `MOV R0, v[OPOS];`, registers, `[ ] , ; . + -` and `#` comments",
    end: "the end of the program",
    semi_label: "the instruction ends here",
};
