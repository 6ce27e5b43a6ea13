//! The analysis's diagnostics as LSP `Diagnostic`s: the help line joins the
//! message (clients show no separate field for it), secondary labels become
//! `relatedInformation`, once each, and the code is the stable `check` code.

use lsp_types::{
    Diagnostic, DiagnosticRelatedInformation, DiagnosticSeverity, Location, NumberOrString,
    PublishDiagnosticsParams, Uri,
};

use super::documents::Document;
use crate::diag::{self, Severity};

fn severity(s: Severity) -> DiagnosticSeverity {
    match s {
        Severity::Error => DiagnosticSeverity::ERROR,
        Severity::Warning => DiagnosticSeverity::WARNING,
        Severity::Info => DiagnosticSeverity::INFORMATION,
        Severity::Hint => DiagnosticSeverity::HINT,
    }
}

/// One diagnostic for the client.
pub fn to_lsp(doc: &Document, uri: &Uri, d: &diag::Diagnostic) -> Diagnostic {
    let mut message = d.message.clone();
    if let Some(help) = &d.help {
        message.push_str("\nhelp: ");
        message.push_str(help);
    }
    let related: Vec<DiagnosticRelatedInformation> = d
        .secondary
        .iter()
        .map(|l| DiagnosticRelatedInformation {
            location: Location { uri: uri.clone(), range: doc.range(l.span) },
            message: l.message.clone(),
        })
        .collect();
    Diagnostic {
        range: doc.range(d.primary.span),
        severity: Some(severity(d.severity)),
        code: Some(NumberOrString::String(d.code.to_string())),
        source: Some("shadec".to_string()),
        message,
        related_information: (!related.is_empty()).then_some(related),
        ..Default::default()
    }
}

/// `textDocument/publishDiagnostics` for the document's current version.
pub fn publish(doc: &Document, uri: &Uri) -> PublishDiagnosticsParams {
    PublishDiagnosticsParams {
        uri: uri.clone(),
        diagnostics: doc.analysis.diagnostics.iter().map(|d| to_lsp(doc, uri, d)).collect(),
        version: Some(doc.version),
    }
}
