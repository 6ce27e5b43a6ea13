//! Textures for the renderer: storage and GL sampling (Kilgard 2000, Appendix A
//! for cube maps; nearest, bilinear, trilinear with mipmaps), image files
//! (PNG, JPEG, Radiance HDR through `image`), and the generators of the
//! papers — normalization cube maps (Kilgard 2000, Appendix D), normal maps with
//! Kilgard's mipmap filter (Kilgard 2000 Appendices E-F), dual-paraboloid
//! environment maps (Heidrich & Seidel 1999, Section 4.1-4.2), Heidrich-Seidel BRDF factor
//! textures (Heidrich & Seidel 1999, Eq. 1-3) and exponent lookup tables (GeForce3 Phong);
//! cube maps from images (crosses, strips, six faces, equirectangular
//! panoramas) in [`cube_image`].

pub mod cube_image;
pub mod generators;
pub mod lanes;
pub mod sampling;
pub mod solid;
pub mod unit;

use std::path::Path;

use thiserror::Error;

pub use cube_image::{CubeImageError, CubeLayout};
pub use generators::{CubeBits, DualParaboloid, HeightField, NormalMapFormat, ParaboloidFace};
pub use sampling::{
    cube_direction, cube_face_uv, CubeFace, Filter, Level, TexelFormat, Texture2D, TextureCube, Wrap,
};

/// Why a texture file could not be loaded.
#[derive(Debug, Error)]
pub enum TextureError {
    #[error(
        "{path}: texture file not found; check the path (relative paths are relative to the scene file)"
    )]
    NotFound { path: String },
    #[error("{path}: cannot decode image: {message}; supported formats are PNG, JPEG and Radiance HDR")]
    Decode { path: String, message: String },
}

/// Any texture a scene can bind.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Flat(Texture2D),
    Cube(TextureCube),
    DualParaboloid(DualParaboloid),
}

/// Loads an image file as a 2D texture (RGBA, f32 for HDR sources, else
/// `format`); row 0 of the texture is the image's top row.
pub fn load_image(path: &Path, format: TexelFormat, wrap: Wrap) -> Result<Texture2D, TextureError> {
    let display = path.display().to_string();
    if !path.is_file() {
        return Err(TextureError::NotFound { path: display });
    }
    let img =
        image::open(path).map_err(|e| TextureError::Decode { path: display, message: e.to_string() })?;
    let rgba = img.to_rgba32f();
    let (w, h) = rgba.dimensions();
    let texels = rgba.pixels().map(|p| p.0).collect();
    Ok(Texture2D::new(format, wrap, Level::new(w, h, texels)))
}

/// Loads a grayscale height field (luminance in [0, 1]) from an image file.
pub fn load_height_field(path: &Path) -> Result<HeightField, TextureError> {
    let display = path.display().to_string();
    if !path.is_file() {
        return Err(TextureError::NotFound { path: display });
    }
    let img =
        image::open(path).map_err(|e| TextureError::Decode { path: display, message: e.to_string() })?;
    let luma = img.to_luma32f();
    let (w, h) = luma.dimensions();
    Ok(HeightField { width: w, height: h, heights: luma.pixels().map(|p| p.0[0].clamp(0.0, 1.0)).collect() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_and_corrupt_images_are_errors() {
        let err = load_image(Path::new("/nonexistent/x.png"), TexelFormat::Rgba8, Wrap::Repeat).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/x.png"));
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("bad.png");
        std::fs::write(&bad, b"not a png").unwrap();
        let err = load_image(&bad, TexelFormat::Rgba8, Wrap::Repeat).unwrap_err();
        assert!(matches!(err, TextureError::Decode { .. }), "{err}");
    }

    #[test]
    fn png_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.png");
        let img = image::RgbaImage::from_fn(2, 2, |x, y| image::Rgba([x as u8 * 255, y as u8 * 255, 0, 255]));
        img.save(&path).unwrap();
        let t = load_image(&path, TexelFormat::Rgba8, Wrap::ClampToEdge).unwrap();
        assert_eq!(t.levels[0].texel(1, 0), [1.0, 0.0, 0.0, 1.0]);
        assert_eq!(t.levels[0].texel(0, 1), [0.0, 1.0, 0.0, 1.0]);
    }
}
