//! The WGSL backend on every example: the emitted WGSL is snapshotted
//! (insta; `INSTA_UPDATE=always cargo test --test wgsl_snapshots` re-blesses),
//! stable, and every compiled example also writes SPIR-V and GLSL.
#![cfg(feature = "wgsl")]

use shadec::backends::wgsl::{codegen, emit};
use shadec::numerics::Precision;

fn examples() -> Vec<(String, String)> {
    let dir = format!("{}/examples", env!("CARGO_MANIFEST_DIR"));
    let mut v: Vec<(String, String)> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            (p.extension()? == "shd").then(|| {
                (p.file_stem().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&p).unwrap())
            })
        })
        .collect();
    v.sort();
    v
}

fn compile(
    name: &str,
    src: &str,
    fidelity: Precision,
) -> Result<Vec<codegen::PassShader>, Vec<shadec::diag::Diagnostic>> {
    let profile = shadec::profile::Profile::resolve("wgsl").unwrap();
    let planned = shadec::driver::compile(src, &profile, &Default::default())
        .map(|c| c.planned)
        .unwrap_or_else(|d| panic!("{name} does not plan on wgsl: {d:#?}"));
    codegen::generate(&planned, Some(src), fidelity)
}

#[test]
fn every_example_compiles() {
    for (name, src) in examples() {
        let passes = compile(&name, &src, Precision::F32)
            .unwrap_or_else(|d| panic!("{name} does not compile: {d:#?}"));
        let doc = emit::wgsl(&name, &passes).unwrap();
        insta::assert_snapshot!(format!("wgsl_{name}"), doc);
        // Stable: the same input gives the same bytes.
        let again = emit::wgsl(&name, &compile(&name, &src, Precision::F32).unwrap()).unwrap();
        assert_eq!(doc, again, "{name}: output is not stable");
        // Each section parses back and validates.
        for (label, text) in emit::split_wgsl(&doc) {
            let m = naga::front::wgsl::parse_str(&text)
                .unwrap_or_else(|e| panic!("{name} {label}: {}", e.emit_to_string(&text)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::default(),
            )
            .validate(&m)
            .unwrap_or_else(|e| panic!("{name} {label}: {e:?}"));
        }
        for p in &passes {
            let words = emit::spirv(p).unwrap();
            assert!(words.len() > 5 && words[0] == 0x0723_0203, "{name}: SPIR-V");
            let (vs, fs) = emit::glsl_pass(p).unwrap();
            assert!(vs.contains("void main()") && fs.contains("void main()"), "{name}: GLSL");
            assert!(vs.starts_with("#version 330"), "{name}: {vs}");
        }
        // Hardware fidelity compiles and validates too.
        let hw =
            compile(&name, &src, Precision::Fixed9).unwrap_or_else(|d| panic!("{name} hardware: {d:#?}"));
        assert_eq!(hw.len(), passes.len());
    }
}

/// Fat texels (seeds/001 (5), (6), (14)-(16)): a bundle is written as one
/// colour attachment per member, and read from the layers of a 2-D array.
#[test]
fn fat_texels_are_array_layers_written_as_several_outputs() {
    let src =
        std::fs::read_to_string(format!("{}/examples/deferred_shading.shd", env!("CARGO_MANIFEST_DIR")))
            .unwrap();
    let passes = compile("deferred_shading", &src, Precision::F32).unwrap();
    assert_eq!(passes.len(), 2);
    // (5): N, L, V, H into the fat framebuffer T.
    assert_eq!(passes[0].outputs, 4);
    let doc = emit::wgsl("deferred_shading", &passes).unwrap();
    let (_, second) = emit::split_wgsl(&doc).into_iter().nth(1).unwrap();
    assert!(second.contains("texture_2d_array<f32>"), "{second}");
    // (6): N·L reads layers 0 and 1, N·H layers 0 and 3, at level 0.
    for layer in ["0i, 0.0", "1i, 0.0", "3i, 0.0"] {
        assert!(second.contains(layer), "layer {layer} not read: {second}");
    }
    assert!(!second.contains("2i, 0.0"), "V is not used by p: {second}");
    assert_eq!(passes[1].outputs, 1);

    // Solid mapping: T is fat (one member, P) in (15) and (16), a colour
    // in (2) — its first layer.
    let src = std::fs::read_to_string(format!("{}/examples/solid_mapping.shd", env!("CARGO_MANIFEST_DIR")))
        .unwrap();
    let profile = shadec::profile::Profile::resolve("wgsl").unwrap();
    let planned = shadec::driver::compile(&src, &profile, &Default::default()).map(|c| c.planned).unwrap();
    assert_eq!(codegen::fat_layers(&planned.module), vec![1]);
    let passes = codegen::generate(&planned, Some(&src), Precision::F32).unwrap();
    assert_eq!(passes.iter().map(|p| p.outputs).collect::<Vec<_>>(), vec![1, 1, 1]);
    let doc = emit::wgsl("solid_mapping", &passes).unwrap();
    let third = &emit::split_wgsl(&doc)[2].1;
    assert!(third.contains("textureSample(T, T_sampler, u_frag, 0i)"), "{third}");
}

/// Shadow mask (seeds/001 Section 3.5): `α C xs ← (z C xs) > …` reads the
/// target's own depth, which blending cannot: the shader reads a copy
/// taken before the pass, and `π⁻¹ xs` takes the pixel's depth from it.
#[test]
fn own_target_reads_bind_a_copy_taken_before_the_pass() {
    let src =
        std::fs::read_to_string(format!("{}/examples/shadow_mask.shd", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let passes = compile("shadow_mask", &src, Precision::F32).unwrap();
    let with_copies: Vec<_> = passes.iter().filter(|p| !p.target_copies.is_empty()).collect();
    assert_eq!(with_copies.len(), 1, "only statement 4 reads its own target");
    let p = with_copies[0];
    assert_eq!(
        p.target_copies,
        vec![codegen::TargetCopy { binding: 3, framebuffer: "C".into(), depth: true, stencil: false }]
    );
    assert!(p.source[0].starts_with("31:1:"), "{:?}", p.source);
    // Both projections of `πl π⁻¹ xs` are in the uniform block.
    assert_eq!(p.interface.projections.len(), 2);
    // `z C xs` and the depth of `π⁻¹ xs` share one load of the copy; the
    // next pass reads C′ at the pixel and builds no pixel position.
    let doc = emit::wgsl("shadow_mask", &passes).unwrap();
    let sections = emit::split_wgsl(&doc);
    assert_eq!(sections[3].1.matches("textureLoad(C_depth_before").count(), 1, "{}", sections[3].1);
    assert!(!sections[4].1.contains("pixel_position"), "{}", sections[4].1);
}

#[test]
fn hardware_fidelity_snapshot() {
    let src =
        std::fs::read_to_string(format!("{}/examples/kilgard_bump_mapping.shd", env!("CARGO_MANIFEST_DIR")))
            .unwrap();
    let passes = compile("kilgard_bump_mapping", &src, Precision::Fixed9).unwrap();
    insta::assert_snapshot!(
        "wgsl_hardware_kilgard_bump_mapping",
        emit::wgsl("kilgard_bump_mapping (hardware)", &passes).unwrap()
    );
}

#[test]
fn geforce256_plan_compiles_to_three_passes() {
    let src =
        std::fs::read_to_string(format!("{}/examples/kilgard_bump_mapping.shd", env!("CARGO_MANIFEST_DIR")))
            .unwrap();
    let profile = shadec::profile::Profile::resolve("geforce256").unwrap();
    let planned = shadec::driver::compile(&src, &profile, &Default::default()).map(|c| c.planned).unwrap();
    let passes = codegen::generate(&planned, Some(&src), Precision::Fixed9).unwrap();
    assert_eq!(passes.len(), 3);
    for p in &passes {
        assert!(p.label.starts_with(&format!("pass {} of 3", p.pass + 1)));
        assert_eq!(p.source.len(), 1, "one statement per pass: {:?}", p.source);
    }
}

/// Every example planned on every built-in profile compiles to valid
/// modules or to `wgsl-unsupported` diagnostics — never an internal error
/// or a panic — in both fidelities.
#[test]
fn every_profile_plan_compiles_without_internal_errors() {
    for (name, src) in examples() {
        for profile in ["geforce256", "geforce3", "multitexture", "wgsl"] {
            let p = shadec::profile::Profile::resolve(profile).unwrap();
            let Ok(planned) = shadec::driver::compile(&src, &p, &Default::default()).map(|c| c.planned)
            else {
                continue;
            };
            for fidelity in [Precision::F32, Precision::Fixed9] {
                if let Err(diags) = codegen::generate(&planned, Some(&src), fidelity) {
                    assert!(
                        diags.iter().all(|d| d.code == "wgsl-unsupported"),
                        "{name} on {profile}: {diags:#?}"
                    );
                }
            }
        }
    }
}
