//! The pass plan as data: what `shadec::compile` returns and
//! `shadec compile --emit plan` writes (RON or JSON). The schema is
//! documented in `docs/pass-plan.md`; a plan serializes and loads back
//! identical (tested).
//!
//! A plan is self-describing: every IR value a pass uses is listed once in
//! `values` (id = the IR handle's index, readable operation text, type,
//! frequency, range and source position), and passes refer to values by id.

use serde::{Deserialize, Serialize};

use super::RenderState;

/// The plan of a whole program on one target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassPlan {
    /// The profile the plan is for (`geforce256`, `geforce3`, `multitexture`, `wgsl`, or a file's).
    pub target: String,
    /// Rendering passes in the order they run.
    pub passes: Vec<Pass>,
    /// What specialization removed, and why.
    pub removed: Vec<Removed>,
    /// Every IR value the passes refer to, in topological order.
    pub values: Vec<Value>,
    /// What the lowering replaced by what the target has
    /// (docs/lowering.md): empty when the program planned as written.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub approximations: Vec<Approximation>,
    /// The frame time the target's cost model predicts
    /// (docs/cost-model.md); `None` on a target with no cost model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted: Option<FramePrediction>,
    /// The approximations' error measured on a scene, when `--max-error`
    /// chose among the lowerings by it (`accuracy::choose`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub measured: Option<MeasuredError>,
}

/// A lowered plan's render (f32, or the precision it is drawn in) against
/// the f32 render of the program's meaning on a scene: what its approximations cost in accuracy.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeasuredError {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    /// Largest difference of a colour channel, in [0, 1].
    pub max_abs: f64,
    pub rmse: f64,
    /// The arithmetic the plan was rendered in, where not f32 (`render
    /// --precision fixed9`, `exact`); the meaning is rendered in f32.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub precision: Option<crate::numerics::Precision>,
}

/// A plan's predicted frame time on its target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FramePrediction {
    /// What was assumed drawn: a scene, or GeForce3 Phong, Section 5.4's
    /// screen-filling mesh when no scene was given.
    pub workload: String,
    /// The whole frame (µs): clearing, then every pass.
    pub total_us: f64,
    /// Clearing colour and depth (µs).
    pub clear_us: f64,
}

impl FramePrediction {
    /// `predicted on geforce3: 2.356 ms a frame (…)`.
    pub fn line(&self, target: &str) -> String {
        format!(
            "predicted on {target}: {:.3} ms a frame ({:.3} ms clearing), drawing {} (cost model, docs/cost-model.md)",
            self.total_us / 1000.0,
            self.clear_us / 1000.0,
            self.workload
        )
    }
}

/// A pass's predicted time on its target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassPrediction {
    /// The pass (µs): its slowest stage, its overhead, any copy.
    pub us: f64,
    /// What limits it: `vertex`, `setup`, `fill`, `memory`, or `compiler`
    /// (a `bake` table, computed at compile time).
    pub bound: String,
    /// Pixel clocks per fragment: texture trips, then combiner stages.
    pub clocks_per_pixel: f64,
    /// Fragments rasterized.
    pub pixels: u64,
}

/// One rendering pass.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pass {
    /// Which source statements this pass implements (0-based, in source
    /// order); several when statements were fused, one statement may need
    /// several passes when it was split.
    pub statements: Vec<usize>,
    /// For a program written for light 0 on a scene with lights: the light
    /// this pass adds (one pass per light, docs/pass-plan.md).
    #[serde(default)]
    pub light: Option<u32>,
    /// The objects (indices into the scene's `objects`) this pass is drawn
    /// for, when light culling skipped it for the others; `None`: all.
    #[serde(default)]
    pub objects: Option<Vec<usize>>,
    /// Drawn object by object with the adjacent passes of the same group
    /// ([`PassPlan::draws`]): every pass of the group for the scene's first
    /// object, then every pass for the next. The passes a statement in
    /// texture space (`T δu ← …` over a mesh) was split into: no depth test
    /// orders their texels, and objects whose parameterizations overlap
    /// each leave their whole value, the last drawn winning, as the
    /// statement drawn once per object does. `None`: drawn over every
    /// object before the next pass.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_major: Option<u32>,
    /// `line:col` of the first statement (text for people: executors read
    /// the typed span of `Planned::setups`).
    pub at: String,
    /// Why this pass exists: the statement it implements, the limit that
    /// forced a split, or the fusion that made it.
    pub reason: String,
    pub target: RenderTarget,
    /// What is rasterized.
    pub geometry: Geometry,
    pub vertex: VertexWork,
    /// Texture unit `i` is `textures[i]`.
    pub textures: Vec<TextureBinding>,
    pub fragment: FragmentWork,
    /// How the fragment colour meets the target, in the paper's terms
    /// (`replace`, `add`, `modulate`, `dst_alpha_add`, …).
    pub blend: BlendMode,
    /// Cull, depth, stencil and GL blend factors, as the renderers take them.
    pub state: RenderState,
    /// The texel pass of a `bake(f)` table: computed by the compiler on the
    /// CPU at compile time (in float, stored in the texture's format), not
    /// by the target, which only samples the table. Its fragment
    /// work is therefore not held to the target's limits.
    #[serde(default)]
    pub baked: bool,
    /// The time the target's cost model predicts for this pass.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted: Option<PassPrediction>,
}

/// Where a pass writes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum RenderTarget {
    /// A declared framebuffer; `channels` are the ones written (`rgba`, `a`, `stencil`).
    Framebuffer { name: String, channels: String },
    /// A declared texture rendered into (texture shading, deferred shading).
    Texture { name: String },
    /// A screen-sized texture the planner introduced to hold an
    /// intermediate value (render-to-texture split).
    Temporary { name: String },
}

/// What a pass rasterizes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Geometry {
    /// The scene's meshes, projected by `projection` (`π`, `πl`, `π*`).
    Mesh { projection: String },
    /// One full-screen rectangle (a screen pass, `C xs ←`).
    Screen,
    /// The texel grid of a texture (texture shading, `T δu ←`).
    Texels,
}

/// Per-vertex work: the values the vertex stage computes and the rasterizer
/// interpolates (δ), and the texture-coordinate sets generated per vertex.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VertexWork {
    /// The clip-space position (`π x`), when geometry is a mesh.
    pub position: Option<u32>,
    /// `Interpolate` values the fragment stage reads.
    pub interpolants: Vec<u32>,
    /// Texgen statements (`u x ← …`, Pipeline Grammar, eq. (7)) this pass evaluates per vertex.
    pub texgen: Vec<String>,
}

/// A texture bound to a unit of the pass, with the lookup that reads it and its coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TextureBinding {
    pub unit: u32,
    /// The declared texture's name, or a temporary's.
    pub texture: String,
    /// The lookup node and its coordinates.
    pub lookup: u32,
    pub coords: u32,
}

/// What a pass's fragment stage computes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FragmentWork {
    /// The colour the fragment stage outputs (before blending).
    pub output: u32,
    /// Per-sample operations (nodes) the stage evaluates.
    pub operations: usize,
    /// Discard the fragment where this value is zero (`c ? a` with no `:`,
    /// Pipeline Grammar, Section 3.5), when the condition is not a stencil test.
    pub condition: Option<u32>,
    /// On a register-combiner target: the general combiner stages the code
    /// generator's setup for this pass uses (what the cost model charges).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub general_combiners: Option<u32>,
    /// The depth each fragment takes in place of its interpolated one,
    /// before the depth test (NV_texture_shader's
    /// `DOT_PRODUCT_DEPTH_REPLACE_NV`; WGSL's `frag_depth`): the shadow
    /// mask's redraw on a GeForce3 (docs/shadow-maps.md).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub depth: Option<u32>,
}

/// The framebuffer operation of a pass (Pipeline Grammar, eq. (9): `C ← C ⊕ …`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum BlendMode {
    /// `C ← f` (glBlendFunc(GL_ONE, GL_ZERO)).
    Replace,
    /// `C ← C + f` (GL_ONE, GL_ONE).
    Add,
    /// `C ← C · f` (GL_DST_COLOR, GL_ZERO).
    Modulate,
    /// `C ← C − f` (GL_ONE, GL_ONE, GL_FUNC_REVERSE_SUBTRACT; EXT_blend_subtract,
    /// which the GeForce 256 and GeForce3 have): a term below zero, taken
    /// off in the blender, where an addition would have its source clamped to 0.
    ReverseSubtract,
    /// `C ← 2·C·f` (GL_DST_COLOR, GL_SRC_COLOR: `f·C + C·f`): a modulation
    /// by a factor in [0, 2], written with its source halved into [0, 1],
    /// where GL clamps it (§4.1.8) — the multipass "2× modulate".
    Modulate2x,
    /// `C ← C + Cα · f` (GL_DST_ALPHA, GL_ONE): Kilgard 2000, Section 5.5.
    DstAlphaAdd,
    /// `C ← Cα · f` (GL_DST_ALPHA, GL_ZERO).
    DstAlphaModulate,
    /// `C ← fα · f + (1 − fα) · C` (GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA): decal.
    AlphaBlend,
    /// `C ← Cα · C + (1 − Cα) · f` (GL_ONE_MINUS_DST_ALPHA, GL_DST_ALPHA):
    /// a mask kept in destination alpha chooses between C and f (the
    /// shadow-mask compositing pass).
    DstAlphaMix,
    /// `C ← Cα · f + (1 − Cα) · C` (GL_DST_ALPHA, GL_ONE_MINUS_DST_ALPHA):
    /// the same choice the other way round, f where the mask is set.
    DstAlphaLerp,
    /// `C ← max(C, f)` (GL_MAX, EXT_blend_minmax, factors ignored; the GL
    /// 1.2 imaging subset, which the GeForce 256 and GeForce3 have): a
    /// `max` of more terms than a pass computes, one pass per group. On an
    /// 8-bit framebuffer it is exact: max of values clamped to [0, 1] is
    /// the clamp of their max.
    Max,
    /// `C ← min(C, f)` (GL_MIN, EXT_blend_minmax), as [`BlendMode::Max`].
    Min,
}

impl BlendMode {
    /// The blend state of the mode: how the pass's colour meets the framebuffer's.
    pub fn render_state(self) -> super::BlendState {
        use super::BlendState as B;
        match self {
            BlendMode::Replace => B::REPLACE,
            BlendMode::Add => B::ADD,
            BlendMode::Modulate => B::MODULATE,
            BlendMode::ReverseSubtract => B { equation: super::BlendEquation::ReverseSubtract, ..B::ADD },
            BlendMode::Modulate2x => B::factors(super::BlendFactor::DstColor, super::BlendFactor::SrcColor),
            BlendMode::DstAlphaAdd => B::DEST_ALPHA_ADD,
            BlendMode::DstAlphaModulate => B::DEST_ALPHA_MODULATE,
            BlendMode::AlphaBlend => B::ALPHA_BLEND,
            BlendMode::DstAlphaMix => {
                B::factors(super::BlendFactor::OneMinusDstAlpha, super::BlendFactor::DstAlpha)
            }
            BlendMode::DstAlphaLerp => {
                B::factors(super::BlendFactor::DstAlpha, super::BlendFactor::OneMinusDstAlpha)
            }
            BlendMode::Max => B { equation: super::BlendEquation::Max, ..B::ADD },
            BlendMode::Min => B { equation: super::BlendEquation::Min, ..B::ADD },
        }
    }

    /// The mode's name as plans and reports spell it.
    pub fn name(self) -> &'static str {
        match self {
            BlendMode::Replace => "replace",
            BlendMode::Add => "add",
            BlendMode::Modulate => "modulate",
            BlendMode::ReverseSubtract => "reverse_subtract",
            BlendMode::Modulate2x => "modulate_2x",
            BlendMode::DstAlphaAdd => "dst_alpha_add",
            BlendMode::DstAlphaModulate => "dst_alpha_modulate",
            BlendMode::AlphaBlend => "alpha_blend",
            BlendMode::DstAlphaMix => "dst_alpha_mix",
            BlendMode::DstAlphaLerp => "dst_alpha_lerp",
            BlendMode::Max => "max",
            BlendMode::Min => "min",
        }
    }
}

/// One IR value as the plan document shows it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Value {
    pub id: u32,
    /// The operation, operands as `%id` (the `--emit ir` notation).
    pub op: String,
    pub ty: String,
    pub freq: String,
    pub range: String,
    /// `line:col` in the source, or `-` for values the planner built.
    pub at: String,
}

/// One rewrite of the lowering: a part of the program the
/// target cannot compute, replaced by what it has — a table, a cube map,
/// a per-vertex value — with what that costs and how far it may be off.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Approximation {
    /// The rule's name (`normalization_cube_map`, `per_vertex`, `baked_table`, …).
    pub rule: String,
    /// `line:col` of the replaced operation: [`Approximation::span`] as text.
    pub at: String,
    /// The replaced operation's span: what diagnostics and the language
    /// server place by (the document's `at` is its text, never read back).
    #[serde(skip)]
    pub span: crate::span::Span,
    /// What was replaced, by what, and why the target needed it.
    pub why: String,
    pub cost: ApproximationCost,
    /// The rule's own bound on the absolute error of the replaced value
    /// (per component), when it has one; `None` when only a scene can
    /// say (a per-vertex approximation depends on the triangles).
    pub error_bound: Option<f64>,
    /// What that error can become at the program's output (per channel):
    /// the site bound times the output's sensitivity to the replaced value
    /// (`lowering::sensitivity`) — `x¹⁶` multiplies an error of `x` by up
    /// to 16. `None` when either is unknown (a coordinate, a condition).
    #[serde(default)]
    pub output_bound: Option<f64>,
}

/// Equal as documents: `span` is the contract's, never written, so a plan
/// read back from its text equals the plan written.
impl PartialEq for Approximation {
    fn eq(&self, other: &Self) -> bool {
        self.rule == other.rule
            && self.at == other.at
            && self.why == other.why
            && self.cost == other.cost
            && self.error_bound == other.error_bound
            && self.output_bound == other.output_bound
    }
}

/// What an approximation spends (the four resources).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ApproximationCost {
    /// Texture units a pass that uses the replacement needs for it.
    pub texture_units: u32,
    /// Passes it adds on the target (a baked table's texel pass runs on
    /// the compiler, not the target: 0).
    pub passes: u32,
    /// General combiner stages it needs (an estimate: one per operation).
    pub general_combiners: u32,
    /// Texels of the tables it adds.
    pub texels: u64,
}

/// Something specialization removed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Removed {
    /// `uniform`, `term`, `texture`, `pass`, `light` (a light culled for an
    /// object), `note` (why a statement was not replicated per light).
    pub kind: String,
    pub what: String,
    pub why: String,
    pub at: String,
}

impl PassPlan {
    /// The plan as RON (`--emit plan`).
    #[allow(clippy::expect_used, reason = "a plan is strings, numbers and lists: RON writes every one")]
    pub fn to_ron(&self) -> String {
        ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default().struct_names(true))
            .expect("a pass plan serializes")
    }

    /// The plan as JSON (`--plan-format json`).
    #[allow(clippy::expect_used, reason = "a plan has string keys and finite numbers: JSON writes it")]
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a pass plan serializes")
    }

    /// Reads a plan written as RON (a document derived from `Planned`, for people and tests,
    /// never planned from).
    pub fn from_ron(text: &str) -> Result<PassPlan, String> {
        ron::from_str(text).map_err(|e| e.to_string())
    }

    /// Reads a plan written as JSON (see [`PassPlan::from_ron`]).
    pub fn from_json(text: &str) -> Result<PassPlan, String> {
        serde_json::from_str(text).map_err(|e| e.to_string())
    }

    /// Total texture fetches per covered pixel over all passes.
    pub fn fetches(&self) -> usize {
        self.passes.iter().map(|p| p.textures.len()).sum()
    }

    /// One line per pass: what a person reads first.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} pass{} on {}\n",
            self.passes.len(),
            if self.passes.len() == 1 { "" } else { "es" },
            self.target
        );
        for (i, p) in self.passes.iter().enumerate() {
            let target = match &p.target {
                RenderTarget::Framebuffer { name, channels } => format!("{name}.{channels}"),
                RenderTarget::Texture { name } | RenderTarget::Temporary { name } => name.clone(),
            };
            let units: Vec<&str> = p.textures.iter().map(|t| t.texture.as_str()).collect();
            s += &format!(
                "  pass {}: {target} ← {} [{}]  — {}{}\n",
                i + 1,
                p.blend.name(),
                if units.is_empty() { "no textures".to_string() } else { units.join(", ") },
                p.reason,
                p.predicted.as_ref().map_or(String::new(), |t| format!(
                    " (predicted {:.3} ms, {}-bound, {:.2} clocks a pixel)",
                    t.us / 1000.0,
                    t.bound,
                    t.clocks_per_pixel
                ))
            );
        }
        for a in &self.approximations {
            s += &format!("  approximation {} at {}: {}\n", a.rule, a.at, a.why);
        }
        if let Some(f) = &self.predicted {
            s += &format!("  {}\n", f.line(&self.target));
        }
        s
    }
}
