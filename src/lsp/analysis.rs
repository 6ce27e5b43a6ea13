//! The server's view of a document: its text and target in, every
//! diagnostic `shadec check --target` reports out, with the AST, the IR and
//! the pass plan kept for hover, hints and navigation. No second
//! parse→lower→plan path: the front end and the planner are the driver's
//! (`driver::front`, `driver::plan`), run as `verdict::check` runs
//! them, keeping the plan it drops.

use crate::diag::{Diagnostic, SourceFile};
use crate::driver;
use crate::ir::Module;
use crate::parser::{self, ast};
use crate::pipeline::Planned;
use crate::profile::Profile;
use crate::span::Span;
use crate::verdict::{self, Judging};

/// Where the document's target came from, strongest first: the one
/// precedence of [`driver::choose_target`] (the editor's setting is a
/// default for the workspace, weaker than what the file declares, as
/// `--target` on a command line is stronger).
pub use crate::driver::TargetSource;

/// Everything the server knows about one version of a document.
#[derive(Clone, Debug)]
pub struct Analysis {
    pub file: SourceFile,
    pub program: ast::Program,
    pub diagnostics: Vec<Diagnostic>,
    /// The lowered program, when it parsed and resolved without errors.
    pub module: Option<Module>,
    /// The pass plan for the target, when the program lowered and fitted.
    pub planned: Option<Planned>,
    pub target: String,
    pub target_source: TargetSource,
}

/// The profile named by a `// target: NAME` comment (also `# target: NAME`),
/// with the span of the name.
pub fn target_comment(text: &str) -> Option<(String, Span)> {
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let trimmed = line.trim_start();
        let body = trimmed.strip_prefix("//").or_else(|| trimmed.strip_prefix('#'));
        if let Some(rest) = body.and_then(|b| b.trim_start().strip_prefix("target:")) {
            let name = rest.trim();
            if !name.is_empty() {
                let start = offset + line.find(name).unwrap_or(0);
                return Some((name.to_string(), Span::new(start, start + name.len())));
            }
        }
        offset += line.len();
    }
    None
}

/// Checks `text` as `shadec check --target T` does, T being the document's
/// target: the program's declaration, else a `// target:` comment, else the
/// client's setting (`client`), else `wgsl`.
pub fn analyze(name: &str, text: &str, client: Option<&str>) -> Analysis {
    #[allow(
        clippy::expect_used,
        reason = "`analyze_unless` returns `None` only when asked to stop, never here"
    )]
    analyze_unless(name, text, client, &|| false).expect("never superseded")
}

/// [`analyze`], or `None` when `superseded()` says a newer version is
/// waiting once the front end is done (the planner's work on a
/// version nobody will see is skipped).
pub fn analyze_unless(
    name: &str,
    text: &str,
    client: Option<&str>,
    superseded: &dyn Fn() -> bool,
) -> Option<Analysis> {
    analyze_in(name, None, text, client, superseded)
}

/// [`analyze_unless`] for a document saved in the folder `images` (where
/// its `image("…")` files are looked for, as `shadec check` looks next to
/// the file); `None`: an unsaved or remote document, whose images are not
/// looked for.
pub fn analyze_in(
    name: &str,
    images: Option<&std::path::Path>,
    text: &str,
    client: Option<&str>,
    superseded: &dyn Fn() -> bool,
) -> Option<Analysis> {
    let file = SourceFile::new(name, text);
    let driver::Front { program, module, mut diagnostics } = driver::front(text);
    if superseded() {
        return None;
    }
    diagnostics.extend(replacement_characters(text));
    let comment = target_comment(text);
    let (target, target_source) = driver::choose_target([
        (TargetSource::Declaration, driver::declared_target(&program)),
        (TargetSource::Comment, comment.as_ref().map(|c| c.0.as_str())),
        (TargetSource::Client, client),
        (TargetSource::Default, Some("wgsl")),
    ])
    .unwrap_or_else(|| ("wgsl".to_string(), TargetSource::Default));
    let mut analysis = Analysis {
        file,
        program,
        diagnostics: Vec::new(),
        module: None,
        planned: None,
        target,
        target_source,
    };
    match module {
        Some(module) if diagnostics.iter().all(|d| !d.is_error()) => {
            plan_for_target(&mut analysis, &module, images, &mut diagnostics, comment.map(|c| c.1));
            analysis.module = Some(module);
        }
        _ => {}
    }
    diagnostics.sort_by_key(|d| (d.primary.span.start, d.severity));
    analysis.diagnostics = diagnostics;
    Some(analysis)
}

/// At most this many U+FFFD are reported one by one.
const MAX_REPLACEMENTS_REPORTED: usize = 20;

/// A warning at each U+FFFD (the first [`MAX_REPLACEMENTS_REPORTED`]): the
/// server puts one where the client sent a lone UTF-16 surrogate or bytes
/// that are not UTF-8 (`transport.rs`), rather than refusing the document.
fn replacement_characters(text: &str) -> Vec<Diagnostic> {
    let total = text.matches('\u{fffd}').count();
    text.match_indices('\u{fffd}')
        .take(MAX_REPLACEMENTS_REPORTED)
        .map(|(at, r)| {
            Diagnostic::warning(
                "replacement-character",
                "U+FFFD, the replacement character, stands here",
                Span::new(at, at + r.len()),
                "not the text that was typed",
            )
            .with_help(format!(
                "the editor sent something that is not Unicode text here (a lone UTF-16 surrogate or bytes that are not UTF-8), which the server replaced{}; retype the character",
                if total > MAX_REPLACEMENTS_REPORTED {
                    format!(" ({total} in the document, the first {MAX_REPLACEMENTS_REPORTED} shown)")
                } else {
                    String::new()
                }
            ))
        })
        .collect()
}

/// The verdict `check --target` reaches ([`verdict::verdict`]): what
/// cannot be planned is an error with the planner's message, the "the
/// planner will split it" warnings go with it, and every approximation the
/// plan takes is a warning.
fn plan_for_target(
    analysis: &mut Analysis,
    module: &Module,
    images: Option<&std::path::Path>,
    diagnostics: &mut Vec<Diagnostic>,
    comment: Option<Span>,
) {
    let profile = match Profile::resolve(&analysis.target) {
        Ok(p) => p,
        Err(e) => {
            // A declaration's unknown profile is already an error of the resolver.
            if analysis.target_source != TargetSource::Declaration {
                let span = comment.filter(|_| analysis.target_source == TargetSource::Comment);
                diagnostics.push(unknown_target(span.unwrap_or_default(), &e.to_string()));
            }
            return;
        }
    };
    let source = analysis.file.text.clone();
    let judging = Judging { images, ..Judging::default() };
    let (judged, found) = verdict::verdict(module, &analysis.program, &profile, &source, &judging);
    analysis.planned = match judged {
        Some(j) => Some(j.planned),
        // Hover and hints still read the plan while an image is missing.
        None if found.iter().any(|d| d.code == "missing-image") => {
            verdict::judge(module, &analysis.program, &profile, &source, &Judging::default())
                .ok()
                .map(|j| j.planned)
        }
        None => None,
    };
    diagnostics.extend(found);
}

fn unknown_target(span: Span, why: &str) -> Diagnostic {
    Diagnostic::error("unknown-profile", why, span, "no such profile").with_help(format!(
        "name a built-in profile ({}) or a profile's `.ron` file",
        parser::resolve::PROFILES.join(", ")
    ))
}
