//! Rule `texel_cube_map` (geforce3's texture shaders): a cube map looked
//! up at an 8-bit normal map's expanded texel — `Ncube vec3(t.x, t.y,
//! t.z)` with `t = expand(Tn δu x)`, and `normalize(expand(Tn δu x))`,
//! the filtered normal renormalized through a normalization cube map —
//! becomes the form NV_texture_shader computes, Section 3.8.13
//! (DOT_PRODUCT_TEXTURE_CUBE_MAP_NV): the cube map at `(N·a, N·b, N·c)`
//! with N the expanded texel (GL_EXPAND_NORMAL_NV) and a, b, c the
//! texture coordinates of the three dot-product units. At the texel
//! itself they are the identity's rows, (1,0,0), (0,1,0), (0,0,1),
//! interpolated (constant over the triangle): four texture units,
//!
//! ```text
//! texture_2d();                              // unit 0: the normal map
//! dot_product_cube_map_1of3(expand(tex0));   // (s,t,r) = (1,0,0)
//! dot_product_cube_map_2of3(expand(tex0));   // (s,t,r) = (0,1,0)
//! dot_product_cube_map_3of3(expand(tex0));   // (s,t,r) = (0,0,1): samples the cube map
//! ```
//!
//! Kilgard 2000, Section 5.2 renormalizes interpolated vectors with such a
//! map; GeForce3 Phong, Section 4.2.2 (Figure 5) stores `v/|v|`
//! range-compressed. A cube map written at the texel is the same lookup,
//! rewritten exactly (`N·(1,0,0)` is `N.x`); `normalize` of the texel is
//! an approximation with the 8-bit map's bound (`cube_map::error_bound`:
//! an RGB8 map, which the dot-product stage's result reaches the
//! combiners as, not the HILO one `cube_map` uses elsewhere on geforce3).

use super::Rewriter;
use crate::ir::{AddedSource, Constant, Expr, Handle, MathFunction, Module, Texture, Ty};
use crate::parser::ast::{TextureAttr, TextureFormat, TextureKind};
use crate::pipeline::ApproximationCost;
use crate::span::Span;

/// The name of the 8-bit normalization cube map the rule adds.
pub const NAME: &str = "Ncube8_lowered";

/// Whether `r`'s target reads a cube map at dot products of a texel.
pub fn available(r: &Rewriter) -> bool {
    r.combiners() && r.profile.cube_maps && r.profile.texture_shaders.as_ref().is_some_and(|t| t.dot_product)
}

/// `expand(n)`, `expand(n).rgb` or `vec3(e.x, e.y, e.z)` with `e =
/// expand(n)`, `n` a lookup of a 2-D unsigned 8-bit colour texture at
/// interpolated coordinates (a normal map on a `texture_2d` unit): `n`.
/// What a dot-product stage with the expand-normal mapping reads of it.
pub fn expanded_texel(m: &Module, h: Handle<Expr>) -> Option<Handle<Expr>> {
    let expand = match &m.exprs[h] {
        Expr::Math { fun: MathFunction::Expand, .. } => h,
        Expr::Swizzle { value, pattern, len: 3, .. } if pattern[..3] == [0, 1, 2] => *value,
        Expr::Compose { components, .. } if components.len() == 3 => {
            let mut base = None;
            for (k, &c) in components.iter().enumerate() {
                let Expr::Swizzle { value, pattern, len: 1, .. } = m.exprs[c] else { return None };
                if usize::from(pattern[0]) != k || base.is_some_and(|b| b != value) {
                    return None;
                }
                base = Some(value);
            }
            base?
        }
        _ => return None,
    };
    let Expr::Math { fun: MathFunction::Expand, args } = &m.exprs[expand] else { return None };
    let [n] = args[..] else { return None };
    let Expr::Lookup { texture, coords } = m.exprs[n] else { return None };
    let t = m.textures.get(texture as usize)?;
    let colour = matches!(t.format, TextureFormat::Rgb8 | TextureFormat::Rgba8);
    (t.kind == TextureKind::Tex2d && colour && matches!(m.exprs[coords], Expr::Interpolate { .. }))
        .then_some(n)
}

/// `Ncube vec3(N·δ(1,0,0), N·δ(0,1,0), N·δ(0,0,1))` for the cube lookup
/// `h` at an expanded texel: the same value, in the form the texture
/// shader performs (`planner::hilo::dot_lookup`). `None` when `h` is not one.
pub fn lookup_at_texel(r: &mut Rewriter, h: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let Expr::Lookup { texture, coords } = r.m.exprs[h] else { return None };
    if r.m.textures.get(texture as usize)?.kind != TextureKind::Cube || !available(r) {
        return None;
    }
    let n = expanded_texel(&r.m, coords)?;
    let coords = identity_dots(r, n, span)?;
    let lookup = r.node(Expr::Lookup { texture, coords }, span)?;
    // Exact, but recorded: the plan says the lookup takes three units.
    r.record(
        "texel_cube_map",
        span,
        Some(lookup),
        "a cube map at a normal-map texel is looked up by the texture shader's dot_product_cube_map stages \
         at the texel's dot products with the identity's rows (the same value)"
            .into(),
        ApproximationCost { texture_units: 2, passes: 0, general_combiners: 0, texels: 0 },
        Some(0.0),
    );
    Some(lookup)
}

/// `expand(Ncube8 (N·rows))` for `normalize(x)` with `x` an expanded
/// 8-bit texel, recorded as an approximation; `None` when `x` is not one
/// or the target cannot.
pub fn normalize_texel(r: &mut Rewriter, x: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    if !available(r) {
        return None;
    }
    let n = expanded_texel(&r.m, x)?;
    let coords = identity_dots(r, n, span)?;
    let texture = texture(r);
    let lookup = r.node(Expr::Lookup { texture, coords }, span)?;
    let expanded = r.node(Expr::Math { fun: MathFunction::Expand, args: vec![lookup] }, span)?;
    let size = super::cube_map::SIZE;
    r.record(
        "texel_cube_map",
        span,
        Some(expanded),
        format!(
            "`normalize` of a filtered normal-map texel is a lookup in an 8-bit normalization cube map \
             ({size}² texels a face) at the texel, by the texture shader's dot_product_cube_map stages"
        ),
        ApproximationCost {
            texture_units: 3,
            passes: 0,
            general_combiners: 0,
            texels: 6 * u64::from(size).pow(2),
        },
        Some(super::cube_map::error_bound(size)),
    );
    Some(expanded)
}

/// `vec3(N·δ(1,0,0), N·δ(0,1,0), N·δ(0,0,1))`, N = `expand(n)` as a vec3.
fn identity_dots(r: &mut Rewriter, n: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let e = r.node(Expr::Math { fun: MathFunction::Expand, args: vec![n] }, span)?;
    let mut xyz = Vec::with_capacity(3);
    for k in 0..3u8 {
        xyz.push(r.node(Expr::Swizzle { value: e, pattern: [k, 0, 0, 0], len: 1, ty: Ty::Scalar }, span)?);
    }
    let normal = r.node(Expr::Compose { ty: Ty::Vec3, components: xyz }, span)?;
    // The rows are interpolated as the normal map's coordinates are.
    let to = r.m.info(n).freq;
    let mut dots = Vec::with_capacity(3);
    for k in 0..3 {
        let mut axis = [0.0; 3];
        axis[k] = 1.0;
        let row = r.node(Expr::Constant(Constant::new(Ty::Vec3, &axis)), span)?;
        let row = r.node(Expr::Interpolate { value: row, to }, span)?;
        dots.push(r.node(Expr::Binary { op: crate::ir::BinaryOp::Dot, lhs: normal, rhs: row }, span)?);
    }
    r.node(Expr::Compose { ty: Ty::Vec3, components: dots }, span)
}

/// The program's 8-bit normalization cube map, added on first use.
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
        declaration: Some(AddedSource::NormalizeCube { size: super::cube_map::SIZE, bits: 8 }),
        copy_of: None,
        tabulates: Some(crate::ir::Tabulated::Normalize),
        sampling: crate::ir::Sampling::of(TextureKind::Cube, &[TextureAttr::Bilinear, TextureAttr::Clamp]),
        span: Span::DETACHED,
    });
    (r.m.textures.len() - 1) as u32
}
