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
pub(crate) mod poison;
pub mod print;
pub mod resolve;
mod split;

use pest::Parser as _;
use rayon::prelude::*;

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
    let pieces = split::split_items(source);
    let mut parsed = parse_pieces(source, &pieces, pieces.len() >= PARALLEL_ITEMS);
    for (n, piece) in pieces.into_iter().enumerate() {
        let text = &source[piece.range.clone()];
        if let Some(d) = piece.error {
            diagnostics.push(d);
            program.poisoned.extend(poison::declared_names(text, piece.range.start));
            continue;
        }
        let comments = attach_comments(&mut program, text, n == 0);
        if is_blank(text) {
            program.trailing_comments = comments.leading;
            continue;
        }
        if piece.missing_semicolon {
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
        }
        match parsed[n].take() {
            Some(Ok(item)) => {
                let mut item = ast::Item { comments, ..item };
                attach_inner_comments(
                    &mut item,
                    &piece_text(text, piece.missing_semicolon),
                    piece.range.start,
                );
                program.items.push(item);
            }
            Some(Err(errs)) => {
                diagnostics.extend(errs);
                program.poisoned.extend(poison::declared_names(text, piece.range.start));
            }
            None => {}
        }
    }
    (program, diagnostics)
}

/// A piece's item, or its syntax errors.
type Parsed = Result<ast::Item, Vec<Diagnostic>>;

/// Fewest items parsed in parallel. Below it the pieces parse on the
/// calling thread: handing a few items to the pool and waiting for it costs
/// more than it saves (the language server parses per keystroke).
const PARALLEL_ITEMS: usize = 64;

/// Parses every piece, in source order. The pieces parse independently
/// (pest and the AST builder read nothing but the piece), so they can parse
/// in parallel; comments are attached and items kept in source order after,
/// one piece at a time ([`parse`]).
fn parse_pieces(source: &str, pieces: &[split::Piece], parallel: bool) -> Vec<Option<Parsed>> {
    if parallel {
        pieces.par_iter().map(|piece| parse_piece(source, piece)).collect()
    } else {
        pieces.iter().map(|piece| parse_piece(source, piece)).collect()
    }
}

/// The text pest reads for a piece: a piece cut at a line break (its `;`
/// missing) is parsed with the `;` added, so later statements see its names,
/// and one error (in [`parse`]) says where the `;` goes.
fn piece_text(text: &str, missing_semicolon: bool) -> std::borrow::Cow<'_, str> {
    if missing_semicolon {
        format!("{};", text.trim_end()).into()
    } else {
        text.into()
    }
}

/// Parses one piece with pest and builds its item; `None` for a piece that
/// has no item (a nesting error, or only blanks and comments).
fn parse_piece(source: &str, piece: &split::Piece) -> Option<Parsed> {
    let text = &source[piece.range.clone()];
    if piece.error.is_some() || is_blank(text) {
        return None;
    }
    let text = piece_text(text, piece.missing_semicolon);
    Some(match ShadeParser::parse(Rule::item, &text) {
        Ok(mut pairs) => match pairs.next() {
            Some(item) => build::item(item, piece.range.start),
            None => {
                let at = Span::new(piece.range.start, piece.range.start);
                Err(vec![Diagnostic::error(
                    "internal-error",
                    "internal error: the item rule produced nothing",
                    at,
                    "here",
                )])
            }
        },
        Err(err) => Err(vec![errors::from_pest(err, &text, piece.range.start, piece.broken_line)]),
    })
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
    refine_parameter_help(&program, &mut diagnostics);
    name_the_shader(source, &program, &mut diagnostics);
    for d in diagnostics.iter_mut() {
        if let Some(help) = definition_help(source, &program, d) {
            d.help = Some(help);
        }
    }
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
            .with_help("add a statement, such as `C δπx ← T δu x;` (Pipeline Grammar, equation (2))"),
        );
    }
    diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
    (program, diagnostics)
}

/// `p(16) δ s x`: when `p` is a declared shader, the help names
/// its own first parameter, or says it has none.
fn refine_parameter_help(program: &ast::Program, diagnostics: &mut [Diagnostic]) {
    const SUFFIX: &str = "`: a shader's parameters cannot be set where it is used";
    for d in diagnostics.iter_mut().filter(|d| d.code == "not-supported" && d.message.ends_with(SUFFIX)) {
        let written = &d.message[1..d.message.len() - SUFFIX.len()];
        let Some((key, args)) = written.find('(').map(|i| written.split_at(i)) else { continue };
        let shader = program.items.iter().find_map(|i| match &i.kind {
            ast::ItemKind::Shader(s) if s.name.key() == key => Some(s),
            _ => None,
        });
        let Some(shader) = shader else { continue };
        d.help = Some(match shader.params.first() {
            Some(p) => {
                let ty = p.ty.as_ref().map_or(String::new(), |t| format!(": {}", t.value.as_str()));
                build::parameters_help(key, args, Some(&format!("{}{ty}", p.name.key())))
            }
            None => format!("the shader `{key}` has no parameters: remove `{args}` and write `{key} δ s x`"),
        });
    }
}

/// `δ max(0, N·L) s x`: the help's shader gets a name the program does not
/// declare (`p`, else `p′`, `p″`, …), so that following it checks.
fn name_the_shader(source: &str, program: &ast::Program, diagnostics: &mut [Diagnostic]) {
    let declared: Vec<String> = program
        .items
        .iter()
        .flat_map(declared_names)
        .chain(program.poisoned.iter().map(|p| p.name.key()))
        .collect();
    let Some(free) = (0..).map(|n| format!("p{}", "'".repeat(n))).find(|k| !declared.contains(k)) else {
        return;
    };
    if free == "p" {
        return;
    }
    let free = free.replace('\'', "′");
    let text = |s: Span| source.get(s.start as usize..s.end as usize).unwrap_or_default();
    for d in diagnostics.iter_mut().filter(|d| d.code == "value-applied") {
        let Some(rest) = d.secondary.first().map(|l| l.span) else { continue };
        let fresh = build::builtin_in_chain(text(d.primary.span), d.primary.span, text(rest), rest, &free);
        d.help = fresh.help;
    }
}

/// Pipeline Grammar, eq. (28) as printed, `ρ = 1 − (1 − V·N)^n`: a name defined by
/// `=` where a statement's `←` was expected. The help offers the
/// definition as a shader of the shading parameters, its free names as
/// parameters — and only when the program with that shader in place of the
/// line resolves without errors there, so following it leads to a program
/// that checks.
fn definition_help(source: &str, program: &ast::Program, d: &Diagnostic) -> Option<String> {
    if d.code != "syntax" || !d.message.ends_with("found `=`") || !d.message.contains("`←`") {
        return None;
    }
    let eq = d.primary.span.start as usize;
    let start = source[..eq].rfind([';', '}', '\n']).map_or(0, |i| i + 1);
    let name = source[start..eq].trim();
    let ok_name = !name.is_empty() && name.chars().all(|c| c.is_alphanumeric() || c == '_' || c == '\'');
    if !ok_name || source[start..eq].contains("//") {
        return None;
    }
    let end = source[eq..].find(';').map(|i| eq + i)?;
    let value = source[eq + 1..end].trim();
    let params = free_names(program, name, value)?;
    let params: Vec<String> = params.iter().map(|p| format!("{p}: scalar = 1")).collect();
    let params = if params.is_empty() { String::new() } else { format!("({})", params.join(", ")) };
    let shader = format!("shader {name}{params} : s → c = {value};");
    let candidate = format!("{}{shader}{}", &source[..start], &source[end + 1..]);
    let (candidate_program, mut errors) = parse(&candidate);
    errors.extend(resolve::resolve(&candidate_program));
    let replaced = start as u32..(start + shader.len()) as u32;
    if errors.iter().any(|e| e.is_error() && replaced.contains(&e.primary.span.start)) {
        return None;
    }
    Some(format!(
        "to define `{name}` as a function of the shading parameters (as Pipeline Grammar, eq. (28) does), write it as a shader: `{shader}`, then use it in a statement such as `C δπx ← δ {name} s x;`; to assign into a table, write `←` (ASCII `<-`)"
    ))
}

/// The names `value` uses that the program does not declare (nor are
/// built in, nor the paper's families): what a shader defined by it needs
/// as parameters. `None` when the value does not parse.
fn free_names(program: &ast::Program, name: &str, value: &str) -> Option<Vec<String>> {
    let (probe, errors) = parse(&format!("shader {name} : s → c = {value};"));
    if errors.iter().any(Diagnostic::is_error) {
        return None;
    }
    let ast::ItemKind::Shader(sh) = &probe.items.first()?.kind else { return None };
    let declared: Vec<String> = program.items.iter().flat_map(declared_names).collect();
    let mut free = Vec::new();
    sh.body.walk(&mut |e| {
        let n = match &e.kind {
            ast::ExprKind::Name(n) => n,
            ast::ExprKind::Apply { func: ast::Func { kind: ast::FuncKind::Name(n), .. }, .. } => n,
            _ => return,
        };
        let key = n.key();
        let known = declared.contains(&key)
            || resolve::family(n).is_some()
            || resolve::FUNCTIONS.contains(&key.as_str())
            || free.contains(&key);
        if !known {
            free.push(key);
        }
    });
    Some(free)
}

fn declared_names(item: &ast::Item) -> Vec<String> {
    use ast::ItemKind as K;
    let keys = |names: &[ast::Name]| names.iter().map(ast::Name::key).collect();
    match &item.kind {
        K::Texture(t) => keys(&t.names),
        K::Framebuffer(f) => keys(&f.names),
        K::Vector(v) => keys(&v.names),
        K::Params(p) => vec![p.name.key()],
        K::Const(c) => vec![c.name.key()],
        K::Uniform(u) => vec![u.name.key()],
        K::Let(l) => vec![l.name.key()],
        K::Shader(s) => vec![s.name.key()],
        K::Target(_) | K::Statement(_) => vec![],
    }
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
