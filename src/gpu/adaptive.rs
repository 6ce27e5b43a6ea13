//! Adaptive sample shading on wgpu (Adaptive Sample Shading, Section 2.1).
//! WebGPU has no variable-rate shading, so each pass into the picture is
//! drawn twice:
//!
//! 1. a **sparse pass**: the pass's own fragment stage at one sample every
//!    `spacing` pixels each way, into a float texture whose alpha is the
//!    pass's alpha + 2 (so that a covered sample tells itself from the
//!    cleared, uncovered ones);
//! 2. the **full pass**, whose fragment stage first loads the four sparse
//!    samples around its pixel: where all four are covered and no channel
//!    differs among them by more than the threshold, it returns their
//!    bilinear interpolation and skips the pass's shading; elsewhere
//!    (silhouettes, highlights, edges of the sparse grid's coverage) it
//!    shades the pixel exactly. Blending, depth and stencil are the pass's.
//!
//! The skipped work is the plan's own shading, in the same shader: the
//! pass's fragment function is kept as `shade` and called by both entry
//! points. A pass whose shading needs implicit derivatives (`textureSample`,
//! `dpdx`, …) is left to full shading, because WGSL allows those only in
//! uniform control flow; so is a pass that writes several outputs (a fat
//! texel) or a texture.

use super::runner::{
    ColorTarget, LoadedTexture, PassTarget, RenderedTexture, RunPass, RunShader, ShaderSource, Target,
    TextureData,
};
use crate::pipeline::state::{BlendState, CompareFunc, RenderState};

/// The sparse grid and the interpolation threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GpuAdaptive {
    /// Pixels between sparse samples, each way.
    pub spacing: u32,
    /// Largest per-channel difference among four samples that is
    /// interpolated.
    pub threshold: f32,
}

/// `passes` with every pass into the picture that can be shaded adaptively
/// preceded by its sparse pass; and a note for each pass left full.
pub fn adaptive_passes(
    passes: &[RunPass],
    target: &Target,
    settings: GpuAdaptive,
) -> (Vec<RunPass>, Vec<String>) {
    let mut out = Vec::with_capacity(2 * passes.len());
    let mut notes = Vec::new();
    for (i, pass) in passes.iter().enumerate() {
        match split(pass, i, target, settings) {
            Ok((sparse, full)) => {
                out.push(sparse);
                out.push(full);
            }
            Err(why) => {
                notes.push(format!("pass {} is shaded in full on wgpu: {why}", i + 1));
                out.push(pass.clone());
            }
        }
    }
    (out, notes)
}

/// The sparse pass and the full pass that interpolates it.
fn split(
    pass: &RunPass,
    index: usize,
    target: &Target,
    settings: GpuAdaptive,
) -> Result<(RunPass, RunPass), String> {
    if pass.target != PassTarget::Main || pass.outputs != 1 {
        return Err("it does not draw one colour into the picture".into());
    }
    let text = wgsl_text(&pass.shader)?;
    if ["textureSample(", "textureSampleBias(", "dpdx", "dpdy", "fwidth"].iter().any(|f| text.contains(f)) {
        return Err(
            "its shading uses implicit derivatives, which WGSL allows only in uniform control flow".into()
        );
    }
    let spacing = settings.spacing.max(1);
    let (w, h) = (target.width.div_ceil(spacing), target.height.div_ceil(spacing));
    let scale = (w as f32 / target.width as f32, h as f32 / target.height as f32);
    let binding = next_binding(&text).max(pass.loaded.iter().map(|l| l.binding + 1).max().unwrap_or(0));
    let source = wrapped(&text, &pass.shader.fragment_entry, binding, scale, settings.threshold)?;
    let name = format!("adaptive_sparse{index}");
    let sparse = RunPass {
        label: format!("{} (sparse samples)", pass.label),
        shader: RunShader {
            source: ShaderSource::Wgsl(source.clone()),
            fragment_entry: "fs_sparse".into(),
            ..pass.shader.clone()
        },
        state: sparse_state(pass.state),
        target: PassTarget::Texture(RenderedTexture {
            name: name.clone(),
            width: w,
            height: h,
            layers: 1,
            format: ColorTarget::Rgba16Float,
        }),
        ..pass.clone()
    };
    let mut full = RunPass {
        label: format!("{} (adaptive)", pass.label),
        shader: RunShader {
            source: ShaderSource::Wgsl(source),
            fragment_entry: "fs_adaptive".into(),
            ..pass.shader.clone()
        },
        ..pass.clone()
    };
    full.loaded.push(LoadedTexture { binding, data: TextureData::Rendered { name, array: false } });
    Ok((sparse, full))
}

/// The sparse pass finds its own visible surface (its texture has its own
/// depth buffer) and stores what the pass computes, unblended.
fn sparse_state(mut state: RenderState) -> RenderState {
    state.depth.func = CompareFunc::Less;
    state.depth.write = true;
    state.stencil.enabled = false;
    state.blend = BlendState::REPLACE;
    state
}

/// The pass's WGSL (a naga module written out).
fn wgsl_text(shader: &RunShader) -> Result<String, String> {
    match &shader.source {
        ShaderSource::Wgsl(text) => Ok(text.clone()),
        ShaderSource::Naga(module) => {
            let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), Default::default())
                .validate(module)
                .map_err(|e| format!("its module does not validate: {e}"))?;
            naga::back::wgsl::write_string(module, &info, naga::back::wgsl::WriterFlags::empty())
                .map_err(|e| format!("its module cannot be written as WGSL: {e}"))
        }
    }
}

/// One past the largest `@binding(n)` of group 0 in `text`.
fn next_binding(text: &str) -> u32 {
    text.match_indices("@binding(")
        .filter_map(|(i, m)| text[i + m.len()..].split(')').next()?.trim().parse::<u32>().ok())
        .max()
        .map_or(0, |b| b + 1)
}

/// `text` with the fragment entry `entry(NAME: VertexOutput) -> @location(0)
/// vec4<f32>` turned into `fn shade` and the two entry points added.
fn wrapped(
    text: &str,
    entry: &str,
    binding: u32,
    scale: (f32, f32),
    threshold: f32,
) -> Result<String, String> {
    let head = format!("fn {entry}(");
    let at = text.find(&head).ok_or("its fragment entry point was not found")?;
    let open = at + head.len();
    let close = open + text[open..].find(')').ok_or("its fragment entry point has no parameter list")?;
    let (param, ty) = text[open..close].split_once(':').ok_or("its fragment entry point takes no input")?;
    let (param, ty) = (param.trim(), ty.trim());
    let body = close + text[close..].find('{').ok_or("its fragment entry point has no body")?;
    if !text[close..body].contains("-> @location(0) vec4<f32>") {
        return Err("its fragment entry point does not return one vec4 colour".into());
    }
    let position = position_member(text, ty).ok_or("its fragment input has no @builtin(position)")?;
    let attribute = text[..at].rfind("@fragment").ok_or("its fragment entry point has no @fragment")?;
    let mut out = String::with_capacity(text.len() + 2048);
    out.push_str(&text[..attribute]);
    out.push_str(&text[attribute + "@fragment".len()..at]);
    out.push_str(&format!("fn shade({param}: {ty}) -> vec4<f32> "));
    out.push_str(&text[body..]);
    out.push_str(&entry_points(ty, &position, binding, scale, threshold));
    Ok(out)
}

/// The member of struct `ty` that is `@builtin(position)`.
fn position_member(text: &str, ty: &str) -> Option<String> {
    let start = text.find(&format!("struct {ty} {{"))?;
    let end = start + text[start..].find('}')?;
    let member = text[start..end].split("@builtin(position)").nth(1)?;
    Some(member.split(':').next()?.trim().to_string())
}

fn entry_points(ty: &str, position: &str, binding: u32, scale: (f32, f32), threshold: f32) -> String {
    format!(
        r#"
@group(0) @binding({binding}) var adaptive_sparse: texture_2d<f32>;

@fragment
fn fs_sparse(input: {ty}) -> @location(0) vec4<f32> {{
    let c = shade(input);
    return vec4<f32>(c.rgb, c.a + 2.0);
}}

@fragment
fn fs_adaptive(input: {ty}) -> @location(0) vec4<f32> {{
    let last = vec2<i32>(textureDimensions(adaptive_sparse)) - vec2<i32>(1);
    let q = input.{position}.xy * vec2<f32>({sx:?}, {sy:?}) - vec2<f32>(0.5);
    let base = floor(q);
    let f = q - base;
    let i0 = clamp(vec2<i32>(base), vec2<i32>(0), last);
    let i1 = clamp(vec2<i32>(base) + vec2<i32>(1), vec2<i32>(0), last);
    let a = textureLoad(adaptive_sparse, i0, 0);
    let b = textureLoad(adaptive_sparse, vec2<i32>(i1.x, i0.y), 0);
    let c = textureLoad(adaptive_sparse, vec2<i32>(i0.x, i1.y), 0);
    let d = textureLoad(adaptive_sparse, i1, 0);
    let lo = min(min(a, b), min(c, d));
    let hi = max(max(a, b), max(c, d));
    if lo.a >= 1.5 && all(hi - lo <= vec4<f32>({threshold:?})) {{
        let v = mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
        return vec4<f32>(v.rgb, v.a - 2.0);
    }}
    return shade(input);
}}
"#,
        sx = scale.0,
        sy = scale.1,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHADER: &str = "struct VertexOutput {\n    @builtin(position) position: vec4<f32>,\n    @location(0) n: vec4<f32>,\n}\n@group(0) @binding(0) var<uniform> u: vec4<f32>;\n@vertex \nfn vs_main(@location(0) x: vec4<f32>) -> VertexOutput {\n    return VertexOutput(x, x);\n}\n@fragment \nfn fs_main(input: VertexOutput) -> @location(0) vec4<f32> {\n    return input.n * u;\n}\n";

    #[test]
    fn the_wrapped_shader_validates_with_both_entry_points() {
        let text = wrapped(SHADER, "fs_main", next_binding(SHADER), (0.25, 0.25), 0.085).unwrap();
        let module = naga::front::wgsl::parse_str(&text)
            .unwrap_or_else(|e| panic!("{}\n{text}", e.emit_to_string(&text)));
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), Default::default())
            .validate(&module)
            .unwrap();
        let entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
        assert_eq!(entries, ["vs_main", "fs_sparse", "fs_adaptive"]);
        assert!(text.contains("@binding(1) var adaptive_sparse"), "{text}");
    }

    #[test]
    fn a_shader_without_the_expected_entry_is_left_alone() {
        assert!(wrapped(SHADER, "fs_other", 1, (0.25, 0.25), 0.1).is_err());
        let two =
            SHADER.replace("-> @location(0) vec4<f32> {\n    return input.n", "-> Out {\n    return input.n");
        assert!(wrapped(&two, "fs_main", 1, (0.25, 0.25), 0.1).is_err());
    }
}
