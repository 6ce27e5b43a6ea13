//! seeds/003 Appendix G and H transcribed call by call (glCombinerInputNV,
//! glCombinerOutputNV, glFinalCombinerInputNV on the Table 4-6 initial
//! state) and compared with `tests/data/combiners/appendix_{g,h}.ron`, which
//! a later golden test compares the DSL compiler's output against. Set
//! `UPDATE_GOLDEN=1` to rewrite the .ron files.

use crate::combiners_common;
use combiners_common as common;

use shadec::backends::combiners::emulator::{emulate, Inputs};
use shadec::backends::combiners::rc1::parse_and_validate;
use shadec::backends::combiners::{
    validate, Bias, CombinerConfig, CombinerLimits, ComponentUsage, FinalInput, FinalSource, GeneralInput,
    GeneralStage, InputMapping, PortionKind, Register, Scale,
};
use shadec::numerics::Precision;

use ComponentUsage::{Alpha, Blue, Rgb};
use InputMapping::*;
use Register::*;

fn input(
    c: &mut CombinerConfig,
    stage: usize,
    portion: PortionKind,
    var: char,
    register: Register,
    mapping: InputMapping,
    usage: ComponentUsage,
) {
    let p = match portion {
        PortionKind::Rgb => &mut c.general[stage].rgb,
        PortionKind::Alpha => &mut c.general[stage].alpha,
    };
    let v = match var {
        'A' => &mut p.a,
        'B' => &mut p.b,
        'C' => &mut p.c,
        _ => &mut p.d,
    };
    *v = GeneralInput { register, mapping, usage };
}

#[allow(clippy::too_many_arguments)]
fn output(
    c: &mut CombinerConfig,
    stage: usize,
    portion: PortionKind,
    ab: Option<Register>,
    cd: Option<Register>,
    sum: Option<Register>,
    scale: Scale,
    bias: Bias,
    ab_dot: bool,
    cd_dot: bool,
    mux: bool,
) {
    let p = match portion {
        PortionKind::Rgb => &mut c.general[stage].rgb,
        PortionKind::Alpha => &mut c.general[stage].alpha,
    };
    (p.ab_output, p.cd_output, p.sum_output, p.scale, p.bias, p.ab_dot, p.cd_dot, p.mux_sum) =
        (ab, cd, sum, scale, bias, ab_dot, cd_dot, mux);
}

fn fin(c: &mut CombinerConfig, var: char, source: FinalSource, mapping: InputMapping, usage: ComponentUsage) {
    let f = &mut c.final_combiner;
    let v = match var {
        'A' => &mut f.a,
        'B' => &mut f.b,
        'C' => &mut f.c,
        'D' => &mut f.d,
        'E' => &mut f.e,
        'F' => &mut f.f,
        _ => &mut f.g,
    };
    *v = FinalInput { source, mapping, usage };
}

/// The GL initial state with `GL_NUM_GENERAL_COMBINERS_NV` = 2.
fn initial_two() -> CombinerConfig {
    CombinerConfig {
        general: vec![GeneralStage::initial(0), GeneralStage::initial(1)],
        ..CombinerConfig::default()
    }
}

/// configCombinersForAmbientAndDiffusePass, Appendix G.
fn appendix_g() -> CombinerConfig {
    use PortionKind::{Alpha as A, Rgb as R};
    let mut c = initial_two();
    c.constant0 = Some([0.1, 0.1, 0.1, 0.0]);
    c.constant1 = Some([0.9, 1.0, 1.0, 0.0]);
    input(&mut c, 0, R, 'A', Texture0, ExpandNormal, Rgb);
    input(&mut c, 0, R, 'B', Texture1, ExpandNormal, Rgb);
    output(&mut c, 0, R, Some(Spare0), None, None, Scale::One, Bias::Zero, true, false, false);
    input(&mut c, 0, A, 'A', Zero, UnsignedInvert, Alpha);
    input(&mut c, 0, A, 'B', Texture1, ExpandNormal, Blue);
    input(&mut c, 0, A, 'C', Zero, UnsignedInvert, Alpha);
    input(&mut c, 0, A, 'D', Texture1, ExpandNormal, Blue);
    output(&mut c, 0, A, None, None, Some(Spare0), Scale::Four, Bias::Zero, false, false, false);
    input(&mut c, 1, R, 'A', Spare0, UnsignedIdentity, Rgb);
    input(&mut c, 1, R, 'B', Texture0, UnsignedIdentity, Alpha);
    output(&mut c, 1, R, Some(Spare0), None, None, Scale::One, Bias::Zero, false, false, false);
    output(&mut c, 1, A, None, None, None, Scale::One, Bias::Zero, false, false, false);
    fin(&mut c, 'A', FinalSource::Register(Spare0), UnsignedIdentity, Alpha);
    fin(&mut c, 'B', FinalSource::EfProduct, UnsignedIdentity, Rgb);
    fin(&mut c, 'C', FinalSource::Register(Zero), UnsignedIdentity, Rgb);
    fin(&mut c, 'D', FinalSource::Register(Constant0), UnsignedIdentity, Rgb);
    fin(&mut c, 'E', FinalSource::Register(Constant1), UnsignedIdentity, Rgb);
    fin(&mut c, 'F', FinalSource::Register(Spare0), UnsignedIdentity, Rgb);
    fin(&mut c, 'G', FinalSource::Register(Spare0), UnsignedIdentity, Alpha);
    c
}

/// configCombinersForSpecular, Appendix H.
fn appendix_h() -> CombinerConfig {
    use PortionKind::{Alpha as A, Rgb as R};
    let mut c = initial_two();
    input(&mut c, 0, R, 'A', Texture0, ExpandNormal, Rgb);
    input(&mut c, 0, R, 'B', Texture1, ExpandNormal, Rgb);
    output(&mut c, 0, R, Some(Spare0), None, None, Scale::One, Bias::Zero, true, false, false);
    input(&mut c, 0, A, 'A', Texture1, UnsignedIdentity, Blue);
    input(&mut c, 0, A, 'B', Zero, UnsignedInvert, Alpha);
    output(&mut c, 0, A, Some(Spare0), None, None, Scale::One, Bias::Zero, false, false, false);
    input(&mut c, 1, R, 'A', Zero, UnsignedIdentity, Rgb);
    input(&mut c, 1, R, 'B', Zero, UnsignedIdentity, Rgb);
    input(&mut c, 1, R, 'C', Spare0, UnsignedIdentity, Rgb);
    input(&mut c, 1, R, 'D', Spare0, SignedIdentity, Rgb);
    output(&mut c, 1, R, None, None, Some(Spare0), Scale::One, Bias::Zero, false, false, true);
    output(&mut c, 1, A, None, None, None, Scale::One, Bias::Zero, false, false, false);
    fin(&mut c, 'A', FinalSource::EfProduct, UnsignedIdentity, Rgb);
    fin(&mut c, 'B', FinalSource::EfProduct, UnsignedIdentity, Rgb);
    fin(&mut c, 'C', FinalSource::Register(Zero), UnsignedIdentity, Rgb);
    fin(&mut c, 'D', FinalSource::Register(Zero), UnsignedIdentity, Rgb);
    fin(&mut c, 'E', FinalSource::Register(Spare0), UnsignedIdentity, Rgb);
    fin(&mut c, 'F', FinalSource::Register(Spare0), UnsignedIdentity, Rgb);
    fin(&mut c, 'G', FinalSource::Register(Zero), UnsignedIdentity, Alpha);
    c
}

#[test]
fn ron_transcriptions_match_the_c_code() {
    for (name, config) in [("appendix_g.ron", appendix_g()), ("appendix_h.ron", appendix_h())] {
        assert!(validate(&config, &CombinerLimits::GEFORCE256).is_ok(), "{name} fits a GeForce 256");
        let path = format!("{}/tests/data/combiners/{name}", env!("CARGO_MANIFEST_DIR"));
        if std::env::var_os("UPDATE_GOLDEN").is_some() {
            std::fs::write(&path, config.to_ron()).unwrap();
        }
        let stored = CombinerConfig::from_ron(&common::data(name)).unwrap();
        assert_eq!(stored, config, "{name}");
    }
}

/// The nvparse programs and the GL-call transcriptions differ only in state
/// nothing reads (unused inputs, the colour-sum clamp); every pixel agrees.
#[test]
fn rc_and_ron_transcriptions_emulate_identically() {
    let n = 64 * 64;
    let t0: Vec<u8> = (0..n * 4).map(|i| (i * 7919 % 256) as u8).collect();
    let t1: Vec<u8> = (0..n * 4).map(|i| (i * 104729 % 253) as u8).collect();
    let inputs =
        Inputs { width: 64, height: 64, textures: [Some(&t0), Some(&t1), None, None], ..Inputs::default() };
    for (rc, ron) in [("appendix_g.rc", appendix_g()), ("appendix_h.rc", appendix_h())] {
        let program = parse_and_validate(&common::data(rc), &CombinerLimits::GEFORCE256).unwrap();
        for precision in [Precision::Fixed9, Precision::F32] {
            assert_eq!(
                emulate(&program, &inputs, precision).unwrap(),
                emulate(&ron, &inputs, precision).unwrap(),
                "{rc}"
            );
        }
    }
}
