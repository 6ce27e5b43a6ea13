//! The vertex stages of the CPU executor: the screen-filling [`Quad`] of
//! screen and texel passes, and [`MeshVertices`], an object's per-vertex
//! IR evaluated up front in f64.

use rayon::prelude::*;

use crate::ir::{self, eval::Value, Expr, Handle, Module, Ty};
use crate::pipeline::PassInterface;
use crate::renderer::VertexStage;
use crate::scene::bind::{self, BoundObject};

/// The screen-filling rectangle of screen and texel passes.
pub(super) struct Quad;

impl VertexStage for Quad {
    fn n_vertices(&self) -> usize {
        4
    }
    fn n_varyings(&self) -> usize {
        0
    }
    fn shade_vertex(&self, index: u32, _varyings: &mut [f32]) -> [f32; 4] {
        // Counter-clockwise in NDC.
        match index {
            0 => [-1.0, -1.0, 0.0, 1.0],
            1 => [1.0, -1.0, 0.0, 1.0],
            2 => [1.0, 1.0, 0.0, 1.0],
            _ => [-1.0, 1.0, 0.0, 1.0],
        }
    }
}

/// The vertex stage of one object in one pass: every vertex evaluated up
/// front (in f64), in parallel.
pub(super) struct MeshVertices {
    pub(super) n_varyings: usize,
    pub(super) varyings: Vec<f32>,
    pub(super) clip: Vec<[f32; 4]>,
}

impl MeshVertices {
    pub(super) fn new(
        m: &Module,
        object: &BoundObject,
        pi: &PassInterface,
        uniforms: &[Option<Value>],
    ) -> MeshVertices {
        let values: Vec<Handle<Expr>> = pi
            .interpolants
            .iter()
            .map(|h| match m.exprs[*h] {
                Expr::Interpolate { value, .. } => value,
                _ => *h,
            })
            .collect();
        let mut roots = values.clone();
        roots.extend(pi.position);
        let n = object.n_vertices();
        let nv = 4 * values.len();
        let chunk = 256;
        let results: Vec<(Vec<f32>, Vec<[f32; 4]>)> = (0..n.div_ceil(chunk))
            .into_par_iter()
            .map(|c| {
                let mut ev = ir::eval::Evaluator::new(m, &roots, crate::numerics::Precision::Exact);
                let mut vary = Vec::with_capacity(chunk * nv);
                let mut clip = Vec::with_capacity(chunk);
                for v in c * chunk..((c + 1) * chunk).min(n) {
                    let mut env = bind::VertexEnv { object, module: m, vertex: v, uniforms };
                    let r = ev.eval(&mut env);
                    for (k, &value) in values.iter().enumerate() {
                        let ty = m.info(value).ty;
                        let x = widen_vertex(r.values[k], ty);
                        vary.extend(x.map(|c| c as f32));
                    }
                    let p = match pi.position {
                        // Into a texture by its coordinates (seeds/001 (15)): clip (2u − 1, 1 − 2v), row 0 at v = 0.
                        Some(p) if m.info(p).ty == Ty::Vec2 => {
                            let [u, v, ..] = r.values[values.len()];
                            [2.0 * u - 1.0, 1.0 - 2.0 * v, 0.0, 1.0]
                        }
                        Some(_) => r.values[values.len()],
                        None => [0.0, 0.0, 0.0, 1.0],
                    };
                    clip.push(p.map(|c| c as f32));
                }
                (vary, clip)
            })
            .collect();
        let mut varyings = Vec::with_capacity(n * nv);
        let mut clip = Vec::with_capacity(n);
        for (v, c) in results {
            varyings.extend(v);
            clip.extend(c);
        }
        MeshVertices { n_varyings: nv, varyings, clip }
    }
}

/// A per-vertex value as a varying: a scalar as itself in lane 0 (then
/// splatted again when read), others as they are.
pub(super) fn widen_vertex(v: Value, _ty: Ty) -> Value {
    v
}

impl VertexStage for MeshVertices {
    fn n_vertices(&self) -> usize {
        self.clip.len()
    }
    fn n_varyings(&self) -> usize {
        self.n_varyings
    }
    fn shade_vertex(&self, index: u32, varyings: &mut [f32]) -> [f32; 4] {
        let i = index as usize;
        varyings.copy_from_slice(&self.varyings[i * self.n_varyings..(i + 1) * self.n_varyings]);
        self.clip[i]
    }
}
