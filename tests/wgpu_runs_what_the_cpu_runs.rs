//! Every construct the CPU renders, wgpu renders (issue 33): each example
//! × the targets `wgsl` (f32), `geforce3` and `geforce256` (fixed9: the
//! combiner plan on wgpu, `--precision hardware`), and the constructs no
//! example shows (a scene's dual-paraboloid map read by direction, the
//! colour of the framebuffer read back and the stencil read in a shader),
//! on Kilgard's torus with the binder's stand-ins (the stencil reads on
//! the shadow-volume scene). Where the target plans it and the
//! CPU renders it, `gpu::scene_run` must render it too — no
//! `SceneRunError` — and not leave black what the CPU lit. Small (64×48)
//! so that it stays cheap on two cores under lavapipe; agreement is
//! `tests/wgsl_agreement.rs`'s and the GPU check's business.

use std::path::Path;

use shadec::gpu::runner::Target;
use shadec::gpu::scene_run::ScenePlan;
use shadec::numerics::Precision;
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;
use shadec::scene::Scene;

const W: u32 = 64;
const H: u32 = 48;

const TARGETS: [(&str, Precision); 3] =
    [("wgsl", Precision::F32), ("geforce3", Precision::Fixed9), ("geforce256", Precision::Fixed9)];

fn torus(extra: &str) -> Scene {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron"))
        .unwrap()
        .replace("    objects: [", &format!("{extra}    objects: ["));
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap()
}

/// What happened to one case.
enum Outcome {
    /// The target does not plan it, or the CPU does not render it: nothing to ask of wgpu.
    NotForTheCpu(String),
    /// Both rendered: the lit pixels of each.
    Both { cpu_lit: usize, gpu_lit: usize },
}

fn lit(rgba: &[u8]) -> usize {
    rgba.chunks_exact(4).filter(|p| p[..3].iter().any(|&c| c > 0)).count()
}

/// Plans `source` for `target`, renders it on the CPU and, if the CPU
/// renders it, on wgpu; `Err` when wgpu does not.
fn case(
    gpu: &shadec::gpu::runner::Gpu,
    source: &str,
    target: &str,
    precision: Precision,
    scene: &Scene,
) -> Result<Outcome, String> {
    let profile = Profile::resolve(target).map_err(|e| format!("{e:?}"))?;
    let planned = match shadec::driver::compile(source, &profile, &Default::default()) {
        Ok(c) => c.planned,
        Err(d) => return Ok(Outcome::NotForTheCpu(format!("does not plan: {}", d[0].message))),
    };
    let (program, _) = shadec::parser::check(source);
    let assets = scene.build().unwrap();
    let cpu = match PlanRenderer::new(&planned, &program, scene, &assets)
        .and_then(|r| r.render(precision, W, H, &mut |_, _| {}))
    {
        Ok(frame) => frame.image.to_rgba8(),
        Err(e) => return Ok(Outcome::NotForTheCpu(format!("the CPU does not render it: {e}"))),
    };
    let plan = ScenePlan::new(&planned, &program, Some(source), precision, scene, &assets)
        .map_err(|e| format!("wgpu: {e}"))?;
    let frame = if precision == Precision::Fixed9 { Target::new(W, H) } else { Target::float(W, H) };
    let gpu_image = plan.render_into(gpu, &frame).map_err(|e| format!("wgpu: {e}"))?.into_raw();
    Ok(Outcome::Both { cpu_lit: lit(&cpu), gpu_lit: lit(&gpu_image) })
}

/// Runs every case; the failures, and how many cases both rendered.
fn sweep(cases: &[(String, String, Scene)]) -> (Vec<String>, usize, Vec<String>) {
    let gpu = crate::common::gpu::gpu().expect("no wgpu adapter: the suite needs lavapipe (see .ci/run)");
    let (mut failures, mut both, mut skipped) = (Vec::new(), 0, Vec::new());
    for (name, source, scene) in cases {
        for (target, precision) in TARGETS {
            match case(&gpu, source, target, precision, scene) {
                Err(e) => failures.push(format!("{name} on {target} ({precision:?}): {e}")),
                Ok(Outcome::NotForTheCpu(why)) => skipped.push(format!("{name} on {target}: {why}")),
                Ok(Outcome::Both { cpu_lit, gpu_lit }) => {
                    both += 1;
                    // Black where the CPU lit: an unbound texture, a lost pass.
                    if gpu_lit * 2 < cpu_lit {
                        failures.push(format!(
                            "{name} on {target} ({precision:?}): wgpu lit {gpu_lit} pixels, the CPU {cpu_lit}"
                        ));
                    }
                }
            }
        }
    }
    (failures, both, skipped)
}

#[test]
fn wgpu_renders_every_example_the_cpu_renders() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".shd"))
        .collect();
    names.sort();
    assert!(names.len() >= 28, "{names:?}");
    let scene = torus("");
    let cases: Vec<(String, String, Scene)> = names
        .iter()
        .map(|n| (n.clone(), std::fs::read_to_string(format!("{dir}/{n}")).unwrap(), scene.clone()))
        .collect();
    let (failures, both, skipped) = sweep(&cases);
    eprintln!("{both} cases rendered on both; not for the CPU:\n{}", skipped.join("\n"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // Most of the 3 × examples plan and render (5 do not plan: EMBM and
    // signed textures on geforce256, shadow mask's depth test on the
    // combiners, solid mapping's float textures on both GeForces).
    assert!(both + 8 >= 3 * names.len(), "only {both} of {} cases rendered", 3 * names.len());
}

/// The constructs no example shows.
#[test]
fn wgpu_renders_the_constructs_no_example_shows() {
    let dual_paraboloid =
        torus("    textures: { \"Env\": DualParaboloid(size: 32, sun: (0.3, 0.8, 0.5)) },\n");
    // Shadow volumes' first two statements: the stencil counts the volumes.
    let volumes: String =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/shadow_volumes.shd"))
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with("C delta pi x <- !"))
            .map(|l| format!("{l}\n"))
            .collect();
    let occluder =
        Scene::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/shadow_occluder_floor.ron")))
            .unwrap();
    let lit = "vector N : normal;\nvector L : light(0);\nshader d : s → c = max(0, N·L);\nC δπx ← δ d s x;\n";
    let cases = [
        (
            "a scene's dual-paraboloid map by direction",
            "vector R : reflection in eye;\ntexture Env : cube rgb8 bilinear clamp = image(\"sky.png\");\nC δπx ← Env δR s x;\n".to_string(),
            dual_paraboloid,
        ),
        (
            "the read-back framebuffer's alpha in a condition",
            format!("{lit}C xs ← ((α C xs) > 0.5) ? (1, 0, 0, 1);\n"),
            torus(""),
        ),
        (
            "the read-back framebuffer's colour in a condition",
            format!("{lit}C xs ← ((C xs).r > 0.3) ? (0, 1, 0, 1);\n"),
            torus(""),
        ),
        (
            "the stencil read in a mesh pass's shader",
            format!("{volumes}C delta pi x <- (stencil C delta pi x) * (delta p s' x);\n"),
            occluder.clone(),
        ),
        ("the stencil read in a screen pass's shader", format!("{volumes}C xs <- (stencil C xs) * 0.5 + (C xs);\n"), occluder),
    ];
    let cases: Vec<(String, String, Scene)> =
        cases.into_iter().map(|(n, s, scene)| (n.to_string(), s, scene)).collect();
    let (failures, both, skipped) = sweep(&cases);
    eprintln!("{both} cases rendered on both; not for the CPU:\n{}", skipped.join("\n"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // The conditions on the framebuffer's own colour plan on wgsl only: a
    // combiner target discards by the alpha test, whose alpha the
    // combiners compute and cannot read the destination into.
    assert!(both >= 7, "only {both} cases rendered on both:\n{}", skipped.join("\n"));
}
