//! Additive passes over the same triangles drawn as one adaptive draw of
//! their sum (`renderer::adaptive::draw_adaptive_sum`): exact where every
//! pixel is shaded, within the interpolation's own error where it is not,
//! and refused — the target untouched — wherever the sum would not be what
//! the passes leave.

use crate::adaptive_common;

use adaptive_common::{lit, target};
use shadec::renderer::adaptive::draw_adaptive_sum;
use shadec::renderer::{
    draw, draw_adaptive, image_error, AdaptiveSettings, BlendState, ColorFormat, CullMode, DepthState,
    EdgeMode, Fragment, FragmentResult, FragmentStage, Framebuffer, Pass,
};

/// The lit sphere's shading, scaled and offset per channel (a light of
/// its own colour), dropping the fragments left of column `discard_left`.
struct Light<'a> {
    inner: &'a dyn FragmentStage,
    scale: [f32; 4],
    offset: [f32; 4],
    discard_left: u32,
}

impl FragmentStage for Light<'_> {
    fn shade(&self, fragment: &Fragment, varyings: &[f32], out: &mut [f32; 4]) -> FragmentResult {
        if fragment.x < self.discard_left {
            return FragmentResult::Discard;
        }
        let result = self.inner.shade(fragment, varyings, out);
        let shaded = *out;
        *out = std::array::from_fn(|c| shaded[c] * self.scale[c] + self.offset[c]);
        result
    }
}

/// Three lights: the second pushes channels past 1, the third below 0,
/// so that `Unorm`'s clamps and `F16`'s roundings between passes matter.
fn lights(inner: &dyn FragmentStage) -> [Light<'_>; 3] {
    [
        Light { inner, scale: [0.5, 0.3, 0.2, 1.0], offset: [0.0; 4], discard_left: 0 },
        Light { inner, scale: [1.5, 0.7, 0.1, 0.0], offset: [0.2, 0.0, 0.0, 0.0], discard_left: 0 },
        Light { inner, scale: [0.25, 0.25, 0.9, 0.0], offset: [-0.1, 0.01, -0.3, 0.0], discard_left: 0 },
    ]
}

/// The plan's passes per light over `base` (one draw, one object): the
/// first replaces and writes depth, the later ones add, `Equal` without writes.
fn members<'a>(base: &Pass<'a>, stages: &'a [Light<'a>]) -> Vec<Vec<Pass<'a>>> {
    stages
        .iter()
        .enumerate()
        .map(|(k, stage)| {
            let mut state = base.state;
            if k > 0 {
                state.depth = DepthState::EQUAL_NO_WRITE;
                state.blend = BlendState::ADD;
            }
            vec![Pass { triangles: base.triangles, vertex: base.vertex, fragment: stage, state }]
        })
        .collect()
}

fn fused(fb: &mut Framebuffer, members: &[Vec<Pass>], settings: &AdaptiveSettings) -> Option<u64> {
    let slices: Vec<&[Pass]> = members.iter().map(Vec::as_slice).collect();
    draw_adaptive_sum(fb, &slices, settings).unwrap().map(|s| s.covered)
}

#[test]
fn fused_sum_at_threshold_zero_equals_the_passes_drawn_in_full_bit_for_bit() {
    let (scene, lit) = lit("adaptive_sphere_4lights.ron", None);
    let base = lit.passes().remove(0);
    let stages = lights(base.fragment);
    let members = members(&base, &stages);
    let settings = AdaptiveSettings::new(8, 0.0, EdgeMode::Pass);
    let (w, h) = scene.resolution;
    // `Rgba8`: each pass's sum stored rounded to k/255 (what `f32` renders
    // an `rgba8` framebuffer into, as wgpu does).
    for format in [ColorFormat::F32, ColorFormat::F16, ColorFormat::Unorm, ColorFormat::Rgba8] {
        let mut full = Framebuffer::new(w, h, format).unwrap();
        for member in &members {
            draw(&mut full, &member[0]).unwrap();
        }
        let mut sum = Framebuffer::new(w, h, format).unwrap();
        let covered = fused(&mut sum, &members, &settings).expect("fusable");
        assert!(covered > 10_000, "{format:?}: {covered}");
        let (a, b) = (full.to_rgba_f32(), sum.to_rgba_f32());
        let differ = a.iter().zip(&b).filter(|(p, q)| p.map(f32::to_bits) != q.map(f32::to_bits)).count();
        assert_eq!(differ, 0, "{format:?}: {differ} pixels differ");
    }
}

#[test]
fn fused_sum_is_within_the_interpolation_error_of_the_per_pass_adaptive_draws() {
    // Stated bound: at 8.5 % both pictures are within 40 dB of full
    // shading, and the fused one within 40 dB of the per-pass one.
    let (scene, lit) = lit("adaptive_sphere_4lights.ron", None);
    let base = lit.passes().remove(0);
    let stages = lights(base.fragment);
    let members = members(&base, &stages);
    let settings = AdaptiveSettings::new(16, 0.085, EdgeMode::Pass);
    let (mut full, mut per_pass, mut sum) = (target(&scene), target(&scene), target(&scene));
    for member in &members {
        draw(&mut full, &member[0]).unwrap();
        draw_adaptive(&mut per_pass, member, &settings).unwrap();
    }
    fused(&mut sum, &members, &settings).expect("fusable");
    let full = full.to_rgba_f32();
    let fused_error = image_error(&full, &sum.to_rgba_f32());
    let per_pass_error = image_error(&full, &per_pass.to_rgba_f32());
    let between = image_error(&per_pass.to_rgba_f32(), &sum.to_rgba_f32());
    println!("fused {fused_error:?}, per pass {per_pass_error:?}, between {between:?}");
    assert!(fused_error.psnr >= 40.0 && per_pass_error.psnr >= 40.0);
    assert!(between.psnr >= 40.0, "{between:?}");
}

#[test]
fn fused_sum_refuses_followers_over_other_triangles_or_states() {
    let (scene, lit) = lit("adaptive_sphere_4lights.ron", None);
    let base = lit.passes().remove(0);
    let stages = lights(base.fragment);
    let settings = AdaptiveSettings::new(16, 0.085, EdgeMode::Pass);
    let changes: [fn(&mut Pass); 4] = [
        // Other triangles: the back faces too.
        |p| p.state.cull = CullMode::None,
        |p| p.state.depth = DepthState::LESS_WRITE,
        |p| p.state.blend = BlendState::REPLACE,
        |p| p.state.blend = BlendState::MODULATE,
    ];
    for (k, change) in changes.iter().enumerate() {
        let mut members = members(&base, &stages);
        change(&mut members[2][0]);
        let mut fb = target(&scene);
        fb.clear_color([0.25; 4]);
        assert_eq!(fused(&mut fb, &members, &settings), None, "change {k}");
        assert!(fb.to_rgba_f32().iter().all(|p| *p == [0.25; 4]), "change {k}");
    }
}

#[test]
fn fused_sum_gives_up_when_its_first_pass_discards() {
    let (scene, lit) = lit("adaptive_sphere_4lights.ron", None);
    let base = lit.passes().remove(0);
    let mut stages = lights(base.fragment);
    stages[0].discard_left = scene.resolution.0 / 2;
    let members = members(&base, &stages);
    let mut fb = target(&scene);
    fb.clear_color([0.25; 4]);
    assert_eq!(fused(&mut fb, &members, &AdaptiveSettings::new(16, 0.085, EdgeMode::Pass)), None);
    assert!(fb.to_rgba_f32().iter().all(|p| *p == [0.25; 4]));
}

#[test]
fn a_follower_that_discards_adds_nothing_where_it_does() {
    let (scene, lit) = lit("adaptive_sphere_4lights.ron", None);
    let base = lit.passes().remove(0);
    let mut stages = lights(base.fragment);
    stages[1].discard_left = scene.resolution.0 / 2;
    let members = members(&base, &stages);
    let (mut full, mut sum) = (target(&scene), target(&scene));
    for member in &members {
        draw(&mut full, &member[0]).unwrap();
    }
    fused(&mut sum, &members, &AdaptiveSettings::new(8, 0.0, EdgeMode::Pass)).expect("fusable");
    assert!(full.to_rgba_f32() == sum.to_rgba_f32());
}
