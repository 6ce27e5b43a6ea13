//! Rule `solid_texture_3d`: solid mapping (Pipeline Grammar, Section 3.7,
//! eq. (15)-(16), after Carr et al. 2000) on a target with 3-D textures
//! and no float formats (GeForce3), planned for a scene.
//!
//! As written, (15) rasterizes the object-space position `δ P` into a
//! float texture `T` and (16) replaces each texel by `p` of it. The
//! compiler cannot choose an 8-bit form of positions of unknown range; the
//! scene's object bounds give it one. The GeForce3 way of a procedural
//! solid texture is a 3-D texture (OpenGL 1.2's TEXTURE_3D, the texture
//! shader's `texture_3d()` stage of NV_texture_shader2) indexed by the
//! position mapped into [0, 1]³: so `p` over the bounds' box is baked by
//! the compiler into an RGBA8 3-D texture of [`solid::SIDE`]² ×
//! [`solid::SLICES`] texels (the box's corners at the first and last texel
//! centres), and (15) writes that texture read at the interpolated,
//! box-mapped position — an affine map per vertex, so interpolation keeps
//! it exact. (16) is then already done: `p` of each texel is what (15)
//! wrote, and `T` holds colours in [0, 1] (stored RGBA8 by
//! [`super::float_texture`]).
//!
//! Error bound: measured when the compiler bakes — the largest difference
//! between `p` and the 8-bit volume read back trilinearly, over
//! [`PROBES`] places of the box. Where (15) leaves texels of `T` unwritten,
//! (16) as written shades them with `p` of a zero position and this rule
//! leaves them cleared: a filtered lookup at the border of what (15) drew
//! mixes them, which the bound does not cover.
//!
//! Without a scene there are no bounds and the float texture keeps the
//! planner's located refusal; a target without 3-D textures (GeForce 256)
//! keeps it too.

use super::Rewriter;
use crate::ir::eval::{Env, Evaluator, Value};
use crate::ir::{
    BinaryOp, Constant, Expr, Frequency, Handle, MathFunction, Sampling, Statement, Table, Texture, Ty,
};
use crate::numerics::Precision;
use crate::parser::ast::{Space, TextureFormat, TextureKind, VectorKind};
use crate::pipeline::ApproximationCost;
use crate::span::Span;
use crate::textures::solid;

/// Places of the box at which the compiler measures the volume's error.
pub const PROBES: usize = 4096;

// The renderer renders a baked texture at this size: the tiled volume.
const _: () = assert!(solid::GRID == crate::pipeline::RENDERED_TEXTURE_SIZE);

/// The box of object space the scene's meshes fill.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
}

impl Bounds {
    /// The object-space bounds of `meshes` (`None` without a vertex).
    pub fn of_meshes(meshes: &[(crate::scene::mesh::Mesh, glam::Mat4)]) -> Option<Bounds> {
        let mut points = meshes.iter().flat_map(|(m, _)| m.positions.iter());
        let first = points.next()?;
        let (mut lo, mut hi) = (*first, *first);
        for p in points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let f = |v: glam::Vec3| [v.x as f64, v.y as f64, v.z as f64];
        Some(Bounds { lo: f(lo), hi: f(hi) })
    }

    /// The box's side per axis (a flat box is given a unit side, so the
    /// map stays finite).
    fn extent(&self) -> [f64; 3] {
        std::array::from_fn(|k| if self.hi[k] > self.lo[k] { self.hi[k] - self.lo[k] } else { 1.0 })
    }
}

/// (15) and (16) of one float texture, found by [`matched`].
struct SolidMap {
    write: usize,
    shade: usize,
    /// The per-vertex object-space position (15) interpolates.
    position: Handle<Expr>,
    /// (16)'s read of the stored position (`fat-member 0` of its texel).
    read: Handle<Expr>,
}

/// Bakes every solid map of the program into a 3-D texture when the
/// rewriter has the scene's bounds and the target 3-D textures.
pub fn apply(r: &mut Rewriter) {
    let Some(bounds) = r.bounds else { return };
    if !r.profile.textures_3d || r.profile.float_textures {
        return;
    }
    for t in 0..r.m.textures.len() as u32 {
        if let Some(found) = matched(r, t) {
            rewrite(r, t, &found, bounds);
        }
    }
}

/// `T δu x ← δ P` then `T δu ← p T δu` on float texture `t`, with P an
/// object-space position and `p` a function of it and constants only.
fn matched(r: &Rewriter, t: u32) -> Option<SolidMap> {
    let m = &r.m;
    let texture = &m.textures[t as usize];
    if texture.kind != TextureKind::Tex2d || !texture.format.is_wide() || !texture.rendered || texture.baked {
        return None;
    }
    let writes: Vec<usize> =
        (0..m.statements.len()).filter(|&i| m.statements[i].table == Table::Texture(t)).collect();
    let [write, shade] = writes[..] else { return None };
    let (w, s) = (&m.statements[write], &m.statements[shade]);
    if w.freq != Frequency::Texel
        || s.freq != Frequency::Texel
        || !matches!(m.exprs[s.index], Expr::TexelCoord)
    {
        return None;
    }
    let written = match &m.exprs[w.value] {
        Expr::Bundle(members) if members.len() == 1 => members[0],
        _ => return None,
    };
    let Expr::Interpolate { value: position, .. } = m.exprs[written] else { return None };
    let Expr::Vector { vector, .. } = m.exprs[position] else { return None };
    let v = &m.vectors[vector as usize];
    if v.kind != Some(VectorKind::Position) || v.space != Some(Space::Object) {
        return None;
    }
    let texel = m.exprs.find(&Expr::Lookup { texture: t, coords: s.index })?;
    let read = m.exprs.find(&Expr::FatMember { texel, member: 0 })?;
    // p reads the stored position and constants only; its colour is one
    // an 8-bit texture holds.
    let reach = m.reachable(&[s.value]);
    let pure = reach.iter().all(|&h| {
        h == read || h == texel || h == s.index || crate::ir::eval::is_pure_arithmetic(&m.exprs[h])
    });
    let users_of_texel = reach.iter().filter(|&&h| m.operands(h).contains(&texel)).all(|&h| h == read);
    let iv = m.info(s.value).interval;
    (pure && users_of_texel && iv.lo >= 0.0 && iv.hi <= 1.0).then_some(SolidMap {
        write,
        shade,
        position,
        read,
    })
}

/// (15) writes the baked 3-D texture read at the box-mapped position;
/// (16) goes; the 3-D texture's texel statement runs first.
fn rewrite(r: &mut Rewriter, t: u32, found: &SolidMap, bounds: Bounds) -> Option<()> {
    let (w, s) = (r.m.statements[found.write].clone(), r.m.statements[found.shade].clone());
    let bound = measure(r, &s, bounds)?;
    let span = s.span;
    let texel_value = texel_function(r, &s, found.read, bounds, span)?;
    let name = format!("{}_solid", r.m.textures[t as usize].name);
    r.m.textures.push(Texture {
        name: name.clone(),
        kind: TextureKind::Tex3d,
        format: TextureFormat::Rgba8,
        rendered: true,
        baked: true,
        declaration: None,
        copy_of: None,
        tabulates: None,
        sampling: Sampling::ADDED,
        span: Span::DETACHED,
    });
    let id = (r.m.textures.len() - 1) as u32;
    let coords = coordinates(r, found.position, bounds, w.span)?;
    let looked_up = r.node(Expr::Lookup { texture: id, coords }, w.span)?;
    let table = Statement {
        table: Table::Texture(id),
        index: s.index,
        freq: Frequency::Texel,
        value: texel_value,
        span,
        target_span: s.target_span,
    };
    let mut statements: Vec<Statement> = r.m.statements.iter().cloned().collect();
    statements[found.write] = Statement { value: looked_up, ..w };
    statements.remove(found.shade);
    statements.insert(found.write, table);
    r.m.statements = statements.into();
    let (lo, hi) = (bounds.lo, bounds.hi);
    r.record(
        "solid_texture_3d",
        span,
        Some(looked_up),
        format!(
            "the solid texture is a {}×{}×{} 8-bit 3-D texture of the shader over the scene's object bounds \
             ({:.3}, {:.3}, {:.3})–({:.3}, {:.3}, {:.3}), baked by the compiler and read trilinearly at the \
             interpolated position mapped into [0, 1]³",
            solid::SIDE,
            solid::SIDE,
            solid::SLICES,
            lo[0],
            lo[1],
            lo[2],
            hi[0],
            hi[1],
            hi[2]
        ),
        ApproximationCost {
            texture_units: 1,
            passes: 0,
            general_combiners: 0,
            texels: (solid::GRID as u64).pow(2),
        },
        Some(bound),
    );
    Some(())
}

/// The measured error of the 8-bit volume of (16)'s `p` over the box.
fn measure(r: &Rewriter, s: &Statement, bounds: Bounds) -> Option<f64> {
    let ext = bounds.extent();
    let mut evaluator = Evaluator::new(&r.m, &[s.value], Precision::Exact);
    let mut f = |t: [f64; 3]| -> [f64; 4] {
        let mut env = ShadeEnv { position: std::array::from_fn(|k| bounds.lo[k] + ext[k] * t[k]) };
        evaluator.eval(&mut env).values[0]
    };
    let baked = solid::bake(&mut f);
    let e = solid::measured_error(&baked, &mut f, PROBES);
    e.is_finite().then_some(e)
}

/// The environment of [`measure`]: the stored position is `position`.
struct ShadeEnv {
    position: [f64; 3],
}

impl Env for ShadeEnv {
    fn fat_member(&mut self, _: u32, _: Value, _: u8) -> Value {
        [self.position[0], self.position[1], self.position[2], 0.0]
    }
}

/// (16)'s value with the stored position replaced by the position of the
/// 3-D texel the tiled grid's texel coordinate stands for
/// ([`solid::point_of`], [`solid::place`]).
fn texel_function(
    r: &mut Rewriter,
    s: &Statement,
    read: Handle<Expr>,
    bounds: Bounds,
    span: Span,
) -> Option<Handle<Expr>> {
    let tiles = solid::TILES as f64;
    let four = r.node(Expr::Constant(Constant::scalar(tiles)), span)?;
    let scaled = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: s.index, rhs: four }, span)?;
    let xy = r.node(Expr::Math { fun: MathFunction::Fract, args: vec![scaled] }, span)?;
    let cell = r.node(Expr::Math { fun: MathFunction::Floor, args: vec![scaled] }, span)?;
    let swizzle = |k: u8| Expr::Swizzle { value: cell, pattern: [k, 0, 0, 0], len: 1, ty: Ty::Scalar };
    let (cx, cy) = (r.node(swizzle(0), span)?, r.node(swizzle(1), span)?);
    let row = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: cy, rhs: four }, span)?;
    let slice = r.node(Expr::Binary { op: BinaryOp::Add, lhs: row, rhs: cx }, span)?;
    let slices = solid::SLICES as f64;
    let z = affine(r, slice, 1.0 / slices, 0.5 / slices, Ty::Scalar, span)?;
    let c = r.node(Expr::Compose { ty: Ty::Vec3, components: vec![xy, z] }, span)?;
    // position = lo + ext·place(c), place(c) = (c·N − ½)/(N − 1).
    let (n, ext) = ([solid::SIDE as f64, solid::SIDE as f64, slices], bounds.extent());
    let m: [f64; 3] = std::array::from_fn(|k| ext[k] * n[k] / (n[k] - 1.0));
    let b: [f64; 3] = std::array::from_fn(|k| bounds.lo[k] - ext[k] * 0.5 / (n[k] - 1.0));
    let position = affine3(r, c, m, b, span)?;
    substitute(r, s.value, read, position)
}

/// The 3-D texture coordinate of the per-vertex position `p`:
/// `solid::coordinate((p − lo)/ext)`, interpolated to the texels of (15).
fn coordinates(r: &mut Rewriter, p: Handle<Expr>, bounds: Bounds, span: Span) -> Option<Handle<Expr>> {
    let n = [solid::SIDE as f64, solid::SIDE as f64, solid::SLICES as f64];
    let ext = bounds.extent();
    let m: [f64; 3] = std::array::from_fn(|k| (n[k] - 1.0) / (n[k] * ext[k]));
    let b: [f64; 3] = std::array::from_fn(|k| 0.5 / n[k] - bounds.lo[k] * m[k]);
    let c = affine3(r, p, m, b, span)?;
    r.node(Expr::Interpolate { value: c, to: Frequency::Texel }, span)
}

/// `x·m + b` with constants of type `ty` (scalar).
fn affine(r: &mut Rewriter, x: Handle<Expr>, m: f64, b: f64, ty: Ty, span: Span) -> Option<Handle<Expr>> {
    let mc = r.node(Expr::Constant(Constant::new(ty, &[m])), span)?;
    let bc = r.node(Expr::Constant(Constant::new(ty, &[b])), span)?;
    let scaled = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: x, rhs: mc }, span)?;
    r.node(Expr::Binary { op: BinaryOp::Add, lhs: scaled, rhs: bc }, span)
}

/// `x·m + b` per component of a vec3.
fn affine3(r: &mut Rewriter, x: Handle<Expr>, m: [f64; 3], b: [f64; 3], span: Span) -> Option<Handle<Expr>> {
    let mc = r.node(Expr::Constant(Constant::new(Ty::Vec3, &m)), span)?;
    let bc = r.node(Expr::Constant(Constant::new(Ty::Vec3, &b)), span)?;
    let scaled = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: x, rhs: mc }, span)?;
    r.node(Expr::Binary { op: BinaryOp::Add, lhs: scaled, rhs: bc }, span)
}

/// `value` with node `from` replaced by `to`.
fn substitute(
    r: &mut Rewriter,
    value: Handle<Expr>,
    from: Handle<Expr>,
    to: Handle<Expr>,
) -> Option<Handle<Expr>> {
    let mut map = std::collections::HashMap::new();
    map.insert(from, to);
    for h in r.m.reachable(&[value]) {
        if h == from {
            continue;
        }
        let e = r.m.exprs[h].map_operands(|o| map.get(&o).copied().unwrap_or(o));
        let out = r.node(e, r.m.span(h))?;
        map.insert(h, out);
    }
    map.get(&value).copied()
}
