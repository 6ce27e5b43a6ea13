//! The register-combiner emulator: golden pixels worked by hand from
//! seeds/003 (Appendix G and H), each emulation decision of
//! docs/combiners.md, agreement with a per-pixel scalar reference written
//! straight from Section 4.2, the fixed9-vs-f32 bound, and no panics.

use crate::combiners_common;
use combiners_common as common;

use proptest::prelude::*;
use shadec::backends::combiners::emulator::{emulate, EmulateError, Inputs, PixelEmulator, PixelRegisters};
use shadec::backends::combiners::rc1::{self, parse_and_validate};
use shadec::backends::combiners::{
    Bias, CombinerConfig, CombinerLimits, ComponentUsage, FinalSource, GeneralInput, GeneralPortion,
    InputMapping, PortionKind, Register, Scale,
};
use shadec::numerics::Precision;

fn program(text: &str) -> CombinerConfig {
    parse_and_validate(text, &CombinerLimits::GEFORCE3).unwrap_or_else(|d| panic!("{d:?}"))
}

/// Runs a config on one pixel given as RGBA8 per input.
fn pixel(
    config: &CombinerConfig,
    tex: [[u8; 4]; 4],
    primary: [u8; 4],
    secondary: [u8; 4],
    precision: Precision,
) -> [u8; 4] {
    let t = tex.map(|t| t.to_vec());
    let (p, s) = (primary.to_vec(), secondary.to_vec());
    let inputs = Inputs {
        width: 1,
        height: 1,
        textures: [Some(&t[0]), Some(&t[1]), Some(&t[2]), Some(&t[3])],
        primary: Some(&p),
        secondary: Some(&s),
        ..Inputs::default()
    };
    let out = emulate(config, &inputs, precision).unwrap();
    [out[0], out[1], out[2], out[3]]
}

fn tex01(t0: [u8; 4], t1: [u8; 4]) -> [[u8; 4]; 4] {
    [t0, t1, [0; 4], [0; 4]]
}

#[test]
fn appendix_h_golden_pixel() {
    // N' = (0, 0, 1) and H at 45° in x-z, range-compressed (Section 5.1):
    // fixed9: N'·H → 182/255, squared by the mux stage → 130, EF → 66, EF² → 17.
    let h = program(&common::data("appendix_h.rc"));
    let t = tex01([128, 128, 255, 255], [218, 128, 218, 255]);
    assert_eq!(pixel(&h, t, [0; 4], [0; 4], Precision::Fixed9), [17, 17, 17, 0]);
    assert_eq!(pixel(&h, t, [0; 4], [0; 4], Precision::F32), [17, 17, 17, 0]);
    // H facing away (Hz < 0, so texture1.b < 128): the mux picks AB = 0.
    let away = tex01([128, 128, 255, 255], [218, 128, 100, 255]);
    assert_eq!(pixel(&h, away, [0; 4], [0; 4], Precision::Fixed9), [0, 0, 0, 0]);
}

/// Hardware results (issue 20): NV2A (NV20 family) golden images of
/// nxdk_pgraph_tests' "Combiner" suite, CombinerOps test — constant colour
/// 0 = (25, 63, 255)/255 written to spare0 by general combiner 0 with each
/// output mapping and shown by the final combiner. The hardware subtracts
/// exactly 128 for the −½ bias (255 − 128 = 127) and halves round half up.
#[test]
fn hardware_output_mappings() {
    for (mapping, hardware) in common::NV2A_COMBINER_OPS {
        let config = program(&common::nv2a_combiner_ops_program(mapping));
        let out = pixel(&config, [[0; 4]; 4], [0; 4], [0; 4], Precision::Fixed9);
        assert_eq!(out[..3], hardware, "{mapping}");
    }
}

/// nvparse's final combiner takes G from a register's blue as from its
/// alpha (`glFinalCombinerInputNV(GL_VARIABLE_G_NV, …, GL_BLUE)`).
#[test]
fn final_alpha_reads_blue() {
    let config = program("!!RC1.0\nout.rgb = tex0;\nout.a = tex0.b;\n");
    assert_eq!(
        pixel(&config, [[10, 20, 30, 40], [0; 4], [0; 4], [0; 4]], [0; 4], [0; 4], Precision::Fixed9),
        [10, 20, 30, 30]
    );
    let spare = program("!!RC1.0\n{ rgb { spare0 = tex1 * one; } }\nout.rgb = zero;\nout.a = spare0.b;\n");
    assert_eq!(
        pixel(&spare, [[0; 4], [1, 2, 200, 9], [0; 4], [0; 4]], [0; 4], [0; 4], Precision::Fixed9)[3],
        200
    );
}

#[test]
fn appendix_g_golden_pixel() {
    // Same vectors, normal-map alpha 200/255. fixed9: L·N' = 182, self-shadow
    // term saturates (4·2·0.71 → 255), spare0 = 182·200/255 → 143; constants
    // 0.9 → 230 and 0.1 → 26; EF = (129, 143, 143); out = EF + 26.
    let g = program(&common::data("appendix_g.rc"));
    let t = tex01([128, 128, 255, 200], [218, 128, 218, 255]);
    assert_eq!(pixel(&g, t, [0; 4], [0; 4], Precision::Fixed9), [155, 169, 169, 255]);
    // f32: 0.712599 · 200/255 = 0.558901; 0.9·that + 0.1 = 0.603 → 154; 0.6589 → 168.
    assert_eq!(pixel(&g, t, [0; 4], [0; 4], Precision::F32), [154, 168, 168, 255]);
    // Light below the surface (Lz < 0): the self-shadowing term is 0, only ambient remains.
    let below = tex01([128, 128, 255, 200], [218, 128, 100, 255]);
    assert_eq!(pixel(&g, below, [0; 4], [0; 4], Precision::Fixed9), [26, 26, 26, 0]);
}

#[test]
fn nine_bit_range_is_symmetric() {
    // expand(zero) = −1 is −255/255, not −256/255: −spare0 · ½ → 128 (−256 would give 129).
    let c = program("!!RC1.0\nconst0 = (0.5, 0.5, 0.5, 0.5);\n{ rgb { spare0 = expand(zero); } }\n{ rgb { spare1 = -spare0 * unsigned(const0); } }\nout.rgb = spare1;");
    assert_eq!(pixel(&c, [[0; 4]; 4], [0; 4], [0; 4], Precision::Fixed9)[0], 128);
}

#[test]
fn stage_outputs_clamp_to_plus_minus_one() {
    // 4 · (0.6 + 0.6) = 4.8 clamps to 1, and −4.8 to −1 (then 0 in the final combiner).
    let c = program("!!RC1.0\nconst0 = (0.6, 0.6, 0.6, 0.6);\n{ rgb { discard = const0; discard = const0; spare0 = sum(); scale_by_four(); } }\n{ rgb { spare1 = -spare0 * half_bias(one); } }\nout.rgb = lerp(spare0, one, zero) + spare1;");
    for precision in [Precision::Fixed9, Precision::F32] {
        assert_eq!(pixel(&c, [[0; 4]; 4], [0; 4], [0; 4], precision), [255, 255, 255, 0]);
    }
    // −(1) · ½ = −½ → final combiner clamps negatives to zero.
    let c = program("!!RC1.0\n{ rgb { spare0 = -one; } }\nout.rgb = spare0 + const0;");
    assert_eq!(pixel(&c, [[0; 4]; 4], [0; 4], [0; 4], Precision::Fixed9), [0, 0, 0, 0]);
}

#[test]
fn color_sum_clamp_and_unsigned_identity_above_one() {
    // A = ½, B = spare0 + secondary = 0.8 + 0.8: clamped 1 → ½ → 128; unclamped 1.6 → 0.8 → 204
    // (Table 3's unsigned identity is max(0, x): no clamp above 1). In fixed9 the constant ½ is
    // stored as 128/255, so 128 · 408 / 255 = 204.8 → 205.
    let base = "const0 = (0.5, 0.5, 0.5, 0.5);\n{ rgb { spare0 = unsigned(col0); } }\n";
    let clamped =
        program(&format!("!!RC1.0\n{base}clamp_color_sum();\nout.rgb = lerp(const0, color_sum, zero);"));
    let unclamped = program(&format!("!!RC1.0\n{base}out.rgb = lerp(const0, color_sum, zero);"));
    let c = [204, 204, 204, 255];
    for (precision, expected) in [(Precision::Fixed9, 205), (Precision::F32, 204)] {
        assert_eq!(pixel(&clamped, [[0; 4]; 4], c, c, precision)[0], 128);
        assert_eq!(pixel(&unclamped, [[0; 4]; 4], c, c, precision)[0], expected);
    }
    // Configs built any other way start with the GL default: clamp on.
    assert!(CombinerConfig::default().final_combiner.color_sum_clamp);
}

#[test]
fn mux_threshold_is_one_half() {
    // spare0.a starts as texture0 alpha; mux picks AB (=0) below ½ and CD (=1) from 128/255 up.
    let c = program("!!RC1.0\n{ rgb { discard = zero; discard = one; spare1 = mux(); } }\nout.rgb = spare1;");
    for precision in [Precision::Fixed9, Precision::F32] {
        assert_eq!(pixel(&c, [[0, 0, 0, 127], [0; 4], [0; 4], [0; 4]], [0; 4], [0; 4], precision)[0], 0);
        assert_eq!(pixel(&c, [[0, 0, 0, 128], [0; 4], [0; 4], [0; 4]], [0; 4], [0; 4], precision)[0], 255);
    }
}

#[test]
fn both_portions_read_the_registers_as_the_stage_began() {
    // rgb writes spare0 = texture1; alpha reads spare0.b in the same stage: the old value (0).
    let c = program("!!RC1.0\n{ rgb { spare0 = unsigned(tex1); } alpha { spare1 = unsigned(spare0.b) * one; } }\nout.rgb = spare0;\nout.a = spare1;");
    let px = pixel(&c, tex01([0; 4], [10, 20, 200, 0]), [0; 4], [0; 4], Precision::Fixed9);
    assert_eq!(px, [10, 20, 200, 0]);
}

#[test]
fn constants_program_over_command_line_and_per_stage_only_in_stage() {
    let c = program("!!RC1.0\nconst1 = (0, 0, 1, 1);\n{ const0 = (1, 0, 0, 1); rgb { spare0 = unsigned(const0); } }\n{ rgb { spare1 = unsigned(const0); } }\nout.rgb = spare0 + spare1;\nout.a = const1;");
    let inputs = Inputs {
        width: 1,
        height: 1,
        constant0: [0.0, 1.0, 0.0, 1.0],
        constant1: [1.0, 0.0, 0.0, 0.0],
        ..Inputs::default()
    };
    let out = emulate(&c, &inputs, Precision::Fixed9).unwrap();
    // Stage 0 sees its own const0 (red), stage 1 the command line's (green); const1 comes from the program.
    assert_eq!(out, vec![255, 255, 0, 255]);
}

#[test]
fn fog_alpha_reaches_the_final_combiner_and_missing_inputs_read_zero() {
    let c = program("!!RC1.0\nout.rgb = lerp(fog.a, fog, tex2);\nout.a = fog;");
    let inputs = Inputs { width: 2, height: 1, fog: [1.0, 0.5, 0.0, 0.25], ..Inputs::default() };
    let out = emulate(&c, &inputs, Precision::Fixed9).unwrap();
    // ¼ · (255, 128, 0) → (64, 32, 0); alpha = fog factor.
    assert_eq!(&out[..4], &[64, 32, 0, 64]);
    assert_eq!(&out[..4], &out[4..]);
}

#[test]
fn initial_gl_state_modulates_primary_by_texture() {
    // Table 5/6 as the GL leaves them: spare0 = primary · texture0 (sum of AB + CD with C = D = 0),
    // final = fog.a · (spare0 + secondary) + (1 − fog.a) · fog.rgb; with fog factor 1 that is spare0.
    let c = CombinerConfig::default();
    let inputs_px = ([[200, 100, 50, 255], [0; 4], [0; 4], [0; 4]], [255, 255, 128, 255]);
    let t: Vec<Vec<u8>> = inputs_px.0.iter().map(|t| t.to_vec()).collect();
    let p = inputs_px.1.to_vec();
    let inputs = Inputs {
        width: 1,
        height: 1,
        textures: [Some(&t[0]), None, None, None],
        primary: Some(&p),
        fog: [0.0, 0.0, 0.0, 1.0],
        ..Inputs::default()
    };
    // 128·50/255 = 25.1 → 25; alpha: G = spare0.a = 255·255/255.
    assert_eq!(emulate(&c, &inputs, Precision::Fixed9).unwrap(), vec![200, 100, 25, 255]);
}

#[test]
fn errors_instead_of_panics() {
    let c = CombinerConfig::default();
    let short = vec![0u8; 7];
    let inputs = Inputs { width: 2, height: 1, primary: Some(&short), ..Inputs::default() };
    assert!(matches!(emulate(&c, &inputs, Precision::F32), Err(EmulateError::SizeMismatch { .. })));
    let mut bad = CombinerConfig::default();
    bad.general[0].alpha.ab_dot = true;
    assert!(matches!(
        emulate(&bad, &Inputs { width: 1, height: 1, ..Inputs::default() }, Precision::F32),
        Err(EmulateError::Invalid(_))
    ));
    assert_eq!(emulate(&c, &Inputs::default(), Precision::Fixed9), Ok(Vec::new()));
    let huge = Inputs { width: usize::MAX, height: 3, ..Inputs::default() };
    assert!(emulate(&c, &huge, Precision::Fixed9).is_err());
}

// ---------------------------------------------------------------------------
// A scalar reference: one pixel at a time, straight from Section 4.2.

fn reference(config: &CombinerConfig, inputs: &Inputs, i: usize, precision: Precision) -> [u8; 4] {
    let fixed = precision == Precision::Fixed9;
    // Registers as reals; in fixed9 every stored value is k/255.
    // Exact values here are multiples of 1/(255·2040), so a tie k + ½ is never
    // closer than 1/2040 to a non-tie: the 1e-7 makes f64 ties round up exactly.
    let q = |x: f64| if fixed { ((x * 255.0) + 0.5 + 1e-7).floor() / 255.0 } else { x };
    let unit = |c: [f32; 4]| {
        c.map(|v| {
            if fixed {
                (v.clamp(0.0, 1.0) * 255.0 + 0.5).floor() as f64 / 255.0
            } else {
                v.clamp(0.0, 1.0) as f64
            }
        })
    };
    let px = |img: Option<&[u8]>| {
        img.map_or([0.0; 4], |img| {
            [0, 1, 2, 3].map(|c| {
                if fixed {
                    img[i * 4 + c] as f64 / 255.0
                } else {
                    (img[i * 4 + c] as f32 * (1.0 / 255.0)) as f64
                }
            })
        })
    };
    let mut regs = [[0.0f64; 4]; 12];
    regs[Register::Fog.index()] = unit(inputs.fog);
    for (u, t) in inputs.textures.iter().enumerate() {
        regs[Register::Texture0.index() + u] = px(*t);
    }
    regs[Register::Primary.index()] = px(inputs.primary);
    regs[Register::Secondary.index()] = px(inputs.secondary);
    regs[Register::Spare0.index()][3] = regs[Register::Texture0.index()][3];
    let globals = [
        unit(config.constant0.unwrap_or(inputs.constant0)),
        unit(config.constant1.unwrap_or(inputs.constant1)),
    ];
    let map = |m: InputMapping, x: f64| -> f64 {
        let r = m.apply(x as f32) as f64;
        if fixed {
            m_exact(m, x)
        } else {
            r
        }
    };
    for stage in &config.general {
        regs[Register::Constant0.index()] = stage.constant0.map_or(globals[0], unit);
        regs[Register::Constant1.index()] = stage.constant1.map_or(globals[1], unit);
        let old = regs;
        for (kind, p) in [(PortionKind::Rgb, &stage.rgb), (PortionKind::Alpha, &stage.alpha)] {
            let chans: &[usize] = if kind == PortionKind::Rgb { &[0, 1, 2] } else { &[3] };
            let var = |v: &GeneralInput, ch: usize| {
                let src = match v.usage {
                    ComponentUsage::Rgb => ch,
                    ComponentUsage::Alpha => 3,
                    ComponentUsage::Blue => 2,
                };
                map(v.mapping, old[v.register.index()][src])
            };
            let prod = |a: &GeneralInput, b: &GeneralInput, dot: bool, ch: usize| -> f64 {
                if dot {
                    (0..3).map(|c| var(a, c) * var(b, c)).fold(0.0, |s, x| {
                        if fixed {
                            s + x
                        } else {
                            (s as f32 + x as f32) as f64
                        }
                    })
                } else if fixed {
                    var(a, ch) * var(b, ch)
                } else {
                    (var(a, ch) as f32 * var(b, ch) as f32) as f64
                }
            };
            for &ch in chans {
                let ab = prod(&p.a, &p.b, p.ab_dot, ch);
                let cd = prod(&p.c, &p.d, p.cd_dot, ch);
                let sum = if p.mux_sum {
                    if old[Register::Spare0.index()][3] < 0.5 {
                        ab
                    } else {
                        cd
                    }
                } else if fixed {
                    ab + cd
                } else {
                    (ab as f32 + cd as f32) as f64
                };
                let out = |v: f64| {
                    // fixed9: the bias's ½ is 128/255 (NV2A golden images, above).
                    let bias = if p.bias == Bias::Zero { 0.0 } else { -HALF };
                    let v = if fixed {
                        (v + bias) * p.scale.factor() as f64
                    } else {
                        ((v as f32 + p.bias.offset()) * p.scale.factor()) as f64
                    };
                    q(v.clamp(-1.0, 1.0))
                };
                for (r, v) in [(p.ab_output, ab), (p.cd_output, cd), (p.sum_output, sum)] {
                    if let Some(r) = r {
                        regs[r.index()][ch] = out(v);
                    }
                }
            }
        }
    }
    regs[Register::Constant0.index()] = globals[0];
    regs[Register::Constant1.index()] = globals[1];
    let f = &config.final_combiner;
    let cs: [f64; 3] = [0, 1, 2].map(|c| {
        let s = regs[Register::Spare0.index()][c].max(0.0) + regs[Register::Secondary.index()][c].max(0.0);
        if fixed {
            s.min(if f.color_sum_clamp { 1.0 } else { 2.0 })
        } else {
            (s as f32).min(if f.color_sum_clamp { 1.0 } else { 2.0 }) as f64
        }
    });
    let fmap = |m: InputMapping, x: f64| {
        if m == InputMapping::UnsignedInvert {
            1.0 - x.clamp(0.0, 1.0)
        } else {
            x.max(0.0)
        }
    };
    let read = |v: &shadec::backends::combiners::FinalInput, ch: usize, ef: &[f64; 3]| match v.source {
        FinalSource::Register(r) => fmap(
            v.mapping,
            regs[r.index()][match v.usage {
                ComponentUsage::Alpha => 3,
                ComponentUsage::Blue => 2,
                ComponentUsage::Rgb => ch,
            }],
        ),
        FinalSource::EfProduct => fmap(v.mapping, ef[ch]),
        FinalSource::Spare0PlusSecondary => fmap(v.mapping, cs[ch]),
    };
    let ef: [f64; 3] = [0, 1, 2].map(|c| {
        let e = read(&f.e, c, &[0.0; 3]);
        let g = read(&f.f, c, &[0.0; 3]);
        if fixed {
            q(e * g)
        } else {
            (e as f32 * g as f32) as f64
        }
    });
    let to_u8 = |x: f64| {
        if fixed {
            ((x.clamp(0.0, 1.0) * 255.0) + 0.5 + 1e-7).floor() as u8
        } else {
            ((x as f32).clamp(0.0, 1.0) * 255.0 + 0.5) as u8
        }
    };
    let rgb = [0, 1, 2].map(|c| {
        let (a, b, cc, d) = (read(&f.a, c, &ef), read(&f.b, c, &ef), read(&f.c, c, &ef), read(&f.d, c, &ef));
        if fixed {
            to_u8(q(a * b + (1.0 - a) * cc + d))
        } else {
            let (a, b, cc, d) = (a as f32, b as f32, cc as f32, d as f32);
            to_u8((a * b + (1.0 - a) * cc + d).min(1.0) as f64)
        }
    });
    let g = read(&f.g, 0, &ef);
    [rgb[0], rgb[1], rgb[2], to_u8(g)]
}

/// The output bias's ½ in fixed9: 128/255 (see `hardware_output_mappings`).
const HALF: f64 = 128.0 / 255.0;

/// Table 3 in exact arithmetic (for fixed9 values k/255).
fn m_exact(m: InputMapping, x: f64) -> f64 {
    match m {
        InputMapping::UnsignedIdentity => x.max(0.0),
        InputMapping::UnsignedInvert => 1.0 - x.clamp(0.0, 1.0),
        InputMapping::ExpandNormal => 2.0 * x.max(0.0) - 1.0,
        InputMapping::ExpandNegate => 1.0 - 2.0 * x.max(0.0),
        InputMapping::HalfBiasNormal => x.max(0.0) - 0.5,
        InputMapping::HalfBiasNegate => 0.5 - x.max(0.0),
        InputMapping::SignedIdentity => x,
        InputMapping::SignedNegate => -x,
    }
}

fn image(n: usize) -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(any::<u8>(), n * 4)
}

/// Largest per-channel difference between two RGBA8 buffers.
fn max_diff(a: &[u8], b: &[u8]) -> u8 {
    a.iter().zip(b).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// The tiled SoA emulator equals the scalar reference exactly.
    #[test]
    fn emulator_matches_scalar_reference(config in common::config(8), imgs in prop::collection::vec(image(300), 6), fog in common::color(), c0 in common::color(), c1 in common::color(), fixed in any::<bool>()) {
        let (w, h) = (20, 15);
        let precision = if fixed { Precision::Fixed9 } else { Precision::F32 };
        let inputs = Inputs {
            width: w, height: h,
            textures: [Some(&imgs[0]), Some(&imgs[1]), Some(&imgs[2]), Some(&imgs[3])],
            primary: Some(&imgs[4]), secondary: Some(&imgs[5]),
            fog, constant0: c0, constant1: c1,
        };
        let out = emulate(&config, &inputs, precision).unwrap();
        for i in 0..w * h {
            let r = reference(&config, &inputs, i, precision);
            let d = max_diff(&out[i * 4..i * 4 + 4], &r);
            let at = |img: &Vec<u8>| img[i * 4..i * 4 + 4].to_vec();
            prop_assert!(d == 0, "pixel {}: emulator {:?}, reference {:?}; inputs {:?}\n{}", i, &out[i * 4..i * 4 + 4], r, imgs.iter().map(at).collect::<Vec<_>>(), rc1::print(&config));
        }
    }

    /// The one-pixel entry the CPU renderer uses equals the tiled emulator
    /// bit for bit, pixels run in any order on one thread's scratch (which
    /// must not carry state from one pixel, config or fog to the next).
    #[test]
    fn pixel_emulator_equals_tiled(config in common::config(8), other in common::config(8), imgs in prop::collection::vec(image(30), 6), fog in common::color(), c0 in common::color(), c1 in common::color(), fixed in any::<bool>()) {
        let (w, h) = (10, 3);
        let precision = if fixed { Precision::Fixed9 } else { Precision::F32 };
        let inputs = Inputs {
            width: w, height: h,
            textures: [Some(&imgs[0]), Some(&imgs[1]), Some(&imgs[2]), Some(&imgs[3])],
            primary: Some(&imgs[4]), secondary: Some(&imgs[5]),
            fog, constant0: c0, constant1: c1,
        };
        let out = emulate(&config, &inputs, precision).unwrap();
        let machine = PixelEmulator::new(&config, c0, c1, fog, precision).unwrap();
        let distractor = PixelEmulator::new(&other, c1, c0, [fog[1], fog[0], fog[3], fog[2]], precision).unwrap();
        for i in (0..w * h).rev() {
            let at = |k: usize| -> [u8; 4] { imgs[k][i * 4..i * 4 + 4].try_into().unwrap() };
            let tex = |k: usize| at(k).map(i16::from);
            let regs = PixelRegisters { textures: [tex(0), tex(1), tex(2), tex(3)], primary: at(4), secondary: at(5) };
            distractor.run(&PixelRegisters { textures: [tex(5), tex(4), tex(3), tex(2)], primary: at(1), secondary: at(0) });
            let px = machine.run(&regs);
            prop_assert_eq!(px.as_slice(), &out[i * 4..i * 4 + 4], "pixel {}\n{}", i, rc1::print(&config));
        }
    }

    /// Many pixels at once through the tile engine (the renderer's batches)
    /// equal one pixel at a time, signed texture registers included, with
    /// another machine's run in between on the same thread's scratch.
    #[test]
    fn run_many_equals_run(config in common::config(8), other in common::config(8), regs in prop::collection::vec((prop::array::uniform4(prop::array::uniform4(-255i16..=255)), prop::array::uniform4(any::<u8>()), prop::array::uniform4(any::<u8>())), 1..40), fog in common::color(), c0 in common::color(), c1 in common::color(), fixed in any::<bool>()) {
        let precision = if fixed { Precision::Fixed9 } else { Precision::F32 };
        let regs: Vec<PixelRegisters> = regs.into_iter().map(|(textures, primary, secondary)| PixelRegisters { textures, primary, secondary }).collect();
        let machine = PixelEmulator::new(&config, c0, c1, fog, precision).unwrap();
        let distractor = PixelEmulator::new(&other, c1, c0, [fog[1], fog[0], fog[3], fog[2]], precision).unwrap();
        let mut ignored = vec![[0u8; 4]; regs.len()];
        distractor.run_many(&regs, &mut ignored);
        let mut many = vec![[0u8; 4]; regs.len()];
        machine.run_many(&regs, &mut many);
        for (i, r) in regs.iter().enumerate() {
            prop_assert_eq!(many[i], machine.run(r), "pixel {}\n{}", i, rc1::print(&config));
        }
    }

    /// fixed9 and f32 agree on Kilgard's passes within the bound of docs/combiners.md.
    #[test]
    fn fixed9_and_f32_agree_on_appendix_g_and_h(imgs in prop::collection::vec(image(256), 2)) {
        // Bounds derived in docs/combiners.md ("fixed9 versus f32").
        for (name, bound) in [("appendix_g.rc", 5), ("appendix_h.rc", 8)] {
            let c = program(&common::data(name));
            let inputs = Inputs { width: 16, height: 16, textures: [Some(&imgs[0]), Some(&imgs[1]), None, None], ..Inputs::default() };
            let a = emulate(&c, &inputs, Precision::Fixed9).unwrap();
            let b = emulate(&c, &inputs, Precision::F32).unwrap();
            prop_assert!(max_diff(&a, &b) <= bound, "{}: {} levels", name, max_diff(&a, &b));
        }
    }

    /// One general stage without mux (products, dots, sums, any mapping, scale ≤ 2) and a
    /// product-free final combiner: fixed9 stays within 2 levels of f32.
    #[test]
    fn fixed9_and_f32_agree_on_one_stage(stage in common::stage(), imgs in prop::collection::vec(image(64), 6)) {
        let mut stage = stage;
        for p in [&mut stage.rgb, &mut stage.alpha] {
            p.mux_sum = false;
            if p.scale == Scale::Four { p.scale = Scale::Two; p.bias = Bias::Zero; }
        }
        stage.constant0 = None;
        stage.constant1 = None;
        let mut config = program("!!RC1.0\nout.rgb = spare0 + spare1;\nout.a = spare1;");
        config.general = vec![stage];
        let inputs = Inputs {
            width: 8, height: 8,
            textures: [Some(&imgs[0]), Some(&imgs[1]), Some(&imgs[2]), Some(&imgs[3])],
            primary: Some(&imgs[4]), secondary: Some(&imgs[5]),
            // Constants on the 8-bit grid: fixed9 stores constant colours in
            // 8 bits, f32 does not, and a scale of 2 after two products
            // would turn that storage difference (not the arithmetic this
            // test bounds) into 4 levels (CI found 0.25 → 64/255).
            constant0: [51.0 / 255.0, 128.0 / 255.0, 191.0 / 255.0, 1.0], constant1: [1.0, 128.0 / 255.0, 0.0, 51.0 / 255.0],
            ..Inputs::default()
        };
        let a = emulate(&config, &inputs, Precision::Fixed9).unwrap();
        let b = emulate(&config, &inputs, Precision::F32).unwrap();
        prop_assert!(max_diff(&a, &b) <= 2, "{} levels", max_diff(&a, &b));
    }

    /// Any config at all (valid or not, any sizes): a result or an error, never a panic.
    #[test]
    fn emulator_never_panics(config in common::config(9), fields in prop::collection::vec(any::<u8>(), 8), w in 0usize..40, h in 0usize..5, len in 0usize..700) {
        let mut config = config;
        // Break rules at random.
        if let Some(s) = config.general.first_mut() {
            s.alpha.ab_dot |= fields[0] & 1 == 1;
            if fields[1] & 1 == 1 { s.rgb.sum_output = Some(Register::Zero); }
            if fields[2] & 1 == 1 { s.rgb.a.usage = ComponentUsage::Blue; }
        }
        if fields[3] & 1 == 1 { config.final_combiner.g.source = FinalSource::EfProduct; }
        if fields[4] & 1 == 1 { config.constant0 = Some([f32::NAN, f32::INFINITY, -0.0, 1e30]); }
        let img = vec![fields[5]; len];
        let inputs = Inputs { width: w, height: h, textures: [Some(&img), None, None, Some(&img)], fog: [f32::NAN, 2.0, -1.0, 0.5], ..Inputs::default() };
        for precision in [Precision::Fixed9, Precision::F32] {
            if let Ok(out) = emulate(&config, &inputs, precision) {
                prop_assert_eq!(out.len(), w * h * 4);
            }
        }
    }
}

#[test]
fn result_does_not_depend_on_thread_count() {
    let g = program(&common::data("appendix_g.rc"));
    let n = 300 * 7;
    let t0: Vec<u8> = (0..n * 4).map(|i| (i * 37 % 251) as u8).collect();
    let t1: Vec<u8> = (0..n * 4).map(|i| (i * 101 % 253) as u8).collect();
    let inputs =
        Inputs { width: 300, height: 7, textures: [Some(&t0), Some(&t1), None, None], ..Inputs::default() };
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    for precision in [Precision::Fixed9, Precision::F32] {
        let a = one.install(|| emulate(&g, &inputs, precision).unwrap());
        let b = emulate(&g, &inputs, precision).unwrap();
        assert_eq!(a, b);
    }
}

#[test]
fn unused_portion_is_cheap_and_harmless() {
    // A portion that discards everything leaves the registers alone.
    let mut c = program("!!RC1.0\n{ rgb { spare0 = unsigned(tex0); } }\nout.rgb = spare0;\nout.a = spare0;");
    c.general[0].alpha = GeneralPortion::discard_all();
    assert_eq!(pixel(&c, tex01([1, 2, 3, 4], [0; 4]), [0; 4], [0; 4], Precision::Fixed9), [1, 2, 3, 4]);
}

/// The NV2A vectors (`common::NV2A_COMBINER_OPS`, with their provenance) in
/// the one-pixel emulator, which is what the CPU renderer's `fixed9` mode
/// runs for every fragment of a combiner pass (`renderer::plan`, through
/// `combiners::PixelEmulator`).
#[test]
fn hardware_output_mappings_in_the_pixel_emulator() {
    for (mapping, hardware) in common::NV2A_COMBINER_OPS {
        let config = program(&common::nv2a_combiner_ops_program(mapping));
        let machine = PixelEmulator::new(&config, [0.0; 4], [0.0; 4], [0.0; 4], Precision::Fixed9).unwrap();
        let out = machine.run(&PixelRegisters::default());
        assert_eq!(out[..3], hardware, "{mapping}");
    }
}
