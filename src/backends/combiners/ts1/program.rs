//! The NV_texture_shader state as data: one shader operation per texture
//! unit (at most four on the geforce3 / NV20 family), in nvparse's
//! `!!TS1.0` vocabulary (`ts1.0_grammar.y`, `ts1.0_inst.h`).
//!
//! A [`TextureShader`] may hold an inconsistent program (a dependent stage
//! reading a later stage, a `2of2` with no `1of2`): [`super::validate()`]
//! says what NV_texture_shader forbids.

use serde::{Deserialize, Serialize};

/// Texture units a texture shader program drives (NV_texture_shader on the
/// geforce3: `GL_MAX_TEXTURE_UNITS_ARB` = 4).
pub const MAX_STAGES: usize = 4;

/// How a dot-product stage maps the previous stage's unsigned RGB before the
/// dot product (`GL_RGBA_UNSIGNED_DOT_PRODUCT_MAPPING_NV`): nvparse writes
/// `texN` for unsigned identity and `expand(texN)` for expand normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DotMapping {
    UnsignedIdentity,
    ExpandNormal,
}

/// One texture coordinate test of `cull_fragment` (`GL_CULL_MODES_NV`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CullCondition {
    /// `GEQUAL_TO_ZERO`: the fragment survives where the coordinate is ≥ 0.
    GequalToZero,
    /// `LESS_THAN_ZERO`: the fragment survives where the coordinate is < 0.
    LessThanZero,
}

impl CullCondition {
    /// The condition's name as `!!TS1.0` spells it.
    pub fn name(self) -> &'static str {
        match self {
            CullCondition::GequalToZero => "GEQUAL_TO_ZERO",
            CullCondition::LessThanZero => "LESS_THAN_ZERO",
        }
    }
}

/// A family of dot-product stages: two or three consecutive units whose
/// last one (or last two) uses the dot products of all of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DotFamily {
    /// `dot_product_2d_1of2/2of2`: a 2-D lookup at (dot₀, dot₁).
    Texture2d,
    /// `dot_product_rectangle_*`: a rectangle lookup at (dot₀, dot₁) in texels.
    Rectangle,
    /// `dot_product_depth_replace_*`: depth = dot₀ / dot₁.
    DepthReplace,
    /// `dot_product_3d_*`: a 3-D lookup at (dot₀, dot₁, dot₂).
    Texture3d,
    /// `dot_product_cube_map_*`: a cube map lookup in direction (dot₀, dot₁, dot₂).
    CubeMap,
    /// `dot_product_reflect_cube_map_eye_from_qs_*`: the normal N = (dot₀,
    /// dot₁, dot₂) reflects the eye vector made of the three stages' q.
    ReflectEyeFromQs,
    /// `dot_product_reflect_cube_map_const_eye_*`: as above, a constant eye.
    ReflectConstEye,
    /// `dot_product_cube_map_and_reflect_cube_map_eye_from_qs_*`: stage 2 is
    /// `GL_DOT_PRODUCT_DIFFUSE_CUBE_MAP_NV` (a lookup in N), stage 3 reflects.
    DiffuseReflectEyeFromQs,
    /// `dot_product_cube_map_and_reflect_cube_map_const_eye_*`.
    DiffuseReflectConstEye,
}

impl DotFamily {
    /// Every dot-product family of NV_texture_shader, for readers and exhaustive tests.
    pub const ALL: [DotFamily; 9] = [
        DotFamily::Texture2d,
        DotFamily::Rectangle,
        DotFamily::DepthReplace,
        DotFamily::Texture3d,
        DotFamily::CubeMap,
        DotFamily::ReflectEyeFromQs,
        DotFamily::ReflectConstEye,
        DotFamily::DiffuseReflectEyeFromQs,
        DotFamily::DiffuseReflectConstEye,
    ];

    /// nvparse's name between `dot_product_` and `_KofN`.
    pub fn stem(self) -> &'static str {
        match self {
            DotFamily::Texture2d => "2d",
            DotFamily::Rectangle => "rectangle",
            DotFamily::DepthReplace => "depth_replace",
            DotFamily::Texture3d => "3d",
            DotFamily::CubeMap => "cube_map",
            DotFamily::ReflectEyeFromQs => "reflect_cube_map_eye_from_qs",
            DotFamily::ReflectConstEye => "reflect_cube_map_const_eye",
            DotFamily::DiffuseReflectEyeFromQs => "cube_map_and_reflect_cube_map_eye_from_qs",
            DotFamily::DiffuseReflectConstEye => "cube_map_and_reflect_cube_map_const_eye",
        }
    }

    /// How many consecutive stages the family takes.
    pub fn stages(self) -> u8 {
        match self {
            DotFamily::Texture2d | DotFamily::Rectangle | DotFamily::DepthReplace => 2,
            _ => 3,
        }
    }

    /// The const-eye families take the eye vector in their first stage.
    pub fn has_const_eye(self) -> bool {
        matches!(self, DotFamily::ReflectConstEye | DotFamily::DiffuseReflectConstEye)
    }

    /// Whether stage `step` (0-based) of the family writes an RGBA result
    /// (`noOutput` in nvparse's `ts1.0_inst.h`): the last stage, and the
    /// diffuse cube map's middle stage.
    pub fn has_output(self, step: u8) -> bool {
        step + 1 == self.stages()
            || (step == 1
                && matches!(self, DotFamily::DiffuseReflectEyeFromQs | DotFamily::DiffuseReflectConstEye))
    }
}

/// One texture unit's shader operation (`GL_SHADER_OPERATION_NV`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Operation {
    /// `nop()`: `GL_NONE`, RGBA = (0, 0, 0, 0).
    Nop,
    Texture1d,
    Texture2d,
    TextureRectangle,
    Texture3d,
    TextureCubeMap,
    /// `cull_fragment(c_s, c_t, c_r, c_q)`: RGBA = 0; the fragment is
    /// discarded unless every coordinate passes its test.
    CullFragment([CullCondition; 4]),
    /// `pass_through()`: RGBA = the coordinates (s, t, r, q) clamped to [0, 1].
    PassThrough,
    /// `offset_2d(texN, m₀, m₁, m₂, m₃)` and its `_scale` and `_rectangle`
    /// forms: a lookup at (s + m₀·ds + m₂·dt, t + m₁·ds + m₃·dt), with
    /// (ds, dt) the previous stage's signed DSDT texel; `scale` = (scale,
    /// bias) multiplies RGB by clamp(scale·mag + bias, 0, 1).
    Offset {
        rectangle: bool,
        previous: u8,
        matrix: [f32; 4],
        scale: Option<(f32, f32)>,
    },
    /// `dependent_ar(texN)` / `dependent_gb(texN)`: a 2-D lookup at the
    /// previous stage's (alpha, red) or (green, blue).
    Dependent {
        green_blue: bool,
        previous: u8,
    },
    /// One stage of a dot-product family: dot((s, t, r), mapped RGB of the
    /// previous stage); `step` is 0-based; `eye` only on step 0 of a
    /// const-eye family.
    DotProduct {
        family: DotFamily,
        step: u8,
        previous: u8,
        mapping: DotMapping,
        eye: Option<[f32; 3]>,
    },
}

impl Operation {
    /// nvparse's instruction name.
    pub fn name(&self) -> String {
        match self {
            Operation::Nop => "nop".into(),
            Operation::Texture1d => "texture_1d".into(),
            Operation::Texture2d => "texture_2d".into(),
            Operation::TextureRectangle => "texture_rectangle".into(),
            Operation::Texture3d => "texture_3d".into(),
            Operation::TextureCubeMap => "texture_cube_map".into(),
            Operation::CullFragment(_) => "cull_fragment".into(),
            Operation::PassThrough => "pass_through".into(),
            Operation::Offset { rectangle, scale, .. } => {
                let base = if *rectangle { "offset_rectangle" } else { "offset_2d" };
                if scale.is_some() {
                    format!("{base}_scale")
                } else {
                    base.into()
                }
            }
            Operation::Dependent { green_blue, .. } => {
                if *green_blue { "dependent_gb" } else { "dependent_ar" }.into()
            }
            Operation::DotProduct { family, step, .. } => {
                format!("dot_product_{}_{}of{}", family.stem(), step + 1, family.stages())
            }
        }
    }

    /// The earlier stage this one reads, if it is a dependent operation.
    pub fn previous(&self) -> Option<u8> {
        match *self {
            Operation::Offset { previous, .. }
            | Operation::Dependent { previous, .. }
            | Operation::DotProduct { previous, .. } => Some(previous),
            _ => None,
        }
    }

    /// Whether the stage writes an RGBA result a later stage (or the
    /// combiners) can read.
    pub fn has_output(&self) -> bool {
        match *self {
            Operation::Nop | Operation::CullFragment(_) => false,
            Operation::DotProduct { family, step, .. } => family.has_output(step),
            _ => true,
        }
    }
}

/// A `!!TS1.0` program: the operations of texture units 0, 1, … in order.
/// Units past the end run `nop` (as nvparse's `InstList::Validate` sets).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TextureShader {
    pub stages: Vec<Operation>,
}

impl TextureShader {
    /// The operation of unit `unit` (`nop` past the program's end).
    pub fn stage(&self, unit: usize) -> Operation {
        self.stages.get(unit).copied().unwrap_or(Operation::Nop)
    }
}
