//! Depth buffers read as colour: [`DepthCopier`] copies a depth aspect into
//! an `R32Float` texture a later pass can sample.

use super::fullscreen;

/// Copies a depth buffer into an `R32Float` texture (`.x`): a full-screen
/// triangle loading the depth aspect texel by texel — a depth buffer can
/// neither be sampled as a colour nor copied into one.
pub(super) struct DepthCopier {
    pub(super) pipeline: wgpu::RenderPipeline,
    pub(super) layout: wgpu::BindGroupLayout,
}

const DEPTH_COPY_WGSL: &str = "
@group(0) @binding(0) var depth: texture_depth_2d;
@fragment
fn fs_main(@builtin(position) at: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(textureLoad(depth, vec2<i32>(at.xy), 0), 0.0, 0.0, 1.0);
}
";

impl DepthCopier {
    pub(super) fn new(device: &wgpu::Device) -> DepthCopier {
        let label = "shadec depth copy";
        let (module, layout) =
            fullscreen::module_and_layout(device, label, DEPTH_COPY_WGSL, wgpu::TextureSampleType::Depth);
        let pipeline = fullscreen::pipeline(device, label, &module, &layout, wgpu::TextureFormat::R32Float);
        DepthCopier { pipeline, layout }
    }

    pub(super) fn copy(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        depth: &wgpu::Texture,
        into: &wgpu::Texture,
    ) {
        let view = depth.create_view(&wgpu::TextureViewDescriptor {
            aspect: wgpu::TextureAspect::DepthOnly,
            ..Default::default()
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadec depth copy"),
            layout: &self.layout,
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
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}
