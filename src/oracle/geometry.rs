//! Where the scene's triangles fall on the image, found pixel by pixel —
//! OpenGL 1.x §2.10-2.11 (transformation, perspective division, viewport)
//! and §3.5.1 (a pixel centre inside a triangle is one of its fragments),
//! in f64, with none of the tiled rasterizer's code: the matrices are
//! gluLookAt's and gluPerspective's (GLU 1.3 §4.1-4.2), a
//! triangle covers a pixel when the pixel centre's barycentric coordinates
//! in window space are all non-negative, and the nearest covering front
//! face wins (depth test `LESS`, back faces culled as the program's mesh
//! statements cull them).

use glam::{DMat4, DVec3, DVec4};

use crate::scene::{Scene, SceneAssets, Viewer};

/// One object of the scene, its matrices in f64.
pub struct Object<'a> {
    pub mesh: &'a crate::scene::Mesh,
    pub model: DMat4,
    /// Camera: projection · view · model (`π`).
    pub camera_clip: DMat4,
    /// Light 0's: projection · view · model (`πl`).
    pub light_clip: DMat4,
    pub model_view: DMat4,
}

/// The camera and the objects.
pub struct World<'a> {
    pub objects: Vec<Object<'a>>,
    pub eye: DVec3,
    /// The direction to an infinite viewer, in world space.
    pub infinite_view: Option<DVec3>,
    pub view: DMat4,
    /// The camera's projection · view, world to clip: `π` of a pixel,
    /// which belongs to no object (`π⁻¹ xs` of a screen pass).
    pub camera_vp: DMat4,
    /// Light 0's projection · view, world to clip (`πl` of a pixel).
    pub light_vp: DMat4,
}

/// Which plane a mesh statement rasterizes its triangles into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// `δπx`: the camera's projection.
    Camera,
    /// `δπl x`: light 0's projection (docs/language.md), as a camera.
    Light,
    /// `T δu x`: the mesh unwrapped over its texture coordinates, u across
    /// and v down (v = 0 the top row), no culling and no depth test.
    Texels,
}

fn d3(v: glam::Vec3) -> DVec3 {
    v.as_dvec3()
}

impl<'a> World<'a> {
    /// The oracle's world for `scene`: its camera's view and projection at `aspect`, and the
    /// meshes of `assets`.
    pub fn new(scene: &Scene, assets: &'a SceneAssets, aspect: f64) -> World<'a> {
        let cam = &scene.camera;
        let view = look_at(d3(cam.eye), d3(cam.target), d3(cam.up));
        let projection =
            perspective(f64::from(cam.fov_y_deg).to_radians(), aspect, cam.near.into(), cam.far.into());
        let light = light_projection(scene, assets);
        let objects = assets
            .meshes
            .iter()
            .map(|(mesh, model)| {
                let model = model.as_dmat4();
                Object {
                    mesh,
                    model,
                    camera_clip: projection * view * model,
                    light_clip: light * model,
                    model_view: view * model,
                }
            })
            .collect();
        let infinite_view = match cam.viewer {
            Viewer::Local => None,
            Viewer::Infinite => Some((d3(cam.eye) - d3(cam.target)).normalize_or_zero()),
        };
        World {
            objects,
            eye: d3(cam.eye),
            infinite_view,
            view,
            camera_vp: projection * view,
            light_vp: light,
        }
    }
}

/// gluLookAt: the eye at the origin looking down −z, `up` in the y-z plane.
fn look_at(eye: DVec3, centre: DVec3, up: DVec3) -> DMat4 {
    let f = (centre - eye).normalize();
    let s = f.cross(up).normalize();
    let u = s.cross(f);
    DMat4::from_cols(
        DVec4::new(s.x, u.x, -f.x, 0.0),
        DVec4::new(s.y, u.y, -f.y, 0.0),
        DVec4::new(s.z, u.z, -f.z, 0.0),
        DVec4::new(-s.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
    )
}

/// gluPerspective: GL clip space, z in −w..w between `near` and `far`.
fn perspective(fov_y: f64, aspect: f64, near: f64, far: f64) -> DMat4 {
    let f = 1.0 / (0.5 * fov_y).tan();
    DMat4::from_cols(
        DVec4::new(f / aspect, 0.0, 0.0, 0.0),
        DVec4::new(0.0, f, 0.0, 0.0),
        DVec4::new(0.0, 0.0, (far + near) / (near - far), -1.0),
        DVec4::new(0.0, 0.0, 2.0 * far * near / (near - far), 0.0),
    )
}

/// `πl`'s view-projection, as docs/language.md defines it: a perspective
/// from light 0's position (from 4 radii back along a directional light;
/// from above with no light) towards the centre of the scene's bounding
/// box, a 60° frustum (a spot: twice its cut-off, within 10-170°), square,
/// near and far around the scene's bounding sphere.
fn light_projection(scene: &Scene, assets: &SceneAssets) -> DMat4 {
    use crate::scene::Light;
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for (mesh, model) in &assets.meshes {
        for p in &mesh.positions {
            let w = model.as_dmat4().transform_point3(d3(*p));
            lo = lo.min(w);
            hi = hi.max(w);
        }
    }
    let (centre, radius) = if lo.is_finite() && hi.is_finite() {
        ((lo + hi) * 0.5, ((hi - lo) * 0.5).length().max(1e-3))
    } else {
        (DVec3::ZERO, 1.0)
    };
    let back = 4.0 * radius.max(1.0);
    let (eye, fov) = match scene.lights.first() {
        Some(Light::Point { position, .. }) => (d3(*position), 60.0),
        Some(Light::Spot { position, cutoff_deg, .. }) => {
            (d3(*position), (2.0 * f64::from(*cutoff_deg)).clamp(10.0, 170.0))
        }
        Some(Light::Directional { direction, .. }) => {
            (centre - d3(*direction).normalize_or_zero() * back, 60.0)
        }
        None => (centre + DVec3::Y * back, 60.0),
    };
    let d = (centre - eye).length().max(1e-3);
    let up = if (centre - eye).cross(DVec3::Y).length_squared() < 1e-6 * d * d { DVec3::Z } else { DVec3::Y };
    let near = (d - 2.0 * radius).max(d * 0.05);
    let far = d + 2.0 * radius.max(1.0);
    perspective(f64::to_radians(fov), 1.0, near, far) * look_at(eye, centre, up)
}

impl Object<'_> {
    /// Vertex `i` in the clip space of `view`.
    pub fn clip(&self, view: View, i: usize) -> DVec4 {
        match view {
            View::Camera => self.camera_clip * d3(self.mesh.positions[i]).extend(1.0),
            View::Light => self.light_clip * d3(self.mesh.positions[i]).extend(1.0),
            View::Texels => {
                let uv = self.mesh.uvs.get(i).copied().unwrap_or_default();
                DVec4::new(2.0 * f64::from(uv.x) - 1.0, 1.0 - 2.0 * f64::from(uv.y), 0.0, 1.0)
            }
        }
    }
}

/// A fragment: a point of one triangle of one object, by its perspective-
/// correct barycentric weights (GL §3.5.1, eq. 3.6: each attribute weighted
/// by λᵢ/wᵢ, normalized).
#[derive(Clone, Copy, Debug)]
pub struct Fragment {
    pub object: usize,
    pub triangle: usize,
    /// Perspective-correct weights of the triangle's three vertices.
    pub weights: [f64; 3],
    /// Window depth in [0, 1].
    pub depth: f64,
    pub pixel: (u32, u32),
    /// The projection the triangle was rasterized with.
    pub view: View,
}

/// Pixel (column, row; row 0 at the top) → normalized device coordinates.
pub fn pixel_ndc(x: f64, y: f64, width: u32, height: u32) -> (f64, f64) {
    (2.0 * x / f64::from(width) - 1.0, 1.0 - 2.0 * y / f64::from(height))
}

/// A vertex of a clipped polygon: its clip position and its weights over
/// the original triangle's three vertices (GL §2.12: a vertex made on a
/// clip plane is `t·P₁ + (1 − t)·P₂`, its attributes weighted alike).
type ClipVertex = (DVec4, [f64; 3]);

/// The triangle clipped to the near plane `z ≥ −w` in clip space (GL 1.x
/// §2.11-2.12: the view volume's near face, where a vertex behind the eye
/// has w ≤ 0 and lies outside it), Sutherland and Hodgman's way: walking
/// the edges, a vertex inside is kept and an edge crossing the plane adds
/// the point where `z + w = 0`. The result (empty, a triangle or a
/// quadrilateral) keeps the triangle's winding. The other five planes need
/// no clipping here: every vertex left has w > 0 and a pixel outside the
/// window or the depth range is simply not visited.
fn clip_near(c: [DVec4; 3]) -> Vec<ClipVertex> {
    let unit = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let d = c.map(|v| v.z + v.w);
    let mut out = Vec::with_capacity(4);
    for i in 0..3 {
        let j = (i + 1) % 3;
        if d[i] >= 0.0 {
            out.push((c[i], unit[i]));
        }
        if (d[i] >= 0.0) != (d[j] >= 0.0) {
            let t = d[i] / (d[i] - d[j]);
            let weights = std::array::from_fn(|k| (1.0 - t) * unit[i][k] + t * unit[j][k]);
            out.push((c[i] + (c[j] - c[i]) * t, weights));
        }
    }
    out
}

/// The triangles to rasterize for triangle `t` of `o`: the triangle itself
/// when every vertex is inside the near plane, else the fan of its clipped
/// polygon; each vertex with its weights over `t`'s vertices.
fn clipped_triangles(o: &Object, t: [u32; 3], view: View) -> Vec<[ClipVertex; 3]> {
    let c = t.map(|i| o.clip(view, i as usize));
    let poly = if view == View::Texels || c.iter().all(|v| v.z + v.w >= 0.0 && v.w > 1e-9) {
        vec![(c[0], [1.0, 0.0, 0.0]), (c[1], [0.0, 1.0, 0.0]), (c[2], [0.0, 0.0, 1.0])]
    } else {
        clip_near(c)
    };
    (2..poly.len())
        .map(|k| [poly[0], poly[k - 1], poly[k]])
        .filter(|v| v.iter().all(|v| v.0.w > 1e-12))
        .collect()
}

/// The perspective-correct weights of the window point `(nx, ny)` (NDC)
/// over a triangle with clip positions `clip`, any of whose w may be ≤ 0:
/// `k = M⁻¹ (nx, ny, 1)` with M's columns `(xᵢ, yᵢ, wᵢ)`, normalized to sum 1
/// — the point of the triangle's plane that projects there (Olano and
/// Greer 1997's 2-D homogeneous form of eq. 3.6).
fn homogeneous_weights(clip: [DVec4; 3], nx: f64, ny: f64) -> Option<[f64; 3]> {
    let m = glam::DMat3::from_cols(
        DVec3::new(clip[0].x, clip[0].y, clip[0].w),
        DVec3::new(clip[1].x, clip[1].y, clip[1].w),
        DVec3::new(clip[2].x, clip[2].y, clip[2].w),
    );
    if m.determinant().abs() < 1e-300 {
        return None;
    }
    let k = m.inverse() * DVec3::new(nx, ny, 1.0);
    let s = k.x + k.y + k.z;
    (s.abs() > 1e-300).then(|| [k.x / s, k.y / s, k.z / s])
}

/// Window-space barycentrics λ of `(px, py)` (NDC) in the projected triangle
/// and whether it faces the viewer (counter-clockwise in NDC).
fn barycentric(ndc: &[DVec3; 3], px: f64, py: f64) -> Option<([f64; 3], bool)> {
    let [a, b, c] = ndc;
    let area = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
    if area.abs() < 1e-300 {
        return None;
    }
    let l1 = ((px - a.x) * (c.y - a.y) - (c.x - a.x) * (py - a.y)) / area;
    let l2 = ((b.x - a.x) * (py - a.y) - (px - a.x) * (b.y - a.y)) / area;
    Some(([1.0 - l1 - l2, l1, l2], area > 0.0))
}

/// The perspective-correct weights from window-space λ and the vertices' w.
fn perspective_weights(l: [f64; 3], w: [f64; 3]) -> [f64; 3] {
    let q = [l[0] / w[0], l[1] / w[1], l[2] / w[2]];
    let s = q[0] + q[1] + q[2];
    [q[0] / s, q[1] / s, q[2] / s]
}

/// The visible fragment of every pixel.
pub struct Coverage {
    pub width: u32,
    pub height: u32,
    pub fragments: Vec<Option<Fragment>>,
}

impl Coverage {
    /// For every pixel, the nearest front-facing triangle whose projection
    /// contains the pixel centre (inside the depth range).
    pub fn find(world: &World, width: u32, height: u32) -> Coverage {
        Coverage::find_in(world, width, height, View::Camera)
    }

    /// [`Coverage::find`] under `view`; over texels, every triangle (no
    /// culling) and the last one drawn at a texel keeps it (no depth test),
    /// as a pass rendering in texture space draws (docs/pass-plan.md).
    pub fn find_in(world: &World, width: u32, height: u32, view: View) -> Coverage {
        let mut fragments: Vec<Option<Fragment>> = vec![None; (width * height) as usize];
        each_fragment(world, width, height, view, &mut |f| {
            let slot = &mut fragments[(f.pixel.1 * width + f.pixel.0) as usize];
            if view == View::Texels || slot.is_none_or(|g| f.depth < g.depth) {
                *slot = Some(f);
            }
        });
        Coverage { width, height, fragments }
    }

    /// The same triangle's fragment at another window position (a pixel
    /// centre offset by `(dx, dy)` pixels), extrapolated on its plane: what
    /// the derivatives of GL §3.8.8's level of detail are taken from.
    pub fn offset(&self, world: &World, f: &Fragment, dx: f64, dy: f64) -> Fragment {
        let o = &world.objects[f.object];
        let t = o.mesh.triangles[f.triangle];
        let clip = t.map(|i| o.clip(f.view, i as usize));
        let ndc = clip.map(|c| c.truncate() / c.w);
        let (nx, ny) = pixel_ndc(
            f64::from(f.pixel.0) + 0.5 + dx,
            f64::from(f.pixel.1) + 0.5 + dy,
            self.width,
            self.height,
        );
        if clip.iter().any(|c| c.w <= 1e-9) {
            // A vertex behind the eye has no window position.
            let weights = homogeneous_weights(clip, nx, ny).unwrap_or(f.weights);
            return Fragment { weights, ..*f };
        }
        match barycentric(&ndc, nx, ny) {
            Some((l, _)) => Fragment { weights: perspective_weights(l, clip.map(|c| c.w)), ..*f },
            None => *f,
        }
    }
}

/// Every fragment of every triangle under `view`: each pixel centre inside
/// a triangle facing the viewer (either facing over texels), within the
/// depth range, handed to `visit`; a triangle crossing the near plane
/// clipped first (`clip_near`).
pub fn each_fragment(world: &World, width: u32, height: u32, view: View, visit: &mut dyn FnMut(Fragment)) {
    for (oi, o) in world.objects.iter().enumerate() {
        for (ti, t) in o.mesh.triangles.iter().enumerate() {
            for part in clipped_triangles(o, *t, view) {
                rasterize(part, width, height, view, &mut |pixel, weights, depth| {
                    visit(Fragment { object: oi, triangle: ti, weights, depth, pixel, view });
                });
            }
        }
    }
}

/// The pixels whose centres lie in triangle `part` (facing the viewer,
/// either facing over texels, within the depth range), each with the
/// perspective-correct weights over the original triangle's vertices and
/// its window depth.
fn rasterize(
    part: [ClipVertex; 3],
    width: u32,
    height: u32,
    view: View,
    visit: &mut dyn FnMut((u32, u32), [f64; 3], f64),
) {
    let clip = part.map(|p| p.0);
    let ndc = clip.map(|c| c.truncate() / c.w);
    let w = clip.map(|c| c.w);
    // The pixels whose centres the triangle's bounds include.
    let to_px = |x: f64, size: u32| (x + 1.0) * 0.5 * f64::from(size);
    let (xs, ys): (Vec<f64>, Vec<f64>) = ndc.iter().map(|v| (to_px(v.x, width), to_px(-v.y, height))).unzip();
    let range = |v: &[f64], size: u32| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min).floor().max(0.0) as u32;
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max).ceil().min(f64::from(size)) as u32;
        lo..hi
    };
    for py in range(&ys, height) {
        for px in range(&xs, width) {
            let (nx, ny) = pixel_ndc(f64::from(px) + 0.5, f64::from(py) + 0.5, width, height);
            let Some((l, front)) = barycentric(&ndc, nx, ny) else { continue };
            if !(front || view == View::Texels) || l.iter().any(|&v| v < 0.0) {
                continue;
            }
            let z = l[0] * ndc[0].z + l[1] * ndc[1].z + l[2] * ndc[2].z;
            let depth = 0.5 * z + 0.5;
            if !(0.0..=1.0).contains(&depth) {
                continue;
            }
            let sub = perspective_weights(l, w);
            let weights = std::array::from_fn(|k| (0..3).map(|v| sub[v] * part[v].1[k]).sum());
            visit((px, py), weights, depth);
        }
    }
}
