//! What a frame draws, as the cost model needs it: per object its vertices,
//! triangles and the pixels its front and back faces cover (overdraw
//! counted, clipped to the screen) and the resolution. Either measured from
//! a scene, or the nominal
//! workload of GeForce3 Phong, Section 5.4: "a screen-filling mesh with 20k
//! triangles".

use glam::{Mat4, Vec2, Vec4};

use crate::pipeline::{CullMode, Geometry, Pass, RenderTarget};
use crate::scene::mesh::Mesh;
use crate::scene::Scene;

/// The size of a texture statements render into (texture shading).
const RENDERED_TEXTURE_SIDE: u64 = crate::pipeline::RENDERED_TEXTURE_SIZE as u64;

/// One object's share of the frame.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectLoad {
    pub vertices: u64,
    pub triangles: u64,
    /// Pixels the front faces (counter-clockwise on screen) cover.
    pub front_pixels: f64,
    /// Pixels the back faces cover.
    pub back_pixels: f64,
}

/// A frame's drawing work.
#[derive(Clone, Debug, PartialEq)]
pub struct Workload {
    /// Said beside every prediction.
    pub name: String,
    pub resolution: (u32, u32),
    pub objects: Vec<ObjectLoad>,
}

/// What one pass draws.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PassLoad {
    pub vertices: u64,
    pub triangles: u64,
    pub pixels: u64,
    /// Pixels of a texture target copied after the pass.
    pub target_pixels: u64,
}

impl Workload {
    /// GeForce3 Phong, Section 5.4's timing setup: a screen-filling mesh of
    /// 20 000 triangles (a 100 × 100 grid, 10 201 vertices), at 1280 × 1024
    /// as `scenes/screen_mesh_20k.ron`. What a plan is predicted on when no
    /// scene is given.
    pub fn nominal() -> Workload {
        let (w, h) = (1280, 1024);
        Workload {
            name: "a screen-filling mesh of 20 000 triangles at 1280×1024 (GeForce3 Phong, §5.4)".into(),
            resolution: (w, h),
            objects: vec![ObjectLoad {
                vertices: 101 * 101,
                triangles: 20_000,
                front_pixels: f64::from(w * h),
                back_pixels: 0.0,
            }],
        }
    }

    /// The workload of `scene` with its built meshes (`SceneAssets::meshes`).
    pub fn of_scene(scene: &Scene, meshes: &[(Mesh, Mat4)], name: &str) -> Workload {
        let (w, h) = scene.resolution;
        let aspect = w as f32 / h.max(1) as f32;
        let view_projection = scene.camera.view_projection(aspect);
        let objects = meshes
            .iter()
            .map(|(mesh, model)| object_load(mesh, view_projection * *model, scene.resolution))
            .collect();
        Workload { name: format!("{name} at {w}×{h}"), resolution: scene.resolution, objects }
    }

    /// What `pass` draws.
    pub fn pass_load(&self, pass: &Pass) -> PassLoad {
        let screen = u64::from(self.resolution.0) * u64::from(self.resolution.1);
        let target_pixels = match &pass.target {
            RenderTarget::Temporary { .. } => screen,
            RenderTarget::Texture { .. } => RENDERED_TEXTURE_SIDE * RENDERED_TEXTURE_SIDE,
            RenderTarget::Framebuffer { .. } => 0,
        };
        let quad = |pixels| PassLoad { vertices: 4, triangles: 2, pixels, target_pixels };
        match pass.geometry {
            Geometry::Screen => quad(screen),
            Geometry::Texels => quad(RENDERED_TEXTURE_SIDE * RENDERED_TEXTURE_SIDE),
            Geometry::Mesh { .. } => {
                let mut load = PassLoad { target_pixels, ..PassLoad::default() };
                let mut pixels = 0.0;
                for (i, o) in self.objects.iter().enumerate() {
                    if pass.objects.as_ref().is_some_and(|only| !only.contains(&i)) {
                        continue;
                    }
                    load.vertices += o.vertices;
                    load.triangles += o.triangles;
                    pixels += match pass.state.cull {
                        CullMode::Back => o.front_pixels,
                        CullMode::Front => o.back_pixels,
                        CullMode::None => o.front_pixels + o.back_pixels,
                    };
                }
                load.pixels = pixels.round() as u64;
                load
            }
        }
    }
}

/// The vertices, triangles and covered pixels of one mesh drawn with
/// `clip_from_model` at `resolution`.
fn object_load(mesh: &Mesh, clip_from_model: Mat4, resolution: (u32, u32)) -> ObjectLoad {
    let clip: Vec<Vec4> = mesh.positions.iter().map(|p| clip_from_model * p.extend(1.0)).collect();
    let half = Vec2::new(resolution.0 as f32, resolution.1 as f32) / 2.0;
    let (mut front, mut back) = (0.0, 0.0);
    for t in &mesh.triangles {
        let corners = [clip[t[0] as usize], clip[t[1] as usize], clip[t[2] as usize]];
        let area = f64::from(screen_area(corners)) * f64::from(half.x * half.y);
        if area > 0.0 {
            front += area;
        } else {
            back -= area;
        }
    }
    ObjectLoad {
        vertices: mesh.positions.len() as u64,
        triangles: mesh.triangles.len() as u64,
        front_pixels: front,
        back_pixels: back,
    }
}

/// The signed area, in normalized device coordinates, of a clip-space
/// triangle's visible part: clipped to w > ε (in front of the eye), then to
/// the screen square [−1, 1]²; positive when counter-clockwise (GL's front).
pub fn screen_area(corners: [Vec4; 3]) -> f32 {
    const EPS: f32 = 1e-5;
    let in_front = clip_polygon(&corners, |v| v.w - EPS);
    let mut poly: Vec<Vec2> = in_front.iter().map(|v| Vec2::new(v.x / v.w, v.y / v.w)).collect();
    for (axis, sign) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)] {
        poly = clip_polygon(&poly, |p: &Vec2| 1.0 - sign * p[axis]);
    }
    let mut twice = 0.0;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        twice += a.x * b.y - b.x * a.y;
    }
    twice / 2.0
}

/// Sutherland–Hodgman against one plane: keeps where `inside(v) ≥ 0`.
fn clip_polygon<V>(poly: &[V], inside: impl Fn(&V) -> f32) -> Vec<V>
where
    V: Copy + std::ops::Sub<Output = V> + std::ops::Add<Output = V> + std::ops::Mul<f32, Output = V>,
{
    let mut out = Vec::with_capacity(poly.len() + 2);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (da, db) = (inside(&a), inside(&b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_inside_the_screen_keeps_its_area_and_winding() {
        let ccw =
            [Vec4::new(0.0, 0.0, 0.0, 1.0), Vec4::new(0.5, 0.0, 0.0, 1.0), Vec4::new(0.0, 0.5, 0.0, 1.0)];
        assert!((screen_area(ccw) - 0.125).abs() < 1e-6);
        let cw = [ccw[0], ccw[2], ccw[1]];
        assert!((screen_area(cw) + 0.125).abs() < 1e-6);
    }

    #[test]
    fn a_triangle_larger_than_the_screen_covers_the_screen_once() {
        let big = [
            Vec4::new(-10.0, -10.0, 0.0, 1.0),
            Vec4::new(30.0, -10.0, 0.0, 1.0),
            Vec4::new(-10.0, 30.0, 0.0, 1.0),
        ];
        assert!((screen_area(big) - 4.0).abs() < 1e-4, "{}", screen_area(big));
    }

    #[test]
    fn a_triangle_behind_the_eye_covers_nothing() {
        let behind =
            [Vec4::new(0.0, 0.0, 0.0, -1.0), Vec4::new(0.5, 0.0, 0.0, -1.0), Vec4::new(0.0, 0.5, 0.0, -1.0)];
        assert_eq!(screen_area(behind), 0.0);
    }
}
