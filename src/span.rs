//! Byte spans into a source text, and the line index that turns them into
//! human (1-based line:col) and LSP (0-based line, UTF-16 character) positions.
//!
//! Spans are plain byte ranges, `Copy` and 8 bytes (after naga's `span.rs`).

use serde::{Deserialize, Serialize};

/// A half-open byte range `start..end` into one source text.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Span {
    pub start: u32,
    pub end: u32,
}

impl Span {
    /// A span for compiler-made nodes that have no source text.
    pub const DETACHED: Span = Span { start: 0, end: 0 };

    /// The span of bytes `start..end`.
    pub fn new(start: usize, end: usize) -> Span {
        Span { start: start as u32, end: end as u32 }
    }

    /// The smallest span covering both.
    pub fn join(self, other: Span) -> Span {
        Span { start: self.start.min(other.start), end: self.end.max(other.end) }
    }

    /// This span moved right by `offset` bytes.
    pub fn shifted(self, offset: usize) -> Span {
        Span { start: self.start + offset as u32, end: self.end + offset as u32 }
    }

    /// The span as a byte range, to slice the text.
    pub fn range(self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }

    /// Its length in bytes.
    pub fn len(self) -> usize {
        (self.end - self.start) as usize
    }

    /// Whether it covers no byte.
    pub fn is_empty(self) -> bool {
        self.start == self.end
    }
}

/// A value with the span it came from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Spanned<T> {
    pub node: T,
    pub span: Span,
}

/// A 1-based line and column (column counted in Unicode scalar values), as
/// printed in `file:line:col`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineCol {
    pub line: usize,
    pub col: usize,
}

/// Start offsets of every line of a text, for offset → position conversion.
#[derive(Clone, Debug)]
pub struct LineIndex {
    line_starts: Vec<usize>,
}

impl LineIndex {
    /// The index of the line starts of `text`.
    pub fn new(text: &str) -> LineIndex {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex { line_starts }
    }

    fn line_of(&self, offset: usize) -> usize {
        match self.line_starts.binary_search(&offset) {
            Ok(line) => line,
            Err(next) => next - 1,
        }
    }

    /// 1-based line and column of a byte offset (clamped into the text).
    pub fn line_col(&self, text: &str, offset: usize) -> LineCol {
        let offset = clamp_to_char_boundary(text, offset);
        let line = self.line_of(offset);
        let start = self.line_starts[line];
        LineCol { line: line + 1, col: text[start..offset].chars().count() + 1 }
    }

    /// The byte offset of 1-based `line` and `col` (in characters), the
    /// inverse of [`LineIndex::line_col`]; `None` outside the text.
    pub fn offset(&self, text: &str, line: usize, col: usize) -> Option<usize> {
        let start = *self.line_starts.get(line.checked_sub(1)?)?;
        let end = self.line_starts.get(line).copied().unwrap_or(text.len());
        let mut chars = text[start..end].char_indices();
        let (i, _) = chars.nth(col.checked_sub(1)?)?;
        Some(start + i)
    }

    /// LSP position: 0-based line, and the character offset in UTF-16 code units.
    pub fn lsp_position(&self, text: &str, offset: usize) -> (u32, u32) {
        let offset = clamp_to_char_boundary(text, offset);
        let line = self.line_of(offset);
        let start = self.line_starts[line];
        let character: usize = text[start..offset].chars().map(char::len_utf16).sum();
        (line as u32, character as u32)
    }
}

fn clamp_to_char_boundary(text: &str, offset: usize) -> usize {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    offset
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positions_count_utf16_for_lsp_and_chars_for_humans() {
        let text = "a\nδπx ← 𝑇";
        let index = LineIndex::new(text);
        let t = text.find('𝑇').unwrap();
        assert_eq!(index.line_col(text, t), LineCol { line: 2, col: 7 });
        // δ, π, x, space, ←, space: six UTF-16 units before 𝑇 on line 1 (0-based).
        assert_eq!(index.lsp_position(text, t), (1, 6));
        assert_eq!(index.lsp_position(text, text.len()), (1, 8));
    }
}
