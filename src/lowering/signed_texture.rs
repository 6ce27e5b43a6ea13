//! Rule `signed_texture_compression`: a signed texture of directions (a
//! cube or 3-D map: `normalize_cube(n, 16)`, a generated normal field) on
//! a target without signed formats is stored range-compressed, `(v + 1)/2`
//! in RGB8, and every lookup of it expanded — how the GeForce 256 keeps its
//! normalization cube map (Kilgard 2000, Section 5.2: "the vector is
//! range-compressed into [0, 1] … and expanded by the register
//! combiners' `expand_normal` input mapping", Table 3).
//!
//! Only the storage changes: the texture is the declared one's source,
//! generated again into the 8-bit format (`ir::Texture::copy_of`). Error:
//! the 8-bit store rounds by ½ of 1/255, which `expand` doubles — at most
//! 1/255 per component more than the declared texture (filtering is a
//! convex combination, so it does not grow the rounding).
//!
//! A rendered signed texture (a statement writes it) and a signed 1-D or
//! 2-D map (a scalar or an offset pair, Pipeline Grammar, eq. (8)) are left to the
//! planner's refusal.

use std::collections::HashMap;

use super::Rewriter;
use crate::ir::{Expr, Handle, MathFunction, Texture};
use crate::parser::ast::{TextureFormat, TextureKind};
use crate::pipeline::ApproximationCost;

/// The bound on a looked-up component's added error (module doc).
pub const ERROR_BOUND: f64 = 1.0 / 255.0;

/// Re-stores every signed direction texture the target cannot hold and
/// rewrites its lookups in every statement.
pub fn apply(r: &mut Rewriter) {
    if r.profile.signed_textures {
        return;
    }
    let mut moved: HashMap<u32, u32> = HashMap::new();
    for (id, t) in r.m.textures.clone().iter().enumerate() {
        let signed = matches!(t.format, TextureFormat::Signed8 | TextureFormat::Signed16);
        let directions = matches!(t.kind, TextureKind::Cube | TextureKind::Tex3d);
        if signed && directions && !t.rendered {
            moved.insert(id as u32, restore(r, t));
        }
    }
    if moved.is_empty() {
        return;
    }
    r.rebuild_statements(|r, e, span| match *e {
        Expr::Lookup { texture, coords } if moved.contains_key(&texture) => {
            let name = r.m.textures[texture as usize].name.clone();
            expanded(r, moved[&texture], coords, span, &name)
        }
        _ => None,
    });
}

/// The RGB8 copy of signed texture `t`, added to the module.
fn restore(r: &mut Rewriter, t: &Texture) -> u32 {
    r.m.textures.push(Texture {
        name: format!("{}_rgb8", t.name),
        format: TextureFormat::Rgb8,
        declaration: None,
        copy_of: Some(t.name.clone()),
        ..t.clone()
    });
    (r.m.textures.len() - 1) as u32
}

/// `expand(T_rgb8 coords)`, recorded at the lookup.
fn expanded(
    r: &mut Rewriter,
    texture: u32,
    coords: Handle<Expr>,
    span: crate::span::Span,
    name: &str,
) -> Option<Handle<Expr>> {
    let lookup = r.node(Expr::Lookup { texture, coords }, span)?;
    let out = r.node(Expr::Math { fun: MathFunction::Expand, args: vec![lookup] }, span)?;
    r.record(
        "signed_texture_compression",
        span,
        Some(out),
        format!("the target has no signed textures: `{name}` is stored range-compressed in rgb8, (v + 1)/2, and expanded after the lookup"),
        ApproximationCost { texture_units: 0, passes: 0, general_combiners: 0, texels: 0 },
        Some(ERROR_BOUND),
    );
    Some(out)
}
