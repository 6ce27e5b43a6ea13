//! The precision models of the register-combiner emulator (Kilgard
//! 2000, Section 4.2; GeForce3 Phong, Section 5.2): `Fixed9`, the
//! hardware's 8 bits + sign with one rounding per register write, and the
//! float models `F32` and `F64` (`Precision::Exact`). Each is a [`Model`]:
//! the register arithmetic the tile engine and the per-pixel emulator run.

use super::super::config::{Bias, InputMapping, Scale};

pub(super) trait Model {
    /// A register component.
    type R: Copy + Default + Send + Sync;
    /// A mapped input, product or sum, before the output scale and bias.
    type W: Copy + Default + Send + Sync;
    /// A mapped input (narrower than `W` where the model allows: fixed9
    /// keeps it in 16 bits so products use 16-bit vector multiplies).
    type V: Copy + Default + Send + Sync;
    fn from_u8(v: u8) -> Self::R;
    /// A 9-bit signed register value in 1/255 steps (clamped to ±255).
    fn from_i9(v: i16) -> Self::R;
    fn from_unit(v: f32) -> Self::R;
    fn map(m: InputMapping, src: &[Self::R], dst: &mut [Self::V]);
    fn mul(a: &[Self::V], b: &[Self::V], dst: &mut [Self::W]);
    fn mul_add(a: &[Self::V], b: &[Self::V], dst: &mut [Self::W]);
    fn add(a: &[Self::W], b: &[Self::W], dst: &mut [Self::W]);
    /// spare0.a < ½ → AB, else CD.
    fn mux(spare0_alpha: &[Self::R], ab: &[Self::W], cd: &[Self::W], dst: &mut [Self::W]);
    /// Bias, scale, clamp to [−1, 1], store in a register.
    fn output(src: &[Self::W], scale: Scale, bias: Bias, dst: &mut [Self::R]);
    /// Final-combiner input mapping (unsigned identity or invert, after the
    /// clamp of negative values to zero).
    fn final_map(m: InputMapping, src: &[Self::R], dst: &mut [Self::R]);
    fn ef(e: &[Self::R], f: &[Self::R], dst: &mut [Self::R]);
    fn color_sum(spare0: &[Self::R], secondary: &[Self::R], clamp: bool, dst: &mut [Self::R]);
    /// A·B + (1 − A)·C + D, clamped to [0, 1].
    fn lerp_add(a: &[Self::R], b: &[Self::R], c: &[Self::R], d: &[Self::R], dst: &mut [Self::R]);
    fn to_u8(v: Self::R) -> u8;
}

/// 8 bits + sign: registers hold integers in [−255, 255] (units of 1/255).
/// Mapped inputs are exact in units of 1/510, products and sums exact in
/// units of 1/260100; the output scale and bias are exact, and the single
/// rounding (to nearest, ties toward +∞) happens on the register write.
pub(super) struct Fixed9;

/// What the hardware subtracts for "½" in its 8-bit integer units: 128, not
/// 127.5. Evidence: NV2A (NV20 family) golden images of nxdk_pgraph_tests'
/// "Combiner" suite, CombinerOps test, constant colour 0 = (25, 63, 255)/255
/// written through spare0 with each output mapping:
/// `bias_by_negative_one_half()` gives (0, 0, 127) — 255 − 128 — and
/// `bias_by_negative_one_half_scale_by_two()` (0, 0, 254); halving rounds
/// half up (`scale_by_one_half()`: (13, 32, 128)). The bias works on the
/// sum in the register's 8-bit units, where ½ is not a step; the input
/// mappings (`expand`, `half_bias`, and their negates) work in the mapped
/// inputs' units of 1/510, where ½ is exactly 255 steps, so they keep Table
/// 3's ½ — the decision docs/combiners.md records, consistent with the
/// evidence, which does not measure them. Used by this emulator (hence the
/// CPU renderer's fixed9 and `shadec emulate`) and by the WGSL it
/// translates to (`wgsl::rc1`).
pub const HARDWARE_HALF: i16 = 128;

/// `t / 2040` rounded to nearest with ties up, for |t| < 8.3e6: turns a
/// scaled product sum (units of 1/520200) into units of 1/255.
///
/// Integer division by a constant does not vectorize on x86 (there is no
/// 32-bit vector multiply-high), so it is done as 2040 = 8 · 255: a shift,
/// then `div255_floor`, both exact.
#[inline(always)]
pub(super) fn round_2040(t: i32) -> i32 {
    const K: i32 = 4096;
    div255_floor((t + 1020 + 2040 * K) >> 3) - K
}

/// ⌊y / 255⌋ for 0 ≤ y < 2²¹, exactly, with shifts and adds only (so the
/// loop vectorizes): with t = 257·(y + 1), ⌊(t + ⌊t/2¹⁶⌋) / 2¹⁶⌋ = ⌊y/255⌋,
/// since 257·(1 + 2⁻¹⁶)/2¹⁶ approximates 1/255 from above closely enough
/// for this range; t < 2²⁹ fits an i32. `tests::div255_floor_is_exact`
/// checks every y.
#[inline(always)]
pub(super) fn div255_floor(y: i32) -> i32 {
    let t = ((y + 1) << 8) + (y + 1);
    (t + (t >> 16)) >> 16
}

impl Model for Fixed9 {
    type R = i16;
    type W = i32;
    /// Mapped inputs are in [−510, 510] (units of 1/510): they fit an i16.
    type V = i16;

    fn from_u8(v: u8) -> i16 {
        v as i16
    }

    fn from_i9(v: i16) -> i16 {
        v.clamp(-255, 255)
    }

    fn from_unit(v: f32) -> i16 {
        let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
        (v * 255.0 + 0.5).floor() as i16
    }

    fn map(m: InputMapping, src: &[i16], dst: &mut [i16]) {
        // Registers are in [−255, 255], so every result is in [−510, 510].
        let it = dst.iter_mut().zip(src);
        match m {
            InputMapping::UnsignedIdentity => it.for_each(|(d, &s)| *d = 2 * s.max(0)),
            InputMapping::UnsignedInvert => it.for_each(|(d, &s)| *d = 2 * (255 - s.clamp(0, 255))),
            // Mapped inputs carry one more bit (units of 1/510), in which ½
            // is exact: Table 3 as written ([`HARDWARE_HALF`] says why the
            // output bias differs).
            InputMapping::ExpandNormal => it.for_each(|(d, &s)| *d = 4 * s.max(0) - 510),
            InputMapping::ExpandNegate => it.for_each(|(d, &s)| *d = 510 - 4 * s.max(0)),
            InputMapping::HalfBiasNormal => it.for_each(|(d, &s)| *d = 2 * s.max(0) - 255),
            InputMapping::HalfBiasNegate => it.for_each(|(d, &s)| *d = 255 - 2 * s.max(0)),
            InputMapping::SignedIdentity => it.for_each(|(d, &s)| *d = 2 * s),
            InputMapping::SignedNegate => it.for_each(|(d, &s)| *d = -2 * s),
        }
    }

    fn mul(a: &[i16], b: &[i16], dst: &mut [i32]) {
        dst.iter_mut().zip(a.iter().zip(b)).for_each(|(d, (&a, &b))| *d = a as i32 * b as i32);
    }

    fn mul_add(a: &[i16], b: &[i16], dst: &mut [i32]) {
        dst.iter_mut().zip(a.iter().zip(b)).for_each(|(d, (&a, &b))| *d += a as i32 * b as i32);
    }

    fn add(a: &[i32], b: &[i32], dst: &mut [i32]) {
        dst.iter_mut().zip(a.iter().zip(b)).for_each(|(d, (&a, &b))| *d = a + b);
    }

    fn mux(spare0_alpha: &[i16], ab: &[i32], cd: &[i32], dst: &mut [i32]) {
        // ½ lies between 127/255 and 128/255.
        dst.iter_mut()
            .zip(spare0_alpha.iter().zip(ab.iter().zip(cd)))
            .for_each(|(d, (&s, (&ab, &cd)))| *d = if s < 128 { ab } else { cd });
    }

    fn output(src: &[i32], scale: Scale, bias: Bias, dst: &mut [i16]) {
        // (v + bias) · scale in units of 1/520200 = 2 · 260100.
        let b = match bias {
            Bias::Zero => 0,
            // −128/255 in units of 1/260100 (1/255 = 1020 units).
            Bias::NegativeOneHalf => -HARDWARE_HALF as i32 * 1020,
        };
        let s = match scale {
            Scale::OneHalf => 1,
            Scale::One => 2,
            Scale::Two => 4,
            Scale::Four => 8,
        };
        dst.iter_mut().zip(src).for_each(|(d, &v)| *d = round_2040((v + b) * s).clamp(-255, 255) as i16);
    }

    fn final_map(m: InputMapping, src: &[i16], dst: &mut [i16]) {
        let it = dst.iter_mut().zip(src);
        match m {
            InputMapping::UnsignedInvert => it.for_each(|(d, &s)| *d = 255 - s.clamp(0, 255)),
            _ => it.for_each(|(d, &s)| *d = s.max(0)),
        }
    }

    fn ef(e: &[i16], f: &[i16], dst: &mut [i16]) {
        dst.iter_mut()
            .zip(e.iter().zip(f))
            // Inputs are unsigned (final-combiner mappings), so the numerator is ≥ 0
            // and ⌊n/510⌋ = ⌊⌊n/2⌋/255⌋.
            .for_each(|(d, (&e, &f))| *d = div255_floor((2 * e as i32 * f as i32 + 255) >> 1) as i16);
    }

    fn color_sum(spare0: &[i16], secondary: &[i16], clamp: bool, dst: &mut [i16]) {
        let max = if clamp { 255 } else { 510 };
        dst.iter_mut()
            .zip(spare0.iter().zip(secondary))
            .for_each(|(d, (&a, &b))| *d = (a.max(0) + b.max(0)).min(max));
    }

    fn lerp_add(a: &[i16], b: &[i16], c: &[i16], d: &[i16], dst: &mut [i16]) {
        for (i, o) in dst.iter_mut().enumerate() {
            let (a, b, c, d) = (a[i] as i32, b[i] as i32, c[i] as i32, d[i] as i32);
            let num = a * b + (255 - a) * c + 255 * d;
            *o = div255_floor((2 * num + 255) >> 1).min(255) as i16;
        }
    }

    fn to_u8(v: i16) -> u8 {
        v.clamp(0, 255) as u8
    }
}

/// A float model: Table 3 on reals in `$t`, outputs clamped to [−1, 1]
/// (`F32` what a float GPU computes, `F64` the exact reference).
macro_rules! float_model {
    ($model:ident, $t:ty) => {
        impl Model for $model {
            type R = $t;
            type W = $t;
            type V = $t;

            fn from_u8(v: u8) -> $t {
                v as $t * (1.0 / 255.0)
            }

            fn from_i9(v: i16) -> $t {
                v.clamp(-255, 255) as $t * (1.0 / 255.0)
            }

            fn from_unit(v: f32) -> $t {
                if v.is_nan() {
                    0.0
                } else {
                    v.clamp(0.0, 1.0) as $t
                }
            }

            fn map(m: InputMapping, src: &[$t], dst: &mut [$t]) {
                let it = dst.iter_mut().zip(src);
                match m {
                    InputMapping::UnsignedIdentity => it.for_each(|(d, &s)| *d = s.max(0.0)),
                    InputMapping::UnsignedInvert => it.for_each(|(d, &s)| *d = 1.0 - s.clamp(0.0, 1.0)),
                    InputMapping::ExpandNormal => it.for_each(|(d, &s)| *d = 2.0 * s.max(0.0) - 1.0),
                    InputMapping::ExpandNegate => it.for_each(|(d, &s)| *d = 1.0 - 2.0 * s.max(0.0)),
                    InputMapping::HalfBiasNormal => it.for_each(|(d, &s)| *d = s.max(0.0) - 0.5),
                    InputMapping::HalfBiasNegate => it.for_each(|(d, &s)| *d = 0.5 - s.max(0.0)),
                    InputMapping::SignedIdentity => it.for_each(|(d, &s)| *d = s),
                    InputMapping::SignedNegate => it.for_each(|(d, &s)| *d = -s),
                }
            }

            fn mul(a: &[$t], b: &[$t], dst: &mut [$t]) {
                dst.iter_mut().zip(a.iter().zip(b)).for_each(|(d, (&a, &b))| *d = a * b);
            }

            fn mul_add(a: &[$t], b: &[$t], dst: &mut [$t]) {
                dst.iter_mut().zip(a.iter().zip(b)).for_each(|(d, (&a, &b))| *d += a * b);
            }

            fn add(a: &[$t], b: &[$t], dst: &mut [$t]) {
                dst.iter_mut().zip(a.iter().zip(b)).for_each(|(d, (&a, &b))| *d = a + b);
            }

            fn mux(spare0_alpha: &[$t], ab: &[$t], cd: &[$t], dst: &mut [$t]) {
                dst.iter_mut()
                    .zip(spare0_alpha.iter().zip(ab.iter().zip(cd)))
                    .for_each(|(d, (&s, (&ab, &cd)))| *d = if s < 0.5 { ab } else { cd });
            }

            fn output(src: &[$t], scale: Scale, bias: Bias, dst: &mut [$t]) {
                let (s, b) = (scale.factor() as $t, bias.offset() as $t);
                dst.iter_mut().zip(src).for_each(|(d, &v)| *d = ((v + b) * s).clamp(-1.0, 1.0));
            }

            fn final_map(m: InputMapping, src: &[$t], dst: &mut [$t]) {
                let it = dst.iter_mut().zip(src);
                match m {
                    InputMapping::UnsignedInvert => it.for_each(|(d, &s)| *d = 1.0 - s.clamp(0.0, 1.0)),
                    _ => it.for_each(|(d, &s)| *d = s.max(0.0)),
                }
            }

            fn ef(e: &[$t], f: &[$t], dst: &mut [$t]) {
                dst.iter_mut().zip(e.iter().zip(f)).for_each(|(d, (&e, &f))| *d = e * f);
            }

            fn color_sum(spare0: &[$t], secondary: &[$t], clamp: bool, dst: &mut [$t]) {
                let max = if clamp { 1.0 } else { 2.0 };
                dst.iter_mut()
                    .zip(spare0.iter().zip(secondary))
                    .for_each(|(d, (&a, &b))| *d = (a.max(0.0) + b.max(0.0)).min(max));
            }

            fn lerp_add(a: &[$t], b: &[$t], c: &[$t], d: &[$t], dst: &mut [$t]) {
                for (i, o) in dst.iter_mut().enumerate() {
                    let (a, b, c, d) = (a[i], b[i], c[i], d[i]);
                    *o = (a * b + (1.0 - a) * c + d).min(1.0);
                }
            }

            fn to_u8(v: $t) -> u8 {
                (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
            }
        }
    };
}

/// f32 inside the combiners.
pub(super) struct F32;
float_model!(F32, f32);

/// f64 inside the combiners: `Precision::Exact`.
pub(super) struct F64;
float_model!(F64, f64);
