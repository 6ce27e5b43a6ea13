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

use std::fmt;
use std::sync::Arc;

use image::RgbaImage;

mod depth;
mod fixed_function;
mod frame;
mod fullscreen;
mod mips;
mod passes;
mod prepare;
mod resources;

pub use frame::{Frame, TimedFrame};
pub use mips::full_chain;
pub use passes::{
    AddressMode, ColorTarget, DepthFormat, Filter, LoadedTexture, PassTarget, RenderedTexture, RunPass,
    RunShader, RunTexture, SamplerSettings, ShaderSource, Target, TexelUpload, TextureData, VertexData,
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

    /// The adapter's name, backend, type and driver.
    pub fn adapter_info(&self) -> wgpu::AdapterInfo {
        self.adapter.get_info()
    }

    /// The wgpu device the runner draws with.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The device's queue.
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

/// A pass's shader as naga modules: `vertex` holds the vertex entry point,
/// and the fragment entry point too unless `fragment` is given.
#[derive(Debug)]
pub struct Modules {
    pub vertex: naga::Module,
    pub fragment: Option<naga::Module>,
}

/// Parses (WGSL) and validates a shader with naga, and checks that both
/// entry points exist with the right stages.
pub fn validate_shader(pass: &str, shader: &RunShader) -> Result<Modules, GpuError> {
    let (vertex, fragment) = match &shader.source {
        ShaderSource::Staged { vertex, fragment } => {
            (module_of(pass, vertex)?, Some(module_of(pass, fragment)?))
        }
        source => (module_of(pass, source)?, None),
    };
    has_entry(pass, &vertex, &shader.vertex_entry, naga::ShaderStage::Vertex)?;
    has_entry(
        pass,
        fragment.as_ref().unwrap_or(&vertex),
        &shader.fragment_entry,
        naga::ShaderStage::Fragment,
    )?;
    Ok(Modules { vertex, fragment })
}

/// One module of a shader, parsed and validated.
fn module_of(pass: &str, source: &ShaderSource) -> Result<naga::Module, GpuError> {
    let invalid = |message: String| GpuError::InvalidShader { pass: pass.to_string(), message };
    let module = match source {
        ShaderSource::Wgsl(text) => {
            naga::front::wgsl::parse_str(text).map_err(|err| invalid(err.emit_to_string(text)))?
        }
        ShaderSource::Naga(module) => module.clone(),
        ShaderSource::Staged { .. } => {
            return Err(invalid("a staged shader's stages are modules, not staged shaders".to_string()))
        }
    };
    if let Err(err) = crate::backends::wgsl::validate::validate(&module) {
        return Err(invalid(match source {
            ShaderSource::Wgsl(text) => err.emit_to_string(text),
            _ => error_chain(&err),
        }));
    }
    Ok(module)
}

/// The module has an entry point `name` of `stage`.
fn has_entry(
    pass: &str,
    module: &naga::Module,
    name: &str,
    stage: naga::ShaderStage,
) -> Result<(), GpuError> {
    if module.entry_points.iter().any(|ep| ep.name == name && ep.stage == stage) {
        return Ok(());
    }
    let found: Vec<String> =
        module.entry_points.iter().map(|ep| format!("{} ({:?})", ep.name, ep.stage)).collect();
    Err(GpuError::InvalidShader {
        pass: pass.to_string(),
        message: format!(
            "no {stage:?} entry point named `{name}`; the module has: {}",
            if found.is_empty() { "none".to_string() } else { found.join(", ") }
        ),
    })
}

/// Renders `passes` in order into one RGBA8 target and reads it back.
/// The first pass clears colour, depth and stencil; later passes load them.
pub fn run_passes(gpu: &Gpu, target: &Target, passes: &[RunPass]) -> Result<RgbaImage, GpuError> {
    Frame::prepare(gpu, target, passes)?.draw(gpu)
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
