//! A CPU emulator of the register-combiner machine (Kilgard 2000, Section 4.2,
//! Figures 7-10): every pixel runs the general stages in order, then the
//! final combiner.
//!
//! Two precision models ([`Precision`]): `Fixed9`, the hardware's 8 bits +
//! sign (GeForce3 Phong, Section 5.2: range [−255, 255]/255) with one rounding per
//! register write, and `F32`. docs/combiners.md states each rule.
//!
//! Speed: pixels are processed in tiles of [`TILE`] with the register file
//! as a structure of arrays (one slice per register channel), the per-tile
//! buffers are allocated once per worker, and tiles run on all cores with
//! rayon. Inner loops are branch-free per input mapping so they vectorise.
//!
//! [`PixelEmulator`] runs the same steps on one pixel at a time, registers
//! on the stack and the same precision models on one-element slices, for
//! the CPU renderer's `fixed9` mode, which shades fragment by fragment
//! (blending and depth need each fragment's colour before the next).

use std::cell::RefCell;

use rayon::prelude::*;
use thiserror::Error;

use super::config::{
    Bias, Color, CombinerConfig, CombinerLimits, ComponentUsage, FinalSource, GeneralInput, PortionKind,
    Register, Scale,
};
use super::validate::{validate, ValidationError};

mod precision;
pub use precision::HARDWARE_HALF;
use precision::{Fixed9, Model, F32, F64};

/// Pixels per tile.
pub const TILE: usize = 256;

pub use crate::numerics::Precision;

/// Per-pixel inputs (RGBA8, `width * height * 4` bytes, row-major) and the
/// uniform ones. A missing image reads as (0, 0, 0, 0).
#[derive(Clone, Copy, Debug, Default)]
pub struct Inputs<'a> {
    pub width: usize,
    pub height: usize,
    pub textures: [Option<&'a [u8]>; 4],
    pub primary: Option<&'a [u8]>,
    pub secondary: Option<&'a [u8]>,
    /// Fog colour (rgb) and fog factor (alpha).
    pub fog: Color,
    /// Constant colours used when the config does not set them (its own
    /// constants override these, as in nvparse).
    pub constant0: Color,
    pub constant1: Color,
}

/// Why the combiner emulator cannot run a configuration over its inputs.
#[derive(Debug, Error, PartialEq)]
pub enum EmulateError {
    #[error("{what} has {got} bytes, but a {width}x{height} RGBA8 image has {expected}")]
    SizeMismatch { what: String, got: usize, expected: usize, width: usize, height: usize },
    #[error("output buffer has {got} bytes, expected {expected}")]
    OutputSize { got: usize, expected: usize },
    #[error("the combiner setup is invalid: {}", .0.first().map(ToString::to_string).unwrap_or_default())]
    Invalid(Vec<ValidationError>),
}

/// Runs `config` on every pixel; returns the final combiner's RGBA as RGBA8.
pub fn emulate(
    config: &CombinerConfig,
    inputs: &Inputs,
    precision: Precision,
) -> Result<Vec<u8>, EmulateError> {
    let len = inputs.width.checked_mul(inputs.height).and_then(|n| n.checked_mul(4)).unwrap_or(usize::MAX);
    if len == usize::MAX {
        return Err(EmulateError::OutputSize { got: 0, expected: len });
    }
    let mut out = vec![0u8; len];
    emulate_into(config, inputs, precision, &mut out)?;
    Ok(out)
}

/// Like [`emulate`], writing into `out` (`width * height * 4` bytes).
pub fn emulate_into(
    config: &CombinerConfig,
    inputs: &Inputs,
    precision: Precision,
    out: &mut [u8],
) -> Result<(), EmulateError> {
    // The emulator runs anything a geforce3 accepts (and NV2A's alpha dot
    // products); the caller checks its own profile.
    validate(config, &CombinerLimits::GEFORCE3.permissive()).map_err(EmulateError::Invalid)?;
    let expected = inputs.width.saturating_mul(inputs.height).saturating_mul(4);
    if out.len() != expected {
        return Err(EmulateError::OutputSize { got: out.len(), expected });
    }
    let images = [
        ("texture0", inputs.textures[0]),
        ("texture1", inputs.textures[1]),
        ("texture2", inputs.textures[2]),
        ("texture3", inputs.textures[3]),
        ("primary", inputs.primary),
        ("secondary", inputs.secondary),
    ];
    for (what, image) in images {
        if let Some(image) = image {
            if image.len() != expected {
                return Err(EmulateError::SizeMismatch {
                    what: what.into(),
                    got: image.len(),
                    expected,
                    width: inputs.width,
                    height: inputs.height,
                });
            }
        }
    }
    let plan = Plan::new(config, inputs);
    match precision {
        Precision::Fixed9 => run::<Fixed9>(&plan, inputs, out),
        Precision::F32 => run::<F32>(&plan, inputs, out),
        Precision::Exact => run::<F64>(&plan, inputs, out),
    }
    Ok(())
}

/// One pixel's per-pixel registers (Kilgard 2000, Table 2): the four texture
/// registers and the primary and secondary colours (RGBA8). A texture
/// register is 9-bit signed, −255..=255 for −1..1: a signed texture's texel
/// (a HILO normalization map, GeForce3 Phong, Section 5.1) is negative where its
/// component is; an unsigned texel is 0..=255.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelRegisters {
    pub textures: [[i16; 4]; 4],
    pub primary: [u8; 4],
    pub secondary: [u8; 4],
}

/// A validated config with its constants and fog resolved, run one pixel at
/// a time ([`PixelEmulator::run`]) with the same precision models as
/// [`emulate`], so a renderer's fixed9 fragments are exactly what `shadec
/// emulate` computes from the same registers
/// (tests/combiners_emulator.rs, `pixel_emulator_equals_tiled`).
pub struct PixelEmulator {
    plan: Plan,
    fog: Color,
    precision: Precision,
}

impl PixelEmulator {
    /// `constant0`, `constant1`: used where the config leaves a constant
    /// colour unset (its own override them, as in [`Inputs`]).
    pub fn new(
        config: &CombinerConfig,
        constant0: Color,
        constant1: Color,
        fog: Color,
        precision: Precision,
    ) -> Result<PixelEmulator, EmulateError> {
        validate(config, &CombinerLimits::GEFORCE3.permissive()).map_err(EmulateError::Invalid)?;
        let inputs = Inputs { constant0, constant1, fog, ..Inputs::default() };
        Ok(PixelEmulator { plan: Plan::new(config, &inputs), fog, precision })
    }

    /// The final combiner's RGBA for one pixel's registers.
    pub fn run(&self, r: &PixelRegisters) -> [u8; 4] {
        match self.precision {
            Precision::Fixed9 => pixel::<Fixed9>(&self.plan, self.fog, r),
            Precision::F32 => pixel::<F32>(&self.plan, self.fog, r),
            Precision::Exact => pixel::<F64>(&self.plan, self.fog, r),
        }
    }

    /// [`PixelEmulator::run`] of many pixels at once (at most [`TILE`]),
    /// through the tile engine's structure of arrays (the CPU
    /// renderer's batched fragments); the same colours as `run` on each
    /// (test below).
    pub fn run_many(&self, registers: &[PixelRegisters], out: &mut [[u8; 4]]) {
        assert!(registers.len() <= TILE && out.len() == registers.len());
        match self.precision {
            Precision::Fixed9 => SCRATCH_FIXED9.with(|c| self.many::<Fixed9>(c, registers, out)),
            Precision::F32 => SCRATCH_F32.with(|c| self.many::<F32>(c, registers, out)),
            Precision::Exact => SCRATCH_F64.with(|c| self.many::<F64>(c, registers, out)),
        }
    }

    fn many<M: Model>(
        &self,
        cell: &RefCell<Option<Scratch<M>>>,
        registers: &[PixelRegisters],
        out: &mut [[u8; 4]],
    ) {
        let mut cell = cell.borrow_mut();
        let s = cell.get_or_insert_with(|| Scratch::new(self.fog));
        s.fill(Register::Fog, self.fog);
        let n = registers.len();
        let mut load = |r: Register, ch: usize, value: &dyn Fn(&PixelRegisters) -> M::R| {
            for (d, px) in s.reg_mut(r.index(), ch)[..n].iter_mut().zip(registers) {
                *d = value(px);
            }
        };
        for ch in 0..4 {
            for (k, t) in [Register::Texture0, Register::Texture1, Register::Texture2, Register::Texture3]
                .into_iter()
                .enumerate()
            {
                load(t, ch, &|px| M::from_i9(px.textures[k][ch]));
            }
            load(Register::Primary, ch, &|px| M::from_u8(px.primary[ch]));
            load(Register::Secondary, ch, &|px| M::from_u8(px.secondary[ch]));
            // spare0: RGB undefined (zero here), alpha = texture 0 alpha; spare1 zero.
            load(Register::Spare0, ch, &|px| {
                if ch == 3 {
                    M::from_i9(px.textures[0][3])
                } else {
                    M::R::default()
                }
            });
            load(Register::Spare1, ch, &|_| M::R::default());
        }
        stages::<M>(&self.plan, s, n, out.as_flattened_mut());
    }
}

thread_local! {
    static SCRATCH_FIXED9: RefCell<Option<Scratch<Fixed9>>> = const { RefCell::new(None) };
    static SCRATCH_F32: RefCell<Option<Scratch<F32>>> = const { RefCell::new(None) };
    static SCRATCH_F64: RefCell<Option<Scratch<F64>>> = const { RefCell::new(None) };
}

// ---------------------------------------------------------------------------
// One pixel: the tile engine's steps with the register file on the stack and
// the same precision models applied to one-element slices.

type Regs<M> = [[<M as Model>::R; 4]; N_REGS];

fn one<T>(v: &T) -> &[T] {
    std::slice::from_ref(v)
}

fn one_mut<T>(v: &mut T) -> &mut [T] {
    std::slice::from_mut(v)
}

fn pixel<M: Model>(plan: &Plan, fog: Color, input: &PixelRegisters) -> [u8; 4] {
    let mut r: Regs<M> = [[M::R::default(); 4]; N_REGS];
    let load = |px: [u8; 4]| px.map(M::from_u8);
    for (k, t) in input.textures.iter().enumerate() {
        r[Register::Texture0.index() + k] = t.map(M::from_i9);
    }
    r[Register::Primary.index()] = load(input.primary);
    r[Register::Secondary.index()] = load(input.secondary);
    r[Register::Fog.index()] = fog.map(M::from_unit);
    // spare0: RGB undefined (zero here), alpha = texture 0 alpha; spare1 zero.
    r[Register::Spare0.index()][3] = r[Register::Texture0.index()][3];
    for stage in &plan.stages {
        r[Register::Constant0.index()] = stage.constants[0].map(M::from_unit);
        r[Register::Constant1.index()] = stage.constants[1].map(M::from_unit);
        // Both portions read the registers as the stage found them; write after.
        let rgb = pixel_portion::<M>(&r, &stage.rgb, PortionKind::Rgb);
        let alpha = pixel_portion::<M>(&r, &stage.alpha, PortionKind::Alpha);
        for (slot, reg) in stage.rgb.outputs.iter().enumerate() {
            if let Some(reg) = reg {
                r[reg.index()][..3].copy_from_slice(&rgb[slot]);
            }
        }
        for (slot, reg) in stage.alpha.outputs.iter().enumerate() {
            if let Some(reg) = reg {
                r[reg.index()][3] = alpha[slot][0];
            }
        }
    }
    r[Register::Constant0.index()] = plan.global_constants[0].map(M::from_unit);
    r[Register::Constant1.index()] = plan.global_constants[1].map(M::from_unit);
    pixel_final::<M>(&r, &plan.final_combiner)
}

/// One portion of one pixel: the AB, CD and sum outputs (rgb: 3 channels,
/// alpha: channel 0), after scale, bias and clamp (as [`portion`]).
fn pixel_portion<M: Model>(r: &Regs<M>, p: &PortionPlan, kind: PortionKind) -> [[M::R; 3]; 3] {
    let mut out = [[M::R::default(); 3]; 3];
    if !p.need_ab && !p.need_cd {
        return out;
    }
    let channels = if kind == PortionKind::Rgb { 3 } else { 1 };
    let mut mapped = [[M::V::default(); 3]; 4];
    for (v, input) in p.inputs.iter().enumerate() {
        if (v < 2 && !p.need_ab) || (v >= 2 && !p.need_cd) {
            continue;
        }
        for (ch, dst) in mapped[v].iter_mut().enumerate().take(channels) {
            let src_ch = source_channel(kind, input.usage, ch);
            M::map(input.mapping, one(&r[input.register.index()][src_ch]), one_mut(dst));
        }
    }
    // A dot product in the alpha portion (NV2A, `--permissive`) is the
    // one-component dot product: the plain product.
    let product = |a: usize, dot: bool| {
        let mut w = [M::W::default(); 3];
        if dot && kind == PortionKind::Rgb {
            M::mul(one(&mapped[a][0]), one(&mapped[a + 1][0]), one_mut(&mut w[0]));
            M::mul_add(one(&mapped[a][1]), one(&mapped[a + 1][1]), one_mut(&mut w[0]));
            M::mul_add(one(&mapped[a][2]), one(&mapped[a + 1][2]), one_mut(&mut w[0]));
            w = [w[0]; 3];
        } else {
            for ch in 0..channels {
                M::mul(one(&mapped[a][ch]), one(&mapped[a + 1][ch]), one_mut(&mut w[ch]));
            }
        }
        w
    };
    let ab = if p.need_ab { product(0, p.ab_dot) } else { [M::W::default(); 3] };
    let cd = if p.need_cd { product(2, p.cd_dot) } else { [M::W::default(); 3] };
    let mut sum = [M::W::default(); 3];
    if p.outputs[2].is_some() {
        let spare0_alpha = r[Register::Spare0.index()][3];
        for ch in 0..channels {
            if p.mux {
                M::mux(one(&spare0_alpha), one(&ab[ch]), one(&cd[ch]), one_mut(&mut sum[ch]));
            } else {
                M::add(one(&ab[ch]), one(&cd[ch]), one_mut(&mut sum[ch]));
            }
        }
    }
    let sources = [ab, cd, sum];
    for (slot, o) in p.outputs.iter().enumerate() {
        if o.is_some() {
            for ch in 0..channels {
                M::output(one(&sources[slot][ch]), p.scale, p.bias, one_mut(&mut out[slot][ch]));
            }
        }
    }
    out
}

/// The final combiner of one pixel (as [`final_combiner`]).
fn pixel_final<M: Model>(r: &Regs<M>, fc: &super::config::FinalCombiner) -> [u8; 4] {
    let vars = [fc.a, fc.b, fc.c, fc.d, fc.e, fc.f, fc.g];
    let uses = |src: FinalSource| vars[..4].iter().any(|v| v.source == src);
    let read = |v: usize, ch: usize, ef: &[M::R; 3], cs: &[M::R; 3]| -> M::R {
        let input = vars[v];
        let mut d = M::R::default();
        match input.source {
            FinalSource::Register(reg) => {
                let src_ch = match input.usage {
                    ComponentUsage::Blue => 2,
                    _ if v == 6 => 3,
                    ComponentUsage::Alpha => 3,
                    ComponentUsage::Rgb => ch,
                };
                M::final_map(input.mapping, one(&r[reg.index()][src_ch]), one_mut(&mut d));
            }
            FinalSource::EfProduct => M::final_map(input.mapping, one(&ef[ch]), one_mut(&mut d)),
            FinalSource::Spare0PlusSecondary => M::final_map(input.mapping, one(&cs[ch]), one_mut(&mut d)),
        }
        d
    };
    let zero = [M::R::default(); 3];
    let mut ef = zero;
    if uses(FinalSource::EfProduct) {
        for (ch, o) in ef.iter_mut().enumerate() {
            let (e, f) = (read(4, ch, &zero, &zero), read(5, ch, &zero, &zero));
            M::ef(one(&e), one(&f), one_mut(o));
        }
    }
    let mut cs = zero;
    if uses(FinalSource::Spare0PlusSecondary) {
        for (ch, o) in cs.iter_mut().enumerate() {
            M::color_sum(
                one(&r[Register::Spare0.index()][ch]),
                one(&r[Register::Secondary.index()][ch]),
                fc.color_sum_clamp,
                one_mut(o),
            );
        }
    }
    let mut px = [0u8; 4];
    for (ch, p) in px.iter_mut().take(3).enumerate() {
        let v = [0, 1, 2, 3].map(|k| read(k, ch, &ef, &cs));
        let mut o = M::R::default();
        M::lerp_add(one(&v[0]), one(&v[1]), one(&v[2]), one(&v[3]), one_mut(&mut o));
        *p = M::to_u8(o);
    }
    px[3] = M::to_u8(read(6, 0, &ef, &cs));
    px
}

// ---------------------------------------------------------------------------
// The plan: the config with constants resolved and dead work marked.

struct PortionPlan {
    inputs: [GeneralInput; 4],
    outputs: [Option<Register>; 3],
    ab_dot: bool,
    cd_dot: bool,
    mux: bool,
    scale: Scale,
    bias: Bias,
    need_ab: bool,
    need_cd: bool,
}

struct StagePlan {
    rgb: PortionPlan,
    alpha: PortionPlan,
    constants: [Color; 2],
}

struct Plan {
    stages: Vec<StagePlan>,
    global_constants: [Color; 2],
    final_combiner: super::config::FinalCombiner,
}

impl Plan {
    fn new(config: &CombinerConfig, inputs: &Inputs) -> Plan {
        let global_constants =
            [config.constant0.unwrap_or(inputs.constant0), config.constant1.unwrap_or(inputs.constant1)];
        let portion = |p: &super::config::GeneralPortion| {
            let sum = p.sum_output.is_some();
            PortionPlan {
                inputs: [p.a, p.b, p.c, p.d],
                outputs: [p.ab_output, p.cd_output, p.sum_output],
                ab_dot: p.ab_dot,
                cd_dot: p.cd_dot,
                mux: p.mux_sum,
                scale: p.scale,
                bias: p.bias,
                need_ab: p.ab_output.is_some() || sum,
                need_cd: p.cd_output.is_some() || sum,
            }
        };
        let stages = config
            .general
            .iter()
            .map(|s| StagePlan {
                rgb: portion(&s.rgb),
                alpha: portion(&s.alpha),
                constants: [
                    s.constant0.unwrap_or(global_constants[0]),
                    s.constant1.unwrap_or(global_constants[1]),
                ],
            })
            .collect();
        Plan { stages, global_constants, final_combiner: config.final_combiner }
    }
}

// ---------------------------------------------------------------------------
// The tile engine.

const N_REGS: usize = 12;

/// Per-worker buffers, allocated once and reused for every tile.
struct Scratch<M: Model> {
    /// `N_REGS × 4` channel slices of `TILE`.
    regs: Vec<M::R>,
    /// Mapped A-D, 3 channels each.
    mapped: Vec<M::V>,
    ab: Vec<M::W>,
    cd: Vec<M::W>,
    sum: Vec<M::W>,
    /// Stage results before they are written: rgb 3 slots × 3 channels, alpha 3 slots.
    staged_rgb: Vec<M::R>,
    staged_alpha: Vec<M::R>,
    /// Final combiner: A-G (3 channels each), EF, colour sum, result.
    fin: Vec<M::R>,
    ef: Vec<M::R>,
    cs: Vec<M::R>,
    rgb: Vec<M::R>,
    /// Which constants the constant registers hold now.
    constants: Option<[Color; 2]>,
}

impl<M: Model> Scratch<M> {
    fn new(fog: Color) -> Scratch<M> {
        let mut s = Scratch {
            regs: vec![M::R::default(); N_REGS * 4 * TILE],
            mapped: vec![M::V::default(); 4 * 3 * TILE],
            ab: vec![M::W::default(); 3 * TILE],
            cd: vec![M::W::default(); 3 * TILE],
            sum: vec![M::W::default(); 3 * TILE],
            staged_rgb: vec![M::R::default(); 3 * 3 * TILE],
            staged_alpha: vec![M::R::default(); 3 * TILE],
            fin: vec![M::R::default(); 7 * 3 * TILE],
            ef: vec![M::R::default(); 3 * TILE],
            cs: vec![M::R::default(); 3 * TILE],
            rgb: vec![M::R::default(); 3 * TILE],
            constants: None,
        };
        s.fill(Register::Zero, [0.0; 4]);
        s.fill(Register::Fog, fog);
        s
    }

    fn fill(&mut self, r: Register, c: Color) {
        for (ch, &v) in c.iter().enumerate() {
            let v = M::from_unit(v);
            self.reg_mut(r.index(), ch).fill(v);
        }
    }

    fn set_constants(&mut self, c: [Color; 2]) {
        if self.constants != Some(c) {
            self.fill(Register::Constant0, c[0]);
            self.fill(Register::Constant1, c[1]);
            self.constants = Some(c);
        }
    }

    fn reg_mut(&mut self, r: usize, ch: usize) -> &mut [M::R] {
        &mut self.regs[(r * 4 + ch) * TILE..][..TILE]
    }
}

fn reg<M: Model>(regs: &[M::R], r: usize, ch: usize, n: usize) -> &[M::R] {
    &regs[(r * 4 + ch) * TILE..][..n]
}

fn run<M: Model>(plan: &Plan, inputs: &Inputs, out: &mut [u8]) {
    out.par_chunks_mut(TILE * 4).enumerate().for_each_init(
        || Scratch::<M>::new(inputs.fog),
        |scratch, (tile_idx, out)| tile::<M>(plan, inputs, scratch, tile_idx * TILE, out),
    );
}

fn tile<M: Model>(plan: &Plan, inputs: &Inputs, s: &mut Scratch<M>, first: usize, out: &mut [u8]) {
    let n = out.len() / 4;
    // Load the per-pixel registers (Section 4.2.1).
    let images = [
        (Register::Texture0, inputs.textures[0]),
        (Register::Texture1, inputs.textures[1]),
        (Register::Texture2, inputs.textures[2]),
        (Register::Texture3, inputs.textures[3]),
        (Register::Primary, inputs.primary),
        (Register::Secondary, inputs.secondary),
    ];
    for (r, image) in images {
        match image {
            Some(image) => {
                let src = &image[first * 4..(first + n) * 4];
                for ch in 0..4 {
                    let dst = s.reg_mut(r.index(), ch);
                    for (d, px) in dst[..n].iter_mut().zip(src.chunks_exact(4)) {
                        *d = M::from_u8(px[ch]);
                    }
                }
            }
            None => (0..4).for_each(|ch| s.reg_mut(r.index(), ch)[..n].fill(M::R::default())),
        }
    }
    // spare0: RGB undefined (zero here), alpha = texture 0 alpha; spare1 undefined (zero).
    for ch in 0..3 {
        s.reg_mut(Register::Spare0.index(), ch)[..n].fill(M::R::default());
    }
    let (t0a, spare0a) = (Register::Texture0.index() * 4 + 3, Register::Spare0.index() * 4 + 3);
    s.regs.copy_within(t0a * TILE..t0a * TILE + n, spare0a * TILE);
    for ch in 0..4 {
        s.reg_mut(Register::Spare1.index(), ch)[..n].fill(M::R::default());
    }
    stages::<M>(plan, s, n, out);
}

/// The general stages and the final combiner over the first `n` pixels of
/// the loaded register file, into `out` (RGBA8).
fn stages<M: Model>(plan: &Plan, s: &mut Scratch<M>, n: usize, out: &mut [u8]) {
    for stage in &plan.stages {
        s.set_constants(stage.constants);
        portion::<M>(s, &stage.rgb, PortionKind::Rgb, n);
        portion::<M>(s, &stage.alpha, PortionKind::Alpha, n);
        // Both portions read the registers as the stage found them; write now.
        for (slot, r) in stage.rgb.outputs.iter().enumerate() {
            if let Some(r) = r {
                for ch in 0..3 {
                    let at = (r.index() * 4 + ch) * TILE;
                    s.regs[at..at + n].copy_from_slice(&s.staged_rgb[(slot * 3 + ch) * TILE..][..n]);
                }
            }
        }
        for (slot, r) in stage.alpha.outputs.iter().enumerate() {
            if let Some(r) = r {
                let at = (r.index() * 4 + 3) * TILE;
                s.regs[at..at + n].copy_from_slice(&s.staged_alpha[slot * TILE..][..n]);
            }
        }
    }
    s.set_constants(plan.global_constants);
    final_combiner::<M>(s, &plan.final_combiner, n, out);
}

/// One portion of a general stage, into `staged_rgb` / `staged_alpha`.
fn portion<M: Model>(s: &mut Scratch<M>, p: &PortionPlan, kind: PortionKind, n: usize) {
    if !p.need_ab && !p.need_cd {
        return;
    }
    let channels = if kind == PortionKind::Rgb { 3 } else { 1 };
    // Map the variables that are needed.
    for (v, input) in p.inputs.iter().enumerate() {
        if (v < 2 && !p.need_ab) || (v >= 2 && !p.need_cd) {
            continue;
        }
        for ch in 0..channels {
            let src_ch = source_channel(kind, input.usage, ch);
            let src = reg::<M>(&s.regs, input.register.index(), src_ch, n);
            M::map(input.mapping, src, &mut s.mapped[(v * 3 + ch) * TILE..][..n]);
        }
    }
    let mapped = &s.mapped;
    let var = |v: usize, ch: usize| &mapped[(v * 3 + ch) * TILE..][..n];
    // An alpha-portion dot product (NV2A, `--permissive`) is the plain product.
    let rgb_dot = |dot: bool| dot && kind == PortionKind::Rgb;
    let product = |a: usize, dot: bool, dst: &mut [M::W]| {
        if rgb_dot(dot) {
            let dst = &mut dst[..n];
            M::mul(var(a, 0), var(a + 1, 0), dst);
            M::mul_add(var(a, 1), var(a + 1, 1), dst);
            M::mul_add(var(a, 2), var(a + 1, 2), dst);
        } else {
            for ch in 0..channels {
                M::mul(var(a, ch), var(a + 1, ch), &mut dst[ch * TILE..][..n]);
            }
        }
    };
    if p.need_ab {
        product(0, p.ab_dot, &mut s.ab);
        if rgb_dot(p.ab_dot) {
            smear::<M>(&mut s.ab, n);
        }
    }
    if p.need_cd {
        product(2, p.cd_dot, &mut s.cd);
        if rgb_dot(p.cd_dot) {
            smear::<M>(&mut s.cd, n);
        }
    }
    if p.outputs[2].is_some() {
        let spare0_alpha = reg::<M>(&s.regs, Register::Spare0.index(), 3, n);
        for ch in 0..channels {
            let (ab, cd) = (&s.ab[ch * TILE..][..n], &s.cd[ch * TILE..][..n]);
            let dst = &mut s.sum[ch * TILE..][..n];
            if p.mux {
                M::mux(spare0_alpha, ab, cd, dst);
            } else {
                M::add(ab, cd, dst);
            }
        }
    }
    let sources = [&s.ab, &s.cd, &s.sum];
    for (slot, out) in p.outputs.iter().enumerate() {
        if out.is_none() {
            continue;
        }
        for ch in 0..channels {
            let src = &sources[slot][ch * TILE..][..n];
            let dst = match kind {
                PortionKind::Rgb => &mut s.staged_rgb[(slot * 3 + ch) * TILE..][..n],
                PortionKind::Alpha => &mut s.staged_alpha[slot * TILE..][..n],
            };
            M::output(src, p.scale, p.bias, dst);
        }
    }
}

/// The register channel a portion's variable reads for output channel `ch`
/// (Section 4.2.2: RGB, alpha or blue component usage).
fn source_channel(kind: PortionKind, usage: ComponentUsage, ch: usize) -> usize {
    match (kind, usage) {
        (PortionKind::Rgb, ComponentUsage::Rgb) => ch,
        (_, ComponentUsage::Alpha) => 3,
        (_, ComponentUsage::Blue) => 2,
        // Invalid (rejected by validation); read alpha.
        (PortionKind::Alpha, ComponentUsage::Rgb) => 3,
    }
}

/// Copies a dot product (channel 0) to channels 1 and 2 (Section 4.2.2:
/// "the dot product result is a scalar so it is smeared across RGB").
fn smear<M: Model>(buf: &mut [M::W], n: usize) {
    let (first, rest) = buf.split_at_mut(TILE);
    rest[..n].copy_from_slice(&first[..n]);
    rest[TILE..TILE + n].copy_from_slice(&first[..n]);
}

fn final_combiner<M: Model>(s: &mut Scratch<M>, fc: &super::config::FinalCombiner, n: usize, out: &mut [u8]) {
    // Pseudo-registers first: EF needs E and F, spare0+secondary needs nothing.
    let vars = [fc.a, fc.b, fc.c, fc.d, fc.e, fc.f, fc.g];
    let load = |s: &mut Scratch<M>, v: usize, ch: usize| {
        let input = vars[v];
        let dst = &mut s.fin[(v * 3 + ch) * TILE..][..n];
        match input.source {
            FinalSource::Register(r) => {
                let src_ch = match input.usage {
                    ComponentUsage::Blue => 2,
                    _ if v == 6 => 3,
                    ComponentUsage::Alpha => 3,
                    ComponentUsage::Rgb => ch,
                };
                M::final_map(input.mapping, reg::<M>(&s.regs, r.index(), src_ch, n), dst);
            }
            FinalSource::EfProduct => M::final_map(input.mapping, &s.ef[ch * TILE..][..n], dst),
            FinalSource::Spare0PlusSecondary => M::final_map(input.mapping, &s.cs[ch * TILE..][..n], dst),
        }
    };
    let uses = |src: FinalSource| vars[..4].iter().any(|v| v.source == src);
    if uses(FinalSource::EfProduct) {
        for ch in 0..3 {
            load(s, 4, ch);
            load(s, 5, ch);
            let (e, f) = (&s.fin[(4 * 3 + ch) * TILE..][..n], &s.fin[(5 * 3 + ch) * TILE..][..n]);
            M::ef(e, f, &mut s.ef[ch * TILE..][..n]);
        }
    }
    if uses(FinalSource::Spare0PlusSecondary) {
        for ch in 0..3 {
            let spare0 = reg::<M>(&s.regs, Register::Spare0.index(), ch, n);
            let secondary = reg::<M>(&s.regs, Register::Secondary.index(), ch, n);
            M::color_sum(spare0, secondary, fc.color_sum_clamp, &mut s.cs[ch * TILE..][..n]);
        }
    }
    for ch in 0..3 {
        for v in 0..4 {
            load(s, v, ch);
        }
        let f = &s.fin;
        let var = |v: usize| &f[(v * 3 + ch) * TILE..][..n];
        M::lerp_add(var(0), var(1), var(2), var(3), &mut s.rgb[ch * TILE..][..n]);
    }
    load(s, 6, 0);
    let g = &s.fin[(6 * 3) * TILE..][..n];
    for (i, px) in out.chunks_exact_mut(4).enumerate() {
        px[0] = M::to_u8(s.rgb[i]);
        px[1] = M::to_u8(s.rgb[TILE + i]);
        px[2] = M::to_u8(s.rgb[2 * TILE + i]);
        px[3] = M::to_u8(g[i]);
    }
}

#[cfg(test)]
mod tests {
    use super::precision::{div255_floor, round_2040};

    #[test]
    fn div255_floor_is_exact() {
        for y in 0..(1 << 21) {
            assert_eq!(div255_floor(y), y / 255, "y = {y}");
        }
    }

    /// The vectorizable rounding equals the plain integer one over the whole
    /// range a stage output can reach (|(v + bias) · scale| ≤ 5.3e6).
    #[test]
    fn round_2040_matches_integer_division() {
        const K: i32 = 4096;
        for t in -5_300_000..=5_300_000 {
            let reference = (((t + 1020 + 2040 * K) as u32) / 2040) as i32 - K;
            assert_eq!(round_2040(t), reference, "t = {t}");
        }
    }
}
