//! The arithmetic a plan is run in, and the rounding the executors share
//! (one precision model). Every executor — the CPU renderer, the
//! combiner emulator, the WGSL it is translated to, the evaluator — takes one
//! [`Precision`], and where two of them round they call the same functions
//! here, so the register combiners' 8-bit + sign model (Kilgard 2000, Section
//! 4.2) is written once.

/// How a plan's arithmetic is modelled.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// f64 throughout, true functions, no clamps but GL's: the reference
    /// (on a GPU, which has no f64, the f32 shader).
    #[default]
    Exact,
    /// 32-bit floats: what a programmable GPU computes.
    F32,
    /// The register combiners: 8-bit textures and framebuffer, 9-bit signed
    /// registers with their clamps (the `fixed9` module), as the GeForce
    /// hardware did.
    #[value(alias = "hardware")]
    Fixed9,
}

impl Precision {
    /// The precision's name, as `--precision` spells it.
    pub fn name(self) -> &'static str {
        match self {
            Precision::Exact => "exact",
            Precision::F32 => "f32",
            Precision::Fixed9 => "fixed9",
        }
    }

    /// Whether values are rounded to f32 (rather than kept in f64) between
    /// operations: every model but the reference.
    pub fn rounds_to_f32(self) -> bool {
        self != Precision::Exact
    }
}

impl std::fmt::Display for Precision {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The register-combiner precision model: clamp to [−1, 1], round to
/// 1/255 (nearest, ties toward +∞), as the emulator's register writes; NaN
/// (0/0) is 0.
#[inline]
pub fn fixed9(v: f64) -> f64 {
    fixed9_with(v, 0.0)
}

/// [`fixed9`] with its tie point moved by `bias` steps (the renderer's
/// rounding-bias probe, `PlanRenderer::set_rounding_bias`).
#[inline]
pub fn fixed9_with(v: f64, bias: f64) -> f64 {
    if v.is_nan() {
        return 0.0;
    }
    (v.clamp(-1.0, 1.0) * 255.0 + 0.5 + bias).floor().clamp(-255.0, 255.0) / 255.0
}

/// A constant or uniform subexpression in the combiner precision model:
/// the compiler folds it before the combiners run, into an 8-bit constant
/// register times an output scale of 1, 2 or 4 (Kilgard 2000, Section 4.2:
/// `scale_by_two`, `scale_by_four`), so it keeps its magnitude and is
/// rounded to 1/255 like the register.
#[inline]
pub fn fixed9_folded_with(v: f64, bias: f64) -> f64 {
    if v.is_nan() {
        return 0.0;
    }
    (v * 255.0 + 0.5 + bias).floor() / 255.0
}

/// a / b in the combiners' precision from the registers' integers
/// k₁ = a·255, k₂ = b·255: the quotient in 1/255 steps is k₁·255/k₂,
/// exact (in f64 as in f32) where it is a tie m + ½ — a quotient of 8-bit
/// values lands on ties, unlike a product — so the tie rounds up on both
/// executors rather than by float noise (WGSL: codegen's `divide_*`).
/// x/0 is ±1 (clamped), 0/0 (NaN) is 0, as in [`fixed9`].
#[inline]
pub fn fixed9_quotient(k1: f64, k2: f64, bias: f64) -> f64 {
    let t = k1 * 255.0 / k2;
    if t.is_nan() {
        return 0.0;
    }
    (t + 0.5 + bias).floor().clamp(-255.0, 255.0) / 255.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed9_rounds_ties_up_and_clamps() {
        assert_eq!(fixed9(0.5 / 255.0), 1.0 / 255.0);
        assert_eq!(fixed9(-0.5 / 255.0), 0.0);
        assert_eq!(fixed9(3.0), 1.0);
        assert_eq!(fixed9(-3.0), -1.0);
        assert_eq!(fixed9(f64::NAN), 0.0);
    }

    /// Quotients of 8-bit values that land on ties (k₁·255/k₂ = m + ½) round
    /// up; x/0 clamps to ±1, 0/0 is 0.
    #[test]
    fn fixed9_quotient_rounds_ties_up() {
        for (k1, k2, m) in
            [(1.0, 170.0, 2.0), (1.0, 102.0, 3.0), (1.0, 30.0, 9.0), (-1.0, 170.0, -1.0), (3.0, 6.0, 128.0)]
        {
            assert_eq!(fixed9_quotient(k1, k2, 0.0), m / 255.0, "{k1}/{k2}");
        }
        assert_eq!(
            (fixed9_quotient(5.0, 0.0, 0.0), fixed9_quotient(-5.0, 0.0, 0.0), fixed9_quotient(0.0, 0.0, 0.0)),
            (1.0, -1.0, 0.0)
        );
    }

    #[test]
    fn hardware_is_an_alias_of_fixed9() {
        use clap::ValueEnum;
        assert_eq!(Precision::from_str("hardware", true), Ok(Precision::Fixed9));
        assert_eq!(Precision::from_str("exact", true), Ok(Precision::Exact));
    }
}
