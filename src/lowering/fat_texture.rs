//! Rule `fat_texture_split`: a fat texture — each texel a bundle of
//! shading parameters, the fat framebuffer of deferred shading (Pipeline Grammar
//! (5)-(6)) or the fat texture map ((14)-(15)) — on the register
//! combiners, which write one colour per pass and read one per texture
//! unit: one 8-bit texture per member, each written by its own statement
//! and read where the member is. A member in [−1, 1] (a direction) is
//! stored range-compressed, `(v + 1)/2`, and expanded where it is read
//! (Kilgard 2000, Section 5.2); a member in [0, 1] as it is. The planner then
//! gives each member texture a unit and splits what needs more units than
//! the target has.
//!
//! Error: the 8-bit store, ½ of 1/255 per component, doubled by `expand`
//! — at most 1/255 per component of a member; nearest or linear filtering
//! of the stored texels is a convex combination and does not grow it.
//!
//! A member whose range leaves [−1, 1] (a position) has no 8-bit form the
//! compiler can choose without the scene: the texture keeps the planner's
//! refusal. A fat texture declared unsigned fixed-point (`rgba8`) holds
//! what GL stores there, every member clamped to [0, 1]: its members are
//! stored so, not range-compressed (a direction's negative components are
//! 0, as the program says).

use super::Rewriter;
use crate::ir::{Expr, Handle, MathFunction, Statement, Table, Texture, Ty};
use crate::parser::ast::TextureFormat;
use crate::pipeline::ApproximationCost;

/// The bound on a member's added error per component (module doc).
pub const ERROR_BOUND: f64 = 1.0 / 255.0;

/// Splits every fat texture whose members all have an 8-bit form.
pub fn apply(r: &mut Rewriter) {
    if !r.combiners() {
        return;
    }
    for t in 0..r.m.textures.len() as u32 {
        let Some(signed) = members(r, t) else { continue };
        let read = read_members(r, t);
        // A member nothing reads gets no texture and no pass.
        let split: Vec<Option<u32>> =
            (0..signed.len()).map(|i| read.contains(&(i as u8)).then(|| member_texture(r, t, i))).collect();
        rewrite_writes(r, t, &split, &signed);
        rewrite_reads(r, t, &split, &signed);
    }
}

/// The members of `t` some statement reads.
fn read_members(r: &Rewriter, t: u32) -> Vec<u8> {
    let roots: Vec<Handle<Expr>> = r.m.statements.iter().map(|st| st.value).collect();
    let mut read: Vec<u8> =
        r.m.reachable(&roots)
            .into_iter()
            .filter_map(|h| match r.m.exprs[h] {
                Expr::FatMember { texel, member } => {
                    matches!(r.m.exprs[texel], Expr::Lookup { texture, .. } if texture == t).then_some(member)
                }
                _ => None,
            })
            .collect();
    read.sort_unstable();
    read.dedup();
    read
}

/// Per member of the bundles written to `t`: whether it is signed; `None`
/// when `t` is not a fat texture, or a member has no 8-bit form. A fat
/// texture declared unsigned fixed-point (`rgba8`, `rgb8`, `r8`,
/// `rgba16`) stores each member clamped to [0, 1], as GL stores it: no
/// member is signed, and one of any range has its 8-bit form.
fn members(r: &Rewriter, t: u32) -> Option<Vec<bool>> {
    let unsigned = matches!(
        r.m.textures[t as usize].format,
        TextureFormat::Rgba8 | TextureFormat::Rgb8 | TextureFormat::R8 | TextureFormat::Rgba16
    );
    let writes: Vec<&Statement> = r.m.statements.iter().filter(|st| st.table == Table::Texture(t)).collect();
    let mut signed: Option<Vec<bool>> = None;
    for st in &writes {
        let Expr::Bundle(ms) = &r.m.exprs[st.value] else { return None };
        let these: Option<Vec<bool>> = ms
            .iter()
            .map(|&m| {
                let iv = r.m.info(m).interval;
                (unsigned || (iv.lo >= -1.0 && iv.hi <= 1.0)).then_some(!unsigned && iv.lo < 0.0)
            })
            .collect();
        let these = these?;
        match &mut signed {
            None => signed = Some(these),
            Some(s) if s.len() == these.len() => s.iter_mut().zip(these).for_each(|(a, b)| *a |= b),
            Some(_) => return None,
        }
    }
    signed
}

/// Texture `T#i` (rgba8, rendered, sampled as `T`), added to the module.
fn member_texture(r: &mut Rewriter, t: u32, i: usize) -> u32 {
    let fat = &r.m.textures[t as usize];
    let texture = Texture {
        name: format!("{}_member{i}", fat.name),
        format: TextureFormat::Rgba8,
        declaration: None,
        copy_of: None,
        tabulates: None,
        ..fat.clone()
    };
    r.m.textures.push(texture);
    (r.m.textures.len() - 1) as u32
}

/// Each statement writing a bundle to `t` becomes one per member.
fn rewrite_writes(r: &mut Rewriter, t: u32, split: &[Option<u32>], signed: &[bool]) {
    let mut out = Vec::new();
    for st in std::mem::take(&mut r.m.statements) {
        let members = match (&st.table, &r.m.exprs[st.value]) {
            (Table::Texture(x), Expr::Bundle(ms)) if *x == t => ms.clone(),
            _ => {
                out.push(st);
                continue;
            }
        };
        let per_member: Option<Vec<Statement>> = members
            .into_iter()
            .enumerate()
            .filter_map(|(i, m)| split[i].map(|texture| (i, m, texture)))
            .map(|(i, m, texture)| {
                let value = stored(r, m, signed[i], r.m.span(m))?;
                Some(Statement { table: Table::Texture(texture), value, ..st.clone() })
            })
            .collect();
        match per_member {
            Some(statements) => out.extend(statements),
            // A member without an 8-bit form: the statement stays (refused).
            None => out.push(st),
        }
    }
    r.m.statements = out.into();
}

/// `rgba(compress(m), 1)` (or `rgba(m, 1)`): alpha 1 marks a texel a
/// statement wrote, so that a read can tell it from the cleared texels,
/// whose compressed zero would otherwise expand to (−1, −1, −1).
fn stored(r: &mut Rewriter, m: Handle<Expr>, signed: bool, span: crate::span::Span) -> Option<Handle<Expr>> {
    let colour =
        if signed { r.node(Expr::Math { fun: MathFunction::Compress, args: vec![m] }, span)? } else { m };
    let one = r.node(Expr::Constant(crate::ir::Constant::scalar(1.0)), span)?;
    r.node(Expr::Compose { ty: Ty::Rgba, components: vec![colour, one] }, span)
}

/// Every member read, `member i of T c`, becomes `T#i c` (expanded).
fn rewrite_reads(r: &mut Rewriter, t: u32, split: &[Option<u32>], signed: &[bool]) {
    r.rebuild_statements(|r, e, span| match *e {
        Expr::FatMember { texel, member } => match r.m.exprs[texel] {
            Expr::Lookup { texture, coords } if texture == t => {
                split[member as usize].and_then(|to| read(r, to, coords, signed[member as usize], span))
            }
            _ => None,
        },
        _ => None,
    });
}

/// `expand(rgb(T#i c)) · alpha(T#i c)` (or the rgb without `expand`),
/// recorded: a written texel (alpha 1) gives its member, a cleared one
/// (alpha 0) the zero the fat texture's cleared texel holds.
fn read(
    r: &mut Rewriter,
    texture: u32,
    coords: Handle<Expr>,
    signed: bool,
    span: crate::span::Span,
) -> Option<Handle<Expr>> {
    let lookup = r.node(Expr::Lookup { texture, coords }, span)?;
    let rgb = r.node(Expr::Swizzle { value: lookup, pattern: [0, 1, 2, 0], len: 3, ty: Ty::Rgb }, span)?;
    let out = if signed {
        let expanded = r.node(Expr::Math { fun: MathFunction::Expand, args: vec![rgb] }, span)?;
        let alpha =
            r.node(Expr::Swizzle { value: lookup, pattern: [3, 0, 0, 0], len: 1, ty: Ty::Scalar }, span)?;
        r.node(Expr::Binary { op: crate::ir::BinaryOp::Mul, lhs: expanded, rhs: alpha }, span)?
    } else {
        rgb
    };
    let name = r.m.textures[texture as usize].name.clone();
    r.record(
        "fat_texture_split",
        span,
        Some(out),
        format!(
            "the combiners read one colour per texture unit: this member of a fat texel is its own 8-bit texture `{name}`{}",
            if signed { ", stored range-compressed, (v + 1)/2, and expanded" } else { "" }
        ),
        ApproximationCost { texture_units: 1, passes: 1, general_combiners: 0, texels: 0 },
        Some(ERROR_BOUND),
    );
    Some(out)
}
