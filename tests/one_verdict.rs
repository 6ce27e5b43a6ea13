//! One verdict (issue 36, items 1–3; issue 34, "no silent approximation"):
//! `check --target T`, `compile --target T` and `render --target T` accept
//! and refuse the same programs; every approximation a plan takes is a
//! located warning with its error; a per-vertex fall-back beyond its budget
//! is refused; a missing image file is a located error unless stand-ins are
//! asked for; `render` ends with one summary line whose figures name their
//! precision and reference.
//!
//! The sweep calls the driver functions the commands call
//! (`verdict::check_with` for `check`, `verdict::judge` for `compile` and, on
//! the built-in scene, for `render`, then the CPU renderer's set-up), and a
//! few real command runs check that the commands call them.

use std::path::Path;

use proptest::strategy::{Strategy, ValueTree};
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use shadec::diag::SourceFile;
use shadec::driver::{self, ForScene, PlanOptions, TargetSource};
use shadec::renderer::plan::PlanRenderer;
use shadec::scene::Scene;
use shadec::verdict::{self, Judging};

use crate::common::{examples, shadec, shadec_in};

const TARGETS: [&str; 4] = ["geforce256", "geforce3", "multitexture", "wgsl"];

/// What each command decides for `source` on `target`: `Ok` or the first
/// error's code.
#[derive(Debug, PartialEq, Eq)]
struct Verdicts {
    check: Result<(), String>,
    compile: Result<(), String>,
    render: Result<(), String>,
    /// The render's plan took rule `solid_texture_3d` (issue 39: solid
    /// mapping plans only for a scene, whose object bounds map the
    /// positions; without one it is refused, located, naming the scene).
    for_scene_only: bool,
}

fn first_error(ds: &[shadec::diag::Diagnostic]) -> Result<(), String> {
    match ds.iter().find(|d| d.is_error()) {
        Some(d) => Err(format!("{}: {}", d.code, d.message)),
        None => Ok(()),
    }
}

/// The three verdicts, stand-ins allowed (the image files are the subject
/// of their own test): `check --target`, `compile --target --emit plan`,
/// and `render --target` on `scene` (specialized, as `render` plans).
fn verdicts(source: &str, target: &str, dir: &Path, scene: &Scene) -> Verdicts {
    let judging = Judging { images: Some(dir), stand_ins: true, ..Judging::default() };
    let checked = verdict::check_with(source, Some(target), &judging).expect("a built-in target");
    let check = first_error(&checked.diagnostics);
    let front = driver::front(source);
    let Some(module) = front.module.as_ref().filter(|_| !front.has_errors()) else {
        let e = first_error(&front.diagnostics);
        return Verdicts { check, compile: e.clone(), render: e, for_scene_only: false };
    };
    let name = driver::target_for(Some(target), &front.program, Some("wgsl")).unwrap();
    let profile = shadec::profile::Profile::resolve(&name).unwrap();
    let compile = verdict::judge(module, &front.program, &profile, source, &judging)
        .map(|_| ())
        .map_err(|e| first_error(&e).unwrap_err());
    let assets = scene.build().unwrap();
    let on_scene = Judging {
        plan: PlanOptions { scene: Some(ForScene::specialized(scene, &assets)), ..PlanOptions::default() },
        ..judging
    };
    let mut for_scene_only = false;
    let render = match verdict::judge(module, &front.program, &profile, source, &on_scene) {
        Ok(j) => {
            for_scene_only = j.planned.plan.approximations.iter().any(|a| a.rule == "solid_texture_3d");
            PlanRenderer::new(&j.planned, &front.program, scene, &assets)
                .map(|_| ())
                .map_err(|e| format!("renderer: {e}"))
        }
        Err(e) => Err(first_error(&e).unwrap_err()),
    };
    Verdicts { check, compile, render, for_scene_only }
}

/// `render`'s built-in scene, its images looked for in `dir`.
fn built_in_scene(dir: &Path) -> Scene {
    shadec::accuracy::default_scene(dir).unwrap()
}

fn same_verdict(v: &Verdicts) -> bool {
    if v.for_scene_only {
        // The one verdict that depends on the scene: refused by both
        // commands that plan for any scene, planned by `render`.
        return v.check.is_err() && v.compile == v.check && v.render.is_ok();
    }
    v.check.is_ok() == v.compile.is_ok() && v.compile.is_ok() == v.render.is_ok()
}

#[test]
fn every_example_gets_one_verdict_on_every_target() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let scene = built_in_scene(&dir);
    let mut disagree = Vec::new();
    let (mut accepted, mut refused) = (0, 0);
    for path in examples() {
        let source = std::fs::read_to_string(&path).unwrap();
        for target in TARGETS {
            let v = verdicts(&source, target, &dir, &scene);
            if !same_verdict(&v) {
                disagree.push(format!("{} on {target}: {v:?}", path.display()));
            }
            if v.check.is_ok() {
                accepted += 1;
            } else {
                refused += 1;
            }
        }
    }
    assert!(disagree.is_empty(), "check, compile and render disagree:\n{}", disagree.join("\n"));
    assert!(accepted > 0 && refused > 0, "both verdicts occur ({accepted} accepted, {refused} refused)");
}

/// Generated programs (the three-way generator's), a small fixed sample.
#[test]
fn generated_programs_get_one_verdict_on_every_target() {
    let mut runner =
        TestRunner::new_with_rng(Config::default(), TestRng::from_seed(RngAlgorithm::ChaCha, &[36; 32]));
    let dir = Path::new("/nonexistent-shadec-images");
    let scene = built_in_scene(dir);
    let mut disagree = Vec::new();
    for _ in 0..6 {
        let program = crate::three_way_generated::program().new_tree(&mut runner).unwrap().current();
        let source = program.source();
        for target in TARGETS {
            let v = verdicts(&source, target, dir, &scene);
            if !same_verdict(&v) {
                disagree.push(format!("on {target}: {v:?}\n{source}"));
            }
        }
    }
    assert!(disagree.is_empty(), "check, compile and render disagree:\n{}", disagree.join("\n\n"));
}

/// A textured Phong program, as a new user writes it from docs/language.md.
const TEXTURED_PHONG: &str = "vector N : normal;
vector L : light(0);
vector V : view;
texture Base : 2d rgba8 = image(\"wood.png\");

shader p(n: scalar = 32) : s → c {
    let Nn = normalize(N);
    let Hn = normalize(normalize(L) + normalize(V));
    max(0, Nn·normalize(L)) + max(0, Nn·Hn)^n
}

C δπx ← Base δu x * p δ s x;
";

/// Issue 36's first case: `check --target multitexture` refused a textured
/// Phong program (the texture environment cannot do arithmetic) while
/// `compile --target multitexture` planned it quietly, per vertex. Both
/// now plan it, measure the per-vertex fall-back and refuse it for the
/// same reason, at the same place; with `--max-error` both accept it.
#[test]
fn check_and_compile_agree_on_textured_phong_for_multitexture() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("phong.shd"), TEXTURED_PHONG).unwrap();
    let check = shadec_in(dir.path(), &["check", "--stand-ins", "--target", "multitexture", "phong.shd"]);
    let compile = shadec_in(
        dir.path(),
        &["compile", "--stand-ins", "--target", "multitexture", "--emit", "plan", "phong.shd"],
    );
    assert_eq!((check.code, compile.code), (1, 1), "{}\n{}", check.stderr, compile.stderr);
    for r in [&check, &compile] {
        assert!(r.stderr.contains("error[per-vertex-over-budget]"), "{}", r.stderr);
        assert!(r.stderr.contains("phong.shd:9:5"), "located at the fall-back: {}", r.stderr);
        assert!(r.stderr.contains("--max-error"), "names the flag that accepts it: {}", r.stderr);
    }
    let accept = ["--stand-ins", "--max-error", "0.5", "--target", "multitexture"];
    let check = shadec_in(dir.path(), &[&["check"], &accept[..], &["phong.shd"]].concat());
    let compile =
        shadec_in(dir.path(), &[&["compile"], &accept[..], &["--emit", "plan", "phong.shd"]].concat());
    assert_eq!((check.code, compile.code), (0, 0), "{}\n{}", check.stderr, compile.stderr);
    assert!(check.stderr.contains("warning[approximation]") && check.stderr.contains("`per_vertex`"));
    assert!(compile.stdout.contains("per_vertex"));
}

/// A per-vertex fall-back within its budget is taken, and said: a warning
/// in `check --target` and `compile`, located at the expression, with the
/// error measured on the built-in scene (precision and reference named)
/// and the options that forbid it — once each.
#[test]
fn per_vertex_fall_back_is_a_located_warning_with_its_measured_error() {
    let file = "examples/fragment_lighting.shd";
    let check = shadec(&["check", "--target", "geforce256", file]);
    let compile = shadec(&["compile", "--target", "geforce256", "--emit", "plan", file]);
    assert_eq!((check.code, compile.code), (0, 0), "{}\n{}", check.stderr, compile.stderr);
    for r in [&check, &compile] {
        let per_vertex: Vec<&str> = r.stderr.lines().filter(|l| l.contains("(`per_vertex`)")).collect();
        assert_eq!(per_vertex.len(), 1, "once: {}", r.stderr);
        assert!(r.stderr.contains("measured ") && r.stderr.contains("rendered in f32"), "{}", r.stderr);
        assert!(r.stderr.contains("--no-approx") && r.stderr.contains("--max-error"), "{}", r.stderr);
    }
    let source = std::fs::read_to_string(file).unwrap();
    let checked = verdict::check(&source, Some("geforce256")).unwrap();
    let warnings: Vec<_> =
        checked.diagnostics.iter().filter(|d| d.code == "approximation").cloned().collect();
    let text = SourceFile::new(file, source).render(&warnings, false);
    insta::assert_snapshot!("fragment_lighting_geforce256_approximations", text);
    // --no-approx refuses what the warnings named.
    let refused = shadec(&["check", "--no-approx", "--target", "geforce256", file]);
    assert_eq!(refused.code, 1, "{}", refused.stderr);
}

/// Beyond the budget: refused, located, naming the fall-back, its error and
/// the flag that accepts it; a `--max-error` below the measured error
/// refuses it too.
#[test]
fn per_vertex_beyond_its_budget_is_refused_naming_the_flag_that_accepts_it() {
    let source = TEXTURED_PHONG.replace("image(\"wood.png\")", "bumps(8)");
    let checked = verdict::check(&source, Some("multitexture")).unwrap();
    let errors: Vec<_> = checked.diagnostics.iter().filter(|d| d.is_error()).collect();
    assert_eq!(errors.len(), 1, "{errors:?}");
    let e = errors[0];
    assert_eq!(e.code, "per-vertex-over-budget");
    assert!(e.message.contains("per_vertex") && e.message.contains("/255"), "{}", e.message);
    assert!(e.help.as_deref().unwrap_or("").contains("--max-error"), "{:?}", e.help);
    let line_col = shadec::span::LineIndex::new(&source).line_col(&source, e.primary.span.start as usize);
    assert_eq!((line_col.line, line_col.col), (9, 5));
    let judging = |e: f64| Judging {
        plan: PlanOptions {
            lowering: shadec::lowering::LowerOptions { max_error: Some(e), ..Default::default() },
            ..Default::default()
        },
        ..Judging::default()
    };
    assert!(!verdict::check_with(&source, Some("multitexture"), &judging(0.9)).unwrap().has_errors());
    assert!(verdict::check_with(&source, Some("multitexture"), &judging(0.01)).unwrap().has_errors());
}

/// The library's `shadec::compile` gives the CLI's verdict: the textured
/// Phong program whose per-vertex fall-back `check` refuses is refused
/// there too, with the same error (it used to be planned quietly, since
/// it went through `driver::compile`, the planner's plan without the
/// vetting — which still plans it, as its documentation says).
#[test]
fn the_library_compile_refuses_what_check_refuses() {
    let source = TEXTURED_PHONG.replace("image(\"wood.png\")", "bumps(8)");
    let multitexture = shadec::profile::Profile::resolve("multitexture").unwrap();
    let refused = shadec::compile(&source, &multitexture).unwrap_err();
    let codes: Vec<&str> = refused.iter().map(|d| d.code).collect();
    assert_eq!(codes, ["per-vertex-over-budget"], "{refused:?}");
    assert!(driver::compile(&source, &multitexture, &PlanOptions::default()).is_ok());
    let lighting = std::fs::read_to_string("examples/fragment_lighting.shd").unwrap();
    let geforce256 = shadec::profile::Profile::resolve("geforce256").unwrap();
    let judged = verdict::compile(&lighting, &geforce256, &Judging::default()).unwrap();
    assert!(
        judged.warnings.iter().any(|w| w.code == "approximation"),
        "the fall-back within its budget is said"
    );
}

/// A missing image file is a located error in `check`, `compile` and
/// `render` (it used to become procedural bricks in `render`, exit 0);
/// `--stand-ins` asks for the bricks.
#[test]
fn a_missing_image_is_a_located_error_in_check_compile_and_render() {
    let dir = tempfile::tempdir().unwrap();
    let source = "texture T : 2d rgba8 = image(\"wood.png\");\nC δπx ← T δu x;\n";
    std::fs::write(dir.path().join("t.shd"), source).unwrap();
    let runs = [
        shadec_in(dir.path(), &["check", "t.shd"]),
        shadec_in(dir.path(), &["compile", "--emit", "plan", "t.shd"]),
        shadec_in(dir.path(), &["render", "--shader", "t.shd", "--size", "16x16", "-o", "t.png"]),
    ];
    for r in &runs {
        assert_eq!(r.code, 1, "{}", r.stderr);
        assert!(r.stderr.contains("error[missing-image]"), "{}", r.stderr);
        assert!(r.stderr.contains("t.shd:1:29"), "located at the file's name: {}", r.stderr);
        assert!(r.stderr.contains("--stand-ins"), "{}", r.stderr);
    }
    assert!(!dir.path().join("t.png").exists());
    let r = shadec_in(
        dir.path(),
        &["render", "--stand-ins", "--shader", "t.shd", "--size", "16x16", "-o", "t.png"],
    );
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.stdout.matches("procedural brick stand-in").count(), 1, "said once: {}", r.stdout);
    assert_eq!(shadec_in(dir.path(), &["check", "--stand-ins", "t.shd"]).code, 0);
}

/// `render` ends with one summary line (target, passes, precision, error
/// against the meaning, PSNR and what it means), its error figures name
/// their precision and reference, and an approximation is listed once.
#[test]
fn render_ends_with_one_summary_line_whose_figures_say_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let r = shadec(&[
        "render",
        "--shader",
        "examples/fragment_lighting.shd",
        "--target",
        "geforce256",
        "--size",
        "64x48",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let summary = r.stdout.lines().filter(|l| l.starts_with("summary: ")).collect::<Vec<_>>();
    assert_eq!(summary.len(), 1, "{}", r.stdout);
    let s = summary[0];
    for part in ["geforce256", "pass", "fixed9", "PSNR", "/255"] {
        assert!(s.contains(part), "{part} in {s}");
    }
    assert!(
        ["identical", "indistinguishable", "close", "visibly different", "far from"]
            .iter()
            .any(|w| s.contains(w)),
        "{s}"
    );
    assert!(r.stdout.contains("error against the program's meaning (exact, unsplit) of this fixed9 render"));
    // Measured in the arithmetic drawn (fixed9), against the meaning in f32.
    for line in r.stdout.lines().filter(|l| l.starts_with("lowering ")) {
        assert!(line.contains("the plan rendered in fixed9, the meaning in f32"), "{line}");
    }
    let listed =
        r.stderr.matches("(`per_vertex`)").count() + r.stdout.matches("approximation per_vertex").count();
    assert_eq!(listed, 1, "once:\n{}\n{}", r.stdout, r.stderr);
}

/// The plan `render` runs is `compile`'s unless the scene or the
/// precision drawn changes it, and then `render` says which and why: on
/// four lights, one pass per light. On the built-in torus (one light)
/// `compile` measures a per-vertex fall-back's lowerings there as `render`
/// in f32 does, so the two print one plan; `render` in fixed9, the
/// combiners' own arithmetic, measures them in fixed9 and on geforce3
/// draws one pass with normalization cube maps (24/255 from the meaning in
/// fixed9) where `compile` takes three with Taylor renormalization (35/255
/// in fixed9, 0.2/255 in f32), and says so.
#[test]
fn render_says_why_its_plan_is_not_the_one_compile_prints() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let out = out.to_str().unwrap();
    let (scene, shader) = ("scenes/adaptive_sphere_4lights.ron", "examples/fragment_lighting.shd");
    let r = shadec(&["render", scene, "--shader", shader, "--target", "wgsl", "--size", "32x32", "-o", out]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(
        r.stdout.contains("note: this plan (4 passes, no approximation) is not the one `shadec compile --target wgsl` prints (1 pass, no approximation): the plan is specialized for this scene"),
        "{}",
        r.stdout
    );
    let r = shadec(&["render", scene, "--shader", shader, "--no-specialize", "--size", "32x32", "-o", out]);
    assert!(!r.stdout.contains("is not the one"), "{}", r.stdout);
    for target in ["geforce3", "geforce256"] {
        let compile = shadec(&["compile", "--target", target, "--emit", "plan", shader]);
        let render = shadec(&[
            "render",
            "--shader",
            shader,
            "--target",
            target,
            "--precision",
            "f32",
            "--size",
            "32x24",
            "-o",
            out,
        ]);
        assert_eq!((compile.code, render.code), (0, 0), "{}\n{}", compile.stderr, render.stderr);
        assert!(!render.stdout.contains("is not the one"), "{target}: {}", render.stdout);
        let plan = shadec::pipeline::PassPlan::from_ron(&compile.stdout).unwrap();
        let n = plan.passes.len();
        let said = format!("{n} pass{} on {target}", if n == 1 { "" } else { "es" });
        assert!(render.stdout.contains(&said), "{target}: compile planned {n} passes:\n{}", render.stdout);
    }
    let render =
        shadec(&["render", "--shader", shader, "--target", "geforce3", "--size", "32x24", "-o", out]);
    assert_eq!(render.code, 0, "{}", render.stderr);
    assert!(
        render.stdout.contains("the lowerings measured on this scene in fixed9 (the arithmetic drawn; `compile` measures in f32), the most accurate there was chosen"),
        "{}",
        render.stdout
    );
}

/// One choice of target: `--target` > the program's declaration > a
/// `// target:` comment > the editor's setting > the default; the CLI's
/// `target_for` and the language server apply it.
#[test]
fn one_precedence_chooses_the_target() {
    use TargetSource::*;
    let pick = |said: &[(TargetSource, Option<&str>)]| driver::choose_target(said.iter().copied());
    assert_eq!(
        pick(&[(Default, Some("wgsl")), (Flag, Some("geforce3")), (Declaration, Some("geforce256"))]),
        Some(("geforce3".into(), Flag))
    );
    assert_eq!(
        pick(&[(Client, Some("geforce3")), (Declaration, Some("geforce256"))]),
        Some(("geforce256".into(), Declaration))
    );
    assert_eq!(
        pick(&[(Client, Some("geforce3")), (Comment, Some("multitexture"))]),
        Some(("multitexture".into(), Comment))
    );
    assert_eq!(pick(&[(Flag, None), (Default, Some("wgsl"))]), Some(("wgsl".into(), Default)));
    assert_eq!(pick(&[(Flag, None)]), None);
    let program = shadec::parser::parse("target geforce256;\nC δπx ← 1;\n").0;
    assert_eq!(driver::target_for(Some("geforce3"), &program, Some("wgsl")).as_deref(), Some("geforce3"));
    assert_eq!(driver::target_for(None, &program, Some("wgsl")).as_deref(), Some("geforce256"));
    let analysis =
        shadec::lsp::analysis::analyze("a.shd", "target geforce256;\nC δπx ← 1;\n", Some("geforce3"));
    assert_eq!((analysis.target.as_str(), analysis.target_source), ("geforce256", Declaration));
    // `check` of a program that declares a target checks that target.
    let declared = "target multitexture;\nvector N : normal;\nvector L : light(0);\n\
        shader p(n: scalar = 64) : s → c { max(0, normalize(N)·normalize(L))^n }\nC δπx ← p δ s x;\n";
    let checked = verdict::check(declared, None).unwrap();
    assert!(
        checked.diagnostics.iter().any(|d| d.message.contains("multitexture")),
        "{:?}",
        checked.diagnostics
    );
}

/// `render` says its plan is specialized for the scene only where
/// specialization changed it: fragment lighting on geforce3 on the
/// built-in torus (one light, no uniforms) draws in fixed9 one pass with
/// normalization cube maps where `compile` takes three — a lowering
/// measured on the scene, not specialization — and `render` said "the plan
/// is specialized for this scene (a pass per light, its uniforms folded,
/// lights culled…)" because the pass counts differed. On four lights it
/// still says so, and names the passes per light.
#[test]
fn render_says_specialized_only_where_specialization_changed_the_plan() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let out = out.to_str().unwrap();
    let shader = "examples/fragment_lighting.shd";
    let r = shadec(&["render", "--shader", shader, "--target", "geforce3", "--size", "32x24", "-o", out]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("is not the one"), "{}", r.stdout);
    assert!(r.stdout.contains("the most accurate there was chosen"), "{}", r.stdout);
    assert!(!r.stdout.contains("specialized"), "{}", r.stdout);
    let scene = "scenes/adaptive_sphere_4lights.ron";
    let r = shadec(&["render", scene, "--shader", shader, "--target", "wgsl", "--size", "32x32", "-o", out]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(
        r.stdout
            .contains("the plan is specialized for this scene (a pass per light, 3 lights after light 0;"),
        "{}",
        r.stdout
    );
}
