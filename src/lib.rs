//! shadec — a compiler for the shading-pipeline grammar of seeds/001
//! ("A graphics pipeline grammar"): `.shd` text → AST → IR → pass plans for
//! register combiners (seeds/003) or WGSL.
//!
//! See `ARCHITECTURE.md` for the flow and the invariants.

pub mod backends;
pub mod bench;
pub mod diag;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod io;
pub mod ir;
pub mod lowering;
pub mod meaning;
pub mod parser;
pub mod pipeline;
pub mod planner;
pub mod profile;
pub mod renderer;
pub mod scene;
pub mod span;
pub mod textures;

/// Compiles `source` for `profile` into a pass plan — parse, check, lower,
/// specialize, plan; never touches a GPU (issue 3 part 4). The plan
/// serializes to RON and JSON (`PassPlan::to_ron`, `to_json`); for the IR
/// the plan's value ids refer to, use [`planner::compile_source`].
pub fn compile(source: &str, profile: &profile::Profile) -> Result<pipeline::PassPlan, Diagnostics> {
    planner::compile_source(source, profile).map(|p| p.plan)
}

/// Every problem found in a program, each with its location.
pub type Diagnostics = Vec<diag::Diagnostic>;
