//! HILO normal maps read by the texture shader's dot products
//! (NV_texture_shader, Section 3.8.13: the SIGNED_HILO16_NV internal format,
//! the DOT_PRODUCT_NV and DOT_PRODUCT_TEXTURE_2D_NV operations).
//!
//! A signed HILO texture stores two signed 16-bit channels (hi, lo); a
//! dot-product stage reading it sees the 3-vector
//! (hi, lo, sqrt(max(0, 1 − hi² − lo²))), the third component computed by the
//! texture shader. The program writes that vector as it is,
//!
//! ```text
//! let n = Nh δu x;                                  // Nh : 2d signed16
//! let N = vec3(n.x, n.y, sqrt(max(0, 1 − n·n)));
//! C δπx ← T vec2(N · δ L s x, N · δ H s x);        // DOT_PRODUCT_TEXTURE_2D
//! ```
//!
//! and this module recognizes it: the lookup `T` at two dot products of the
//! rebuilt normal with interpolated vectors is three texture units on the
//! GeForce3 — `texture_2d` of the HILO map, `dot_product_2d_1of2` and
//! `dot_product_2d_2of2` (whose unit samples `T`) — and nothing under its
//! coordinates is the combiners' work (not even the `sqrt`). Everything
//! else keeps its meaning: the CPU renderer and the WGSL compute the same
//! expression in float. See docs/hilo.md.

use rustc_hash::FxHashSet as HashSet;

use crate::ir::{BinaryOp, Expr, Handle, MathFunction, Module};
use crate::parser::ast::{TextureFormat, TextureKind};
use crate::profile::Profile;

/// A lookup the texture shader addresses by dot products with an earlier
/// unit's texel: a HILO normal's (DOT_PRODUCT_TEXTURE_2D) or an 8-bit
/// normal map's expanded texel (DOT_PRODUCT_TEXTURE_CUBE_MAP).
#[derive(Clone, Debug, PartialEq)]
pub struct DotLookup {
    /// The lookup whose texel the dot products read: the HILO map (a 2-D
    /// `signed16` texture), or the 8-bit normal map for [`DotKind::CubeMap`].
    pub hilo: Handle<Expr>,
    /// The interpolated vectors dotted with the normal, one per stage, in
    /// the order of the lookup's coordinates.
    pub rows: Vec<Handle<Expr>>,
    /// Which dot-product family reads them.
    pub kind: DotKind,
}

/// The NV_texture_shader dot-product family of a [`DotLookup`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DotKind {
    /// `dot_product_2d_1of2/2of2(texN)`: a 2-D lookup at two dot products
    /// of a HILO normal (read as it is, unsigned identity).
    Hilo2d,
    /// `dot_product_cube_map_1of3/2of3/3of3(expand(texN))`: a cube map
    /// looked up in the direction (N·a, N·b, N·c), N an unsigned 8-bit
    /// texel expanded to [-1, 1] (GL_EXPAND_NORMAL_NV) — Kilgard's bump
    /// mapping with a normalization cube map at a perturbed normal; the rows
    /// (1,0,0), (0,1,0), (0,0,1) look the cube map up at N itself.
    CubeMap,
}

/// Whether `profile` reads HILO textures by dot products: NV_texture_shader's
/// dot-product stages and its signed formats.
pub fn available(profile: &Profile) -> bool {
    profile.signed_textures && profile.texture_shaders.as_ref().is_some_and(|t| t.dot_product)
}

/// `vec3(n.x, n.y, sqrt(max(0, 1 − n·n)))` with `n` a lookup of a 2-D
/// `signed16` texture (also `1 − n.x·n.x − n.y·n.y` under the root): `n`.
pub fn hilo_normal(m: &Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    let Expr::Compose { components, .. } = &m.exprs[h] else { return None };
    let [x, y, z] = components[..] else { return None };
    let (n, 0) = component(m, x)? else { return None };
    let (n2, 1) = component(m, y)? else { return None };
    if n != n2 || !is_hilo_texel(m, n) {
        return None;
    }
    let Expr::Math { fun: MathFunction::Sqrt, args } = &m.exprs[z] else { return None };
    let Expr::Math { fun: MathFunction::Max, args } = &m.exprs[args[0]] else { return None };
    let [a, b] = args[..] else { return None };
    let under = if m.is_constant(a, 0.0) {
        b
    } else if m.is_constant(b, 0.0) {
        a
    } else {
        return None;
    };
    let Expr::Binary { op: BinaryOp::Sub, lhs, rhs } = m.exprs[under] else { return None };
    (m.is_constant(lhs, 1.0) && is_square_of(m, rhs, n)).then_some(n)
}

/// How a dot-product family finds the lookup whose texel it reads.
type Normal = fn(&Module, Handle<Expr>) -> Option<Handle<Expr>>;

/// `T (N·a, N·b)` with N a HILO normal and a, b interpolated 3-vectors
/// (either operand order): the HILO lookup and a, b; or a cube map at
/// `(N·a, N·b, N·c)` with N an expanded 8-bit texel ([`DotKind::CubeMap`]).
pub fn dot_lookup(m: &Module, lookup: Handle<Expr>) -> Option<DotLookup> {
    let Expr::Lookup { texture, coords } = m.exprs[lookup] else { return None };
    let (kind, normal): (DotKind, Normal) = match m.textures.get(texture as usize)?.kind {
        TextureKind::Tex2d => (DotKind::Hilo2d, hilo_normal),
        TextureKind::Cube => (DotKind::CubeMap, crate::lowering::texel_cube::expanded_texel),
        _ => return None,
    };
    let Expr::Compose { components, .. } = &m.exprs[coords] else { return None };
    if components.len() != if kind == DotKind::Hilo2d { 2 } else { 3 } {
        return None;
    }
    let mut hilo = None;
    let mut rows = Vec::new();
    for &c in components {
        let Expr::Binary { op: BinaryOp::Dot, lhs, rhs } = m.exprs[c] else { return None };
        let (n, row) = match (normal(m, lhs), normal(m, rhs)) {
            (Some(n), _) => (n, rhs),
            (_, Some(n)) => (n, lhs),
            _ => return None,
        };
        if hilo.is_some_and(|h| h != n) || !matches!(m.exprs[row], Expr::Interpolate { .. }) {
            return None;
        }
        hilo = Some(n);
        rows.push(row);
    }
    Some(DotLookup { hilo: hilo?, rows, kind })
}

/// The hardware's texture units for a pass's `units` (lookups in the plan's
/// order): each dot-product lookup preceded by its family's first stages,
/// which have no texture of their own (`None`); the HILO map must be bound
/// on an earlier unit. `units` itself where no unit is a dot-product lookup.
pub fn hardware_units(m: &Module, units: &[Handle<Expr>]) -> Vec<Option<Handle<Expr>>> {
    let mut out = Vec::with_capacity(units.len() + 1);
    for &u in units {
        if let Some(d) = dot_lookup(m, u) {
            out.extend(std::iter::repeat_n(None, d.rows.len() - 1));
        }
        out.push(Some(u));
    }
    out
}

/// The hardware unit of the plan's unit `i` ([`hardware_units`]); `i`
/// itself past `units` (a framebuffer read as a texture).
pub fn hardware_unit(m: &Module, units: &[Handle<Expr>], i: usize) -> usize {
    let extra: usize =
        units.iter().take(i + 1).filter_map(|&u| dot_lookup(m, u)).map(|d| d.rows.len() - 1).sum();
    i + extra
}

/// The interpolated vectors the dot-product stages read as their texture
/// coordinates, each with its hardware unit ([`hardware_units`]).
pub fn row_units(m: &Module, units: &[Handle<Expr>]) -> Vec<(Handle<Expr>, usize)> {
    let mut out = Vec::new();
    for (i, &u) in units.iter().enumerate() {
        if let Some(d) = dot_lookup(m, u) {
            let last = hardware_unit(m, units, i);
            let first = last + 1 - d.rows.len();
            out.extend(d.rows.iter().enumerate().map(|(j, &r)| (r, first + j)));
        }
    }
    out
}

/// Texture units the dot-product stages add to `lookups`'s own.
pub fn extra_units(m: &Module, lookups: &[Handle<Expr>]) -> usize {
    lookups.iter().filter_map(|&u| dot_lookup(m, u)).map(|d| d.rows.len() - 1).sum()
}

/// Whether `h` is a HILO map's texel that only dot-product stages read:
/// the combiners never see a HILO texel (NV_texture_shader gives them no
/// RGBA for it), so a unit holding one is not a combiner input.
pub fn is_hilo_unit(m: &Module, units: &[Handle<Expr>], h: Handle<Expr>) -> bool {
    units.iter().filter_map(|&u| dot_lookup(m, u)).any(|d| d.kind == DotKind::Hilo2d && d.hilo == h)
}

/// The nodes the texture shader computes for the dot-product lookups
/// reachable from `value` (their coordinates, the rebuilt normal included,
/// and nothing the combiners also read): not combiner operations.
pub fn texture_shader_nodes(m: &Module, value: Handle<Expr>, profile: &Profile) -> HashSet<Handle<Expr>> {
    if !available(profile) {
        return HashSet::default();
    }
    let reach = m.reachable(&[value]);
    let coords: Vec<Handle<Expr>> = reach
        .iter()
        .filter(|&&h| dot_lookup(m, h).is_some())
        .filter_map(|&h| match m.exprs[h] {
            Expr::Lookup { coords, .. } => Some(coords),
            _ => None,
        })
        .collect();
    m.reachable(&coords).into_iter().collect()
}

/// `(v, k)` for `v.k` (a one-component swizzle).
fn component(m: &Module, h: Handle<Expr>) -> Option<(Handle<Expr>, u8)> {
    match m.exprs[h] {
        Expr::Swizzle { value, pattern, len: 1, .. } => Some((value, pattern[0])),
        _ => None,
    }
}

/// `n·n`, or `n.x·n.x + n.y·n.y` (`n.x² + n.y²`).
fn is_square_of(m: &Module, h: Handle<Expr>, n: Handle<Expr>) -> bool {
    match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Dot, lhs, rhs } => lhs == n && rhs == n,
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } => {
            let mut ks = [square_component(m, lhs, n), square_component(m, rhs, n)];
            ks.sort();
            ks == [Some(0), Some(1)]
        }
        _ => false,
    }
}

/// `k` for `n.k · n.k` or `n.k^2`.
fn square_component(m: &Module, h: Handle<Expr>, n: Handle<Expr>) -> Option<u8> {
    let (a, b) = match m.exprs[h] {
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } => (lhs, rhs),
        Expr::Binary { op: BinaryOp::Pow, lhs, rhs } if m.is_constant(rhs, 2.0) => (lhs, lhs),
        _ => return None,
    };
    let (v, k) = component(m, a)?;
    (a == b && v == n).then_some(k)
}

/// A lookup of a 2-D `signed16` texture at interpolated coordinates: a
/// SIGNED_HILO16 map on a `texture_2d` unit.
fn is_hilo_texel(m: &Module, h: Handle<Expr>) -> bool {
    let Expr::Lookup { texture, coords } = m.exprs[h] else { return false };
    let Some(t) = m.textures.get(texture as usize) else { return false };
    t.kind == TextureKind::Tex2d
        && t.format == TextureFormat::Signed16
        && matches!(m.exprs[coords], Expr::Interpolate { .. })
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::ir::lower::lowered as module;

    const HEAD: &str = "vector L : light(0) in tangent;\nvector H : half(0) in tangent;\n\
        texture Nh : 2d signed16 = bumps(4);\ntexture T : 2d rgba8 clamp = exponent_table(8);\nlet n = Nh δu x;\n";

    fn output(m: &Module) -> Handle<Expr> {
        m.statements.last().unwrap().value
    }

    #[test]
    fn the_rebuilt_normal_and_its_dot_products_are_recognized() {
        for z in ["sqrt(max(0, 1 - n·n))", "sqrt(max(1 - (n.x*n.x + n.y*n.y), 0))"] {
            let src =
                format!("{HEAD}let N = vec3(n.x, n.y, {z});\nC δπx ← T vec2(N · δ L s x, δ H s x · N);\n");
            let m = module(&src);
            let d = dot_lookup(&m, output(&m));
            assert!(d.as_ref().is_some_and(|d| d.rows.len() == 2), "{z}: {d:?}");
        }
    }

    #[test]
    fn other_thirds_and_formats_are_not() {
        for (decl, z) in
            [("signed16", "sqrt(1 - n·n)"), ("signed8", "sqrt(max(0, 1 - n·n))"), ("signed16", "0")]
        {
            let src =
                format!("{HEAD}let N = vec3(n.x, n.y, {z});\nC δπx ← T vec2(N · δ L s x, N · δ H s x);\n")
                    .replace("2d signed16", &format!("2d {decl}"));
            let m = module(&src);
            assert_eq!(dot_lookup(&m, output(&m)), None, "{decl} {z}");
        }
    }
}
