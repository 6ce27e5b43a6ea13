//! The lane program's test against the plain lane code (`super::plain`).

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use crate::numerics::Precision;
use crate::renderer::plan::PlanRenderer;
use crate::scene::Scene;

/// Set: the lane code runs plain ([`super::plain`]).
pub(super) static PLAIN: AtomicBool = AtomicBool::new(false);
thread_local! {
    /// Per program compiled on this thread: its lane ops, how many of
    /// them copy components (swizzles, compositions, conversions), and how
    /// many run fused ([`super::runs::fuse_runs`]).
    pub(super) static COMPILED: std::cell::RefCell<Vec<(usize, usize, usize)>> = const { std::cell::RefCell::new(Vec::new()) };
}
/// Records a compiled program's counts in [`COMPILED`].
pub(super) fn record(ops: &[super::Op], runs: &[super::runs::Run]) {
    use super::{Op, K};
    let linked = runs.iter().map(super::runs::Run::len).sum::<usize>();
    let lanes = ops.iter().filter(|op| matches!(op, Op::Lanes { .. })).count() + linked;
    let copy = |op: &&Op| matches!(op, Op::Lanes { k: K::Swizzle(..) | K::Same | K::Compose(_), .. });
    COMPILED.with(|c| c.borrow_mut().push((lanes, ops.iter().filter(copy).count(), linked)));
}

/// Set: straight runs of ops are not fused ([`super::fused`]).
pub(super) static UNFUSED: AtomicBool = AtomicBool::new(false);
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
    let copies = |ops: &[(usize, usize, usize)]| ops.iter().map(|&(_, c, _)| c).sum::<usize>();
    assert!(copies(&plain_ops) >= 6, "plain ops {plain_ops:?}");
    assert_eq!(copies(&fast_ops), 0, "copies left: {fast_ops:?}");
    let lane_ops = |ops: &[(usize, usize, usize)]| ops.iter().map(|&(n, _, _)| n).sum::<usize>();
    assert_eq!(lane_ops(&fast_ops) + copies(&plain_ops), lane_ops(&plain_ops));
    let bits = |f: &crate::renderer::plan::Frame| {
        f.image.to_rgba_f32().into_iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
    };
    assert!(fast.stats.written > 500, "{:?}", fast.stats);
    assert!(bits(&fast) == bits(&plain), "the frames differ");
}

/// Kilgard's pass with straight runs of ops fused
/// ([`super::runs::fuse_runs`]: its `max`, `^8` and selection after the
/// specular dot product, the diffuse term's products and sum, the
/// colour's saturation and modulation) is the frame of the same ops one
/// at a time, bit for bit.
#[test]
fn fused_runs_render_the_frame_of_the_ops_one_at_a_time_bit_for_bit() {
    let (scene, assets, program, planned) = kilgard_on_wgsl();
    let (mut fused, mut single) = (None, None);
    for (unfused, out) in [(false, &mut fused), (true, &mut single)] {
        UNFUSED.store(unfused, Ordering::Relaxed);
        let frame = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let renderer = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
            COMPILED.with(|c| c.borrow_mut().clear());
            let frame = renderer.render(Precision::F32, 96, 72, &mut |_, _| {}).unwrap();
            (frame, COMPILED.with(|c| c.borrow().clone()))
        }));
        UNFUSED.store(false, Ordering::Relaxed);
        *out = Some(frame.unwrap());
    }
    let ((fused, fused_ops), (single, single_ops)) = (fused.unwrap(), single.unwrap());
    let linked = |ops: &[(usize, usize, usize)]| ops.iter().map(|&(_, _, l)| l).sum::<usize>();
    assert!(linked(&fused_ops) >= 8, "fused: {fused_ops:?}");
    assert_eq!(linked(&single_ops), 0);
    let bits = |f: &crate::renderer::plan::Frame| {
        f.image.to_rgba_f32().into_iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>()
    };
    assert!(fused.stats.written > 500, "{:?}", fused.stats);
    assert!(bits(&fused) == bits(&single), "the frames differ");
    assert_eq!(fused.stats, single.stats);
}

/// A fused run ([`super::runs::run_links`]) computes the values of its
/// ops run one at a time ([`super::exec`]) bit for bit: a run of five
/// vec3 ops (a product, `expand`, `max` with the run's value as its
/// second operand, `mix`, `saturate`) and, after a dot product, a run of
/// four scalar ops (`max`, `x^5`, a selection whose condition is 0 in
/// some lanes, a difference), on values of every sign and size, ±0 and
/// ±∞; an intermediate read after the run is written, the others not.
#[test]
fn a_fused_run_gives_the_values_of_its_ops_one_at_a_time_bit_for_bit() {
    use super::{Op, K};
    const NO: u32 = u32::MAX;
    let lanes = |k, dst, ops: [u32; 4], width| Op::Lanes {
        k,
        dst,
        ops,
        width,
        keep: 0b1111,
        rows: ops.map(|o| [0, 1, 2, 3].map(|c| o.saturating_mul(4).saturating_add(c))),
    };
    let ops = vec![
        lanes(K::Mul, 6, [0, 1, NO, NO], 3),
        lanes(K::Expand, 7, [6, NO, NO, NO], 3),
        lanes(K::Max, 8, [2, 7, NO, NO], 3),
        lanes(K::Mix, 9, [8, 3, 4, NO], 3),
        lanes(K::Saturate, 10, [9, NO, NO, NO], 3),
        lanes(K::Dot(3), 11, [10, 5, NO, NO], 1),
        lanes(K::Max, 12, [0, 11, NO, NO], 1),
        lanes(K::PowInt(5), 13, [12, 4, NO, NO], 1),
        lanes(K::Select(true), 14, [1, 13, 2, NO], 1),
        lanes(K::Sub, 15, [14, 3, NO, NO], 1),
        lanes(K::Add, 16, [8, 10, NO, NO], 3),
    ];
    let mut r = vec![[0.0f32; super::BATCH]; 17 * 4];
    let mut seed = 0x2545_f491u32;
    for (row, lane) in r[..24].iter_mut().flat_map(|x| x.iter_mut()).enumerate().map(|(i, v)| (v, i)) {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        *row = match lane % 11 {
            0 => 0.0,
            1 => -0.0,
            2 => f32::INFINITY,
            3 => f32::NEG_INFINITY,
            _ => (seed as i32 as f32) / (1u32 << (seed % 31)) as f32,
        };
    }
    // Lanes whose selection's condition is 0.
    r[4].iter_mut().step_by(3).for_each(|v| *v = 0.0);
    let vary = crate::renderer::raster::Vary::by_fragment(&[], 0);
    let mut discard = [false; super::BATCH];
    let mut single = r.clone();
    for &op in &ops {
        super::exec(op, &mut single, vary, super::BATCH, &mut discard);
    }
    let mut fused_ops = ops.clone();
    let mut direct = vec![false; 17];
    direct[15] = true;
    let runs = super::runs::fuse_runs(&mut fused_ops, &direct);
    assert_eq!(runs.iter().map(super::runs::Run::len).collect::<Vec<_>>(), [5, 4]);
    assert_eq!(fused_ops.len(), 4, "{fused_ops:?}");
    let mut fused = r.clone();
    for &op in &fused_ops {
        match op {
            Op::Run(i) => super::runs::run_links(&runs[i as usize], &mut fused),
            _ => super::exec(op, &mut fused, vary, super::BATCH, &mut discard),
        }
    }
    let bits = |r: &[[f32; super::BATCH]], slot: usize, comps: usize| {
        r[slot * 4..slot * 4 + comps].iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>()
    };
    for (slot, comps) in [(8, 3), (10, 3), (11, 1), (15, 1), (16, 3)] {
        assert!(bits(&fused, slot, comps) == bits(&single, slot, comps), "slot {slot} differs");
    }
    // The intermediates no op after the run reads are not written.
    assert!(bits(&fused, 13, 1).iter().all(|&b| b == 0), "slot 13 written");
}
