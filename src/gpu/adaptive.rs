//! Adaptive sample shading on wgpu (Adaptive Sample Shading, Section 2.1),
//! built the way a GPU rewards it: the work skipped is rejected by the
//! depth test before the fragment stage runs, not branched around inside it.
//! WebGPU has no variable-rate shading, so a frame is drawn as
//!
//! 1. the **sparse frame**: the plan's passes into the picture, unchanged,
//!    into a texture of one sample every `spacing` pixels each way (the same
//!    camera, so the same surface at a coarser grid), with its own depth
//!    buffer, which tells a covered sample from the cleared background;
//! 2. the **classification**: one full-screen triangle whose fragment stage
//!    loads the four sparse samples around its pixel. Where all four are
//!    covered and no channel differs among them by more than the threshold,
//!    it writes their bilinear interpolation and depth 0; elsewhere
//!    (silhouettes, highlights, the grid's border with the background) the
//!    clear colour and the clear depth 1;
//! 3. the plan's passes into the picture, unchanged, at full size. Their
//!    depth test (`Less`, `LessEqual` or `Equal`) fails wherever the
//!    classification wrote depth 0, so those pixels are never shaded: early
//!    depth rejection skips the fragment stage, and the interpolated colour
//!    stays. Elsewhere the plan runs exactly as it would without adaptive
//!    shading.
//!
//! Passes into textures run first and once, as in the plan. A plan is left
//! to full shading (with the reason as a note) when a pass into the
//! picture does not depth-test with one of those functions, uses the
//! stencil, reads the picture's depth, or is followed by a pass into a
//! texture. Like the paper's sparse sampling, a hole in a surface narrower
//! than the grid can be interpolated over.

use super::runner::{
    LoadedTexture, PassTarget, RenderedTexture, RunPass, RunShader, ShaderSource, Target, TextureData,
    VertexData,
};
use crate::pipeline::state::{BlendState, CompareFunc, CullMode, DepthState, RenderState, StencilState};

/// The sparse grid and the interpolation threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuAdaptive {
    /// Pixels between sparse samples, each way.
    pub spacing: u32,
    /// Largest per-channel difference among four samples that is
    /// interpolated.
    pub threshold: f32,
}

/// The name of the sparse frame's texture.
const SPARSE: &str = "adaptive_sparse";

/// `passes` drawn adaptively: the sparse frame, the classification and
/// the plan's passes; or `passes` unchanged and a note saying why.
pub fn adaptive_passes(
    passes: &[RunPass],
    target: &Target,
    settings: GpuAdaptive,
) -> (Vec<RunPass>, Vec<String>) {
    match eligible(passes) {
        Ok(first_main) => (adaptive_frame(passes, first_main, target, settings), Vec::new()),
        Err(why) => (passes.to_vec(), vec![format!("the frame is shaded in full on wgpu: {why}")]),
    }
}

/// The index of the first pass into the picture, when every pass from it
/// on can be masked by the depth the classification writes.
fn eligible(passes: &[RunPass]) -> Result<usize, String> {
    let first =
        passes.iter().position(|p| p.target == PassTarget::Main).ok_or("no pass draws into the picture")?;
    for (i, pass) in passes.iter().enumerate().skip(first) {
        let n = i + 1;
        if pass.target != PassTarget::Main {
            return Err(format!("pass {n} draws into a texture after a pass into the picture"));
        }
        if !matches!(pass.state.depth.func, CompareFunc::Less | CompareFunc::LessEqual | CompareFunc::Equal) {
            return Err(format!(
                "pass {n} does not test depth with less, less-equal or equal, so the depth mask cannot skip it"
            ));
        }
        if pass.state.stencil.enabled {
            return Err(format!("pass {n} uses the stencil buffer"));
        }
        if pass.loaded.iter().any(|l| l.data == TextureData::RenderedDepth { name: None }) {
            return Err(format!("pass {n} reads the picture's depth"));
        }
    }
    Ok(first)
}

fn adaptive_frame(
    passes: &[RunPass],
    first_main: usize,
    target: &Target,
    settings: GpuAdaptive,
) -> Vec<RunPass> {
    let spacing = settings.spacing.max(1);
    let sparse = RenderedTexture {
        name: SPARSE.into(),
        width: target.width.div_ceil(spacing),
        height: target.height.div_ceil(spacing),
        layers: 1,
        format: target.color_format,
        mip_levels: 1,
        cube: false,
    };
    let scale = (sparse.width as f32 / target.width as f32, sparse.height as f32 / target.height as f32);
    let main = &passes[first_main..];
    let mut out = Vec::with_capacity(passes.len() + main.len() + 1);
    out.extend_from_slice(&passes[..first_main]);
    out.extend(main.iter().map(|p| RunPass {
        label: format!("{} (sparse samples)", p.label),
        target: PassTarget::Texture(sparse.clone()),
        ..p.clone()
    }));
    out.push(classification(target, scale, settings.threshold));
    out.extend_from_slice(main);
    out
}

/// The full-screen pass that interpolates the sparse frame where it is
/// smooth (depth 0: the plan's passes are rejected there) and leaves the
/// rest to them (the clear colour and depth).
fn classification(target: &Target, scale: (f32, f32), threshold: f32) -> RunPass {
    RunPass {
        label: "adaptive classification".into(),
        shader: RunShader {
            source: ShaderSource::Wgsl(classification_wgsl(scale, threshold, target.clear_color)),
            vertex_entry: "vs_main".into(),
            fragment_entry: "fs_classify".into(),
        },
        vertices: VertexData {
            floats: vec![-1.0, -1.0, 0.0, 1.0, 3.0, -1.0, 0.0, 1.0, -1.0, 3.0, 0.0, 1.0],
            components: vec![4],
        },
        indices: vec![0, 1, 2],
        textures: Vec::new(),
        uniforms: None,
        state: RenderState {
            cull: CullMode::None,
            depth: DepthState { func: CompareFunc::Always, write: true },
            stencil: StencilState::DISABLED,
            blend: BlendState::REPLACE,
            alpha_test: crate::pipeline::AlphaTest::DISABLED,
        },
        target: PassTarget::Main,
        loaded: vec![
            LoadedTexture { binding: 0, data: TextureData::Rendered { name: SPARSE.into(), array: false } },
            LoadedTexture { binding: 1, data: TextureData::RenderedDepth { name: Some(SPARSE.into()) } },
        ],
        outputs: 1,
    }
}

fn classification_wgsl(scale: (f32, f32), threshold: f32, clear: [f32; 4]) -> String {
    let [r, g, b, a] = clear;
    format!(
        r#"struct Position {{
    @builtin(position) position: vec4<f32>,
}}

struct Classified {{
    @location(0) colour: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}}

@group(0) @binding(0) var sparse_colour: texture_2d<f32>;
@group(0) @binding(1) var sparse_depth: texture_2d<f32>;

@vertex
fn vs_main(@location(0) corner: vec4<f32>) -> Position {{
    return Position(corner);
}}

@fragment
fn fs_classify(input: Position) -> Classified {{
    let last = vec2<i32>(textureDimensions(sparse_colour)) - vec2<i32>(1);
    let q = input.position.xy * vec2<f32>({sx:?}, {sy:?}) - vec2<f32>(0.5);
    let base = floor(q);
    let f = q - base;
    let i0 = clamp(vec2<i32>(base), vec2<i32>(0), last);
    let i1 = clamp(vec2<i32>(base) + vec2<i32>(1), vec2<i32>(0), last);
    let j = vec2<i32>(i1.x, i0.y);
    let k = vec2<i32>(i0.x, i1.y);
    let far = max(max(textureLoad(sparse_depth, i0, 0).x, textureLoad(sparse_depth, j, 0).x),
                  max(textureLoad(sparse_depth, k, 0).x, textureLoad(sparse_depth, i1, 0).x));
    let a = textureLoad(sparse_colour, i0, 0);
    let b = textureLoad(sparse_colour, j, 0);
    let c = textureLoad(sparse_colour, k, 0);
    let d = textureLoad(sparse_colour, i1, 0);
    let spread = max(max(a, b), max(c, d)) - min(min(a, b), min(c, d));
    if far < 1.0 && all(spread <= vec4<f32>({threshold:?})) {{
        return Classified(mix(mix(a, b, f.x), mix(c, d, f.x), f.y), 0.0);
    }}
    return Classified(vec4<f32>({r:?}, {g:?}, {b:?}, {a:?}), 1.0);
}}
"#,
        sx = scale.0,
        sy = scale.1,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::runner::ColorTarget;

    fn pass(target: PassTarget, depth: CompareFunc) -> RunPass {
        let mut p = classification(&Target::new(8, 8), (0.5, 0.5), 0.1);
        p.target = target;
        p.state.depth.func = depth;
        p.loaded.clear();
        p
    }

    #[test]
    fn the_classification_validates() {
        let text = classification_wgsl((0.0625, 0.0625), 0.085, [0.0; 4]);
        let module = naga::front::wgsl::parse_str(&text)
            .unwrap_or_else(|e| panic!("{}\n{text}", e.emit_to_string(&text)));
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), Default::default())
            .validate(&module)
            .unwrap();
    }

    #[test]
    fn the_frame_is_sparse_passes_the_classification_and_the_plan() {
        let texture = RenderedTexture {
            name: "T".into(),
            width: 4,
            height: 4,
            layers: 1,
            format: ColorTarget::Rgba8,
            mip_levels: 1,
            cube: false,
        };
        let passes = [
            pass(PassTarget::Texture(texture), CompareFunc::Less),
            pass(PassTarget::Main, CompareFunc::Less),
            pass(PassTarget::Main, CompareFunc::Equal),
        ];
        let settings = GpuAdaptive { spacing: 4, threshold: 0.1 };
        let (out, notes) = adaptive_passes(&passes, &Target::new(64, 32), settings);
        assert!(notes.is_empty(), "{notes:?}");
        let labels: Vec<&str> = out.iter().map(|p| p.label.as_str()).collect();
        assert_eq!(out.len(), 6, "{labels:?}");
        let PassTarget::Texture(sparse) = &out[1].target else { panic!("{labels:?}") };
        assert_eq!((sparse.width, sparse.height), (16, 8));
        assert_eq!(out[3].label, "adaptive classification");
        assert_eq!(out[4].target, PassTarget::Main);
    }

    #[test]
    fn a_pass_the_depth_mask_cannot_skip_leaves_the_frame_full() {
        let passes = [pass(PassTarget::Main, CompareFunc::Less), pass(PassTarget::Main, CompareFunc::Always)];
        let settings = GpuAdaptive { spacing: 4, threshold: 0.1 };
        let (out, notes) = adaptive_passes(&passes, &Target::new(64, 32), settings);
        assert_eq!(out.len(), 2);
        assert!(notes[0].contains("pass 2 does not test depth"), "{notes:?}");
        let mut stencil = pass(PassTarget::Main, CompareFunc::Less);
        stencil.state.stencil.enabled = true;
        let (_, notes) = adaptive_passes(&[stencil], &Target::new(64, 32), settings);
        assert!(notes[0].contains("pass 1 uses the stencil buffer"), "{notes:?}");
    }
}
