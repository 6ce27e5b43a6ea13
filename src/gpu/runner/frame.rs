//! A frame's GPU objects made once ([`Frame::prepare`]), then drawn as
//! often as asked: record, submit, time and read back.

use std::collections::BTreeMap;

use image::RgbaImage;

use super::depth::DepthCopier;
use super::passes::{ColorTarget, DepthFormat, PassTarget, RenderedTexture, RunPass, Target, TextureData};
use super::prepare::{check_pass, depth_snapshots, prepare, rendered_targets, Prepared};
use super::resources::load_ops;
use super::{in_error_scopes, validate_shader, Gpu, GpuError};

/// Rendered textures by name: (texture, scratch copy, depth/stencil).
type RenderedTargets = BTreeMap<String, (wgpu::Texture, wgpu::Texture, wgpu::Texture)>;

/// Depth snapshots by (pass, texture unit): the copy, the depth buffer
/// copied (`None`: the main one), and whether its stencil is copied.
type DepthSnapshots = BTreeMap<(usize, usize), (wgpu::Texture, Option<String>, bool)>;

/// A frame's GPU objects, made once (pipelines, bind groups,
/// uploads and render targets per scene, not per frame); [`Frame::draw`]
/// then only records, submits and reads back.
pub struct Frame<'a> {
    pub(super) target: &'a Target,
    pub(super) passes: &'a [RunPass],
    pub(super) color: wgpu::Texture,
    pub(super) depth: wgpu::Texture,
    pub(super) depth_view: wgpu::TextureView,
    /// Rendered textures: (texture, scratch copy, depth/stencil).
    pub(super) textures: RenderedTargets,
    pub(super) texture_depth_views: BTreeMap<String, wgpu::TextureView>,
    pub(super) snapshots: DepthSnapshots,
    pub(super) depth_copier: Option<DepthCopier>,
    /// Where some rendered texture has a mip chain.
    pub(super) mips: Option<super::mips::MipMaker>,
    pub(super) prepared: Vec<Prepared>,
    pub(super) readback: wgpu::Buffer,
    pub(super) padded_row: u32,
    pub(super) unpadded_row: u32,
    /// Timestamps around every render pass, where the device has them.
    pub(super) timer: Option<crate::gpu::timer::Timer>,
    /// The render passes the last submission recorded.
    pub(super) recorded: std::cell::Cell<usize>,
}

/// A frame [`Frame::draw_median`] timed.
#[derive(Clone, Debug)]
pub struct TimedFrame {
    pub image: RgbaImage,
    /// From timestamp queries; `None` where the device has none.
    pub gpu: Option<std::time::Duration>,
    /// Submit to read-back.
    pub wall: std::time::Duration,
}

impl TimedFrame {
    /// GPU time where there is one, else wall time.
    pub fn time(&self) -> std::time::Duration {
        self.gpu.unwrap_or(self.wall)
    }
}

impl<'a> Frame<'a> {
    /// Checks `passes` against `target` and the adapter, then makes every
    /// GPU object the frame needs.
    pub fn prepare(gpu: &Gpu, target: &'a Target, passes: &'a [RunPass]) -> Result<Frame<'a>, GpuError> {
        let max_dim = gpu.device.limits().max_texture_dimension_2d;
        if target.width == 0 || target.height == 0 || target.width > max_dim || target.height > max_dim {
            return Err(GpuError::InvalidInput {
                pass: "target".to_string(),
                message: format!(
                    "size {}×{} is outside 1..={max_dim} (this adapter's limit)",
                    target.width, target.height
                ),
            });
        }
        // The rendered textures, by name: one description each.
        let mut rendered: BTreeMap<String, RenderedTexture> = BTreeMap::new();
        for pass in passes {
            if let PassTarget::Texture(t) = &pass.target {
                if t.width == 0
                    || t.height == 0
                    || t.width > max_dim
                    || t.height > max_dim
                    || t.layers == 0
                    || t.layers > 8
                {
                    return Err(GpuError::InvalidInput {
                        pass: pass.label.clone(),
                        message: format!(
                            "rendered texture `{}` is {}×{} with {} layers: sizes 1..={max_dim}, 1 to 8 layers",
                            t.name, t.width, t.height, t.layers
                        ),
                    });
                }
                if t.cube && (t.width != t.height || t.layers != 6 || t.mip_levels != 1) {
                    return Err(GpuError::InvalidInput {
                        pass: pass.label.clone(),
                        message: format!(
                            "rendered cube map `{}` is {}×{} with {} layers and {} levels: square, 6 layers, 1 level",
                            t.name, t.width, t.height, t.layers, t.mip_levels
                        ),
                    });
                }
                match rendered.get(&t.name) {
                    Some(known) if known != t => {
                        return Err(GpuError::InvalidInput {
                            pass: pass.label.clone(),
                            message: format!(
                                "rendered texture `{}` is described two ways: {known:?} and {t:?}",
                                t.name
                            ),
                        });
                    }
                    Some(_) => {}
                    None => {
                        rendered.insert(t.name.clone(), t.clone());
                    }
                }
            }
        }
        // Check everything we can before touching the device.
        let mut modules = Vec::with_capacity(passes.len());
        for pass in passes {
            check_pass(pass, target, &rendered)?;
            modules.push(validate_shader(&pass.label, &pass.shader)?);
        }

        in_error_scopes(&gpu.device, || Frame::create(gpu, target, passes, rendered, modules))
    }

    /// The GPU objects (inside error scopes: nothing here returns early).
    pub(super) fn create(
        gpu: &Gpu,
        target: &'a Target,
        passes: &'a [RunPass],
        rendered: BTreeMap<String, RenderedTexture>,
        modules: Vec<super::Modules>,
    ) -> Frame<'a> {
        let device = &gpu.device;

        let (color, depth, depth_format) = main_targets(device, target);
        let depth_view = depth.create_view(&Default::default());
        let textures = rendered_targets(device, &rendered, depth_format);
        let snapshots = depth_snapshots(device, target, passes, &rendered);
        let depth_copier = (!snapshots.is_empty()).then(|| DepthCopier::new(device));
        let mips = rendered
            .values()
            .any(|t| t.mip_levels > 1)
            .then(|| super::mips::MipMaker::new(device, rendered.values()));

        let prepared = prepare_passes(gpu, target, passes, modules, &textures, &snapshots, depth_format);

        let texture_depth_views: BTreeMap<String, wgpu::TextureView> = textures
            .iter()
            .map(|(name, (_, _, depth))| (name.clone(), depth.create_view(&Default::default())))
            .collect();
        let (readback, padded_row, unpadded_row) = readback_buffer(device, target);
        Frame {
            target,
            passes,
            color,
            depth,
            depth_view,
            textures,
            texture_depth_views,
            snapshots,
            depth_copier,
            mips,
            prepared,
            readback,
            padded_row,
            unpadded_row,
            // Every pass, and the clear of an undrawn main target.
            timer: crate::gpu::timer::Timer::new(device, passes.len() + 1),
            recorded: std::cell::Cell::new(0),
        }
    }

    /// The depth buffer a snapshot copies: the main one or a rendered texture's.
    pub(super) fn depth_source(&self, name: &Option<String>) -> &wgpu::Texture {
        match name {
            None => &self.depth,
            Some(n) => &self.textures[n].2,
        }
    }

    /// Records and submits the passes, and reads the main target back.
    pub fn draw(&self, gpu: &Gpu) -> Result<RgbaImage, GpuError> {
        let device = &gpu.device;
        in_error_scopes(device, || self.submit(gpu))?;
        self.read_back(device)
    }

    /// [`Frame::draw`], and the frame's GPU time from timestamp queries
    /// (`None` where the device has none: [`Frame::timestamps`]).
    pub fn draw_timed(&self, gpu: &Gpu) -> Result<(RgbaImage, Option<std::time::Duration>), GpuError> {
        let image = self.draw(gpu)?;
        let time = self.timer.as_ref().and_then(|t| t.elapsed(&gpu.device, &gpu.queue, self.recorded.get()));
        Ok((image, time))
    }

    /// A warm-up frame, then `runs` timed ones: the last picture and the
    /// median frame's times, ordered by GPU time where the device has
    /// timestamp queries, else by submit-to-read-back wall time.
    pub fn draw_median(&self, gpu: &Gpu, runs: usize) -> Result<TimedFrame, GpuError> {
        let mut image = self.draw(gpu)?;
        let mut times = Vec::with_capacity(runs.max(1));
        for _ in 0..runs.max(1) {
            let start = std::time::Instant::now();
            let (drawn, gpu_time) = self.draw_timed(gpu)?;
            times.push((gpu_time, start.elapsed()));
            image = drawn;
        }
        times.sort_by_key(|&(g, w)| g.unwrap_or(w));
        let (gpu_time, wall) = times[times.len() / 2];
        Ok(TimedFrame { image, gpu: gpu_time, wall })
    }

    /// Whether [`Frame::draw_timed`] measures GPU time.
    pub fn timestamps(&self) -> bool {
        self.timer.is_some()
    }

    /// The views a pass drawing into rendered texture `t` writes (one per
    /// output layer); a pass that samples its own target first gets the
    /// copy it binds, taken now.
    pub(super) fn texture_target_views(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pass: &RunPass,
        t: &RenderedTexture,
    ) -> Vec<wgpu::TextureView> {
        let (texture, scratch, _) = &self.textures[&t.name];
        if pass
            .textures
            .iter()
            .map(|x| &x.data)
            .chain(pass.loaded.iter().map(|l| &l.data))
            .any(|d| matches!(d, TextureData::Rendered { name, .. } | TextureData::RenderedCube { name } if *name == t.name))
        {
            // It samples its own target: the copy it binds, taken now.
            encoder.copy_texture_to_texture(
                texture.as_image_copy(),
                scratch.as_image_copy(),
                wgpu::Extent3d { width: t.width, height: t.height, depth_or_array_layers: t.layers },
            );
        }
        (0..pass.outputs)
            .map(|layer| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: layer,
                    array_layer_count: Some(1),
                    mip_level_count: Some(1),
                    ..Default::default()
                })
            })
            .collect()
    }

    /// After pass `pass_idx`, the last of the passes into a rendered
    /// texture: a cube map's other faces, a mipmapped texture's chain.
    fn after_pass(&self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder, pass_idx: usize) {
        let Some(PassTarget::Texture(t)) = self.passes.get(pass_idx).map(|p| &p.target) else { return };
        let next = self.passes.get(pass_idx + 1).map(|p| &p.target);
        if matches!(next, Some(PassTarget::Texture(n)) if n.name == t.name) {
            return;
        }
        if t.cube {
            copy_cube_faces(encoder, &self.textures[&t.name].0, t);
        }
        if let (Some(mips), true) = (&self.mips, t.mip_levels > 1) {
            mips.generate(device, encoder, &self.textures[&t.name].0, t);
        }
    }

    pub(super) fn submit(&self, gpu: &Gpu) {
        let device = &gpu.device;
        let (target, passes, prepared) = (self.target, self.passes, &self.prepared);
        let texture_depth_views = &self.texture_depth_views;
        let (color, depth_view, snapshots) = (&self.color, &self.depth_view, &self.snapshots);
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("shadec passes") });
        let mut cleared: std::collections::BTreeSet<String> = std::collections::BTreeSet::new();
        let main_key = String::new();
        let has_stencil = target.depth_format == DepthFormat::Depth24PlusStencil8;
        let mut recorded = 0;
        for pass_idx in 0..passes.len() + 1 {
            let (pass, prep) = match (passes.get(pass_idx), prepared.get(pass_idx)) {
                (Some(pass), Some(prep)) => (Some(pass), Some(prep)),
                // After the last pass: clear the main target if nothing drew there.
                _ if !cleared.contains(&main_key) => (None, None),
                _ => break,
            };
            // The depth buffers this pass reads, as they are now.
            for ((_, _), (copy, name, stencil)) in snapshots.range((pass_idx, 0)..(pass_idx + 1, 0)) {
                #[allow(
                    clippy::expect_used,
                    reason = "`prepare` makes the copier whenever it plans a snapshot"
                )]
                let copier = self.depth_copier.as_ref().expect("made when there are snapshots");
                copier.copy(device, &mut encoder, (self.depth_source(name), *stencil), copy);
            }
            let (key, views, depth_view): (&String, Vec<wgpu::TextureView>, &wgpu::TextureView) =
                match pass.map(|p| (p, &p.target)) {
                    None | Some((_, PassTarget::Main)) => {
                        (&main_key, vec![color.create_view(&Default::default())], depth_view)
                    }
                    Some((pass, PassTarget::Texture(t))) => {
                        let views = self.texture_target_views(&mut encoder, pass, t);
                        (&t.name, views, &texture_depth_views[&t.name])
                    }
                };
            let first = cleared.insert(key.clone());
            let (color_load, depth_load, stencil_load) = load_ops(target, key.is_empty(), first);
            let color_attachments: Vec<Option<wgpu::RenderPassColorAttachment>> = views
                .iter()
                .map(|view| {
                    Some(wgpu::RenderPassColorAttachment {
                        view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations { load: color_load, store: wgpu::StoreOp::Store },
                    })
                })
                .collect();
            let mut render_pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: pass.map(|p| p.label.as_str()),
                color_attachments: &color_attachments,
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: depth_view,
                    depth_ops: Some(wgpu::Operations { load: depth_load, store: wgpu::StoreOp::Store }),
                    stencil_ops: has_stencil
                        .then_some(wgpu::Operations { load: stencil_load, store: wgpu::StoreOp::Store }),
                }),
                timestamp_writes: self.timer.as_ref().and_then(|t| t.writes(recorded)),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            recorded += 1;
            if let (Some(pass), Some(prep)) = (pass, prep) {
                record_draw(&mut render_pass, pass, prep);
            }
            drop(render_pass);
            self.after_pass(device, &mut encoder, pass_idx);
        }

        self.copy_to_readback(&mut encoder);
        if let Some(timer) = &self.timer {
            timer.resolve(&mut encoder, recorded);
        }
        self.recorded.set(recorded);
        gpu.queue.submit([encoder.finish()]);
    }

    /// Records the copy of the main colour target into the read-back
    /// buffer, rows padded to wgpu's alignment.
    fn copy_to_readback(&self, encoder: &mut wgpu::CommandEncoder) {
        let target = self.target;
        let size = wgpu::Extent3d { width: target.width, height: target.height, depth_or_array_layers: 1 };
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.color,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(target.height),
                },
            },
            size,
        );
    }

    pub(super) fn read_back(&self, device: &wgpu::Device) -> Result<RgbaImage, GpuError> {
        let (target, readback) = (self.target, &self.readback);
        let (padded_row, unpadded_row) = (self.padded_row, self.unpadded_row);
        let slice = readback.slice(..);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |res| {
            let _ = sender.send(res);
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|err| GpuError::Readback(err.to_string()))?;
        receiver
            .recv()
            .map_err(|_| GpuError::Readback("the map callback never ran".to_string()))?
            .map_err(|err| GpuError::Readback(err.to_string()))?;
        let mapped = slice.get_mapped_range().map_err(|err| GpuError::Readback(err.to_string()))?;
        let mut pixels = Vec::with_capacity((target.width * 4 * target.height) as usize);
        for row in mapped.chunks_exact(padded_row as usize) {
            let row = &row[..unpadded_row as usize];
            match target.color_format {
                ColorTarget::Rgba8 => pixels.extend_from_slice(row),
                // Half floats to 8 bits as the CPU renderer's framebuffer does.
                ColorTarget::Rgba16Float => pixels.extend(row.chunks_exact(2).map(|h| {
                    let v = half::f16::from_bits(u16::from_le_bytes([h[0], h[1]])).to_f32();
                    crate::renderer::quantize_unorm8(v)
                })),
            }
        }
        drop(mapped);
        readback.unmap();
        RgbaImage::from_raw(target.width, target.height, pixels)
            .ok_or_else(|| GpuError::Readback("the image has the wrong size".to_string()))
    }
}

/// A cube map rendered over its texels: layer 0, which its passes drew,
/// copied into the other five faces (each face the rendered image at its
/// own (s, t), as the CPU renderer and the reference read it).
fn copy_cube_faces(encoder: &mut wgpu::CommandEncoder, texture: &wgpu::Texture, t: &RenderedTexture) {
    for layer in 1..t.layers {
        encoder.copy_texture_to_texture(
            texture.as_image_copy(),
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::Extent3d { width: t.width, height: t.height, depth_or_array_layers: 1 },
        );
    }
}

/// Records a pass's draw: its pipeline and bindings, blend constant,
/// stencil reference and indexed triangles (nothing for a pass without
/// triangles, which only clears).
fn record_draw(render_pass: &mut wgpu::RenderPass<'_>, pass: &RunPass, prep: &Prepared) {
    if pass.indices.is_empty() {
        return;
    }
    render_pass.set_pipeline(&prep.pipeline);
    if let Some(bind_group) = &prep.bind_group {
        render_pass.set_bind_group(0, bind_group, &[]);
    }
    let [cr, cg, cb, ca] = pass.state.blend.constant.map(f64::from);
    render_pass.set_blend_constant(wgpu::Color { r: cr, g: cg, b: cb, a: ca });
    render_pass.set_stencil_reference(u32::from(pass.state.stencil.reference));
    render_pass.set_vertex_buffer(0, prep.vertex_buffer.slice(..));
    render_pass.set_index_buffer(prep.index_buffer.slice(..), wgpu::IndexFormat::Uint32);
    render_pass.draw_indexed(0..pass.indices.len() as u32, 0, 0..1);
}

/// The frame's main colour target and its depth/stencil buffer, with the
/// depth format.
fn main_targets(
    device: &wgpu::Device,
    target: &Target,
) -> (wgpu::Texture, wgpu::Texture, wgpu::TextureFormat) {
    let size = wgpu::Extent3d { width: target.width, height: target.height, depth_or_array_layers: 1 };
    let color = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("shadec colour target"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: target.color_format.wgpu(),
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let depth_format = match target.depth_format {
        DepthFormat::Depth24PlusStencil8 => wgpu::TextureFormat::Depth24PlusStencil8,
        DepthFormat::Depth32Float => wgpu::TextureFormat::Depth32Float,
    };
    let depth = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("shadec depth/stencil"),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: depth_format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    (color, depth, depth_format)
}

/// Each pass's GPU objects ([`prepare`]), its rendered textures viewed as
/// the pass samples them: a scratch copy of its own target, a whole array
/// for a fat texture, a depth snapshot for a depth read.
fn prepare_passes(
    gpu: &Gpu,
    target: &Target,
    passes: &[RunPass],
    modules: Vec<super::Modules>,
    textures: &RenderedTargets,
    snapshots: &DepthSnapshots,
    depth_format: wgpu::TextureFormat,
) -> Vec<Prepared> {
    passes
        .iter()
        .zip(modules)
        .enumerate()
        .map(|(pass_idx, (pass, module))| {
            let (color_format, own) = match &pass.target {
                PassTarget::Main => (target.color_format.wgpu(), None),
                PassTarget::Texture(t) => (t.format.wgpu(), Some(t.name.as_str())),
            };
            let view_of = |slot: usize, data: &TextureData| -> Option<wgpu::TextureView> {
                match data {
                    TextureData::Rendered { name, array } => {
                        let (t, scratch, _) = &textures[name];
                        let t = if Some(name.as_str()) == own { scratch } else { t };
                        let dimension = if *array {
                            wgpu::TextureViewDimension::D2Array
                        } else {
                            wgpu::TextureViewDimension::D2
                        };
                        Some(t.create_view(&wgpu::TextureViewDescriptor {
                            dimension: Some(dimension),
                            base_array_layer: 0,
                            array_layer_count: if *array { None } else { Some(1) },
                            ..Default::default()
                        }))
                    }
                    TextureData::RenderedCube { name } => {
                        let (t, scratch, _) = &textures[name];
                        let t = if Some(name.as_str()) == own { scratch } else { t };
                        Some(t.create_view(&wgpu::TextureViewDescriptor {
                            dimension: Some(wgpu::TextureViewDimension::Cube),
                            base_array_layer: 0,
                            array_layer_count: Some(6),
                            mip_level_count: Some(1),
                            ..Default::default()
                        }))
                    }
                    TextureData::RenderedDepth { .. } | TextureData::RenderedStencil { .. } => {
                        Some(snapshots[&(pass_idx, slot)].0.create_view(&Default::default()))
                    }
                    _ => None,
                }
            };
            prepare(gpu, pass, module, depth_format, color_format, &view_of)
        })
        .collect()
}

/// The buffer the main target is copied into, with its padded and
/// unpadded row sizes in bytes.
fn readback_buffer(device: &wgpu::Device, target: &Target) -> (wgpu::Buffer, u32, u32) {
    // Copy out with rows padded to wgpu's 256-byte alignment.
    let unpadded_row = target.width * target.color_format.bytes_per_pixel();
    let padded_row =
        unpadded_row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("shadec readback"),
        size: u64::from(padded_row) * u64::from(target.height),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    (readback, padded_row, unpadded_row)
}
