//! The WGSL backend on every example: the emitted WGSL is snapshotted
//! (insta; `INSTA_UPDATE=always cargo test --test wgsl_snapshots` re-blesses),
//! stable, and every compiled example also writes SPIR-V and GLSL.
#![cfg(feature = "wgsl")]

use shadec::backends::wgsl::{codegen, emit, Fidelity};

/// Examples the backend cannot compile yet, with the diagnostic code and
/// the reason (see the report in ARCHITECTURE.md).
const UNSUPPORTED: &[(&str, &str)] = &[
    // Fat texels: no texture layout for a shading-parameter vector is defined.
    ("deferred_shading", "wgsl-unsupported"),
    ("fat_texture_map", "wgsl-unsupported"),
    ("solid_mapping", "wgsl-unsupported"),
    // Reads the target framebuffer's depth inside a screen pass.
    ("shadow_mask", "wgsl-unsupported"),
    // Per-texel shading vectors (`s δu`) have no binding in PassInterface.
    ("texture_shading", "wgsl-unsupported"),
];

fn examples() -> Vec<(String, String)> {
    let dir = format!("{}/examples", env!("CARGO_MANIFEST_DIR"));
    let mut v: Vec<(String, String)> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            (p.extension()? == "shd").then(|| (p.file_stem().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&p).unwrap()))
        })
        .collect();
    v.sort();
    v
}

fn compile(name: &str, src: &str, fidelity: Fidelity) -> Result<Vec<codegen::PassShader>, Vec<shadec::diag::Diagnostic>> {
    let profile = shadec::profile::Profile::resolve("wgsl").unwrap();
    let planned = shadec::planner::compile_source(src, &profile).unwrap_or_else(|d| panic!("{name} does not plan on wgsl: {d:#?}"));
    codegen::generate(&planned, Some(src), fidelity)
}

#[test]
fn every_example_compiles_or_is_known_unsupported() {
    for (name, src) in examples() {
        let known = UNSUPPORTED.iter().find(|(n, _)| *n == name);
        match (compile(&name, &src, Fidelity::Exact), known) {
            (Ok(passes), None) => {
                let doc = emit::wgsl(&name, &passes).unwrap();
                insta::assert_snapshot!(format!("wgsl_{name}"), doc);
                // Stable: the same input gives the same bytes.
                let again = emit::wgsl(&name, &compile(&name, &src, Fidelity::Exact).unwrap()).unwrap();
                assert_eq!(doc, again, "{name}: output is not stable");
                // Each section parses back and validates.
                for (label, text) in emit::split_wgsl(&doc) {
                    let m = naga::front::wgsl::parse_str(&text).unwrap_or_else(|e| panic!("{name} {label}: {}", e.emit_to_string(&text)));
                    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
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
                let hw = compile(&name, &src, Fidelity::Hardware).unwrap_or_else(|d| panic!("{name} hardware: {d:#?}"));
                assert_eq!(hw.len(), passes.len());
            }
            (Err(diags), Some((_, code))) => {
                assert!(diags.iter().all(|d| d.code == *code), "{name}: {diags:#?}");
            }
            (Ok(_), Some(_)) => panic!("{name} compiles now: remove it from UNSUPPORTED"),
            (Err(diags), None) => panic!("{name} does not compile: {diags:#?}"),
        }
    }
}

#[test]
fn hardware_fidelity_snapshot() {
    let src = std::fs::read_to_string(format!("{}/examples/kilgard_bump_mapping.shd", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let passes = compile("kilgard_bump_mapping", &src, Fidelity::Hardware).unwrap();
    insta::assert_snapshot!("wgsl_hardware_kilgard_bump_mapping", emit::wgsl("kilgard_bump_mapping (hardware)", &passes).unwrap());
}

#[test]
fn geforce256_plan_compiles_to_three_passes() {
    let src = std::fs::read_to_string(format!("{}/examples/kilgard_bump_mapping.shd", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let profile = shadec::profile::Profile::resolve("geforce256").unwrap();
    let planned = shadec::planner::compile_source(&src, &profile).unwrap();
    let passes = codegen::generate(&planned, Some(&src), Fidelity::Hardware).unwrap();
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
            let Ok(planned) = shadec::planner::compile_source(&src, &p) else { continue };
            for fidelity in [Fidelity::Exact, Fidelity::Hardware] {
                if let Err(diags) = codegen::generate(&planned, Some(&src), fidelity) {
                    assert!(diags.iter().all(|d| d.code == "wgsl-unsupported"), "{name} on {profile}: {diags:#?}");
                }
            }
        }
    }
}
