//! The names a failed declaration meant to declare, read from its text.
//!
//! A declaration with an error (`vector L : lite;`) is left out of the AST,
//! but its name stays declared — poisoned, as rustc and rust-analyzer keep
//! an erroneous item's name — so that every later use of `L` is not also an
//! "unknown name" with a "did you mean" toward another name. One mistake,
//! one error. The text is read with a few rules of the grammar's tokens
//! (a keyword, then names separated by commas), because the item did not
//! parse and pest gave no tree.

use std::collections::HashSet;

use super::ast::{Name, Poisoned, Program};
use super::split::next_significant;
use crate::span::Span;

/// Keywords that declare names, and whether they take a list (`texture T, T′`).
const DECLARING: &[(&str, bool)] = &[
    ("texture", true),
    ("framebuffer", true),
    ("vector", true),
    ("params", false),
    ("const", false),
    ("uniform", false),
    ("shader", false),
    ("let", false),
];

/// The names the declaration in `text` (one item, at file offset `offset`)
/// declares, as far as its text can be read; none for a statement.
pub fn declared_names(text: &str, offset: usize) -> Vec<Poisoned> {
    let Some(start) = next_significant(text, 0) else { return Vec::new() };
    let word_end = text[start..]
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .map_or(text.len(), |e| start + e);
    let keyword = &text[start..word_end];
    let Some(&(keyword, list)) = DECLARING.iter().find(|(k, _)| *k == keyword) else { return Vec::new() };
    let mut found = Vec::new();
    let mut i = word_end;
    loop {
        i = skip_spaces(text, i);
        let Some(name) = name_at(text, i, offset) else { break };
        i = name.span.end as usize - offset;
        found.push(Poisoned { keyword: keyword.to_string(), name });
        i = skip_spaces(text, i);
        if !list || !text[i..].starts_with(',') {
            break;
        }
        i += 1;
    }
    found
}

fn skip_spaces(text: &str, i: usize) -> usize {
    i + text[i..].find(|c: char| !c.is_whitespace()).unwrap_or(text.len() - i)
}

/// A name at `i` (grammar rule `name`: a letter or `_` but not δ π α σ,
/// then letters, digits and `_`, then primes, then a star mark), unless it
/// is a keyword.
fn name_at(text: &str, i: usize, offset: usize) -> Option<Name> {
    let reserved = |c: char| matches!(c, 'δ' | 'π' | 'α' | 'σ');
    let rest = &text[i..];
    let first = rest.chars().next()?;
    if !(first.is_alphabetic() || first == '_') || reserved(first) {
        return None;
    }
    let base_len =
        rest.find(|c: char| !(c.is_alphanumeric() || c == '_') || reserved(c)).unwrap_or(rest.len());
    let base = &rest[..base_len];
    if super::resolve::KEYWORDS.contains(&base) {
        return None;
    }
    let mut end = base_len;
    let mut primes = 0u8;
    for c in rest[base_len..].chars() {
        let n = match c {
            '\'' | '′' | '’' => 1,
            '″' => 2,
            '‴' => 3,
            _ => break,
        };
        primes = primes.saturating_add(n);
        end += c.len_utf8();
    }
    let star = rest[end..].starts_with('*');
    if star {
        end += 1;
    }
    Some(Name { base: base.to_string(), primes, star, span: Span::new(offset + i, offset + i + end) })
}

/// Which items of `program` (from `source`) have errors of their own: an
/// item holding one of `errors`, or using a name that such an item, or a
/// declaration left out, declares — directly or through other items. The
/// others' lowering errors are their own; those of the poisoned items may
/// be the first error's echo.
pub fn poisoned_items(source: &str, program: &Program, errors: &[Span]) -> Vec<bool> {
    let text_of = |span: Span| source.get(span.start as usize..span.end as usize).unwrap_or("");
    let holds = |item: Span, at: Span| item.start <= at.start && at.start < item.end;
    let items = &program.items;
    let mut poisoned: Vec<bool> = items.iter().map(|i| errors.iter().any(|&e| holds(i.span, e))).collect();
    let used: Vec<HashSet<String>> = items.iter().map(|i| names_in(text_of(i.span))).collect();
    let mut names: HashSet<String> = program.poisoned.iter().map(|p| p.name.key()).collect();
    let mut declared_by = vec![false; items.len()];
    loop {
        for (k, item) in items.iter().enumerate() {
            if poisoned[k] && !declared_by[k] {
                declared_by[k] = true;
                let declared = declared_names(text_of(item.span), item.span.start as usize);
                names.extend(declared.into_iter().map(|p| p.name.key()));
            }
        }
        let newly: Vec<usize> =
            (0..items.len()).filter(|&k| !poisoned[k] && used[k].iter().any(|n| names.contains(n))).collect();
        if newly.is_empty() {
            return poisoned;
        }
        newly.into_iter().for_each(|k| poisoned[k] = true);
    }
}

/// Every name written in `text` (keys, primes included), read as
/// [`declared_names`] reads one.
fn names_in(text: &str) -> HashSet<String> {
    let word = |c: char| (c.is_alphanumeric() || c == '_') && !matches!(c, 'δ' | 'π' | 'α' | 'σ');
    let mut previous = None;
    let mut names = HashSet::new();
    for (i, c) in text.char_indices() {
        if !previous.is_some_and(word) {
            names.extend(name_at(text, i, 0).map(|n| n.key()));
        }
        previous = Some(c);
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(text: &str) -> Vec<(String, String)> {
        declared_names(text, 0).into_iter().map(|p| (p.keyword, p.name.key())).collect()
    }

    #[test]
    fn reads_the_names_of_a_failed_declaration() {
        assert_eq!(keys("vector L : lite;"), [("vector".into(), "L".into())]);
        assert_eq!(
            keys("// c\ntexture T, T′ : 2x;"),
            [("texture".into(), "T".into()), ("texture".into(), "T'".into())]
        );
        assert_eq!(keys("shader diffuse : s → c = max(0, N.xyq·L);"), [("shader".into(), "diffuse".into())]);
        assert_eq!(keys("shader p(n = 1) : s ← c = 1;"), [("shader".into(), "p".into())]);
        assert!(keys("C δπx ← ⊕;").is_empty());
        assert!(keys("vector : normal;").is_empty());
        assert!(keys("const in = 1;").is_empty());
    }

    #[test]
    fn an_error_poisons_its_item_and_the_items_that_use_what_it_declares() {
        // The shader does not parse (`q`): its name is poisoned, and so is
        // every item that uses it, directly or through `k`.
        let source = "shader p : s → c = max(0, N.xyq·L);\nlet k = δ p s x;\nC δπx ← k;\nC δπx ← T′ δu x;\n";
        let (program, _) = crate::parser::parse(source);
        assert_eq!(poisoned_items(source, &program, &[]), [true, true, false]);
        // An error inside a parsed item poisons it and its users.
        let source = "let a = 1;\nC δπx ← 2 * a;\nC δπx ← 1;\n";
        let (program, _) = crate::parser::parse(source);
        let error = Span::new(source.find('1').unwrap_or(0), 0);
        assert_eq!(poisoned_items(source, &program, &[error]), [true, true, false]);
        assert_eq!(poisoned_items(source, &program, &[]), [false; 3]);
        assert_eq!(names_in("C δπx ← T′ δu x"), ["C", "T'", "u", "x"].map(String::from).into());
    }
}
