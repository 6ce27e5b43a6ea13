//! Tokens of `!!VP1.0` text: names (`MOV`, `R3`, `o`, `xyzw`), unsigned
//! integers, `[ ] , ; . + -`, and `#` comments to the end of the line (the
//! spec's only comment; `//` and `/* */`, which some tools wrote, too).

use crate::diag::Diagnostic;
use crate::span::Span;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tok<'a> {
    Name(&'a str),
    /// A decimal integer (register numbers and relative offsets).
    Int(u32),
    LBracket,
    RBracket,
    Comma,
    Semi,
    Dot,
    Plus,
    Minus,
    Eof,
}

impl Tok<'_> {
    pub fn describe(&self) -> String {
        match self {
            Tok::Name(n) => format!("`{n}`"),
            Tok::Int(x) => format!("number `{x}`"),
            Tok::LBracket => "`[`".into(),
            Tok::RBracket => "`]`".into(),
            Tok::Comma => "`,`".into(),
            Tok::Semi => "`;`".into(),
            Tok::Dot => "`.`".into(),
            Tok::Plus => "`+`".into(),
            Tok::Minus => "`-`".into(),
            Tok::Eof => "the end of the program".into(),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Token<'a> {
    pub tok: Tok<'a>,
    pub span: Span,
}

fn error(message: String, span: Span, label: &str, help: &str) -> Diagnostic {
    Diagnostic::error("syntax", message, span, label).with_help(help)
}

/// Splits `text` (which starts at byte `base` of the file) into tokens ending in `Eof`.
pub fn lex(text: &str, base: usize) -> Result<Vec<Token<'_>>, Diagnostic> {
    let bytes = text.as_bytes();
    let mut tokens = Vec::new();
    let mut i = 0;
    let span = |a: usize, b: usize| Span::new(base + a, base + b);
    while i < bytes.len() {
        let start = i;
        let c = bytes[i];
        let single = match c {
            b'[' => Some(Tok::LBracket),
            b']' => Some(Tok::RBracket),
            b',' => Some(Tok::Comma),
            b';' => Some(Tok::Semi),
            b'.' => Some(Tok::Dot),
            b'+' => Some(Tok::Plus),
            b'-' => Some(Tok::Minus),
            _ => None,
        };
        if let Some(tok) = single {
            i += 1;
            tokens.push(Token { tok, span: span(start, i) });
            continue;
        }
        match c {
            b' ' | b'\t' | b'\r' | b'\n' => i += 1,
            b'#' => i = line_end(bytes, i),
            b'/' if bytes.get(i + 1) == Some(&b'/') => i = line_end(bytes, i),
            b'/' if bytes.get(i + 1) == Some(&b'*') => match text[i + 2..].find("*/") {
                Some(end) => i += 2 + end + 2,
                None => {
                    return Err(error(
                        "unterminated `/*` comment".into(),
                        span(i, i + 2),
                        "comment starts here",
                        "close the comment with `*/`",
                    ))
                }
            },
            b'0'..=b'9' => {
                while i < bytes.len() && bytes[i].is_ascii_digit() {
                    i += 1;
                }
                let s = &text[start..i];
                let value = s.parse::<u32>().map_err(|_| {
                    error(
                        format!("number `{s}` is too large"),
                        span(start, i),
                        "too large",
                        "register numbers are below 96",
                    )
                })?;
                tokens.push(Token { tok: Tok::Int(value), span: span(start, i) });
            }
            b'a'..=b'z' | b'A'..=b'Z' | b'_' => {
                while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                    i += 1;
                }
                tokens.push(Token { tok: Tok::Name(&text[start..i]), span: span(start, i) });
            }
            _ => {
                let ch = text[i..].chars().next().unwrap_or('?');
                return Err(error(
                    format!("unexpected character `{ch}`"),
                    span(i, i + ch.len_utf8()),
                    "not part of !!VP1.0",
                    "!!VP1.0 has instructions such as `MOV R0, v[OPOS];`, registers, `[ ] , ; . + -` and `#` comments",
                ));
            }
        }
    }
    tokens.push(Token { tok: Tok::Eof, span: span(bytes.len(), bytes.len()) });
    Ok(tokens)
}

fn line_end(bytes: &[u8], mut i: usize) -> usize {
    while i < bytes.len() && bytes[i] != b'\n' {
        i += 1;
    }
    i
}
