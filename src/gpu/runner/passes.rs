//! What a run is made of, as its callers describe it: each pass's shader,
//! vertices, textures (loaded, or rendered by an earlier pass), uniforms
//! and fixed-function state ([`RunPass`]), and the [`Target`] they render
//! into.

use crate::pipeline::RenderState;

/// The shader of a pass: WGSL text or a module built in memory.
// One per pass, built once and moved: boxing the module would buy nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
pub enum ShaderSource {
    Wgsl(String),
    Naga(naga::Module),
    /// A vertex stage in a module of its own before the fragment stage's:
    /// the vertex entry point is read from `vertex`, the fragment entry
    /// point from `fragment` (a pass's vertex program translated to WGSL,
    /// NV_vertex_program, before the WGSL backend's fragment stage).
    Staged {
        vertex: Box<ShaderSource>,
        fragment: Box<ShaderSource>,
    },
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

/// How a texture unit's sampler filters and addresses its texture.
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
    /// Nearest texel, clamped to the edge, level 0 only.
    pub const NEAREST_CLAMP: SamplerSettings = SamplerSettings {
        mag: Filter::Nearest,
        min: Filter::Nearest,
        address: AddressMode::ClampToEdge,
        mipmap: None,
    };
    /// Bilinear, clamped to the edge, level 0 only.
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
    /// `layers` images of `width × height` texels one after another, as a
    /// `texture_2d_array` (a dual-paraboloid map: front, back).
    D2Array { width: u32, height: u32, layers: u32, rgba: Vec<u8> },
    /// A 2D texture with its mip chain: `levels[k]` is
    /// `max(1, width >> k) × max(1, height >> k)` texels, row 0 at v = 0.
    D2Mipmapped { width: u32, height: u32, levels: Vec<Vec<u8>> },
    /// The texture an earlier pass of the same run rendered
    /// ([`PassTarget::Texture`] of that name): all its layers as a
    /// `texture_2d_array` when `array` (a fat texture), else its first
    /// layer as a `texture_2d`. A pass that samples its own target reads a
    /// copy taken just before it (Pipeline Grammar, eq. (16): `T δu ← p T δu`).
    Rendered { name: String, array: bool },
    /// A cube map an earlier pass of the run rendered (a
    /// [`RenderedTexture`] with `cube`: its six layers the faces +X, −X,
    /// +Y, −Y, +Z, −Z), as a `texture_cube`.
    RenderedCube { name: String },
    /// The depth buffer of a rendered texture (`None`: of the main target)
    /// as it is just before the pass, in `.x` of an `R32Float` texture —
    /// `z C′ …` read in a shader (Pipeline Grammar, Section 3.5, shadow mask).
    /// Unfilterable: a unit of this kind samples through a nearest,
    /// non-filtering sampler.
    RenderedDepth { name: Option<String> },
    /// The stencil buffer of a rendered texture (`None`: of the main
    /// target) as it is just before the pass, s/255 in `.x` of an
    /// `R32Float` texture — `σ C xs` read in a shader (Pipeline Grammar,
    /// Section 3.5). Unfilterable, as [`TextureData::RenderedDepth`].
    RenderedStencil { name: Option<String> },
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
    /// The [`Target`] of [`run_passes`](super::run_passes): the picture read back.
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
    /// Mip levels: 1, level 0 only; more, a texture declared `mipmap`
    /// whose levels 1.. are box filtered from level 0 after the passes
    /// into it (`mips::full_chain` for the whole chain).
    pub mip_levels: u32,
    /// A cube map rendered over its texels (square, six layers, one
    /// level): the passes into it draw layer 0, and after the last of them
    /// layer 0 is copied into the other five — six faces, each the
    /// rendered image at the face's (s, t) (GL 1.3 §3.8.6) — sampled as
    /// [`TextureData::RenderedCube`].
    pub cube: bool,
}

/// A texture unit of a pass: its image and how it is sampled.
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
    /// it rounded to `Rgba8Unorm` (see [`Gpu::filters_16bit_norm`](super::Gpu::filters_16bit_norm)).
    Rgba16,
}

impl TexelUpload {
    /// Bytes per texel in the upload.
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
    pub(super) fn wgpu(self) -> wgpu::TextureFormat {
        match self {
            ColorTarget::Rgba8 => wgpu::TextureFormat::Rgba8Unorm,
            ColorTarget::Rgba16Float => wgpu::TextureFormat::Rgba16Float,
        }
    }
    pub(super) fn bytes_per_pixel(self) -> u32 {
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
