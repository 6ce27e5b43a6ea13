//! Shared helpers for the combiner tests: proptest strategies that generate
//! valid `CombinerConfig`s by construction (every Appendix B rule holds), and
//! the transcriptions of seeds/003 Appendix G and H.
#![allow(dead_code)]

use proptest::prelude::*;
use shadec::backends::combiners::ts1::{Operation, TextureShader};
use shadec::backends::combiners::{
    Bias, CombinerConfig, ComponentUsage, FinalCombiner, FinalInput, FinalSource, GeneralInput,
    GeneralPortion, GeneralStage, InputMapping, PortionKind, Register, Scale,
};

/// A fixed-seed xorshift generator.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    pub fn byte(&mut self) -> u8 {
        (self.next() >> 24) as u8
    }
    pub fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| self.byte()).collect()
    }
    /// Uniform in [0, 1).
    pub fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

pub fn data(name: &str) -> String {
    let path = format!("{}/tests/data/combiners/{name}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

pub fn register() -> impl Strategy<Value = Register> {
    prop::sample::select(Register::ALL.to_vec())
}

pub fn writable() -> impl Strategy<Value = Register> {
    prop::sample::select(Register::ALL.iter().copied().filter(|r| r.is_writable()).collect::<Vec<_>>())
}

pub fn mapping() -> impl Strategy<Value = InputMapping> {
    prop::sample::select(InputMapping::ALL.to_vec())
}

pub fn general_input(kind: PortionKind) -> impl Strategy<Value = GeneralInput> {
    (register(), mapping(), any::<bool>()).prop_map(move |(register, mapping, alt)| {
        let usage = match (kind, alt || register == Register::Fog) {
            (PortionKind::Rgb, false) => ComponentUsage::Alpha,
            (PortionKind::Rgb, true) => ComponentUsage::Rgb,
            (PortionKind::Alpha, false) => ComponentUsage::Alpha,
            (PortionKind::Alpha, true) => ComponentUsage::Blue,
        };
        GeneralInput { register, mapping, usage }
    })
}

pub fn portion(kind: PortionKind) -> impl Strategy<Value = GeneralPortion> {
    let inputs = [general_input(kind), general_input(kind), general_input(kind), general_input(kind)];
    let outputs = prop::array::uniform3(prop::option::of(writable()));
    let flags = (any::<bool>(), any::<bool>(), any::<bool>());
    let scale = prop::sample::select(vec![Scale::One, Scale::Two, Scale::Four, Scale::OneHalf]);
    let special = prop::sample::select(vec![0u8, 0, 0, 1, 2]);
    (inputs, outputs, flags, scale, any::<bool>(), special).prop_map(
        move |([a, b, c, d], mut out, (ab_dot, cd_dot, mux_sum), scale, bias, special)| {
            if special == 1 {
                return GeneralPortion::discard_all();
            }
            // Distinct outputs: drop repeats.
            if out[1].is_some() && out[1] == out[0] {
                out[1] = None;
            }
            if out[2].is_some() && (out[2] == out[0] || out[2] == out[1]) {
                out[2] = None;
            }
            let dots = kind == PortionKind::Rgb;
            let (ab_dot, cd_dot) = (ab_dot && dots, cd_dot && dots);
            if ab_dot || cd_dot {
                out[2] = None;
            }
            let bias = if bias && matches!(scale, Scale::One | Scale::Two) {
                Bias::NegativeOneHalf
            } else {
                Bias::Zero
            };
            let mut p = GeneralPortion {
                a,
                b,
                c,
                d,
                ab_output: out[0],
                cd_output: out[1],
                sum_output: out[2],
                ab_dot,
                cd_dot,
                mux_sum,
                scale,
                bias,
            };
            if special == 2 {
                // What nvparse makes of a lone product: C = D = zero, CD and sum discarded.
                let usage =
                    if kind == PortionKind::Rgb { ComponentUsage::Rgb } else { ComponentUsage::Alpha };
                let zero =
                    GeneralInput { register: Register::Zero, mapping: InputMapping::UnsignedIdentity, usage };
                (p.c, p.d, p.cd_output, p.cd_dot, p.sum_output, p.mux_sum) =
                    (zero, zero, None, false, None, false);
            }
            p
        },
    )
}

pub fn color() -> impl Strategy<Value = [f32; 4]> {
    prop_oneof![
        prop::array::uniform4(0.0f32..=1.0),
        prop::array::uniform4(-3.0f32..3.0),
        prop::array::uniform4(prop::sample::select(vec![0.0f32, 1.0, 0.5, 0.1, 1.0 / 3.0])),
    ]
}

pub fn stage() -> impl Strategy<Value = GeneralStage> {
    (
        portion(PortionKind::Rgb),
        portion(PortionKind::Alpha),
        prop::option::of(color()),
        prop::option::of(color()),
    )
        .prop_map(|(rgb, alpha, constant0, constant1)| GeneralStage { rgb, alpha, constant0, constant1 })
}

pub fn final_input(var: char) -> impl Strategy<Value = FinalInput> {
    let pseudo = prop::sample::select(vec![0u8, 0, 0, 1, 2]);
    (register(), any::<bool>(), any::<bool>(), pseudo).prop_map(move |(register, alpha, invert, pseudo)| {
        let mapping = if invert { InputMapping::UnsignedInvert } else { InputMapping::UnsignedIdentity };
        let source = match pseudo {
            1 if "ABCD".contains(var) => FinalSource::EfProduct,
            2 if "BCD".contains(var) => FinalSource::Spare0PlusSecondary,
            _ => FinalSource::Register(register),
        };
        let usage = match source {
            FinalSource::Register(_) if alpha || var == 'G' => ComponentUsage::Alpha,
            _ => ComponentUsage::Rgb,
        };
        FinalInput { source, mapping, usage }
    })
}

pub fn final_combiner() -> impl Strategy<Value = FinalCombiner> {
    (
        (final_input('A'), final_input('B'), final_input('C'), final_input('D')),
        (final_input('E'), final_input('F'), final_input('G')),
        any::<bool>(),
    )
        .prop_map(|((a, b, c, d), (e, f, g), color_sum_clamp)| FinalCombiner {
            a,
            b,
            c,
            d,
            e,
            f,
            g,
            color_sum_clamp,
        })
}

/// A valid config (geforce3 limits) by construction.
pub fn config(max_stages: usize) -> impl Strategy<Value = CombinerConfig> {
    // Texture shaders made of stages that read no other stage (always consistent).
    let ts = prop::option::of(
        prop::collection::vec(
            prop_oneof![
                Just(Operation::Texture2d),
                Just(Operation::Nop),
                Just(Operation::PassThrough),
                Just(Operation::TextureCubeMap),
            ],
            0..=4,
        )
        .prop_map(|stages| TextureShader { stages }),
    );
    (
        prop::option::of(color()),
        prop::option::of(color()),
        prop::collection::vec(stage(), 0..=max_stages),
        final_combiner(),
        ts,
    )
        .prop_map(|(constant0, constant1, general, final_combiner, texture_shader)| CombinerConfig {
            constant0,
            constant1,
            general,
            final_combiner,
            texture_shader,
        })
}

/// Hardware results (issue 20): NV2A (NV20 family, the Xbox GPU) golden
/// images of nxdk_pgraph_tests' "Combiner" suite, CombinerOps test —
/// constant colour 0 = (25, 63, 255)/255 written to spare0 by general
/// combiner 0 with each output mapping and shown by the final combiner.
/// The hardware subtracts exactly 128 for the −½ bias (255 − 128 = 127)
/// and halves round half up. Pairs of (output mapping call, RGB).
pub const NV2A_COMBINER_OPS: [(&str, [u8; 3]); 6] = [
    ("", [25, 63, 255]),
    ("scale_by_two();", [50, 126, 255]),
    ("scale_by_four();", [100, 252, 255]),
    ("scale_by_one_half();", [13, 32, 128]),
    ("bias_by_negative_one_half();", [0, 0, 127]),
    ("bias_by_negative_one_half_scale_by_two();", [0, 0, 254]),
];

/// The CombinerOps setup for one output mapping, as `!!RC1.0`.
pub fn nv2a_combiner_ops_program(mapping: &str) -> String {
    format!("!!RC1.0\nconst0 = (0.09803922, 0.24705882, 1, 1);\n{{ rgb {{ spare0 = const0 * one; {mapping} }} }}\nout.rgb = spare0;\nout.a = one;\n")
}
