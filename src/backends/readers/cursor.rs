//! The token cursor every reader's recursive-descent parser walks: one
//! token of look-ahead (two for `!!RC1.0`'s `const0 =`), and the located
//! `expected …, found …` error, which for a missing `;` points just after
//! the statement rather than at the next line's first token.

use crate::diag::Diagnostic;
use crate::span::Span;

use super::lex::{lex, syntax, Dialect, Tok, Token};

/// A parser's position in its tokens, and what else the parser keeps
/// (`state`): each reader implements its grammar on its own
/// `Cursor<'_, State>`, so the walking is written once.
pub struct Cursor<'a, S> {
    tokens: Vec<Token<'a>>,
    pos: usize,
    dialect: &'static Dialect,
    pub state: S,
}

impl<'a, S> Cursor<'a, S> {
    /// Lexes `text` (at byte `base` of the file) under `dialect`.
    pub fn new(
        text: &'a str,
        base: usize,
        dialect: &'static Dialect,
        state: S,
    ) -> Result<Cursor<'a, S>, Diagnostic> {
        Ok(Cursor { tokens: lex(text, base, dialect)?, pos: 0, dialect, state })
    }

    /// The next token (the final `Eof` once the text is read).
    pub fn peek(&self) -> Token<'a> {
        self.nth(0)
    }

    /// The token after the next.
    pub fn peek2(&self) -> Token<'a> {
        self.nth(1)
    }

    fn nth(&self, k: usize) -> Token<'a> {
        // `lex` always ends the list with `Eof`, so it is never empty.
        let last = self.tokens.len().saturating_sub(1);
        self.tokens
            .get((self.pos + k).min(last))
            .copied()
            .unwrap_or(Token { tok: Tok::Eof(self.dialect.end), span: Span::new(0, 0) })
    }

    /// Takes the next token; at the end, keeps returning `Eof`.
    pub fn bump(&mut self) -> Token<'a> {
        let t = self.peek();
        if self.pos + 1 < self.tokens.len() {
            self.pos += 1;
        }
        t
    }

    /// The empty span just after the token taken last.
    pub fn prev_end(&self) -> Span {
        let prev = self.tokens[self.pos.saturating_sub(1)].span;
        Span { start: prev.end, end: prev.end }
    }

    /// Takes `want` or reports `expected {what}, found …` with `help`; a
    /// missing `;` is reported at the end of the statement it closes.
    pub fn expect(&mut self, want: Tok<'static>, what: &str, help: &str) -> Result<Span, Diagnostic> {
        let t = self.peek();
        if t.tok == want {
            self.bump();
            return Ok(t.span);
        }
        if want == Tok::Semi {
            return Err(syntax(
                format!("expected `;`, found {}", t.tok.describe()),
                self.prev_end(),
                self.dialect.semi_label,
                help,
            ));
        }
        Err(syntax(
            format!("expected {what}, found {}", t.tok.describe()),
            t.span,
            format!("expected {what}"),
            help,
        ))
    }
}
