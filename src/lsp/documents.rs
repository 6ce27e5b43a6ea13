//! The open documents: text, version and analysis per URI (full-document
//! sync), and conversions between byte offsets and LSP positions (0-based
//! line, UTF-16 character, as LSP 3.17 §"Position" defaults to).

use std::collections::HashMap;

use lsp_types::{Position, Range};

use std::panic::{catch_unwind, AssertUnwindSafe};

use super::analysis::{analyze, Analysis, TargetSource};
use super::uri;
use crate::span::Span;

/// One open document.
#[derive(Debug)]
pub struct Document {
    pub version: i32,
    pub analysis: Analysis,
}

impl Document {
    pub fn text(&self) -> &str {
        &self.analysis.file.text
    }

    /// The LSP range of a byte span.
    pub fn range(&self, span: Span) -> Range {
        let (text, index) = (self.text(), self.analysis.file.line_index());
        let pos = |o: u32| {
            let (line, character) = index.lsp_position(text, o as usize);
            Position { line, character }
        };
        Range { start: pos(span.start), end: pos(span.end) }
    }

    /// The byte offset of an LSP position, clamped to its line and the text.
    pub fn offset(&self, pos: Position) -> usize {
        offset_of(self.text(), pos)
    }
}

/// The byte offset of `pos` in `text`: past the end of a line is its end.
pub fn offset_of(text: &str, pos: Position) -> usize {
    let mut start = 0;
    for _ in 0..pos.line {
        match text[start..].find('\n') {
            Some(i) => start += i + 1,
            None => return text.len(),
        }
    }
    let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
    let mut units = 0;
    for (i, c) in text[start..line_end].char_indices() {
        if units >= pos.character as usize {
            return start + i;
        }
        units += c.len_utf16();
    }
    line_end
}

/// The analysis of a text whose checking panicked: one located error that
/// says so, so that the document stays open and the server goes on.
fn crashed(name: &str, text: &str, why: &str) -> Analysis {
    let d = crate::diag::Diagnostic::error(
        "internal-error",
        format!("shadec panicked while checking this document: {why}"),
        Span::new(0, 0),
        "while checking this document",
    )
    .with_help(
        "this is a bug in shadec: please report it with the document; the other features go on working",
    );
    Analysis {
        file: crate::diag::SourceFile::new(name, text),
        program: Default::default(),
        diagnostics: vec![d],
        module: None,
        planned: None,
        target: "wgsl".into(),
        target_source: TargetSource::Default,
    }
}

/// The documents the client has open, and the target it configured.
#[derive(Debug, Default)]
pub struct Documents {
    docs: HashMap<String, Document>,
    /// `shadec.target` from `initializationOptions` or the workspace settings.
    pub client_target: Option<String>,
}

impl Documents {
    /// Stores and analyses a version of a document.
    pub fn update(&mut self, uri: &str, version: i32, text: String) -> &Document {
        let name = uri::display_name(uri);
        let client = self.client_target.as_deref();
        let analysis = catch_unwind(AssertUnwindSafe(|| analyze(&name, &text, client)))
            .unwrap_or_else(|panic| crashed(&name, &text, &super::server::panic_text(&panic)));
        self.docs.insert(uri.to_string(), Document { version, analysis });
        &self.docs[uri]
    }

    /// Re-analyses every document (the configured target changed).
    pub fn reanalyze_all(&mut self) -> Vec<String> {
        let uris: Vec<String> = self.docs.keys().cloned().collect();
        for u in &uris {
            let doc = &self.docs[u];
            let (version, text) = (doc.version, doc.text().to_string());
            self.update(u, version, text);
        }
        uris
    }

    pub fn get(&self, uri: &str) -> Option<&Document> {
        self.docs.get(uri)
    }

    pub fn close(&mut self, uri: &str) {
        self.docs.remove(uri);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_count_utf16_units() {
        let text = "a\nδπx ← 𝑇 y\n";
        assert_eq!(offset_of(text, Position { line: 1, character: 6 }), text.find('𝑇').unwrap());
        assert_eq!(offset_of(text, Position { line: 1, character: 9 }), text.find('y').unwrap());
        assert_eq!(offset_of(text, Position { line: 0, character: 99 }), 1);
        assert_eq!(offset_of(text, Position { line: 9, character: 0 }), text.len());
    }
}
