//! Tokens of nvparse's `!!TS1.0` text (`ts1.0_tokens.l`): names, signed
//! numbers, `( ) ; ,`, and `#`, `//` and `/* */` comments — the shared
//! reader scanner ([`crate::backends::readers::lex`]) under this dialect.

use crate::backends::readers::lex::{Dialect, Numbers};

pub use crate::backends::readers::lex::Tok;

pub static TS1: Dialect = Dialect {
    format: "!!TS1.0",
    punctuation: b"();,",
    numbers: Numbers::Signed,
    selectors: &[],
    alphabet:
        "!!TS1.0 uses instruction names, `tex0`..`tex2`, numbers, `( ) ; ,` and `#`, `//`, `/* */` comments",
    end: "the end of the texture-shader program",
    semi_label: "instruction ends here",
};
