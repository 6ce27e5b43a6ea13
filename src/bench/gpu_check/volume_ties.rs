//! Where a shadow volume's stencil count is the rasterizer's choice: the
//! pixels whose count may differ between two conforming implementations
//! because each snaps the volume's vertices, one by one, to its own
//! sub-pixel grid.
//!
//! Vulkan converts a primitive's framebuffer coordinates to fixed point with
//! `subPixelPrecisionBits` bits of fraction, at least 4 (the Vulkan
//! specification, "Limits", required limit of `subPixelPrecisionBits`;
//! GL's `GL_SUBPIXEL_BITS` likewise, initial value 4), and says neither how
//! it rounds nor that two primitives sharing a position snap it alike unless
//! they are the same primitive (GL 1.x, Appendix A: invariance holds for
//! the same primitive, not across primitives). So each vertex of the
//! volume may lie up to 1/16 pixel off the CPU's along each axis, plus the
//! CPU's own rounding to 1/256 (`renderer::raster::SUBPIXEL_BITS`, to
//! nearest: 1/512): [`SNAP`] = 1/16 + 1/512 pixel along each axis, each
//! vertex on its own.
//!
//! **The criterion, local to the pixel.** A volume triangle's depth is
//! affine in the framebuffer, z(p) = Σ bⱼ(p) zⱼ. Moving vertex j by eⱼ
//! moves z at p, to first order in |eⱼ| over the triangle's size, by
//! −bⱼ(p) ∇z·eⱼ; all three together by at most Σ|bⱼ(p)| ‖∇z‖₁ [`SNAP`]
//! (‖∇z‖₁ = |∂z/∂x| + |∂z/∂y| per pixel: the most ∇z·e takes over the
//! snapping box |eₓ|, |e_y| ≤ SNAP). The surface's own vertices snap too:
//! its depth at p by ‖∇z_S‖₁ [`SNAP`] (p inside its triangle, the
//! barycentrics sum to 1). The
//! stencil count at a pixel changes between two snappings only where a
//! volume triangle's depth test against the surface can change: a closed
//! volume's triangles that share an edge snap the shared vertices alike
//! within one draw, so a pixel near an edge is covered by one of the two
//! (same facing: the same count) or by both or neither (a fold: +1 and −1)
//! — the count differs only if the two depth tests differ, and at the
//! shared edge their depths meet. So a pixel is **ambiguous** when some
//! volume triangle within √2 [`SNAP`] of its centre (covering it, or
//! covering it after snapping) has, at the centre,
//!
//! |z_T(p) − z_S(p)| ≤ Σ|bⱼ(p)| ‖∇z_T‖₁ SNAP + ‖∇z_S‖₁ SNAP + [`DEPTH_SLACK`],
//!
//! [`DEPTH_SLACK`] a few steps of the depth buffer's resolvable difference
//! (24 bits: r = 2⁻²⁴; the smallest of `TIES`' volume offsets). A triangle
//! seen edge-on (no area) may take any depth between its vertices' within
//! √2 [`SNAP`] of it. Such pixels
//! are left out of the comparison, counted and reported, as the edge mask's
//! are: either count is a conforming result there.
//!
//! **The near cap** (`scene::shadow_volume`: the occluder's dark side,
//! reversed) is made of the surface's own vertices, so it snaps as the
//! surface does; its ties with the surface are those of depth precision,
//! which the model's `volume_depth_steps` renders bound. Its triangles are
//! left out here (with the criterion above, every pixel of the dark side
//! would tie).

use glam::{DVec2, DVec3, Mat4, Vec3};

use crate::pipeline::Planned;
use crate::scene::bind::{light_view_projection, BoundObject};
use crate::scene::{Scene, SceneAssets};

/// The largest distance along each axis, in pixels, between a volume
/// vertex where the CPU draws it and where a conforming rasterizer may snap
/// it: 1/16 pixel (4 sub-pixel bits, Vulkan's least, either rounding) plus
/// the CPU's rounding to the nearest 1/256.
pub const SNAP: f64 = 1.0 / 16.0 + 1.0 / 512.0;

/// The farthest a snapped point may lie from where it was: the corner of
/// the snapping box.
const REACH: f64 = std::f64::consts::SQRT_2 * SNAP;

/// The depth buffer's precision: 16 steps of its resolvable difference
/// r = 2⁻²⁴ (a 24-bit depth), the smallest volume offset of `TIES`.
pub const DEPTH_SLACK: f64 = 16.0 / 16_777_216.0;

/// A triangle in framebuffer coordinates: x, y in pixels (y down), z the
/// depth in [0, 1].
type Screen = [DVec3; 3];

/// The visible surface per pixel: its depth and its triangle's ‖∇z‖₁ per
/// pixel (`INFINITY` depth where no object covers the pixel centre).
pub struct Surface {
    size: (u32, u32),
    depth: Vec<f64>,
    slope: Vec<f64>,
}

impl Surface {
    /// The scene's objects scan-converted at pixel centres with a depth test,
    /// through the binder's camera clip matrices (as every executor draws them).
    pub fn of(scene: &Scene, assets: &SceneAssets, (w, h): (u32, u32)) -> Surface {
        let n = (w * h) as usize;
        let mut s = Surface { size: (w, h), depth: vec![f64::INFINITY; n], slope: vec![0.0; n] };
        let (center, radius) = assets.bounding_sphere();
        let light = light_view_projection(scene.lights.first(), center, radius);
        for (mesh, model) in &assets.meshes {
            let object = BoundObject::new(scene, mesh, *model, w as f32 / h as f32, light);
            for tri in &mesh.triangles {
                let corners = tri.map(|v| mesh.positions[v as usize]);
                for t in screen_triangles(object.camera_clip, corners, (w, h)) {
                    let Some(plane) = Plane::of(&t) else { continue };
                    for_pixels_near(&t, 0.0, (w, h), |i, p| {
                        let b = plane.barycentrics(p);
                        if b.iter().all(|&b| b >= 0.0) {
                            let z = plane.depth(&t, b);
                            if z < s.depth[i] {
                                s.depth[i] = z;
                                s.slope[i] = plane.slope;
                            }
                        }
                    });
                }
            }
        }
        s
    }

    /// Whether an object covers pixel `i`'s centre.
    pub fn covers(&self, i: usize) -> bool {
        self.depth[i].is_finite()
    }
}

/// The pixels where the stencil count of the volumes `planned` draws is
/// ambiguous under per-vertex snapping (module docs), or why the volume
/// cannot be built.
pub fn ambiguous(
    scene: &Scene,
    assets: &SceneAssets,
    planned: &Planned,
    surface: &Surface,
) -> Result<Vec<bool>, String> {
    let (w, h) = surface.size;
    let mut out = vec![false; (w * h) as usize];
    let mut lights = Vec::new();
    for (index, pass) in planned.plan.passes.iter().enumerate() {
        if !planned.setup(index).draws_volumes || lights.contains(&pass.light) {
            continue;
        }
        lights.push(pass.light);
        let Some(volume) = crate::planner::shadow_volumes::for_pass(scene, assets, planned, index)? else {
            continue;
        };
        let clip =
            crate::scene::shadow_volume::bind_volume(scene, assets, &volume, w as f32 / h as f32).camera_clip;
        let (center, radius) = assets.bounding_sphere();
        let on_object = |p: Vec3| p.distance(center) <= radius * 1.001;
        for tri in &volume.triangles {
            let corners = tri.map(|v| volume.positions[v as usize]);
            if corners.iter().all(|&p| on_object(p)) {
                continue; // the near cap: snapped as the surface is (module docs)
            }
            for t in screen_triangles(clip, corners, (w, h)) {
                mark_ties(&t, surface, &mut out);
            }
        }
    }
    Ok(out)
}

/// Marks the pixels near `t` whose depth test against the surface may go
/// either way under snapping (module docs).
fn mark_ties(t: &Screen, surface: &Surface, out: &mut [bool]) {
    let size = surface.size;
    match Plane::of(t) {
        Some(plane) => for_pixels_near(t, REACH, size, |i, p| {
            if !surface.covers(i) {
                return;
            }
            let b = plane.barycentrics(p);
            let moved = b.iter().map(|b| b.abs()).sum::<f64>() * plane.slope * SNAP;
            let tol = moved + surface.slope[i] * SNAP + DEPTH_SLACK;
            if (plane.depth(t, b) - surface.depth[i]).abs() <= tol {
                out[i] = true;
            }
        }),
        None => {
            let lo = t.iter().map(|v| v.z).fold(f64::INFINITY, f64::min) - DEPTH_SLACK;
            let hi = t.iter().map(|v| v.z).fold(f64::NEG_INFINITY, f64::max) + DEPTH_SLACK;
            for_pixels_near(t, REACH, size, |i, _| {
                let (z, moved) = (surface.depth[i], surface.slope[i] * SNAP);
                if surface.covers(i) && z + moved >= lo && z - moved <= hi {
                    out[i] = true;
                }
            });
        }
    }
}

/// A triangle's depth plane in framebuffer coordinates.
struct Plane {
    /// Twice the signed area, pixels².
    area2: f64,
    /// ‖∇z‖₁ = |∂z/∂x| + |∂z/∂y|, depth per pixel.
    slope: f64,
    corners: [DVec2; 3],
}

impl Plane {
    /// `None` for a triangle without area (seen edge-on).
    fn of(t: &Screen) -> Option<Plane> {
        let [a, b, c] = *t;
        let area2 = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
        if area2.abs() < 1e-9 {
            return None;
        }
        let dzdx = ((b.z - a.z) * (c.y - a.y) - (c.z - a.z) * (b.y - a.y)) / area2;
        let dzdy = ((c.z - a.z) * (b.x - a.x) - (b.z - a.z) * (c.x - a.x)) / area2;
        Some(Plane { area2, slope: dzdx.abs() + dzdy.abs(), corners: t.map(|v| v.truncate()) })
    }

    /// The barycentric coordinates of `p` (any sign outside the triangle).
    fn barycentrics(&self, p: DVec2) -> [f64; 3] {
        let [a, b, c] = self.corners;
        let edge = |u: DVec2, v: DVec2| (v.x - u.x) * (p.y - u.y) - (p.x - u.x) * (v.y - u.y);
        [edge(b, c) / self.area2, edge(c, a) / self.area2, edge(a, b) / self.area2]
    }

    fn depth(&self, t: &Screen, b: [f64; 3]) -> f64 {
        b[0] * t[0].z + b[1] * t[1].z + b[2] * t[2].z
    }
}

/// Calls `f(pixel index, pixel centre)` for the pixel centres inside `t` or
/// within `reach` pixels of one of its edges.
fn for_pixels_near(t: &Screen, reach: f64, (w, h): (u32, u32), mut f: impl FnMut(usize, DVec2)) {
    let xs = t.iter().map(|v| v.x);
    let ys = t.iter().map(|v| v.y);
    let (x0, x1) = (xs.clone().fold(f64::INFINITY, f64::min), xs.fold(f64::NEG_INFINITY, f64::max));
    let (y0, y1) = (ys.clone().fold(f64::INFINITY, f64::min), ys.fold(f64::NEG_INFINITY, f64::max));
    let first = |lo: f64| (lo - reach - 0.5).ceil().max(0.0) as u32;
    let last = |hi: f64, n: u32| ((hi + reach - 0.5).floor().min(n as f64 - 1.0)).max(-1.0) as i64;
    let c = t.map(|v| v.truncate());
    let area2 = (c[1].x - c[0].x) * (c[2].y - c[0].y) - (c[2].x - c[0].x) * (c[1].y - c[0].y);
    for y in first(y0) as i64..=last(y1, h) {
        for x in first(x0) as i64..=last(x1, w) {
            let p = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            let side =
                |u: DVec2, v: DVec2| ((v.x - u.x) * (p.y - u.y) - (p.x - u.x) * (v.y - u.y)) * area2.signum();
            let inside = area2 != 0.0 && (0..3).all(|k| side(c[k], c[(k + 1) % 3]) >= 0.0);
            if inside || (0..3).any(|k| segment_distance(p, c[k], c[(k + 1) % 3]) <= reach) {
                f((y * w as i64 + x) as usize, p);
            }
        }
    }
}

/// The distance from `p` to the segment `a`–`b`.
fn segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let d = b - a;
    let len2 = d.length_squared();
    let s = if len2 > 0.0 { ((p - a).dot(d) / len2).clamp(0.0, 1.0) } else { 0.0 };
    p.distance(a + s * d)
}

/// A world- (or model-) space triangle through `clip`, clipped to the near
/// plane (z ≥ −w) and fanned into framebuffer triangles at `w`×`h`.
fn screen_triangles(clip: Mat4, corners: [Vec3; 3], (w, h): (u32, u32)) -> Vec<Screen> {
    let clip = clip.as_dmat4();
    let mut poly: Vec<glam::DVec4> = corners.iter().map(|p| clip * p.as_dvec3().extend(1.0)).collect();
    let near = |v: &glam::DVec4| v.z + v.w;
    let mut kept = Vec::with_capacity(4);
    for k in 0..poly.len() {
        let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
        if near(&a) >= 0.0 {
            kept.push(a);
        }
        if (near(&a) >= 0.0) != (near(&b) >= 0.0) {
            let s = near(&a) / (near(&a) - near(&b));
            kept.push(a + s * (b - a));
        }
    }
    poly = kept;
    let window = |v: glam::DVec4| {
        let n = v.truncate() / v.w.max(1e-12);
        DVec3::new((n.x + 1.0) * 0.5 * w as f64, (1.0 - n.y) * 0.5 * h as f64, (n.z + 1.0) * 0.5)
    };
    (1..poly.len().saturating_sub(1))
        .map(|k| [window(poly[0]), window(poly[k]), window(poly[k + 1])])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat surface at depth 0.5 over 8×8 pixels.
    fn flat(depth: f64) -> Surface {
        Surface { size: (8, 8), depth: vec![depth; 64], slope: vec![0.0; 64] }
    }

    /// A volume wall crossing the surface along x = 4.5 with a depth slope
    /// of 10⁻³ per pixel: the pixel centre on the crossing line ties, the
    /// centres a pixel either side are 10⁻³ off — beyond what snapping
    /// moves (10⁻³ × [`SNAP`] ≈ 0.6·10⁻⁴) plus [`DEPTH_SLACK`] (10⁻⁶).
    #[test]
    fn a_pixel_on_the_crossing_of_a_wall_and_the_surface_is_ambiguous_its_neighbours_are_not() {
        let z = |x: f64| 0.5 + 1e-3 * (x - 4.5);
        let t = [
            DVec3::new(-10.0, -10.0, z(-10.0)),
            DVec3::new(20.0, -10.0, z(20.0)),
            DVec3::new(-10.0, 30.0, z(-10.0)),
        ];
        let mut out = vec![false; 64];
        mark_ties(&t, &flat(0.5), &mut out);
        let row: Vec<bool> = (0..8).map(|x| out[3 * 8 + x]).collect();
        assert_eq!(row, [false, false, false, false, true, false, false, false]);
    }

    /// A pixel centre 0.05 pixel outside a volume triangle's edge, where the
    /// triangle's plane ties with the surface, may be covered once the
    /// vertices snap (0.05 < 1/16); one 0.2 pixel outside may not.
    #[test]
    fn a_tie_just_outside_a_volume_edge_is_ambiguous_within_the_snapping_distance() {
        let tri = |edge: f64| {
            [DVec3::new(edge, -10.0, 0.5), DVec3::new(edge, 30.0, 0.5), DVec3::new(-20.0, 4.0, 0.5)]
        };
        for (edge, expected) in [(4.45, true), (4.3, false)] {
            let mut out = vec![false; 64];
            mark_ties(&tri(edge), &flat(0.5), &mut out);
            assert_eq!(out[2 * 8 + 4], expected, "edge at x = {edge}");
            assert!(out[2 * 8 + 3], "the pixel inside the triangle, on the tie");
        }
    }

    /// Away from any tie nothing is ambiguous, however near an edge.
    #[test]
    fn an_edge_without_a_depth_tie_is_not_ambiguous() {
        let t = [DVec3::new(4.5, -10.0, 0.2), DVec3::new(4.5, 30.0, 0.2), DVec3::new(-20.0, 4.0, 0.2)];
        let mut out = vec![false; 64];
        mark_ties(&t, &flat(0.5), &mut out);
        assert!(out.iter().all(|&a| !a));
    }
}
