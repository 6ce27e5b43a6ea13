//! A CPU interpreter of vertex programs in IEEE f32, as NV_vertex_program
//! (NVIDIA 2001, Section 2.14.1.10) specifies each instruction in
//! pseudo-code. Where the spec allows an approximation (RCP, RSQ, and the
//! "rough" base-2 logarithm, exponential and power of LOG, EXP and LIT, at
//! least 11 bits), this computes the f32 function itself: the spec's
//! bounds hold with room to spare, and the WGSL translation computes the
//! same functions.
//!
//! At the start of every vertex the temporaries are (0, 0, 0, 0), `A0.x` is
//! 0 and the results are (0, 0, 0, 1); a relative parameter read outside
//! `c[0]`..`c[95]` reads (0, 0, 0, 0). What the rasterizer then receives
//! — the colours clamped to [0, 1], the point size to its range — is
//! [`Results::rasterized`].

use std::borrow::Cow;

use super::program::*;

/// A four-component register value, as NV_vertex_program computes in.
pub type Vec4 = [f32; 4];

/// One vertex's registers after the program ran.
#[derive(Clone, Debug, PartialEq)]
pub struct Results {
    /// Indexed by [`Output::index`]: `o[HPOS]` first, `o[TEX7]` last.
    pub outputs: [Vec4; OUTPUTS],
}

impl Results {
    /// The value of output register `o`.
    pub fn get(&self, o: Output) -> Vec4 {
        self.outputs[o.index()]
    }

    /// The results as the rest of the pipeline receives them after the
    /// program ends (NV_vertex_program, Section 2.14.1.5, "The Vertex
    /// Result Register Set"): the colour results `o[COL0]`, `o[COL1]`,
    /// `o[BFC0]`, `o[BFC1]` clamped to [0, 1] before interpolation ("the
    /// selected primary and secondary colors ... are clamped to the range
    /// \[0,1\] and then interpolated"; clamping is one of the operations the
    /// spec's overview lists as *not* subsumed by the program), and the x
    /// of `o[PSIZ]` clamped to [0, `max_point_size`], the high end of the
    /// implementation's point size range. `o[FOGC]` is a fog *distance*
    /// and is not clamped, nor are the position and the texture
    /// coordinates. The registers themselves are never clamped while the
    /// program runs, so [`run`] returns them as written. A NaN stays NaN.
    pub fn rasterized(&self, max_point_size: f32) -> Results {
        let mut outputs = self.outputs;
        for o in Output::COLOURS {
            outputs[o.index()] = outputs[o.index()].map(|x| x.clamp(0.0, 1.0));
        }
        let psiz = &mut outputs[Output::PSIZ.index()][0];
        *psiz = psiz.clamp(0.0, max_point_size.max(0.0));
        Results { outputs }
    }
}

struct Machine<'a> {
    attributes: &'a [Vec4; ATTRIBUTES],
    /// Borrowed; copied on the first write of a vertex state program.
    parameters: Cow<'a, [Vec4; PARAMETERS]>,
    temporaries: [Vec4; TEMPORARIES],
    outputs: [Vec4; OUTPUTS],
    address: i32,
}

/// Runs `program` on one vertex's attributes with the parameters `c[]`.
pub fn run(
    program: &VertexProgram,
    attributes: &[Vec4; ATTRIBUTES],
    parameters: &[Vec4; PARAMETERS],
) -> Results {
    let mut m = Machine::new(attributes, Cow::Borrowed(parameters));
    for ins in &program.instructions {
        m.step(ins);
    }
    Results { outputs: m.outputs }
}

/// Runs a vertex state program (`!!VSP1.0`) once, as `ExecuteProgramNV`
/// does (NV_vertex_program, Section 2.14.4): `v[0]` is `v0`, the other
/// attributes (0, 0, 0, 0), and the parameters it writes are updated in
/// `parameters` (a later instruction reads what an earlier one wrote).
pub fn run_state(program: &VertexProgram, v0: Vec4, parameters: &mut [Vec4; PARAMETERS]) {
    let mut attributes = [[0.0; 4]; ATTRIBUTES];
    attributes[0] = v0;
    let mut m = Machine::new(&attributes, Cow::Borrowed(&*parameters));
    for ins in &program.instructions {
        m.step(ins);
    }
    if let Cow::Owned(written) = m.parameters {
        *parameters = written;
    }
}

impl<'a> Machine<'a> {
    fn new(attributes: &'a [Vec4; ATTRIBUTES], parameters: Cow<'a, [Vec4; PARAMETERS]>) -> Machine<'a> {
        Machine {
            attributes,
            parameters,
            temporaries: [[0.0; 4]; TEMPORARIES],
            outputs: [[0.0, 0.0, 0.0, 1.0]; OUTPUTS],
            address: 0,
        }
    }

    fn read(&self, s: &Source) -> Vec4 {
        let r = match s.reg {
            SrcReg::Attribute(k) => self.attributes[usize::from(k) % ATTRIBUTES],
            SrcReg::Parameter(k) => self.parameters[usize::from(k) % PARAMETERS],
            SrcReg::Relative(k) => {
                let i = i64::from(self.address) + i64::from(k);
                usize::try_from(i).ok().and_then(|i| self.parameters.get(i)).copied().unwrap_or([0.0; 4])
            }
            SrcReg::Temporary(k) => self.temporaries[usize::from(k) % TEMPORARIES],
        };
        let v = s.swizzle.map(|c| r[usize::from(c & 3)]);
        if s.negate {
            v.map(|x| -x)
        } else {
            v
        }
    }

    fn step(&mut self, ins: &Instruction) {
        let s: Vec<Vec4> = ins.src.iter().map(|s| self.read(s)).collect();
        let a = s.first().copied().unwrap_or([0.0; 4]);
        let b = s.get(1).copied().unwrap_or([0.0; 4]);
        let c = s.get(2).copied().unwrap_or([0.0; 4]);
        if ins.op == Opcode::Arl {
            // ARL: A0.x = floor(s.x) (saturating at i32's range, NaN to 0).
            self.address = a[0].floor() as i32;
            return;
        }
        let r = compute(ins.op, a, b, c);
        let target = match ins.dst.reg {
            DstReg::Temporary(k) => &mut self.temporaries[usize::from(k) % TEMPORARIES],
            DstReg::Output(o) => &mut self.outputs[o.index() % OUTPUTS],
            DstReg::Parameter(k) => &mut self.parameters.to_mut()[usize::from(k) % PARAMETERS],
            DstReg::Address => return,
        };
        for (k, t) in target.iter_mut().enumerate() {
            if ins.dst.mask & (1 << k) != 0 {
                *t = r[k];
            }
        }
    }
}

/// One instruction's result from its (swizzled, negated) sources.
pub fn compute(op: Opcode, a: Vec4, b: Vec4, c: Vec4) -> Vec4 {
    let lanes = |f: &dyn Fn(usize) -> f32| [f(0), f(1), f(2), f(3)];
    use Opcode::*;
    match op {
        Mov => a,
        Mul => lanes(&|i| a[i] * b[i]),
        Add => lanes(&|i| a[i] + b[i]),
        Sub => lanes(&|i| a[i] - b[i]),
        Mad => lanes(&|i| a[i] * b[i] + c[i]),
        Abs => a.map(f32::abs),
        Dst => [1.0, a[1] * b[1], a[2], b[3]],
        Min => lanes(&|i| if a[i] < b[i] { a[i] } else { b[i] }),
        Max => lanes(&|i| if a[i] >= b[i] { a[i] } else { b[i] }),
        Slt => lanes(&|i| if a[i] < b[i] { 1.0 } else { 0.0 }),
        Sge => lanes(&|i| if a[i] >= b[i] { 1.0 } else { 0.0 }),
        Rcp => [rcp(a[0]); 4],
        Rcc => [rcc(a[0]); 4],
        Rsq => [rsq(a[0]); 4],
        Dp3 => [a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; 4],
        Dp4 => [a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]; 4],
        Dph => [a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + b[3]; 4],
        Log => log(a[0]),
        Exp => exp(a[0]),
        Lit => lit(a),
        Arl => [0.0; 4],
    }
}

/// RCP: 1/x, exactly 1 for x = 1 (the spec requires it); 1/±0 = ±∞.
pub fn rcp(x: f32) -> f32 {
    if x == 1.0 {
        1.0
    } else {
        1.0 / x
    }
}

/// RCC (VP1.1): 1/x clamped away from 0 and ∞, to magnitudes in
/// [5.42101e−20, 1.884467e+19], the sign kept.
pub fn rcc(x: f32) -> f32 {
    let r = rcp(x);
    let m = r.abs();
    let m = m.clamp(5.42101e-20, 1.884467e19);
    if r.is_nan() {
        r
    } else {
        m.copysign(r)
    }
}

/// RSQ: 1/√|x| (the spec takes the absolute value); RSQ(0) = +∞.
pub fn rsq(x: f32) -> f32 {
    let t = x.abs();
    if t == 1.0 {
        1.0
    } else {
        1.0 / t.sqrt()
    }
}

/// LOG: (exponent, mantissa in [1, 2), log₂|x|, 1) of |x|; LOG(0) =
/// (−∞, 1, −∞, 1) and LOG(∞) = (+∞, 1, +∞, 1).
pub fn log(x: f32) -> Vec4 {
    let t = x.abs();
    if t == 0.0 {
        return [f32::NEG_INFINITY, 1.0, f32::NEG_INFINITY, 1.0];
    }
    if t.is_infinite() {
        return [f32::INFINITY, 1.0, f32::INFINITY, 1.0];
    }
    if t.is_nan() {
        return [t, t, t, 1.0];
    }
    let e = exponent(t);
    // t / 2^e is exact: a power-of-two scaling, done in f64 so that 2^e
    // itself cannot overflow or underflow.
    let mantissa = (f64::from(t) / 2f64.powi(e)) as f32;
    [e as f32, mantissa, t.log2(), 1.0]
}

/// The unbiased binary exponent of a finite, non-zero `t` (subnormals
/// included): ⌊log₂ t⌋.
fn exponent(t: f32) -> i32 {
    let bits = t.to_bits();
    let biased = ((bits >> 23) & 0xff) as i32;
    if biased != 0 {
        return biased - 127;
    }
    // Subnormal: the leading one of the mantissa.
    let mantissa = bits & 0x7f_ffff;
    -118 - mantissa.leading_zeros() as i32
}

/// EXP: (2^⌊x⌋, x − ⌊x⌋, 2^x, 1).
pub fn exp(x: f32) -> Vec4 {
    let f = x.floor();
    [f.exp2(), x - f, x.exp2(), 1.0]
}

/// LIT: (1, max(x, 0), max(x, 0) > 0 ? max(y, 0)^w : 0, 1), the power with
/// w clamped to ±(128 − 1/256) and 0^0 = 1, as the spec's pseudo-code.
pub fn lit(s: Vec4) -> Vec4 {
    let x = if s[0] < 0.0 { 0.0 } else { s[0] };
    let y = if s[1] < 0.0 { 0.0 } else { s[1] };
    let limit = 128.0 - 1.0 / 256.0;
    let w = s[3].clamp(-limit, limit);
    let z = if x > 0.0 { power(y, w) } else { 0.0 };
    [1.0, x, z, 1.0]
}

/// The spec's RoughApproxPower(a, b) = RoughApproxExp2(b · RoughApproxLog2(a)),
/// with 0^0 = 1.
pub fn power(a: f32, b: f32) -> f32 {
    if a == 0.0 && b == 0.0 {
        1.0
    } else {
        (b * a.log2()).exp2()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subnormal_exponent() {
        assert_eq!(exponent(f32::MIN_POSITIVE), -126);
        assert_eq!(exponent(f32::MIN_POSITIVE / 2.0), -127);
        assert_eq!(exponent(f32::from_bits(1)), -149);
        assert_eq!(exponent(1.0), 0);
        assert_eq!(exponent(3.5), 1);
    }

    fn results_with(o: Output, v: Vec4) -> Results {
        let mut outputs = [[0.0, 0.0, 0.0, 1.0]; OUTPUTS];
        outputs[o.index()] = v;
        Results { outputs }
    }

    #[test]
    fn colour_results_are_clamped_to_unit_range_when_rasterized() {
        for o in Output::COLOURS {
            let r = results_with(o, [-0.5, 0.25, 1.5, 7.0]).rasterized(64.0);
            assert_eq!(r.get(o), [0.0, 0.25, 1.0, 1.0], "{}", o.name());
        }
    }

    #[test]
    fn point_size_x_is_clamped_to_the_point_size_range() {
        let r = results_with(Output::PSIZ, [100.0, -3.0, 5.0, 9.0]).rasterized(64.0);
        assert_eq!(r.get(Output::PSIZ), [64.0, -3.0, 5.0, 9.0]);
        let r = results_with(Output::PSIZ, [-2.0, 0.0, 0.0, 0.0]).rasterized(64.0);
        assert_eq!(r.get(Output::PSIZ)[0], 0.0);
    }

    #[test]
    fn fog_position_and_texture_coordinates_are_not_clamped() {
        for o in [Output::FOGC, Output::HPOS, Output::tex(0), Output::tex(7)] {
            let v = [-2.0, 3.5, -0.25, 9.0];
            assert_eq!(results_with(o, v).rasterized(64.0).get(o), v, "{}", o.name());
        }
    }
}
