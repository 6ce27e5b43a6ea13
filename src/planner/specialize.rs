//! Specialization basics: constants are folded while
//! lowering; here terms whose coefficient is exactly zero are dropped
//! (`0 · T δu x` costs no texture unit), sums with zero and products with
//! one are simplified, selections on a constant condition take their
//! branch — and every removal is reported, with the textures and passes
//! that only the removed terms used.

use rustc_hash::FxHashMap as HashMap;

use super::affine::Builder;
use crate::ir::{BinaryOp, Expr, FbChannel, Handle, Module, Statement, Table};
use crate::parser::ast::CombineMode;
use crate::pipeline::Removed;
use crate::span::Span;

/// Simplifies every statement of `m` in place; returns what went.
pub fn specialize(m: &mut Module, at: &dyn Fn(Span) -> String) -> Vec<Removed> {
    let mut removed = Vec::new();
    let used_before = used_textures(m, &[]);
    for i in 0..m.statements.len() {
        let v = m.statements[i].value;
        if let Some(nv) = simplify(m, v, &mut removed, at) {
            m.statements[i].value = nv;
        }
    }
    let used_after = used_textures(m, &[]);
    for t in used_before.difference(&used_after) {
        let tex = &m.textures[*t as usize];
        removed.push(Removed {
            kind: "texture".into(),
            what: tex.name.clone(),
            why: "only removed terms used it".into(),
            at: at(tex.span),
        });
    }
    removed
}

/// Textures looked up by the statements other than those in `skip`.
pub(crate) fn used_textures(m: &Module, skip: &[usize]) -> std::collections::BTreeSet<u32> {
    let roots: Vec<Handle<Expr>> =
        m.statements.iter().enumerate().filter(|(i, _)| !skip.contains(i)).map(|(_, s)| s.value).collect();
    m.reachable(&roots)
        .into_iter()
        .filter_map(|h| match m.exprs[h] {
            Expr::Lookup { texture, .. } => Some(texture),
            _ => None,
        })
        .collect()
}

fn simplify(
    m: &mut Module,
    root: Handle<Expr>,
    removed: &mut Vec<Removed>,
    at: &dyn Fn(Span) -> String,
) -> Option<Handle<Expr>> {
    let mut new: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::default();
    for h in m.reachable(&[root]) {
        let e = m.exprs[h].clone();
        let mapped = e.map_operands(|o| new[&o]);
        let ty = m.info(h).ty;
        let span = m.span(h);
        let zero = |m: &Module, x: Handle<Expr>| m.is_constant(x, 0.0);
        let one = |m: &Module, x: Handle<Expr>| m.is_constant(x, 1.0);
        let same_ty = |m: &Module, x: Handle<Expr>| m.info(x).ty == ty;
        let result = match mapped {
            Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
            | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs }
                if zero(m, lhs) || zero(m, rhs) =>
            {
                let dropped = if zero(m, lhs) { rhs } else { lhs };
                if !matches!(m.exprs[dropped], Expr::Constant(_)) {
                    removed.push(Removed {
                        kind: "term".into(),
                        what: format!("the term at {}", at(m.span(dropped))),
                        why: "its coefficient is exactly zero".into(),
                        at: at(span),
                    });
                }
                Builder { module: m }.constant(ty, 0.0)
            }
            Expr::Binary { op: BinaryOp::Add, lhs, rhs }
            | Expr::Combine { mode: CombineMode::Add, lhs, rhs }
                if zero(m, lhs) && same_ty(m, rhs) =>
            {
                Some(rhs)
            }
            Expr::Binary { op: BinaryOp::Add | BinaryOp::Sub, lhs, rhs }
            | Expr::Combine { mode: CombineMode::Add, lhs, rhs }
                if zero(m, rhs) && same_ty(m, lhs) =>
            {
                Some(lhs)
            }
            Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
            | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs }
                if one(m, lhs) && same_ty(m, rhs) =>
            {
                Some(rhs)
            }
            Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
            | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs }
                if one(m, rhs) && same_ty(m, lhs) =>
            {
                Some(lhs)
            }
            Expr::Select { cond, accept, reject: Some(reject) }
                if matches!(m.exprs[cond], Expr::Constant(_)) =>
            {
                let take = if zero(m, cond) { reject } else { accept };
                same_ty(m, take).then_some(take)
            }
            other => m.intern(other, span).ok(),
        };
        new.insert(h, result.unwrap_or(h));
    }
    new.get(&root).copied()
}

/// Whether a statement leaves its target as it was (`C ← C`, `C ← C ⊕[add] 0`).
pub fn is_noop(m: &Module, st: &Statement) -> bool {
    let Table::Framebuffer { id, channel } = st.table else { return false };
    let own = m.exprs.find(&Expr::FramebufferRead { framebuffer: id, channel, position: st.index });
    if own == Some(st.value) {
        return true;
    }
    let own_color = m.exprs.find(&Expr::FramebufferRead {
        framebuffer: id,
        channel: FbChannel::Color,
        position: st.index,
    });
    match m.exprs[st.value] {
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } | Expr::Combine { mode: CombineMode::Add, lhs, rhs } => {
            (Some(lhs) == own_color && m.is_constant(rhs, 0.0))
                || (Some(rhs) == own_color && m.is_constant(lhs, 0.0))
        }
        _ => false,
    }
}

/// Scene-driven specialization, first step: every uniform
/// the scene gives a value (`constants: { "ks": [0, 0, 0] }`, by name, one
/// value or one per component) becomes that constant, so the folding and
/// zero-term removal of [`specialize`] see it — a matte material loses its
/// specular term, its textures and its pass. Returns what was bound, as
/// `Removed` entries of kind `uniform`, and the uniforms whose value did not
/// fit their type (left as uniforms).
pub fn bind_uniforms(
    m: &mut Module,
    values: &std::collections::BTreeMap<String, Vec<f32>>,
    at: &dyn Fn(Span) -> String,
) -> (Vec<Removed>, Vec<String>) {
    let mut map = HashMap::default();
    let mut bound = Vec::new();
    let mut mismatched = Vec::new();
    for (id, u) in m.uniforms.clone().iter().enumerate() {
        let Some(v) = values.get(&u.name) else { continue };
        let width = u.ty.width().min(4);
        let comps: Vec<f64> = match v.len() {
            1 => vec![v[0] as f64; width],
            n if n == width => v.iter().map(|x| *x as f64).collect(),
            _ => {
                mismatched.push(format!(
                    "`{}` is a {} but the scene gives {} value(s)",
                    u.name,
                    u.ty.name(),
                    v.len()
                ));
                continue;
            }
        };
        let Some(node) = m.exprs.find(&Expr::Uniform(id as u32)) else { continue };
        let Ok(c) = m.intern(Expr::Constant(crate::ir::Constant::new(u.ty, &comps)), u.span) else {
            continue;
        };
        map.insert(node, c);
        bound.push(Removed {
            kind: "uniform".into(),
            what: u.name.clone(),
            why: format!("the scene sets it to {comps:?}: folded as a constant"),
            at: at(u.span),
        });
    }
    if !map.is_empty() {
        for i in 0..m.statements.len() {
            let v = m.statements[i].value;
            if let Some(nv) = super::substitute(m, v, &map) {
                m.statements[i].value = nv;
            }
        }
    }
    (bound, mismatched)
}

/// What scene-driven specialization removed from one program on one scene
///: the data `shadec bench` prints and
/// `shadec compile --scene` lists.
#[derive(Clone, Debug, PartialEq)]
pub struct RemovalReport {
    pub target: String,
    pub lights: usize,
    pub objects: usize,
    /// Passes of the program on the scene, one per light, before specialization.
    pub passes_before: usize,
    /// Passes after folding, zero-term removal and light culling.
    pub passes_after: usize,
    /// Mesh draws (a pass drawn for an object) before and after: light
    /// culling skips a light's pass for the objects it cannot reach.
    pub draws_before: usize,
    pub draws_after: usize,
    /// (light, object) pairs skipped by light culling.
    pub lights_culled: usize,
    /// Every entry of the specialized plan's `removed`.
    pub removed: Vec<Removed>,
}

impl RemovalReport {
    /// A Markdown section: the counts, then one row per removal.
    pub fn to_markdown(&self) -> String {
        let mut s = format!(
            "| target | lights | objects | passes | mesh draws | lights culled (light × object) |\n|---|---|---|---|---|---|\n| {} | {} | {} | {} → {} | {} → {} | {} |\n\n",
            self.target, self.lights, self.objects, self.passes_before, self.passes_after, self.draws_before, self.draws_after, self.lights_culled
        );
        if self.removed.is_empty() {
            s += "Nothing removed.\n";
            return s;
        }
        s += "| kind | what | why | at |\n|---|---|---|---|\n";
        for r in &self.removed {
            let cell = |t: &str| t.replace('|', "\\|");
            s += &format!("| {} | {} | {} | {} |\n", r.kind, cell(&r.what), cell(&r.why), r.at);
        }
        s
    }
}

/// Mesh draws of a plan on a scene with `objects` objects.
pub fn draws(plan: &super::PassPlan, objects: usize) -> usize {
    plan.passes
        .iter()
        .map(|p| match p.geometry {
            super::Geometry::Mesh { .. } => p.objects.as_ref().map_or(objects, |o| o.len()),
            _ => 1,
        })
        .sum()
}
