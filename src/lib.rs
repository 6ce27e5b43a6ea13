//! shadec — a compiler for the shading-pipeline grammar of seeds/001
//! ("A graphics pipeline grammar"): `.shd` text → AST → IR → pass plans for
//! register combiners (seeds/003) or WGSL.
//!
//! See `ARCHITECTURE.md` for the flow and the invariants.

pub mod backends;
pub mod diag;
pub mod io;
pub mod ir;
pub mod parser;
pub mod profile;
pub mod renderer;
pub mod scene;
pub mod textures;
pub mod span;
