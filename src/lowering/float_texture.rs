//! Rule `float_texture_8bit`: a float texture (`rgba16f`, `rgba32f`) on a
//! target without float formats, whose every write is a value in [0, 1] (a
//! colour a texel pass or a first pass computes, seeds/001 (13)), is the
//! same texture in RGBA8: its writes and lookups retargeted. Error: the
//! 8-bit store rounds by ½ of 1/255 (filtering does not grow it).
//!
//! A float texture holding a fat texel is [`super::fat_texture`]'s; one
//! holding values outside [0, 1] (positions, unbounded sums) keeps the
//! planner's refusal: the compiler cannot choose their 8-bit form without
//! the scene.

use super::Rewriter;
use crate::ir::{Expr, Table, Texture};
use crate::parser::ast::TextureFormat;
use crate::pipeline::ApproximationCost;

/// The bound on a looked-up channel's added error (module doc).
pub const ERROR_BOUND: f64 = 0.5 / 255.0;

/// Retargets every float texture whose writes all fit RGBA8.
pub fn apply(r: &mut Rewriter) {
    if r.profile.float_textures {
        return;
    }
    for t in 0..r.m.textures.len() as u32 {
        if fits_rgba8(r, t) {
            let to = restore(r, t);
            retarget(r, t, to);
        }
    }
}

/// Whether `t` is a rendered float texture every statement writes with a
/// (non-bundle) value in [0, 1].
fn fits_rgba8(r: &Rewriter, t: u32) -> bool {
    let texture = &r.m.textures[t as usize];
    let float = matches!(texture.format, TextureFormat::Rgba16f | TextureFormat::Rgba32f);
    let mut writes = r.m.statements.iter().filter(|st| st.table == Table::Texture(t)).peekable();
    float
        && texture.rendered
        && writes.peek().is_some()
        && writes.all(|st| {
            let iv = r.m.info(st.value).interval;
            !matches!(r.m.exprs[st.value], Expr::Bundle(_)) && iv.lo >= 0.0 && iv.hi <= 1.0
        })
}

/// The RGBA8 texture standing for `t`.
fn restore(r: &mut Rewriter, t: u32) -> u32 {
    let texture = Texture {
        name: format!("{}_rgba8", r.m.textures[t as usize].name),
        format: TextureFormat::Rgba8,
        ..r.m.textures[t as usize].clone()
    };
    r.m.textures.push(texture);
    (r.m.textures.len() - 1) as u32
}

/// Writes of `t` go to `to`; its lookups read `to`, each recorded.
fn retarget(r: &mut Rewriter, t: u32, to: u32) {
    let name = r.m.textures[t as usize].name.clone();
    r.rebuild_statements(|r, e, span| match *e {
        Expr::Lookup { texture, coords } if texture == t => {
            let looked_up = r.node(Expr::Lookup { texture: to, coords }, span)?;
            r.record(
                "float_texture_8bit",
                span,
                Some(looked_up),
                format!("the target has no float textures: `{name}`, written only with values in [0, 1], is stored in rgba8"),
                ApproximationCost::default(),
                Some(ERROR_BOUND),
            );
            Some(looked_up)
        }
        _ => None,
    });
    for st in &mut r.m.statements {
        if st.table == Table::Texture(t) {
            st.table = Table::Texture(to);
        }
    }
}
