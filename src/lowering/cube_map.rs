//! Rule `normalization_cube_map`: `normalize(δ v)` per fragment becomes a
//! lookup of the interpolated (unnormalized) vector in a cube map that
//! stores `v/|v|` range-compressed to [0, 1], expanded after the lookup —
//! seeds/000 Section 4.2.2 (Formula 4, Figure 5) and seeds/003 Section 5.2.
//! The texture is the one `examples/phong_cubemap_normalized.shd` declares
//! by hand (`normalize_cube(size, 8)`, the same generator).
//!
//! Error bound (per component of the unit vector): the 8-bit texel's
//! rounding, ½ step of 1/255 stored, doubled by `expand` = 1/255, plus the
//! bilinear chord between two texels ≤ (2/size)²/8 (a face spans 2 units
//! over `size` texels, the chord of an arc θ sags θ²/8).

use super::{per_vertex, Rewriter};
use crate::ir::{Expr, Handle, MathFunction, Texture};
use crate::parser::ast::{TextureAttr, TextureFormat, TextureKind};
use crate::pipeline::ApproximationCost;
use crate::span::Span;

/// Texels per cube face.
pub const SIZE: u32 = 128;
/// The name of the texture the rule adds (one per program).
pub const NAME: &str = "Ncube_lowered";

/// The rule's analytic bound (see the module doc).
pub fn error_bound(size: u32) -> f64 {
    1.0 / 255.0 + (2.0 / size as f64).powi(2) / 8.0
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
    let texture = texture(r);
    let lookup = r.node(Expr::Lookup { texture, coords }, span)?;
    let expanded = r.node(Expr::Math { fun: MathFunction::Expand, args: vec![lookup] }, span)?;
    r.record(
        "normalization_cube_map",
        span,
        Some(expanded),
        format!(
            "`normalize` per fragment is a lookup in an 8-bit normalization cube map ({SIZE}² texels a face)"
        ),
        ApproximationCost {
            texture_units: 1,
            passes: 0,
            general_combiners: 0,
            texels: 6 * (SIZE as u64).pow(2),
        },
        Some(error_bound(SIZE)),
    );
    Some(expanded)
}

/// The program's normalization cube map, added on first use.
fn texture(r: &mut Rewriter) -> u32 {
    if let Some(i) = r.m.textures.iter().position(|t| t.name == NAME) {
        return i as u32;
    }
    r.m.textures.push(Texture {
        name: NAME.into(),
        kind: TextureKind::Cube,
        format: TextureFormat::Rgb8,
        rendered: false,
        baked: false,
        declaration: Some(format!(
            "texture {NAME} : cube rgb8 bilinear clamp = normalize_cube({SIZE}, 8);\n"
        )),
        copy_of: None,
        tabulates: Some(crate::ir::Tabulated::Normalize),
        sampling: crate::ir::Sampling::of(TextureKind::Cube, &[TextureAttr::Bilinear, TextureAttr::Clamp]),
        span: Span::DETACHED,
    });
    (r.m.textures.len() - 1) as u32
}
