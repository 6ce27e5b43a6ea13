//! The plan contract: what the planner produces and every
//! backend and executor consumes — the serializable [`PassPlan`] (its
//! passes, render targets, texture bindings and fixed-function state,
//! `docs/pass-plan.md`), the IR it refers to ([`Planned`]), and the
//! interface each pass binds ([`PassInterface`]). It sits just above the IR
//! and the profiles; the planner, the backends and the executors depend on
//! it and on none of each other's insides.

pub mod interface;
pub mod plan;
pub mod state;

pub use interface::PassInterface;
pub use plan::{
    Approximation, ApproximationCost, BlendMode, FragmentWork, FramePrediction, Geometry, MeasuredError,
    Pass, PassPlan, PassPrediction, Removed, RenderTarget, TextureBinding, Value, VertexWork,
};
pub use state::{
    BlendEquation, BlendFactor, BlendState, CompareFunc, CullMode, DepthState, RenderState, StencilOp,
    StencilState,
};

use crate::ir::{Expr, Handle, Module};
use crate::profile::CombinerLimits;

/// A plan together with the IR it refers to (value ids are handle indices
/// into `module.exprs`): what backends and renderers take.
#[derive(Clone, Debug)]
pub struct Planned {
    pub module: Module,
    pub plan: PassPlan,
    /// The target's register-combiner limits (`None` off the combiner
    /// targets): what each pass's setup is generated under downstream
    /// (fixed9 renders, hardware fidelity), so that a profile given as a
    /// `.ron` file keeps its own limits — the plan names its target only by
    /// name, and a name is not a profile.
    pub combiners: Option<CombinerLimits>,
}

impl Planned {
    pub fn handle(&self, id: u32) -> Handle<Expr> {
        Handle::new(id as usize)
    }
}
