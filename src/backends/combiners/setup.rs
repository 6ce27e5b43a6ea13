//! A pass's register-combiner setup as the `fixed9` model runs it (the CPU
//! renderer, WGSL's `--fidelity hardware`, the language server's hover,
//! `--emit combiners`): read from the pass's `pipeline::PassSetup`, never
//! generated again. On a combiner target it is the setup the plan was
//! assembled with; on another target the model is a GeForce 3 (the most
//! capable combiner machine, Kilgard 2000, Section 4.2), generated on first
//! use and kept — this is the one place that policy lives.

use std::sync::Arc;

use super::codegen::{generate, Generated, PassInput};
use super::config::CombinerLimits;
use crate::ir::{Expr, Handle};
use crate::pipeline::{CombinerProgram, Planned, SetupRefusal};

/// The setup of pass `index` of `planned` for the `fixed9` model, or why
/// the generator made none (located).
pub fn of(planned: &Planned, index: usize) -> Result<&Generated, SetupRefusal> {
    let program =
        planned.setup(index).fixed9.get_or_init(|| model(planned, index)).as_ref().map_err(Clone::clone)?;
    program.get::<Generated>().ok_or_else(|| SetupRefusal {
        span: None,
        error: Arc::new(NotGenerated("the pass's setup was not made by the combiner code generator")),
    })
}

/// The model's setup, generated under the plan's own limits, else a GeForce 3's.
fn model(planned: &Planned, index: usize) -> Result<CombinerProgram, SetupRefusal> {
    let pass = &planned.plan.passes[index];
    let limits = planned.combiners.unwrap_or(CombinerLimits::GEFORCE3);
    let units: Vec<Handle<Expr>> = planned.setup(index).units.iter().map(|u| u.lookup).collect();
    let input =
        PassInput { module: &planned.module, value: planned.handle(pass.fragment.output), units: &units };
    generate(&input, &limits)
        .map(|g| CombinerProgram::new(g.config.general.len() as u32, g))
        .map_err(|e| SetupRefusal { span: e.span(), error: Arc::new(e) })
}

#[derive(Debug)]
struct NotGenerated(&'static str);

impl std::fmt::Display for NotGenerated {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.0)
    }
}

impl std::error::Error for NotGenerated {}
