//! The scanner of nvparse's three text formats (its `rc1.0_tokens.l`,
//! `ts1.0_tokens.l` and `vp1.0_tokens.l` differ only in which punctuation
//! and which numbers they take): names, numbers, punctuation, whitespace and
//! `#`, `//`, `/* */` comments, every token with its byte span.

use crate::diag::Diagnostic;
use crate::span::Span;

/// A token of any of the three formats; a [`Dialect`] decides which of
/// them a format's text can contain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tok<'a> {
    /// A name such as `tex0`, `MOV` or `R3`.
    Name(&'a str),
    /// A `!!RC1.0` name with a component selector glued on (`tex0.rgb` →
    /// `tex0`, `rgb`).
    Selected(&'a str, &'a str),
    /// A decimal number (`!!RC1.0` constants, `!!TS1.0` arguments).
    Number(f32),
    /// An unsigned integer (`!!VP1.0` register numbers and offsets).
    Int(u32),
    LBrace,
    RBrace,
    LParen,
    RParen,
    LBracket,
    RBracket,
    Semi,
    Comma,
    Dot,
    Star,
    Minus,
    Plus,
    Equals,
    /// The end of the text, with what the format calls it in messages.
    Eof(&'static str),
}

impl Tok<'_> {
    /// The token as an `expected …, found {}` message quotes it.
    pub fn describe(&self) -> String {
        match self {
            Tok::Name(n) => format!("`{n}`"),
            Tok::Selected(n, s) => format!("`{n}.{s}`"),
            Tok::Number(x) => format!("number `{x}`"),
            Tok::Int(x) => format!("number `{x}`"),
            Tok::Eof(end) => (*end).into(),
            punctuation => format!("`{}`", char::from(punctuation.punctuation().unwrap_or(b'?'))),
        }
    }

    /// The name, with its selector if one was glued on.
    pub fn name(&self) -> Option<(&str, Option<&str>)> {
        match *self {
            Tok::Name(n) => Some((n, None)),
            Tok::Selected(n, s) => Some((n, Some(s))),
            _ => None,
        }
    }

    /// Whether this is the end of the text.
    pub fn is_eof(&self) -> bool {
        matches!(self, Tok::Eof(_))
    }

    fn punctuation(&self) -> Option<u8> {
        PUNCTUATION.iter().find(|(_, t)| t == self).map(|(c, _)| *c)
    }
}

const PUNCTUATION: [(u8, Tok<'static>); 13] = [
    (b'{', Tok::LBrace),
    (b'}', Tok::RBrace),
    (b'(', Tok::LParen),
    (b')', Tok::RParen),
    (b'[', Tok::LBracket),
    (b']', Tok::RBracket),
    (b';', Tok::Semi),
    (b',', Tok::Comma),
    (b'.', Tok::Dot),
    (b'*', Tok::Star),
    (b'-', Tok::Minus),
    (b'+', Tok::Plus),
    (b'=', Tok::Equals),
];

/// A token of the `!!RC1.0`, `!!TS1.0` and `!!VP1.0` readers' shared lexer, with its span in
/// the text.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Token<'a> {
    pub tok: Tok<'a>,
    pub span: Span,
}

/// Which numbers a format writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Numbers {
    /// `1`, `0.5`, `.5`, `1.` (nvparse's `!!RC1.0`): unsigned, `-` is an operator.
    Unsigned,
    /// `-1`, `+.5`, `2.` (nvparse's `!!TS1.0`): the sign is part of the number.
    Signed,
    /// `0`..`4294967295` (`!!VP1.0` register numbers and offsets).
    Integer,
}

/// What tells one format's text from another's.
#[derive(Debug)]
pub struct Dialect {
    /// The header, for `not part of !!RC1.0`.
    pub format: &'static str,
    /// The punctuation characters that are tokens.
    pub punctuation: &'static [u8],
    pub numbers: Numbers,
    /// Component selectors glued onto a name (`.rgb`), `!!RC1.0` only.
    pub selectors: &'static [&'static str],
    /// The help of an unexpected character: what the format does contain.
    pub alphabet: &'static str,
    /// What an `expected …, found` message calls the end of the text.
    pub end: &'static str,
    /// The label at the end of the statement that lacks its `;`.
    pub semi_label: &'static str,
}

/// A `syntax` error: every reader's grammar errors share the code.
pub fn syntax(
    message: impl Into<String>,
    span: Span,
    label: impl Into<String>,
    help: impl Into<String>,
) -> Diagnostic {
    Diagnostic::error("syntax", message, span, label).with_help(help)
}

/// Splits `text` (which starts at byte `base` of the file) into tokens of
/// `dialect`, ending in [`Tok::Eof`].
pub fn lex<'a>(text: &'a str, base: usize, dialect: &Dialect) -> Result<Vec<Token<'a>>, Diagnostic> {
    let scanner = Scanner { text, bytes: text.as_bytes(), base, dialect };
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < text.len() {
        if let Some(end) = scanner.blank(i)? {
            i = end;
            continue;
        }
        let (tok, end) = scanner.token(i)?;
        tokens.push(Token { tok, span: scanner.span(i, end) });
        i = end;
    }
    tokens.push(Token { tok: Tok::Eof(dialect.end), span: scanner.span(text.len(), text.len()) });
    Ok(tokens)
}

struct Scanner<'a, 'd> {
    text: &'a str,
    bytes: &'a [u8],
    base: usize,
    dialect: &'d Dialect,
}

impl<'a> Scanner<'a, '_> {
    fn span(&self, a: usize, b: usize) -> Span {
        Span::new(self.base + a, self.base + b)
    }

    fn at(&self, i: usize) -> Option<u8> {
        self.bytes.get(i).copied()
    }

    fn digit_at(&self, i: usize) -> bool {
        self.at(i).is_some_and(|b| b.is_ascii_digit())
    }

    /// The end of the whitespace or comment at `i`, if one starts there.
    fn blank(&self, i: usize) -> Result<Option<usize>, Diagnostic> {
        Ok(match (self.bytes[i], self.at(i + 1)) {
            (b' ' | b'\t' | b'\r' | b'\n', _) => Some(i + 1),
            (b'#', _) | (b'/', Some(b'/')) => Some(self.while_from(i, |b| b != b'\n')),
            (b'/', Some(b'*')) => match self.text[i + 2..].find("*/") {
                Some(end) => Some(i + 2 + end + 2),
                None => {
                    return Err(Diagnostic::error(
                        "syntax",
                        "unterminated `/*` comment",
                        self.span(i, i + 2),
                        "comment starts here",
                    )
                    .with_help("close the comment with `*/`"))
                }
            },
            _ => None,
        })
    }

    fn while_from(&self, mut i: usize, keep: impl Fn(u8) -> bool) -> usize {
        while i < self.bytes.len() && keep(self.bytes[i]) {
            i += 1;
        }
        i
    }

    fn name_end(&self, i: usize) -> usize {
        self.while_from(i, |b| b.is_ascii_alphanumeric() || b == b'_')
    }

    /// The token at `i` (not blank) and where it ends.
    fn token(&self, i: usize) -> Result<(Tok<'a>, usize), Diagnostic> {
        if self.number_starts(i) {
            return self.number(i);
        }
        let c = self.bytes[i];
        if c.is_ascii_alphabetic() || c == b'_' {
            return self.name(i);
        }
        if self.dialect.punctuation.contains(&c) {
            if let Some((_, tok)) = PUNCTUATION.iter().find(|(p, _)| *p == c) {
                return Ok((*tok, i + 1));
            }
        }
        let ch = self.text[i..].chars().next().unwrap_or('?');
        Err(syntax(
            format!("unexpected character `{ch}`"),
            self.span(i, i + ch.len_utf8()),
            format!("not part of {}", self.dialect.format),
            self.dialect.alphabet,
        ))
    }

    fn number_starts(&self, i: usize) -> bool {
        let c = self.bytes[i];
        let unsigned = c.is_ascii_digit() || (c == b'.' && self.digit_at(i + 1));
        match self.dialect.numbers {
            Numbers::Integer => c.is_ascii_digit(),
            Numbers::Unsigned => unsigned,
            Numbers::Signed => {
                unsigned
                    || (matches!(c, b'-' | b'+')
                        && (self.digit_at(i + 1) || (self.at(i + 1) == Some(b'.') && self.digit_at(i + 2))))
            }
        }
    }

    fn number(&self, start: usize) -> Result<(Tok<'a>, usize), Diagnostic> {
        let digits = |i| self.while_from(i, |b| b.is_ascii_digit());
        let malformed = |s: &str, end: usize, label: &str, help: &str| {
            syntax(format!("malformed number `{s}`"), self.span(start, end), label, help)
        };
        match self.dialect.numbers {
            Numbers::Integer => {
                let end = digits(start);
                let s = &self.text[start..end];
                let value = s.parse::<u32>().map_err(|_| {
                    syntax(
                        format!("number `{s}` is too large"),
                        self.span(start, end),
                        "too large",
                        "register numbers are below 96",
                    )
                })?;
                Ok((Tok::Int(value), end))
            }
            Numbers::Unsigned => {
                let mut end = digits(start);
                if self.at(end) == Some(b'.') {
                    end = digits(end + 1);
                }
                let s = self.text[start..end].strip_suffix('.').unwrap_or(&self.text[start..end]);
                let value = s
                    .parse::<f32>()
                    .map_err(|_| malformed(s, end, "not a number", "write numbers like `0.5` or `1`"))?;
                Ok((Tok::Number(value), end))
            }
            Numbers::Signed => {
                let end = self.while_from(start + 1, |b| b.is_ascii_digit() || b == b'.');
                let s = &self.text[start..end];
                let value = s.parse::<f32>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                    malformed(s, end, "not a finite number", "write numbers like `0.5`, `-1` or `2.`")
                })?;
                Ok((Tok::Number(value), end))
            }
        }
    }

    /// A name, and in `!!RC1.0` the selector glued onto it; a selector the
    /// format does not have is refused where it is clearly meant as one
    /// (after `out`, or made of colour letters).
    fn name(&self, start: usize) -> Result<(Tok<'a>, usize), Diagnostic> {
        let end = self.name_end(start);
        let name = &self.text[start..end];
        let selectors = self.dialect.selectors;
        if selectors.is_empty()
            || self.at(end) != Some(b'.')
            || !self.at(end + 1).is_some_and(|b| b.is_ascii_alphabetic())
        {
            return Ok((Tok::Name(name), end));
        }
        let word_end = self.name_end(end + 1);
        let word = &self.text[end + 1..word_end];
        if selectors.contains(&word) {
            return Ok((Tok::Selected(name, word), word_end));
        }
        if name == "out" || word.len() <= 5 && word.chars().all(|c| "rgba".contains(c)) {
            let list = selectors.iter().map(|s| format!("`.{s}`")).collect::<Vec<_>>();
            let (last, rest) = list.split_last().map_or(("", &[][..]), |(l, r)| (l.as_str(), r));
            return Err(syntax(
                format!("unknown component selector `.{word}`"),
                self.span(end, word_end),
                "not a selector",
                format!("the selectors are {} and {last}", rest.join(", ")),
            ));
        }
        Ok((Tok::Name(name), end))
    }
}
