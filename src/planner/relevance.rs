//! Light relevance for compiled plans (Adaptive Sample Shading, Section
//! 2.2): per object and per light, a bound on everything a light's terms
//! can add to a pixel of the object; a light whose bound is below the
//! threshold is culled — its pass is not drawn for that object, and when no
//! object needs it, the pass (with the textures only it used) goes.
//!
//! The bound is an abstract evaluation of the light's terms over the
//! object (sound: every value a fragment can take lies in it):
//!
//! - each interpolated value `δ v` lies in the convex hull of `v` at the
//!   object's vertices (perspective-correct interpolation is a convex
//!   combination), so it is bounded by the componentwise extremes of `v`
//!   evaluated exactly at every vertex — the light's `intensity(i)`
//!   (colour · attenuation · spot factor) included: the **volume of
//!   influence** (Section 2.2.3: distance attenuation, spot cut-off cone)
//!   comes in through it;
//! - a unit direction interpolated between vertex values lies in the
//!   **bounding cone** of those values (Section 2.2.2: axis the average,
//!   half-angle the largest angle; [`crate::scene::relevance::Cone`]), its
//!   length in [cos θ, 1]; `normalize` makes it unit again; the dot product
//!   of two cones is at most cos(max(0, ∠(axes) − θ₁ − θ₂)) — the cone of
//!   normals against the cone of light directions ("the light is behind the
//!   object") and, for N·H or M·L, the cone of half or reflected vectors
//!   against it;
//! - a power x^n with x ≤ cos α is at most cos^n α: the **shininess
//!   cut-off** of Section 2.2.3 (cos α = threshold^(1/n)) — the cone of
//!   highlights widened by a material-dependent angle — falls out of the
//!   bound of `x^n` rather than being a separate test;
//! - a lookup in a normalization cube map (`normalize_cube(…)`) keeps the
//!   cone of its coordinates, widened by a texel's angle (the stored table
//!   is filtered and 8-bit); other textures give their format's range;
//!   framebuffers their channel's;
//! - everything else is interval arithmetic, componentwise.
//!
//! Culling drops, per object, the lights with the smallest bounds while the
//! sum of the dropped bounds stays at most the threshold: the culled image
//! differs from the unculled one by at most the threshold in every channel
//! (in exact arithmetic; clamping only shrinks a change).

use std::collections::BTreeMap;

use glam::Vec3;

use crate::ir::{self, BinaryOp, Expr, FbChannel, Handle, MathFunction, Module, Ty, UnaryOp};
use crate::parser::ast::{CombineMode, VectorKind};
use crate::scene::bind::{self, BoundObject, TextureDecl, TextureSource};
use crate::scene::relevance::{shininess_cutoff, Cone};

/// Componentwise bounds of a value (scalars splatted, as `ir::eval` keeps
/// them), and for a direction its cone and length range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bound {
    /// The least value of each component.
    pub lo: [f64; 4],
    /// The greatest value of each component.
    pub hi: [f64; 4],
    /// For a direction: the cone its unit vector lies in, and its least and
    /// greatest length (negative for a range-compressed cone-map lookup).
    pub cone: Option<(Cone, f64, f64)>,
}

impl Bound {
    /// No bound: every component anywhere.
    pub const ALL: Bound = Bound { lo: [f64::NEG_INFINITY; 4], hi: [f64::INFINITY; 4], cone: None };

    fn splat(lo: f64, hi: f64) -> Bound {
        Bound { lo: [lo; 4], hi: [hi; 4], cone: None }.clean()
    }

    fn point(v: [f64; 4]) -> Bound {
        Bound { lo: v, hi: v, cone: None }.clean()
    }

    /// NaN bounds widen to everything.
    fn clean(mut self) -> Bound {
        for i in 0..4 {
            if self.lo[i].is_nan() || self.hi[i].is_nan() {
                self.lo[i] = f64::NEG_INFINITY;
                self.hi[i] = f64::INFINITY;
            }
        }
        self
    }

    /// The largest magnitude over the first `width` components.
    pub fn magnitude(&self, width: usize) -> f64 {
        (0..width.clamp(1, 4)).map(|i| self.lo[i].abs().max(self.hi[i].abs())).fold(0.0, f64::max)
    }

    fn lanes(a: &Bound, b: &Bound, f: impl Fn(f64, f64, f64, f64) -> (f64, f64)) -> Bound {
        let mut out = Bound::ALL;
        for i in 0..4 {
            let (lo, hi) = f(a.lo[i], a.hi[i], b.lo[i], b.hi[i]);
            out.lo[i] = lo;
            out.hi[i] = hi;
        }
        out.clean()
    }

    fn map(&self, f: impl Fn(f64, f64) -> (f64, f64)) -> Bound {
        let mut out = Bound::ALL;
        for i in 0..4 {
            let (lo, hi) = f(self.lo[i], self.hi[i]);
            out.lo[i] = lo;
            out.hi[i] = hi;
        }
        out.clean()
    }

    /// A direction in `cone` with length in [l0, l1]: components bounded
    /// by the cone's angle to each axis.
    fn of_cone(cone: Cone, l0: f64, l1: f64) -> Bound {
        let mut out = Bound::splat(-l1, l1);
        if cone.half_angle < std::f32::consts::PI {
            for (k, e) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
                let a = crate::scene::relevance::angle(cone.axis, e);
                let hi = (a - cone.half_angle).max(0.0).cos() as f64 + 1e-6;
                let lo = (a + cone.half_angle).min(std::f32::consts::PI).cos() as f64 - 1e-6;
                out.hi[k] = if hi >= 0.0 { hi * l1 } else { hi * l0 };
                out.lo[k] = if lo >= 0.0 { lo * l0 } else { lo * l1 };
            }
        }
        out.lo[3] = 0.0;
        out.hi[3] = 0.0;
        out.cone = Some((cone, l0, l1));
        out
    }
}

fn mul_iv(a0: f64, a1: f64, b0: f64, b1: f64) -> (f64, f64) {
    let c = [a0 * b0, a0 * b1, a1 * b0, a1 * b1];
    if c.iter().any(|x| x.is_nan()) {
        return (f64::NEG_INFINITY, f64::INFINITY);
    }
    (c.iter().copied().fold(f64::INFINITY, f64::min), c.iter().copied().fold(f64::NEG_INFINITY, f64::max))
}

/// Why a bound came out small: the criteria of Section 2.2 met on the way.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Findings {
    /// The light's intensity at every vertex of the object is below this.
    pub max_intensity: Option<f64>,
    /// max(0, x) with x ≤ 0 everywhere: the light is behind the surface.
    pub faces_away: bool,
    /// A power x^n whose base is at most `base` (< 1): the shininess cut-off.
    pub highlight: Option<(f64, f64)>,
}

/// The abstract evaluator of one object (module docs).
pub struct Bounder<'a, 's> {
    /// The program, lights expanded.
    pub module: &'a Module,
    /// The object whose vertices bound the per-vertex values.
    pub object: &'a BoundObject<'s>,
    /// The scene's uniforms, by id (`None`: unset, unbounded).
    pub uniforms: &'a [Option<[f64; 4]>],
    /// The declared textures: a normalization cube map's lookup keeps the
    /// cone of the direction it is looked up at.
    pub decls: &'a [TextureDecl],
    /// What the evaluation found that made a bound small (the criteria of
    /// Adaptive Sample Shading, Section 2.2), for the report.
    pub findings: Findings,
    memo: BTreeMap<usize, Bound>,
}

impl<'a, 's> Bounder<'a, 's> {
    /// An evaluator of `module` over `object`, with the scene's `uniforms` and the textures
    /// `decls` declares.
    pub fn new(
        module: &'a Module,
        object: &'a BoundObject<'s>,
        uniforms: &'a [Option<[f64; 4]>],
        decls: &'a [TextureDecl],
    ) -> Bounder<'a, 's> {
        Bounder { module, object, uniforms, decls, findings: Findings::default(), memo: BTreeMap::new() }
    }

    /// The bound of `h` over every fragment of the object.
    pub fn bound(&mut self, h: Handle<Expr>) -> Bound {
        let m = self.module;
        for n in m.reachable(&[h]) {
            if self.memo.contains_key(&n.index()) {
                continue;
            }
            let b = self.node(n);
            self.memo.insert(n.index(), b);
        }
        self.memo[&h.index()]
    }

    fn get(&self, h: Handle<Expr>) -> Bound {
        self.memo.get(&h.index()).copied().unwrap_or(Bound::ALL)
    }

    fn node(&mut self, h: Handle<Expr>) -> Bound {
        let m = self.module;
        let info = m.info(h);
        match &m.exprs[h] {
            Expr::Constant(c) => Bound::point(ir::eval::value(c)),
            Expr::Uniform(id) => self.uniform(*id),
            Expr::Interpolate { value, .. } => self.vertex_hull(*value),
            Expr::Lookup { texture, coords } => self.lookup(*texture, *coords, info.interval),
            Expr::FramebufferRead {
                channel: FbChannel::Color | FbChannel::Alpha | FbChannel::Depth, ..
            }
            | Expr::Depth(_) => Bound::splat(info.interval.lo, info.interval.hi),
            Expr::Unary { op: UnaryOp::Neg, value } => self.get(*value).map(|lo, hi| (-hi, -lo)),
            Expr::Unary { op: UnaryOp::Not, .. } => Bound::splat(0.0, 1.0),
            Expr::Binary { op, lhs, rhs } => self.binary(*op, *lhs, *rhs),
            Expr::Combine { mode, lhs, rhs } => self.combine(*mode, *lhs, *rhs),
            Expr::Math { fun, args } => self.math(*fun, args),
            Expr::Swizzle { value, pattern, len, .. } => self.swizzle(*value, pattern, *len),
            Expr::Compose { components, .. } => self.compose(components),
            Expr::Convert { value, to } => self.convert(*value, *to),
            Expr::Select { accept, reject, .. } => {
                let a = self.get(*accept);
                match reject {
                    Some(r) => Bound::lanes(&a, &self.get(*r), |a0, a1, b0, b1| (a0.min(b0), a1.max(b1))),
                    None => a,
                }
            }
            _ => Bound::ALL,
        }
    }

    /// A uniform: the scene's value, else its default; unknown, anything.
    fn uniform(&self, id: ir::UniformId) -> Bound {
        let m = self.module;
        let v = self
            .uniforms
            .get(id as usize)
            .copied()
            .flatten()
            .or_else(|| m.uniforms[id as usize].default.as_ref().map(ir::eval::value));
        v.map_or(Bound::ALL, Bound::point)
    }

    /// Interval arithmetic of a binary operation; a highlight `x^n` with
    /// x < 1 and n > 1 is noted (its peak is where culling must be careful).
    fn binary(&mut self, op: BinaryOp, lhs: Handle<Expr>, rhs: Handle<Expr>) -> Bound {
        let m = self.module;
        let (a, b) = (self.get(lhs), self.get(rhs));
        match op {
            BinaryOp::Add => Bound::lanes(&a, &b, |a0, a1, b0, b1| (a0 + b0, a1 + b1)),
            BinaryOp::Sub => Bound::lanes(&a, &b, |a0, a1, b0, b1| (a0 - b1, a1 - b0)),
            BinaryOp::Mul => Bound::lanes(&a, &b, mul_iv),
            BinaryOp::Div => Bound::lanes(&a, &b, |a0, a1, b0, b1| {
                if b0 > 0.0 || b1 < 0.0 {
                    mul_iv(a0, a1, 1.0 / b1, 1.0 / b0)
                } else {
                    (f64::NEG_INFINITY, f64::INFINITY)
                }
            }),
            BinaryOp::Dot => self.dot(&a, &b, m.info(lhs).ty.width()),
            BinaryOp::Pow => {
                let r = Bound::lanes(&a, &b, |a0, a1, b0, b1| {
                    if a0 < 0.0 || b0.is_nan() || b0 <= 0.0 {
                        return (f64::NEG_INFINITY, f64::INFINITY);
                    }
                    let c = [a0.powf(b0), a0.powf(b1), a1.powf(b0), a1.powf(b1)];
                    (
                        c.iter().copied().fold(f64::INFINITY, f64::min),
                        c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                    )
                });
                if a.lo[0] >= 0.0 && a.hi[0] < 1.0 && b.lo[0] > 1.0 {
                    self.findings.highlight = Some((a.hi[0], b.lo[0]));
                }
                r
            }
            _ => Bound::splat(0.0, 1.0),
        }
    }

    /// Interval arithmetic of a texture-environment ⊕ (Pipeline Grammar, eq. (3)).
    fn combine(&mut self, mode: CombineMode, lhs: Handle<Expr>, rhs: Handle<Expr>) -> Bound {
        let (t, f) = (self.get(lhs), self.get(rhs));
        match mode {
            CombineMode::Modulate => Bound::lanes(&t, &f, mul_iv),
            CombineMode::Add => Bound::lanes(&t, &f, |a0, a1, b0, b1| (a0 + b0, a1 + b1)),
            CombineMode::AddSigned => Bound::lanes(&t, &f, |a0, a1, b0, b1| (a0 + b0 - 0.5, a1 + b1 - 0.5)),
            CombineMode::Subtract => Bound::lanes(&t, &f, |a0, a1, b0, b1| (a0 - b1, a1 - b0)),
            CombineMode::Blend => {
                // rgb = Cf·(1 − Ct) (Cc = 0), alpha = Af·At: the hull of both.
                let rgb = Bound::lanes(&t, &f, |t0, t1, f0, f1| mul_iv(f0, f1, 1.0 - t1, 1.0 - t0));
                let alpha = Bound::lanes(&t, &f, mul_iv);
                Bound::lanes(&rgb, &alpha, |a0, a1, b0, b1| (a0.min(b0), a1.max(b1)))
            }
            CombineMode::Decal | CombineMode::Interpolate | CombineMode::Replace
                if t.lo[3] >= 0.0 && t.hi[3] <= 1.0 =>
            {
                Bound::lanes(&t, &f, |a0, a1, b0, b1| (a0.min(b0), a1.max(b1)))
            }
            CombineMode::Dot3Rgb | CombineMode::Dot3Rgba => {
                let mut lo = 0.0;
                let mut hi = 0.0;
                for i in 0..3 {
                    let (l, u) = mul_iv(t.lo[i] - 0.5, t.hi[i] - 0.5, f.lo[i] - 0.5, f.hi[i] - 0.5);
                    lo += 4.0 * l;
                    hi += 4.0 * u;
                }
                let all = Bound::lanes(&t, &f, mul_iv);
                Bound { lo: [lo, lo, lo, lo.min(all.lo[3])], hi: [hi, hi, hi, hi.max(all.hi[3])], cone: None }
                    .clean()
            }
            _ => Bound::ALL,
        }
    }

    fn swizzle(&mut self, value: Handle<Expr>, pattern: &[u8; 4], len: u8) -> Bound {
        let v = self.get(value);
        let mut out = Bound::ALL;
        for k in 0..4 {
            let src = pattern[k.min(len as usize - 1).min(3)] as usize;
            out.lo[k] = v.lo[src.min(3)];
            out.hi[k] = v.hi[src.min(3)];
        }
        if len == 1 {
            out = Bound::splat(out.lo[0], out.hi[0]);
        }
        out
    }

    fn compose(&mut self, components: &[Handle<Expr>]) -> Bound {
        let m = self.module;
        let mut out = Bound::splat(0.0, 0.0);
        let mut k = 0;
        for c in components {
            let b = self.get(*c);
            for j in 0..m.info(*c).ty.width() {
                if k < 4 {
                    out.lo[k] = b.lo[j.min(3)];
                    out.hi[k] = b.hi[j.min(3)];
                }
                k += 1;
            }
        }
        out
    }

    fn convert(&mut self, value: Handle<Expr>, to: Ty) -> Bound {
        let m = self.module;
        let v = self.get(value);
        let from = m.info(value).ty;
        if from == Ty::Scalar {
            Bound::splat(v.lo[0], v.hi[0])
        } else if from == Ty::Rgb && to == Ty::Rgba {
            Bound { lo: [v.lo[0], v.lo[1], v.lo[2], 1.0], hi: [v.hi[0], v.hi[1], v.hi[2], 1.0], cone: None }
        } else {
            Bound { cone: None, ..v }
        }
    }

    /// `δ v`: the hull of `v` at every vertex, and the cone of a unit direction.
    fn vertex_hull(&mut self, value: Handle<Expr>) -> Bound {
        let m = self.module;
        let mut ev = ir::eval::Evaluator::new(m, &[value], crate::numerics::Precision::Exact);
        let mut lo = [f64::INFINITY; 4];
        let mut hi = [f64::NEG_INFINITY; 4];
        let unit = bind::is_unit_direction(m, value) && m.info(value).ty == Ty::Vec3;
        let mut dirs = Vec::new();
        let intensity = m.reachable(&[value]).into_iter().any(|n| matches!(m.exprs[n], Expr::Vector { vector, .. } if m.vectors[vector as usize].kind == Some(VectorKind::Intensity)));
        for v in 0..self.object.n_vertices() {
            let mut env =
                bind::VertexEnv { object: self.object, module: m, vertex: v, uniforms: self.uniforms };
            let r = ev.eval(&mut env);
            let x = r.values[0];
            for i in 0..4 {
                lo[i] = lo[i].min(x[i]);
                hi[i] = hi[i].max(x[i]);
            }
            if unit {
                dirs.push(Vec3::new(x[0] as f32, x[1] as f32, x[2] as f32));
            }
        }
        if self.object.n_vertices() == 0 {
            return Bound::ALL;
        }
        let hull = Bound { lo, hi, cone: None }.clean();
        if intensity && matches!(m.exprs[value], Expr::Vector { .. }) {
            let peak = hull.magnitude(3);
            self.findings.max_intensity =
                Some(self.findings.max_intensity.map_or(peak, |p: f64| p.max(peak)));
        }
        if unit {
            let cone = Cone::of_directions(dirs.iter().copied());
            if cone.half_angle < std::f32::consts::FRAC_PI_2 {
                let l0 = (cone.half_angle.cos() as f64 - 1e-6).max(0.0);
                let c = Bound::of_cone(cone, l0, 1.0);
                return Bound::lanes(&hull, &c, |a0, a1, b0, b1| (a0.max(b0), a1.min(b1))).with_cone(c.cone);
            }
        }
        hull
    }

    fn lookup(&mut self, texture: u32, coords: Handle<Expr>, interval: ir::Interval) -> Bound {
        let m = self.module;
        let name = &m.textures[texture as usize].name;
        if let Some(TextureSource::NormalizeCube { size, .. }) =
            self.decls.iter().find(|d| &d.name == name).map(|d| &d.source)
        {
            if let Some((cone, _, _)) = self.get(coords).cone {
                // A filtered texel blends directions up to a texel's angle apart.
                let slack = 2.5 / (*size).max(1) as f32 + 0.01;
                let c = Bound::of_cone(cone.widened(slack), 1.0 - 0.01, 1.0 + 0.01);
                let signed = interval.lo < 0.0;
                return if signed {
                    c
                } else {
                    // Range-compressed: (d + 1)/2, the cone kept for `expand`.
                    let mut b = c.map(|lo, hi| ((lo + 1.0) / 2.0, (hi + 1.0) / 2.0));
                    b.lo[3] = 0.0;
                    b.hi[3] = 1.0;
                    b.cone = c.cone.map(|(c, l0, l1)| (c, -l0, -l1));
                    b
                };
            }
        }
        Bound::splat(interval.lo, interval.hi)
    }

    fn dot(&mut self, a: &Bound, b: &Bound, width: usize) -> Bound {
        if let (Some((ca, a0, a1)), Some((cb, b0, b1))) = (a.cone, b.cone) {
            if a0 >= 0.0 && b0 >= 0.0 {
                let (cmax, cmin) = (ca.max_cos(cb) as f64 + 1e-6, ca.min_cos(cb) as f64 - 1e-6);
                let hi = if cmax >= 0.0 { a1 * b1 * cmax } else { a0 * b0 * cmax };
                let lo = if cmin >= 0.0 { a0 * b0 * cmin } else { a1 * b1 * cmin };
                return Bound::splat(lo, hi);
            }
        }
        let (mut lo, mut hi) = (0.0, 0.0);
        for i in 0..width.clamp(1, 4) {
            let (l, u) = mul_iv(a.lo[i], a.hi[i], b.lo[i], b.hi[i]);
            lo += l;
            hi += u;
        }
        Bound::splat(lo, hi)
    }

    fn math(&mut self, fun: MathFunction, args: &[Handle<Expr>]) -> Bound {
        use MathFunction::*;
        let a = args.first().map_or(Bound::ALL, |h| self.get(*h));
        let b = args.get(1).map_or(Bound::ALL, |h| self.get(*h));
        match fun {
            Max => {
                let r = Bound::lanes(&a, &b, |a0, a1, b0, b1| (a0.max(b0), a1.max(b1)));
                if (a.hi[0] <= 0.0 && b.lo[0] >= 0.0 && b.hi[0] == 0.0)
                    || (b.hi[0] <= 0.0 && a.lo[0] >= 0.0 && a.hi[0] == 0.0)
                {
                    self.findings.faces_away = true;
                }
                r
            }
            Min => Bound::lanes(&a, &b, |a0, a1, b0, b1| (a0.min(b0), a1.min(b1))),
            Clamp => {
                let c = args.get(2).map_or(Bound::ALL, |h| self.get(*h));
                let lo_clamped = Bound::lanes(&a, &b, |a0, a1, b0, b1| (a0.max(b0), a1.max(b1)));
                Bound::lanes(&lo_clamped, &c, |a0, a1, c0, c1| (a0.min(c0), a1.min(c1)))
            }
            Mix => {
                let t = args.get(2).map_or(Bound::ALL, |h| self.get(*h));
                if t.lo[0] >= 0.0 && t.hi[0] <= 1.0 {
                    Bound::lanes(&a, &b, |a0, a1, b0, b1| (a0.min(b0), a1.max(b1)))
                } else {
                    Bound::ALL
                }
            }
            Reflect | Cross => match (a.cone, b.cone) {
                (Some((_, a0, a1)), Some((_, b0, b1))) if a0 >= 0.0 && b0 >= 0.0 => {
                    // |reflect(i, n)| ≤ |i|(1 + 2|n|²), |i × n| ≤ |i||n|.
                    let l = a1 * (1.0 + 2.0 * b1 * b1);
                    Bound::splat(-l, l)
                }
                _ => Bound::ALL,
            },
            _ => of_first_argument(fun, a),
        }
    }
}

/// The bound of `fun` from its first argument's bound `a` alone, by
/// interval arithmetic over monotone pieces: every function whose range
/// does not need its other arguments; `ALL` for those that do, which
/// [`Bounder::math`] bounds itself.
fn of_first_argument(fun: MathFunction, a: Bound) -> Bound {
    use MathFunction::*;
    let monotone = |f: fn(f64) -> f64| a.map(|lo, hi| (f(lo), f(hi)));
    match fun {
        Normalize => match a.cone {
            Some((c, l0, _)) if l0 > 0.0 => Bound::of_cone(c, 1.0, 1.0),
            _ => Bound::splat(-1.0, 1.0),
        },
        Length => match a.cone {
            Some((_, l0, l1)) if l0 >= 0.0 => Bound::splat(l0, l1),
            _ => Bound::splat(0.0, f64::INFINITY),
        },
        Saturate => a.map(|lo, hi| (lo.clamp(0.0, 1.0), hi.clamp(0.0, 1.0))),
        Abs => a.map(|lo, hi| {
            if lo >= 0.0 {
                (lo, hi)
            } else if hi <= 0.0 {
                (-hi, -lo)
            } else {
                (0.0, hi.max(-lo))
            }
        }),
        Sign => Bound::splat(-1.0, 1.0),
        Sqrt => a.map(
            |lo, hi| {
                if lo >= 0.0 {
                    (lo.sqrt(), hi.sqrt())
                } else {
                    (f64::NEG_INFINITY, f64::INFINITY)
                }
            },
        ),
        Rsqrt => a.map(|lo, hi| {
            if lo > 0.0 {
                (1.0 / hi.sqrt(), 1.0 / lo.sqrt())
            } else {
                (f64::NEG_INFINITY, f64::INFINITY)
            }
        }),
        Exp => monotone(f64::exp),
        Log => a.map(|lo, hi| if lo > 0.0 { (lo.ln(), hi.ln()) } else { (f64::NEG_INFINITY, f64::INFINITY) }),
        Floor => monotone(f64::floor),
        Sin | Cos => Bound::splat(-1.0, 1.0),
        Fract | Step | Smoothstep => Bound::splat(0.0, 1.0),
        Expand => {
            let mut r = a.map(|lo, hi| (2.0 * lo - 1.0, 2.0 * hi - 1.0));
            // `expand` of a range-compressed cone-map lookup: the cone again.
            if let Some((c, l0, l1)) = a.cone.filter(|(_, l0, _)| *l0 < 0.0) {
                let unit = Bound::of_cone(c, -l0, -l1);
                r = Bound::lanes(&r, &unit, |a0, a1, b0, b1| (a0.max(b0), a1.min(b1))).with_cone(unit.cone);
            }
            r
        }
        HalfBias => a.map(|lo, hi| (lo - 0.5, hi - 0.5)),
        Compress => a.map(|lo, hi| ((lo + 1.0) / 2.0, (hi + 1.0) / 2.0)),
        Max | Min | Clamp | Mix | Reflect | Cross => Bound::ALL,
    }
}

impl Bound {
    fn with_cone(mut self, cone: Option<(Cone, f64, f64)>) -> Bound {
        self.cone = cone;
        self
    }
}

/// A light culled for an object: what the report says.
#[derive(Clone, Debug, PartialEq)]
pub struct Culled {
    /// The scene light.
    pub light: u32,
    /// The object, by its index in the scene's meshes.
    pub object: usize,
    /// The bound of what the light's terms add to a pixel of the object.
    pub bound: f64,
    /// The criterion of Adaptive Sample Shading, Section 2.2 that made the bound small.
    pub criterion: String,
}

/// Words for a culled light's criterion.
pub fn criterion(
    findings: &Findings,
    light: &crate::scene::Light,
    reach: &crate::scene::relevance::Reach,
    threshold: f64,
) -> String {
    use crate::scene::relevance::Outside;
    match (findings.max_intensity, reach.outside, light) {
        (Some(_), Some(Outside::SpotCone { cutoff_deg }), _) => return format!("volume of influence: the object lies outside the spot's cone (cut-off {cutoff_deg}°)"),
        (Some(0.0), _, crate::scene::Light::Spot { cutoff_deg, .. }) => {
            return format!("volume of influence: every vertex of the object lies outside the spot's cone (cut-off {cutoff_deg}°)")
        }
        _ => {}
    }
    match (findings.max_intensity, reach.outside) {
        (Some(i), _) if i <= threshold => {
            return format!("volume of influence: distance attenuation — the light is at least {:.2} away, its intensity at most {:.2e}", reach.min_distance, i)
        }
        _ => {}
    }
    if findings.faces_away {
        return "bounding cones: the light is behind every face (the cone of normals against the cone of light directions: max N·L ≤ 0)".into();
    }
    if let Some((base, n)) = findings.highlight {
        let alpha = shininess_cutoff(threshold as f32, 1.0, n as f32).map_or(0.0, |a| a.to_degrees());
        return format!(
            "shininess cut-off: the highlight's base is at most {base:.3} on the object, beyond cos α = threshold^(1/n) (n = {n}, α = {alpha:.1}°)"
        );
    }
    "bounding cones and volume of influence: the light's terms are below the threshold everywhere on the object".into()
}

/// What [`cull`] decided.
#[derive(Clone, Debug, Default)]
pub struct Culling {
    /// Report entries (kind `light`, `pass`, `texture`).
    pub removed: Vec<super::Removed>,
    /// Per-light statements no object needs (not planned).
    pub statements: Vec<usize>,
    /// Per-light statements drawn only for some objects: (statement, objects).
    pub objects: Vec<(usize, Vec<usize>)>,
    /// Every (light, object) skipped.
    pub culled: Vec<Culled>,
}

fn light_word(l: &crate::scene::Light) -> &'static str {
    match l {
        crate::scene::Light::Directional { .. } => "directional",
        crate::scene::Light::Point { .. } => "point",
        crate::scene::Light::Spot { .. } => "spot",
    }
}

fn mesh_word(d: &crate::scene::MeshDesc) -> String {
    use crate::scene::MeshDesc::*;
    match d {
        Sphere { .. } => "sphere".into(),
        Torus { .. } => "torus".into(),
        Plane { .. } => "plane".into(),
        Cube { .. } => "cube".into(),
        Obj(f) => format!("mesh {f}"),
    }
}

/// Culls, per object, the lights whose terms stay below `threshold`
/// (module docs) in the expanded module `m`; light 0's statement loses its
/// light terms when no object needs them, light i's statement is dropped
/// or drawn only for the objects that need it.
pub fn cull(
    m: &mut Module,
    spec: &super::SceneSpecialization,
    exp: &super::lights::Expansion,
    threshold: f64,
    names: &[String],
    at: &dyn Fn(crate::span::Span) -> String,
) -> Culling {
    let mut out = Culling::default();
    if exp.statements.is_empty() || spec.assets.meshes.is_empty() {
        return out;
    }
    let scene = spec.scene;
    let uniforms = bind::uniforms(m, scene);
    let objects = bound_objects(m, spec);
    // A statement whose target a later statement reads (other than by the
    // per-light accumulation itself) passes its change on: not culled.
    let per_light: Vec<usize> = exp.statements.iter().map(|s| s.statement).collect();
    let blocked = |m: &Module, stmt: usize| {
        let crate::ir::Table::Framebuffer { id, .. } = m.statements[stmt].table else { return true };
        (stmt + 1..m.statements.len()).filter(|j| !per_light.contains(j)).any(|j| {
            m.reachable(&[m.statements[j].value])
                .into_iter()
                .any(|n| matches!(m.exprs[n], Expr::FramebufferRead { framebuffer, .. } if framebuffer == id))
        })
    };
    let (dropped, detail) = culled_pairs(m, spec, exp, &objects, &uniforms, threshold, &blocked);
    let used_before = super::specialize::used_textures(m, &[]);
    drop_culled_terms(m, exp, &dropped, objects.len(), names, at, &mut out);
    report_culled_lights(m, spec, exp, (&dropped, &detail), threshold, at, &mut out);
    let used_after = super::specialize::used_textures(m, &out.statements);
    for t in used_before.difference(&used_after) {
        let tex = &m.textures[*t as usize];
        out.removed.push(super::Removed {
            kind: "texture".into(),
            what: tex.name.clone(),
            why: "only the culled lights' terms used it".into(),
            at: at(tex.span),
        });
    }
    out
}

/// Per light and object, whether the light is culled for the object, and
/// the bound and findings of each culled pair.
type Dropped = (Vec<Vec<bool>>, BTreeMap<(u32, usize), (f64, Findings)>);

/// The light and object pairs to cull (module docs): per object, the
/// lights whose terms' bounds, smallest first, sum to at most `threshold`.
/// A statement that is `blocked` (a later statement reads its target)
/// counts as unbounded.
fn culled_pairs(
    m: &Module,
    spec: &super::SceneSpecialization,
    exp: &super::lights::Expansion,
    objects: &[BoundObject],
    uniforms: &[Option<[f64; 4]>],
    threshold: f64,
    blocked: &dyn Fn(&Module, usize) -> bool,
) -> Dropped {
    let n_lights = spec.scene.lights.len();
    let mut dropped: Vec<Vec<bool>> = vec![vec![false; objects.len()]; n_lights.max(1)];
    let mut detail: BTreeMap<(u32, usize), (f64, Findings)> = BTreeMap::new();
    for (oi, object) in objects.iter().enumerate() {
        let mut totals: Vec<(f64, u32, Findings)> = Vec::new();
        for light in 0..n_lights as u32 {
            let mut total = 0.0;
            let mut findings = Findings::default();
            let mut worst = -1.0;
            for ls in exp.statements.iter().filter(|s| s.light == light) {
                if blocked(m, ls.statement) {
                    total = f64::INFINITY;
                    continue;
                }
                let mut b = Bounder::new(m, object, uniforms, spec.textures);
                let bound = b.bound(ls.light_terms).magnitude(3);
                total += bound;
                if bound > worst {
                    worst = bound;
                    findings = b.findings.clone();
                }
            }
            if exp.statements.iter().any(|s| s.light == light) {
                totals.push((total, light, findings));
            }
        }
        totals.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut sum = 0.0;
        for (total, light, findings) in totals {
            if total.is_nan() || sum + total > threshold {
                break;
            }
            sum += total;
            dropped[light as usize][oi] = true;
            detail.insert((light, oi), (total, findings));
        }
    }
    (dropped, detail)
}

/// The culling applied to the statements: light 0's statement loses its
/// light terms when no object needs them; light i's statement is dropped
/// (noted in `out.removed`) or drawn only for the objects that need it.
fn drop_culled_terms(
    m: &mut Module,
    exp: &super::lights::Expansion,
    dropped: &[Vec<bool>],
    n_objects: usize,
    names: &[String],
    at: &dyn Fn(crate::span::Span) -> String,
    out: &mut Culling,
) {
    let all_objects: Vec<usize> = (0..n_objects).collect();
    for ls in &exp.statements {
        let keep: Vec<usize> =
            all_objects.iter().copied().filter(|&o| !dropped[ls.light as usize][o]).collect();
        if ls.light == 0 {
            if keep.is_empty() {
                if let Some(wl) = ls.without_light {
                    m.statements[ls.statement].value = wl;
                }
            }
        } else if keep.is_empty() {
            out.statements.push(ls.statement);
            out.removed.push(super::Removed {
                kind: "pass".into(),
                what: format!("statement {}", names.get(ls.statement).cloned().unwrap_or_default()),
                why: format!("light {} reaches no object (light culling)", ls.light),
                at: at(m.statements[ls.statement].span),
            });
        } else if keep.len() < all_objects.len() {
            out.objects.push((ls.statement, keep));
        }
    }
}

/// The scene's objects bound for the abstract evaluation, texgen run.
fn bound_objects<'s>(m: &Module, spec: &super::SceneSpecialization<'s>) -> Vec<BoundObject<'s>> {
    let scene = spec.scene;
    let (w, h) = scene.resolution;
    let (center, radius) = spec.assets.bounding_sphere();
    let light_clip = bind::light_view_projection(scene.lights.first(), center, radius);
    let mut objects: Vec<BoundObject> = spec
        .assets
        .meshes
        .iter()
        .map(|(mesh, model)| BoundObject::new(scene, mesh, *model, w as f32 / h.max(1) as f32, light_clip))
        .collect();
    for o in &mut objects {
        // Texgen failures leave the mesh UVs: the bound is then only looser.
        let _ = o.run_texgen(m);
    }
    objects
}

/// Light and object pairs whose terms were dropped, and their bounds.
type Drops<'d> = (&'d [Vec<bool>], &'d BTreeMap<(u32, usize), (f64, Findings)>);

/// One `Removed` and one `Culled` per light culled for an object, with the
/// criterion that justified it.
fn report_culled_lights(
    m: &Module,
    spec: &super::SceneSpecialization,
    exp: &super::lights::Expansion,
    (dropped, detail): Drops,
    threshold: f64,
    at: &dyn Fn(crate::span::Span) -> String,
    out: &mut Culling,
) {
    let scene = spec.scene;
    let n_objects = spec.assets.meshes.len();
    for light in 0..scene.lights.len() as u32 {
        let Some(first) = exp.statements.iter().find(|s| s.light == light) else { continue };
        for o in 0..n_objects {
            // Light 0's terms are in a statement drawn for every object: skipped only when no object needs them.
            let effective =
                dropped[light as usize][o] && (light > 0 || (0..n_objects).all(|x| dropped[0][x]));
            if !effective {
                continue;
            }
            let (bound, findings) = detail.get(&(light, o)).cloned().unwrap_or_default();
            let l = &scene.lights[light as usize];
            let (mesh, model) = &spec.assets.meshes[o];
            let (oc, or) = sphere_of(mesh, *model);
            let reach = crate::scene::relevance::light_reach(l, oc, or);
            let criterion = criterion(&findings, l, &reach, threshold);
            let object = &scene.objects[o];
            out.removed.push(super::Removed {
                kind: "light".into(),
                what: format!(
                    "light {light} ({}) for object {o} ({}, material `{}`)",
                    light_word(l),
                    mesh_word(&object.mesh),
                    object.material
                ),
                why: format!(
                    "{criterion}; its terms add at most {bound:.2e} to a pixel (threshold {threshold:.2e})"
                ),
                at: at(m.statements[first.statement].span),
            });
            out.culled.push(Culled { light, object: o, bound, criterion });
        }
    }
}

/// The world-space bounding sphere of one mesh.
fn sphere_of(mesh: &crate::scene::Mesh, model: glam::Mat4) -> (Vec3, f32) {
    let pts: Vec<Vec3> = mesh.positions.iter().map(|p| model.transform_point3(*p)).collect();
    if pts.is_empty() {
        return (Vec3::ZERO, 0.0);
    }
    let c = pts.iter().fold(Vec3::ZERO, |s, p| s + *p) / pts.len() as f32;
    let r = pts.iter().map(|p| (*p - c).length()).fold(0.0, f32::max);
    (c, r)
}
