//! Held-out user programs of the twenty-first session
//! (`tests/data/heldout_twentyfirst/`), written as a new user would and
//! not among the examples: a matcap, a detail texture repeated eight times
//! as often, clouds scrolled by a uniform offset, energy-conserving
//! Blinn-Phong, a gamma pass, Reinhard tone mapping of a float framebuffer,
//! a halftone, toon shading through a baked ramp indexed per vertex, dirt
//! by GL's BLEND, triplanar mapping, parallax mapping, OpenGL's whole
//! lighting equation per vertex (with and without the light's intensity),
//! glass by Schlick's Fresnel between two lookups of a panorama, the
//! brighter of two photographs, a dissolve by a threshold uniform, a
//! leaf lit from either side, emboss bump mapping, four photographs
//! averaged, the darker of a shadow texture and the light, contour lines
//! and a sphere as a window on a panorama. Each renders alike on the CPU, wgpu and the
//! independent reference on every target its header names, and is refused
//! where its header says (`three_way_heldout::renders_alike_everywhere_in`).

use crate::three_way_heldout::{held_out_everywhere_in, program_in};

held_out_everywhere_in!("heldout_twentyfirst":
    avg_four,
    brighter_of_two,
    contour_lines,
    darken_min,
    detail_scaled,
    dirt_blend,
    dissolve,
    emboss,
    env_skybox,
    fresnel_glass,
    gamma_pass,
    gl_lighting_full,
    gl_material,
    halftone,
    matcap,
    normalized_blinn,
    parallax,
    reinhard,
    scroll_uniform,
    toon_texgen,
    triplanar,
    two_sided_abs,
);

/// The program of this session's folder ([`program_in`]).
fn program(name: &str) -> String {
    program_in("heldout_twentyfirst", name)
}

/// The errors `check` gives `source` on `target` (none: it plans).
fn plans(source: &str, target: &str) -> Result<(), Vec<shadec::diag::Diagnostic>> {
    let front = shadec::verdict::check(source, Some(target)).unwrap();
    let errors: Vec<_> =
        front.diagnostics.into_iter().filter(|d| d.severity == shadec::diag::Severity::Error).collect();
    if errors.is_empty() {
        Ok(())
    } else {
        Err(errors)
    }
}

/// A lookup at a swizzle of an interpolated vector that moves its
/// components (`Rock ((P δ s x).zy)`, the planes of triplanar mapping)
/// takes its mipmap level from the coordinates it samples at. Before, the
/// CPU took it from the vector's first two components (x and y), so it
/// sampled a level other than wgpu's and the reference's (16-22/255 on a
/// fifth of the torus at the probe's size).
#[test]
fn a_lookup_at_swizzled_coordinates_takes_its_level_of_detail_from_them() {
    let dir = tempfile::tempdir().unwrap();
    let brick = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/brick.png");
    std::fs::copy(brick, dir.path().join("brick.png")).unwrap();
    let program = "vector P : position;\n\
                   texture Rock : 2d rgb8 mipmap trilinear repeat = image(\"brick.png\");\n\
                   C δπx ← Rock ((P δ s x).zy);\n";
    std::fs::write(dir.path().join("t.shd"), program).unwrap();
    let mut pixels = Vec::new();
    for backend in ["cpu", "wgpu"] {
        let args = ["render", "--shader", "t.shd", "--backend", backend, "--size", "96x96", "-o", "t.png"];
        let run = crate::common::shadec_in(dir.path(), &args);
        assert_eq!(run.code, 0, "{backend}: {}", run.stderr);
        pixels.push(image::open(dir.path().join("t.png")).unwrap().to_rgba8());
    }
    let apart = pixels[0]
        .pixels()
        .zip(pixels[1].pixels())
        .map(|(a, b)| (0..3).map(|c| a.0[c].abs_diff(b.0[c])).max());
    let beyond = apart.filter(|d| d.is_some_and(|d| d > 4)).count();
    let covered = pixels[0].pixels().filter(|p| p.0[..3] != [0, 0, 0]).count();
    assert!(covered > 1000, "{covered} pixels drawn");
    assert!(beyond * 200 <= covered, "{beyond} of {covered} pixels beyond 4/255");
}

/// Two computed scalars compared select in the register combiners:
/// `a > b` is `a + (½ − b) ≥ ½` in the mux (Kilgard 2000, Section
/// 4.2.2), `½ − b` an input mapping. Before, only a comparison with a
/// constant was built, and a halftone (the light against a dot pattern)
/// and the brighter of two textures were refused on geforce3.
#[test]
fn two_computed_scalars_compared_select_in_the_combiners() {
    for name in ["halftone", "brighter_of_two"] {
        plans(&program(name), "geforce3").unwrap_or_else(|e| panic!("{name}: {e:#?}"));
    }
    // Vectors are still no condition.
    let vectors = "texture A : 2d rgb8 = image(\"examples/brick.png\");\n\
                   texture B : 2d rgb8 = image(\"examples/wood.png\");\n\
                   C δπx ← ((A δu x) > (B δu x)) ? (A δu x) : (B δu x);\n";
    assert!(plans(vectors, "geforce3").is_err());
}

/// `min` and `max` of two computed scalars pick one by the same mux (`a ≥
/// b` selects): the darker of a shadow texture and the diffuse light
/// plans on both combiner targets (`darken_min` renders alike three ways
/// there). Before, `min` was "cannot be computed by the register
/// combiners" on both.
#[test]
fn min_and_max_of_two_computed_scalars_select_in_the_combiners() {
    let darker = program("darken_min");
    for target in ["geforce256", "geforce3"] {
        plans(&darker, target).unwrap_or_else(|e| panic!("{target}: {e:#?}"));
        plans(&darker.replace("min(", "max("), target).unwrap_or_else(|e| panic!("{target} max: {e:#?}"));
    }
}

/// A square is never negative: the triplanar weights `n.x*n.x` of a
/// normalized vector are in [0, 1], so the weighted sum of three lookups
/// fits the combiners. Before, the product of two intervals gave a weight
/// [−1, 1], and geforce3 refused the program for "this value (range [-2,
/// 2]) may leave [−1, 1]", which it never does.
#[test]
fn a_square_is_never_negative_so_triplanar_weights_plan() {
    plans(&program("triplanar"), "geforce3").unwrap_or_else(|e| panic!("{e:#?}"));
}

/// A scalar uniform with no bound, compared, gets a help whose advice
/// plans: `saturate(t)` where it is read. Before, the help said only to
/// declare it a colour, `uniform t : c`, which makes the comparison a
/// type error (a scalar against an rgb).
#[test]
fn an_unbounded_scalar_uniform_compared_is_told_to_saturate_where_read() {
    let clamped = program("dissolve");
    let as_written = clamped.replace("saturate(t)", "t");
    let refusal = plans(&as_written, "geforce3").unwrap_err();
    let help = refusal[0].help.as_deref().unwrap_or_default();
    assert!(help.contains("`saturate(t)`"), "{help}");
    plans(&clamped, "geforce3").unwrap_or_else(|e| panic!("{e:#?}"));
}

/// A stated bound holds: `contour_lines` (`step(0.1, fract(8·y))`, `y` an
/// interpolated position) on geforce3 computed `fract(8·y)` per vertex
/// and tabulated `step(0.1, ·)` over [0, 1] at its interpolant; the
/// per-vertex rule's approximation was dropped once the table read it,
/// and the plan stated the table's 95.6/255 as its whole error where it
/// renders 203/255 from the meaning. The per-vertex fall-back is now kept
/// beside the table, measured on the scene, and past the per-vertex
/// budget the program is refused, naming it; a plan, where one is made,
/// is within the bounds it states. (Since the twenty-second session
/// `fract(8·y)` is a periodic table read with REPEAT wrap at `8·y`,
/// interpolated exactly: no per-vertex part, and no bound at the output,
/// which a step reads.)
#[test]
fn a_table_at_a_per_vertex_argument_states_a_bound_that_holds() {
    let source = program("contour_lines");
    let profile = shadec::profile::Profile::builtin("geforce3").unwrap();
    match shadec::driver::compile(&source, &profile, &Default::default()) {
        Ok(compiled) => {
            let planned = compiled.planned;
            let approximations = &planned.plan.approximations;
            if approximations.iter().all(|a| a.output_bound.is_some()) {
                let scene = crate::planner_algebra::scene("kilgard_torus.ron");
                let (program, _) = shadec::parser::check(&source);
                let (written, _) = shadec::ir::lower(&program);
                let meaning = shadec::meaning::plan(&written, scene.lights.len()).unwrap();
                let render = |p| crate::planner_algebra::f32_render(p, &source, &scene);
                let e = shadec::renderer::plan::compare(&render(&meaning), &render(&planned));
                let stated: f64 = approximations.iter().filter_map(|a| a.output_bound).sum();
                assert!(stated + 2.0 / 255.0 >= e.max_abs as f64, "stated {stated}, measured {}", e.max_abs);
            }
        }
        Err(errors) => {
            let over = errors.iter().find(|d| d.code == "per-vertex-over-budget");
            assert!(over.is_some_and(|d| d.message.contains("`per_vertex`")), "{errors:#?}");
        }
    }
}
