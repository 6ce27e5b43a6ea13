//! Shadow volumes that cast shadows (Pipeline Grammar, Section 3.5;
//! Crow 1977; Heidmann 1991; Everitt and Kilgard 2002): the volume `x′` of
//! `examples/shadow_volumes.shd` is built from the scene, and a ball over a
//! floor (`scenes/shadow_occluder_floor.ron`) darkens the floor under it on
//! the CPU, on wgpu and in the program's meaning.

use shadec::numerics::Precision;
use shadec::scene::shadow_volume;

const W: u32 = 128;
const H: u32 = 128;

fn root() -> &'static str {
    env!("CARGO_MANIFEST_DIR")
}

fn source() -> String {
    std::fs::read_to_string(format!("{}/examples/shadow_volumes.shd", root())).unwrap()
}

fn scene_text() -> String {
    std::fs::read_to_string(format!("{}/scenes/shadow_occluder_floor.ron", root())).unwrap()
}

fn prepared(target: &str) -> shadec::bench::Prepared {
    shadec::bench::Prepared::new("shadow volumes", &source(), target, &scene_text()).unwrap()
}

/// The mean red of the 3×3 pixels around where world point `p` projects.
fn brightness(rgba: &[u8], scene: &shadec::scene::Scene, p: glam::Vec3) -> f64 {
    let clip = scene.camera.view_projection(W as f32 / H as f32) * p.extend(1.0);
    let (x, y) = (clip.x / clip.w, clip.y / clip.w);
    let px = ((x * 0.5 + 0.5) * W as f32) as i64;
    let py = ((0.5 - y * 0.5) * H as f32) as i64;
    let mut sum = 0.0;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let i = ((py + dy) * W as i64 + px + dx) as usize;
            sum += rgba[4 * i] as f64;
        }
    }
    sum / 9.0
}

/// The floor straight under the ball is in its shadow; a floor point as
/// brightly lit by N·L out in the open is not. Both visible from the camera.
fn assert_shadow(what: &str, rgba: &[u8], scene: &shadec::scene::Scene) {
    let under = brightness(rgba, scene, glam::Vec3::new(0.0, 0.0, 0.6));
    let open = brightness(rgba, scene, glam::Vec3::new(2.0, 0.0, 0.6));
    assert!(open > 100.0, "{what}: the open floor is lit ({open:.0}/255)");
    assert!(
        under < 0.5 * open,
        "{what}: the floor under the ball ({under:.0}/255) is not in shadow (open floor {open:.0}/255)"
    );
}

#[test]
fn the_ball_shadows_the_floor_on_the_cpu() {
    for (target, mode) in
        [("geforce256", Precision::Fixed9), ("geforce3", Precision::Fixed9), ("wgsl", Precision::F32)]
    {
        let p = prepared(target);
        let frame = p.renderer().unwrap().render(mode, W, H, &mut |_, _| {}).unwrap();
        assert_shadow(target, &frame.image.to_rgba8(), &p.scene);
    }
}

#[test]
fn the_ball_shadows_the_floor_in_the_meaning() {
    let p = prepared("wgsl").meaning().unwrap();
    let frame = p.renderer().unwrap().render(Precision::Exact, W, H, &mut |_, _| {}).unwrap();
    assert_shadow("meaning", &frame.image.to_rgba8(), &p.scene);
}

#[test]
fn the_ball_shadows_the_floor_on_wgpu() {
    let Some(gpu) = crate::common::gpu::gpu() else {
        eprintln!("no adapter: skipped");
        return;
    };
    let p = prepared("wgsl");
    let src = source();
    let plan = shadec::gpu::scene_run::ScenePlan::new(
        &p.planned,
        &p.program,
        Some(&src),
        Precision::F32,
        &p.scene,
        &p.assets,
    )
    .unwrap();
    let image = plan.render(&gpu, W, H).unwrap();
    assert_shadow("wgpu", image.as_raw(), &p.scene);
}

/// The stencil update over `x′` is two passes where the target had one
/// stencil state for both faces (GeForce 256, GeForce3): back faces +1,
/// front faces −1, where the volume lies behind the stored depth.
#[test]
fn the_stencil_update_counts_the_volume_by_facing() {
    use shadec::renderer::{CompareFunc, CullMode, StencilOp};
    for target in ["geforce256", "geforce3"] {
        let plan = &prepared(target).planned.plan;
        assert_eq!(plan.passes.len(), 4, "{target}: {}", plan.summary());
        let (back, front) = (&plan.passes[1], &plan.passes[2]);
        assert_eq!((back.state.cull, back.state.stencil.pass), (CullMode::Front, StencilOp::IncrWrap));
        assert_eq!((front.state.cull, front.state.stencil.pass), (CullMode::Back, StencilOp::DecrWrap));
        for p in [back, front] {
            assert_eq!(p.state.depth.func, CompareFunc::Greater);
            assert_eq!(p.state.blend.write_mask, [false; 4]);
        }
        assert_eq!(
            plan.passes[3].state.stencil.func,
            CompareFunc::Equal,
            "{target}: lit where the count is 0"
        );
    }
}

/// Where the target has a stencil state per face (WebGPU; EXT_stencil_two_side
/// on a GeForce FX), one pass draws both faces of the volume: −1 on a front
/// face, +1 on a back face. The meaning counts the same way.
#[test]
fn two_sided_stencil_counts_the_volume_in_one_pass() {
    use shadec::renderer::{CompareFunc, CullMode, StencilOp};
    let p = prepared("wgsl");
    let meaning = p.meaning().unwrap();
    for (what, plan) in [("wgsl", &p.planned.plan), ("meaning", &meaning.planned.plan)] {
        assert_eq!(plan.passes.len(), 3, "{what}: {}", plan.summary());
        let s = &plan.passes[1].state;
        assert_eq!(s.cull, CullMode::None, "{what}");
        assert_eq!((s.stencil.pass, s.stencil.back_pass), (StencilOp::DecrWrap, Some(StencilOp::IncrWrap)));
        assert_eq!(s.depth.func, CompareFunc::Greater);
        assert_eq!(plan.passes[2].state.stencil.func, CompareFunc::Equal);
    }
}

/// The volume built for the ball is closed and wound outwards: every
/// directed edge appears once and its reverse once, and its signed volume
/// (divergence theorem) is positive.
#[test]
fn the_volume_is_closed_and_wound_outwards() {
    let p = prepared("wgsl");
    let mesh = shadow_volume::volumes(&p.scene, &p.assets, 0).unwrap();
    assert!(!mesh.triangles.is_empty());
    let (positions, tris) = shadow_volume::closed_triangles(&mesh.positions, &mesh.triangles)
        .expect("the volume is a closed, consistently wound mesh");
    let signed: f32 = tris
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum();
    assert!(signed > 0.0, "signed volume {signed}");
    // The floor, an open plane, casts nothing: only the ball's volume.
    let ball_only = mesh.positions.iter().all(|q| q.y > -20.0);
    assert!(ball_only);
}

/// With no closed mesh in the scene, `x′` has no geometry: the render is
/// refused at the stencil update's statement, saying why.
#[test]
fn a_scene_with_no_occluder_is_refused_located() {
    let text = scene_text().replace(
        "(mesh: Sphere(radius: 0.7, slices: 24, stacks: 12), transform: (translate: (0.0, 1.5, 0.0)), material: \"matte\"),",
        "",
    );
    let p = shadec::bench::Prepared::new("no occluder", &source(), "wgsl", &text).unwrap();
    let err = p.renderer().unwrap().render(Precision::F32, W, H, &mut |_, _| {}).err().expect("refused");
    let text = err.to_string();
    assert!(text.contains("has no geometry") && text.contains("closed mesh"), "{text}");
    let at = source().lines().position(|l| l.starts_with("stencil C")).unwrap() + 1;
    assert!(text.contains(&format!("{at}:")), "located at line {at}: {text}");
}

/// A colour statement reading `x′` interpolates a stream with no vertices:
/// refused at the use.
#[test]
fn reading_the_volume_stream_outside_the_stencil_update_is_refused() {
    let src = source().replace(
        "C delta pi x <- delta ambient s x;",
        "C delta pi x <- (delta ambient s x) * (z delta pi x');",
    );
    let profile = shadec::profile::Profile::resolve("wgsl").unwrap();
    let errs = shadec::driver::compile(&src, &profile, &Default::default()).err().expect("refused");
    let d = errs.iter().find(|d| d.code == "no-geometry").unwrap_or_else(|| panic!("{errs:?}"));
    assert!(d.message.contains("x'") || d.message.contains("x′"), "{}", d.message);
    assert_ne!(d.primary.span, shadec::span::Span::DETACHED, "located");
}

/// The eye inside the ball's volume (under the ball, above the floor): the
/// capped volume counted where the depth test fails (Everitt and Kilgard
/// 2002) still shadows the floor near the eye and leaves the far floor lit,
/// where counting the volume in front of the surface ("z-pass") would miss
/// the front faces behind the eye.
#[test]
fn the_eye_inside_the_volume_still_sees_the_shadow() {
    let text = scene_text().replace(
        "camera: (eye: (0.0, 4.0, 5.0), target: (0.0, 0.0, 0.0),",
        "camera: (eye: (0.0, 0.5, 0.0), target: (0.0, 0.0, 3.0),",
    );
    assert_ne!(text, scene_text());
    let p = shadec::bench::Prepared::new("eye inside", &source(), "wgsl", &text).unwrap();
    let frame = p.renderer().unwrap().render(Precision::F32, W, H, &mut |_, _| {}).unwrap();
    let rgba = frame.image.to_rgba8();
    let under = brightness(&rgba, &p.scene, glam::Vec3::new(0.0, 0.0, 0.85));
    let open = brightness(&rgba, &p.scene, glam::Vec3::new(0.0, 0.0, 2.5));
    assert!(open > 100.0, "the far floor is lit ({open:.0}/255)");
    assert!(
        under < 0.5 * open,
        "the floor under the ball ({under:.0}/255) is in shadow (far floor {open:.0}/255)"
    );
}
