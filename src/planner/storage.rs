//! What a target's framebuffer can hold between passes.
//!
//! A framebuffer declared `rgba16f` or `rgba32f` keeps what a statement
//! writes unclamped for the statements that read it back. The register-
//! combiner and texture-environment targets have 8-bit framebuffers
//! (their profiles' `framebuffer_bits`): GL clamps every colour written
//! there to [0, 1] (OpenGL 1.2.1, Sections 2.13.9 and 4.1.8), so a value
//! outside [0, 1] that a later pass reads back is not what the program
//! means. The planner refuses that plan, located, rather than render it
//! silently clamped.

use crate::diag::Diagnostic;
use crate::ir::{Expr, FbChannel, Module, Table};
use crate::parser::ast::FramebufferChannel;
use crate::pipeline::{PassPlan, RenderTarget};
use crate::profile::Profile;

/// The first pass of `plan` that stores in a float framebuffer, on a target
/// whose framebuffer holds `framebuffer_bits ≤ 8`, a value whose range
/// leaves [0, 1] and that a later statement, not fused into the pass,
/// reads back: a located refusal naming both statements.
pub fn float_framebuffer_read_back(
    module: &Module,
    plan: &PassPlan,
    profile: &Profile,
) -> Option<Diagnostic> {
    if profile.framebuffer_bits > 8 {
        return None;
    }
    for pass in &plan.passes {
        let RenderTarget::Framebuffer { name, .. } = &pass.target else { continue };
        let Some(id) = module.framebuffers.iter().position(|f| f.name == *name) else { continue };
        let fb = &module.framebuffers[id];
        let float = fb
            .channels
            .iter()
            .any(|c| matches!(c, FramebufferChannel::Rgba16f | FramebufferChannel::Rgba32f));
        let Some(&last) = pass.statements.iter().max() else { continue };
        let Some(written) = module.statements.get(last) else { continue };
        let colour = matches!(written.table, Table::Framebuffer { id: w, channel: FbChannel::Color } if w as usize == id);
        let range = module.info(written.value).interval;
        if !float || !colour || (range.lo >= 0.0 && range.hi <= 1.0) {
            continue;
        }
        let reads = |h| matches!(module.exprs[h], Expr::FramebufferRead { framebuffer, .. } if framebuffer as usize == id);
        let reader = module.statements.iter().enumerate().skip(last + 1).find(|(j, st)| {
            !pass.statements.contains(j) && module.reachable(&[st.value]).into_iter().any(reads)
        });
        let Some((_, reader)) = reader else { continue };
        let message = format!(
            "{} cannot keep `{}` unclamped: its framebuffer holds {} bits per channel",
            profile.name, fb.name, profile.framebuffer_bits
        );
        let label = format!("a value in [{}, {}] stored here", range.lo, range.hi);
        return Some(
            Diagnostic::error("unsupported-by-target", message, written.span, label)
                .with_label(reader.span, "read back here, where the target gives it clamped to [0, 1]")
                .with_help(scale_help(&fb.name, range.lo, range.hi)),
        );
    }
    None
}

/// How to keep a value of range [lo, hi] in an 8-bit framebuffer: scaled
/// into [0, 1] where written and back where read, when the range is known.
fn scale_help(name: &str, lo: f64, hi: f64) -> String {
    let scale = if lo >= 0.0 && hi.is_finite() {
        let k = hi.ceil().max(2.0);
        format!(
            "divide the value by {k} where it is written and multiply `{name} δπx` by {k} where it is read, "
        )
    } else {
        String::new()
    };
    format!("`{name}` is declared float, which this target's framebuffer is not: {scale}or target wgsl")
}
