//! The texture-shader stages per pixel, in integers, so that the CPU
//! (`shadec emulate`) and the WGSL `translate` writes (`wgsl::ts1`) compute
//! the same texels bit for bit. NV_texture_shader Section 3.8.13 defines the
//! operations on real numbers; this model fixes their precision:
//!
//! - **Coordinates** are integers in units of 1/65536 ([`COORD_ONE`]; 16
//!   fractional bits). By default unit *i* at pixel (x, y) of a W×H image
//!   has s = (x + ½)/W, t = (y + ½)/H, r = 0, q = 1, rounded to that unit.
//!   A coordinate image (`--coordN`, RGBA8 = s, t, r, q) overrides it; a
//!   byte b means b/255 where the stage reads a position (lookups,
//!   `pass_through`, offsets) and (2b − 255)/255 where it reads a direction
//!   (`cull_fragment`, dot products), so both ranges keep 8 bits.
//! - **Lookups** are nearest (no filtering), clamp-to-edge, with texel
//!   index ⌊c·n⌋ of the normalized coordinate c; `texture_1d/2d/rectangle`
//!   divide s and t by q (q ≤ 0 reads index 0); the rectangle's coordinate
//!   is c·n texels, so `texture_rectangle` reads what `texture_2d` reads.
//!   `texture_1d` reads row 0 of its image.
//! - **Signed DSDT texels** (the stage an `offset_*` reads): red = ds,
//!   green = dt as two's-complement bytes k ∈ −128..=127, meaning
//!   max(k, −127)/127 (the NV signed 8-bit normalized format, as
//!   `textures::TexelFormat::Signed8`); blue = the unsigned magnitude of
//!   `DSDT_MAG` for `_scale`.
//! - **Offset matrix, scale and bias** are clamped to [−8, 8] and rounded
//!   to units of 1/4096 ([`MATRIX_ONE`]); the offset is
//!   ⌊(m₀·ds + m₂·dt)·16 / 127⌋ coordinate units, so a zero matrix gives the
//!   plain lookup exactly. `_scale` multiplies RGB by
//!   clamp(scale·mag + bias, 0, 1), rounded to nearest.
//! - **Dot products** take the unsigned texel k (`texN`: k/255) or its
//!   expansion (`expand(texN)`: (2k − 255)/255) against (s, t, r) and keep
//!   ⌊Σ/255⌋ coordinate units; `dot_product_rectangle_2of2` reads texel
//!   ⌊dot⌋ directly. Stages without an RGBA result read (0, 0, 0, 0).
//! - **Cube maps** are one image of six square faces stacked top to bottom
//!   (+X, −X, +Y, −Y, +Z, −Z; height = 6 × width); the face is GL's
//!   major-axis choice (ties go to x, then y) and the texel
//!   ⌊(sc/|ma| + 1)/2 · size⌋, in integers. `texture_cube_map` reads its
//!   (s, t, r) as a direction (signed coordinate bytes), ignoring q.
//! - **3-D textures** are square slices stacked top to bottom (height =
//!   depth × width), r = 0 on top.
//! - **Reflections** (`dot_product_reflect_cube_map_*`, the diffuse
//!   family's last stage): N = (dot₀, dot₁, dot₂) and the eye E (the three
//!   stages' q, or the constant eye clamped to [−2, 2]) in units of 1/256;
//!   R = ⌊2·N·(N·E)/(N·N)⌋ − E per component (−E when N = 0). The diffuse
//!   stage reads the cube map at N, its next stage's dot product computed
//!   first, as the hardware does.
//!
//! - **Depth replace** (`dot_product_depth_replace_1of2/2of2`): the
//!   fragment's depth is z/w of the two dot products (z of the first
//!   stage, w of the second), ⌊z·65536/w⌋ in coordinate units clamped to
//!   [0, 1], and 1 where w = 0 (as Direct3D's `texm3x2depth` defines the
//!   same operation); both stages' RGBA is 0, as NV_texture_shader says.
//!   [`Shaded::depth`] holds it; `emulate` has no depth buffer to test it
//!   against.
//!
//! Not modelled: filtering (every lookup is nearest); texture wrap modes
//! other than clamp to edge.

use rayon::prelude::*;
use thiserror::Error;

use super::program::{CullCondition, DotFamily, DotMapping, Operation, TextureShader, MAX_STAGES};
use crate::backends::combiners::config::CombinerConfig;
use crate::backends::combiners::emulator::{self, EmulateError, Inputs, Precision};

/// One coordinate unit: 1/65536.
pub const COORD_ONE: i32 = 65536;
/// One unit of the offset matrix, scale and bias: 1/4096.
pub const MATRIX_ONE: i32 = 4096;
/// The largest texture side a stage may read (keeps every product in i32).
pub const MAX_TEXTURE_SIDE: u32 = 4096;

/// An RGBA8 texture image, row-major, row 0 at t = 0.
#[derive(Clone, Copy, Debug)]
pub struct Image<'a> {
    pub width: u32,
    pub height: u32,
    pub rgba: &'a [u8],
}

/// What the texture-shader stages read: each unit's texture image (any
/// size) and, optionally, its per-pixel coordinates (an RGBA8 image of the
/// output's size).
#[derive(Clone, Copy, Debug, Default)]
pub struct TextureInputs<'a> {
    pub width: usize,
    pub height: usize,
    pub textures: [Option<Image<'a>>; 4],
    pub coords: [Option<&'a [u8]>; 4],
}

/// Why the texture-shader emulator cannot run a program over its texture images.
#[derive(Debug, Error, PartialEq)]
pub enum TsEmulateError {
    #[error("texture shader stage {stage}: `{name}` cannot read its texture image ({why})")]
    Unsupported { stage: usize, name: String, why: &'static str },
    #[error("{what} is {width}x{height}; texture images may be at most {MAX_TEXTURE_SIDE} texels a side")]
    TooLarge { what: String, width: u32, height: u32 },
    #[error("{what} has {got} bytes, but a {width}x{height} RGBA8 image has {expected}")]
    SizeMismatch { what: String, got: usize, expected: usize, width: usize, height: usize },
    #[error("the texture shader is inconsistent: {0}")]
    Invalid(String),
    #[error(transparent)]
    Combiners(#[from] EmulateError),
}

/// The four texture registers of every pixel, and which pixels
/// `cull_fragment` discarded.
pub struct Shaded {
    pub textures: [Vec<u8>; 4],
    pub culled: Vec<bool>,
    /// The depth `dot_product_depth_replace` gave each pixel, in
    /// coordinate units (1/65536), where the program replaces it.
    pub depth: Vec<Option<i32>>,
}

/// `⌊a / b⌋` for b > 0.
#[inline]
pub fn floor_div(a: i32, b: i32) -> i32 {
    a.div_euclid(b)
}

/// A matrix entry, scale or bias in units of 1/4096.
pub fn matrix_units(v: f32) -> i32 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(-8.0, 8.0) };
    (v * MATRIX_ONE as f32).round() as i32
}

/// How unit `unit`'s texture image is laid out for `op`: a 2-D image, a
/// cube map (six square faces stacked top to bottom, +X −X +Y −Y +Z −Z) or
/// a 3-D texture (square slices stacked top to bottom, r = 0 on top).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    Flat,
    Cube,
    Volume,
}

/// The image layout the stage's lookup reads.
pub fn layout(op: &Operation) -> Layout {
    match op {
        Operation::TextureCubeMap => Layout::Cube,
        Operation::Texture3d => Layout::Volume,
        Operation::DotProduct { family, step, .. } if family.has_output(*step) => match family {
            DotFamily::Texture3d => Layout::Volume,
            DotFamily::CubeMap
            | DotFamily::ReflectEyeFromQs
            | DotFamily::ReflectConstEye
            | DotFamily::DiffuseReflectEyeFromQs
            | DotFamily::DiffuseReflectConstEye => Layout::Cube,
            _ => Layout::Flat,
        },
        _ => Layout::Flat,
    }
}

/// Whether unit `unit`'s coordinates are read as directions (signed).
pub fn signed_coordinates(op: &Operation) -> bool {
    matches!(op, Operation::CullFragment(_) | Operation::DotProduct { .. } | Operation::TextureCubeMap)
}

/// Runs the texture-shader stages on every pixel.
pub fn shade(program: &TextureShader, inputs: &TextureInputs) -> Result<Shaded, TsEmulateError> {
    check(program, inputs)?;
    let n = inputs.width * inputs.height;
    let mut pixels = vec![([[0u8; 4]; 4], false, None); n];
    let width = inputs.width.max(1);
    pixels.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        for (x, px) in row.iter_mut().enumerate() {
            *px = pixel(program, inputs, x, y);
        }
    });
    let mut textures: [Vec<u8>; 4] = Default::default();
    for (unit, t) in textures.iter_mut().enumerate() {
        *t = pixels.iter().flat_map(|(texels, _, _)| texels[unit]).collect();
    }
    Ok(Shaded {
        textures,
        culled: pixels.iter().map(|p| p.1).collect(),
        depth: pixels.iter().map(|p| p.2).collect(),
    })
}

fn check(program: &TextureShader, inputs: &TextureInputs) -> Result<(), TsEmulateError> {
    if let Some(e) = super::validate(program).first() {
        return Err(TsEmulateError::Invalid(e.to_string()));
    }
    for (stage, op) in program.stages.iter().enumerate() {
        let Some(t) = inputs.textures.get(stage).copied().flatten() else { continue };
        let why = match layout(op) {
            Layout::Cube if t.height != 6 * t.width => {
                "a cube map is six square faces stacked: height = 6 × width"
            }
            Layout::Volume if t.height % t.width != 0 => {
                "a 3-D texture is square slices stacked: height = depth × width"
            }
            _ => continue,
        };
        return Err(TsEmulateError::Unsupported { stage, name: op.name(), why });
    }
    let expected = inputs.width.saturating_mul(inputs.height).saturating_mul(4);
    for unit in 0..MAX_STAGES {
        if let Some(t) = inputs.textures[unit] {
            if t.width > MAX_TEXTURE_SIDE || t.height > MAX_TEXTURE_SIDE || t.width == 0 || t.height == 0 {
                return Err(TsEmulateError::TooLarge {
                    what: format!("texture {unit}"),
                    width: t.width,
                    height: t.height,
                });
            }
            let need = t.width as usize * t.height as usize * 4;
            if t.rgba.len() != need {
                return Err(TsEmulateError::SizeMismatch {
                    what: format!("texture {unit}"),
                    got: t.rgba.len(),
                    expected: need,
                    width: t.width as usize,
                    height: t.height as usize,
                });
            }
        }
        if let Some(c) = inputs.coords[unit] {
            if c.len() != expected {
                return Err(TsEmulateError::SizeMismatch {
                    what: format!("coordinates of unit {unit}"),
                    got: c.len(),
                    expected,
                    width: inputs.width,
                    height: inputs.height,
                });
            }
        }
    }
    Ok(())
}

/// Unit `unit`'s (s, t, r, q) at pixel (x, y), in coordinate units.
fn coordinates(inputs: &TextureInputs, unit: usize, x: usize, y: usize, signed: bool) -> [i32; 4] {
    match inputs.coords[unit] {
        Some(c) => {
            let at = (y * inputs.width + x) * 4;
            [0, 1, 2, 3].map(|k| coordinate_from_byte(c[at + k], signed))
        }
        None => [default_coordinate(x, inputs.width), default_coordinate(y, inputs.height), 0, COORD_ONE],
    }
}

/// (i + ½)/n in coordinate units, rounded to nearest.
pub fn default_coordinate(i: usize, n: usize) -> i32 {
    let n = n.max(1) as i64;
    ((2 * i as i64 + 1) * COORD_ONE as i64 + n).div_euclid(2 * n) as i32
}

/// A coordinate byte: b/255, or (2b − 255)/255 for a direction, in
/// coordinate units rounded to nearest.
pub fn coordinate_from_byte(b: u8, signed: bool) -> i32 {
    let v = if signed { 2 * b as i32 - 255 } else { b as i32 };
    floor_div(v * 2 * COORD_ONE + 255, 510)
}

/// A byte as a coordinate in [0, 1] (dependent lookups read texels so).
fn unit_coordinate(k: u8) -> i32 {
    coordinate_from_byte(k, false)
}

/// The texel index of normalized coordinate `c` (divided by `q`) in a side of `n`, clamped to the edge.
pub fn texel_index(c: i32, q: i32, n: i32) -> i32 {
    if q <= 0 {
        return 0;
    }
    let c = c.clamp(-2 * COORD_ONE, 2 * COORD_ONE);
    floor_div(c * n, q).clamp(0, n - 1)
}

fn fetch(image: Option<Image>, ix: i32, iy: i32) -> [u8; 4] {
    let Some(im) = image else { return [0; 4] };
    let x = ix.clamp(0, im.width as i32 - 1) as usize;
    let y = iy.clamp(0, im.height as i32 - 1) as usize;
    let at = (y * im.width as usize + x) * 4;
    [im.rgba[at], im.rgba[at + 1], im.rgba[at + 2], im.rgba[at + 3]]
}

/// A lookup at normalized (s, t), both divided by q.
fn lookup(image: Option<Image>, s: i32, t: i32, q: i32) -> [u8; 4] {
    let Some(im) = image else { return [0; 4] };
    fetch(image, texel_index(s, q, im.width as i32), texel_index(t, q, im.height as i32))
}

/// A signed DSDT component: max(k, −127) in units of 1/127.
pub fn signed_component(k: u8) -> i32 {
    (k as i8 as i32).max(-127)
}

/// The offset ⌊(a·ds + b·dt)·16/127⌋ in coordinate units (a, b in 1/4096).
pub fn offset(a: i32, b: i32, ds: i32, dt: i32) -> i32 {
    floor_div((a * ds + b * dt) * 16, 127)
}

/// The depth `dot_product_depth_replace` gives a fragment: z/w in
/// coordinate units, ⌊z·65536/w⌋ clamped to [0, 65536]; 65536 (1) where
/// w = 0.
pub fn replaced_depth(z: i32, w: i32) -> i32 {
    if w == 0 {
        return COORD_ONE;
    }
    let (z, w) = if w < 0 { (-(z as i64), -(w as i64)) } else { (z as i64, w as i64) };
    (z * COORD_ONE as i64).div_euclid(w).clamp(0, COORD_ONE as i64) as i32
}

/// One pixel: the four texture registers, whether it was culled, and the
/// depth a depth-replace stage gave it.
fn pixel(
    program: &TextureShader,
    inputs: &TextureInputs,
    x: usize,
    y: usize,
) -> ([[u8; 4]; 4], bool, Option<i32>) {
    let mut out = [[0u8; 4]; 4];
    // Dot products of the current group, in coordinate units, its stages'
    // q (the eye vector of `eye_from_qs`) and its constant eye (1/256).
    let mut dots = [0i32; 3];
    let mut eyes = [0i32; 3];
    let mut const_eye = [0i32; 3];
    let mut culled = false;
    let mut depth = None;
    for unit in 0..MAX_STAGES {
        let op = program.stage(unit);
        let c = coordinates(inputs, unit, x, y, signed_coordinates(&op));
        let image = inputs.textures[unit];
        out[unit] = match op {
            Operation::Nop => [0; 4],
            Operation::Texture1d => lookup(image, c[0], 0, c[3]),
            Operation::Texture2d | Operation::TextureRectangle => lookup(image, c[0], c[1], c[3]),
            Operation::PassThrough => {
                c.map(|v| floor_div(v * 255 + COORD_ONE / 2, COORD_ONE).clamp(0, 255) as u8)
            }
            Operation::CullFragment(conditions) => {
                let keep = conditions.iter().zip(c).all(|(cond, v)| match cond {
                    CullCondition::GequalToZero => v >= 0,
                    CullCondition::LessThanZero => v < 0,
                });
                culled |= !keep;
                [0; 4]
            }
            Operation::Offset { rectangle, previous, matrix, scale } => {
                offset_stage(image, out[previous as usize], c, rectangle, matrix, scale)
            }
            Operation::Dependent { green_blue, previous } => {
                let p = out[previous as usize];
                let (s, t) = if green_blue { (p[1], p[2]) } else { (p[3], p[0]) };
                lookup(image, unit_coordinate(s), unit_coordinate(t), COORD_ONE)
            }
            Operation::DotProduct { family, step, previous, mapping, eye } => {
                dots[step as usize] = dot(c, out[previous as usize], mapping);
                if family == DotFamily::DepthReplace && step == 1 {
                    depth = Some(replaced_depth(dots[0], dots[1]));
                }
                if step == 0 {
                    const_eye = eye.map_or([0; 3], |e| e.map(eye_units));
                }
                eyes[step as usize] = c[3];
                if step == 1 && family.has_output(1) {
                    // The diffuse cube map reads N = (dot₀, dot₁, dot₂): the
                    // next stage's dot product is computed here (its unit
                    // reads a stage before this group, so it is known).
                    if let Operation::DotProduct { previous: p, mapping: m, .. } = program.stage(unit + 1) {
                        let next = program.stage(unit + 1);
                        let c2 = coordinates(inputs, unit + 1, x, y, signed_coordinates(&next));
                        dots[2] = dot(c2, out[p as usize], m);
                    }
                }
                dot_result(image, family, step, &dots, eyes, const_eye)
            }
            Operation::Texture3d => volume_lookup(image, [c[0], c[1], c[2]], c[3]),
            Operation::TextureCubeMap => cube_lookup(image, [c[0], c[1], c[2]]),
        };
    }
    (out, culled, depth)
}

fn offset_stage(
    image: Option<Image>,
    dsdt: [u8; 4],
    c: [i32; 4],
    rectangle: bool,
    matrix: [f32; 4],
    scale: Option<(f32, f32)>,
) -> [u8; 4] {
    let m = matrix.map(matrix_units);
    let (ds, dt) = (signed_component(dsdt[0]), signed_component(dsdt[1]));
    let (os, ot) = (offset(m[0], m[2], ds, dt), offset(m[1], m[3], ds, dt));
    let mut texel = match (rectangle, image) {
        (_, None) => [0; 4],
        (false, Some(_)) => lookup(image, c[0] + os, c[1] + ot, COORD_ONE),
        (true, Some(im)) => {
            let index = |v: i32, off: i32, n: u32| {
                floor_div(
                    v.clamp(-2 * COORD_ONE, 2 * COORD_ONE) * n as i32 + off.clamp(-(1 << 24), 1 << 24),
                    COORD_ONE,
                )
            };
            fetch(image, index(c[0], os, im.width), index(c[1], ot, im.height))
        }
    };
    if let Some((scale, bias)) = scale {
        let factor = scale_factor(matrix_units(scale), matrix_units(bias), dsdt[2]);
        for v in &mut texel[..3] {
            *v = scaled(*v, factor) as u8;
        }
    }
    texel
}

/// clamp(scale·mag + bias, 0, 1) in units of 1/(4096·255).
pub fn scale_factor(scale: i32, bias: i32, mag: u8) -> i32 {
    (scale * mag as i32 + bias * 255).clamp(0, MATRIX_ONE * 255)
}

/// v·factor rounded to nearest (ties up).
pub fn scaled(v: u8, factor: i32) -> i32 {
    let one = MATRIX_ONE * 255;
    floor_div(v as i32 * factor + one / 2, one)
}

/// dot((s, t, r), mapped RGB) in coordinate units.
fn dot(c: [i32; 4], texel: [u8; 4], mapping: DotMapping) -> i32 {
    let m = |k: u8| match mapping {
        DotMapping::UnsignedIdentity => k as i32,
        DotMapping::ExpandNormal => 2 * k as i32 - 255,
    };
    floor_div(c[0] * m(texel[0]) + c[1] * m(texel[1]) + c[2] * m(texel[2]), 255)
}

fn dot_result(
    image: Option<Image>,
    family: DotFamily,
    step: u8,
    dots: &[i32; 3],
    eyes: [i32; 3],
    const_eye: [i32; 3],
) -> [u8; 4] {
    if !family.has_output(step) {
        return [0; 4];
    }
    match family {
        DotFamily::Texture2d => lookup(image, dots[0], dots[1], COORD_ONE),
        DotFamily::Rectangle => {
            let index = |d: i32| floor_div(d, COORD_ONE);
            fetch(image, index(dots[0]), index(dots[1]))
        }
        DotFamily::DepthReplace => [0; 4],
        DotFamily::Texture3d => volume_lookup(image, *dots, COORD_ONE),
        DotFamily::CubeMap => cube_lookup(image, *dots),
        DotFamily::DiffuseReflectEyeFromQs | DotFamily::DiffuseReflectConstEye if step == 1 => {
            cube_lookup(image, *dots)
        }
        DotFamily::ReflectEyeFromQs | DotFamily::DiffuseReflectEyeFromQs => {
            cube_lookup(image, reflect(dots.map(|d| floor_div(d, 256)), eyes.map(|q| floor_div(q, 256))))
        }
        DotFamily::ReflectConstEye | DotFamily::DiffuseReflectConstEye => {
            cube_lookup(image, reflect(dots.map(|d| floor_div(d, 256)), const_eye))
        }
    }
}

/// A constant eye component, clamped to [−2, 2], in units of 1/256.
pub fn eye_units(v: f32) -> i32 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(-2.0, 2.0) };
    (v * 256.0).round() as i32
}

/// R = 2·N·(N·E)/(N·N) − E (NV_texture_shader's reflection), N and E in
/// units of 1/256, each component's quotient rounded down; R = −E when N = 0.
pub fn reflect(n: [i32; 3], e: [i32; 3]) -> [i32; 3] {
    let ne = n[0] * e[0] + n[1] * e[1] + n[2] * e[2];
    let nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    if nn == 0 {
        return e.map(|v| -v);
    }
    [0, 1, 2].map(|k| floor_div(2 * n[k] * ne, nn) - e[k])
}

/// A nearest, clamp-to-edge lookup of a 3-D texture (square slices stacked)
/// at (s, t, r) / q.
fn volume_lookup(image: Option<Image>, c: [i32; 3], q: i32) -> [u8; 4] {
    let Some(im) = image else { return [0; 4] };
    let side = im.width as i32;
    let depth = (im.height / im.width.max(1)) as i32;
    let (ix, iy, iz) = (texel_index(c[0], q, side), texel_index(c[1], q, side), texel_index(c[2], q, depth));
    fetch(image, ix, iz * side + iy)
}

/// The face and texel of direction v (any scale) in a cube map of faces
/// `size`² (GL's face selection, ties to x then y; s = (sc/|ma| + 1)/2).
pub fn cube_texel(v: [i32; 3], size: i32) -> (i32, i32, i32) {
    let [x, y, z] = v.map(|c| c.clamp(-(1 << 18), 1 << 18));
    let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
    let (face, sc, tc, ma) = if ax >= ay && ax >= az {
        if x >= 0 {
            (0, -z, -y, ax)
        } else {
            (1, z, -y, ax)
        }
    } else if ay >= az {
        if y >= 0 {
            (2, x, z, ay)
        } else {
            (3, x, -z, ay)
        }
    } else if z >= 0 {
        (4, x, -y, az)
    } else {
        (5, -x, -y, az)
    };
    if ma == 0 {
        return (0, 0, 0);
    }
    let index = |c: i32| floor_div((c + ma) * size, 2 * ma).clamp(0, size - 1);
    (face, index(sc), index(tc))
}

fn cube_lookup(image: Option<Image>, v: [i32; 3]) -> [u8; 4] {
    let Some(im) = image else { return [0; 4] };
    let size = im.width as i32;
    let (face, ix, iy) = cube_texel(v, size);
    fetch(image, ix, face * size + iy)
}

/// A `!!TS1.0` + `!!RC1.0` setup on every pixel: the texture-shader stages
/// compute texture0..3 (`inputs.textures` is ignored), the combiners run
/// on them, and culled pixels are (0, 0, 0, 0).
pub fn emulate(
    config: &CombinerConfig,
    program: &TextureShader,
    inputs: &Inputs,
    textures: &TextureInputs,
    precision: Precision,
) -> Result<Vec<u8>, TsEmulateError> {
    let shaded = shade(program, textures)?;
    let registers = Inputs {
        width: textures.width,
        height: textures.height,
        textures: [0, 1, 2, 3].map(|k| Some(shaded.textures[k].as_slice())),
        ..*inputs
    };
    let mut out = emulator::emulate(config, &registers, precision)?;
    for (px, culled) in out.chunks_exact_mut(4).zip(&shaded.culled) {
        if *culled {
            px.fill(0);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_coordinate_byte_comes_back_through_pass_through() {
        for b in 0..=255u8 {
            let c = coordinate_from_byte(b, false);
            assert_eq!(floor_div(c * 255 + COORD_ONE / 2, COORD_ONE), b as i32);
        }
        assert_eq!(coordinate_from_byte(255, true), COORD_ONE);
        assert_eq!(coordinate_from_byte(0, true), -COORD_ONE);
    }

    #[test]
    fn default_coordinates_are_pixel_centres() {
        assert_eq!(default_coordinate(0, 2), COORD_ONE / 4);
        assert_eq!(default_coordinate(1, 2), 3 * COORD_ONE / 4);
        // An image of the output's size is read texel for texel.
        for n in 1..300 {
            for i in 0..n {
                assert_eq!(
                    texel_index(default_coordinate(i, n), COORD_ONE, n as i32),
                    i as i32,
                    "{i} of {n}"
                );
            }
        }
    }

    #[test]
    fn signed_bytes_are_twos_complement_over_127() {
        assert_eq!([0u8, 1, 127, 128, 129, 255].map(signed_component), [0, 1, 127, -127, -127, -1]);
        assert_eq!(offset(0, 0, 127, -127), 0, "a zero matrix adds nothing");
        assert_eq!(
            offset(MATRIX_ONE, 0, 127, 0),
            COORD_ONE / 8 * 8 * 16 / 16,
            "m = 1, ds = 1 → one unit of s"
        );
    }

    #[test]
    fn cube_faces_follow_the_major_axis() {
        assert_eq!(cube_texel([10, 0, 0], 4).0, 0);
        assert_eq!(cube_texel([-10, 1, 1], 4).0, 1);
        assert_eq!(cube_texel([1, 10, 1], 4).0, 2);
        assert_eq!(cube_texel([1, -10, 1], 4).0, 3);
        assert_eq!(cube_texel([1, 1, 10], 4).0, 4);
        assert_eq!(cube_texel([1, 1, -10], 4).0, 5);
        // The centre of +Z is the centre of the face; its corner (x = y = −z… ) the edge.
        assert_eq!(cube_texel([0, 0, 10], 4), (4, 2, 2));
        assert_eq!(cube_texel([0, 0, 0], 4), (0, 0, 0));
    }

    #[test]
    fn reflection_of_the_eye_about_the_normal() {
        // N = z, E = (1, 0, 1): R = 2·(0,0,1)·1/1 − E = (−1, 0, 1).
        assert_eq!(reflect([0, 0, 256], [256, 0, 256]), [-256, 0, 256]);
        assert_eq!(reflect([0, 0, 0], [3, 4, 5]), [-3, -4, -5]);
    }
}
