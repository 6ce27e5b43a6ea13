//! The texture-shader program of a pass that reads a HILO normal map by dot
//! products (`planner::hilo`): NV_texture_shader, Section 3.8.13 —
//! `texture_2d` on the SIGNED_HILO16_NV map's unit, then per dot-product
//! lookup `dot_product_2d_1of2(texN)` and `dot_product_2d_2of2(texN)`, the
//! second unit sampling the lookup's texture at the two dot products. The
//! previous-stage mapping does not apply to a HILO texel (it is signed), so
//! nvparse's plain `texN` is written.
//!
//! The same layout serves a cube map looked up at dot products of an
//! 8-bit normal map's expanded texel (`planner::hilo::DotKind::CubeMap`):
//! `texture_2d` on the normal map, then `dot_product_cube_map_1of3`,
//! `2of3` and `3of3(expand(texN))`, the third unit sampling the cube map
//! (Section 3.8.13, DOT_PRODUCT_TEXTURE_CUBE_MAP_NV, with
//! GL_EXPAND_NORMAL_NV as the previous-texture mapping).

use crate::ir::{Expr, Handle, Module};
use crate::planner::hilo::{dot_lookup, hardware_units, DotKind};

use super::program::{DotFamily, DotMapping, Operation, TextureShader};

/// How the other units' operations are read (`lower::operation`).
type Other = fn(&Module, &[Handle<Expr>], Handle<Expr>) -> Option<Operation>;

/// `None` when no unit is a HILO dot-product lookup; `Some(None)` when one
/// is but some unit has no operation; else the program.
pub fn program(m: &Module, units: &[Handle<Expr>], other: Other) -> Option<Option<TextureShader>> {
    let layout = hardware_units(m, units);
    if layout.len() == units.len() {
        return None;
    }
    let mut stages = Vec::with_capacity(layout.len());
    for (k, unit) in layout.iter().enumerate() {
        let Some(unit) = *unit else { continue };
        let Some(d) = dot_lookup(m, unit) else {
            // A dot stage's unit stands as `unit` itself, which no operation reads.
            let earlier: Vec<Handle<Expr>> = layout[..k].iter().map(|u| u.unwrap_or(unit)).collect();
            let Some(op) = other(m, &earlier, unit) else { return Some(None) };
            stages.push(op);
            continue;
        };
        let Some(previous) = layout.iter().position(|u| *u == Some(d.hilo)) else { return Some(None) };
        let Ok(previous) = u8::try_from(previous) else { return Some(None) };
        if usize::from(previous) >= k + 1 - d.rows.len() {
            return Some(None);
        }
        // A HILO texel is signed (the mapping does not apply: plain
        // `texN`); an 8-bit normal map's is expanded (`expand(texN)`).
        let (family, mapping) = match d.kind {
            DotKind::Hilo2d => (DotFamily::Texture2d, DotMapping::UnsignedIdentity),
            DotKind::CubeMap => (DotFamily::CubeMap, DotMapping::ExpandNormal),
        };
        for step in 0..d.rows.len() as u8 {
            stages.push(Operation::DotProduct { family, step, previous, mapping, eye: None });
        }
    }
    Some(Some(TextureShader { stages }))
}
