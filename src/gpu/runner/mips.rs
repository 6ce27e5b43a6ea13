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
    /// Per colour format of a rendered texture.
    pipelines: Vec<(wgpu::TextureFormat, wgpu::RenderPipeline)>,
    layout: wgpu::BindGroupLayout,
}

const MIP_WGSL: &str = "
@group(0) @binding(0) var above: texture_2d<f32>;
@fragment
fn fs_main(@builtin(position) at: vec4<f32>) -> @location(0) vec4<f32> {
    let last = vec2<i32>(textureDimensions(above)) - vec2<i32>(1);
    let p = 2 * vec2<i32>(at.xy);
    var sum = vec4<f32>(0.0);
    for (var dy = 0; dy < 2; dy++) {
        for (var dx = 0; dx < 2; dx++) {
            sum += 0.25 * textureLoad(above, min(p + vec2<i32>(dx, dy), last), 0);
        }
    }
    return sum;
}
";

/// The levels of a `width`×`height` texture down to 1×1.
pub fn full_chain(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

impl MipMaker {
    pub(super) fn new(device: &wgpu::Device) -> MipMaker {
        let label = "shadec mip chain";
        let sample_type = wgpu::TextureSampleType::Float { filterable: false };
        let (module, layout) = fullscreen::module_and_layout(device, label, MIP_WGSL, sample_type);
        let pipelines = [ColorTarget::Rgba8, ColorTarget::Rgba16Float]
            .map(|format| {
                let format = format.wgpu();
                (format, fullscreen::pipeline(device, label, &module, &layout, format))
            })
            .into();
        MipMaker { pipelines, layout }
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
        let Some((_, pipeline)) = self.pipelines.iter().find(|(f, _)| *f == format) else { return };
        let view = |level: u32, layer: u32| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2),
                base_mip_level: level,
                mip_level_count: Some(1),
                base_array_layer: layer,
                array_layer_count: Some(1),
                ..Default::default()
            })
        };
        for layer in 0..t.layers {
            for level in 1..t.mip_levels.min(texture.mip_level_count()) {
                let above = view(level - 1, layer);
                let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("shadec mip chain"),
                    layout: &self.layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(&above),
                    }],
                });
                let target = view(level, layer);
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
