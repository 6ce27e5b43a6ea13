//! `shadec lsp`: a language server over stdio, on `lsp-server`
//! and `lsp-types`, on the compiler's own front end (`analysis.rs`: the
//! phases `check --target` runs, no second one). One file per concern:
//! the loop (`server`), the open documents (`documents`), diagnostics,
//! hover, navigation (definition, references, rename), document symbols,
//! formatting, semantic tokens, inlay hints, completion and code actions,
//! over a name index (`index`). URIs are percent-encoded (`uri`).
//!
//! The document's target — what hover and inlay hints report passes,
//! texture units and combiner stages for — is, strongest first: the
//! program's `target X;`, a `// target: X` comment, the client's
//! `shadec.target` (initializationOptions or workspace settings), `wgsl`.
//! `docs/editors.md` shows the editors' setups.

pub mod analysis;
pub mod code_actions;
pub mod completion;
pub mod diagnostics;
pub mod documents;
pub mod formatting;
pub mod hover;
pub mod index;
pub mod inlay_hints;
pub mod navigation;
pub mod semantic_tokens;
pub mod server;
pub mod symbols;
pub mod transport;
pub mod uri;

pub use server::run;
