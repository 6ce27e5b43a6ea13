//! Diagnostics shared by every phase: one struct, rendered late — like rustc
//! for people (codespan-reporting), or as LSP `Diagnostic` objects for editors.
//!
//! Every user-facing error has a span (hence file:line:col), a message saying
//! what is wrong, a primary label, and a help line saying how to fix it.

use std::fmt::Write as _;

use codespan_reporting::diagnostic as cs;
use codespan_reporting::files::SimpleFile;
use codespan_reporting::term;
use serde::Serialize;

use crate::span::{LineIndex, Span};

/// How serious a diagnostic is: an error refuses the program, a warning or note does not.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Severity {
    Error,
    Warning,
    Info,
    Hint,
}

impl Severity {
    /// The LSP `DiagnosticSeverity` number.
    pub fn lsp(self) -> u8 {
        match self {
            Severity::Error => 1,
            Severity::Warning => 2,
            Severity::Info => 3,
            Severity::Hint => 4,
        }
    }
}

/// A span with a short message: the primary place of a diagnostic, or a related one.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Label {
    pub span: Span,
    pub message: String,
}

/// One finding about a source text. The primary label says where; secondary
/// labels point at related places (a previous definition, the declaration).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic {
    pub severity: Severity,
    /// A stable, searchable code such as `syntax` or `unknown-name`.
    pub code: &'static str,
    pub message: String,
    pub primary: Label,
    pub secondary: Vec<Label>,
    /// How to fix it.
    pub help: Option<String>,
}

impl Diagnostic {
    /// An error `code` with its `message`, at `span` labelled `label`: the program is refused.
    pub fn error(
        code: &'static str,
        message: impl Into<String>,
        span: Span,
        label: impl Into<String>,
    ) -> Diagnostic {
        Diagnostic {
            severity: Severity::Error,
            code,
            message: message.into(),
            primary: Label { span, message: label.into() },
            secondary: Vec::new(),
            help: None,
        }
    }

    /// A warning, built like [`Diagnostic::error`]: the program is still compiled.
    pub fn warning(
        code: &'static str,
        message: impl Into<String>,
        span: Span,
        label: impl Into<String>,
    ) -> Diagnostic {
        Diagnostic { severity: Severity::Warning, ..Diagnostic::error(code, message, span, label) }
    }

    /// The help line: what to do about it (which must be true).
    pub fn with_help(mut self, help: impl Into<String>) -> Diagnostic {
        self.help = Some(help.into());
        self
    }

    /// A secondary place, with its message ("declared here").
    pub fn with_label(mut self, span: Span, message: impl Into<String>) -> Diagnostic {
        self.secondary.push(Label { span, message: message.into() });
        self
    }

    /// Moves every span right by `offset` bytes (for text parsed out of a larger file).
    pub fn shifted(mut self, offset: usize) -> Diagnostic {
        self.primary.span = self.primary.span.shifted(offset);
        for label in &mut self.secondary {
            label.span = label.span.shifted(offset);
        }
        self
    }

    /// Whether the diagnostic refuses the program.
    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }
}

/// A named source text with its line index.
#[derive(Clone, Debug)]
pub struct SourceFile {
    pub name: String,
    pub text: String,
    index: LineIndex,
}

impl SourceFile {
    /// A source file `name` with its `text`, indexed by line for `file:line:col` positions.
    pub fn new(name: impl Into<String>, text: impl Into<String>) -> SourceFile {
        let text = text.into();
        let index = LineIndex::new(&text);
        SourceFile { name: name.into(), text, index }
    }

    /// `name:line:col` of a byte offset, 1-based.
    pub fn location(&self, offset: u32) -> String {
        let lc = self.index.line_col(&self.text, offset as usize);
        format!("{}:{}:{}", self.name, lc.line, lc.col)
    }

    /// The file's line index, for positions in it.
    pub fn line_index(&self) -> &LineIndex {
        &self.index
    }

    /// Renders diagnostics like rustc: header, `--> file:line:col`, the source
    /// line with the labelled span underlined, then `= help:`.
    pub fn render(&self, diagnostics: &[Diagnostic], color: bool) -> String {
        let file = SimpleFile::new(self.name.as_str(), self.text.as_str());
        let config = term::Config::default();
        let mut out = String::new();
        for d in diagnostics {
            if self.touches_long_line(d) {
                out.push_str(&self.render_excerpt(d));
                continue;
            }
            let rendered = if color {
                let mut buffer = termcolor_buffer();
                let _ = term::emit_to_write_style(&mut buffer, &config, &file, &self.to_codespan(d));
                String::from_utf8_lossy(buffer.as_slice()).into_owned()
            } else {
                let mut s = String::new();
                let _ = term::emit_to_string(&mut s, &config, &file, &self.to_codespan(d));
                s
            };
            out.push_str(&rendered);
        }
        out
    }

    fn touches_long_line(&self, d: &Diagnostic) -> bool {
        std::iter::once(&d.primary)
            .chain(&d.secondary)
            .any(|l| self.line_around(l.span.start as usize).len() > MAX_SHOWN_LINE)
    }

    /// The whole line that holds byte `offset`.
    fn line_around(&self, offset: usize) -> &str {
        let offset = offset.min(self.text.len());
        let start = self.text[..offset].rfind('\n').map_or(0, |i| i + 1);
        let end = self.text[offset..].find('\n').map_or(self.text.len(), |i| offset + i);
        &self.text[start..end]
    }

    /// A diagnostic on a line too long to echo: 80 characters around the span.
    fn render_excerpt(&self, d: &Diagnostic) -> String {
        let at = d.primary.span.start as usize;
        let line = self.line_around(at);
        let line_start = line.as_ptr() as usize - self.text.as_ptr() as usize;
        let before: String = self.text[line_start..at.min(self.text.len())]
            .chars()
            .rev()
            .take(40)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect();
        let after: String =
            self.text[at.min(self.text.len())..line_start + line.len()].chars().take(40).collect();
        let mut out = String::new();
        let _ = writeln!(out, "{}[{}]: {}", severity_word(d.severity), d.code, d.message);
        let _ = writeln!(out, "  ┌─ {}", self.location(d.primary.span.start));
        let _ = writeln!(
            out,
            "  │ (this line has {} characters; showing the 80 around the error)",
            line.chars().count()
        );
        let _ = writeln!(out, "  │ …{before}{after}…");
        let _ = writeln!(out, "  │  {}^ {}", " ".repeat(before.chars().count()), d.primary.message);
        if let Some(help) = &d.help {
            let _ = writeln!(out, "  = help: {help}");
        }
        out.push('\n');
        out
    }

    fn to_codespan(&self, d: &Diagnostic) -> cs::Diagnostic<()> {
        let clamp = |s: Span| {
            let len = self.text.len();
            (s.start as usize).min(len)..(s.end as usize).min(len)
        };
        let severity = match d.severity {
            Severity::Error => cs::Severity::Error,
            Severity::Warning => cs::Severity::Warning,
            Severity::Info => cs::Severity::Note,
            Severity::Hint => cs::Severity::Help,
        };
        let mut labels = vec![cs::Label::primary((), clamp(d.primary.span)).with_message(&d.primary.message)];
        labels.extend(
            d.secondary.iter().map(|l| cs::Label::secondary((), clamp(l.span)).with_message(&l.message)),
        );
        let mut notes = Vec::new();
        if let Some(help) = &d.help {
            notes.push(format!("help: {help}"));
        }
        cs::Diagnostic::new(severity)
            .with_code(d.code)
            .with_message(&d.message)
            .with_labels(labels)
            .with_notes(notes)
    }

    /// One line per diagnostic: `file:line:col: error[code]: message`.
    pub fn render_short(&self, diagnostics: &[Diagnostic]) -> String {
        let mut out = String::new();
        for d in diagnostics {
            let sev = severity_word(d.severity);
            let _ =
                writeln!(out, "{}: {sev}[{}]: {}", self.location(d.primary.span.start), d.code, d.message);
        }
        out
    }

    /// LSP `Diagnostic` objects (0-based line, UTF-16 character).
    pub fn to_lsp(&self, uri: &str, diagnostics: &[Diagnostic]) -> Vec<LspDiagnostic> {
        diagnostics
            .iter()
            .map(|d| {
                let mut message = d.message.clone();
                if let Some(help) = &d.help {
                    message.push_str("\nhelp: ");
                    message.push_str(help);
                }
                LspDiagnostic {
                    range: self.lsp_range(d.primary.span),
                    severity: d.severity.lsp(),
                    code: d.code,
                    source: "shadec",
                    message,
                    related_information: d
                        .secondary
                        .iter()
                        .map(|l| LspRelated {
                            location: LspLocation { uri: uri.to_string(), range: self.lsp_range(l.span) },
                            message: l.message.clone(),
                        })
                        .collect(),
                }
            })
            .collect()
    }

    fn lsp_range(&self, span: Span) -> LspRange {
        let pos = |offset: u32| {
            let (line, character) = self.index.lsp_position(&self.text, offset as usize);
            LspPosition { line, character }
        };
        LspRange { start: pos(span.start), end: pos(span.end) }
    }
}

/// Lines longer than this are shown as an excerpt, not echoed whole.
const MAX_SHOWN_LINE: usize = 400;

fn severity_word(s: Severity) -> &'static str {
    match s {
        Severity::Error => "error",
        Severity::Warning => "warning",
        Severity::Info => "info",
        Severity::Hint => "hint",
    }
}

fn termcolor_buffer() -> codespan_reporting::term::termcolor::Buffer {
    codespan_reporting::term::termcolor::Buffer::ansi()
}

/// LSP `Diagnostic`, with fields in the order the specification lists them.
#[derive(Clone, Debug, Serialize, PartialEq, Eq)]
#[serde(rename_all = "camelCase")]
pub struct LspDiagnostic {
    pub range: LspRange,
    pub severity: u8,
    pub code: &'static str,
    pub source: &'static str,
    pub message: String,
    pub related_information: Vec<LspRelated>,
}

/// A position as the Language Server Protocol counts it (0-based line, UTF-16 character).
#[derive(Clone, Copy, Debug, Serialize, PartialEq, Eq)]
pub struct LspPosition {
    pub line: u32,
    pub character: u32,
}

/// A range of [`LspPosition`]s, end exclusive.
#[derive(Clone, Copy, Debug, Serialize, PartialEq, Eq)]
pub struct LspRange {
    pub start: LspPosition,
    pub end: LspPosition,
}

/// A range in a document, by URI: a related place of an LSP diagnostic.
#[derive(Clone, Debug, Serialize, PartialEq, Eq)]
pub struct LspLocation {
    pub uri: String,
    pub range: LspRange,
}

/// A related place of an LSP diagnostic (a secondary label), with its message.
#[derive(Clone, Debug, Serialize, PartialEq, Eq)]
pub struct LspRelated {
    pub location: LspLocation,
    pub message: String,
}

/// Edit distance for "did you mean" suggestions: insertions, deletions,
/// substitutions and transpositions of neighbours each cost 1 (optimal
/// string alignment), so `Ligth` is one edit from `Light`.
pub fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    bounded_distance(&a, &b, usize::MAX, &mut Vec::new()).unwrap_or(usize::MAX)
}

/// The optimal-string-alignment distance of `a` and `b` if it is at most
/// `limit`, else `None`, in O(|a|·|b|) at worst and stopping as soon as a
/// whole row exceeds the limit (the resolver calls this for every
/// candidate it cannot rule out by length, so it allocates nothing but the
/// caller's `rows`).
fn bounded_distance(a: &[char], b: &[char], limit: usize, rows: &mut Vec<usize>) -> Option<usize> {
    if a.len().abs_diff(b.len()) > limit {
        return None;
    }
    let w = b.len() + 1;
    rows.clear();
    rows.resize(3 * w, 0);
    let (mut prev2, mut prev, mut cur) = (0, w, 2 * w);
    for (j, cell) in rows[prev..prev + w].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        rows[cur] = i;
        let mut row_min = i;
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut d = (rows[prev + j] + 1).min(rows[cur + j - 1] + 1).min(rows[prev + j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d = d.min(rows[prev2 + j - 2] + 1);
            }
            rows[cur + j] = d;
            row_min = row_min.min(d);
        }
        if row_min > limit {
            return None;
        }
        (prev2, prev, cur) = (prev, cur, prev2);
    }
    Some(rows[prev + b.len()]).filter(|&d| d <= limit)
}

/// How many edits a name of `n` characters may be from a suggestion: a
/// third of its length, at least one.
fn edit_limit(n: usize) -> usize {
    (n / 3).max(1)
}

/// The order of suggestions, best first, so that ties are broken the same
/// way on every run (`h8` suggested `h` or `H` by hash order):
/// fewest edits ignoring case, then the shortest name (in characters), then
/// fewest edits counting case, then Unicode code-point order.
fn suggestion_key<'c>(name: &[char], candidate: &'c str, distance: usize) -> (usize, usize, usize, &'c str) {
    let exact: Vec<char> = candidate.chars().collect();
    let cased = bounded_distance(name, &exact, usize::MAX, &mut Vec::new()).unwrap_or(usize::MAX);
    (distance, exact.len(), cased, candidate)
}

fn lower(s: &str) -> Vec<char> {
    s.chars().flat_map(char::to_lowercase).collect()
}

/// The candidate closest to `name`, if it is close enough to be a likely
/// typo: within a third of its length in edits, ignoring case; ties broken
/// by `suggestion_key`'s order. Compares with every candidate: for a few
/// dozen keywords; [`Suggester`] serves a program's names.
pub fn did_you_mean<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let (key, exact) = (lower(name), name.chars().collect::<Vec<_>>());
    let limit = edit_limit(exact.len());
    let mut rows = Vec::new();
    candidates
        .into_iter()
        .filter_map(|c| {
            bounded_distance(&key, &lower(c), limit, &mut rows).map(|d| suggestion_key(&exact, c, d))
        })
        .min()
        .map(|k| k.3)
}

/// A "did you mean" index over a program's names. Comparing each
/// unknown name with every declared one made `check` quadratic in the number
/// of errors (15 s for 8 000 misspellings). Here:
///
/// - every candidate is filed, lowercased, under itself and each string one
///   deletion away from it (symmetric deletion, as SymSpell does); a name
///   within one edit of a candidate — a substitution, an insertion, a
///   deletion or a swap of neighbours — shares one of those strings with it,
///   so looking up the name and its own one-deletion strings finds every
///   candidate within one edit, in time independent of how many there are;
/// - only when none is that close does it look further (longer names allow
///   up to a third of their length), among the candidates whose length is
///   within the limit, nearest length first, at most [`Suggester::MAX_SCAN`]
///   of them: past that a suggestion two edits away can be missed, which is
///   the price of a bound on the work per unknown name.
///
/// The answer is the same candidate [`did_you_mean`] picks whenever the best
/// is one edit away or the scan covers the window, with the same tie order.
#[derive(Debug, Default)]
pub struct Suggester {
    /// Candidate names, sorted by (length in characters, name), deduplicated.
    names: Vec<(String, Vec<char>)>,
    /// Hashes of each candidate's lowercase text and its one-deletion
    /// strings, with the candidate's index, sorted. A hash collision only
    /// costs a comparison: every hit is checked by the distance itself.
    deletions: Vec<(u64, u32)>,
}

impl Suggester {
    /// At most this many candidates are compared with one name past the
    /// one-edit lookup.
    pub const MAX_SCAN: usize = 512;

    /// A suggester over `candidates` (the names in scope, a closed set of words).
    pub fn new<'a>(candidates: impl IntoIterator<Item = &'a str>) -> Suggester {
        let mut names: Vec<(String, Vec<char>)> =
            candidates.into_iter().map(|c| (c.to_string(), lower(c))).collect();
        names.sort_by(|a, b| (a.1.len(), &a.0).cmp(&(b.1.len(), &b.0)));
        names.dedup_by(|a, b| a.0 == b.0);
        let mut deletions = Vec::new();
        for (i, (_, key)) in names.iter().enumerate() {
            for_each_deletion(key, |h| deletions.push((h, i as u32)));
        }
        deletions.sort_unstable();
        deletions.dedup();
        Suggester { names, deletions }
    }

    /// The best suggestion for `name` among the candidates that `accept`
    /// lets through, and `extra` (a shader's few locals, compared in full).
    pub fn suggest<'s>(
        &'s self,
        name: &str,
        accept: impl Fn(&str) -> bool,
        extra: &[&'s str],
    ) -> Option<&'s str> {
        let (key, exact) = (lower(name), name.chars().collect::<Vec<_>>());
        let limit = edit_limit(exact.len());
        let mut rows = Vec::new();
        let mut best: Option<(usize, usize, usize, &str)> = None;
        let consider = |best: &mut Option<_>, c: &'s str, lowered: &[char], rows: &mut Vec<usize>| {
            let bound = best.map_or(limit, |b: (usize, usize, usize, &str)| b.0);
            if let Some(d) = bounded_distance(&key, lowered, bound, rows) {
                let k = suggestion_key(&exact, c, d);
                if best.is_none_or(|b| k < b) {
                    *best = Some(k);
                }
            }
        };
        for c in extra {
            consider(&mut best, c, &lower(c), &mut rows);
        }
        let mut hits: Vec<u32> = Vec::new();
        for_each_deletion(&key, |h| {
            let from = self.deletions.partition_point(|&(x, _)| x < h);
            hits.extend(self.deletions[from..].iter().take_while(|&&(x, _)| x == h).map(|&(_, i)| i));
        });
        hits.sort_unstable();
        hits.dedup();
        for i in hits {
            let (c, lowered) = &self.names[i as usize];
            if accept(c) {
                consider(&mut best, c, lowered, &mut rows);
            }
        }
        if best.is_none_or(|b| b.0 > 1) && limit > 1 {
            // Nearest length first: the window's lengths in the order
            // L, L-1, L+1, L-2, L+2, ….
            let mut scanned = 0;
            'lengths: for delta in 0..=limit {
                for n in [key.len().wrapping_sub(delta), key.len() + delta] {
                    if n > key.len() + limit {
                        continue; // L - delta wrapped below zero
                    }
                    let from = self.names.partition_point(|c| c.1.len() < n);
                    for (c, lowered) in self.names[from..].iter().take_while(|c| c.1.len() == n) {
                        if scanned == Self::MAX_SCAN {
                            break 'lengths;
                        }
                        if accept(c) {
                            scanned += 1;
                            consider(&mut best, c, lowered, &mut rows);
                        }
                    }
                    if delta == 0 {
                        break;
                    }
                }
            }
        }
        best.map(|b| b.3)
    }
}

/// Calls `f` with the hash of `key` and of each string one character
/// shorter than it.
fn for_each_deletion(key: &[char], mut f: impl FnMut(u64)) {
    use std::hash::{Hash, Hasher};
    let hash = |skip: usize| {
        let mut h = rustc_hash::FxHasher::default();
        for (i, c) in key.iter().enumerate() {
            if i != skip {
                c.hash(&mut h);
            }
        }
        // The length tells "ab" with nothing skipped from "abc" less one.
        (key.len() - usize::from(skip < key.len())).hash(&mut h);
        h.finish()
    };
    f(hash(usize::MAX));
    for skip in 0..key.len() {
        f(hash(skip));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestions_find_close_names_only() {
        assert_eq!(did_you_mean("modulat", ["modulate", "add", "decal"]), Some("modulate"));
        assert_eq!(did_you_mean("xyzzy", ["modulate", "add", "decal"]), None);
        // A transposition is one edit (it was two, past the limit for 5 letters).
        assert_eq!(edit_distance("Ligth", "Light"), 1);
        assert_eq!(did_you_mean("Ligth", ["Light", "N", "L"]), Some("Light"));
    }

    /// `h` and `H` are both one edit from `h8` ignoring case; the
    /// stated order (then fewest edits counting case) picks `h`, whatever
    /// order the candidates come in.
    #[test]
    fn ties_are_broken_by_a_stated_order() {
        assert_eq!(did_you_mean("h8", ["H", "h"]), Some("h"));
        assert_eq!(did_you_mean("h8", ["h", "H"]), Some("h"));
        assert_eq!(did_you_mean("H8", ["h", "H"]), Some("H"));
        // Same distance, same length, same case distance: code-point order.
        assert_eq!(did_you_mean("ab", ["ac", "aa"]), Some("aa"));
        for order in [["H", "h", "hx"], ["hx", "h", "H"]] {
            assert_eq!(Suggester::new(order).suggest("h8", |_| true, &[]), Some("h"));
        }
    }

    /// The index gives what comparing with every candidate gives, on
    /// pseudo-random names and typos (one to three edits), with fewer
    /// candidates than its scan bound so that the scan is complete.
    #[test]
    fn the_index_agrees_with_the_full_comparison() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: u64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed % n
        };
        let alphabet: Vec<char> = "abcdeABCDE_1δ".chars().collect();
        for _ in 0..40 {
            let names: Vec<String> = (0..1 + next(60))
                .map(|_| (0..1 + next(9)).map(|_| alphabet[next(alphabet.len() as u64) as usize]).collect())
                .collect();
            let index = Suggester::new(names.iter().map(String::as_str));
            for _ in 0..50 {
                let mut query: Vec<char> = names[next(names.len() as u64) as usize].chars().collect();
                for _ in 0..1 + next(3) {
                    let at = next(query.len() as u64 + 1) as usize;
                    let c = alphabet[next(alphabet.len() as u64) as usize];
                    match next(3) {
                        0 if at < query.len() => query[at] = c,
                        1 if at < query.len() => {
                            query.remove(at);
                        }
                        _ => query.insert(at, c),
                    }
                }
                let query: String = query.into_iter().collect();
                let full = did_you_mean(&query, names.iter().map(String::as_str));
                assert_eq!(index.suggest(&query, |_| true, &[]), full, "{query} in {names:?}");
            }
        }
    }

    /// A few thousand unknown names against a few thousand declared ones:
    /// near-linear, where the full comparison took seconds. The
    /// bound is generous; BENCHMARKS.md has the figures.
    #[test]
    fn many_unknown_names_cost_little() {
        let names: Vec<String> = (0..4000).map(|i| format!("light_{i:04}")).collect();
        let index = Suggester::new(names.iter().map(String::as_str));
        let start = std::time::Instant::now();
        for (i, name) in names.iter().enumerate() {
            assert_eq!(index.suggest(&format!("ligth_{i:04}"), |_| true, &[]), Some(name.as_str()));
        }
        for i in 0..4000 {
            // Nothing close: the scan runs and is bounded.
            assert_eq!(index.suggest(&format!("zzzzzzzzz{i}"), |_| true, &[]), None);
        }
        assert!(start.elapsed() < std::time::Duration::from_secs(20), "{:?}", start.elapsed());
    }

    #[test]
    fn rendering_names_file_line_and_column_and_help() {
        let text = "C δπx ← T δu x\n";
        let end = text.trim_end().len();
        let file = SourceFile::new("a.shd", text);
        let d = Diagnostic::error("syntax", "expected `;`", Span::new(end, end), "statement ends here")
            .with_help("end every statement with `;`");
        let text = file.render(&[d], false);
        assert!(text.contains("a.shd:1:15"), "{text}");
        assert!(text.contains("help: end every statement with `;`"), "{text}");
    }
}
