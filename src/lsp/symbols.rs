//! `textDocument/documentSymbol`: the program as an outline — each
//! declaration (a shader with its parameters and `let`s as children) and
//! each statement `C δπx ← …` (Pipeline Grammar, eq. (2)), named by its left side.

use lsp_types::{DocumentSymbol, SymbolKind};

use super::documents::Document;
use crate::parser::ast::*;
use crate::span::Span;

#[allow(deprecated)] // `DocumentSymbol::deprecated` must be written out.
fn symbol(
    doc: &Document,
    name: String,
    detail: &str,
    kind: SymbolKind,
    span: Span,
    sel: Span,
) -> DocumentSymbol {
    DocumentSymbol {
        name,
        detail: Some(detail.to_string()),
        kind,
        tags: None,
        deprecated: None,
        range: doc.range(span),
        selection_range: doc.range(sel),
        children: None,
    }
}

/// The outline of the document.
pub fn document_symbols(doc: &Document) -> Vec<DocumentSymbol> {
    let mut out = Vec::new();
    for item in &doc.analysis.program.items {
        let named = |names: &[&Name], detail: &str, kind: SymbolKind| -> Vec<DocumentSymbol> {
            names.iter().map(|n| symbol(doc, n.key(), detail, kind, item.span, n.span)).collect()
        };
        match &item.kind {
            ItemKind::Target(t) => out.push(symbol(
                doc,
                format!("target {}", t.profile.value),
                "target",
                SymbolKind::NAMESPACE,
                item.span,
                t.profile.span,
            )),
            ItemKind::Texture(t) => {
                out.extend(named(&t.names.iter().collect::<Vec<_>>(), "texture", SymbolKind::ARRAY))
            }
            ItemKind::Framebuffer(f) => {
                out.extend(named(&f.names.iter().collect::<Vec<_>>(), "framebuffer", SymbolKind::ARRAY))
            }
            ItemKind::Vector(v) => {
                out.extend(named(&v.names.iter().collect::<Vec<_>>(), "vector", SymbolKind::VARIABLE))
            }
            ItemKind::Params(p) => out.extend(named(&[&p.name], "params", SymbolKind::STRUCT)),
            ItemKind::Const(c) => out.extend(named(&[&c.name], "const", SymbolKind::CONSTANT)),
            ItemKind::Uniform(u) => out.extend(named(&[&u.name], "uniform", SymbolKind::PROPERTY)),
            ItemKind::Let(l) => out.extend(named(&[&l.name], "let", SymbolKind::VARIABLE)),
            ItemKind::Shader(s) => out.push(shader(doc, item, s)),
            ItemKind::Statement(st) => {
                let left = doc.text().get(st.target.span.range()).unwrap_or("?");
                let name = format!("{} ←", left.split_whitespace().collect::<Vec<_>>().join(" "));
                out.push(symbol(doc, name, "statement", SymbolKind::EVENT, item.span, st.target.span));
            }
        }
    }
    out
}

fn shader(doc: &Document, item: &Item, s: &ShaderDecl) -> DocumentSymbol {
    let mut sym = symbol(doc, s.name.key(), "shader", SymbolKind::FUNCTION, item.span, s.name.span);
    let mut children = Vec::new();
    for p in &s.params {
        let span = p.default.as_ref().map_or(p.name.span, |d| p.name.span.join(d.span));
        children.push(symbol(doc, p.name.key(), "parameter", SymbolKind::VARIABLE, span, p.name.span));
    }
    for l in &s.lets {
        children.push(symbol(
            doc,
            l.name.key(),
            "let",
            SymbolKind::VARIABLE,
            l.name.span.join(l.value.span),
            l.name.span,
        ));
    }
    sym.children = (!children.is_empty()).then_some(children);
    sym
}
