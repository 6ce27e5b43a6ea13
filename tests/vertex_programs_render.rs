//! `render` through the vertex programs (NV_vertex_program on geforce3):
//! each mesh pass's vertices come from its emitted `!!VP1.0` program run in
//! the interpreter, and that equals the host's evaluation of the IR within
//! f32 rounding, the colour results clamped to [0, 1] as NV_vertex_program
//! Section 2.14.1.5 says (`src/renderer/vertex_program.rs`).

use std::path::Path;

use shadec::backends::vertex_program::program::Output;
use shadec::ir::eval::{Evaluator, Value};
use shadec::ir::Expr;
use shadec::numerics::Precision;
use shadec::pipeline::{PassInterface, Planned};
use shadec::profile::Profile;
use shadec::renderer::plan::PlanRenderer;
use shadec::renderer::vertex_program::PassProgram;
use shadec::scene::bind::{self, VertexEnv};
use shadec::scene::Scene;

/// The bound: |program − host| ≤ TOLERANCE · (1 + |host|) per component,
/// the emitter's own check (`vertex_programs::emit`): a few dozen f32
/// operations, each rounded once (2⁻²⁴ ≈ 6·10⁻⁸), where the host rounds
/// once from f64; `RSQ` of a small length multiplies the error.
const TOLERANCE: f64 = 2e-4;

fn scene() -> Scene {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap()
}

fn plan(source: &str, target: &str) -> Planned {
    let profile = Profile::resolve(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default())
        .map(|c| c.planned)
        .unwrap_or_else(|d| panic!("{target}: {d:?}\n{source}"))
}

/// Per-vertex programs like the emitter's own generated ones.
fn generated(case: u64) -> String {
    const SCALARS: [&str; 10] = [
        "max(0, N·L)",
        "N·V",
        "saturate(N·H)",
        "max(0, N·H)^8",
        "k",
        "clamp(N·L, 0.2, 0.9)",
        "abs(V·L)",
        "(N·L + 1)/2",
        "normalize(N + L)·V",
        "cross(N, L)·V",
    ];
    let mut seed = 0x9e37_79b9_7f4a_7c15u64 ^ case.wrapping_mul(0x2545_f491_4f6c_dd1d);
    let mut pick = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 33) as usize
    };
    let mut term = || {
        let (a, b) = (SCALARS[pick() % SCALARS.len()], SCALARS[pick() % SCALARS.len()]);
        match pick() % 4 {
            0 => format!("({a} + {b})"),
            1 => format!("({a} * {b})"),
            2 => format!("max({a}, {b})"),
            _ => format!("({a} - {b})"),
        }
    };
    let (r, g, b) = (term(), term(), term());
    format!(
        "vector N : normal;\nvector L : light(0);\nvector V : view;\nvector H = normalize(L + V);\nuniform k : scalar = 0.5;\nconst kd : rgb = (0.8, 0.6, 0.4);\n\nshader p : s → c = kd * rgb({r}, {g}, {b});\nC δπx ← δ p s x;\n"
    )
}

/// The host's values of pass `index` at one vertex: interpolants, then the
/// clip position (what the renderer's host vertex stage computes).
fn host(planned: &Planned, index: usize, env: &mut VertexEnv) -> Vec<Value> {
    let m = &planned.module;
    let pi = PassInterface::of(planned, index);
    let mut roots: Vec<_> = pi
        .interpolants
        .iter()
        .map(|&h| match m.exprs[h] {
            Expr::Interpolate { value, .. } => value,
            _ => h,
        })
        .collect();
    roots.extend(pi.position);
    let mut ev = Evaluator::new(m, &roots, Precision::Exact);
    ev.eval(env).values.to_vec()
}

/// Compares every vertex of every object; the worst relative difference.
fn compare_pass(planned: &Planned, index: usize, program: &PassProgram, scene: &Scene, what: &str) -> f64 {
    let assets = scene.build().unwrap();
    let m = &planned.module;
    let objects = bind::bound_objects(scene, &assets, m, 4.0 / 3.0).unwrap();
    let uniforms = bind::uniforms(m, scene);
    let e = program.emitted();
    let mut worst = 0.0f64;
    for object in &objects {
        let (nv, varyings, clip) = program.vertices(m, object, &uniforms);
        assert_eq!(nv, 4 * e.interpolants.len());
        assert_eq!(clip.len(), object.n_vertices());
        for vertex in 0..object.n_vertices() {
            let mut env = VertexEnv { object, module: m, vertex, uniforms: &uniforms };
            let want = host(planned, index, &mut env);
            let mut check = |name: &str, w: f64, g: f32| {
                let d = (w - f64::from(g)).abs() / (1.0 + w.abs());
                worst = worst.max(d);
                assert!(d <= TOLERANCE, "{what}: vertex {vertex} {name}: host {w}, vertex program {g}");
            };
            for (k, o) in e.outputs.iter().take(e.interpolants.len()).enumerate() {
                // The colours reach the rasterizer clamped (Section 2.14.1.5).
                let colour = Output::COLOURS.contains(o);
                for c in 0..4 {
                    let w = if colour { want[k][c].clamp(0.0, 1.0) } else { want[k][c] };
                    check(&format!("o[{}].{c}", o.name()), w, varyings[vertex * nv + 4 * k + c]);
                }
            }
            if want.len() > e.interpolants.len() {
                let p = want[e.interpolants.len()];
                for c in 0..4 {
                    check(&format!("o[HPOS].{c}"), p[c], clip[vertex][c]);
                }
            }
        }
    }
    worst
}

#[test]
fn rendering_through_vertex_programs_equals_the_host_path_on_generated_programs() {
    let scene = scene();
    let (mut passes, mut worst) = (0, 0.0f64);
    for case in 0..12 {
        let source = generated(case);
        let planned = plan(&source, "geforce3");
        for index in 0..planned.plan.passes.len() {
            let Some(program) = PassProgram::of(&planned, index) else { continue };
            worst = worst.max(compare_pass(&planned, index, &program, &scene, &format!("case {case}")));
            passes += 1;
        }
    }
    eprintln!("generated programs: {passes} passes through vertex programs, worst relative difference {worst:e} (bound {TOLERANCE:e})");
    assert!(passes >= 12, "only {passes} passes ran as vertex programs");
}

/// Renders `planned` at 96×72, through its vertex programs or not.
fn render(planned: &Planned, source: &str, scene: &Scene, mode: Precision) -> Vec<[f32; 4]> {
    let (program, _) = shadec::parser::check(source);
    let assets = scene.build().unwrap();
    let mut r = PlanRenderer::new(planned, &program, scene, &assets).unwrap();
    // Unrounded: the two frames differ by f32 rounding, below an 8-bit step.
    r.set_unrounded_targets(true);
    r.render(mode, 96, 72, &mut |_, _| {}).unwrap().image.to_rgba_f32()
}

#[test]
fn a_geforce3_frame_through_vertex_programs_matches_the_host_frame() {
    let scene = scene();
    let (mut worst, mut differing, mut total) = (0.0f32, 0usize, 0usize);
    for case in 0..4 {
        let source = generated(case);
        let programmed = plan(&source, "geforce3");
        assert!(PassProgram::of(&programmed, 0).is_some(), "case {case}: no vertex program");
        let mut on_host = programmed.clone();
        on_host.vertex_programs = false;
        let a = render(&programmed, &source, &scene, Precision::Fixed9);
        let b = render(&on_host, &source, &scene, Precision::Fixed9);
        for (p, q) in a.iter().zip(&b) {
            let d = (0..4).map(|c| (p[c] - q[c]).abs()).fold(0.0f32, f32::max);
            worst = worst.max(d);
            differing += usize::from(d > 0.0);
            total += 1;
        }
    }
    eprintln!(
        "fixed9 frames: {differing} of {total} pixels differ, by at most {worst} ({} steps of 1/255)",
        worst * 255.0
    );
    // A varying that differs in its last f32 bit can round to the other
    // side of an 8-bit tie, and a triangle edge through a pixel centre can
    // move: a step or two on a few pixels, never a different picture.
    assert!(
        worst <= 3.0 / 255.0 + 1e-6 || differing * 1000 <= total,
        "{differing} of {total} pixels differ by up to {worst}"
    );
    assert!(differing * 100 <= total, "{differing} of {total} pixels differ");
}

#[test]
fn an_f32_frame_through_vertex_programs_differs_from_the_host_frame_only_by_rounding() {
    let scene = scene();
    let (mut worst, mut differing) = (0.0f32, 0usize);
    for case in 4..6 {
        let source = generated(case);
        let programmed = plan(&source, "geforce3");
        let mut on_host = programmed.clone();
        on_host.vertex_programs = false;
        let a = render(&programmed, &source, &scene, Precision::F32);
        let b = render(&on_host, &source, &scene, Precision::F32);
        for (p, q) in a.iter().zip(&b) {
            let d = (0..4).map(|c| (p[c] - q[c]).abs() / (1.0 + q[c].abs())).fold(0.0f32, f32::max);
            worst = worst.max(d);
            differing += usize::from(d > 0.0);
        }
    }
    eprintln!("f32 frames: {differing} pixels differ, by at most {worst:e} relative");
    // The frames were drawn through the programs: their f32 vertex values
    // differ from the host's f64 ones in the last bits somewhere …
    assert!(differing > 0, "no pixel differs: were the vertex programs run?");
    // … and by no more than the vertex values' bound (a pixel whose
    // coverage moves at an edge aside, which f32 frames of these smooth
    // programs did not show).
    assert!(f64::from(worst) <= TOLERANCE, "worst {worst}");
}

#[test]
fn whether_a_target_has_vertex_programs_comes_from_its_profile() {
    assert!(Profile::builtin("geforce3").unwrap().vertex_programs);
    assert!(!Profile::builtin("geforce256").unwrap().vertex_programs);
    assert!(!Profile::builtin("wgsl").unwrap().vertex_programs);
    let source = generated(0);
    let planned = plan(&source, "geforce3");
    assert!(planned.vertex_programs);
    assert!(PassProgram::of(&planned, 0).is_some());
    let text = shadec::backends::vertex_program::emit::pass_text(&planned, 0, Some(&source), "");
    assert!(text.starts_with("!!VP1.0"), "{text}");
    // The same target name with a profile that says no: the host computes.
    let mut without = planned.clone();
    without.vertex_programs = false;
    assert!(PassProgram::of(&without, 0).is_none());
    let text = shadec::backends::vertex_program::emit::pass_text(&without, 0, Some(&source), "");
    assert!(text.contains("has no vertex programs"), "{text}");
    // A profile file of a GeForce3 without the field: none (the default).
    let ron = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/profiles/geforce3.ron")).unwrap();
    let stripped: String =
        ron.lines().filter(|l| !l.contains("vertex_programs:")).collect::<Vec<_>>().join("\n");
    let profile = Profile::from_ron(&stripped, "geforce3_without.ron").unwrap();
    assert!(!profile.vertex_programs);
    let planned = shadec::driver::compile(&source, &profile, &Default::default()).unwrap().planned;
    assert!(PassProgram::of(&planned, 0).is_none());
}
