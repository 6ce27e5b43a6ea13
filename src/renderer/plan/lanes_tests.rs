//! The lane program's test against the plain lane code (`super::plain`).

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use crate::numerics::Precision;
use crate::renderer::plan::PlanRenderer;
use crate::scene::Scene;

/// Set: the lane code runs plain ([`super::plain`]).
pub(super) static PLAIN: AtomicBool = AtomicBool::new(false);
thread_local! {
    /// Per program compiled on this thread: its lane ops, and how many
    /// of them copy components (swizzles, compositions, conversions).
    pub(super) static COMPILED: std::cell::RefCell<Vec<(usize, usize)>> = const { std::cell::RefCell::new(Vec::new()) };
}
/// Records a compiled program's counts in [`COMPILED`].
pub(super) fn record(ops: &[super::Op]) {
    use super::{Op, K};
    let lanes = ops.iter().filter(|op| matches!(op, Op::Lanes { .. })).count();
    let copy = |op: &&Op| matches!(op, Op::Lanes { k: K::Swizzle(..) | K::Same | K::Compose(_), .. });
    COMPILED.with(|c| c.borrow_mut().push((lanes, ops.iter().filter(copy).count())));
}

/// Lookups that fetched through another's footprints.
pub(super) static SHARED: AtomicU64 = AtomicU64::new(0);

/// Kilgard's program planned on wgsl, with the torus scene built.
fn kilgard_on_wgsl(
) -> (Scene, crate::scene::SceneAssets, crate::parser::ast::Program, crate::pipeline::Planned) {
    let source = include_str!("../../../examples/kilgard_bump_mapping.shd");
    let text = include_str!("../../../scenes/kilgard_torus.ron");
    let scene = Scene::parse(text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap();
    let assets = scene.build().unwrap();
    let (program, _) = crate::parser::check(source);
    let profile = crate::profile::Profile::resolve("wgsl").unwrap();
    let planned = crate::driver::compile(source, &profile, &Default::default()).unwrap().planned;
    (scene, assets, program, planned)
}

/// Kilgard's torus on the wgsl plan (the decal and the normal map, both
/// 256² chains that repeat, looked up at the same `u`; two cube lookups
/// at other coordinates; a dozen scalar results): the same frame bit for
/// bit with the second 2-D lookup fetching through the first one's
/// footprints, results written only in the components read and the cube
/// lookups reading their faces bordered by the seams, as plain, with
/// every lookup computing its own footprints, every result in all four
/// components and the cube's seam lanes through the one-lane code; and
/// the sharing did happen.
#[test]
fn shared_footprints_and_demanded_components_render_the_plain_frame_bit_for_bit() {
    let (scene, assets, program, planned) = kilgard_on_wgsl();
    let render = || {
        let renderer = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
        renderer.render(Precision::F32, 160, 120, &mut |_, _| {}).unwrap()
    };
    let before = SHARED.load(Ordering::Relaxed);
    let fast = render();
    assert!(SHARED.load(Ordering::Relaxed) > before, "no lookup shared footprints");
    PLAIN.store(true, Ordering::Relaxed);
    let plain = std::panic::catch_unwind(std::panic::AssertUnwindSafe(render));
    PLAIN.store(false, Ordering::Relaxed);
    let plain = plain.unwrap();
    let bits = |f: &crate::renderer::plan::Frame| {
        f.image.to_rgba_f32().into_iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
    };
    assert!(fast.stats.written > 1000, "{:?}", fast.stats);
    assert_eq!(bits(&fast), bits(&plain));
    assert_eq!((fast.stats, fast.nonfinite), (plain.stats, plain.nonfinite));
}

/// `x^k` over the lanes ([`super::power_lanes`]) is the interpreter's
/// per-value [`crate::ir::power_by_squaring`] bit for bit, for every
/// exponent the lanes take (1-256) on values of every sign and magnitude,
/// ±0, ±∞ and NaN.
#[test]
fn powers_over_lanes_are_the_squarings_of_each_lane_bit_for_bit() {
    let mut x = [0.0f32; super::BATCH];
    let mut seed = 0x9e37_79b9u32;
    for (i, v) in x.iter_mut().enumerate() {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        *v = f32::from_bits((seed % 0x7f80_0000) | (seed & 0x8000_0000))
            * if i % 2 == 0 { 1.0 } else { 1e-30 };
    }
    x[..6].copy_from_slice(&[0.0, -0.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 1.000_001]);
    for k in 1..=256 {
        let lanes = super::power_lanes(&x, k);
        for (lane, (&v, &p)) in x.iter().zip(&lanes).enumerate() {
            let one = crate::ir::power_by_squaring(v, k, |a, b| a * b);
            assert_eq!(one.to_bits(), p.to_bits(), "{v}^{k} (lane {lane})");
        }
    }
}

/// A frame rendered into a recycled image (`PlanRenderer::recycle`, whose
/// clear is deferred to the rasterizer's tiles) is the frame rendered into
/// a new one, bit for bit: Kilgard's torus in `f32` after an `exact` frame
/// of the same size (the same depths, other colours: a tile left
/// uncleared would keep the exact frame's colours, its depth test failing
/// everywhere), and again after a frame of its own.
#[test]
fn a_frame_into_a_recycled_image_is_the_frame_into_a_new_one_bit_for_bit() {
    let (scene, assets, program, planned) = kilgard_on_wgsl();
    let bits = |f: &crate::renderer::plan::Frame| {
        f.image.to_rgba_f32().into_iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
    };
    let (w, h) = (200, 150);
    let fresh = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
    let new = fresh.render(Precision::F32, w, h, &mut |_, _| {}).unwrap();
    let renderer = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
    let exact = renderer.render(Precision::Exact, w, h, &mut |_, _| {}).unwrap();
    assert_ne!(bits(&exact), bits(&new), "the exact frame must differ for the test to see a stale tile");
    renderer.recycle(exact);
    let recycled = renderer.render(Precision::F32, w, h, &mut |_, _| {}).unwrap();
    assert_eq!(bits(&recycled), bits(&new));
    assert_eq!(recycled.stats, new.stats);
    renderer.recycle(recycled);
    let again = renderer.render(Precision::F32, w, h, &mut |_, _| {}).unwrap();
    assert_eq!(bits(&again), bits(&new));
}

/// Copies forwarded to their readers ([`super::forward_copies`]): Kilgard's
/// pass compiles to fewer lane ops than plain (its swizzles of texels and
/// its composition of the colour are gone, read through their rows), and
/// a frame whose every component goes through them — swizzles of one
/// component read as a splat, of three, a composition of a vector and a
/// scalar — is the frame of the plain ops bit for bit (a wrong row read
/// in any forwarded operand changes its pixels).
#[test]
fn forwarded_copies_give_the_values_of_the_copies_bit_for_bit() {
    let (scene, assets, program, planned) = kilgard_on_wgsl();
    let (mut fast, mut plain) = (None, None);
    for (is_plain, out) in [(false, &mut fast), (true, &mut plain)] {
        PLAIN.store(is_plain, Ordering::Relaxed);
        let frame = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let renderer = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
            COMPILED.with(|c| c.borrow_mut().clear());
            let frame = renderer.render(Precision::F32, 96, 72, &mut |_, _| {}).unwrap();
            (frame, COMPILED.with(|c| c.borrow().clone()))
        }));
        PLAIN.store(false, Ordering::Relaxed);
        *out = Some(frame.unwrap());
    }
    let ((fast, fast_ops), (plain, plain_ops)) = (fast.unwrap(), plain.unwrap());
    let copies = |ops: &[(usize, usize)]| ops.iter().map(|&(_, c)| c).sum::<usize>();
    assert!(copies(&plain_ops) >= 6, "plain ops {plain_ops:?}");
    assert_eq!(copies(&fast_ops), 0, "copies left: {fast_ops:?}");
    let lane_ops = |ops: &[(usize, usize)]| ops.iter().map(|&(n, _)| n).sum::<usize>();
    assert_eq!(lane_ops(&fast_ops) + copies(&plain_ops), lane_ops(&plain_ops));
    let bits = |f: &crate::renderer::plan::Frame| {
        f.image.to_rgba_f32().into_iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
    };
    assert!(fast.stats.written > 500, "{:?}", fast.stats);
    assert!(bits(&fast) == bits(&plain), "the frames differ");
}
