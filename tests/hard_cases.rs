//! The hard cases of numerical stability (issue 6, part 6; docs/numerics.md).
//!
//! Each case renders a scene chosen to hit one singularity or precision
//! cliff of the papers' shading formulas, in every mode of the plan
//! renderer (`exact`, `f32`, `fixed9`) and, where the case has a meaning
//! there, in the native Phong stage (`renderer::lights`, seeds/004) and its
//! adaptive sample shading. Every render is checked for NaN and ±∞ twice:
//! in the float framebuffer (or the RGBA8 one of fixed9) and in the
//! fragment values *before* they were written (`Frame::nonfinite`), since
//! the renderer writes a NaN as 0 and that must not hide one. Then each case
//! asserts its expected behaviour: an error bound where the maths gives one,
//! the documented fallback where it does not.

use crate::adaptive_common;

use std::path::{Path, PathBuf};

use adaptive_common::max_diff;
use glam::{Vec3, Vec4};
use shadec::numerics::fixed9;
use shadec::numerics::Precision;
use shadec::profile::Profile;
use shadec::renderer::lights::LitScene;
use shadec::renderer::plan::PlanRenderer;
use shadec::renderer::{AdaptiveSettings, ColorFormat, EdgeMode, Framebuffer};
use shadec::scene::Scene;
use shadec::textures::generators::{self, HeightField, NormalMapFormat};

const MODES: [Precision; 3] = [Precision::Exact, Precision::F32, Precision::Fixed9];

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn data() -> PathBuf {
    root().join("tests/data/hard")
}

fn example(name: &str) -> String {
    std::fs::read_to_string(root().join("examples").join(name)).unwrap()
}

/// A scene from RON text, anchored in `tests/data/hard/` (OBJ files resolve there).
fn scene(ron: &str) -> Scene {
    Scene::parse(ron, &data().join("scene.ron")).unwrap_or_else(|e| panic!("{e}"))
}

/// One rendered image.
struct Image {
    mode: Precision,
    width: usize,
    height: usize,
    pixels: Vec<[f32; 4]>,
}

impl Image {
    fn at(&self, x: usize, y: usize) -> [f32; 4] {
        self.pixels[y * self.width + x]
    }
    /// Pixels a fragment was written to (alpha 1; the clear colour is 0).
    fn covered(&self) -> impl Iterator<Item = (usize, [f32; 4])> + '_ {
        self.pixels.iter().copied().enumerate().filter(|(_, p)| p[3] > 0.5)
    }
    fn max_rgb(&self) -> f32 {
        self.pixels.iter().map(|p| p[0].max(p[1]).max(p[2])).fold(0.0, f32::max)
    }
}

/// No NaN or ±∞ in an image.
fn assert_finite(what: &str, pixels: &[[f32; 4]]) {
    let bad = pixels.iter().filter(|p| p.iter().any(|c| !c.is_finite())).count();
    assert_eq!(bad, 0, "{what}: {bad} pixels hold NaN or ±∞");
}

/// Plans `source` for `target` and renders it for `scene` in `mode` at the
/// scene's resolution, asserting that no value anywhere was NaN or ±∞.
fn render(what: &str, source: &str, target: &str, scene: &Scene, mode: Precision) -> Image {
    let (image, nonfinite) = render_counting(what, source, target, scene, mode);
    assert_eq!(
        nonfinite,
        0,
        "{what} [{}]: {nonfinite} fragments computed NaN or ±∞ (written as 0)",
        mode.name()
    );
    image
}

/// [`render`], returning how many fragments computed NaN or ±∞ instead of
/// failing on them (the image itself must still be finite).
fn render_counting(what: &str, source: &str, target: &str, scene: &Scene, mode: Precision) -> (Image, u64) {
    let profile = Profile::resolve(target).unwrap();
    let planned = shadec::driver::compile(source, &profile, &Default::default())
        .map(|c| c.planned)
        .unwrap_or_else(|d| panic!("{what}: {d:?}"));
    let (program, _) = shadec::parser::check(source);
    let assets = scene.build().unwrap();
    let mut r =
        PlanRenderer::new(&planned, &program, scene, &assets).unwrap_or_else(|e| panic!("{what}: {e}"));
    // The hard cases probe the arithmetic, values past 1 included.
    r.set_unrounded_targets(true);
    let (w, h) = scene.resolution;
    let frame = r.render(mode, w, h, &mut |_, _| {}).unwrap_or_else(|e| panic!("{what}: {e}"));
    let what = format!("{what} [{}]", mode.name());
    let pixels = frame.image.to_rgba_f32();
    assert_finite(&what, &pixels);
    assert!(frame.stats.written > 0, "{what}: nothing drawn");
    (Image { mode, width: w as usize, height: h as usize, pixels }, frame.nonfinite)
}

fn render_modes(what: &str, source: &str, target: &str, scene: &Scene) -> Vec<Image> {
    MODES.iter().map(|&m| render(what, source, target, scene, m)).collect()
}

/// The native Phong stage (seeds/004 Section 3.3): full per-pixel shading
/// and adaptive sample shading (Section 2.1), both checked for NaN/∞.
fn native(what: &str, scene: &Scene) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let assets = scene.build().unwrap();
    let lit = LitScene::new(scene, &assets, None);
    let (w, h) = scene.resolution;
    let mut full = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
    lit.draw_full(&mut full).unwrap();
    let mut adaptive = Framebuffer::new(w, h, ColorFormat::F32).unwrap();
    lit.draw_adaptive(&mut adaptive, &AdaptiveSettings::new(8, 0.05, EdgeMode::Triangle)).unwrap();
    let (full, adaptive) = (full.to_rgba_f32(), adaptive.to_rgba_f32());
    assert_finite(&format!("{what} [native]"), &full);
    assert_finite(&format!("{what} [adaptive]"), &adaptive);
    (full, adaptive)
}

/// Largest per-channel RGB difference between two images, both clamped to
/// [0, 1] (what a display shows; fixed9's framebuffer is 8-bit).
fn max_error(a: &Image, b: &Image) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| max_diff(p.map(|c| c.clamp(0.0, 1.0)), q.map(|c| c.clamp(0.0, 1.0))))
        .fold(0.0, f32::max)
}

/// Pixel (x, y) centre → the world point where its ray meets the plane y = 0.
fn unproject_to_ground(scene: &Scene, x: usize, y: usize) -> Option<Vec3> {
    let (w, h) = scene.resolution;
    let inv = scene.camera.view_projection(w as f32 / h as f32).inverse();
    let ndc_x = (x as f32 + 0.5) / w as f32 * 2.0 - 1.0;
    let ndc_y = 1.0 - (y as f32 + 0.5) / h as f32 * 2.0;
    let near = inv * Vec4::new(ndc_x, ndc_y, -1.0, 1.0);
    let far = inv * Vec4::new(ndc_x, ndc_y, 1.0, 1.0);
    let (near, far) = (near.truncate() / near.w, far.truncate() / far.w);
    let d = far - near;
    if d.y.abs() < 1e-9 {
        return None;
    }
    let t = -near.y / d.y;
    (t > 0.0).then(|| near + d * t)
}

/// World point → pixel.
fn project(scene: &Scene, p: Vec3) -> (f32, f32) {
    let (w, h) = scene.resolution;
    let c = scene.camera.view_projection(w as f32 / h as f32) * p.extend(1.0);
    ((c.x / c.w * 0.5 + 0.5) * w as f32, (0.5 - c.y / c.w * 0.5) * h as f32)
}

// ---------------------------------------------------------------------------
// Grazing view: cos β → 0 in G/(π cos β) (seeds/002 Section 3.1).

/// A wide plane seen at a grazing angle (the eye 0.25 above it, 3 away:
/// cos β ≈ 0.08 at the centre) and lit from behind at the mirror angle, so
/// the highlight (N = H, D = 1) lies where cos β → 0.
const GRAZING: &str = r#"(
    resolution: (96, 64),
    camera: (eye: (0.0, 0.25, 3.0), target: (0.0, 0.0, 0.0), fov_y_deg: 30.0, near: 0.05, viewer: Local),
    lights: [Directional(direction: (0.0, -0.08, 1.0), color: (1.0, 1.0, 1.0))],
    objects: [(mesh: Plane(size: 8.0, subdivisions: 16), material: "m")],
    materials: { "m": (ambient: (0.1, 0.1, 0.1), diffuse: (0.3, 0.3, 0.35), specular: (0.5, 0.5, 0.5), shininess: 20.0) },
)"#;

/// sup over cos β ∈ (0, 1] of G1(cos β)/(π cos β), Smith's masking with
/// roughness m: the bound of the Heidrich-Seidel geometry factor. Smith's
/// G1 vanishes like cos β at grazing view, so the quotient tends to
/// 3.535/(π m) instead of the singularity a constant G would give.
fn geometry_factor_sup(m: f32) -> f32 {
    let mut sup = 0.0f32;
    for k in 0..=20000 {
        // Log-spaced towards 0 and linear up to 1.
        let c = if k < 10000 {
            1e-6f32 * (1e6f32).powf(k as f32 / 10000.0)
        } else {
            (k - 10000) as f32 / 10000.0
        };
        let c = c.max(1e-6);
        sup = sup.max(generators::smith_g1(c, m) / (std::f32::consts::PI * c));
    }
    sup
}

/// The example's output, `I_light * g_scale * (F·D ⊕ G/(π cos β)/g_scale)`,
/// with the scale applied to the product instead — how the combiners apply
/// it, as the output scale of the stage that multiplies the two texels
/// (seeds/003 Section 4.2, "scale by four"). fixed9 models every IR
/// operation as one clamped register write, so there the order matters.
fn scale_on_the_product(source: &str) -> String {
    let from = "I_light * g_scale * ((Tfd δu x) ⊕ (Tg δu′ x))";
    assert!(source.contains(from));
    source.replace(from, "((Tfd δu x) ⊕ (Tg δu′ x)) * g_scale * I_light")
}

#[test]
fn grazing_view_geometry_factor_is_bounded_and_scaling_avoids_the_clamp() {
    let scene = scene(GRAZING);
    let scaled = example("torrance_sparrow_factored.shd");
    assert!(scaled.contains("const g_scale = 4;"));
    let unscaled = scaled.replace("const g_scale = 4;", "const g_scale = 1;");
    let sup = geometry_factor_sup(0.3);
    // The limit 3.535/(π m) of the rational Smith approximation.
    assert!((sup - 3.535 / (std::f32::consts::PI * 0.3)).abs() < 0.02, "sup G/(π cos β) = {sup}");
    let s4 = render_modes("Torrance-Sparrow, g_scale 4", &scaled, "wgsl", &scene);
    let s1 = render_modes("Torrance-Sparrow, g_scale 1", &unscaled, "wgsl", &scene);
    let p4 = render(
        "Torrance-Sparrow, g_scale 4, ×4 on the product",
        &scale_on_the_product(&scaled),
        "wgsl",
        &scene,
        Precision::Fixed9,
    );
    let p1 = render(
        "Torrance-Sparrow, g_scale 1, ×1 on the product",
        &scale_on_the_product(&unscaled),
        "wgsl",
        &scene,
        Precision::Fixed9,
    );
    // Exact: F·D ≤ 1, G/(π cos β) ≤ sup, plus the diffuse term kd·max(0, N·L) ≤ 0.35.
    let bound = sup + 0.35 + 1e-4;
    for img in [&s4[0], &s1[0]] {
        assert!(img.max_rgb() <= bound, "exact radiance {} above the analytic bound {bound}", img.max_rgb());
    }
    assert!(s4[0].max_rgb() > 1.0, "the highlight at grazing view needs G/(π cos β) > 1");
    // The constant is exactly multiplied back: exact does not see it.
    let e = max_error(&s4[0], &s1[0]);
    assert!(e < 1e-5, "exact images differ by {e} between g_scale 4 and 1");
    // Stored tables: g_scale 4 keeps the grazing values inside [0, 1]
    // (sup/4 < 1), g_scale 1 clamps them and renders grazing areas too dark
    // (seeds/002 Section 3.1: "areas around the grazing angles can be
    // rendered too dark ... reduced by dividing the values stored in the
    // texture by a constant").
    assert!(sup / 4.0 < 1.0);
    for (with, without) in [(&s4[1], &s1[1]), (&p4, &p1)] {
        let mode = with.mode.name();
        let (e4, e1) = (max_error(&s4[0], with), max_error(&s1[0], without));
        let darker =
            without.pixels.iter().zip(&s1[0].pixels).filter(|(t, x)| t[0] < x[0].min(1.0) - 0.05).count();
        eprintln!("grazing {mode}: max error g_scale 4 = {e4:.4}, g_scale 1 = {e1:.4}; {darker} pixels too dark by > 0.05");
        assert!(e4 <= 0.04, "{mode}: g_scale 4 error {e4} over its bound");
        assert!(
            e1 > 0.3 && darker > 50,
            "{mode}: the clamp darkens the grazing highlight ({e1}, {darker} pixels)"
        );
    }
    native("grazing plane", &scene);
}

/// The example's `I_light * g_scale * (…)`: the constant product
/// `I_light * g_scale` = 4 is folded by the compiler into a constant register
/// and an output scale (`scale_by_four`, seeds/003 Section 4.2), so fixed9
/// keeps the paper's scale; clamping it to the combiners' [−1, 1] before the
/// texels are multiplied made the term 4× too dark (max error 0.73).
#[test]
fn grazing_fixed9_keeps_a_leading_constant_scale() {
    let scene = scene(GRAZING);
    let src = example("torrance_sparrow_factored.shd");
    let exact = render("Torrance-Sparrow", &src, "wgsl", &scene, Precision::Exact);
    let fixed = render("Torrance-Sparrow", &src, "wgsl", &scene, Precision::Fixed9);
    let e = max_error(&exact, &fixed);
    assert!(e <= 0.04, "fixed9 error {e}");
}

/// The exact reference's G/(π cos β) is evaluated at cos β clamped to
/// [1e-6, 1] (a back-facing view, which interpolated normals give at
/// silhouettes, takes the grazing limit, as the clamp-to-edge table does).
#[test]
fn grazing_limit_of_the_exact_geometry_function() {
    use shadec::renderer::plan::exact_lookup;
    use shadec::scene::bind::ExactFunction;
    let f = ExactFunction::Geometry { roughness: 0.3, scale: 1.0 };
    let sup = geometry_factor_sup(0.3);
    for cos_beta in [1.0, 0.5, 1e-3, 1e-7, 0.0, -0.5, -1.0] {
        for cos_alpha in [1.0, 0.3, 0.0] {
            let v = exact_lookup(f, [cos_alpha, cos_beta, 0.0, 0.0]);
            assert!(v.iter().all(|x| x.is_finite()), "{cos_alpha}, {cos_beta}: {v:?}");
            assert!(v[0] >= 0.0 && v[0] <= sup as f64 + 1e-3, "{cos_alpha}, {cos_beta}: {} > {sup}", v[0]);
        }
    }
    let limit = exact_lookup(f, [1.0, 0.0, 0.0, 0.0])[0];
    let near = exact_lookup(f, [1.0, 1e-3, 0.0, 0.0])[0];
    assert!((limit - near).abs() < 0.05, "continuous at grazing: {limit} vs {near}");
}

// ---------------------------------------------------------------------------
// L = −V: the half vector H = (L + V)/|L + V| is undefined.

/// An infinite viewer looking down −z (V = +z everywhere) and a directional
/// light shining towards the viewer (L = −z = −V).
const BACKLIT: &str = r#"(
    resolution: (64, 64),
    camera: (eye: (0.0, 0.0, 4.0), target: (0.0, 0.0, 0.0), fov_y_deg: 40.0, viewer: Infinite),
    lights: [Directional(direction: (0.0, 0.0, 1.0), color: (1.0, 1.0, 1.0))],
    objects: [(mesh: Sphere(radius: 1.0, slices: 32, stacks: 16), material: "m")],
    materials: { "m": (ambient: (0.2, 0.2, 0.2), diffuse: (0.8, 0.6, 0.4), specular: (1.0, 1.0, 1.0), shininess: 32.0) },
    ambient: (0.25, 0.25, 0.25),
)"#;

#[test]
fn light_opposite_the_viewer_half_vector_falls_back_to_zero() {
    let scene = scene(BACKLIT);
    // Every program with a half vector: per vertex (H = normalize(L + V),
    // Gouraud), per pixel (fragment lighting normalizes L + V), the binder's
    // `half` role (tangent space, unnormalized Phong), Kilgard's cube map.
    for (name, target) in [
        ("gouraud.shd", "wgsl"),
        ("fragment_lighting.shd", "wgsl"),
        // Written for geforce3, whose combiner generator cannot realize
        // them yet (the planner refuses them there): planned for wgsl.
        ("phong_unnormalized.shd", "wgsl"),
        ("phong_taylor_renormalized.shd", "wgsl"),
    ] {
        let images = render_modes(name, &example(name), target, &scene);
        // Where the sphere is seen, N·V ≥ 0, so N·L = −N·V ≤ 0: no diffuse,
        // and with H = 0 (normalize(0) = 0) no specular — GL's answer too,
        // whose specular term is 0 wherever N·L ≤ 0. The image is black.
        for img in &images {
            let brightest = img.covered().map(|(_, p)| p[0].max(p[1]).max(p[2])).fold(0.0, f32::max);
            eprintln!("L = −V, {name} [{}]: brightest pixel {brightest}", img.mode.name());
            assert!(img.covered().count() > 500, "{name}: the sphere is drawn");
            assert!(
                brightest <= 2.0 / 255.0,
                "{name} [{}]: light from an undefined half vector: {brightest}",
                img.mode.name()
            );
        }
    }
    // Kilgard: s_self = 0 gates the specular pass; the stored cube map holds
    // no zero vector (it returns +X's centre), exact uses H = 0.
    let images = render_modes("kilgard", &example("kilgard_bump_mapping.shd"), "geforce256", &scene);
    for img in &images[1..] {
        let e = max_error(&images[0], img);
        eprintln!("L = −V, kilgard [{}]: max error {e}", img.mode.name());
        assert!(e <= 3.0 / 255.0, "kilgard [{}]: {e}", img.mode.name());
    }
    // Native Phong: N·L ≤ 0 everywhere seen, so ambient only: ka·A = 0.2·0.25.
    let (full, adaptive) = native("L = −V", &scene);
    for (what, img) in [("native", &full), ("adaptive", &adaptive)] {
        for p in img.iter().filter(|p| p[3] > 0.5) {
            assert!(max_diff(*p, [0.05, 0.05, 0.05, 1.0]) < 1e-6, "{what}: {p:?}");
        }
    }
}

// ---------------------------------------------------------------------------
// Zero-length interpolated normal.

const ZERO_NORMALS: &str = r#"(
    resolution: (48, 48),
    camera: (eye: (0.0, 0.0, 3.0), target: (0.0, 0.0, 0.0), fov_y_deg: 50.0, viewer: Local),
    lights: [Point(position: (0.5, 1.0, 2.0), color: (1.0, 1.0, 1.0))],
    objects: [(mesh: Obj("zero_normals.obj"), material: "m")],
    materials: { "m": (ambient: (0.2, 0.2, 0.2), diffuse: (0.8, 0.6, 0.4), specular: (1.0, 1.0, 1.0), shininess: 32.0) },
    ambient: (0.25, 0.25, 0.25),
)"#;

#[test]
fn zero_length_normal_lights_nothing() {
    let scene = scene(ZERO_NORMALS);
    assert!(
        scene.build().unwrap().meshes[0].0.normals.iter().all(|n| *n == Vec3::ZERO),
        "the OBJ's normals stay zero"
    );
    for (name, target) in [("fragment_lighting.shd", "wgsl"), ("gouraud.shd", "wgsl")] {
        for img in render_modes(name, &example(name), target, &scene) {
            // normalize(0) = 0: N·L = N·H = 0, so nothing is lit.
            assert!(img.covered().count() > 300);
            let brightest = img.covered().map(|(_, p)| p[0].max(p[1]).max(p[2])).fold(0.0, f32::max);
            assert!(
                brightest == 0.0,
                "{name} [{}]: a zero normal lit a pixel ({brightest})",
                img.mode.name()
            );
        }
    }
    let (full, adaptive) = native("zero normals", &scene);
    for img in [&full, &adaptive] {
        for p in img.iter().filter(|p| p[3] > 0.5) {
            assert!(max_diff(*p, [0.05, 0.05, 0.05, 1.0]) < 1e-6, "{p:?}");
        }
    }
}

/// A program that divides by a cosine itself — Cook-Torrance's
/// ρ = F·D·G/(π (N·V)(N·L)), seeds/001 (17) — computes 0/0 where N = 0. No
/// IR fallback can choose that quotient for the program; the renderer
/// counts such fragments (`Frame::nonfinite`) and writes them as 0, as
/// Direct3D's float → UNORM conversion does with a NaN (docs/numerics.md).
#[test]
fn program_level_zero_over_zero_is_counted_and_written_as_zero() {
    let scene = scene(ZERO_NORMALS);
    for mode in MODES {
        let (img, nonfinite) =
            render_counting("cook_torrance.shd", &example("cook_torrance.shd"), "wgsl", &scene, mode);
        let covered = img.covered().count() as u64;
        eprintln!("Cook-Torrance with N = 0 [{}]: {nonfinite} of {covered} fragments NaN", mode.name());
        if mode == Precision::Fixed9 {
            // fixed9 clamps every operation's result to [−1, 1] (a NaN to 0): no NaN reaches the output.
            assert_eq!(nonfinite, 0);
        } else {
            assert!(nonfinite >= covered, "every covered fragment divides 0 by 0: {nonfinite} < {covered}");
        }
        assert!(img.covered().all(|(_, p)| p[..3] == [0.0; 3]), "written as 0");
    }
}

// ---------------------------------------------------------------------------
// Antipodal vectors across a triangle: N on one edge, −N on the other.

/// W odd: the quad's midline x = 0 (where N interpolates to zero) passes
/// through the centres of column 32.
const ANTIPODAL: &str = r#"(
    resolution: (65, 65),
    camera: (eye: (0.0, 0.0, 3.0), target: (0.0, 0.0, 0.0), fov_y_deg: 50.0, viewer: Infinite),
    lights: [Directional(direction: (0.0, 0.0, -1.0), color: (1.0, 1.0, 1.0))],
    objects: [(mesh: Obj("antipodal.obj"), material: "m")],
    materials: { "m": (ambient: (0.2, 0.2, 0.2), diffuse: (0.8, 0.6, 0.4), specular: (1.0, 1.0, 1.0), shininess: 32.0) },
    ambient: (0.25, 0.25, 0.25),
)"#;

#[test]
fn antipodal_normals_flip_at_the_zero_crossing() {
    let scene = scene(ANTIPODAL);
    let mid = 32usize;
    // Interpolating N and −N and renormalizing gives +N left of the midline
    // and −N right of it (no slerp between antipodes is defined): fragment
    // lighting shows exactly two colours, kd + ks facing the light and 0
    // facing away, and the zero vector's fallback (0) on the midline itself.
    let lit = [0.8f32 + 1.0, 0.6 + 1.0, 0.4 + 1.0];
    for img in render_modes("fragment_lighting", &example("fragment_lighting.shd"), "wgsl", &scene) {
        let mode = img.mode.name();
        let expect = |left: bool| -> [f32; 4] {
            let c = if left { lit } else { [0.0; 3] };
            let c = if img.mode == Precision::Fixed9 { c.map(|x| x.min(1.0)) } else { c };
            [c[0], c[1], c[2], 1.0]
        };
        let mut n = 0;
        for (i, p) in img.covered() {
            let x = i % img.width;
            let ok = |left: bool| max_diff(p, expect(left)) <= 1e-3;
            let fine = if x < mid {
                ok(true)
            } else if x > mid {
                ok(false)
            } else {
                ok(true) || ok(false)
            };
            assert!(fine, "{mode}: pixel ({x}, {}) = {p:?}", i / img.width);
            n += 1;
        }
        assert!(n > 1000, "{mode}: {n} pixels");
    }
    // Gouraud interpolates the two vertex colours: a ramp, never a NaN.
    for img in render_modes("gouraud", &example("gouraud.shd"), "wgsl", &scene) {
        let y = img.height / 2;
        let (l, c, r) = (img.at(20, y)[1], img.at(mid, y)[1], img.at(44, y)[1]);
        assert!(l > c && c > r && c > 0.05, "{}: a ramp {l} > {c} > {r}", img.mode.name());
    }
    let (full, _) = native("antipodal", &scene);
    for (i, p) in full.iter().enumerate().filter(|(_, p)| p[3] > 0.5) {
        let x = i % 65;
        let ambient = max_diff(*p, [0.05, 0.05, 0.05, 1.0]) < 1e-6;
        let bright = p[0] > 0.9;
        assert!(
            if x < mid {
                bright
            } else if x > mid {
                ambient
            } else {
                bright || ambient
            },
            "native ({x}): {p:?}"
        );
    }
}

// ---------------------------------------------------------------------------
// Exponents 64-256 in 8 bits.

/// A sphere lit from the camera: the highlight fills the middle.
const HIGHLIGHT_SPHERE: &str = r#"(
    resolution: (96, 96),
    camera: (eye: (0.0, 0.0, 4.0), target: (0.0, 0.0, 0.0), fov_y_deg: 40.0, viewer: Local),
    lights: [Directional(direction: (0.2, -0.1, -1.0), color: (1.0, 1.0, 1.0))],
    objects: [(mesh: Sphere(radius: 1.0, slices: 48, stacks: 24), material: "m")],
    materials: { "m": (ambient: (0.0, 0.0, 0.0), diffuse: (0.0, 0.0, 0.0), specular: (1.0, 1.0, 1.0), shininess: 128.0) },
)"#;

/// `max(0, N·H)^n`, H renormalized per pixel, in one of three forms.
fn specular_program(n: u32, form: &str) -> String {
    let mut s = String::from("vector H : half(0) in tangent;\nconst N : vec3 = (0, 0, 1);\nlet Hn = normalize(δ H s x);\nlet h = max(0, N·Hn);\n");
    match form {
        "squaring" => {
            // seeds/000 Section 5.2: repeated self multiplication.
            let mut k = 1;
            let mut prev = "h".to_string();
            while k < n {
                k *= 2;
                s += &format!("let h{k} = {prev} * {prev};\n");
                prev = format!("h{k}");
            }
            s += &format!("C δπx ← {prev};\n");
        }
        "pow" => s += &format!("C δπx ← h^{n};\n"),
        _ => {
            s += &format!("texture Texp : 1d r8 bilinear clamp = exponent_table({n});\n");
            s += "C δπx ← Texp h;\n";
        }
    }
    s
}

/// sup over x ∈ [0, 1] of |f(x) − xⁿ|, sampled finely (2·10⁵ points plus
/// every 8-bit grid point and its neighbours).
fn sup_error(n: u32, f: impl Fn(f64) -> f64) -> f64 {
    let mut xs: Vec<f64> = (0..=200_000).map(|k| k as f64 / 200_000.0).collect();
    for j in 0..=255 {
        let g = j as f64 / 255.0;
        xs.extend([g, g - 0.5 / 255.0, g + 0.5 / 255.0, g - 0.5 / 255.0 + 1e-12, g + 0.5 / 255.0 - 1e-12]);
    }
    xs.into_iter()
        .filter(|x| (0.0..=1.0).contains(x))
        .map(|x| (f(x) - x.powi(n as i32)).abs())
        .fold(0.0, f64::max)
}

/// The RMS of f(x) − xⁿ over x uniform in [0, 1].
fn rms_error(n: u32, f: impl Fn(f64) -> f64) -> f64 {
    let k = 100_000;
    ((0..=k).map(|i| i as f64 / k as f64).map(|x| (f(x) - x.powi(n as i32)).powi(2)).sum::<f64>()
        / (k + 1) as f64)
        .sqrt()
}

/// What 8-bit repeated squaring computes: the input rounded to the
/// combiners' grid, then every product rounded (fixed9).
fn squaring_chain(n: u32, x: f64) -> f64 {
    let mut h = fixed9(x);
    let mut k = 1;
    while k < n {
        h = fixed9(h * h);
        k *= 2;
    }
    h
}

#[test]
fn high_exponents_in_8_bits_stay_within_the_squaring_bound() {
    let scene = scene(HIGHLIGHT_SPHERE);
    for n in [64u32, 128, 256] {
        // The bounds, from the arithmetic alone.
        let b_squaring = sup_error(n, |x| squaring_chain(n, x));
        let b_pow = sup_error(n, |x| fixed9(fixed9(x).powi(n as i32)));
        let lut = generators::exponent_lut(256, n as f32, shadec::textures::TexelFormat::Rgba8);
        let b_lut =
            sup_error(n, |x| lut.sample(x as f32, 0.5, shadec::textures::Filter::Bilinear, 0.0)[0] as f64);
        // Below (1/510)^(1/n) every input squares to 0 — the highlight's
        // skirt vanishes — and the surviving inputs are the few 8-bit
        // steps near 1: the banding of seeds/000 Figure 10.
        let survivors = (0..=255).filter(|j| squaring_chain(n, *j as f64 / 255.0) > 0.0).count();
        eprintln!("n = {n}: sup error squaring {b_squaring:.4}, one rounded pow {b_pow:.4}, 8-bit table {b_lut:.4}; {survivors} nonzero levels");
        // In the sup norm both lose ≈ n/(2·255)·x^(n−1) near x = 1 (the
        // input's rounding, the table's last half texel); on average the
        // table is far closer (no banding).
        let (r_squaring, r_lut) = (
            rms_error(n, |x| squaring_chain(n, x)),
            rms_error(n, |x| lut.sample(x as f32, 0.5, shadec::textures::Filter::Bilinear, 0.0)[0] as f64),
        );
        eprintln!("n = {n}: rms error squaring {r_squaring:.5}, table {r_lut:.5}");
        assert!(r_lut < r_squaring, "n = {n}: the lookup table beats repeated squaring on average");
        assert!(survivors <= 1 + (255.0 * (1.0 - (1.0f64 / 510.0).powf(1.0 / n as f64))).ceil() as usize + 1);
        for form in ["squaring", "pow", "table"] {
            let src = specular_program(n, form);
            let images = render_modes(&format!("n = {n}, {form}"), &src, "wgsl", &scene);
            let exact = &images[0];
            assert!(exact.max_rgb() > 0.9, "n = {n}: the highlight is in view");
            let e_f32 = max_error(exact, &images[1]) as f64;
            let e_9 = max_error(exact, &images[2]) as f64;
            eprintln!("  {form}: max error f32 {e_f32:.4}, fixed9 {e_9:.4}");
            let tol = 2e-6 * n as f64; // f32 varyings against f64
            match form {
                "squaring" => {
                    assert!(e_f32 <= 1e-4, "n = {n}: f32 squaring {e_f32}");
                    assert!(e_9 <= b_squaring + tol, "n = {n}: fixed9 squaring {e_9} > bound {b_squaring}");
                }
                "pow" => {
                    assert!(e_f32 <= 1e-4, "n = {n}: f32 pow {e_f32}");
                    // Whether fixed9 models `^` as one rounded pow or as squaring.
                    assert!(e_9 <= b_pow.max(b_squaring) + tol, "n = {n}: fixed9 pow {e_9}");
                }
                _ => {
                    assert!(e_f32 <= b_lut + 1e-3, "n = {n}: table {e_f32} > bound {b_lut}");
                    assert!(e_9 <= b_lut + 1.0 / 255.0 + 1e-3, "n = {n}: fixed9 table {e_9}");
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------
// A highlight peaking inside one large triangle.

/// A 4×4 plane of two triangles; eye and point light at the same height, so
/// the Blinn and Phong highlights peak at the mirror point (0.8, 0, −0.4),
/// inside one triangle and far from every vertex.
const BIG_TRIANGLES: &str = r#"(
    resolution: (96, 96),
    camera: (eye: (0.0, 3.0, 3.0), target: (0.0, 0.0, 0.0), fov_y_deg: 60.0, viewer: Local),
    lights: [Point(position: (1.6, 3.0, -3.8), color: (1.0, 1.0, 1.0))],
    objects: [(mesh: Plane(size: 4.0, subdivisions: 1), material: "m")],
    materials: { "m": (ambient: (0.0, 0.0, 0.0), diffuse: (0.3, 0.2, 0.1), specular: (1.0, 1.0, 1.0), shininess: 32.0) },
)"#;

/// The brightest pixel (the first, if several).
fn brightest(pixels: &[[f32; 4]], width: usize) -> (f32, (usize, usize)) {
    let (i, v) = pixels
        .iter()
        .map(|p| p[0].max(p[1]).max(p[2]))
        .enumerate()
        .fold((0, 0.0f32), |a, (i, v)| if v > a.1 { (i, v) } else { a });
    (v, (i % width, i / width))
}

#[test]
fn highlight_inside_one_triangle_per_pixel_finds_it_gouraud_misses_it() {
    let scene = scene(BIG_TRIANGLES);
    let peak = project(&scene, Vec3::new(0.8, 0.0, -0.4));
    let near_peak = |(x, y): (usize, usize)| {
        ((x as f32 + 0.5 - peak.0).powi(2) + (y as f32 + 0.5 - peak.1).powi(2)).sqrt() <= 3.0
    };
    let phong = render_modes("fragment lighting", &example("fragment_lighting.shd"), "wgsl", &scene);
    let gouraud = render_modes("gouraud", &example("gouraud.shd"), "wgsl", &scene);
    for (p, g) in phong.iter().zip(&gouraud) {
        let mode = p.mode.name();
        let (vp, at) = brightest(&p.pixels, p.width);
        let (vg, at_g) = brightest(&g.pixels, g.width);
        // Blue: the smallest diffuse (kd = 0.4), the same specular (ks = 1).
        let m = (peak.0 as usize, peak.1 as usize);
        let (p_at_peak, g_at_peak) = (p.at(m.0, m.1)[2], g.at(m.0, m.1)[2]);
        eprintln!("highlight [{mode}]: per pixel {vp:.3} at {at:?} (mirror point at {peak:?}), blue there {p_at_peak:.3}; Gouraud's {g_at_peak:.3} there, brightest {vg:.3} at {at_g:?}");
        // ks·1 at the peak, plus diffuse (fixed9 clamps to 1).
        assert!(p_at_peak >= 0.99, "{mode}: per-pixel shading finds the highlight ({p_at_peak})");
        if p.mode != Precision::Fixed9 {
            assert!(near_peak(at), "{mode}: the brightest pixel is the mirror point: {at:?} vs {peak:?}");
        }
        // Gouraud interpolates vertex colours, whose highlight term
        // (N·H)^32 is ≈ 0 at every vertex: only the diffuse ramp remains.
        assert!(g_at_peak < 0.5, "{mode}: Gouraud misses the highlight ({g_at_peak} at the peak)");
        assert!(!near_peak(at_g), "{mode}: Gouraud's brightest pixel is not the highlight");
    }
    let (full, adaptive) = native("big triangles", &scene);
    // Phong's (M·L)^32 peaks at the same mirror point; the stage clamps to 1.
    let m = (peak.0 as usize, peak.1 as usize);
    let i = m.1 * 96 + m.0;
    let (vn, va) = (full[i][2], adaptive[i][2]);
    eprintln!("highlight [native]: blue {vn:.3} at the mirror point; adaptive {va:.3}");
    assert!(vn >= 0.99, "native Phong finds it: {vn}");
    assert!(va >= 0.99, "adaptive sample shading finds it: {va}");
}

// ---------------------------------------------------------------------------
// A spot cut-off crossing a triangle.

const SPOT_POSITION: [f32; 3] = [0.4, 2.0, 0.3];
const SPOT_DIRECTION: [f32; 3] = [-0.1, -1.0, -0.05];
const SPOT_CUTOFF_DEG: f32 = 15.0;

/// A 6×6 plane of two triangles under a sharp spot (exponent 0) whose cone
/// lies inside one triangle: every vertex is outside the cone.
fn spot_scene() -> Scene {
    let [px, py, pz] = SPOT_POSITION;
    let [dx, dy, dz] = SPOT_DIRECTION;
    scene(&format!(
        r#"(
    resolution: (96, 96),
    camera: (eye: (0.0, 4.0, 3.0), target: (0.0, 0.0, 0.0), fov_y_deg: 60.0, viewer: Local),
    lights: [Spot(position: ({px}, {py}, {pz}), direction: ({dx}, {dy}, {dz}), cutoff_deg: {SPOT_CUTOFF_DEG}, exponent: 0.0, color: (1.0, 1.0, 1.0))],
    objects: [(mesh: Plane(size: 6.0, subdivisions: 1), material: "m")],
    materials: {{ "m": (ambient: (0.0, 0.0, 0.0), diffuse: (0.7, 0.7, 0.7), specular: (0.0, 0.0, 0.0), shininess: 1.0) }},
)"#
    ))
}

/// GL's spot cut-off written in the language: the binder's light vector
/// carries no spot factor, so the cone test is the program's.
fn spot_program(per_pixel: bool) -> String {
    let d = Vec3::from(SPOT_DIRECTION).normalize();
    format!(
        "vector N : normal in world;\nvector L : light(0) in world;\nconst D : vec3 = ({}, {}, {});\nconst cos_cut = {};\nconst kd : rgb = (0.7, 0.7, 0.7);\n\
         shader p : s → c {{\n    let Ln = normalize(L);\n    let spot = (-Ln)·D ≥ cos_cut ? 1 : 0;\n    spot * kd * max(0, normalize(N)·Ln)\n}}\n\
         C δπx ← {};\n",
        d.x,
        d.y,
        d.z,
        SPOT_CUTOFF_DEG.to_radians().cos(),
        if per_pixel { "p δ s x" } else { "δ p s x" }
    )
}

#[test]
fn spot_cut_off_inside_a_triangle_is_sharp_per_pixel_and_lost_by_gouraud() {
    let scene = spot_scene();
    let (w, h) = (96usize, 96usize);
    let d = Vec3::from(SPOT_DIRECTION).normalize();
    let cos_cut = SPOT_CUTOFF_DEG.to_radians().cos();
    // The analytic cone test at every pixel centre: the cosine to the axis.
    let cosine: Vec<Option<f32>> = (0..w * h)
        .map(|i| {
            unproject_to_ground(&scene, i % w, i / w)
                .filter(|p| p.x.abs() <= 3.0 && p.z.abs() <= 3.0)
                .map(|p| (p - Vec3::from(SPOT_POSITION)).normalize().dot(d))
        })
        .collect();
    let inside = |i: usize| cosine[i].is_some_and(|c| c >= cos_cut);
    let n_inside = (0..w * h).filter(|&i| inside(i)).count();
    assert!(n_inside > 200, "the cone covers {n_inside} pixels");
    // A pixel on the boundary: a neighbour is on the other side.
    let boundary = |i: usize| {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                let (nx, ny) = (x + dx, y + dy);
                nx >= 0
                    && ny >= 0
                    && nx < w as i64
                    && ny < h as i64
                    && inside(ny as usize * w + nx as usize) != inside(i)
            })
        })
    };
    let check = |what: &str, pixels: &[[f32; 4]], band: f32| {
        let mut wrong = 0;
        for i in 0..w * h {
            let Some(c) = cosine[i] else { continue };
            let lit = pixels[i][0] > 0.01;
            if lit != inside(i) {
                wrong += 1;
                assert!(
                    boundary(i) || (c - cos_cut).abs() <= band,
                    "{what}: pixel ({}, {}) lit {lit}, cos {c} vs {cos_cut}",
                    i % w,
                    i / w
                );
            }
        }
        eprintln!("spot [{what}]: {wrong} pixels on the other side of the cut-off, all on its boundary (band {band})");
    };
    for img in render_modes("spot, per pixel", &spot_program(true), "wgsl", &scene) {
        // fixed9 rounds (−L)·D to 8 bits + sign: the edge may move by the
        // cosines within 3/255 of the cut-off (each component of L and
        // the dot product rounded by ½/255).
        let band = if img.mode == Precision::Fixed9 { 3.0 / 255.0 } else { 0.0 };
        check(img.mode.name(), &img.pixels, band);
    }
    for img in render_modes("spot, Gouraud", &spot_program(false), "wgsl", &scene) {
        // Every vertex is outside the cone: the per-vertex shader sees no
        // light, and δ interpolates zeros.
        let lit = img.pixels.iter().filter(|p| p[0] > 0.01).count();
        assert!(lit * 20 < n_inside, "{}: Gouraud lights {lit} of {n_inside} pixels", img.mode.name());
    }
    let (full, adaptive) = native("spot", &scene);
    check("native", &full, 0.0);
    check("adaptive", &adaptive, 0.0);
}

// ---------------------------------------------------------------------------
// Mipmapped bumpy normal maps: the golf-ball dimming (seeds/003 Section 2.4.2).

/// Looking straight down at a unit plane of golf-ball dimples (16 cells,
/// `bumps(16)`: 256² texels), from `height` above; the light 30° off the
/// normal, so no dimple faces away from it (no self-shadow clamping).
fn golf_scene(height: f32) -> Scene {
    scene(&format!(
        r#"(
    resolution: (64, 64),
    camera: (eye: (0.0, {height}, 0.0), target: (0.0, 0.0, 0.0), up: (0.0, 0.0, -1.0), fov_y_deg: 45.0, near: 0.01, viewer: Local),
    lights: [Directional(direction: (-0.5, -0.8660254, 0.0), color: (1.0, 1.0, 1.0))],
    objects: [(mesh: Plane(size: 1.0, subdivisions: 1), material: "m")],
    materials: {{ "m": (diffuse: (1.0, 1.0, 1.0)) }},
)"#
    ))
}

/// Diffuse bump mapping with the filtered normal N′ of Kilgard's mipmaps:
/// `with_alpha` rescales by the averaged length kept in alpha (Equation 15,
/// Appendix G's combiner stage 1), else the renormalized N′ alone (the
/// alternative Section 2.4.2 rejects).
fn golf_program(with_alpha: bool) -> String {
    format!(
        "vector L : light(0) in tangent;\ntexture Tn : 2d rgba8 mipmap trilinear repeat = bumps(16);\nconst kd : rgb = (1, 1, 1);\nlet N′ = Tn δu x;\nC δπx ← kd * max(0, (δ L s x)·expand(N′.rgb)){};\n",
        if with_alpha { " * N′.a" } else { "" }
    )
}

/// The mean red value of the covered pixels (alpha 1: the output is rgb).
fn mean_covered(img: &Image) -> f32 {
    let v: Vec<f32> = img.covered().map(|(_, p)| p[0]).collect();
    assert!(!v.is_empty());
    v.iter().sum::<f32>() / v.len() as f32
}

#[test]
fn golf_ball_dimming_is_kept_by_the_alpha_of_kilgards_filter() {
    // Equation 13, the brute-force reference: the mean of max(0, L·N′ᵢ)
    // over the base level's normals, with L in tangent space (T = +x,
    // B = −z, N = +y for the plane: L = (0.5, 0, 0.866)).
    let l = [0.5f32, 0.0, 0.8660254];
    let base = generators::normal_map(&HeightField::dimples(256, 16), 4.0, NormalMapFormat::F32);
    let texels = &base.levels[0].texels;
    let eq13 = texels
        .iter()
        .map(|t| (0..3).map(|c| l[c] * generators::expand(t[c])).sum::<f32>().max(0.0))
        .sum::<f32>()
        / texels.len() as f32;
    let smooth = l[2]; // L·N of the flat ball
    eprintln!("golf ball: Equation 13 gives {eq13:.4}, a smooth surface {smooth:.4}");
    assert!(eq13 < smooth - 0.03, "the dimples make the surface dimmer");
    // The mipmap chain keeps the mean vector, so the coarse levels' alpha shrinks.
    let coarse = &base.levels[4];
    let mean_alpha = coarse.texels.iter().map(|t| t[3]).sum::<f32>() / coarse.texels.len() as f32;
    assert!(mean_alpha < 0.95, "level 4 (one texel per dimple) is shorter: {mean_alpha}");
    let (near, far) = (golf_scene(0.15), golf_scene(4.8));
    for mode in MODES {
        let m = mode.name();
        let near_a = mean_covered(&render("golf near, alpha", &golf_program(true), "wgsl", &near, mode));
        let near_n =
            mean_covered(&render("golf near, renormalized", &golf_program(false), "wgsl", &near, mode));
        let far_a = mean_covered(&render("golf far, alpha", &golf_program(true), "wgsl", &far, mode));
        let far_n = mean_covered(&render("golf far, renormalized", &golf_program(false), "wgsl", &far, mode));
        eprintln!("golf ball [{m}]: near {near_a:.4} / {near_n:.4}, far {far_a:.4} (alpha) / {far_n:.4} (renormalized)");
        // Up close (level 0, alpha 1) both programs see the bumps themselves.
        assert!((near_a - near_n).abs() < 0.01, "{m}: near {near_a} vs {near_n}");
        assert!((near_a - eq13).abs() < 0.03, "{m}: near {near_a} vs Equation 13 {eq13}");
        // From afar, the alpha keeps Equation 13's dimming; renormalizing
        // loses it: "bumpy diffuse surfaces incorrectly appear too bright".
        // 8-bit maps (f32, fixed9) lose a little more: Appendix F stores
        // each level's length truncated to 1/255 and the next level filters
        // the stored texels, so the truncations add up over 4 levels.
        let tol = if mode == Precision::Exact { 0.005 } else { 0.04 };
        assert!((far_a - eq13).abs() < tol, "{m}: far with alpha {far_a} vs Equation 13 {eq13}");
        assert!(far_n > eq13 + 0.06, "{m}: far, renormalized {far_n} is too bright against {eq13}");
        assert!(far_n - eq13 > 2.0 * (far_a - eq13).abs(), "{m}: the alpha is the better filter");
    }
}

// ---------------------------------------------------------------------------
// A light exactly in the surface plane.

fn in_plane_scene(light: &str) -> Scene {
    scene(&format!(
        r#"(
    resolution: (64, 64),
    camera: (eye: (0.0, 3.0, 3.0), target: (0.0, 0.0, 0.0), fov_y_deg: 60.0, viewer: Local),
    lights: [{light}],
    objects: [(mesh: Plane(size: 4.0, subdivisions: 4), material: "m")],
    materials: {{ "m": (ambient: (0.2, 0.2, 0.2), diffuse: (0.8, 0.8, 0.8), specular: (1.0, 1.0, 1.0), shininess: 16.0) }},
    ambient: (0.25, 0.25, 0.25),
)"#
    ))
}

#[test]
fn light_in_the_surface_plane_gives_no_diffuse_and_gated_specular() {
    let diffuse = "vector N : normal in world;\nvector L : light(0) in world;\nshader p : s → c = max(0, normalize(N)·normalize(L));\nC δπx ← p δ s x;\n";
    for light in [
        "Directional(direction: (-1.0, 0.0, 0.0), color: (1.0, 1.0, 1.0))",
        "Point(position: (3.0, 0.0, 0.5), color: (1.0, 1.0, 1.0))",
    ] {
        let scene = in_plane_scene(light);
        // N·L = 0 exactly at every vertex and pixel: no diffuse light, in any mode.
        for img in render_modes("N·L, light in the plane", diffuse, "wgsl", &scene) {
            assert!(img.covered().count() > 1000);
            assert!(img.max_rgb() == 0.0, "{} [{light}]: {}", img.mode.name(), img.max_rgb());
        }
        // Kilgard's s_self = saturate(8 Lz) is 0, which gates the diffuse term
        // and, through destination alpha, the specular pass (Equation 16):
        // exact shows the ambient decal only. The stored cube map encodes
        // Lz = 0 as 128/255, i.e. 1/255 after expand (Appendix D), so
        // s_self ≤ 8/255 there, and each gated term is at most that much.
        let k = render_modes(
            "kilgard, light in the plane",
            &example("kilgard_bump_mapping.shd"),
            "geforce256",
            &scene,
        );
        for img in &k[1..] {
            let e = max_error(&k[0], img);
            eprintln!("light in the plane [{}], kilgard: max error {e:.4}", img.mode.name());
            assert!(e <= 2.0 * 8.0 / 255.0 + 2.0 / 255.0, "{}: {e}", img.mode.name());
        }
        // The native Phong stage: N·L ≤ 0 skips the light (GL's rule): ambient only.
        let (full, adaptive) = native("light in the plane", &scene);
        for img in [&full, &adaptive] {
            for p in img.iter().filter(|p| p[3] > 0.5) {
                assert!(max_diff(*p, [0.05, 0.05, 0.05, 1.0]) < 1e-6, "{light}: {p:?}");
            }
        }
    }
}
