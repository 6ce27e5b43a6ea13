//! The range of what a program reads back from a texture it renders
//! itself: what its statements wrote there. A float texture (`rgba16f`)
//! holds any value, so its lookups are unbounded by their format; but a
//! G-buffer written only with `G δπx ← δ s x` (a normal and a light
//! direction, each component in [−1, 1]) holds only such values — and the
//! 0 it was cleared to, where nothing was drawn. Filtering and mipmaps
//! average texels, which stays within their hull. So each member read
//! back is bounded by the hull of what was written: `clamp(m, lo, hi)`,
//! equal to the member on every texel the program can write, with the
//! range the planner needs to blend a value read back exactly (`C xs ←
//! (C xs) * (p G xs)` modulates by `p` in [0, 0.8], not by an unbounded
//! `p`).

use rustc_hash::FxHashMap as HashMap;

use crate::ir::{Expr, Handle, Interval, MathFunction, Module, Table, TextureId};

/// The hull of the values written into texture `t` by `m`'s statements,
/// member by member (one entry for a texture that is not fat), with the 0
/// it is cleared to; `None` when a write is unbounded or reads `t` itself.
fn written_hulls(m: &Module, t: TextureId) -> Option<Vec<Interval>> {
    let mut hulls: Option<Vec<Interval>> = None;
    for st in m.statements.iter().filter(|st| matches!(st.table, Table::Texture(x) if x == t)) {
        let value = match m.exprs[st.value] {
            Expr::Select { accept, reject: None, .. } => accept,
            _ => st.value,
        };
        let members = match &m.exprs[value] {
            Expr::Bundle(members) => members.clone(),
            _ => vec![value],
        };
        let reads_itself = m.reachable(&[st.value]).into_iter().any(|h| match m.exprs[h] {
            Expr::Lookup { texture, .. } => texture == t,
            _ => false,
        });
        if reads_itself {
            return None;
        }
        let ranges: Vec<Interval> = members.iter().map(|h| m.info(*h).interval).collect();
        if ranges.iter().any(|i| !(i.lo.is_finite() && i.hi.is_finite())) {
            return None;
        }
        hulls = Some(match hulls {
            None => ranges.iter().map(|i| Interval { lo: i.lo.min(0.0), hi: i.hi.max(0.0) }).collect(),
            Some(h) if h.len() == ranges.len() => h
                .iter()
                .zip(&ranges)
                .map(|(a, b)| Interval { lo: a.lo.min(b.lo), hi: a.hi.max(b.hi) })
                .collect(),
            Some(_) => return None,
        });
    }
    hulls
}

/// Every unbounded read of a texture `m` renders itself — a member of a
/// fat texel, or a lookup — clamped to what its statements wrote there
/// ([`written_hulls`]), in the statements that blend onto their target;
/// the statements changed. Nothing is done for a
/// program that renders no texture, or reads none back unbounded.
pub fn bound_rendered_reads(m: &mut Module) -> Vec<usize> {
    let mut changed = Vec::new();
    if !m.textures.iter().any(|t| t.rendered) {
        return changed;
    }
    let roots: Vec<Handle<Expr>> = m.statements.iter().map(|s| s.value).collect();
    let unbounded = |i: Interval| !(i.lo.is_finite() && i.hi.is_finite());
    let mut reads: Vec<(Handle<Expr>, TextureId, usize)> = Vec::new();
    for h in m.reachable(&roots) {
        if !unbounded(m.info(h).interval) {
            continue;
        }
        let (texel, member) = match m.exprs[h] {
            Expr::FatMember { texel, member } => (texel, member as usize),
            Expr::Lookup { .. } if !matches!(m.info(h).ty, crate::ir::Ty::Bundle(_)) => (h, 0),
            _ => continue,
        };
        if let Expr::Lookup { texture, .. } = m.exprs[texel] {
            if m.textures[texture as usize].rendered {
                reads.push((h, texture, member));
            }
        }
    }
    if reads.is_empty() {
        return changed;
    }
    let mut hulls: HashMap<TextureId, Option<Vec<Interval>>> = HashMap::default();
    let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::default();
    for (h, t, member) in reads {
        let hull = hulls.entry(t).or_insert_with(|| written_hulls(m, t));
        let Some(i) = hull.as_ref().and_then(|h| h.get(member).copied()) else { continue };
        let span = m.span(h);
        let constant =
            |m: &mut Module, v: f64| m.intern(Expr::Constant(crate::ir::Constant::scalar(v)), span).ok();
        let (Some(lo), Some(hi)) = (constant(m, i.lo), constant(m, i.hi)) else { continue };
        if let Ok(c) = m.intern(Expr::Math { fun: MathFunction::Clamp, args: vec![h, lo, hi] }, span) {
            if m.info(c).ty == m.info(h).ty {
                map.insert(h, c);
            }
        }
    }
    if map.is_empty() {
        return changed;
    }
    for i in 0..m.statements.len() {
        // Only where the range decides the plan: a statement blending onto
        // what its target holds (elsewhere the clamp would be one more
        // operation in the pass for nothing).
        let st = m.statements[i].clone();
        let channels = [crate::ir::FbChannel::Color, crate::ir::FbChannel::Alpha];
        if !channels.iter().any(|c| super::form::self_read(m, &st, *c).is_some()) {
            continue;
        }
        let v = m.statements[i].value;
        if let Some(nv) = super::substitute(m, v, &map).filter(|nv| *nv != v) {
            m.statements[i].value = nv;
            changed.push(i);
        }
    }
    changed
}
