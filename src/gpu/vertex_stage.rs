//! A pass's vertex program as its vertex stage on wgpu. On a target with
//! vertex programs (GeForce3: NV_vertex_program, NVIDIA 2001) a mesh pass's
//! clip position and interpolants are what its emitted `!!VP1.0` program
//! computes, on the CPU ([`crate::renderer::vertex_program`], the
//! interpreter) and here alike: the program translated to a WGSL vertex
//! stage (`backends::vertex_program::wgsl::pass_stage`, the colours clamped
//! to [0, 1] as NV_vertex_program Section 2.14.1.5 says) runs before the
//! WGSL backend's fragment stage, fed the attributes and parameters
//! [`PassProgram::inputs`] loads for both executors.

use super::runner::{RunPass, ShaderSource, VertexData};
use crate::backends::vertex_program::program::{Output, ATTRIBUTES};
use crate::backends::vertex_program::wgsl;
use crate::backends::wgsl::codegen::PassShader;
use crate::ir::eval::Value;
use crate::ir::Module;
use crate::pipeline::Planned;
use crate::renderer::vertex_program::PassProgram;
use crate::scene::bind::BoundObject;

/// A pass's vertex program and where each of its results goes: `outputs[k]`
/// is the result register the fragment stage reads at `@location(k)`.
pub struct VertexStage {
    program: PassProgram,
    outputs: Vec<Output>,
    /// The attribute registers the vertex buffer holds, `v[0]`..: at least
    /// one (the runner's vertex buffer is never empty), every one read.
    attributes: usize,
}

impl VertexStage {
    /// Pass `s`'s vertex program, where the target has them, the emitter
    /// gives the pass one and the pass draws meshes at a position (the
    /// same passes the CPU renderer runs through the interpreter).
    pub fn of(planned: &Planned, s: &PassShader) -> Option<VertexStage> {
        if s.quad_input {
            return None;
        }
        let program = PassProgram::of(planned, s.pass)?;
        let e = program.emitted();
        let outputs = s
            .interface
            .interpolants
            .iter()
            .map(|h| e.interpolants.iter().position(|i| i == h).and_then(|k| e.outputs.get(k).copied()))
            .collect::<Option<Vec<Output>>>()?;
        let read = wgsl::attributes_read(&e.program).last().map_or(0, |k| k + 1);
        let attributes = e.attributes.len().max(read).clamp(1, ATTRIBUTES);
        Some(VertexStage { program, outputs, attributes })
    }

    /// `draw` (one object of the pass, as the backend's own vertex stage
    /// would draw it) through the vertex program instead: the vertex
    /// buffer holds the attribute registers, the uniform buffer the
    /// fragment stage's block followed by `c[0]`..`c[95]`.
    pub fn draw(
        &self,
        mut draw: RunPass,
        m: &Module,
        object: &BoundObject,
        uniforms: &[Option<Value>],
    ) -> RunPass {
        let (vertices, parameters) = self.program.inputs(m, object, uniforms);
        let mut floats = Vec::with_capacity(vertices.len() * 4 * self.attributes);
        for v in &vertices {
            floats.extend(v.iter().take(self.attributes).flatten());
        }
        let mut bytes = draw.uniforms.take().unwrap_or_default();
        bytes.resize(bytes.len().div_ceil(16) * 16, 0);
        let host_vec4s = bytes.len() / 16;
        for c in parameters {
            bytes.extend(c.iter().flat_map(|x| x.to_le_bytes()));
        }
        let stage = wgsl::pass_stage(&self.program.emitted().program, &self.outputs, host_vec4s);
        let fragment = std::mem::replace(&mut draw.shader.source, ShaderSource::Wgsl(String::new()));
        draw.shader.source = ShaderSource::Staged {
            vertex: Box::new(ShaderSource::Wgsl(stage)),
            fragment: Box::new(fragment),
        };
        draw.shader.vertex_entry = wgsl::PASS_ENTRY.into();
        draw.vertices = VertexData { floats, components: vec![4; self.attributes] };
        draw.uniforms = Some(bytes);
        draw
    }
}
