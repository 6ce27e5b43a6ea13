//! Perspective-correct interpolation and the depth-equal re-rendering test.
use crate::common;

use common::{ClipVertices, Constant, VaryingsAsColor};
use glam::{Vec3, Vec4};
use shadec::renderer::{
    draw, BlendState, ColorFormat, CompareFunc, CullMode, DepthState, Fragment, FragmentResult,
    FragmentStage, Framebuffer, Pass, RenderState,
};
use shadec::scene::camera::perspective_gl;

/// A large triangle on the tilted plane z = −4 − 0.8·x (eye space), seen in
/// perspective; each vertex carries its eye-space (x, y). At every pixel the
/// interpolated varyings must equal the eye-space point where the pixel's
/// ray hits the plane.
#[test]
fn interpolation_is_perspective_correct_against_ray_plane_intersection() {
    let (w, h) = (64u32, 48u32);
    let aspect = w as f32 / h as f32;
    let fov = 1.0f32;
    let proj = perspective_gl(fov, aspect, 0.1, 100.0);
    let plane_z = |x: f32| -4.0 - 0.8 * x;
    let eye = [
        Vec3::new(-3.0, -2.0, plane_z(-3.0)),
        Vec3::new(4.0, -2.5, plane_z(4.0)),
        Vec3::new(0.5, 3.0, plane_z(0.5)),
    ];
    let clip = eye.iter().map(|p| (proj * p.extend(1.0)).to_array()).collect();
    let varyings = eye.iter().flat_map(|p| [p.x, p.y]).collect();
    let verts = ClipVertices { clip, varyings, n: 2 };
    let mut fb = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
    fb.clear_color([f32::NAN; 4]);
    let state = RenderState { cull: CullMode::None, ..RenderState::default() };
    let stats =
        draw(&mut fb, &Pass { triangles: &[[0, 1, 2]], vertex: &verts, fragment: &VaryingsAsColor, state })
            .unwrap();
    assert!(stats.written > 500, "{stats:?}");
    let tan = (fov / 2.0).tan();
    let mut checked = 0;
    let mut worst = 0.0f32;
    for y in 0..h {
        for x in 0..w {
            let c = fb.color(x, y).unwrap();
            if c[0].is_nan() {
                continue;
            }
            let xn = 2.0 * (x as f32 + 0.5) / w as f32 - 1.0;
            let yn = 1.0 - 2.0 * (y as f32 + 0.5) / h as f32;
            let dir = Vec3::new(xn * tan * aspect, yn * tan, -1.0);
            // Ray t·dir on the plane z = −4 − 0.8·x: −t = −4 − 0.8·t·dx.
            let t = 4.0 / (1.0 - 0.8 * dir.x);
            let hit = dir * t;
            worst = worst.max((c[0] - hit.x).abs()).max((c[1] - hit.y).abs());
            // Linear (affine) interpolation would be off by much more than this.
            checked += 1;
        }
    }
    assert!(checked as u64 == stats.written);
    assert!(worst < 2e-3, "worst error {worst}");
}

/// Depth of a pixel is the same whenever the same triangle covers it, so a
/// second pass with `Equal` touches exactly the pixels where pass 1 left the
/// visible surface — on a sphere drawn with no culling (back faces lose).
#[test]
fn depth_equal_rerender_touches_exactly_the_visible_pixels() {
    let (w, h) = (80u32, 80u32);
    let (clip, tris) = sphere_clip(24, 16);
    let verts = ClipVertices { clip, varyings: Vec::new(), n: 0 };
    let mut fb = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
    let first = RenderState { cull: CullMode::None, depth: DepthState::LESS_WRITE, ..RenderState::default() };
    draw(
        &mut fb,
        &Pass { triangles: &tris, vertex: &verts, fragment: &Constant([1.0, 0.0, 0.0, 0.0]), state: first },
    )
    .unwrap();
    let again = RenderState {
        cull: CullMode::None,
        depth: DepthState::EQUAL_NO_WRITE,
        blend: BlendState::ADD,
        ..RenderState::default()
    };
    let stats = draw(
        &mut fb,
        &Pass { triangles: &tris, vertex: &verts, fragment: &Constant([0.0, 1.0, 0.0, 0.0]), state: again },
    )
    .unwrap();
    let image = fb.to_rgba_f32();
    let visible = image.iter().filter(|c| c[0] == 1.0).count();
    assert!(visible > 1000);
    for c in &image {
        assert_eq!(c[1], c[0], "re-render must add exactly once where visible, never elsewhere");
    }
    assert!(stats.fragments > stats.written, "back faces must have failed the equal test");
    assert_eq!(stats.written as usize, visible);
}

/// A UV sphere of radius 1 at z = −3 projected with a 60° camera.
fn sphere_clip(slices: u32, stacks: u32) -> (Vec<[f32; 4]>, Vec<[u32; 3]>) {
    let proj = perspective_gl(1.0, 1.0, 0.5, 10.0);
    let mut clip = Vec::new();
    for j in 0..=stacks {
        let phi = std::f32::consts::PI * j as f32 / stacks as f32;
        for i in 0..=slices {
            let theta = std::f32::consts::TAU * i as f32 / slices as f32;
            let p = Vec4::new(phi.sin() * theta.cos(), phi.cos(), phi.sin() * theta.sin() - 3.0, 1.0);
            clip.push((proj * p).to_array());
        }
    }
    let mut tris = Vec::new();
    for j in 0..stacks {
        for i in 0..slices {
            let a = j * (slices + 1) + i;
            let b = a + slices + 1;
            tris.push([a, b, a + 1]);
            tris.push([a + 1, b, b + 1]);
        }
    }
    (clip, tris)
}

/// Derivatives handed to the fragment stage match finite differences of the
/// interpolated varyings.
#[test]
fn fragment_derivatives_match_finite_differences() {
    struct Probe;
    impl FragmentStage for Probe {
        fn shade(&self, f: &Fragment, v: &[f32], out: &mut [f32; 4]) -> FragmentResult {
            let d = f.derivatives(0, v[0]);
            *out = [v[0], d[0], d[1], 0.0];
            FragmentResult::Keep
        }
    }
    let (w, h) = (32u32, 32u32);
    let proj = perspective_gl(1.2, 1.0, 0.1, 50.0);
    let eye = [Vec3::new(-3.0, -3.0, -3.0), Vec3::new(3.0, -3.0, -9.0), Vec3::new(0.0, 3.0, -5.0)];
    let clip = eye.iter().map(|p| (proj * p.extend(1.0)).to_array()).collect();
    let verts = ClipVertices { clip, varyings: vec![0.0, 10.0, 5.0], n: 1 };
    let mut fb = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
    fb.clear_color([f32::NAN; 4]);
    let state = RenderState {
        cull: CullMode::None,
        depth: DepthState { func: CompareFunc::Always, write: false },
        ..RenderState::default()
    };
    draw(&mut fb, &Pass { triangles: &[[0, 1, 2]], vertex: &verts, fragment: &Probe, state }).unwrap();
    let mut checked = 0;
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let c = fb.color(x, y).unwrap();
            let (l, r) = (fb.color(x - 1, y).unwrap(), fb.color(x + 1, y).unwrap());
            let (u, d) = (fb.color(x, y - 1).unwrap(), fb.color(x, y + 1).unwrap());
            if [c, l, r, u, d].iter().any(|p| p[0].is_nan()) {
                continue;
            }
            let ddx = (r[0] - l[0]) / 2.0;
            let ddy = (d[0] - u[0]) / 2.0;
            assert!((c[1] - ddx).abs() < 0.02 * (1.0 + ddx.abs()), "ddx {} vs {}", c[1], ddx);
            assert!((c[2] - ddy).abs() < 0.02 * (1.0 + ddy.abs()), "ddy {} vs {}", c[2], ddy);
            checked += 1;
        }
    }
    assert!(checked > 50);
}
