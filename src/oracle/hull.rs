//! The hull of a sample over the level-of-detail choices GL §3.8.8
//! leaves to an implementation, for any number of minified lookups.
//!
//! An implementation computes each mipmapped lookup's λ on its own,
//! anywhere in the interval §3.8.8 allows (`program.rs`, `minified`), so a
//! program reading n minified lookups may take any of their values'
//! combinations. Rendering every combination of every lookup's extremes
//! grows as 5ⁿ renders, and it is a hull only where the program is
//! monotone in each lookup (`x·(1 − x)` is largest between a lookup's
//! extremes). Here each sample is evaluated once more with intervals: a
//! lookup's value is, per channel, the least and greatest texel it takes
//! over its λ interval; every operation maps its operands' intervals to an
//! interval holding every value it takes on them (sums, products of
//! intervals at their corners, monotone functions at the ends, clamps,
//! dot products, comparisons decided or left open); a lookup whose
//! coordinates are themselves an interval (a dependent lookup reading a
//! minified lookup, Pipeline Grammar, eq. (8)) is bounded by the texels
//! its coordinates' box may reach on the levels its λ interval — from the
//! intervals of its coordinates' derivatives — selects. What cannot be
//! bounded so (a cube-map, 3-D or baked lookup at moving coordinates, a
//! framebuffer read at a moving position, a condition that moves and
//! keeps the destination) is [`Unsupported`], and the caller falls back
//! to rendering the combinations.
//!
//! The hull is sound, not exact: an operand read twice (`x − x`), or the
//! channels of one lookup, which share one λ, are taken as if apart.

use std::collections::HashMap;

use super::geometry::View;
use super::ops::{self, V};
use super::program::{uv, At, Evaluator, Memo, Tex};
use super::sampling::Image;
use super::Unsupported;
use crate::ir::{BinaryOp, Expr, FbChannel, Handle, MathFunction, Module, Ty, UnaryOp};
use crate::parser::ast::CombineMode;

/// Per channel, the least and the greatest value.
pub type R = (V, V);

/// The hulls of nodes already evaluated at one sample.
pub type Ranges = HashMap<Handle<Expr>, Option<R>>;

/// One interval.
type I = (f64, f64);

pub fn point(v: V) -> R {
    (v, v)
}

pub fn is_point(r: &R) -> bool {
    (0..4).all(|c| r.0[c].to_bits() == r.1[c].to_bits() || r.0[c] == r.1[c])
}

fn lane(r: &R, c: usize) -> I {
    (r.0[c], r.1[c])
}

fn lanes(f: impl Fn(usize) -> I) -> R {
    let v: [I; 4] = std::array::from_fn(f);
    (v.map(|i| i.0), v.map(|i| i.1))
}

fn splat(i: I) -> R {
    ([i.0; 4], [i.1; 4])
}

fn hull_of(values: impl IntoIterator<Item = f64>) -> I {
    values.into_iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)))
}

fn add(a: I, b: I) -> I {
    (a.0 + b.0, a.1 + b.1)
}

fn sub(a: I, b: I) -> I {
    (a.0 - b.1, a.1 - b.0)
}

fn mul(a: I, b: I) -> I {
    hull_of([a.0 * b.0, a.0 * b.1, a.1 * b.0, a.1 * b.1])
}

fn div(a: I, b: I) -> I {
    if b.0 > 0.0 || b.1 < 0.0 {
        mul(a, (1.0 / b.1, 1.0 / b.0))
    } else {
        (f64::NEG_INFINITY, f64::INFINITY)
    }
}

fn square(a: I) -> I {
    if a.0 >= 0.0 {
        (a.0 * a.0, a.1 * a.1)
    } else if a.1 <= 0.0 {
        (a.1 * a.1, a.0 * a.0)
    } else {
        (0.0, (a.0 * a.0).max(a.1 * a.1))
    }
}

fn increasing(a: I, f: impl Fn(f64) -> f64) -> I {
    (f(a.0), f(a.1))
}

fn constant(x: f64) -> I {
    (x, x)
}

/// The truth of a value (non-zero) as an interval of 0 and 1.
fn truth(a: I) -> I {
    if a.0 > 0.0 || a.1 < 0.0 {
        (1.0, 1.0)
    } else if a.0 == 0.0 && a.1 == 0.0 {
        (0.0, 0.0)
    } else {
        (0.0, 1.0)
    }
}

/// A comparison decided where the intervals say so, else open.
fn decided(surely: bool, surely_not: bool) -> I {
    match (surely, surely_not) {
        (true, _) => (1.0, 1.0),
        (false, true) => (0.0, 0.0),
        _ => (0.0, 1.0),
    }
}

fn dot(a: &R, b: &R, width: usize) -> I {
    (0..width.min(4)).fold(constant(0.0), |s, c| add(s, mul(lane(a, c), lane(b, c))))
}

/// The hull of a computing node from its operands' hulls (`ops::compute`'s
/// arithmetic, on intervals). `None` for `c ? a` where `c` is surely false.
fn compute(m: &Module, e: &Expr, ty: Ty, o: &[R]) -> Result<Option<R>, Unsupported> {
    if o.iter().all(is_point) {
        let values: Vec<V> = o.iter().map(|r| r.0).collect();
        return Ok(ops::compute(m, e, ty, &values).map(point));
    }
    // Operations that move each lane by lanes alone, never decreasing.
    let monotone = || -> Result<Option<R>, Unsupported> {
        let (lo, hi): (Vec<V>, Vec<V>) = o.iter().copied().unzip();
        Ok(ops::compute(m, e, ty, &lo).zip(ops::compute(m, e, ty, &hi)))
    };
    let r = match e {
        Expr::Unary { op: UnaryOp::Neg, .. } => lanes(|c| (-o[0].1[c], -o[0].0[c])),
        Expr::Unary { op: UnaryOp::Not, .. } => {
            let t = truth(lane(&o[0], 0));
            splat((1.0 - t.1, 1.0 - t.0))
        }
        Expr::Binary { op, lhs, .. } => binary(*op, &o[0], &o[1], m.info(*lhs).ty.width())?,
        Expr::Combine { mode: CombineMode::Replace, .. }
        | Expr::Swizzle { .. }
        | Expr::Compose { .. }
        | Expr::Convert { .. } => return monotone(),
        Expr::Combine { mode, .. } => texture_env(*mode, ty.width(), &o[0], &o[1]),
        Expr::Math { fun, args } => math(*fun, o, m.info(args[0]).ty.width())?,
        Expr::Select { reject, .. } => {
            let c = lane(&o[0], 0);
            match (truth(c), reject) {
                ((1.0, 1.0), _) => o[1],
                ((0.0, 0.0), Some(_)) => o[2],
                ((0.0, 0.0), None) => return Ok(None),
                (_, Some(_)) => lanes(|k| hull_of([o[1].0[k], o[1].1[k], o[2].0[k], o[2].1[k]])),
                (_, None) => {
                    return Err(Unsupported::new(
                        "a condition that moves with a level of detail and keeps the destination",
                    ))
                }
            }
        }
        _ => return Err(Unsupported::new("a node of this kind over a level-of-detail range")),
    };
    Ok(Some(r))
}

fn binary(op: BinaryOp, a: &R, b: &R, width: usize) -> Result<R, Unsupported> {
    use BinaryOp::*;
    let (x, y) = (lane(a, 0), lane(b, 0));
    Ok(match op {
        Dot => splat(dot(a, b, width)),
        Add => lanes(|c| add(lane(a, c), lane(b, c))),
        Sub => lanes(|c| sub(lane(a, c), lane(b, c))),
        Mul => lanes(|c| mul(lane(a, c), lane(b, c))),
        Div => lanes(|c| div(lane(a, c), lane(b, c))),
        // x^y = exp(y ln x) for x ≥ 0: y ln x is bilinear, so its extremes
        // (and exp's) lie at the corners.
        Pow if (0..4).all(|c| a.0[c] >= 0.0) => lanes(|c| {
            let (x, y) = (lane(a, c), lane(b, c));
            hull_of([x.0.powf(y.0), x.0.powf(y.1), x.1.powf(y.0), x.1.powf(y.1)])
        }),
        Pow => {
            return Err(Unsupported::new(
                "a power of a value that may be negative over a level-of-detail range",
            ))
        }
        Lt => splat(decided(x.1 < y.0, x.0 >= y.1)),
        Le => splat(decided(x.1 <= y.0, x.0 > y.1)),
        Gt => splat(decided(x.0 > y.1, x.1 <= y.0)),
        Ge => splat(decided(x.0 >= y.1, x.1 < y.0)),
        Eq => splat(decided(false, x.1 < y.0 || y.1 < x.0)),
        Ne => splat(decided(x.1 < y.0 || y.1 < x.0, false)),
        And => {
            let (p, q) = (truth(x), truth(y));
            splat((p.0.min(q.0), p.1.min(q.1)))
        }
        Or => {
            let (p, q) = (truth(x), truth(y));
            splat((p.0.max(q.0), p.1.max(q.1)))
        }
    })
}

fn math(fun: MathFunction, o: &[R], width: usize) -> Result<R, Unsupported> {
    use MathFunction::*;
    let a = &o[0];
    let each = |f: &dyn Fn(I) -> I| lanes(|c| f(lane(a, c)));
    let length = || {
        let s = (0..width.min(4)).fold(constant(0.0), |s, c| add(s, square(lane(a, c))));
        increasing(s, f64::sqrt)
    };
    Ok(match fun {
        Normalize => {
            let n = length();
            lanes(|c| if c >= width || n.0 <= 0.0 { (-1.0, 1.0) } else { div(lane(a, c), n) })
        }
        Length => splat(length()),
        Cross => {
            let (x, y) = (a, &o[1]);
            let term = |i: usize, j: usize| sub(mul(lane(x, i), lane(y, j)), mul(lane(x, j), lane(y, i)));
            let (c0, c1, c2) = (term(1, 2), term(2, 0), term(0, 1));
            lanes(|c| [c0, c1, c2, constant(0.0)][c])
        }
        Reflect => {
            let twice = mul(constant(2.0), dot(&o[1], a, 3));
            lanes(|c| sub(lane(a, c), mul(twice, lane(&o[1], c))))
        }
        Max => lanes(|c| (a.0[c].max(o[1].0[c]), a.1[c].max(o[1].1[c]))),
        Min => lanes(|c| (a.0[c].min(o[1].0[c]), a.1[c].min(o[1].1[c]))),
        Clamp => lanes(|c| (a.0[c].max(o[1].0[c]).min(o[2].0[c]), a.1[c].max(o[1].1[c]).min(o[2].1[c]))),
        Saturate => each(&|x| increasing(x, |v| v.clamp(0.0, 1.0))),
        Abs => each(&|x| {
            if x.0 >= 0.0 || x.1 <= 0.0 {
                hull_of([x.0.abs(), x.1.abs()])
            } else {
                (0.0, x.1.max(-x.0))
            }
        }),
        Sign => each(&|x| increasing(x, f64::signum)),
        Sqrt => each(&|x| increasing(x, f64::sqrt)),
        Rsqrt => each(&|x| (x.1.sqrt().recip(), x.0.sqrt().recip())),
        Exp => each(&|x| increasing(x, f64::exp)),
        Log => each(&|x| increasing(x, f64::ln)),
        Sin | Cos => each(&|_| (-1.0, 1.0)),
        Floor => each(&|x| increasing(x, f64::floor)),
        Fract => {
            each(&|x| if x.0.floor() == x.1.floor() { increasing(x, |v| v - v.floor()) } else { (0.0, 1.0) })
        }
        Expand => each(&|x| increasing(x, |v| 2.0 * v - 1.0)),
        HalfBias => each(&|x| increasing(x, |v| v - 0.5)),
        Compress => each(&|x| increasing(x, |v| 0.5 * (v + 1.0))),
        // step(edge, x) = x ≥ edge: rising in x, falling in the edge.
        Step => lanes(|c| {
            let (edge, x) = (lane(a, c), lane(&o[1], c));
            decided(x.0 >= edge.1, x.1 < edge.0)
        }),
        // a + (b − a)·t is multilinear in (a, b, t): extremes at corners.
        Mix => {
            lanes(|c| {
                let (x, y, t) = (lane(a, c), lane(&o[1], c), lane(&o[2], c));
                hull_of([x.0, x.1].into_iter().flat_map(|p| {
                    [y.0, y.1].into_iter().flat_map(move |q| [t.0, t.1].map(|s| p + (q - p) * s))
                }))
            })
        }
        Smoothstep if is_point(a) && is_point(&o[1]) => lanes(|c| {
            let (e0, e1, x) = (a.0[c], o[1].0[c], lane(&o[2], c));
            let f = |v: f64| {
                let t = ((v - e0) / (e1 - e0)).clamp(0.0, 1.0);
                t * t * (3.0 - 2.0 * t)
            };
            hull_of([f(x.0), f(x.1)])
        }),
        Smoothstep => return Err(Unsupported::new("a smoothstep whose edges move with a level of detail")),
    })
}

/// `t ⊕[mode] f` on intervals (`ops::texture_env`; `replace` is monotone
/// and taken apart). The texture's alpha in `decal` and `interpolate` is
/// taken as a variable of its own: a corner hull of a multilinear form.
fn texture_env(mode: CombineMode, width: usize, t: &R, f: &R) -> R {
    let alpha = width == 4;
    let at = if alpha { lane(t, 3) } else { constant(1.0) };
    let with_alpha = |r: R, a: I| if alpha { lanes(|c| if c == 3 { a } else { lane(&r, c) }) } else { r };
    let blend = |c: usize| {
        let (x, y) = (lane(t, c), lane(f, c));
        hull_of([x.0, x.1].into_iter().flat_map(|p| {
            [y.0, y.1].into_iter().flat_map(move |q| [at.0, at.1].map(|s| p * s + q * (1.0 - s)))
        }))
    };
    let dot3 = || {
        let n = if width == 1 { 1 } else { 3 };
        let half = constant(0.5);
        let s = (0..n).fold(constant(0.0), |s, c| add(s, mul(sub(lane(t, c), half), sub(lane(f, c), half))));
        mul(constant(4.0), s)
    };
    match mode {
        CombineMode::Modulate => lanes(|c| mul(lane(t, c), lane(f, c))),
        CombineMode::Add => lanes(|c| add(lane(t, c), lane(f, c))),
        CombineMode::AddSigned => lanes(|c| sub(add(lane(t, c), lane(f, c)), constant(0.5))),
        CombineMode::Subtract => lanes(|c| sub(lane(t, c), lane(f, c))),
        CombineMode::Decal => with_alpha(lanes(blend), lane(f, 3)),
        CombineMode::Interpolate => lanes(blend),
        CombineMode::Blend => with_alpha(
            lanes(|c| mul(lane(f, c), sub(constant(1.0), lane(t, c)))),
            mul(lane(t, 3), lane(f, 3)),
        ),
        CombineMode::Dot3Rgb => with_alpha(splat(dot3()), mul(lane(t, 3), lane(f, 3))),
        CombineMode::Dot3Rgba => splat(dot3()),
        // Monotone: taken apart in `compute`.
        CombineMode::Replace => lanes(|c| lane(t, c)),
    }
}

/// The box of texture coordinates a coordinate hull `c` of type `ty`
/// spans (`program::uv`: a position divided by its w, an interval).
fn uv_box(c: &R, ty: Ty) -> [I; 2] {
    if is_point(c) {
        let [u, v] = uv(c.0, ty);
        return [constant(u), constant(v)];
    }
    match ty {
        Ty::Scalar => [lane(c, 0), constant(0.5)],
        Ty::Position => {
            let w = lane(c, 3);
            let (x, y) = (div(lane(c, 0), w), div(lane(c, 1), w));
            [increasing(x, |x| 0.5 * x + 0.5), (0.5 - 0.5 * y.1, 0.5 - 0.5 * y.0)]
        }
        _ => [lane(c, 0), lane(c, 1)],
    }
}

impl Evaluator<'_> {
    /// The hull of node `h` at `at` over the level-of-detail choices
    /// (`value`'s twin on intervals); `values` holds the sample's nominal
    /// values, which a node that cannot move takes as its hull.
    pub(super) fn range(
        &self,
        h: Handle<Expr>,
        at: At,
        lod_depth: u8,
        ranges: &mut Ranges,
        values: &mut Memo,
    ) -> Result<Option<R>, Unsupported> {
        if let Some(r) = ranges.get(&h) {
            return Ok(*r);
        }
        let ty = self.m.info(h).ty;
        let e = &self.m.exprs[h];
        let nan = point([f64::NAN; 4]);
        let r = match e {
            Expr::Lookup { texture, coords } => {
                let c = self.range(*coords, at, lod_depth, ranges, values)?.unwrap_or(nan);
                let image = match &self.textures[*texture as usize] {
                    Tex::Flat(image) => Some(image),
                    _ => None,
                };
                Some(self.lookup_range(h, image, (*texture, *coords), c, at, lod_depth, values)?)
            }
            Expr::FatMember { texel, member } => {
                let Expr::Lookup { texture, coords } = self.m.exprs[*texel] else {
                    return Err(Unsupported::new("a fat member of a value other than a texture lookup"));
                };
                let c = self.range(coords, at, lod_depth, ranges, values)?.unwrap_or(nan);
                let image = match &self.textures[texture as usize] {
                    Tex::Fat(members) => members.get(usize::from(*member)),
                    _ => None,
                };
                Some(self.lookup_range(h, image, (texture, coords), c, at, lod_depth, values)?)
            }
            Expr::FramebufferRead { framebuffer, channel, position } => {
                let p = self.range(*position, at, lod_depth, ranges, values)?.unwrap_or(nan);
                if !is_point(&p) {
                    return Err(Unsupported::new(
                        "a framebuffer read at a position that moves with a level of detail",
                    ));
                }
                match self.read_range(*framebuffer as usize, *channel, *position, p.0, at) {
                    Some(r) => Some(r),
                    None => self.value(h, at, lod_depth, values)?.map(point),
                }
            }
            Expr::Project { value, .. } | Expr::Depth(value) => {
                let v = self.range(*value, at, lod_depth, ranges, values)?.unwrap_or(nan);
                if !is_point(&v) {
                    return Err(Unsupported::new(
                        "a projection of a value that moves with a level of detail",
                    ));
                }
                self.value(h, at, lod_depth, values)?.map(point)
            }
            Expr::Constant(_)
            | Expr::Interpolate { .. }
            | Expr::Pixel { .. }
            | Expr::TexelCoord
            | Expr::Uniform(_)
            | Expr::VertexPosition(_)
            | Expr::TexCoord { .. }
            | Expr::Vector { .. }
            | Expr::Bundle(_) => self.value(h, at, lod_depth, values)?.map(point),
            _ => {
                let mut operands = Vec::new();
                for o in e.operands() {
                    match self.range(o, at, lod_depth, ranges, values)? {
                        Some(r) => operands.push(r),
                        None => {
                            ranges.insert(h, None);
                            return Ok(None);
                        }
                    }
                }
                let r = compute(self.m, e, ty, &operands)?;
                match e {
                    Expr::Combine { .. } if self.clamp_texture_env => {
                        r.map(|(lo, hi)| (lo.map(|x| x.clamp(0.0, 1.0)), hi.map(|x| x.clamp(0.0, 1.0))))
                    }
                    _ => r,
                }
            }
        };
        let r = r.map(|(lo, hi)| (ops::shape(ty, lo), ops::shape(ty, hi)));
        ranges.insert(h, r);
        Ok(r)
    }

    /// The hull a colour or alpha read of framebuffer `fb` at `p` (the
    /// value of `position`) holds there (`Store::low`, `Store::high`);
    /// `None` for another channel or outside the framebuffer.
    fn read_range(&self, fb: usize, channel: FbChannel, position: Handle<Expr>, p: V, at: At) -> Option<R> {
        let light = self.through_light(position);
        let own = match at {
            At::Fragment(f) => f.view != View::Texels && (f.view == View::Light) == light,
            _ => !light,
        };
        let i = self.read_pixel(p, at, own)?;
        let fb = &self.framebuffers[fb];
        match channel {
            FbChannel::Color => Some((fb.low[i], fb.high[i])),
            FbChannel::Alpha => Some(([fb.low[i][3]; 4], [fb.high[i][3]; 4])),
            _ => None,
        }
    }

    /// The hull of lookup `h` of a flat image (`image`; `None` for any other
    /// texture) at coordinates of hull `c`.
    #[allow(clippy::too_many_arguments)]
    fn lookup_range(
        &self,
        h: Handle<Expr>,
        image: Option<&Image>,
        key: super::program::LookupKey,
        c: R,
        at: At,
        lod_depth: u8,
        values: &mut Memo,
    ) -> Result<R, Unsupported> {
        let mut nominal = || -> Result<V, Unsupported> {
            Ok(self.value(h, at, lod_depth, values)?.unwrap_or([f64::NAN; 4]))
        };
        let cty = self.m.info(key.1).ty;
        match (image, at) {
            (Some(image), At::Fragment(f)) if lod_depth < 2 && image.levels.len() > 1 => {
                let nominal = nominal()?;
                let r = self.minified_range(image, key, cty, &c, &f, lod_depth)?;
                Ok(lanes(|k| hull_of([r.0[k], r.1[k], nominal[k]])))
            }
            _ if is_point(&c) => Ok(point(nominal()?)),
            (Some(image), _) => {
                let [u, v] = uv_box(&c, cty);
                Ok(image.footprint_hull(u, v, 0.0, 0.0))
            }
            (None, _) => Err(Unsupported::new(
                "a cube-map, 3-D, environment or baked lookup at coordinates that move with a level of detail",
            )),
        }
    }

    /// A minified lookup's hull at fragment `f` (`minified`'s interval of
    /// λ, from the intervals of the coordinates' differences where they
    /// move): its texel's extremes over that interval where the
    /// coordinates are one point, else the texels of their box's footprint
    /// on the levels the interval selects.
    fn minified_range(
        &self,
        image: &Image,
        key: super::program::LookupKey,
        cty: Ty,
        c: &R,
        f: &super::geometry::Fragment,
        lod_depth: u8,
    ) -> Result<R, Unsupported> {
        let here = uv_box(c, cty);
        let at_offset = |dx: f64, dy: f64| -> Result<[I; 2], Unsupported> {
            if dx == 0.0 && dy == 0.0 {
                return Ok(here);
            }
            let g = At::Fragment(self.shifted(f, dx, dy));
            let r = self.range(key.1, g, lod_depth + 1, &mut Ranges::new(), &mut Memo::new())?;
            Ok(uv_box(&r.unwrap_or(point([f64::NAN; 4])), cty))
        };
        let d = |a: [I; 2], b: [I; 2]| [sub(b[0], a[0]), sub(b[1], a[1])];
        let (right, below) = (at_offset(1.0, 0.0)?, at_offset(0.0, 1.0)?);
        let (qx, qy) = (-f64::from(f.pixel.0 & 1), -f64::from(f.pixel.1 & 1));
        let q = [
            at_offset(qx, qy)?,
            at_offset(qx + 1.0, qy)?,
            at_offset(qx, qy + 1.0)?,
            at_offset(qx + 1.0, qy + 1.0)?,
        ];
        let row = if qy == 0.0 { (q[0], q[1]) } else { (q[2], q[3]) };
        let column = if qx == 0.0 { (q[0], q[2]) } else { (q[1], q[3]) };
        let sets = [
            (d(here, right), d(here, below)),
            (d(q[0], q[1]), d(q[0], q[2])),
            (d(row.0, row.1), d(column.0, column.1)),
        ];
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (dx, dy) in sets {
            let (a, b) = image.lod_bounds_within(dx, dy);
            (lo, hi) = (lo.min(a), hi.max(b));
        }
        let slack = super::program::LOG2_SLACK;
        let lo = if lo.is_nan() { 0.0 } else { (lo - slack).max(0.0) };
        let hi = if hi.is_nan() { f64::INFINITY } else { hi + slack };
        let hi = hi.min(image.levels.len() as f64);
        if here[0].0 == here[0].1 && here[1].0 == here[1].1 {
            let (u, v) = (here[0].0, here[1].0);
            let mut at = vec![image.sample(u, v, lo)];
            at.extend(image.lod_extremes(u, v, lo, hi));
            return Ok(lanes(|k| hull_of(at.iter().map(|t| t[k]))));
        }
        Ok(image.footprint_hull(here[0], here[1], lo, hi))
    }
}
