//! Rule `normalization_cube_map`: `normalize(δ v)` per fragment becomes a
//! lookup of the interpolated (unnormalized) vector in a cube map that
//! stores `v/|v|` range-compressed to [0, 1], expanded after the lookup —
//! GeForce3 Phong, Section 4.2.2 (Formula 4, Figure 5) and Kilgard 2000, Section 5.2.
//! The texture is the one `examples/phong_cubemap_normalized.shd` declares
//! by hand (`normalize_cube(size, 8)`, the same generator).
//!
//! Where the target has signed formats (geforce3), the cube map is 16-bit
//! signed — the HILO normalization map of GeForce3 Phong, Section 5.1, read by
//! the texture shaders and the combiners without `expand`.
//!
//! Error bound (per component of the unit vector): the texel's rounding —
//! 8-bit: ½ step of 1/255 stored, doubled by `expand` = 1/255; 16-bit
//! signed: 1/65535 — plus the bilinear chord between two texels ≤
//! (2/size)²/8 (a face spans 2 units over `size` texels, the chord of an
//! arc θ sags θ²/8).

use super::{per_vertex, Rewriter};
use crate::ir::{AddedSource, Expr, Handle, MathFunction, Texture};
use crate::parser::ast::{TextureAttr, TextureFormat, TextureKind};
use crate::pipeline::ApproximationCost;
use crate::span::Span;

/// Texels per cube face.
pub const SIZE: u32 = 128;
/// The name of the texture the rule adds (one per program).
pub const NAME: &str = "Ncube_lowered";

/// The rule's analytic bound for the 8-bit map (see the module doc).
pub fn error_bound(size: u32) -> f64 {
    1.0 / 255.0 + chord(size)
}

/// The bound of the 16-bit signed (HILO) map.
pub fn error_bound_hilo(size: u32) -> f64 {
    1.0 / 65535.0 + chord(size)
}

fn chord(size: u32) -> f64 {
    (2.0 / size as f64).powi(2) / 8.0
}

/// `expand(Ncube δ v)` for `normalize(x)` (`x_written`: `x` as the
/// program wrote it); `None` when `x` cannot be interpolated per vertex (a
/// normal map's texel: a dependent lookup).
pub fn apply(r: &mut Rewriter, x: Handle<Expr>, x_written: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let coords = if super::is_interpolant(&r.m, x) {
        x
    } else {
        per_vertex::apply(r, x_written, "the vector normalized here", span)?
    };
    let hilo = r.profile.signed_textures;
    let texture = texture(r, hilo);
    let lookup = r.node(Expr::Lookup { texture, coords }, span)?;
    let expanded = if hilo {
        lookup
    } else {
        r.node(Expr::Math { fun: MathFunction::Expand, args: vec![lookup] }, span)?
    };
    let (what, bound) = if hilo {
        ("a 16-bit signed (HILO)", error_bound_hilo(SIZE))
    } else {
        ("an 8-bit", error_bound(SIZE))
    };
    r.record(
        "normalization_cube_map",
        span,
        Some(expanded),
        format!(
            "`normalize` per fragment is a lookup in {what} normalization cube map ({SIZE}² texels a face)"
        ),
        ApproximationCost {
            texture_units: 1,
            passes: 0,
            general_combiners: 0,
            texels: 6 * (SIZE as u64).pow(2),
        },
        Some(bound),
    );
    Some(expanded)
}

/// The program's normalization cube map, added on first use: 16-bit
/// signed where the target has signed formats (`hilo`), else RGB8.
fn texture(r: &mut Rewriter, hilo: bool) -> u32 {
    if let Some(i) = r.m.textures.iter().position(|t| t.name == NAME) {
        return i as u32;
    }
    let format = if hilo { TextureFormat::Signed16 } else { TextureFormat::Rgb8 };
    let bits = if hilo { 16 } else { 8 };
    r.m.textures.push(Texture {
        name: NAME.into(),
        kind: TextureKind::Cube,
        format,
        rendered: false,
        baked: false,
        declaration: Some(AddedSource::NormalizeCube { size: SIZE, bits }),
        copy_of: None,
        tabulates: Some(crate::ir::Tabulated::Normalize),
        sampling: crate::ir::Sampling::of(TextureKind::Cube, &[TextureAttr::Bilinear, TextureAttr::Clamp]),
        span: Span::DETACHED,
    });
    (r.m.textures.len() - 1) as u32
}
