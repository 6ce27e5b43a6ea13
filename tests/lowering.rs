//! The lowering (issue 18, `shadec::lowering`): each rule's output (the IR
//! it makes), its stated error bound measured against the program's
//! meaning on a scene, its refusal; a property over generated programs;
//! and every example planned on both combiner targets with every pass
//! realized, or refused with a located reason.

use crate::common;

use std::path::Path;

use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use shadec::diag::Diagnostic;
use shadec::driver::PlanOptions;
use shadec::ir::{Expr, MathFunction, Module};
use shadec::lowering::{self, Choice, LowerOptions, Normalization};
use shadec::numerics::Precision;
use shadec::parser::ast::TextureKind;
use shadec::pipeline::Planned;
use shadec::profile::Profile;
use shadec::renderer::plan::{compare, PlanRenderer};
use shadec::scene::Scene;

const W: u32 = 48;
const H: u32 = 36;
/// Both renders are rounded to RGBA8 once each.
const FRAMEBUFFER: f64 = 1.0 / 255.0;

fn module(source: &str) -> Module {
    let (program, diags) = shadec::parser::check(source);
    assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
    let (module, diags) = shadec::ir::lower(&program);
    assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
    module
}

/// Plans `source` through the driver with the lowering `options`.
fn compile_with(source: &str, profile: &Profile, lowering: LowerOptions) -> Result<Planned, Vec<Diagnostic>> {
    let options = PlanOptions { lowering, ..Default::default() };
    shadec::driver::compile(source, profile, &options).map(|c| c.planned)
}

/// `source` planned with only the choice of rules `pick` selects.
fn compile_choice(source: &str, profile: &Profile, pick: impl Fn(&Choice) -> bool) -> Planned {
    let choice = lowering::choices(profile).into_iter().find(|c| pick(c)).expect("such a choice");
    compile_with(source, profile, LowerOptions { only: Some(choice), ..Default::default() }).unwrap()
}

fn compile(source: &str, profile: &Profile) -> Result<Planned, Vec<Diagnostic>> {
    compile_with(source, profile, LowerOptions::default())
}

fn example(name: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples").join(name)).unwrap()
}

fn scene() -> Scene {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap()
}

/// Whether a statement of `m` still computes `fun` per fragment.
fn computes_per_fragment(m: &Module, fun: MathFunction) -> bool {
    let roots: Vec<_> = m.statements.iter().filter(|st| !m.is_baked(st)).map(|st| st.value).collect();
    m.reachable(&roots)
        .into_iter()
        .any(|h| m.info(h).freq.is_sample() && matches!(&m.exprs[h], Expr::Math { fun: f, .. } if *f == fun))
}

/// The f32 render of `planned` (a plan of `source`) on `scene`.
fn f32_render(planned: &Planned, source: &str, scene: &Scene) -> shadec::renderer::Framebuffer {
    let (program, _) = shadec::parser::check(source);
    let assets = scene.build().unwrap();
    PlanRenderer::new(planned, &program, scene, &assets)
        .and_then(|mut r| {
            // The plan's arithmetic, not the 8-bit store every plan shares.
            r.set_unrounded_targets(true);
            r.render(Precision::F32, W, H, &mut |_, _| {})
        })
        .unwrap()
        .image
}

/// The largest difference between the f32 render of `planned` and the f32
/// render of the program's meaning (the reference shares nothing with the
/// lowering: it evaluates `normalize`, `sqrt`, … themselves).
fn error_against_meaning(source: &str, planned: &Planned, scene: &Scene) -> f64 {
    against_meaning(source, planned, scene).max_abs as f64
}

/// The RMSE of the same comparison.
fn rmse_against_meaning(source: &str, planned: &Planned, scene: &Scene) -> f64 {
    against_meaning(source, planned, scene).rmse
}

fn against_meaning(source: &str, planned: &Planned, scene: &Scene) -> shadec::renderer::plan::ErrorReport {
    let (program, _) = shadec::parser::check(source);
    let (written, _) = shadec::ir::lower(&program);
    let meaning = shadec::meaning::plan(&written, scene.lights.len()).unwrap();
    compare(&f32_render(&meaning, source, scene), &f32_render(planned, source, scene))
}

const NORMALIZED: &str = "vector N : normal;\nC δπx ← rgb(compress(normalize(δ N s x)));\n";

#[test]
fn normalize_per_fragment_becomes_a_normalization_cube_map_lookup() {
    let m = module(NORMALIZED);
    let profile = Profile::builtin("geforce256").unwrap();
    let lowered = lowering::lower(
        &m,
        &profile,
        Choice { normalization: Normalization::CubeMap, gouraud: false, tables_2d: false, by_term: false },
        &|_| "-".into(),
    );
    assert!(computes_per_fragment(&m, MathFunction::Normalize));
    assert!(!computes_per_fragment(&lowered.module, MathFunction::Normalize));
    let cube = lowered.module.textures.iter().find(|t| t.kind == TextureKind::Cube).expect("a cube map");
    assert!(matches!(cube.declaration, Some(shadec::ir::AddedSource::NormalizeCube { .. })), "{cube:?}");
    let st = lowered.module.statements.last().unwrap();
    let looked_up = lowered.module.reachable(&[st.value]).into_iter().any(|h| {
        matches!(lowered.module.exprs[h], Expr::Lookup { texture, .. } if lowered.module.textures[texture as usize].kind == TextureKind::Cube)
    });
    assert!(looked_up, "the statement samples the cube map");
    assert_eq!(lowered.approximations.len(), 1);
    assert_eq!(lowered.approximations[0].rule, "normalization_cube_map");
    assert_eq!(
        lowered.approximations[0].error_bound,
        Some(lowering::cube_map::error_bound(lowering::cube_map::SIZE))
    );
}

#[test]
fn a_normalization_cube_map_stays_within_its_bound_of_the_meaning() {
    let profile = Profile::builtin("geforce256").unwrap();
    let planned = compile(NORMALIZED, &profile).expect("lowered and planned");
    let a = &planned.plan.approximations;
    assert_eq!(a.len(), 1, "{a:?}");
    // compress halves the vector's error.
    let bound = a[0].output_bound.unwrap() + FRAMEBUFFER;
    let e = error_against_meaning(NORMALIZED, &planned, &scene());
    assert!(e <= bound, "measured {e} > stated {bound}");
    assert!(e > 0.0, "a table is not exact");
}

/// On geforce3, which has signed formats, the cube map is 16-bit signed
/// (HILO, seeds/000 Section 5.1) and read without `expand`; the combiners
/// take its negative components as they are (signed identity — unsigned
/// identity would clamp them to 0, which the bit-faithful render of
/// `max(0, N·L)` with two signed texels exposed: 101/255 off). In fixed9,
/// 9-bit registers and an 8-bit framebuffer, the plan stays within a few
/// steps of the meaning.
#[test]
fn a_hilo_normalization_cube_map_is_signed_all_the_way_through_the_combiners() {
    let source = "vector N : normal;\nvector L : light(0);\nC δπx ← rgb(max(0, normalize(δ N s x)·normalize(δ L s x)));\n";
    let profile = Profile::builtin("geforce3").unwrap();
    let planned = compile(source, &profile).unwrap();
    let a = &planned.plan.approximations;
    assert!(a.iter().all(|a| a.rule == "normalization_cube_map" && a.why.contains("HILO")), "{a:?}");
    assert_eq!(a[0].error_bound, Some(lowering::cube_map::error_bound_hilo(lowering::cube_map::SIZE)));
    let cube = planned.module.textures.iter().find(|t| t.kind == TextureKind::Cube).unwrap();
    assert_eq!(cube.format, shadec::parser::ast::TextureFormat::Signed16);
    let scene = scene();
    let (program, _) = shadec::parser::check(source);
    let (written, _) = shadec::ir::lower(&program);
    let assets = scene.build().unwrap();
    let render = |p: &Planned, precision| {
        PlanRenderer::new(p, &program, &scene, &assets)
            .and_then(|r| r.render(precision, W, H, &mut |_, _| {}))
            .unwrap()
            .image
    };
    let meaning = shadec::meaning::plan(&written, scene.lights.len()).unwrap();
    let e = compare(&render(&meaning, Precision::Exact), &render(&planned, Precision::Fixed9));
    assert!(e.max_abs <= 4.0 / 255.0, "{e:?}");
}

#[test]
fn taylor_renormalization_is_formula_6_on_the_vertex_unit_vector() {
    let m = module(NORMALIZED);
    let profile = Profile::builtin("geforce256").unwrap();
    let lowered = lowering::lower(
        &m,
        &profile,
        Choice { normalization: Normalization::Taylor, gouraud: false, tables_2d: false, by_term: false },
        &|_| "-".into(),
    );
    assert!(!computes_per_fragment(&lowered.module, MathFunction::Normalize));
    assert!(lowered.module.textures.iter().all(|t| t.kind != TextureKind::Cube));
    // w + ½w(1 − w·w): a dot product of the interpolant with itself.
    let st = lowered.module.statements.last().unwrap();
    let dots = lowered.module.reachable(&[st.value]).into_iter().any(|h| {
        matches!(lowered.module.exprs[h], Expr::Binary { op: shadec::ir::BinaryOp::Dot, lhs, rhs } if lhs == rhs)
    });
    assert!(dots);
    let rules: Vec<&str> = lowered.approximations.iter().map(|a| a.rule.as_str()).collect();
    // The interpolated unit vector reaches the combiners range-compressed.
    assert_eq!(rules, ["taylor_renormalization", "range_compression"]);
    assert_eq!(lowered.approximations[0].error_bound, None, "only a scene knows the vertex angles");
    assert_eq!(lowered.approximations[1].error_bound, Some(1.0 / 255.0));
}

fn tabulated(f: &str) -> String {
    format!(
        "vector N : normal;\nvector L : light(0);\nshader c : s → scalar = max(0, N·L);\n\
         const k : rgb = (1, 1, 1);\nC δπx ← k * ({});\n",
        f.replace('@', "(δ c s x)")
    )
}

#[test]
fn a_function_of_an_interpolated_scalar_becomes_a_table_baked_by_the_compiler() {
    let source = tabulated("sqrt(@)");
    let m = module(&source);
    let profile = Profile::builtin("geforce256").unwrap();
    let lowered = lowering::lower(&m, &profile, lowering::choices(&profile)[0], &|_| "-".into());
    assert!(!computes_per_fragment(&lowered.module, MathFunction::Sqrt));
    assert_eq!(lowered.module.statements.len(), m.statements.len() + 1);
    let table = &lowered.module.statements[lowered.module.statements.len() - 2];
    assert!(lowered.module.is_baked(table), "the table's texel statement comes first and is the compiler's");
    let a = &lowered.approximations;
    assert_eq!(a.iter().map(|a| a.rule.as_str()).collect::<Vec<_>>(), ["baked_table"]);
    // √ is steep at 0: the bound the compiler measured says so.
    let bound = a[0].error_bound.unwrap();
    assert!(bound > 0.5 / 255.0 && bound < 0.05, "{bound}");
}

#[test]
fn what_no_rule_lowers_keeps_its_located_refusal() {
    let profile = Profile::builtin("geforce256").unwrap();
    let embm = example("embm.shd");
    let err = compile(&embm, &profile).unwrap_err();
    assert!(err[0].message.contains("dependent lookup"), "{}", err[0].message);
    assert!(err[0].primary.span.end > 0);
    // --no-approx refuses as before issue 18.
    let source = example("fragment_lighting.shd");
    let off = LowerOptions { approximate: false, max_error: None, only: None };
    let err = compile_with(&source, &profile, off).unwrap_err();
    assert!(err[0].message.contains("`normalize` per fragment"), "{}", err[0].message);
    // A bound tighter than the cube map's refuses it too.
    let tight = LowerOptions { approximate: true, max_error: Some(1e-4), only: None };
    assert!(compile_with(&source, &profile, tight).is_err());
    let on = compile(&source, &profile).unwrap();
    assert!(on.plan.approximations.iter().any(|a| a.rule == "normalization_cube_map"));
}

#[test]
fn a_program_that_plans_as_written_is_not_lowered() {
    for (name, target) in
        [("phong_cubemap_normalized.shd", "geforce3"), ("kilgard_bump_mapping.shd", "geforce256")]
    {
        let planned = compile(&example(name), &Profile::builtin(target).unwrap()).unwrap();
        assert!(planned.plan.approximations.is_empty(), "{name}");
    }
}

/// Generated programs `k · f(δ c)` for functions the combiners lack:
/// each lowered plan's render stays within its stated bound of the
/// meaning's.
#[test]
fn lowered_tables_stay_within_their_stated_bounds_of_the_meaning() {
    let functions = prop_oneof![
        Just("sqrt(@)".to_string()),
        (1.0f64..4.0).prop_map(|a| format!("exp(-{a:.2} * @)")),
        (0.3f64..0.95).prop_map(|p| format!("@ ^ {p:.2}")),
        (1.05f64..1.95).prop_map(|p| format!("@ ^ {p:.2}")),
        (2.0f64..6.0).prop_map(|a| format!("0.2 / (0.2 + {a:.2} * @)")),
        Just("fract(3 * @)".to_string()),
    ];
    let scene = scene();
    let mut runner = TestRunner::new(Config { cases: 12, failure_persistence: None, ..Config::default() });
    runner
        .run(&(functions, prop::bool::ANY), |(f, gf3)| {
            let source = tabulated(&f);
            let profile = Profile::builtin(if gf3 { "geforce3" } else { "geforce256" }).unwrap();
            let planned = compile(&source, &profile)
                .map_err(|e| TestCaseError::fail(format!("{f}: {}", e[0].message)))?;
            let a = &planned.plan.approximations;
            // `fract(3·δc)`: one period of a table read with REPEAT wrap.
            let tables = ["baked_table", "periodic_table"];
            prop_assert!(a.iter().any(|a| tables.contains(&a.rule.as_str())), "{f}: {a:?}");
            let bound: f64 = a.iter().map(|a| a.output_bound.unwrap()).sum::<f64>() + FRAMEBUFFER;
            let e = error_against_meaning(&source, &planned, &scene);
            prop_assert!(e <= bound, "{f}: measured {e} > stated {bound}");
            Ok(())
        })
        .unwrap();
}

/// A table whose argument the lowering computes per vertex (`f(d)`, `d` a
/// dot product of normalized interpolants) against an independent
/// reference: the meaning of the same program written with `d` evaluated
/// per vertex and interpolated by the user (`δ dv s x`), which is what
/// the approximation claims to compute. Chains of one to three functions
/// (steps among them) make the lowering tabulate parts before the whole
/// (the bug `a_table_over_a_tabulated_part_…` pins: the rest of a chain
/// tabulated as a function of an inner table's value). The per-vertex
/// approximation has no bound of its own, so the differential suite holds
/// such plans only to the lowered program's meaning; this holds the
/// lowering itself to a program the user could have written.
#[test]
fn a_table_at_a_per_vertex_argument_computes_the_program_with_that_argument_interpolated() {
    let step = prop_oneof![
        Just("sqrt(@)"),
        Just("@ ^ 0.6"),
        Just("exp(-2 * @)"),
        Just("floor(3 * @) / 3"),
        Just("0.3 + 0.7 * @"),
        Just("1 - @"),
        Just("0.2 / (0.2 + 3 * @)"),
    ];
    let chain = prop::collection::vec(step, 1..=3).prop_map(|steps| {
        steps.iter().fold("d".to_string(), |inner, f| f.replace('@', &format!("({inner})")))
    });
    let scene = scene();
    let checked = std::sync::atomic::AtomicUsize::new(0);
    let mut runner = TestRunner::new(Config { cases: 16, failure_persistence: None, ..Config::default() });
    runner
        .run(&(chain, prop::bool::ANY), |(f, gf3)| {
            let program = |d: &str| {
                format!(
                    "vector N : normal in eye;\nvector L : light(0) in eye;\nconst kd : rgb = (0.8, 0.7, 0.6);\n\
                     shader dv : s → scalar = max(0, normalize(N) · normalize(L));\nlet d = {d};\nC δπx ← kd * saturate({f});\n"
                )
            };
            let source = program("max(0, normalize(N δ s x) · normalize(L δ s x))");
            let reference = program("δ dv s x");
            let profile = Profile::builtin(if gf3 { "geforce3" } else { "geforce256" }).unwrap();
            let Ok(planned) = compile(&source, &profile) else { return Ok(()) };
            let a = &planned.plan.approximations;
            if !a.iter().any(|a| a.rule == "per_vertex") || !a.iter().any(|a| a.rule == "baked_table") {
                return Ok(()); // not this rule: the differential suite's
            }
            let tables: f64 = a.iter().filter_map(|a| a.output_bound).sum();
            let (program_ref, _) = shadec::parser::check(&reference);
            let (written, _) = shadec::ir::lower(&program_ref);
            let meaning = shadec::meaning::plan(&written, scene.lights.len()).unwrap();
            let e = compare(&f32_render(&meaning, &reference, &scene), &f32_render(&planned, &source, &scene));
            // A step's edge moves by a pixel between the two interpolations
            // (a table coordinate against the argument itself): RMSE, not max.
            prop_assert!(e.rmse <= tables + 2.0 * FRAMEBUFFER + 0.01, "{f}: RMSE {} (max {}) from the per-vertex program", e.rmse, e.max_abs);
            checked.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            Ok(())
        })
        .unwrap();
    let checked = checked.into_inner();
    assert!(checked >= 4, "only {checked} of 16 programs took a per-vertex table");
}

/// Issue 18's done-when: every example plans on both combiner targets with
/// every pass realized by the combiner generator, or is refused with a
/// located reason and a help line.
#[test]
fn every_example_plans_realized_or_is_refused_where_it_is() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "shd"))
        .collect();
    names.sort();
    let mut planned_count = 0;
    for path in &names {
        let source = std::fs::read_to_string(path).unwrap();
        for target in ["geforce256", "geforce3"] {
            let profile = Profile::builtin(target).unwrap();
            match compile(&source, &profile) {
                Ok(p) => {
                    planned_count += 1;
                    for (i, pass) in p.plan.passes.iter().enumerate() {
                        assert!(
                            pass.baked || p.setups[i].combiners().is_some(),
                            "{path:?} on {target}: pass {i}: no combiner setup"
                        );
                    }
                }
                Err(errors) => {
                    eprintln!("{} on {target}: refused: {}", path.display(), errors[0].message);
                    for d in errors.iter().filter(|d| d.is_error()) {
                        let s = d.primary.span;
                        assert!(
                            s.end as usize <= source.len() && s.end > 0,
                            "{path:?}: unlocated {}",
                            d.message
                        );
                        assert!(d.help.as_deref().is_some_and(|h| !h.is_empty()), "{path:?}: no help");
                    }
                }
            }
        }
    }
    // 27 of 56 planned before the lowering; fragment_lighting then planned
    // on both; powers by squaring and per-vertex shading as the last resort
    // then planned 43 of 56; signed textures re-stored and fat textures split,
    // 48; a decal distributed over an rgb sum written as rgba (and steps per
    // vertex), phong_taylor_renormalized on both: 50; the exponent table's
    // function for a dependent lookup, phong_exponent_lookup on geforce256: 51.
    assert!(planned_count >= 51, "{planned_count}");
}

/// A 16-bit signed normalization cube map on the GeForce 256, which has no
/// signed formats: rule `signed_texture_compression` binds the same
/// generator into RGB8, range-compressed, and expands each lookup — within
/// its bound of the meaning (the meaning samples the declared 16-bit map).
#[test]
fn a_signed_cube_map_is_stored_range_compressed_where_the_target_has_no_signed_textures() {
    let source = "texture Nc : cube signed16 bilinear clamp = normalize_cube(64, 16);\nvector L : light(0);\nC δπx ← rgb(compress(Nc δ L s x));\n";
    let gf3 = compile(source, &Profile::builtin("geforce3").unwrap()).unwrap();
    assert!(gf3.plan.approximations.is_empty(), "geforce3 has signed textures");
    let planned = compile(source, &Profile::builtin("geforce256").unwrap()).expect("lowered and planned");
    let a = &planned.plan.approximations;
    assert_eq!(a.len(), 1, "{a:?}");
    assert_eq!((a[0].rule.as_str(), a[0].at.as_str()), ("signed_texture_compression", "3:21"));
    let copy = planned.module.textures.iter().find(|t| t.copy_of.as_deref() == Some("Nc")).expect("a copy");
    assert_eq!(copy.format, shadec::parser::ast::TextureFormat::Rgb8);
    // compress halves the vector's error.
    let bound = a[0].output_bound.unwrap() + FRAMEBUFFER;
    let e = error_against_meaning(source, &planned, &scene());
    assert!(e <= bound, "measured {e} > stated {bound}");
    // Where a dependent lookup remains (its coordinate reads an image: no
    // function, no vertex value), the refusal names it, not the signed
    // format the lowering supplied.
    let dependent = "vector H : half(0) in tangent;\ntexture Nc : cube signed16 = normalize_cube(64, 16);\n\
        texture D : 2d r8 = image(\"d.png\");\ntexture Ramp : 1d r8 = image(\"ramp.png\");\n\
        const N : vec3 = (0, 0, 1);\nC δπx ← rgb(Ramp ((N·(Nc δ H s x)) * (D δu x)));\n";
    let err = compile(dependent, &Profile::builtin("geforce256").unwrap()).unwrap_err();
    assert_eq!(err.len(), 1, "{err:?}");
    assert!(err[0].message.contains("dependent lookup"), "{}", err[0].message);
}

/// Deferred shading's fat framebuffer (seeds/001 (5)-(6)) on geforce3:
/// rule `fat_texture_split` gives each member the shader reads its own
/// 8-bit texture, range-compressed, with alpha marking written texels; the
/// f32 render stays within the rule's bounds of the same program planned
/// for wgsl, which keeps the float fat texture (the written program, no
/// lowering) — the background too, where a compressed zero would expand
/// to (−1, −1, −1).
#[test]
fn a_fat_texture_becomes_one_compressed_texture_per_member_read() {
    let source = example("deferred_shading.shd");
    let planned = compile(&source, &Profile::builtin("geforce3").unwrap()).expect("lowered and planned");
    let a = &planned.plan.approximations;
    let splits = a.iter().filter(|a| a.rule == "fat_texture_split").count();
    assert_eq!(splits, 3, "N, L and H are read, V is not: {a:?}");
    let m = &planned.module;
    let roots: Vec<_> = m.statements.iter().map(|st| st.value).collect();
    assert!(m
        .reachable(&roots)
        .iter()
        .all(|&h| !matches!(m.exprs[h], Expr::Bundle(_) | Expr::FatMember { .. })));
    let members: Vec<_> = m.textures.iter().filter(|t| t.name.starts_with("T_member")).collect();
    assert_eq!(members.len(), 3);
    assert!(members.iter().all(|t| t.format == shadec::parser::ast::TextureFormat::Rgba8));
    let wgsl = compile(&source, &Profile::builtin("wgsl").unwrap()).unwrap();
    assert!(wgsl.plan.approximations.is_empty());
    let scene = scene();
    let reference = f32_render(&wgsl, &source, &scene);
    let lit = (0..W * H).filter(|i| reference.color(i % W, i / W).is_some_and(|c| c[0] > 0.2)).count();
    assert!(lit > (W * H / 10) as usize, "the object is shaded: {lit} lit pixels");
    let e = compare(&reference, &f32_render(&planned, &source, &scene));
    eprintln!("fat texture split against the float fat texture: {e:?}");
    // Each term reads two members (≤ 1/255 each) into a dot product of
    // unit vectors; x^24 amplifies the specular term's error near 1.
    assert!(e.max_abs <= 24.0 * 2.0 / 255.0 + 2.0 * FRAMEBUFFER as f32, "{e:?}");
    assert!(e.rmse < 2.0 / 255.0, "{e:?}");
}

/// A function of a dot product that reads a normal map (rule
/// `dependent_table`: a table looked up at the dot product) used to plan
/// on geforce3 as a 1-D lookup with no `!!TS1.0` program — a pass the card
/// could not run: NV_texture_shader has no stage that looks a 1-D table up
/// at one dot product (DOT_PRODUCT_TEXTURE_1D is NV_texture_shader3's, not
/// the GeForce3's). It is now refused, located at the statement, with the
/// planner's reason (issue 39's invariant); the program as written still
/// plans for wgsl, and geforce256 still refuses it.
#[test]
fn a_function_of_a_texel_dot_product_is_refused_on_geforce3_without_its_texture_shader_stage() {
    for f in ["sqrt(max(0, @))", "max(0, @) ^ 0.7", "exp(-2 * max(0, @))"] {
        let source = format!(
            "vector L : light(0) in tangent;\ntexture Tn : 2d rgba8 bilinear repeat = normal_map(height(\"bumps.png\"), 4);\nlet N = expand((Tn δu x).rgb);\nC δπx ← rgb({});\n",
            f.replace('@', "N·(δ L s x)")
        );
        let err = compile(&source, &Profile::builtin("geforce3").unwrap()).unwrap_err();
        let start = source.find("C δπx").unwrap() as u32;
        assert!(
            err.iter().any(|d| d.primary.span.start == start),
            "{f}: not located at the statement: {err:?}"
        );
        assert!(
            err.iter().any(|d| d.message.contains("which no NV_texture_shader operation computes")),
            "{f}: {err:?}"
        );
        assert!(compile(&source, &Profile::builtin("wgsl").unwrap()).is_ok(), "{f}: wgsl");
        let err = compile(&source, &Profile::builtin("geforce256").unwrap()).unwrap_err();
        assert!(
            err.iter().any(|d| d.message.contains("dependent lookup") || d.message.contains("cannot")),
            "{err:?}"
        );
    }
}

/// The shadow mask (seeds/001 Section 3.5) on the combiner targets: the
/// light's depth map (`Cl δπl x ← δ x`) is a depth-only pass, which the
/// combiners realize by writing no colour; what is refused is the
/// per-pixel comparison of two depths, at its statement, naming what the
/// targets lack (a depth buffer the combiners read, depth textures).
#[test]
fn the_shadow_mask_is_refused_only_for_its_depth_comparison() {
    let source = example("shadow_mask.shd");
    // geforce3 runs the printed comparison as a depth-replacing redraw
    // (tests/shadow_mask.rs); geforce256 had neither texture shaders nor
    // depth textures.
    assert!(compile(&source, &Profile::builtin("geforce3").unwrap()).is_ok());
    let target = "geforce256";
    let err = compile(&source, &Profile::builtin(target).unwrap()).unwrap_err();
    assert_eq!(err.len(), 1, "{target}: {err:?}");
    let at = shadec::span::LineIndex::new(&source).line_col(&source, err[0].primary.span.start as usize);
    assert_eq!(at.line, 31, "{target}: {err:?}");
    assert!(err[0].message.contains("a per-pixel depth comparison"), "{}", err[0].message);
    assert!(err[0].help.as_deref().is_some_and(|h| h.contains("no depth textures")), "{:?}", err[0].help);
}

/// A float texture written only with colours in [0, 1] (texture shading,
/// seeds/001 (13)) on the combiner targets, which have no float formats:
/// rule `float_texture_8bit` stores it in RGBA8; the f32 render stays
/// within the rule's bound, the interpolants' range compression and the
/// framebuffer's rounding of the wgsl plan, which keeps the float texture.
#[test]
fn a_float_texture_of_colours_is_stored_in_rgba8() {
    let source = "vector N : normal in object;\nvector L : light(0) in object;\nconst kd : rgb = (0.7, 0.5, 0.3);\ntexture T : 2d rgba16f bilinear clamp;\nshader p : s → c = kd * max(0, N·L);\nT δu ← p s δu;\nC δπx ← T δu x;\n";
    let scene = scene();
    let wgsl = f32_render(&compile(source, &Profile::builtin("wgsl").unwrap()).unwrap(), source, &scene);
    for target in ["geforce256", "geforce3"] {
        let planned = compile(source, &Profile::builtin(target).unwrap()).expect("lowered and planned");
        let a = &planned.plan.approximations;
        assert!(a.iter().any(|a| a.rule == "float_texture_8bit"), "{target}: {a:?}");
        assert!(planned.module.textures.iter().any(|t| t.name == "T_rgba8"), "{target}");
        let bound: f64 = a.iter().map(|a| a.output_bound.unwrap()).sum::<f64>() + 2.0 * FRAMEBUFFER;
        let e = compare(&wgsl, &f32_render(&planned, source, &scene));
        assert!((e.max_abs as f64) <= bound, "{target}: {e:?} > {bound}");
    }
}

/// A G-buffer of normals in a float texture (`rgba(N δ s x, 1)`, deferred
/// shading, seeds/001 (5)) on the combiner targets: rule
/// `float_texture_8bit` stores the signed rgb range-compressed in RGBA8
/// and reads it expanded (bound 1/255 at the lookup); the f32 render stays
/// within the output bound, the interpolants' range compression and the
/// framebuffer's rounding of the wgsl plan, which keeps the float
/// texture. The same texture with an alpha of its own stays refused.
#[test]
fn a_float_texture_of_signed_directions_is_stored_range_compressed() {
    let source = "vector N : normal in eye;\nconst kd : rgb = (0.7, 0.7, 0.8);\nconst l : vec3 = (0.0, 0.6, 0.8);\ntexture G : 2d rgba16f nearest clamp;\nframebuffer C : rgba8, depth;\nG δπx ← rgba(N δ s x, 1);\nC xs ← rgba(kd * max(0, (G xs).rgb · l), 1);\n";
    let scene = scene();
    let wgsl = f32_render(&compile(source, &Profile::builtin("wgsl").unwrap()).unwrap(), source, &scene);
    for target in ["geforce256", "geforce3"] {
        let planned = compile(source, &Profile::builtin(target).unwrap()).expect("lowered and planned");
        let a = &planned.plan.approximations;
        let rule =
            a.iter().find(|a| a.rule == "float_texture_8bit").unwrap_or_else(|| panic!("{target}: {a:?}"));
        assert!(rule.why.contains("range-compressed"), "{}", rule.why);
        assert_eq!(rule.error_bound, Some(1.0 / 255.0));
        let bound: f64 = a.iter().map(|a| a.output_bound.unwrap()).sum::<f64>() + 2.0 * FRAMEBUFFER;
        let e = compare(&wgsl, &f32_render(&planned, source, &scene));
        assert!((e.max_abs as f64) <= bound, "{target}: {e:?} > {bound}");
        assert!(e.max_abs > 0.0, "{target}: the 8-bit store changes nothing?");
        let own_alpha = source.replace("rgba(N δ s x, 1)", "rgba(N δ s x, 0.5)");
        let err = compile(&own_alpha, &Profile::builtin(target).unwrap()).unwrap_err();
        assert!(err[0].message.contains("float textures"), "{target}: {err:?}");
    }
}

/// Kajiya-Kay's specular term, `(t·l t·v + √(1 − (t·l)²) √(1 − (t·v)²))ⁿ`, a
/// function of two dot products (seeds/001 (24)): rule `baked_table_2d`
/// tabulates it whole, indexed by the two computed per vertex (Heidrich and
/// Seidel's anisotropic lighting, seeds/002 Section 3), and the result is
/// closer to the program's meaning on the torus than per-vertex shading of
/// the whole statement, the choice it was before.
#[test]
fn a_function_of_two_dot_products_becomes_a_2d_table() {
    let source = example("kajiya_kay_hair.shd");
    for target in ["geforce256", "geforce3"] {
        let profile = Profile::builtin(target).unwrap();
        let planned = compile(&source, &profile).expect("planned with a 2-D table");
        let a = &planned.plan.approximations;
        let table =
            a.iter().find(|a| a.rule == "baked_table_2d").unwrap_or_else(|| panic!("{target}: {a:?}"));
        assert!(table.error_bound.is_some_and(|b| b > 0.0 && b < 0.02), "{table:?}");
        assert!(planned.module.textures.iter().any(|t| t.name.starts_with("table2d_lowered") && t.baked));
        let per_vertex = compile_choice(&source, &profile, |c| c.gouraud && !c.by_term);
        let (e2d, ev) = (
            error_against_meaning(&source, &planned, &scene()),
            error_against_meaning(&source, &per_vertex, &scene()),
        );
        assert!(e2d < ev, "{target}: the 2-D table is {e2d}, per-vertex shading {ev}");
    }
}

/// Seeliger's `kd·(N·L)/(N·L + N·V)` (henyey_greenstein_skin.shd) is a
/// per-object colour times a quotient of two dot products whose
/// denominator crosses 0: with 2-D tables, the quotient is tabulated
/// clamped to the combiners' [−1, 1] (recorded without a bound: only a
/// scene can say what the clamp changes), and on the sphere that is
/// closer to the program's meaning than per-vertex shading.
#[test]
fn a_quotient_that_leaves_the_combiners_range_is_tabulated_clamped() {
    let source = example("henyey_greenstein_skin.shd");
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bench_sphere.ron")).unwrap();
    let sphere = Scene::parse(&text, Path::new("scenes/bench_sphere.ron")).unwrap();
    for target in ["geforce256", "geforce3"] {
        let profile = Profile::builtin(target).unwrap();
        let planned = compile_choice(&source, &profile, |c| c.tables_2d);
        let a = &planned.plan.approximations;
        let table =
            a.iter().find(|a| a.rule == "baked_table_2d").unwrap_or_else(|| panic!("{target}: {a:?}"));
        assert!(table.error_bound.is_none() && table.why.contains("clamped to [-1, 1]"), "{table:?}");
        let first = compile(&source, &profile).unwrap();
        assert!(first.plan.approximations.iter().all(|a| a.rule != "baked_table_2d"));
        let (e2d, ev) = (
            error_against_meaning(&source, &planned, &sphere),
            error_against_meaning(&source, &first, &sphere),
        );
        assert!(e2d < ev, "{target}: the clamped table is {e2d}, per-vertex {ev}");
    }
}

/// A function of one dot product whose intermediate values leave the
/// combiners' [−1, 1] — the silhouette's `1 − (1 − V·N)⁶` (down to −63),
/// Schlick's `(1 − N·V)⁵` (up to 32) — becomes one 1-D table of the whole
/// function (clamped to [−1, 1] where it leaves it: no bound) at the dot
/// product computed per vertex, closer to the meaning than per-vertex
/// shading of the whole statement, the choice it was before.
#[test]
fn a_function_of_one_dot_product_leaving_the_combiners_range_becomes_one_table() {
    let schlick = "vector N : normal;\nvector V : view;\nconst F0 : rgb = (0.04, 0.04, 0.04);\n\
        C δπx ← F0 + (1 - F0) * (1 - (δ N s x)·(δ V s x))^5;\n";
    for source in [example("silhouette.shd"), schlick.to_string()] {
        for target in ["geforce256", "geforce3"] {
            let profile = Profile::builtin(target).unwrap();
            let planned = compile_choice(&source, &profile, |c| c.tables_2d);
            let a = &planned.plan.approximations;
            assert!(
                a.iter().any(|a| a.rule == "baked_table" && a.why.contains("one per-fragment value")),
                "{a:?}"
            );
            let table = planned.module.textures.iter().find(|t| t.baked).expect("a baked table");
            assert_eq!(table.kind, TextureKind::Tex1d);
            let per_vertex = compile_choice(&source, &profile, |c| c.gouraud && !c.by_term);
            let (et, ev) = (
                error_against_meaning(&source, &planned, &scene()),
                error_against_meaning(&source, &per_vertex, &scene()),
            );
            assert!(et < ev, "{target}: the table is {et}, per-vertex shading {ev}");
        }
    }
}

/// `x^6` of a value the combiners hold: rule `power_by_squaring` makes it
/// `x^4 · x^2` with `x^4 = (x^2)^2` — every power a square the code
/// generator builds — in one pass, within its stated bound of the meaning.
#[test]
fn a_power_that_is_not_a_power_of_two_is_squared_and_multiplied_in_one_pass() {
    let source = "vector N : normal;\nvector H : half(0);\nC δπx ← rgb(max(0, (δ N s x)·(δ H s x))^6);\n";
    let profile = Profile::builtin("geforce3").unwrap();
    let planned = compile(source, &profile).expect("lowered and planned");
    let a = &planned.plan.approximations;
    assert!(a.iter().any(|a| a.rule == "power_by_squaring"), "{a:?}");
    assert_eq!(planned.plan.passes.len(), 1);
    let m = &planned.module;
    let roots: Vec<_> = m.statements.iter().map(|st| st.value).collect();
    for h in m.reachable(&roots) {
        if let Expr::Binary { op: shadec::ir::BinaryOp::Pow, rhs, .. } = m.exprs[h] {
            assert!(m.is_constant(rhs, 2.0), "only squares remain: {:?}", m.exprs[h]);
        }
    }
    let bound: f64 = a.iter().map(|a| a.output_bound.expect("bounded")).sum::<f64>() + FRAMEBUFFER;
    let e = error_against_meaning(source, &planned, &scene());
    assert!(e <= bound, "measured {e} > stated {bound}");
}

/// Cook-Torrance's per-fragment square roots and quotients of four dot
/// products: no table of one or two arguments holds them and no split
/// fits, so the last resort shades the statement per vertex (Gouraud),
/// reported as an approximation without a bound — which `--max-error` and
/// `--no-approx` refuse.
#[test]
fn per_vertex_shading_is_the_last_resort_and_is_reported() {
    let source = example("cook_torrance.shd");
    for target in ["geforce256", "geforce3"] {
        let profile = Profile::builtin(target).unwrap();
        let planned = compile(&source, &profile).expect("planned per vertex");
        let a = &planned.plan.approximations;
        assert!(
            a.iter().any(|a| a.rule == "per_vertex" && a.error_bound.is_none() && a.at == "40:9"),
            "{target}: {a:?}"
        );
        assert!(!computes_per_fragment(&planned.module, MathFunction::Sqrt), "{target}");
        // Measured, not bounded: the per-vertex picture differs from the
        // meaning, but stays a picture of it.
        let e = error_against_meaning(&source, &planned, &scene());
        assert!(e > 0.0 && e < 0.5, "{target}: {e}");
        for refuse in [
            LowerOptions { approximate: false, max_error: None, only: None },
            LowerOptions { approximate: true, max_error: Some(0.5), only: None },
        ] {
            let err = compile_with(&source, &profile, refuse).unwrap_err();
            assert_eq!(err[0].code, "cannot-split", "{target}: {refuse:?}");
        }
    }
}

/// `--max-error` on a scene (issue 18 item 2): Cook-Torrance has only
/// unbounded lowerings on geforce3 (per-vertex shading), which the bound
/// check refuses; measured on the scene they are judged by what they do to
/// the picture: accepted within a loose E, with the measured error in the
/// plan; a tight E is refused at the approximation, naming the error the
/// closest lowering would need.
#[test]
fn max_error_on_a_scene_is_measured_against_the_meaning() {
    let source = example("cook_torrance.shd");
    let (program, _) = shadec::parser::check(&source);
    let (module, _) = shadec::ir::lower(&program);
    let profile = Profile::builtin("geforce3").unwrap();
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/bench_sphere.ron")).unwrap();
    let scene = Scene::parse(&text, Path::new("scenes/bench_sphere.ron")).unwrap();
    let assets = scene.build().unwrap();
    let options = PlanOptions {
        scene: Some(shadec::driver::ForScene::specialized(&scene, &assets)),
        ..Default::default()
    };
    let bounded = LowerOptions { max_error: Some(0.1), ..Default::default() };
    assert!(compile_with(&source, &profile, bounded).is_err(), "no stated bound: refused without a scene");
    let choose = |e: f64| shadec::accuracy::choose(&module, &program, &profile, &source, &options, e, 1);
    let (planned, candidates) = choose(0.1).expect("measured within 0.1");
    let measured = planned.plan.measured.as_ref().expect("the measured error is recorded");
    assert!(measured.max_abs > 0.0 && measured.max_abs <= 0.1, "{measured:?}");
    assert_eq!((measured.width, measured.height), (256, 256));
    assert!(candidates.iter().any(|c| c.within && c.rules == "per_vertex"), "{candidates:?}");
    let err = choose(measured.max_abs / 2.0).unwrap_err();
    assert_eq!(err[0].code, "max-error");
    let at = shadec::span::LineIndex::new(&source).line_col(&source, err[0].primary.span.start as usize);
    assert_eq!((at.line, at.col), (40, 9), "{err:?}");
    assert!(
        err[0].help.as_deref().is_some_and(|h| h.contains(&format!("{:.4}", measured.max_abs))),
        "{err:?}"
    );
}

/// Without `--max-error`, on a scene (`render`, `compile --scene`): the
/// lowering measured closest to the program's meaning, not the first in
/// the rules' order. `fragment_lighting.shd` on geforce256 has two: the
/// cube maps with x³² by passes, and per-vertex shading; whichever renders
/// closer to the meaning on the scene is taken, and its error recorded.
#[test]
fn without_max_error_a_scene_takes_the_measured_most_accurate_lowering() {
    let source = example("fragment_lighting.shd");
    let (program, _) = shadec::parser::check(&source);
    let (module, _) = shadec::ir::lower(&program);
    let profile = Profile::builtin("geforce256").unwrap();
    let scene = scene();
    let assets = scene.build().unwrap();
    let options = PlanOptions {
        scene: Some(shadec::driver::ForScene::specialized(&scene, &assets)),
        ..Default::default()
    };
    let (planned, candidates) =
        shadec::accuracy::most_accurate(&module, &program, &profile, &source, &options, 1).unwrap();
    assert!(candidates.len() >= 2, "{candidates:?}");
    let best = candidates.iter().map(|c| c.error.rmse).fold(f64::INFINITY, f64::min);
    let measured = planned.plan.measured.as_ref().expect("recorded");
    assert_eq!(measured.rmse, best, "{candidates:?}");
    // The chosen plan is one of the measured candidates, and really that close.
    assert!((error_against_meaning(&source, &planned, &scene) - measured.max_abs).abs() < 0.05);
}

/// A table of a function whose inner part an earlier step already
/// tabulated (a toon ramp `0.3 + 0.7·floor(3d)/3`: `floor(3d)` first, then
/// the chain above it, its argument `d` computed per vertex) tabulates the
/// chain as written down to that argument — it once tabulated the rest of
/// the chain as if `d` were the inner table's value (geforce3: RMSE 0.054
/// against the meaning on the torus; 0.0049 now, as on geforce256) — and
/// the inner table, read by nothing, costs no pass.
#[test]
fn a_table_over_a_tabulated_part_tabulates_the_function_as_written() {
    let source = "vector N : normal in eye;\nvector L : light(0) in eye;\nconst base : rgb = (0.2, 0.5, 0.9);\nlet d = max(0, normalize(N δ s x) · normalize(L δ s x));\nlet band = floor(d * 3) / 3;\nC δπx ← base * (0.3 + 0.7 * band);\n";
    let scene = scene();
    for target in ["geforce3", "geforce256"] {
        let profile = Profile::builtin(target).unwrap();
        let planned = compile(source, &profile).expect("planned with a table");
        let e = error_against_meaning(source, &planned, &scene);
        let rmse = rmse_against_meaning(source, &planned, &scene);
        assert!(rmse < 0.02, "{target}: RMSE {rmse} (max {e}) against the meaning");
        let m = &planned.module;
        let roots: Vec<_> = m.statements.iter().map(|st| st.value).collect();
        let read: Vec<u32> = m
            .reachable(&roots)
            .into_iter()
            .filter_map(|h| match m.exprs[h] {
                Expr::Lookup { texture, .. } => Some(texture),
                _ => None,
            })
            .collect();
        for st in &m.statements {
            if let shadec::ir::Table::Texture(t) = st.table {
                assert!(
                    read.contains(&t),
                    "{target}: `{}` is written and never read",
                    m.textures[t as usize].name
                );
            }
        }
    }
}

/// A refusal names what is left after the lowering, not what it removed:
/// `normalize` per fragment becomes a cube map, and the program is then
/// refused for its variable exponent (a gloss map's) or, on geforce256,
/// the texture units of the cube maps; the help says the lowering got
/// past the `normalize` to find it.
#[test]
fn a_refusal_names_what_the_lowering_left_not_what_it_removed() {
    let source = "texture G : 2d rgba8 bilinear repeat = image(\"gloss.png\");\nvector N : normal in eye;\nvector H : half(0) in eye;\nC δπx ← rgb(max(0, normalize(N δ s x) · normalize(H δ s x)) ^ (1 + 63 * (G δu x).a));\n";
    for target in ["geforce3", "geforce256"] {
        let err = compile(source, &Profile::builtin(target).unwrap()).unwrap_err();
        // geforce3 is left with the exponent; geforce256 first with the
        // third texture unit the two cube maps and the gloss map need.
        let left =
            if target == "geforce3" { "non-constant or fractional exponent" } else { "3 texture units" };
        assert!(err[0].message.contains(left), "{target}: {}", err[0].message);
        assert!(!err[0].message.contains("normalize"), "{target}: {}", err[0].message);
        let help = err[0].help.as_deref().unwrap_or("");
        assert!(
            help.contains("as written it also needs `normalize` per fragment, which the lowering"),
            "{target}: {help}"
        );
    }
}

/// Most accurate means the smallest RMSE, not the smallest largest
/// difference: a toon ramp (`floor`, `step`) has a step that every
/// approximation moves by a pixel somewhere, so the largest difference is
/// about the same for all; on geforce3 the per-vertex shading of the whole
/// statement is measured closer (in RMSE) than tables of the steps at
/// interpolated arguments, and is taken.
#[test]
fn the_most_accurate_lowering_is_the_one_with_the_smallest_rmse() {
    let source = "vector N : normal in eye;\nvector L : light(0) in eye;\nvector V : view in eye;\nconst base : rgb = (0.2, 0.5, 0.9);\nlet d = max(0, normalize(N δ s x) · normalize(L δ s x));\nlet band = floor(d * 3) / 3;\nlet edge = step(0.3, normalize(N δ s x) · normalize(V δ s x));\nC δπx ← base * (0.3 + 0.7 * band) * edge;\n";
    let (program, _) = shadec::parser::check(source);
    let (module, _) = shadec::ir::lower(&program);
    let scene = scene();
    let assets = scene.build().unwrap();
    let options = PlanOptions {
        scene: Some(shadec::driver::ForScene::specialized(&scene, &assets)),
        ..Default::default()
    };
    for target in ["geforce3", "geforce256"] {
        let profile = Profile::builtin(target).unwrap();
        let (planned, candidates) =
            shadec::accuracy::most_accurate(&module, &program, &profile, source, &options, 1).unwrap();
        assert!(candidates.len() >= 2, "{target}: {candidates:?}");
        let chosen = candidates.iter().find(|c| c.chosen).expect("one chosen");
        assert!(candidates.iter().all(|c| c.error.rmse >= chosen.error.rmse), "{target}: {candidates:?}");
        assert_eq!(planned.plan.measured.as_ref().map(|m| m.rmse), Some(chosen.error.rmse));
    }
}

/// The same through the CLI: `compile --scene S --max-error E` records the
/// measured error in the plan; `render --max-error E` lists every lowering
/// it measured.
#[test]
fn the_cli_measures_max_error_on_the_scene() {
    let common = ["examples/cook_torrance.shd", "--target", "geforce3", "--max-error", "0.1"];
    let r = common::shadec(
        &[
            &["compile"][..],
            &common,
            &["--emit", "plan", "--format", "json", "--scene", "scenes/bench_sphere.ron"],
        ]
        .concat(),
    );
    assert_eq!(r.code, 0, "{}", r.stderr);
    let plan = shadec::pipeline::PassPlan::from_json(&r.stdout).unwrap();
    assert!(plan.measured.is_some_and(|m| m.scene == "bench_sphere.ron" && m.max_abs <= 0.1));
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.png");
    let r = common::shadec(&[
        "render",
        "scenes/bench_sphere.ron",
        "--shader",
        common[0],
        "--target",
        "geforce3",
        "--max-error",
        "0.1",
        "--size",
        "48x48",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(
        r.stdout.contains("lowering per_vertex: ") && r.stdout.contains("from the meaning on the scene"),
        "{}",
        r.stdout
    );
    assert_eq!(r.stdout.matches("— chosen").count(), 1, "{}", r.stdout);
}

/// `compile --emit plan` lists each approximation with its rule, place,
/// cost and bound; `--no-approx` and a `--max-error` below the cube map's
/// bound refuse with the planner's located reason.
#[test]
fn compile_lists_approximations_and_honours_the_flags() {
    let args = [
        "compile",
        "examples/fragment_lighting.shd",
        "--target",
        "geforce3",
        "--emit",
        "plan",
        "--format",
        "json",
    ];
    // Without a scene, a per-vertex fall-back's lowerings are measured on
    // the built-in torus and the most accurate kept, as `render` keeps it:
    // Taylor renormalization there. The fastest within --max-error 0.01 is
    // the cube maps'.
    let r = common::shadec(&args);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let plan = shadec::pipeline::PassPlan::from_json(&r.stdout).unwrap();
    assert!(plan.approximations.iter().any(|a| a.rule == "taylor_renormalization"), "{}", r.stdout);
    let r = common::shadec(&[&args[..], &["--max-error", "0.01"]].concat());
    assert_eq!(r.code, 0, "{}", r.stderr);
    let plan = shadec::pipeline::PassPlan::from_json(&r.stdout).unwrap();
    let cube = plan.approximations.iter().find(|a| a.rule == "normalization_cube_map").expect("a cube map");
    assert_eq!(cube.at, "16:14", "normalize(N) in the shader");
    assert_eq!(cube.cost.texture_units, 1);
    assert!(cube.error_bound.is_some_and(|b| b > 0.0 && b < 0.005));
    for extra in [&["--no-approx"][..], &["--max-error", "0.001"][..]] {
        let r = common::shadec(&[&args[..6], extra].concat());
        assert_eq!(r.code, 1, "{extra:?}: {}", r.stdout);
        assert!(r.stderr.contains("fragment_lighting.shd:21:1"), "{extra:?}: {}", r.stderr);
    }
    // fragment_lighting's half vector is per vertex, which states no bound:
    // any --max-error refuses it; a cube map alone is within 0.01.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("n.shd");
    std::fs::write(&file, NORMALIZED).unwrap();
    let f = file.to_str().unwrap();
    let r =
        common::shadec(&["compile", f, "--target", "geforce256", "--emit", "plan", "--max-error", "0.01"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("normalization_cube_map"), "{}", r.stdout);
}

/// A dependent lookup on the GeForce 256 (no texture shaders), property
/// over exponents and texels: a table whose generator the compiler knows
/// (`exponent_table(n)`) becomes xⁿ of the clamped coordinate in the
/// combiners (`table_function`), within its stated bound of the meaning,
/// which samples the 8-bit table; a table it does not know is indexed by
/// the coordinate computed per vertex, where the coordinate reads a
/// normalization cube map (`normalize` at the vertices), reported without
/// a bound; EMBM's offset texture is neither and stays refused
/// ([`what_no_rule_lowers_keeps_its_located_refusal`]).
#[test]
fn a_dependent_lookup_on_geforce256_becomes_its_function_or_a_per_vertex_coordinate() {
    let profile = Profile::builtin("geforce256").unwrap();
    let scene = scene();
    let mut runner = TestRunner::new(Config { cases: 6, failure_persistence: None, ..Config::default() });
    runner
        .run(&(1u32..=5, 0.3f64..1.0), |(n, k)| {
            let source = format!(
                "texture A : 2d r8 = image(\"a.png\");\ntexture Texp : 1d r8 bilinear clamp = exponent_table({n});\n\
                 const k : rgb = ({k:.2}, {k:.2}, {k:.2});\nC δπx ← k * Texp (A δu x);\n"
            );
            let planned = compile(&source, &profile).map_err(|e| TestCaseError::fail(e[0].message.clone()))?;
            let a = &planned.plan.approximations;
            prop_assert!(a.iter().any(|a| a.rule == "table_function"), "{a:?}");
            for (pass, setup) in planned.plan.passes.iter().zip(&planned.setups) {
                prop_assert!(pass.baked || setup.combiners().is_some(), "{}", pass.reason);
            }
            let bound: f64 = a.iter().map(|a| a.output_bound.unwrap()).sum::<f64>() + FRAMEBUFFER;
            let e = error_against_meaning(&source, &planned, &scene);
            prop_assert!(e <= bound, "x^{n}: measured {e} > stated {bound}");
            Ok(())
        })
        .unwrap();
    // A table of unknown content at N·normalize(H): the coordinate per vertex.
    let source =
        "vector H : half(0) in tangent;\ntexture Ncube : cube rgb8 bilinear clamp = normalize_cube(64, 8);\n\
        texture Ramp : 1d r8 bilinear clamp = image(\"ramp.png\");\nconst N : vec3 = (0, 0, 1);\n\
        C δπx ← rgb(Ramp (N·expand(Ncube δ H s x)));\n";
    let planned = compile(source, &profile).unwrap();
    let a = &planned.plan.approximations;
    assert_eq!(a.iter().map(|a| a.rule.as_str()).collect::<Vec<_>>(), ["per_vertex"], "{a:?}");
    assert!(a[0].why.contains("coordinate of this lookup") && a[0].error_bound.is_none());
    let m = &planned.module;
    let lookup = m.reachable(&[m.statements[0].value]).into_iter().find(|&h| {
        matches!(&m.exprs[h], Expr::Lookup { texture, .. } if m.textures[*texture as usize].name == "Ramp")
    });
    let Some(Expr::Lookup { coords, .. }) = lookup.map(|h| &m.exprs[h]) else { panic!("no Ramp lookup") };
    assert!(lowering::is_interpolant(m, *coords), "{:?}", m.exprs[*coords]);
}
