//! Depth buffers read as colour: [`DepthCopier`] copies a depth aspect (or
//! the stencil aspect, as s/255) into an `R32Float` texture a later pass
//! can sample.

use super::fullscreen;

/// Copies a depth buffer into an `R32Float` texture (`.x`): a full-screen
/// triangle loading the depth aspect texel by texel — a depth buffer can
/// neither be sampled as a colour nor copied into one.
pub(super) struct DepthCopier {
    pub(super) pipeline: wgpu::RenderPipeline,
    pub(super) layout: wgpu::BindGroupLayout,
    /// The same for the stencil aspect (an unsigned integer texture).
    pub(super) stencil_pipeline: wgpu::RenderPipeline,
    pub(super) stencil_layout: wgpu::BindGroupLayout,
}

const DEPTH_COPY_WGSL: &str = "
@group(0) @binding(0) var depth: texture_depth_2d;
@fragment
fn fs_main(@builtin(position) at: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(textureLoad(depth, vec2<i32>(at.xy), 0), 0.0, 0.0, 1.0);
}
";

/// The stencil value s as s/255, as the shader reads a stencil copy
/// (codegen's `framebuffer_channel`: `round(255·x)`).
const STENCIL_COPY_WGSL: &str = "
@group(0) @binding(0) var stencil: texture_2d<u32>;
@fragment
fn fs_main(@builtin(position) at: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(f32(textureLoad(stencil, vec2<i32>(at.xy), 0).x) / 255.0, 0.0, 0.0, 1.0);
}
";

impl DepthCopier {
    pub(super) fn new(device: &wgpu::Device) -> DepthCopier {
        let label = "shadec depth copy";
        let (module, layout) =
            fullscreen::module_and_layout(device, label, DEPTH_COPY_WGSL, wgpu::TextureSampleType::Depth);
        let pipeline = fullscreen::pipeline(device, label, &module, &layout, wgpu::TextureFormat::R32Float);
        let label = "shadec stencil copy";
        let (module, stencil_layout) =
            fullscreen::module_and_layout(device, label, STENCIL_COPY_WGSL, wgpu::TextureSampleType::Uint);
        let stencil_pipeline =
            fullscreen::pipeline(device, label, &module, &stencil_layout, wgpu::TextureFormat::R32Float);
        DepthCopier { pipeline, layout, stencil_pipeline, stencil_layout }
    }

    pub(super) fn copy(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        (depth, stencil): (&wgpu::Texture, bool),
        into: &wgpu::Texture,
    ) {
        let view = depth.create_view(&wgpu::TextureViewDescriptor {
            aspect: if stencil { wgpu::TextureAspect::StencilOnly } else { wgpu::TextureAspect::DepthOnly },
            ..Default::default()
        });
        let (pipeline, layout) = if stencil {
            (&self.stencil_pipeline, &self.stencil_layout)
        } else {
            (&self.pipeline, &self.layout)
        };
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadec depth copy"),
            layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            }],
        });
        let target = into.create_view(&Default::default());
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shadec depth copy"),
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
