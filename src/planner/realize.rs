//! What the planner asks of a fixed-function fragment stage: can it compute
//! this value in one pass? On the register-combiner targets only the
//! combiner code generator knows (Kilgard 2000, Section 4.2: a setup the
//! Appendix B rules accept), and the generator sits above the planner in
//! the data flow (backends). So the driver passes it in as a [`Realizer`]
//!: the planner depends on this trait, not on a backend.

use crate::ir::{Expr, Handle, Module};
use crate::span::Span;

/// Why a fragment stage cannot compute a value in one pass.
#[derive(Clone, Debug, PartialEq)]
pub struct Refusal {
    /// What is missing, in the stage's own words (a register, a stage, an operation).
    pub reason: String,
    /// The part of the program the refusal is about, when it is one part.
    pub span: Option<Span>,
    /// What the user can do about it, in the stage's own words.
    pub help: String,
}

/// Realizes one pass's fragment value on a target's fixed-function stage.
pub trait Realizer {
    /// `Ok` when the stage computes `value` in one pass with texture unit
    /// `i` holding `units[i]` (a lookup, or a framebuffer read as a
    /// texture), with what it took; else why not.
    fn realize(
        &self,
        module: &Module,
        value: Handle<Expr>,
        units: &[Handle<Expr>],
    ) -> Result<Realized, Refusal>;

    /// `Err` when a texture unit of the pass is a dependent lookup (its
    /// coordinates read another unit's texel) that the target's texture
    /// stage does not perform (`texture_shaders`: whether the target has
    /// NV_texture_shader): a pass the card cannot run, which the planner
    /// then splits or refuses, located at the lookup. Asked of every pass
    /// before [`Realizer::realize`]; no default, so no realizer forgets it.
    fn dependent_lookups(
        &self,
        module: &Module,
        units: &[Handle<Expr>],
        texture_shaders: bool,
    ) -> Result<(), Refusal>;

    /// The setup itself for a planned pass, kept in its
    /// `pipeline::PassSetup`: asked once per pass, when the plan is
    /// assembled, so no consumer generates it again.
    fn setup(
        &self,
        module: &Module,
        value: Handle<Expr>,
        units: &[Handle<Expr>],
    ) -> Result<crate::pipeline::CombinerProgram, Refusal>;
}

/// What a realized pass takes of the stage: what the cost model charges
/// (`crate::cost`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Realized {
    /// General combiner stages used (Kilgard 2000, Section 4.2).
    pub general_combiners: u32,
}
