//! `textDocument/semanticTokens/full`: textures, framebuffers, vectors,
//! shaders, constants and the other declared names by what they are; the
//! operators of the notation δ π ← ⊕ (and their ASCII spellings); built-in
//! functions and the paper's families (Pipeline Grammar, Figure 2) marked
//! `defaultLibrary`; keywords, numbers, strings, comments.

use lsp_types::{SemanticToken, SemanticTokenModifier, SemanticTokenType, SemanticTokensLegend};

use super::documents::Document;
use super::index;
use super::navigation::KEYWORDS;
use crate::parser::resolve::Entity;
use crate::span::Span;

/// Token types, in legend order (the index is the wire value).
pub const TYPES: &[&str] = &[
    "texture",
    "framebuffer",
    "vector",
    "shader",
    "constant",
    "uniform",
    "variable",
    "parameter",
    "function",
    "keyword",
    "number",
    "string",
    "comment",
    "operator",
];
/// Modifiers, in legend order (bit `1 << i`).
pub const MODIFIERS: &[&str] = &["declaration", "defaultLibrary"];

/// The token types and modifiers the server announces, in the order
/// the encoded tokens index them.
pub fn legend() -> SemanticTokensLegend {
    SemanticTokensLegend {
        token_types: TYPES.iter().map(|t| SemanticTokenType::new(t)).collect(),
        token_modifiers: MODIFIERS.iter().map(|m| SemanticTokenModifier::new(m)).collect(),
    }
}

/// The legend index of token type `name`; every caller names one of
/// [`TYPES`] (a constant list), so the fall-back to the first is never taken.
fn ty(name: &str) -> u32 {
    TYPES.iter().position(|t| *t == name).unwrap_or(0) as u32
}

fn entity_type(e: Entity) -> &'static str {
    match e {
        Entity::Texture => "texture",
        Entity::Framebuffer => "framebuffer",
        Entity::Vector => "vector",
        Entity::Shader => "shader",
        Entity::Const => "constant",
        Entity::Uniform => "uniform",
        Entity::Params | Entity::ShaderParam => "parameter",
        Entity::Let | Entity::Vertex | Entity::Pixel | Entity::TexCoords => "variable",
        Entity::Function => "function",
    }
}

/// One token before delta encoding: byte span, type, modifier bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Token {
    pub span: Span,
    pub ty: u32,
    pub modifiers: u32,
}

/// The document's tokens, in order, none overlapping, none across a line.
pub fn tokens(doc: &Document) -> Vec<Token> {
    let text = doc.text();
    let occ = index::occurrences(&doc.analysis.program);
    let mut names = occ.iter().peekable();
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        while names.next_if(|o| (o.span.start as usize) < i).is_some() {}
        if let Some(o) = names.next_if(|o| o.span.start as usize == i && !o.span.is_empty()) {
            if let Some(e) = o.entity {
                let modifiers = u32::from(o.is_decl()) | (u32::from(o.decl.is_none()) << 1);
                out.push(Token { span: o.span, ty: ty(entity_type(e)), modifiers });
            }
            i = o.span.end as usize;
            continue;
        }
        i = lex_one(text, i, &mut out);
    }
    out
}

/// Lexes the token at `i` (if any) into `out`; returns where the next starts.
fn lex_one(text: &str, i: usize, out: &mut Vec<Token>) -> usize {
    let rest = &text[i..];
    let Some(c) = rest.chars().next() else { return text.len() };
    let push = |out: &mut Vec<Token>, len: usize, name: &str| {
        out.push(Token { span: Span::new(i, i + len), ty: ty(name), modifiers: 0 });
        i + len
    };
    if rest.starts_with("//") || c == '#' {
        return push(out, rest.find('\n').unwrap_or(rest.len()), "comment");
    }
    if rest.starts_with("/*") {
        let end = rest.find("*/").map_or(rest.len(), |j| j + 2);
        let mut at = 0;
        for line in rest[..end].split_inclusive('\n') {
            let len = line.trim_end_matches('\n').len();
            out.push(Token { span: Span::new(i + at, i + at + len), ty: ty("comment"), modifiers: 0 });
            at += line.len();
        }
        return i + end;
    }
    if c == '"' {
        // An unterminated string ends at its line's end (a token never spans lines).
        let end = match rest[1..].find(['"', '\n']) {
            Some(j) if rest.as_bytes()[j + 1] == b'"' => j + 2,
            Some(j) => j + 1,
            None => rest.len(),
        };
        return push(out, end, "string");
    }
    if c.is_ascii_digit() {
        let len = rest.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(rest.len());
        return push(out, len, "number");
    }
    if c.is_ascii_alphabetic() || c == '_' {
        let len = rest.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(rest.len());
        let word = &rest[..len];
        return match word {
            "delta" | "pi" | "alpha" | "stencil" | "depth" => push(out, len, "operator"),
            w if KEYWORDS.contains(&w) => push(out, len, "keyword"),
            _ => i + len,
        };
    }
    for op in ["δ", "π", "←", "⊕", "·", "⋅", "α", "σ", "⁻¹", "<-", "(+)", "(.)", "^-1"] {
        if rest.starts_with(op) {
            return push(out, op.len(), "operator");
        }
    }
    i + c.len_utf8()
}

/// The tokens in the protocol's relative encoding (UTF-16 positions).
pub fn encode(doc: &Document, tokens: &[Token]) -> Vec<SemanticToken> {
    let (mut line, mut start) = (0, 0);
    let mut out = Vec::with_capacity(tokens.len());
    for t in tokens {
        let r = doc.range(t.span);
        if r.end.line != r.start.line {
            continue; // cannot happen (`tokens` cuts at lines); never a wrong length
        }
        let delta_line = r.start.line - line;
        let delta_start = if delta_line == 0 { r.start.character - start } else { r.start.character };
        out.push(SemanticToken {
            delta_line,
            delta_start,
            length: r.end.character - r.start.character,
            token_type: t.ty,
            token_modifiers_bitset: t.modifiers,
        });
        (line, start) = (r.start.line, r.start.character);
    }
    out
}
