//! Texture sampling as OpenGL 1.x §3.8 specifies it, in f64: wrap modes
//! (§3.8.7: REPEAT on texel indices, CLAMP_TO_EDGE), the level of detail
//! λ = log₂ρ with ρ the larger of the two screen-axis scale factors
//! (§3.8.8, eq. 3.17, the exact derivatives rather than an approximation,
//! and the interval §3.8.8 lets an implementation's ρ lie in),
//! NEAREST and LINEAR (eq. 3.18-3.19), mipmap selection for
//! `*_MIPMAP_NEAREST` and the blend of `LINEAR_MIPMAP_LINEAR` (§3.8.8), and
//! cube-map face selection by the major axis (§3.8.6, Table 3.19, ties to
//! x, then y), each face clamped to its edge as 2000-era hardware did.
//!
//! The texels are data — a generator's or an image's level 0 (and the levels
//! a generator filters itself, such as Kilgard's normal-map mipmaps); the
//! other levels are built here by averaging 2×2 blocks, rounded to the
//! texture's format, as `glGenerateMipmap`-style box filtering does.

use super::ops::V;
use crate::textures::{Filter, TexelFormat, Wrap};

/// One level: `width × height` texels, row 0 first (v = 0).
#[derive(Clone, Debug)]
pub struct Level {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<V>,
}

/// A 2-D (or 1-D: height 1) texture with its mipmap chain.
#[derive(Clone, Debug)]
pub struct Image {
    pub levels: Vec<Level>,
    pub wrap: Wrap,
    pub filter: Filter,
}

pub(super) fn quantize(format: TexelFormat, v: f64) -> f64 {
    match format {
        TexelFormat::Rgba8 => (v.clamp(0.0, 1.0) * 255.0).round() / 255.0,
        TexelFormat::Signed8 => (v.clamp(-1.0, 1.0) * 127.0).round() / 127.0,
        TexelFormat::Rgba16 => (v.clamp(0.0, 1.0) * 65535.0).round() / 65535.0,
        TexelFormat::F32 => v,
    }
}

/// Box-filtered levels down to 1×1 below `base`.
pub fn mip_chain(base: Level, format: TexelFormat) -> Vec<Level> {
    let mut levels = vec![base];
    while let Some(last) = levels.last().filter(|l| l.width > 1 || l.height > 1) {
        let (w, h) = ((last.width / 2).max(1), (last.height / 2).max(1));
        let mut texels = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let mut sum = [0.0; 4];
                let mut n = 0.0;
                for (sx, sy) in
                    [(2 * x, 2 * y), (2 * x + 1, 2 * y), (2 * x, 2 * y + 1), (2 * x + 1, 2 * y + 1)]
                {
                    if sx < last.width && sy < last.height {
                        let t = last.texels[(sy * last.width + sx) as usize];
                        for c in 0..4 {
                            sum[c] += t[c];
                        }
                        n += 1.0;
                    }
                }
                texels.push(sum.map(|s| quantize(format, s / n)));
            }
        }
        levels.push(Level { width: w, height: h, texels });
    }
    levels
}

fn wrap_index(i: i64, size: u32, wrap: Wrap) -> u32 {
    let n = i64::from(size);
    match wrap {
        Wrap::Repeat => i.rem_euclid(n) as u32,
        Wrap::ClampToEdge => i.clamp(0, n - 1) as u32,
    }
}

impl Level {
    fn texel(&self, i: i64, j: i64, wrap: Wrap) -> V {
        let (x, y) = (wrap_index(i, self.width, wrap), wrap_index(j, self.height, wrap));
        self.texels[(y * self.width + x) as usize]
    }

    /// The least and greatest LINEAR sample (eq. 3.19) over the box
    /// `u × v`: the samples at the corners of the box's pieces between
    /// texel centres — the box's corners, the texel centres inside it and
    /// where its edges cross the centres' lines —, since a bilinear form
    /// on a rectangle is extreme at a corner. `None` for a box wider than
    /// 32 texels (or not finite).
    fn bilinear_range(&self, u: (f64, f64), v: (f64, f64), wrap: Wrap) -> Option<(V, V)> {
        let stops = |(a, b): (f64, f64), size: u32| -> Option<Vec<f64>> {
            let n = f64::from(size);
            if !(a.is_finite() && b.is_finite()) || (b - a) * n > 32.0 {
                return None;
            }
            let first = (a * n - 0.5).floor() + 1.0;
            let inside = (0..).map(|k| (first + f64::from(k) + 0.5) / n).take_while(|&c| c < b);
            Some([a, b].into_iter().chain(inside).collect())
        };
        let (us, vs) = (stops(u, self.width)?, stops(v, self.height)?);
        let (mut low, mut high) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
        for &y in &vs {
            for &x in &us {
                let t = self.sample(x, y, true, wrap);
                for c in 0..4 {
                    (low[c], high[c]) = (low[c].min(t[c]), high[c].max(t[c]));
                }
            }
        }
        Some((low, high))
    }

    /// GL eq. 3.18 (NEAREST) and 3.19 (LINEAR) at (u, v).
    fn sample(&self, u: f64, v: f64, linear: bool, wrap: Wrap) -> V {
        let (su, sv) = (u * f64::from(self.width), v * f64::from(self.height));
        if !linear {
            return self.texel(su.floor() as i64, sv.floor() as i64, wrap);
        }
        let (x, y) = (su - 0.5, sv - 0.5);
        let (i0, j0) = (x.floor() as i64, y.floor() as i64);
        let (a, b) = (x - x.floor(), y - y.floor());
        let t = |i, j| self.texel(i, j, wrap);
        let (t00, t10, t01, t11) = (t(i0, j0), t(i0 + 1, j0), t(i0, j0 + 1), t(i0 + 1, j0 + 1));
        let mut out = [0.0; 4];
        for c in 0..4 {
            out[c] = (1.0 - a) * (1.0 - b) * t00[c]
                + a * (1.0 - b) * t10[c]
                + (1.0 - a) * b * t01[c]
                + a * b * t11[c];
        }
        out
    }
}

impl Image {
    /// λ of GL eq. 3.17 from the coordinates' change over one pixel in x
    /// (`du_dx`) and in y, scaled by the base level's size.
    pub fn lod(&self, d_dx: [f64; 2], d_dy: [f64; 2]) -> f64 {
        let (w, h) = (f64::from(self.levels[0].width), f64::from(self.levels[0].height));
        let rho_x = (d_dx[0] * w).hypot(d_dx[1] * h);
        let rho_y = (d_dy[0] * w).hypot(d_dy[1] * h);
        rho_x.max(rho_y).log2()
    }

    /// The interval GL 1.x §3.8.8 allows λ in, from one pixel's
    /// coordinate derivatives: ρ may be approximated by any f with
    /// `max{m_u, m_v} ≤ f ≤ m_u + m_v`, where `m_u = max{|∂u/∂x|, |∂u/∂y|}`
    /// (in texels) and `m_v` likewise — an interval holding eq. 3.17's ρ.
    /// Returns `(log₂ max{m_u, m_v}, log₂ (m_u + m_v))`.
    pub fn lod_bounds(&self, d_dx: [f64; 2], d_dy: [f64; 2]) -> (f64, f64) {
        let (w, h) = (f64::from(self.levels[0].width), f64::from(self.levels[0].height));
        let m_u = (d_dx[0] * w).abs().max((d_dy[0] * w).abs());
        let m_v = (d_dx[1] * h).abs().max((d_dy[1] * h).abs());
        (m_u.max(m_v).log2(), (m_u + m_v).log2())
    }

    /// [`Image::lod_bounds`] for derivatives known only to lie in
    /// intervals (a dependent lookup whose coordinates move with another
    /// lookup's λ): the least λ any derivatives within them give and the
    /// greatest (−∞ where a derivative may be 0: magnified, level 0).
    pub fn lod_bounds_within(&self, d_dx: [(f64, f64); 2], d_dy: [(f64, f64); 2]) -> (f64, f64) {
        let (w, h) = (f64::from(self.levels[0].width), f64::from(self.levels[0].height));
        let least = |d: (f64, f64)| if d.0 <= 0.0 && d.1 >= 0.0 { 0.0 } else { d.0.abs().min(d.1.abs()) };
        let most = |d: (f64, f64)| d.0.abs().max(d.1.abs());
        let (u_lo, v_lo) = (least(d_dx[0]).max(least(d_dy[0])) * w, least(d_dx[1]).max(least(d_dy[1])) * h);
        let (u_hi, v_hi) = (most(d_dx[0]).max(most(d_dy[0])) * w, most(d_dx[1]).max(most(d_dy[1])) * h);
        (u_lo.max(v_lo).log2(), (u_hi + v_hi).log2())
    }

    /// The least and greatest value, per channel, of any texel a filtered
    /// lookup at (u, v) within the box `u × v` may read for λ in
    /// `[lo, hi]`: every texel of the box's footprint (with its LINEAR
    /// neighbours, wrapped) on every level those λ select. A filtered
    /// value is a convex combination of those texels (eq. 3.19-3.20), so
    /// it lies within.
    pub fn footprint_hull(&self, u: (f64, f64), v: (f64, f64), lo: f64, hi: f64) -> (V, V) {
        let last = self.levels.len() - 1;
        let linear = self.filter != Filter::Nearest;
        let nearest_level = |l: f64| if l > 0.5 { (l + 0.5).ceil() - 1.0 } else { 0.0 };
        let (first, end) = if last == 0 || hi <= 0.0 || hi.is_nan() {
            (0.0, 0.0)
        } else {
            let lo = if lo.is_nan() { 0.0 } else { lo.max(0.0) };
            match self.filter {
                Filter::Trilinear => (lo.floor(), hi.floor() + 1.0),
                Filter::Nearest | Filter::Bilinear => (nearest_level(lo), nearest_level(hi)),
            }
        };
        let (first, end) = (first.min(last as f64) as usize, end.min(last as f64) as usize);
        let (mut low, mut high) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
        for level in &self.levels[first..=end] {
            let span = |(a, b): (f64, f64), size: u32| -> (i64, i64) {
                let n = f64::from(size);
                let (a, b) = if linear { (a * n - 0.5, b * n - 0.5 + 1.0) } else { (a * n, b * n) };
                if !(a.is_finite() && b.is_finite()) || b - a >= n {
                    (0, i64::from(size) - 1)
                } else {
                    (a.floor() as i64, b.floor() as i64)
                }
            };
            if let Some((lo, hi)) = level.bilinear_range(u, v, self.wrap).filter(|_| linear) {
                for c in 0..4 {
                    (low[c], high[c]) = (low[c].min(lo[c]), high[c].max(hi[c]));
                }
                continue;
            }
            let ((i0, i1), (j0, j1)) = (span(u, level.width), span(v, level.height));
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let t = level.texel(i, j, self.wrap);
                    for c in 0..4 {
                        (low[c], high[c]) = (low[c].min(t[c]), high[c].max(t[c]));
                    }
                }
            }
        }
        (low, high)
    }

    /// The filtered texels between which the texel at (u, v) moves as λ
    /// runs over `[lo, hi]`: its values at the ends and, between them, at
    /// every integer λ (`LINEAR_MIPMAP_LINEAR` is linear in λ between
    /// two levels, eq. 3.20, so its extremes lie there) or at every level
    /// chosen (`*_MIPMAP_NEAREST` steps from level to level). Empty for a
    /// texture without mipmaps, whose texel does not depend on λ.
    pub fn lod_extremes(&self, u: f64, v: f64, lo: f64, hi: f64) -> Vec<V> {
        let last = self.levels.len() - 1;
        if last == 0 || !lo.is_finite() || !hi.is_finite() || hi <= 0.0 {
            return Vec::new();
        }
        let lo = lo.max(0.0);
        let mut at = vec![lo, hi];
        match self.filter {
            Filter::Trilinear => {
                let first = lo.floor() + 1.0;
                at.extend((0..).map(|k| first + f64::from(k)).take_while(|&l| l < hi && l <= last as f64));
            }
            Filter::Nearest | Filter::Bilinear => {
                let level = |l: f64| if l > 0.5 { (l + 0.5).ceil() - 1.0 } else { 0.0 };
                let (a, b) = (level(lo), level(hi).min(last as f64));
                at.extend((0..).map(|k| a + 1.0 + f64::from(k)).take_while(|&d| d < b));
            }
        }
        at.into_iter().map(|l| self.sample(u, v, l)).collect()
    }

    /// The filtered texels at (u, v) at the ends of the pieces of λ's
    /// interval `[lo, hi]` on which the texel is affine in λ, in λ's
    /// order: `LINEAR_MIPMAP_LINEAR` blends two levels linearly in λ
    /// (eq. 3.20), so its pieces end at `lo`, every integer λ between (past
    /// the last level too, where the texel stays) and `hi`;
    /// `*_MIPMAP_NEAREST` steps from level to level (d = ⌈λ + ½⌉ − 1), so
    /// its path is each level chosen, in order. One texel where it does not
    /// move with λ (no mipmaps, or λ ≤ 0 throughout: magnified).
    pub fn lod_path(&self, u: f64, v: f64, lo: f64, hi: f64) -> Vec<V> {
        let last = self.levels.len() - 1;
        if last == 0 || !lo.is_finite() || !hi.is_finite() || hi <= 0.0 || hi <= lo {
            return vec![self.sample(u, v, lo)];
        }
        let lo = lo.max(0.0);
        match self.filter {
            Filter::Trilinear => {
                let inner = (0..).map(|k| lo.floor() + 1.0 + f64::from(k)).take_while(|&l| l < hi);
                std::iter::once(lo).chain(inner).chain([hi]).map(|l| self.sample(u, v, l)).collect()
            }
            Filter::Nearest | Filter::Bilinear => {
                let level = |l: f64| if l > 0.5 { (l + 0.5).ceil() - 1.0 } else { 0.0 };
                let (a, b) = (level(lo) as usize, level(hi) as usize);
                (a..=b.max(a)).map(|d| self.sample(u, v, d as f64)).collect()
            }
        }
    }

    /// The filtered texel at (u, v) for level of detail `lambda`.
    pub fn sample(&self, u: f64, v: f64, lambda: f64) -> V {
        let last = self.levels.len() - 1;
        let linear = self.filter != Filter::Nearest;
        // Magnification (λ ≤ 0), or a texture without mipmaps: level 0.
        if lambda <= 0.0 || last == 0 || !lambda.is_finite() {
            return self.levels[0].sample(u, v, linear, self.wrap);
        }
        match self.filter {
            Filter::Nearest | Filter::Bilinear => {
                // `*_MIPMAP_NEAREST`: d = ⌈λ + ½⌉ − 1 for λ > ½, else 0.
                let d = if lambda > 0.5 { ((lambda + 0.5).ceil() - 1.0) as usize } else { 0 };
                self.levels[d.min(last)].sample(u, v, linear, self.wrap)
            }
            Filter::Trilinear => {
                let d1 = (lambda.floor() as usize).min(last);
                let d2 = (d1 + 1).min(last);
                let f = if d1 == last { 0.0 } else { lambda - lambda.floor() };
                let (a, b) = (
                    self.levels[d1].sample(u, v, true, self.wrap),
                    self.levels[d2].sample(u, v, true, self.wrap),
                );
                std::array::from_fn(|c| (1.0 - f) * a[c] + f * b[c])
            }
        }
    }
}

/// GL Table 3.19: the face (0..6 in +x, −x, +y, −y, +z, −z order) and
/// (s, t) of direction `r`. A zero direction takes +x's centre.
pub fn cube_face(r: [f64; 3]) -> (usize, f64, f64) {
    let [x, y, z] = r.map(|c| if c.is_finite() { c } else { 0.0 });
    let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
    let (face, sc, tc, ma) = if ax >= ay && ax >= az {
        if x >= 0.0 {
            (0, -z, -y, ax)
        } else {
            (1, z, -y, ax)
        }
    } else if ay >= az {
        if y >= 0.0 {
            (2, x, z, ay)
        } else {
            (3, x, -z, ay)
        }
    } else if z >= 0.0 {
        (4, x, -y, az)
    } else {
        (5, -x, -y, az)
    };
    if ma == 0.0 {
        return (0, 0.5, 0.5);
    }
    (face, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0))
}

/// A cube map: six faces, each clamped to its edge.
#[derive(Clone, Debug)]
pub struct Cube {
    pub faces: Vec<Image>,
}

impl Cube {
    /// The filtered texel at direction `r`, and whether the filter's
    /// footprint reaches a face edge — where GL 1.x (each face clamped),
    /// ARB_seamless_cube_map and Vulkan (seamless) may all differ.
    pub fn sample(&self, r: [f64; 3]) -> (V, bool) {
        let (face, s, t) = cube_face(r);
        let image = &self.faces[face];
        let size = f64::from(image.levels[0].width);
        let edge = |x: f64| x * size < 1.0 || (1.0 - x) * size < 1.0;
        (image.sample(s, t, 0.0), edge(s) || edge(t))
    }

    /// The least and greatest texel a lookup may read at any direction in
    /// the box `r` (an interval per axis), and whether the box reaches
    /// within a texel of a face edge (where implementations differ:
    /// [`Cube::sample`]). Every face some direction of the box may select
    /// by Table 3.19 (its axis's sign possible and its size not surely
    /// below another axis's) is read over the box of (s, t) that
    /// `(sc/|ma| + 1)/2`, `(tc/|ma| + 1)/2` span there, each within
    /// [0, 1] (|sc|, |tc| ≤ |ma| on the face), at level 0 with the face's
    /// filter ([`Image::footprint_hull`]: exact over the box).
    pub fn box_hull(&self, r: [(f64, f64); 3]) -> (V, V, bool) {
        let size = |(a, b): (f64, f64)| -> (f64, f64) {
            if a <= 0.0 && b >= 0.0 {
                (0.0, a.abs().max(b.abs()))
            } else {
                (a.abs().min(b.abs()), a.abs().max(b.abs()))
            }
        };
        let neg = |(a, b): (f64, f64)| (-b, -a);
        let (mut low, mut high, mut edge) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4], false);
        // (axis, sign, sc's interval, tc's) per face, Table 3.19.
        let [x, y, z] = r;
        let faces = [
            (0, 1.0, neg(z), neg(y)),
            (0, -1.0, z, neg(y)),
            (1, 1.0, x, z),
            (1, -1.0, x, neg(z)),
            (2, 1.0, x, neg(y)),
            (2, -1.0, neg(x), neg(y)),
        ];
        for (face, &(axis, sign, sc, tc)) in faces.iter().enumerate() {
            let a = r[axis];
            let possible = if sign > 0.0 { a.1 >= 0.0 } else { a.0 <= 0.0 };
            let ma = size(if sign > 0.0 { (a.0.max(0.0), a.1) } else { (a.0, a.1.min(0.0)) });
            let others = (0..3).filter(|&k| k != axis).map(|k| size(r[k]).0).fold(0.0, f64::max);
            if !possible || ma.1 < others || ma.1.is_nan() || ma.1 <= 0.0 {
                continue;
            }
            let coordinate = |c: (f64, f64)| -> (f64, f64) {
                let q = if ma.0 > 0.0 {
                    let v = [c.0 / ma.0, c.0 / ma.1, c.1 / ma.0, c.1 / ma.1];
                    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)))
                } else {
                    (-1.0, 1.0)
                };
                (0.5 * (q.0.clamp(-1.0, 1.0) + 1.0), 0.5 * (q.1.clamp(-1.0, 1.0) + 1.0))
            };
            let (s, t) = (coordinate(sc), coordinate(tc));
            let image = &self.faces[face];
            let n = f64::from(image.levels[0].width);
            let near = |(a, b): (f64, f64)| a * n < 1.0 || (1.0 - b) * n < 1.0;
            edge |= near(s) || near(t);
            let (lo, hi) = image.footprint_hull(s, t, 0.0, 0.0);
            for c in 0..4 {
                (low[c], high[c]) = (low[c].min(lo[c]), high[c].max(hi[c]));
            }
        }
        // The zero direction reads +x's centre ([`cube_face`]).
        if r.iter().all(|a| a.0 <= 0.0 && a.1 >= 0.0) {
            let (v, _) = self.sample([0.0; 3]);
            for c in 0..4 {
                (low[c], high[c]) = (low[c].min(v[c]), high[c].max(v[c]));
            }
        }
        if low.iter().zip(&high).any(|(l, h)| l.is_nan() || h.is_nan() || l > h) {
            return ([f64::NEG_INFINITY; 4], [f64::INFINITY; 4], true);
        }
        (low, high, edge)
    }
}

/// A 3-D texture (GL 1.2 §3.8, `TEXTURE_3D`): `width × height × depth`
/// texels, slice `r` after slice, each row-major; one level.
#[derive(Clone, Debug)]
pub struct Volume {
    pub width: u32,
    pub height: u32,
    pub depth: u32,
    pub texels: Vec<V>,
    pub wrap: Wrap,
    pub filter: Filter,
}

impl Volume {
    fn texel(&self, i: i64, j: i64, k: i64) -> V {
        let (x, y, z) = (
            wrap_index(i, self.width, self.wrap),
            wrap_index(j, self.height, self.wrap),
            wrap_index(k, self.depth, self.wrap),
        );
        self.texels[((z * self.height + y) * self.width + x) as usize]
    }

    /// The filtered texel at (s, t, r): NEAREST the texel holding it (GL
    /// eq. 3.18 in three dimensions), LINEAR the eight texels around it
    /// weighted by the distances along each axis (eq. 3.19's trilinear
    /// form within a level), wrapped per the declaration. A volume has
    /// one level, so λ only chooses between the minification and
    /// magnification filters, which are the same one here.
    pub fn sample(&self, s: f64, t: f64, r: f64) -> V {
        let [s, t, r] = [s, t, r].map(|c| if c.is_finite() { c } else { 0.0 });
        let scaled = [s * f64::from(self.width), t * f64::from(self.height), r * f64::from(self.depth)];
        if self.filter == Filter::Nearest {
            let [i, j, k] = scaled.map(|c| c.floor() as i64);
            return self.texel(i, j, k);
        }
        let shifted = scaled.map(|c| c - 0.5);
        let base = shifted.map(|c| c.floor() as i64);
        let frac: [f64; 3] = std::array::from_fn(|a| shifted[a] - shifted[a].floor());
        let mut out = [0.0; 4];
        for corner in 0..8 {
            let bit = |a: usize| (corner >> a) & 1 == 1;
            let weight: f64 = (0..3).map(|a| if bit(a) { frac[a] } else { 1.0 - frac[a] }).product();
            let texel = self.texel(
                base[0] + i64::from(bit(0)),
                base[1] + i64::from(bit(1)),
                base[2] + i64::from(bit(2)),
            );
            for c in 0..4 {
                out[c] += weight * texel[c];
            }
        }
        out
    }

    /// The least and greatest texel a lookup may read at any (s, t, r) in
    /// the box `c` (an interval per axis): every texel the box's
    /// footprint covers, with its LINEAR neighbours, wrapped as
    /// [`Volume::sample`] wraps. A filtered value is a convex combination
    /// of those texels, so it lies within. A box not finite reads all.
    pub fn box_hull(&self, c: [(f64, f64); 3]) -> (V, V) {
        let linear = self.filter != Filter::Nearest;
        let sizes = [self.width, self.height, self.depth];
        let span = |a: usize| -> (i64, i64) {
            let (n, (lo, hi)) = (f64::from(sizes[a]), c[a]);
            let (lo, hi) = if linear { (lo * n - 0.5, hi * n + 0.5) } else { (lo * n, hi * n) };
            if !(lo.is_finite() && hi.is_finite()) || hi - lo >= n {
                (0, i64::from(sizes[a]) - 1)
            } else {
                (lo.floor() as i64, hi.floor() as i64)
            }
        };
        let (si, sj, sk) = (span(0), span(1), span(2));
        let (mut low, mut high) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
        for k in sk.0..=sk.1 {
            for j in sj.0..=sj.1 {
                for i in si.0..=si.1 {
                    let t = self.texel(i, j, k);
                    for ch in 0..4 {
                        (low[ch], high[ch]) = (low[ch].min(t[ch]), high[ch].max(t[ch]));
                    }
                }
            }
        }
        (low, high)
    }
}

/// A dual-paraboloid environment map (Heidrich & Seidel 1999, Section
/// 4.1): two images over [−1, 1]², the front one holding the directions
/// with z ≥ 0, the back one the others.
#[derive(Clone, Debug)]
pub struct Paraboloid {
    pub front: Image,
    pub back: Image,
}

impl Paraboloid {
    /// The direction through (x, y) ∈ [−1, 1]² of a face: the point
    /// (x, y, ½ − ½(x² + y²)) of the paraboloid (eq. 5) reflects ±z into
    /// the direction whose halfway vector with ±z is the paraboloid's
    /// normal (x, y, 1): `(2x, 2y, ±(1 − r²)) / (1 + r²)`. Outside the
    /// unit circle the same formula continues into the other hemisphere.
    pub fn direction(front: bool, x: f64, y: f64) -> [f64; 3] {
        let r2 = x * x + y * y;
        let z = (1.0 - r2) / (1.0 + r2);
        [2.0 * x / (1.0 + r2), 2.0 * y / (1.0 + r2), if front { z } else { -z }]
    }

    /// The filtered texel in direction `r`: the front face where
    /// `r.z ≥ 0`, at `(x, y) = (r_x, r_y)/(1 ± r_z)` of the unit `r`
    /// (eq. 7 with the identity for the environment's frame), at level 0
    /// as a lookup by direction without derivatives is.
    pub fn sample(&self, r: [f64; 3]) -> V {
        let r = r.map(|c| if c.is_finite() { c } else { 0.0 });
        let len = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        let [x, y, z] = if len > 0.0 { r.map(|c| c / len) } else { [0.0, 0.0, 1.0] };
        let (image, denom) = if z >= 0.0 { (&self.front, 1.0 + z) } else { (&self.back, 1.0 - z) };
        image.sample(0.5 * (x / denom + 1.0), 0.5 * (y / denom + 1.0), 0.0)
    }

    /// The least and greatest texel a lookup may read at any direction in
    /// the box `r` (an interval per axis): the unit direction's box (each
    /// axis over the box's least and greatest length, within [−1, 1]),
    /// then on each face its z may select (front where z ≥ 0) the box of
    /// `(x, y)/(1 ± z)` [`Paraboloid::sample`] reads, at level 0
    /// ([`Image::footprint_hull`]: every texel of the box's footprint).
    pub fn box_hull(&self, r: [(f64, f64); 3]) -> (V, V) {
        let whole = |(a, b): (f64, f64)| !(a.is_finite() && b.is_finite());
        let r = if r.iter().any(|&a| whole(a)) { [(-1.0, 1.0); 3] } else { r };
        let square = |(a, b): (f64, f64)| {
            let (p, q) = (a * a, b * b);
            if a <= 0.0 && b >= 0.0 {
                (0.0, p.max(q))
            } else {
                (p.min(q), p.max(q))
            }
        };
        let sum = r.iter().fold((0.0, 0.0), |s, &a| (s.0 + square(a).0, s.1 + square(a).1));
        let len = (sum.0.sqrt(), sum.1.sqrt());
        // A box that may hold the zero direction (or a length not a number).
        let zero = len.0.is_nan() || len.0 <= 0.0;
        let unit = |(a, b): (f64, f64)| -> (f64, f64) {
            if zero {
                return (-1.0, 1.0);
            }
            let v = [a / len.0, a / len.1, b / len.0, b / len.1];
            let (lo, hi) =
                v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &x| (l.min(x), h.max(x)));
            (lo.clamp(-1.0, 1.0), hi.clamp(-1.0, 1.0))
        };
        let [x, y, z] = r.map(unit);
        let (mut low, mut high) = ([f64::INFINITY; 4], [f64::NEG_INFINITY; 4]);
        let mut read = |image: &Image, denom: (f64, f64)| {
            // (c/denom + 1)/2 over c in `c` and denom in [1, 2]: monotone
            // in each, at the corners.
            let coordinate = |c: (f64, f64)| {
                let v = [c.0 / denom.0, c.0 / denom.1, c.1 / denom.0, c.1 / denom.1].map(|q| 0.5 * (q + 1.0));
                let (lo, hi) =
                    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &q| (l.min(q), h.max(q)));
                // Widened past the rounding of `sample`'s own division.
                (lo - 1e-9, hi + 1e-9)
            };
            let (lo, hi) = image.footprint_hull(coordinate(x), coordinate(y), 0.0, 0.0);
            for c in 0..4 {
                (low[c], high[c]) = (low[c].min(lo[c]), high[c].max(hi[c]));
            }
        };
        if z.1 >= 0.0 {
            read(&self.front, (1.0 + z.0.max(0.0), 1.0 + z.1));
        }
        if z.0 < 0.0 {
            read(&self.back, (1.0 - z.1.min(0.0), 1.0 - z.0));
        }
        // The zero direction reads the front face at (0, 0, 1).
        if zero {
            let v = self.sample([0.0, 0.0, 1.0]);
            for c in 0..4 {
                (low[c], high[c]) = (low[c].min(v[c]), high[c].max(v[c]));
            }
        }
        (low, high)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(filter: Filter) -> Image {
        // 8×8 of a checker: level 0 black and white, level 1 on grey.
        let texels = (0..64).map(|i| if (i % 8 + i / 8) % 2 == 0 { [1.0; 4] } else { [0.0; 4] }).collect();
        let levels = mip_chain(Level { width: 8, height: 8, texels }, TexelFormat::Rgba8);
        Image { levels, wrap: Wrap::Repeat, filter }
    }

    /// GL §3.8.8's interval holds eq. 3.17's ρ: for a rotated isotropic
    /// map, λ lies between log₂ of the larger derivative and of the sum.
    #[test]
    fn lod_bounds_hold_the_ideal_lambda() {
        let t = image(Filter::Trilinear);
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let (dx, dy) = ([0.25 * c, 0.25 * s], [-0.25 * s, 0.25 * c]);
        let (lo, hi) = t.lod_bounds(dx, dy);
        let ideal = t.lod(dx, dy);
        assert!(lo <= ideal && ideal <= hi, "{lo} {ideal} {hi}");
        assert!((ideal - 1.0).abs() < 1e-12 && hi - lo <= 1.0 + 1e-12, "{lo} {hi}");
    }

    /// A 2 × 2 × 2 volume whose texel (x, y, z) holds x + 2y + 4z: LINEAR
    /// returns a texel at its centre and the mean of the eight at the
    /// volume's centre; NEAREST the texel holding the point; outside,
    /// CLAMP_TO_EDGE the edge texel and REPEAT the opposite one.
    #[test]
    fn a_volume_filters_trilinearly_and_wraps_as_declared() {
        let texels = (0..8).map(|i| [f64::from(i); 4]).collect();
        let v = Volume {
            width: 2,
            height: 2,
            depth: 2,
            texels,
            wrap: Wrap::ClampToEdge,
            filter: Filter::Bilinear,
        };
        assert_eq!(v.sample(0.75, 0.25, 0.75)[0], 5.0);
        assert!((v.sample(0.5, 0.5, 0.5)[0] - 3.5).abs() < 1e-12);
        assert!((v.sample(0.5, 0.25, 0.25)[0] - 0.5).abs() < 1e-12);
        assert_eq!(v.sample(-0.4, 0.25, 0.25)[0], 0.0);
        let repeat = Volume { wrap: Wrap::Repeat, ..v.clone() };
        assert!((repeat.sample(0.0, 0.25, 0.25)[0] - 0.5).abs() < 1e-12);
        let nearest = Volume { filter: Filter::Nearest, ..v };
        assert_eq!(nearest.sample(0.9, 0.1, 0.6)[0], 5.0);
    }

    /// The path of a texel over λ's pieces holds its value at every λ of
    /// the interval: each λ's texel is the path's at its piece's start
    /// plus that piece's change scaled by how far λ has run through it.
    #[test]
    fn lod_path_ends_its_pieces_where_the_texel_bends() {
        for filter in [Filter::Trilinear, Filter::Bilinear] {
            let t = image(filter);
            let (lo, hi) = (0.3, 2.6);
            let path = t.lod_path(0.3, 0.55, lo, hi);
            let ends: Vec<f64> = match filter {
                Filter::Trilinear => vec![lo, 1.0, 2.0, hi],
                _ => vec![0.0, 1.0, 2.0, 3.0],
            };
            assert_eq!(path.len(), ends.len(), "{filter:?}");
            for k in 0..=100 {
                let l = lo + (hi - lo) * f64::from(k) / 100.0;
                let v = t.sample(0.3, 0.55, l)[0];
                let j = match filter {
                    Filter::Trilinear => ends.windows(2).position(|w| l <= w[1]).unwrap_or(0),
                    _ => ends.iter().rposition(|&d| d == 0.0 || l > d - 0.5).unwrap_or(0),
                };
                let expected = match filter {
                    Filter::Trilinear => {
                        let f = (l - ends[j]) / (ends[j + 1] - ends[j]);
                        path[j][0] + f * (path[j + 1][0] - path[j][0])
                    }
                    _ => path[j][0],
                };
                assert!((v - expected).abs() < 1e-12, "{filter:?} λ {l}: {v} against {expected}");
            }
        }
    }

    /// Every direction in a box that crosses a face edge reads a texel
    /// within the box's hull, and the box is said to reach an edge.
    #[test]
    fn a_cube_box_hull_holds_every_direction_in_the_box() {
        let face = |k: usize| {
            let texels = (0..64).map(|i| [f64::from((i * 7 + k as u32 * 13) % 17) / 16.0; 4]).collect();
            Image {
                levels: vec![Level { width: 8, height: 8, texels }],
                wrap: Wrap::ClampToEdge,
                filter: Filter::Bilinear,
            }
        };
        let cube = Cube { faces: (0..6).map(face).collect() };
        let b = [(0.6, 1.0), (-0.3, 0.9), (0.2, 0.5)];
        let (lo, hi, edge) = cube.box_hull(b);
        assert!(edge);
        for i in 0..=20 {
            for j in 0..=20 {
                for k in 0..=4 {
                    let r = [
                        b[0].0 + (b[0].1 - b[0].0) * f64::from(i) / 20.0,
                        b[1].0 + (b[1].1 - b[1].0) * f64::from(j) / 20.0,
                        b[2].0 + (b[2].1 - b[2].0) * f64::from(k) / 4.0,
                    ];
                    let v = cube.sample(r).0[0];
                    assert!(lo[0] <= v && v <= hi[0], "{r:?}: {v} outside {}..{}", lo[0], hi[0]);
                }
            }
        }
    }

    /// 21 points along each axis of box `b`.
    fn grid(b: [(f64, f64); 3]) -> impl Iterator<Item = [f64; 3]> {
        let at = move |a: usize, k: u32| b[a].0 + (b[a].1 - b[a].0) * f64::from(k) / 20.0;
        (0..21 * 21 * 21).map(move |i| [at(0, i % 21), at(1, (i / 21) % 21), at(2, i / 441)])
    }

    /// Every (s, t, r) in a box reads a texel of a volume within the box's
    /// hull, for both filters and wraps; a box outside [0, 1] wraps.
    #[test]
    fn a_volume_box_hull_holds_every_point_in_the_box() {
        let texels = (0..64u32).map(|i| [f64::from((i * 7) % 17) / 16.0; 4]).collect();
        for (filter, wrap) in [(Filter::Bilinear, Wrap::ClampToEdge), (Filter::Nearest, Wrap::Repeat)] {
            let v = Volume { width: 4, height: 4, depth: 4, texels: Vec::clone(&texels), wrap, filter };
            let b = [(0.1, 0.45), (0.7, 1.2), (-0.2, 0.3)];
            let (lo, hi) = v.box_hull(b);
            for p in grid(b) {
                // The trilinear weights' rounding: a part in 10¹⁵.
                let x = v.sample(p[0], p[1], p[2])[0];
                assert!(
                    lo[0] - 1e-12 <= x && x <= hi[0] + 1e-12,
                    "{filter:?} {p:?}: {x} outside {}..{}",
                    lo[0],
                    hi[0]
                );
            }
        }
    }

    /// Every direction in a box, on either side of z = 0, reads a texel of
    /// a dual-paraboloid map within the box's hull; a box near +z reads
    /// less than the whole front face.
    #[test]
    fn a_paraboloid_box_hull_holds_every_direction_in_the_box() {
        let face = |k: u32| {
            let texels = (0..256u32).map(|i| [f64::from((i * 7 + k * 5) % 23) / 22.0; 4]).collect();
            Image {
                levels: vec![Level { width: 16, height: 16, texels }],
                wrap: Wrap::ClampToEdge,
                filter: Filter::Bilinear,
            }
        };
        let map = Paraboloid { front: face(0), back: face(1) };
        let (lo, hi) = map.box_hull([(-0.05, 0.05), (0.0, 0.1), (0.9, 1.1)]);
        assert!(hi[0] - lo[0] < 1.0, "the whole face");
        for b in [[(-0.05, 0.05), (0.0, 0.1), (0.9, 1.1)], [(0.3, 0.9), (-0.6, 0.2), (-0.4, 0.5)]] {
            let (lo, hi) = map.box_hull(b);
            for r in grid(b) {
                let x = map.sample(r)[0];
                assert!(lo[0] <= x && x <= hi[0], "{r:?}: {x} outside {}..{}", lo[0], hi[0]);
            }
        }
    }

    /// Trilinear: the ends and every integer λ between them; a
    /// `MIPMAP_NEAREST` filter: every level between; no mipmaps: none.
    #[test]
    fn lod_extremes_are_the_ends_and_the_levels_between() {
        let t = image(Filter::Trilinear);
        assert_eq!(t.lod_extremes(0.3, 0.3, 0.4, 2.6).len(), 4);
        assert_eq!(t.lod_extremes(0.3, 0.3, 1.2, 1.8).len(), 2);
        assert!(t.lod_extremes(0.3, 0.3, -2.0, -0.5).is_empty());
        let n = image(Filter::Bilinear);
        assert_eq!(n.lod_extremes(0.3, 0.3, 0.2, 2.9).len(), 4);
        let one = Image { levels: vec![t.levels[0].clone()], ..t };
        assert!(one.lod_extremes(0.3, 0.3, 0.2, 2.9).is_empty());
    }
}
