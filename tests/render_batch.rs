//! The batched fragment stage (issue 22 item 2) against the executor it
//! replaced, shading one fragment at a time: the same pictures bit for
//! bit, the same counters, for every example on every target in every
//! mode (the differential suite checks the same over generated programs).

use std::path::Path;

use shadec::numerics::Precision;
use shadec::profile::Profile;
use shadec::renderer::plan::{Frame, PlanRenderer};
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
                if let Err(e) = same_frames(&batched, &single) {
                    differ.push(format!("{} on {target}, {}: {e}", path.display(), mode.name()));
                }
            }
        }
    }
    assert!(differ.is_empty(), "batched and one at a time differ:\n{}", differ.join("\n"));
    // 28 examples, most on three targets, three modes each.
    assert!(compared >= 150, "only {compared} renders compared");
}
