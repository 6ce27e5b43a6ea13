//! Prints a `CombinerConfig` as `!!RC1.0` text that [`super::parse`] reads
//! back to the identical config (the round-trip property tested in
//! `tests/combiners_rc1.rs`).
//!
//! Every valid config prints as nvparse-compatible text. A few invalid
//! states (bias with scale ½ or 4, a mux flag on a discarded output beside a
//! dot product) have no nvparse spelling; they print in this parser's
//! extended form (two scale/bias calls; `discard = mux();`) so that the
//! validator, not the printer, reports them.

use std::fmt::Write as _;

use super::register_name;

use crate::backends::combiners::config::{
    Bias, CombinerConfig, ComponentUsage, FinalCombiner, FinalInput, FinalSource, GeneralInput,
    GeneralPortion, InputMapping, PortionKind, Register, Scale,
};

/// The configuration as `!!RC1.0` text (nvparse's language for the register combiners),
/// preceded by its `!!TS1.0` texture shader if it has one.
pub fn print(config: &CombinerConfig) -> String {
    let mut out = String::new();
    if let Some(ts) = &config.texture_shader {
        out.push_str(&crate::backends::combiners::ts1::print(ts));
    }
    out.push_str("!!RC1.0\n");
    for (i, c) in [config.constant0, config.constant1].iter().enumerate() {
        if let Some(c) = c {
            let _ = writeln!(out, "const{i} = {};", color(c));
        }
    }
    for (s, stage) in config.general.iter().enumerate() {
        let _ = writeln!(out, "# general combiner {s}");
        out.push_str("{\n");
        for (i, c) in [stage.constant0, stage.constant1].iter().enumerate() {
            if let Some(c) = c {
                let _ = writeln!(out, "  const{i} = {};", color(c));
            }
        }
        let rgb_empty = stage.rgb == GeneralPortion::discard_all();
        let alpha_empty = stage.alpha == GeneralPortion::discard_all();
        if !rgb_empty || alpha_empty {
            portion(&mut out, PortionKind::Rgb, &stage.rgb);
        }
        if !alpha_empty {
            portion(&mut out, PortionKind::Alpha, &stage.alpha);
        }
        out.push_str("}\n");
    }
    final_combiner(&mut out, &config.final_combiner);
    out
}

fn color(c: &[f32; 4]) -> String {
    format!("({}, {}, {}, {})", c[0], c[1], c[2], c[3])
}

fn selector(usage: ComponentUsage, default: ComponentUsage) -> &'static str {
    if usage == default {
        return "";
    }
    match usage {
        ComponentUsage::Rgb => ".rgb",
        ComponentUsage::Alpha => ".a",
        ComponentUsage::Blue => ".b",
    }
}

fn default_usage(kind: PortionKind) -> ComponentUsage {
    match kind {
        PortionKind::Rgb => ComponentUsage::Rgb,
        PortionKind::Alpha => ComponentUsage::Alpha,
    }
}

fn general_operand(input: &GeneralInput, kind: PortionKind) -> String {
    let sel = selector(input.usage, default_usage(kind));
    if input.register == Register::Zero && input.mapping == InputMapping::UnsignedInvert {
        return format!("one{sel}");
    }
    let r = format!("{}{sel}", register_name(input.register));
    match input.mapping {
        InputMapping::SignedIdentity => r,
        InputMapping::SignedNegate => format!("-{r}"),
        InputMapping::ExpandNormal => format!("expand({r})"),
        InputMapping::ExpandNegate => format!("-expand({r})"),
        InputMapping::HalfBiasNormal => format!("half_bias({r})"),
        InputMapping::HalfBiasNegate => format!("-half_bias({r})"),
        InputMapping::UnsignedIdentity => format!("unsigned({r})"),
        InputMapping::UnsignedInvert => format!("unsigned_invert({r})"),
    }
}

fn output(r: Option<Register>) -> &'static str {
    r.map_or("discard", register_name)
}

fn portion(out: &mut String, kind: PortionKind, p: &GeneralPortion) {
    let _ = writeln!(out, "  {} {{", kind.name());
    let op = |dot: bool| if dot { " . " } else { " * " };
    let _ = writeln!(
        out,
        "    {} = {}{}{};",
        output(p.ab_output),
        general_operand(&p.a, kind),
        op(p.ab_dot),
        general_operand(&p.b, kind)
    );
    // nvparse fills C and D with unsigned zero when the CD product is left out.
    let zero = GeneralInput::new(Register::Zero, InputMapping::UnsignedIdentity, default_usage(kind));
    let cd_default = p.cd_output.is_none() && !p.cd_dot && p.c == zero && p.d == zero;
    let sum_default = p.sum_output.is_none() && !p.mux_sum;
    if !cd_default || !sum_default {
        let _ = writeln!(
            out,
            "    {} = {}{}{};",
            output(p.cd_output),
            general_operand(&p.c, kind),
            op(p.cd_dot),
            general_operand(&p.d, kind)
        );
    }
    if !sum_default {
        let _ = writeln!(out, "    {} = {}();", output(p.sum_output), if p.mux_sum { "mux" } else { "sum" });
    }
    let scale = match p.scale {
        Scale::One => None,
        Scale::Two => Some("scale_by_two"),
        Scale::Four => Some("scale_by_four"),
        Scale::OneHalf => Some("scale_by_one_half"),
    };
    match (scale, p.bias) {
        (None, Bias::Zero) => {}
        (Some(s), Bias::Zero) => {
            let _ = writeln!(out, "    {s}();");
        }
        (None, Bias::NegativeOneHalf) => out.push_str("    bias_by_negative_one_half();\n"),
        (Some("scale_by_two"), Bias::NegativeOneHalf) => {
            out.push_str("    bias_by_negative_one_half_scale_by_two();\n")
        }
        (Some(s), Bias::NegativeOneHalf) => {
            let _ = writeln!(out, "    {s}();\n    bias_by_negative_one_half();");
        }
    }
    out.push_str("  }\n");
}

fn final_operand(input: &FinalInput, default: ComponentUsage) -> String {
    let sel = selector(input.usage, default);
    let r = match input.source {
        FinalSource::EfProduct => "final_product".to_string(),
        FinalSource::Spare0PlusSecondary => "color_sum".to_string(),
        FinalSource::Register(Register::Zero) if input.mapping == InputMapping::UnsignedInvert => {
            return format!("one{sel}")
        }
        FinalSource::Register(r) => format!("{}{sel}", register_name(r)),
    };
    match input.mapping {
        InputMapping::UnsignedInvert => format!("unsigned_invert({r})"),
        // Signed mappings have no final-combiner spelling; `unsigned(...)`
        // is the closest, and the validator rejects such configs anyway.
        _ => r,
    }
}

fn final_combiner(out: &mut String, fc: &FinalCombiner) {
    use ComponentUsage::{Alpha, Rgb};
    if fc.color_sum_clamp {
        out.push_str("clamp_color_sum();\n");
    }
    let zero = FinalInput::register(Register::Zero, Rgb);
    let reads_ef = [fc.a, fc.b, fc.c, fc.d].iter().any(|i| i.source == FinalSource::EfProduct);
    if reads_ef || fc.e != zero || fc.f != zero {
        let _ =
            writeln!(out, "final_product = {} * {};", final_operand(&fc.e, Rgb), final_operand(&fc.f, Rgb));
    }
    let _ = writeln!(
        out,
        "out.rgb = lerp({}, {}, {}) + {};",
        final_operand(&fc.a, Rgb),
        final_operand(&fc.b, Rgb),
        final_operand(&fc.c, Rgb),
        final_operand(&fc.d, Rgb)
    );
    let _ = writeln!(out, "out.a = {};", final_operand(&fc.g, Alpha));
}
