//! The WGSL backend executed for real (wgpu; Mesa's lavapipe in CI):
//! - `shadec translate` output against the fixed9 emulator, bit for bit;
//! - a compiled plan (`fragment_lighting.shd`) with synthetic inputs against
//!   the shader's formula evaluated on the CPU in f64.
//!
//! With no adapter these fail with the fix, unless `SHADEC_ALLOW_NO_GPU=1`
//! (outside CI), as `tests/gpu_runner.rs` documents.
#![cfg(feature = "gpu")]

use crate::combiners_common;
use crate::common;

use shadec::backends::combiners::config::CombinerLimits;
use shadec::backends::combiners::emulator::{emulate, Inputs};
use shadec::backends::combiners::rc1;
use shadec::backends::wgsl::codegen::{self, uniform_bytes};
use shadec::gpu::runner::{
    run_passes, PassTarget, RunPass, RunShader, RunTexture, SamplerSettings, ShaderSource, Target,
    TexelUpload, TextureData, VertexData,
};
use shadec::ir::Expr;
use shadec::numerics::Precision;
use shadec::renderer::{BlendState, CullMode, DepthState, RenderState, StencilState};

use common::gpu::gpu;

/// A deterministic pseudo-random RGBA8 image.
fn noise(w: u32, h: u32, seed: u64) -> Vec<u8> {
    let mut s = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    (0..w * h * 4)
        .map(|_| {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 56) as u8
        })
        .collect()
}

const FULL: RenderState = RenderState {
    cull: CullMode::None,
    depth: DepthState::DISABLED,
    stencil: StencilState::DISABLED,
    blend: BlendState::REPLACE,
    alpha_test: shadec::pipeline::AlphaTest::DISABLED,
};

fn translated_matches_emulator(file: &str) {
    let path = format!("{}/tests/data/combiners/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    translated_text_matches_emulator(file, &text, &CombinerLimits::GEFORCE3);
}

fn translated_text_matches_emulator(file: &str, text: &str, limits: &CombinerLimits) {
    let Some(gpu) = gpu() else { return };
    let config = rc1::parse_and_validate(text, limits).unwrap();
    let wgsl = shadec::backends::wgsl::rc1::translate(&config, file).unwrap();
    let (w, h) = (64u32, 48u32);
    let images: Vec<Vec<u8>> = (0..6).map(|i| noise(w, h, 17 + i)).collect();
    let fog = [0.25, 0.5, 0.75, 0.3];
    let (c0, c1) = ([0.2, 0.4, 0.6, 0.8], [0.9, 0.1, 0.5, 0.33]);
    let inputs = Inputs {
        width: w as usize,
        height: h as usize,
        textures: [Some(&images[0]), Some(&images[1]), Some(&images[2]), Some(&images[3])],
        primary: Some(&images[4]),
        secondary: Some(&images[5]),
        fog,
        constant0: c0,
        constant1: c1,
    };
    let expected = emulate(&config, &inputs, Precision::Fixed9).unwrap();
    let mut uniforms = Vec::new();
    for c in [c0, c1, fog] {
        for v in c {
            uniforms.extend_from_slice(&f32::to_le_bytes(v));
        }
    }
    let floats = vec![-1.0, -1.0, 0.0, 1.0, 1.0, -1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0, -1.0, 1.0, 0.0, 1.0];
    let pass = RunPass {
        label: file.to_string(),
        shader: RunShader {
            source: ShaderSource::Wgsl(wgsl),
            vertex_entry: "vs_main".into(),
            fragment_entry: "fs_main".into(),
        },
        vertices: VertexData { floats, components: vec![4] },
        indices: vec![0, 1, 2, 0, 2, 3],
        textures: images
            .iter()
            .map(|rgba| RunTexture {
                data: TextureData::D2 { width: w, height: h, rgba: rgba.clone() },
                sampler: SamplerSettings::NEAREST_CLAMP,
                texels: TexelUpload::Rgba8,
            })
            .collect(),
        uniforms: Some(uniforms),
        state: FULL,
        target: PassTarget::Main,
        loaded: vec![],
        outputs: 1,
    };
    let image = run_passes(&gpu, &Target::new(w, h), &[pass]).unwrap();
    let got = image.into_raw();
    let diff = got.iter().zip(&expected).filter(|(a, b)| a != b).count();
    assert_eq!(diff, 0, "{file}: {diff} channels differ from the fixed9 emulator");
}

#[test]
fn translated_appendix_g_is_bit_exact() {
    translated_matches_emulator("appendix_g.rc");
}

#[test]
fn translated_appendix_h_is_bit_exact() {
    translated_matches_emulator("appendix_h.rc");
}

/// NV2A's alpha dot products (`--permissive`, issue 20) translate bit-exactly too.
#[test]
fn translated_permissive_alpha_dot_is_bit_exact() {
    let text = "!!RC1.0\n{ rgb { spare0 = expand(tex0) . expand(tex1); } alpha { spare1.a = tex2.b . expand(tex3.a); discard.a = tex0.a . col0.a; } }\nout.rgb = spare0;\nout.a = spare1.a;\n";
    translated_text_matches_emulator("alpha_dot", text, &CombinerLimits::GEFORCE3.permissive());
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / l, v[1] / l, v[2] / l]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// fragment_lighting.shd with N, L, V constant over a full-screen quad: every
/// pixel is kd·max(0, N·L) + ks·max(0, N·H)^32.
#[test]
fn compiled_fragment_lighting_matches_its_formula() {
    let Some(gpu) = gpu() else { return };
    let src =
        std::fs::read_to_string(format!("{}/examples/fragment_lighting.shd", env!("CARGO_MANIFEST_DIR")))
            .unwrap();
    let profile = shadec::profile::Profile::resolve("wgsl").unwrap();
    let planned = shadec::driver::compile(&src, &profile, &Default::default()).map(|c| c.planned).unwrap();
    let shaders = codegen::generate(&planned, Some(&src), Precision::F32).unwrap();
    assert_eq!(shaders.len(), 1);
    let s = &shaders[0];
    let (n, l, v) = ([0.2, 0.3, 1.0], [0.5, 0.6, 0.7], [-0.3, 0.2, 1.0]);
    let corners = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];
    let m = &planned.module;
    let mut floats = Vec::new();
    for c in corners {
        for leaf in &s.interface.vertex_leaves {
            let value: [f32; 4] = match &m.exprs[*leaf] {
                Expr::VertexPosition(_) => [c[0], c[1], 0.0, 1.0],
                Expr::Vector { vector, .. } => {
                    let d = match m.vectors[*vector as usize].name.as_str() {
                        "N" => n,
                        "L" => l,
                        "V" => v,
                        other => panic!("unexpected vector {other}"),
                    };
                    [d[0] as f32, d[1] as f32, d[2] as f32, 0.0]
                }
                e => panic!("unexpected leaf {e:?}"),
            };
            floats.extend_from_slice(&value);
        }
    }
    let identity: [f32; 16] =
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
    assert_eq!(s.interface.projections.len(), 1);
    let pass = RunPass {
        label: s.label.clone(),
        shader: RunShader {
            source: ShaderSource::Naga(s.module.clone()),
            vertex_entry: codegen::VERTEX_ENTRY.into(),
            fragment_entry: codegen::FRAGMENT_ENTRY.into(),
        },
        vertices: VertexData { floats, components: vec![4; s.interface.vertex_leaves.len()] },
        indices: vec![0, 1, 2, 0, 2, 3],
        textures: vec![],
        uniforms: Some(uniform_bytes(&[identity], &[])),
        state: planned.plan.passes[0].state,
        target: PassTarget::Main,
        loaded: vec![],
        outputs: 1,
    };
    let image = run_passes(&gpu, &Target::new(32, 32), &[pass]).unwrap();
    let (nn, ln, vn) = (normalize(n), normalize(l), normalize(v));
    let h = normalize([ln[0] + vn[0], ln[1] + vn[1], ln[2] + vn[2]]);
    let (kd, ks) = ([0.8, 0.6, 0.4], [1.0, 1.0, 1.0]);
    let diffuse = dot(nn, ln).max(0.0);
    let spec = dot(nn, h).max(0.0).powf(32.0);
    let expected: Vec<u8> = (0..3)
        .map(|i| ((kd[i] * diffuse + ks[i] * spec).clamp(0.0, 1.0) * 255.0).round() as u8)
        .chain([255])
        .collect();
    for px in image.pixels() {
        for c in 0..4 {
            assert!(
                (px.0[c] as i32 - expected[c] as i32).abs() <= 1,
                "pixel {:?} vs expected {expected:?}",
                px.0
            );
        }
    }
}

/// `translate` of a `!!TS1.0` + `!!RC1.0` pair against `shadec emulate`'s
/// texture-shader model, bit for bit: textures of other sizes than the
/// target, some units with coordinate images and some with the default
/// coordinates (issue 20).
fn translated_texture_shader_matches_emulator(text: &str, coords_given: [bool; 4], sizes: [(u32, u32); 4]) {
    use shadec::backends::combiners::ts1::emulate::{self as ts_emulate, Image, TextureInputs};
    let Some(gpu) = gpu() else { return };
    let config = rc1::parse_and_validate(text, &CombinerLimits::GEFORCE3).unwrap();
    let program = config.texture_shader.clone().unwrap();
    let wgsl = shadec::backends::wgsl::rc1::translate(&config, "pair").unwrap();
    let (w, h) = (40u32, 24u32);
    let textures: Vec<Vec<u8>> =
        sizes.iter().enumerate().map(|(i, &(tw, th))| noise(tw, th, 31 + i as u64)).collect();
    let coords: Vec<Vec<u8>> = (0..4).map(|i| noise(w, h, 41 + i)).collect();
    let colours: Vec<Vec<u8>> = (0..2).map(|i| noise(w, h, 51 + i)).collect();
    let (fog, c0, c1) = ([0.25, 0.5, 0.75, 0.3], [0.2, 0.4, 0.6, 0.8], [0.9, 0.1, 0.5, 0.33]);
    let texture_inputs = TextureInputs {
        width: w as usize,
        height: h as usize,
        textures: [0, 1, 2, 3]
            .map(|k| Some(Image { width: sizes[k].0, height: sizes[k].1, rgba: &textures[k] })),
        coords: [0, 1, 2, 3].map(|k| coords_given[k].then_some(coords[k].as_slice())),
    };
    let inputs = Inputs {
        width: w as usize,
        height: h as usize,
        primary: Some(&colours[0]),
        secondary: Some(&colours[1]),
        fog,
        constant0: c0,
        constant1: c1,
        ..Inputs::default()
    };
    let expected =
        ts_emulate::emulate(&config, &program, &inputs, &texture_inputs, Precision::Fixed9).unwrap();
    let distinct: std::collections::HashSet<&[u8]> = expected.chunks(4).collect();
    assert!(
        distinct.len() > 50,
        "{text}: the image varies ({} colours), so agreement means something",
        distinct.len()
    );
    let mut uniforms = Vec::new();
    for c in [c0, c1, fog] {
        for v in c {
            uniforms.extend_from_slice(&f32::to_le_bytes(v));
        }
    }
    let mask = coords_given.iter().enumerate().filter(|(_, g)| **g).map(|(k, _)| 1i32 << k).sum::<i32>();
    for v in [w as i32, h as i32, mask, 0] {
        uniforms.extend_from_slice(&i32::to_le_bytes(v));
    }
    let d2 = |width: u32, height: u32, rgba: Vec<u8>| RunTexture {
        data: TextureData::D2 { width, height, rgba },
        sampler: SamplerSettings::NEAREST_CLAMP,
        texels: TexelUpload::Rgba8,
    };
    let mut bound: Vec<RunTexture> =
        (0..4).map(|k| d2(sizes[k].0, sizes[k].1, textures[k].clone())).collect();
    bound.extend(colours.iter().map(|c| d2(w, h, c.clone())));
    for k in 0..4 {
        bound.push(if coords_given[k] { d2(w, h, coords[k].clone()) } else { d2(1, 1, vec![0; 4]) });
    }
    let floats = vec![-1.0, -1.0, 0.0, 1.0, 1.0, -1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0, -1.0, 1.0, 0.0, 1.0];
    let pass = RunPass {
        label: "texture shader".into(),
        shader: RunShader {
            source: ShaderSource::Wgsl(wgsl),
            vertex_entry: "vs_main".into(),
            fragment_entry: "fs_main".into(),
        },
        vertices: VertexData { floats, components: vec![4] },
        indices: vec![0, 1, 2, 0, 2, 3],
        textures: bound,
        uniforms: Some(uniforms),
        state: FULL,
        target: PassTarget::Main,
        loaded: vec![],
        outputs: 1,
    };
    let got = run_passes(&gpu, &Target::new(w, h), &[pass]).unwrap().into_raw();
    let diff = got.iter().zip(&expected).filter(|(a, b)| a != b).count();
    assert_eq!(diff, 0, "{text}: {diff} channels differ from the emulator");
}

#[test]
fn translated_texture_shaders_are_bit_exact() {
    let rc = "!!RC1.0\n{ rgb { spare0 = tex1 * col0; spare1 = tex3 * col1; } }\nout.rgb = lerp(tex0, tex2, spare0) + spare1;\nout.a = tex2.a;\n";
    let programs = [
        ("texture_1d();\noffset_2d(tex0, 0.5, -0.25, 0.125, 0.75);\noffset_2d_scale(tex1, -1.5, 0.3, 0.2, 1, 0.8, 0.1);\noffset_rectangle_scale(tex0, 3, 1, -2, 4, 1.5, -0.2);\n", [false, true, false, true]),
        ("texture_2d();\ndependent_ar(tex0);\ndependent_gb(tex0);\noffset_rectangle(tex1, 7, 0, 0, -5);\n", [true, false, true, false]),
        ("texture_rectangle();\ndot_product_2d_1of2(expand(tex0));\ndot_product_2d_2of2(expand(tex0));\npass_through();\n", [false, true, true, true]),
        ("pass_through();\ndot_product_rectangle_1of2(tex0);\ndot_product_rectangle_2of2(tex0);\ncull_fragment(GEQUAL_TO_ZERO, LESS_THAN_ZERO, GEQUAL_TO_ZERO, GEQUAL_TO_ZERO);\n", [true, true, false, true]),
        ("texture_2d();\ndot_product_depth_replace_1of2(expand(tex0));\ndot_product_depth_replace_2of2(tex0);\ntexture_2d();\n", [false, false, false, false]),
    ];
    let flat = [(17u32, 9u32), (32, 32), (5, 13), (64, 3)];
    for (ts, coords) in programs {
        translated_texture_shader_matches_emulator(&format!("!!TS1.0\n{ts}{rc}"), coords, flat);
    }
    // Cube maps (six faces stacked) and 3-D textures (square slices stacked).
    let volumes = [
        ("texture_3d();\ntexture_cube_map();\ndot_product_3d_1of3(expand(tex1));\npass_through();\n", [true, true, false, false], [(4, 20), (8, 48), (5, 13), (3, 3)]),
        ("texture_2d();\ndot_product_3d_1of3(expand(tex0));\ndot_product_3d_2of3(tex0);\ndot_product_3d_3of3(expand(tex0));\n", [false, true, true, true], [(17, 9), (3, 3), (3, 3), (8, 40)]),
        ("texture_2d();\ndot_product_cube_map_1of3(expand(tex0));\ndot_product_cube_map_2of3(expand(tex0));\ndot_product_cube_map_3of3(expand(tex0));\n", [false, true, true, true], [(17, 9), (3, 3), (3, 3), (16, 96)]),
        ("texture_2d();\ndot_product_reflect_cube_map_eye_from_qs_1of3(expand(tex0));\ndot_product_reflect_cube_map_eye_from_qs_2of3(expand(tex0));\ndot_product_reflect_cube_map_eye_from_qs_3of3(expand(tex0));\n", [false, true, true, true], [(17, 9), (3, 3), (3, 3), (16, 96)]),
        ("texture_2d();\ndot_product_reflect_cube_map_const_eye_1of3(expand(tex0), 0.3, -0.7, 1.5);\ndot_product_reflect_cube_map_const_eye_2of3(expand(tex0));\ndot_product_reflect_cube_map_const_eye_3of3(expand(tex0));\n", [false, false, true, true], [(17, 9), (3, 3), (3, 3), (16, 96)]),
        ("texture_2d();\ndot_product_cube_map_and_reflect_cube_map_eye_from_qs_1of3(expand(tex0));\ndot_product_cube_map_and_reflect_cube_map_eye_from_qs_2of3(expand(tex0));\ndot_product_cube_map_and_reflect_cube_map_eye_from_qs_3of3(expand(tex0));\n", [false, true, true, true], [(17, 9), (3, 3), (8, 48), (16, 96)]),
        ("texture_2d();\ndot_product_cube_map_and_reflect_cube_map_const_eye_1of3(tex0, -1, 0.5, 0.25);\ndot_product_cube_map_and_reflect_cube_map_const_eye_2of3(expand(tex0));\ndot_product_cube_map_and_reflect_cube_map_const_eye_3of3(expand(tex0));\n", [false, true, false, true], [(17, 9), (3, 3), (8, 48), (16, 96)]),
    ];
    for (ts, coords, sizes) in volumes {
        translated_texture_shader_matches_emulator(&format!("!!TS1.0\n{ts}{rc}"), coords, sizes);
    }
}

/// The NV2A vectors (`combiners_common::NV2A_COMBINER_OPS`, with their
/// provenance: nxdk_pgraph_tests CombinerOps, constant colour 0 = (25, 63,
/// 255)/255) through `translate` on the GPU, compared with the hardware's
/// numbers, not with the emulator. `translate` wraps
/// `rc1::combiners_function`, the same function WGSL `--fidelity hardware`
/// splices into every combiner pass (`wgsl::codegen::with_combiners`), so
/// this holds for both.
#[test]
fn translated_hardware_output_mappings_match_nv2a() {
    let Some(gpu) = gpu() else { return };
    for (mapping, hardware) in combiners_common::NV2A_COMBINER_OPS {
        let config = rc1::parse_and_validate(
            &combiners_common::nv2a_combiner_ops_program(mapping),
            &CombinerLimits::GEFORCE3,
        )
        .unwrap();
        let wgsl = shadec::backends::wgsl::rc1::translate(&config, mapping).unwrap();
        let (w, h) = (4u32, 4u32);
        let uniforms = vec![0u8; 48];
        let floats = vec![-1.0, -1.0, 0.0, 1.0, 1.0, -1.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0, -1.0, 1.0, 0.0, 1.0];
        let pass = RunPass {
            label: mapping.to_string(),
            shader: RunShader {
                source: ShaderSource::Wgsl(wgsl),
                vertex_entry: "vs_main".into(),
                fragment_entry: "fs_main".into(),
            },
            vertices: VertexData { floats, components: vec![4] },
            indices: vec![0, 1, 2, 0, 2, 3],
            textures: (0..6)
                .map(|_| RunTexture {
                    data: TextureData::D2 { width: w, height: h, rgba: vec![0; (w * h * 4) as usize] },
                    sampler: SamplerSettings::NEAREST_CLAMP,
                    texels: TexelUpload::Rgba8,
                })
                .collect(),
            uniforms: Some(uniforms),
            state: FULL,
            target: PassTarget::Main,
            loaded: vec![],
            outputs: 1,
        };
        let got = run_passes(&gpu, &Target::new(w, h), &[pass]).unwrap().into_raw();
        for px in got.chunks(4) {
            assert_eq!(px[..3], hardware, "{mapping}");
        }
    }
}
