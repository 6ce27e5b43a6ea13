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
//! `planner::shadow_volumes::count_by_facing`). A pixel is in shadow where the count is not
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
    /// The rays of a light: from its position, or along its direction.
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

/// A shadow volume (world space: the identity as model matrix) bound for
/// drawing like an object.
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

/// `object` drawn `d` normalized device units off (`xyz + d·w` in clip
/// space; in z, glPolygonOffset's constant term): the GPU check's model of
/// the ties between a volume and the surface it grazes, whose depths and
/// snapped positions GL does not make invariant across primitives (GL 1.x,
/// Appendix A).
pub fn offset_clip(mut object: BoundObject<'_>, d: Vec3) -> BoundObject<'_> {
    if d != Vec3::ZERO {
        let mut offset = Mat4::IDENTITY;
        offset.w_axis = d.extend(1.0);
        object.camera_clip = offset * object.camera_clip;
    }
    object
}
