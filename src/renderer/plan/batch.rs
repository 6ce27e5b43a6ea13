//! The fragment stage over batches: the fragments of one
//! triangle in one tile, up to [`BATCH`] of them, run through the pass's
//! steps together. The registers are a structure of arrays — per slot, per
//! component, one lane per fragment — and each step's kind is matched once
//! per batch instead of once per fragment, so the common operations
//! ([`Kernel`]) run as tight loops over the lanes.
//!
//! A lane holds what the fragment-at-a-time path keeps in its slot: `f32`
//! in the `f32` mode (whose every slot is rounded to f32), `f64` in `exact`
//! and in `fixed9` (whose register values are multiples of 1/255, which f32
//! cannot hold). Each kernel computes a lane with the same formula as
//! [`Kernel::apply`] and rounds it with [`FragmentProgram::stored`], so a
//! batch's colours are bit for bit the fragment-at-a-time ones (every
//! example on every target in every mode, `tests/render_batch.rs`;
//! generated programs, `tests/differential.rs`). Varyings are copied lane
//! by lane in one loop; the other leaves (texture lookups, framebuffer
//! reads, uniforms), the operations without a kernel and fixed9's
//! register-rounded powers and quotients run lane by lane through
//! [`FragmentProgram::step_value`].

use std::cell::RefCell;

use super::{FragmentProgram, Kernel, Leaf, RegisterOp, Step};
use crate::backends::combiners::PixelRegisters;
use crate::ir::eval::Value;
use crate::numerics::Precision;
use crate::numerics::{fixed9_folded_with, fixed9_with};
use crate::renderer::{Fragment, FragmentResult, BATCH};

/// What a lane stores: the mode's precision ([`FragmentProgram::stored`]
/// has already rounded the value to it).
pub(super) trait Lane: Copy + Default {
    fn load(self) -> f64;
    fn store(x: f64) -> Self;
}

impl Lane for f32 {
    #[inline(always)]
    fn load(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn store(x: f64) -> f32 {
        x as f32
    }
}

impl Lane for f64 {
    #[inline(always)]
    fn load(self) -> f64 {
        self
    }
    #[inline(always)]
    fn store(x: f64) -> f64 {
        x
    }
}

thread_local! {
    static LANES_F32: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
    static LANES_F64: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

/// One batch's registers: slot `s`, component `c`, lane `i` at
/// `(s * 4 + c) * BATCH + i`.
struct Registers<'r, L> {
    lanes: &'r mut [L],
}

impl<L: Lane> Registers<'_, L> {
    #[inline(always)]
    fn get(&self, slot: u32, lane: usize) -> Value {
        let at = slot as usize * 4 * BATCH + lane;
        [0, 1, 2, 3].map(|c| self.lanes[at + c * BATCH].load())
    }

    #[inline(always)]
    fn set(&mut self, slot: u32, lane: usize, v: Value) {
        let at = slot as usize * 4 * BATCH + lane;
        for (c, x) in v.into_iter().enumerate() {
            self.lanes[at + c * BATCH] = L::store(x);
        }
    }

    #[inline(always)]
    fn component(&self, slot: u32, c: usize) -> &[L] {
        &self.lanes[(slot as usize * 4 + c) * BATCH..][..BATCH]
    }

    #[inline(always)]
    fn component_mut(&mut self, slot: u32, c: usize) -> &mut [L] {
        &mut self.lanes[(slot as usize * 4 + c) * BATCH..][..BATCH]
    }

    fn splat(&mut self, slot: u32, v: Value, n: usize) {
        for (c, x) in v.into_iter().enumerate() {
            let at = (slot as usize * 4 + c) * BATCH;
            self.lanes[at..at + n].fill(L::store(x));
        }
    }
}

impl FragmentProgram<'_> {
    /// Shades `fragments` (at most [`BATCH`]; `varyings`: the same number
    /// per fragment, in order) into `out` and `results`.
    pub(super) fn shade_lanes(
        &self,
        fragments: &[Fragment],
        varyings: &[f32],
        out: &mut [[f32; 4]],
        results: &mut [FragmentResult],
    ) {
        debug_assert!(fragments.len() <= BATCH);
        match self.mode {
            Precision::F32 => LANES_F32
                .with(|cell| self.run_batch(&mut cell.borrow_mut(), fragments, varyings, out, results)),
            _ => LANES_F64
                .with(|cell| self.run_batch(&mut cell.borrow_mut(), fragments, varyings, out, results)),
        }
    }

    fn run_batch<L: Lane>(
        &self,
        lanes: &mut Vec<L>,
        fragments: &[Fragment],
        varyings: &[f32],
        out: &mut [[f32; 4]],
        results: &mut [FragmentResult],
    ) {
        let n = fragments.len();
        let per = varyings.len().checked_div(n).unwrap_or(0);
        if lanes.len() < self.n_slots * 4 * BATCH {
            lanes.resize(self.n_slots * 4 * BATCH, L::default());
        }
        let mut r = Registers { lanes: &mut lanes[..self.n_slots * 4 * BATCH] };
        for &(s, v) in &self.constants {
            r.splat(s, v, n);
        }
        let mut discard = [false; BATCH];
        for (i, s) in self.steps.iter().enumerate() {
            if vectorizes(s) {
                self.kernel_lanes(s, &mut r, n);
                continue;
            }
            if let Some(Leaf::Varying { k }) = s.leaf {
                self.varying_lanes(s, k, varyings, per, &mut r, n);
                continue;
            }
            for lane in 0..n {
                let mut buf = [[0.0; 4]; 4];
                for (b, &o) in buf.iter_mut().zip(&s.ops[..s.n_ops as usize]) {
                    *b = r.get(o, lane);
                }
                let vary = &varyings[lane * per..(lane + 1) * per];
                let v = self.step_value(i, &buf, &fragments[lane], vary, None, true, &mut discard[lane]);
                r.set(s.slot, lane, self.stored(s, v));
            }
        }
        for lane in 0..n {
            let dropped = discard[lane] || self.condition.is_some_and(|c| r.get(c, lane)[0] == 0.0);
            results[lane] = if dropped { FragmentResult::Discard } else { FragmentResult::Keep };
        }
        match &self.combiners {
            // The combiners run on all the lanes at once (a discarded
            // lane's colour is computed and not used).
            Some((machine, registers)) => {
                let mut loaded = [PixelRegisters::default(); BATCH];
                for (lane, l) in loaded[..n].iter_mut().enumerate() {
                    *l = self.registers(registers, |s| r.get(s, lane));
                }
                let mut colours = [[0u8; 4]; BATCH];
                machine.run_many(&loaded[..n], &mut colours[..n]);
                for lane in 0..n {
                    // The pass's alpha test on the machine's alpha (planner::alpha_test).
                    if self.alpha_test.is_some_and(|t| !t.passes_steps(colours[lane][3])) {
                        results[lane] = FragmentResult::Discard;
                    }
                    if results[lane] == FragmentResult::Keep {
                        out[lane] = self.output(colours[lane].map(|c| c as f64 / 255.0));
                    }
                }
            }
            None => {
                for lane in (0..n).filter(|&l| results[l] == FragmentResult::Keep) {
                    out[lane] = self.output(r.get(self.output, lane));
                }
            }
        }
    }

    /// Step `s` over the lanes: its kernel, matched once, computes every
    /// lane with [`Kernel::apply`]'s formula component by component; the
    /// result is made canonical and rounded as [`FragmentProgram::stored`]
    /// does, lane by lane in one loop.
    fn kernel_lanes<L: Lane>(&self, s: &Step, r: &mut Registers<L>, n: usize) {
        let mut v = [[0.0f64; BATCH]; 4];
        let op = |k: usize, c: usize| r.component(s.ops[k], c);
        macro_rules! each {
            ($c:ident, $i:ident, $e:expr) => {
                for $c in 0..4 {
                    for $i in 0..n {
                        v[$c][$i] = $e;
                    }
                }
            };
        }
        match s.kernel {
            Kernel::Add => each!(c, i, op(0, c)[i].load() + op(1, c)[i].load()),
            Kernel::Sub => each!(c, i, op(0, c)[i].load() - op(1, c)[i].load()),
            Kernel::Mul => each!(c, i, op(0, c)[i].load() * op(1, c)[i].load()),
            Kernel::Neg => each!(c, i, -op(0, c)[i].load()),
            Kernel::Max => each!(c, i, op(0, c)[i].load().max(op(1, c)[i].load())),
            Kernel::Min => each!(c, i, op(0, c)[i].load().min(op(1, c)[i].load())),
            Kernel::Clamp => each!(c, i, op(0, c)[i].load().max(op(1, c)[i].load()).min(op(2, c)[i].load())),
            Kernel::Saturate => each!(c, i, op(0, c)[i].load().clamp(0.0, 1.0)),
            Kernel::Expand => each!(c, i, 2.0 * op(0, c)[i].load() - 1.0),
            Kernel::Compress => each!(c, i, (op(0, c)[i].load() + 1.0) / 2.0),
            Kernel::Same => each!(c, i, op(0, c)[i].load()),
            Kernel::RgbToRgba => each!(c, i, if c == 3 { 1.0 } else { op(0, c)[i].load() }),
            Kernel::Mix => each!(c, i, {
                let t = op(2, c)[i].load();
                op(0, c)[i].load() * (1.0 - t) + op(1, c)[i].load() * t
            }),
            Kernel::Swizzle(pattern, len) => {
                for (k, &from) in pattern[..len as usize].iter().enumerate() {
                    let a = op(0, from as usize & 3);
                    for i in 0..n {
                        v[k][i] = a[i].load();
                    }
                }
            }
            Kernel::Dot(width) => {
                let w = width.min(4);
                for i in 0..n {
                    let d = (0..w).map(|c| op(0, c)[i].load() * op(1, c)[i].load()).sum::<f64>();
                    for x in &mut v {
                        x[i] = d;
                    }
                }
            }
            Kernel::Normalize(width) => {
                let w = width.min(4);
                for i in 0..n {
                    let len = (0..w).map(|c| op(0, c)[i].load() * op(0, c)[i].load()).sum::<f64>().sqrt();
                    for (c, x) in v.iter_mut().enumerate() {
                        x[i] = if len == 0.0 { 0.0 } else { op(0, c)[i].load() / len };
                    }
                }
            }
            Kernel::General => unreachable!("a general step runs lane by lane"),
        }
        self.store_lanes(s, &mut v, r, n);
    }

    /// Varying `k` of every lane (`per`: varyings per fragment).
    fn varying_lanes<L: Lane>(
        &self,
        s: &Step,
        k: usize,
        varyings: &[f32],
        per: usize,
        r: &mut Registers<L>,
        n: usize,
    ) {
        let mut v = [[0.0f64; BATCH]; 4];
        for (c, x) in v.iter_mut().enumerate() {
            for (i, x) in x[..n].iter_mut().enumerate() {
                *x = varyings[i * per + 4 * k + c] as f64;
            }
        }
        self.store_lanes(s, &mut v, r, n);
    }

    /// Stores step `s`'s lanes `v` into its slot as [`FragmentProgram::stored`]
    /// stores one value: canonical for its type, rounded by the mode.
    fn store_lanes<L: Lane>(&self, s: &Step, v: &mut [[f64; BATCH]; 4], r: &mut Registers<L>, n: usize) {
        if !s.raw {
            match s.ty.width() {
                1 => {
                    let [x, rest @ ..] = v;
                    for y in rest {
                        y[..n].copy_from_slice(&x[..n]);
                    }
                }
                w @ 2..=4 => v[w..].iter_mut().for_each(|x| x[..n].fill(0.0)),
                _ => v.iter_mut().for_each(|x| x[..n].fill(f64::NAN)),
            }
        }
        let bias = self.tie.register_steps;
        for (c, x) in v.iter().enumerate() {
            let out = r.component_mut(s.slot, c);
            match self.mode {
                Precision::Exact | Precision::F32 => {
                    out[..n].iter_mut().zip(&x[..n]).for_each(|(o, &x)| *o = L::store(x))
                }
                Precision::Fixed9 if s.quantize => {
                    out[..n].iter_mut().zip(&x[..n]).for_each(|(o, &x)| *o = L::store(fixed9_with(x, bias)))
                }
                Precision::Fixed9 if s.folded => out[..n]
                    .iter_mut()
                    .zip(&x[..n])
                    .for_each(|(o, &x)| *o = L::store(fixed9_folded_with(x, bias))),
                Precision::Fixed9 => {
                    out[..n].iter_mut().zip(&x[..n]).for_each(|(o, &x)| *o = L::store(x as f32 as f64))
                }
            }
        }
    }
}

/// Whether step `s` runs as one kernel over the lanes: an operation with a
/// kernel, rounded as any other ([`RegisterOp::Rounded`]); not a leaf, and
/// not a comparison that a rounding bias moves (those are
/// [`Kernel::General`]).
fn vectorizes(s: &Step) -> bool {
    s.leaf.is_none() && s.register == RegisterOp::Rounded && s.kernel != Kernel::General
}
