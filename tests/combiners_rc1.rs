//! `!!RC1.0` (nvparse's register-combiner text format): the Appendix G and H
//! programs, the syntax nvparse accepts, the errors it raises (with
//! file:line:col), and the print → parse round trip.

use crate::combiners_common;
use combiners_common as common;

use proptest::prelude::*;
use shadec::backends::combiners::rc1::{parse, parse_and_validate, print};
use shadec::backends::combiners::{
    validate, Bias, CombinerConfig, CombinerLimits, ComponentUsage, FinalInput, FinalSource, GeneralInput,
    InputMapping, Register, Scale,
};
use shadec::diag::SourceFile;

use InputMapping::*;

fn gi(register: Register, mapping: InputMapping, usage: ComponentUsage) -> GeneralInput {
    GeneralInput { register, mapping, usage }
}

fn ok(text: &str) -> CombinerConfig {
    match parse_and_validate(text, &CombinerLimits::GEFORCE3) {
        Ok(c) => c,
        Err(d) => panic!("{}", SourceFile::new("test.rc", text).render(&d, false)),
    }
}

/// The rendered errors of an invalid program (short form: `file:line:col: error[code]: message`).
fn errors(text: &str, limits: &CombinerLimits) -> String {
    match parse_and_validate(text, limits) {
        Ok(c) => panic!("expected an error, got {c:?}"),
        Err(d) => {
            let file = SourceFile::new("test.rc", text);
            let full = file.render(&d, false);
            assert!(full.contains("help:"), "every error has a help line: {full}");
            file.render_short(&d)
        }
    }
}

#[track_caller]
fn check_error(text: &str, expected: &str) {
    let got = errors(text, &CombinerLimits::GEFORCE3);
    assert!(got.contains(expected), "expected `{expected}` in:\n{got}");
}

#[test]
fn appendix_g_parses_to_kilgards_setup() {
    let c = ok(&common::data("appendix_g.rc"));
    assert_eq!(c.constant0, Some([0.1, 0.1, 0.1, 0.0]));
    assert_eq!(c.constant1, Some([0.9, 1.0, 1.0, 0.0]));
    assert_eq!(c.general.len(), 2);
    let s0 = &c.general[0];
    assert_eq!(s0.rgb.a, gi(Register::Texture0, ExpandNormal, ComponentUsage::Rgb));
    assert_eq!(s0.rgb.b, gi(Register::Texture1, ExpandNormal, ComponentUsage::Rgb));
    assert!(s0.rgb.ab_dot && !s0.rgb.cd_dot);
    assert_eq!((s0.rgb.ab_output, s0.rgb.cd_output, s0.rgb.sum_output), (Some(Register::Spare0), None, None));
    assert_eq!(s0.alpha.a, gi(Register::Zero, UnsignedInvert, ComponentUsage::Alpha));
    assert_eq!(s0.alpha.b, gi(Register::Texture1, ExpandNormal, ComponentUsage::Blue));
    assert_eq!(s0.alpha.sum_output, Some(Register::Spare0));
    assert_eq!((s0.alpha.scale, s0.alpha.bias, s0.alpha.mux_sum), (Scale::Four, Bias::Zero, false));
    let s1 = &c.general[1];
    assert_eq!(s1.rgb.b, gi(Register::Texture0, UnsignedIdentity, ComponentUsage::Alpha));
    let f = &c.final_combiner;
    assert_eq!(f.a, FinalInput::register(Register::Spare0, ComponentUsage::Alpha));
    assert_eq!(f.b.source, FinalSource::EfProduct);
    assert_eq!(f.c, FinalInput::register(Register::Zero, ComponentUsage::Rgb));
    assert_eq!(f.d, FinalInput::register(Register::Constant0, ComponentUsage::Rgb));
    assert_eq!(f.e, FinalInput::register(Register::Constant1, ComponentUsage::Rgb));
    assert_eq!(f.f, FinalInput::register(Register::Spare0, ComponentUsage::Rgb));
    assert_eq!(f.g, FinalInput::register(Register::Spare0, ComponentUsage::Alpha));
    assert!(!f.color_sum_clamp, "!!RC1.0 leaves the colour-sum clamp off unless clamp_color_sum(); appears");
}

#[test]
fn appendix_h_parses_to_kilgards_setup() {
    let c = ok(&common::data("appendix_h.rc"));
    let s1 = &c.general[1].rgb;
    assert!(s1.mux_sum);
    assert_eq!((s1.ab_output, s1.cd_output, s1.sum_output), (None, None, Some(Register::Spare0)));
    assert_eq!(s1.c, gi(Register::Spare0, UnsignedIdentity, ComponentUsage::Rgb));
    assert_eq!(s1.d, gi(Register::Spare0, SignedIdentity, ComponentUsage::Rgb));
    assert_eq!(c.general[0].alpha.a, gi(Register::Texture1, UnsignedIdentity, ComponentUsage::Blue));
    let f = &c.final_combiner;
    assert_eq!((f.a.source, f.b.source), (FinalSource::EfProduct, FinalSource::EfProduct));
    assert_eq!(f.g, FinalInput::register(Register::Zero, ComponentUsage::Alpha));
}

#[test]
fn appendix_programs_round_trip() {
    for name in ["appendix_g.rc", "appendix_h.rc"] {
        let c = ok(&common::data(name));
        let printed = print(&c);
        assert_eq!(ok(&printed), c, "{name}:\n{printed}");
    }
}

#[test]
fn syntax_of_nvparse() {
    let c = ok("  !!RC1.0 // header
/* block
   comment */
const1 = (-0.5, .25, 1., 0);
{
  const0 = (1, 0, 0, 1);
  alpha { spare1 = -half_bias(col0.b) * -expand(one); }
  rgb {
    discard = col0;            # bare operand: times one
    spare1 = -tex2.a . half_bias(fog);
  }
}
clamp_color_sum();
final_product = unsigned_invert(tex0) * col1.a;
out.rgb = spare0 + lerp(final_product, color_sum, unsigned(one));
out.a = unsigned_invert(tex3);
");
    assert_eq!(c.constant1, Some([-0.5, 0.25, 1.0, 0.0]));
    assert_eq!(c.general[0].constant0, Some([1.0, 0.0, 0.0, 1.0]));
    let a = &c.general[0].alpha;
    assert_eq!(a.a, gi(Register::Primary, HalfBiasNegate, ComponentUsage::Blue));
    // `-expand(one)` = −1 = expand_normal(zero) (nvparse's MappedRegisterStruct::Init).
    assert_eq!(a.b, gi(Register::Zero, ExpandNormal, ComponentUsage::Alpha));
    let r = &c.general[0].rgb;
    assert_eq!(r.a, gi(Register::Primary, SignedIdentity, ComponentUsage::Rgb));
    assert_eq!(r.b, gi(Register::Zero, UnsignedInvert, ComponentUsage::Rgb));
    assert_eq!(r.c, gi(Register::Texture2, SignedNegate, ComponentUsage::Alpha));
    assert_eq!(r.d, gi(Register::Fog, HalfBiasNormal, ComponentUsage::Rgb));
    assert!(r.cd_dot && r.sum_output.is_none());
    let f = &c.final_combiner;
    assert!(f.color_sum_clamp);
    assert_eq!(
        f.e,
        FinalInput::new(FinalSource::Register(Register::Texture0), UnsignedInvert, ComponentUsage::Rgb)
    );
    assert_eq!(f.f, FinalInput::register(Register::Secondary, ComponentUsage::Alpha));
    assert_eq!(f.d, FinalInput::register(Register::Spare0, ComponentUsage::Rgb));
    assert_eq!(f.b.source, FinalSource::Spare0PlusSecondary);
    assert_eq!(
        f.c,
        FinalInput::new(FinalSource::Register(Register::Zero), UnsignedInvert, ComponentUsage::Rgb)
    );
    assert_eq!(
        f.g,
        FinalInput::new(FinalSource::Register(Register::Texture3), UnsignedInvert, ComponentUsage::Alpha)
    );
}

#[test]
fn shorter_final_forms() {
    let zero = FinalInput::register(Register::Zero, ComponentUsage::Rgb);
    let one = FinalInput::new(FinalSource::Register(Register::Zero), UnsignedInvert, ComponentUsage::Rgb);
    let t0 = FinalInput::register(Register::Texture0, ComponentUsage::Rgb);
    let t1 = FinalInput::register(Register::Texture1, ComponentUsage::Rgb);
    let abcd = |src: &str| {
        let f = ok(&format!("!!RC1.0\nout.rgb = {src};\n")).final_combiner;
        (f.a, f.b, f.c, f.d)
    };
    assert_eq!(abcd("lerp(tex0, tex1, zero)"), (t0, t1, zero, zero));
    assert_eq!(abcd("tex0 * tex1"), (t0, t1, zero, zero));
    assert_eq!(abcd("tex0 * tex1 + tex0"), (t0, t1, zero, t0));
    assert_eq!(abcd("tex1"), (zero, zero, zero, t1));
    assert_eq!(abcd("tex0 + tex1"), (t0, one, zero, t1));
    // nvparse moves color_sum out of A: `color_sum * tex0` → A = tex0, B = color_sum.
    let cs = FinalInput::new(FinalSource::Spare0PlusSecondary, UnsignedIdentity, ComponentUsage::Rgb);
    assert_eq!(abcd("color_sum * tex0"), (t0, cs, zero, zero));
    // `color_sum + tex0`: nvparse's first swap already applies (C is zero): A = one, B = color_sum.
    assert_eq!(abcd("color_sum + tex0"), (one, cs, zero, t0));
    // A program with only `out.a`: rgb is zero, alpha as given; no general combiner.
    let c = ok("!!RC1.0\nout.a = col0;");
    assert!(c.general.is_empty());
    assert_eq!(c.final_combiner.a, zero);
}

#[test]
fn texture_shader_block_is_parsed() {
    use shadec::backends::combiners::ts1::Operation;
    let text = "!!TS1.0\ntexture_2d();\nnop();\n!!RC1.0\nout.rgb = tex0;\n";
    let c = ok(text);
    let stages = c.texture_shader.as_ref().map(|t| t.stages.clone());
    assert_eq!(stages, Some(vec![Operation::Texture2d, Operation::Nop]));
    assert_eq!(print(&c).lines().next(), Some("!!TS1.0"));
    assert_eq!(ok(&print(&c)), c);
}

#[test]
fn syntax_errors_have_locations_and_help() {
    check_error(
        "!!RC1.0\n{ rgb { spare0 = tex0 * tex1 } }\nout.rgb = spare0;",
        "test.rc:2:29: error[syntax]: expected `;`",
    );
    check_error(
        "!!RC1.0\n{ rgb { spare0 = texture0 * tex1; } }\nout.rgb = spare0;",
        "test.rc:2:18: error[unknown-register]: unknown register `texture0`",
    );
    check_error(
        "{ rgb { spare0 = tex0; } }\nout.rgb = spare0;",
        "test.rc:1:1: error[syntax]: expected the `!!RC1.0` header",
    );
    check_error(
        "!!RC1.0\n{ rgb { spare0 = tex0; } rgb { spare1 = tex0; } }\nout.rgb = spare0;",
        "test.rc:2:26: error[portion-twice]",
    );
    check_error(
        "!!RC1.0\nconst0 = (1, 0, 0, 1);\nconst0 = (0, 1, 0, 1);\nout.rgb = const0;",
        "test.rc:3:1: error[constant-twice]",
    );
    check_error(
        "!!RC1.0\n{ rgb { spare0 = discard * tex1; } }\nout.rgb = spare0;",
        "test.rc:2:18: error[read-discard]",
    );
    check_error("!!RC1.0\nout.rgb = final_product;", "test.rc:2:11: error[final-product-unset]");
    check_error(
        "!!RC1.0\n{ rgb { spare0 = tex0; scale_by_three(); } }\nout.rgb = spare0;",
        "test.rc:2:24: error[syntax]: unknown function `scale_by_three`",
    );
    check_error(
        "!!RC1.0\n{ rgb { spare0 = color_sum; } }\nout.rgb = spare0;",
        "test.rc:2:18: error[final-only]",
    );
    check_error(
        "!!RC1.0\n{ rgb { spare0 = sum(); } }\nout.rgb = spare0;",
        "error[syntax]: `sum()` needs both an AB and a CD product",
    );
    check_error(
        "!!RC1.0\nout.rgb = -tex0;",
        "test.rc:2:11: error[syntax]: the final combiner has no signed mappings",
    );
    check_error("!!RC1.0\n{ rgb { spare0 = tex0; } }\n", "expected the final combiner");
    check_error(
        "!!RC1.0\nout.rgb = tex0;\n{ rgb { spare0 = tex0; } }",
        "test.rc:3:1: error[syntax]: unexpected `{`",
    );
    check_error("!!RC1.0\nout.rgb = tex0 @ tex1;", "test.rc:2:16: error[syntax]: unexpected character `@`");
    check_error("!!RC1.0\nout.rgb = tex0; /* open", "error[syntax]: unterminated `/*` comment");
    check_error("!!RC1.0\nout.rgb = tex0.rgba;", "unknown component selector `.rgba`");
}

#[test]
fn validation_errors_point_at_the_source() {
    // Each Appendix B rule, found by the validator, located in the program.
    check_error(
        "!!RC1.0\n{ alpha { spare0 = tex0 . tex1; } }\nout.rgb = spare0;",
        "test.rc:2:11: error[dot-in-alpha]",
    );
    check_error(
        "!!RC1.0\n{ rgb { discard = tex0 . tex1; discard = tex0 * tex1; spare0 = sum(); } }\nout.rgb = spare0;",
        "test.rc:2:55: error[dot-with-sum]",
    );
    check_error(
        "!!RC1.0\n{ rgb { spare0 = tex0; spare0 = tex1; } }\nout.rgb = spare0;",
        "test.rc:2:24: error[duplicate-output]",
    );
    check_error(
        "!!RC1.0\n{ rgb { zero = tex0; } }\nout.rgb = spare0;",
        "test.rc:2:9: error[read-only-output]",
    );
    check_error("!!RC1.0\n{ rgb { spare0 = tex0; scale_by_four(); bias_by_negative_one_half(); } }\nout.rgb = spare0;", "test.rc:2:24: error[bias-with-scale]");
    check_error(
        "!!RC1.0\n{ alpha { spare0 = fog * one; } }\nout.rgb = spare0;",
        "test.rc:2:20: error[fog-alpha-in-general]",
    );
    check_error(
        "!!RC1.0\n{ rgb { spare0 = tex0.b; } }\nout.rgb = spare0;",
        "test.rc:2:18: error[component-usage]",
    );
    check_error(
        "!!RC1.0\n{ alpha { spare0 = tex0.rgb; } }\nout.rgb = spare0;",
        "test.rc:2:20: error[component-usage]",
    );
    check_error(
        "!!RC1.0\nout.rgb = lerp(color_sum, color_sum, tex0);",
        "test.rc:2:16: error[color-sum-input]",
    );
    check_error("!!RC1.0\nout.a = tex0.rgb;", "test.rc:2:9: error[g-reads-alpha]");
    check_error("!!RC1.0\nout.rgb = tex0.b;", "test.rc:2:11: error[component-usage]");
    check_error(
        "!!RC1.0\nfinal_product = final_product * tex0;\nout.rgb = tex0;",
        "test.rc:2:17: error[ef-product-input]",
    );
    check_error("!!RC1.0\nout.a = final_product;", "error[ef-product-input]");
    check_error("!!RC1.0\nout.a = color_sum;", "error[color-sum-input]");
}

#[test]
fn too_many_general_combiners_is_an_error_not_a_truncation() {
    let three = "!!RC1.0\n{ rgb { spare0 = tex0; } }\n{ rgb { spare0 = tex1; } }\n{ rgb { spare0 = col0; } }\nout.rgb = spare0;";
    let got = errors(three, &CombinerLimits::GEFORCE256);
    assert!(got.contains("test.rc:4:1: error[too-many-stages]: general combiner 2: 3 general combiners, but the target profile has only 2"), "{got}");
    assert_eq!(ok(three).general.len(), 3);
    let per_stage = "!!RC1.0\n{ const0 = (1, 1, 1, 1); rgb { spare0 = const0; } }\nout.rgb = spare0;";
    let got = errors(per_stage, &CombinerLimits::GEFORCE256);
    assert!(got.contains("test.rc:2:3: error[per-stage-constant]"), "{got}");
    let tex2 = "!!RC1.0\nout.rgb = tex2;";
    assert!(errors(tex2, &CombinerLimits::GEFORCE256).contains("test.rc:2:11: error[texture-unit]"));
}

#[test]
fn parser_never_panics_on_mangled_programs() {
    let g = common::data("appendix_g.rc");
    // Every prefix, and every single-byte deletion, of a real program.
    for cut in (0..=g.len()).filter(|&i| g.is_char_boundary(i)) {
        let _ = parse(&g[..cut]);
        if cut < g.len() {
            let mut s = g.clone();
            s.remove(cut);
            let _ = parse(&s);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn print_parse_round_trip(config in common::config(8)) {
        prop_assert!(validate(&config, &CombinerLimits::GEFORCE3).is_ok(), "generator made an invalid config");
        let printed = print(&config);
        let parsed = parse_and_validate(&printed, &CombinerLimits::GEFORCE3);
        match parsed {
            Ok(parsed) => prop_assert_eq!(parsed, config, "{}", printed),
            Err(d) => prop_assert!(false, "{}\n{}", SourceFile::new("printed.rc", printed.clone()).render(&d, false), printed),
        }
    }

    #[test]
    fn ron_round_trip(config in common::config(8)) {
        let ron = config.to_ron();
        prop_assert_eq!(CombinerConfig::from_ron(&ron).map_err(|e| e.to_string()), Ok(config), "{}", ron);
    }

    #[test]
    fn parser_never_panics(text in "!!RC1\\.0[ -~\n]{0,200}") {
        let _ = parse_and_validate(&text, &CombinerLimits::GEFORCE256);
    }

    #[test]
    fn parser_never_panics_on_token_soup(words in prop::collection::vec(prop::sample::select(vec![
        "{", "}", "(", ")", ";", ",", ".", "*", "-", "+", "=", "rgb", "alpha", "tex0", "spare0.a", "col1.b", "one", "zero",
        "discard", "expand", "half_bias", "unsigned", "unsigned_invert", "sum", "mux", "scale_by_two", "out.rgb", "out.a",
        "lerp", "final_product", "color_sum", "clamp_color_sum", "const0", "0.5", "1", "fog", "é", "/*", "#",
    ]), 0..60)) {
        let text = format!("!!RC1.0\n{}", words.join(" "));
        let _ = parse_and_validate(&text, &CombinerLimits::GEFORCE3);
    }
}
