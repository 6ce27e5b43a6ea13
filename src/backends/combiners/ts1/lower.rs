//! The texture-shader program a pass's texture units need: each unit's lookup in the IR, read as an NV_texture_shader operation.
//! A lookup at interpolated coordinates is `texture_2d` (`texture_1d`,
//! `texture_3d`, `texture_cube_map` by the texture's kind); a 2-D lookup at
//! interpolated coordinates plus a signed 2-D lookup of an earlier unit is
//! Pipeline Grammar, equation (8)'s environment-mapped bump mapping, `offset_2d`
//! with the identity matrix (Section 3.4; Direct3D 6's EMBM), or with
//! s·I where the offset is scaled by a constant s.

use crate::ir::{BinaryOp, Expr, Handle, Module};
use crate::parser::ast::{TextureFormat, TextureKind};

use super::program::{DotFamily, DotMapping, Operation, TextureShader};

/// The program for `units` (unit k holds `units[k]`), when at least one unit
/// is a dependent lookup and every unit has an operation; `None` when no
/// unit depends on another (plain texturing needs no texture shader) or
/// some unit's coordinates have no NV_texture_shader operation.
pub fn program(m: &Module, units: &[Handle<Expr>]) -> Option<TextureShader> {
    // The shadow mask's redraw: the light's map, then the fragment's depth
    // replaced by its two dot products (`planner::shadow_mask`).
    if let [read] = units {
        if crate::planner::shadow_mask::replaced_depth(m, *read).is_some() {
            return Some(depth_replace());
        }
    }
    // A HILO map's dot products: stages of their own (`super::hilo`).
    if let Some(hilo) = super::hilo::program(m, units, operation) {
        return hilo;
    }
    let mut stages = Vec::new();
    for (k, &unit) in units.iter().enumerate() {
        stages.push(operation(m, &units[..k], unit)?);
    }
    let compares = units.iter().any(|&u| crate::planner::shadow_map::depth_texture_read(m, u).is_some());
    (compares || stages.iter().any(|op| op.previous().is_some())).then_some(TextureShader { stages })
}

/// The first unit whose lookup is dependent — its coordinates read
/// another unit's texel (or a framebuffer read) — when no texture-shader
/// program performs it: the target has no texture shaders
/// (`texture_shaders` false), or [`program`] finds no operation for some
/// unit. A pass with such a unit is a pass the card cannot run as
/// planned (the units would look up at interpolated coordinates). Every
/// stage of a [`program`] that is `Some` realizes its unit (it is built
/// unit by unit, each from its coordinates), so nothing else is asked.
/// Coordinates computed from the vertices alone (texgen, a texture
/// matrix) are not dependent.
pub fn unrealized_unit(m: &Module, units: &[Handle<Expr>], texture_shaders: bool) -> Option<usize> {
    let dependent = units.iter().position(|&u| match m.exprs[u] {
        Expr::Lookup { coords, .. } => m
            .reachable(&[coords])
            .iter()
            .any(|h| matches!(m.exprs[*h], Expr::Lookup { .. } | Expr::FramebufferRead { .. })),
        _ => false,
    })?;
    if texture_shaders && program(m, units).is_some() {
        return None;
    }
    Some(dependent)
}

/// [`unrealized_unit`] as the planner's refusal, located at the lookup.
pub fn dependent_lookups(
    m: &Module,
    units: &[Handle<Expr>],
    texture_shaders: bool,
) -> Result<(), crate::planner::realize::Refusal> {
    let Some(k) = unrealized_unit(m, units, texture_shaders) else { return Ok(()) };
    let (reason, help) = if texture_shaders {
        (
            "looks a texture up at coordinates computed from another texture unit's texel, which no NV_texture_shader operation computes",
            "texture shaders look up at interpolated coordinates, offset by an earlier signed texel (offset_2d), \
             or at dot products of an earlier texel with interpolated vectors (a HILO map's 2-D lookup, \
             a cube map at an expanded normal-map texel: docs/combiners.md); \
             compute the coordinates per vertex, or target wgsl",
        )
    } else {
        (
            "looks a texture up at coordinates computed from another texture unit's texel (a dependent lookup), and the target has no texture shaders",
            "dependent lookups need NV_texture_shader: target geforce3 or wgsl, or compute the coordinates per vertex",
        )
    };
    // A cube map at an expanded texel as written: the lowering's
    // `texel_cube_map` writes it as dot products (exact, but a rewrite).
    let at_texel = matches!(m.exprs[units[k]], Expr::Lookup { texture, coords }
        if m.textures.get(texture as usize).is_some_and(|t| t.kind == TextureKind::Cube)
            && crate::lowering::texel_cube::expanded_texel(m, coords).is_some());
    let help = if texture_shaders && at_texel {
        "as written no stage reads the texel as a direction; the lowering's `texel_cube_map` rule writes the lookup \
         as dot_product_cube_map stages with the identity's rows (the same value): allow it with --max-error 0 \
         rather than --no-approx"
    } else {
        help
    };
    Err(crate::planner::realize::Refusal {
        reason: reason.into(),
        span: Some(m.span(units[k])),
        help: help.into(),
    })
}

/// `texture_2d(); dot_product_depth_replace_1of2(tex0);
/// dot_product_depth_replace_2of2(tex0);` (NV_texture_shader,
/// `DOT_PRODUCT_DEPTH_REPLACE_NV`): unit 0 reads the light's depth map
/// stored as two bytes, units 1 and 2 rebuild it as z / w and replace the
/// fragment's depth with it. The dot products read unit 0's texel as it
/// is (unsigned identity).
pub fn depth_replace() -> TextureShader {
    let step = |step| Operation::DotProduct {
        family: DotFamily::DepthReplace,
        step,
        previous: 0,
        mapping: DotMapping::UnsignedIdentity,
        eye: None,
    };
    TextureShader { stages: vec![Operation::Texture2d, step(0), step(1)] }
}

fn operation(m: &Module, earlier: &[Handle<Expr>], unit: Handle<Expr>) -> Option<Operation> {
    // A depth texture: TEXTURE_2D divides by q, the unit compares r/q (ARB_shadow).
    if crate::planner::shadow_map::depth_texture_read(m, unit).is_some() {
        return Some(Operation::Texture2d);
    }
    let Expr::Lookup { texture, coords } = m.exprs[unit] else { return None };
    let kind = m.textures.get(texture as usize)?.kind;
    if interpolated(m, coords) {
        return Some(match kind {
            TextureKind::Tex1d => Operation::Texture1d,
            TextureKind::Tex2d => Operation::Texture2d,
            TextureKind::Tex3d => Operation::Texture3d,
            TextureKind::Cube => Operation::TextureCubeMap,
        });
    }
    if kind != TextureKind::Tex2d {
        return None;
    }
    let Expr::Binary { op: BinaryOp::Add, lhs, rhs } = m.exprs[coords] else { return None };
    let (base, offset) = if interpolated(m, lhs) { (lhs, rhs) } else { (rhs, lhs) };
    if !interpolated(m, base) {
        return None;
    }
    let (scale, offset) = scaled(m, offset);
    let previous = earlier.iter().position(|&e| e == offset)?;
    let Expr::Lookup { texture: dsdt, .. } = m.exprs[offset] else { return None };
    let signed = m.textures.get(dsdt as usize)?.format;
    if !matches!(signed, TextureFormat::Signed8 | TextureFormat::Signed16) {
        return None;
    }
    Some(Operation::Offset {
        rectangle: false,
        previous: u8::try_from(previous).ok()?,
        matrix: [scale, 0.0, 0.0, scale],
        scale: None,
    })
}

/// Interpolated texture coordinates (`δ(u x)`).
fn interpolated(m: &Module, h: Handle<Expr>) -> bool {
    matches!(m.exprs[h], Expr::Interpolate { .. })
}

/// `s · e` or `e · s` with a constant scalar s: (s, e); else (1, h).
fn scaled(m: &Module, h: Handle<Expr>) -> (f32, Handle<Expr>) {
    if let Expr::Binary { op: BinaryOp::Mul, lhs, rhs } = m.exprs[h] {
        for (c, e) in [(lhs, rhs), (rhs, lhs)] {
            if let Expr::Constant(k) = &m.exprs[c] {
                if let [v] = k.values()[..] {
                    return (v as f32, e);
                }
            }
        }
    }
    (1.0, h)
}
