//! Every validity rule Kilgard 2000, Appendix B states (B.4 for general stages,
//! B.5 for the final combiner), plus the target profile's limits.
//!
//! Validation reports all problems, not just the first. Each error names a
//! [`Place`] in the config; a front end that knows where that place came from
//! (the `!!RC1.0` parser) turns it into a span, otherwise the message itself
//! says which stage, portion and variable.

use std::fmt;

use crate::diag::Diagnostic;
use crate::span::Span;

use super::config::{
    Bias, CombinerConfig, CombinerLimits, ComponentUsage, FinalSource, GeneralPortion, InputMapping,
    PortionKind, Register, Scale,
};

/// Which output of a general portion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OutputSlot {
    Ab,
    Cd,
    Sum,
}

impl OutputSlot {
    /// The output's name as `!!RC1.0` spells it.
    pub fn name(self) -> &'static str {
        match self {
            OutputSlot::Ab => "AB",
            OutputSlot::Cd => "CD",
            OutputSlot::Sum => "sum/mux",
        }
    }
}

/// A place in a `CombinerConfig`, for error messages and spans.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Place {
    Config,
    /// `const0` (0) or `const1` (1) of the whole program.
    GlobalConstant(u8),
    Stage(usize),
    StageConstant(usize, u8),
    Portion(usize, PortionKind),
    Input(usize, PortionKind, char),
    Output(usize, PortionKind, OutputSlot),
    ScaleBias(usize, PortionKind),
    FinalInput(char),
}

impl fmt::Display for Place {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Place::Config => write!(f, "the combiner setup"),
            Place::GlobalConstant(i) => write!(f, "constant colour {i}"),
            Place::Stage(s) => write!(f, "general combiner {s}"),
            Place::StageConstant(s, i) => write!(f, "general combiner {s}, per-stage constant colour {i}"),
            Place::Portion(s, p) => write!(f, "general combiner {s}, {} portion", p.name()),
            Place::Input(s, p, v) => write!(f, "general combiner {s}, {} portion, variable {v}", p.name()),
            Place::Output(s, p, o) => {
                write!(f, "general combiner {s}, {} portion, {} output", p.name(), o.name())
            }
            Place::ScaleBias(s, p) => write!(f, "general combiner {s}, {} portion, scale/bias", p.name()),
            Place::FinalInput(v) => write!(f, "final combiner, variable {v}"),
        }
    }
}

/// One broken rule.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ValidationError {
    /// A stable code, e.g. `dot-in-alpha`.
    pub code: &'static str,
    pub place: Place,
    /// What is wrong, without the place.
    pub message: String,
    pub help: String,
}

impl fmt::Display for ValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.place, self.message)
    }
}

impl ValidationError {
    /// A diagnostic at the span `span_of` gives for the place (or a detached
    /// span, with the place spelled out in the message).
    pub fn to_diagnostic(&self, span_of: &dyn Fn(Place) -> Option<Span>) -> Diagnostic {
        let (span, label) = match span_of(self.place) {
            Some(span) => (span, self.message.clone()),
            None => (Span::DETACHED, self.place.to_string()),
        };
        Diagnostic::error(self.code, self.to_string(), span, label).with_help(self.help.clone())
    }
}

/// Checks `config` against Kilgard 2000, Appendix B and `limits`.
pub fn validate(config: &CombinerConfig, limits: &CombinerLimits) -> Result<(), Vec<ValidationError>> {
    let mut v = Validator { limits, errors: Vec::new() };
    v.config(config);
    if v.errors.is_empty() {
        Ok(())
    } else {
        Err(v.errors)
    }
}

struct Validator<'a> {
    limits: &'a CombinerLimits,
    errors: Vec<ValidationError>,
}

impl Validator<'_> {
    fn error(
        &mut self,
        code: &'static str,
        place: Place,
        message: impl Into<String>,
        help: impl Into<String>,
    ) {
        self.errors.push(ValidationError { code, place, message: message.into(), help: help.into() });
    }

    fn config(&mut self, config: &CombinerConfig) {
        for (i, c) in [config.constant0, config.constant1].iter().enumerate() {
            if let Some(c) = c {
                self.constant(Place::GlobalConstant(i as u8), c);
            }
        }
        let n = config.general.len();
        if n > self.limits.general_combiners {
            self.error(
                "too-many-stages",
                Place::Stage(self.limits.general_combiners),
                format!(
                    "{n} general combiners, but the target profile has only {}",
                    self.limits.general_combiners
                ),
                "merge stages, split the work into several passes, or target a profile with more general combiners (geforce3 has 8)",
            );
        }
        for (s, stage) in config.general.iter().enumerate() {
            for (i, c) in [stage.constant0, stage.constant1].iter().enumerate() {
                if let Some(c) = c {
                    if !self.limits.per_stage_constants {
                        self.error(
                            "per-stage-constant",
                            Place::StageConstant(s, i as u8),
                            "per-stage constant colours need NV_register_combiners2, which the target profile lacks",
                            "set the constant once for the whole program, or target geforce3",
                        );
                    }
                    self.constant(Place::StageConstant(s, i as u8), c);
                }
            }
            self.portion(s, PortionKind::Rgb, &stage.rgb);
            self.portion(s, PortionKind::Alpha, &stage.alpha);
        }
        self.final_combiner(config);
    }

    fn constant(&mut self, place: Place, c: &[f32; 4]) {
        if c.iter().any(|x| !x.is_finite()) {
            self.error(
                "constant-not-finite",
                place,
                format!("constant colour ({}, {}, {}, {}) is not finite", c[0], c[1], c[2], c[3]),
                "give four finite numbers; colours are clamped to [0, 1]",
            );
        }
    }

    fn register(&mut self, place: Place, register: Register) {
        if let Some(unit) = register.texture_unit() {
            if unit >= self.limits.texture_units {
                self.error(
                    "texture-unit",
                    place,
                    format!(
                        "`{}` needs texture unit {unit}, but the target profile has {}",
                        register.name(),
                        self.limits.texture_units
                    ),
                    "use a texture unit the profile has, or target geforce3 (4 units)",
                );
            }
        }
    }

    /// One portion of general stage `s` against Appendix B's rules.
    fn portion(&mut self, s: usize, kind: PortionKind, p: &GeneralPortion) {
        self.portion_inputs(s, kind, p);
        if kind == PortionKind::Alpha && !self.limits.alpha_dot_products {
            for (dot, slot) in [(p.ab_dot, OutputSlot::Ab), (p.cd_dot, OutputSlot::Cd)] {
                if dot {
                    self.error(
                        "dot-in-alpha",
                        Place::Output(s, kind, slot),
                        "dot products exist only in the RGB portion",
                        "compute the dot product in the RGB portion and read its result's blue or alpha (or pass `--permissive` to run NV2A's alpha dot product, the product of the two inputs)",
                    );
                }
            }
        }
        if (p.ab_dot || p.cd_dot) && p.sum_output.is_some() {
            self.error(
                "dot-with-sum",
                Place::Output(s, kind, OutputSlot::Sum),
                "a dot product output forbids the sum/mux output",
                "discard the sum/mux output (`discard = sum();` or leave it out), or use products instead of dots",
            );
        }
        self.portion_outputs(s, kind, p);
        if p.bias == Bias::NegativeOneHalf && matches!(p.scale, Scale::OneHalf | Scale::Four) {
            self.error(
                "bias-with-scale",
                Place::ScaleBias(s, kind),
                "bias by −½ cannot be combined with scale by ½ or 4",
                "use the bias with scale 1 or 2 (`bias_by_negative_one_half_scale_by_two()`), or drop the bias",
            );
        }
    }

    /// The inputs of one portion: their registers readable, their
    /// component usage allowed in the portion (Kilgard 2000, Appendix B).
    fn portion_inputs(&mut self, s: usize, kind: PortionKind, p: &GeneralPortion) {
        for (var, input) in p.inputs() {
            let place = Place::Input(s, kind, var);
            self.register(place, input.register);
            match (kind, input.usage) {
                (PortionKind::Rgb, ComponentUsage::Blue) => self.error(
                    "component-usage",
                    place,
                    "an RGB variable reads `rgb` or `alpha`, not `blue`",
                    "use the blue component in the alpha portion, or read the register's rgb or alpha",
                ),
                (PortionKind::Alpha, ComponentUsage::Rgb) => self.error(
                    "component-usage",
                    place,
                    "an alpha variable reads `alpha` or `blue`, not `rgb`",
                    "read `.a` or `.b` in the alpha portion",
                ),
                _ => {}
            }
            if input.register == Register::Fog && input.usage == ComponentUsage::Alpha {
                self.error(
                    "fog-alpha-in-general",
                    place,
                    "the fog register's alpha (the fog factor) is available only in the final combiner",
                    "read fog alpha in the final combiner, or use the fog colour (`fog.rgb` / `fog.b`)",
                );
            }
        }
    }

    /// The outputs of one portion: writable registers, none written twice.
    fn portion_outputs(&mut self, s: usize, kind: PortionKind, p: &GeneralPortion) {
        let outputs =
            [(OutputSlot::Ab, p.ab_output), (OutputSlot::Cd, p.cd_output), (OutputSlot::Sum, p.sum_output)];
        for (i, (slot, out)) in outputs.iter().enumerate() {
            let Some(register) = *out else { continue };
            let place = Place::Output(s, kind, *slot);
            if !register.is_writable() {
                self.error(
                    "read-only-output",
                    place,
                    format!("`{}` is a read-only register", register.name()),
                    "write to spare0, spare1, primary, secondary or a texture register",
                );
            } else {
                self.register(place, register);
            }
            if let Some((first, _)) = outputs[..i].iter().find(|(_, o)| *o == Some(register)) {
                self.error(
                    "duplicate-output",
                    place,
                    format!(
                        "`{}` is already written by the {} output of this portion",
                        register.name(),
                        first.name()
                    ),
                    "each output of a portion needs its own register (several may be discarded)",
                );
            }
        }
    }

    fn final_combiner(&mut self, config: &CombinerConfig) {
        for (var, input) in config.final_combiner.inputs() {
            let place = Place::FinalInput(var);
            if !matches!(input.mapping, InputMapping::UnsignedIdentity | InputMapping::UnsignedInvert) {
                self.error(
                    "final-mapping",
                    place,
                    format!(
                        "the final combiner accepts only unsigned_identity and unsigned_invert, not {}",
                        input.mapping.name()
                    ),
                    "do signed work in a general combiner and pass the result on",
                );
            }
            match input.source {
                FinalSource::Register(register) => {
                    self.register(place, register);
                    // G is one number: a register's alpha, or its blue (nvparse's
                    // final-combiner check, and `glFinalCombinerInputNV(GL_VARIABLE_G_NV,
                    // …, GL_BLUE)` in real code: `out.a = tex3.b;`).
                    if var == 'G' && input.usage == ComponentUsage::Rgb {
                        self.error(
                            "g-reads-alpha",
                            place,
                            "variable G reads one component (`.a` or `.b`), not rgb",
                            "read `.a` or `.b` of a register for G",
                        );
                    } else if var != 'G' && input.usage == ComponentUsage::Blue {
                        self.error(
                            "component-usage",
                            place,
                            "final combiner variables read `rgb` or `alpha`, not `blue`",
                            "move the blue component to alpha in a general combiner",
                        );
                    }
                }
                FinalSource::EfProduct => {
                    if !matches!(var, 'A' | 'B' | 'C' | 'D') {
                        self.error(
                            "ef-product-input",
                            place,
                            "the EF product pseudo-register can feed only A, B, C and D",
                            "use `final_product` in `out.rgb`, not in E, F or G",
                        );
                    } else if input.usage != ComponentUsage::Rgb {
                        self.error(
                            "pseudo-register-usage",
                            place,
                            "the EF product is read as RGB only",
                            "drop the component selector",
                        );
                    }
                }
                FinalSource::Spare0PlusSecondary => {
                    if !matches!(var, 'B' | 'C' | 'D') {
                        self.error(
                            "color-sum-input",
                            place,
                            "the spare0+secondary pseudo-register can feed only B, C and D",
                            "use `color_sum` as the second or third lerp operand or the added term",
                        );
                    } else if input.usage != ComponentUsage::Rgb {
                        self.error(
                            "pseudo-register-usage",
                            place,
                            "spare0+secondary is read as RGB only",
                            "drop the component selector",
                        );
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::backends::combiners::config::{FinalInput, GeneralInput, GeneralStage};

    fn codes(config: &CombinerConfig, limits: &CombinerLimits) -> Vec<&'static str> {
        match validate(config, limits) {
            Ok(()) => Vec::new(),
            Err(errors) => errors.iter().map(|e| e.code).collect(),
        }
    }

    /// Validates `config` on geforce3 and expects exactly the error `code`.
    #[track_caller]
    fn check(config: &CombinerConfig, code: &str) {
        assert_eq!(codes(config, &CombinerLimits::GEFORCE3), vec![code]);
    }

    #[test]
    fn initial_state_of_tables_4_to_6_is_valid() {
        assert_eq!(codes(&CombinerConfig::default(), &CombinerLimits::GEFORCE256), Vec::<&str>::new());
        let eight = CombinerConfig {
            general: (0..8).map(GeneralStage::initial).collect(),
            ..CombinerConfig::default()
        };
        assert_eq!(codes(&eight, &CombinerLimits::GEFORCE3), Vec::<&str>::new());
        assert_eq!(CombinerConfig::default().general[0].rgb.b.register, Register::Texture0);
        assert_eq!(GeneralStage::initial(1).alpha.b.register, Register::Texture1);
        assert!(CombinerConfig::default().final_combiner.color_sum_clamp);
    }

    #[test]
    fn dot_only_in_rgb() {
        let mut c = CombinerConfig::default();
        c.general[0].alpha.ab_dot = true;
        c.general[0].alpha.sum_output = None;
        check(&c, "dot-in-alpha");
    }

    #[test]
    fn dot_forbids_sum_output() {
        let mut c = CombinerConfig::default();
        c.general[0].rgb.cd_dot = true; // sum_output is spare0 initially
        check(&c, "dot-with-sum");
        c.general[0].rgb.sum_output = None;
        check_ok(&c);
    }

    #[track_caller]
    fn check_ok(config: &CombinerConfig) {
        assert_eq!(codes(config, &CombinerLimits::GEFORCE3), Vec::<&str>::new());
    }

    #[test]
    fn output_registers_are_distinct_but_discards_may_repeat() {
        let mut c = CombinerConfig::default();
        c.general[0].rgb.ab_output = Some(Register::Spare0);
        check(&c, "duplicate-output");
        c.general[0].rgb.ab_output = None;
        c.general[0].rgb.cd_output = None;
        check_ok(&c);
    }

    #[test]
    fn outputs_are_read_write_registers() {
        for r in [Register::Zero, Register::Constant0, Register::Constant1, Register::Fog] {
            let mut c = CombinerConfig::default();
            c.general[0].alpha.sum_output = Some(r);
            check(&c, "read-only-output");
        }
    }

    #[test]
    fn bias_not_with_scale_one_half_or_four() {
        for (scale, ok) in
            [(Scale::OneHalf, false), (Scale::Four, false), (Scale::One, true), (Scale::Two, true)]
        {
            let mut c = CombinerConfig::default();
            c.general[0].rgb.scale = scale;
            c.general[0].rgb.bias = Bias::NegativeOneHalf;
            if ok {
                check_ok(&c);
            } else {
                check(&c, "bias-with-scale");
            }
        }
    }

    #[test]
    fn ef_product_only_into_a_to_d() {
        let ef = FinalInput::new(FinalSource::EfProduct, InputMapping::UnsignedIdentity, ComponentUsage::Rgb);
        let mut c = CombinerConfig::default();
        c.final_combiner.a = ef;
        c.final_combiner.d = ef;
        check_ok(&c);
        c.final_combiner.e = ef;
        check(&c, "ef-product-input");
        let mut c = CombinerConfig::default();
        c.final_combiner.g = FinalInput { usage: ComponentUsage::Alpha, ..ef };
        check(&c, "ef-product-input");
    }

    #[test]
    fn color_sum_only_into_b_to_d() {
        let cs = FinalInput::new(
            FinalSource::Spare0PlusSecondary,
            InputMapping::UnsignedIdentity,
            ComponentUsage::Rgb,
        );
        for var in ['A', 'F'] {
            let mut c = CombinerConfig::default();
            match var {
                'A' => c.final_combiner.a = cs,
                _ => c.final_combiner.f = cs,
            }
            check(&c, "color-sum-input");
        }
        let mut c = CombinerConfig::default();
        c.final_combiner.d = cs;
        check_ok(&c);
    }

    #[test]
    fn pseudo_registers_are_read_as_rgb() {
        let mut c = CombinerConfig::default();
        c.final_combiner.b.usage = ComponentUsage::Alpha; // B is spare0+secondary initially
        check(&c, "pseudo-register-usage");
    }

    #[test]
    fn g_reads_alpha() {
        let mut c = CombinerConfig::default();
        c.final_combiner.g.usage = ComponentUsage::Rgb;
        check(&c, "g-reads-alpha");
    }

    #[test]
    fn final_mappings_are_unsigned() {
        let mut c = CombinerConfig::default();
        c.final_combiner.c.mapping = InputMapping::ExpandNormal;
        check(&c, "final-mapping");
    }

    #[test]
    fn final_variables_do_not_read_blue() {
        let mut c = CombinerConfig::default();
        c.final_combiner.d.usage = ComponentUsage::Blue;
        check(&c, "component-usage");
    }

    #[test]
    fn fog_alpha_only_in_final_combiner() {
        let mut c = CombinerConfig::default();
        c.general[0].alpha.c =
            GeneralInput::new(Register::Fog, InputMapping::UnsignedIdentity, ComponentUsage::Alpha);
        check(&c, "fog-alpha-in-general");
        // The fog colour's blue is fine in the alpha portion, fog alpha in the final combiner.
        c.general[0].alpha.c.usage = ComponentUsage::Blue;
        c.final_combiner.g = FinalInput::register(Register::Fog, ComponentUsage::Alpha);
        check_ok(&c);
        // In the RGB portion, smearing fog alpha is just as forbidden.
        c.general[0].rgb.d =
            GeneralInput::new(Register::Fog, InputMapping::UnsignedIdentity, ComponentUsage::Alpha);
        check(&c, "fog-alpha-in-general");
    }

    #[test]
    fn component_usage_matches_portion() {
        let mut c = CombinerConfig::default();
        c.general[0].rgb.a.usage = ComponentUsage::Blue;
        check(&c, "component-usage");
        let mut c = CombinerConfig::default();
        c.general[0].alpha.a.usage = ComponentUsage::Rgb;
        check(&c, "component-usage");
    }

    #[test]
    fn stage_count_within_profile() {
        let c = CombinerConfig {
            general: (0..3).map(GeneralStage::initial).collect(),
            ..CombinerConfig::default()
        };
        // Stage 2's B reads texture2, which geforce256 lacks as well.
        let errors = validate(&c, &CombinerLimits::GEFORCE256).unwrap_err();
        assert_eq!(errors[0].code, "too-many-stages");
        assert_eq!(errors[0].place, Place::Stage(2));
        assert!(
            errors[0].to_string().contains("3 general combiners, but the target profile has only 2"),
            "{}",
            errors[0]
        );
        check_ok(&c);
        let c = CombinerConfig {
            general: (0..9).map(|_| GeneralStage::initial(0)).collect(),
            ..CombinerConfig::default()
        };
        check(&c, "too-many-stages");
        // No general combiner at all is valid.
        check_ok(&CombinerConfig { general: Vec::new(), ..CombinerConfig::default() });
    }

    #[test]
    fn texture_units_within_profile() {
        let c = CombinerConfig { general: vec![GeneralStage::initial(3)], ..CombinerConfig::default() };
        assert_eq!(codes(&c, &CombinerLimits::GEFORCE256), vec!["texture-unit", "texture-unit"]);
        check_ok(&c);
    }

    #[test]
    fn per_stage_constants_need_the_profile() {
        let mut c = CombinerConfig::default();
        c.general[0].constant1 = Some([0.5; 4]);
        check_ok(&c);
        assert_eq!(codes(&c, &CombinerLimits::GEFORCE256), vec!["per-stage-constant"]);
    }

    #[test]
    fn constants_are_finite() {
        let c = CombinerConfig { constant0: Some([0.0, f32::NAN, 0.0, 1.0]), ..CombinerConfig::default() };
        check(&c, "constant-not-finite");
    }

    #[test]
    fn errors_name_stage_portion_and_variable_without_a_span() {
        let mut c = CombinerConfig::default();
        c.general[0].alpha.b.usage = ComponentUsage::Rgb;
        let errors = validate(&c, &CombinerLimits::GEFORCE3).unwrap_err();
        let d = errors[0].to_diagnostic(&|_| None);
        assert_eq!(d.message, "general combiner 0, alpha portion, variable B: an alpha variable reads `alpha` or `blue`, not `rgb`");
        assert!(d.help.is_some());
    }
}
