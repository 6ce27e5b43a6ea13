//! Stencil writes, evaluated from what they say (docs/language.md,
//! "Stencil writes") rather than from the stencil operations an executor
//! runs. The stencil holds an integer 0-255 per pixel, 0 clear.
//!
//! - `σ C δπx ← k` (an integer): k at the visible fragment of every pixel
//!   the geometry covers;
//! - `σ C δπx ← (σ C δπx) OR c`: set (1) at the visible fragments where
//!   `c` ≠ 0; `… AND c`: cleared where `c` = 0; `σ C δπx ← c`: the truth
//!   of `c` (1 or 0) at the visible fragments;
//!
//! and the depth comparison of Pipeline Grammar, Section 3.5,
//! `σ C δπy ← (σ C δπy) OR ((z δπy) ⋚ (z C δπy))` with any of `>`, `≥`,
//! `<`, `≤`:
//!
//! - Over a vertex stream some statement draws (the scene's objects), the
//!   stencil is set at a pixel where any fragment of a front face there
//!   passes the comparison of its depth with the depth stored in C — an
//!   OR over the fragments, in any order (no depth write).
//! - Over `x′`, a stream no statement draws — the shadow volumes (Crow
//!   1977) — the stencil counts the volume faces the comparison passes,
//!   as GL's `INCR_WRAP`/`DECR_WRAP` (GL 1.x §4.1.5, EXT_stencil_wrap) do
//!   by facing: +1 on a back face, −1 on a front one. A volume of a closed
//!   occluder, its silhouette from light 0 extruded away from the light
//!   and capped by the occluder's faces turned from the light, is the
//!   union of those faces' prisms, so the volumes' winding number at a
//!   point q — how many hold it — is how many such faces the segment from
//!   q towards the light crosses. This module builds no volume: it casts
//!   segments towards light 0 against the faces of the scene's closed
//!   meshes that face away from the light — an independent check of the
//!   executors' volumes as well as of their counting. The faces behind
//!   the visible point p (`>`, `≥`: Everitt and Kilgard 2002's z-fail)
//!   add up to winding(p); those between the near plane and p (`<`, `≤`:
//!   Heidmann 1991's z-pass) to winding(q) − winding(p), q where the
//!   pixel's ray meets the near plane. The visible point is the pixel
//!   centre at C's stored depth, taken back through the camera. A mesh is
//!   closed when, its coincident vertices welded, every edge borders two
//!   triangles (docs/scenes.md: a plane receives, a sphere casts). The
//!   executors' volumes end 2.5 radii of the scene's bounding sphere past
//!   the silhouette (docs/pass-plan.md), beyond every surface of the
//!   scene, which is all a visible point can lie on.
//!
//! Latitude (left out of comparisons): a visible point on an occluder's
//! face turned from the light, where the volume's near cap coincides with
//! the surface and the count depends on a depth tie between two
//! primitives, which GL does not make invariant (OpenGL 1.x Appendix A
//! holds only for the same primitive drawn the same way); and a segment
//! passing within rounding of a face's edge.

use std::collections::HashMap;

use glam::{DVec3, DVec4};

use super::geometry::{each_fragment, pixel_ndc, View};
use super::program::Evaluator;
use super::Unsupported;
use crate::ir::{BinaryOp, Expr, FbChannel, Handle, Module, Statement};
use crate::scene::Light;

/// `frag OP stored` of the update.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Compare {
    Less,
    LessEqual,
    Greater,
    GreaterEqual,
}

impl Compare {
    fn passes(self, fragment: f64, stored: f64) -> bool {
        match self {
            Compare::Less => fragment < stored,
            Compare::LessEqual => fragment <= stored,
            Compare::Greater => fragment > stored,
            Compare::GreaterEqual => fragment >= stored,
        }
    }
}

/// Runs the stencil update `st` into framebuffer `fb`.
pub fn update(
    ev: &mut Evaluator,
    st: &Statement,
    fb: usize,
    latitude: &mut [bool],
) -> Result<(), Unsupported> {
    let Some((compare, drawn)) = read_update(ev.m, st, fb) else {
        return at_visible_fragments(ev, st, fb, latitude);
    };
    let stream = camera_stream(ev.m, drawn)
        .ok_or_else(|| Unsupported::new("a stencil update over a position other than `δπ` of vertices"))?;
    if drawn_by_a_statement(ev.m, stream) {
        mark_fragments(ev, fb, compare);
        return Ok(());
    }
    shadow(ev, fb, compare, latitude)
}

/// What a write at the visible fragment does to the stencil there.
#[derive(Clone, Copy)]
enum Write {
    /// `σ ← k`.
    Constant(u8),
    /// `σ ← σ OR c`: 1 where c ≠ 0.
    SetWhere(Handle<Expr>),
    /// `σ ← σ AND c`: 0 where c = 0.
    ClearUnless(Handle<Expr>),
    /// `σ ← c`: 1 where c ≠ 0, else 0.
    Truth(Handle<Expr>),
}

/// The write `st`'s value says, its condition a scalar that does not read
/// the stencil being written.
fn read_write(m: &Module, st: &Statement, fb: usize) -> Option<Write> {
    let own = |h: Handle<Expr>| {
        matches!(m.exprs[h], Expr::FramebufferRead { framebuffer, channel: FbChannel::Stencil, .. }
            if framebuffer as usize == fb)
    };
    let reads_own = |h: Handle<Expr>| m.reachable(&[h]).into_iter().any(own);
    let condition = |c: Handle<Expr>| (m.info(c).ty == crate::ir::Ty::Scalar && !reads_own(c)).then_some(c);
    match &m.exprs[st.value] {
        Expr::Constant(k) => match k.values() {
            [v] if v.fract() == 0.0 && (0.0..=255.0).contains(v) => Some(Write::Constant(*v as u8)),
            _ => None,
        },
        Expr::Binary { op: op @ (BinaryOp::Or | BinaryOp::And), lhs, rhs } => {
            let c = match (own(*lhs), own(*rhs)) {
                (true, false) => condition(*rhs)?,
                (false, true) => condition(*lhs)?,
                _ => return condition(st.value).map(Write::Truth),
            };
            Some(if *op == BinaryOp::Or { Write::SetWhere(c) } else { Write::ClearUnless(c) })
        }
        _ => condition(st.value).map(Write::Truth),
    }
}

/// A stencil write at the visible fragment of each pixel of the
/// statement's index, which draws its geometry like any statement (and so
/// stores its depth).
fn at_visible_fragments(
    ev: &mut Evaluator,
    st: &Statement,
    fb: usize,
    latitude: &mut [bool],
) -> Result<(), Unsupported> {
    let write = read_write(ev.m, st, fb).ok_or_else(|| {
        Unsupported::new(
            "a stencil write other than a constant, `σ OR c`, `σ AND c`, `c` or a depth comparison",
        )
    })?;
    ev.target = fb;
    let mut writes = Vec::new();
    for (i, at) in super::samples(ev, st)? {
        ev.latitude.set(false);
        let truth = |h| -> Result<bool, Unsupported> {
            Ok(ev.value(h, at, 0, &mut HashMap::new())?.is_some_and(|v| v[0] != 0.0))
        };
        let stored = ev.framebuffers[fb].stencil[i];
        let new = match write {
            Write::Constant(k) => k,
            Write::SetWhere(c) => {
                if truth(c)? {
                    1
                } else {
                    stored
                }
            }
            Write::ClearUnless(c) => {
                if truth(c)? {
                    stored
                } else {
                    0
                }
            }
            Write::Truth(c) => u8::from(truth(c)?),
        };
        latitude[i] |= ev.latitude.get();
        writes.push((i, new, at));
    }
    let store = &mut ev.framebuffers[fb];
    for (i, new, at) in writes {
        store.stencil[i] = new;
        if let super::program::At::Fragment(f) = at {
            store.depth[i] = f.depth;
        }
    }
    Ok(())
}

/// `(σ C) OR (a ⋚ b)`, one of a, b the depth stored in C and the other the
/// depth of a drawn position: the comparison (fragment first) and that
/// position.
fn read_update(m: &Module, st: &Statement, fb: usize) -> Option<(Compare, Handle<Expr>)> {
    let Expr::Binary { op: BinaryOp::Or, lhs, rhs } = m.exprs[st.value] else { return None };
    let is_own = |h: Handle<Expr>, ch: FbChannel| {
        matches!(m.exprs[h], Expr::FramebufferRead { framebuffer, channel, .. }
            if framebuffer as usize == fb && channel == ch)
    };
    let cmp = if is_own(lhs, FbChannel::Stencil) {
        rhs
    } else if is_own(rhs, FbChannel::Stencil) {
        lhs
    } else {
        return None;
    };
    let Expr::Binary { op, lhs: a, rhs: b } = m.exprs[cmp] else { return None };
    let (fragment, stored_second) = match (&m.exprs[a], is_own(b, FbChannel::Depth)) {
        (Expr::Depth(p), true) => (*p, true),
        _ if is_own(a, FbChannel::Depth) => match m.exprs[b] {
            Expr::Depth(p) => (p, false),
            _ => return None,
        },
        _ => return None,
    };
    // Written `stored OP fragment`: the comparison turned around.
    let compare = match (op, stored_second) {
        (BinaryOp::Gt, true) | (BinaryOp::Lt, false) => Compare::Greater,
        (BinaryOp::Ge, true) | (BinaryOp::Le, false) => Compare::GreaterEqual,
        (BinaryOp::Lt, true) | (BinaryOp::Gt, false) => Compare::Less,
        (BinaryOp::Le, true) | (BinaryOp::Ge, false) => Compare::LessEqual,
        _ => return None,
    };
    Some((compare, fragment))
}

/// The vertex stream of `δ (π y)` under the camera's projection.
fn camera_stream(m: &Module, drawn: Handle<Expr>) -> Option<u32> {
    let Expr::Interpolate { value, .. } = m.exprs[drawn] else { return None };
    let Expr::Project { projection, value } = &m.exprs[value] else { return None };
    if projection.inverse || !matches!(projection.subscript.as_deref(), None | Some("")) {
        return None;
    }
    match m.exprs[*value] {
        Expr::VertexPosition(v) => Some(v),
        _ => None,
    }
}

/// Whether a statement is indexed by vertex stream `v` (its index reaches
/// it): the stream is the scene's objects, not the shadow volumes.
fn drawn_by_a_statement(m: &Module, v: u32) -> bool {
    m.statements.iter().any(|s| {
        m.reachable(&[s.index]).into_iter().any(|h| matches!(m.exprs[h], Expr::VertexPosition(w) if w == v))
    })
}

/// The objects' front faces at every pixel, the stencil set to 1 where one
/// passes `compare` against C's stored depth.
fn mark_fragments(ev: &mut Evaluator, fb: usize, compare: Compare) {
    let (w, h) = (ev.coverage.width, ev.coverage.height);
    let store = &mut ev.framebuffers[fb];
    each_fragment(&ev.world, w, h, View::Camera, &mut |f| {
        let i = (f.pixel.1 * w + f.pixel.0) as usize;
        if compare.passes(f.depth, store.depth[i]) {
            store.stencil[i] = 1;
        }
    });
}

/// A triangle of a closed mesh, in world space, facing away from light 0.
struct Face {
    a: DVec3,
    e1: DVec3,
    e2: DVec3,
    object: usize,
    triangle: usize,
}

/// Where the light is: a point, or a direction towards it (directional).
#[derive(Clone, Copy)]
enum Towards {
    Point(DVec3),
    Direction(DVec3),
}

fn light_0(lights: &[Light]) -> Option<Towards> {
    Some(match lights.first()? {
        Light::Point { position, .. } | Light::Spot { position, .. } => Towards::Point(position.as_dvec3()),
        Light::Directional { direction, .. } => Towards::Direction(-direction.as_dvec3().normalize_or_zero()),
    })
}

/// The shadow-volume update: the stencil counts, as GL's `INCR_WRAP` and
/// `DECR_WRAP` on the volume's back and front faces (GL 1.x §4.1.5), the
/// volume's faces the comparison passes along the pixel's ray. The
/// volumes' winding number at a point q (how many of them hold it) is
/// [`crossings`] from q towards the light (module doc), so:
///
/// - `>`, `≥` (z-fail, Everitt and Kilgard 2002): the faces behind the
///   visible point p, back ones +1 and front ones −1, add up to
///   winding(p) − winding(far), and the far end is past every volume:
///   winding(p);
/// - `<`, `≤` (z-pass, Heidmann 1991): the faces between the near plane
///   and p, each back face +1 and front face −1 as the plan counts them,
///   add up to winding(q) − winding(p), q the pixel's ray on the near
///   plane: 0 − winding(p) with the camera outside every volume, and
///   wrong where a volume reaches past the near plane, as z-pass is.
///
/// The count is added to what the stencil held (8 bits, wrapping).
fn shadow(ev: &mut Evaluator, fb: usize, compare: Compare, latitude: &mut [bool]) -> Result<(), Unsupported> {
    let light =
        light_0(ev.lights).ok_or_else(|| Unsupported::new("shadow volumes on a scene without a light"))?;
    let faces = dark_faces(ev, light);
    let z_pass = matches!(compare, Compare::Less | Compare::LessEqual);
    let (w, h) = (ev.coverage.width, ev.coverage.height);
    let unproject = ev.world.camera_vp.inverse();
    let at = |x: u32, y: u32, ndc_z: f64| {
        let (nx, ny) = pixel_ndc(f64::from(x) + 0.5, f64::from(y) + 0.5, w, h);
        let p = unproject * DVec4::new(nx, ny, ndc_z, 1.0);
        p.truncate() / p.w
    };
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let depth = ev.framebuffers[fb].depth[i];
            let visible = ev.coverage.fragments[i].map(|f| (f.object, f.triangle));
            // The volume's faces the comparison passes, counted: winding
            // numbers at the ends of the stretch of ray they lie on.
            let (mut count, mut edge) = (0i64, false);
            if depth < 1.0 {
                let (s, l) = crossings(&faces, at(x, y, 2.0 * depth - 1.0), light, visible);
                (count, edge) = (if z_pass { -l } else { l }, s != l);
            } else if !z_pass {
                continue; // nothing drawn: no volume face lies behind the far plane
            }
            if z_pass {
                let (s, l) = crossings(&faces, at(x, y, -1.0), light, None);
                (count, edge) = (count + l, edge || s != l);
            }
            let stencil = &mut ev.framebuffers[fb].stencil[i];
            *stencil = stencil.wrapping_add(count.rem_euclid(256) as u8);
            // On a face turned from the light (the near cap), or at an edge.
            let on_cap = visible.is_some_and(|v| faces.iter().any(|f| (f.object, f.triangle) == v));
            latitude[i] |= edge || on_cap;
        }
    }
    Ok(())
}

/// The faces of the scene's closed meshes turned away from the light
/// (their plane puts the light behind them), in world space.
fn dark_faces(ev: &Evaluator, light: Towards) -> Vec<Face> {
    let mut out = Vec::new();
    for (oi, o) in ev.world.objects.iter().enumerate() {
        if !closed(&o.mesh.positions, &o.mesh.triangles) {
            continue;
        }
        let world = |i: u32| o.model.transform_point3(o.mesh.positions[i as usize].as_dvec3());
        for (ti, t) in o.mesh.triangles.iter().enumerate() {
            let [a, b, c] = t.map(world);
            let n = (b - a).cross(c - a);
            let to_light = match light {
                Towards::Point(l) => l - a,
                Towards::Direction(d) => d,
            };
            if n.length_squared() > 0.0 && n.dot(to_light) < 0.0 {
                out.push(Face { a, e1: b - a, e2: c - a, object: oi, triangle: ti });
            }
        }
    }
    out
}

/// How many faces the segment from `p` towards the light crosses: with
/// every barycentric at least a rounding margin inside (`strict`) and
/// within it (`loose`). The visible point's own triangle does not count.
fn crossings(faces: &[Face], p: DVec3, light: Towards, own: Option<(usize, usize)>) -> (i64, i64) {
    const MARGIN: f64 = 1e-7;
    let (dir, t_max) = match light {
        Towards::Point(l) => (l - p, 1.0),
        Towards::Direction(d) => (d, f64::INFINITY),
    };
    let (mut strict, mut loose) = (0, 0);
    for f in faces {
        if own == Some((f.object, f.triangle)) {
            continue;
        }
        // Möller and Trumbore: p + t·dir = a + u·e1 + v·e2.
        let q = dir.cross(f.e2);
        let det = f.e1.dot(q);
        if det.abs() < 1e-300 {
            continue;
        }
        let s = p - f.a;
        let u = s.dot(q) / det;
        let r = s.cross(f.e1);
        let v = dir.dot(r) / det;
        let t = f.e2.dot(r) / det;
        if t <= 1e-9 || t >= t_max {
            continue;
        }
        let least = u.min(v).min(1.0 - u - v);
        strict += i64::from(least > MARGIN);
        loose += i64::from(least > -MARGIN);
    }
    (strict, loose)
}

/// Whether a triangle mesh is closed: its coincident vertices welded (a
/// seam repeats a position), its degenerate triangles (a pole's) dropped,
/// every edge borders exactly two triangles.
fn closed(positions: &[glam::Vec3], triangles: &[[u32; 3]]) -> bool {
    if triangles.is_empty() {
        return false;
    }
    let weld = weld(positions);
    let mut edges: HashMap<(usize, usize), u32> = HashMap::new();
    for t in triangles {
        let [a, b, c] = t.map(|i| weld[i as usize]);
        if a == b || b == c || a == c {
            continue;
        }
        for (x, y) in [(a, b), (b, c), (c, a)] {
            *edges.entry((x.min(y), x.max(y))).or_default() += 1;
        }
    }
    !edges.is_empty() && edges.values().all(|&n| n == 2)
}

/// Each vertex's representative: the first vertex within 1e-5 of it.
fn weld(positions: &[glam::Vec3]) -> Vec<usize> {
    const CELL: f64 = 1e-4;
    let key =
        |p: DVec3| ((p.x / CELL).floor() as i64, (p.y / CELL).floor() as i64, (p.z / CELL).floor() as i64);
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    let mut out = Vec::with_capacity(positions.len());
    for (i, p) in positions.iter().enumerate() {
        let p = p.as_dvec3();
        let (kx, ky, kz) = key(p);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &j in grid.get(&(kx + dx, ky + dy, kz + dz)).into_iter().flatten() {
                        if positions[j].as_dvec3().distance(p) < 1e-5 {
                            found = Some(j);
                            break 'search;
                        }
                    }
                }
            }
        }
        out.push(found.unwrap_or(i));
        if found.is_none() {
            grid.entry((kx, ky, kz)).or_default().push(i);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cube's six faces as twelve triangles, its corners repeated per
    /// face (as flat normals need), is closed; one face fewer is not.
    #[test]
    fn a_cube_with_repeated_corners_is_closed_and_an_open_box_is_not() {
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let base = positions.len() as u32;
                for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    let mut p = [0.0f32; 3];
                    p[axis] = sign;
                    p[(axis + 1) % 3] = a;
                    p[(axis + 2) % 3] = b;
                    positions.push(glam::Vec3::from(p));
                }
                triangles.push([base, base + 1, base + 2]);
                triangles.push([base, base + 2, base + 3]);
            }
        }
        assert!(closed(&positions, &triangles));
        assert!(!closed(&positions, &triangles[..10]));
    }
}
