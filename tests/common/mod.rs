//! Helpers shared by the integration tests: run the `shadec` binary; drive
//! the rasterizer with explicit clip-space vertices; the shadow-mask scene.

#![allow(dead_code)]

#[cfg(feature = "gpu")]
pub mod gpu;

use std::path::Path;
use std::process::Command;

pub struct Run {
    pub code: i32,
    pub stdout: String,
    pub stderr: String,
}

pub fn shadec(args: &[&str]) -> Run {
    shadec_in(Path::new(env!("CARGO_MANIFEST_DIR")), args)
}

pub fn shadec_in(dir: &Path, args: &[&str]) -> Run {
    let out = Command::new(env!("CARGO_BIN_EXE_shadec"))
        .args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .output()
        .expect("the shadec binary runs");
    Run {
        code: out.status.code().expect("shadec exits normally, not by a signal"),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

/// Every `.shd` file under `examples/`, sorted.
pub fn examples() -> Vec<std::path::PathBuf> {
    shd_files("examples")
}

/// Every `.shd` file in a folder of the repository, sorted.
pub fn shd_files(dir: &str) -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "shd"))
        .collect();
    v.sort();
    v
}

// ---------------------------------------------------------------- rasterizer helpers
// A vertex stage over explicit clip positions and varyings, and small fragment stages.

use shadec::renderer::{
    draw, ColorFormat, CullMode, DepthState, DrawStats, Fragment, FragmentResult, FragmentStage, Framebuffer,
    Pass, RenderState, VertexStage,
};

/// Vertices given directly in clip space, each with `n` varyings.
pub struct ClipVertices {
    pub clip: Vec<[f32; 4]>,
    pub varyings: Vec<f32>,
    pub n: usize,
}

impl ClipVertices {
    /// Vertices at pixel positions (w = 1, z = 0) on a `width`×`height` target.
    pub fn from_pixels(points: &[[f32; 2]], width: u32, height: u32) -> ClipVertices {
        let clip = points.iter().map(|p| pixel_to_clip(*p, width, height, 0.0, 1.0)).collect();
        ClipVertices { clip, varyings: Vec::new(), n: 0 }
    }
}

/// Pixel coordinates (x right, y down; pixel centres at +0.5) to clip space.
pub fn pixel_to_clip(p: [f32; 2], width: u32, height: u32, z: f32, w: f32) -> [f32; 4] {
    let x = 2.0 * p[0] / width as f32 - 1.0;
    let y = 1.0 - 2.0 * p[1] / height as f32;
    [x * w, y * w, z * w, w]
}

impl VertexStage for ClipVertices {
    fn n_vertices(&self) -> usize {
        self.clip.len()
    }
    fn n_varyings(&self) -> usize {
        self.n
    }
    fn shade_vertex(&self, index: u32, varyings: &mut [f32]) -> [f32; 4] {
        let i = index as usize;
        varyings.copy_from_slice(&self.varyings[i * self.n..(i + 1) * self.n]);
        self.clip[i]
    }
}

/// Writes a constant colour.
pub struct Constant(pub [f32; 4]);

impl FragmentStage for Constant {
    fn shade(&self, _: &Fragment, _: &[f32], out: &mut [f32; 4]) -> FragmentResult {
        *out = self.0;
        FragmentResult::Keep
    }
}

/// Writes the first four varyings (missing ones are 0).
pub struct VaryingsAsColor;

impl FragmentStage for VaryingsAsColor {
    fn shade(&self, _: &Fragment, varyings: &[f32], out: &mut [f32; 4]) -> FragmentResult {
        *out = [0.0; 4];
        for (o, v) in out.iter_mut().zip(varyings) {
            *o = *v;
        }
        FragmentResult::Keep
    }
}

/// State that counts hits: additive blending, no depth, no culling.
pub fn counting_state() -> RenderState {
    RenderState {
        cull: CullMode::None,
        depth: DepthState::DISABLED,
        blend: shadec::renderer::BlendState::ADD,
        ..RenderState::default()
    }
}

/// Draws `triangles` with a +1 additive count per fragment; returns the count image.
pub fn hit_counts(
    vertices: &ClipVertices,
    triangles: &[[u32; 3]],
    width: u32,
    height: u32,
) -> (Vec<f32>, DrawStats) {
    let mut fb = Framebuffer::new(width, height, ColorFormat::F32).unwrap();
    let stats = draw(
        &mut fb,
        &Pass {
            triangles,
            vertex: vertices,
            fragment: &Constant([1.0, 0.0, 0.0, 0.0]),
            state: counting_state(),
        },
    )
    .unwrap();
    (fb.to_rgba_f32().iter().map(|c| c[0]).collect(), stats)
}

/// `tests/data/shadow_floor.ron`: a ball over a floor, one light.
pub fn shadow_floor_scene() -> shadec::scene::Scene {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/shadow_floor.ron")).unwrap();
    shadec::scene::Scene::parse(&text, Path::new("/nonexistent-shadec-scene/shadow_floor.ron")).unwrap()
}

/// `examples/shadow_mask.shd` as printed, and with Williams's test written
/// out (GAPS.md 15): an ambient first image, and the reprojected point's
/// depth from the light against the light's depth buffer, with a bias.
pub fn shadow_mask_and_williams() -> (String, String) {
    let lit =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/shadow_mask.shd")).unwrap();
    let williams = lit.replace("C δπx ← δ p s x;", "C δπx ← ka;").replace(
        "α C xs ← (z C xs) > (z Cl πl π⁻¹ xs);",
        "α C xs ← (z πl π⁻¹ xs) > (z Cl πl π⁻¹ xs) + 0.002;",
    );
    assert_ne!(williams, lit, "the example's statements changed");
    (lit, williams)
}
