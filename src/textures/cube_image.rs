//! Cube maps from images: one image in a known layout, six face images, or
//! an equirectangular panorama resampled to faces.
//!
//! Faces follow OpenGL's cube-map convention (OpenGL 1.3, Section 3.8.6,
//! Table 3.19; Kilgard 2000, Appendix A, Table 1): a face image's row 0 (its
//! top, as an image is stored) is t = 0 and its column 0 is s = 0, with sc
//! and tc as the table gives them per major axis — so a face image is the
//! texels `glTexImage2D` would be handed for that face, top row first.
//!
//! Layouts of one image, by aspect ratio (each face `n`×`n`):
//!
//! | layout | shape | where the faces are (column, row in face units) |
//! |---|---|---|
//! | horizontal cross | 4n × 3n | +Y (1, 0); −X (0, 1), +Z (1, 1), +X (2, 1), −Z (3, 1); −Y (1, 2) |
//! | vertical cross | 3n × 4n | +Y (1, 0); −X (0, 1), +Z (1, 1), +X (2, 1); −Y (1, 2); −Z (1, 3) turned 180° |
//! | horizontal strip | 6n × n | +X, −X, +Y, −Y, +Z, −Z left to right |
//! | vertical strip | n × 6n | +X, −X, +Y, −Y, +Z, −Z top to bottom (what `shadec emulate` reads) |
//! | equirectangular | 2m × m | longitude across, latitude down: resampled to faces of m/2 |
//!
//! The crosses are the common unfolded cube (AMD CubeMapGen's and cmft's
//! `hcross`/`vcross`): in the middle row of the horizontal cross the faces
//! meet edge to edge in the order −X +Z +X −Z, +Y above +Z and −Y below
//! it, every face upright; the vertical cross puts −Z below −Y, upside
//! down, so that its edges meet −Y's.
//!
//! An equirectangular image is looked up by direction d as
//! u = ½ + atan2(dx, −dz)/(2π), v = acos(dy/|d|)/π: its centre is −Z (where
//! an OpenGL camera looks), +X to the right of it, +Y the top row. Each
//! face texel is the image's bilinear sample (repeating across u, clamped
//! in v) at the direction through the texel's centre; the face is m/2 texels
//! wide, the image's own angular resolution at a face's centre (m/2 pixels
//! per 90°), at most [`MAX_CUBE_FACE`].

use std::f64::consts::PI;
use std::path::Path;

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::generators::MAX_CUBE_FACE;
use super::sampling::{cube_direction, CubeFace, Level, TexelFormat, Texture2D, TextureCube, Wrap};

/// How the six faces of a cube map lie in one image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CubeLayout {
    /// 4:3, the unfolded cube with −X +Z +X −Z across.
    HorizontalCross,
    /// 3:4, the unfolded cube with +Y +Z −Y −Z down (−Z turned 180°).
    VerticalCross,
    /// 6:1, the faces in GL order left to right.
    HorizontalStrip,
    /// 1:6, the faces in GL order top to bottom.
    VerticalStrip,
    /// 2:1, longitude and latitude, resampled to faces.
    Equirectangular,
}

impl CubeLayout {
    /// Every layout, in the order a shape is matched against them.
    pub const ALL: [CubeLayout; 5] = [
        CubeLayout::HorizontalCross,
        CubeLayout::VerticalCross,
        CubeLayout::HorizontalStrip,
        CubeLayout::VerticalStrip,
        CubeLayout::Equirectangular,
    ];

    /// The name a program writes: `image("env.png", "hcross")`.
    pub fn name(self) -> &'static str {
        match self {
            CubeLayout::HorizontalCross => "hcross",
            CubeLayout::VerticalCross => "vcross",
            CubeLayout::HorizontalStrip => "hstrip",
            CubeLayout::VerticalStrip => "vstrip",
            CubeLayout::Equirectangular => "equirect",
        }
    }

    /// The layout a program names (`hcross`, …); `None` for another name.
    pub fn from_name(name: &str) -> Option<CubeLayout> {
        CubeLayout::ALL.into_iter().find(|l| l.name() == name)
    }

    /// Width : height.
    pub fn aspect(self) -> (u32, u32) {
        match self {
            CubeLayout::HorizontalCross => (4, 3),
            CubeLayout::VerticalCross => (3, 4),
            CubeLayout::HorizontalStrip => (6, 1),
            CubeLayout::VerticalStrip => (1, 6),
            CubeLayout::Equirectangular => (2, 1),
        }
    }

    /// Whether a `width`×`height` image has this layout's shape exactly.
    pub fn fits(self, width: u32, height: u32) -> bool {
        let (a, b) = self.aspect();
        width > 0 && height > 0 && u64::from(width) * u64::from(b) == u64::from(height) * u64::from(a)
    }

    /// The layout whose shape a `width`×`height` image has.
    pub fn of_shape(width: u32, height: u32) -> Option<CubeLayout> {
        CubeLayout::ALL.into_iter().find(|l| l.fits(width, height))
    }

    /// The face size of a `width`-wide image of this layout.
    pub fn face_size(self, width: u32) -> u32 {
        match self {
            CubeLayout::Equirectangular => (width / 4).clamp(1, MAX_CUBE_FACE),
            _ => width / self.aspect().0,
        }
    }

    /// Where face `f` lies, in face units, and whether it is turned 180°
    /// (the −Z face of the vertical cross); `None` for the equirectangular
    /// layout, which is resampled.
    pub fn place(self, f: CubeFace) -> Option<(u32, u32, bool)> {
        let i = f as u32;
        Some(match self {
            CubeLayout::HorizontalStrip => (i, 0, false),
            CubeLayout::VerticalStrip => (0, i, false),
            CubeLayout::HorizontalCross | CubeLayout::VerticalCross => match f {
                CubeFace::PosX => (2, 1, false),
                CubeFace::NegX => (0, 1, false),
                CubeFace::PosY => (1, 0, false),
                CubeFace::NegY => (1, 2, false),
                CubeFace::PosZ => (1, 1, false),
                CubeFace::NegZ if self == CubeLayout::HorizontalCross => (3, 1, false),
                CubeFace::NegZ => (1, 3, true),
            },
            CubeLayout::Equirectangular => return None,
        })
    }
}

/// The names six face files take in a pattern `env_{face}.png`, in GL order.
pub const FACE_NAMES: [&str; 6] = ["px", "nx", "py", "ny", "pz", "nz"];

/// Why images do not make a cube map; [`CubeImageError::help`] says what to do.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum CubeImageError {
    #[error("{path}: image file not found")]
    NotFound { path: String },
    #[error("{path}: cannot decode image: {message}")]
    Decode { path: String, message: String },
    #[error("{path} is {width}×{height}, which is no cube-map layout (4:3, 3:4, 6:1, 1:6 or 2:1)")]
    UnknownShape { path: String, width: u32, height: u32 },
    #[error("{path} is {width}×{height}, not the {w}:{h} shape of the `{layout}` layout", layout = layout.name(), w = layout.aspect().0, h = layout.aspect().1)]
    WrongShape { path: String, width: u32, height: u32, layout: CubeLayout },
    #[error("the face {path} is {width}×{height}: a cube face is square")]
    NotSquare { path: String, width: u32, height: u32 },
    #[error("the faces differ in size: {first} is {size}×{size}, {path} is {width}×{height}")]
    UnequalFaces { first: String, size: u32, path: String, width: u32, height: u32 },
    #[error("{path} makes faces of {size}×{size}, larger than the limit of {MAX_CUBE_FACE}×{MAX_CUBE_FACE}")]
    TooLarge { path: String, size: u32 },
}

impl CubeImageError {
    /// What to do about it.
    pub fn help(&self) -> String {
        let layouts = "a cube map image is a horizontal cross (4:3), a vertical cross (3:4), six faces side by side (6:1) or stacked (1:6), or an equirectangular panorama (2:1); six face files are `image(\"env_{face}.png\")` (px nx py ny pz nz) or six file names";
        match self {
            CubeImageError::NotFound { .. } => {
                "check the path (relative paths are relative to the scene file, or the current folder)".into()
            }
            CubeImageError::Decode { .. } => "supported formats are PNG, JPEG and Radiance HDR".into(),
            CubeImageError::UnknownShape { .. } => layouts.into(),
            CubeImageError::WrongShape { width, height, .. } => match CubeLayout::of_shape(*width, *height) {
                Some(l) => format!(
                    "its shape is the `{}` layout's: write that name, or leave the layout out to deduce it",
                    l.name()
                ),
                None => layouts.into(),
            },
            CubeImageError::NotSquare { .. } | CubeImageError::UnequalFaces { .. } => {
                "give six square face images of one size (n×n each)".into()
            }
            CubeImageError::TooLarge { .. } => {
                format!("scale the image down to faces of at most {MAX_CUBE_FACE}×{MAX_CUBE_FACE}")
            }
        }
    }
}

/// An image file's texels, RGBA f32 (HDR values kept), row 0 its top row.
pub fn read_level(path: &Path) -> Result<Level, CubeImageError> {
    let display = path.display().to_string();
    if !path.is_file() {
        return Err(CubeImageError::NotFound { path: display });
    }
    let img =
        image::open(path).map_err(|e| CubeImageError::Decode { path: display, message: e.to_string() })?;
    let rgba = img.to_rgba32f();
    let (w, h) = rgba.dimensions();
    Ok(Level::new(w, h, rgba.pixels().map(|p| p.0).collect()))
}

/// A cube map from one image: in `layout`, or the layout its shape has.
pub fn load_cube_image(
    path: &Path,
    layout: Option<CubeLayout>,
    format: TexelFormat,
) -> Result<TextureCube, CubeImageError> {
    let image = read_level(path)?;
    let display = || path.display().to_string();
    let (width, height) = (image.width, image.height);
    let layout = match layout {
        Some(l) if !l.fits(width, height) => {
            return Err(CubeImageError::WrongShape { path: display(), width, height, layout: l })
        }
        Some(l) => l,
        None => CubeLayout::of_shape(width, height).ok_or(CubeImageError::UnknownShape {
            path: display(),
            width,
            height,
        })?,
    };
    let size = layout.face_size(width);
    if size > MAX_CUBE_FACE {
        return Err(CubeImageError::TooLarge { path: display(), size });
    }
    let faces = match layout {
        CubeLayout::Equirectangular => CubeFace::ALL.map(|f| equirect_face(&image, f, size)),
        _ => CubeFace::ALL.map(|f| cut_face(&image, layout, f, size)),
    };
    Ok(cube_of(faces, format))
}

/// A cube map from six face images, in GL order (+X −X +Y −Y +Z −Z).
pub fn load_cube_faces(paths: &[&Path; 6], format: TexelFormat) -> Result<TextureCube, CubeImageError> {
    let mut faces: [Level; 6] = std::array::from_fn(|_| Level { width: 0, height: 0, texels: Vec::new() });
    let mut first: Option<u32> = None;
    for (face, path) in faces.iter_mut().zip(paths) {
        let level = read_level(path)?;
        let display = path.display().to_string();
        if level.width != level.height {
            return Err(CubeImageError::NotSquare {
                path: display,
                width: level.width,
                height: level.height,
            });
        }
        if let Some(first) = first {
            if level.width != first {
                return Err(CubeImageError::UnequalFaces {
                    first: paths[0].display().to_string(),
                    size: first,
                    path: display,
                    width: level.width,
                    height: level.height,
                });
            }
        }
        if level.width > MAX_CUBE_FACE {
            return Err(CubeImageError::TooLarge { path: display, size: level.width });
        }
        first = Some(level.width);
        *face = level;
    }
    Ok(cube_of(faces, format))
}

fn cube_of(faces: [Level; 6], format: TexelFormat) -> TextureCube {
    TextureCube { faces: faces.map(|l| Texture2D::new(format, Wrap::ClampToEdge, l)) }
}

/// Face `f` of an image in `layout`, copied texel for texel (turned 180°
/// where the layout stores it so).
pub fn cut_face(image: &Level, layout: CubeLayout, f: CubeFace, size: u32) -> Level {
    // A panorama places no face: its faces are resampled instead.
    let Some((col, row, turned)) = layout.place(f) else { return equirect_face(image, f, size) };
    let (x0, y0) = (col * size, row * size);
    let mut texels = Vec::with_capacity((size * size) as usize);
    for y in 0..size {
        for x in 0..size {
            let (sx, sy) = if turned { (size - 1 - x, size - 1 - y) } else { (x, y) };
            texels.push(image.texel(x0 + sx, y0 + sy));
        }
    }
    Level::new(size, size, texels)
}

/// Where direction `d` falls in an equirectangular image: u = ½ +
/// atan2(dx, −dz)/(2π) across (−Z at the centre, +X to its right), v =
/// acos(dy/|d|)/π down (+Y the top row). A zero direction gives the centre.
pub fn equirect_uv(d: [f64; 3]) -> (f64, f64) {
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if !(len > 0.0 && len.is_finite()) {
        return (0.5, 0.5);
    }
    let u = 0.5 + d[0].atan2(-d[2]) / (2.0 * PI);
    let v = (d[1] / len).clamp(-1.0, 1.0).acos() / PI;
    (u, v)
}

/// The equirectangular image's bilinear sample in direction `d`: texel
/// centres at (i + ½)/size, repeating across u (longitude wraps), clamped
/// in v (the poles).
pub fn equirect_sample(image: &Level, d: [f64; 3]) -> [f32; 4] {
    let (u, v) = equirect_uv(d);
    let (w, h) = (i64::from(image.width), i64::from(image.height));
    let fx = u * w as f64 - 0.5;
    let fy = (v * h as f64 - 0.5).clamp(0.0, (h - 1) as f64);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (ax, ay) = ((fx - x0) as f32, (fy - y0) as f32);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let at = |x: i64, y: i64| image.texel(x.rem_euclid(w) as u32, y.clamp(0, h - 1) as u32);
    let (t00, t10, t01, t11) = (at(x0, y0), at(x0 + 1, y0), at(x0, y0 + 1), at(x0 + 1, y0 + 1));
    std::array::from_fn(|c| {
        let top = t00[c] + ax * (t10[c] - t00[c]);
        let bottom = t01[c] + ax * (t11[c] - t01[c]);
        top + ay * (bottom - top)
    })
}

/// Face `f` of a cube map resampled from an equirectangular image: each
/// texel the image's bilinear sample through the texel's centre.
pub fn equirect_face(image: &Level, f: CubeFace, size: u32) -> Level {
    let mut texels = Vec::with_capacity((size * size) as usize);
    for y in 0..size {
        for x in 0..size {
            let s = (x as f32 + 0.5) / size as f32;
            let t = (y as f32 + 0.5) / size as f32;
            texels.push(equirect_sample(image, cube_direction(f, s, t).map(f64::from)));
        }
    }
    Level::new(size, size, texels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_pick_their_layouts() {
        assert_eq!(CubeLayout::of_shape(256, 192), Some(CubeLayout::HorizontalCross));
        assert_eq!(CubeLayout::of_shape(192, 256), Some(CubeLayout::VerticalCross));
        assert_eq!(CubeLayout::of_shape(384, 64), Some(CubeLayout::HorizontalStrip));
        assert_eq!(CubeLayout::of_shape(64, 384), Some(CubeLayout::VerticalStrip));
        assert_eq!(CubeLayout::of_shape(512, 256), Some(CubeLayout::Equirectangular));
        assert_eq!(CubeLayout::of_shape(100, 100), None);
        assert_eq!(CubeLayout::of_shape(0, 0), None);
        for l in CubeLayout::ALL {
            assert_eq!(CubeLayout::from_name(l.name()), Some(l));
        }
        assert_eq!(CubeLayout::HorizontalCross.face_size(256), 64);
        assert_eq!(CubeLayout::Equirectangular.face_size(512), 128);
        assert_eq!(CubeLayout::Equirectangular.face_size(16384), MAX_CUBE_FACE);
    }

    #[test]
    fn equirect_centre_is_minus_z_and_top_is_plus_y() {
        let (u, v) = equirect_uv([0.0, 0.0, -1.0]);
        assert!((u - 0.5).abs() < 1e-12 && (v - 0.5).abs() < 1e-12);
        let (u, _) = equirect_uv([1.0, 0.0, 0.0]);
        assert!((u - 0.75).abs() < 1e-12, "+X right of the centre: {u}");
        let (_, v) = equirect_uv([0.0, 2.0, 0.0]);
        assert!(v.abs() < 1e-12);
        assert_eq!(equirect_uv([0.0, 0.0, 0.0]), (0.5, 0.5));
    }
}
