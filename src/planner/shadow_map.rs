//! The shadow map's depth test on a target with depth textures (GeForce3:
//! SGIX_depth_texture and SGIX_shadow, later ARB_depth_texture and
//! ARB_shadow). Williams 1978's test, as Pipeline Grammar, Section 3.5
//! writes it at the pixel,
//!
//! ```text
//! α C xs ← (z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b
//! ```
//!
//! takes each pixel back to the model (`π⁻¹`) and into the light's view
//! (`πl`). A GeForce3 did not invert the camera per pixel: it drew the
//! scene's meshes again with the depth test `Equal` (the pixel is the
//! fragment that wrote C's depth, so `π⁻¹ xs` is the interpolated vertex
//! position `δ x`), with texture coordinates `πl x` generated per vertex
//! (eye-linear texgen with the light's matrices); the texture unit divided
//! them by q and compared `r/q` with the depth texel (`r ≤ texel` → 1, lit).
//! So the statement is rewritten here into that pass, `α C δπx ←
//! (z δπl x) > (z Cl δπl x) + b`, which is the same value at every pixel
//! the meshes cover (`δ` is perspective-correct and `πl` projective, so
//! `δ πl x = πl δ x`), and the compare result `(z δπl x) ≤ (z Cl δπl x) + b`
//! is what the unit's register holds ([`compare_node`]).
//!
//! On a combiner target without depth textures (GeForce 256) the same
//! redraw runs as the lowering's rule `alpha_ramp_shadow_map`
//! (`lowering::alpha_ramp`): both depths encoded in an 8-bit ramp and
//! compared in the combiners; [`equal_depth`] gives its pass the `Equal`
//! depth test too.
//!
//! The example's printed test, `(z C xs) > (z Cl πl π⁻¹ xs)`, compares the
//! camera's depth with the light's: the unit's `r/q` shares q with `s/q`
//! and `t/q`, so it cannot be the camera's depth; that form is left to the
//! code generator, which refuses it, located.

use rustc_hash::FxHashMap as HashMap;

use crate::ir::{BinaryOp, Constant, Expr, FbChannel, Frequency, Handle, Module, Table};
use crate::pipeline::{DepthState, Pass};
use crate::profile::{FragmentStage, Profile};

/// Rewrites every statement at the pixel whose value is Williams's test
/// through `πl π⁻¹ xs` into a pass over the meshes an earlier statement
/// projected into the same framebuffer, on a combiner target with depth
/// textures. Returns the indices of the statements rewritten.
pub fn redraw_over_geometry(m: &mut Module, profile: &Profile) -> Vec<usize> {
    if !profile.depth_textures || !matches!(profile.fragment, FragmentStage::Combiners(_)) {
        return Vec::new();
    }
    let mut done = Vec::new();
    for i in 0..m.statements.len() {
        if let Some((index, value)) = rewritten(m, i) {
            let st = &mut m.statements[i];
            st.index = index;
            st.value = value;
            st.freq = Frequency::Fragment;
            done.push(i);
        }
    }
    // The tests now read depth textures at interpolated coordinates: a
    // `≤` among them, bare or selecting, takes the unit's form too.
    for &i in &done {
        tests_as_greater(m, i, true);
    }
    done
}

/// Writes every selection on a depth-texture test in the form the texture
/// unit compares, `a > d (+ b)`: `a ≤ d (+ b) ? x : y` as `a > d (+ b) ?
/// y : x`, and `d (+ b) ≥ a`, `d (+ b) < a` with their sides exchanged.
/// The same value (depths are never NaN): ARB_shadow's `LEQUAL` returns
/// `a ≤ d`, and which branch is the lit one is the combiners' choice. The
/// unit's result, `a ≤ d (+ b)`, is interned for every test
/// ([`compare_node`] finds it).
pub fn depth_tests_as_greater(m: &mut Module) {
    for i in 0..m.statements.len() {
        tests_as_greater(m, i, false);
    }
}

/// [`depth_tests_as_greater`] of statement `i`; with `bare`, a test
/// written as a value too ([`bare_tests_as_greater`]: only in a statement
/// [`redraw_over_geometry`] rewrote, whose value is the shadow mask — a
/// stencil statement's depth comparison is the depth test's, not a unit's).
fn tests_as_greater(m: &mut Module, i: usize, bare: bool) {
    let value = m.statements[i].value;
    let mut map = HashMap::default();
    let reach = m.reachable(&[value]);
    if bare {
        bare_tests_as_greater(m, &reach, &mut map);
    }
    for h in reach {
        let Expr::Select { cond, accept, reject } = m.exprs[h] else { continue };
        let Some((greater, swap)) = as_greater(m, cond) else { continue };
        let (accept, reject) = match (swap, reject) {
            (false, reject) => (accept, reject),
            (true, Some(reject)) => (reject, Some(accept)),
            (true, None) => continue,
        };
        let span = m.span(h);
        if let Ok(select) = m.intern(Expr::Select { cond: greater, accept, reject }, span) {
            map.insert(h, select);
        }
    }
    if let Some(value) = (!map.is_empty()).then(|| super::substitute(m, value, &map)).flatten() {
        m.statements[i].value = value;
    }
    compare_nodes(m, m.statements[i].value);
}

/// A depth test written as a value, not as a selection's condition (the
/// shadow mask `α C xs ← (z πl π⁻¹ xs) ≤ (z Cl πl π⁻¹ xs) + b`): `a ≤ d`
/// is `a > d ? 0 : 1` and `d < a` is `a > d`, the unit's form, entered in
/// `map` for [`depth_tests_as_greater`] to substitute.
fn bare_tests_as_greater(
    m: &mut Module,
    reach: &[Handle<Expr>],
    map: &mut HashMap<Handle<Expr>, Handle<Expr>>,
) {
    let conds: Vec<Handle<Expr>> = reach
        .iter()
        .filter_map(|&h| if let Expr::Select { cond, .. } = m.exprs[h] { Some(cond) } else { None })
        .collect();
    for &h in reach {
        if conds.contains(&h) {
            continue;
        }
        let Some((greater, swap)) = as_greater(m, h) else { continue };
        let span = m.span(h);
        let replaced = if swap {
            let (Ok(zero), Ok(one)) = (
                m.intern(Expr::Constant(Constant::scalar(0.0)), span),
                m.intern(Expr::Constant(Constant::scalar(1.0)), span),
            ) else {
                continue;
            };
            match m.intern(Expr::Select { cond: greater, accept: zero, reject: Some(one) }, span) {
                Ok(select) => select,
                Err(_) => continue,
            }
        } else {
            greater
        };
        map.insert(h, replaced);
    }
}

/// `cond` as the unit's `a > d (+ b)` and whether the branches exchange,
/// for a comparison with a depth-texture read on one side; `None` for one
/// already in that form or not a depth test.
fn as_greater(m: &mut Module, cond: Handle<Expr>) -> Option<(Handle<Expr>, bool)> {
    let Expr::Binary { op, lhs, rhs } = m.exprs[cond] else { return None };
    let (a, d, swap) = match op {
        BinaryOp::Le if depth_texture_read(m, rhs).is_some() => (lhs, rhs, true),
        BinaryOp::Ge if depth_texture_read(m, lhs).is_some() => (rhs, lhs, true),
        BinaryOp::Lt if depth_texture_read(m, lhs).is_some() => (rhs, lhs, false),
        _ => return None,
    };
    let span = m.span(cond);
    let greater = m.intern(Expr::Binary { op: BinaryOp::Gt, lhs: a, rhs: d }, span).ok()?;
    Some((greater, swap))
}

/// The new index and value of statement `i`, if it is a depth test
/// through `πl π⁻¹ xs` at the pixel and an earlier statement drew meshes
/// into its framebuffer.
fn rewritten(m: &mut Module, i: usize) -> Option<(Handle<Expr>, Handle<Expr>)> {
    let st = m.statements[i].clone();
    let Table::Framebuffer { id, .. } = st.table else { return None };
    let Expr::Pixel { freq: Frequency::Screen } = m.exprs[st.index] else { return None };
    let reach = m.reachable(&[st.value]);
    // Every use of the pixel is `πl π⁻¹ xs`, and a depth texture is read there.
    let through = |h: Handle<Expr>| match m.exprs[h] {
        Expr::Project { ref projection, value } if !projection.inverse => match m.exprs[value] {
            Expr::Project { projection: ref inv, value: p } if inv.inverse && p == st.index => Some(value),
            _ => None,
        },
        _ => None,
    };
    let reprojected: Vec<Handle<Expr>> = reach.iter().copied().filter(|&h| through(h).is_some()).collect();
    let inverses: Vec<Handle<Expr>> = reprojected.iter().filter_map(|&h| through(h)).collect();
    let reads_depth = reach.iter().any(|&h| {
        matches!(m.exprs[h], Expr::FramebufferRead { channel: FbChannel::Depth, position, .. } if reprojected.contains(&position))
    });
    let other_pixel_use =
        reach.iter().any(|&h| !inverses.contains(&h) && m.exprs[h].operands().contains(&st.index));
    if !reads_depth || other_pixel_use {
        return None;
    }
    let index = earlier_mesh_index(m, i, id)?;
    let Expr::Interpolate { value: clip, .. } = m.exprs[index] else { return None };
    let Expr::Project { value: vertex, .. } = m.exprs[clip] else { return None };
    let mut map = HashMap::default();
    for &h in &reprojected {
        let Expr::Project { ref projection, .. } = m.exprs[h] else { continue };
        let light = Expr::Project { projection: projection.clone(), value: vertex };
        let span = m.span(h);
        let per_vertex = m.intern(light, span).ok()?;
        let interpolated =
            m.intern(Expr::Interpolate { value: per_vertex, to: Frequency::Fragment }, span).ok()?;
        map.insert(h, interpolated);
    }
    let value = super::substitute(m, st.value, &map)?;
    compare_nodes(m, value);
    Some((index, value))
}

/// The index (`δπx`) of the last statement before `i` that drew meshes
/// into framebuffer `id`.
fn earlier_mesh_index(m: &Module, i: usize, id: u32) -> Option<Handle<Expr>> {
    m.statements[..i].iter().rev().find_map(|s| match s.table {
        Table::Framebuffer { id: f, .. }
            if f == id && matches!(m.exprs[s.index], Expr::Interpolate { .. }) =>
        {
            Some(s.index)
        }
        _ => None,
    })
}

/// Interns, for every depth test `a > d` (or `a > d + b`) of `value`
/// whose `d` reads a depth texture at interpolated coordinates, the
/// compare result `a ≤ d (+ b)` the texture unit returns (ARB_shadow's
/// `TEXTURE_COMPARE_FUNC` `LEQUAL`, the bias folded into r by the texgen).
fn compare_nodes(m: &mut Module, value: Handle<Expr>) {
    for h in m.reachable(&[value]) {
        if let Expr::Binary { op: BinaryOp::Gt, lhs, rhs } = m.exprs[h] {
            if depth_texture_read(m, rhs).is_some() {
                let span = m.span(h);
                let _ = m.intern(Expr::Binary { op: BinaryOp::Le, lhs, rhs }, span);
            }
        }
    }
}

/// The depth-texture read of `d` or `d + b` (`b` a constant): a read of a
/// framebuffer's depth at coordinates interpolated from the vertices,
/// which is what a texture unit with a depth texture can compare.
pub fn depth_texture_read(m: &Module, rhs: Handle<Expr>) -> Option<Handle<Expr>> {
    let read = match m.exprs[rhs] {
        Expr::Binary { op: BinaryOp::Add, lhs, rhs: b } if matches!(m.exprs[b], Expr::Constant(_)) => lhs,
        _ => rhs,
    };
    match m.exprs[read] {
        Expr::FramebufferRead { channel: FbChannel::Depth, position, .. }
            if matches!(m.exprs[position], Expr::Interpolate { .. }) =>
        {
            Some(read)
        }
        _ => None,
    }
}

/// The node whose value the texture unit serving `read` returns, if
/// `read` is a depth texture compared in `output`: `a ≤ d (+ b)`, 1 where
/// the fragment is lit (interned by [`redraw_over_geometry`]).
pub fn compare_node(m: &Module, output: Handle<Expr>, read: Handle<Expr>) -> Option<Handle<Expr>> {
    m.reachable(&[output]).into_iter().find_map(|h| match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Gt, lhs, rhs } if depth_texture_read(m, rhs) == Some(read) => {
            m.exprs.find(&Expr::Binary { op: BinaryOp::Le, lhs, rhs })
        }
        _ => None,
    })
}

/// The passes that compare a depth texture over a framebuffer whose depth
/// an earlier pass wrote test depth `Equal` without writing: their
/// fragment is the one that wrote the framebuffer's depth (the redraw of
/// Kilgard 2000, Section 5), not a nearer one of its own. The first pass
/// to draw into a framebuffer keeps its own depth test (nothing is there
/// to be equal to: `Equal` against the cleared depth drew nothing).
pub fn equal_depth(m: &Module, passes: &mut [Pass]) {
    use crate::pipeline::RenderTarget;
    // Framebuffers by name: a later pass may write other channels.
    let name = |t: &RenderTarget| match t {
        RenderTarget::Framebuffer { name, .. }
        | RenderTarget::Texture { name }
        | RenderTarget::Temporary { name } => name.clone(),
    };
    let mut depth_written: Vec<String> = Vec::new();
    for pass in passes.iter_mut() {
        let output = Handle::new(pass.fragment.output as usize);
        let reach = m.reachable(&[output]);
        let compares = reach.iter().any(|&h| {
            matches!(m.exprs[h], Expr::Binary { op: BinaryOp::Gt, rhs, .. } if depth_texture_read(m, rhs).is_some())
        }) || ramp_compare(m, &reach);
        let mesh = matches!(pass.geometry, crate::pipeline::Geometry::Mesh { .. });
        if compares && mesh && depth_written.contains(&name(&pass.target)) {
            pass.state.depth = DepthState::EQUAL_NO_WRITE;
        }
        if mesh && pass.state.depth.write && !depth_written.contains(&name(&pass.target)) {
            depth_written.push(name(&pass.target));
        }
    }
}

/// Whether the nodes `reach` of a pass are the alpha-ramp compare of
/// rule `alpha_ramp_shadow_map` (GeForce 256): the ramp read at the
/// fragment's own depth from the light and a framebuffer's alpha read at
/// the light's interpolated projection — a redraw over the meshes, whose
/// fragment must be the one that wrote the camera's depth.
fn ramp_compare(m: &Module, reach: &[Handle<Expr>]) -> bool {
    let ramp = reach.iter().any(|&h| {
        matches!(m.exprs[h], Expr::Lookup { texture, .. }
            if m.textures[texture as usize].name.starts_with(crate::lowering::alpha_ramp::RAMP) && m.textures[texture as usize].baked)
    });
    let projected = reach.iter().any(|&h| {
        matches!(m.exprs[h], Expr::FramebufferRead { channel: FbChannel::Alpha, position, .. }
            if matches!(m.exprs[position], Expr::Interpolate { .. }))
    });
    ramp && projected
}

/// The texture unit whose depth comparison is the condition `cond` of a
/// register-combiner pass, if it is one: `cond` is `(z P) > (z T P)` or
/// `(z P) > (z T P) + b`, where the unit reads depth texture T at the
/// interpolated coordinates P and compares their own `r/q` with it —
/// the only depth a texture unit compares (ARB_shadow). The unit's
/// register holds the compare result, 1 where the fragment is lit, so
/// the condition holds where it is below ½.
pub fn compare_unit(m: &Module, units: &[Handle<Expr>], cond: Handle<Expr>) -> Option<usize> {
    let Expr::Binary { op: BinaryOp::Gt, lhs, rhs } = m.exprs[cond] else { return None };
    let read = depth_texture_read(m, rhs)?;
    let Expr::FramebufferRead { position, .. } = m.exprs[read] else { return None };
    if !matches!(m.exprs[lhs], Expr::Depth(p) if p == position) {
        return None;
    }
    units.iter().position(|&u| u == read)
}

/// Why a depth comparison has no combiner setup: what each target had,
/// and the forms that plan.
pub const REFUSAL_HELP: &str = "the register combiners cannot read a depth buffer. geforce3's depth textures (SGIX_shadow / ARB_shadow) compare a texel only with the r/q of the coordinates it is read at, interpolated from the vertices with the light's q — the point's own depth from the light, never the camera's depth `z C xs` (on geforce3 the printed comparison `(z C xs) > (z Cl πl π⁻¹ xs)` without a bias plans by the depth test instead); write Williams's test `(z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + b` (redrawn over the meshes) or `(z δπl x) > (z Cl δπl x)`. geforce256 has no depth textures (SGIX_shadow came with the GeForce3): Williams's test plans there only as an approximation, both depths from the light encoded in an 8-bit alpha ramp and compared in the combiners (rule `alpha_ramp_shadow_map`, which --no-approx refuses); or target wgsl (docs/shadow-maps.md)";
