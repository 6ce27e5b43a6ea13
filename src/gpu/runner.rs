//! A headless wgpu runner: renders a list of passes into one offscreen RGBA8
//! target with one depth/stencil buffer, in order, and reads the image back.
//!
//! The passes carry the same fixed-function state as the CPU rasterizer
//! (`renderer::RenderState`: cull, depth, stencil, GL blending), so one pass
//! plan can drive both renderers and their images can be compared.
//!
//! Conventions a shader must follow:
//! - Vertex attribute `i` is `@location(i)`, `f32` × `VertexData::components[i]`;
//!   attribute 0 is the position by convention (the shader decides).
//! - Bind group 0: `@binding(0)` the uniform block (when `uniforms` is set);
//!   texture `i` at `@binding(1 + 2i)` and its sampler at `@binding(2 + 2i)`.
//! - Clip space is wgpu's: z in [0, 1] (GL's is [−1, 1]), y up; front faces
//!   are counter-clockwise, as in the CPU renderer. Row 0 of the image is the
//!   top (y = +1).
//!
//! Every shader is parsed and validated by naga before wgpu sees it, so a bad
//! shader is a `GpuError::InvalidShader` with naga's message; every wgpu
//! error is caught in an error scope, so nothing here panics on bad input.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

use image::RgbaImage;
use wgpu::util::DeviceExt;

use crate::pipeline::{
    BlendEquation, BlendFactor, BlendState, CompareFunc, CullMode, RenderState, StencilOp, StencilState,
};

/// What went wrong, with what to do about it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GpuError {
    /// No adapter (no GPU, no software driver).
    #[error(
        "no GPU adapter found ({0}): install Mesa's software drivers: apt-get install mesa-vulkan-drivers libvulkan1"
    )]
    NoAdapter(String),
    /// An adapter exists but refused to give a device.
    #[error("the GPU adapter `{adapter}` refused to create a device: {message}")]
    NoDevice { adapter: String, message: String },
    /// naga rejected the shader (parse or validation), or an entry point is missing.
    #[error("invalid shader in pass `{pass}`:\n{message}")]
    InvalidShader { pass: String, message: String },
    /// The pass description is inconsistent (sizes, indices, formats).
    #[error("invalid input in pass `{pass}`: {message}")]
    InvalidInput { pass: String, message: String },
    /// wgpu reported an error (validation, out of memory, internal).
    #[error("wgpu error: {0}")]
    Wgpu(String),
    /// Reading the image back failed.
    #[error("reading the image back failed: {0}")]
    Readback(String),
}

/// An instance, adapter, device and queue. Create one per thread or test;
/// creating several at once is fine.
pub struct Gpu {
    adapter: wgpu::Adapter,
    device: wgpu::Device,
    queue: wgpu::Queue,
}

impl Gpu {
    /// Picks an adapter (honours `WGPU_BACKEND`, `WGPU_ADAPTER_NAME`, …) and
    /// creates a device with the adapter's own limits.
    pub fn new() -> Result<Gpu, GpuError> {
        super::runtime_dir::ensure();
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let options = wgpu::RequestAdapterOptions { compatible_surface: None, ..Default::default() };
        let adapter = pollster::block_on(instance.request_adapter(&options))
            .map_err(|err| GpuError::NoAdapter(err.to_string()))?;
        let descriptor = wgpu::DeviceDescriptor {
            label: Some("shadec runner"),
            // 16-bit unorm textures, where the adapter has them: exact
            // fidelity's uploads (`TexelUpload::Rgba16`).
            // and timestamp queries, where it has them: the frame's GPU time.
            required_features: adapter.features()
                & (wgpu::Features::TEXTURE_FORMAT_16BIT_NORM | wgpu::Features::TIMESTAMP_QUERY),
            required_limits: adapter.limits(),
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor)).map_err(|err| {
            GpuError::NoDevice { adapter: adapter.get_info().name, message: err.to_string() }
        })?;
        // Errors are caught in scopes around each run; anything that escapes
        // them is printed, never turned into a panic (wgpu's default).
        device.on_uncaptured_error(Arc::new(|err| eprintln!("wgpu: uncaptured error: {err}")));
        Ok(Gpu { adapter, device, queue })
    }

    pub fn adapter_info(&self) -> wgpu::AdapterInfo {
        self.adapter.get_info()
    }

    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Whether [`TexelUpload::Rgba16`] textures are uploaded as
    /// `Rgba16Unorm` (else rounded to `Rgba8Unorm`).
    pub fn filters_16bit_norm(&self) -> bool {
        self.device.features().contains(wgpu::Features::TEXTURE_FORMAT_16BIT_NORM)
    }
}

impl fmt::Display for Gpu {
    /// `llvmpipe (LLVM 15.0.6, 256 bits) [Vulkan, Cpu, driver llvmpipe: Mesa 22.3.6]`.
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let info = self.adapter.get_info();
        write!(
            f,
            "{} [{:?}, {:?}, driver {}: {}]",
            info.name, info.backend, info.device_type, info.driver, info.driver_info
        )
    }
}

/// The shader of a pass: WGSL text or a module built in memory.
// One per pass, built once and moved: boxing the module would buy nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum ShaderSource {
    Wgsl(String),
    Naga(naga::Module),
}

/// A shader and the two entry points a pass uses.
#[derive(Clone, Debug)]
pub struct RunShader {
    pub source: ShaderSource,
    pub vertex_entry: String,
    pub fragment_entry: String,
}

/// Interleaved `f32` vertices: attribute `i` has `components[i]` floats
/// (1 to 4) and is `@location(i)`.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexData {
    pub floats: Vec<f32>,
    pub components: Vec<u32>,
}

/// Texel filtering, for magnification and minification (one mip level only).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Nearest,
    Linear,
}

/// What texture coordinates outside [0, 1] do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AddressMode {
    ClampToEdge,
    Repeat,
    MirrorRepeat,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SamplerSettings {
    pub mag: Filter,
    pub min: Filter,
    pub address: AddressMode,
    /// Between mip levels (only for [`TextureData::D2Mipmapped`]); `None`:
    /// level 0 only.
    pub mipmap: Option<Filter>,
}

impl SamplerSettings {
    pub const NEAREST_CLAMP: SamplerSettings = SamplerSettings {
        mag: Filter::Nearest,
        min: Filter::Nearest,
        address: AddressMode::ClampToEdge,
        mipmap: None,
    };
    pub const LINEAR_CLAMP: SamplerSettings = SamplerSettings {
        mag: Filter::Linear,
        min: Filter::Linear,
        address: AddressMode::ClampToEdge,
        mipmap: None,
    };
}

/// Texels (unorm, not sRGB: the framebuffer is linear, as in the papers) in
/// the layout of [`RunTexture::texels`], or a texture rendered in the run.
#[derive(Clone, Debug, PartialEq)]
pub enum TextureData {
    /// `width × height` texels, row 0 at texture coordinate v = 0.
    D2 { width: u32, height: u32, rgba: Vec<u8> },
    /// Six `size × size` faces in wgpu/GL order +X, −X, +Y, −Y, +Z, −Z.
    Cube { size: u32, rgba: Vec<u8> },
    /// A 2D texture with its mip chain: `levels[k]` is
    /// `max(1, width >> k) × max(1, height >> k)` texels, row 0 at v = 0.
    D2Mipmapped { width: u32, height: u32, levels: Vec<Vec<u8>> },
    /// The texture an earlier pass of the same run rendered
    /// ([`PassTarget::Texture`] of that name): all its layers as a
    /// `texture_2d_array` when `array` (a fat texture), else its first
    /// layer as a `texture_2d`. A pass that samples its own target reads a
    /// copy taken just before it (Pipeline Grammar, eq. (16): `T δu ← p T δu`).
    Rendered { name: String, array: bool },
    /// The depth buffer of a rendered texture (`None`: of the main target)
    /// as it is just before the pass, in `.x` of an `R32Float` texture —
    /// `z C′ …` read in a shader (Pipeline Grammar, Section 3.5, shadow mask).
    /// Unfilterable: a unit of this kind samples through a nearest,
    /// non-filtering sampler.
    RenderedDepth { name: Option<String> },
}

/// A texture a pass reads with `textureLoad` only, at `binding` of group 0
/// (codegen's `PassShader::target_copies`): [`TextureData::RenderedDepth`]
/// or [`TextureData::Rendered`].
#[derive(Clone, Debug, PartialEq)]
pub struct LoadedTexture {
    pub binding: u32,
    pub data: TextureData,
}

/// Where a pass draws.
#[derive(Clone, Debug, PartialEq)]
pub enum PassTarget {
    /// The [`Target`] of [`run_passes`]: the picture read back.
    Main,
    /// A texture the plan renders for later passes to sample
    /// ([`TextureData::Rendered`]), created and cleared (transparent black,
    /// depth 1) before its first pass.
    Texture(RenderedTexture),
}

/// A texture rendered during a run. A fat texture (Pipeline Grammar, eq. (5), (15);
/// `codegen::fat_layers`) has one array layer per member, and a pass
/// with `outputs` colour outputs writes layers `0..outputs`.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderedTexture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub layers: u32,
    pub format: ColorTarget,
}

#[derive(Clone, Debug, PartialEq)]
pub struct RunTexture {
    pub data: TextureData,
    pub sampler: SamplerSettings,
    /// How the texel bytes of `data` are laid out and uploaded.
    pub texels: TexelUpload,
}

/// The texel format a [`TextureData`] image is uploaded in: what a texture
/// unit filters, and at which precision (`textures::unit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TexelUpload {
    /// `Rgba8Unorm`, 4 bytes a texel. lavapipe filters it in 8.8 fixed
    /// point with 8-bit results, as the papers' hardware did.
    Rgba8,
    /// `Rgba16Unorm`, four native-endian `u16` (8 bytes) a texel; 8-bit
    /// values k/255 are exact (k·257). Filtered in float: exact fidelity.
    /// On a device without `TEXTURE_FORMAT_16BIT_NORM` the runner uploads
    /// it rounded to `Rgba8Unorm` (see [`Gpu::filters_16bit_norm`]).
    Rgba16,
}

impl TexelUpload {
    pub fn bytes_per_texel(self) -> usize {
        match self {
            TexelUpload::Rgba8 => 4,
            TexelUpload::Rgba16 => 8,
        }
    }
}

/// One draw: a shader, a triangle list and the fixed-function state.
#[derive(Clone, Debug)]
pub struct RunPass {
    /// Names the pass in errors.
    pub label: String,
    pub shader: RunShader,
    pub vertices: VertexData,
    /// Triangle list, three indices per triangle.
    pub indices: Vec<u32>,
    pub textures: Vec<RunTexture>,
    /// The uniform block's bytes (WGSL layout), padded here to 16 bytes.
    pub uniforms: Option<Vec<u8>>,
    pub state: RenderState,
    pub target: PassTarget,
    /// Textures read with `textureLoad`, after the units' bindings.
    pub loaded: Vec<LoadedTexture>,
    /// Colour outputs of the fragment stage (`@location(0..outputs)`): 1,
    /// or a fat texel's members into the layers of a [`PassTarget::Texture`].
    pub outputs: u32,
}

/// The depth/stencil buffer's format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthFormat {
    /// Depth and an 8-bit stencil; required when any pass uses the stencil.
    Depth24PlusStencil8,
    Depth32Float,
}

/// The offscreen target and what it is cleared to before the first pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Target {
    pub width: u32,
    pub height: u32,
    pub clear_color: [f32; 4],
    pub clear_depth: f32,
    pub clear_stencil: u8,
    pub depth_format: DepthFormat,
    pub color_format: ColorTarget,
}

/// The colour target's format. The picture read back is RGBA8 either way;
/// a float target keeps the values *between* passes in float, as the CPU
/// renderer's `f32` mode does ("the same plan in float"), so that
/// multipass plans can be compared with it without the 8-bit rounding of
/// every intermediate framebuffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ColorTarget {
    /// `Rgba8Unorm`: what a GPU of the papers' era had (and the default).
    Rgba8,
    /// `Rgba16Float`: blendable everywhere (WebGPU core), 11-bit mantissa.
    Rgba16Float,
}

impl ColorTarget {
    fn wgpu(self) -> wgpu::TextureFormat {
        match self {
            ColorTarget::Rgba8 => wgpu::TextureFormat::Rgba8Unorm,
            ColorTarget::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
        }
    }
    fn bytes_per_pixel(self) -> u32 {
        match self {
            ColorTarget::Rgba8 => 4,
            ColorTarget::Rgba16Float => 8,
        }
    }
}

impl Target {
    /// Cleared to transparent black, depth 1, stencil 0; depth and stencil;
    /// an RGBA8 colour target.
    pub fn new(width: u32, height: u32) -> Target {
        Target {
            width,
            height,
            clear_color: [0.0; 4],
            clear_depth: 1.0,
            clear_stencil: 0,
            depth_format: DepthFormat::Depth24PlusStencil8,
            color_format: ColorTarget::Rgba8,
        }
    }

    /// The same with a float colour target ([`ColorTarget::Rgba16Float`]).
    pub fn float(width: u32, height: u32) -> Target {
        Target { color_format: ColorTarget::Rgba16Float, ..Target::new(width, height) }
    }
}

/// Parses (WGSL) and validates a shader with naga, and checks that both
/// entry points exist with the right stages.
pub fn validate_shader(pass: &str, shader: &RunShader) -> Result<naga::Module, GpuError> {
    let invalid = |message: String| GpuError::InvalidShader { pass: pass.to_string(), message };
    let module = match &shader.source {
        ShaderSource::Wgsl(text) => {
            naga::front::wgsl::parse_str(text).map_err(|err| invalid(err.emit_to_string(text)))?
        }
        ShaderSource::Naga(module) => module.clone(),
    };
    let mut validator = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    );
    if let Err(err) = validator.validate(&module) {
        return Err(invalid(match &shader.source {
            ShaderSource::Wgsl(text) => err.emit_to_string(text),
            ShaderSource::Naga(_) => error_chain(&err),
        }));
    }
    for (name, stage) in [
        (&shader.vertex_entry, naga::ShaderStage::Vertex),
        (&shader.fragment_entry, naga::ShaderStage::Fragment),
    ] {
        if !module.entry_points.iter().any(|ep| &ep.name == name && ep.stage == stage) {
            let found: Vec<String> =
                module.entry_points.iter().map(|ep| format!("{} ({:?})", ep.name, ep.stage)).collect();
            return Err(invalid(format!(
                "no {stage:?} entry point named `{name}`; the module has: {}",
                if found.is_empty() { "none".to_string() } else { found.join(", ") }
            )));
        }
    }
    Ok(module)
}

/// Renders `passes` in order into one RGBA8 target and reads it back.
/// The first pass clears colour, depth and stencil; later passes load them.
pub fn run_passes(gpu: &Gpu, target: &Target, passes: &[RunPass]) -> Result<RgbaImage, GpuError> {
    Frame::prepare(gpu, target, passes)?.draw(gpu)
}

/// A frame's GPU objects, made once (pipelines, bind groups,
/// uploads and render targets per scene, not per frame); [`Frame::draw`]
/// then only records, submits and reads back.
pub struct Frame<'a> {
    target: &'a Target,
    passes: &'a [RunPass],
    color: wgpu::Texture,
    depth: wgpu::Texture,
    depth_view: wgpu::TextureView,
    /// Rendered textures: (texture, scratch copy, depth/stencil).
    textures: BTreeMap<String, (wgpu::Texture, wgpu::Texture, wgpu::Texture)>,
    texture_depth_views: BTreeMap<String, wgpu::TextureView>,
    snapshots: BTreeMap<(usize, usize), (wgpu::Texture, Option<String>)>,
    depth_copier: Option<DepthCopier>,
    prepared: Vec<Prepared>,
    readback: wgpu::Buffer,
    padded_row: u32,
    unpadded_row: u32,
    /// Timestamps around every render pass, where the device has them.
    timer: Option<super::timer::Timer>,
    /// The render passes the last submission recorded.
    recorded: std::cell::Cell<usize>,
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

/// Runs `f` inside wgpu error scopes and turns what they caught into an
/// error. wgpu panics on scopes popped out of order, so `f` returns no early
/// error of its own between the push and the pops.
fn in_error_scopes<T>(device: &wgpu::Device, f: impl FnOnce() -> T) -> Result<T, GpuError> {
    let [validation, out_of_memory, internal] =
        [wgpu::ErrorFilter::Validation, wgpu::ErrorFilter::OutOfMemory, wgpu::ErrorFilter::Internal]
            .map(|filter| device.push_error_scope(filter));
    let out = f();
    let errors = [internal.pop(), out_of_memory.pop(), validation.pop()].map(pollster::block_on);
    match errors.into_iter().flatten().next() {
        Some(err) => Err(GpuError::Wgpu(err.to_string())),
        None => Ok(out),
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
    fn create(
        gpu: &Gpu,
        target: &'a Target,
        passes: &'a [RunPass],
        rendered: BTreeMap<String, RenderedTexture>,
        modules: Vec<naga::Module>,
    ) -> Frame<'a> {
        let device = &gpu.device;

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
        let depth_view = depth.create_view(&Default::default());
        let textures = rendered_targets(device, &rendered, depth_format);
        let snapshots = depth_snapshots(device, target, passes, &rendered);
        let depth_copier = (!snapshots.is_empty()).then(|| DepthCopier::new(device));

        let prepared: Vec<Prepared> = passes
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
                        TextureData::RenderedDepth { .. } => {
                            Some(snapshots[&(pass_idx, slot)].0.create_view(&Default::default()))
                        }
                        _ => None,
                    }
                };
                prepare(gpu, pass, module, depth_format, color_format, &view_of)
            })
            .collect();

        let texture_depth_views: BTreeMap<String, wgpu::TextureView> = textures
            .iter()
            .map(|(name, (_, _, depth))| (name.clone(), depth.create_view(&Default::default())))
            .collect();
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
            prepared,
            readback,
            padded_row,
            unpadded_row,
            // Every pass, and the clear of an undrawn main target.
            timer: super::timer::Timer::new(device, passes.len() + 1),
            recorded: std::cell::Cell::new(0),
        }
    }

    /// The depth buffer a snapshot copies: the main one or a rendered texture's.
    fn depth_source(&self, name: &Option<String>) -> &wgpu::Texture {
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
    fn texture_target_views(
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
            .any(|d| matches!(d, TextureData::Rendered { name, .. } if *name == t.name))
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
                    ..Default::default()
                })
            })
            .collect()
    }

    fn submit(&self, gpu: &Gpu) {
        let device = &gpu.device;
        let (target, passes, prepared) = (self.target, self.passes, &self.prepared);
        let texture_depth_views = &self.texture_depth_views;
        let (color, depth_view, snapshots) = (&self.color, &self.depth_view, &self.snapshots);
        let (padded_row, readback) = (self.padded_row, &self.readback);
        let size = wgpu::Extent3d { width: target.width, height: target.height, depth_or_array_layers: 1 };
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
            for ((_, _), (copy, name)) in snapshots.range((pass_idx, 0)..(pass_idx + 1, 0)) {
                #[allow(
                    clippy::expect_used,
                    reason = "`prepare` makes the copier whenever it plans a snapshot"
                )]
                let copier = self.depth_copier.as_ref().expect("made when there are snapshots");
                copier.copy(device, &mut encoder, self.depth_source(name), copy);
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
            let (Some(pass), Some(prep)) = (pass, prep) else {
                continue;
            };
            if pass.indices.is_empty() {
                continue;
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

        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: color,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row),
                    rows_per_image: Some(target.height),
                },
            },
            size,
        );
        if let Some(timer) = &self.timer {
            timer.resolve(&mut encoder, recorded);
        }
        self.recorded.set(recorded);
        gpu.queue.submit([encoder.finish()]);
    }

    fn read_back(&self, device: &wgpu::Device) -> Result<RgbaImage, GpuError> {
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

/// Copies a depth buffer into an `R32Float` texture (`.x`): a full-screen
/// triangle loading the depth aspect texel by texel — a depth buffer can
/// neither be sampled as a colour nor copied into one.
struct DepthCopier {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

const DEPTH_COPY_WGSL: &str = "
@group(0) @binding(0) var depth: texture_depth_2d;
@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let p = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(p * 2.0 - 1.0, 0.0, 1.0);
}
@fragment
fn fs_main(@builtin(position) at: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(textureLoad(depth, vec2<i32>(at.xy), 0), 0.0, 0.0, 1.0);
}
";

impl DepthCopier {
    fn new(device: &wgpu::Device) -> DepthCopier {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("shadec depth copy"),
            source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(DEPTH_COPY_WGSL)),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadec depth copy"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Depth,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadec depth copy"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadec depth copy"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: wgpu::TextureFormat::R32Float,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        DepthCopier { pipeline, layout }
    }

    fn copy(
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

/// The GPU objects of one pass.
struct Prepared {
    pipeline: wgpu::RenderPipeline,
    bind_group: Option<wgpu::BindGroup>,
    vertex_buffer: wgpu::Buffer,
    index_buffer: wgpu::Buffer,
}

/// Sizes, indices and formats: what wgpu would reject late or not at all
/// (out-of-range indices are not an error on every backend).
/// A rendered source names a texture some pass of the run renders.
fn check_rendered(data: &TextureData, rendered: &BTreeMap<String, RenderedTexture>) -> Result<(), String> {
    match data {
        TextureData::Rendered { name, .. } | TextureData::RenderedDepth { name: Some(name) }
            if !rendered.contains_key(name) =>
        {
            Err(format!("`{name}` is a rendered texture no pass of this run renders"))
        }
        _ => Ok(()),
    }
}

fn check_pass(
    pass: &RunPass,
    target: &Target,
    rendered: &BTreeMap<String, RenderedTexture>,
) -> Result<(), GpuError> {
    let invalid = |message: String| Err(GpuError::InvalidInput { pass: pass.label.clone(), message });
    let components = &pass.vertices.components;
    if components.is_empty() || components.iter().any(|&n| !(1..=4).contains(&n)) {
        return invalid(format!(
            "vertex attributes must have 1 to 4 components each, at least one attribute (position); got {components:?}"
        ));
    }
    let stride: u32 = components.iter().sum();
    if pass.vertices.floats.len() % stride as usize != 0 {
        return invalid(format!(
            "{} vertex floats is not a multiple of the vertex size {stride} ({components:?})",
            pass.vertices.floats.len()
        ));
    }
    let n_vertices = pass.vertices.floats.len() / stride as usize;
    if pass.indices.len() % 3 != 0 {
        return invalid(format!("{} indices is not a whole number of triangles", pass.indices.len()));
    }
    if let Some(&bad) = pass.indices.iter().find(|&&i| i as usize >= n_vertices) {
        return invalid(format!("index {bad} is out of range: the pass has {n_vertices} vertices"));
    }
    for (texture_idx, texture) in pass.textures.iter().enumerate() {
        let bpt = texture.texels.bytes_per_texel();
        let (expected, what) = match texture.data {
            TextureData::D2 { width, height, .. } => (width as usize * height as usize * bpt, "2D"),
            TextureData::Cube { size, .. } => (size as usize * size as usize * bpt * 6, "cube"),
            TextureData::Rendered { .. } | TextureData::RenderedDepth { .. } => {
                check_rendered(&texture.data, rendered).map_err(|message| GpuError::InvalidInput {
                    pass: pass.label.clone(),
                    message: format!("texture {texture_idx}: {message}"),
                })?;
                continue;
            }
            TextureData::D2Mipmapped { width, height, ref levels } => {
                for (k, level) in levels.iter().enumerate() {
                    let need = (width >> k).max(1) as usize * (height >> k).max(1) as usize * bpt;
                    if level.len() != need {
                        return invalid(format!(
                            "mip level {k} of texture {texture_idx} has {} bytes, needs {need}",
                            level.len()
                        ));
                    }
                }
                (width as usize * height as usize * bpt, "mipmapped 2D")
            }
        };
        let rgba = match &texture.data {
            TextureData::D2 { rgba, .. } | TextureData::Cube { rgba, .. } => rgba,
            TextureData::D2Mipmapped { levels, .. } => match levels.first() {
                Some(l) => l,
                None => return invalid(format!("mipmapped texture {texture_idx} has no levels")),
            },
            TextureData::Rendered { .. } | TextureData::RenderedDepth { .. } => continue,
        };
        if expected == 0 || rgba.len() != expected {
            return invalid(format!(
                "{what} texture {texture_idx} has {} bytes, its size needs {expected} ({:?}, non-empty)",
                rgba.len(),
                texture.texels
            ));
        }
    }
    if pass.state.stencil.enabled && target.depth_format != DepthFormat::Depth24PlusStencil8 {
        return invalid("the stencil test needs DepthFormat::Depth24PlusStencil8".to_string());
    }
    for l in &pass.loaded {
        if !matches!(l.data, TextureData::Rendered { .. } | TextureData::RenderedDepth { .. }) {
            return invalid(format!(
                "binding {}: only rendered textures are read with textureLoad",
                l.binding
            ));
        }
        check_rendered(&l.data, rendered).map_err(|message| GpuError::InvalidInput {
            pass: pass.label.clone(),
            message: format!("binding {}: {message}", l.binding),
        })?;
    }
    let layers = match &pass.target {
        PassTarget::Main => 1,
        PassTarget::Texture(t) => t.layers,
    };
    if pass.outputs == 0 || pass.outputs > layers {
        return invalid(format!("{} colour outputs into a target of {layers} layer(s)", pass.outputs));
    }
    Ok(())
}
/// Rendered textures, each with its own depth/stencil buffer, and a
/// scratch copy for passes that sample their own target.
fn rendered_targets(
    device: &wgpu::Device,
    rendered: &BTreeMap<String, RenderedTexture>,
    depth_format: wgpu::TextureFormat,
) -> BTreeMap<String, (wgpu::Texture, wgpu::Texture, wgpu::Texture)> {
    let mut textures: BTreeMap<String, (wgpu::Texture, wgpu::Texture, wgpu::Texture)> = BTreeMap::new();
    for (name, t) in rendered {
        let size = wgpu::Extent3d { width: t.width, height: t.height, depth_or_array_layers: t.layers };
        let make = |label: &str, format: wgpu::TextureFormat, usage: wgpu::TextureUsages, layers: u32| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { depth_or_array_layers: layers, ..size },
                mip_level_count: 1,
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
        let texture = make(name, t.format.wgpu(), usage, t.layers);
        let scratch = make(name, t.format.wgpu(), usage, t.layers);
        let depth = make(
            name,
            depth_format,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            1,
        );
        textures.insert(name.clone(), (texture, scratch, depth));
    }
    textures
}

/// Depth snapshots: per pass, per slot (units, then loaded textures) that
/// reads a depth buffer, an R32Float copy made just before the pass.
fn depth_snapshots(
    device: &wgpu::Device,
    target: &Target,
    passes: &[RunPass],
    rendered: &BTreeMap<String, RenderedTexture>,
) -> BTreeMap<(usize, usize), (wgpu::Texture, Option<String>)> {
    let depth_size = |name: &Option<String>| -> (u32, u32) {
        match name {
            None => (target.width, target.height),
            Some(n) => (rendered[n].width, rendered[n].height),
        }
    };
    let mut snapshots: BTreeMap<(usize, usize), (wgpu::Texture, Option<String>)> = BTreeMap::new();
    for (pass_idx, pass) in passes.iter().enumerate() {
        let slots = pass.textures.iter().map(|t| &t.data).chain(pass.loaded.iter().map(|l| &l.data));
        for (slot, data) in slots.enumerate() {
            if let TextureData::RenderedDepth { name } = data {
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
                snapshots.insert((pass_idx, slot), (copy, name.clone()));
            }
        }
    }
    snapshots
}

/// `view_of(slot, data)`: the view of a rendered source (slot: the unit,
/// then `units + i` for `loaded[i]`), `None` for data to upload.
fn prepare(
    gpu: &Gpu,
    pass: &RunPass,
    module: naga::Module,
    depth_format: wgpu::TextureFormat,
    color_format: wgpu::TextureFormat,
    view_of: &dyn Fn(usize, &TextureData) -> Option<wgpu::TextureView>,
) -> Prepared {
    let device = &gpu.device;
    let label = Some(pass.label.as_str());
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label,
        source: wgpu::ShaderSource::Naga(Cow::Owned(module)),
    });

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
        let binding = 1 + 2 * texture_idx as u32;
        let (view_dimension, view) = match view_of(texture_idx, &texture.data) {
            Some(view) => (
                if matches!(texture.data, TextureData::Rendered { array: true, .. }) {
                    wgpu::TextureViewDimension::D2Array
                } else {
                    wgpu::TextureViewDimension::D2
                },
                view,
            ),
            None => upload_texture(gpu, &texture.data, texture.texels),
        };
        // A depth snapshot (R32Float) is unfilterable: nearest, non-filtering.
        let depth = matches!(texture.data, TextureData::RenderedDepth { .. });
        layout_entries.push(wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: !depth },
                view_dimension,
                multisampled: false,
            },
            count: None,
        });
        layout_entries.push(wgpu::BindGroupLayoutEntry {
            binding: binding + 1,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Sampler(if depth {
                wgpu::SamplerBindingType::NonFiltering
            } else {
                wgpu::SamplerBindingType::Filtering
            }),
            count: None,
        });
        owned_views.push(view);
        let settings = if depth {
            SamplerSettings { address: texture.sampler.address, ..SamplerSettings::NEAREST_CLAMP }
        } else {
            texture.sampler
        };
        owned_samplers.push(device.create_sampler(&sampler_descriptor(&settings)));
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

    let pipeline = render_pipeline(device, pass, &shader, &pipeline_layout, (depth_format, color_format));
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
fn loaded_textures(
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

/// How a pass starts on its target: the first pass into a target clears it
/// (the main target to the frame's clear values, a rendered texture to
/// transparent black, depth 1, stencil 0), later ones load.
fn load_ops(
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
fn render_pipeline(
    device: &wgpu::Device,
    pass: &RunPass,
    shader: &wgpu::ShaderModule,
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
            module: shader,
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
fn bind_entries<'b>(
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
fn upload_texture(
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
        TextureData::D2Mipmapped { width, height, levels } => {
            (*width, *height, 1, levels.as_slice(), wgpu::TextureViewDimension::D2)
        }
        TextureData::Rendered { .. } | TextureData::RenderedDepth { .. } => {
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

fn sampler_descriptor(settings: &SamplerSettings) -> wgpu::SamplerDescriptor<'static> {
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

fn compare(func: CompareFunc) -> wgpu::CompareFunction {
    match func {
        CompareFunc::Never => wgpu::CompareFunction::Never,
        CompareFunc::Less => wgpu::CompareFunction::Less,
        CompareFunc::LessEqual => wgpu::CompareFunction::LessEqual,
        CompareFunc::Equal => wgpu::CompareFunction::Equal,
        CompareFunc::Greater => wgpu::CompareFunction::Greater,
        CompareFunc::GreaterEqual => wgpu::CompareFunction::GreaterEqual,
        CompareFunc::NotEqual => wgpu::CompareFunction::NotEqual,
        CompareFunc::Always => wgpu::CompareFunction::Always,
    }
}

/// GL's stencil state applies to both faces (`glStencilFunc`/`glStencilOp`).
fn stencil_state(stencil: &StencilState) -> wgpu::StencilState {
    if !stencil.enabled {
        return wgpu::StencilState::default();
    }
    let op = |op: StencilOp| match op {
        StencilOp::Keep => wgpu::StencilOperation::Keep,
        StencilOp::Zero => wgpu::StencilOperation::Zero,
        StencilOp::Replace => wgpu::StencilOperation::Replace,
        StencilOp::Incr => wgpu::StencilOperation::IncrementClamp,
        StencilOp::Decr => wgpu::StencilOperation::DecrementClamp,
        StencilOp::Invert => wgpu::StencilOperation::Invert,
        StencilOp::IncrWrap => wgpu::StencilOperation::IncrementWrap,
        StencilOp::DecrWrap => wgpu::StencilOperation::DecrementWrap,
    };
    let face = wgpu::StencilFaceState {
        compare: compare(stencil.func),
        fail_op: op(stencil.fail),
        depth_fail_op: op(stencil.depth_fail),
        pass_op: op(stencil.pass),
    };
    // Two-sided stencil: the back face's own pass operation.
    let back = wgpu::StencilFaceState { pass_op: op(stencil.back_pass.unwrap_or(stencil.pass)), ..face };
    wgpu::StencilState {
        front: face,
        back,
        read_mask: u32::from(stencil.read_mask),
        write_mask: u32::from(stencil.write_mask),
    }
}

fn blend_state(blend: &BlendState) -> wgpu::BlendState {
    let factor = |f: BlendFactor| match f {
        BlendFactor::Zero => wgpu::BlendFactor::Zero,
        BlendFactor::One => wgpu::BlendFactor::One,
        BlendFactor::SrcColor => wgpu::BlendFactor::Src,
        BlendFactor::OneMinusSrcColor => wgpu::BlendFactor::OneMinusSrc,
        BlendFactor::DstColor => wgpu::BlendFactor::Dst,
        BlendFactor::OneMinusDstColor => wgpu::BlendFactor::OneMinusDst,
        BlendFactor::SrcAlpha => wgpu::BlendFactor::SrcAlpha,
        BlendFactor::OneMinusSrcAlpha => wgpu::BlendFactor::OneMinusSrcAlpha,
        BlendFactor::DstAlpha => wgpu::BlendFactor::DstAlpha,
        BlendFactor::OneMinusDstAlpha => wgpu::BlendFactor::OneMinusDstAlpha,
        BlendFactor::ConstantColor => wgpu::BlendFactor::Constant,
        BlendFactor::OneMinusConstantColor => wgpu::BlendFactor::OneMinusConstant,
        BlendFactor::SrcAlphaSaturate => wgpu::BlendFactor::SrcAlphaSaturated,
    };
    let component = |src: BlendFactor, dst: BlendFactor| {
        let operation = match blend.equation {
            BlendEquation::Add => wgpu::BlendOperation::Add,
            BlendEquation::Subtract => wgpu::BlendOperation::Subtract,
            BlendEquation::ReverseSubtract => wgpu::BlendOperation::ReverseSubtract,
            BlendEquation::Min => wgpu::BlendOperation::Min,
            BlendEquation::Max => wgpu::BlendOperation::Max,
        };
        // GL ignores the factors of MIN and MAX; WebGPU requires them to be One.
        if matches!(blend.equation, BlendEquation::Min | BlendEquation::Max) {
            wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::One,
                dst_factor: wgpu::BlendFactor::One,
                operation,
            }
        } else {
            wgpu::BlendComponent { src_factor: factor(src), dst_factor: factor(dst), operation }
        }
    };
    wgpu::BlendState {
        color: component(blend.src_rgb, blend.dst_rgb),
        alpha: component(blend.src_alpha, blend.dst_alpha),
    }
}

fn write_mask([r, g, b, a]: [bool; 4]) -> wgpu::ColorWrites {
    let mut mask = wgpu::ColorWrites::empty();
    for (on, bit) in [
        (r, wgpu::ColorWrites::RED),
        (g, wgpu::ColorWrites::GREEN),
        (b, wgpu::ColorWrites::BLUE),
        (a, wgpu::ColorWrites::ALPHA),
    ] {
        if on {
            mask |= bit;
        }
    }
    mask
}

/// An error and its `source()` chain on one line each.
fn error_chain(err: &dyn std::error::Error) -> String {
    let mut text = err.to_string();
    let mut source = err.source();
    while let Some(cause) = source {
        text.push_str(&format!("\n  caused by: {cause}"));
        source = cause.source();
    }
    text
}

/// `Rgba16Unorm` texel bytes rounded to `Rgba8Unorm` (a device without
/// 16-bit unorm textures): k·257 → k, other values to the nearest 8-bit step.
fn narrow_to_8bit(texel_bytes: &[u8]) -> Vec<u8> {
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
