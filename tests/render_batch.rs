//! The batched fragment stage (issue 22 item 2) against the executor it
//! replaced, shading one fragment at a time: the same pictures bit for
//! bit, the same counters, for every example on every target in `exact`
//! and `fixed9` (the differential suite checks the same over generated
//! programs). The `f32` mode's batches run compiled lane code in `f32`
//! (issue 37), which the one-at-a-time executor computes in `f64` rounded
//! to `f32` per step: held to [`close_frames`]' stated tolerance instead,
//! and to the exact reference.

use std::path::Path;

use shadec::numerics::Precision;
use shadec::profile::Profile;
use shadec::renderer::plan::{compare, Frame, PlanRenderer};
use shadec::scene::Scene;

fn scene() -> Scene {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap()
}

/// Whether two frames are the same bit for bit: image, counters, non-finite values.
pub fn same_frames(a: &Frame, b: &Frame) -> Result<(), String> {
    let (pa, pb) = (a.image.to_rgba_f32(), b.image.to_rgba_f32());
    if let Some(i) = pa.iter().zip(&pb).position(|(x, y)| x.map(f32::to_bits) != y.map(f32::to_bits)) {
        let w = a.image.width() as usize;
        return Err(format!("pixel ({}, {}): {:?} against {:?}", i % w, i / w, pa[i], pb[i]));
    }
    if a.stats != b.stats || a.nonfinite != b.nonfinite {
        return Err(format!("counters {:?}/{} against {:?}/{}", a.stats, a.nonfinite, b.stats, b.nonfinite));
    }
    Ok(())
}

/// The tolerance of the `f32` lane code against the one-at-a-time `f32`
/// executor: every pixel within [`LANE_TOLERANCE`] (a few ulps per
/// operation, and an 8-bit target's rounding moving one step), except at
/// most [`LANE_OUTLIERS`] of them (a comparison or a `floor` whose operands
/// are equal to the last bits flips); the same counters.
pub const LANE_TOLERANCE: f32 = 2.0 / 255.0;
pub const LANE_OUTLIERS: f64 = 0.005;

/// Whether `a` (f32 lanes) is within the stated tolerance of `b`.
pub fn close_frames(a: &Frame, b: &Frame) -> Result<(), String> {
    let (pa, pb) = (a.image.to_rgba_f32(), b.image.to_rgba_f32());
    let off = |x: &[f32; 4], y: &[f32; 4]| {
        x.iter().zip(y).any(|(p, q)| {
            let both_nan = p.is_nan() && q.is_nan();
            let close = (p - q).abs() <= LANE_TOLERANCE;
            !both_nan && !close
        })
    };
    let outliers = pa.iter().zip(&pb).filter(|(x, y)| off(x, y)).count();
    let allowed = (LANE_OUTLIERS * pa.len() as f64).floor() as usize;
    if outliers > allowed {
        let i = pa.iter().zip(&pb).position(|(x, y)| off(x, y)).expect("counted");
        let w = a.image.width() as usize;
        return Err(format!(
            "{outliers} pixels (of {}) differ by more than {LANE_TOLERANCE}, first ({}, {}): {:?} against {:?}",
            pa.len(),
            i % w,
            i / w,
            pa[i],
            pb[i]
        ));
    }
    if a.stats != b.stats || a.nonfinite.abs_diff(b.nonfinite) as usize > allowed {
        return Err(format!("counters {:?}/{} against {:?}/{}", a.stats, a.nonfinite, b.stats, b.nonfinite));
    }
    Ok(())
}

#[test]
fn batches_shade_every_example_as_one_fragment_at_a_time_does() {
    let scene = scene();
    let assets = scene.build().unwrap();
    let mut dir: Vec<_> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/examples"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "shd"))
        .collect();
    dir.sort();
    let mut compared = 0;
    let mut differ = Vec::new();
    for path in &dir {
        let src = std::fs::read_to_string(path).unwrap();
        let (program, _) = shadec::parser::check(&src);
        for target in ["wgsl", "geforce3", "geforce256"] {
            let profile = Profile::resolve(target).unwrap();
            let Ok(planned) = shadec::driver::compile(&src, &profile, &Default::default()).map(|c| c.planned)
            else {
                continue;
            };
            let Ok(mut r) = PlanRenderer::new(&planned, &program, &scene, &assets) else { continue };
            for mode in [Precision::Exact, Precision::F32, Precision::Fixed9] {
                let mut frame = |batched| {
                    r.set_batched(batched);
                    r.render(mode, 67, 45, &mut |_, _| {})
                };
                let (Ok(batched), Ok(single)) = (frame(true), frame(false)) else { continue };
                compared += 1;
                let check = if mode == Precision::F32 { close_frames } else { same_frames };
                if let Err(e) = check(&batched, &single) {
                    differ.push(format!("{} on {target}, {}: {e}", path.display(), mode.name()));
                }
            }
        }
    }
    assert!(differ.is_empty(), "batched and one at a time differ:\n{}", differ.join("\n"));
    // 28 examples, most on three targets, three modes each.
    assert!(compared >= 150, "only {compared} renders compared");
}

/// The `f32` lane code against the exact reference (f64 throughout, true
/// functions): Kilgard's torus on wgsl at 256², the tolerance the
/// one-at-a-time `f32` executor meets, measured in the same test.
#[test]
fn f32_lanes_are_as_close_to_the_exact_reference_as_the_interpreter() {
    let scene = scene();
    let assets = scene.build().unwrap();
    let src =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/kilgard_bump_mapping.shd"))
            .unwrap();
    let (program, _) = shadec::parser::check(&src);
    let planned = shadec::driver::compile(&src, &Profile::resolve("wgsl").unwrap(), &Default::default())
        .unwrap()
        .planned;
    let mut r = PlanRenderer::new(&planned, &program, &scene, &assets).unwrap();
    let exact = r.render(Precision::Exact, 256, 256, &mut |_, _| {}).unwrap();
    let lanes = r.render(Precision::F32, 256, 256, &mut |_, _| {}).unwrap();
    r.set_batched(false);
    let single = r.render(Precision::F32, 256, 256, &mut |_, _| {}).unwrap();
    let (el, es) = (compare(&exact.image, &lanes.image), compare(&exact.image, &single.image));
    // The f32 modes sample through the texture unit's model, the exact one
    // through the ideal sampler: the error is the sampling's, which the
    // lanes must not add to (0.5 dB, 1/255 at the worst pixel).
    assert!(el.psnr >= es.psnr - 0.5, "lanes {el:?} against the interpreter's {es:?}");
    assert!(el.max_abs <= es.max_abs + 1.0 / 255.0, "lanes {el:?} against the interpreter's {es:?}");
    assert!(el.psnr >= 30.0, "lanes {el:?}");
}
