//! Rule `float_texture_8bit`: a float texture (`rgba16f`, `rgba32f`) on a
//! target without float formats, whose every write is a value in [0, 1] (a
//! colour a texel pass or a first pass computes, Pipeline Grammar, eq. (13)), is the
//! same texture in RGBA8: its writes and lookups retargeted. Error: the
//! 8-bit store rounds by ½ of 1/255 (filtering does not grow it).
//!
//! Whose every write is a direction or other signed rgb in [−1, 1] with
//! alpha 1 (`rgba(N δ s x, 1)`: a G-buffer of normals, Pipeline Grammar, eq. (5)), it
//! is stored range-compressed, `rgba(compress(rgb), 1)`, the classic 8-bit
//! normal map encoding (GeForce3 Phong, Section 5.1), and read back as
//! `rgba(expand(rgb) · a, a)`: a written texel gives its value, a cleared
//! one (0, 0, 0, 0) the float texture's cleared zero, not `expand(0) = −1`.
//! Error: `expand` doubles the store's rounding, 1/255; where a filtered
//! lookup mixes written and cleared texels (the border of what was drawn)
//! the value is scaled by the mixed alpha twice, which nearest lookups and
//! the inside of the drawn region do not see.
//!
//! A float texture holding a fat texel is [`super::fat_texture`]'s; one
//! holding values outside [−1, 1] (positions, unbounded sums), or signed
//! values with an alpha of their own, keeps the planner's refusal: the
//! compiler cannot choose their 8-bit form without the scene.

use super::Rewriter;
use crate::ir::{Expr, Handle, MathFunction, Table, Texture, Ty};
use crate::parser::ast::TextureFormat;
use crate::pipeline::ApproximationCost;

/// The bound on a looked-up channel's added error (module doc).
pub const ERROR_BOUND: f64 = 0.5 / 255.0;

/// The bound for a range-compressed texture: `expand` doubles the store's.
pub const ERROR_BOUND_SIGNED: f64 = 1.0 / 255.0;

/// How a float texture's writes fit RGBA8.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fit {
    /// Every write in [0, 1]: stored as it is.
    Unit,
    /// Every write an rgb in [−1, 1] with alpha 1: range-compressed.
    Signed,
}

/// Retargets every float texture whose writes all fit RGBA8.
pub fn apply(r: &mut Rewriter) {
    if r.profile.float_textures {
        return;
    }
    for t in 0..r.m.textures.len() as u32 {
        if let Some(fit) = fit(r, t) {
            let to = restore(r, t);
            retarget(r, t, to, fit);
        }
    }
}

/// How `t`, a rendered float texture every statement writes with a
/// (non-bundle) value, fits RGBA8, if it does.
fn fit(r: &Rewriter, t: u32) -> Option<Fit> {
    let texture = &r.m.textures[t as usize];
    let float = matches!(texture.format, TextureFormat::Rgba16f | TextureFormat::Rgba32f);
    let writes: Vec<Handle<Expr>> =
        r.m.statements.iter().filter(|st| st.table == Table::Texture(t)).map(|st| st.value).collect();
    if !float || !texture.rendered || writes.is_empty() {
        return None;
    }
    let within = |lo: f64, hi: f64| {
        writes.iter().all(|&w| {
            let iv = r.m.info(w).interval;
            !matches!(r.m.exprs[w], Expr::Bundle(_)) && iv.lo >= lo && iv.hi <= hi
        })
    };
    if within(0.0, 1.0) {
        Some(Fit::Unit)
    } else if within(-1.0, 1.0) && writes.iter().all(|&w| signed_rgb(r, w).is_some()) {
        Some(Fit::Signed)
    } else {
        None
    }
}

/// The rgb of a write `rgba(rgb, 1)` (or an rgb widened to rgba, whose
/// alpha is 1).
fn signed_rgb(r: &Rewriter, w: Handle<Expr>) -> Option<Handle<Expr>> {
    match &r.m.exprs[w] {
        Expr::Compose { ty: Ty::Rgba, components } if components.len() == 2 => {
            let one = matches!(&r.m.exprs[components[1]], Expr::Constant(c) if c.values() == [1.0]);
            (one && r.m.info(components[0]).ty.width() == 3).then_some(components[0])
        }
        Expr::Convert { value, to: Ty::Rgba } if r.m.info(*value).ty.width() == 3 => Some(*value),
        _ => None,
    }
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

/// Writes of `t` go to `to` (range-compressed if `Signed`); its lookups
/// read `to` (expanded), each recorded.
fn retarget(r: &mut Rewriter, t: u32, to: u32, fit: Fit) {
    let name = r.m.textures[t as usize].name.clone();
    let signed = fit == Fit::Signed;
    r.rebuild_statements(|r, e, span| match *e {
        Expr::Lookup { texture, coords } if texture == t => {
            let looked_up = r.node(Expr::Lookup { texture: to, coords }, span)?;
            let value = if signed { expanded(r, looked_up, span)? } else { looked_up };
            let (how, bound) = if signed {
                ("a signed rgb in [−1, 1] with alpha 1, is stored range-compressed in rgba8 (compress where written, expand where read)", ERROR_BOUND_SIGNED)
            } else {
                ("written only with values in [0, 1], is stored in rgba8", ERROR_BOUND)
            };
            r.record(
                "float_texture_8bit",
                span,
                Some(value),
                format!("the target has no float textures: `{name}`, {how}"),
                ApproximationCost::default(),
                Some(bound),
            );
            Some(value)
        }
        _ => None,
    });
    let writes: Vec<usize> =
        (0..r.m.statements.len()).filter(|&i| r.m.statements[i].table == Table::Texture(t)).collect();
    for i in writes {
        let st = &r.m.statements[i];
        let (value, span) = (st.value, st.span);
        let stored = if signed { compressed(r, value, span) } else { Some(value) };
        let st = &mut r.m.statements[i];
        st.table = Table::Texture(to);
        // A write the rewriter cannot build keeps its float texture (refused).
        if let Some(v) = stored {
            st.value = v;
        } else {
            st.table = Table::Texture(t);
        }
    }
}

/// `rgba(compress(rgb), 1)` of a write `rgba(rgb, 1)`.
fn compressed(r: &mut Rewriter, w: Handle<Expr>, span: crate::span::Span) -> Option<Handle<Expr>> {
    let rgb = signed_rgb(r, w)?;
    let c = r.node(Expr::Math { fun: MathFunction::Compress, args: vec![rgb] }, span)?;
    let one = r.node(Expr::Constant(crate::ir::Constant::scalar(1.0)), span)?;
    r.node(Expr::Compose { ty: Ty::Rgba, components: vec![c, one] }, span)
}

/// `rgba(expand(rgb) · a, a)` of a lookup (module doc).
fn expanded(r: &mut Rewriter, lookup: Handle<Expr>, span: crate::span::Span) -> Option<Handle<Expr>> {
    let rgb = r.node(Expr::Swizzle { value: lookup, pattern: [0, 1, 2, 0], len: 3, ty: Ty::Rgb }, span)?;
    let alpha =
        r.node(Expr::Swizzle { value: lookup, pattern: [3, 0, 0, 0], len: 1, ty: Ty::Scalar }, span)?;
    let e = r.node(Expr::Math { fun: MathFunction::Expand, args: vec![rgb] }, span)?;
    let scaled = r.node(Expr::Binary { op: crate::ir::BinaryOp::Mul, lhs: e, rhs: alpha }, span)?;
    r.node(Expr::Compose { ty: Ty::Rgba, components: vec![scaled, alpha] }, span)
}
