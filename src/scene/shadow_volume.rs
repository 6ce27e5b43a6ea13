//! Shadow volumes built from a scene: the geometry of `x′` in the shadow
//! volume statements of Pipeline Grammar (Section 3.5),
//! `σ C δπx ← (σ C δπx) OR ((z δπx′) > (z C δπx′))`.
//!
//! For each closed mesh of the scene and a light, the silhouette edges as
//! seen from the light (edges between a triangle that faces the light and
//! one that faces away) are extruded away from it into quadrilaterals
//! (Crow 1977; Heidmann 1991), and the volume is capped at both ends so that
//! it is closed and counting works with the eye inside it (Everitt and
//! Kilgard 2002, "z-fail"). The near cap is the occluder's own dark side
//! (the triangles facing away from the light, reversed) and the far cap its
//! lit side moved along the light's rays: the cap that coincides with a
//! surface is then a surface the light does not reach, so a depth tie at
//! the cap cannot darken a lit pixel.
//!
//! The comparison `z δπx′ > z C δπx′` of the statement selects the
//! fragments of the volume that lie behind the visible surface — the
//! fragments z-fail counts. The count is by facing: +1 for a back face of
//! the volume, −1 for a front face (two passes, culling one face each, as a
//! GeForce 256 or GeForce3 with one stencil state did, or one pass with a
//! state per face where the target has two-sided stencil;
//! [`count_by_facing`]). A pixel is in shadow where the count is not
//! zero; the program reads it as `¬σ C ? …` (lit where no volume counted).
//!
//! The extrusion is finite: 2.5 radii of the scene's bounding sphere,
//! past every receiver (Everitt and Kilgard project to infinity with
//! `w = 0`; a finite volume keeps plain vertices for every executor and
//! needs the camera's far plane beyond its far cap).

use std::collections::HashMap;

use glam::{Mat4, Vec2, Vec3, Vec4};

use super::bind::{self, BoundObject};
use super::{Light, Mesh, Scene, SceneAssets};
use crate::diag::Diagnostic;
use crate::ir::{Expr, Module, Table};
use crate::pipeline::{CullMode, Geometry, Pass, StencilOp};

/// How far the silhouette is extruded, in radii of the scene's bounding
/// sphere: from any point inside it, 2 radii along any ray leave it.
pub const EXTRUSION_RADII: f32 = 2.5;

/// The light's rays: from a position (point, spot) or along a direction.
#[derive(Clone, Copy, Debug)]
pub enum Rays {
    From(Vec3),
    Along(Vec3),
}

impl Rays {
    pub fn of(light: &Light) -> Rays {
        match *light {
            Light::Directional { direction, .. } => Rays::Along(direction.normalize_or_zero()),
            Light::Point { position, .. } | Light::Spot { position, .. } => Rays::From(position),
        }
    }

    /// The direction light travels at `p` (unit).
    fn at(self, p: Vec3) -> Vec3 {
        match self {
            Rays::From(l) => (p - l).normalize_or_zero(),
            Rays::Along(d) => d,
        }
    }
}

/// A mesh's triangles over welded positions (seams and poles of the
/// generated meshes duplicate a position), degenerate ones dropped: `None`
/// when, after welding, some edge is not shared by exactly two triangles
/// running it in opposite directions — an open or inconsistently wound
/// mesh, which bounds no volume and casts none.
pub fn closed_triangles(positions: &[Vec3], triangles: &[[u32; 3]]) -> Option<(Vec<Vec3>, Vec<[u32; 3]>)> {
    let extent = positions.iter().fold(0.0f32, |m, p| m.max(p.abs().max_element())).max(1e-6);
    let q = extent * 1e-4;
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut welded = Vec::new();
    let mut map = Vec::with_capacity(positions.len());
    for p in positions {
        let key = [(p.x / q).round() as i64, (p.y / q).round() as i64, (p.z / q).round() as i64];
        let i = *index.entry(key).or_insert_with(|| {
            welded.push(*p);
            welded.len() as u32 - 1
        });
        map.push(i);
    }
    let tris: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| t.map(|v| map[v as usize]))
        .filter(|[a, b, c]| a != b && b != c && c != a)
        .collect();
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for t in &tris {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
        }
    }
    let closed =
        !tris.is_empty() && directed.iter().all(|(&(a, b), &n)| n == 1 && directed.get(&(b, a)) == Some(&1));
    closed.then_some((welded, tris))
}

/// The shadow volume of one closed mesh (world-space `positions`) lit by
/// `rays`, extruded `distance`: triangles wound counter-clockwise seen from
/// outside the volume, appended to `out`. Silhouette edges are those whose
/// two triangles disagree on facing the light.
fn extrude(positions: &[Vec3], tris: &[[u32; 3]], rays: Rays, distance: f32, out: &mut Vec<[Vec3; 3]>) {
    let faces_light = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        let n = (b - a).cross(c - a);
        n.dot(rays.at((a + b + c) / 3.0)) < 0.0
    };
    let facing: Vec<bool> = tris.iter().map(faces_light).collect();
    let far = |v: u32| {
        let p = positions[v as usize];
        p + rays.at(p) * distance
    };
    let mut edge_facing: HashMap<(u32, u32), bool> = HashMap::new();
    for (t, f) in tris.iter().zip(&facing) {
        for k in 0..3 {
            edge_facing.insert((t[k], t[(k + 1) % 3]), *f);
        }
    }
    for (t, &f) in tris.iter().zip(&facing) {
        let [a, b, c] = *t;
        let p = |v: u32| positions[v as usize];
        if f {
            // Far cap: the lit side moved along the rays, reversed.
            out.push([far(a), far(c), far(b)]);
            for k in 0..3 {
                let (u, v) = (t[k], t[(k + 1) % 3]);
                if edge_facing.get(&(v, u)) == Some(&false) {
                    // Silhouette edge u→v as the lit triangle runs it.
                    out.push([p(v), p(u), far(u)]);
                    out.push([p(v), far(u), far(v)]);
                }
            }
        } else {
            // Near cap: the dark side, reversed (the volume lies beyond it).
            out.push([p(a), p(c), p(b)]);
        }
    }
}

/// The shadow volumes of every closed mesh of the scene for light
/// `light` as one world-space mesh (its normals, tangents and coordinates
/// unused: the stencil pass shades nothing); `None` without such a light.
pub fn volumes(scene: &Scene, assets: &SceneAssets, light: usize) -> Option<Mesh> {
    let rays = Rays::of(scene.lights.get(light)?);
    let (_, radius) = assets.bounding_sphere();
    let mut triangles: Vec<[Vec3; 3]> = Vec::new();
    for (mesh, model) in &assets.meshes {
        let world: Vec<Vec3> = mesh.positions.iter().map(|p| model.transform_point3(*p)).collect();
        if let Some((positions, tris)) = closed_triangles(&world, &mesh.triangles) {
            extrude(&positions, &tris, rays, EXTRUSION_RADII * radius, &mut triangles);
        }
    }
    let n = triangles.len() * 3;
    Some(Mesh {
        positions: triangles.iter().flatten().copied().collect(),
        normals: vec![Vec3::Y; n],
        tangents: vec![Vec4::new(1.0, 0.0, 0.0, 1.0); n],
        uvs: vec![Vec2::ZERO; n],
        triangles: (0..triangles.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect(),
    })
}

/// The vertex streams that only a stencil update's compared depth
/// rasterizes (`x′` of `z δπx′ > z C δπx′`): no statement is indexed by
/// them, so the scene's objects are not their geometry — the shadow
/// volumes are.
pub fn volume_streams(m: &Module) -> Vec<u32> {
    let indexed: Vec<u32> = streams_of(m, &m.statements.iter().map(|s| s.index).collect::<Vec<_>>());
    let all: Vec<u32> = (0..m.vertices.len() as u32).collect();
    all.into_iter().filter(|v| !indexed.contains(v)).collect()
}

fn streams_of(m: &Module, roots: &[crate::ir::Handle<Expr>]) -> Vec<u32> {
    let mut out: Vec<u32> = m
        .reachable(roots)
        .into_iter()
        .filter_map(|h| match m.exprs[h] {
            Expr::VertexPosition(v) => Some(v),
            _ => None,
        })
        .collect();
    out.dedup();
    out
}

/// Whether `pass` rasterizes the shadow volumes: a mesh pass whose
/// position is a volume stream ([`volume_streams`]).
pub fn draws_volumes(m: &Module, pass: &Pass) -> bool {
    let Some(position) = pass.vertex.position else { return false };
    if !matches!(pass.geometry, Geometry::Mesh { .. }) {
        return false;
    }
    let volume = volume_streams(m);
    let drawn = streams_of(m, &[crate::ir::Handle::new(position as usize)]);
    !drawn.is_empty() && drawn.iter().all(|v| volume.contains(v))
}

/// The stencil update over a shadow volume as the hardware counted it
/// (Heidmann 1991; z-fail, Everitt and Kilgard 2002): +1 on the volume's
/// back faces and −1 on its front faces where the depth test
/// `z δπx′ > z C δπx′` passes (wrapping, as `GL_INCR_WRAP`/`GL_DECR_WRAP`).
/// With `two_sided` stencil (a state per face) one pass draws both faces;
/// without (GeForce 256, GeForce3: one state for both) the pass becomes
/// two, the back faces (front ones culled) then the front faces.
pub fn count_by_facing(m: &Module, passes: &mut Vec<Pass>, two_sided: bool) {
    let mut out = Vec::with_capacity(passes.len() + 1);
    for pass in passes.drain(..) {
        if !(draws_volumes(m, &pass) && pass.state.stencil.enabled) {
            out.push(pass);
            continue;
        }
        let why = "where the volume lies behind the surface (z-fail)";
        if two_sided {
            let mut p = pass.clone();
            p.state.cull = CullMode::None;
            p.state.stencil.pass = StencilOp::DecrWrap;
            p.state.stencil.back_pass = Some(StencilOp::IncrWrap);
            p.reason = format!("{}: the shadow volume's faces counted by facing in one pass (two-sided stencil: back +1, front −1) {why}", pass.reason);
            out.push(p);
            continue;
        }
        for (cull, op, faces) in [
            (CullMode::Front, StencilOp::IncrWrap, "back faces, +1"),
            (CullMode::Back, StencilOp::DecrWrap, "front faces, −1"),
        ] {
            let mut p = pass.clone();
            p.state.cull = cull;
            p.state.stencil.pass = op;
            p.reason = format!("{}: the shadow volume's {faces} {why}", pass.reason);
            out.push(p);
        }
    }
    *passes = out;
}

/// Uses of a volume stream other than the depth a stencil update compares
/// (a colour statement interpolating `x′` over `x`): the scene gives `x′`
/// no vertices there, so the program is refused at the use.
pub fn unbound_uses(m: &Module) -> Vec<Diagnostic> {
    let volume = volume_streams(m);
    if volume.is_empty() {
        return Vec::new();
    }
    let mut out = Vec::new();
    for st in &m.statements {
        if matches!(st.table, Table::Framebuffer { channel: crate::ir::FbChannel::Stencil, .. }) {
            continue;
        }
        for h in m.reachable(&[st.value]) {
            if matches!(m.exprs[h], Expr::VertexPosition(v) if volume.contains(&v)) {
                let name = &m.vertices[match m.exprs[h] {
                    Expr::VertexPosition(v) => v as usize,
                    _ => 0,
                }];
                out.push(Diagnostic::error("no-geometry", format!("`{name}` has no geometry here: no statement draws it, and only a stencil update's compared depth (`z δπ{name} > z C δπ{name}`, Pipeline Grammar, Section 3.5) rasterizes the shadow volumes built for it"), m.span(h), "no vertices for this stream").with_help(format!("index a statement by `{name}` (`C δπ{name} ← …`) or read `{name}` only in a stencil update's depth comparison")));
                break;
            }
        }
    }
    out
}

/// The shadow volumes of `pass`'s light (light 0 for a program written for
/// one light) bound for drawing like an object (world space: the identity
/// as model matrix).
pub fn bind_volume<'s>(
    scene: &Scene,
    assets: &SceneAssets,
    volume: &'s Mesh,
    aspect: f32,
) -> BoundObject<'s> {
    let (center, radius) = assets.bounding_sphere();
    let light_clip = bind::light_view_projection(scene.lights.first(), center, radius);
    BoundObject::new(scene, volume, Mat4::IDENTITY, aspect, light_clip)
}

/// The volume a pass draws, or why it has none: no light, or no closed mesh
/// in the scene (located at the pass's statement).
pub fn for_pass(
    scene: &Scene,
    assets: &SceneAssets,
    m: &Module,
    pass: &Pass,
) -> Result<Option<Mesh>, String> {
    if !draws_volumes(m, pass) {
        return Ok(None);
    }
    let light = pass.light.unwrap_or(0) as usize;
    let stream = streams_of(m, &[crate::ir::Handle::new(pass.vertex.position.unwrap_or(0) as usize)]);
    let name = stream.first().map_or("x′", |v| m.vertices[*v as usize].as_str());
    match volumes(scene, assets, light) {
        Some(mesh) if !mesh.triangles.is_empty() => Ok(Some(mesh)),
        Some(_) => Err(format!("{}: the shadow volume `{name}` has no geometry: no object of the scene is a closed mesh (each edge shared by two triangles) to cast a shadow from light {light}; help: add a closed mesh (sphere, cube, torus, closed OBJ) between the light and a receiver", pass.at)),
        None => Err(format!("{}: the shadow volume `{name}` has no geometry: the scene has no light {light} to extrude it from; help: add a light to the scene", pass.at)),
    }
}
