//! shadec — a compiler for the shading-pipeline grammar of Pipeline Grammar
//! ("A graphics pipeline grammar"): `.shd` text → AST → IR → pass plans for
//! register combiners (Kilgard 2000) or WGSL.
//!
//! See `ARCHITECTURE.md` for the flow and the invariants.

// Diagnostics are the error type throughout (a location, labels, a help
// line); they are built once per failure and never on a hot path, so boxing
// them would cost every caller a pointer chase for nothing.
#![allow(clippy::result_large_err)]

pub mod accuracy;
pub mod backends;
pub mod bench;
pub mod cost;
pub mod diag;
pub mod driver;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod io;
pub mod ir;
pub mod lowering;
pub mod lsp;
pub mod meaning;
pub mod numerics;
pub mod parser;
pub mod pipeline;
pub mod planner;
pub mod profile;
pub mod renderer;
pub mod scene;
pub mod span;
pub mod textures;

/// Compiles `source` for `profile` into a pass plan — parse, check, lower,
/// specialize, plan; never touches a GPU. The plan
/// serializes to RON and JSON (`PassPlan::to_ron`, `to_json`); for the IR
/// the plan's value ids refer to, and for scenes, use [`driver::compile`].
pub fn compile(source: &str, profile: &profile::Profile) -> Result<pipeline::PassPlan, Diagnostics> {
    driver::compile(source, profile, &driver::PlanOptions::default()).map(|c| c.planned.plan)
}

pub use driver::Diagnostics;
