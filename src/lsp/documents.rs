//! An analysed version of a document, the edits that make the next
//! version (incremental sync), and conversions between byte offsets and LSP
//! positions (0-based line, UTF-16 character, as LSP 3.17 §"Position"
//! defaults to). The server keeps the open documents (`server.rs`).

use std::panic::{catch_unwind, AssertUnwindSafe};

use lsp_types::{Position, Range};

use super::analysis::{analyze_in, Analysis, TargetSource};
use super::uri;
use crate::span::Span;

/// One open document.
#[derive(Debug)]
pub struct Document {
    pub version: i32,
    pub analysis: Analysis,
}

impl Document {
    /// The document's text, as last analysed.
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

/// Analyses one version of a document, unless `superseded` says a newer one
/// is waiting (checked between the front end and the planner). A panic in
/// the compiler becomes one located error, so that the document stays open.
pub fn analyze_version(
    uri: &str,
    version: i32,
    text: &str,
    client: Option<&str>,
    superseded: &dyn Fn() -> bool,
) -> Option<Document> {
    let name = uri::display_name(uri);
    // A saved document's images are looked for next to it, as `shadec check` does.
    let folder = uri::to_path(uri).and_then(|p| p.parent().map(std::path::Path::to_path_buf));
    let images = folder.as_deref().filter(|f| f.is_dir());
    let analysis = catch_unwind(AssertUnwindSafe(|| analyze_in(&name, images, text, client, superseded)))
        .unwrap_or_else(|panic| Some(crashed(&name, text, &super::server::panic_text(&panic))))?;
    Some(Document { version, analysis })
}

/// Applies one `contentChanges` entry to `text`: with a range, the range
/// (UTF-16 positions, clamped as [`offset_of`] does; an end before the
/// start is the start) is replaced; without one, the whole text is
/// (LSP 3.17 `TextDocumentContentChangeEvent`).
pub fn apply_change(text: &mut String, range: Option<Range>, new_text: &str) {
    match range {
        None => new_text.clone_into(text),
        Some(r) => {
            let start = offset_of(text, r.start);
            let end = offset_of(text, r.end).max(start);
            text.replace_range(start..end, new_text);
        }
    }
}

/// How a newer text differs from the one an analysis saw, as one replaced
/// region between their common prefix and their common suffix. An answer
/// from an older analysis (hover, completion while the newest version is
/// analysed) reads the client's position through it, and its ranges back,
/// so that it points where the client's text has the same characters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Drift {
    /// Bytes the texts share at the start.
    prefix: usize,
    /// Where the shared end starts in the older and in the newer text.
    old_tail: usize,
    new_tail: usize,
}

impl Drift {
    /// How `new` differs from `old`: the shared start and the shared end.
    pub fn between(old: &str, new: &str) -> Drift {
        let (a, b) = (old.as_bytes(), new.as_bytes());
        let mut prefix = a.iter().zip(b).take_while(|(x, y)| x == y).count();
        while !old.is_char_boundary(prefix) {
            prefix -= 1;
        }
        let room = a.len().min(b.len()) - prefix;
        let mut suffix = a.iter().rev().zip(b.iter().rev()).take(room).take_while(|(x, y)| x == y).count();
        while !old.is_char_boundary(a.len() - suffix) || !new.is_char_boundary(b.len() - suffix) {
            suffix -= 1;
        }
        Drift { prefix, old_tail: a.len() - suffix, new_tail: b.len() - suffix }
    }

    /// Where an offset of the newer text is in the older; `None` inside
    /// the replaced region (the older analysis has not seen it).
    pub fn to_old(&self, offset: usize) -> Option<usize> {
        Self::map(offset, self.prefix, self.new_tail, self.old_tail)
    }

    /// Where an offset of the older text is in the newer; `None` inside
    /// the replaced region.
    pub fn to_new(&self, offset: usize) -> Option<usize> {
        Self::map(offset, self.prefix, self.old_tail, self.new_tail)
    }

    fn map(offset: usize, prefix: usize, from_tail: usize, to_tail: usize) -> Option<usize> {
        if offset <= prefix {
            Some(offset)
        } else if offset >= from_tail {
            Some(offset - from_tail + to_tail)
        } else {
            None
        }
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
        // Inside a surrogate pair: the character's start, never mid-UTF-8.
        assert_eq!(offset_of(text, Position { line: 1, character: 7 }), text.find('𝑇').unwrap() + 4);
    }

    #[test]
    fn drift_maps_offsets_around_one_replaced_region() {
        let old = "const a = 1;\nC δπx ← a;\n";
        let new = "const a = 1;\nconst bb = 2;\nC δπx ← a;\n";
        let d = Drift::between(old, new);
        // Before the change: the same offset; after it: shifted by the insertion.
        assert_eq!(d.to_old(3), Some(3));
        let a_new = new.rfind('a').unwrap();
        assert_eq!(d.to_old(a_new), Some(old.rfind('a').unwrap()));
        assert_eq!(d.to_new(old.rfind('a').unwrap()), Some(a_new));
        // Inside what the older text has not seen: nothing.
        assert_eq!(d.to_old(new.find("bb").unwrap()), None);
        // Identical texts: every offset maps to itself.
        let same = Drift::between(old, old);
        assert!((0..=old.len()).all(|o| same.to_old(o) == Some(o) && same.to_new(o) == Some(o)));
        // A change inside a multi-byte character keeps both ends on boundaries.
        let d = Drift::between("δπ", "δρ");
        assert_eq!((d.to_old(0), d.to_old(2), d.to_old(4)), (Some(0), Some(2), Some(4)));
        assert_eq!(d.to_old(3), None);
    }

    mod incremental {
        use super::*;
        use proptest::prelude::*;

        /// The text as UTF-16 code units, edited as a client does.
        fn edit_utf16(units: &mut Vec<u16>, start: usize, end: usize, new: &str) {
            units.splice(start..end, new.encode_utf16());
        }

        fn position_of(units: &[u16], at: usize) -> Position {
            let before = &units[..at];
            let line = before.iter().filter(|&&u| u == u16::from(b'\n')).count();
            let col = before.iter().rev().take_while(|&&u| u != u16::from(b'\n')).count();
            Position { line: line as u32, character: col as u32 }
        }

        /// Pieces with one, two and four UTF-8 bytes and one or two UTF-16
        /// units, and line breaks.
        fn piece() -> impl Strategy<Value = String> {
            prop::sample::select(vec!["a", "δ", "←", "𝑇", "\n", "xs", "", "\r\n", "T δu x;"])
                .prop_map(str::to_string)
        }

        proptest! {
            #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

            /// Random edit sequences applied as ranges give the text the
            /// whole-document edits give. Ranges fall on code
            /// points, as a client's do (never inside a surrogate pair).
            #[test]
            fn incremental_edits_equal_the_full_text(
                start in prop::collection::vec(piece(), 0..12),
                edits in prop::collection::vec((0usize..1000, 0usize..1000, prop::collection::vec(piece(), 0..4)), 1..30),
            ) {
                let mut text: String = start.concat();
                let mut units: Vec<u16> = text.encode_utf16().collect();
                for (a, b, new) in edits {
                    // Code-point boundaries of the current text, in units.
                    let mut bounds = vec![0];
                    for c in text.chars() {
                        bounds.push(bounds.last().unwrap() + c.len_utf16());
                    }
                    let (a, b) = (bounds[a % bounds.len()], bounds[b % bounds.len()]);
                    let (a, b) = (a.min(b), a.max(b));
                    let new = new.concat();
                    let range = Range { start: position_of(&units, a), end: position_of(&units, b) };
                    apply_change(&mut text, Some(range), &new);
                    edit_utf16(&mut units, a, b, &new);
                    prop_assert_eq!(&text, &String::from_utf16(&units).unwrap());
                }
            }
        }
    }
}
