//! The plan validator: rules of the plan contract that every executor
//! relies on, checked on a [`Planned`] plan before any of them runs it.
//! The planner checks the plans it makes (`planner::plan` refuses one that
//! breaks a rule, as an internal error located at the offending node); the
//! executors check the plans they are handed (a plan may be made by hand,
//! or by a planner with a bug), so that a broken plan is a located refusal
//! and never a panic inside an executor.
//!
//! The rules:
//!
//! - **A quad has no vertices to interpolate.** A pass over a screen
//!   (`Geometry::Screen`) or over a texture's texels (`Geometry::Texels`)
//!   draws one rectangle with no vertex attributes: its fragment stage may
//!   not read a `δ` of per-vertex values (an interpolant). Such a value is
//!   drawn by rasterizing the meshes — on the screen, or in texture space
//!   (`T δu x ← …`, Pipeline Grammar, eq. (15)).

use super::{Geometry, PassInterface, Planned};
use crate::diag::Diagnostic;
use crate::span::Span;

/// The passes of `planned` that break a rule of the contract, one located
/// error each (none: the plan is valid).
pub fn validate(planned: &Planned) -> Vec<Diagnostic> {
    let m = &planned.module;
    let mut errors = Vec::new();
    for (k, pass) in planned.plan.passes.iter().enumerate() {
        let quad = match pass.geometry {
            Geometry::Mesh { .. } => continue,
            Geometry::Screen => "the screen",
            Geometry::Texels => "the texels of its target",
        };
        let interface = PassInterface::of(planned, k);
        let Some(&first) = interface.interpolants.first() else { continue };
        let statement = pass.statements.first().and_then(|s| m.statements.get(*s));
        let mut span = m.span(first);
        if span == Span::DETACHED {
            span = statement.map_or(Span::DETACHED, |s| s.span);
        }
        let n = interface.interpolants.len();
        let message = format!(
            "pass {} of the plan draws one rectangle over {quad}, which has no vertices, but its fragment stage \
             reads {n} interpolated per-vertex value{}",
            k + 1,
            if n == 1 { "" } else { "s" }
        );
        errors.push(
            Diagnostic::error("invalid-plan", message, span, "interpolated from vertices here")
                .with_help("a value interpolated from the vertices is drawn by rasterizing the meshes: on the screen (`C δπx ← …`), or in texture space (`T δu x ← …`)"),
        );
    }
    errors
}

impl Planned {
    /// [`validate`]: `Ok` when every pass keeps the contract's rules, else
    /// one located error per pass that breaks one.
    pub fn validate(&self) -> Result<(), Vec<Diagnostic>> {
        let errors = validate(self);
        if errors.is_empty() {
            Ok(())
        } else {
            Err(errors)
        }
    }
}
