//! The scene binder: what a program's leaves are worth for a scene — the
//! inputs of [`crate::pipeline::PassInterface`] that every executor binds.
//!
//! - **Vertex leaves**, per mesh vertex, as `[f64; 4]` (a point has w = 1, a
//!   direction w = 0, coordinates z = w = 0):
//!   - `x` ([`Expr::VertexPosition`]): the model-space position;
//!   - `u x` ([`Expr::TexCoord`]): the mesh UVs for a set the program does
//!     not generate (`u`, `u′`, … all read the mesh's one UV set); a set
//!     written by a texgen statement `u x ← e` (Pipeline Grammar, eq. (7)) is `e`
//!     evaluated at the vertex;
//!   - shading vectors ([`Expr::Vector`]) by role — `normal`, `tangent`,
//!     `binormal` (w·(N × T), Kilgard 2000, Section 5.1), `light(i)` (unit vector
//!     to scene light i), `view` (unit vector to the eye, or the camera's
//!     constant direction for an infinite viewer), `half(i)` =
//!     normalize(L + V), `reflection` = 2(N·V)N − V, `position` (the point) —
//!     in the declared space: `object` (model), `world`, `eye` (the default
//!     when a declaration names none) or `tangent`, where a vector v is
//!     (T·v, B·v, N·v) with the vertex's object-space frame (Kilgard 2000
//!     Appendix C: the per-vertex light vector in tangent space);
//!     `intensity(i)`, light i's colour times its distance attenuation and
//!     spot factor at the vertex (a colour, the same in every space).
//! - **Projections**: `π` (and `π*`: no jitter) = camera projection · view ·
//!   model; `πl` (any other subscript but `R`) = light 0's projection ·
//!   view · model — a perspective from the light's position (or from far
//!   along a directional light) towards the scene's centre; `π⁻¹` the
//!   inverse; `πR d` of a direction: sphere-map coordinates (Pipeline Grammar, eq. (7)).
//! - **Uniforms**: the scene's `constants` by name, else the program's
//!   declared default.
//! - **Textures**: each declaration's source — `image("f.png")`,
//!   `normalize_cube(size[, bits])`, `normal_map(height("f.png"), scale)`,
//!   `bumps(cells)`, `exponent_table(n)`, `brdf_fd(m, η)`, `brdf_g(scale)`,
//!   `dual_paraboloid("env.hdr", face)`, and a `cube` texture's
//!   `image(…)` (one image in a layout, six faces, an equirectangular
//!   panorama: [`super::cube_image`]) — loaded or generated with
//!   [`crate::textures`]. A scene texture of the same name replaces the
//!   program's. **Missing image files** fall back to procedural stand-ins,
//!   with a note for the user: a colour image becomes a checkerboard of
//!   warm bricks (`decal.png`-like: alpha 1), a height field the golf-ball
//!   dimples of Kilgard 2000, Section 2.4.2 (256², 16 cells), an environment the
//!   procedural sky. So the built-in default renders with no files at all.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};

use super::{Light, Mesh, Scene};
use crate::ir::declared::{
    ArgKind, DeclaredSource, DeclaredTexture, GeneratorArg, Space, TextureFormat, TextureKind, VectorKind,
};
use crate::ir::{self, Expr, Handle, Module, Projection, Site, Table, TexCoordId, Ty, UniformId, VectorId};
use crate::textures::{
    self, generators, CubeBits, Filter, HeightField, NormalMapFormat, TexelFormat, Texture, Texture2D, Wrap,
};

/// What a texture declaration's source says.
#[derive(Clone, Debug, PartialEq)]
pub enum TextureSource {
    /// `image("f.png")`: the file, relative to the scene's folder.
    Image(String),
    /// `normalize_cube(size[, bits])`: the normalization cube map of
    /// Kilgard 2000, Appendix D.
    NormalizeCube {
        /// Texels per face side.
        size: u32,
        /// 8 or 16 bits per component.
        bits: u32,
    },
    /// `normal_map(height, scale)`: normals derived from a height field
    /// (Kilgard 2000, Section 2.4.2).
    NormalMap {
        /// The height field.
        height: HeightSource,
        /// How steep the bumps are: height differences are multiplied by it.
        scale: f32,
    },
    /// `bumps(cells)`: a normal map of procedural dimples.
    Bumps {
        /// Dimples per side.
        cells: u32,
    },
    /// `dual_paraboloid("env", face)`: one face of a dual-paraboloid
    /// environment map.
    DualParaboloid {
        /// The environment's file (not read yet: the procedural sky).
        file: String,
        /// 0 for the front paraboloid (z ≥ 0), any other for the back.
        face: u32,
    },
    /// `brdf_fd(m, η)`: the Fresnel-times-distribution table of Heidrich &
    /// Seidel 1999, Section 3.1.
    BrdfFd {
        /// The surface roughness m.
        roughness: f32,
        /// The index of refraction η.
        index: f32,
    },
    /// `brdf_g(scale)`: the geometry-term table of Heidrich & Seidel 1999.
    BrdfG {
        /// The divisor that keeps the table within [0, 1].
        scale: f32,
    },
    /// `exponent_table(n)`: x ↦ xⁿ on [0, 1].
    ExponentTable {
        /// The exponent n.
        exponent: f32,
    },
    /// `image(…)` of a `cube` texture: one image in a layout, or six
    /// faces ([`super::cube_image`]); `Err` says why the arguments are not
    /// one of those.
    CubeImage(Result<super::cube_image::CubeImageSource, String>),
    /// A source the renderer does not know.
    Bake(String),
    /// No source: statements render into it.
    Rendered,
}

/// The height field a `normal_map(…)` is derived from.
#[derive(Clone, Debug, PartialEq)]
pub enum HeightSource {
    /// `height("f.png")`: an image's luminance.
    File(String),
    /// The golf-ball dimples of Kilgard 2000, Section 2.4.2: the stand-in.
    Dimples {
        /// Texels per side.
        size: u32,
        /// Dimples per side.
        cells: u32,
    },
}

/// A texture declaration as the renderer needs it.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureDecl {
    /// The texture's name (one per name of the declaration).
    pub name: String,
    /// 1-D, 2-D, 3-D or cube.
    pub kind: TextureKind,
    /// The declared format; `None` when the declaration names none (8-bit).
    pub format: Option<TextureFormat>,
    /// Whether it has a mipmap chain.
    pub mipmap: bool,
    /// How it is filtered (`ir::Sampling`'s one rule).
    pub filter: Filter,
    /// How coordinates outside [0, 1] wrap.
    pub wrap: Wrap,
    /// What fills it.
    pub source: TextureSource,
}

/// A function that exact mode evaluates instead of looking a table up
/// ("no lookup tables").
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ExactFunction {
    /// normalize(d), range-compressed for an unsigned format.
    Normalize {
        /// Signed formats store the vector as is, unsigned ones range-compressed.
        signed: bool,
    },
    /// x^n on [0, 1].
    Exponent(f32),
    /// F(u)·D(v) of Heidrich & Seidel 1999, Section 3.1.
    FresnelDistribution {
        /// The surface roughness m.
        roughness: f32,
        /// The index of refraction η.
        index: f32,
    },
    /// G(u, v)/(π v)/scale.
    Geometry {
        /// The surface roughness m.
        roughness: f32,
        /// The table's divisor.
        scale: f32,
    },
}

/// A texture ready to sample.
#[derive(Clone, Debug)]
pub struct BoundTexture {
    /// The declared (or lowered) texture's name.
    pub name: String,
    /// Its texels, loaded or generated.
    pub texture: Texture,
    /// How it is filtered.
    pub filter: Filter,
    /// The function this texture tabulates, when it is a lookup table.
    pub exact: Option<ExactFunction>,
}

/// Why a texture or an object could not be bound.
#[derive(Debug, thiserror::Error)]
pub enum BindError {
    /// A texture that cannot be loaded or generated.
    #[error("texture `{name}`: {message}")]
    Texture {
        /// The texture's name.
        name: String,
        /// What is wrong, with what to do.
        message: String,
    },
    /// Something the binder does not support.
    #[error("{0}")]
    Unsupported(String),
    /// The scene's own error (its file or a mesh that cannot be read).
    #[error(transparent)]
    Scene(#[from] super::SceneError),
}

/// The textures `module` declares (its typed declarations,
/// [`crate::ir::declared`]), one per name, a generator's named numbers
/// taken from the scene's constants before the program's values.
pub fn texture_decls(module: &Module, scene_constants: &BTreeMap<String, Vec<f32>>) -> Vec<TextureDecl> {
    let numbers: BTreeMap<String, f32> =
        scene_constants.iter().filter(|(_, v)| v.len() == 1).map(|(k, v)| (k.clone(), v[0])).collect();
    let mut out = Vec::new();
    for t in module.declared.iter() {
        let crate::ir::Sampling { filter, wrap, mipmap } = t.sampling;
        let source = match &t.source {
            None => TextureSource::Rendered,
            Some(e) if t.kind == TextureKind::Cube && super::cube_image::is_image_call(e) => {
                TextureSource::CubeImage(
                    super::cube_image::read_source(e).map_err(|p| format!("{}; {}", p.message, p.help)),
                )
            }
            Some(e) => source(e, &numbers),
        };
        for (name, _) in &t.names {
            out.push(TextureDecl {
                name: name.clone(),
                kind: t.kind,
                format: t.format,
                mipmap,
                filter,
                wrap,
                source: source.clone(),
            });
        }
    }
    out
}

/// The declarations of the textures the lowering added (a
/// normalization cube map), from the typed source each carries
/// (`ir::Texture::declaration`) and its kind, format and sampling, so that
/// they bind like declared ones.
///
/// A texture the lowering re-stores in another format
/// (`ir::Texture::copy_of`) binds as a copy of its `declared` original
/// under its own name and format.
pub fn lowered_decls(module: &crate::ir::Module, declared: &[TextureDecl]) -> Vec<TextureDecl> {
    let copies = module.textures.iter().filter_map(|t| {
        let original = declared.iter().find(|d| Some(&d.name) == t.copy_of.as_ref())?;
        Some(TextureDecl { name: t.name.clone(), format: Some(t.format), ..original.clone() })
    });
    let mut out: Vec<TextureDecl> = copies.collect();
    out.extend(module.textures.iter().filter_map(|t| {
        let source = match t.declaration? {
            crate::ir::AddedSource::NormalizeCube { size, bits } => {
                TextureSource::NormalizeCube { size, bits }
            }
        };
        let crate::ir::Sampling { filter, wrap, mipmap } = t.sampling;
        Some(TextureDecl {
            name: t.name.clone(),
            kind: t.kind,
            format: Some(t.format),
            mipmap,
            filter,
            wrap,
            source,
        })
    }));
    out
}

fn source(e: &DeclaredSource, names: &BTreeMap<String, f32>) -> TextureSource {
    let (f, a) = match e {
        DeclaredSource::Generator { name, args, .. } => (name, args),
        DeclaredSource::Other { text, .. } => return TextureSource::Bake(text.clone()),
    };
    let num = |i: usize, default: f32| a.get(i).and_then(|x| x.number(names)).unwrap_or(default);
    let string = |i: usize| a.get(i).and_then(|x| x.text()).map(str::to_string);
    match f.as_str() {
        "image" => TextureSource::Image(string(0).unwrap_or_default()),
        "normalize_cube" => {
            TextureSource::NormalizeCube { size: num(0, 32.0).max(1.0) as u32, bits: num(1, 8.0) as u32 }
        }
        "normal_map" => {
            let height = match a.first().map(|x| &x.kind) {
                Some(ArgKind::Call { arg, .. }) => match arg.text() {
                    Some(file) => HeightSource::File(file.to_string()),
                    None => HeightSource::Dimples { size: 256, cells: 16 },
                },
                Some(ArgKind::Text(s)) => HeightSource::File(s.clone()),
                _ => HeightSource::Dimples { size: 256, cells: 16 },
            };
            TextureSource::NormalMap { height, scale: num(1, 4.0) }
        }
        "bumps" => TextureSource::Bumps { cells: num(0, 16.0).max(1.0) as u32 },
        "dual_paraboloid" => {
            TextureSource::DualParaboloid { file: string(0).unwrap_or_default(), face: num(1, 0.0) as u32 }
        }
        "brdf_fd" => TextureSource::BrdfFd { roughness: num(0, 0.3), index: num(1, 1.5) },
        "brdf_g" => TextureSource::BrdfG { scale: num(0, 1.0) },
        "exponent_table" => TextureSource::ExponentTable { exponent: num(0, 8.0) },
        // `bake(f)` becomes a texel pass that renders f into the texture
        // (`ir::lower`, seeds/001 (13)).
        "bake" => TextureSource::Rendered,
        other => TextureSource::Bake(other.to_string()),
    }
}

fn texel_format(format: Option<TextureFormat>) -> TexelFormat {
    match format {
        Some(TextureFormat::Rgba16 | TextureFormat::Signed16) => TexelFormat::Rgba16,
        Some(TextureFormat::Rgba16f | TextureFormat::Rgba32f) => TexelFormat::F32,
        _ => TexelFormat::Rgba8,
    }
}

/// Signed formats hold values in [−1, 1] (whatever their `TexelFormat`).
pub(crate) fn is_signed(format: Option<TextureFormat>) -> bool {
    matches!(format, Some(TextureFormat::Signed8 | TextureFormat::Signed16))
}

/// How a texture set is built: what the hardware stores, or the exact reference's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TextureQuality {
    /// As declared: 8-bit (or 16-bit, float) texels.
    Stored,
    /// Generated data in f32 (normal maps unquantized); lookup tables remain
    /// tables but carry their [`ExactFunction`].
    Exact,
}

/// Loads or generates every declared (non-rendered) texture. `notes`
/// receives a line per stand-in used.
pub fn load_textures(
    decls: &[TextureDecl],
    scene: &Scene,
    quality: TextureQuality,
    notes: &mut Vec<String>,
) -> Result<BTreeMap<String, BoundTexture>, BindError> {
    let mut out = BTreeMap::new();
    for d in decls.iter().filter(|d| d.source != TextureSource::Rendered) {
        let bound = match from_scene(d, scene)? {
            Some(t) => t,
            None => {
                let (texture, exact) = generate(d, scene, quality, notes)?;
                BoundTexture { name: d.name.clone(), texture, filter: d.filter, exact }
            }
        };
        out.insert(d.name.clone(), bound);
    }
    Ok(out)
}

/// A scene texture of the declaration's name: it wins over the program's source.
fn from_scene(d: &TextureDecl, scene: &Scene) -> Result<Option<BoundTexture>, BindError> {
    let Some(desc) = scene.textures.get(&d.name) else { return Ok(None) };
    if let (TextureKind::Cube, super::TextureDesc::File { path, format, .. }) = (d.kind, desc) {
        let texture = super::cube_image::scene_file_as_cube(scene, path, *format)
            .map_err(|message| BindError::Texture { name: d.name.clone(), message })?;
        return Ok(Some(BoundTexture { name: d.name.clone(), texture, filter: d.filter, exact: None }));
    }
    let one = Scene {
        textures: [(d.name.clone(), desc.clone())].into_iter().collect(),
        objects: vec![],
        ..scene.clone()
    };
    let built = one.build()?;
    Ok(built.textures.get(&d.name).map(|t| BoundTexture {
        name: d.name.clone(),
        texture: t.clone(),
        filter: d.filter,
        exact: None,
    }))
}

fn texture_error(d: &TextureDecl, message: String) -> BindError {
    BindError::Texture { name: d.name.clone(), message }
}

/// The texture the declaration's source loads or generates, and the
/// function it tabulates (what `exact` mode evaluates instead).
fn generate(
    d: &TextureDecl,
    scene: &Scene,
    quality: TextureQuality,
    notes: &mut Vec<String>,
) -> Result<(Texture, Option<ExactFunction>), BindError> {
    let format = texel_format(d.format);
    Ok(match &d.source {
        TextureSource::Image(file) => (image_texture(d, scene, file, notes)?, None),
        TextureSource::CubeImage(source) => {
            (super::cube_image::cube_image_texture(d, scene, source, format, notes)?, None)
        }
        TextureSource::NormalizeCube { size, bits } => {
            let signed = is_signed(d.format);
            (normalize_cube_texture(d, *size, *bits)?, Some(ExactFunction::Normalize { signed }))
        }
        TextureSource::NormalMap { height, scale } => {
            (normal_map_texture(d, scene, height, *scale, quality, notes)?, None)
        }
        TextureSource::Bumps { cells } => (bumps_texture(d, *cells, quality), None),
        TextureSource::DualParaboloid { file, face } => {
            (dual_paraboloid_texture(d, scene, file, *face, notes), None)
        }
        TextureSource::BrdfFd { roughness, index } => (
            Texture::Flat(generators::hs_fresnel_distribution(64, *roughness, *index, format)),
            Some(ExactFunction::FresnelDistribution { roughness: *roughness, index: *index }),
        ),
        TextureSource::BrdfG { scale } => (
            Texture::Flat(generators::hs_geometry(64, 0.3, *scale, format)),
            Some(ExactFunction::Geometry { roughness: 0.3, scale: *scale }),
        ),
        TextureSource::ExponentTable { exponent } => (
            Texture::Flat(generators::exponent_lut(generators::EXPONENT_TABLE_SIZE, *exponent, format)),
            Some(ExactFunction::Exponent(*exponent)),
        ),
        TextureSource::Bake(what) => return Err(texture_error(d, format!("the texture source `{what}` is not one the renderer knows: use image(\"file\"), a generator (normalize_cube, normal_map, bumps, dual_paraboloid, brdf_fd, brdf_g, exponent_table) or bake(shader)"))),
        TextureSource::Rendered => unreachable!("rendered textures are skipped by load_textures"),
    })
}

/// `image("file")`: the file, or a procedural brick stand-in when missing.
fn image_texture(
    d: &TextureDecl,
    scene: &Scene,
    file: &str,
    notes: &mut Vec<String>,
) -> Result<Texture, BindError> {
    let format = texel_format(d.format);
    let path = scene.resolve_program_file(file);
    let t = match textures::load_image(&path, format, d.wrap) {
        Ok(t) => t,
        Err(textures::TextureError::NotFound { .. }) => {
            notes.push(format!(
                "texture `{}`: {} not found; using a procedural brick stand-in (256×256)",
                d.name,
                path.display()
            ));
            Texture2D::new(format, d.wrap, generators::brick_stand_in(256))
        }
        Err(e) => return Err(texture_error(d, e.to_string())),
    };
    let t = if d.mipmap { t.with_box_mipmaps() } else { t };
    if d.kind == TextureKind::Cube {
        return Err(texture_error(
            d,
            "a cube map from an image file is not supported; use normalize_cube(…) or a scene texture".into(),
        ));
    }
    Ok(Texture::Flat(t))
}

/// `normalize_cube(size, bits)` (GeForce3 Phong, Formula 4): range-compressed,
/// or the vector itself in a signed format.
fn normalize_cube_texture(d: &TextureDecl, size: u32, bits: u32) -> Result<Texture, BindError> {
    if d.kind != TextureKind::Cube {
        return Err(texture_error(d, "normalize_cube(…) needs a `cube` texture".into()));
    }
    let format = texel_format(d.format);
    // The declared format holds the texels: 16 bits only where it has them.
    let sixteen = matches!(format, TexelFormat::Rgba16) || (bits >= 16 && d.format.is_none());
    let bits = if sixteen { CubeBits::Sixteen } else { CubeBits::Eight };
    let mut cube = generators::normalize_cube(size.clamp(1, generators::MAX_CUBE_FACE), bits);
    if is_signed(d.format) {
        // Signed formats hold the vector itself, not its range compression.
        for level in cube.faces.iter_mut().flat_map(|face| face.levels.iter_mut()) {
            expand_rgb(&mut level.texels);
        }
    }
    Ok(Texture::Cube(cube))
}

/// `v ↦ 2v − 1` on the colour channels of `texels`.
fn expand_rgb(texels: &mut [[f32; 4]]) {
    for t in texels.iter_mut() {
        for c in t.iter_mut().take(3) {
            *c = generators::expand(*c);
        }
    }
}

/// `normal_map(height("file"), scale)` (Kilgard 2000, Section 5.3): from the
/// height field, or golf-ball dimples when the file is missing.
fn normal_map_texture(
    d: &TextureDecl,
    scene: &Scene,
    height: &HeightSource,
    scale: f32,
    quality: TextureQuality,
    notes: &mut Vec<String>,
) -> Result<Texture, BindError> {
    let hf = match height {
        HeightSource::File(file) => {
            let path = scene.resolve_program_file(file);
            match textures::load_height_field(&path) {
                Ok(h) => h,
                Err(textures::TextureError::NotFound { .. }) => {
                    notes.push(format!("texture `{}`: height field {} not found; using procedural golf-ball dimples (256×256, 16 cells)", d.name, path.display()));
                    HeightField::dimples(256, 16)
                }
                Err(e) => return Err(texture_error(d, e.to_string())),
            }
        }
        HeightSource::Dimples { size, cells } => HeightField::dimples(*size, *cells),
    };
    let format = texel_format(d.format);
    let nf = if quality == TextureQuality::Exact || format == TexelFormat::F32 {
        NormalMapFormat::F32
    } else {
        NormalMapFormat::Rgba8
    };
    let mut t = generators::normal_map(&hf, scale, nf);
    t.wrap = d.wrap;
    if !d.mipmap {
        t.levels.truncate(1);
    }
    Ok(Texture::Flat(t))
}

/// `bumps(cells)`: a dimpled normal map, expanded in a signed format:
/// `signed8` at 8 bits (Kilgard's bytes), `signed16` at 16 (k/32767, as the texture
/// shader's signed HILO16 stored it), unquantized for the exact reference.
fn bumps_texture(d: &TextureDecl, cells: u32, quality: TextureQuality) -> Texture {
    let sixteen = d.format == Some(TextureFormat::Signed16);
    let nf = if quality == TextureQuality::Exact || sixteen {
        NormalMapFormat::F32
    } else {
        NormalMapFormat::Rgba8
    };
    let mut t = generators::normal_map(&HeightField::dimples(256, cells), 4.0, nf);
    if is_signed(d.format) {
        for level in t.levels.iter_mut() {
            expand_rgb(&mut level.texels);
            if sixteen && quality == TextureQuality::Stored {
                level.texels.iter_mut().for_each(|t| *t = t.map(crate::textures::sampling::signed16));
            }
        }
        t.format = if nf == NormalMapFormat::F32 { TexelFormat::F32 } else { TexelFormat::Signed8 };
    }
    t.wrap = d.wrap;
    if !d.mipmap {
        t.levels.truncate(1);
    }
    Texture::Flat(t)
}

/// `dual_paraboloid("file", face)`: the procedural sky (images are not read yet).
fn dual_paraboloid_texture(
    d: &TextureDecl,
    scene: &Scene,
    file: &str,
    face: u32,
    notes: &mut Vec<String>,
) -> Texture {
    let path = scene.resolve_program_file(file);
    if path.is_file() {
        notes.push(format!(
            "texture `{}`: environment images are not read yet; using the procedural sky",
            d.name
        ));
    } else {
        notes.push(format!("texture `{}`: {} not found; using the procedural sky", d.name, path.display()));
    }
    let dp = generators::dual_paraboloid_stand_in(texel_format(d.format));
    let mut t = if face == 0 { dp.front } else { dp.back };
    t.wrap = d.wrap;
    Texture::Flat(t)
}

/// Light and eye in one object's model space.
#[derive(Clone, Debug)]
struct ObjectSpace {
    model: Mat4,
    /// model → eye for points.
    model_view: Mat4,
    /// Directions (object → eye / world), normals use the inverse transpose.
    normal_eye: Mat3,
    normal_world: Mat3,
    eye_obj: Vec3,
    /// The infinite viewer's direction (object space), if infinite.
    view_dir_obj: Option<Vec3>,
    /// Per light: position (w = 1) or direction to the light (w = 0), object space.
    lights: Vec<Vec4>,
    /// The scene's lights (world space), for `intensity(i)`.
    world_lights: Vec<Light>,
}

/// One object of the scene, bound: per-vertex leaves and projections.
pub struct BoundObject<'s> {
    /// The object's mesh.
    pub mesh: &'s Mesh,
    space: ObjectSpace,
    /// Clip matrices: camera π and light πl (model → clip).
    pub camera_clip: Mat4,
    /// Light 0's: the shadow map's projection.
    pub light_clip: Mat4,
    /// Generated coordinate sets, per vertex.
    texgen: BTreeMap<TexCoordId, Vec<[f64; 4]>>,
}

/// The scene's objects bound for a frame of aspect ratio `aspect`, their
/// texture coordinates generated (Pipeline Grammar, eq. (7)); light 0's projection
/// looks at the centre of the objects. Every executor binds its objects
/// through this, so they draw the same vertices.
pub fn bound_objects<'s>(
    scene: &'s Scene,
    assets: &'s super::SceneAssets,
    module: &Module,
    aspect: f32,
) -> Result<Vec<BoundObject<'s>>, BindError> {
    let (center, radius) = assets.bounding_sphere();
    let light_clip = light_view_projection(scene.lights.first(), center, radius);
    let mut objects: Vec<BoundObject> = assets
        .meshes
        .iter()
        .map(|(mesh, model)| BoundObject::new(scene, mesh, *model, aspect, light_clip))
        .collect();
    for o in &mut objects {
        o.run_texgen(module)?;
    }
    Ok(objects)
}

/// The view-projection of light 0: from its position (or from far along a
/// directional light) towards `center`, a 60° (or the spot's cone) frustum.
pub fn light_view_projection(light: Option<&Light>, center: Vec3, radius: f32) -> Mat4 {
    let (eye, fov) = match light {
        Some(Light::Point { position, .. }) => (*position, 60.0f32),
        Some(Light::Spot { position, cutoff_deg, .. }) => (*position, (2.0 * cutoff_deg).clamp(10.0, 170.0)),
        Some(Light::Directional { direction, .. }) => {
            (center - direction.normalize_or_zero() * (4.0 * radius.max(1.0)), 60.0)
        }
        None => (center + Vec3::new(0.0, 4.0 * radius.max(1.0), 0.0), 60.0),
    };
    let d = (center - eye).length().max(1e-3);
    let up = if (center - eye).cross(Vec3::Y).length_squared() < 1e-6 * d * d { Vec3::Z } else { Vec3::Y };
    let near = (d - 2.0 * radius).max(d * 0.05);
    let far = d + 2.0 * radius.max(1.0);
    super::camera::perspective_gl(fov.to_radians(), 1.0, near, far) * super::camera::look_at(eye, center, up)
}

impl<'s> BoundObject<'s> {
    /// Binds `mesh`, placed by `model`, to the scene's camera (at `aspect`)
    /// and lights; `light_clip` is light 0's view-projection.
    pub fn new(scene: &Scene, mesh: &'s Mesh, model: Mat4, aspect: f32, light_clip: Mat4) -> BoundObject<'s> {
        let view = scene.camera.view();
        let inv = model.inverse();
        let model_view = view * model;
        let normal_eye = Mat3::from_mat4(model_view).inverse().transpose();
        let normal_world = Mat3::from_mat4(model).inverse().transpose();
        let eye_obj = inv.transform_point3(scene.camera.eye);
        let view_dir_obj = match scene.camera.viewer {
            super::Viewer::Local => None,
            super::Viewer::Infinite => {
                Some(inv.transform_vector3(scene.camera.eye - scene.camera.target).normalize_or_zero())
            }
        };
        let lights = scene
            .lights
            .iter()
            .map(|l| match *l {
                Light::Directional { direction, .. } => {
                    inv.transform_vector3(-direction).normalize_or_zero().extend(0.0)
                }
                Light::Point { position, .. } | Light::Spot { position, .. } => {
                    inv.transform_point3(position).extend(1.0)
                }
            })
            .collect();
        BoundObject {
            mesh,
            space: ObjectSpace {
                model,
                model_view,
                normal_eye,
                normal_world,
                eye_obj,
                view_dir_obj,
                lights,
                world_lights: scene.lights.clone(),
            },
            camera_clip: scene.camera.view_projection(aspect) * model,
            light_clip: light_clip * model,
            texgen: BTreeMap::new(),
        }
    }

    /// The mesh's vertex count.
    pub fn n_vertices(&self) -> usize {
        self.mesh.positions.len()
    }

    /// Evaluates the texgen statements of `module` at every vertex.
    pub fn run_texgen(&mut self, module: &Module) -> Result<(), BindError> {
        for st in &module.statements {
            let Table::TexCoords(set) = st.table else { continue };
            let mut ev = ir::eval::Evaluator::new(module, &[st.value], crate::numerics::Precision::Exact);
            let mut values = Vec::with_capacity(self.n_vertices());
            for v in 0..self.n_vertices() {
                let mut env = VertexEnv { object: self, module, vertex: v, uniforms: &[] };
                let r = ev.eval(&mut env);
                values.push(r.values[0]);
            }
            self.texgen.insert(set, values);
        }
        Ok(())
    }

    /// Object-space frame at a vertex: (N, T, B).
    fn frame(&self, v: usize) -> (Vec3, Vec3, Vec3) {
        let n = self.mesh.normals[v].normalize_or_zero();
        let t4 = self.mesh.tangents.get(v).copied().unwrap_or(Vec4::new(1.0, 0.0, 0.0, 1.0));
        let t = t4.truncate();
        let b = n.cross(t) * if t4.w < 0.0 { -1.0 } else { 1.0 };
        (n, t, b)
    }

    /// The value of vector `id` of `module` at vertex `v`.
    pub fn vector(&self, module: &Module, id: VectorId, v: usize) -> [f64; 4] {
        let decl = &module.vectors[id as usize];
        let p = self.mesh.positions[v];
        let (n, t, b) = self.frame(v);
        let to_eye = || match self.space.view_dir_obj {
            Some(d) => d,
            None => (self.space.eye_obj - p).normalize_or_zero(),
        };
        let to_light = |i: u32| match self.space.lights.get(i as usize) {
            Some(l) if l.w == 0.0 => l.truncate(),
            Some(l) => (l.truncate() - p).normalize_or_zero(),
            None => Vec3::ZERO,
        };
        let index = decl.index.unwrap_or(0);
        let kind = decl.kind.unwrap_or(VectorKind::Normal);
        if kind == VectorKind::Intensity {
            // A colour, the same in every space: light i's colour ·
            // attenuation · spot factor at the vertex (scene::Light::incidence).
            let world = self.space.model.transform_point3(p);
            let c = self
                .space
                .world_lights
                .get(index as usize)
                .map_or(Vec3::ZERO, |l| l.incidence(world).intensity);
            return [c.x as f64, c.y as f64, c.z as f64, 0.0];
        }
        let (obj, is_normal, is_point) = match kind {
            VectorKind::Normal => (n, true, false),
            VectorKind::Tangent => (t, false, false),
            VectorKind::Binormal => (b, false, false),
            VectorKind::Light => (to_light(index), false, false),
            VectorKind::View => (to_eye(), false, false),
            VectorKind::Half => ((to_light(index) + to_eye()).normalize_or_zero(), false, false),
            VectorKind::Reflection => {
                let v = to_eye();
                (2.0 * n.dot(v) * n - v, false, false)
            }
            VectorKind::Position => (p, false, true),
            VectorKind::Intensity => (Vec3::ZERO, false, false), // returned above
        };
        let unit = !is_point;
        let out = match decl.space.unwrap_or(Space::Eye) {
            Space::Object => obj,
            Space::Tangent => {
                if is_point {
                    Vec3::new(t.dot(p), b.dot(p), n.dot(p))
                } else {
                    Vec3::new(t.dot(obj), b.dot(obj), n.dot(obj))
                }
            }
            Space::World => {
                if is_point {
                    self.space.model.transform_point3(p)
                } else if is_normal {
                    self.space.normal_world * obj
                } else {
                    self.space.model.transform_vector3(obj)
                }
            }
            Space::Eye => {
                if is_point {
                    self.space.model_view.transform_point3(p)
                } else if is_normal {
                    self.space.normal_eye * obj
                } else {
                    self.space.model_view.transform_vector3(obj)
                }
            }
        };
        let out = if unit { out.normalize_or_zero() } else { out };
        [out.x as f64, out.y as f64, out.z as f64, if is_point { 1.0 } else { 0.0 }]
    }

    /// A texture-coordinate set at vertex `v`.
    pub fn tex_coord(&self, set: TexCoordId, v: usize) -> [f64; 4] {
        if let Some(values) = self.texgen.get(&set) {
            return values[v];
        }
        let uv = self.mesh.uvs.get(v).copied().unwrap_or(Vec2::ZERO);
        [uv.x as f64, uv.y as f64, 0.0, 0.0]
    }

    /// The model → clip matrix of a projection.
    pub fn clip_matrix(&self, p: &Projection) -> Mat4 {
        let base = match p.subscript.as_deref() {
            None | Some("") => self.camera_clip,
            Some(_) => self.light_clip,
        };
        if p.inverse {
            base.inverse()
        } else {
            base
        }
    }
}

/// `π v` (see the module docs): a point to clip space, `π⁻¹` back (divided
/// by w), `πR d` to sphere-map coordinates.
pub fn project(object: &BoundObject, p: &Projection, value: [f64; 4], ty: Ty) -> [f64; 4] {
    if ty == Ty::Vec3 {
        // Sphere map (seeds/001 (7)): m = 2·sqrt(rx² + ry² + (rz + 1)²).
        let [x, y, z, _] = value;
        let m = 2.0 * (x * x + y * y + (z + 1.0) * (z + 1.0)).sqrt();
        return if m > 0.0 { [x / m + 0.5, y / m + 0.5, 0.0, 0.0] } else { [0.5, 0.5, 0.0, 0.0] };
    }
    project_by(object.clip_matrix(p), p.inverse, value, ty)
}

/// `π v` of a point by the projection's model → clip `matrix` (its inverse
/// for `π⁻¹`, whose result is divided by w).
pub fn project_by(matrix: Mat4, inverse: bool, value: [f64; 4], ty: Ty) -> [f64; 4] {
    let w = if ty == Ty::Position && value[3] == 0.0 && !inverse { 1.0 } else { value[3] };
    let v = Vec4::new(value[0] as f32, value[1] as f32, value[2] as f32, w as f32);
    let r = matrix * v;
    if inverse && r.w != 0.0 {
        [(r.x / r.w) as f64, (r.y / r.w) as f64, (r.z / r.w) as f64, 1.0]
    } else {
        [r.x as f64, r.y as f64, r.z as f64, r.w as f64]
    }
}

/// A note for each shading vector of a light the scene does not have
/// (`light(2)` with one light): it delivers nothing — a zero vector and
/// zero intensity — on every executor, which the user should know.
pub fn absent_light_notes(module: &Module, scene: &Scene) -> Vec<String> {
    let n = scene.lights.len();
    let mut out = Vec::new();
    for v in &module.vectors {
        let light = matches!(v.kind, Some(VectorKind::Light | VectorKind::Half | VectorKind::Intensity));
        let index = v.index.unwrap_or(0) as usize;
        if light && index >= n {
            out.push(format!(
                "vector `{}` reads light {index}, and the scene has {n} light{}: it is the zero vector (zero intensity), so its terms are black; add a light to the scene's `lights:` or use an index below {n}",
                v.name,
                if n == 1 { "" } else { "s" }
            ));
        }
    }
    out
}

/// The uniforms of a module for a scene: the scene's constants by name,
/// else `None` (the declared default applies).
pub fn uniforms(module: &Module, scene: &Scene) -> Vec<Option<[f64; 4]>> {
    module
        .uniforms
        .iter()
        .map(|u| {
            scene.constants.get(&u.name).map(|v| {
                let mut out = [0.0; 4];
                for (o, x) in out.iter_mut().zip(v) {
                    *o = *x as f64;
                }
                if v.len() == 1 {
                    out = [v[0] as f64; 4];
                } else if v.len() == 3 && u.ty == Ty::Rgba {
                    out[3] = 1.0;
                }
                out
            })
        })
        .collect()
}

/// The leaves of one vertex.
pub struct VertexEnv<'a, 's> {
    /// The object the vertex belongs to.
    pub object: &'a BoundObject<'s>,
    /// The program.
    pub module: &'a Module,
    /// The vertex's index in the object's mesh.
    pub vertex: usize,
    /// The uniforms' values, by id (`None`: unset).
    pub uniforms: &'a [Option<[f64; 4]>],
}

impl ir::eval::Env for VertexEnv<'_, '_> {
    fn uniform(&mut self, id: UniformId) -> Option<[f64; 4]> {
        self.uniforms.get(id as usize).copied().flatten()
    }
    fn vertex_position(&mut self, _vertex: ir::VertexId) -> [f64; 4] {
        let p = self.object.mesh.positions[self.vertex];
        [p.x as f64, p.y as f64, p.z as f64, 1.0]
    }
    fn tex_coord(&mut self, set: TexCoordId, _vertex: ir::VertexId) -> [f64; 4] {
        self.object.tex_coord(set, self.vertex)
    }
    fn vector(&mut self, vector: VectorId, site: Site) -> [f64; 4] {
        match site {
            Site::Vertex(_) => self.object.vector(self.module, vector, self.vertex),
            Site::Texel => ir::eval::NAN,
        }
    }
    fn project(&mut self, projection: &Projection, value: [f64; 4], ty: Ty) -> [f64; 4] {
        project(self.object, projection, value, ty)
    }
}

/// Whether the per-vertex value `h` is a unit direction: a role vector other
/// than a position, a `normalize(…)`, a negation or reflection of those.
/// Interpolated, its length is at most 1 (the relevance bounds use it).
pub fn is_unit_direction(m: &Module, h: Handle<Expr>) -> bool {
    match &m.exprs[h] {
        Expr::Vector { vector, .. } => m.vectors[*vector as usize]
            .kind
            .is_some_and(|k| !matches!(k, VectorKind::Position | VectorKind::Intensity)),
        Expr::Math { fun: ir::MathFunction::Normalize, .. } => true,
        Expr::Math { fun: ir::MathFunction::Reflect, args } => args.iter().all(|a| is_unit_direction(m, *a)),
        Expr::Unary { op: ir::UnaryOp::Neg, value } => is_unit_direction(m, *value),
        _ => false,
    }
}

/// Resolves a path relative to the current directory when a scene has none.
pub fn scene_dir(scene: &Scene) -> PathBuf {
    scene.path.parent().map(Path::to_path_buf).unwrap_or_default()
}

/// An image file a texture declaration reads (`image("f")`, or a normal
/// map's `height("f")`), with the span of the file's name: what the driver
/// looks for before binding, so that a missing file is a located error
/// unless stand-ins were asked for (`--stand-ins`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImageFile {
    /// The first texture the declaration names.
    pub texture: String,
    /// The file's name as written.
    pub file: String,
    /// Where the name is written.
    pub span: crate::span::Span,
}

/// Every image file the texture declarations read, in source order.
pub fn image_files(declared: &[DeclaredTexture]) -> Vec<ImageFile> {
    let mut out = Vec::new();
    for t in declared {
        let (Some((name, _)), Some(DeclaredSource::Generator { name: f, args, .. })) =
            (t.names.first(), &t.source)
        else {
            continue;
        };
        collect_image_files(f, &args.iter().collect::<Vec<_>>(), name, &mut out);
    }
    out
}

/// The `image("f")` and `height("f")` calls in a texture's source: `f`
/// applied to `args`.
fn collect_image_files(f: &str, args: &[&GeneratorArg], texture: &str, out: &mut Vec<ImageFile>) {
    match (f, args.first().map(|a| (&a.kind, *a))) {
        // A cube map's: six face files, a `{face}` pattern, or one image
        // and its layout (docs/language.md, "Cube maps from images").
        ("image", Some((ArgKind::Text(_), _))) => {
            for a in args {
                let ArgKind::Text(file) = &a.kind else { continue };
                if crate::textures::cube_image::CubeLayout::from_name(file).is_some() {
                    continue;
                }
                let faces = crate::textures::cube_image::FACE_NAMES.map(|n| file.replace("{face}", n));
                let files = if file.contains("{face}") { faces.to_vec() } else { vec![file.clone()] };
                for file in files {
                    out.push(ImageFile { texture: texture.to_string(), file, span: a.span });
                }
            }
        }
        ("height" | "normal_map", Some((ArgKind::Text(file), a))) => {
            out.push(ImageFile { texture: texture.to_string(), file: file.clone(), span: a.span });
        }
        ("normal_map", Some((ArgKind::Call { name: Some(g), arg }, _))) => {
            collect_image_files(g, &arg.items(), texture, out)
        }
        _ => {}
    }
}
