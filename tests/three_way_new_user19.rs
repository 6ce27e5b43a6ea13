//! Held-out user programs of the nineteenth session
//! (`tests/data/heldout_nineteenth/`), written as a new user would and not
//! among the examples: half-Lambert, a lacquer's two specular lobes,
//! Quake 3's "modulate 2x" light map, NPR hatching, two-tone car paint, a
//! toon outline by N·V (and the same through a normalization cube map, as
//! geforce3's refusal suggests), a bloom-style bright pass, desaturation
//! in a screen pass, a spherical-harmonics-like sky per vertex, a
//! reflection fading between two environments, Schlick's Fresnel to the
//! fifth power, tinted wrap lighting, two spot lights over a texture, fog
//! by eye distance, a bump-mapped gloss through a normalization cube map,
//! a rim added in a second draw, light through stained glass, a posterized
//! table, a detail texture fading with distance, Gooch shading with a
//! highlight, a modulate-blended lighting pass, a Kajiya-Kay hair
//! highlight, emissive windows from a mask's alpha and a specular map.
//! Each renders alike on the CPU, wgpu and the independent reference on
//! every target its header names (`three_way_heldout::renders_alike_in`).

use shadec::profile::Profile;

use crate::three_way_heldout::held_out_everywhere_in;

held_out_everywhere_in!("heldout_nineteenth":
    aniso_hair,
    bright_pass,
    car_paint,
    desaturate,
    detail_fade,
    emissive_mask,
    env_blend,
    eye_fog,
    gloss_ncube,
    gooch_spec,
    half_lambert,
    hatching,
    lambert_spec_map,
    modulate2x,
    modulate_pass,
    outline_ncube,
    outline_nv,
    posterize,
    rim_alpha,
    schlick5,
    sh_ambient,
    spot_tex,
    stained_glass,
    two_lobes,
    wrap_tint,
);

fn source(name: &str) -> String {
    std::fs::read_to_string(crate::three_way_heldout::data("heldout_nineteenth").join(name)).unwrap()
}

/// `rgb(g, g, g)` of one scalar is the grey `rgb(g)`: a screen pass
/// pulling a colour toward its grey (`desaturate`) was refused on geforce3
/// ("a vector built from separate components cannot be computed by the
/// register combiners"), though a splat is one input mapping. The
/// three-way test `desaturate` renders it.
#[test]
fn a_grey_written_channel_by_channel_plans_on_geforce3() {
    let geforce3 = Profile::resolve("geforce3").unwrap();
    let planned = shadec::compile(&source("desaturate.shd"), &geforce3);
    assert!(
        planned.is_ok(),
        "{:?}",
        planned.err().map(|d| d.iter().map(|d| d.message.clone()).collect::<Vec<_>>())
    );
    // Three different channels are still a vector the combiners cannot build.
    let swapped = source("desaturate.shd").replace("rgb(grey, grey, grey)", "rgb(grey, (Col xs).r, grey)");
    assert!(shadec::compile(&swapped, &geforce3).is_err());
}

/// A toon outline by `N·V` needs N, V and L per fragment: three signed
/// vectors where the combiners interpolate two colours. geforce3 falls
/// back per vertex, far over the budget, and the refusal now says why per
/// fragment is refused and what to do; done as it says (V and L through a
/// normalization cube map, `outline_ncube`), the program plans per
/// fragment and renders alike three ways.
#[test]
fn the_per_vertex_refusal_says_why_per_fragment_failed_and_its_help_is_true() {
    let geforce3 = Profile::resolve("geforce3").unwrap();
    let refused = shadec::compile(&source("outline_nv.shd"), &geforce3).unwrap_err();
    let [d] = refused.as_slice() else { panic!("{refused:?}") };
    assert_eq!(d.code, "per-vertex-over-budget");
    let help = d.help.as_deref().unwrap_or_default();
    assert!(help.contains("per fragment geforce3 refuses it ("), "{help}");
    assert!(help.contains("normalization cube map"), "{help}");
    let planned = shadec::compile(&source("outline_ncube.shd"), &geforce3).unwrap();
    assert!(planned.approximations.iter().all(|a| a.rule != "per_vertex"), "{:?}", planned.approximations);
}

/// Two spot lights' terms summed inside one δ on geforce3: each term needs
/// three interpolated colours (the intensity, N and L), so the sum falls
/// back per vertex. As one vertex colour GL clamps it to [0, 1]: 88.7/255
/// off on the held-out scene, and `render` refused it, saying to split
/// the sum inside δ. The planner now splits it across δ itself (each
/// term its own vertex colour, added by a pass of its own), as the split
/// written by hand (one statement per light, added) plans: within the
/// budget on its scene, `render` and `check --scene` alike.
#[test]
fn a_sum_of_spot_lights_falls_back_per_vertex_term_by_term_within_the_budget() {
    let dir = tempfile::tempdir().unwrap();
    let data = crate::three_way_heldout::data("heldout_nineteenth");
    std::fs::copy(data.join("spots_floor.ron"), dir.path().join("spots_floor.ron")).unwrap();
    let brick = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/brick.png");
    std::fs::copy(brick, dir.path().join("brick.png")).unwrap();
    let whole = source("spot_tex.shd").replace("../../../examples/brick.png", "brick.png");
    std::fs::write(dir.path().join("whole.shd"), &whole).unwrap();
    let render = |shd: &str| {
        let args = [
            "render",
            "spots_floor.ron",
            "--shader",
            shd,
            "--target",
            "geforce3",
            "--size",
            "64x64",
            "-o",
            "x.png",
        ];
        crate::common::shadec_in(dir.path(), &args)
    };
    let check = |shd: &str| {
        let args = ["check", "--scene", "spots_floor.ron", "--target", "geforce3", shd];
        crate::common::shadec_in(dir.path(), &args)
    };
    let split = whole
        .replace(
            "shader two : s → c = I0 * max(0, N·L0) + I1 * max(0, N·L1);",
            "shader t0 : s → c = I0 * max(0, N·L0);\nshader t1 : s → c = I1 * max(0, N·L1);",
        )
        .replace(
            "C δπx ← Base δu x * two δ s x;",
            "C δπx ← Base δu x * t0 δ s x;\nC δπx ← (C δπx) ⊕[add] (Base δu x * t1 δ s x);",
        );
    std::fs::write(dir.path().join("split.shd"), split).unwrap();
    for shd in ["whole.shd", "split.shd"] {
        for accepted in [render(shd), check(shd)] {
            assert_eq!(accepted.code, 0, "{shd}: {}", accepted.stderr);
            assert!(accepted.stderr.contains("within the per-vertex budget"), "{shd}: {}", accepted.stderr);
            assert!(!accepted.stderr.contains("per-vertex-over-budget"), "{shd}: {}", accepted.stderr);
        }
    }
    // Each light's term is its own per-vertex part, on the whole sum too.
    let checked = check("whole.shd");
    assert_eq!(checked.stderr.matches("(`per_vertex`): this term of a sum").count(), 2, "{}", checked.stderr);
}

/// `check` without a scene measures a per-vertex fall-back on the built-in
/// torus, which has one light: a program naming light 1 (`spot_tex`) was
/// measured 10/255 there, its light 1 terms zero, and refused at 88.7/255
/// on its own scene. The warning now says so and where to measure it.
#[test]
fn a_fall_back_measured_on_the_one_light_torus_says_other_lights_were_not_there() {
    let torus =
        shadec::scene::Scene::parse(shadec::accuracy::DEFAULT_SCENE, std::path::Path::new("t.ron")).unwrap();
    assert_eq!(torus.lights.len(), 1, "the caveat's text says the torus has one light");
    let checked = shadec::verdict::check(&source("spot_tex.shd"), Some("geforce3")).unwrap();
    let per_vertex: Vec<_> =
        checked.diagnostics.iter().filter(|d| d.message.contains("(`per_vertex`)")).collect();
    assert_eq!(per_vertex.len(), 1, "{:?}", checked.diagnostics);
    let help = per_vertex[0].help.as_deref().unwrap_or_default();
    assert!(help.contains("the torus has one light") && help.contains("--scene"), "{help}");
    // A program of light 0 only gets no such caveat.
    let checked = shadec::verdict::check(&source("outline_nv.shd"), Some("geforce3")).unwrap();
    assert!(checked.diagnostics.iter().all(|d| !d.help.as_deref().unwrap_or_default().contains("one light")));
}
