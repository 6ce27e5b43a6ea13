//! The whole NV_register_combiners state as data (Kilgard 2000, Section 4.2 and
//! Appendix B): the register set of Table 2, the general combiner stages with
//! their RGB and alpha portions (B.4), the final combiner (B.5), the two
//! constant colours and the colour-sum clamp (Table 4), with the initial
//! state of Tables 4-6 as defaults (B.6).
//!
//! A `CombinerConfig` may hold invalid state (a dot product in an alpha
//! portion, an output written twice, ...): that is what `validate` is for.

use serde::{Deserialize, Serialize};

/// The limits a setup is validated against come from the target profile.
pub use crate::profile::CombinerLimits;

/// An RGBA colour with components nominally in [0, 1].
pub type Color = [f32; 4];

/// The register set of Kilgard 2000, Table 2 (8 + the texture units; this crate
/// models up to four units, the geforce3 maximum).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Register {
    Zero,
    Constant0,
    Constant1,
    /// RGB: the fog colour; alpha: the fog factor, final combiner only (B.4).
    Fog,
    Primary,
    Secondary,
    /// RGB undefined, alpha = texture 0 alpha initially (Section 4.2.1).
    Spare0,
    Spare1,
    Texture0,
    Texture1,
    Texture2,
    Texture3,
}

impl Register {
    /// Every register: what the register allocator and the `!!RC1.0` reader enumerate.
    pub const ALL: [Register; 12] = [
        Register::Zero,
        Register::Constant0,
        Register::Constant1,
        Register::Fog,
        Register::Primary,
        Register::Secondary,
        Register::Spare0,
        Register::Spare1,
        Register::Texture0,
        Register::Texture1,
        Register::Texture2,
        Register::Texture3,
    ];

    /// Index into a register file laid out in `Register::ALL` order.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Read/write registers of Table 2 (the rest are read-only).
    pub fn is_writable(self) -> bool {
        !matches!(self, Register::Zero | Register::Constant0 | Register::Constant1 | Register::Fog)
    }

    /// The texture unit this register holds the filtered texel of.
    pub fn texture_unit(self) -> Option<u8> {
        match self {
            Register::Texture0 => Some(0),
            Register::Texture1 => Some(1),
            Register::Texture2 => Some(2),
            Register::Texture3 => Some(3),
            _ => None,
        }
    }

    /// The register of texture unit `unit` (0 to 3, the four units of the GeForce 3; `None`
    /// past them).
    pub fn texture(unit: u8) -> Option<Register> {
        match unit {
            0 => Some(Register::Texture0),
            1 => Some(Register::Texture1),
            2 => Some(Register::Texture2),
            3 => Some(Register::Texture3),
            _ => None,
        }
    }

    /// The paper's name (`spare0`, `texture1`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Register::Zero => "zero",
            Register::Constant0 => "constant0",
            Register::Constant1 => "constant1",
            Register::Fog => "fog",
            Register::Primary => "primary",
            Register::Secondary => "secondary",
            Register::Spare0 => "spare0",
            Register::Spare1 => "spare1",
            Register::Texture0 => "texture0",
            Register::Texture1 => "texture1",
            Register::Texture2 => "texture2",
            Register::Texture3 => "texture3",
        }
    }
}

/// The eight input mappings of Kilgard 2000, Table 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputMapping {
    /// max(0, x)
    UnsignedIdentity,
    /// 1 − min(max(0, x), 1)
    UnsignedInvert,
    /// 2·max(0, x) − 1
    ExpandNormal,
    /// −2·max(0, x) + 1
    ExpandNegate,
    /// max(0, x) − ½
    HalfBiasNormal,
    /// −max(0, x) + ½
    HalfBiasNegate,
    /// x
    SignedIdentity,
    /// −x
    SignedNegate,
}

impl InputMapping {
    /// Every input mapping, for readers and exhaustive tests.
    pub const ALL: [InputMapping; 8] = [
        InputMapping::UnsignedIdentity,
        InputMapping::UnsignedInvert,
        InputMapping::ExpandNormal,
        InputMapping::ExpandNegate,
        InputMapping::HalfBiasNormal,
        InputMapping::HalfBiasNegate,
        InputMapping::SignedIdentity,
        InputMapping::SignedNegate,
    ];

    /// The mapping's name as `!!RC1.0` and the RON configurations spell it.
    pub fn name(self) -> &'static str {
        match self {
            InputMapping::UnsignedIdentity => "unsigned_identity",
            InputMapping::UnsignedInvert => "unsigned_invert",
            InputMapping::ExpandNormal => "expand_normal",
            InputMapping::ExpandNegate => "expand_negate",
            InputMapping::HalfBiasNormal => "half_bias_normal",
            InputMapping::HalfBiasNegate => "half_bias_negate",
            InputMapping::SignedIdentity => "signed_identity",
            InputMapping::SignedNegate => "signed_negate",
        }
    }

    /// Table 3 on a real number.
    pub fn apply(self, x: f32) -> f32 {
        match self {
            InputMapping::UnsignedIdentity => x.max(0.0),
            InputMapping::UnsignedInvert => 1.0 - x.clamp(0.0, 1.0),
            InputMapping::ExpandNormal => 2.0 * x.max(0.0) - 1.0,
            InputMapping::ExpandNegate => -2.0 * x.max(0.0) + 1.0,
            InputMapping::HalfBiasNormal => x.max(0.0) - 0.5,
            InputMapping::HalfBiasNegate => -x.max(0.0) + 0.5,
            InputMapping::SignedIdentity => x,
            InputMapping::SignedNegate => -x,
        }
    }
}

/// Which components of the input register a variable reads (B.4, B.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ComponentUsage {
    /// The RGB vector (RGB portion and final combiner only).
    Rgb,
    /// The alpha value (smeared to RGB in an RGB portion).
    Alpha,
    /// The blue component (alpha portion only).
    Blue,
}

/// One variable (A-D) of a general combiner portion: `glCombinerInputNV`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct GeneralInput {
    pub register: Register,
    pub mapping: InputMapping,
    pub usage: ComponentUsage,
}

impl GeneralInput {
    /// A general combiner input: `register`'s `usage` components through `mapping`
    /// (`glCombinerInputNV`).
    pub fn new(register: Register, mapping: InputMapping, usage: ComponentUsage) -> GeneralInput {
        GeneralInput { register, mapping, usage }
    }
}

/// The output scale of a general portion (B.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Scale {
    /// `GL_NONE`: scale by 1.
    One,
    Two,
    Four,
    OneHalf,
}

impl Scale {
    /// The factor the portion's output is scaled by.
    pub fn factor(self) -> f32 {
        match self {
            Scale::One => 1.0,
            Scale::Two => 2.0,
            Scale::Four => 4.0,
            Scale::OneHalf => 0.5,
        }
    }
}

/// The output bias of a general portion (B.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Bias {
    /// `GL_NONE`: bias by 0.
    Zero,
    NegativeOneHalf,
}

impl Bias {
    /// The value added to the portion's output (before the scale, Kilgard 2000, B.4).
    pub fn offset(self) -> f32 {
        match self {
            Bias::Zero => 0.0,
            Bias::NegativeOneHalf => -0.5,
        }
    }
}

/// Which portion of a general stage.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PortionKind {
    Rgb,
    Alpha,
}

impl PortionKind {
    /// The portion's name as `!!RC1.0` spells it (`rgb`, `alpha`).
    pub fn name(self) -> &'static str {
        match self {
            PortionKind::Rgb => "rgb",
            PortionKind::Alpha => "alpha",
        }
    }
}

/// The RGB or alpha portion of one general combiner stage:
/// `glCombinerInputNV` for A-D plus `glCombinerOutputNV` (B.4, Figures 8-9).
///
/// Outputs are `None` for `GL_DISCARD_NV`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct GeneralPortion {
    pub a: GeneralInput,
    pub b: GeneralInput,
    pub c: GeneralInput,
    pub d: GeneralInput,
    pub ab_output: Option<Register>,
    pub cd_output: Option<Register>,
    pub sum_output: Option<Register>,
    pub ab_dot: bool,
    pub cd_dot: bool,
    /// Mux (spare0.a < ½ → AB, else CD) instead of AB + CD.
    pub mux_sum: bool,
    pub scale: Scale,
    pub bias: Bias,
}

impl GeneralPortion {
    /// The initial state of stage `stage_idx` (Table 5 and B.6): A = primary,
    /// B = texture#, C = D = zero, all unsigned identity; AB and CD
    /// discarded, the sum written to spare0, no scale or bias.
    ///
    /// Table 5's `GL_TEXTURE#_ARB` names a texture unit per stage; this crate
    /// models four units, so stages 4-7 start with B = zero (a decision, see
    /// docs/combiners.md).
    pub fn initial(kind: PortionKind, stage_idx: usize) -> GeneralPortion {
        let usage = match kind {
            PortionKind::Rgb => ComponentUsage::Rgb,
            PortionKind::Alpha => ComponentUsage::Alpha,
        };
        let input = |register| GeneralInput::new(register, InputMapping::UnsignedIdentity, usage);
        let texture = u8::try_from(stage_idx).ok().and_then(Register::texture).unwrap_or(Register::Zero);
        GeneralPortion {
            a: input(Register::Primary),
            b: input(texture),
            c: input(Register::Zero),
            d: input(Register::Zero),
            ab_output: None,
            cd_output: None,
            sum_output: Some(Register::Spare0),
            ab_dot: false,
            cd_dot: false,
            mux_sum: false,
            scale: Scale::One,
            bias: Bias::Zero,
        }
    }

    /// A portion that computes nothing: every input zero, every output
    /// discarded (what nvparse sets up for a portion a program leaves out).
    pub fn discard_all() -> GeneralPortion {
        let zero = GeneralInput::new(Register::Zero, InputMapping::UnsignedIdentity, ComponentUsage::Alpha);
        GeneralPortion {
            a: zero,
            b: zero,
            c: zero,
            d: zero,
            ab_output: None,
            cd_output: None,
            sum_output: None,
            ab_dot: false,
            cd_dot: false,
            mux_sum: false,
            scale: Scale::One,
            bias: Bias::Zero,
        }
    }

    /// The four variables A-D with their letters, in order: what printers and validators walk.
    pub fn inputs(&self) -> [(char, &GeneralInput); 4] {
        [('A', &self.a), ('B', &self.b), ('C', &self.c), ('D', &self.d)]
    }

    /// The three outputs (AB, CD, sum) with their names and the registers they write, if any.
    pub fn outputs(&self) -> [(&'static str, Option<Register>); 3] {
        [("AB", self.ab_output), ("CD", self.cd_output), ("sum", self.sum_output)]
    }
}

/// One general combiner stage: an RGB and an alpha portion, plus the
/// per-stage constant colours of NV_register_combiners2 (geforce3), which
/// replace the global ones for this stage only.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GeneralStage {
    pub rgb: GeneralPortion,
    pub alpha: GeneralPortion,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub constant0: Option<Color>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub constant1: Option<Color>,
}

impl GeneralStage {
    /// Table 5's initial state for stage `stage_idx`.
    pub fn initial(stage_idx: usize) -> GeneralStage {
        GeneralStage {
            rgb: GeneralPortion::initial(PortionKind::Rgb, stage_idx),
            alpha: GeneralPortion::initial(PortionKind::Alpha, stage_idx),
            constant0: None,
            constant1: None,
        }
    }

    /// The RGB or the alpha portion of the stage.
    pub fn portion(&self, kind: PortionKind) -> &GeneralPortion {
        match kind {
            PortionKind::Rgb => &self.rgb,
            PortionKind::Alpha => &self.alpha,
        }
    }
}

/// What a final combiner variable reads: a register or one of the two
/// pseudo-registers of Section 4.2.3.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FinalSource {
    Register(Register),
    /// `GL_E_TIMES_F_NV`: the EF product (A-D only).
    EfProduct,
    /// `GL_SPARE0_PLUS_SECONDARY_COLOR_NV` (B-D only).
    Spare0PlusSecondary,
}

/// One variable (A-G) of the final combiner: `glFinalCombinerInputNV`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct FinalInput {
    pub source: FinalSource,
    pub mapping: InputMapping,
    pub usage: ComponentUsage,
}

impl FinalInput {
    /// A final combiner input: `source`'s `usage` components through `mapping`
    /// (`glFinalCombinerInputNV`).
    pub fn new(source: FinalSource, mapping: InputMapping, usage: ComponentUsage) -> FinalInput {
        FinalInput { source, mapping, usage }
    }

    /// A final combiner input reading `register` unchanged (unsigned identity).
    pub fn register(register: Register, usage: ComponentUsage) -> FinalInput {
        FinalInput::new(FinalSource::Register(register), InputMapping::UnsignedIdentity, usage)
    }
}

/// The final combiner (B.5, Figure 10): rgb = A·B + (1 − A)·C + D, alpha = G,
/// with the EF product and spare0+secondary pseudo-registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct FinalCombiner {
    pub a: FinalInput,
    pub b: FinalInput,
    pub c: FinalInput,
    pub d: FinalInput,
    pub e: FinalInput,
    pub f: FinalInput,
    pub g: FinalInput,
    /// `GL_COLOR_SUM_CLAMP_NV`: clamp spare0+secondary to 1 (Table 4: true).
    #[serde(default = "default_true")]
    pub color_sum_clamp: bool,
}

fn default_true() -> bool {
    true
}

impl Default for FinalCombiner {
    /// Table 6 and Table 4 (colour-sum clamp on).
    fn default() -> FinalCombiner {
        use ComponentUsage::{Alpha, Rgb};
        FinalCombiner {
            a: FinalInput::register(Register::Fog, Alpha),
            b: FinalInput::new(FinalSource::Spare0PlusSecondary, InputMapping::UnsignedIdentity, Rgb),
            c: FinalInput::register(Register::Fog, Rgb),
            d: FinalInput::register(Register::Zero, Rgb),
            e: FinalInput::register(Register::Zero, Rgb),
            f: FinalInput::register(Register::Zero, Rgb),
            g: FinalInput::register(Register::Spare0, Alpha),
            color_sum_clamp: true,
        }
    }
}

impl FinalCombiner {
    /// The seven variables A-G with their letters, in order: what printers and validators walk.
    pub fn inputs(&self) -> [(char, &FinalInput); 7] {
        [
            ('A', &self.a),
            ('B', &self.b),
            ('C', &self.c),
            ('D', &self.d),
            ('E', &self.e),
            ('F', &self.f),
            ('G', &self.g),
        ]
    }
}

/// The complete register-combiner state (Kilgard 2000, Section 4.2, Appendix B).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CombinerConfig {
    /// `GL_CONSTANT_COLOR0_NV`; `None` = not set by this config (Table 4's
    /// (0,0,0,0), or what the caller supplies, e.g. `--const0`).
    #[serde(default)]
    pub constant0: Option<Color>,
    /// `GL_CONSTANT_COLOR1_NV`, like `constant0`.
    #[serde(default)]
    pub constant1: Option<Color>,
    /// The active general stages, in order (`GL_NUM_GENERAL_COMBINERS_NV` =
    /// its length). Empty means no general combiner runs.
    pub general: Vec<GeneralStage>,
    #[serde(rename = "final")]
    pub final_combiner: FinalCombiner,
    /// The `!!TS1.0` texture-shader program that computes texture0..3 for
    /// these combiners (NV_texture_shader; `combiners::ts1`), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture_shader: Option<super::ts1::TextureShader>,
}

impl Default for CombinerConfig {
    /// The GL initial state (B.6): one general stage (Table 4) in its Table 5
    /// state, Table 6's final combiner, constants unset.
    fn default() -> CombinerConfig {
        CombinerConfig {
            constant0: None,
            constant1: None,
            general: vec![GeneralStage::initial(0)],
            final_combiner: FinalCombiner::default(),
            texture_shader: None,
        }
    }
}

impl CombinerConfig {
    /// The configuration as RON, the form `--emit combiners` writes and tests snapshot.
    pub fn to_ron(&self) -> String {
        let config = ron::ser::PrettyConfig::new().depth_limit(6).struct_names(false);
        // Serialising plain data with no maps or non-string keys cannot fail.
        ron::ser::to_string_pretty(self, config).unwrap_or_default()
    }

    /// Reads a configuration written by [`CombinerConfig::to_ron`].
    pub fn from_ron(text: &str) -> Result<CombinerConfig, ron::error::SpannedError> {
        ron::from_str(text)
    }
}
