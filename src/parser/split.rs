//! Splits a source text into items for recovery: at each `;` outside
//! brackets, strings and comments, and after a top-level `{ … }` block (with
//! its optional `;`). Also enforces the bracket nesting limit, so pest never
//! recurses deeper than `MAX_NESTING` levels.

use std::ops::Range;

use crate::diag::Diagnostic;
use crate::span::Span;

use super::MAX_NESTING;

/// One top-level item's text, before parsing, with how it was cut.
pub struct Piece {
    /// The item's byte range in the source.
    pub range: Range<usize>,
    /// Set when the piece cannot be parsed at all (nesting too deep).
    pub error: Option<Diagnostic>,
    /// The piece ends at a line break, not at its `;`: the next line starts
    /// an item of its own (the recovery: a missing `;` is one error
    /// at the end of its line, and the statements after it still parse).
    pub missing_semicolon: bool,
    /// The piece ends at a line break, incomplete (after an operator, or
    /// inside a `(`), and the next line surely starts an item: its own
    /// syntax error is its one error, and it does not swallow the next line.
    pub broken_line: bool,
}

/// Keywords that start a declaration.
const ITEM_KEYWORDS: &[&str] =
    &["vector", "texture", "framebuffer", "const", "uniform", "shader", "let", "target", "params"];

/// Whether the line at `j` starts an item: a declaration keyword, or an
/// assignment `… ←` on that line.
fn starts_item(source: &str, j: usize) -> bool {
    let line = source[j..].split('\n').next().unwrap_or_default();
    let line = line.split("//").next().unwrap_or_default();
    let word = line.split(|c: char| !(c.is_alphanumeric() || c == '_')).next().unwrap_or_default();
    (ITEM_KEYWORDS.contains(&word) && line[word.len()..].starts_with(char::is_whitespace))
        || line.contains('←')
        || line.contains("<-")
}

/// Whether the line `next` starts an item even though the piece `so_far`
/// before it is incomplete: it starts with a declaration keyword (never
/// inside an expression), or it assigns with `←` where `so_far` already
/// has its own `←` or is a declaration (an item has at most one `←`).
fn surely_new_item(so_far: &str, next: &str) -> bool {
    let code = |text: &str| -> String {
        text.lines().map(|l| l.split("//").next().unwrap_or_default()).collect::<Vec<_>>().join("\n")
    };
    let first_word = |text: &str| -> String {
        let t = text.trim_start();
        t[..t.find(|c: char| !(c.is_alphanumeric() || c == '_')).unwrap_or(t.len())].to_string()
    };
    let next_line = code(next.split('\n').next().unwrap_or_default());
    if ITEM_KEYWORDS.contains(&first_word(&next_line).as_str()) {
        return true;
    }
    let so_far = code(so_far);
    let assigns = |t: &str| t.contains('←') || t.contains("<-");
    let start = next_significant(&so_far, 0).unwrap_or(0);
    assigns(&next_line)
        && (assigns(&so_far) || ITEM_KEYWORDS.contains(&first_word(&so_far[start..]).as_str()))
}

/// Whether `text` (a piece so far) ends where a statement or declaration
/// could end: after a name, a number, a closing bracket, a prime or a
/// string — not after an operator that continues it on the next line.
fn ends_complete(text: &str) -> bool {
    let last_line = text.rsplit('\n').next().unwrap_or_default();
    let code = last_line.split("//").next().unwrap_or_default();
    let tail = if code.trim().is_empty() { text.trim_end() } else { code.trim_end() };
    tail.chars()
        .last()
        .is_some_and(|c| c.is_alphanumeric() || matches!(c, ')' | ']' | '\'' | '′' | '"' | '_'))
}

/// Splits a source file into its top-level items, without parsing them:
/// at `;` and closing `}` outside brackets, and, to recover, at a line
/// break before what surely starts a new item.
pub fn split_items(source: &str) -> Vec<Piece> {
    let bytes = source.as_bytes();
    let mut pieces = Vec::new();
    let mut start = 0;
    let mut depth = 0usize;
    let mut brace_open_at_top = false;
    let mut braces = 0usize;
    let mut error: Option<Diagnostic> = None;
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'"' => i = skip_string(bytes, i),
            b'#' => i = skip_line(bytes, i),
            b'/' if bytes.get(i + 1) == Some(&b'/') => i = skip_line(bytes, i),
            b'/' if bytes.get(i + 1) == Some(&b'*') => i = skip_block_comment(source, i),
            open @ (b'(' | b'[' | b'{') => {
                if depth == 0 && open == b'{' {
                    brace_open_at_top = true;
                }
                braces += usize::from(open == b'{');
                depth += 1;
                if depth > MAX_NESTING && error.is_none() {
                    error = Some(nesting_too_deep(i));
                }
            }
            b')' | b']' | b'}' => {
                depth = depth.saturating_sub(1);
                braces = braces.saturating_sub(usize::from(bytes[i] == b'}'));
                if depth == 0 && bytes[i] == b'}' && brace_open_at_top {
                    brace_open_at_top = false;
                    let mut end = i + 1;
                    if let Some(semi) = next_significant(source, end).filter(|&j| bytes[j] == b';') {
                        end = semi + 1;
                    }
                    pieces.push(Piece {
                        range: start..end,
                        error: error.take(),
                        missing_semicolon: false,
                        broken_line: false,
                    });
                    start = end;
                    i = end;
                    continue;
                }
            }
            b';' if depth == 0 => {
                pieces.push(Piece {
                    range: start..i + 1,
                    error: error.take(),
                    missing_semicolon: false,
                    broken_line: false,
                });
                start = i + 1;
            }
            b'\n' if braces == 0 && error.is_none() => {
                let so_far = &source[start..i];
                let next = next_significant(source, i).filter(|&j| starts_item(source, j));
                if let (Some(j), true) = (next, next_significant(source, start).is_some_and(|s| s < i)) {
                    let complete = depth == 0 && ends_complete(so_far);
                    if complete || surely_new_item(so_far, &source[j..]) {
                        pieces.push(Piece {
                            range: start..i,
                            error: None,
                            missing_semicolon: complete,
                            broken_line: !complete,
                        });
                        start = i;
                        depth = 0;
                    }
                }
            }
            _ => {}
        }
        i += 1;
    }
    if start < bytes.len() || error.is_some() {
        pieces.push(last_piece(source, start, depth, error));
    }
    pieces
}

/// The piece from `start` to the end of the source. The last item without
/// its `;`, complete otherwise, gets the same recovery as one followed by
/// another item, where white space follows it (the added `;` then lies
/// within the source, as every span must).
fn last_piece(source: &str, start: usize, depth: usize, error: Option<Diagnostic>) -> Piece {
    let rest = &source[start..];
    let missing_semicolon = error.is_none()
        && depth == 0
        && next_significant(source, start).is_some()
        && ends_complete(rest)
        && rest.trim_end().len() < rest.len();
    Piece { range: start..source.len(), error, missing_semicolon, broken_line: false }
}

/// The error for a bracket opened at byte `i`, one level past [`MAX_NESTING`].
fn nesting_too_deep(i: usize) -> Diagnostic {
    Diagnostic::error(
        "nesting-too-deep",
        format!("brackets nest more than {MAX_NESTING} levels deep"),
        Span::new(i, i + 1),
        format!("level {} opens here", MAX_NESTING + 1),
    )
    .with_help("split the expression with `let` bindings; no shading expression needs this depth")
}

/// The index of the closing quote of the string opening at `i` (or of the
/// line's end: a string does not span lines).
fn skip_string(bytes: &[u8], mut i: usize) -> usize {
    i += 1;
    while i < bytes.len() && bytes[i] != b'"' && bytes[i] != b'\n' {
        i += if bytes[i] == b'\\' { 2 } else { 1 };
    }
    i
}

/// The index of the `/` closing the block comment opening at `i`, or the
/// source's end when it is not closed.
fn skip_block_comment(source: &str, i: usize) -> usize {
    match source[i + 2..].find("*/") {
        Some(end) => i + 2 + end + 1,
        None => source.len(),
    }
}

fn skip_line(bytes: &[u8], mut i: usize) -> usize {
    while i < bytes.len() && bytes[i] != b'\n' {
        i += 1;
    }
    i
}

/// The offset of the next character that is neither white space nor comment.
pub fn next_significant(source: &str, mut i: usize) -> Option<usize> {
    let bytes = source.as_bytes();
    loop {
        while i < bytes.len() && bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        if i >= bytes.len() {
            return None;
        }
        if bytes[i] == b'#' || source[i..].starts_with("//") {
            i = skip_line(bytes, i);
        } else if source[i..].starts_with("/*") {
            i = source[i + 2..].find("*/").map_or(bytes.len(), |end| i + 2 + end + 2);
        } else {
            return Some(i);
        }
    }
}

/// One comment in the trivia before an item, with the line breaks before it.
pub struct Comment {
    pub text: String,
    pub newlines_before: usize,
}

/// The comments at the start of `text` (up to its first significant
/// character), and the line breaks between the last of them and that character.
pub fn leading_trivia(text: &str) -> (Vec<Comment>, usize) {
    let bytes = text.as_bytes();
    let mut comments = Vec::new();
    let mut newlines = 0;
    let mut i = 0;
    while i < bytes.len() {
        match bytes[i] {
            b'\n' => {
                newlines += 1;
                i += 1;
            }
            b if b.is_ascii_whitespace() => i += 1,
            b'#' => i = push_comment(text, i, skip_line(bytes, i), &mut comments, &mut newlines),
            b'/' if bytes.get(i + 1) == Some(&b'/') => {
                i = push_comment(text, i, skip_line(bytes, i), &mut comments, &mut newlines)
            }
            b'/' if bytes.get(i + 1) == Some(&b'*') => {
                let end = text[i + 2..].find("*/").map_or(bytes.len(), |e| i + 2 + e + 2);
                i = push_comment(text, i, end, &mut comments, &mut newlines);
            }
            _ => break,
        }
    }
    (comments, newlines)
}

/// A comment inside an item: its offset in the text, and whether it starts
/// its own line (nothing significant before it on that line).
pub struct InnerComment {
    pub at: usize,
    pub text: String,
    pub own_line: bool,
}

/// Every comment of `text` from offset `from` on, skipping string literals.
pub fn comments_in(text: &str, from: usize) -> Vec<InnerComment> {
    let bytes = text.as_bytes();
    let mut found = Vec::new();
    let mut own_line = false;
    let mut i = from;
    while i < bytes.len() {
        let end = match bytes[i] {
            b'"' => {
                i += 1;
                while i < bytes.len() && bytes[i] != b'"' && bytes[i] != b'\n' {
                    i += if bytes[i] == b'\\' { 2 } else { 1 };
                }
                own_line = false;
                i += 1;
                continue;
            }
            b'\n' => {
                own_line = true;
                i += 1;
                continue;
            }
            b if b.is_ascii_whitespace() => {
                i += 1;
                continue;
            }
            b'#' => skip_line(bytes, i),
            b'/' if bytes.get(i + 1) == Some(&b'/') => skip_line(bytes, i),
            b'/' if bytes.get(i + 1) == Some(&b'*') => {
                text[i + 2..].find("*/").map_or(bytes.len(), |e| i + 2 + e + 2)
            }
            _ => {
                own_line = false;
                i += 1;
                continue;
            }
        };
        found.push(InnerComment { at: i, text: text[i..end].trim_end().to_string(), own_line });
        i = end;
    }
    found
}

fn push_comment(
    text: &str,
    start: usize,
    end: usize,
    comments: &mut Vec<Comment>,
    newlines: &mut usize,
) -> usize {
    comments.push(Comment { text: text[start..end].trim_end().to_string(), newlines_before: *newlines });
    *newlines = 0;
    end
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texts(source: &str) -> Vec<&str> {
        split_items(source).into_iter().map(|p| &source[p.range]).collect()
    }

    #[test]
    fn splits_at_top_level_semicolons_only() {
        let src = "a ← f(x; y); // c; d\nshader p : s → c { let a = 1; a }\nb ← \"x;y\";";
        assert_eq!(
            texts(src),
            ["a ← f(x; y);", " // c; d\nshader p : s → c { let a = 1; a }", "\nb ← \"x;y\";"]
        );
    }

    #[test]
    fn comments_in_skip_strings_and_know_their_line() {
        let src = "f(\"// no\", x) // a\n  # b\n y /* c */";
        let found: Vec<_> = comments_in(src, 0).into_iter().map(|c| (c.text, c.own_line)).collect();
        assert_eq!(
            found,
            [("// a".to_string(), false), ("# b".to_string(), true), ("/* c */".to_string(), false)]
        );
    }

    #[test]
    fn deep_nesting_is_reported_once_without_recursion() {
        let src = "(".repeat(100_000);
        let pieces = split_items(&src);
        assert_eq!(pieces.len(), 1);
        assert_eq!(pieces[0].error.as_ref().unwrap().code, "nesting-too-deep");
    }
}
