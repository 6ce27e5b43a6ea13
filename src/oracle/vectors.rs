//! The shading vectors of Pipeline Grammar's Figure 3 at a mesh vertex, from
//! their definitions (docs/language.md, "Shading vectors"): unit vectors to
//! the light and the eye, `half = normalize(L + V)`, `reflection = 2(N·V)N −
//! V`, the binormal `w·(N × T)` (Kilgard 2000, §5.1), expressed in object,
//! world, eye or tangent space (tangent: `(T·v, B·v, N·v)` in object space,
//! Kilgard 2000, Appendix C); `intensity(i)` is GL 1.x's light colour times
//! its distance attenuation `1/(kc + kl·d + kq·d²)` and spot factor
//! (§2.13.1). A light the scene lacks delivers nothing: zero vector, zero
//! intensity.

use glam::{DMat3, DVec3};

use super::geometry::{Object, World};
use crate::parser::ast::{Space, VectorKind};
use crate::scene::Light;

fn d3(v: glam::Vec3) -> DVec3 {
    v.as_dvec3()
}

/// Object-space frame (N, T, B) at vertex `v`; a mesh without tangents uses
/// T = +x.
fn frame(o: &Object, v: usize) -> (DVec3, DVec3, DVec3) {
    let n = d3(o.mesh.normals[v]).normalize_or_zero();
    let t4 = o.mesh.tangents.get(v).map_or(glam::DVec4::new(1.0, 0.0, 0.0, 1.0), |t| t.as_dvec4());
    let t = t4.truncate();
    let b = n.cross(t) * if t4.w < 0.0 { -1.0 } else { 1.0 };
    (n, t, b)
}

/// Vector `kind` (light index `index`) in `space` at vertex `v` of object
/// `o`: `[x, y, z, w]`, w = 1 for a point, 0 for a direction.
pub fn at_vertex(
    world: &World,
    lights: &[Light],
    o: &Object,
    v: usize,
    kind: VectorKind,
    index: u32,
    space: Space,
) -> [f64; 4] {
    let p_obj = d3(o.mesh.positions[v]);
    let p_world = o.model.transform_point3(p_obj);
    let (n, t, b) = frame(o, v);
    let inv = o.model.inverse();
    let to_object = |w: DVec3| inv.transform_vector3(w);
    let light = lights.get(index as usize);
    let to_light = || match light {
        Some(Light::Directional { direction, .. }) => to_object(-d3(*direction)).normalize_or_zero(),
        Some(Light::Point { position, .. } | Light::Spot { position, .. }) => {
            (inv.transform_point3(d3(*position)) - p_obj).normalize_or_zero()
        }
        None => DVec3::ZERO,
    };
    let to_eye = || match world.infinite_view {
        Some(d) => to_object(d).normalize_or_zero(),
        None => (inv.transform_point3(world.eye) - p_obj).normalize_or_zero(),
    };
    if kind == VectorKind::Intensity {
        let c = light.map_or(DVec3::ZERO, |l| intensity(l, p_world));
        return [c.x, c.y, c.z, 0.0];
    }
    let (obj, normal, point) = match kind {
        VectorKind::Normal => (n, true, false),
        VectorKind::Tangent => (t, false, false),
        VectorKind::Binormal => (b, false, false),
        VectorKind::Light => (to_light(), false, false),
        VectorKind::View => (to_eye(), false, false),
        VectorKind::Half => ((to_light() + to_eye()).normalize_or_zero(), false, false),
        VectorKind::Reflection => {
            let e = to_eye();
            (2.0 * n.dot(e) * n - e, false, false)
        }
        VectorKind::Position | VectorKind::Intensity => (p_obj, false, true),
    };
    let linear = |m: glam::DMat4| {
        if point {
            m.transform_point3(obj)
        } else if normal {
            // Normals transform by the inverse transpose.
            DMat3::from_mat4(m).inverse().transpose() * obj
        } else {
            m.transform_vector3(obj)
        }
    };
    let out = match space {
        Space::Object => obj,
        Space::Tangent => DVec3::new(t.dot(obj), b.dot(obj), n.dot(obj)),
        Space::World => linear(o.model),
        Space::Eye => linear(o.model_view),
    };
    let out = if point { out } else { out.normalize_or_zero() };
    [out.x, out.y, out.z, if point { 1.0 } else { 0.0 }]
}

/// GL 1.x §2.13.1: colour · attenuation · spot factor at world point `p`.
fn intensity(light: &Light, p: DVec3) -> DVec3 {
    let attenuate = |a: &crate::scene::Attenuation, d: f64| {
        let k = f64::from(a.constant) + f64::from(a.linear) * d + f64::from(a.quadratic) * d * d;
        if k > 0.0 {
            1.0 / k
        } else {
            0.0
        }
    };
    match light {
        Light::Directional { color, .. } => d3(*color),
        Light::Point { position, color, attenuation } => {
            d3(*color) * attenuate(attenuation, (d3(*position) - p).length())
        }
        Light::Spot { position, direction, cutoff_deg, exponent, color, attenuation } => {
            let to = d3(*position) - p;
            let s = (-to.normalize_or_zero()).dot(d3(*direction).normalize_or_zero());
            let spot = if s < f64::from(*cutoff_deg).to_radians().cos() {
                0.0
            } else {
                s.max(0.0).powf((*exponent).into())
            };
            d3(*color) * attenuate(attenuation, to.length()) * spot
        }
    }
}
