//! The front end: `.shd` text → AST with spans, plus every syntax error.
//!
//! Parsing never fails: `parse` returns the items it could read and the
//! diagnostics for the rest (after rust-analyzer's invariant). Recovery is by
//! item: the text is split at each top-level `;` (and after a top-level
//! `{ … }` block), and each piece is parsed with the `item` rule of
//! `grammar/shade.pest`, so one error never hides the next. Bracket nesting is
//! bounded before pest sees a piece, and expression depth while the tree is
//! built, so no input can overflow the stack.

pub mod ast;
mod build;
mod errors;
pub mod print;
pub mod resolve;
mod split;

use pest::Parser as _;

use crate::diag::Diagnostic;
use crate::span::Span;

/// The pest parser generated from `grammar/shade.pest`.
#[derive(pest_derive::Parser)]
#[grammar = "../grammar/shade.pest"]
pub(crate) struct ShadeParser;

/// Deepest bracket nesting accepted: `(((…)))` beyond this is an error.
pub const MAX_NESTING: usize = 64;
/// Deepest expression tree accepted (operator chains, application chains).
pub const MAX_EXPR_DEPTH: usize = 1000;

/// Parses a whole program. Items with errors are left out of the AST.
pub fn parse(source: &str) -> (ast::Program, Vec<Diagnostic>) {
    let mut program = ast::Program::default();
    let mut diagnostics = Vec::new();
    for (n, piece) in split::split_items(source).into_iter().enumerate() {
        if let Some(d) = piece.error {
            diagnostics.push(d);
            continue;
        }
        let text = &source[piece.range.clone()];
        let comments = attach_comments(&mut program, text, n == 0);
        if is_blank(text) {
            program.trailing_comments = comments.leading;
            continue;
        }
        // A piece cut at a line break (its `;` missing): parsed with the `;`
        // added, so later statements see its names, and one error says where
        // the `;` goes.
        let owned;
        let text = if piece.missing_semicolon {
            let end = piece.range.start + text.trim_end().len();
            diagnostics.push(
                Diagnostic::error(
                    "syntax",
                    "expected `;` at the end of this line",
                    Span::new(end, end),
                    "add `;` here",
                )
                .with_help("end every statement and declaration with `;`; the next line starts a new one"),
            );
            owned = format!("{};", text.trim_end());
            owned.as_str()
        } else {
            text
        };
        match ShadeParser::parse(Rule::item, text) {
            Ok(mut pairs) => {
                let item = pairs.next().expect("the item rule produces one pair");
                match build::item(item, piece.range.start) {
                    Ok(item) => {
                        let mut item = ast::Item { comments, ..item };
                        attach_inner_comments(&mut item, text, piece.range.start);
                        program.items.push(item);
                    }
                    Err(errs) => diagnostics.extend(errs),
                }
            }
            Err(err) => diagnostics.push(errors::from_pest(err, text, piece.range.start)),
        }
    }
    (program, diagnostics)
}

/// Reads the comments before an item: one on the line where the previous
/// item ended belongs to that item; the rest lead this one.
fn attach_comments(program: &mut ast::Program, text: &str, first: bool) -> ast::Comments {
    let (found, newlines_after) = split::leading_trivia(text);
    let mut found = found.into_iter().peekable();
    if let Some(previous) = program.items.last_mut() {
        if let Some(c) = found.next_if(|c| c.newlines_before == 0) {
            previous.comments.trailing = Some(c.text);
        }
    }
    let mut comments = ast::Comments::default();
    let gap = found.peek().map_or(newlines_after, |c| c.newlines_before);
    comments.blank_line_before = !first && gap >= 2;
    // Blank lines among and after the leading comments are kept as "".
    for (k, c) in found.enumerate() {
        if k > 0 && c.newlines_before >= 2 {
            comments.leading.push(String::new());
        }
        comments.leading.push(c.text);
    }
    if !comments.leading.is_empty() && newlines_after >= 2 {
        comments.leading.push(String::new());
    }
    comments
}

/// Keeps the comments inside an item, so that `fmt` loses nothing: in a
/// `{ … }` shader block on the line they were written on (or above the line
/// whose expression they interrupt); anywhere else, above the item.
fn attach_inner_comments(item: &mut ast::Item, text: &str, offset: usize) {
    let Some(start) = split::next_significant(text, 0) else { return };
    let found = split::comments_in(text, start);
    if found.is_empty() {
        return;
    }
    // The lines of a block: each `let`, then the result, as offsets in `text`.
    let lines: Vec<(usize, usize)> = match &item.kind {
        ast::ItemKind::Shader(sh) if sh.block => sh
            .lets
            .iter()
            .map(|l| (l.name.span.start, l.value.span.end))
            .chain([(sh.body.span.start, sh.body.span.end)])
            .map(|(a, b)| ((a as usize).saturating_sub(offset), (b as usize).saturating_sub(offset)))
            .collect(),
        _ => {
            item.comments.leading.extend(found.into_iter().map(|c| c.text));
            return;
        }
    };
    let mut block = vec![ast::LineComments::default(); lines.len() + 1];
    for c in found {
        let inside = lines.iter().position(|&(s, e)| s <= c.at && c.at < e);
        let after = lines.iter().rposition(|&(_, e)| e <= c.at);
        match (inside, after) {
            (None, Some(k)) if !c.own_line => match &mut block[k].trailing {
                Some(t) => {
                    t.push(' ');
                    t.push_str(&c.text);
                }
                t @ None => *t = Some(c.text),
            },
            _ => {
                let k = inside.or_else(|| lines.iter().position(|&(s, _)| s > c.at)).unwrap_or(lines.len());
                block[k].leading.push(c.text);
            }
        }
    }
    item.comments.block = block;
}

/// Parses and resolves names: every diagnostic `shadec check` reports.
pub fn check(source: &str) -> (ast::Program, Vec<Diagnostic>) {
    let (program, mut diagnostics) = parse(source);
    // Names used only by items that failed to parse would look unused.
    let syntax_ok = diagnostics.iter().all(|d| !d.is_error());
    diagnostics.extend(resolve::resolve(&program).into_iter().filter(|d| syntax_ok || d.code != "unused"));
    let has_statement = program.items.iter().any(|i| matches!(i.kind, ast::ItemKind::Statement(_)));
    if !has_statement && diagnostics.iter().all(|d| !d.is_error()) {
        let end = crate::span::Span::new(source.len(), source.len());
        diagnostics.push(
            crate::diag::Diagnostic::error(
                "no-statement",
                "the program has no statement: nothing is drawn",
                end,
                "the file ends here",
            )
            .with_help("add a statement, such as `C δπx ← T δu x;` (seeds/001 equation (2))"),
        );
    }
    diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
    (program, diagnostics)
}

fn is_blank(text: &str) -> bool {
    split::next_significant(text, 0).is_none()
}

#[cfg(test)]
mod tests;

/// Entry points for `benches/parser.rs`: the parser's phases on their own, as
/// baselines for the whole front end. Not part of the stable API.
#[doc(hidden)]
pub mod bench_support {
    use pest::Parser as _;

    use super::{split, Rule, ShadeParser};

    /// Splits into items only: one pass over the bytes.
    pub fn split_only(source: &str) -> usize {
        split::split_items(source).len()
    }

    /// Runs pest on every item without building the AST; returns the pairs made.
    pub fn pest_only(source: &str) -> usize {
        split::split_items(source)
            .into_iter()
            .filter_map(|piece| ShadeParser::parse(Rule::item, &source[piece.range]).ok())
            .map(|pairs| pairs.flatten().count())
            .sum()
    }
}
