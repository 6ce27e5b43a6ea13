//! Mip chains of rendered textures: after the passes into a texture
//! declared `mipmap`, each level is the box filter of the one above it —
//! texel (x, y) of level k the mean of texels (2x..2x+1, 2y..2y+1) of level
//! k − 1, clamped to its edge, sizes halved and floored — as the CPU
//! renderer's `Texture2D::with_box_mipmaps` makes its chain, so a later
//! pass minifies the same texels on either executor.

use super::fullscreen;
use super::passes::{ColorTarget, RenderedTexture};

/// One full-screen triangle per level and layer, reading the level above
/// with `textureLoad`.
pub(super) struct MipMaker {
    /// Per colour format and, for an array texture (a fat texel's
    /// members), per layer: each pipeline with its texture's layout.
    pipelines: Vec<(wgpu::TextureFormat, Option<u32>, wgpu::RenderPipeline, wgpu::BindGroupLayout)>,
}

/// The mip shader for a 2-D texture, or for layer `layer` of a 2-D array.
///
/// An array's layer is read from a view of the whole array by its index,
/// not through a 2-D view of one layer: a backend without texture views
/// (wgpu's GL) binds the array itself, which a `texture_2d` does not
/// sample (a mipmapped fat texture was black there beyond level 0).
fn mip_wgsl(layer: Option<u32>) -> String {
    let (texture, at) = match layer {
        None => ("texture_2d<f32>".to_string(), String::new()),
        Some(l) => ("texture_2d_array<f32>".to_string(), format!(", {l}")),
    };
    format!(
        "
@group(0) @binding(0) var above: {texture};
@fragment
fn fs_main(@builtin(position) at: vec4<f32>) -> @location(0) vec4<f32> {{
    let last = vec2<i32>(textureDimensions(above)) - vec2<i32>(1);
    let p = 2 * vec2<i32>(at.xy);
    var sum = vec4<f32>(0.0);
    for (var dy = 0; dy < 2; dy++) {{
        for (var dx = 0; dx < 2; dx++) {{
            sum += 0.25 * textureLoad(above, min(p + vec2<i32>(dx, dy), last){at}, 0);
        }}
    }}
    return sum;
}}
"
    )
}

/// The levels of a `width`×`height` texture down to 1×1.
pub fn full_chain(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

impl MipMaker {
    /// Pipelines for 2-D textures of both colour formats, and for each
    /// layer of the mipmapped arrays among `textures`.
    pub(super) fn new<'a>(
        device: &wgpu::Device,
        textures: impl Iterator<Item = &'a RenderedTexture>,
    ) -> MipMaker {
        let label = "shadec mip chain";
        let sample_type = wgpu::TextureSampleType::Float { filterable: false };
        let make = |format: wgpu::TextureFormat, layer: Option<u32>| {
            let dimension = if layer.is_some() {
                wgpu::TextureViewDimension::D2Array
            } else {
                wgpu::TextureViewDimension::D2
            };
            let (module, layout) =
                fullscreen::module_and_layout_of(device, label, &mip_wgsl(layer), sample_type, dimension);
            (format, layer, fullscreen::pipeline(device, label, &module, &layout, format), layout)
        };
        let mut pipelines: Vec<_> =
            [ColorTarget::Rgba8, ColorTarget::Rgba16Float].map(|f| make(f.wgpu(), None)).into();
        for t in textures.filter(|t| t.mip_levels > 1 && t.layers > 1) {
            for layer in 0..t.layers {
                let format = t.format.wgpu();
                if !pipelines.iter().any(|(f, l, ..)| *f == format && *l == Some(layer)) {
                    pipelines.push(make(format, Some(layer)));
                }
            }
        }
        MipMaker { pipelines }
    }

    /// Records levels 1.. of every layer of `texture` from its level 0.
    pub(super) fn generate(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        texture: &wgpu::Texture,
        t: &RenderedTexture,
    ) {
        let format = t.format.wgpu();
        let array = t.layers > 1;
        // One layer's 2-D view of `level`, or the whole array's (`None`).
        let view = |level: u32, layer: Option<u32>| {
            let dimension = if layer.is_some() {
                wgpu::TextureViewDimension::D2
            } else {
                wgpu::TextureViewDimension::D2Array
            };
            texture.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(dimension),
                base_mip_level: level,
                mip_level_count: Some(1),
                base_array_layer: layer.unwrap_or(0),
                array_layer_count: layer.map(|_| 1),
                ..Default::default()
            })
        };
        for layer in 0..t.layers {
            let key = array.then_some(layer);
            let Some((_, _, pipeline, layout)) =
                self.pipelines.iter().find(|(f, l, ..)| *f == format && *l == key)
            else {
                continue;
            };
            for level in 1..t.mip_levels.min(texture.mip_level_count()) {
                let above = view(level - 1, (!array).then_some(layer));
                let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("shadec mip chain"),
                    layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&above),
                    }],
                });
                let target = view(level, Some(layer));
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("shadec mip chain"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &target,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &bind_group, &[]);
                pass.draw(0..3, 0..1);
            }
        }
    }
}
