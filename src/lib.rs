//! shadec compiles shading programs written in the notation of "A graphics
//! pipeline grammar" (`C δπx ← T δu x ⊕ δ p s x`) into the rendering passes
//! a target can run: register-combiner setups for the GeForce 256 and
//! GeForce 3 (Kilgard 2000), and WGSL, SPIR-V or GLSL for modern GPUs. It
//! renders a plan on a scene — in the old hardware's arithmetic, in f32, or
//! exactly — and measures it against the program's meaning.
//!
//! The flow is text → [`parser`] (AST) → [`ir`] (typed, with frequencies and
//! ranges) → [`planner`] (a [`pipeline::PassPlan`] for a [`profile::Profile`])
//! → a backend ([`backends`]) or the CPU renderer ([`renderer`]).
//! [`driver`] is the one way through it that the command line, the language
//! server and the examples below take. The repository's `README.md` has a
//! tutorial of the command line, `docs/` the language, the scene format and
//! the plan's schema, and `ARCHITECTURE.md` the modules and their invariants.
//!
//! # A program to a pass plan
//!
//! ```
//! use shadec::profile::Profile;
//!
//! let source = "
//! vector N : normal;
//! vector L : light(0);
//! texture Ncube : cube rgb8 bilinear clamp = normalize_cube(32);
//! texture Tdecal : 2d rgba8 = image(\"decal.png\");
//!
//! let Ln = expand(Ncube δ L s x);
//! C δπx ← (Tdecal δu x) ⊕ max(0, expand(Ncube δ N s x)·Ln);
//! ";
//! let geforce256 = Profile::resolve("geforce256")?;
//! let plan = shadec::compile(source, &geforce256).expect("the program is clean");
//! // Three texture lookups, two texture units: the planner splits it.
//! assert!(plan.passes.len() >= 2);
//! for pass in &plan.passes {
//!     println!("{} — {}", pass.blend.name(), pass.reason);
//! }
//! let ron = plan.to_ron(); // or plan.to_json(); the schema is docs/pass-plan.md
//! assert!(ron.starts_with("PassPlan("));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Diagnostics, printed as rustc prints them
//!
//! Every problem is a [`diag::Diagnostic`] with a location, labels and a
//! help line; [`diag::SourceFile`] renders them (or makes LSP JSON of them,
//! [`diag::SourceFile::to_lsp`]):
//!
//! ```
//! use shadec::diag::SourceFile;
//!
//! let source = "vector N : normal;\nvector L : light(0);\nC δπx ← max(0, N·normalise(L));\n";
//! let front = shadec::driver::front(source);
//! assert!(front.has_errors());
//! let text = SourceFile::new("input.shd", source).render(&front.diagnostics, false);
//! let expected = "\
//! error[unknown-name]: unknown name `normalise`
//!   ┌─ input.shd:3:18
//!   │
//! 3 │ C δπx ← max(0, N·normalise(L));
//!   │                  ^^^^^^^^^ not declared
//!   │
//!   = help: did you mean `normalize`?
//! ";
//! assert_eq!(text.trim_end(), expected.trim_end());
//! ```
//!
//! # WGSL for the passes
//!
//! With the `wgsl` feature (on by default), each pass of a plan becomes a
//! naga module, validated, and the modules one WGSL document:
//!
//! ```
//! # #[cfg(feature = "wgsl")]
//! # {
//! use shadec::driver::{self, PlanOptions};
//! use shadec::numerics::Precision;
//! use shadec::backends::wgsl::{codegen, emit};
//!
//! let source = "vector N : normal;\nvector L : light(0);\nC δπx ← max(0, normalize(N δ s x)·normalize(L δ s x));\n";
//! let wgsl = shadec::profile::Profile::resolve("wgsl").unwrap();
//! let compiled = driver::compile(source, &wgsl, &PlanOptions::default()).expect("clean");
//! let passes = codegen::generate(&compiled.planned, Some(source), Precision::F32).expect("generated");
//! let text = emit::wgsl("example.shd", &passes).expect("valid WGSL");
//! assert!(text.contains("fn vs_main") && text.contains("fn fs_main"));
//! # }
//! ```
//!
//! # A picture
//!
//! A [`scene::Scene`] (RON, `docs/scenes.md`) gives the meshes, camera and
//! lights; the CPU renderer runs the plan on it in the precision asked —
//! here a GeForce 256's 8-bit textures and 9-bit combiner arithmetic:
//!
//! ```
//! use std::path::Path;
//! use shadec::driver::{self, ForScene, PlanOptions};
//! use shadec::numerics::Precision;
//! use shadec::renderer::plan::PlanRenderer;
//! use shadec::scene::Scene;
//!
//! let scene = Scene::parse(
//!     "(camera: (eye: (0.0, 0.0, 3.0), target: (0.0, 0.0, 0.0)),
//!       lights: [Directional(direction: (-1.0, -1.0, -1.0), color: (1.0, 1.0, 1.0))],
//!       objects: [(mesh: Sphere(radius: 1.0, slices: 24, stacks: 12), material: \"m\")],
//!       materials: {\"m\": ()})",
//!     Path::new("inline.ron"),
//! )?;
//! let assets = scene.build()?;
//! let source = "
//! vector N : normal;
//! vector L : light(0);
//! texture Ncube : cube rgb8 bilinear clamp = normalize_cube(32);
//! C δπx ← max(0, expand(Ncube δ N s x)·expand(Ncube δ L s x));
//! ";
//! let geforce256 = shadec::profile::Profile::resolve("geforce256")?;
//! let options = PlanOptions { scene: Some(ForScene::specialized(&scene, &assets)), ..Default::default() };
//! let compiled = driver::compile(source, &geforce256, &options).expect("the program is clean");
//! let renderer = PlanRenderer::new(&compiled.planned, &compiled.program, &scene, &assets)?;
//! let frame = renderer.render(Precision::Fixed9, 48, 48, &mut |_done, _total| {})?;
//! let rgba: Vec<u8> = frame.image.to_rgba8(); // 48 × 48 RGBA8, row by row from the top
//! assert_eq!(rgba.len(), 48 * 48 * 4);
//! // The sphere is lit in the middle and the background is black.
//! let at = |x: usize, y: usize| rgba[4 * (48 * y + x)];
//! assert!(at(24, 24) > 100 && at(1, 1) == 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

// Diagnostics are the error type throughout (a location, labels, a help
// line); they are built once per failure and never on a hot path, so boxing
// them would cost every caller a pointer chase for nothing.
#![allow(clippy::result_large_err)]

pub mod accuracy;
pub mod backends;
pub mod bench;
pub mod cost;
pub mod diag;
pub mod driver;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod io;
pub mod ir;
pub mod lowering;
pub mod lsp;
pub mod meaning;
pub mod numerics;
pub mod oracle;
pub mod parser;
pub mod pipeline;
pub mod planner;
pub mod profile;
pub mod renderer;
pub mod scene;
pub mod span;
pub mod textures;
pub mod verdict;

/// Compiles `source` for `profile` into a pass plan — parse, check, lower,
/// specialize, plan; never touches a GPU. The verdict is `shadec
/// compile`'s ([`verdict::compile`]): an approximation beyond its error
/// budget is refused, as `check` refuses it. The plan serializes to RON
/// and JSON (`PassPlan::to_ron`, `to_json`); for the IR the plan's value
/// ids refer to, the warnings, and for scenes, use [`verdict::compile`]
/// (or [`driver::compile`], the planner's plan without the vetting).
pub fn compile(source: &str, profile: &profile::Profile) -> Result<pipeline::PassPlan, Diagnostics> {
    verdict::compile(source, profile, &verdict::Judging::default()).map(|j| j.planned.plan)
}

pub use driver::Diagnostics;
