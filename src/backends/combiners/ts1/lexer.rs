//! Tokens of nvparse's `!!TS1.0` text (`ts1.0_tokens.l`): names, signed
//! numbers, `( ) ; ,`, and `#`, `//` and `/* */` comments.

use crate::diag::Diagnostic;
use crate::span::Span;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tok<'a> {
    Name(&'a str),
    Number(f32),
    LParen,
    RParen,
    Semi,
    Comma,
    Eof,
}

impl Tok<'_> {
    pub fn describe(&self) -> String {
        match self {
            Tok::Name(n) => format!("`{n}`"),
            Tok::Number(x) => format!("number `{x}`"),
            Tok::LParen => "`(`".into(),
            Tok::RParen => "`)`".into(),
            Tok::Semi => "`;`".into(),
            Tok::Comma => "`,`".into(),
            Tok::Eof => "the end of the texture-shader program".into(),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Token<'a> {
    pub tok: Tok<'a>,
    pub span: Span,
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
        let digit_at = |k: usize| bytes.get(k).is_some_and(u8::is_ascii_digit);
        let number_start = c.is_ascii_digit()
            || (c == b'.' && digit_at(i + 1))
            || ((c == b'-' || c == b'+')
                && (digit_at(i + 1) || (bytes.get(i + 1) == Some(&b'.') && digit_at(i + 2))));
        if number_start {
            i = number_end(bytes, i + 1);
            let s = &text[start..i];
            let value = s.parse::<f32>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                Diagnostic::error(
                    "syntax",
                    format!("malformed number `{s}`"),
                    span(start, i),
                    "not a finite number",
                )
                .with_help("write numbers like `0.5`, `-1` or `2.`")
            })?;
            tokens.push(Token { tok: Tok::Number(value), span: span(start, i) });
            continue;
        }
        match c {
            b' ' | b'\t' | b'\r' | b'\n' => i += 1,
            b'#' => i = line_end(bytes, i),
            b'/' if bytes.get(i + 1) == Some(&b'/') => i = line_end(bytes, i),
            b'/' if bytes.get(i + 1) == Some(&b'*') => match text[i + 2..].find("*/") {
                Some(end) => i += 2 + end + 2,
                None => {
                    return Err(Diagnostic::error(
                        "syntax",
                        "unterminated `/*` comment",
                        span(i, i + 2),
                        "comment starts here",
                    )
                    .with_help("close the comment with `*/`"))
                }
            },
            b'a'..=b'z' | b'A'..=b'Z' | b'_' => {
                while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                    i += 1;
                }
                tokens.push(Token { tok: Tok::Name(&text[start..i]), span: span(start, i) });
            }
            b'(' | b')' | b';' | b',' => {
                let tok = match c {
                    b'(' => Tok::LParen,
                    b')' => Tok::RParen,
                    b';' => Tok::Semi,
                    _ => Tok::Comma,
                };
                i += 1;
                tokens.push(Token { tok, span: span(start, i) });
            }
            _ => {
                let ch = text[i..].chars().next().unwrap_or('?');
                return Err(Diagnostic::error(
                    "syntax",
                    format!("unexpected character `{ch}`"),
                    span(i, i + ch.len_utf8()),
                    "not part of !!TS1.0",
                )
                .with_help(
                    "!!TS1.0 uses instruction names, `tex0`..`tex2`, numbers, `( ) ; ,` and `#`, `//`, `/* */` comments",
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

fn number_end(bytes: &[u8], mut i: usize) -> usize {
    while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
        i += 1;
    }
    i
}
