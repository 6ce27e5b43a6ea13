//! The texture unit of [`super::unit`] over lanes: the lookups of a batch
//! of fragments together (the CPU renderer's `f32` lane code), with this
//! model's choices (`unit::Latitude::MODEL`) and float arithmetic.
//!
//! What runs as lanes: a cube map's face selection, face coordinates,
//! texel addresses and weights (fixed-length loops over `N` lanes that the
//! compiler turns into vector code); a 2-D texture's level choice per lane.
//! The texel fetches stay a loop over the lanes (a gather), each lane's
//! four texels filtered as one 4-wide vector. Every lane computes the
//! formulas of [`unit::sample_cube_with`] and [`unit::sample_2d_with`] in
//! their order, so the values are theirs bit for bit (tests below); a cube
//! lane whose footprint leaves its face (seamless filtering across faces,
//! a few per cent of the lookups) is handed to the one-lane code.

use super::sampling::{floor_finite, Filter, Level, Texture2D, TextureCube, Wrap};
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
#[inline(always)]
pub fn sample_cube_lanes<const N: usize>(
    c: &TextureCube,
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
    let mut face = [0usize; N];
    let mut fx = [0.0f32; N];
    let mut fy = [0.0f32; N];
    for lane in 0..N {
        let r = [d[0][lane], d[1][lane], d[2][lane]].map(|c| if c.is_finite() { c } else { 0.0 });
        let a = r.map(f32::abs);
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
    let x0 = fx.map(floor_finite);
    let y0 = fy.map(floor_finite);
    let ax: [f32; N] = std::array::from_fn(|l| fx[l] - x0[l]);
    let ay: [f32; N] = std::array::from_fn(|l| fy[l] - y0[l]);
    for lane in 0..n {
        let (x, y) = (x0[lane] as i64, y0[lane] as i64);
        let texel = if x >= 0 && y >= 0 && x + 1 < size && y + 1 < size {
            let texels = &c.faces[face[lane]].levels[0].texels;
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

/// The texel of `level` at (x, y), wrapped or clamped (`Level::fetch`).
#[inline(always)]
fn fetch(level: &Level, x: i64, y: i64, wrap: Wrap) -> [f32; 4] {
    let (w, h) = (level.width as i64, level.height as i64);
    let (x, y) = match wrap {
        Wrap::ClampToEdge => (x.clamp(0, w - 1), y.clamp(0, h - 1)),
        Wrap::Repeat if (w & (w - 1)) == 0 && (h & (h - 1)) == 0 => (x & (w - 1), y & (h - 1)),
        Wrap::Repeat => (x.rem_euclid(w), y.rem_euclid(h)),
    };
    level.texels[(y * w + x) as usize]
}

/// `Level::sample_bilinear`: GL bilinear, texel centres at (i + ½)/size.
#[inline(always)]
fn bilinear(level: &Level, u: f32, v: f32, wrap: Wrap) -> [f32; 4] {
    let fx = finite(u * level.width as f32 - 0.5);
    let fy = finite(v * level.height as f32 - 0.5);
    let (x0, y0) = (floor_finite(fx), floor_finite(fy));
    let (ax, ay) = (fx - x0, fy - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let (w, h) = (level.width as i64, level.height as i64);
    if wrap == Wrap::Repeat && (w & (w - 1)) == 0 && (h & (h - 1)) == 0 {
        // The common case without a match per texel: a power-of-two size wraps with a mask.
        let (x1, y1) = ((x0 + 1) & (w - 1), (y0 + 1) & (h - 1));
        let (x0, y0) = (x0 & (w - 1), y0 & (h - 1));
        let t = &level.texels;
        let at = |x: i64, y: i64| t[(y * w + x) as usize];
        return bilinear4(at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1), ax, ay);
    }
    let t = |dx: i64, dy: i64| fetch(level, x0 + dx, y0 + dy, wrap);
    bilinear4(t(0, 0), t(1, 0), t(0, 1), t(1, 1), ax, ay)
}

/// Lanes `0..n` of a 2-D lookup at (`u`, `v`) with levels of detail `lod`
/// into `out`, as [`unit::sample_2d_with`] with float arithmetic and the
/// model's choices: each lane's level (or two, trilinear) chosen from its
/// λ, then filtered. Returns `false`, touching nothing, for a lookup it
/// does not cover (nearest filtering, another latitude).
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
) -> bool {
    if filter == Filter::Nearest || latitude != unit::Latitude::MODEL {
        return false;
    }
    let last = t.levels.len() - 1;
    for lane in 0..n {
        let lod = lod[lane];
        let lod = if lod.is_nan() { f32::NEG_INFINITY } else { LodChoice::Model.apply(lod + 0.0) };
        let at = |level: usize| bilinear(&t.levels[level], u[lane], v[lane], t.wrap);
        let texel = if filter == Filter::Bilinear {
            at(if lod <= 0.0 { 0 } else { ((lod + 0.5).floor() as usize).min(last) })
        } else {
            let floor = lod.floor();
            if lod.is_infinite() || floor < 0.0 || last == 0 {
                at(0)
            } else if floor as usize >= last {
                at(last)
            } else {
                let l0 = floor as usize;
                let (a, b) = (at(l0), at(l0 + 1));
                let fraction = lod - floor;
                [0, 1, 2, 3].map(|c| a[c] + fraction * (b[c] - a[c]))
            }
        };
        for (k, x) in texel.into_iter().enumerate() {
            out[k][lane] = x;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
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
            let [x, y, z] = &d;
            let mut out = [[0.0f32; 32]; 4];
            let n = 32 - round % 5;
            assert!(sample_cube_lanes(&cube, [x, y, z], n, Filter::Bilinear, WeightChoice::Model, &mut out));
            for lane in 0..n {
                let one = unit::sample_cube_with(
                    &cube,
                    [x[lane], y[lane], z[lane]],
                    Filter::Bilinear,
                    WeightChoice::Model,
                );
                let lanes = [0, 1, 2, 3].map(|k| out[k][lane]);
                assert_eq!(one.map(f32::to_bits), lanes.map(f32::to_bits), "lane {lane} of round {round}");
            }
        }
    }

    #[test]
    fn texture_2d_lanes_are_the_one_lane_unit_bit_for_bit() {
        let mut r = numbers(11);
        for (wrap, (w, h)) in
            [(Wrap::Repeat, (16, 8)), (Wrap::ClampToEdge, (16, 16)), (Wrap::Repeat, (12, 10))]
        {
            let t = Texture2D::new(TexelFormat::F32, wrap, level(w, h, w + h)).with_box_mipmaps();
            for filter in [Filter::Bilinear, Filter::Trilinear] {
                let mut u = [0.0f32; 32];
                let mut v = [0.0f32; 32];
                let mut lod = [0.0f32; 32];
                for lane in 0..32 {
                    (u[lane], v[lane], lod[lane]) = (r() * 3.0, r() * 3.0, r() * 6.0);
                }
                (lod[0], lod[1], lod[2], u[3]) = (f32::NEG_INFINITY, f32::NAN, 40.0, f32::INFINITY);
                let mut out = [[0.0f32; 32]; 4];
                assert!(sample_2d_lanes(&t, &u, &v, &lod, 32, filter, unit::Latitude::MODEL, &mut out));
                for lane in 0..32 {
                    let one = unit::sample_2d_with(
                        &t,
                        u[lane],
                        v[lane],
                        filter,
                        lod[lane],
                        unit::Arithmetic::Float,
                        unit::Latitude::MODEL,
                    );
                    let lanes = [0, 1, 2, 3].map(|k| out[k][lane]);
                    assert_eq!(
                        one.map(f32::to_bits),
                        lanes.map(f32::to_bits),
                        "{wrap:?} {filter:?} lane {lane}"
                    );
                }
            }
        }
    }
}
