//! Vertex programs on wgpu (NV_vertex_program on geforce3): the wgpu scene
//! runner draws each mesh pass through its emitted `!!VP1.0` program,
//! translated to a WGSL vertex stage, as the CPU renderer draws it through
//! the interpreter, and both clamp the colour results to [0, 1] before
//! interpolation (NV_vertex_program, Section 2.14.1.5).
//!
//! # The bounds
//!
//! The program's f32 vertex values differ from the host's f64 ones by
//! rounding (`vertex_programs_render::TOLERANCE`, 2·10⁻⁴ relative), and the
//! GPU's `inverseSqrt` and fused multiply-adds from the interpreter's by a
//! few ulps: far below an 8-bit step. So the three frames — wgpu through
//! the programs, the CPU through the interpreter, the CPU and wgpu on the
//! host path — agree as the three-way suite's executors do
//! ([`crate::three_way::PIXEL_TOLERANCE`] on all but
//! [`crate::three_way::PIXEL_FRACTION`] of the covered pixels, the edges
//! where a rounding moves a pixel's coverage), and the reference
//! (`shadec::oracle`) agrees with both.

use shadec::gpu::runner::{Gpu, ShaderSource};
use shadec::gpu::scene_run::ScenePlan;
use shadec::numerics::Precision;
use shadec::pipeline::Planned;
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;
use shadec::renderer::vertex_program::PassProgram;
use shadec::scene::Scene;

use crate::three_way::{difference, render_three, scene, verdict, Difference, H, W};

fn gpu() -> Gpu {
    crate::common::gpu::gpu().expect("no wgpu adapter: the suite needs lavapipe (see .ci/run)")
}

fn plan(source: &str) -> Planned {
    let profile = Profile::resolve("geforce3").unwrap();
    shadec::driver::compile(source, &profile, &Default::default())
        .map(|c| c.planned)
        .unwrap_or_else(|d| panic!("{d:?}\n{source}"))
}

/// Per-vertex colours that stay in [0, 1] (every term is), so clamping
/// them at the vertices changes nothing and the host path (interpolate,
/// then clamp at the pixel) must agree.
pub fn in_range(case: u64) -> String {
    const SCALARS: [&str; 8] = [
        "max(0, N·L)",
        "saturate(N·V)",
        "saturate(N·H)",
        "max(0, N·H)^8",
        "k",
        "clamp(N·L, 0.2, 0.9)",
        "(N·L + 1)/2",
        "saturate(normalize(N + L)·V)",
    ];
    let mut seed = 0x2545_f491_4f6c_dd1du64 ^ case.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    let mut pick = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 33) as usize
    };
    let mut term = || {
        let (a, b) = (SCALARS[pick() % SCALARS.len()], SCALARS[pick() % SCALARS.len()]);
        match pick() % 4 {
            0 => format!("({a} + {b})/2"),
            1 => format!("({a} * {b})"),
            2 => format!("max({a}, {b})"),
            _ => format!("min({a}, {b})"),
        }
    };
    let (r, g, b) = (term(), term(), term());
    format!(
        "vector N : normal;\nvector L : light(0);\nvector V : view;\nvector H = normalize(L + V);\nuniform k : scalar = 0.5;\nconst kd : rgb = (0.8, 0.6, 0.4);\n\nshader p : s → c = kd * rgb({r}, {g}, {b});\nC δπx ← δ p s x;\n"
    )
}

/// The CPU's and wgpu's frames of `planned` (RGBA8, row 0 at the top).
fn frames(
    planned: &Planned,
    source: &str,
    scene: &Scene,
    precision: Precision,
    gpu: &Gpu,
) -> (Vec<u8>, Vec<u8>) {
    let (program, _) = shadec::parser::check(source);
    let assets = scene.build().unwrap();
    let cpu = PlanRenderer::new(planned, &program, scene, &assets)
        .unwrap()
        .render(precision, W, H, &mut |_, _| {})
        .unwrap()
        .image
        .to_rgba8();
    let plan = ScenePlan::new(planned, &program, Some(source), precision, scene, &assets).unwrap();
    let wgpu = plan.render(gpu, W, H).unwrap().into_raw();
    (cpu, wgpu)
}

/// How many of the mesh draws of `planned`'s wgpu frame run a vertex
/// program as their vertex stage, of how many draws.
fn staged_draws(planned: &Planned, source: &str, scene: &Scene) -> (usize, usize) {
    let (program, _) = shadec::parser::check(source);
    let assets = scene.build().unwrap();
    let plan = ScenePlan::new(planned, &program, Some(source), Precision::F32, scene, &assets).unwrap();
    let passes = plan.passes(W, H).unwrap();
    let staged = passes
        .iter()
        .filter(|p| {
            matches!(p.shader.source, ShaderSource::Staged { .. }) && p.shader.vertex_entry == "vp_main"
        })
        .count();
    (staged, passes.len())
}

#[test]
fn wgpu_draws_geforce3_mesh_passes_through_their_vertex_programs() {
    let scene = scene("kilgard_torus.ron");
    for case in 0..3 {
        let source = in_range(case);
        let planned = plan(&source);
        assert!(PassProgram::of(&planned, 0).is_some(), "case {case}: the emitter gave no program\n{source}");
        let (staged, draws) = staged_draws(&planned, &source, &scene);
        assert!(draws > 0 && staged == draws, "case {case}: {staged} of {draws} draws through the program");
        // The same plan on a target without vertex programs: the host's stage.
        let mut on_host = planned.clone();
        on_host.vertex_programs = false;
        assert_eq!(staged_draws(&on_host, &source, &scene).0, 0, "case {case}");
    }
}

/// The largest channel difference and the share of covered pixels off by
/// more than the tolerance, over several generated programs.
fn worst(diffs: &[Difference]) -> (u8, f64) {
    diffs.iter().fold((0, 0.0), |(m, f), d| (m.max(d.max), f64::max(f, d.fraction)))
}

/// wgpu through the programs = the CPU through the interpreter = the
/// host path on both = the reference, on generated per-vertex programs.
#[test]
fn vertex_programs_on_wgpu_agree_with_the_cpu_the_host_path_and_the_reference() {
    let gpu = gpu();
    let scene = scene("kilgard_torus.ron");
    let (mut programmed, mut hosts, mut reference) = (vec![], vec![], vec![]);
    for case in 0..6 {
        let source = in_range(case);
        for precision in [Precision::F32, Precision::Fixed9] {
            let p = render_three(&source, "geforce3", &scene, precision, Some(&gpu)).unwrap();
            assert!(p.gpu_refused.is_none(), "case {case}: wgpu refused: {:?}", p.gpu_refused);
            let through = p.gpu.as_ref().unwrap();
            verdict(&p).unwrap_or_else(|e| panic!("case {case} {precision:?}: {e}\n{source}"));
            programmed.push(difference(&p.cpu, through, &p.covered));
            reference.push(difference(through, &p.oracle, &p.covered));
            // The host path, on either executor, against wgpu through the programs.
            let mut on_host = plan(&source);
            on_host.vertex_programs = false;
            let (cpu_host, gpu_host) = frames(&on_host, &source, &scene, precision, &gpu);
            for (what, host) in [("CPU", &cpu_host), ("wgpu", &gpu_host)] {
                let d = difference(through, host, &p.covered);
                assert!(
                    d.within(),
                    "case {case} {precision:?}: wgpu's programs against the {what} host path: {d:?}"
                );
                hosts.push(d);
            }
        }
    }
    let (a, b, c) = (worst(&programmed), worst(&hosts), worst(&reference));
    eprintln!(
        "12 frames: wgpu programs/CPU programs max {}/255, {:.2}% off; /host paths max {}/255, {:.2}% off; /reference max {}/255, {:.2}% off",
        a.0,
        100.0 * a.1,
        b.0,
        100.0 * b.1,
        c.0,
        100.0 * c.1
    );
}

/// A per-vertex colour that leaves [0, 1]: twice the light's intensity
/// times N·L, which geforce3 cannot compute per fragment (the intensity's
/// attenuation and spot factor), so the plan takes the announced
/// `per_vertex` fall-back, one interpolant clamped as a vertex colour.
/// (A sum of terms each in [0, 1], as `examples/gouraud.shd` has, would
/// not do: the planner interpolates such terms apart; nor would a signed
/// colour: it range-compresses that into [0, 1] itself.)
const OUT_OF_RANGE: &str = "vector N : normal;\nvector L : light(0);\nvector I : intensity;\n\
    shader d : s → c = 2 * I * max(0, N·L);\nC δπx ← d δ s x;\n";

/// NV_vertex_program Section 2.14.1.5: "the selected primary and secondary
/// colors ... are clamped to the range [0,1] and then interpolated". Both
/// executors clamp `o[COL0]` at the vertices, and their frames agree.
#[test]
fn both_executors_clamp_vertex_program_colours_before_interpolation() {
    let gpu = gpu();
    let scene = scene("kilgard_torus.ron");
    let planned = plan(OUT_OF_RANGE);
    let program = PassProgram::of(&planned, 0).expect("a vertex program");
    let e = program.emitted();
    assert!(
        e.outputs.iter().take(e.interpolants.len()).any(|o| o.name() == "COL0"),
        "the colour goes to o[COL0]: {:?}",
        e.outputs
    );
    // The interpreter's vertices are clamped: none outside [0, 1] …
    let assets = scene.build().unwrap();
    let objects = shadec::scene::bind::bound_objects(&scene, &assets, &planned.module, 4.0 / 3.0).unwrap();
    let uniforms = shadec::scene::bind::uniforms(&planned.module, &scene);
    let (nv, varyings, _) = program.vertices(&planned.module, &objects[0], &uniforms);
    let k = e.outputs.iter().position(|o| o.name() == "COL0").unwrap();
    let colours: Vec<f32> = varyings.chunks(nv).flat_map(|v| v[4 * k..4 * k + 3].to_vec()).collect();
    assert!(colours.iter().all(|c| (0.0..=1.0).contains(c)), "a colour outside [0, 1]");
    assert!(colours.contains(&0.0) && colours.contains(&1.0), "the program never left [0, 1]: not a test");
    // … and the frames: wgpu = CPU. (The host path takes the same
    // announced clamp, so it is no contrast here: the vertices above, at
    // exactly 1 where 2·I·max(0, N·L) passes it, are the evidence.)
    let all = vec![true; (W * H) as usize];
    for precision in [Precision::F32, Precision::Fixed9] {
        let (cpu, wgpu) = frames(&planned, OUT_OF_RANGE, &scene, precision, &gpu);
        let same = difference(&cpu, &wgpu, &all);
        eprintln!("{precision:?}: CPU/wgpu {same:?}");
        assert!(same.within(), "{precision:?}: the CPU and wgpu differ: {same:?}");
    }
}
