//! An 8-bit texture's texels as the lanes read them: four bytes a texel
//! instead of four f32, widened to f32 in the filter. An `rgba8` texture
//! holds the values k/255 ([`TexelFormat::quantize`]), which is also what
//! its `Rgba8Unorm` upload gives the wgpu peer; a byte k stands for the f32
//! `k / 255` (correctly rounded), so a footprint widened from bytes
//! filters the very values the f32 texels hold — bit for bit the f32
//! path's result, no tolerance to state — from a quarter of the memory
//! (16 bytes a bilinear footprint instead of 64; a 256² chain 0.33 MB
//! instead of 1.33 MB, within a core's L2). Lavapipe reads its 8-bit
//! textures so (and filters them in 16-bit fixed point; the `f32` mode
//! keeps f32 filtering, `unit`'s docs).

use super::sampling::{TexelFormat, Texture2D};

/// `k / 255` as f32, correctly rounded: the value of an `rgba8` texel k
/// ([`TexelFormat::quantize`] divides so).
#[inline(always)]
fn widen(k: u8) -> f32 {
    k as f32 / 255.0
}

/// A 2-D texture's levels as bytes (level 0 first), where every texel of
/// every level is some k/255 ([`Texels8::of`]).
pub struct Texels8 {
    levels: Vec<Vec<[u8; 4]>>,
}

impl Texels8 {
    /// `t`'s texels as bytes, or `None` where `t` is not an `rgba8`
    /// texture or some texel is not exactly k/255 (a level built
    /// otherwise): the lanes then read its f32 texels.
    pub fn of(t: &Texture2D) -> Option<Texels8> {
        if t.format != TexelFormat::Rgba8 {
            return None;
        }
        let mut exact = true;
        let levels = t
            .levels
            .iter()
            .map(|l| {
                l.texels
                    .iter()
                    .map(|t| {
                        // Saturating (NaN is 0); checked below, so any
                        // rounding that finds k finds it.
                        let k = t.map(|c| (c * 255.0 + 0.5) as u8);
                        for c in 0..4 {
                            exact &= widen(k[c]).to_bits() == t[c].to_bits();
                        }
                        k
                    })
                    .collect()
            })
            .collect();
        exact.then_some(Texels8 { levels })
    }

    /// Level `k`'s texels, row-major.
    #[inline(always)]
    pub(super) fn level(&self, k: usize) -> &[[u8; 4]] {
        &self.levels[k]
    }
}

/// Batches of footprints read from bytes (a test's evidence that a
/// render took this path).
#[cfg(test)]
pub(crate) static READS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Lanes `0..n` of bilinear footprints in one level's bytes: as
/// `lanes::bilinear_lanes` on the f32 texels `k / 255`, the same values
/// (each texel widened first, then the same operations in the same order).
// Indexed loops over several lane arrays at once are the form that vectorises.
#[allow(clippy::needless_range_loop)]
#[allow(clippy::type_complexity, reason = "one footprint's three lane arrays")]
#[inline(always)]
pub(super) fn bilinear_lanes8<const N: usize>(
    texels: &[[u8; 4]],
    (at, ax, ay): (&[[u32; N]; 4], &[f32; N], &[f32; N]),
    n: usize,
    out: &mut [[f32; N]; 4],
) {
    let n = n.min(N);
    #[cfg(test)]
    READS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let mut most = [0u32; N];
    for at in at {
        for lane in 0..N {
            // Lanes past `n` hold another batch's indices, not read.
            most[lane] = most[lane].max(if lane < n { at[lane] } else { 0 });
        }
    }
    let most = most.into_iter().fold(0, u32::max);
    #[cfg(target_arch = "x86_64")]
    if (most as usize) < texels.len()
        && std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma")
    {
        // SAFETY: the CPU has AVX2 and FMA; the lanes below `n` index
        // within `texels` (checked above) and the others are clamped into it.
        unsafe { bilinear_paired8(texels, (at, ax, ay), n, out) };
        return;
    }
    for lane in 0..n {
        let texel = filtered8(texels, (at, ax, ay), lane);
        (0..4).for_each(|k| out[k][lane] = texel[k]);
    }
}

/// Lane `lane`'s footprint widened and filtered as `lanes::bilinear4`.
#[allow(clippy::type_complexity, reason = "one footprint's three lane arrays")]
#[inline(always)]
fn filtered8<const N: usize>(
    texels: &[[u8; 4]],
    (at, ax, ay): (&[[u32; N]; 4], &[f32; N], &[f32; N]),
    lane: usize,
) -> [f32; 4] {
    let t = |c: usize| texels[at[c][lane] as usize].map(widen);
    super::lanes::bilinear4(t(0), t(1), t(2), t(3), ax[lane], ay[lane])
}

/// [`bilinear_lanes8`] eight lanes at a time, as `lanes::bilinear_paired`
/// (two lanes a vector, the same operations), each texel loaded as four
/// bytes and widened: zero-extended to i32 (`vpmovzxbd`), converted, and
/// divided by 255 as one multiplication by the rounded 1/255 corrected by
/// its residual (two fused multiply-adds): correctly rounded for every k
/// (test below), where the multiplication alone misses 126 of the 256.
///
/// # Safety
/// The CPU has AVX2 and FMA; `texels` is not empty and the indices of
/// lanes `0..n` are below its length.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::type_complexity, reason = "one footprint's three lane arrays")]
unsafe fn bilinear_paired8<const N: usize>(
    texels: &[[u8; 4]],
    (at, ax, ay): (&[[u32; N]; 4], &[f32; N], &[f32; N]),
    n: usize,
    out: &mut [[f32; N]; 4],
) {
    use std::arch::x86_64::*;
    let base = texels.as_ptr();
    // Lanes past `n` may index anywhere: clamped to the last texel.
    let last = texels.len() as u32 - 1;
    let (r, k255) = (_mm256_set1_ps(1.0 / 255.0), _mm256_set1_ps(255.0));
    let widen = |k: __m256i| {
        let k = _mm256_cvtepi32_ps(k);
        let q = _mm256_mul_ps(k, r);
        _mm256_fmadd_ps(_mm256_fnmadd_ps(q, k255, k), r, q)
    };
    let mut l = 0;
    while l + 8 <= N {
        let (sub, mul, add) = (_mm256_sub_ps, _mm256_mul_ps, _mm256_add_ps);
        let mut res = [_mm256_setzero_ps(); 4];
        for (j, res) in res.iter_mut().enumerate() {
            let (a, b) = (l + j, l + j + 4);
            // SAFETY: every index is within `texels` (clamped): four bytes each.
            let ld = |c: usize, lane: usize| {
                (base.add(at[c][lane].min(last) as usize) as *const i32).read_unaligned()
            };
            // Corners 0 and 1 of lanes a and b, then 2 and 3: lane a's
            // texel in the low half of each widened vector, b's in the high.
            let x01 = _mm_set_epi32(ld(1, b), ld(1, a), ld(0, b), ld(0, a));
            let x23 = _mm_set_epi32(ld(3, b), ld(3, a), ld(2, b), ld(2, a));
            let high = |x: __m128i| _mm_unpackhi_epi64(x, x);
            let t00 = widen(_mm256_cvtepu8_epi32(x01));
            let t10 = widen(_mm256_cvtepu8_epi32(high(x01)));
            let t01 = widen(_mm256_cvtepu8_epi32(x23));
            let t11 = widen(_mm256_cvtepu8_epi32(high(x23)));
            let both = |w: &[f32; N]| {
                _mm256_blend_ps::<0xF0>(_mm256_broadcast_ss(&w[a]), _mm256_broadcast_ss(&w[b]))
            };
            let (wx, wy) = (both(ax), both(ay));
            let top = add(t00, mul(wx, sub(t10, t00)));
            let bottom = add(t01, mul(wx, sub(t11, t01)));
            *res = add(top, mul(wy, sub(bottom, top)));
        }
        let (lo, hi) = (_mm256_unpacklo_ps, _mm256_unpackhi_ps);
        let (t0, t1, t2, t3) =
            (lo(res[0], res[1]), hi(res[0], res[1]), lo(res[2], res[3]), hi(res[2], res[3]));
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
        let texel = filtered8(texels, (at, ax, ay), lane);
        (0..4).for_each(|k| out[k][lane] = texel[k]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::textures::sampling::{Level, Wrap};

    #[test]
    fn widened_bytes_are_the_quantized_texels() {
        // Every k: the byte's value is the f32 `quantize` stores for k/255.
        for k in 0..=255u8 {
            let stored = TexelFormat::Rgba8.quantize(k as f32 / 255.0);
            assert_eq!(widen(k).to_bits(), stored.to_bits(), "{k}");
        }
        let texels = (0..64u32).map(|i| [i as f32 / 63.0, 0.5, 1.0, 0.0]).collect();
        let t = Texture2D::new(TexelFormat::Rgba8, Wrap::Repeat, Level::new(8, 8, texels)).with_box_mipmaps();
        let b = Texels8::of(&t).unwrap();
        for (k, l) in t.levels.iter().enumerate() {
            let wide: Vec<[f32; 4]> = b.level(k).iter().map(|t| t.map(widen)).collect();
            assert_eq!(wide, l.texels, "level {k}");
        }
        // Not 8-bit, or not k/255: the f32 texels stay.
        let mut f = t.clone();
        f.format = TexelFormat::F32;
        assert!(Texels8::of(&f).is_none());
        let mut off = t.clone();
        off.levels[1].texels[0][2] = 0.3;
        assert!(Texels8::of(&off).is_none());
    }

    /// The byte lanes (AVX2 where the CPU has it, every k in the texels)
    /// are the f32 lanes on the widened texels, bit for bit.
    #[test]
    fn byte_footprints_are_the_f32_footprints_bit_for_bit() {
        let texels8: Vec<[u8; 4]> =
            (0..256u32).map(|i| [i as u8, (255 - i) as u8, (i * 7) as u8, (i * 13 + 5) as u8]).collect();
        let texels: Vec<[f32; 4]> = texels8.iter().map(|t| t.map(widen)).collect();
        let mut x = 12_345u32;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        for n in [32, 31, 17, 8, 5, 0] {
            let at: [[u32; 32]; 4] = std::array::from_fn(|_| std::array::from_fn(|_| next() % 256));
            let ax: [f32; 32] = std::array::from_fn(|_| (next() >> 8) as f32 / (1u32 << 24) as f32);
            let ay: [f32; 32] = std::array::from_fn(|_| (next() >> 8) as f32 / (1u32 << 24) as f32);
            let (mut want, mut got) = ([[0.0f32; 32]; 4], [[0.0f32; 32]; 4]);
            super::super::lanes::bilinear_lanes(&texels, (&at, &ax, &ay), n, &mut want);
            bilinear_lanes8(&texels8, (&at, &ax, &ay), n, &mut got);
            for k in 0..4 {
                let bits = |o: &[[f32; 32]; 4]| o[k][..n].iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got), bits(&want), "n {n} channel {k}");
            }
        }
    }
}
