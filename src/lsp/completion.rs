//! Completion: declared names, built-in functions and texture generators,
//! keywords, and the notation's symbols from their ASCII spellings — typing
//! `\delta`, `delta`, `<-` or `(+)` offers δ, ←, ⊕ (Pipeline Grammar writes the
//! symbols; `docs/language.md` lists the ASCII spellings).

use lsp_types::{CompletionItem, CompletionItemKind, CompletionTextEdit, TextEdit};

use super::documents::Document;
use super::index;
use super::navigation::KEYWORDS;
use crate::parser::resolve::{Entity, FUNCTIONS, GENERATORS};
use crate::span::Span;

/// The symbols and the spellings that call for them (`\name`, the ASCII word).
pub const SYMBOLS: &[(&str, &[&str], &str)] = &[
    ("δ", &["\\delta", "delta"], "rasterize: interpolate per vertex, then sample"),
    ("π", &["\\pi", "pi"], "project"),
    ("←", &["\\leftarrow", "\\gets", "<-"], "assign into a table"),
    ("⊕", &["\\oplus", "(+)"], "combine colours (modulate by default)"),
    ("·", &["\\cdot", "(.)"], "dot product"),
    ("α", &["\\alpha", "alpha"], "the alpha channel"),
    ("σ", &["\\sigma", "stencil"], "the stencil channel"),
    ("′", &["\\prime"], "prime: a new name"),
    ("⁻¹", &["^-1"], "inverse projection"),
];

/// The text just before the cursor that a completion would replace: a word
/// (with a leading `\`), or an ASCII operator spelling.
fn prefix(text: &str, offset: usize) -> (usize, &str) {
    let before = &text[..offset];
    for op in ["(+)", "(+", "(.)", "<-", "^-1"] {
        if before.ends_with(op) {
            return (offset - op.len(), op);
        }
    }
    let start = before
        .char_indices()
        .rev()
        .take_while(|(_, c)| c.is_ascii_alphanumeric() || *c == '_' || *c == '\\')
        .last()
        .map_or(offset, |(i, _)| i);
    (start, &before[start..])
}

fn item(
    doc: &Document,
    label: &str,
    kind: CompletionItemKind,
    detail: &str,
    span: Span,
    filter: &str,
) -> CompletionItem {
    CompletionItem {
        label: label.to_string(),
        kind: Some(kind),
        detail: Some(detail.to_string()),
        filter_text: Some(filter.to_string()),
        text_edit: Some(CompletionTextEdit::Edit(TextEdit {
            range: doc.range(span),
            new_text: label.to_string(),
        })),
        ..Default::default()
    }
}

/// The completions at `offset`.
pub fn complete(doc: &Document, offset: usize) -> Vec<CompletionItem> {
    let text = doc.text();
    let offset = offset.min(text.len());
    let (start, typed) = prefix(text, offset);
    let span = Span::new(start, offset);
    let mut out = Vec::new();
    for (sym, spellings, what) in SYMBOLS {
        if let Some(s) = spellings.iter().find(|s| !typed.is_empty() && s.starts_with(typed)) {
            out.push(item(doc, sym, CompletionItemKind::OPERATOR, &format!("{s}: {what}"), span, s));
        }
    }
    if typed.starts_with('\\') || typed.starts_with(['(', '<', '^']) {
        return out;
    }
    let mut seen = std::collections::HashSet::new();
    for o in index::occurrences(&doc.analysis.program).iter().filter(|o| o.is_decl()) {
        if o.key.starts_with(typed) && seen.insert(o.key.clone()) {
            let e = o.entity.unwrap_or(Entity::Let);
            out.push(item(doc, &o.key, kind(e), e.describe(), span, &o.key));
        }
    }
    let words = FUNCTIONS.iter().map(|f| (*f, "built-in function", CompletionItemKind::FUNCTION));
    let words =
        words.chain(GENERATORS.iter().map(|g| (*g, "texture generator", CompletionItemKind::CONSTRUCTOR)));
    let words = words.chain(KEYWORDS.iter().map(|k| (*k, "keyword", CompletionItemKind::KEYWORD)));
    for (w, detail, k) in words {
        if w.starts_with(typed) && seen.insert(w.to_string()) {
            out.push(item(doc, w, k, detail, span, w));
        }
    }
    out
}

fn kind(e: Entity) -> CompletionItemKind {
    match e {
        Entity::Texture | Entity::Framebuffer => CompletionItemKind::STRUCT,
        Entity::Shader | Entity::Function => CompletionItemKind::FUNCTION,
        Entity::Const => CompletionItemKind::CONSTANT,
        Entity::Uniform => CompletionItemKind::PROPERTY,
        _ => CompletionItemKind::VARIABLE,
    }
}
