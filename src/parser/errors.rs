//! pest's syntax errors → diagnostics: rule names become words a person uses
//! ("an expression", "`;`"), the found token is named, and common slips get a
//! targeted help line (`=` for `←`, `×` for `*`, a missing `;`).

use pest::error::{ErrorVariant, InputLocation};

use super::Rule;
use crate::diag::Diagnostic;
use crate::span::Span;

/// `line_end`: the text is one item cut at a line break (its `;` missing
/// and the next line starting an item), so its end is the end of a line.
pub fn from_pest(err: pest::error::Error<Rule>, text: &str, offset: usize, line_end: bool) -> Diagnostic {
    let pos = match err.location {
        InputLocation::Pos(p) => p,
        InputLocation::Span((s, _)) => s,
    };
    if let ErrorVariant::CustomError { message } = &err.variant {
        // pest's own guards: its call limit and its native stack probe.
        if message.contains("limit reached") {
            return Diagnostic::error(
                "nesting-too-deep",
                format!("this statement is too complex to parse ({message})"),
                Span::new(offset + pos, offset + pos + token_at(text, pos).len()),
                "the parser gave up here",
            )
            .with_help("split it into `let` bindings or several statements");
        }
    }
    let found = token_at(text, pos);
    if found == "." {
        if let Some(d) = bad_swizzle(text, pos, offset) {
            return d;
        }
    }
    let span = Span::new(offset + pos, offset + pos + found.len());
    let mut expected: Vec<&'static str> = match &err.variant {
        ErrorVariant::ParsingError { positives, .. } => {
            positives.iter().filter_map(|r| describe(*r)).collect()
        }
        ErrorVariant::CustomError { .. } => Vec::new(),
    };
    // The most useful words first; "an expression" covers names and numbers.
    const ORDER: &[&str] = &["an operator", "an expression", "a name", "a number", "a string"];
    let rank = |e: &&str| ORDER.iter().position(|o| o == e).unwrap_or(ORDER.len());
    expected.sort_by_key(|e| (rank(e), *e == "`;`", *e));
    expected.dedup();
    if expected.contains(&"an expression") {
        expected.retain(|e| !matches!(*e, "a name" | "a number" | "a string"));
    }
    let expected_text = join_or(&expected);
    let found_text =
        if found.is_empty() && line_end { "the end of the line".into() } else { describe_found(found) };
    let message = if found == ")" && unclosed_paren(text, pos).is_none() {
        "this `)` has no matching `(`".to_string()
    } else if expected.is_empty() {
        format!("unexpected {found_text}")
    } else {
        format!("expected {expected_text}, found {found_text}")
    };
    let label = if found == ")" && unclosed_paren(text, pos).is_none() {
        "no `(` before it".to_string()
    } else if expected.is_empty() {
        "unexpected here".to_string()
    } else {
        format!("expected {expected_text}")
    };
    let help = if found.is_empty() && line_end && !expected.contains(&"`;`") {
        "this line ends in the middle of its statement and the next line starts another: complete this one and end it with `;`".into()
    } else {
        help_for(found, &expected)
    };
    let mut d = Diagnostic::error("syntax", message, span, label).with_help(help);
    // An unclosed `(` says where it opened (issue 21).
    if let Some(open) = unclosed_paren(text, pos).filter(|_| matches!(found, "" | ";" | "←" | "<-")) {
        d.message = format!("expected `)` to close the `(` opened before, found {found_text}");
        d.primary.message = "expected `)`".into();
        d = d
            .with_label(Span::new(offset + open, offset + open + 1), "this `(` is never closed")
            .with_help("close the `(` opened here with `)` before the statement ends");
    }
    if matches!(found, "←" | "<-") && !expected.contains(&"`→` (or `->`)") {
        if let Some(end) = end_of_previous_line(text, pos) {
            d = d.with_label(Span::new(offset + end, offset + end), "perhaps a `;` is missing here");
        }
    }
    d
}

/// The letters of a swizzle: coordinates and colour channels.
const SWIZZLE_SETS: [&str; 2] = ["xyzw", "rgba"];

/// `N.xyq`, `N.xg`, `N.L`: a `.` glued to letters that are no swizzle.
/// Named for what it is — the letter that is wrong and the sets a swizzle
/// takes its letters from, or the dot product `·` a `.` between two names
/// most likely meant — not as a stray `.`. `None` when the letters form a
/// valid swizzle (then the `.` is wrong for another reason).
fn bad_swizzle(text: &str, pos: usize, offset: usize) -> Option<Diagnostic> {
    let after = &text[pos + 1..];
    let len = after.find(|c: char| !(c.is_alphanumeric() || c == '_')).unwrap_or(after.len());
    let letters = &after[..len];
    let first = letters.chars().next().filter(|c| c.is_alphabetic())?;
    let span = Span::new(offset + pos, offset + pos + 1 + len);
    const FILES: &[&str] = &["png", "jpg", "jpeg", "ppm", "pgm", "hdr", "exr", "bmp", "tga", "ron"];
    if FILES.contains(&letters.to_ascii_lowercase().as_str()) {
        let before = &text[..pos];
        let stem = &before
            [before.trim_end_matches(|c: char| c.is_alphanumeric() || matches!(c, '_' | '-' | '/')).len()..];
        return Some(
            Diagnostic::error(
                "syntax",
                format!("`{stem}.{letters}` is a file name without quotes"),
                Span::new(offset + pos - stem.len(), offset + pos + 1 + len),
                "a file name",
            )
            .with_help(format!(
                "a file name is a string: `\"{stem}.{letters}\"`, as in `image(\"{stem}.{letters}\")`"
            )),
        );
    }
    let sets = "a swizzle takes up to four letters from one set: `x y z w` (a vector's coordinates) or `r g b a` (a colour's channels), such as `.xyz` or `.a`";
    let Some(set) = SWIZZLE_SETS.iter().find(|s| s.contains(first)) else {
        let before = &text[..pos];
        let glued = |c: char| c.is_alphanumeric() || matches!(c, '_' | '\'' | '′' | '″' | '‴');
        let operand = &before[before.trim_end_matches(glued).len()..];
        let dot = if operand.is_empty() {
            String::new()
        } else {
            format!("; for the dot product of `{operand}` and `{letters}`, write `{operand}·{letters}` (ASCII `{operand} (.) {letters}`)")
        };
        return Some(
            Diagnostic::error(
                "bad-swizzle",
                format!("`.{letters}` is not a swizzle"),
                span,
                format!("`{first}` is not a swizzle letter"),
            )
            .with_help(format!("{sets}{dot}")),
        );
    };
    let other = SWIZZLE_SETS.iter().find(|s| *s != set).copied().unwrap_or(set);
    let bad = letters.chars().find(|c| !set.contains(*c))?;
    if other.contains(bad) {
        // Both sets mixed: the same positions in the first letter's set.
        let mapped: String =
            letters.chars().map(|c| other.find(c).map_or(c, |i| set.as_bytes()[i] as char)).collect();
        if mapped.len() <= 4 && mapped.chars().all(|c| set.contains(c)) {
            return Some(
                Diagnostic::error(
                    "bad-swizzle",
                    format!("`.{letters}` mixes the two swizzle sets"),
                    span,
                    format!("`{bad}` is from `{other}`, `{first}` from `{set}`"),
                )
                .with_help(format!("take every letter from one set: `.{mapped}` (`{set}`); {sets}")),
            );
        }
    }
    Some(
        Diagnostic::error(
            "bad-swizzle",
            format!("`{bad}` is not a swizzle letter"),
            span,
            format!("`{bad}` is not one of x y z w or r g b a"),
        )
        .with_help(sets),
    )
}

/// The end of the last non-blank text before the line holding `pos`, when a
/// statement runs on from an earlier line (the usual sign of a missing `;`).
/// The byte offset of the last `(` before `pos` that no `)` closes, skipping
/// comments, strings and the ASCII operators `(+)` and `(.)`.
fn unclosed_paren(text: &str, pos: usize) -> Option<usize> {
    let head = &text[..pos.min(text.len())];
    let mut open = Vec::new();
    let mut i = 0;
    while i < head.len() {
        let rest = &head[i..];
        if rest.starts_with("//") {
            i += rest.find('\n').unwrap_or(rest.len());
            continue;
        }
        if rest.starts_with("(+)") || rest.starts_with("(.)") {
            i += 3;
            continue;
        }
        let c = rest.chars().next().unwrap_or(' ');
        if c == '"' {
            // Past the closing quote (or to the end of an unclosed string).
            i += 1 + rest[1..].find('"').map_or(rest.len() - 1, |e| e + 1);
            continue;
        }
        if c == '(' {
            open.push(i);
        } else if c == ')' {
            open.pop();
        }
        i += c.len_utf8();
    }
    open.pop()
}

fn end_of_previous_line(text: &str, pos: usize) -> Option<usize> {
    let line_start = text[..pos].rfind('\n')?;
    let before = text[..line_start].trim_end();
    (!before.is_empty()).then_some(before.len())
}

/// The token starting at `pos`: a word, a known multi-character symbol, or one character.
fn token_at(text: &str, pos: usize) -> &str {
    let rest = &text[pos.min(text.len())..];
    if rest.is_empty() {
        return rest;
    }
    for symbol in ["<-", "->", "(+)", "(.)", ">=", "<=", "==", "!=", "||", "&&", "⁻¹"] {
        if rest.starts_with(symbol) {
            return &rest[..symbol.len()];
        }
    }
    let first = rest.chars().next().unwrap_or(' ');
    if first.is_alphanumeric() || first == '_' {
        let end = rest.find(|c: char| !(c.is_alphanumeric() || c == '_' || c == '\'')).unwrap_or(rest.len());
        // At most 64 bytes, cut at a character's start (`δ` is a letter of two).
        let mut cut = end.min(64);
        while !rest.is_char_boundary(cut) {
            cut -= 1;
        }
        &rest[..cut]
    } else {
        &rest[..first.len_utf8()]
    }
}

fn describe_found(found: &str) -> String {
    match found {
        "" => "the end of the file".to_string(),
        ";" => "`;` (the end of the statement)".to_string(),
        "\n" | "\r" => "the end of the line".to_string(),
        // Never echoed raw (issue 40): a NUL or an escape garbles a terminal.
        f if f.chars().any(char::is_control) => format!("the control character `{}`", f.escape_default()),
        f => format!("`{f}`"),
    }
}

fn describe(rule: Rule) -> Option<&'static str> {
    Some(match rule {
        Rule::item | Rule::statement => "a declaration or a statement",
        Rule::kw_target
        | Rule::kw_texture
        | Rule::kw_framebuffer
        | Rule::kw_vector
        | Rule::kw_params
        | Rule::kw_const
        | Rule::kw_uniform
        | Rule::kw_shader
        | Rule::kw_let
        | Rule::target_decl
        | Rule::texture_decl
        | Rule::framebuffer_decl
        | Rule::vector_decl
        | Rule::params_decl
        | Rule::const_decl
        | Rule::uniform_decl
        | Rule::let_decl
        | Rule::shader_decl => "a declaration or a statement",
        Rule::semi => "`;`",
        Rule::assign => "`←` (or `<-`)",
        Rule::arrow => "`→` (or `->`)",
        Rule::name | Rule::name_list => "a name",
        Rule::word | Rule::vector_kind => "a word",
        Rule::number => "a number",
        Rule::string => "a string",
        Rule::expr | Rule::operand | Rule::application | Rule::postfix | Rule::primary | Rule::tuple => {
            "an expression"
        }
        Rule::delta | Rule::projection | Rule::channel => "an expression",
        Rule::op_or
        | Rule::op_and
        | Rule::op_cmp
        | Rule::op_combine
        | Rule::op_add
        | Rule::op_sub
        | Rule::op_mul
        | Rule::op_div
        | Rule::op_dot
        | Rule::op_pow
        | Rule::question
        | Rule::colon => "an operator",
        Rule::op_neg | Rule::op_not => "an expression",
        Rule::swizzle => "a swizzle such as `.xyz` or `.a`",
        Rule::shader_params | Rule::shader_param => "shader parameters",
        Rule::shader_body => "`=` or `{` (the shader's body)",
        Rule::combine_mode => "a ⊕ mode in brackets, such as `[add]`",
        Rule::EOI => "the end of the statement",
        _ => return None,
    })
}

fn join_or(items: &[&str]) -> String {
    match items {
        [] => String::new(),
        [one] => one.to_string(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

/// Help for a symbol of the language found where it cannot stand: where it
/// belongs ("`→` is not a symbol of the language; the symbols
/// are … → …" contradicted itself). Also the spellings of text pasted from
/// a PDF set in the Symbol font, as Pipeline Grammar prints: `¬` for ←, `Å` for ⊕.
fn symbol_help(found: &str) -> Option<String> {
    let first = found.chars().next()?;
    Some(match first {
        '→' => "`→` (ASCII `->`) only separates a shader's argument from its result type: `shader d : s → c = …`".into(),
        '⊕' => "`⊕` (ASCII `(+)`) combines the values on its two sides: `a ⊕ b`, `a ⊕[add] b`".into(),
        '·' | '⋅' => "`·` (ASCII `(.)`) is a dot product of the vectors on its two sides: `N·L`".into(),
        '¬' => "`¬` (ASCII `!`) negates the condition after it (`¬ c`); a statement assigns with `←` (ASCII `<-`) — text pasted from a PDF set in the Symbol font shows ← as `¬`".into(),
        'Å' => "did you mean `⊕`? Text pasted from a PDF set in the Symbol font shows ⊕ as `Å` (ASCII `(+)`)".into(),
        'δ' | 'π' => format!("`{first}` applies to the value after it: `T δu x`, `δ s x`, `C δπx`"),
        'α' | 'σ' => format!("`{first}` selects a framebuffer's {} before its name: `{first} C δπx`", if first == 'α' { "alpha" } else { "stencil" }),
        '′' => "a prime belongs to the name it follows, without a space: `u′`, `C′`".into(),
        '⁻' => "`⁻¹` follows a projection: `π⁻¹`".into(),
        _ => return None,
    })
}

fn help_for(found: &str, expected: &[&str]) -> String {
    let expects = |what: &str| expected.contains(&what);
    match found {
        "←" | "<-" if expects("`→` (or `->`)") => format!(
            "a shader's type is written with `→` (ASCII `->`): `shader d : s → c = …`; `{found}` assigns in a statement (`C δπx {found} …`)"
        ),
        "→" | "->" if expects("`←` (or `<-`)") => format!(
            "a statement assigns with `←` (ASCII `<-`): `C δπx ← …`; `{found}` only separates a shader's argument from its result type (`shader d : s {found} c = …`)"
        ),
        "=" if expects("`→` (or `->`)") => {
            "a shader's declaration names its argument, `→` (ASCII `->`) and its result type before `=`: `shader d : s → c = …`".into()
        }
        "=" if expects("`←` (or `<-`)") => "assign with `←` (ASCII `<-`): `C δπx ← T δu x;`".into(),
        "=" => "`=` only gives a declaration its value; statements assign with `←` (ASCII `<-`)".into(),
        "←" | "<-" => "a statement has one `←`; if the previous statement lacks its `;`, add it there".into(),
        "×" | "⊗" => "multiply with `*`; take a dot product with `·` (ASCII `(.)`)".into(),
        "." => "swizzles are glued to a value (`L.z`); a dot product is `·` (ASCII `(.)`)".into(),
        "" if expects("`;`") => "end every statement and declaration with `;`".into(),
        "" => "the file ends in the middle of a statement; complete it and end it with `;`".into(),
        ")" | "]" | "}" => "this closing bracket has no matching opening bracket".into(),
        ";" if expects("a declaration or a statement") => {
            "an empty statement: this `;` follows the end of another (`;;`), or starts the file; remove it".into()
        }
        "¬" if expects("`←` (or `<-`)") => "did you mean `←` (ASCII `<-`)? Text pasted from a PDF set in the Symbol font shows ← as `¬`, ⊕ as `Å`, δ as `d` and π as `p`: write those symbols (or their ASCII spellings `<-`, `(+)`, `delta`, `pi`)".into(),
        f if let Some(help) = symbol_help(f) => help,
        f if f.chars().next().is_some_and(|c| !c.is_ascii() && !c.is_alphanumeric()) => format!(
            "`{f}` is not a symbol of the language; the symbols are δ π ← ⊕ · ′ α σ ⁻¹ → and their ASCII spellings (see docs/language.md)"
        ),
        _ if expects("`;`") && expects("an operator") => {
            "the expression ends here: add an operator to continue it, or `;` to end the statement".into()
        }
        _ => "see docs/language.md for the grammar, with an example of every construct".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::token_at;

    /// A long word is cut at 64 bytes, never inside a character: the
    /// language server's fuzz target found `δyyy…δyyy` (a letter of two
    /// bytes at bytes 63-64) ending a check with a panic.
    #[test]
    fn a_long_word_is_cut_at_a_character_boundary() {
        let word = format!("δ{}δ{}", "y".repeat(61), "y".repeat(13));
        assert_eq!(token_at(&word, 0), format!("δ{}", "y".repeat(61)));
        let ascii = "a".repeat(100);
        assert_eq!(token_at(&ascii, 0).len(), 64);
    }
}
