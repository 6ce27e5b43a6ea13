//! The shadow mask as Pipeline Grammar, Section 3.5 prints it, on a
//! GeForce3 (Williams 1978's shadow map, the comparison done by the
//! depth test):
//!
//! ```text
//! α C xs ← (z C xs) > (z Cl πl π⁻¹ xs)
//! ```
//!
//! compares the camera's depth `z C xs` with the light's depth read at the
//! pixel taken back to the model and into the light's view. A depth
//! texture's compare unit (SGIX_shadow / ARB_shadow) compares only the r/q
//! of its own coordinates, never the camera's depth; the one unit that
//! reads the camera's depth buffer is the depth test. So the GeForce3 draws
//! the meshes again (the pass of Kilgard 2000, Section 5, with texture
//! coordinates `πl x` generated per vertex, as `super::shadow_map` does)
//! and replaces each fragment's depth by the light's depth at its light
//! coordinates, NV_texture_shader's `DOT_PRODUCT_DEPTH_REPLACE_NV`:
//!
//! - unit 0, `texture_2d()`: the light's depth map at (s/q, t/q), stored by
//!   the light's pass as a colour — D = ⌊65535·d⌋ as its high byte in red,
//!   low byte in green, blue = 1 ([`DEPTH_STEPS`]);
//! - unit 1, `dot_product_depth_replace_1of2(tex0)` with the constant
//!   coordinates (255·256/65535, 255/65535, 0): z = D/65535;
//! - unit 2, `dot_product_depth_replace_2of2(tex0)` with (0, 0, 1):
//!   w = blue = 1; the fragment's depth is z/w.
//!
//! The depth test `GEQUAL` against the camera's depth buffer (no depth
//! write) then passes exactly where `(z C xs) > (z Cl …)` is false, and the
//! pass writes α C = 0 there. The statement that drew the meshes into `C`
//! left α C = 1 (it wrote a colour without alpha), so α C is 1 where the
//! test holds. The rewritten statement is `α C δπx ← 0` over the meshes;
//! the replaced depth is [`DepthReplaced::depth`], the pass's
//! `fragment.depth` in the plan.
//!
//! What it costs against the meaning: the light's depth is 16 bits
//! (quantized down by less than 1/65535), and every fragment a mesh puts on
//! the pixel takes the test — a hidden surface behind the visible one takes
//! it with its own light depth, and one that passes writes α C = 0 where
//! the visible point alone would have left 1 (docs/shadow-maps.md gives
//! the counts measured).

use crate::ir::{BinaryOp, Constant, Expr, FbChannel, Frequency, Handle, MathFunction, Module, Table};
use crate::pipeline::{CompareFunc, DepthState, Pass, PassPlan, TextureBinding};
use crate::profile::{FragmentStage, Profile};

/// The light's depth as the texture shader rebuilds it: D/65535 with
/// D = ⌊65535·d⌋, the two bytes of the light pass's colour.
pub const DEPTH_STEPS: f64 = 65535.0;

/// A statement rewritten into a depth-replacing redraw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthReplaced {
    /// The statement's index in the module.
    pub statement: usize,
    /// The light's depth read at the interpolated light coordinates.
    pub read: Handle<Expr>,
    /// The depth each fragment gets: the read rebuilt from 16 bits.
    pub depth: Handle<Expr>,
}

/// Whether `profile` replaces fragment depths by a texture shader's dot
/// products: register combiners with NV_texture_shader's dot products.
pub fn available(profile: &Profile) -> bool {
    matches!(profile.fragment, FragmentStage::Combiners(_))
        && profile.texture_shaders.as_ref().is_some_and(|t| t.dot_product)
}

/// Rewrites every printed shadow-mask test into a redraw over the meshes
/// whose fragments take the light's depth, on a target that has
/// `DOT_PRODUCT_DEPTH_REPLACE`. Returns what was rewritten.
pub fn redraw_with_replaced_depth(m: &mut Module, profile: &Profile) -> Vec<DepthReplaced> {
    if !available(profile) {
        return Vec::new();
    }
    (0..m.statements.len()).filter_map(|i| rewrite(m, i)).collect()
}

/// Statement `i` rewritten, if it is `α C xs ← (z C xs) > (z Cl πl π⁻¹ xs)`
/// after a statement that drew the meshes into C with α = 1.
fn rewrite(m: &mut Module, i: usize) -> Option<DepthReplaced> {
    let st = m.statements[i].clone();
    let Table::Framebuffer { id, channel: FbChannel::Alpha } = st.table else { return None };
    let Expr::Pixel { freq: Frequency::Screen } = m.exprs[st.index] else { return None };
    let Expr::Binary { op: BinaryOp::Gt, lhs, rhs } = m.exprs[st.value] else { return None };
    let Expr::FramebufferRead { framebuffer, channel: FbChannel::Depth, position } = m.exprs[lhs] else {
        return None;
    };
    if framebuffer != id || position != st.index {
        return None;
    }
    let Expr::FramebufferRead { framebuffer: light, channel: FbChannel::Depth, position: at } = m.exprs[rhs]
    else {
        return None;
    };
    let projection = light_projection_of_pixel(m, at, st.index)?;
    let index = mesh_index_with_opaque_alpha(m, i, id)?;
    let Expr::Interpolate { value: clip, .. } = m.exprs[index] else { return None };
    let Expr::Project { value: vertex, .. } = m.exprs[clip] else { return None };
    let span = m.span(st.value);
    let per_vertex = m.intern(Expr::Project { projection, value: vertex }, span).ok()?;
    let coords = m.intern(Expr::Interpolate { value: per_vertex, to: Frequency::Fragment }, span).ok()?;
    let read = m
        .intern(
            Expr::FramebufferRead { framebuffer: light, channel: FbChannel::Depth, position: coords },
            span,
        )
        .ok()?;
    let depth = encoded(m, read, span)?;
    let zero = m.intern(Expr::Constant(Constant::scalar(0.0)), span).ok()?;
    let st = &mut m.statements[i];
    st.index = index;
    st.value = zero;
    st.freq = Frequency::Fragment;
    Some(DepthReplaced { statement: i, read, depth })
}

/// `πl` when `at` is `πl π⁻¹ pixel`.
fn light_projection_of_pixel(
    m: &Module,
    at: Handle<Expr>,
    pixel: Handle<Expr>,
) -> Option<crate::ir::Projection> {
    let Expr::Project { ref projection, value } = m.exprs[at] else { return None };
    if projection.inverse {
        return None;
    }
    match m.exprs[value] {
        Expr::Project { projection: ref inv, value: p } if inv.inverse && p == pixel => {
            Some(projection.clone())
        }
        _ => None,
    }
}

/// The index (`δπx`) of the last statement before `i` that drew meshes
/// into framebuffer `id`, when it wrote a colour without alpha (α = 1)
/// and nothing after it, before `i`, writes `id`.
fn mesh_index_with_opaque_alpha(m: &Module, i: usize, id: u32) -> Option<Handle<Expr>> {
    let writes = |s: &crate::ir::Statement| matches!(s.table, Table::Framebuffer { id: f, .. } if f == id);
    let last = m.statements[..i].iter().rposition(writes)?;
    let s = &m.statements[last];
    // A colour without alpha, written as is or converted to RGBA (α = 1).
    let rgb = |h: Handle<Expr>| m.info(h).ty.width() == 3;
    let opaque = matches!(s.table, Table::Framebuffer { channel: FbChannel::Color, .. })
        && (rgb(s.value) || matches!(m.exprs[s.value], Expr::Convert { value, .. } if rgb(value)));
    (opaque && matches!(m.exprs[s.index], Expr::Interpolate { .. })).then_some(s.index)
}

/// `⌊65535·d⌋ / 65535`: the depth the dot products rebuild from the two
/// bytes the light's pass stored.
fn encoded(m: &mut Module, read: Handle<Expr>, span: crate::span::Span) -> Option<Handle<Expr>> {
    let steps = m.intern(Expr::Constant(Constant::scalar(DEPTH_STEPS)), span).ok()?;
    let scaled = m.intern(Expr::Binary { op: BinaryOp::Mul, lhs: read, rhs: steps }, span).ok()?;
    let floor = m.intern(Expr::Math { fun: MathFunction::Floor, args: vec![scaled] }, span).ok()?;
    m.intern(Expr::Binary { op: BinaryOp::Div, lhs: floor, rhs: steps }, span).ok()
}

/// The depth a texture shader gives the fragments of a pass whose unit
/// reads `read`, if a shadow-mask rewrite made one (the node exists only
/// then: the arena is hash-consed).
pub fn replaced_depth(m: &Module, read: Handle<Expr>) -> Option<Handle<Expr>> {
    if !matches!(m.exprs[read], Expr::FramebufferRead { channel: FbChannel::Depth, .. }) {
        return None;
    }
    let steps = m.exprs.find(&Expr::Constant(Constant::scalar(DEPTH_STEPS)))?;
    let scaled = m.exprs.find(&Expr::Binary { op: BinaryOp::Mul, lhs: read, rhs: steps })?;
    let floor = m.exprs.find(&Expr::Math { fun: MathFunction::Floor, args: vec![scaled] })?;
    m.exprs.find(&Expr::Binary { op: BinaryOp::Div, lhs: floor, rhs: steps })
}

/// Each rewritten statement's pass: depth test `GEQUAL` without writing,
/// the fragment's depth replaced, the light's map on unit 0. Returns the
/// indices of the passes changed (their combiner setup must be made again
/// with the unit).
pub fn depth_replacing_passes(m: &Module, plan: &mut PassPlan, replaced: &[DepthReplaced]) -> Vec<usize> {
    let mut changed = Vec::new();
    for (k, pass) in plan.passes.iter_mut().enumerate() {
        let Some(r) = replaced.iter().find(|r| pass.statements == [r.statement]) else { continue };
        if set_replaced(m, pass, r) {
            changed.push(k);
        }
    }
    changed
}

fn set_replaced(m: &Module, pass: &mut Pass, r: &DepthReplaced) -> bool {
    let Expr::FramebufferRead { framebuffer, position, .. } = m.exprs[r.read] else { return false };
    let Some(fb) = m.framebuffers.get(framebuffer as usize) else { return false };
    if !matches!(pass.geometry, crate::pipeline::Geometry::Mesh { .. }) {
        return false;
    }
    pass.state.depth = DepthState { func: CompareFunc::GreaterEqual, write: false };
    pass.fragment.depth = Some(r.depth.index() as u32);
    // The light's coordinates `δπl x`, interpolated for unit 0.
    pass.vertex.interpolants = vec![position.index() as u32];
    pass.textures = vec![TextureBinding {
        unit: 0,
        texture: fb.name.clone(),
        lookup: r.read.index() as u32,
        coords: position.index() as u32,
    }];
    true
}
