//! The interface of one pass: what every executor of a plan — the CPU
//! renderer, the combiner emulator, the WGSL backend — binds before drawing.
//! One definition, so that all of them read the same inputs in the same
//! order and their images can be compared.
//!
//! - **Vertex inputs** (`vertex_leaves`): the per-vertex leaves the pass
//!   reaches — the vertex position `x`, texture coordinates `u x`, shading
//!   vectors `N x`, `L x` … — each one `vec4<f32>` per vertex (a position
//!   has w = 1, a direction w = 0, coordinates z = w = 0), in this order.
//!   The scene binder computes them (lights, tangent space, texgen).
//! - **Projections** (`projections`): one 4×4 matrix each (`π`, `πl`,
//!   `π*`), model to clip space.
//! - **Uniforms** (`uniforms`): one `vec4<f32>` each, in this order.
//! - **Varyings** (`interpolants`): the `Interpolate` nodes (δ) the fragment
//!   stage reads, each a `vec4<f32>`, perspective-correct.
//! - **Textures**: unit `i` is the plan's `textures[i]`.
//! - **Output**: the pass's fragment value widened to RGBA — a scalar is
//!   splatted to all four channels, an rgb value gets alpha 1.

use std::collections::BTreeSet;

use super::Planned;
use crate::ir::{Expr, Handle, Projection, UniformId};

/// What a pass reads from outside its fragment stage: the vertex leaves, projections, uniforms
/// and texture units an executor binds for it.
#[derive(Clone, Debug, PartialEq)]
pub struct PassInterface {
    pub vertex_leaves: Vec<Handle<Expr>>,
    pub projections: Vec<Projection>,
    pub uniforms: Vec<UniformId>,
    pub interpolants: Vec<Handle<Expr>>,
    /// The clip-space position (a per-vertex `Project` node), for meshes.
    pub position: Option<Handle<Expr>>,
    /// The fragment output.
    pub output: Handle<Expr>,
    /// Discard where this is zero.
    pub condition: Option<Handle<Expr>>,
    /// The fragment's depth in place of the interpolated one, when the
    /// pass replaces it (the plan's `fragment.depth`).
    pub depth: Option<Handle<Expr>>,
}

impl PassInterface {
    /// The interface of pass `index` of `planned`.
    pub fn of(planned: &Planned, index: usize) -> PassInterface {
        let m = &planned.module;
        let pass = &planned.plan.passes[index];
        let h = |id: u32| planned.handle(id);
        let output = h(pass.fragment.output);
        let condition = pass.fragment.condition.map(h);
        let depth = pass.fragment.depth.map(h);
        let mut frag_roots = vec![output];
        frag_roots.extend(condition.into_iter().chain(depth));
        // The δ nodes the fragment stage reads (not those under another δ).
        let mut interpolants = BTreeSet::new();
        let mut stack = frag_roots.clone();
        let mut seen = BTreeSet::new();
        while let Some(n) = stack.pop() {
            if !seen.insert(n) {
                continue;
            }
            match &m.exprs[n] {
                Expr::Interpolate { .. } => {
                    interpolants.insert(n);
                }
                e => stack.extend(e.operands()),
            }
        }
        // The clip position: the per-vertex value the index interpolates.
        let position = pass.vertex.position.map(h).and_then(|p| match &m.exprs[p] {
            Expr::Interpolate { value, .. } => Some(*value),
            _ => None,
        });
        let mut vertex_roots: Vec<Handle<Expr>> = interpolants.iter().copied().collect();
        vertex_roots.extend(position);
        let vertex_nodes = m.reachable(&vertex_roots);
        let vertex_leaves = vertex_nodes
            .iter()
            .copied()
            .filter(|n| {
                matches!(m.exprs[*n], Expr::VertexPosition(_) | Expr::TexCoord { .. } | Expr::Vector { .. })
                    && m.info(*n).freq == crate::ir::Frequency::Vertex
            })
            .collect();
        let mut projections = Vec::new();
        // Those of the vertex stage, then those the fragment stage applies
        // (`πl π⁻¹ xs`, seeds/001 Section 3.5).
        let mut fragment_nodes = Vec::new();
        let mut stack = frag_roots.clone();
        let mut seen = BTreeSet::new();
        while let Some(n) = stack.pop() {
            if seen.insert(n) && !matches!(m.exprs[n], Expr::Interpolate { .. }) {
                fragment_nodes.push(n);
                stack.extend(m.exprs[n].operands());
            }
        }
        fragment_nodes.sort();
        for n in vertex_nodes.iter().chain(&fragment_nodes) {
            if let Expr::Project { projection, .. } = &m.exprs[*n] {
                if !projections.contains(projection) {
                    projections.push(projection.clone());
                }
            }
        }
        let mut all = vertex_roots;
        all.extend(frag_roots);
        let uniforms = m
            .reachable(&all)
            .into_iter()
            .filter_map(|n| match m.exprs[n] {
                Expr::Uniform(u) => Some(u),
                _ => None,
            })
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect();
        PassInterface {
            vertex_leaves,
            projections,
            uniforms,
            interpolants: interpolants.into_iter().collect(),
            position,
            output,
            condition,
            depth,
        }
    }
}
