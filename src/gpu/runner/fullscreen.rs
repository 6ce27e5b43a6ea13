//! Full-screen passes over one texture read with `textureLoad`: the one
//! vertex stage (a triangle covering the target) and the pipeline set-up
//! shared by [`super::depth::DepthCopier`] and [`super::mips::MipMaker`].

use std::borrow::Cow;

/// The vertex stage: one triangle whose window covers the whole target.
const FULLSCREEN_VS: &str = "
@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0);
}
";

/// A full-screen pass's shader module and the layout of its one texture
/// (binding 0, fragment stage, 2-D): `fragment` declares the texture and
/// `fs_main`.
pub(super) fn module_and_layout(
    device: &wgpu::Device,
    label: &str,
    fragment: &str,
    sample_type: wgpu::TextureSampleType,
) -> (wgpu::ShaderModule, wgpu::BindGroupLayout) {
    module_and_layout_of(device, label, fragment, sample_type, wgpu::TextureViewDimension::D2)
}

/// [`module_and_layout`] for a texture of `view_dimension` (a 2-D array's
/// layers read by index).
pub(super) fn module_and_layout_of(
    device: &wgpu::Device,
    label: &str,
    fragment: &str,
    sample_type: wgpu::TextureSampleType,
    view_dimension: wgpu::TextureViewDimension,
) -> (wgpu::ShaderModule, wgpu::BindGroupLayout) {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(Cow::Owned(format!("{fragment}{FULLSCREEN_VS}"))),
    });
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture { sample_type, view_dimension, multisampled: false },
            count: None,
        }],
    });
    (module, layout)
}

/// The pass's pipeline writing `format`, no blending, no depth.
pub(super) fn pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    layout: &wgpu::BindGroupLayout,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}
