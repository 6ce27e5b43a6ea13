//! The texture unit of [`super::unit`] over lanes: the lookups of a batch
//! of fragments together (the CPU renderer's `f32` lane code), with this
//! model's choices (`unit::Latitude::MODEL`) and float arithmetic.
//!
//! What runs as lanes: a cube map's face selection, face coordinates,
//! texel addresses and weights (fixed-length loops over `N` lanes that the
//! compiler turns into vector code); a 2-D texture's level choice (one
//! level or two) and each level's coordinates, weights and wrapped texel
//! indices. The texel fetches stay a loop over the lanes (a gather), each
//! lane's four texels filtered as one 4-wide vector. Every lane computes the
//! formulas of [`unit::sample_cube_with`] and [`unit::sample_2d_with`] in
//! their order, so the values are theirs bit for bit (tests below); a cube
//! lane whose footprint leaves its face (seamless filtering across faces,
//! a few per cent of the lookups) is handed to the one-lane code.

use super::sampling::{Filter, Level, Texture2D, TextureCube, Wrap};
use super::unit::{self, LodChoice, WeightChoice};

/// `v` clamped to ±1e9, or 0 where not finite (the texture unit's rule
/// for coordinates, `unit::finite`).
#[inline(always)]
fn finite(v: f32) -> f32 {
    if v.is_finite() {
        v.clamp(-1e9, 1e9)
    } else {
        0.0
    }
}

/// `x.floor()`. In the lane program's AVX2 copy (SSE4.1 included) this is
/// one rounding instruction over eight lanes (`vroundps`); the earlier
/// emulation by truncation (convert, compare, subtract, select, copy the
/// sign: the same values) cost ~4 % of a frame's samples there
/// (BENCHMARKS.md, fourteenth session). Where a function is compiled
/// without SSE4.1 (the copy for CPUs without AVX2) it is a `floorf` call
/// per lane: the same values, slower.
#[inline(always)]
fn floor_lane(x: f32) -> f32 {
    x.floor()
}

/// `x as i32` for a whole number within ±1e9 (a floor of what [`finite`]
/// keeps, or a level index): one conversion instruction over the lanes,
/// where `as` adds the selects that saturate and map NaN to 0 (~3 % of a
/// frame's samples in the footprints' loop, BENCHMARKS.md, fifteenth session).
#[inline(always)]
fn whole_i32(x: f32) -> i32 {
    debug_assert!(x.abs() <= 1e9 && x.fract() == 0.0, "{x}");
    // SAFETY: `x` is finite and within ±1e9, so it is an i32 (the callers'
    // values: floors of `finite` coordinates, levels within a chain).
    unsafe { x.to_int_unchecked::<i32>() }
}

/// `a + w·(b − a)` per channel: the filter's one interpolation.
#[inline(always)]
fn lerp(a: [f32; 4], b: [f32; 4], w: f32) -> [f32; 4] {
    [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1]), a[2] + w * (b[2] - a[2]), a[3] + w * (b[3] - a[3])]
}

/// Bilinear filtering of four texels with weights (ax, ay), as
/// [`unit::sample_cube_with`] and `Level::sample_bilinear` combine them.
#[inline(always)]
fn bilinear4(t00: [f32; 4], t10: [f32; 4], t01: [f32; 4], t11: [f32; 4], ax: f32, ay: f32) -> [f32; 4] {
    let top = lerp(t00, t10, ax);
    let bottom = lerp(t01, t11, ax);
    lerp(top, bottom, ay)
}

/// Lanes `0..n` of a cube-map lookup along the directions `d` (three
/// component lanes) into `out` (four component lanes), bilinear on level 0
/// and seamless, as [`unit::sample_cube_with`] with the model's weights.
/// Returns `false`, touching nothing, for a lookup it does not cover
/// (nearest filtering, quantized weights): the caller samples lane by lane.
///
/// With `borders` (`c`'s faces bordered by their seams, [`CubeBorders`])
/// every lane reads its four texels from them, the lanes whose footprint
/// leaves its face too; without, those lanes go through the one-lane code
/// (`unit::sample_cube_with`; the same values either way).
#[inline(always)]
pub fn sample_cube_lanes<const N: usize>(
    c: &TextureCube,
    borders: Option<&CubeBorders>,
    d: [&[f32; N]; 3],
    n: usize,
    filter: Filter,
    weights: WeightChoice,
    out: &mut [[f32; N]; 4],
) -> bool {
    if filter == Filter::Nearest || weights != WeightChoice::Model {
        return false;
    }
    let level0 = &c.faces[0].levels[0];
    let (w, h) = (level0.width as f32, level0.height as f32);
    let size = level0.width as i64;
    // Face selection (GL's Table 3.19, `sampling::cube_face_uv`) as selects.
    let mut face = [0u32; N];
    let mut fx = [0.0f32; N];
    let mut fy = [0.0f32; N];
    for lane in 0..N {
        let fin = |c: f32| if c.is_finite() { c } else { 0.0 };
        let r = [fin(d[0][lane]), fin(d[1][lane]), fin(d[2][lane])];
        let a = [r[0].abs(), r[1].abs(), r[2].abs()];
        let x_major = a[0] >= a[1] && a[0] >= a[2];
        let y_major = !x_major && a[1] >= a[2];
        let (f, sc, tc, ma) = if x_major {
            if r[0] >= 0.0 {
                (0, -r[2], -r[1], a[0])
            } else {
                (1, r[2], -r[1], a[0])
            }
        } else if y_major {
            if r[1] >= 0.0 {
                (2, r[0], r[2], a[1])
            } else {
                (3, r[0], -r[2], a[1])
            }
        } else if r[2] >= 0.0 {
            (4, r[0], -r[1], a[2])
        } else {
            (5, -r[0], -r[1], a[2])
        };
        let (f, s, t) =
            if ma == 0.0 { (0, 0.5, 0.5) } else { (f, 0.5 * (sc / ma + 1.0), 0.5 * (tc / ma + 1.0)) };
        face[lane] = f;
        fx[lane] = finite(s * w - 0.5);
        fy[lane] = finite(t * h - 0.5);
    }
    // `sampling::floor_finite` (the coordinates are within ±1e9) as lanes:
    // it and `floor` differ only at −0, which `s·w − 0.5` never is.
    let (mut x0, mut y0, mut ax, mut ay) = ([0.0f32; N], [0.0f32; N], [0.0f32; N], [0.0f32; N]);
    for l in 0..N {
        (x0[l], y0[l]) = (floor_lane(fx[l]), floor_lane(fy[l]));
        (ax[l], ay[l]) = (fx[l] - x0[l], fy[l] - y0[l]);
    }
    if let Some(b) = borders.filter(|b| b.n as i64 == size) {
        bordered_cube_lanes(c, b, d, n, (filter, weights), (&face, &x0, &y0, &ax, &ay), out);
        return true;
    }
    for lane in 0..n {
        let (x, y) = (whole_i32(x0[lane]) as i64, whole_i32(y0[lane]) as i64);
        let texel = if x >= 0 && y >= 0 && x + 1 < size && y + 1 < size {
            let texels = &c.faces[face[lane] as usize].levels[0].texels;
            let at = (y * size + x) as usize;
            let s = size as usize;
            bilinear4(texels[at], texels[at + 1], texels[at + s], texels[at + s + 1], ax[lane], ay[lane])
        } else {
            let direction = [d[0][lane], d[1][lane], d[2][lane]];
            unit::sample_cube_with(c, direction, filter, weights)
        };
        for (k, x) in texel.into_iter().enumerate() {
            out[k][lane] = x;
        }
    }
    true
}

/// [`sample_cube_lanes`]' filtering from the bordered faces `b`: each
/// lane's footprint (face, top-left texel `x0`, `y0`, weights `ax`, `ay`)
/// read from the borders, all lanes at once where every lane's footprint
/// is within them, else lane by lane (a lane outside through the one-lane
/// code).
#[inline(always)]
#[allow(clippy::type_complexity, reason = "the footprints' five lane arrays")]
fn bordered_cube_lanes<const N: usize>(
    c: &TextureCube,
    b: &CubeBorders,
    d: [&[f32; N]; 3],
    n: usize,
    (filter, weights): (Filter, WeightChoice),
    (face, x0, y0, ax, ay): (&[u32; N], &[f32; N], &[f32; N], &[f32; N], &[f32; N]),
    out: &mut [[f32; N]; 4],
) {
    let (s, last) = (b.n + 2, b.n as i32 - 1);
    // Each lane's footprint in the bordered faces: −1 ≤ x, y < n, the
    // coordinates being within the face's [−½, n − ½].
    let (mut at, mut inside) = ([[0u32; N]; 4], true);
    let (row, side) = (s as i32, (s * s) as i32);
    for lane in 0..N {
        let (x, y) = (whole_i32(x0[lane]), whole_i32(y0[lane]));
        // Without branches (vector code): a lane outside reads texel 0.
        let fits = (x >= -1) & (y >= -1) & (x <= last) & (y <= last);
        inside &= fits | (lane >= n);
        let a = if fits { face[lane] as i32 * side + (y + 1) * row + (x + 1) } else { 0 } as u32;
        (at[0][lane], at[1][lane], at[2][lane], at[3][lane]) = (a, a + 1, a + row as u32, a + row as u32 + 1);
    }
    if inside {
        bilinear_lanes(&b.texels, (&at, ax, ay), n, out);
        return;
    }
    for lane in 0..n {
        let (x, y) = (whole_i32(x0[lane]), whole_i32(y0[lane]));
        let texel = if x >= -1 && y >= -1 && x <= last && y <= last {
            let t = |c: usize| b.texels[at[c][lane] as usize];
            bilinear4(t(0), t(1), t(2), t(3), ax[lane], ay[lane])
        } else {
            unit::sample_cube_with(c, [d[0][lane], d[1][lane], d[2][lane]], filter, weights)
        };
        for (k, x) in texel.into_iter().enumerate() {
            out[k][lane] = x;
        }
    }
}

/// A cube map's faces (level 0) bordered by one texel of their seams, as
/// [`sample_cube_lanes`] reads them: a lane whose bilinear footprint leaves
/// its face reads the adjacent face's texels (or a corner's average) from
/// the border instead of going through the one-lane code, the same values
/// (the border is that code's texels, `unit::cube_bordered_faces`). Built
/// per pass for faces of at most [`CubeBorders::MAX`] texels a side.
pub struct CubeBorders {
    n: usize,
    /// The six bordered faces one after the other, `(n + 2)²` texels each.
    texels: Vec<[f32; 4]>,
}

impl CubeBorders {
    /// The largest face bordered (6·66² texels, 0.4 MB, built once per pass
    /// and frame; a larger cube map keeps the one-lane code at its seams).
    pub const MAX: u32 = 64;

    /// `c`'s bordered faces, or `None` for faces that are not squares of
    /// one size up to [`CubeBorders::MAX`].
    pub fn of(c: &TextureCube) -> Option<CubeBorders> {
        let n = c.faces[0].levels.first()?.width;
        let square = |f: &Texture2D| f.levels.first().is_some_and(|l| (l.width, l.height) == (n, n));
        (n > 0 && n <= CubeBorders::MAX && c.faces.iter().all(square))
            .then(|| CubeBorders { n: n as usize, texels: unit::cube_bordered_faces(c).concat() })
    }
}

/// The most levels [`sample_2d_lanes`] takes as lanes (a 32768² chain has
/// 16); a longer chain goes lane by lane.
const MAX_LEVELS: usize = 16;

/// A texture's levels as the lanes index them: each level's size as f32
/// (the coordinates' scale) and as the largest texel index, and whether
/// coordinates wrap with a mask (repeat, every level a power of two) or
/// clamp to the edge.
#[derive(Clone, Copy)]
pub struct Levels {
    /// How many levels the chain has (the tables past it are unused).
    count: usize,
    w: [f32; MAX_LEVELS],
    h: [f32; MAX_LEVELS],
    w_last: [i32; MAX_LEVELS],
    h_last: [i32; MAX_LEVELS],
    repeat: bool,
    /// Level 0's size where every level `k` is `max(size >> k, 1)` (the
    /// halving chain of GL 2.1 §3.8.8, which `with_box_mipmaps` builds):
    /// then a lane's level size is two shifts (vector code) instead of a
    /// table lookup per lane, whose scalar stores the vector loads after it
    /// wait for.
    halving: Option<(u32, u32)>,
}

impl PartialEq for Levels {
    /// Field by field, but a halving chain's tables are its level 0's
    /// size and its count ([`Levels::of`] builds them so, the tables past
    /// the count as `Levels::EMPTY`'s): two such chains compare by those
    /// alone (the tables' compare was ~0.8 % of a frame's samples, once
    /// per batch for a shared lookup, BENCHMARKS.md, exec10).
    fn eq(&self, o: &Levels) -> bool {
        (self.count, self.repeat, self.halving) == (o.count, o.repeat, o.halving)
            && (self.halving.is_some()
                || (self.w, self.h, self.w_last, self.h_last) == (o.w, o.h, o.w_last, o.h_last))
    }
}

impl Levels {
    /// No texture's levels (no chain has 0 levels).
    const EMPTY: Levels = Levels {
        count: 0,
        w: [1.0; MAX_LEVELS],
        h: [1.0; MAX_LEVELS],
        w_last: [0; MAX_LEVELS],
        h_last: [0; MAX_LEVELS],
        repeat: false,
        halving: None,
    };

    /// `None` where the lanes do not cover the texture: repeat on a size
    /// that is not a power of two (a remainder per texel), or too many levels.
    /// A caller that looks one texture up batch after batch computes them
    /// once ([`Footprints2d::refill_with`], [`Footprints2d::fits_levels`]).
    pub fn of(t: &Texture2D) -> Option<Levels> {
        if t.levels.len() > MAX_LEVELS {
            return None;
        }
        let repeat = t.wrap == Wrap::Repeat;
        let pot = |x: u32| x.is_power_of_two();
        if repeat && !t.levels.iter().all(|l| pot(l.width) && pot(l.height)) {
            return None;
        }
        let mut s = Levels { count: t.levels.len(), repeat, ..Levels::EMPTY };
        let (w0, h0) = (t.levels[0].width, t.levels[0].height);
        let mut halving = true;
        for (k, l) in t.levels.iter().enumerate() {
            (s.w[k], s.h[k]) = (l.width as f32, l.height as f32);
            (s.w_last[k], s.h_last[k]) = (l.width as i32 - 1, l.height as i32 - 1);
            halving &= (l.width, l.height) == ((w0 >> k).max(1), (h0 >> k).max(1));
        }
        s.halving = halving.then_some((w0, h0));
        Some(s)
    }
}

/// The bilinear footprints of `N` lanes, each on its own level: the four
/// texels' indices (x0y0, x1y0, x0y1, x1y1) in their level and the weights.
#[derive(Clone, Copy)]
struct Footprints<const N: usize> {
    at: [[u32; N]; 4],
    ax: [f32; N],
    ay: [f32; N],
}

/// `Level::sample_bilinear`'s coordinates, weights and wrapped texel
/// indices for each lane at (`u`, `v`) on level `level[lane]`, as
/// fixed-length loops: the same formulas (with i32 where it has i64:
/// `finite` keeps the coordinates within ±1e9), so the same values. The
/// levels' sizes are looked up first, in a loop of their own: a table
/// lookup inside the arithmetic keeps it from becoming vector code.
// Indexed loops over several lane arrays at once are the form that vectorises.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn footprints<const N: usize>(s: &Levels, level: &[u32; N], u: &[f32; N], v: &[f32; N]) -> Footprints<N> {
    let (mut w, mut h, mut wl, mut hl) = ([0.0f32; N], [0.0f32; N], [0i32; N], [0i32; N]);
    match s.halving {
        Some((w0, h0)) => {
            for lane in 0..N {
                // A lane's level is one of the chain's (< MAX_LEVELS ≤ 31).
                let k = level[lane] % MAX_LEVELS as u32;
                let (lw, lh) = ((w0 >> k).max(1), (h0 >> k).max(1));
                (w[lane], h[lane], wl[lane], hl[lane]) = (lw as f32, lh as f32, lw as i32 - 1, lh as i32 - 1);
            }
        }
        None => {
            for lane in 0..N {
                let k = level[lane] as usize % MAX_LEVELS;
                (w[lane], h[lane], wl[lane], hl[lane]) = (s.w[k], s.h[k], s.w_last[k], s.h_last[k]);
            }
        }
    }
    let mut f = Footprints { at: [[0; N]; 4], ax: [0.0; N], ay: [0.0; N] };
    // Repeat (a mask) or clamp to the edge: both computed, one kept (a select).
    let repeat = s.repeat;
    for lane in 0..N {
        let fx = finite(u[lane] * w[lane] - 0.5);
        let fy = finite(v[lane] * h[lane] - 0.5);
        // ⌊f⌋ (+ 0: −0 as the truncation this replaced gave it, +0; one
        // `vroundps`, where the truncation was a conversion, a compare, a
        // subtraction and a select, ~3 % of a frame's samples).
        let (x0, y0) = (floor_lane(fx) + 0.0, floor_lane(fy) + 0.0);
        (f.ax[lane], f.ay[lane]) = (fx - x0, fy - y0);
        let (x0, y0) = (whole_i32(x0), whole_i32(y0));
        let (wl, hl) = (wl[lane], hl[lane]);
        let wrap = |c: i32, last: i32| if repeat { c & last } else { c.max(0).min(last) };
        let (xa, xb) = (wrap(x0, wl), wrap(x0.wrapping_add(1), wl));
        let (ya, yb) = (wrap(y0, hl).wrapping_mul(wl + 1), wrap(y0.wrapping_add(1), hl).wrapping_mul(wl + 1));
        f.at[0][lane] = ya.wrapping_add(xa) as u32;
        f.at[1][lane] = ya.wrapping_add(xb) as u32;
        f.at[2][lane] = yb.wrapping_add(xa) as u32;
        f.at[3][lane] = yb.wrapping_add(xb) as u32;
    }
    f
}

/// Lane `lane`'s footprint in `f` on `level` filtered.
#[inline(always)]
fn filtered<const N: usize>(level: &Level, f: &Footprints<N>, lane: usize) -> [f32; 4] {
    let t = |c: usize| level.texels[f.at[c][lane] as usize];
    bilinear4(t(0), t(1), t(2), t(3), f.ax[lane], f.ay[lane])
}

/// Lanes `0..n` of a 2-D lookup at (`u`, `v`) with levels of detail `lod`
/// into `out`, as [`unit::sample_2d_with`] with float arithmetic and the
/// model's choices. Each lane's level (or two, trilinear), coordinates,
/// weights and texel indices are computed as fixed-length loops (vector
/// code, [`Footprints2d::of`]); then a loop over the lanes fetches each
/// footprint's four texels and filters them as one 4-wide vector
/// ([`Footprints2d::fetch`]). A lookup the vector code does not cover
/// (nearest filtering, another latitude, a texture the level table does
/// not cover) runs lane by lane through the one-lane unit.
#[inline(always)]
#[allow(clippy::too_many_arguments, reason = "the lanes of one lookup and its one texture's state")]
pub fn sample_2d_lanes<const N: usize>(
    t: &Texture2D,
    u: &[f32; N],
    v: &[f32; N],
    lod: &[f32; N],
    n: usize,
    filter: Filter,
    latitude: unit::Latitude,
    out: &mut [[f32; N]; 4],
) {
    match Footprints2d::of(t, u, v, lod, filter, latitude) {
        Some(f) => f.fetch(t, n, out),
        None => sample_2d_lane_by_lane(t, u, v, lod, n, filter, latitude, out),
    }
}

/// What a 2-D lookup over `N` lanes computes before it reads a texel:
/// each lane's level (or two), its footprints' texel indices and weights.
/// They depend on the texture only through its levels' sizes and its wrap
/// mode, so two textures of the same shape looked up at the same
/// coordinates with the same levels of detail (Kilgard's decal and normal
/// map, both at the torus's `u`) share them: [`Footprints2d::fits`], then
/// [`Footprints2d::fetch`] from each — the values [`sample_2d_lanes`] gives
/// for each texture alone, bit for bit (the same formulas on the same inputs).
pub struct Footprints2d<const N: usize> {
    levels: Levels,
    filter: Filter,
    /// Trilinear: ⌊λ⌋ and ⌊λ⌋ + 1 blended by λ's fraction, or one level
    /// (`single`); else bilinear on the level nearest to λ (GL's
    /// LINEAR_MIPMAP_NEAREST), `level0` and `fa` alone.
    trilinear: bool,
    level0: [u32; N],
    level1: [u32; N],
    single: [bool; N],
    fraction: [f32; N],
    fa: Footprints<N>,
    fb: Footprints<N>,
}

impl<const N: usize> Default for Footprints2d<N> {
    fn default() -> Self {
        let none = Footprints { at: [[0; N]; 4], ax: [0.0; N], ay: [0.0; N] };
        Footprints2d {
            levels: Levels::EMPTY,
            filter: Filter::Nearest,
            trilinear: false,
            level0: [0; N],
            level1: [0; N],
            single: [true; N],
            fraction: [0.0; N],
            fa: none,
            fb: none,
        }
    }
}

impl<const N: usize> Footprints2d<N> {
    /// The footprints of the lookup of `t` at (`u`, `v`) with levels of
    /// detail `lod`, or `None` where the lanes do not cover it (nearest
    /// filtering, another latitude than the model's, repeat on a size that
    /// is not a power of two, more than 16 levels).
    #[inline(always)]
    pub fn of(
        t: &Texture2D,
        u: &[f32; N],
        v: &[f32; N],
        lod: &[f32; N],
        filter: Filter,
        latitude: unit::Latitude,
    ) -> Option<Footprints2d<N>> {
        let mut f = Footprints2d::default();
        f.refill(t, u, v, lod, filter, latitude).then_some(f)
    }

    /// [`Footprints2d::of`] in place (a batch's footprints are kilobytes:
    /// moving them cost ~1 % of a frame): whether the lanes cover the
    /// lookup; if not, the footprints fit no texture.
    #[inline(always)]
    pub fn refill(
        &mut self,
        t: &Texture2D,
        u: &[f32; N],
        v: &[f32; N],
        lod: &[f32; N],
        filter: Filter,
        latitude: unit::Latitude,
    ) -> bool {
        self.refill_with(Levels::of(t).as_ref(), t, (u, v, lod), filter, latitude)
    }

    /// [`Footprints2d::refill`] with `t`'s levels computed before
    /// (`levels`: [`Levels::of`] of `t`, which must be `t`'s).
    // Indexed loops over several lane arrays at once are the form that vectorises.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    pub fn refill_with(
        &mut self,
        levels: Option<&Levels>,
        t: &Texture2D,
        (u, v, lod): (&[f32; N], &[f32; N], &[f32; N]),
        filter: Filter,
        latitude: unit::Latitude,
    ) -> bool {
        debug_assert!(levels.copied() == Levels::of(t), "the levels of another texture");
        let covered = filter != Filter::Nearest && latitude == unit::Latitude::MODEL;
        let Some(s) = levels.copied().filter(|_| covered) else {
            self.filter = Filter::Nearest;
            return false;
        };
        let last = (t.levels.len() - 1) as f32;
        // λ as `unit::sample_2d_with` takes it (the model's choice adds nothing).
        let mut lod_in = [0.0f32; N];
        for l in 0..N {
            lod_in[l] =
                if lod[l].is_nan() { f32::NEG_INFINITY } else { LodChoice::Model.apply(lod[l] + 0.0) };
        }
        let lod = &lod_in;
        (self.levels, self.filter, self.trilinear) = (s, filter, filter == Filter::Trilinear);
        if filter == Filter::Bilinear {
            for l in 0..N {
                // λ > 0 (NaN is −∞ above): ⌊λ + ½⌋ ≥ 0, at most `last`.
                self.level0[l] =
                    if lod[l] <= 0.0 { 0 } else { whole_i32(floor_lane(lod[l] + 0.5).min(last)) as u32 };
            }
            self.fa = footprints(&self.levels, &self.level0, u, v);
        } else {
            trilinear_levels(
                lod,
                last,
                (&mut self.level0, &mut self.level1, &mut self.single, &mut self.fraction),
            );
            self.fa = footprints(&self.levels, &self.level0, u, v);
            // The second level's footprints only where some lane blends two
            // levels: a magnified batch (λ ≤ 0, every lane on level 0, most
            // of Kilgard's torus from 1024² on) reads none of them.
            if self.single.iter().any(|&one| !one) {
                self.fb = footprints(&self.levels, &self.level1, u, v);
            }
        }
        true
    }

    /// Whether these footprints are `t`'s for the same coordinates, levels
    /// of detail and `filter`: its levels have the same sizes and it wraps
    /// the same way (the model's latitude, which [`Footprints2d::of`]
    /// requires, is the caller's to keep).
    #[inline(always)]
    pub fn fits(&self, t: &Texture2D, filter: Filter) -> bool {
        self.fits_levels(Levels::of(t).as_ref(), filter)
    }

    /// [`Footprints2d::fits`] of a texture whose [`Levels::of`] is `levels`.
    #[inline(always)]
    pub fn fits_levels(&self, levels: Option<&Levels>, filter: Filter) -> bool {
        filter == self.filter && levels.is_some_and(|s| *s == self.levels)
    }

    /// Lanes `0..n` of the lookup of `t` (one these footprints
    /// [`Footprints2d::fits`]): each footprint's four texels fetched and
    /// filtered, into `out`.
    #[inline(always)]
    pub fn fetch(&self, t: &Texture2D, n: usize, out: &mut [[f32; N]; 4]) {
        let n = n.min(N);
        let (level0, level1, fa, fb) = (&self.level0, &self.level1, &self.fa, &self.fb);
        if !self.trilinear || self.single[..n].iter().all(|&one| one) {
            // One level per lane (a trilinear lane on one level is that
            // level's bilinear sample, as below).
            let first = level0[0];
            if level0[..n].iter().all(|&k| k == first) {
                return fetch_one_level(&t.levels[first as usize], fa, n, out);
            }
            for lane in 0..n {
                let texel = filtered(&t.levels[level0[lane] as usize], fa, lane);
                (0..4).for_each(|k| out[k][lane] = texel[k]);
            }
            return;
        }
        for lane in 0..n {
            let a = filtered(&t.levels[level0[lane] as usize], fa, lane);
            let texel = if self.single[lane] {
                a
            } else {
                let b = filtered(&t.levels[level1[lane] as usize], fb, lane);
                let f = self.fraction[lane];
                [
                    a[0] + f * (b[0] - a[0]),
                    a[1] + f * (b[1] - a[1]),
                    a[2] + f * (b[2] - a[2]),
                    a[3] + f * (b[3] - a[3]),
                ]
            };
            (0..4).for_each(|k| out[k][lane] = texel[k]);
        }
    }
}

/// Lanes `0..n` of footprints `f`, every lane on `level`, filtered into
/// `out` ([`bilinear_lanes`]).
#[inline(always)]
fn fetch_one_level<const N: usize>(level: &Level, f: &Footprints<N>, n: usize, out: &mut [[f32; N]; 4]) {
    bilinear_lanes(&level.texels, (&f.at, &f.ax, &f.ay), n, out);
}

/// Lanes `0..n` of bilinear footprints in one texel array: lane `l`'s
/// texels `at[0..4][l]` (x0y0, x1y0, x0y1, x1y1) weighted by `ax[l]`,
/// `ay[l]` as [`bilinear4`] weights them, into `out` (the lanes past `n`
/// get values no one reads). The indices are checked against `texels`
/// once for the batch (their largest); then, on a CPU with AVX2, eight
/// lanes at a time, two lanes' texels a vector
/// ([`bilinear_paired`]) — the same operations per lane in the same
/// order, so the same values. Else lane by lane.
// Indexed loops over several lane arrays at once are the form that vectorises.
#[allow(clippy::needless_range_loop)]
#[allow(clippy::type_complexity, reason = "one footprint's three lane arrays")]
#[inline(always)]
fn bilinear_lanes<const N: usize>(
    texels: &[[f32; 4]],
    (at, ax, ay): (&[[u32; N]; 4], &[f32; N], &[f32; N]),
    n: usize,
    out: &mut [[f32; N]; 4],
) {
    let n = n.min(N);
    let mut most = [0u32; N];
    for at in at {
        for lane in 0..N {
            // Lanes past `n` hold another batch's indices, not read.
            most[lane] = most[lane].max(if lane < n { at[lane] } else { 0 });
        }
    }
    let most = most.into_iter().fold(0, u32::max);
    if most as usize >= texels.len() {
        // Not reached (the indices are wrapped or clamped into the texels);
        // the checked indexing keeps it safe if a level's texels disagree with its size.
        for lane in 0..n {
            let t = |c: usize| texels[at[c][lane] as usize];
            let texel = bilinear4(t(0), t(1), t(2), t(3), ax[lane], ay[lane]);
            (0..4).for_each(|k| out[k][lane] = texel[k]);
        }
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2; the lanes below `n` index within
        // `texels` (checked above) and the others are clamped into it.
        unsafe { bilinear_paired(texels, (at, ax, ay), n, out) };
        return;
    }
    for lane in 0..n {
        // SAFETY: every index of lanes `0..n` is below `texels.len()` (checked above).
        let t = |c: usize| unsafe { *texels.get_unchecked(at[c][lane] as usize) };
        let texel = bilinear4(t(0), t(1), t(2), t(3), ax[lane], ay[lane]);
        (0..4).for_each(|k| out[k][lane] = texel[k]);
    }
}

/// [`bilinear_lanes`] eight lanes at a time with AVX2 (the lanes past a
/// multiple of eight one by one). Each lane's value is [`bilinear4`]'s:
/// `a + w·(b − a)` per channel, top, bottom, then between them, no fused
/// operation. Two lanes share a vector, each in one half with its four
/// channels (lanes `l + j` and `l + j + 4`): each texel is one 16-byte
/// load into its half, each weight a broadcast, and the four vectors of
/// results are transposed into the eight lanes of each channel (two
/// shuffles per vector). Gathering each channel of eight lanes
/// (`vgatherdps`, 16 gathers per eight footprints) took 1.6× as long in a
/// stand-alone loop on the project's Xeon (BENCHMARKS.md, exec10).
///
/// # Safety
/// The CPU has AVX2; `texels` is not empty and the indices of lanes `0..n`
/// are below its length.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(clippy::type_complexity, reason = "one footprint's three lane arrays")]
unsafe fn bilinear_paired<const N: usize>(
    texels: &[[f32; 4]],
    (at, ax, ay): (&[[u32; N]; 4], &[f32; N], &[f32; N]),
    n: usize,
    out: &mut [[f32; N]; 4],
) {
    use std::arch::x86_64::*;
    let base = texels.as_ptr() as *const f32;
    // Lanes past `n` may index anywhere: clamped to the last texel.
    let last = texels.len() as u32 - 1;
    let mut l = 0;
    while l + 8 <= N {
        let (sub, mul, add) = (_mm256_sub_ps, _mm256_mul_ps, _mm256_add_ps);
        let mut r = [_mm256_setzero_ps(); 4];
        for (j, r) in r.iter_mut().enumerate() {
            let (a, b) = (l + j, l + j + 4);
            // SAFETY: every index is within `texels` (clamped): four floats each.
            let texel = |c: usize| {
                let lo = base.add(4 * at[c][a].min(last) as usize);
                let hi = base.add(4 * at[c][b].min(last) as usize);
                _mm256_loadu2_m128(hi, lo)
            };
            let (t00, t10, t01, t11) = (texel(0), texel(1), texel(2), texel(3));
            let both = |w: &[f32; N]| {
                _mm256_blend_ps::<0xF0>(_mm256_broadcast_ss(&w[a]), _mm256_broadcast_ss(&w[b]))
            };
            let (wx, wy) = (both(ax), both(ay));
            let top = add(t00, mul(wx, sub(t10, t00)));
            let bottom = add(t01, mul(wx, sub(t11, t01)));
            *r = add(top, mul(wy, sub(bottom, top)));
        }
        // r[j]: lane l + j's channels, then lane l + j + 4's; transposed
        // within each half, channel k's vector is lanes l..l + 8.
        let (lo, hi) = (_mm256_unpacklo_ps, _mm256_unpackhi_ps);
        let (t0, t1, t2, t3) = (lo(r[0], r[1]), hi(r[0], r[1]), lo(r[2], r[3]), hi(r[2], r[3]));
        let (pd, ps) = (_mm256_castps_pd, _mm256_castpd_ps);
        let channels = [
            ps(_mm256_unpacklo_pd(pd(t0), pd(t2))),
            ps(_mm256_unpackhi_pd(pd(t0), pd(t2))),
            ps(_mm256_unpacklo_pd(pd(t1), pd(t3))),
            ps(_mm256_unpackhi_pd(pd(t1), pd(t3))),
        ];
        for (out, c) in out.iter_mut().zip(channels) {
            // SAFETY: `l + 8 <= N`: eight lanes of each array.
            _mm256_storeu_ps(out.as_mut_ptr().add(l), c);
        }
        l += 8;
    }
    for lane in l..n {
        let t = |c: usize| texels[at[c][lane] as usize];
        let texel = bilinear4(t(0), t(1), t(2), t(3), ax[lane], ay[lane]);
        (0..4).for_each(|k| out[k][lane] = texel[k]);
    }
}

/// Trilinear filtering's levels per lane: ⌊λ⌋ and ⌊λ⌋ + 1 blended by
/// λ's fraction, or one level (0 for λ < 0, infinite λ or a single level;
/// the last beyond it) — the levels, whether one, and the fraction, into
/// the four lane arrays given.
#[inline(always)]
#[allow(clippy::type_complexity, reason = "four lane arrays of one choice")]
fn trilinear_levels<const N: usize>(
    lod: &[f32; N],
    last: f32,
    (level0, level1, single, fraction): (&mut [u32; N], &mut [u32; N], &mut [bool; N], &mut [f32; N]),
) {
    for l in 0..N {
        let floor = floor_lane(lod[l]);
        let low = lod[l].is_infinite() || floor < 0.0 || last == 0.0;
        single[l] = low || floor >= last;
        level0[l] = if low {
            0
        } else if single[l] {
            last as u32
        } else {
            // 0 ≤ ⌊λ⌋ < last here.
            whole_i32(floor) as u32
        };
        level1[l] = level0[l] + !single[l] as u32;
        fraction[l] = lod[l] - floor;
    }
}

/// [`sample_2d_lanes`] one lane at a time, for the lookups its vector
/// code does not cover.
#[allow(clippy::too_many_arguments, reason = "the lanes of one lookup and its one texture's state")]
fn sample_2d_lane_by_lane<const N: usize>(
    t: &Texture2D,
    u: &[f32; N],
    v: &[f32; N],
    lod: &[f32; N],
    n: usize,
    filter: Filter,
    latitude: unit::Latitude,
    out: &mut [[f32; N]; 4],
) {
    for lane in 0..n {
        let texel =
            unit::sample_2d_with(t, u[lane], v[lane], filter, lod[lane], unit::Arithmetic::Float, latitude);
        (0..4).for_each(|k| out[k][lane] = texel[k]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each of the first `n` lanes of `out` is the one-lane unit's sample at
    /// that lane's coordinates and level of detail, bit for bit.
    fn assert_lanes_are_the_unit(
        t: &Texture2D,
        (u, v, lod): (&[f32; 32], &[f32; 32], &[f32; 32]),
        filter: Filter,
        out: &[[f32; 32]; 4],
        n: usize,
        what: &str,
    ) {
        for lane in 0..n {
            let one = unit::sample_2d_with(
                t,
                u[lane],
                v[lane],
                filter,
                lod[lane],
                unit::Arithmetic::Float,
                unit::Latitude::MODEL,
            );
            let lanes = [0, 1, 2, 3].map(|k| out[k][lane]);
            assert_eq!(one.map(f32::to_bits), lanes.map(f32::to_bits), "{what} lane {lane}");
        }
    }
    use crate::textures::sampling::TexelFormat;

    /// A deterministic sequence in [−1, 1) (no dependency for a test).
    fn numbers(seed: u32) -> impl FnMut() -> f32 {
        let mut x = seed.wrapping_mul(2_654_435_761).max(1);
        move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x >> 8) as f32 / (1u32 << 23) as f32 - 1.0
        }
    }

    fn level(w: u32, h: u32, seed: u32) -> Level {
        let mut r = numbers(seed);
        Level::new(w, h, (0..w * h).map(|_| [r(), r(), r(), r()]).collect())
    }

    #[test]
    fn cube_lanes_are_the_one_lane_unit_bit_for_bit() {
        let faces = std::array::from_fn(|f| {
            Texture2D::new(TexelFormat::F32, Wrap::ClampToEdge, level(8, 8, 7 + f as u32))
        });
        let cube = TextureCube { faces };
        let bordered = CubeBorders::of(&cube);
        assert!(bordered.is_some());
        let (mut seams, mut corners) = (0, 0);
        let mut r = numbers(3);
        for round in 0..64 {
            let mut d = [[0.0f32; 32]; 3];
            for lane in 0..32 {
                d.iter_mut().for_each(|c| c[lane] = r() * 3.0);
            }
            // Ties between axes, zeros and non-finite components, on the faces' edges.
            d[0][0] = d[1][0];
            d[2][1] = 0.0;
            d[1][2] = f32::NAN;
            d[0][3] = -d[2][3];
            // Near the cube's corners: footprints beyond two edges of a face.
            (d[0][4], d[1][4], d[2][4]) = (1.0, 0.99, 0.98);
            (d[0][5], d[1][5], d[2][5]) = (-0.97, -1.0, 0.985 + r() * 0.01);
            let [x, y, z] = &d;
            let n = 32 - round % 5;
            for borders in [None, bordered.as_ref()] {
                let mut out = [[0.0f32; 32]; 4];
                let (f, w) = (Filter::Bilinear, WeightChoice::Model);
                assert!(sample_cube_lanes(&cube, borders, [x, y, z], n, f, w, &mut out));
                for lane in 0..n {
                    let one = unit::sample_cube_with(&cube, [x[lane], y[lane], z[lane]], f, w);
                    let lanes = [0, 1, 2, 3].map(|k| out[k][lane]);
                    let what = if borders.is_some() { "bordered" } else { "plain" };
                    assert_eq!(
                        one.map(f32::to_bits),
                        lanes.map(f32::to_bits),
                        "{what}: lane {lane} of round {round}"
                    );
                    if borders.is_some() {
                        // The lanes whose footprint leaves the face, and those at a corner.
                        let (_, s, t) = crate::textures::cube_face_uv([x[lane], y[lane], z[lane]]);
                        let edge = |c: f32| c * 8.0 - 0.5 < 0.0 || c * 8.0 - 0.5 >= 7.0;
                        seams += (edge(s) || edge(t)) as usize;
                        corners += (edge(s) && edge(t)) as usize;
                    }
                }
            }
        }
        assert!(seams > 100 && corners > 60, "{seams} lanes at a seam, {corners} at a corner");
        // Every lane reads the bordered faces (none goes to the one-lane code):
        // faces of another value give that value in every lane.
        let Some(mut other) = bordered else { return };
        other.texels.fill([0.25; 4]);
        let d = [[0.0f32; 32]; 3].map(|_| std::array::from_fn(|_| r() * 3.0));
        let mut out = [[0.0f32; 32]; 4];
        let (f, w) = (Filter::Bilinear, WeightChoice::Model);
        assert!(sample_cube_lanes(&cube, Some(&other), [&d[0], &d[1], &d[2]], 32, f, w, &mut out));
        assert!(out.iter().flatten().all(|&x| x == 0.25));
    }

    /// Every lane of [`sample_2d_lanes`] on `t` against the one-lane unit,
    /// bit for bit, over rounds of random and edge-case lanes.
    fn assert_2d_lanes_are_the_unit(t: &Texture2D, r: &mut impl FnMut() -> f32, what: &str) {
        for (round, filter) in [Filter::Bilinear, Filter::Trilinear].repeat(8).into_iter().enumerate() {
            let mut u = [0.0f32; 32];
            let mut v = [0.0f32; 32];
            let mut lod = [0.0f32; 32];
            for lane in 0..32 {
                (u[lane], v[lane], lod[lane]) = (r() * 3.0, r() * 3.0, r() * 6.0);
            }
            (lod[0], lod[1], lod[2], u[3]) = (f32::NEG_INFINITY, f32::NAN, 40.0, f32::INFINITY);
            // +∞ (level 0 in trilinear), exact levels and halves, huge coordinates.
            (lod[4], lod[5], lod[6], lod[7], lod[8]) = (f32::INFINITY, 1.0, 2.5, 0.0, -0.0);
            (u[9], v[10], v[11]) = (-3e9, f32::NAN, 7.0e8);
            // Coordinates on texel centres and edges, and −0 (floors of whole numbers).
            (u[12], v[12], u[13], v[14]) = (-0.0, -0.0, 0.5, -1.0);
            if round % 4 >= 2 {
                // Magnified (λ ≤ 0): every lane on level 0, filtered eight
                // lanes at a time where the CPU gathers.
                lod.iter_mut().for_each(|l| *l = -r().abs());
            }
            let mut out = [[0.0f32; 32]; 4];
            let n = 32 - round % 3;
            sample_2d_lanes(t, &u, &v, &lod, n, filter, unit::Latitude::MODEL, &mut out);
            assert_lanes_are_the_unit(
                t,
                (&u, &v, &lod),
                filter,
                &out,
                n,
                &format!("{what} {filter:?} round {round}"),
            );
        }
    }

    #[test]
    fn texture_2d_lanes_are_the_one_lane_unit_bit_for_bit() {
        let mut r = numbers(11);
        // Repeat on powers of two and clamp as lanes; repeat on other sizes lane by lane; one level.
        let cases = [
            (Wrap::Repeat, (16, 8), true),
            (Wrap::ClampToEdge, (16, 16), true),
            (Wrap::Repeat, (12, 10), true),
            (Wrap::ClampToEdge, (12, 10), true),
            (Wrap::Repeat, (8, 8), false),
            (Wrap::ClampToEdge, (5, 3), false),
        ];
        for (wrap, (w, h), mipmaps) in cases {
            let t = Texture2D::new(TexelFormat::F32, wrap, level(w, h, w + h));
            let t = if mipmaps { t.with_box_mipmaps() } else { t };
            // The box chains halve: their level sizes are shifts, not the table.
            assert!(Levels::of(&t).is_none_or(|s| s.halving.is_some()), "{wrap:?} {w}×{h}");
            assert_2d_lanes_are_the_unit(&t, &mut r, &format!("{wrap:?} {w}×{h}"));
        }
    }

    /// Footprints computed on one texture and fetched from another of the
    /// same shape (what the lane program shares between two lookups at the
    /// same coordinates) give that other texture's lookups as the one-lane
    /// unit computes them, bit for bit; a texture of another size, wrap
    /// mode or number of levels (a chain one 1×1 level shorter: the same
    /// sizes' tables) does not fit them, nor another filter.
    #[test]
    fn footprints_shared_between_textures_of_one_shape_are_the_one_lane_unit_bit_for_bit() {
        let mut r = numbers(41);
        let chain =
            |wrap, (w, h), seed| Texture2D::new(TexelFormat::F32, wrap, level(w, h, seed)).with_box_mipmaps();
        for (wrap, size) in [(Wrap::Repeat, (16, 8)), (Wrap::ClampToEdge, (12, 10))] {
            let (first, second) = (chain(wrap, size, 1), chain(wrap, size, 2));
            let other_wrap = if wrap == Wrap::Repeat { Wrap::ClampToEdge } else { Wrap::Repeat };
            let mut shorter = chain(wrap, size, 3);
            shorter.levels.pop();
            for (round, filter) in [Filter::Bilinear, Filter::Trilinear].repeat(6).into_iter().enumerate() {
                let (mut u, mut v, mut lod) = ([0.0f32; 32], [0.0f32; 32], [0.0f32; 32]);
                for lane in 0..32 {
                    (u[lane], v[lane], lod[lane]) = (r() * 3.0, r() * 3.0, r() * 6.0);
                }
                (lod[0], lod[1], lod[2], u[3], lod[4]) = (f32::NEG_INFINITY, f32::NAN, 40.0, f32::NAN, 0.5);
                let Some(f) = Footprints2d::of(&first, &u, &v, &lod, filter, unit::Latitude::MODEL) else {
                    panic!("{wrap:?} {size:?} is covered by the lanes")
                };
                assert!(f.fits(&second, filter) && f.fits(&first, filter));
                assert!(!f.fits(&chain(wrap, (size.0 * 2, size.1), 4), filter));
                assert!(!f.fits(&chain(other_wrap, size, 5), filter));
                assert!(!f.fits(&shorter, filter), "{wrap:?} {size:?}: a chain one level shorter");
                let other = if filter == Filter::Bilinear { Filter::Trilinear } else { Filter::Bilinear };
                assert!(!f.fits(&second, other));
                let mut out = [[0.0f32; 32]; 4];
                let n = 32 - round % 3;
                f.fetch(&second, n, &mut out);
                assert_lanes_are_the_unit(
                    &second,
                    (&u, &v, &lod),
                    filter,
                    &out,
                    n,
                    &format!("{filter:?} round {round}"),
                );
            }
        }
    }

    /// A chain whose levels do not halve (a level set by hand) takes its
    /// sizes from the table: the same values as the unit, as the shifts
    /// give them for the halving chains above.
    #[test]
    fn texture_2d_lanes_off_the_halving_chain_are_the_one_lane_unit_bit_for_bit() {
        let mut r = numbers(29);
        for wrap in [Wrap::ClampToEdge, Wrap::Repeat] {
            let levels = vec![level(16, 8, 3), level(4, 8, 4), level(2, 1, 5), level(1, 1, 6)];
            let t = Texture2D { format: TexelFormat::F32, wrap, levels };
            assert!(Levels::of(&t).is_some_and(|s| s.halving.is_none()));
            assert_2d_lanes_are_the_unit(&t, &mut r, &format!("{wrap:?} by hand"));
        }
    }
}
