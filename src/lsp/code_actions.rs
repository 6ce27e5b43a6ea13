//! Code actions: apply a diagnostic's "did you mean `X`?", insert a missing
//! `;`, and rewrite the whole document in ASCII or Unicode spellings (the
//! canonical printer, `formatting.rs`).

use std::collections::HashMap;

use lsp_types::{CodeAction, CodeActionKind, Range, TextEdit, Uri, WorkspaceEdit};

use super::diagnostics::to_lsp;
use super::documents::Document;
use super::formatting::print_document;
use crate::diag::Diagnostic;
use crate::parser::print::Style;
use crate::span::Span;

fn edit(uri: &Uri, edits: Vec<TextEdit>) -> WorkspaceEdit {
    WorkspaceEdit { changes: Some(HashMap::from([(uri.clone(), edits)])), ..Default::default() }
}

/// The replacement a help line proposes: the first `` `X` `` after "did you mean".
pub fn suggestion(help: &str) -> Option<&str> {
    let rest = &help[help.find("did you mean `")? + "did you mean `".len()..];
    rest.find('`').map(|end| &rest[..end]).filter(|s| !s.is_empty())
}

fn overlaps(a: Range, b: Range) -> bool {
    (a.start.line, a.start.character) <= (b.end.line, b.end.character)
        && (b.start.line, b.start.character) <= (a.end.line, a.end.character)
}

/// The quick fix for one diagnostic, if it has one.
fn quick_fix(doc: &Document, uri: &Uri, d: &Diagnostic) -> Option<CodeAction> {
    let (title, new_text) = if d.message.starts_with("expected `;`") {
        ("Insert `;`".to_string(), ";".to_string())
    } else {
        let s = suggestion(d.help.as_deref()?)?;
        (format!("Replace with `{s}`"), s.to_string())
    };
    let span = if new_text == ";" {
        Span::new(d.primary.span.end as usize, d.primary.span.end as usize)
    } else {
        d.primary.span
    };
    Some(CodeAction {
        title,
        kind: Some(CodeActionKind::QUICKFIX),
        diagnostics: Some(vec![to_lsp(doc, uri, d)]),
        edit: Some(edit(uri, vec![TextEdit { range: doc.range(span), new_text }])),
        is_preferred: Some(true),
        ..Default::default()
    })
}

/// The document rewritten in `style`, as an action (none when it cannot be printed).
fn convert(doc: &Document, uri: &Uri, style: Style) -> Option<CodeAction> {
    let out = print_document(doc.text(), style).ok()?;
    if out == doc.text() {
        return None;
    }
    let title = match style {
        Style::Ascii => "Convert the document to ASCII spellings (delta, pi, <-, (+))",
        Style::Unicode => "Convert the document to Unicode symbols (δ, π, ←, ⊕)",
    };
    let whole = doc.range(Span::new(0, doc.text().len()));
    Some(CodeAction {
        title: title.to_string(),
        kind: Some(CodeActionKind::new("source.convert")),
        edit: Some(edit(uri, vec![TextEdit { range: whole, new_text: out }])),
        ..Default::default()
    })
}

/// The actions for `range`: fixes of the diagnostics there, then the conversions.
pub fn code_actions(doc: &Document, uri: &Uri, range: Range) -> Vec<CodeAction> {
    let mut out: Vec<CodeAction> = doc
        .analysis
        .diagnostics
        .iter()
        .filter(|d| overlaps(doc.range(d.primary.span), range))
        .filter_map(|d| quick_fix(doc, uri, d))
        .collect();
    out.extend(convert(doc, uri, Style::Ascii));
    out.extend(convert(doc, uri, Style::Unicode));
    out
}
