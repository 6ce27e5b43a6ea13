//! One pass per light: how a program written for one light
//! runs on a scene with several.
//!
//! **The rule.** A program that names only light 0 — vectors declared
//! `light`, `light(0)`, `half`, `half(0)`, `intensity`, `intensity(0)` — is
//! written for "one of possibly many light sources" (Pipeline Grammar, Figure 3's
//! L). On a scene with n lights, each colour statement on a mesh
//! (`C δπx ← …`) is read as a sum of products (through `+`, `−`, unary `−`,
//! `*`, `⊕[add]` and `⊕[modulate]`, a product distributed over a sum when
//! only one factor depends on the light). The terms that depend on light 0
//! are the statement's *light terms*; the others are its *once terms*. The
//! statement runs as written for light 0, and for every other light i a
//! statement `C δπx ← (C δπx) ⊕[add] (light terms with light 0's vectors
//! replaced by light i's)` follows it — the multipass accumulation of
//! Pipeline Grammar, eq. (9) with ⊕ = add, "a separate pass for each light source"
//! (Pipeline Grammar, Section 3.4). These per-light statements are never fused with
//! one another, so each light is its own pass and light culling can skip it
//! per object (`planner::relevance`).
//!
//! Not replicated (light 0 only, and said so in the plan's `removed` list
//! as kind `note`): a program that names another light index (it addresses
//! lights explicitly); a statement whose framebuffer operation is not a
//! replacement or an addition (a modulation `C ← C · d(L)` does not
//! distribute over lights); a light term that reads its own target (Kilgard's
//! `(α C) · specular` gates by a value the previous light's pass changed);
//! a light term under a ⊕ mode that is not linear in it (`decal`, `blend`,
//! `replace`, `interpolate`, `add_signed`, `dot3`) or under a selection.

use std::collections::HashSet;

use rustc_hash::FxHashMap as HashMap;

use super::affine::Builder;
use crate::ir::{
    BinaryOp, Expr, FbChannel, Frequency, Handle, Module, Statement, Table, Ty, UnaryOp, Vector, VectorId,
};
use crate::parser::ast::{CombineMode, VectorKind};
use crate::pipeline::Removed;
use crate::span::Span;

/// A statement that depends on light 0 and was replicated.
#[derive(Clone, Debug, PartialEq)]
pub struct LightStatement {
    /// The statement's index in the expanded module.
    pub statement: usize,
    /// The original statement's index (0-based, in source order).
    pub source_statement: usize,
    pub light: u32,
    /// Light 0's statement only: its value without the light terms (the
    /// once terms, or zero), what it becomes when light 0 is culled.
    pub without_light: Option<Handle<Expr>>,
    /// The light terms (light `light`'s vectors).
    pub light_terms: Handle<Expr>,
}

/// What [`expand`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Expansion {
    pub statements: Vec<LightStatement>,
    /// Why statements that depend on light 0 were not replicated.
    pub notes: Vec<Removed>,
    /// Per statement of the expanded module: its source statement (empty: the identity).
    pub source: Vec<usize>,
}

impl Expansion {
    /// The light of statement `i` of the expanded module, if it is a per-light statement.
    pub fn light_of(&self, i: usize) -> Option<u32> {
        self.statements.iter().find(|s| s.statement == i).map(|s| s.light)
    }
}

/// Whether a vector declaration is light 0 as "the light" (module docs).
fn is_light_zero(v: &Vector) -> bool {
    matches!(v.kind, Some(VectorKind::Light | VectorKind::Half | VectorKind::Intensity))
        && v.index.unwrap_or(0) == 0
}

/// Replicates the light terms of `m`'s statements for lights 1..n (module docs).
pub fn expand(m: &mut Module, n_lights: usize, at: &dyn Fn(Span) -> String) -> Expansion {
    let mut out = Expansion::default();
    let template: Vec<VectorId> =
        (0..m.vectors.len() as VectorId).filter(|&v| is_light_zero(&m.vectors[v as usize])).collect();
    if template.is_empty() {
        return out;
    }
    if let Some(note) = names_a_light(m, at) {
        out.notes.push(note);
        return out;
    }
    let dep = light_dependent(m, &template);
    let mut r = Replicator { template: &template, dep: &dep, copies: HashMap::default(), at };
    let mut new_statements: Vec<(usize, Statement, u32, Handle<Expr>)> = Vec::new();
    for k in 0..m.statements.len() {
        let st = m.statements[k].clone();
        if !dep.contains(&st.value) {
            continue;
        }
        let split = match r.split_light_terms(m, k, &st) {
            Ok(split) => split,
            Err(note) => {
                out.notes.extend(note);
                continue;
            }
        };
        out.statements.push(LightStatement {
            statement: k,
            source_statement: k,
            light: 0,
            without_light: Some(split.without),
            light_terms: split.light_sum,
        });
        for i in 1..n_lights as u32 {
            match r.for_light(m, k, &st, &split, i) {
                Ok(Some((st, term))) => new_statements.push((k, st, i, term)),
                Ok(None) => {}
                Err(note) => out.notes.push(note),
            }
        }
    }
    insert_per_light(m, &mut out, new_statements);
    out
}

/// A note when the program names a light other than 0 explicitly: then it
/// is not replicated per scene light.
fn names_a_light(m: &Module, at: &dyn Fn(Span) -> String) -> Option<Removed> {
    let v = m.vectors.iter().find(|v| {
        matches!(v.kind, Some(VectorKind::Light | VectorKind::Half | VectorKind::Intensity))
            && v.index.unwrap_or(0) > 0
    })?;
    Some(Removed {
        kind: "note".into(),
        what: "per-light passes".into(),
        why: format!(
            "the program names light {} explicitly (`{}`), so it is not replicated per scene light",
            v.index.unwrap_or(0),
            v.name
        ),
        at: at(v.span),
    })
}

/// The nodes that depend on light 0's vectors (`template`).
fn light_dependent(m: &Module, template: &[VectorId]) -> HashSet<Handle<Expr>> {
    let mut dep: HashSet<Handle<Expr>> = HashSet::new();
    for i in 0..m.exprs.len() {
        let h = Handle::new(i);
        let e = &m.exprs[h];
        let d = match e {
            Expr::Vector { vector, .. } => template.contains(vector),
            _ => e.operands().iter().any(|o| dep.contains(o)),
        };
        if d {
            dep.insert(h);
        }
    }
    dep
}

/// A statement's value as `C + Σ light terms + the rest`: what each light
/// adds, what is written once, and the target's own colour read.
struct LightSplit {
    light_sum: Handle<Expr>,
    without: Handle<Expr>,
    own: Handle<Expr>,
}

/// What the replication shares across statements: light 0's vectors, the
/// nodes depending on them, and light i's copies of each vector.
struct Replicator<'r> {
    template: &'r [VectorId],
    dep: &'r HashSet<Handle<Expr>>,
    copies: HashMap<(VectorId, u32), VectorId>,
    at: &'r dyn Fn(Span) -> String,
}

impl Replicator<'_> {
    fn note(&self, k: usize, st: &Statement, why: String) -> Removed {
        Removed { kind: "note".into(), what: format!("statement {}", k + 1), why, at: (self.at)(st.span) }
    }

    /// Statement `k` as a sum of light terms and the rest, or why it stays
    /// light 0 only (a product does not distribute over lights); `Err(None)`:
    /// light 0 only, with nothing to say.
    fn split_light_terms(
        &self,
        m: &mut Module,
        k: usize,
        st: &Statement,
    ) -> Result<LightSplit, Option<Removed>> {
        let (fb, own) = match st.table {
            Table::Framebuffer { id, channel: FbChannel::Color } if st.freq == Frequency::Fragment => (
                id,
                m.exprs.find(&Expr::FramebufferRead {
                    framebuffer: id,
                    channel: FbChannel::Color,
                    position: st.index,
                }),
            ),
            _ => {
                return Err(Some(self.note(
                    k,
                    st,
                    "it depends on the light but is not a colour statement on a mesh: light 0 only".into(),
                )))
            }
        };
        let own_alpha = m.exprs.find(&Expr::FramebufferRead {
            framebuffer: fb,
            channel: FbChannel::Alpha,
            position: st.index,
        });
        // An rgb value the framebuffer widens (alpha 1) is split inside the
        // widening, and each part widened again: its once terms run once
        // (`C ← ka + δ p s x`), each light's pass adds alpha 1 as written.
        let (value, widened) = match m.exprs[st.value] {
            Expr::Convert { value, to: Ty::Rgba }
                if m.info(value).ty == Ty::Rgb && self.dep.contains(&value) =>
            {
                (value, true)
            }
            _ => (st.value, false),
        };
        let mut terms = Vec::new();
        if let Err(why) = decompose(m, self.dep, value, false, &mut terms) {
            return Err(Some(self.note(k, st, format!("{why}: light 0 only"))));
        }
        let reads_own = |m: &Module, h: Handle<Expr>| {
            m.reachable(&[h]).into_iter().any(|n| {
                Some(n) == own
                    || Some(n) == own_alpha
                    || matches!(m.exprs[n], Expr::FramebufferRead { framebuffer, .. } if framebuffer == fb)
            })
        };
        // A product `decompose` built (a factor times one light term) is
        // new to `dep`: a term is a light term where it reaches the light.
        let reaches_light = |m: &Module, h: Handle<Expr>| {
            self.dep.contains(&h) || m.reachable(&[h]).into_iter().any(|n| self.dep.contains(&n))
        };
        let (light, once): (Vec<_>, Vec<_>) = terms.into_iter().partition(|(h, _)| reaches_light(m, *h));
        if light.iter().any(|(h, _)| reads_own(m, *h)) {
            return Err(Some(self.note(
                k,
                st,
                "its light term reads its own target (as Kilgard's `(α C) · specular` does): light 0 only".into(),
            )));
        }
        // The framebuffer appears only as `C + …` (a term C itself) or not at all.
        if once.iter().any(|(h, neg)| reads_own(m, *h) && (Some(*h) != own || *neg)) {
            return Err(Some(self.note(k, st, "its framebuffer operation is not a replacement or an addition (a product does not distribute over lights): light 0 only".into())));
        }
        let ty = m.info(value).ty;
        let without = match sum(m, &once) {
            Some(h) => Some(h),
            None if once.is_empty() => Builder { module: m }.constant(ty, 0.0),
            None => None,
        };
        let widen = |m: &mut Module, h: Option<Handle<Expr>>| match h {
            Some(h) if widened => m.intern(Expr::Convert { value: h, to: Ty::Rgba }, Span::DETACHED).ok(),
            h => h,
        };
        let (light_sum, without) = (sum(m, &light), without);
        let (Some(light_sum), Some(without)) = (widen(m, light_sum), widen(m, without)) else {
            return Err(Some(self.note(k, st, "its light terms could not be summed: light 0 only".into())));
        };
        let own = own.or_else(|| {
            m.intern(
                Expr::FramebufferRead { framebuffer: fb, channel: FbChannel::Color, position: st.index },
                Span::DETACHED,
            )
            .ok()
        });
        // No node for the target's colour: nothing to add light i to.
        let own = own.ok_or(None)?;
        Ok(LightSplit { light_sum, without, own })
    }

    /// Light i's statement `C ← C ⊕[add] term_i`, with light 0's vectors
    /// replaced by light i's copies; `None` when the term cannot be built.
    fn for_light(
        &mut self,
        m: &mut Module,
        k: usize,
        st: &Statement,
        split: &LightSplit,
        i: u32,
    ) -> Result<Option<(Statement, Handle<Expr>)>, Removed> {
        let map = self.light_copies(m, split.light_sum, i);
        let Some(term) = super::substitute(m, split.light_sum, &map) else { return Ok(None) };
        let term = match m.info(term).ty {
            Ty::Rgb => m.intern(Expr::Convert { value: term, to: Ty::Rgba }, m.span(term)).ok(),
            Ty::Rgba | Ty::Scalar => Some(term),
            _ => None,
        };
        let Some(value) = term.and_then(|t| {
            m.intern(Expr::Combine { mode: CombineMode::Add, lhs: split.own, rhs: t }, st.span).ok()
        }) else {
            return Err(self.note(k, st, format!("light {i}'s term does not add to a colour: light 0 only")));
        };
        Ok(Some((Statement { value, ..st.clone() }, term.unwrap_or(value))))
    }

    /// Light 0's vector nodes under `light_sum`, each mapped to light i's copy.
    fn light_copies(
        &mut self,
        m: &mut Module,
        light_sum: Handle<Expr>,
        i: u32,
    ) -> HashMap<Handle<Expr>, Handle<Expr>> {
        let mut map = HashMap::default();
        for h in m.reachable(&[light_sum]) {
            let Expr::Vector { vector, site } = m.exprs[h] else { continue };
            if !self.template.contains(&vector) {
                continue;
            }
            let copy = *self.copies.entry((vector, i)).or_insert_with(|| {
                let v = &m.vectors[vector as usize];
                let c = Vector {
                    name: format!("{}#{i}", v.name),
                    kind: v.kind,
                    index: Some(i),
                    space: v.space,
                    span: v.span,
                };
                m.vectors.push(c);
                (m.vectors.len() - 1) as VectorId
            });
            if let Ok(n) = m.intern(Expr::Vector { vector: copy, site }, m.span(h)) {
                map.insert(h, n);
            }
        }
        map
    }
}

/// Inserts light i's statements right after their statement, in light
/// order, and renumbers `out`'s statements and sources.
fn insert_per_light(
    m: &mut Module,
    out: &mut Expansion,
    new_statements: Vec<(usize, Statement, u32, Handle<Expr>)>,
) {
    let mut by_source: HashMap<usize, Vec<(Statement, u32, Handle<Expr>)>> = HashMap::default();
    for (k, st, i, term) in new_statements {
        by_source.entry(k).or_default().push((st, i, term));
    }
    let old = std::mem::take(&mut m.statements);
    let mut index_of = vec![0; old.len()];
    let mut added: Vec<LightStatement> = Vec::new();
    for (k, st) in old.into_iter().enumerate() {
        index_of[k] = m.statements.len();
        m.statements.push(st);
        for (st, i, term) in by_source.remove(&k).unwrap_or_default() {
            added.push(LightStatement {
                statement: m.statements.len(),
                source_statement: k,
                light: i,
                without_light: None,
                light_terms: term,
            });
            m.statements.push(st);
        }
    }
    for s in &mut out.statements {
        s.statement = index_of[s.source_statement];
    }
    out.source = (0..m.statements.len())
        .map(|i| {
            added
                .iter()
                .find(|a| a.statement == i)
                .map_or_else(|| index_of.iter().position(|&x| x == i).unwrap_or(i), |a| a.source_statement)
        })
        .collect();
    out.statements.extend(added);
    out.statements.sort_by_key(|s| s.statement);
}

/// The terms of a sum of products (module docs); `Err` when a light term
/// sits under an operation that is not linear in it.
fn decompose(
    m: &mut Module,
    dep: &HashSet<Handle<Expr>>,
    h: Handle<Expr>,
    neg: bool,
    out: &mut Vec<(Handle<Expr>, bool)>,
) -> Result<(), String> {
    if !dep.contains(&h) {
        out.push((h, neg));
        return Ok(());
    }
    match m.exprs[h].clone() {
        Expr::Binary { op: BinaryOp::Add, lhs, rhs } | Expr::Combine { mode: CombineMode::Add, lhs, rhs } => {
            decompose(m, dep, lhs, neg, out)?;
            decompose(m, dep, rhs, neg, out)
        }
        Expr::Binary { op: BinaryOp::Sub, lhs, rhs }
        | Expr::Combine { mode: CombineMode::Subtract, lhs, rhs } => {
            decompose(m, dep, lhs, neg, out)?;
            decompose(m, dep, rhs, !neg, out)
        }
        Expr::Unary { op: UnaryOp::Neg, value } => decompose(m, dep, value, !neg, out),
        ref e @ (Expr::Binary { op: BinaryOp::Mul, lhs, rhs }
        | Expr::Combine { mode: CombineMode::Modulate, lhs, rhs })
            if dep.contains(&lhs) != dep.contains(&rhs) =>
        {
            let (factor, light) = if dep.contains(&lhs) { (rhs, lhs) } else { (lhs, rhs) };
            let mut inner = Vec::new();
            decompose(m, dep, light, false, &mut inner)?;
            if inner.len() == 1 {
                out.push((h, neg ^ inner[0].1));
                return Ok(());
            }
            let combine = matches!(e, Expr::Combine { .. });
            for (t, n) in inner {
                let p = if combine {
                    m.intern(
                        Expr::Combine { mode: CombineMode::Modulate, lhs: factor, rhs: t },
                        Span::DETACHED,
                    )
                    .ok()
                } else {
                    Builder { module: m }.mul(factor, t)
                };
                out.push((p.ok_or("a product of its light terms is ill-typed")?, neg ^ n));
            }
            Ok(())
        }
        Expr::Combine { mode, .. } if !matches!(mode, CombineMode::Modulate) => {
            Err(format!("its light term is under ⊕[{}], which is not linear in it", mode.as_str()))
        }
        Expr::Select { .. } => Err("its light term is under a selection".into()),
        _ => {
            out.push((h, neg));
            Ok(())
        }
    }
}

/// Σ ± terms (`None` for no terms or an ill-typed sum).
fn sum(m: &mut Module, terms: &[(Handle<Expr>, bool)]) -> Option<Handle<Expr>> {
    let mut acc: Option<Handle<Expr>> = None;
    for &(t, neg) in terms {
        let mut b = Builder { module: m };
        acc = Some(match (acc, neg) {
            (None, false) => t,
            (None, true) => b.neg(t)?,
            (Some(a), false) => add_any(m, a, t)?,
            (Some(a), true) => {
                let n = Builder { module: m }.neg(t)?;
                add_any(m, a, n)?
            }
        });
    }
    acc
}

/// `a + b`, as `⊕[add]` when only colours unify that way (rgba with rgb).
fn add_any(m: &mut Module, a: Handle<Expr>, b: Handle<Expr>) -> Option<Handle<Expr>> {
    if let Some(h) = (Builder { module: m }).add(a, b) {
        return Some(h);
    }
    let widen = |m: &mut Module, h: Handle<Expr>| {
        if m.info(h).ty == Ty::Rgb {
            m.intern(Expr::Convert { value: h, to: Ty::Rgba }, Span::DETACHED).ok()
        } else {
            Some(h)
        }
    };
    let (a, b) = (widen(m, a)?, widen(m, b)?);
    m.intern(Expr::Combine { mode: CombineMode::Add, lhs: a, rhs: b }, Span::DETACHED).ok()
}
