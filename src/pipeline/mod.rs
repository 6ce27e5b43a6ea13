//! The plan contract: what the planner produces and every
//! backend and executor consumes — the serializable [`PassPlan`] (its
//! passes, render targets, texture bindings and fixed-function state,
//! `docs/pass-plan.md`), the IR it refers to ([`Planned`]), and the
//! interface each pass binds ([`PassInterface`]). It sits just above the IR
//! and the profiles; the planner, the backends and the executors depend on
//! it and on none of each other's insides.

pub mod interface;
pub mod order;
pub mod plan;
pub mod setup;
pub mod state;
pub mod validate;

pub use interface::PassInterface;
pub use order::Draw;
pub use plan::{
    Approximation, ApproximationCost, BlendMode, FragmentWork, FramePrediction, Geometry, MeasuredError,
    Pass, PassPlan, PassPrediction, Removed, RenderTarget, TextureBinding, Value, VertexWork,
};
pub use setup::{
    CombinerProgram, Extent, FragmentSetup, PassSetup, SetupRefusal, TargetFormat, TargetImage, TargetKind,
    UnitBinding, UnitSource, RENDERED_TEXTURE_SIZE,
};
pub use state::{
    AlphaTest, BlendEquation, BlendFactor, BlendState, CompareFunc, CullMode, DepthState, RenderState,
    StencilOp, StencilState,
};

use crate::ir::{Expr, Handle, Module};
use crate::profile::CombinerLimits;
use crate::span::Span;

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
    /// Whether the target runs each pass's vertices as a `!!VP1.0` program
    /// (its profile's `vertex_programs`; docs/vertex-programs.md), carried
    /// for the same reason as `combiners`.
    pub vertex_programs: bool,
    /// Every pass resolved once (`setups[i]` is `plan.passes[i]`'s):
    /// what every executor, emitter and the language server read.
    pub setups: Vec<PassSetup>,
}

impl Planned {
    /// This plan with every pass resolved on a programmable fragment
    /// stage (a plan made without the planner: the program's meaning),
    /// each pass placed at its first statement.
    pub fn resolved(mut self) -> Planned {
        let m = &self.module;
        let stages = self.plan.passes.iter().map(|p| {
            let span =
                p.statements.first().and_then(|s| m.statements.get(*s)).map_or(Span::DETACHED, |s| s.span);
            (span, if p.baked { FragmentSetup::Baked } else { FragmentSetup::Programmable })
        });
        self.setups = setup::resolve_all(m, &self.plan, stages);
        self
    }

    /// The setup of pass `index`.
    pub fn setup(&self, index: usize) -> &PassSetup {
        &self.setups[index]
    }

    /// The IR handle of a plan's value id.
    pub fn handle(&self, id: u32) -> Handle<Expr> {
        Handle::new(id as usize)
    }
}
