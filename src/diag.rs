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

    pub fn warning(
        code: &'static str,
        message: impl Into<String>,
        span: Span,
        label: impl Into<String>,
    ) -> Diagnostic {
        Diagnostic { severity: Severity::Warning, ..Diagnostic::error(code, message, span, label) }
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Diagnostic {
        self.help = Some(help.into());
        self
    }

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

#[derive(Clone, Copy, Debug, Serialize, PartialEq, Eq)]
pub struct LspPosition {
    pub line: u32,
    pub character: u32,
}

#[derive(Clone, Copy, Debug, Serialize, PartialEq, Eq)]
pub struct LspRange {
    pub start: LspPosition,
    pub end: LspPosition,
}

#[derive(Clone, Debug, Serialize, PartialEq, Eq)]
pub struct LspLocation {
    pub uri: String,
    pub range: LspRange,
}

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
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            d[i][j] = (d[i - 1][j] + 1).min(d[i][j - 1] + 1).min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                d[i][j] = d[i][j].min(d[i - 2][j - 2] + 1);
            }
        }
    }
    d[a.len()][b.len()]
}

/// The candidate closest to `name`, if it is close enough to be a likely typo.
pub fn did_you_mean<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).max(1);
    candidates
        .into_iter()
        .map(|c| (edit_distance(&name.to_lowercase(), &c.to_lowercase()), c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, c)| (*d, c.len()))
        .map(|(_, c)| c)
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
