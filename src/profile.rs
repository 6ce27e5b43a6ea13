//! Target profiles as data: the resources of a GPU generation (texture
//! units, register combiners, texture shaders, formats), read from RON —
//! the built-in ones are `profiles/*.ron`, embedded in the binary — and the
//! check of a lowered program against them.
//!
//! **Policy**: a statement is one pass until the planner splits
//! it. A *capacity* overflow (texture units, constant colours, interpolants)
//! is a warning — "does not fit in one pass on geforce256: needs 3 texture
//! units; it has 2; the pass planner will split it" — whether or not the
//! program names the target, because framebuffer blending and
//! render-to-texture can split such a statement. A *missing capability*
//! (dependent lookups without texture shaders, cube maps, signed or float
//! textures, per-fragment arithmetic on the fixed texture environment,
//! vertex texture fetch) is an error: no split makes the hardware do it.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::diag::Diagnostic;
use crate::ir::{Expr, Handle, Module, Statement, Usage};

/// The register combiners a target profile has (Kilgard 2000, Section 4.2.2:
/// GeForce has two general stages, later GPUs more; NV_register_combiners2
/// adds per-stage constants): the profile's `fragment: Combiners((…))`
/// section, and the limits the combiner code generator, validator and
/// emulator work under — one statement of the machine, read from the
/// profile. The constants equal the built-in profiles' sections (a unit
/// test keeps them so).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CombinerLimits {
    /// General combiner stages.
    pub general_combiners: usize,
    /// Constant colours (constant0/1) visible to a stage.
    pub constant_colors: u32,
    /// Whether each stage has its own constant colours (NV_register_combiners2).
    pub per_stage_constants: bool,
    /// Dot products in the alpha portion (`spare0.a = tex0.b . tex1.b;`):
    /// NV_register_combiners forbids them and nvparse refuses them, but
    /// NV2A (the Xbox GPU) runs them, as the product of the two alpha inputs
    /// (a one-component dot product). Off in every built-in profile; the
    /// emulator's and `translate`'s `--permissive` turn it on.
    #[serde(default, skip_serializing_if = "is_false")]
    pub alpha_dot_products: bool,
    /// Texture units, hence `texture0..` registers (Table 2: 8 + units):
    /// the profile's own `texture_units`, not stated twice in its RON, set
    /// when the profile is read ([`Profile::from_ron`]).
    #[serde(skip)]
    pub texture_units: u8,
}

/// The profile's combiner section is the combiner limits.
pub type Combiners = CombinerLimits;

fn is_false(b: &bool) -> bool {
    !*b
}

impl CombinerLimits {
    /// GeForce 256 / Quadro: two general combiners, two texture units.
    pub const GEFORCE256: CombinerLimits = CombinerLimits {
        general_combiners: 2,
        constant_colors: 2,
        per_stage_constants: false,
        texture_units: 2,
        alpha_dot_products: false,
    };
    /// GeForce3: eight general combiners, per-stage constants, four units.
    pub const GEFORCE3: CombinerLimits = CombinerLimits {
        general_combiners: 8,
        constant_colors: 2,
        per_stage_constants: true,
        texture_units: 4,
        alpha_dot_products: false,
    };

    /// These limits with NV2A's dot products in the alpha portion allowed.
    pub const fn permissive(self) -> CombinerLimits {
        CombinerLimits { alpha_dot_products: true, ..self }
    }
}

/// The names of the built-in profiles.
pub const BUILTIN: &[&str] = &["geforce256", "geforce3", "multitexture", "wgsl"];

/// A target profile: what one GPU generation offers a pass (see the module doc).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Profile {
    /// The profile's name (`geforce3`), as `target` and `--target` write it.
    pub name: String,
    /// One line for humans.
    pub description: String,
    /// Textures one pass can sample (texture units, or WGSL sampled textures).
    pub texture_units: u32,
    /// Interpolated values a pass can carry (texture coordinate sets and colours).
    pub interpolants: u32,
    /// What computes fragments.
    pub fragment: FragmentStage,
    /// NV_texture_shader-style lookups, if any.
    pub texture_shaders: Option<TextureShaders>,
    /// The ⊕ modes the texture environment offers.
    pub texture_env_modes: Vec<String>,
    /// Cube-map textures.
    pub cube_maps: bool,
    /// 3-D textures.
    pub textures_3d: bool,
    /// Signed texture formats (HILO, signed8).
    pub signed_textures: bool,
    /// Float texture formats.
    pub float_textures: bool,
    /// Texture lookups in the vertex stage.
    pub vertex_texture_fetch: bool,
    /// Bits per texture channel.
    pub texture_bits: u8,
    /// Bits per framebuffer channel.
    pub framebuffer_bits: u8,
    /// ⊕ modes framebuffer blending can do (`C δπx ← (C δπx) ⊕ …`).
    pub blend_modes: Vec<String>,
    /// One stencil state per face (EXT_stencil_two_side on GeForce FX,
    /// WebGPU's per-face stencil): a shadow volume's count by facing in one
    /// pass (Everitt and Kilgard 2002). GeForce 256 and GeForce3 had one
    /// state for both faces: two passes.
    #[serde(default)]
    pub two_sided_stencil: bool,
    /// NV_vertex_program (NVIDIA 2001; Lindholm, Kilgard and Moreton
    /// 2001): the per-vertex part of a pass runs on the card as a `!!VP1.0`
    /// program (GeForce3). Without it (GeForce 256, fixed-function
    /// transform and lighting) the host computes what a pass needs per
    /// vertex. See docs/vertex-programs.md.
    #[serde(default)]
    pub vertex_programs: bool,
    /// Depth textures with the hardware's comparison (SGIX_depth_texture,
    /// SGIX_shadow / ARB_shadow: 24-bit depth, `r ≤ texel` → 0 or 1 per
    /// sample; Williams 1978's shadow map as Pipeline Grammar, Section 3.5
    /// writes it). GeForce3 had them; GeForce 256 did not.
    #[serde(default)]
    pub depth_textures: bool,
    /// How fast the target runs a pass (`docs/cost-model.md`):
    /// `None` for a profile with no timing model (`wgsl`, `multitexture`),
    /// whose plans get no predicted time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost: Option<CostModel>,
}

impl CostModel {
    /// Why these parameters cannot predict a time (a rate of zero, a
    /// negative or non-finite number), if they cannot.
    pub fn problem(&self) -> Option<String> {
        let positive = [
            ("clock_mhz", self.clock_mhz),
            ("memory_gb_per_s", self.memory_gb_per_s),
            ("pixel_pipes", f64::from(self.pixel_pipes)),
            ("samples_per_clock", f64::from(self.samples_per_clock)),
        ];
        let non_negative = [
            ("clocks_per_general_combiner", self.clocks_per_general_combiner),
            ("vertex_clocks_per_op", self.vertex_clocks_per_op),
            ("setup_clocks_per_triangle", self.setup_clocks_per_triangle),
            ("depth_bytes_per_pixel", self.depth_bytes_per_pixel),
            ("texel_bytes_per_sample", self.texel_bytes_per_sample),
            ("clear_bytes_per_pixel", self.clear_bytes_per_pixel),
            ("pass_overhead_us", self.pass_overhead_us),
        ];
        let bad = positive
            .iter()
            .find(|(_, v)| !(v.is_finite() && *v > 0.0))
            .map(|(name, v)| format!("cost.{name} is {v}; it must be a positive number"))
            .or_else(|| {
                non_negative
                    .iter()
                    .find(|(_, v)| !(v.is_finite() && *v >= 0.0))
                    .map(|(name, v)| format!("cost.{name} is {v}; it must be zero or a positive number"))
            });
        bad.map(|b| format!("{b} (docs/cost-model.md gives each parameter's meaning)"))
    }
}

/// The parameters of the cost model: what a pass costs on the
/// target, as a bottleneck of vertex work, triangle setup and fill
/// (`crate::cost`). Every number's source is in `docs/cost-model.md`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CostModel {
    /// Core clock.
    pub clock_mhz: f64,
    /// Pixel pipelines: pixels started per clock.
    pub pixel_pipes: u32,
    /// Bilinear texture samples one pipe fetches per clock (its texture
    /// units); a pixel needing more loops back (GeForce3: 3–4 textures take
    /// two clocks).
    pub samples_per_clock: u32,
    /// Clocks a general combiner stage adds to a pixel's trip through a
    /// pipe (fractional: the stages are pipelined).
    pub clocks_per_general_combiner: f64,
    /// Vertex work: clocks per vertex-program instruction (or fixed-function
    /// T&L operation) of one vertex.
    pub vertex_clocks_per_op: f64,
    /// Clocks of triangle setup per triangle.
    pub setup_clocks_per_triangle: f64,
    /// Memory bandwidth (GB/s): the fill of a pass is at least its bytes
    /// over this.
    pub memory_gb_per_s: f64,
    /// Depth bytes per depth-tested pixel (read and write, after any
    /// depth compression).
    pub depth_bytes_per_pixel: f64,
    /// Memory bytes per texture sample after the texture cache.
    pub texel_bytes_per_sample: f64,
    /// Memory bytes per pixel of clearing the frame (colour, and depth
    /// unless the target clears it by its compression tags).
    pub clear_bytes_per_pixel: f64,
    /// Fixed cost of a pass: state changes and the pipeline's drain (µs).
    pub pass_overhead_us: f64,
}

/// What computes fragments on the target.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum FragmentStage {
    /// OpenGL 1.2.1 texture environment: one ⊕ per unit, nothing else.
    TextureEnv,
    /// NVIDIA register combiners (Kilgard 2000, Section 4.2).
    Combiners(Combiners),
    /// A programmable fragment stage (WGSL).
    Programmable,
}

/// The NV_texture_shader stages a target has (Kilgard 2000, Section 4.3).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TextureShaders {
    /// Offset (EMBM) lookups, Pipeline Grammar, eq. (8).
    pub offset_2d: bool,
    /// Dot-product texture addressing (a dependent lookup by `N·x`).
    pub dot_product: bool,
    /// Lookups indexed by an earlier stage's result.
    pub dependent_lookups: bool,
}

/// Why a profile could not be had: an unknown name, an unreadable or invalid file.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error("unknown target profile `{name}` (the built-in profiles are: {})", BUILTIN.join(", "))]
    Unknown { name: String },
    #[error("{path}: cannot read the profile: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: not a valid profile: {message}")]
    Parse { path: String, message: String },
}

impl Profile {
    /// Whether a texture can be indexed by another's result: texture
    /// shaders' dependent stages or EMBM's offset (Kilgard 2000, Section 4.3).
    pub fn has_dependent_lookups(&self) -> bool {
        self.texture_shaders.as_ref().is_some_and(|t| t.dependent_lookups || t.offset_2d)
    }

    /// A built-in profile by name.
    pub fn builtin(name: &str) -> Result<Profile, ProfileError> {
        let text = match name {
            "geforce256" => include_str!("../profiles/geforce256.ron"),
            "geforce3" => include_str!("../profiles/geforce3.ron"),
            "multitexture" => include_str!("../profiles/multitexture.ron"),
            "wgsl" => include_str!("../profiles/wgsl.ron"),
            _ => return Err(ProfileError::Unknown { name: name.to_string() }),
        };
        Profile::from_ron(text, &format!("<builtin {name}>"))
    }

    /// A profile from a RON file.
    pub fn load(path: &Path) -> Result<Profile, ProfileError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| ProfileError::Io { path: path.display().to_string(), source })?;
        Profile::from_ron(&text, &path.display().to_string())
    }

    /// A built-in name, or else a path to a `.ron` file.
    pub fn resolve(name_or_path: &str) -> Result<Profile, ProfileError> {
        if BUILTIN.contains(&name_or_path) {
            return Profile::builtin(name_or_path);
        }
        let path = Path::new(name_or_path);
        if path.extension().is_some_and(|e| e == "ron") || path.exists() {
            return Profile::load(path);
        }
        Err(ProfileError::Unknown { name: name_or_path.to_string() })
    }

    /// A profile from RON `text` (`path` names it in errors); the combiner
    /// section's texture units are the profile's.
    pub fn from_ron(text: &str, path: &str) -> Result<Profile, ProfileError> {
        let mut profile: Profile = ron::from_str(text)
            .map_err(|e| ProfileError::Parse { path: path.to_string(), message: e.to_string() })?;
        if let FragmentStage::Combiners(c) = &mut profile.fragment {
            c.texture_units = u8::try_from(profile.texture_units).unwrap_or(u8::MAX);
        }
        if let Some(message) = profile.cost.as_ref().and_then(CostModel::problem) {
            return Err(ProfileError::Parse { path: path.to_string(), message });
        }
        Ok(profile)
    }

    /// The profile as RON, as `from_ron` reads it.
    #[allow(clippy::expect_used)] // strings, numbers, bools and enums always serialize to RON
    pub fn to_ron(&self) -> String {
        ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default()).expect("a profile serializes")
    }

    /// The combiner machine's limits, for the combiners backend.
    pub fn combiner_limits(&self) -> Option<CombinerLimits> {
        match &self.fragment {
            FragmentStage::Combiners(c) => Some(CombinerLimits {
                texture_units: u8::try_from(self.texture_units).unwrap_or(u8::MAX),
                ..*c
            }),
            _ => None,
        }
    }

    /// Constant registers one pass offers.
    pub fn constant_registers(&self) -> Option<u32> {
        match &self.fragment {
            FragmentStage::Combiners(c) if c.per_stage_constants => {
                Some(c.constant_colors * (c.general_combiners as u32 + 1))
            }
            FragmentStage::Combiners(c) => Some(c.constant_colors),
            // The texture environment has one constant colour (GL_TEXTURE_ENV_COLOR) per unit.
            FragmentStage::TextureEnv => Some(self.texture_units),
            FragmentStage::Programmable => None,
        }
    }
}

/// Checks every statement of `module` against `profile` (see the policy in
/// the module doc). Diagnostics point at the statement, with a secondary
/// label at each node that needs the resource.
pub fn fit(module: &Module, profile: &Profile) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    // A `bake` table is the compiler's work: the target only samples it.
    for st in module.statements.iter().filter(|st| !module.is_baked(st)) {
        let u = Usage::of(module, st);
        capacity(module, profile, st, &u, &mut out);
        capabilities(module, profile, st, &u, &mut out);
    }
    out.sort_by_key(|d| (d.primary.span.start, d.severity));
    // One read shared by two statements (equal nodes are one node, with
    // the first one's span) is one finding, printed once.
    out.dedup();
    out
}

/// `d` with a secondary label `what` at each of `hs`.
fn labelled(module: &Module, d: Diagnostic, hs: &[Handle<Expr>], what: &str) -> Diagnostic {
    hs.iter().fold(d, |d, h| d.with_label(module.span(*h), what.to_string()))
}

/// The capacity overflows of statement `st` (warnings: the planner splits).
fn capacity(module: &Module, profile: &Profile, st: &Statement, u: &Usage, out: &mut Vec<Diagnostic>) {
    let name = &profile.name;
    let labels = |d: Diagnostic, hs: &[Handle<Expr>], what: &str| labelled(module, d, hs, what);
    let overflow = |resource: &str, need: usize, have: u32, hs: &[Handle<Expr>], what: &str| {
        let d = Diagnostic::warning(
            "does-not-fit",
            format!("does not fit in one pass on {name}: needs {need} {resource}; it has {have}; the pass planner will split it"),
            st.span,
            format!("needs {need} {resource}"),
        )
        .with_help(format!("{name} offers {have} {resource} per pass; the planner splits the statement with framebuffer blending or render-to-texture"));
        labels(d, hs, what)
    };
    if u.texture_units() > profile.texture_units as usize {
        out.push(overflow(
            "texture units",
            u.texture_units(),
            profile.texture_units,
            &u.lookups,
            "a texture unit",
        ));
    }
    if u.interpolants.len() > profile.interpolants as usize {
        out.push(overflow(
            "interpolants",
            u.interpolants.len(),
            profile.interpolants,
            &u.interpolants,
            "interpolated",
        ));
    }
    if let Some(have) = profile.constant_registers() {
        if u.constants.len() > have as usize {
            out.push(overflow(
                "constant colours",
                u.constants.len(),
                have,
                &u.constants,
                "a constant register",
            ));
        }
    }
}

/// The capabilities statement `st` needs and `profile` lacks (errors: no
/// split makes the hardware do it).
fn capabilities(module: &Module, profile: &Profile, st: &Statement, u: &Usage, out: &mut Vec<Diagnostic>) {
    let name = &profile.name;
    let labels = |d: Diagnostic, hs: &[Handle<Expr>], what: &str| labelled(module, d, hs, what);
    let missing = |what: String, hs: &[Handle<Expr>], help: &str| {
        let first = hs.first().map_or(st.span, |h| module.span(*h));
        let d = Diagnostic::error(
            "unsupported-by-target",
            format!("{name} cannot do this: {what}"),
            first,
            what.clone(),
        )
        .with_help(help.to_string());
        labels(d, &hs[hs.len().min(1)..], "here too")
    };
    if !u.dependent_lookups.is_empty() && !profile.has_dependent_lookups() {
        out.push(missing(
            "a texture indexed by another texture's result (dependent lookup)".into(),
            &u.dependent_lookups,
            "dependent lookups need texture shaders: target geforce3 or wgsl",
        ));
    }
    if !u.cube_lookups.is_empty() && !profile.cube_maps {
        out.push(missing(
            "cube-map lookups".into(),
            &u.cube_lookups,
            "target a profile with cube maps (geforce256, geforce3, wgsl)",
        ));
    }
    if !u.lookups_3d.is_empty() && !profile.textures_3d {
        out.push(missing("3-D texture lookups".into(), &u.lookups_3d, "target a profile with 3-D textures"));
    }
    if !u.signed_lookups.is_empty() && !profile.signed_textures {
        out.push(missing(
            "signed textures".into(),
            &u.signed_lookups,
            "store range-compressed vectors in rgb8 and `expand` them (Kilgard 2000, Section 5.2)",
        ));
    }
    if !u.float_lookups.is_empty() && !profile.float_textures {
        out.push(missing(
            "float textures".into(),
            &u.float_lookups,
            "an 8-bit format holds [0, 1]: the lowering re-stores a float texture itself when every write is a value in [0, 1], or an rgb in [−1, 1] with alpha 1 (range-compressed); values of a range it cannot know (object-space positions, solid mapping) must be scaled into [0, 1] where they are written and back where they are read (`compress(P / r)`, `expand(T δu x) * r`), or target wgsl; solid mapping planned for a scene (`render`, `compile --scene`) on a target with 3-D textures (geforce3) is a 3-D texture of the shader over the scene's object bounds (docs/solid-textures.md)",
        ));
    }
    if !u.vertex_lookups.is_empty() && !profile.vertex_texture_fetch {
        out.push(missing(
            "texture lookups per vertex".into(),
            &u.vertex_lookups,
            "interpolate the coordinates first: `T δu x`",
        ));
    }
    if profile.fragment == FragmentStage::TextureEnv && !u.arithmetic.is_empty() {
        // A `max`/`min` of texels is what GL's MIN/MAX blend equations
        // would split across passes: the help says the target lacks them.
        let min_max = u.arithmetic.iter().any(|&h| {
            matches!(
                module.exprs[h],
                Expr::Math { fun: crate::ir::MathFunction::Max | crate::ir::MathFunction::Min, .. }
            )
        });
        let blend = if min_max && !profile.blend_modes.iter().any(|b| b == "max") {
            format!("; a `max` or `min` would split across passes with the MIN/MAX blend equations (EXT_blend_minmax), which {name} does not have")
        } else {
            String::new()
        };
        out.push(missing(
            format!("per-{} arithmetic beyond the texture environment", if st.freq == crate::ir::Frequency::Texel { "texel" } else { "fragment" }),
            &u.arithmetic,
            &format!("the OpenGL 1.2.1 texture environment only combines texels (⊕); compute this per vertex (`δ p s x`) or target geforce256/geforce3/wgsl{blend}"),
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_load_and_round_trip() {
        for name in BUILTIN {
            let p = Profile::builtin(name).unwrap();
            assert_eq!(&p.name, name);
            let back = Profile::from_ron(&p.to_ron(), "round trip").unwrap();
            assert_eq!(p, back);
        }
    }

    #[test]
    fn consistent_with_combiner_limits() {
        assert_eq!(
            Profile::builtin("geforce256").unwrap().combiner_limits(),
            Some(CombinerLimits::GEFORCE256)
        );
        assert_eq!(Profile::builtin("geforce3").unwrap().combiner_limits(), Some(CombinerLimits::GEFORCE3));
        assert_eq!(Profile::builtin("wgsl").unwrap().combiner_limits(), None);
    }

    #[test]
    fn unknown_and_bad_profiles_are_clear() {
        let e = Profile::builtin("voodoo2").unwrap_err().to_string();
        assert!(e.contains("unknown target profile `voodoo2`"), "{e}");
        let e = Profile::from_ron("Profile(name: \"x\")", "p.ron").unwrap_err().to_string();
        assert!(e.starts_with("p.ron: not a valid profile:"), "{e}");
        // A cost model that cannot predict (a clock of zero) is refused, saying which number.
        let text = include_str!("../profiles/geforce3.ron").replace("clock_mhz: 200.0", "clock_mhz: 0.0");
        let e = Profile::from_ron(&text, "slow.ron").unwrap_err().to_string();
        assert!(
            e.contains("slow.ron: not a valid profile: cost.clock_mhz is 0; it must be a positive number"),
            "{e}"
        );
        let text = include_str!("../profiles/geforce3.ron")
            .replace("pass_overhead_us: 5.0", "pass_overhead_us: -1.0");
        let e = Profile::from_ron(&text, "p.ron").unwrap_err().to_string();
        assert!(e.contains("cost.pass_overhead_us is -1"), "{e}");
    }
}
