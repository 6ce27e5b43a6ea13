//! `render` through the vertex programs. On a target whose profile has
//! `vertex_programs` (GeForce3: NV_vertex_program, NVIDIA 2001), a mesh
//! pass's per-vertex values — its clip position and interpolants — come
//! from the pass's emitted `!!VP1.0` program run in the interpreter
//! ([`emulate::run`], IEEE f32), as the card computed them, instead of
//! from the host's evaluation of the IR. The host still fetches each
//! vertex's attributes (`v[k]`: a position, a coordinate set, a shading
//! vector) and loads the parameters (`c[k]`: constants, uniforms, the rows
//! of a projection's model → clip matrix), which is what an application
//! did.
//!
//! The colour results reach the rasterizer clamped to [0, 1], as
//! NV_vertex_program Section 2.14.1.5 says ([`emulate::Results::rasterized`]);
//! the wgpu runner runs the same program as its WGSL vertex stage
//! (`backends::vertex_program::wgsl::pass_stage`), which clamps them too,
//! with the attributes and parameters [`PassProgram::inputs`] gives both.
//!
//! A pass whose per-vertex values have no vertex-program form (the emitter
//! refuses it, and `compile --emit combiners` says why) keeps the host's
//! vertex stage.

use std::sync::Arc;

use glam::Mat4;

use crate::backends::vertex_program::emit::{self, Emitted};
use crate::backends::vertex_program::emulate;
use crate::backends::vertex_program::program::{Output, ATTRIBUTES, PARAMETERS};
use crate::ir::eval::{Evaluator, Value};
use crate::ir::Module;
use crate::numerics::Precision;
use crate::pipeline::Planned;
use crate::scene::bind::{BoundObject, VertexEnv};

/// The high end of the point size range `o[PSIZ]` is clamped to
/// (NV_vertex_program 2.14.1.5). The emitter never writes `o[PSIZ]`.
const MAX_POINT_SIZE: f32 = 64.0;

/// Every vertex's attribute registers, and the parameter registers.
pub type Inputs = (Vec<[[f32; 4]; ATTRIBUTES]>, [[f32; 4]; PARAMETERS]);

/// One pass's vertex program, ready to run on each object's vertices.
pub struct PassProgram {
    emitted: Arc<Emitted>,
}

/// A vertex stage's values laid out as the renderer's: the number of
/// varyings per vertex, the varyings of every vertex, the clip positions.
pub type Vertices = (usize, Vec<f32>, Vec<[f32; 4]>);

impl PassProgram {
    /// Pass `index`'s program, where the target has vertex programs and
    /// the emitter gives the pass one.
    pub fn of(planned: &Planned, index: usize) -> Option<PassProgram> {
        if !planned.vertex_programs {
            return None;
        }
        emit::of(planned, index).ok().map(|emitted| PassProgram { emitted })
    }

    /// The emitted program and how the host binds it.
    pub fn emitted(&self) -> &Emitted {
        &self.emitted
    }

    /// Runs the program on every vertex of `object`: interpolant k is
    /// varyings 4k..4k+4 (the result register the emitter chose for it,
    /// a colour clamped to [0, 1] as the rasterizer receives it), the clip
    /// position is `o[HPOS]`.
    pub fn vertices(&self, m: &Module, object: &BoundObject, uniforms: &[Option<Value>]) -> Vertices {
        let e = &self.emitted;
        let nv = 4 * e.interpolants.len();
        let (attributes, parameters) = self.inputs(m, object, uniforms);
        let mut varyings = Vec::with_capacity(attributes.len() * nv);
        let mut clip = Vec::with_capacity(attributes.len());
        for vertex in &attributes {
            let results = emulate::run(&e.program, vertex, &parameters).rasterized(MAX_POINT_SIZE);
            for o in e.outputs.iter().take(e.interpolants.len()) {
                varyings.extend(results.get(*o));
            }
            clip.push(results.get(Output::HPOS));
        }
        (nv, varyings, clip)
    }

    /// What the host loads for `object`, the same for either executor:
    /// every vertex's attribute registers `v[]` (the pass's vertex leaves,
    /// `v[k]` for `attributes[k]`, the rest zero) and the parameters `c[]`.
    pub fn inputs(&self, m: &Module, object: &BoundObject, uniforms: &[Option<Value>]) -> Inputs {
        let e = &self.emitted;
        let n = object.n_vertices();
        if n == 0 {
            return (Vec::new(), [[0.0; 4]; PARAMETERS]);
        }
        let parameters = self.parameters(m, object, uniforms);
        let mut fetch = Evaluator::new(m, &e.attributes, Precision::Exact);
        let mut vertices = Vec::with_capacity(n);
        for vertex in 0..n {
            let mut env = VertexEnv { object, module: m, vertex, uniforms };
            let mut attributes = [[0.0f32; 4]; ATTRIBUTES];
            for (a, value) in attributes.iter_mut().zip(fetch.eval(&mut env).values) {
                *a = value.map(|x| x as f32);
            }
            vertices.push(attributes);
        }
        (vertices, parameters)
    }

    /// `c[]` for `object`: per-object leaves evaluated once (at its first
    /// vertex; they do not vary over it), matrices from the scene binder.
    fn parameters(
        &self,
        m: &Module,
        object: &BoundObject,
        uniforms: &[Option<Value>],
    ) -> [[f32; 4]; PARAMETERS] {
        let mut env = VertexEnv { object, module: m, vertex: 0, uniforms };
        emit::parameter_values(
            &self.emitted,
            |h| {
                let mut ev = Evaluator::new(m, &[h], Precision::Exact);
                ev.eval(&mut env).values.first().copied().unwrap_or([0.0; 4]).map(|x| x as f32)
            },
            |p| rows(object.clip_matrix(p)),
        )
    }
}

/// A glam matrix (column-major) as its four rows, the `DP4` operands.
fn rows(m: Mat4) -> [[f32; 4]; 4] {
    let c = m.to_cols_array_2d();
    std::array::from_fn(|r| [c[0][r], c[1][r], c[2][r], c[3][r]])
}
