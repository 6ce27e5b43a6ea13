//! The WGSL backend executed for real (wgpu; Mesa's lavapipe in CI):
//! - `shadec translate` output against the fixed9 emulator, bit for bit;
//! - a compiled plan (`fragment_lighting.shd`) with synthetic inputs against
//!   the shader's formula evaluated on the CPU in f64.
//!
//! With no adapter these fail with the fix, unless `SHADEC_ALLOW_NO_GPU=1`
//! (outside CI), as `tests/gpu_runner.rs` documents.
#![cfg(feature = "gpu")]

mod common;

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
};

fn translated_matches_emulator(file: &str) {
    let Some(gpu) = gpu() else { return };
    let path = format!("{}/tests/data/combiners/{file}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap();
    let config = rc1::parse_and_validate(&text, &CombinerLimits::GEFORCE3).unwrap();
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
