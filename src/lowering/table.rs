//! Rule `baked_table`: a per-fragment function `f(a)` of one bounded
//! scalar that the combiners cannot compute (`sqrt`, division, `floor`,
//! `fract`, `exp`, a fractional power, …) becomes a 1-D table of `f`,
//! computed by the compiler on the CPU (the `bake(f)` path: a texel pass
//! `baked: true`), and looked up at the interpolated argument — texgen
//! indexing, which every target has (Pipeline Grammar, eq. (7), (13); Heidrich & Seidel 1999
//! Section 3 stores functions as textures the same way). An argument that
//! is not itself interpolated is first computed per vertex (rule
//! `per_vertex`, reported).
//!
//! The table has [`TEXELS`] entries over the argument's interval [lo, hi]
//! (its texel centres at the ends, so nothing is clamped), stored 8-bit,
//! range-compressed to the values' own interval when they leave [0, 1].
//! Error bound: measured by the compiler when it bakes — the largest
//! difference between `f` and the 8-bit table read back with linear
//! filtering, over [`PROBES`] arguments in [lo, hi].

use super::{per_vertex, Rewriter};
use crate::ir::eval::{self, Value};
use crate::ir::{BinaryOp, Constant, Expr, Frequency, Handle, Module, Statement, Table, Texture, Ty};
use crate::parser::ast::{TextureFormat, TextureKind};
use crate::pipeline::ApproximationCost;
use crate::span::Span;

/// Entries of a table: the compiler renders baked textures this size
/// (`pipeline::RENDERED_TEXTURE_SIZE`).
pub const TEXELS: usize = 256;
/// Arguments at which the compiler measures a table's error.
pub const PROBES: usize = 4096;

/// The table lookup standing for `h` (`written`: `h` as the program
/// wrote it), or `None` when `h` is not a function of one bounded
/// interpolated scalar.
pub fn apply(r: &mut Rewriter, h: Handle<Expr>, written: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let (ops, b) = chain(&r.m, h)?;
    if let Some(looked_up) = dependent(r, &ops, b, span) {
        return Some(looked_up);
    }
    // The argument per vertex: `δ v` gives v; another value of
    // interpolants is computed per vertex (rule `per_vertex`, recorded
    // below once the table stands for it) — then the function tabulated
    // is the chain as written down to that argument: `h`'s own chain may
    // end at a part already lowered (`floor(3d)/3` with `floor(3d)` a
    // table of d), which is not the per-vertex argument's function.
    let (ops, b, a_v, hoisted) = match r.m.exprs[b] {
        Expr::Interpolate { value, to: Frequency::Fragment } => (ops, b, value, false),
        _ => match chain(&r.m, written)? {
            // The written chain's argument is itself interpolated: exact.
            (ops_written, b_written)
                if let Expr::Interpolate { value, to: Frequency::Fragment } = r.m.exprs[b_written] =>
            {
                (ops_written, b_written, value, false)
            }
            (ops_written, b_written) => {
                let a_v = per_vertex::at_vertex(&mut r.m, b_written)?;
                (ops_written, b_written, a_v, true)
            }
        },
    };
    let (lo, hi) = (r.m.info(a_v).interval.lo, r.m.info(a_v).interval.hi);
    if !(lo.is_finite() && hi.is_finite() && hi > lo) || r.m.info(b).freq != Frequency::Fragment {
        return None;
    }
    let domain = Domain::Ends(lo, hi);
    let f = |x: f64| evaluate(&r.m, &ops, b, x);
    let (samples, store) = tabulate(&f, domain)?;
    let bound = table_error(&samples, store, domain, &f);
    let texel_value = texel_function(r, &ops, b, domain, store, span)?;
    let coords = coordinates(r, a_v, lo, hi, span)?;
    let decoded = baked_lookup(r, TextureKind::Tex1d, texel_value, coords, store, span)?;
    if hoisted {
        record_per_vertex_argument(r, decoded, span);
    }
    // An argument an earlier rule computed per vertex (`fract(8·y)` of an
    // interpolated position: its interpolant is `b`) stays that rule's
    // approximation: the table, which reads it, now stands for it. Else
    // it would be dropped as no longer reached, and the table's bound —
    // of the function at its argument — stated as the whole error.
    r.carry_results(b, decoded);
    r.record(
        "baked_table",
        span,
        Some(decoded),
        format!(
            "a function per fragment is a {TEXELS}-texel 8-bit table over [{lo:.3}, {hi:.3}] baked by the compiler, \
             looked up at the interpolated argument"
        ),
        ApproximationCost { texture_units: 1, passes: 0, general_combiners: 0, texels: TEXELS as u64 },
        Some(bound),
    );
    Some(decoded)
}

/// Records rule `per_vertex` for a table `decoded` whose argument the
/// lowering computes per vertex (no bound: it depends on the mesh).
pub(super) fn record_per_vertex_argument(r: &mut Rewriter, decoded: Handle<Expr>, span: Span) {
    r.record(
        "per_vertex",
        span,
        Some(decoded),
        "the argument of the function tabulated here is computed per vertex and interpolated".into(),
        ApproximationCost::default(),
        None,
    );
}

/// Rule `dependent_table` (geforce3's texture shaders, GeForce3 Phong, Section
/// 5.2, Figure 10 "Texture Shader, Lookup Table"): `f(a·c)` where the dot
/// product reads a texel (a normal map), so no per-vertex value can stand
/// for it — a table of `f` over [0, 1] looked up at the dot product itself
/// by a `DOT_PRODUCT_TEXTURE_1D` stage. The texture coordinate is the dot
/// product, clamped to the table's edge, so only a chain that is constant
/// below 0 (`max(0, ·)` first, or a dot product that cannot be negative)
/// and an argument that cannot exceed 1 are tabulated. Error bound:
/// measured as [`apply`]'s, over the clamped argument.
fn dependent(r: &mut Rewriter, ops: &[Expr], b: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
    let shaders = r.profile.texture_shaders.as_ref()?;
    if !(shaders.dependent_lookups && shaders.dot_product && r.combiners()) {
        return None;
    }
    let Expr::Binary { op: BinaryOp::Dot, lhs, rhs } = r.m.exprs[b] else { return None };
    let reads_texel = |h: Handle<Expr>| {
        r.m.reachable(&[h]).into_iter().any(|x| matches!(r.m.exprs[x], Expr::Lookup { .. }))
    };
    let iv = r.m.info(b).interval;
    let clamped_below = iv.lo >= 0.0 || clamps_at_zero(&r.m, ops, b);
    if !(reads_texel(lhs) || reads_texel(rhs)) || !clamped_below || iv.hi > 1.0 {
        return None;
    }
    let f = |x: f64| evaluate(&r.m, ops, b, x.max(0.0));
    let (samples, store) = tabulate(&f, Domain::Direct)?;
    let bound = table_error(&samples, store, Domain::Direct, &f);
    let texel_value = texel_function(r, ops, b, Domain::Direct, store, span)?;
    let decoded = baked_lookup(r, TextureKind::Tex1d, texel_value, b, store, span)?;
    r.record(
        "dependent_table",
        span,
        Some(decoded),
        format!(
            "a function of a per-fragment dot product is a {TEXELS}-texel 8-bit table over [0, 1] baked by the compiler, \
             looked up at the dot product by a texture-shader dot-product stage"
        ),
        ApproximationCost { texture_units: 2, passes: 0, general_combiners: 0, texels: TEXELS as u64 },
        Some(bound),
    );
    Some(decoded)
}

/// Whether the chain's first operation on `b` is `max(0, b)` (or
/// `saturate(b)`): the function is constant below 0.
fn clamps_at_zero(m: &Module, ops: &[Expr], b: Handle<Expr>) -> bool {
    match ops.last() {
        Some(Expr::Math { fun: crate::ir::MathFunction::Saturate, .. }) => true,
        Some(Expr::Math { fun: crate::ir::MathFunction::Max, args }) => {
            args.iter().any(|&a| m.is_constant(a, 0.0)) && args.contains(&b)
        }
        _ => false,
    }
}

/// `f` at the table's texels, and the 8-bit storage its values fit;
/// `None` when a value is not finite.
pub(super) fn tabulate(f: &dyn Fn(f64) -> f64, domain: Domain) -> Option<(Vec<f64>, Storage)> {
    let samples: Vec<f64> = (0..TEXELS).map(|i| f(domain.texel(i))).collect();
    let (ylo, yhi) =
        samples.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), y| (l.min(*y), h.max(*y)));
    (ylo.is_finite() && yhi.is_finite()).then(|| (samples, Storage::for_range(ylo, yhi)))
}

/// A new table texture whose texels `texel_value` computes (the compiler
/// bakes it), looked up at `coords` and decoded; sampled bilinearly,
/// clamped to its edge ([`crate::ir::Sampling::ADDED`]).
pub(super) fn baked_lookup(
    r: &mut Rewriter,
    kind: TextureKind,
    texel_value: Handle<Expr>,
    coords: Handle<Expr>,
    store: Storage,
    span: Span,
) -> Option<Handle<Expr>> {
    let at = (coords, crate::ir::Sampling::ADDED);
    baked_lookup_sampled(r, kind, texel_value, at, store, span)
}

/// [`baked_lookup`] with the table sampled as `sampling` says (a periodic
/// table: nearest, repeating).
pub(super) fn baked_lookup_sampled(
    r: &mut Rewriter,
    kind: TextureKind,
    texel_value: Handle<Expr>,
    (coords, sampling): (Handle<Expr>, crate::ir::Sampling),
    store: Storage,
    span: Span,
) -> Option<Handle<Expr>> {
    let index = r.node(Expr::TexelCoord, span)?;
    // The table is added once its statement and coordinates exist.
    let id = add_texture(r, kind);
    r.m.textures[id as usize].sampling = sampling;
    let looked_up = r.node(Expr::Lookup { texture: id, coords }, span)?;
    let decoded = store.decode(r, looked_up, span)?;
    r.pending.push(Statement {
        table: Table::Texture(id),
        index,
        freq: Frequency::Texel,
        value: texel_value,
        span,
        target_span: span,
    });
    Some(decoded)
}

/// The one per-sample scalar operand of `expr` when its others are
/// constants (a table can only vary with one).
pub(super) fn single_argument(m: &Module, expr: &Expr) -> Option<Handle<Expr>> {
    let mut arg = None;
    for o in expr.operands() {
        match &m.exprs[o] {
            Expr::Constant(_) => {}
            _ if m.info(o).freq.is_sample() && m.info(o).ty == Ty::Scalar && arg.is_none_or(|a| a == o) => {
                arg = Some(o)
            }
            _ => return None,
        }
    }
    arg
}

/// The operations from `h` down to the bounded scalar `b` they are a
/// function of (`sqrt(1 − t²)`: sqrt, −, ^ down to t), top first: the
/// table tabulates the whole chain over b's interval.
pub(super) fn chain(m: &Module, h: Handle<Expr>) -> Option<(Vec<Expr>, Handle<Expr>)> {
    let mut nodes = vec![m.exprs[h].clone()];
    let mut b = single_argument(m, &m.exprs[h])?;
    // As deep as one-argument operations go: an interpolant's affine map
    // (`3·δc`) is then in the table, not computed per vertex.
    while let Some(next) = arithmetic(m, b).then(|| single_argument(m, &m.exprs[b])).flatten() {
        if nodes.len() > 16 {
            return None;
        }
        nodes.push(m.exprs[b].clone());
        b = next;
    }
    Some((nodes, b))
}

fn arithmetic(m: &Module, h: Handle<Expr>) -> bool {
    matches!(m.exprs[h], Expr::Unary { .. } | Expr::Binary { .. } | Expr::Math { .. })
}

/// The chain at `b = x`, evaluated bottom up (its other operands constant).
pub(super) fn evaluate(m: &Module, chain: &[Expr], b: Handle<Expr>, x: f64) -> f64 {
    let mut below: (Handle<Expr>, f64) = (b, x);
    let mut value = x;
    for expr in chain.iter().rev() {
        let operands: Vec<Value> = expr
            .operands()
            .iter()
            .map(|o| match &m.exprs[*o] {
                Expr::Constant(c) => eval::value(c),
                _ if *o == below.0 => [below.1; 4],
                _ => [f64::NAN; 4],
            })
            .collect();
        value = eval::apply(m, expr, Ty::Scalar, &operands)[0];
        below = (m.exprs.find(expr).unwrap_or(below.0), value);
    }
    value
}

/// How far a tabulated function may leave [0, 1] by its own rounding and
/// still be stored as is (clamped by the 8-bit encoding: an error far
/// below the 8-bit step).
pub(super) const SNAP: f64 = 1e-9;

/// How table values are kept in 8 bits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Storage {
    lo: f64,
    scale: f64,
}

impl Storage {
    /// As they are when in [0, 1] (up to [`SNAP`], rounding in the
    /// function's own arithmetic); else range-compressed to [lo, hi].
    pub(super) fn for_range(lo: f64, hi: f64) -> Storage {
        if lo >= -SNAP && hi <= 1.0 + SNAP {
            Storage { lo: 0.0, scale: 1.0 }
        } else {
            Storage { lo, scale: (hi - lo).max(f64::MIN_POSITIVE) }
        }
    }
    pub(super) fn encode(self, y: f64) -> f64 {
        ((y - self.lo) / self.scale).clamp(0.0, 1.0)
    }
    pub(super) fn decode_value(self, t: f64) -> f64 {
        self.lo + self.scale * t
    }
    /// `saturate((y − lo)/scale)` as IR: what a texel stores of `y`.
    pub(super) fn encoded(self, r: &mut Rewriter, y: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
        let encoded = affine(r, y, 1.0 / self.scale, -self.lo / self.scale, span)?;
        r.node(Expr::Math { fun: crate::ir::MathFunction::Saturate, args: vec![encoded] }, span)
    }

    /// `lo + scale·T` as IR (nothing when stored as is).
    pub(super) fn decode(self, r: &mut Rewriter, t: Handle<Expr>, span: Span) -> Option<Handle<Expr>> {
        if self.lo == 0.0 && self.scale == 1.0 {
            return Some(t);
        }
        if self.lo == -1.0 && self.scale == 2.0 {
            // The combiners' expand_normal (seeds/003 Table 3).
            return r.node(Expr::Math { fun: crate::ir::MathFunction::Expand, args: vec![t] }, span);
        }
        let scale = r.node(Expr::Constant(Constant::scalar(self.scale)), span)?;
        let lo = r.node(Expr::Constant(Constant::scalar(self.lo)), span)?;
        let scaled = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: scale, rhs: t }, span)?;
        r.node(Expr::Binary { op: BinaryOp::Add, lhs: scaled, rhs: lo }, span)
    }
}

/// The largest |f(x) − table(x)| over [`PROBES`] arguments across the
/// domain: the table rounded to 8 bits and read back with linear filtering
/// between texel centres (clamped at the edge texels), as the target's
/// texture unit reads it.
pub(super) fn table_error(samples: &[f64], store: Storage, domain: Domain, f: &dyn Fn(f64) -> f64) -> f64 {
    let q: Vec<f64> = samples.iter().map(|y| (store.encode(*y) * 255.0).round() / 255.0).collect();
    let mut worst: f64 = 0.0;
    for k in 0..PROBES {
        let s = k as f64 / (PROBES - 1) as f64;
        let (x, p) = domain.probe(s);
        let i = (p.floor() as usize).min(TEXELS - 2);
        let w = p - i as f64;
        let t = q[i] * (1.0 - w) + q[i + 1] * w;
        worst = worst.max((f(x) - store.decode_value(t)).abs());
    }
    worst
}

/// Which argument texel i of a table holds.
#[derive(Clone, Copy)]
pub(super) enum Domain {
    /// [lo, hi] with the texel centres at the ends (texgen coordinates
    /// remapped per vertex).
    Ends(f64, f64),
    /// (i + ½)/N: the argument is the texture coordinate itself.
    Direct,
}

impl Domain {
    /// The argument texel `i` holds.
    pub(super) fn texel(self, i: usize) -> f64 {
        let n = TEXELS as f64;
        match self {
            Domain::Ends(lo, hi) => lo + (hi - lo) * i as f64 / (n - 1.0),
            Domain::Direct => (i as f64 + 0.5) / n,
        }
    }
    /// At fraction `s` of the domain: the argument, and where between the
    /// texels (in texels, from the first) the unit reads it.
    fn probe(self, s: f64) -> (f64, f64) {
        let n = TEXELS as f64;
        match self {
            Domain::Ends(lo, hi) => (lo + (hi - lo) * s, s * (n - 1.0)),
            Domain::Direct => (s, (s * n - 0.5).clamp(0.0, n - 1.0)),
        }
    }
}

/// A new 1-D or 2-D table texture, baked by the compiler.
fn add_texture(r: &mut Rewriter, kind: TextureKind) -> u32 {
    let prefix = if kind == TextureKind::Tex1d { "table_lowered" } else { "table2d_lowered" };
    let k = r.m.textures.iter().filter(|t| t.name.starts_with(prefix)).count();
    r.m.textures.push(Texture {
        name: format!("{prefix}{k}"),
        kind,
        format: TextureFormat::R8,
        rendered: true,
        baked: true,
        declaration: None,
        copy_of: None,
        tabulates: None,
        sampling: crate::ir::Sampling::ADDED,
        span: Span::DETACHED,
    });
    (r.m.textures.len() - 1) as u32
}

/// The texel statement's value: `encode(f(lo + (hi − lo)·s))`, with `s`
/// the texel centre's place in [0, 1] (`(t·N − ½)/(N − 1)`).
pub(super) fn texel_function(
    r: &mut Rewriter,
    chain: &[Expr],
    b: Handle<Expr>,
    domain: Domain,
    store: Storage,
    span: Span,
) -> Option<Handle<Expr>> {
    let n = TEXELS as f64;
    let texel = r.node(Expr::TexelCoord, span)?;
    let t = r.node(Expr::Swizzle { value: texel, pattern: [0, 0, 0, 0], len: 1, ty: Ty::Scalar }, span)?;
    let x = match domain {
        Domain::Ends(lo, hi) => {
            affine(r, t, (hi - lo) * n / (n - 1.0), lo - (hi - lo) * 0.5 / (n - 1.0), span)?
        }
        Domain::Direct => t,
    };
    let mut below = (b, x);
    for expr in chain.iter().rev() {
        let rebuilt = r.node(expr.map_operands(|o| if o == below.0 { below.1 } else { o }), span)?;
        below = (r.m.exprs.find(expr)?, rebuilt);
    }
    store.encoded(r, below.1, span)
}

/// The table coordinate per vertex, `(a − lo)/(hi − lo)·(N − 1)/N + ½/N`,
/// interpolated (exact: interpolation commutes with an affine map).
pub(super) fn coordinates(
    r: &mut Rewriter,
    a_v: Handle<Expr>,
    lo: f64,
    hi: f64,
    span: Span,
) -> Option<Handle<Expr>> {
    let n = TEXELS as f64;
    let scale = (n - 1.0) / (n * (hi - lo));
    let c = affine(r, a_v, scale, 0.5 / n - lo * scale, span)?;
    r.node(Expr::Interpolate { value: c, to: Frequency::Fragment }, span)
}

/// `x·m + b` (scalar).
pub(super) fn affine(r: &mut Rewriter, x: Handle<Expr>, m: f64, b: f64, span: Span) -> Option<Handle<Expr>> {
    let mc = r.node(Expr::Constant(Constant::scalar(m)), span)?;
    let bc = r.node(Expr::Constant(Constant::scalar(b)), span)?;
    let scaled = r.node(Expr::Binary { op: BinaryOp::Mul, lhs: x, rhs: mc }, span)?;
    r.node(Expr::Binary { op: BinaryOp::Add, lhs: scaled, rhs: bc }, span)
}
