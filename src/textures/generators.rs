//! Texture generators from the papers:
//! - [`normalize_cube`]: the normalization cube map of Kilgard 2000, Section 5.2
//!   and Appendix D, 8-bit (Kilgard's `128 + 127·v` encoding) or 16-bit;
//! - [`normal_map`]: a normal map from a height field (Kilgard 2000, Section 5.3,
//!   Appendix E) with Kilgard's mipmap filter (Appendix F, Section 2.6.3) that
//!   keeps the averaged normal's length in alpha;
//! - [`dual_paraboloid`]: dual-paraboloid environment maps (Heidrich & Seidel 1999
//!   Section 4.1, Eq. 5) with solid-angle-weighted mipmaps (Section 4.2, Eq. 6);
//! - [`hs_fresnel_distribution`], [`hs_geometry`]: the Torrance-Sparrow
//!   factor textures F·D and G/(π cos β) of Heidrich & Seidel 1999, Section 3.1 (Eq. 1-3);
//! - [`exponent_lut`]: a specular exponent lookup table (GeForce3 Phong, Section 5.2).

use std::f32::consts::PI;

/// The largest face of a generated cube map (`normalize_cube(size)`): 1024²
/// texels × 6 faces is ~6 M texels, about a second and 400 MB with mipmaps
/// and the exact reference's copy; the papers' normalization cubes are 32²
/// (Kilgard 2000, Appendix D) and the GeForce-era limit was 512. A program asking
/// for more is refused where it declares the texture (`ir::lower`); the
/// generators clamp as a last guard.
pub const MAX_CUBE_FACE: u32 = 1024;

/// The largest side of a generated 2-D table (height fields, the BRDF factor
/// textures, exponent tables, dual-paraboloid maps): 4096² = 16 M texels.
pub const MAX_TABLE_SIDE: u32 = 4096;

use super::sampling::{cube_direction, CubeFace, Level, TexelFormat, Texture2D, TextureCube, Wrap};

/// Range compression [−1, 1] → [0, 1] (Kilgard 2000, Section 5.2).
#[inline]
pub fn range_compress(v: f32) -> f32 {
    0.5 * v + 0.5
}

/// Range expansion [0, 1] → [−1, 1], the combiners' `GL_EXPAND_NORMAL`.
#[inline]
pub fn expand(v: f32) -> f32 {
    2.0 * v - 1.0
}

fn normalize3(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 && l.is_finite() {
        v.map(|c| c / l)
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// Kilgard's 8-bit vector encoding, `(GLubyte)(128 + 127·v)` (Appendices D, E):
/// truncation, as C's float-to-unsigned-byte conversion does.
#[inline]
pub fn kilgard_byte(v: f32) -> u8 {
    (128.0 + 127.0 * v.clamp(-1.0, 1.0)).floor().clamp(0.0, 255.0) as u8
}

/// Bits per channel of a normalization cube map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum CubeBits {
    /// RGB8 with Kilgard's `128 + 127·v` encoding (Appendix D).
    Eight,
    /// 16-bit unsigned, range-compressed and rounded to nearest (GeForce3 Phong, Section 5.1).
    Sixteen,
}

/// The normalization cube map (Kilgard 2000, Appendix D): each texel stores the
/// range-compressed unit vector through its centre; alpha is 1. Expanding a
/// fetched texel with [`expand`] gives the normalized direction.
pub fn normalize_cube(size: u32, bits: CubeBits) -> TextureCube {
    let size = size.clamp(1, MAX_CUBE_FACE);
    let face = |face: CubeFace| {
        let mut texels = Vec::with_capacity((size * size) as usize);
        for y in 0..size {
            for x in 0..size {
                let s = (x as f32 + 0.5) / size as f32;
                let t = (y as f32 + 0.5) / size as f32;
                let n = normalize3(cube_direction(face, s, t));
                let rgb = match bits {
                    CubeBits::Eight => n.map(|c| kilgard_byte(c) as f32 / 255.0),
                    CubeBits::Sixteen => n.map(|c| TexelFormat::Rgba16.quantize(range_compress(c))),
                };
                texels.push([rgb[0], rgb[1], rgb[2], 1.0]);
            }
        }
        let format = match bits {
            CubeBits::Eight => TexelFormat::Rgba8,
            CubeBits::Sixteen => TexelFormat::Rgba16,
        };
        Texture2D { format, wrap: Wrap::ClampToEdge, levels: vec![Level::new(size, size, texels)] }
    };
    TextureCube { faces: CubeFace::ALL.map(face) }
}

/// A height field with values in [0, 1], row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct HeightField {
    pub width: u32,
    pub height: u32,
    pub heights: Vec<f32>,
}

impl HeightField {
    /// Procedural dimples on a grid (a golf ball's surface, Kilgard 2000
    /// Section 2.4.2): `cells` round pits per side.
    pub fn dimples(size: u32, cells: u32) -> HeightField {
        let size = size.clamp(1, MAX_TABLE_SIDE);
        let cells = cells.max(1) as f32;
        let heights = (0..size * size)
            .map(|i| {
                let u = (i % size) as f32 / size as f32 * cells;
                let v = (i / size) as f32 / size as f32 * cells;
                let (fu, fv) = (u.fract() - 0.5, v.fract() - 0.5);
                let r2 = (fu * fu + fv * fv) * 4.0;
                if r2 < 0.8 {
                    1.0 - (0.8 - r2) / 0.8
                } else {
                    1.0
                }
            })
            .collect();
        HeightField { width: size, height: size, heights }
    }

    /// A constant (flat) height field.
    pub fn flat(size: u32) -> HeightField {
        let size = size.clamp(1, MAX_TABLE_SIDE);
        HeightField { width: size, height: size, heights: vec![0.5; (size * size) as usize] }
    }

    fn at(&self, x: u32, y: u32) -> f32 {
        self.heights[((y % self.height) * self.width + x % self.width) as usize]
    }
}

/// Storage of a generated normal map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum NormalMapFormat {
    /// Kilgard's BGRA8 texels: RGB `128 + 127·n`, alpha `255·mag` (Appendices E-F).
    Rgba8,
    /// The same filter in f32: RGB range-compressed, alpha the length.
    F32,
}

/// A normal map from a wrapping height field (Kilgard 2000, Appendix E: forward
/// differences to the right and up, n = (dcy, −dcx, 1)/|…| with dc = scale·(c − c')),
/// with every mip level built by Kilgard's filter (Appendix F): each 2×2
/// block's vectors are denormalized by their alpha, averaged; the average's
/// length goes to alpha and its direction, normalized, to RGB. Texels are
/// range-compressed: expand RGB, and alpha is the (unsigned) length.
///
/// Two deliberate departures from the printed code: the neighbour indices
/// use `% w` for columns and `% h` for rows (the listing swaps them, which
/// only matters for non-square maps), and 8-bit texels decode as
/// `(byte − 128)/127`, the exact inverse of the encoding (the listing's
/// `byte/127 − 1` adds a bias of 1/127 at every level).
pub fn normal_map(height: &HeightField, scale: f32, format: NormalMapFormat) -> Texture2D {
    let (w, h) = (height.width, height.height);
    // Working representation: unit vector + magnitude, both f32.
    let mut level: Vec<([f32; 3], f32)> = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let c = height.at(x, y);
            let cx = height.at(x + 1, y);
            let cy = height.at(x, y + 1);
            let dcx = scale * (c - cx);
            let dcy = scale * (c - cy);
            level.push((normalize3([dcy, -dcx, 1.0]), 1.0));
        }
    }
    // Quantize as the paper stores it, so coarser levels filter stored values.
    let store = |v: &mut Vec<([f32; 3], f32)>| {
        if format == NormalMapFormat::Rgba8 {
            for (n, mag) in v.iter_mut() {
                *n = n.map(|c| (kilgard_byte(c) as f32 - 128.0) / 127.0);
                *mag = (255.0 * mag.clamp(0.0, 1.0)).floor() / 255.0;
            }
        }
    };
    store(&mut level);
    let to_level = |w: u32, h: u32, v: &[([f32; 3], f32)]| {
        let texels = v
            .iter()
            .map(|(n, mag)| match format {
                NormalMapFormat::Rgba8 => {
                    // Store exactly the byte 128 + 127·n that the paper writes.
                    let b = n.map(|c| (128.0 + 127.0 * c).round() / 255.0);
                    [b[0], b[1], b[2], *mag]
                }
                NormalMapFormat::F32 => {
                    [range_compress(n[0]), range_compress(n[1]), range_compress(n[2]), *mag]
                }
            })
            .collect();
        Level::new(w, h, texels)
    };
    let tex_format = match format {
        NormalMapFormat::Rgba8 => TexelFormat::Rgba8,
        NormalMapFormat::F32 => TexelFormat::F32,
    };
    let mut levels = vec![to_level(w, h, &level)];
    let (mut cw, mut ch) = (w, h);
    while cw > 1 || ch > 1 {
        let (nw, nh) = ((cw / 2).max(1), (ch / 2).max(1));
        let mut next = Vec::with_capacity((nw * nh) as usize);
        for i in 0..nh {
            for j in 0..nw {
                let mut sum = [0.0f32; 3];
                for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                    let (yy, xx) = ((2 * i + dy) % ch, (2 * j + dx) % cw);
                    let (n, mag) = level[(yy * cw + xx) as usize];
                    for c in 0..3 {
                        sum[c] += mag * n[c];
                    }
                }
                let l = (sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]).sqrt();
                let n = if l == 0.0 { [0.0, 0.0, 1.0] } else { sum.map(|c| c / l) };
                next.push((n, (l / 4.0).min(1.0)));
            }
        }
        store(&mut next);
        levels.push(to_level(nw, nh, &next));
        level = next;
        (cw, ch) = (nw, nh);
    }
    Texture2D { format: tex_format, wrap: Wrap::Repeat, levels }
}

/// Which hemisphere of a dual-paraboloid map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum ParaboloidFace {
    /// Directions with z ≥ 0 (towards a viewer looking down −z).
    Front,
    /// Directions with z < 0.
    Back,
}

/// Direction → (face, u, v) of Heidrich & Seidel 1999, Section 4.1: the paraboloid of Eq. 5
/// has normal (x, y, 1), the halfway vector of d and ±z, so
/// (x, y) = (dx, dy)/(1 ± dz); u = (x + 1)/2, v = (y + 1)/2.
pub fn paraboloid_uv(d: [f32; 3]) -> (ParaboloidFace, f32, f32) {
    let d = normalize3(d.map(|c| if c.is_finite() { c } else { 0.0 }));
    let (face, denom) =
        if d[2] >= 0.0 { (ParaboloidFace::Front, 1.0 + d[2]) } else { (ParaboloidFace::Back, 1.0 - d[2]) };
    (face, 0.5 * (d[0] / denom + 1.0), 0.5 * (d[1] / denom + 1.0))
}

/// (face, u, v) → unit direction, the inverse of [`paraboloid_uv`] inside the
/// unit circle; outside it (the extension to [−1, 1]² that Section 4.2 uses
/// for mipmaps) it continues the paraboloid into the other hemisphere.
pub fn paraboloid_direction(face: ParaboloidFace, u: f32, v: f32) -> [f32; 3] {
    let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    let r2 = x * x + y * y;
    let z = (1.0 - r2) / (1.0 + r2);
    let z = if face == ParaboloidFace::Front { z } else { -z };
    [2.0 * x / (1.0 + r2), 2.0 * y / (1.0 + r2), z]
}

/// Solid angle of a texel at (x, y) ∈ [−1, 1]² with area `da` (Eq. 6):
/// dω = dA / |(x, y, f(x, y))|², f = ½ − ½(x² + y²), i.e. 4·dA/(1 + r²)².
pub fn paraboloid_solid_angle(x: f32, y: f32, da: f32) -> f32 {
    let f = 0.5 - 0.5 * (x * x + y * y);
    da / (x * x + y * y + f * f)
}

/// A dual-paraboloid environment map: two square textures over [−1, 1]².
/// The front map's alpha is 1 inside the unit circle and 0 outside (Section
/// 4.1, used to select the map per pixel); the back map's alpha is 1.
#[derive(Clone, Debug, PartialEq)]
pub struct DualParaboloid {
    pub front: Texture2D,
    pub back: Texture2D,
}

impl DualParaboloid {
    /// Looks up a direction (bilinear in the selected map at `lod`).
    pub fn sample(&self, d: [f32; 3], filter: super::sampling::Filter, lod: f32) -> [f32; 4] {
        let (face, u, v) = paraboloid_uv(d);
        let map = if face == ParaboloidFace::Front { &self.front } else { &self.back };
        map.sample(u, v, filter, lod)
    }
}

/// Renders `environment(direction)` into a dual-paraboloid map of `size`²
/// per face, with mipmaps whose 2×2 blocks are averaged with weights
/// proportional to each texel's solid angle; a coarse texel's weight is the
/// sum of its children's (Section 4.2).
pub fn dual_paraboloid(
    size: u32,
    format: TexelFormat,
    environment: &dyn Fn([f32; 3]) -> [f32; 3],
) -> DualParaboloid {
    let size = size.clamp(1, MAX_TABLE_SIDE);
    let make = |face: ParaboloidFace| {
        let da = (2.0 / size as f32).powi(2);
        let mut colors = Vec::with_capacity((size * size) as usize);
        let mut weights = Vec::with_capacity((size * size) as usize);
        for j in 0..size {
            for i in 0..size {
                let u = (i as f32 + 0.5) / size as f32;
                let v = (j as f32 + 0.5) / size as f32;
                let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
                let c = environment(paraboloid_direction(face, u, v));
                let alpha = if face == ParaboloidFace::Back || x * x + y * y <= 1.0 { 1.0 } else { 0.0 };
                colors.push([c[0], c[1], c[2], alpha]);
                weights.push(paraboloid_solid_angle(x, y, da));
            }
        }
        let mut levels =
            vec![Level::new(size, size, colors.iter().map(|t| t.map(|c| format.quantize(c))).collect())];
        let mut n = size;
        while n > 1 {
            let m = n / 2;
            let mut next_c = Vec::with_capacity((m * m) as usize);
            let mut next_w = Vec::with_capacity((m * m) as usize);
            for j in 0..m {
                for i in 0..m {
                    let mut sum = [0.0f32; 4];
                    let mut wsum = 0.0;
                    for (dj, di) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                        let k = ((2 * j + dj) * n + 2 * i + di) as usize;
                        for c in 0..4 {
                            sum[c] += weights[k] * colors[k][c];
                        }
                        wsum += weights[k];
                    }
                    next_c.push(sum.map(|c| c / wsum));
                    next_w.push(wsum);
                }
            }
            colors = next_c;
            weights = next_w;
            n = m;
            levels.push(Level::new(n, n, colors.iter().map(|t| t.map(|c| format.quantize(c))).collect()));
        }
        Texture2D { format, wrap: Wrap::ClampToEdge, levels }
    };
    DualParaboloid { front: make(ParaboloidFace::Front), back: make(ParaboloidFace::Back) }
}

/// The environment `dual_paraboloid("file", face)` stands in with, both
/// faces (Heidrich & Seidel 1999, Sections 4.1-4.2): the procedural [`sky`],
/// 128² per face. The scene binder's data, which the reference (`oracle`)
/// reads too, as it reads the stand-in of a missing image.
pub fn dual_paraboloid_stand_in(format: TexelFormat) -> DualParaboloid {
    dual_paraboloid(128, format, &|dir| sky(dir, [0.3, 0.8, 0.5]))
}

/// A procedural sky for environment maps: a horizon-to-zenith gradient (y up),
/// a darker ground, and a sun disc around `sun`.
pub fn sky(direction: [f32; 3], sun: [f32; 3]) -> [f32; 3] {
    let d = normalize3(direction);
    let s = normalize3(sun);
    let up = d[1];
    let base = if up >= 0.0 {
        let t = up.sqrt();
        [0.8 - 0.5 * t, 0.85 - 0.35 * t, 1.0 - 0.1 * t]
    } else {
        [0.3, 0.25, 0.2]
    };
    let cos_sun = d[0] * s[0] + d[1] * s[1] + d[2] * s[2];
    let glow = if cos_sun > 0.995 { 4.0 } else { 0.0 };
    base.map(|c| c + glow)
}

/// The procedural [`sky`] as a cube map of `size`² faces: each texel the sky
/// in the direction through its centre (GL Table 3.19's inverse,
/// [`cube_direction`]). The stand-in for a cube map image that is missing.
pub fn sky_cube(size: u32, format: TexelFormat, sun: [f32; 3]) -> TextureCube {
    let size = size.clamp(1, MAX_CUBE_FACE);
    let face = |face: CubeFace| {
        let mut texels = Vec::with_capacity((size * size) as usize);
        for y in 0..size {
            for x in 0..size {
                let (s, t) = ((x as f32 + 0.5) / size as f32, (y as f32 + 0.5) / size as f32);
                let c = sky(cube_direction(face, s, t), sun);
                texels.push([c[0], c[1], c[2], 1.0]);
            }
        }
        Texture2D::new(format, Wrap::ClampToEdge, Level::new(size, size, texels))
    };
    TextureCube { faces: CubeFace::ALL.map(face) }
}

/// The sun of the procedural stand-ins for environment images.
pub const STAND_IN_SUN: [f32; 3] = [0.3, 0.8, 0.5];

/// Fresnel reflectance of a dielectric with relative index `n` for unpolarized
/// light at cos θ = `c` (the F of Torrance-Sparrow, Heidrich & Seidel 1999, Eq. 1).
pub fn fresnel(c: f32, n: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    let g2 = n * n + c * c - 1.0;
    if g2 <= 0.0 {
        return 1.0; // Total internal reflection.
    }
    let g = g2.sqrt();
    let a = (g - c) / (g + c);
    let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
    (0.5 * a * a * (1.0 + b * b)).clamp(0.0, 1.0)
}

/// Facet distribution D(cos δ): Torrance-Sparrow's Gaussian in the angle δ,
/// exp(−(δ/m)²), which is bounded by 1 as the F·D texture needs.
pub fn distribution(cos_delta: f32, m: f32) -> f32 {
    let delta = cos_delta.clamp(-1.0, 1.0).acos();
    (-(delta / m.max(1e-4)).powi(2)).exp()
}

/// Smith's shadowing-masking for one direction (Beckmann facets, the rational
/// approximation), with roughness `m` (RMS slope).
pub fn smith_g1(cos: f32, m: f32) -> f32 {
    let cos = cos.clamp(1e-6, 1.0);
    let tan = (1.0 - cos * cos).sqrt() / cos;
    if tan == 0.0 {
        return 1.0;
    }
    let a = 1.0 / (m.max(1e-4) * tan);
    if a >= 1.6 {
        1.0
    } else {
        (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
    }
}

/// The F·D texture of Heidrich & Seidel 1999, Section 3.1: u = cos θ (between l and h),
/// v = cos δ (between n and h), texel centres at (i + ½)/size.
pub fn hs_fresnel_distribution(size: u32, roughness: f32, index: f32, format: TexelFormat) -> Texture2D {
    let size = size.clamp(2, MAX_TABLE_SIDE);
    let texels = (0..size * size)
        .map(|k| {
            let cos_theta = ((k % size) as f32 + 0.5) / size as f32;
            let cos_delta = ((k / size) as f32 + 0.5) / size as f32;
            let fd = fresnel(cos_theta, index) * distribution(cos_delta, roughness);
            [fd, fd, fd, 1.0]
        })
        .collect();
    Texture2D::new(format, Wrap::ClampToEdge, Level::new(size, size, texels))
}

/// The G/(π cos β) texture of Heidrich & Seidel 1999, Section 3.1: u = cos α (n·l),
/// v = cos β (n·v). The term is singular at grazing view (cos β → 0); values
/// are stored divided by `scale` (multiply back after the lookup), and
/// fixed-point formats clamp to [0, 1] as the paper notes.
pub fn hs_geometry(size: u32, roughness: f32, scale: f32, format: TexelFormat) -> Texture2D {
    let size = size.clamp(2, MAX_TABLE_SIDE);
    let scale = if scale > 0.0 && scale.is_finite() { scale } else { 1.0 };
    let texels = (0..size * size)
        .map(|k| {
            let cos_alpha = ((k % size) as f32 + 0.5) / size as f32;
            let cos_beta = ((k / size) as f32 + 0.5) / size as f32;
            let g = smith_g1(cos_alpha, roughness) * smith_g1(cos_beta, roughness);
            let value = g / (PI * cos_beta) / scale;
            [value, value, value, 1.0]
        })
        .collect();
    Texture2D::new(format, Wrap::ClampToEdge, Level::new(size, size, texels))
}

/// Texels of an `exponent_table(n)` (the binder's size; the lowering's
/// bound of computing xⁿ instead of sampling it depends on it).
pub const EXPONENT_TABLE_SIZE: u32 = 256;

/// A 1-texel-high lookup table of x^exponent for x ∈ [0, 1] (GeForce3 Phong
/// Section 5.2: the texture-shader exponent by table lookup), texel centres at
/// (i + ½)/size; bilinear filtering interpolates between them.
pub fn exponent_lut(size: u32, exponent: f32, format: TexelFormat) -> Texture2D {
    let size = size.clamp(2, MAX_TABLE_SIDE);
    let texels = (0..size)
        .map(|i| {
            let x = (i as f32 + 0.5) / size as f32;
            let v = x.powf(exponent.max(0.0));
            [v, v, v, 1.0]
        })
        .collect();
    Texture2D::new(format, Wrap::ClampToEdge, Level::new(size, 1, texels))
}

/// Stand-in for a missing colour image: warm bricks, alpha 1.
pub fn brick_stand_in(size: u32) -> Level {
    let texels = (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as f32 / size as f32, (i / size) as f32 / size as f32);
            let row = (y * 8.0).floor();
            let bx = (x * 4.0 + if row as i32 % 2 == 0 { 0.0 } else { 0.5 }).fract();
            let by = (y * 8.0).fract();
            let mortar = bx < 0.04 || by < 0.08;
            if mortar {
                [0.85, 0.82, 0.75, 1.0]
            } else {
                let k = 0.85 + 0.15 * ((row * 1.7 + (x * 4.0).floor() * 2.3).sin() * 0.5 + 0.5);
                [0.72 * k, 0.32 * k, 0.2 * k, 1.0]
            }
        })
        .collect();
    Level::new(size, size, texels)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decoded_length_error(cube: &TextureCube) -> f32 {
        let mut worst = 0.0f32;
        for face in &cube.faces {
            for t in &face.levels[0].texels {
                let v = [expand(t[0]), expand(t[1]), expand(t[2])];
                let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                worst = worst.max((l - 1.0).abs());
            }
        }
        worst
    }

    #[test]
    fn normalize_cube_texels_are_unit_within_quantization() {
        let c8 = normalize_cube(32, CubeBits::Eight);
        let c16 = normalize_cube(32, CubeBits::Sixteen);
        let (e8, e16) = (decoded_length_error(&c8), decoded_length_error(&c16));
        // Kilgard's encoding decodes to (1 + 254·v)/255 − δ with δ ∈ [0, 2/255).
        assert!(e8 <= 3.0f32.sqrt() * 2.0 / 255.0, "8-bit error {e8}");
        assert!(e16 <= 3.0f32.sqrt() / 65535.0 + 1e-6, "16-bit error {e16}");
        assert!(e16 < e8, "16-bit must be strictly more accurate: {e16} vs {e8}");
        // Each texel points along its own direction.
        for face in CubeFace::ALL {
            let t = c16.faces[face as usize].levels[0].texel(5, 20);
            let d = normalize3(cube_direction(face, 5.5 / 32.0, 20.5 / 32.0));
            let v = [expand(t[0]), expand(t[1]), expand(t[2])];
            assert!((v[0] * d[0] + v[1] * d[1] + v[2] * d[2]) > 0.9999);
        }
    }

    fn mean_alpha(level: &Level) -> f32 {
        level.texels.iter().map(|t| t[3]).sum::<f32>() / level.texels.len() as f32
    }

    #[test]
    fn kilgard_filter_shrinks_bumpy_maps_and_keeps_flat_ones() {
        for format in [NormalMapFormat::Rgba8, NormalMapFormat::F32] {
            let bumpy = normal_map(&HeightField::dimples(64, 8), 4.0, format);
            assert_eq!(bumpy.levels.len(), 7);
            assert_eq!(mean_alpha(&bumpy.levels[0]), 1.0);
            let alphas: Vec<f32> = bumpy.levels.iter().map(mean_alpha).collect();
            // Golf-ball dimming: coarser levels are shorter on average.
            assert!(alphas[3] < 0.97, "{alphas:?}");
            // |mean of mag·n| ≤ mean of mag (triangle inequality), up to 8-bit rounding.
            for pair in alphas.windows(2) {
                assert!(pair[1] <= pair[0] + 0.01, "{alphas:?}");
            }
            let flat = normal_map(&HeightField::flat(32), 4.0, format);
            for level in &flat.levels {
                for t in &level.texels {
                    assert_eq!(t[3], 1.0);
                    let n = [expand(t[0]), expand(t[1]), expand(t[2])];
                    assert!(n[0].abs() < 0.01 && n[1].abs() < 0.01 && (n[2] - 1.0).abs() < 0.01, "{n:?}");
                }
            }
        }
    }

    #[test]
    fn normal_map_differences_follow_appendix_e() {
        // Height rising to the right: dcx < 0, so nx = 0 and ny = −dcx/len > 0.
        let hf =
            HeightField { width: 4, height: 4, heights: (0..16).map(|i| (i % 4) as f32 * 0.1).collect() };
        let nm = normal_map(&hf, 1.0, NormalMapFormat::F32);
        let t = nm.levels[0].texel(1, 1);
        let n = [expand(t[0]), expand(t[1]), expand(t[2])];
        let expected = normalize3([0.0, 0.1, 1.0]);
        for c in 0..3 {
            assert!((n[c] - expected[c]).abs() < 1e-5, "{n:?}");
        }
    }

    #[test]
    fn dual_paraboloid_round_trips_directions() {
        let mut worst = 0.0f32;
        for i in 0..200 {
            let a = i as f32 * 0.731;
            let b = (i as f32 * 0.377).sin() * 1.5;
            let d = [a.cos() * b.cos(), b.sin(), a.sin() * b.cos()];
            let (face, u, v) = paraboloid_uv(d);
            assert!((0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v));
            let back = paraboloid_direction(face, u, v);
            let dn = normalize3(d);
            worst = worst.max((0..3).map(|c| (back[c] - dn[c]).abs()).fold(0.0, f32::max));
        }
        assert!(worst < 1e-5, "{worst}");
        assert_eq!(paraboloid_uv([0.0, 0.0, 1.0]), (ParaboloidFace::Front, 0.5, 0.5));
        assert_eq!(paraboloid_uv([0.0, 0.0, -1.0]), (ParaboloidFace::Back, 0.5, 0.5));
    }

    #[test]
    fn paraboloid_mipmaps_weight_by_solid_angle() {
        // Sampling rate varies by a factor of 4 between centre and rim (Section 4.1).
        let ratio = paraboloid_solid_angle(0.0, 0.0, 1.0) / paraboloid_solid_angle(1.0, 0.0, 1.0);
        assert!((ratio - 4.0).abs() < 1e-5);
        // Environment: bright where y > 0.3. The 1×1 level is the solid-angle-weighted mean,
        // which differs from the plain texel mean (the rim of [−1,1]² counts less).
        let env = |d: [f32; 3]| if d[1] > 0.3 { [1.0, 1.0, 1.0] } else { [0.0, 0.0, 0.0] };
        let dp = dual_paraboloid(32, TexelFormat::F32, &env);
        let top = dp.front.levels.last().unwrap().texels[0][0];
        let plain = dp.front.levels[0].texels.iter().map(|t| t[0]).sum::<f32>() / 1024.0;
        let mut weighted = 0.0;
        let mut wsum = 0.0;
        for (k, t) in dp.front.levels[0].texels.iter().enumerate() {
            let (i, j) = (k % 32, k / 32);
            let (x, y) = ((i as f32 + 0.5) / 16.0 - 1.0, (j as f32 + 0.5) / 16.0 - 1.0);
            let w = paraboloid_solid_angle(x, y, 1.0);
            weighted += w * t[0];
            wsum += w;
        }
        assert!((top - weighted / wsum).abs() < 1e-4, "{top} vs {}", weighted / wsum);
        assert!((top - plain).abs() > 1e-3, "weighting must matter: {top} vs {plain}");
        let centre = dp.front.levels[0].texel(16, 16)[3];
        let corner = dp.front.levels[0].texel(0, 0)[3];
        assert_eq!((centre, corner), (1.0, 0.0));
    }

    #[test]
    fn brdf_factor_textures() {
        let fd = hs_fresnel_distribution(32, 0.3, 1.5, TexelFormat::F32);
        assert!(fd.levels[0].texels.iter().all(|t| (0.0..=1.0).contains(&t[0])));
        // D peaks at cos δ = 1, F rises towards grazing (cos θ → 0).
        let l = &fd.levels[0];
        assert!(l.texel(5, 31)[0] > l.texel(5, 10)[0]);
        assert!(l.texel(0, 31)[0] > l.texel(31, 31)[0]);
        assert!((fresnel(1.0, 1.5) - 0.04).abs() < 1e-4);
        // G/(π cos β) grows towards grazing view; 8-bit clamps, f32 does not.
        let g = hs_geometry(32, 0.3, 1.0, TexelFormat::F32);
        assert!(g.levels[0].texel(20, 0)[0] > 1.0);
        assert!(g.levels[0].texel(20, 0)[0] > g.levels[0].texel(20, 31)[0]);
        let g8 = hs_geometry(32, 0.3, 1.0, TexelFormat::Rgba8);
        assert_eq!(g8.levels[0].texel(20, 0)[0], 1.0);
        let g8s = hs_geometry(32, 0.3, 8.0, TexelFormat::Rgba8);
        assert!(g8s.levels[0].texel(20, 0)[0] < 1.0, "a scale keeps the grazing values");
        assert!(g.levels[0].texels.iter().all(|t| t[0].is_finite()));
    }

    #[test]
    fn exponent_lut_matches_pow_between_centres() {
        let lut = exponent_lut(256, 64.0, TexelFormat::F32);
        for x in [0.5f32, 0.9, 0.97] {
            let s = lut.sample(x, 0.5, super::super::sampling::Filter::Bilinear, 0.0)[0];
            assert!((s - x.powf(64.0)).abs() < 0.02, "{x}: {s}");
        }
        let lut8 = exponent_lut(256, 64.0, TexelFormat::Rgba8);
        let err8 = (lut8.levels[0].texel(200, 0)[0] - ((200.5f32) / 256.0).powf(64.0)).abs();
        assert!(err8 <= 0.5 / 255.0 + 1e-6);
    }
}
