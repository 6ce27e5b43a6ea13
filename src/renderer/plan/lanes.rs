//! The `f32` mode's fragment stage compiled once per pass into lane code.
//!
//! [`LaneProgram::compile`] turns a pass's [`Step`]s into a list of
//! [`Op`]s whose operands are resolved register offsets; each op runs over
//! all [`BATCH`] lanes of a batch (fragments of one tile, of one triangle
//! or several) in `f32`, as fixed-length loops over `[f32; BATCH]` that the
//! compiler turns into SIMD code — 8 lanes a vector on a CPU with AVX2
//! (the whole batch is compiled a second time with AVX2 and FMA enabled and
//! chosen at run time, [`run`]), 4 with SSE2. A third copy for AVX-512
//! (16 lanes) spent 8 % more time in the lane program on the project's
//! Xeon in one measurement (BENCHMARKS.md, thirteenth session): not kept. Operations the lanes do not
//! cover (texture lookups, framebuffer reads, the rarely used functions)
//! run lane by lane through [`FragmentProgram::step_value`], as the
//! interpreter does.
//!
//! Why this shape, measured (BENCHMARKS.md, "An executor that is not an
//! interpreter"): on one pass (Kilgard's torus, wgsl plan) the
//! same lane kernels dispatched by a `match` per op and per batch
//! ([`Dispatch::Kernels`]) and compiled into boxed closures specialised per
//! op ([`Dispatch::Closures`], the closure-compilation stand-in for a JIT)
//! were both 1.4-2.0× faster than the batch interpreter; between them a
//! heavily loaded machine did not decide (kernels ahead in one run,
//! closures in three, by 11-27 %), so the default stays the kernels until
//! a quiet machine does. With 32 lanes a dispatch costs one indirect
//! branch per op per batch, so what a JIT (Cranelift) would add over
//! either is keeping values in registers between ops; the time left is in
//! the per-lane texture sampling and in the rasterizer and blending, which
//! a JIT of the fragment program does not touch, and Cranelift would bring
//! some twenty crates and a code generator to maintain. It was not built.
//! No SIMD crate either: the fixed-length loops vectorise as written (the
//! `wide` or `pulp` types would give the same instructions), and the one
//! run-time choice, AVX2 or not, is a `#[target_feature]` function.
//!
//! Precision: every op computes in `f32` (the interpreter computed in `f64`
//! and rounded each step to `f32`), and `x^k` with a constant integer `k`
//! is `k`'s squarings. The difference is a few ulps per op; images are
//! checked against the exact reference and against the one-at-a-time `f32`
//! executor with stated tolerances (`tests/render_batch.rs`).

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, AtomicU8, Ordering};

use super::{uv_derivatives, FragmentProgram, Kernel, Leaf, RegisterOp, Source, Step};
use crate::ir::Ty;
use crate::ir::{self, BinaryOp, Expr, MathFunction, UnaryOp};
use crate::parser::ast::CombineMode;
use crate::renderer::raster::{quad_lod_lanes, Vary};
use crate::renderer::{Fragment, FragmentResult, BATCH};
use crate::textures::{lanes as texture_lanes, unit, Texture};

/// How a compiled pass's ops are dispatched (for the measurement that
/// chose the default; both compute the same values).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dispatch {
    /// A `match` per op per batch over the compiled op list (the default).
    Kernels,
    /// Each op compiled into a boxed closure, called in order.
    Closures,
    /// Not compiled: the batch interpreter of `batch.rs`, which computes
    /// in `f64` and rounds every step to `f32` (the executor before this one).
    Interpreter,
}

/// Whether programs compiled now get lane code ([`Dispatch::Interpreter`] not chosen).
pub(super) fn enabled() -> bool {
    DISPATCH.load(Ordering::Relaxed) != Dispatch::Interpreter as u8
}

static DISPATCH: AtomicU8 = AtomicU8::new(0);

/// Numbers compiled programs, so that a thread's registers know whose
/// constants they hold ([`FragmentProgram::shade_compiled`]).
static PROGRAMS: AtomicU64 = AtomicU64::new(1);

/// Chooses the dispatch of the `f32` lane executor for programs compiled
/// from now on (a benchmark's switch; the default is [`Dispatch::Kernels`]).
pub fn set_dispatch(d: Dispatch) {
    DISPATCH.store(d as u8, Ordering::Relaxed);
}

/// A step's arithmetic over the lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
enum K {
    Add,
    Sub,
    Mul,
    Div,
    Neg,
    Max,
    Min,
    Clamp,
    Saturate,
    Expand,
    Compress,
    HalfBias,
    /// `a + b − ½`.
    AddSigned,
    Abs,
    Sqrt,
    Rsqrt,
    Floor,
    Fract,
    Step,
    Mix,
    Same,
    RgbToRgba,
    Swizzle([u8; 4], u8),
    Dot(u8),
    Normalize(u8),
    Length(u8),
    /// `x^k`, `k` a constant integer: `k`'s squarings.
    PowInt(u32),
    Pow,
    Cmp(BinaryOp),
    Not,
    /// `c ? a : b`; without `b` a lane whose `c` is 0 is discarded.
    Select(bool),
    /// Components concatenated: the operands' widths.
    Compose([u8; 4]),
    /// A varying, `k`: varyings 4k..4k+4 of each fragment.
    Varying(u32),
}

/// One compiled op: the arithmetic, the destination slot and the operand
/// slots, the result's width (1: splat, 2-4: zero above, 0: NaN, as
/// [`ir::eval::canonical`] makes a value canonical), the components of
/// the result some op or the output reads (`keep`, a bit each): the
/// canonical form is written only there ([`demanded`]), and per operand
/// and component the register row the op reads (`rows`: the operand
/// slot's own rows, or the rows of the value a copy it reads copied,
/// [`forward_copies`]).
#[derive(Clone, Copy, Debug)]
enum Op {
    Lanes {
        k: K,
        dst: u32,
        ops: [u32; 4],
        width: u8,
        keep: u8,
        rows: [[u32; 4]; 4],
    },
    /// Step `i` lane by lane through [`FragmentProgram::step_value`].
    Scalar(u32),
    /// Step `i`, a lookup of a bound 2D or cube texture, lane by lane
    /// straight into the texture unit's model in `f32`.
    Sample(u32),
}

type Closure = Box<dyn Fn(&mut [Lanes], Vary, usize, &mut [bool; BATCH]) + Send + Sync>;

/// A pass's fragment program as lane code ([`LaneProgram::compile`]).
pub(in crate::renderer) struct LaneProgram {
    ops: Vec<Op>,
    closures: Option<Vec<Closure>>,
    /// Uniform and constant slots, splatted into a thread's registers
    /// when it shades a batch of another program than its last.
    splats: Vec<(u32, [f32; 4])>,
    /// Per texture of the program, a bound 2-D texture's levels as the
    /// lanes index them, computed once here instead of at every lookup.
    levels: Vec<Option<texture_lanes::Levels>>,
    /// Per texture, a bound cube map's faces bordered by their seams.
    cubes: Vec<Option<texture_lanes::CubeBorders>>,
    n_slots: usize,
    id: u64,
}

impl LaneProgram {
    /// Compiles `p` (an `f32` program without combiners).
    pub(super) fn compile(p: &FragmentProgram) -> LaneProgram {
        let mut splats: Vec<(u32, [f32; 4])> =
            p.constants.iter().map(|&(s, v)| (s, v.map(|x| x as f32))).collect();
        let mut ops = Vec::with_capacity(p.steps.len());
        for (i, s) in p.steps.iter().enumerate() {
            if let Some(Leaf::Uniform(v)) = s.leaf {
                let v = p.stored(s, v);
                splats.push((s.slot, v.map(|x| x as f32)));
                continue;
            }
            if samples_directly(p, s) {
                ops.push(Op::Sample(i as u32));
                continue;
            }
            let op = lane_kernel(p, s)
                .filter(|_| s.ops[..s.n_ops as usize].iter().all(|&o| o < s.slot))
                .map(|k| Op::Lanes {
                    k,
                    dst: s.slot,
                    ops: s.ops,
                    width: width_of(s.ty),
                    keep: 0b1111,
                    rows: s.ops.map(|o| [0, 1, 2, 3].map(|c| o.saturating_mul(4).saturating_add(c))),
                })
                .unwrap_or(Op::Scalar(i as u32));
            ops.push(op);
        }
        if !plain() {
            let demand = demanded(p, &ops);
            for op in &mut ops {
                if let Op::Lanes { dst, keep, .. } = op {
                    *keep = demand[*dst as usize];
                }
            }
            forward_copies(p, &mut ops);
        }
        #[cfg(test)]
        tests::record(&ops);
        let closures = (DISPATCH.load(Ordering::Relaxed) == Dispatch::Closures as u8)
            .then(|| ops.iter().map(closure).collect());
        // What the lookups of each texture keep from batch to batch (only
        // the textures some op samples through the lanes).
        let sampled = |texture: usize| {
            ops.iter().any(|op| match *op {
                Op::Sample(i) => {
                    matches!(p.steps[i as usize].leaf, Some(Leaf::Lookup { texture: t, .. }) if t as usize == texture)
                }
                _ => false,
            })
        };
        let bound = |texture: usize| match &p.sources[texture] {
            Source::Bound { texture: b, exact: None } if sampled(texture) => Some(&b.texture),
            _ => None,
        };
        let n_textures = p.sources.len();
        let levels = (0..n_textures)
            .map(|k| match bound(k) {
                Some(Texture::Flat(t)) => texture_lanes::Levels::of(t),
                _ => None,
            })
            .collect();
        let cubes = (0..n_textures)
            .map(|k| match bound(k) {
                Some(Texture::Cube(c)) if !plain() => texture_lanes::CubeBorders::of(c),
                _ => None,
            })
            .collect();
        LaneProgram {
            ops,
            closures,
            splats,
            levels,
            cubes,
            n_slots: p.n_slots,
            id: PROGRAMS.fetch_add(1, Ordering::Relaxed),
        }
    }
}

fn width_of(ty: ir::Ty) -> u8 {
    match ty.width() {
        w @ 1..=4 => w as u8,
        _ => 0,
    }
}

/// Whether step `s` is a lookup [`Op::Sample`] takes: a bound texture
/// sampled through the texture unit's model (2D: its level of detail from a
/// varying's quad derivatives, or a single level; or a cube map).
fn samples_directly(p: &FragmentProgram, s: &Step) -> bool {
    let Some(Leaf::Lookup { texture, coords_ty, lod_from }) = s.leaf else { return false };
    let Source::Bound { texture: b, exact: None } = &p.sources[texture as usize] else { return false };
    s.register == RegisterOp::Rounded
        && !s.raw
        && s.ops[0] < s.slot
        && match &b.texture {
            Texture::Flat(t) => coords_ty != Ty::Position && (lod_from.is_some() || t.levels.len() == 1),
            Texture::Cube(_) => true,
            _ => false,
        }
}

/// The lane arithmetic of step `s`, if it has one.
fn lane_kernel(p: &FragmentProgram, s: &Step) -> Option<K> {
    let m = p.module;
    if s.register != RegisterOp::Rounded || s.raw {
        return None;
    }
    if let Some(leaf) = s.leaf {
        return match leaf {
            Leaf::Varying { k } => Some(K::Varying(k as u32)),
            _ => None,
        };
    }
    let w = |h: ir::Handle<Expr>| m.info(h).ty.width().min(4) as u8;
    Some(match s.kernel {
        Kernel::Add => K::Add,
        Kernel::Sub => K::Sub,
        Kernel::Mul => K::Mul,
        Kernel::Neg => K::Neg,
        Kernel::Dot(width) => K::Dot(width.min(4) as u8),
        Kernel::Swizzle(p, len) => K::Swizzle(p, len),
        Kernel::RgbToRgba => K::RgbToRgba,
        Kernel::Same => K::Same,
        Kernel::Max => K::Max,
        Kernel::Min => K::Min,
        Kernel::Clamp => K::Clamp,
        Kernel::Saturate => K::Saturate,
        Kernel::Expand => K::Expand,
        Kernel::Compress => K::Compress,
        Kernel::Mix => K::Mix,
        Kernel::Normalize(width) => K::Normalize(width.min(4) as u8),
        Kernel::General => match s.expr {
            Expr::Binary { op: BinaryOp::Div, .. } => K::Div,
            Expr::Binary { op: BinaryOp::Pow, rhs, .. } => match integer_exponent(m, *rhs) {
                Some(k) => K::PowInt(k),
                None => K::Pow,
            },
            Expr::Binary {
                op:
                    op @ (BinaryOp::Lt | BinaryOp::Le | BinaryOp::Gt | BinaryOp::Ge | BinaryOp::Eq | BinaryOp::Ne),
                ..
            } if p.tie.comparison_ulps == 0.0 => K::Cmp(*op),
            Expr::Binary { op: op @ (BinaryOp::And | BinaryOp::Or), .. } => K::Cmp(*op),
            Expr::Unary { op: UnaryOp::Not, .. } => K::Not,
            // The componentwise texture-environment modes (`ir::eval::combine`).
            Expr::Combine { mode: CombineMode::Modulate, .. } => K::Mul,
            Expr::Combine { mode: CombineMode::Add, .. } => K::Add,
            Expr::Combine { mode: CombineMode::Subtract, .. } => K::Sub,
            Expr::Combine { mode: CombineMode::AddSigned, .. } => K::AddSigned,
            Expr::Select { reject, .. } => K::Select(reject.is_some()),
            Expr::Compose { components, .. } if components.len() <= 4 => {
                let mut ws = [0u8; 4];
                for (x, &h) in ws.iter_mut().zip(components) {
                    *x = w(h);
                }
                K::Compose(ws)
            }
            Expr::Math { fun, args } => match fun {
                MathFunction::HalfBias => K::HalfBias,
                MathFunction::Abs => K::Abs,
                MathFunction::Sqrt => K::Sqrt,
                MathFunction::Rsqrt => K::Rsqrt,
                MathFunction::Floor => K::Floor,
                MathFunction::Fract => K::Fract,
                MathFunction::Step => K::Step,
                MathFunction::Length => K::Length(w(args[0])),
                _ => return None,
            },
            _ => return None,
        },
    })
}

/// `k` where the exponent `rhs` is the constant integer `k` in every
/// component (1 ≤ k ≤ 256, as [`ir::squaring_exponent`] takes it).
fn integer_exponent(m: &ir::Module, rhs: ir::Handle<Expr>) -> Option<u32> {
    let Expr::Constant(c) = &m.exprs[rhs] else { return None };
    let w = c.ty.width().clamp(1, 4);
    let k = c.components[0];
    let same = c.components[..w].iter().all(|&x| x == k);
    (same && (1.0..=256.0).contains(&k) && k.fract() == 0.0).then_some(k as u32)
}

/// A batch's 2-D lookup whose footprints a later lookup may share
/// ([`FragmentProgram::sample_lanes`]): whether there is one in this
/// batch, its coordinates' slot and type, the varying its level of detail
/// came from, and the footprints (a thread's, refilled in place).
pub(super) struct SharedLookup {
    valid: bool,
    coords: u32,
    coords_ty: Ty,
    lod_from: Option<usize>,
    f: texture_lanes::Footprints2d<BATCH>,
}

thread_local! {
    /// A thread's registers, and the program whose constants they hold.
    static REGISTERS: RefCell<(Vec<Lanes>, u64)> = const { RefCell::new((Vec::new(), 0)) };
    /// A thread's shared footprints.
    static LOOKUP: RefCell<SharedLookup> = RefCell::new(SharedLookup {
        valid: false,
        coords: 0,
        coords_ty: Ty::Scalar,
        lod_from: None,
        f: Default::default(),
    });
}

type Lanes = [f32; BATCH];

#[inline(always)]
fn lanes(r: &[Lanes], slot: u32, c: usize) -> &Lanes {
    &r[slot as usize * 4 + c]
}

impl FragmentProgram<'_> {
    /// Shades a batch through the compiled lane program `lp`.
    pub(super) fn shade_compiled(
        &self,
        lp: &LaneProgram,
        fragments: &[Fragment],
        varyings: Vary,
        out: &mut [[f32; 4]],
        results: &mut [FragmentResult],
    ) {
        REGISTERS.with(|cell| {
            let (r, holds) = &mut *cell.borrow_mut();
            if r.len() < lp.n_slots * 4 {
                r.resize(lp.n_slots * 4, [0.0; BATCH]);
            }
            let r = &mut r[..lp.n_slots * 4];
            // No op writes a constant's slot: they stay from the last batch.
            if *holds != lp.id {
                for &(s, v) in &lp.splats {
                    for (c, x) in v.into_iter().enumerate() {
                        r[s as usize * 4 + c].fill(x);
                    }
                }
                *holds = lp.id;
            }
            LOOKUP.with(|l| {
                let shared = &mut *l.borrow_mut();
                shared.valid = false;
                run(self, lp, r, (fragments, varyings), shared, (out, results))
            });
        })
    }

    /// Lookup step `i` ([`samples_directly`]) of lanes `0..n` in `f32`:
    /// the coordinates, the level of detail and the filtered texel as
    /// [`FragmentProgram::lookup`] computes them, without the `f64` values;
    /// the texture unit over the lanes ([`crate::textures::lanes`]) where
    /// it covers the lookup, else lane by lane.
    ///
    /// `shared`: the batch's last 2-D lookup that went through the lanes'
    /// footprints; a lookup of a texture of the same shape at the same
    /// coordinates (the same slot: every slot is written once a batch) and
    /// the same varying's level of detail reuses its levels and footprints
    /// and only fetches its own texels (the same values: the same formulas
    /// on the same inputs).
    #[inline(always)]
    fn sample_lanes(
        &self,
        i: usize,
        r: &mut [Lanes],
        (fragments, varyings): (&[Fragment], Vary),
        lp: &LaneProgram,
        shared: &mut SharedLookup,
    ) {
        let s = &self.steps[i];
        let Some(Leaf::Lookup { texture, coords_ty, lod_from }) = s.leaf else { return };
        let Source::Bound { texture: b, .. } = &self.sources[texture as usize] else { return };
        let filter = self.filters[texture as usize];
        let n = fragments.len();
        let (lo, hi) = r.split_at_mut(s.slot as usize * 4);
        let c = |k: usize| lanes(lo, s.ops[0], k);
        let (c0, c1, c2) = (c(0), c(1), c(2));
        // Straight into the step's registers (no texel array zeroed and copied).
        let Some(texel) = hi.first_chunk_mut::<4>() else { return };
        match &b.texture {
            Texture::Flat(t) => {
                let l = &*shared;
                let same = (l.coords, l.coords_ty, l.lod_from) == (s.ops[0], coords_ty, lod_from);
                let levels = lp.levels.get(texture as usize).and_then(Option::as_ref);
                if l.valid && same && !plain() && l.f.fits_levels(levels, filter) {
                    #[cfg(test)]
                    tests::SHARED.fetch_add(1, Ordering::Relaxed);
                    l.f.fetch(t, n, texel);
                    return canonical(texel, width_of(s.ty), 0b1111);
                }
                let half = [0.5f32; BATCH];
                let v = if coords_ty == Ty::Scalar { &half } else { c1 };
                let mut lod = [f32::NEG_INFINITY; BATCH];
                if let Some(k) = lod_from.filter(|_| t.levels.len() > 1) {
                    let size = (t.width(), t.height());
                    let left = quad_lod_lanes(fragments, varyings, k, size, &mut lod);
                    for (lane, fragment) in fragments.iter().enumerate().filter(|&(l, _)| left[l]) {
                        let vary = [0, 1, 2, 3].map(|j| varyings.get(lane, 4 * k + j));
                        let d = |j| fragment.quad_derivatives(4 * k + j, vary[j]);
                        let (du, dv) = uv_derivatives(coords_ty, &vary, d);
                        lod[lane] = unit::quad_lod(t.width(), t.height(), [du[0], dv[0]], [du[1], dv[1]]);
                    }
                }
                shared.valid = shared.f.refill_with(levels, t, (c0, v, &lod), filter, self.latitude);
                if shared.valid {
                    (shared.coords, shared.coords_ty, shared.lod_from) = (s.ops[0], coords_ty, lod_from);
                    shared.f.fetch(t, n, texel);
                } else {
                    // Lane by lane: the lanes do not cover this lookup.
                    texture_lanes::sample_2d_lanes(t, c0, v, &lod, n, filter, self.latitude, texel)
                }
            }
            Texture::Cube(t) => {
                let weights = self.latitude.weights;
                let borders = lp.cubes.get(texture as usize).and_then(Option::as_ref);
                if !texture_lanes::sample_cube_lanes(t, borders, [c0, c1, c2], n, filter, weights, texel) {
                    for lane in 0..n {
                        let one = unit::sample_cube_with(t, [c0[lane], c1[lane], c2[lane]], filter, weights);
                        (0..4).for_each(|k| texel[k][lane] = one[k]);
                    }
                }
            }
            _ => *texel = [[f32::NAN; BATCH]; 4],
        }
        // As `FragmentProgram::lookup` narrows a texel to the node's type.
        canonical(texel, width_of(s.ty), 0b1111)
    }

    /// Step `i` of lane `lane` through the interpreter's [`FragmentProgram::step_value`].
    fn scalar_lane(
        &self,
        i: usize,
        r: &mut [Lanes],
        fragment: &Fragment,
        vary: &[f32],
        lane: usize,
        d: &mut bool,
    ) {
        let s = &self.steps[i];
        let mut buf = [[0.0f64; 4]; 4];
        for (b, &o) in buf.iter_mut().zip(&s.ops[..s.n_ops as usize]) {
            *b = [0, 1, 2, 3].map(|c| r[o as usize * 4 + c][lane] as f64);
        }
        let v = self.stored(s, self.step_value(i, &buf, fragment, vary, None, true, d));
        for (c, x) in v.into_iter().enumerate() {
            r[s.slot as usize * 4 + c][lane] = x as f32;
        }
    }
}

/// Runs the ops over the registers `r`: with AVX2 and FMA where the CPU
/// has them (the same code compiled for 8-lane vectors), else as built.
/// Each lane's fate and colour go to `outputs` ([`FragmentProgram::lane_outputs`]).
fn run(
    p: &FragmentProgram,
    lp: &LaneProgram,
    r: &mut [Lanes],
    batch: (&[Fragment], Vary),
    shared: &mut SharedLookup,
    outputs: (&mut [[f32; 4]], &mut [FragmentResult]),
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU has the features the function is compiled for.
        unsafe { run_avx2(p, lp, r, batch, shared, outputs) };
        return;
    }
    run_body(p, lp, r, batch, shared, outputs)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn run_avx2(
    p: &FragmentProgram,
    lp: &LaneProgram,
    r: &mut [Lanes],
    batch: (&[Fragment], Vary),
    shared: &mut SharedLookup,
    outputs: (&mut [[f32; 4]], &mut [FragmentResult]),
) {
    run_body(p, lp, r, batch, shared, outputs)
}

#[inline(always)]
fn run_body(
    p: &FragmentProgram,
    lp: &LaneProgram,
    r: &mut [Lanes],
    batch: (&[Fragment], Vary),
    shared: &mut SharedLookup,
    (out, results): (&mut [[f32; 4]], &mut [FragmentResult]),
) {
    let mut discard = [false; BATCH];
    let discard = &mut discard;
    let (fragments, varyings) = batch;
    let n = fragments.len();
    let mut vary = Vec::new();
    for (j, op) in lp.ops.iter().enumerate() {
        match *op {
            Op::Scalar(i) => {
                vary.resize(varyings.per, 0.0);
                for lane in 0..n {
                    // The fragment's own varyings, as the one-lane code takes them.
                    varyings.lane_into(lane, &mut vary);
                    p.scalar_lane(i as usize, r, &fragments[lane], &vary, lane, &mut discard[lane]);
                }
            }
            Op::Sample(i) => p.sample_lanes(i as usize, r, (fragments, varyings), lp, shared),
            Op::Lanes { .. } => match &lp.closures {
                Some(c) => c[j](r, varyings, n, discard),
                None => exec(*op, r, varyings, n, discard),
            },
        }
    }
    p.lane_outputs(r, discard, n, out, results);
}

/// `op` compiled into a closure (the kernel chosen here, once).
fn closure(op: &Op) -> Closure {
    let op = *op;
    macro_rules! bin {
        ($f:expr) => {{
            let Op::Lanes { dst, rows, width, keep, .. } = op else { unreachable!() };
            Box::new(move |r: &mut [Lanes], _: Vary, _: usize, _: &mut [bool; BATCH]| {
                let nn = BATCH;
                let (lo, hi) = r.split_at_mut(dst as usize * 4);
                let out = &mut hi[..4];
                for c in 0..width.max(1) as usize {
                    let (a, b) = (&lo[rows[0][c] as usize], &lo[rows[1][c] as usize]);
                    let o = &mut out[c];
                    for i in 0..nn {
                        o[i] = $f(a[i], b[i]);
                    }
                }
                canonical(out, width, keep);
            }) as Closure
        }};
    }
    match op {
        Op::Lanes { k: K::Add, .. } => bin!(|a: f32, b: f32| a + b),
        Op::Lanes { k: K::Sub, .. } => bin!(|a: f32, b: f32| a - b),
        Op::Lanes { k: K::Mul, .. } => bin!(|a: f32, b: f32| a * b),
        Op::Lanes { k: K::Max, .. } => bin!(|a: f32, b: f32| a.max(b)),
        Op::Lanes { k: K::Min, .. } => bin!(|a: f32, b: f32| a.min(b)),
        _ => Box::new(move |r, v, n, d| exec(op, r, v, n, d)),
    }
}

/// Makes the lanes of a result canonical for its width, in the components
/// `keep` names (a bit each; the others no one reads, [`demanded`]).
#[inline(always)]
fn canonical(out: &mut [Lanes], width: u8, keep: u8) {
    match width {
        1 => {
            let (x, rest) = out.split_at_mut(1);
            for (c, o) in rest.iter_mut().enumerate() {
                if keep & (2 << c) != 0 {
                    *o = x[0];
                }
            }
        }
        2..=3 => {
            for (c, o) in out.iter_mut().enumerate().skip(width as usize) {
                if keep & (1 << c) != 0 {
                    o.fill(0.0);
                }
            }
        }
        4 => {}
        _ => {
            for o in out {
                o.fill(f32::NAN);
            }
        }
    }
}

/// An op's operands: the registers below its destination, the operand
/// slots, the components it computes and the lanes it computes: all
/// [`BATCH`] (a constant trip count, so straight vector code without a
/// remainder; batches are filled across triangles, so most are full, and a
/// lane past the batch's fragments computes on stale values no one reads).
struct Operands<'r> {
    lo: &'r [Lanes],
    rows: [[u32; 4]; 4],
    comps: usize,
    nn: usize,
}

impl Operands<'_> {
    /// Component `c` of operand `j`.
    #[inline(always)]
    fn at(&self, j: usize, c: usize) -> &Lanes {
        &self.lo[self.rows[j][c] as usize]
    }
    #[inline(always)]
    fn a(&self, c: usize) -> &Lanes {
        self.at(0, c)
    }
    #[inline(always)]
    fn b(&self, c: usize) -> &Lanes {
        self.at(1, c)
    }
    #[inline(always)]
    fn c(&self, c: usize) -> &Lanes {
        self.at(2, c)
    }
}

/// One op over the [`BATCH`] lanes (the first `n` in use).
// Indexed loops over several lane arrays at once are the form that vectorises.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn exec(op: Op, r: &mut [Lanes], varyings: Vary, n: usize, discard: &mut [bool; BATCH]) {
    let Op::Lanes { k, dst, width, keep, rows, .. } = op else { return };
    let (lo, hi) = r.split_at_mut(dst as usize * 4);
    let out = &mut hi[..4];
    // Components computed: a width-1 result only its first (then splatted).
    let x = Operands { lo, rows, comps: width.clamp(1, 4) as usize, nn: BATCH };
    if componentwise(k, &x, out) {
        return canonical(out, width, keep);
    }
    match k {
        K::Dot(w) => {
            let o = &mut out[0];
            for i in 0..x.nn {
                o[i] = x.a(0)[i] * x.b(0)[i];
            }
            for c in 1..w as usize {
                for i in 0..x.nn {
                    o[i] += x.a(c)[i] * x.b(c)[i];
                }
            }
            // A scalar of a dot product: splat it whatever the node's width.
            splat_first(out, width, keep)
        }
        K::Length(w) => {
            let o = &mut out[0];
            length(o, |c| x.a(c), w, x.nn);
            for v in o.iter_mut() {
                *v = v.sqrt();
            }
            splat_first(out, width, keep)
        }
        K::Cmp(op) => {
            compare_lanes(op, &x, &mut out[0]);
            splat_first(out, width, keep)
        }
        K::Not => {
            let (a, o) = (x.a(0), &mut out[0]);
            for i in 0..x.nn {
                o[i] = (a[i] == 0.0) as u8 as f32;
            }
            splat_first(out, width, keep)
        }
        _ => {
            structural(k, &x, out, (varyings, n), discard);
            canonical(out, width, keep)
        }
    }
}

/// The ops computed component by component with one formula per lane;
/// false for the others.
// Indexed loops over several lane arrays at once are the form that vectorises.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn componentwise(k: K, x: &Operands, out: &mut [Lanes]) -> bool {
    macro_rules! each {
        (|$c:ident, $i:ident| $e:expr) => {
            for $c in 0..x.comps {
                let o = &mut out[$c];
                for $i in 0..x.nn {
                    o[$i] = $e;
                }
            }
        };
    }
    let (a, b, cc) = (|c| x.a(c), |c| x.b(c), |c| x.c(c));
    match k {
        K::Add => each!(|c, i| a(c)[i] + b(c)[i]),
        K::Sub => each!(|c, i| a(c)[i] - b(c)[i]),
        K::Mul => each!(|c, i| a(c)[i] * b(c)[i]),
        K::Div => each!(|c, i| a(c)[i] / b(c)[i]),
        K::Neg => each!(|c, i| -a(c)[i]),
        K::Max => each!(|c, i| a(c)[i].max(b(c)[i])),
        K::Min => each!(|c, i| a(c)[i].min(b(c)[i])),
        K::Clamp => each!(|c, i| a(c)[i].max(b(c)[i]).min(cc(c)[i])),
        K::Saturate => each!(|c, i| a(c)[i].clamp(0.0, 1.0)),
        K::Expand => each!(|c, i| 2.0 * a(c)[i] - 1.0),
        K::Compress => each!(|c, i| (a(c)[i] + 1.0) / 2.0),
        K::HalfBias => each!(|c, i| a(c)[i] - 0.5),
        K::AddSigned => each!(|c, i| a(c)[i] + b(c)[i] - 0.5),
        K::Abs => each!(|c, i| a(c)[i].abs()),
        K::Sqrt => each!(|c, i| a(c)[i].sqrt()),
        K::Rsqrt => each!(|c, i| 1.0 / a(c)[i].sqrt()),
        K::Floor => each!(|c, i| a(c)[i].floor()),
        K::Fract => each!(|c, i| a(c)[i] - a(c)[i].floor()),
        K::Step => each!(|c, i| if b(c)[i] < a(c)[i] { 0.0 } else { 1.0 }),
        K::Mix => each!(|c, i| a(c)[i] * (1.0 - cc(c)[i]) + b(c)[i] * cc(c)[i]),
        K::Same => each!(|c, i| a(c)[i]),
        K::RgbToRgba => each!(|c, i| if c == 3 { 1.0 } else { a(c)[i] }),
        K::Pow => each!(|c, i| a(c)[i].powf(b(c)[i])),
        K::PowInt(e) => (0..x.comps).for_each(|c| out[c] = power_lanes(a(c), e)),
        _ => return false,
    }
    true
}

/// `x^k` in every lane: [`ir::power_by_squaring`]'s products in its
/// order, each over the lanes (vector code; `power_by_squaring` per lane
/// kept its loop over `k`'s bits scalar, 2.6 % of a frame's samples for
/// Kilgard's `^8`), so the same values.
#[inline(always)]
fn power_lanes(x: &Lanes, k: u32) -> Lanes {
    let mul = |p: Lanes, q: Lanes| {
        let mut o = [0.0f32; BATCH];
        for ((o, a), b) in o.iter_mut().zip(&p).zip(&q) {
            *o = a * b;
        }
        o
    };
    ir::power_by_squaring(*x, k, mul)
}

/// A comparison or a logical operator of the first components, as 0 or 1:
/// the operator matched once, then one loop over the lanes (vector code;
/// matched per lane, the loop stayed scalar, ~2.5 % of a frame's samples
/// for Kilgard's one `≥`, BENCHMARKS.md, exec10).
#[inline(always)]
fn compare_lanes(op: BinaryOp, x: &Operands, o: &mut Lanes) {
    #[inline(always)]
    fn each(a: &Lanes, b: &Lanes, o: &mut Lanes, nn: usize, test: impl Fn(f32, f32) -> bool) {
        for i in 0..nn.min(BATCH) {
            o[i] = test(a[i], b[i]) as u8 as f32;
        }
    }
    let (a, b, nn) = (x.a(0), x.b(0), x.nn);
    match op {
        BinaryOp::Lt => each(a, b, o, nn, |a, b| a < b),
        BinaryOp::Le => each(a, b, o, nn, |a, b| a <= b),
        BinaryOp::Gt => each(a, b, o, nn, |a, b| a > b),
        BinaryOp::Ge => each(a, b, o, nn, |a, b| a >= b),
        BinaryOp::Eq => each(a, b, o, nn, |a, b| a == b),
        BinaryOp::Ne => each(a, b, o, nn, |a, b| a != b),
        BinaryOp::And => each(a, b, o, nn, |a, b| (a != 0.0) & (b != 0.0)),
        _ => each(a, b, o, nn, |a, b| (a != 0.0) | (b != 0.0)),
    }
}

/// The ops that move components (swizzles, composition, varyings,
/// selection) and normalization; `vary`: the batch's varyings (by
/// fragment or by component: [`Vary`]), and the lanes in use.
#[inline(always)]
fn structural(
    k: K,
    x: &Operands,
    out: &mut [Lanes],
    (varyings, n): (Vary, usize),
    discard: &mut [bool; BATCH],
) {
    match k {
        K::Swizzle(pattern, len) => {
            for (c, &from) in pattern[..len as usize].iter().enumerate() {
                out[c] = *x.a(from as usize & 3);
            }
        }
        K::Normalize(w) => {
            let mut len = [0.0f32; BATCH];
            length(&mut len, |c| x.a(c), w, x.nn);
            for v in len.iter_mut() {
                *v = v.sqrt();
            }
            for (c, o) in out.iter_mut().enumerate() {
                let a = x.a(c);
                for i in 0..x.nn {
                    o[i] = if len[i] == 0.0 { 0.0 } else { a[i] / len[i] };
                }
            }
        }
        K::Select(with_reject) => select(x, out, with_reject, n, discard),
        K::Compose(ws) => {
            let mut at = 0;
            for (j, &w) in ws.iter().enumerate() {
                for c in 0..w as usize {
                    if at < 4 {
                        out[at] = *x.at(j, c);
                    }
                    at += 1;
                }
            }
        }
        K::Varying(kv) => {
            for (c, o) in out[..x.comps].iter_mut().enumerate() {
                let at = 4 * kv as usize + c;
                match varyings.row(at, n) {
                    // Stored by component: one row, a vector copy.
                    Some(row) => o[..n].copy_from_slice(row),
                    None => {
                        for (i, v) in o[..n].iter_mut().enumerate() {
                            *v = varyings.get(i, at);
                        }
                    }
                }
            }
        }
        _ => {}
    }
}

/// `c ? a : b`; without `b`, a lane whose `c` is 0 is discarded (NaN).
// Indexed loops over several lane arrays at once are the form that vectorises.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn select(x: &Operands, out: &mut [Lanes], with_reject: bool, n: usize, discard: &mut [bool; BATCH]) {
    let cond = x.a(0);
    for c in 0..x.comps {
        let (a, b) = (x.b(c), if with_reject { x.c(c) } else { x.b(c) });
        let o = &mut out[c];
        for i in 0..x.nn {
            o[i] = if cond[i] != 0.0 { a[i] } else { b[i] };
        }
    }
    if !with_reject {
        for i in 0..n {
            if cond[i] == 0.0 {
                discard[i] = true;
                for o in out.iter_mut() {
                    o[i] = f32::NAN;
                }
            }
        }
    }
}

/// The sum of squares of `a`'s first `w` components, into `o`.
#[inline(always)]
fn length<'x>(o: &mut Lanes, a: impl Fn(usize) -> &'x Lanes, w: u8, nn: usize) {
    let x = a(0);
    for i in 0..nn {
        o[i] = x[i] * x[i];
    }
    for c in 1..w as usize {
        let x = a(c);
        for i in 0..nn {
            o[i] += x[i] * x[i];
        }
    }
}

/// A scalar result in the first component, splatted (or NaN for a node
/// without a numeric width).
#[inline(always)]
fn splat_first(out: &mut [Lanes], width: u8, keep: u8) {
    canonical(out, if width == 0 { 0 } else { 1 }, keep)
}

/// Whether the lane code runs plain: every result written in all four
/// components, every lookup computing its own footprints and a cube's
/// seam lanes going through the one-lane code — never,
/// except in this module's test that renders both ways.
#[inline(always)]
fn plain() -> bool {
    #[cfg(test)]
    return tests::PLAIN.load(Ordering::Relaxed);
    #[cfg(not(test))]
    false
}

#[path = "lane_outputs.rs"]
mod outputs;

#[path = "lane_copies.rs"]
mod copies;
use copies::{demanded, forward_copies};

#[cfg(test)]
#[path = "lanes_tests.rs"]
mod tests;
