//! Checks a run against its target and the adapter before wgpu sees it
//! (sizes, indices, formats, rendered sources), then makes each pass's
//! GPU objects ([`Prepared`]).

use std::borrow::Cow;
use std::collections::BTreeMap;

use wgpu::util::DeviceExt;

use super::passes::{
    DepthFormat, PassTarget, RenderedTexture, RunPass, RunTexture, SamplerSettings, Target, TextureData,
};
use super::resources::{bind_entries, render_pipeline, sampler_descriptor, upload_texture};
use super::{Gpu, GpuError};

/// The GPU objects of one pass.
pub(super) struct Prepared {
    pub(super) pipeline: wgpu::RenderPipeline,
    pub(super) bind_group: Option<wgpu::BindGroup>,
    pub(super) vertex_buffer: wgpu::Buffer,
    pub(super) index_buffer: wgpu::Buffer,
}

/// A rendered source names a texture some pass of the run renders.
pub(super) fn check_rendered(
    data: &TextureData,
    rendered: &BTreeMap<String, RenderedTexture>,
) -> Result<(), String> {
    match data {
        TextureData::Rendered { name, .. }
        | TextureData::RenderedCube { name }
        | TextureData::RenderedDepth { name: Some(name) }
        | TextureData::RenderedStencil { name: Some(name) }
            if !rendered.contains_key(name) =>
        {
            Err(format!("`{name}` is a rendered texture no pass of this run renders"))
        }
        _ => Ok(()),
    }
}

/// Sizes, indices and formats: what wgpu would reject late or not at all
/// (out-of-range indices are not an error on every backend).
pub(super) fn check_pass(
    pass: &RunPass,
    target: &Target,
    rendered: &BTreeMap<String, RenderedTexture>,
) -> Result<(), GpuError> {
    let invalid = |message: String| GpuError::InvalidInput { pass: pass.label.clone(), message };
    check_vertices(pass).map_err(invalid)?;
    for (texture_idx, texture) in pass.textures.iter().enumerate() {
        check_texture(texture_idx, texture, rendered).map_err(invalid)?;
    }
    if pass.state.stencil.enabled && target.depth_format != DepthFormat::Depth24PlusStencil8 {
        return Err(invalid("the stencil test needs DepthFormat::Depth24PlusStencil8".to_string()));
    }
    let reads_stencil = pass
        .textures
        .iter()
        .map(|t| &t.data)
        .chain(pass.loaded.iter().map(|l| &l.data))
        .any(|d| matches!(d, TextureData::RenderedStencil { .. }));
    if reads_stencil && target.depth_format != DepthFormat::Depth24PlusStencil8 {
        return Err(invalid("reading the stencil needs DepthFormat::Depth24PlusStencil8".to_string()));
    }
    for l in &pass.loaded {
        if !matches!(
            l.data,
            TextureData::Rendered { .. }
                | TextureData::RenderedDepth { .. }
                | TextureData::RenderedStencil { .. }
        ) {
            return Err(invalid(format!(
                "binding {}: only rendered textures are read with textureLoad",
                l.binding
            )));
        }
        check_rendered(&l.data, rendered)
            .map_err(|message| invalid(format!("binding {}: {message}", l.binding)))?;
    }
    let layers = match &pass.target {
        PassTarget::Main => 1,
        PassTarget::Texture(t) => t.layers,
    };
    if pass.outputs == 0 || pass.outputs > layers {
        return Err(invalid(format!("{} colour outputs into a target of {layers} layer(s)", pass.outputs)));
    }
    Ok(())
}

/// Vertex attributes of 1 to 4 components, whole vertices, whole
/// triangles, indices in range.
fn check_vertices(pass: &RunPass) -> Result<(), String> {
    let components = &pass.vertices.components;
    if components.is_empty() || components.iter().any(|&n| !(1..=4).contains(&n)) {
        return Err(format!(
            "vertex attributes must have 1 to 4 components each, at least one attribute (position); got {components:?}"
        ));
    }
    let stride: u32 = components.iter().sum();
    if pass.vertices.floats.len() % stride as usize != 0 {
        return Err(format!(
            "{} vertex floats is not a multiple of the vertex size {stride} ({components:?})",
            pass.vertices.floats.len()
        ));
    }
    let n_vertices = pass.vertices.floats.len() / stride as usize;
    if pass.indices.len() % 3 != 0 {
        return Err(format!("{} indices is not a whole number of triangles", pass.indices.len()));
    }
    if let Some(&bad) = pass.indices.iter().find(|&&i| i as usize >= n_vertices) {
        return Err(format!("index {bad} is out of range: the pass has {n_vertices} vertices"));
    }
    Ok(())
}

/// Texture `texture_idx` of a pass: as many bytes as its size needs (every
/// mip level too), or a rendered source some pass renders.
fn check_texture(
    texture_idx: usize,
    texture: &RunTexture,
    rendered: &BTreeMap<String, RenderedTexture>,
) -> Result<(), String> {
    let bpt = texture.texels.bytes_per_texel();
    let (expected, what) = match texture.data {
        TextureData::D2 { width, height, .. } => (width as usize * height as usize * bpt, "2D"),
        TextureData::Cube { size, .. } => (size as usize * size as usize * bpt * 6, "cube"),
        TextureData::D2Array { width, height, layers, .. } => {
            (width as usize * height as usize * bpt * layers as usize, "2D array")
        }
        TextureData::RenderedCube { ref name } if rendered.get(name).is_some_and(|t| !t.cube) => {
            return Err(format!(
                "texture {texture_idx}: `{name}` is sampled as a cube map but not rendered as one"
            ));
        }
        TextureData::Rendered { .. }
        | TextureData::RenderedCube { .. }
        | TextureData::RenderedDepth { .. }
        | TextureData::RenderedStencil { .. } => {
            return check_rendered(&texture.data, rendered)
                .map_err(|message| format!("texture {texture_idx}: {message}"));
        }
        TextureData::D2Mipmapped { width, height, ref levels } => {
            for (k, level) in levels.iter().enumerate() {
                let need = (width >> k).max(1) as usize * (height >> k).max(1) as usize * bpt;
                if level.len() != need {
                    return Err(format!(
                        "mip level {k} of texture {texture_idx} has {} bytes, needs {need}",
                        level.len()
                    ));
                }
            }
            (width as usize * height as usize * bpt, "mipmapped 2D")
        }
    };
    let rgba = match &texture.data {
        TextureData::D2 { rgba, .. } | TextureData::Cube { rgba, .. } | TextureData::D2Array { rgba, .. } => {
            rgba
        }
        TextureData::D2Mipmapped { levels, .. } => match levels.first() {
            Some(l) => l,
            None => return Err(format!("mipmapped texture {texture_idx} has no levels")),
        },
        TextureData::Rendered { .. }
        | TextureData::RenderedCube { .. }
        | TextureData::RenderedDepth { .. }
        | TextureData::RenderedStencil { .. } => return Ok(()),
    };
    if expected == 0 || rgba.len() != expected {
        return Err(format!(
            "{what} texture {texture_idx} has {} bytes, its size needs {expected} ({:?}, non-empty)",
            rgba.len(),
            texture.texels
        ));
    }
    Ok(())
}

/// Rendered textures, each with its own depth/stencil buffer, and a
/// scratch copy for passes that sample their own target.
pub(super) fn rendered_targets(
    device: &wgpu::Device,
    rendered: &BTreeMap<String, RenderedTexture>,
    depth_format: wgpu::TextureFormat,
) -> BTreeMap<String, (wgpu::Texture, wgpu::Texture, wgpu::Texture)> {
    let mut textures: BTreeMap<String, (wgpu::Texture, wgpu::Texture, wgpu::Texture)> = BTreeMap::new();
    for (name, t) in rendered {
        let size = wgpu::Extent3d { width: t.width, height: t.height, depth_or_array_layers: t.layers };
        // Only the texture itself has the chain (not its scratch copy or depth).
        let levels = t.mip_levels.clamp(1, super::mips::full_chain(t.width, t.height));
        let make =
            |label: &str, format: wgpu::TextureFormat, usage: wgpu::TextureUsages, layers: u32, levels| {
                device.create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d { depth_or_array_layers: layers, ..size },
                    mip_level_count: levels,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                })
            };
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST;
        let texture = make(name, t.format.wgpu(), usage, t.layers, levels);
        let scratch = make(name, t.format.wgpu(), usage, t.layers, 1);
        let depth = make(
            name,
            depth_format,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            1,
            1,
        );
        textures.insert(name.clone(), (texture, scratch, depth));
    }
    textures
}

/// Depth snapshots: per pass, per slot (units, then loaded textures) that
/// reads a depth (or stencil) buffer, an R32Float copy made just before
/// the pass, the buffer's name, and whether it is the stencil.
pub(super) fn depth_snapshots(
    device: &wgpu::Device,
    target: &Target,
    passes: &[RunPass],
    rendered: &BTreeMap<String, RenderedTexture>,
) -> BTreeMap<(usize, usize), (wgpu::Texture, Option<String>, bool)> {
    let depth_size = |name: &Option<String>| -> (u32, u32) {
        match name {
            None => (target.width, target.height),
            Some(n) => (rendered[n].width, rendered[n].height),
        }
    };
    let mut snapshots: BTreeMap<(usize, usize), (wgpu::Texture, Option<String>, bool)> = BTreeMap::new();
    for (pass_idx, pass) in passes.iter().enumerate() {
        let slots = pass.textures.iter().map(|t| &t.data).chain(pass.loaded.iter().map(|l| &l.data));
        for (slot, data) in slots.enumerate() {
            let stencil = matches!(data, TextureData::RenderedStencil { .. });
            if let TextureData::RenderedDepth { name } | TextureData::RenderedStencil { name } = data {
                let (width, height) = depth_size(name);
                let copy = device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("shadec depth snapshot"),
                    size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::R32Float,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                });
                snapshots.insert((pass_idx, slot), (copy, name.clone(), stencil));
            }
        }
    }
    snapshots
}

/// `view_of(slot, data)`: the view of a rendered source (slot: the unit,
/// then `units + i` for `loaded[i]`), `None` for data to upload.
pub(super) fn prepare(
    gpu: &Gpu,
    pass: &RunPass,
    modules: super::Modules,
    depth_format: wgpu::TextureFormat,
    color_format: wgpu::TextureFormat,
    view_of: &dyn Fn(usize, &TextureData) -> Option<wgpu::TextureView>,
) -> Prepared {
    let device = &gpu.device;
    let label = Some(pass.label.as_str());
    let shader_module = |module: naga::Module| {
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label,
            source: wgpu::ShaderSource::Naga(Cow::Owned(module)),
        })
    };
    let shader = shader_module(modules.vertex);
    let fragment_shader = modules.fragment.map(shader_module);

    // Bind group 0: uniforms at 0, texture i at 1 + 2i, its sampler at 2 + 2i.
    let mut layout_entries = Vec::new();
    let mut owned_views = Vec::new();
    let mut owned_samplers = Vec::new();
    let uniform_buffer = pass.uniforms.as_ref().map(|bytes| {
        let mut padded = bytes.clone();
        padded.resize(bytes.len().div_ceil(16).max(1) * 16, 0);
        layout_entries.push(wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        });
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label,
            contents: &padded,
            usage: wgpu::BufferUsages::UNIFORM,
        })
    });
    for (texture_idx, texture) in pass.textures.iter().enumerate() {
        let (entries, view, sampler) = sampled_texture(gpu, texture_idx, texture, view_of);
        layout_entries.extend(entries);
        owned_views.push(view);
        owned_samplers.push(sampler);
    }
    let loaded_views = loaded_textures(pass, view_of, &mut layout_entries);
    let bind_group_layout = (!layout_entries.is_empty()).then(|| {
        device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label, entries: &layout_entries })
    });
    let bind_group = bind_group_layout.as_ref().map(|layout| {
        let entries = bind_entries(uniform_buffer.as_ref(), &loaded_views, &owned_views, &owned_samplers);
        device.create_bind_group(&wgpu::BindGroupDescriptor { label, layout, entries: &entries })
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label,
        bind_group_layouts: &[bind_group_layout.as_ref()].into_iter().flatten().map(Some).collect::<Vec<_>>(),
        immediate_size: 0,
    });

    let shaders = (&shader, fragment_shader.as_ref().unwrap_or(&shader));
    let pipeline = render_pipeline(device, pass, shaders, &pipeline_layout, (depth_format, color_format));
    let vertex_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label,
        contents: bytemuck::cast_slice(&pass.vertices.floats),
        usage: wgpu::BufferUsages::VERTEX,
    });
    let index_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label,
        contents: bytemuck::cast_slice(&pass.indices),
        usage: wgpu::BufferUsages::INDEX,
    });
    Prepared { pipeline, bind_group, vertex_buffer, index_buffer }
}

/// The textures a pass reads from its own target as it was before the
/// pass (unfilterable, at their own bindings): their views, and their
/// layout entries appended.
pub(super) fn loaded_textures(
    pass: &RunPass,
    view_of: &dyn Fn(usize, &TextureData) -> Option<wgpu::TextureView>,
    layout_entries: &mut Vec<wgpu::BindGroupLayoutEntry>,
) -> Vec<(u32, wgpu::TextureView)> {
    let units = pass.textures.len();
    let mut loaded_views = Vec::new();
    for (i, l) in pass.loaded.iter().enumerate() {
        #[allow(clippy::expect_used, reason = "`check_pass` refuses a pass whose loaded texture has no view")]
        let view = view_of(units + i, &l.data).expect("loaded textures are rendered (check_pass)");
        layout_entries.push(wgpu::BindGroupLayoutEntry {
            binding: l.binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        });
        loaded_views.push((l.binding, view));
    }
    loaded_views
}

/// Texture unit `texture_idx` of a pass: its texture and sampler layout
/// entries (bindings 1 + 2i and 2 + 2i), its view (a rendered texture's, or
/// the upload's) and its sampler.
fn sampled_texture(
    gpu: &Gpu,
    texture_idx: usize,
    texture: &RunTexture,
    view_of: &dyn Fn(usize, &TextureData) -> Option<wgpu::TextureView>,
) -> ([wgpu::BindGroupLayoutEntry; 2], wgpu::TextureView, wgpu::Sampler) {
    let binding = 1 + 2 * texture_idx as u32;
    let (view_dimension, view) = match view_of(texture_idx, &texture.data) {
        Some(view) => (
            if matches!(texture.data, TextureData::Rendered { array: true, .. }) {
                wgpu::TextureViewDimension::D2Array
            } else if matches!(texture.data, TextureData::RenderedCube { .. }) {
                wgpu::TextureViewDimension::Cube
            } else {
                wgpu::TextureViewDimension::D2
            },
            view,
        ),
        None => upload_texture(gpu, &texture.data, texture.texels),
    };
    // A depth snapshot (R32Float) is unfilterable: nearest, non-filtering.
    let depth =
        matches!(texture.data, TextureData::RenderedDepth { .. } | TextureData::RenderedStencil { .. });
    let texture_entry = wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: !depth },
            view_dimension,
            multisampled: false,
        },
        count: None,
    };
    let sampler_entry = wgpu::BindGroupLayoutEntry {
        binding: binding + 1,
        visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
        ty: wgpu::BindingType::Sampler(if depth {
            wgpu::SamplerBindingType::NonFiltering
        } else {
            wgpu::SamplerBindingType::Filtering
        }),
        count: None,
    };
    let settings = if depth {
        SamplerSettings { address: texture.sampler.address, ..SamplerSettings::NEAREST_CLAMP }
    } else {
        texture.sampler
    };
    let sampler = gpu.device.create_sampler(&sampler_descriptor(&settings));
    ([texture_entry, sampler_entry], view, sampler)
}
