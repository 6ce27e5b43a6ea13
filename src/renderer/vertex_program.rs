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
//! The results are interpolated as the program wrote them, *not* clamped
//! as NV_vertex_program Section 2.14.1.5 clamps the colours before
//! interpolation ([`emulate::Results::rasterized`]): the wgpu runner still
//! draws geforce3 passes with the host's unclamped vertex values, and the
//! two executors must agree (`tools/gpu-check`); clamping here alone moved
//! `gouraud.shd` on geforce3 by up to 40/255 against it. The clamp joins
//! both executors when the runner takes the vertex program's WGSL stage.
//!
//! A pass whose per-vertex values have no vertex-program form (the emitter
//! refuses it, and `compile --emit combiners` says why) keeps the host's
//! vertex stage.

use std::sync::Arc;

use glam::Mat4;

use crate::backends::vertex_program::emit::{self, Emitted};
use crate::backends::vertex_program::emulate;
use crate::backends::vertex_program::program::{Output, ATTRIBUTES};
use crate::ir::eval::{Evaluator, Value};
use crate::ir::Module;
use crate::numerics::Precision;
use crate::pipeline::Planned;
use crate::scene::bind::{BoundObject, VertexEnv};

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
    /// varyings 4k..4k+4 (the result register the emitter chose for it),
    /// the clip position is `o[HPOS]`.
    pub fn vertices(&self, m: &Module, object: &BoundObject, uniforms: &[Option<Value>]) -> Vertices {
        let e = &self.emitted;
        let n = object.n_vertices();
        let nv = 4 * e.interpolants.len();
        if n == 0 {
            return (nv, Vec::new(), Vec::new());
        }
        let parameters = self.parameters(m, object, uniforms);
        let mut fetch = Evaluator::new(m, &e.attributes, Precision::Exact);
        let mut varyings = Vec::with_capacity(n * nv);
        let mut clip = Vec::with_capacity(n);
        for vertex in 0..n {
            let mut env = VertexEnv { object, module: m, vertex, uniforms };
            let mut attributes = [[0.0f32; 4]; ATTRIBUTES];
            for (a, value) in attributes.iter_mut().zip(fetch.eval(&mut env).values) {
                *a = value.map(|x| x as f32);
            }
            let results = emulate::run(&e.program, &attributes, &parameters);
            for o in e.outputs.iter().take(e.interpolants.len()) {
                varyings.extend(results.get(*o));
            }
            clip.push(results.get(Output::HPOS));
        }
        (nv, varyings, clip)
    }

    /// `c[]` for `object`: per-object leaves evaluated once (at its first
    /// vertex; they do not vary over it), matrices from the scene binder.
    fn parameters(
        &self,
        m: &Module,
        object: &BoundObject,
        uniforms: &[Option<Value>],
    ) -> [[f32; 4]; crate::backends::vertex_program::program::PARAMETERS] {
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
