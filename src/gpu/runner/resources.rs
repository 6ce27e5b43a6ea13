//! The wgpu objects of one pass: load operations, the render pipeline,
//! bind-group entries, texture uploads and samplers.

use crate::pipeline::CullMode;

use super::fixed_function::{blend_state, compare, stencil_state, write_mask};
use super::passes::{AddressMode, Filter, RunPass, SamplerSettings, Target, TexelUpload, TextureData};
use super::Gpu;

/// How a pass starts on its target: the first pass into a target clears it
/// (the main target to the frame's clear values, a rendered texture to
/// transparent black, depth 1, stencil 0), later ones load.
pub(super) fn load_ops(
    target: &Target,
    main: bool,
    first: bool,
) -> (wgpu::LoadOp<wgpu::Color>, wgpu::LoadOp<f32>, wgpu::LoadOp<u32>) {
    if !first {
        return (wgpu::LoadOp::Load, wgpu::LoadOp::Load, wgpu::LoadOp::Load);
    }
    let [r, g, b, a] = target.clear_color.map(f64::from);
    let color = if main { wgpu::Color { r, g, b, a } } else { wgpu::Color::TRANSPARENT };
    let depth = if main { target.clear_depth } else { 1.0 };
    let stencil = if main { u32::from(target.clear_stencil) } else { 0 };
    (wgpu::LoadOp::Clear(color), wgpu::LoadOp::Clear(depth), wgpu::LoadOp::Clear(stencil))
}

/// The pass's pipeline: its vertex layout (one attribute per vertex leaf),
/// culling, depth and stencil, blending and write mask, one colour target
/// per output.
pub(super) fn render_pipeline(
    device: &wgpu::Device,
    pass: &RunPass,
    (shader, fragment_shader): (&wgpu::ShaderModule, &wgpu::ShaderModule),
    pipeline_layout: &wgpu::PipelineLayout,
    (depth_format, color_format): (wgpu::TextureFormat, wgpu::TextureFormat),
) -> wgpu::RenderPipeline {
    let label = Some(pass.label.as_str());
    let mut offset = 0;
    let attributes: Vec<wgpu::VertexAttribute> = pass
        .vertices
        .components
        .iter()
        .enumerate()
        .map(|(location, &n)| {
            let format = match n {
                1 => wgpu::VertexFormat::Float32,
                2 => wgpu::VertexFormat::Float32x2,
                3 => wgpu::VertexFormat::Float32x3,
                _ => wgpu::VertexFormat::Float32x4,
            };
            let attribute = wgpu::VertexAttribute { format, offset, shader_location: location as u32 };
            offset += u64::from(n) * 4;
            attribute
        })
        .collect();
    let state = &pass.state;
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label,
        layout: Some(pipeline_layout),
        vertex: wgpu::VertexState {
            module: shader,
            entry_point: Some(&pass.shader.vertex_entry),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: offset,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &attributes,
            })],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            front_face: wgpu::FrontFace::Ccw,
            cull_mode: match state.cull {
                CullMode::None => None,
                CullMode::Back => Some(wgpu::Face::Back),
                CullMode::Front => Some(wgpu::Face::Front),
            },
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: depth_format,
            depth_write_enabled: Some(state.depth.write),
            depth_compare: Some(compare(state.depth.func)),
            stencil: stencil_state(&state.stencil),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: fragment_shader,
            entry_point: Some(&pass.shader.fragment_entry),
            compilation_options: Default::default(),
            targets: &vec![
                Some(wgpu::ColorTargetState {
                    format: color_format,
                    blend: Some(blend_state(&state.blend)),
                    write_mask: write_mask(state.blend.write_mask),
                });
                pass.outputs as usize
            ],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// Bind group 0's entries: the uniform block at 0, textures a pass loads
/// from its own target at their bindings, unit i's view and sampler at
/// 1 + 2i and 2 + 2i.
pub(super) fn bind_entries<'b>(
    uniform_buffer: Option<&'b wgpu::Buffer>,
    loaded_views: &'b [(u32, wgpu::TextureView)],
    owned_views: &'b [wgpu::TextureView],
    owned_samplers: &'b [wgpu::Sampler],
) -> Vec<wgpu::BindGroupEntry<'b>> {
    let mut entries = Vec::new();
    if let Some(buffer) = uniform_buffer {
        entries.push(wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() });
    }
    for (binding, view) in loaded_views {
        entries.push(wgpu::BindGroupEntry {
            binding: *binding,
            resource: wgpu::BindingResource::TextureView(view),
        });
    }
    for (texture_idx, (view, sampler)) in owned_views.iter().zip(owned_samplers).enumerate() {
        let binding = 1 + 2 * texture_idx as u32;
        entries.push(wgpu::BindGroupEntry { binding, resource: wgpu::BindingResource::TextureView(view) });
        entries.push(wgpu::BindGroupEntry {
            binding: binding + 1,
            resource: wgpu::BindingResource::Sampler(sampler),
        });
    }
    entries
}

/// Uploads the texels in `texels`' format (an `Rgba16` image rounded to
/// RGBA8 where the device has no 16-bit unorm); returns the view dimension
/// the layout needs.
pub(super) fn upload_texture(
    gpu: &Gpu,
    data: &TextureData,
    texels: TexelUpload,
) -> (wgpu::TextureViewDimension, wgpu::TextureView) {
    let (width, height, layers, levels, dimension) = match data {
        TextureData::D2 { width, height, rgba } => {
            (*width, *height, 1, std::slice::from_ref(rgba), wgpu::TextureViewDimension::D2)
        }
        TextureData::Cube { size, rgba } => {
            (*size, *size, 6, std::slice::from_ref(rgba), wgpu::TextureViewDimension::Cube)
        }
        TextureData::D2Array { width, height, layers, rgba } => {
            (*width, *height, *layers, std::slice::from_ref(rgba), wgpu::TextureViewDimension::D2Array)
        }
        TextureData::D2Mipmapped { width, height, levels } => {
            (*width, *height, 1, levels.as_slice(), wgpu::TextureViewDimension::D2)
        }
        TextureData::Rendered { .. }
        | TextureData::RenderedCube { .. }
        | TextureData::RenderedDepth { .. }
        | TextureData::RenderedStencil { .. } => {
            unreachable!("bound by `prepare`")
        }
    };
    let wide = texels == TexelUpload::Rgba16 && gpu.filters_16bit_norm();
    let size = wgpu::Extent3d { width, height, depth_or_array_layers: layers };
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("shadec texture"),
        size,
        mip_level_count: levels.len() as u32,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: if wide { wgpu::TextureFormat::Rgba16Unorm } else { wgpu::TextureFormat::Rgba8Unorm },
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    for (k, texel_bytes) in levels.iter().enumerate() {
        let (w, h) = ((width >> k).max(1), (height >> k).max(1));
        let narrowed;
        let rgba = if texels == TexelUpload::Rgba16 && !wide {
            narrowed = narrow_to_8bit(texel_bytes);
            &narrowed
        } else {
            texel_bytes
        };
        let bpt = if wide { 8 } else { 4 };
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: k as u32,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            rgba,
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * bpt), rows_per_image: Some(h) },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: layers },
        );
    }
    let view = texture
        .create_view(&wgpu::TextureViewDescriptor { dimension: Some(dimension), ..Default::default() });
    (dimension, view)
}

pub(super) fn sampler_descriptor(settings: &SamplerSettings) -> wgpu::SamplerDescriptor<'static> {
    let filter = |f: Filter| match f {
        Filter::Nearest => wgpu::FilterMode::Nearest,
        Filter::Linear => wgpu::FilterMode::Linear,
    };
    let address = match settings.address {
        AddressMode::ClampToEdge => wgpu::AddressMode::ClampToEdge,
        AddressMode::Repeat => wgpu::AddressMode::Repeat,
        AddressMode::MirrorRepeat => wgpu::AddressMode::MirrorRepeat,
    };
    wgpu::SamplerDescriptor {
        label: Some("shadec sampler"),
        address_mode_u: address,
        address_mode_v: address,
        address_mode_w: address,
        mag_filter: filter(settings.mag),
        min_filter: filter(settings.min),
        mipmap_filter: match settings.mipmap {
            Some(Filter::Linear) => wgpu::MipmapFilterMode::Linear,
            _ => wgpu::MipmapFilterMode::Nearest,
        },
        ..Default::default()
    }
}

/// `Rgba16Unorm` texel bytes rounded to `Rgba8Unorm` (a device without
/// 16-bit unorm textures): k·257 → k, other values to the nearest 8-bit step.
pub(super) fn narrow_to_8bit(texel_bytes: &[u8]) -> Vec<u8> {
    texel_bytes
        .chunks_exact(2)
        .map(|c| ((u16::from_ne_bytes([c[0], c[1]]) as u32 + 128) / 257) as u8)
        .collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn narrowing_16bit_texels_recovers_8bit_values_and_rounds_the_rest() {
        let wide: Vec<u8> =
            (0..=255u16).map(|k| k * 257).chain([128, 129, 65535 - 128]).flat_map(u16::to_ne_bytes).collect();
        let narrow = super::narrow_to_8bit(&wide);
        assert_eq!(&narrow[..256], (0..=255u8).collect::<Vec<_>>().as_slice());
        // 128/65535 is just under half a step: 0; 129/65535 just over: 1.
        assert_eq!(&narrow[256..], &[0, 1, 255]);
    }
}
