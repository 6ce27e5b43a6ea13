//! Texture storage and GL-style sampling: 2D textures with mip chains and cube
//! maps (face selection of the GL spec, Kilgard 2000, Appendix A Table 1),
//! nearest / bilinear / trilinear filtering, clamp-to-edge or repeat.
//!
//! Texels are kept as f32 RGBA but *quantized to their format on creation*
//! ([`TexelFormat::quantize`]), so an RGBA8 texture holds exactly the values
//! k/255 that 8-bit hardware would hold; a bit-faithful consumer recovers the
//! integer as `round(v·255)`.

use serde::{Deserialize, Serialize};

/// Precision of a texture's stored texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TexelFormat {
    /// Unsigned 8-bit normalized: k/255, k ∈ 0..=255.
    Rgba8,
    /// Signed 8-bit normalized (NV texture shader formats): k/127, k ∈ −127..=127.
    Signed8,
    /// Unsigned 16-bit normalized: k/65535.
    Rgba16,
    /// 32-bit float, unquantized.
    F32,
}

impl TexelFormat {
    /// The nearest value this format can store.
    #[inline]
    pub fn quantize(self, v: f32) -> f32 {
        let v = if v.is_nan() { 0.0 } else { v };
        match self {
            TexelFormat::Rgba8 => (v.clamp(0.0, 1.0) * 255.0).round() / 255.0,
            TexelFormat::Signed8 => (v.clamp(-1.0, 1.0) * 127.0).round() / 127.0,
            TexelFormat::Rgba16 => (v.clamp(0.0, 1.0) * 65535.0).round() / 65535.0,
            TexelFormat::F32 => v,
        }
    }
}

/// The nearest signed 16-bit normalized value, k/32767 with k ∈
/// −32767..=32767 (NV_texture_shader's signed HILO16 channels): a `signed16`
/// texture's stored texel. Its `TexelFormat` is `F32` (filtered in float,
/// uploaded at 16 bits).
#[inline]
pub fn signed16(v: f32) -> f32 {
    let v = if v.is_nan() { 0.0 } else { v };
    (v.clamp(-1.0, 1.0) * 32767.0).round() / 32767.0
}

/// How coordinates outside [0, 1] are treated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Wrap {
    ClampToEdge,
    Repeat,
}

/// Texture filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Filter {
    /// Nearest texel of the chosen level (level = round(lod)).
    Nearest,
    /// Bilinear within the level nearest to lod.
    Bilinear,
    /// Bilinear in the two levels around lod, blended (GL LINEAR_MIPMAP_LINEAR).
    Trilinear,
}

/// One mipmap level.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 is t = 0.
    pub texels: Vec<[f32; 4]>,
}

impl Level {
    /// A level of `width`×`height` texels, row-major.
    pub fn new(width: u32, height: u32, texels: Vec<[f32; 4]>) -> Level {
        debug_assert_eq!(texels.len(), width as usize * height as usize);
        Level { width, height, texels }
    }

    /// The texel at (x, y), which must be inside.
    #[inline]
    pub fn texel(&self, x: u32, y: u32) -> [f32; 4] {
        self.texels[y as usize * self.width as usize + x as usize]
    }

    /// Texel with integer coordinates wrapped or clamped.
    #[inline]
    pub(crate) fn fetch(&self, x: i64, y: i64, wrap: Wrap) -> [f32; 4] {
        let (w, h) = (self.width as i64, self.height as i64);
        let (x, y) = match wrap {
            Wrap::ClampToEdge => (x.clamp(0, w - 1), y.clamp(0, h - 1)),
            // A power-of-two size wraps with a mask (the same as rem_euclid).
            Wrap::Repeat if (w & (w - 1)) == 0 && (h & (h - 1)) == 0 => (x & (w - 1), y & (h - 1)),
            Wrap::Repeat => (x.rem_euclid(w), y.rem_euclid(h)),
        };
        self.texels[(y * w + x) as usize]
    }

    /// The texel nearest (u, v), wrapped or clamped.
    pub fn sample_nearest(&self, u: f32, v: f32, wrap: Wrap) -> [f32; 4] {
        let x = finite_or_zero(u * self.width as f32).floor() as i64;
        let y = finite_or_zero(v * self.height as f32).floor() as i64;
        self.fetch(x, y, wrap)
    }

    /// GL bilinear: texel centres at (i + ½)/size.
    pub fn sample_bilinear(&self, u: f32, v: f32, wrap: Wrap) -> [f32; 4] {
        let fx = finite_or_zero(u * self.width as f32 - 0.5);
        let fy = finite_or_zero(v * self.height as f32 - 0.5);
        let (x0, y0) = (floor_finite(fx), floor_finite(fy));
        let (ax, ay) = (fx - x0, fy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let t00 = self.fetch(x0, y0, wrap);
        let t10 = self.fetch(x0 + 1, y0, wrap);
        let t01 = self.fetch(x0, y0 + 1, wrap);
        let t11 = self.fetch(x0 + 1, y0 + 1, wrap);
        let mut out = [0.0; 4];
        for c in 0..4 {
            let top = t00[c] + ax * (t10[c] - t00[c]);
            let bottom = t01[c] + ax * (t11[c] - t01[c]);
            out[c] = top + ay * (bottom - top);
        }
        out
    }
}

/// `x.floor()` for a finite `x` within ±1e9 ([`finite_or_zero`]'s range),
/// without the library call (x86-64's baseline has no rounding
/// instruction): the conversion truncates toward zero, exactly, since such
/// an `x` fits an i64; a negative non-integer is one below its truncation.
#[inline(always)]
pub(crate) fn floor_finite(x: f32) -> f32 {
    let t = x as i64 as f32;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

#[inline]
fn finite_or_zero(v: f32) -> f32 {
    // Huge values are clamped so the integer conversion stays meaningful.
    if v.is_finite() {
        v.clamp(-1e9, 1e9)
    } else {
        0.0
    }
}

/// A 2D texture with its mip chain (level 0 first).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture2D {
    pub format: TexelFormat,
    pub wrap: Wrap,
    pub levels: Vec<Level>,
}

impl Texture2D {
    /// A single-level texture; texels are quantized to `format`.
    pub fn new(format: TexelFormat, wrap: Wrap, mut base: Level) -> Texture2D {
        for t in &mut base.texels {
            *t = t.map(|c| format.quantize(c));
        }
        Texture2D { format, wrap, levels: vec![base] }
    }

    /// Replaces the mip chain below level 0 by 2×2 box-filtered levels down
    /// to 1×1 (odd sizes take the clamped neighbour), quantized to the format.
    pub fn with_box_mipmaps(mut self) -> Texture2D {
        self.levels.truncate(1);
        while let Some(last) = self.levels.last() {
            if last.width == 1 && last.height == 1 {
                break;
            }
            let next = downsample_box(last, self.format);
            self.levels.push(next);
        }
        self
    }

    /// Level 0's width in texels.
    pub fn width(&self) -> u32 {
        self.levels[0].width
    }
    /// Level 0's height in texels.
    pub fn height(&self) -> u32 {
        self.levels[0].height
    }

    /// Samples at (u, v) with a level of detail `lod` (log2 of texels per pixel).
    pub fn sample(&self, u: f32, v: f32, filter: Filter, lod: f32) -> [f32; 4] {
        let max_level = (self.levels.len() - 1) as f32;
        let lod = if lod.is_nan() { 0.0 } else { lod.clamp(0.0, max_level) };
        match filter {
            Filter::Nearest => self.levels[lod.round() as usize].sample_nearest(u, v, self.wrap),
            Filter::Bilinear => self.levels[lod.round() as usize].sample_bilinear(u, v, self.wrap),
            Filter::Trilinear => {
                let l0 = lod.floor() as usize;
                let l1 = (l0 + 1).min(self.levels.len() - 1);
                let t = lod - l0 as f32;
                let a = self.levels[l0].sample_bilinear(u, v, self.wrap);
                if t == 0.0 || l0 == l1 {
                    return a;
                }
                let b = self.levels[l1].sample_bilinear(u, v, self.wrap);
                [0, 1, 2, 3].map(|c| a[c] + t * (b[c] - a[c]))
            }
        }
    }

    /// GL's level of detail from screen-space derivatives of (u, v).
    pub fn lod(&self, du: [f32; 2], dv: [f32; 2]) -> f32 {
        let (w, h) = (self.width() as f32, self.height() as f32);
        let rho_x = ((du[0] * w).powi(2) + (dv[0] * h).powi(2)).sqrt();
        let rho_y = ((du[1] * w).powi(2) + (dv[1] * h).powi(2)).sqrt();
        let rho = rho_x.max(rho_y);
        if rho > 0.0 && rho.is_finite() {
            rho.log2()
        } else {
            0.0
        }
    }
}

fn downsample_box(src: &Level, format: TexelFormat) -> Level {
    let (w, h) = ((src.width / 2).max(1), (src.height / 2).max(1));
    let mut texels = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0.0f32; 4];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let t = src.fetch((2 * x + dx) as i64, (2 * y + dy) as i64, Wrap::ClampToEdge);
                for c in 0..4 {
                    sum[c] += 0.25 * t[c];
                }
            }
            texels.push(sum.map(|c| format.quantize(c)));
        }
    }
    Level::new(w, h, texels)
}

/// The six faces of a cube map, in GL order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CubeFace {
    PosX = 0,
    NegX = 1,
    PosY = 2,
    NegY = 3,
    PosZ = 4,
    NegZ = 5,
}

impl CubeFace {
    /// The faces in GL order: +X −X +Y −Y +Z −Z.
    pub const ALL: [CubeFace; 6] =
        [CubeFace::PosX, CubeFace::NegX, CubeFace::PosY, CubeFace::NegY, CubeFace::PosZ, CubeFace::NegZ];
}

/// GL cube-map face selection (Kilgard 2000, Appendix A, Table 1): the major axis
/// picks the face, then (s, t) = ((sc/|ma| + 1)/2, (tc/|ma| + 1)/2). Ties go to
/// x before y before z. A zero or non-finite direction gives +X's centre.
pub fn cube_face_uv(d: [f32; 3]) -> (CubeFace, f32, f32) {
    let [rx, ry, rz] = d.map(|c| if c.is_finite() { c } else { 0.0 });
    let (ax, ay, az) = (rx.abs(), ry.abs(), rz.abs());
    let (face, sc, tc, ma) = if ax >= ay && ax >= az {
        if rx >= 0.0 {
            (CubeFace::PosX, -rz, -ry, ax)
        } else {
            (CubeFace::NegX, rz, -ry, ax)
        }
    } else if ay >= az {
        if ry >= 0.0 {
            (CubeFace::PosY, rx, rz, ay)
        } else {
            (CubeFace::NegY, rx, -rz, ay)
        }
    } else if rz >= 0.0 {
        (CubeFace::PosZ, rx, -ry, az)
    } else {
        (CubeFace::NegZ, -rx, -ry, az)
    };
    if ma == 0.0 {
        return (CubeFace::PosX, 0.5, 0.5);
    }
    (face, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0))
}

/// The (unnormalized) direction through (s, t) of a face: the inverse of
/// [`cube_face_uv`], Kilgard 2000, Appendix D `getCubeVector`.
pub fn cube_direction(face: CubeFace, s: f32, t: f32) -> [f32; 3] {
    let (sc, tc) = (2.0 * s - 1.0, 2.0 * t - 1.0);
    match face {
        CubeFace::PosX => [1.0, -tc, -sc],
        CubeFace::NegX => [-1.0, -tc, sc],
        CubeFace::PosY => [sc, 1.0, tc],
        CubeFace::NegY => [sc, -1.0, -tc],
        CubeFace::PosZ => [sc, -tc, 1.0],
        CubeFace::NegZ => [-sc, -tc, -1.0],
    }
}

/// A cube map: six square faces in GL order, each with its own mip chain,
/// clamped to edge per face (no seamless filtering, like 2000-era hardware).
#[derive(Clone, Debug, PartialEq)]
pub struct TextureCube {
    pub faces: [Texture2D; 6],
}

impl TextureCube {
    /// The cube map sampled in `direction` (GL's face selection, Table 3.19).
    pub fn sample(&self, direction: [f32; 3], filter: Filter, lod: f32) -> [f32; 4] {
        let (face, s, t) = cube_face_uv(direction);
        self.faces[face as usize].sample(s, t, filter, lod)
    }
    /// A face's side in texels.
    pub fn size(&self) -> u32 {
        self.faces[0].width()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_finite_is_floor() {
        let mut x = -1e9f32;
        while x < 1e9 {
            for y in [x, -x, x + 0.5, x - 0.25, x.next_up(), x.next_down()] {
                assert_eq!(floor_finite(y), y.floor(), "{y}");
            }
            x = if x.abs() < 1e-3 {
                1e-3
            } else if x < 0.0 {
                x * 0.97
            } else {
                x * 1.03
            };
        }
        for y in [0.0, 0.5, -0.5, 0.999_999_94, -0.999_999_94, 8_388_607.5, -8_388_607.5, 1e9, -1e9] {
            assert_eq!(floor_finite(y), y.floor(), "{y}");
        }
    }

    fn ramp(w: u32, h: u32) -> Level {
        Level::new(w, h, (0..w * h).map(|i| [(i % w) as f32, (i / w) as f32, 0.0, 1.0]).collect())
    }

    #[test]
    fn bilinear_interpolates_between_texel_centres() {
        let t = Texture2D::new(TexelFormat::F32, Wrap::ClampToEdge, ramp(4, 4));
        // u = 0.375 is halfway between texel centres 0.125·4−0.5 = 1 and 2 → x = 1.0; here 1.0.
        let s = t.sample(0.375, 0.625, Filter::Bilinear, 0.0);
        assert!((s[0] - 1.0).abs() < 1e-6 && (s[1] - 2.0).abs() < 1e-6, "{s:?}");
        let s = t.sample(0.5, 0.5, Filter::Bilinear, 0.0);
        assert!((s[0] - 1.5).abs() < 1e-6 && (s[1] - 1.5).abs() < 1e-6, "{s:?}");
        // Clamp to edge: beyond the border, the edge texel.
        let s = t.sample(-3.0, 7.0, Filter::Bilinear, 0.0);
        assert_eq!([s[0], s[1]], [0.0, 3.0]);
        let s = t.sample(0.3, 0.9, Filter::Nearest, 0.0);
        assert_eq!([s[0], s[1]], [1.0, 3.0]);
    }

    #[test]
    fn repeat_wraps_bilinear_across_the_border() {
        let t = Texture2D::new(TexelFormat::F32, Wrap::Repeat, ramp(4, 1));
        let s = t.sample(0.0, 0.5, Filter::Bilinear, 0.0);
        assert!((s[0] - 1.5).abs() < 1e-6, "halfway between texel 3 and texel 0: {s:?}");
    }

    #[test]
    fn trilinear_blends_levels() {
        let base = Level::new(4, 4, vec![[1.0, 0.0, 0.0, 1.0]; 16]);
        let mut t = Texture2D::new(TexelFormat::F32, Wrap::ClampToEdge, base).with_box_mipmaps();
        assert_eq!(t.levels.len(), 3);
        t.levels[1].texels.fill([0.0, 1.0, 0.0, 1.0]);
        let s = t.sample(0.4, 0.4, Filter::Trilinear, 0.25);
        assert!((s[0] - 0.75).abs() < 1e-6 && (s[1] - 0.25).abs() < 1e-6, "{s:?}");
        let s = t.sample(0.4, 0.4, Filter::Trilinear, 99.0);
        assert_eq!(s, [1.0, 0.0, 0.0, 1.0], "clamped to the last level");
        assert_eq!(t.lod([0.25, 0.0], [0.0, 0.25]), 0.0, "one texel per pixel");
        assert_eq!(t.lod([1.0, 0.0], [0.0, 1.0]), 2.0);
    }

    #[test]
    fn rgba8_quantizes_on_creation() {
        let t = Texture2D::new(
            TexelFormat::Rgba8,
            Wrap::ClampToEdge,
            Level::new(1, 1, vec![[0.5, 2.0, -1.0, 0.1]]),
        );
        assert_eq!(t.levels[0].texels[0], [128.0 / 255.0, 1.0, 0.0, 26.0 / 255.0]);
    }

    #[test]
    fn cube_face_selection_round_trips_and_breaks_ties_consistently() {
        for face in CubeFace::ALL {
            for (s, t) in [(0.5, 0.5), (0.1, 0.9), (0.75, 0.2)] {
                let d = cube_direction(face, s, t);
                let (f2, s2, t2) = cube_face_uv(d);
                assert_eq!(f2, face);
                assert!((s2 - s).abs() < 1e-6 && (t2 - t).abs() < 1e-6);
            }
        }
        // Edges and corners: ties pick x, then y; coordinates stay inside [0, 1].
        assert_eq!(cube_face_uv([1.0, 1.0, 0.0]).0, CubeFace::PosX);
        assert_eq!(cube_face_uv([0.0, -1.0, 1.0]).0, CubeFace::NegY);
        assert_eq!(cube_face_uv([-1.0, 1.0, 1.0]).0, CubeFace::NegX);
        let (_, s, t) = cube_face_uv([1.0, 1.0, 1.0]);
        assert!((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t));
        // The edge between +X and +Y: +X's t = 0 row meets +Y's s = 1 column.
        let (_, s, t) = cube_face_uv([1.0, 1.0, 0.3]);
        assert!((t - 0.0).abs() < 1e-6 && (s - 0.35).abs() < 1e-6, "{s} {t}");
        let (f, s, t) = cube_face_uv([0.99999, 1.0, 0.3]);
        assert_eq!(f, CubeFace::PosY);
        assert!((s - 1.0).abs() < 1e-4 && (t - 0.65).abs() < 1e-4, "{s} {t}");
        assert_eq!(cube_face_uv([0.0, 0.0, 0.0]), (CubeFace::PosX, 0.5, 0.5));
        assert_eq!(cube_face_uv([f32::NAN, 0.0, -2.0]).0, CubeFace::NegZ);
    }
}
