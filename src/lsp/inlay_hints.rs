//! Inlay hints: the computation frequency after each `let` (Pipeline Grammar
//! Section 3: per vertex, per fragment, per texel…), and after each
//! statement the passes that implement it on the document's target — the
//! cost of the line where the cursor is.

use lsp_types::{InlayHint, InlayHintKind, InlayHintLabel};

use super::documents::Document;
use crate::ir::{Module, Table};
use crate::parser::ast::{ItemKind, LetDecl};
use crate::pipeline::Planned;
use crate::span::Span;

fn hint(doc: &Document, at: u32, label: String, kind: InlayHintKind) -> InlayHint {
    InlayHint {
        position: doc.range(Span::new(at as usize, at as usize)).start,
        label: InlayHintLabel::String(label),
        kind: Some(kind),
        text_edits: None,
        tooltip: None,
        padding_left: Some(true),
        padding_right: None,
        data: None,
    }
}

/// Every hint of the document whose position lies in `[from, to)` bytes.
pub fn inlay_hints(doc: &Document, from: usize, to: usize) -> Vec<InlayHint> {
    let a = &doc.analysis;
    let mut out = Vec::new();
    for item in &a.program.items {
        let end = item.span.end;
        if (end as usize) < from || (end as usize) > to {
            continue;
        }
        match &item.kind {
            ItemKind::Let(l) => {
                if let Some(f) = a.module.as_ref().and_then(|m| let_frequency(m, l)) {
                    out.push(hint(doc, end, format!(": {f}"), InlayHintKind::TYPE));
                }
            }
            ItemKind::Shader(s) => {
                for l in &s.lets {
                    if let Some(f) = a.module.as_ref().and_then(|m| let_frequency(m, l)) {
                        out.push(hint(doc, l.value.span.end, format!(": {f}"), InlayHintKind::TYPE));
                    }
                }
            }
            ItemKind::Statement(_) => {
                if let Some(p) = &a.planned {
                    out.push(hint(
                        doc,
                        end,
                        statement_passes(p, item.span, &a.target),
                        InlayHintKind::PARAMETER,
                    ));
                }
            }
            _ => {}
        }
    }
    out
}

/// The frequency of a `let`'s value, when lowering made a node of it (an
/// unused `let` is not lowered).
fn let_frequency(m: &Module, l: &LetDecl) -> Option<&'static str> {
    let h = m.exprs.arena().iter().map(|(h, _)| h).find(|&h| m.span(h) == l.value.span)?;
    Some(m.info(h).freq.name())
}

/// `pass 2 (geforce3)`, `passes 2–4 (geforce256)`, or why none.
pub fn statement_passes(p: &Planned, span: Span, target: &str) -> String {
    let m = &p.module;
    let Some(i) = m
        .statements
        .iter()
        .position(|st| st.span == span || span.start <= st.span.start && st.span.end <= span.end)
    else {
        return format!("no pass on {target}");
    };
    if matches!(m.statements[i].table, Table::TexCoords(_)) {
        return format!("per vertex, in the passes that read it ({target})");
    }
    let passes: Vec<usize> = p
        .plan
        .passes
        .iter()
        .enumerate()
        .filter(|(_, pass)| pass.statements.contains(&i))
        .map(|(k, _)| k + 1)
        .collect();
    match passes.as_slice() {
        [] => format!("no pass on {target} (removed: see `compile --emit plan`)"),
        [k] => format!("pass {k} ({target})"),
        [first, .., last] if last - first + 1 == passes.len() => format!("passes {first}–{last} ({target})"),
        _ => format!(
            "passes {} ({target})",
            passes.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")
        ),
    }
}
