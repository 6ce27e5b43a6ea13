//! Held-out user programs of the twentieth session
//! (`tests/data/heldout_twentieth/`), written as a new user would and not
//! among the examples: velvet's sheen, Lommel–Seeliger's lunar
//! reflectance, an Earth-like day/night blend, translucency from behind,
//! thin-film iridescence from a baked ramp, a sepia post pass, a chroma-key
//! cut-out, two materials by a mask, a wet floor, sky and sun, cel bands by
//! nested selects, a glow post pass, fog by eye depth, a Fresnel clear
//! coat over a panorama cube map, a roughness map through a baked 2-D
//! exponent table, colour grading through a baked 3-D table, a rim over
//! plastic, ambient occlusion under a hemisphere, two fur shells,
//! Minnaert's limb darkening; and, for the combiner targets, a falloff
//! from a baked 3-D attenuation volume, a detail texture added signed, a
//! decal by GL's DECAL mode, (N·H)⁸ squared in the combiners, a bumped
//! diffuse and specular in two draws, a per-pixel toon ramp, moss over
//! stone by INTERPOLATE and a gloss-mapped cube-map reflection; a
//! shadow map tested with `≤`, shadow volumes under a textured highlight,
//! a stencil cut-away, a specular term replicated over four lights and a
//! material set by the scene's uniforms. Each renders alike on the CPU, wgpu and the
//! independent reference on every target its header names
//! (`three_way_heldout::renders_alike_in`).

use crate::three_way_heldout::held_out_everywhere_in;

held_out_everywhere_in!("heldout_twentieth":
    ao_hemi,
    atten_volume,
    back_light,
    cel_bands,
    chroma_key,
    clear_coat,
    day_night,
    decal_over_lit,
    depth_fog,
    detail_signed,
    env_gloss_cube,
    fur_shell,
    glow_post,
    grade_lut,
    interpolate_layers,
    lommel_seeliger,
    minnaert,
    ramp_toon_ps,
    rim_fresnel_spec,
    rough_map,
    sepia,
    shadow_le,
    shadow_vol_spec,
    sky_sun,
    spec_squared,
    stencil_cutaway,
    thin_film,
    three_lights_spec,
    two_materials,
    two_pass_bump_spec,
    uniform_tint,
    velvet,
    wet_floor,
);

/// `bake(f)` of a `3d` texture gives `f` the texel's three coordinates:
/// a table of the identity, `rgb(s.x, s.y, s.z)`, looked up at a point
/// returns the point. Before, `s` was the coordinate of the tiled 2-D grid
/// the volume is rendered as (`s.z` an error: "a vec2 has 2 components"),
/// so a colour-grading table could not be written and `s.x` depended on
/// the slice.
#[test]
fn a_baked_volume_sees_its_three_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let program = "shader id : s → c = rgb(s.x, s.y, s.z);\n\
                   texture V : 3d rgba8 bilinear clamp = bake(id);\n\
                   C xs ← V vec3(0.3, 0.6, 0.8);\n";
    std::fs::write(dir.path().join("v.shd"), program).unwrap();
    for backend in ["cpu", "wgpu"] {
        let args = ["render", "--shader", "v.shd", "--backend", backend, "--size", "8x8", "-o", "v.png"];
        let run = crate::common::shadec_in(dir.path(), &args);
        assert_eq!(run.code, 0, "{backend}: {}", run.stderr);
        let image = image::open(dir.path().join("v.png")).unwrap().to_rgba8();
        let [r, g, b, _] = image.get_pixel(4, 4).0;
        for (got, want) in [(r, 0.3), (g, 0.6), (b, 0.8)] {
            // 8-bit storage and trilinear weights: within 2/255.
            let off = (f64::from(got) - want * 255.0).abs();
            assert!(off <= 2.0, "{backend}: ({r}, {g}, {b}) for (0.3, 0.6, 0.8)·255");
        }
    }
}

/// A texture read at coordinates the same for the whole draw (one texel
/// as a colour, `T vec2(0.3, 0.6)`) takes a texture unit like any lookup.
/// Before, it had none: `--backend wgpu` stopped with "compiler bug: …
/// lookup has no texture unit" and geforce3 refused the statement, while
/// the CPU rendered it.
#[test]
fn a_texel_read_at_constant_coordinates_renders_on_every_executor() {
    let dir = tempfile::tempdir().unwrap();
    let brick = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/brick.png");
    std::fs::copy(brick, dir.path().join("brick.png")).unwrap();
    let program = "texture T : 2d rgba8 bilinear clamp = image(\"brick.png\");\n\
                   vector N : normal;\n\
                   vector L : light;\n\
                   C δπx ← T vec2(0.3, 0.6) * max(0, N δ s x · L δ s x);\n";
    std::fs::write(dir.path().join("t.shd"), program).unwrap();
    let mut pixels = Vec::new();
    for (backend, target, precision) in [
        ("cpu", "wgsl", "f32"),
        ("wgpu", "wgsl", "f32"),
        ("cpu", "geforce3", "fixed9"),
        ("wgpu", "geforce3", "fixed9"),
    ] {
        let args = [
            "render",
            "--shader",
            "t.shd",
            "--backend",
            backend,
            "--target",
            target,
            "--precision",
            precision,
            "--size",
            "32x32",
            "-o",
            "t.png",
        ];
        let run = crate::common::shadec_in(dir.path(), &args);
        assert_eq!(run.code, 0, "{backend} {target}: {}", run.stderr);
        pixels.push(image::open(dir.path().join("t.png")).unwrap().to_rgba8());
    }
    let lit = pixels[0].pixels().filter(|p| p.0[0] > 8).count();
    assert!(lit > 50, "{lit} lit pixels");
    for other in &pixels[1..] {
        let worst = pixels[0]
            .pixels()
            .zip(other.pixels())
            .flat_map(|(a, b)| (0..3).map(move |c| a.0[c].abs_diff(b.0[c])))
            .max()
            .unwrap();
        assert!(worst <= 4, "{worst}/255 apart");
    }
}

/// A signed 2-D texture read as a normal (`(Tn δu x).rgb` of a `signed8`
/// bump map, which holds two components) is one error per read whose help
/// says what the texture holds and how to rebuild a normal; the statement
/// that adds to `C` after the one that failed gets no warning that `C` is
/// never written (it was: a cascade of the first error).
#[test]
fn a_signed_bump_map_read_as_a_normal_is_explained_without_a_cascade() {
    let dir = tempfile::tempdir().unwrap();
    let program = "vector L : light in tangent;\n\
                   vector H : half in tangent;\n\
                   texture Tn : 2d signed8 mipmap trilinear repeat = bumps(8);\n\
                   texture Ncube : cube rgb8 bilinear clamp = normalize_cube(32);\n\
                   C δπx ← max(0, (Tn δu x).rgb · expand(Ncube δ L s x));\n\
                   C δπx ← (C δπx) ⊕[add] (max(0, (Tn δu x).rgb · expand(Ncube δ H s x))^8);\n";
    std::fs::write(dir.path().join("b.shd"), program).unwrap();
    let run = crate::common::shadec_in(dir.path(), &["check", "--format", "short", "b.shd"]);
    assert_eq!(run.code, 1, "{}", run.stdout);
    let lines: Vec<&str> =
        run.stderr.lines().chain(run.stdout.lines()).filter(|l| l.starts_with("b.shd:")).collect();
    assert_eq!(lines.len(), 2, "{lines:#?}");
    assert!(lines.iter().all(|l| l.contains("error[bad-swizzle]")), "{lines:#?}");
    let human = crate::common::shadec_in(dir.path(), &["check", "b.shd"]);
    assert!(human.stderr.contains("`Tn` is a signed 2-D texture"), "{}", human.stderr);
}

/// A per-vertex fall-back taken within its budget says why per fragment
/// was refused, as the refusal beyond the budget does: a scalar `uniform`
/// with no type is unbounded, so a product with it leaves the combiners'
/// ranges and geforce3 shaded the material per vertex, with a warning that
/// said only "the target cannot compute it per fragment". The help now
/// names the uniform and what to declare; declared so, it plans per
/// fragment.
#[test]
fn a_per_vertex_fall_back_within_its_budget_says_why_per_fragment_was_refused() {
    let source =
        std::fs::read_to_string(crate::three_way_heldout::data("heldout_twentieth").join("uniform_tint.shd"))
            .unwrap()
            .replace("../../../examples/", "examples/");
    let warnings = |source: &str| {
        let front = shadec::verdict::check(source, Some("geforce3")).unwrap();
        front.diagnostics.into_iter().filter(|d| d.code == "approximation").collect::<Vec<_>>()
    };
    let fell_back = warnings(&source);
    let per_vertex: Vec<_> = fell_back.iter().filter(|d| d.message.contains("(`per_vertex`)")).collect();
    let [d] = per_vertex.as_slice() else { panic!("{fell_back:#?}") };
    let help = d.help.as_deref().unwrap_or_default();
    assert!(help.contains("per fragment geforce3 refuses it ("), "{help}");
    assert!(help.contains("`uniform ks : c = …;`"), "{help}");
    let declared = warnings(&source.replace("uniform ks = 0.6;", "uniform ks : c = 0.6;"));
    assert!(declared.iter().all(|d| !d.message.contains("(`per_vertex`)")), "{declared:#?}");
}
