//! The vertex work of a pass, counted as vertex-program instructions (or
//! fixed-function T&L operations) per vertex — the length of the program a
//! GeForce3 vertex program would run for the pass (GeForce3 Phong, Section 4.1:
//! the light and half-angle vectors transformed into tangent space per
//! vertex), estimated from the per-vertex IR the pass interpolates.

use std::collections::HashSet;

use crate::ir::{Expr, Frequency, Handle, MathFunction, Module};
use crate::pipeline::Pass;

/// Transforming the position to clip space: four `dp4`.
pub const PROJECT_OPS: f64 = 4.0;
/// A normal, tangent or binormal into the space asked: three `dp3`.
pub const FRAME_OPS: f64 = 3.0;
/// A light or view vector: `p_light − p` (one `add`), normalized (`dp3`,
/// `rsq`, `mul`).
pub const DIRECTION_OPS: f64 = 4.0;
/// Into tangent space: three `dp3` more (GeForce3 Phong, Section 4.1).
pub const TANGENT_SPACE_OPS: f64 = 3.0;
/// Writing one interpolant (`mov` to an output register).
pub const OUTPUT_OPS: f64 = 1.0;

/// Instructions per vertex of `pass`: its position, every per-vertex node
/// its interpolants read, and one output each.
pub fn ops_per_vertex(pass: &Pass, module: &Module) -> f64 {
    let mut roots: Vec<Handle<Expr>> = Vec::new();
    roots.extend(pass.vertex.position.map(|p| Handle::new(p as usize)));
    roots.extend(pass.vertex.interpolants.iter().map(|&i| Handle::new(i as usize)));
    let mut seen = HashSet::new();
    let mut ops = pass.vertex.interpolants.len() as f64 * OUTPUT_OPS;
    let mut stack = roots;
    while let Some(h) = stack.pop() {
        if h.index() >= module.exprs.len() || !seen.insert(h) {
            continue;
        }
        let expr = &module.exprs[h];
        if module.info(h).freq == Frequency::Vertex || matches!(expr, Expr::Project { .. }) {
            ops += node_ops(module, expr);
        }
        expr.visit_operands(|o| stack.push(o));
    }
    ops
}

/// Instructions of one node: arithmetic is one, swizzles and inputs are
/// free, a normalization three, a power one (`lit`).
fn node_ops(module: &Module, expr: &Expr) -> f64 {
    match expr {
        Expr::Constant(_)
        | Expr::Uniform(_)
        | Expr::VertexPosition(_)
        | Expr::TexCoord { .. }
        | Expr::Swizzle { .. }
        | Expr::Compose { .. }
        | Expr::Convert { .. }
        | Expr::Interpolate { .. } => 0.0,
        Expr::Vector { vector, .. } => module.vectors.get(*vector as usize).map_or(FRAME_OPS, vector_ops),
        Expr::Project { .. } => PROJECT_OPS,
        Expr::Math {
            fun: MathFunction::Normalize | MathFunction::Length | MathFunction::Reflect, ..
        } => 3.0,
        _ => 1.0,
    }
}

/// A role-declared shading vector: what the vertex program computes for it.
fn vector_ops(v: &crate::ir::Vector) -> f64 {
    use crate::parser::ast::{Space, VectorKind};
    let base = match v.kind {
        Some(VectorKind::Light | VectorKind::View | VectorKind::Position) => DIRECTION_OPS,
        // H = normalize(L + V): both directions, an `add`, a normalization.
        Some(VectorKind::Half) => 2.0 * DIRECTION_OPS + 4.0,
        // R = 2 (N·V) N − V: a `dp3` and a `mad` beside the view vector.
        Some(VectorKind::Reflection) => DIRECTION_OPS + 2.0,
        Some(VectorKind::Intensity) => 2.0,
        Some(VectorKind::Normal | VectorKind::Tangent | VectorKind::Binormal) | None => FRAME_OPS,
    };
    let tangent = if v.space == Some(Space::Tangent) { TANGENT_SPACE_OPS } else { 0.0 };
    base + tangent
}
