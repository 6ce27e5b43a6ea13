//! The lane program's last step: each lane's fate and colour
//! ([`FragmentProgram::lane_outputs`]).

use std::sync::atomic::Ordering;

use super::{lanes, Lanes};
use crate::renderer::plan::FragmentProgram;
use crate::renderer::{FragmentResult, BATCH};

impl FragmentProgram<'_> {
    /// Each lane's fate and colour from the registers `r`: as
    /// [`FragmentProgram::output`] computes them (the `f32` values are the
    /// `f64` ones it takes, exactly), without the round trip through `f64`
    /// and with one count of non-finite values per batch. Fixed-length
    /// loops over the lanes (vector code in the lane program's AVX2 copy,
    /// [`super::run`]); a dropped lane's colour is written too, and not read.
    // Indexed loops over several lane arrays at once are the form that vectorises.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    pub(super) fn lane_outputs(
        &self,
        r: &[Lanes],
        discard: &[bool; BATCH],
        n: usize,
        out: &mut [[f32; 4]],
        results: &mut [FragmentResult],
    ) {
        let n = n.min(BATCH).min(out.len()).min(results.len());
        let mut dropped = *discard;
        if let Some(c) = self.condition {
            let condition = lanes(r, c, 0);
            for i in 0..BATCH {
                dropped[i] |= condition[i] == 0.0;
            }
        }
        let (zero, one) = ([0.0f32; BATCH], [1.0f32; BATCH]);
        let o = |c: usize| lanes(r, self.output, c);
        // The colour's components as `FragmentProgram::output` widens them.
        let v: [&Lanes; 4] = match self.output_ty.width() {
            1 => [o(0); 4],
            2 => [o(0), o(1), &zero, &one],
            3 => [o(0), o(1), o(2), &one],
            _ => [o(0), o(1), o(2), o(3)],
        };
        let (mut finite, mut colour) = ([true; BATCH], [[0.0f32; 4]; BATCH]);
        let zero_nan = |x: f32| if x.is_nan() { 0.0 } else { x };
        for i in 0..BATCH {
            let x = [v[0][i], v[1][i], v[2][i], v[3][i]];
            finite[i] = x[0].is_finite() & x[1].is_finite() & x[2].is_finite() & x[3].is_finite();
            colour[i] = [zero_nan(x[0]), zero_nan(x[1]), zero_nan(x[2]), zero_nan(x[3])];
        }
        let mut nonfinite = 0;
        for lane in 0..n {
            results[lane] = if dropped[lane] { FragmentResult::Discard } else { FragmentResult::Keep };
            nonfinite += (!dropped[lane] && !finite[lane]) as u64;
        }
        out[..n].copy_from_slice(&colour[..n]);
        if nonfinite > 0 {
            self.nonfinite.fetch_add(nonfinite, Ordering::Relaxed);
        }
    }
}
