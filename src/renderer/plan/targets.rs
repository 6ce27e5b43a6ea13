//! The images a frame's passes render into and read back: a pass's
//! cleared target as its setup says ([`new_target`]), the framebuffers a
//! pass reads, and a rendered texture or temporary kept for later lookups
//! ([`Rendered`], fat-texel layers).

use std::collections::{BTreeMap, HashMap};

use crate::ir::{self, eval::Value, Expr, Module, Ty};
use crate::pipeline::{PassInterface, TargetFormat, TargetImage};
use crate::renderer::{ColorFormat, Framebuffer, RenderError};
use crate::textures::{Filter, Level, TexelFormat, Texture2D, TextureCube, Wrap};

use crate::numerics::Precision;

use super::shade::to_pixel;

/// A cleared image for a pass to render into, as its setup says
/// (`pipeline::TargetImage`): a texture declared 16-bit or float keeps what
/// is rendered into it (deferred shading's signed vectors) in half floats,
/// as the WGSL target's `Rgba16Float` (fixed9 and f32; exact keeps f32); a
/// fixed-point target (`rgba8`) is clamped to [0, 1] and rounded to k/255
/// as GL stores it ([`ColorFormat::Rgba8`], `f32` and `fixed9`, as wgpu's
/// `Rgba8Unorm`), which `exact` keeps clamped but unrounded in float
/// ([`ColorFormat::Unorm`]: the ideal the stores are measured against); a planner temporary keeps its value unclamped. One
/// of `pool` (images of earlier frames, [`super::PlanRenderer::recycle`])
/// of that size and format is taken before a new one is made, its clear
/// deferred ([`Framebuffer::reset_deferred`]): the caller settles it
/// ([`Framebuffer::settle`]) unless a plain draw into it comes first.
pub(super) fn new_target(
    target: &TargetImage,
    mode: Precision,
    format: ColorFormat,
    frame: (u32, u32),
    pool: &mut Vec<Framebuffer>,
) -> Result<Framebuffer, RenderError> {
    let format = match (mode, target.format) {
        (Precision::Exact, TargetFormat::Half) => ColorFormat::F32,
        (_, TargetFormat::Half) => ColorFormat::F16,
        (Precision::Exact, TargetFormat::Unorm8) => ColorFormat::Unorm,
        (Precision::F32 | Precision::Fixed9, TargetFormat::Unorm8) => ColorFormat::Rgba8,
        (_, TargetFormat::Frame) => format,
    };
    let (width, height) = target.extent.size(frame.0, frame.1);
    if let Some(at) = pool.iter().position(|fb| fb.fits(width, height, format)) {
        let mut fb = pool.swap_remove(at);
        // Cleared by the first draw's rasterizer tile by tile, or settled
        // by `PlanRenderer::render_with` before anything else reads it.
        fb.reset_deferred();
        return Ok(fb);
    }
    // `Framebuffer::new` clears to colour 0, depth 1, stencil 0.
    Framebuffer::new(width, height, format)
}

/// Whether the pass reads its own target's size or depth (`xs`, `δu`).
pub(super) fn reads_own_target(m: &Module, pi: &PassInterface) -> bool {
    let mut roots = vec![pi.output];
    roots.extend(pi.condition.into_iter().chain(pi.depth));
    m.reachable(&roots).into_iter().any(|h| matches!(m.exprs[h], Expr::Pixel { .. } | Expr::TexelCoord))
}

/// Snapshots of the framebuffers a pass reads (another's, or its own in a
/// screen pass), by framebuffer id.
pub(super) fn framebuffer_reads(
    m: &Module,
    pi: &PassInterface,
    targets: &BTreeMap<String, Framebuffer>,
) -> HashMap<u32, Framebuffer> {
    let mut reads: HashMap<u32, Framebuffer> = HashMap::new();
    let mut roots = vec![pi.output];
    roots.extend(pi.condition.into_iter().chain(pi.depth));
    for h in m.reachable(&roots) {
        if let Expr::FramebufferRead { framebuffer, .. } = m.exprs[h] {
            let fname = &m.framebuffers[framebuffer as usize].name;
            if let Some(fb) = targets.get(fname) {
                reads.entry(framebuffer).or_insert_with(|| fb.clone());
            }
        }
    }
    reads
}

/// A texture or temporary a pass rendered: its pixels (for lookups by
/// screen position) and a filtered texture (for lookups by coordinates).
pub(super) struct Rendered {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) pixels: Vec<[f32; 4]>,
    pub(super) texture: Texture2D,
    /// A texture declared `cube`: six faces, each the rendered image at
    /// the face's (s, t), clamped to its edge, level 0 (GL 1.3 §3.8.6: a
    /// cube map is six 2-D images; looked up by direction, Table 3.19).
    pub(super) cube: Option<Box<TextureCube>>,
}

impl Rendered {
    /// The texel at a pixel position (`T xs`, `T δπx`), or sampled at
    /// texture coordinates (level 0).
    pub(super) fn sample(&self, c: Value, coords_ty: Ty, filter: Filter) -> Value {
        if coords_ty == Ty::Position {
            match to_pixel(c, self.width, self.height, 0.0) {
                Some((x, y)) => self.pixels[(y * self.width + x) as usize].map(|v| v as f64),
                None => [0.0; 4],
            }
        } else {
            self.texture.sample(c[0] as f32, c[1] as f32, filter, 0.0).map(|v| v as f64)
        }
    }

    pub(super) fn from_framebuffer(fb: &Framebuffer, mipmap: bool, cube: bool, wrap: Wrap) -> Rendered {
        let pixels = fb.read_back_rgba_f32();
        let face = || {
            Texture2D::new(
                TexelFormat::F32,
                Wrap::ClampToEdge,
                Level::new(fb.width(), fb.height(), pixels.clone()),
            )
        };
        let cube = cube.then(|| Box::new(TextureCube { faces: std::array::from_fn(|_| face()) }));
        let t = Texture2D::new(TexelFormat::F32, wrap, Level::new(fb.width(), fb.height(), pixels.clone()));
        let texture = if mipmap { t.with_box_mipmaps() } else { t };
        Rendered { width: fb.width(), height: fb.height(), pixels, texture, cube }
    }
}

/// Per texture, the layers of its fat texels a bundle pass rendered (`T`,
/// `T#1`, `T#2`, …).
pub(super) fn fat_texel_layers<'a>(
    m: &Module,
    rendered: &'a BTreeMap<String, Rendered>,
) -> Vec<Vec<&'a Rendered>> {
    m.textures
        .iter()
        .zip(ir::fat_layers(m))
        .map(|(t, n)| {
            (0..n)
                .map_while(|i| rendered.get(&if i == 0 { t.name.clone() } else { format!("{}#{i}", t.name) }))
                .collect()
        })
        .collect()
}
