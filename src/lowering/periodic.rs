//! Rule `periodic_table`: `g(fract(t))` — stripes, contour lines, any
//! function of a fractional part — with `t` affine in interpolated values
//! (`fract(8·y)` of a position, which no table over `t`'s range holds: a
//! position has none). One period of `g` is a 1-D table baked by the
//! compiler, read with REPEAT wrap, which takes the fractional part of the
//! coordinate (OpenGL 1.2.1, Section 3.8.7), at `t` itself interpolated as
//! a texture coordinate — exact, since interpolation commutes with an
//! affine map (Pipeline Grammar, eq. (7): texgen indexing). The table is
//! sampled `nearest`, so that the seam between two periods is not
//! blended: texel `i` holds `g((i + ½)/N)` for the arguments in
//! `[i/N, (i + 1)/N)`.
//!
//! Error bound: measured by the compiler when it bakes, the largest
//! difference between `g` and the 8-bit texel the unit reads, over
//! [`table::PROBES`] arguments in one period (a jump of `g` is a texel
//! wide).

use super::table::{self, Domain};
use super::{per_vertex, Rewriter};
use crate::ir::{BinaryOp, Expr, Frequency, Handle, MathFunction, Module, UnaryOp};
use crate::parser::ast::TextureKind;
use crate::pipeline::ApproximationCost;
use crate::span::Span;
use crate::textures::{Filter, Wrap};

/// The table lookup standing for `h`, a chain of one-argument operations
/// over `fract(t)`; `None` for another value.
pub fn apply(r: &mut Rewriter, h: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let (ops, _) = table::chain(&r.m, h)?;
    let k = ops.iter().position(|e| matches!(e, Expr::Math { fun: MathFunction::Fract, .. }))?;
    let t = table::single_argument(&r.m, &ops[k])?;
    if !affine_in_interpolants(&r.m, t) {
        return None;
    }
    let period = &ops[..=k];
    let g = |x: f64| table::evaluate(&r.m, period, t, x);
    let (samples, store) = table::tabulate(&g, Domain::Direct)?;
    let bound = nearest_error(&samples, store, &g);
    let texel_value = table::texel_function(r, period, t, Domain::Direct, store, span)?;
    let t_v = per_vertex::at_vertex(&mut r.m, t)?;
    let coords = r.node(Expr::Interpolate { value: t_v, to: Frequency::Fragment }, span)?;
    let repeating = crate::ir::Sampling { filter: Filter::Nearest, wrap: Wrap::Repeat, mipmap: false };
    let decoded =
        table::baked_lookup_sampled(r, TextureKind::Tex1d, texel_value, (coords, repeating), store, span)?;
    r.record(
        "periodic_table",
        span,
        Some(decoded),
        format!(
            "a function of a fractional part is one period in a {}-texel 8-bit table baked by the compiler, \
             read with REPEAT wrap at the interpolated argument",
            table::TEXELS
        ),
        ApproximationCost { texture_units: 1, passes: 0, general_combiners: 0, texels: table::TEXELS as u64 },
        Some(bound),
    );
    Some(decoded)
}

/// Whether `t` is an affine function of interpolated values (sums,
/// differences, negations, products by values per object, swizzles):
/// computed per vertex and interpolated, it is exact. What is below an
/// interpolant (per vertex) or per object may be anything.
fn affine_in_interpolants(m: &Module, t: Handle<Expr>) -> bool {
    let not_per_sample = |h: Handle<Expr>| !m.info(h).freq.is_sample();
    m.reachable(&[t]).into_iter().all(|h| match &m.exprs[h] {
        _ if not_per_sample(h) => true,
        Expr::Interpolate { to: Frequency::Fragment, .. } | Expr::Swizzle { .. } => true,
        Expr::Unary { op: UnaryOp::Neg, .. } | Expr::Binary { op: BinaryOp::Add | BinaryOp::Sub, .. } => true,
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } => not_per_sample(*lhs) || not_per_sample(*rhs),
        _ => false,
    })
}

/// The largest difference between `g` and the texel a `nearest` unit reads
/// over one period: texel `⌊s·N⌋`, stored in 8 bits.
fn nearest_error(samples: &[f64], store: table::Storage, g: &dyn Fn(f64) -> f64) -> f64 {
    let n = table::TEXELS;
    let stored: Vec<f64> =
        samples.iter().map(|y| store.decode_value((store.encode(*y) * 255.0).round() / 255.0)).collect();
    (0..table::PROBES)
        .map(|k| {
            let s = (k as f64 + 0.5) / table::PROBES as f64;
            let i = ((s * n as f64) as usize).min(n - 1);
            (g(s) - stored[i]).abs()
        })
        .fold(0.0, f64::max)
}
