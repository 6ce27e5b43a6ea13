//! Rule `baked_table_2d`: a per-fragment scalar function of **two** scalar
//! arguments — dot products of interpolated vectors, or interpolated
//! scalars — that the combiners cannot compute, or whose intermediate
//! values leave their [−1, 1] (Kajiya-Kay's `(t·l · t·v + √(1 − (t·l)²)
//! √(1 − (t·v)²))ⁿ`), becomes a 2-D table of the whole function baked by
//! the compiler and looked up at the two arguments computed per vertex and
//! interpolated as texture coordinates: Heidrich and Seidel's technique of
//! BRDFs stored as textures indexed by dot products (Heidrich & Seidel 1999, Section 3).
//! A function of **one** such argument becomes a 1-D table the same way
//! (rule `baked_table`: the silhouette's `1 − (1 − V·N)⁶`). A function
//! that itself leaves [−1, 1] is tabulated clamped to it, without a bound.
//!
//! Applied top-down (the largest such part of a statement), as a choice of
//! its own ([`super::Choice::tables_2d`]), so that the function's inner
//! square roots are not tabulated one by one first. The arguments per
//! vertex are recorded as `per_vertex` (no bound); the table's error is
//! measured while baking: the largest difference between the function
//! and the 8-bit table read back with bilinear filtering, over a grid of
//! [`PROBES`]² argument pairs.

use std::collections::HashMap;

use super::table::{affine, baked_lookup, Domain, Storage};
use super::{per_vertex, Rewriter};
use crate::ir::eval::{self, Value};
use crate::ir::{BinaryOp, Expr, Frequency, Handle, Module, Ty};
use crate::parser::ast::TextureKind;
use crate::pipeline::ApproximationCost;
use crate::span::Span;

/// Texels a side: the compiler renders baked textures this size
/// (`pipeline::RENDERED_TEXTURE_SIZE`).
pub const TEXELS: usize = 256;
/// Argument pairs a side at which the table's error is measured.
pub const PROBES: usize = 160;

/// `value` with every largest per-fragment scalar part that is a function
/// of two arguments tabulated.
pub fn apply(r: &mut Rewriter, value: Handle<Expr>) -> Handle<Expr> {
    r.top_down(value, &mut |r, h| {
        if r.m.info(h).ty == Ty::Scalar {
            tabulate(r, h)
        } else {
            scaled_quotient(r, h)
        }
    })
}

/// `k·s / d` with `k` a per-object colour and `s`, `d` per-fragment
/// scalars (Seeliger's `kd·(N·L)/(N·L + N·V)`): `k · (s/d)`, the scalar
/// quotient tabulated.
fn scaled_quotient(r: &mut Rewriter, h: Handle<Expr>) -> Option<Handle<Expr>> {
    let Expr::Binary { op: BinaryOp::Div, lhs, rhs } = r.m.exprs[h] else { return None };
    let Expr::Binary { op: BinaryOp::Mul, lhs: a, rhs: b } = r.m.exprs[lhs] else { return None };
    let scalar = |x: Handle<Expr>| r.m.info(x).ty == Ty::Scalar;
    let per_object = |x: Handle<Expr>| !r.m.info(x).freq.is_sample();
    let (k, s) = match (per_object(a), per_object(b)) {
        (true, false) if scalar(b) => (a, b),
        (false, true) if scalar(a) => (b, a),
        _ => return None,
    };
    if !scalar(rhs) {
        return None;
    }
    let span = r.m.span(h);
    let quotient = r.node(Expr::Binary { op: BinaryOp::Div, lhs: s, rhs }, span)?;
    let table = tabulate(r, quotient)?;
    r.node(Expr::Binary { op: BinaryOp::Mul, lhs: k, rhs: table }, span)
}

/// The arguments `h` is a function of (dot products or interpolated
/// scalars, reached through arithmetic on them and constants), when there
/// are one or two and it needs what the combiners lack.
fn arguments(m: &Module, h: Handle<Expr>) -> Option<Vec<Handle<Expr>>> {
    let mut args: Vec<Handle<Expr>> = Vec::new();
    let mut needs_table = false;
    let mut stack = vec![h];
    let mut seen = std::collections::HashSet::new();
    while let Some(x) = stack.pop() {
        if !seen.insert(x) {
            continue;
        }
        let info = m.info(x);
        match &m.exprs[x] {
            Expr::Constant(_) => continue,
            _ if !info.freq.is_sample() => return None, // a uniform: not the compiler's to bake
            Expr::Binary { op: BinaryOp::Dot, .. } | Expr::Interpolate { .. } if info.ty == Ty::Scalar => {
                if !args.contains(&x) {
                    args.push(x);
                }
            }
            Expr::Unary { .. } | Expr::Binary { .. } | Expr::Math { .. } if info.ty == Ty::Scalar => {
                needs_table |=
                    super::no_combiner_op(m, x) || info.interval.lo < -1.0 || info.interval.hi > 1.0;
                stack.extend(m.exprs[x].operands());
            }
            _ => return None,
        }
    }
    (needs_table && matches!(args.len(), 1 | 2)).then_some(args)
}

/// The table lookup standing for `h`, or `None`.
fn tabulate(r: &mut Rewriter, h: Handle<Expr>) -> Option<Handle<Expr>> {
    let args = arguments(&r.m, h)?;
    let [a, b] = match args[..] {
        [a, b] => [a, b],
        [a] => return tabulate_1d(r, h, a),
        _ => return None,
    };
    let (a_v, b_v) = (per_vertex::at_vertex(&mut r.m, a)?, per_vertex::at_vertex(&mut r.m, b)?);
    let range = |x: Handle<Expr>| {
        let iv = r.m.info(x).interval;
        (iv.lo.is_finite() && iv.hi.is_finite() && iv.hi > iv.lo).then_some((iv.lo, iv.hi))
    };
    let (ra, rb) = (range(a_v)?, range(b_v)?);
    let function = Function::new(&r.m, h, [a, b]);
    let n = TEXELS as f64;
    let at = |(lo, hi): (f64, f64), i: usize| lo + (hi - lo) * i as f64 / (n - 1.0);
    let grid = |f: &dyn Fn(f64, f64) -> f64| -> Vec<f64> {
        (0..TEXELS * TEXELS).map(|k| f(at(ra, k % TEXELS), at(rb, k / TEXELS))).collect()
    };
    let raw = grid(&|x, y| function.at(x, y));
    // A function that leaves [−1, 1] (a quotient whose denominator crosses
    // 0: Seeliger's N·L/(N·L + N·V)) is tabulated clamped to the range the
    // combiners hold; what the clamp changes only a scene can say.
    let clamp = clamp_range(&raw);
    let f = |x: f64, y: f64| clamped(function.at(x, y), clamp);
    let samples = if clamp.is_some() { grid(&f) } else { raw };
    let store = storage(&samples)?;
    let bound = clamp.is_none().then(|| table_error(&samples, store, ra, rb, &f));
    let span = r.m.span(h);
    let texel_value = texel_function(r, h, &[a, b], &[ra, rb], clamp, store, span)?;
    let coords = coordinates(r, [a_v, b_v], [ra, rb], span)?;
    let decoded = baked_lookup(r, TextureKind::Tex2d, texel_value, coords, store, span)?;
    r.record(
        "per_vertex",
        span,
        Some(decoded),
        "the two arguments of the function tabulated here are computed per vertex and interpolated".into(),
        ApproximationCost::default(),
        None,
    );
    let clamped = clamp_note(clamp);
    r.record(
        "baked_table_2d",
        span,
        Some(decoded),
        format!(
            "a function of two per-fragment values is a {TEXELS}×{TEXELS} 8-bit table over [{:.3}, {:.3}]×[{:.3}, {:.3}] \
             baked by the compiler, looked up at the interpolated arguments (Heidrich & Seidel 1999, Section 3){clamped}",
            ra.0, ra.1, rb.0, rb.1
        ),
        ApproximationCost { texture_units: 1, passes: 0, general_combiners: 0, texels: (TEXELS * TEXELS) as u64 },
        bound,
    );
    Some(decoded)
}

/// The range to clamp a tabulated function to when its samples leave
/// [−1, 1] or are not finite: [−1, 1] where it goes negative (stored
/// range-compressed, read back by `expand`), else [0, 1]; `None` when the
/// function stays within [−1, 1].
fn clamp_range(samples: &[f64]) -> Option<(f64, f64)> {
    let finite = samples.iter().filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| (l.min(*v), h.max(*v)));
    let snap = super::table::SNAP;
    let inside = lo >= -1.0 - snap && hi <= 1.0 + snap && samples.iter().all(|v| v.is_finite());
    (!inside && lo < hi).then_some((if lo < 0.0 { -1.0 } else { 0.0 }, 1.0))
}

/// A function of one argument whose intermediate values leave [−1, 1]
/// (the silhouette's `1 − (1 − V·N)⁶`, Schlick's `(1 − N·V)⁵`): a 1-D
/// table of the whole function, clamped like the 2-D ones when it leaves
/// [−1, 1] itself, looked up at the argument computed per vertex.
fn tabulate_1d(r: &mut Rewriter, h: Handle<Expr>, a: Handle<Expr>) -> Option<Handle<Expr>> {
    let a_v = per_vertex::at_vertex(&mut r.m, a)?;
    let iv = r.m.info(a_v).interval;
    if !(iv.lo.is_finite() && iv.hi.is_finite() && iv.hi > iv.lo) {
        return None;
    }
    let (lo, hi) = (iv.lo, iv.hi);
    let function = Function::new(&r.m, h, [a, a]);
    let domain = Domain::Ends(lo, hi);
    let raw: Vec<f64> = (0..TEXELS).map(|i| function.at(domain.texel(i), 0.0)).collect();
    let clamp = clamp_range(&raw);
    let f = |x: f64| clamped(function.at(x, 0.0), clamp);
    let samples: Vec<f64> = (0..TEXELS).map(|i| f(domain.texel(i))).collect();
    let store = storage(&samples)?;
    let bound = clamp.is_none().then(|| super::table::table_error(&samples, store, domain, &f));
    let span = r.m.span(h);
    let texel_value = texel_function(r, h, &[a], &[(lo, hi)], clamp, store, span)?;
    let coords = super::table::coordinates(r, a_v, lo, hi, span)?;
    let decoded = baked_lookup(r, TextureKind::Tex1d, texel_value, coords, store, span)?;
    super::table::record_per_vertex_argument(r, decoded, span);
    let clamped = clamp_note(clamp);
    r.record(
        "baked_table",
        span,
        Some(decoded),
        format!(
            "a function of one per-fragment value whose intermediate values leave the combiners' [−1, 1] is a \
             {TEXELS}-texel 8-bit table over [{lo:.3}, {hi:.3}] baked by the compiler, looked up at the \
             interpolated argument{clamped}"
        ),
        ApproximationCost { texture_units: 1, passes: 0, general_combiners: 0, texels: TEXELS as u64 },
        bound,
    );
    Some(decoded)
}

/// `v` clamped as [`clamp_range`] asks (a NaN, 0/0 on the singular line,
/// as 0).
fn clamped(v: f64, clamp: Option<(f64, f64)>) -> f64 {
    match clamp {
        Some((lo, hi)) if v.is_nan() => 0.0f64.clamp(lo, hi),
        Some((lo, hi)) => v.clamp(lo, hi),
        None => v,
    }
}

/// The 8-bit storage of a table's samples; `None` when they are not
/// finite or all equal.
fn storage(samples: &[f64]) -> Option<Storage> {
    let (lo, hi) =
        samples.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), y| (l.min(*y), h.max(*y)));
    (lo.is_finite() && hi.is_finite() && hi > lo).then(|| Storage::for_range(lo, hi))
}

/// What the approximation's record says of a clamp.
fn clamp_note(clamp: Option<(f64, f64)>) -> String {
    clamp.map_or(String::new(), |(lo, hi)| {
        format!(
            ", its values clamped to [{lo:.0}, {hi:.0}] (the function leaves the combiners' range: no bound)"
        )
    })
}

/// `h` as a function of its two arguments: the nodes between them and
/// `h`, in the arena's (topological) order, each with where its operands
/// are among them, so a texel's evaluation indexes a vector instead of
/// hashing (it runs for every texel of the table and of the error probe).
struct Function<'m> {
    m: &'m Module,
    nodes: Vec<Handle<Expr>>,
    /// Per node, the positions of its operands in `nodes` (`None`: not
    /// evaluated, read as NaN).
    operands: Vec<Vec<Option<usize>>>,
    args: [Handle<Expr>; 2],
    /// The position of `h` in `nodes`.
    result: Option<usize>,
}

impl<'m> Function<'m> {
    fn new(m: &'m Module, h: Handle<Expr>, args: [Handle<Expr>; 2]) -> Function<'m> {
        // Only what depends on the arguments or is a constant is evaluated.
        let mut above: std::collections::HashSet<Handle<Expr>> = args.into_iter().collect();
        let mut nodes = Vec::new();
        for node in m.reachable(&[h]) {
            let e = &m.exprs[node];
            if args.contains(&node) || matches!(e, Expr::Constant(_)) {
                nodes.push(node);
            } else if e.operands().iter().any(|o| above.contains(o)) {
                above.insert(node);
                nodes.push(node);
            }
        }
        let mut position: HashMap<Handle<Expr>, usize> = HashMap::with_capacity(nodes.len());
        let mut operands = Vec::with_capacity(nodes.len());
        for (k, &node) in nodes.iter().enumerate() {
            operands.push(m.exprs[node].operands().iter().map(|o| position.get(o).copied()).collect());
            position.insert(node, k);
        }
        let result = position.get(&h).copied();
        Function { m, nodes, operands, args, result }
    }

    /// `h` at `a = x`, `b = y`.
    fn at(&self, x: f64, y: f64) -> f64 {
        let mut values: Vec<Value> = Vec::with_capacity(self.nodes.len());
        let mut ops: Vec<Value> = Vec::new();
        for (&node, operands) in self.nodes.iter().zip(&self.operands) {
            let e = &self.m.exprs[node];
            let v = if node == self.args[0] {
                [x; 4]
            } else if node == self.args[1] {
                [y; 4]
            } else if let Expr::Constant(c) = e {
                eval::value(c)
            } else {
                ops.clear();
                ops.extend(operands.iter().map(|o| o.map_or([f64::NAN; 4], |i| values[i])));
                eval::apply(self.m, e, self.m.info(node).ty, &ops)
            };
            values.push(v);
        }
        self.result.map_or(f64::NAN, |k| values[k][0])
    }
}

/// The largest |f − table| over a [`PROBES`]² grid of the domain, the table
/// rounded to 8 bits and read back bilinearly between texel centres.
fn table_error(
    samples: &[f64],
    store: Storage,
    ra: (f64, f64),
    rb: (f64, f64),
    f: &dyn Fn(f64, f64) -> f64,
) -> f64 {
    let q: Vec<f64> = samples.iter().map(|y| (store.encode(*y) * 255.0).round() / 255.0).collect();
    let last = (TEXELS - 1) as f64;
    let mut worst: f64 = 0.0;
    for j in 0..PROBES {
        for i in 0..PROBES {
            let (s, t) = (i as f64 / (PROBES - 1) as f64, j as f64 / (PROBES - 1) as f64);
            let (px, py) = (s * last, t * last);
            let (ix, iy) = ((px.floor() as usize).min(TEXELS - 2), (py.floor() as usize).min(TEXELS - 2));
            let (wx, wy) = (px - ix as f64, py - iy as f64);
            let texel = |x: usize, y: usize| q[y * TEXELS + x];
            let top = texel(ix, iy) * (1.0 - wx) + texel(ix + 1, iy) * wx;
            let bottom = texel(ix, iy + 1) * (1.0 - wx) + texel(ix + 1, iy + 1) * wx;
            let table = store.decode_value(top * (1.0 - wy) + bottom * wy);
            worst = worst.max((f(ra.0 + (ra.1 - ra.0) * s, rb.0 + (rb.1 - rb.0) * t) - table).abs());
        }
    }
    worst
}

/// The texel statement's value: `h` rebuilt on the texel coordinate's
/// arguments (texel centres at the domain's ends; a 1-D table's coordinate
/// is the first), clamped where asked, encoded to [0, 1].
fn texel_function(
    r: &mut Rewriter,
    h: Handle<Expr>,
    args: &[Handle<Expr>],
    ranges: &[(f64, f64)],
    clamp: Option<(f64, f64)>,
    store: Storage,
    span: Span,
) -> Option<Handle<Expr>> {
    let n = TEXELS as f64;
    let texel = r.node(Expr::TexelCoord, span)?;
    let mut map: HashMap<Handle<Expr>, Handle<Expr>> = HashMap::new();
    for (k, (&arg, &(a, b))) in args.iter().zip(ranges).enumerate() {
        let t = r.node(
            Expr::Swizzle { value: texel, pattern: [k as u8, 0, 0, 0], len: 1, ty: Ty::Scalar },
            span,
        )?;
        map.insert(arg, affine(r, t, (b - a) * n / (n - 1.0), a - (b - a) * 0.5 / (n - 1.0), span)?);
    }
    for node in r.m.reachable(&[h]) {
        if map.contains_key(&node) {
            continue;
        }
        let e = r.m.exprs[node].map_operands(|o| map.get(&o).copied().unwrap_or(o));
        let rebuilt = r.node(e, span)?;
        map.insert(node, rebuilt);
    }
    let mut value = map[&h];
    if let Some((lo, hi)) = clamp {
        let constant = |v: f64| Expr::Constant(crate::ir::Constant::new(Ty::Scalar, &[v]));
        let (lo, hi) = (r.node(constant(lo), span)?, r.node(constant(hi), span)?);
        value =
            r.node(Expr::Math { fun: crate::ir::MathFunction::Clamp, args: vec![value, lo, hi] }, span)?;
    }
    store.encoded(r, value, span)
}

/// The table coordinates per vertex, each `(a − lo)/(hi − lo)·(N − 1)/N +
/// ½/N`, interpolated together.
fn coordinates(
    r: &mut Rewriter,
    args: [Handle<Expr>; 2],
    ranges: [(f64, f64); 2],
    span: Span,
) -> Option<Handle<Expr>> {
    let n = TEXELS as f64;
    let mut c = Vec::with_capacity(2);
    for (a_v, (lo, hi)) in args.into_iter().zip(ranges) {
        let scale = (n - 1.0) / (n * (hi - lo));
        c.push(affine(r, a_v, scale, 0.5 / n - lo * scale, span)?);
    }
    let pair = r.node(Expr::Compose { ty: Ty::Vec2, components: c }, span)?;
    r.node(Expr::Interpolate { value: pair, to: Frequency::Fragment }, span)
}
