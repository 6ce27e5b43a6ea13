//! Tokens of NVIDIA's `!!RC1.0` text format (nvparse's `rc1.0_tokens.l`):
//! names with an optional `.rgb` / `.a` / `.b` selector glued on, numbers,
//! punctuation, and `#`, `//` and `/* */` comments.

use crate::diag::Diagnostic;
use crate::span::Span;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tok<'a> {
    /// A name such as `tex0`, `expand` or `out`, with its selector if one was
    /// glued on (`tex0.rgb` → name `tex0`, selector `rgb`).
    Name(&'a str, Option<&'a str>),
    Number(f32),
    LBrace,
    RBrace,
    LParen,
    RParen,
    Semi,
    Comma,
    Dot,
    Star,
    Minus,
    Plus,
    Equals,
    Eof,
}

impl Tok<'_> {
    pub fn describe(&self) -> String {
        match self {
            Tok::Name(n, Some(s)) => format!("`{n}.{s}`"),
            Tok::Name(n, None) => format!("`{n}`"),
            Tok::Number(x) => format!("number `{x}`"),
            Tok::LBrace => "`{`".into(),
            Tok::RBrace => "`}`".into(),
            Tok::LParen => "`(`".into(),
            Tok::RParen => "`)`".into(),
            Tok::Semi => "`;`".into(),
            Tok::Comma => "`,`".into(),
            Tok::Dot => "`.`".into(),
            Tok::Star => "`*`".into(),
            Tok::Minus => "`-`".into(),
            Tok::Plus => "`+`".into(),
            Tok::Equals => "`=`".into(),
            Tok::Eof => "end of program".into(),
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Token<'a> {
    pub tok: Tok<'a>,
    pub span: Span,
}

const SELECTORS: [&str; 3] = ["rgb", "a", "b"];

/// Splits `text` (starting at byte `base` of the file) into tokens ending in `Eof`.
pub fn lex(text: &str, base: usize) -> Result<Vec<Token<'_>>, Diagnostic> {
    let bytes = text.as_bytes();
    let mut tokens = Vec::new();
    let mut i = 0;
    let span = |a: usize, b: usize| Span::new(base + a, base + b);
    while i < bytes.len() {
        let c = bytes[i];
        let start = i;
        match c {
            b' ' | b'\t' | b'\r' | b'\n' => i += 1,
            b'#' => {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
            }
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                while i < bytes.len() && bytes[i] != b'\n' {
                    i += 1;
                }
            }
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
            b'0'..=b'9' => {
                i = number_end(bytes, i);
                tokens.push(Token {
                    tok: Tok::Number(parse_number(&text[start..i], span(start, i))?),
                    span: span(start, i),
                });
            }
            b'.' if bytes.get(i + 1).is_some_and(u8::is_ascii_digit) => {
                i = number_end(bytes, i);
                tokens.push(Token {
                    tok: Tok::Number(parse_number(&text[start..i], span(start, i))?),
                    span: span(start, i),
                });
            }
            b'a'..=b'z' | b'A'..=b'Z' | b'_' => {
                i = name_end(bytes, i);
                let name = &text[start..i];
                let mut selector = None;
                if bytes.get(i) == Some(&b'.') && bytes.get(i + 1).is_some_and(|b| b.is_ascii_alphabetic()) {
                    let end = name_end(bytes, i + 1);
                    let word = &text[i + 1..end];
                    if SELECTORS.contains(&word) {
                        selector = Some(word);
                        i = end;
                    } else if name == "out" || word.len() <= 5 && word.chars().all(|c| "rgba".contains(c)) {
                        return Err(Diagnostic::error(
                            "syntax",
                            format!("unknown component selector `.{word}`"),
                            span(i, end),
                            "not a selector",
                        )
                        .with_help("the selectors are `.rgb`, `.a` and `.b`"));
                    }
                }
                tokens.push(Token { tok: Tok::Name(name, selector), span: span(start, i) });
            }
            _ => {
                let tok = match c {
                    b'{' => Tok::LBrace,
                    b'}' => Tok::RBrace,
                    b'(' => Tok::LParen,
                    b')' => Tok::RParen,
                    b';' => Tok::Semi,
                    b',' => Tok::Comma,
                    b'.' => Tok::Dot,
                    b'*' => Tok::Star,
                    b'-' => Tok::Minus,
                    b'+' => Tok::Plus,
                    b'=' => Tok::Equals,
                    _ => {
                        let ch = text[i..].chars().next().unwrap_or('?');
                        let end = i + ch.len_utf8();
                        return Err(Diagnostic::error("syntax", format!("unexpected character `{ch}`"), span(i, end), "not part of !!RC1.0")
                            .with_help("!!RC1.0 uses names, numbers, `{ } ( ) ; , . * - + =` and `#`, `//`, `/* */` comments"));
                    }
                };
                i += 1;
                tokens.push(Token { tok, span: span(start, i) });
            }
        }
    }
    tokens.push(Token { tok: Tok::Eof, span: span(bytes.len(), bytes.len()) });
    Ok(tokens)
}

fn name_end(bytes: &[u8], mut i: usize) -> usize {
    while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
        i += 1;
    }
    i
}

fn number_end(bytes: &[u8], mut i: usize) -> usize {
    while i < bytes.len() && bytes[i].is_ascii_digit() {
        i += 1;
    }
    if i < bytes.len() && bytes[i] == b'.' {
        i += 1;
        while i < bytes.len() && bytes[i].is_ascii_digit() {
            i += 1;
        }
    }
    i
}

fn parse_number(s: &str, span: Span) -> Result<f32, Diagnostic> {
    let s = s.strip_suffix('.').unwrap_or(s);
    s.parse::<f32>().map_err(|_| {
        Diagnostic::error("syntax", format!("malformed number `{s}`"), span, "not a number")
            .with_help("write numbers like `0.5` or `1`")
    })
}
