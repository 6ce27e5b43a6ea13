//! Differential tests over generated programs (issue 16): for each program
//! a proptest strategy writes and each built-in target, the compiler either
//! refuses with a diagnostic located in the source, or gives a plan that
//!
//! 1. passes an independent plan validator ([`validate_plan`], written here
//!    from the profiles and seeds/003 Appendix B, not from the planner):
//!    every pass within the target's texture units and interpolants; on a
//!    register-combiner target every pass realized by the code generator
//!    and accepted by the Appendix B validator under that profile's own
//!    limits (a pass whose `combiners` says "not generated" is a failure); per-fragment texture coordinates only with texture shaders;
//!    render targets only in formats the target can write;
//! 2. renders in f32 within 2/255 of the program's own meaning
//!    (`shadec::meaning`: each statement in order, whole, unsplit), the
//!    meaning rendered in f32 through the same texture unit so that
//!    filtering differences, which amplified values magnify, do not hide
//!    or fake a plan's error.
//!
//! `cargo test` runs `CASES` programs (a couple of minutes on two cores);
//! `SHADEC_DIFFERENTIAL_CASES=N` runs more. What the runs found is in
//! BENCHMARKS.md ("Differential suite"); each bug has a named test below.

use std::path::Path;

use proptest::prelude::*;
use proptest::strategy::ValueTree;
use shadec::backends::combiners::{codegen, validate};
use shadec::ir::{Expr, Frequency, Handle};
use shadec::numerics::Precision;
use shadec::pipeline::{Planned, RenderTarget};
use shadec::profile::Profile;
use shadec::renderer::plan::{compare, PlanRenderer};
use shadec::scene::Scene;

const TARGETS: &[&str] = &["geforce256", "geforce3", "multitexture", "wgsl"];
const CASES: u32 = 200;
const W: u32 = 48;
const H: u32 = 36;
/// Both images rounded to RGBA8 once, and f32 arithmetic in a different
/// order (a blend instead of one sum).
const TOLERANCE: f32 = 2.0 / 255.0;

// ---- the program generator ------------------------------------------------

/// A colour-valued (rgb) expression of the generated language subset.
#[derive(Clone, Debug)]
enum Colour {
    /// `T δu x` of an rgb8 texture, or `(T δu x).rgb` of an rgba8 one.
    Texture(usize),
    /// `kd` … a declared constant colour.
    Constant(usize),
    /// `I` — a uniform colour (the scene leaves it at its default).
    Uniform,
    /// `δ g s x` — Gouraud shading, the shader applied per vertex (seeds/001 (1)).
    Gouraud,
    /// `T δu x` through the sphere-map texgen `u x ← πR R s x` (seeds/001 (7)).
    SphereMap,
    /// The baked texture `B δu x`, filled by texture shading (seeds/001 (13)).
    Baked,
    Scaled(Scalar, Box<Colour>),
    Mul(Box<Colour>, Box<Colour>),
    Add(Box<Colour>, Box<Colour>),
    /// `a ⊕[mode] b` (seeds/001 (3), (12)).
    Combine(&'static str, Box<Colour>, Box<Colour>),
    Saturate(Box<Colour>),
}

/// A scalar-valued expression.
#[derive(Clone, Debug)]
enum Scalar {
    Number(u8),
    /// `max(0, N·Ln)` with `Ln` from the normalization cube map (Formula 4 of seeds/000).
    Diffuse,
    /// `max(0, N·Hn)^n`.
    Specular(u32),
    /// `(T δu x).a` of an rgba8 texture.
    Alpha(usize),
    /// `(T δu x).r` or `.g`: one colour channel (an occlusion map), which
    /// the combiners read by a dot product with a unit colour.
    Channel(usize, char),
    /// `max(0, Nt·(δ Lt s x))`, or `max(0, Nt·(δ Ht s x))^n`: an interpolated
    /// signed vector read as it comes (seeds/000 Figure 9, "no
    /// normalization"), which the combiner targets take range-compressed.
    Unnormalized(Option<u32>),
    /// What the lowering rewrites (issue 18), one form per rule family.
    Lowered(Lowered),
}

/// A scalar only a lowering makes plan on some target.
#[derive(Clone, Copy, Debug)]
enum Lowered {
    /// `max(0, Nt·normalize(δ Lt s x))`: a cube map or Taylor (Formula 6).
    Normalize,
    /// `Tx (Nt·Hn)`, `Tx = exponent_table(n)`: a dependent lookup — texture
    /// shaders on geforce3, the table's function on geforce256.
    ExponentTable(u32),
    /// `max(0, Nt·(Ns δ Ht s x))^n` with `Ns` a signed16 cube map: re-stored
    /// in RGB8 where the target has no signed formats.
    SignedCube(u32),
    /// `f(δ c s x)`, f the combiners lack (√, exp, a fractional power):
    /// a table baked by the compiler.
    Function(&'static str),
    /// `x^n` with n not a power of two: squarings multiplied.
    Power(u32),
    /// `k·(1 − Nt·(δ Lt s x))^5`: Schlick's factor, whose intermediate
    /// values leave [−1, 1] (a 1-D table of the whole function).
    Schlick,
}

/// The last two nest a function the combiners lack inside another: the
/// inner one is tabulated first, then the whole chain (a table over a
/// tabulated part must tabulate the function as written).
const FUNCTIONS: &[&str] = &[
    "sqrt(@)",
    "exp(-2 * @)",
    "@ ^ 0.6",
    "0.2 / (0.2 + 3 * @)",
    "(0.5 * sqrt(@) + 0.2) ^ 0.6",
    "exp(-2 * sqrt(@))",
];

fn lowered() -> impl Strategy<Value = Lowered> {
    prop_oneof![
        Just(Lowered::Normalize),
        prop_oneof![Just(4u32), Just(8), Just(16)].prop_map(Lowered::ExponentTable),
        prop_oneof![Just(1u32), Just(8)].prop_map(Lowered::SignedCube),
        prop::sample::select(FUNCTIONS).prop_map(Lowered::Function),
        prop_oneof![Just(3u32), Just(6), Just(12)].prop_map(Lowered::Power),
        Just(Lowered::Schlick),
    ]
}

impl Lowered {
    fn text(self) -> String {
        match self {
            Lowered::Normalize => "max(0, Nt·normalize(δ Lt s x))".into(),
            Lowered::ExponentTable(n) => format!("Tx{n} (Nt·Hn)"),
            Lowered::SignedCube(1) => "max(0, Nt·(Ns δ Ht s x))".into(),
            Lowered::SignedCube(n) => format!("max(0, Nt·(Ns δ Ht s x))^{n}"),
            Lowered::Function(f) => format!("({})", f.replace('@', "(δ c s x)")),
            Lowered::Power(n) => format!("max(0, Nt·Hn)^{n}"),
            Lowered::Schlick => "(0.03 * (1 - Nt·(δ Lt s x))^5)".into(),
        }
    }
}

#[derive(Clone, Debug)]
enum Accumulate {
    Add,
    Modulate,
    /// `(C δπx) * e + f`: modulate, then add.
    Affine,
    /// `(C δπx) ⊕[add] ((α C δπx) * e)`: the specular pass of seeds/003
    /// Section 5.5, gated by destination alpha (GL_DST_ALPHA, GL_ONE).
    DstAlphaAdd,
    /// `rgba((α C δπx) * e, α C δπx)` (GL_DST_ALPHA, GL_ZERO).
    DstAlphaModulate,
}

#[derive(Clone, Debug)]
struct Program {
    /// Per texture: rgba8 (else rgb8).
    rgba: Vec<bool>,
    first: Colour,
    /// The first statement's alpha, `rgba(first, a)` (else alpha 1).
    first_alpha: Option<Scalar>,
    more: Vec<(Accumulate, Colour, Colour)>,
}

const N_TEXTURES: usize = 4;
const N_CONSTANTS: usize = 3;
const MODES: &[&str] = &["modulate", "add", "add_signed", "subtract", "interpolate"];

fn scalar() -> impl Strategy<Value = Scalar> {
    prop_oneof![
        (1u8..=9).prop_map(Scalar::Number),
        Just(Scalar::Diffuse),
        prop_oneof![Just(2u32), Just(4), Just(8), Just(16)].prop_map(Scalar::Specular),
        (0..N_TEXTURES).prop_map(Scalar::Alpha),
        (0..N_TEXTURES, prop_oneof![Just('r'), Just('g')]).prop_map(|(t, c)| Scalar::Channel(t, c)),
        prop_oneof![Just(None), Just(Some(2u32)), Just(Some(8))].prop_map(Scalar::Unnormalized),
        lowered().prop_map(Scalar::Lowered),
    ]
}

fn colour() -> impl Strategy<Value = Colour> {
    let leaf = prop_oneof![
        6 => (0..N_TEXTURES).prop_map(Colour::Texture),
        2 => (0..N_CONSTANTS).prop_map(Colour::Constant),
        1 => Just(Colour::Uniform),
        2 => Just(Colour::Gouraud),
        1 => Just(Colour::SphereMap),
        1 => Just(Colour::Baked),
    ];
    leaf.prop_recursive(4, 12, 2, |inner| {
        // Weighted towards what the combiners can compute (products,
        // clamped sums), so that the combiner targets plan, split and
        // refuse in about equal measure.
        prop_oneof![
            3 => (scalar(), inner.clone()).prop_map(|(s, c)| Colour::Scaled(s, Box::new(c))),
            4 => (inner.clone(), inner.clone()).prop_map(|(a, b)| Colour::Mul(Box::new(a), Box::new(b))),
            1 => (inner.clone(), inner.clone()).prop_map(|(a, b)| Colour::Add(Box::new(a), Box::new(b))),
            2 => (inner.clone(), inner.clone()).prop_map(|(a, b)| Colour::Saturate(Box::new(Colour::Add(Box::new(a), Box::new(b))))),
            2 => (prop::sample::select(MODES), inner.clone(), inner.clone()).prop_map(|(m, a, b)| Colour::Combine(m, Box::new(a), Box::new(b))),
            1 => inner.prop_map(|c| Colour::Saturate(Box::new(c))),
        ]
    })
}

fn accumulate() -> impl Strategy<Value = Accumulate> {
    prop_oneof![
        Just(Accumulate::Add),
        Just(Accumulate::Modulate),
        Just(Accumulate::Affine),
        Just(Accumulate::DstAlphaAdd),
        Just(Accumulate::DstAlphaModulate)
    ]
}

fn program() -> impl Strategy<Value = Program> {
    (
        prop::collection::vec(any::<bool>(), N_TEXTURES),
        colour(),
        prop::option::of(scalar()),
        prop::collection::vec((accumulate(), colour(), colour()), 0..3),
    )
        .prop_map(|(rgba, first, first_alpha, more)| Program { rgba, first, first_alpha, more })
}

const NAMES: [&str; N_TEXTURES] = ["A", "B2", "D", "E"];
const CONSTANTS: [(&str, &str); N_CONSTANTS] =
    [("kd", "(0.8, 0.6, 0.4)"), ("ks", "(0.5, 0.5, 0.5)"), ("ka", "(0.1, 0.2, 0.1)")];

impl Scalar {
    fn text(&self, p: &Program) -> String {
        match self {
            Scalar::Number(k) => format!("0.{k}"),
            Scalar::Diffuse => "max(0, Nt·Ln)".into(),
            Scalar::Specular(n) => format!("max(0, Nt·Hn)^{n}"),
            Scalar::Unnormalized(None) => "max(0, Nt·(δ Lt s x))".into(),
            Scalar::Unnormalized(Some(n)) => format!("max(0, Nt·(δ Ht s x))^{n}"),
            Scalar::Alpha(t) if p.rgba[*t] => format!("({} δu x).a", NAMES[*t]),
            Scalar::Alpha(_) => "0.5".into(),
            Scalar::Channel(t, c) => format!("({} δu x).{c}", NAMES[*t]),
            Scalar::Lowered(l) => l.text(),
        }
    }
}

impl Colour {
    fn text(&self, p: &Program) -> String {
        match self {
            Colour::Texture(t) if p.rgba[*t] => format!("({} δu x).rgb", NAMES[*t]),
            Colour::Texture(t) => format!("{} δu x", NAMES[*t]),
            Colour::Constant(k) => CONSTANTS[*k].0.into(),
            Colour::Uniform => "I".into(),
            Colour::Gouraud => "(δ g s x)".into(),
            Colour::SphereMap => "Env δu x".into(),
            Colour::Baked => "(Bk δu x).rgb".into(),
            Colour::Scaled(s, c) => format!("{} * {}", s.text(p), c.text(p)),
            Colour::Mul(a, b) => format!("({}) * ({})", a.text(p), b.text(p)),
            Colour::Add(a, b) => format!("({}) + ({})", a.text(p), b.text(p)),
            Colour::Combine(m, a, b) => format!("({}) ⊕[{m}] ({})", a.text(p), b.text(p)),
            Colour::Saturate(c) => format!("saturate({})", c.text(p)),
        }
    }

    /// Whether a leaf `leaf` says yes to occurs in the expression.
    fn uses(&self, leaf: &dyn Fn(&Colour) -> bool) -> bool {
        match self {
            Colour::Scaled(_, c) | Colour::Saturate(c) => c.uses(leaf),
            Colour::Mul(a, b) | Colour::Add(a, b) | Colour::Combine(_, a, b) => a.uses(leaf) || b.uses(leaf),
            c => leaf(c),
        }
    }
}

impl Program {
    fn uses(&self, leaf: &dyn Fn(&Colour) -> bool) -> bool {
        self.first.uses(leaf) || self.more.iter().any(|(_, a, b)| a.uses(leaf) || b.uses(leaf))
    }

    /// The program's text: declarations, then the statements.
    fn source(&self) -> String {
        let mut s = String::new();
        s += "vector N : normal;\nvector L : light(0);\nvector R : reflection in eye;\n";
        s += "vector Lt : light(0) in tangent;\nvector Ht : half(0) in tangent;\n";
        s += "const Nt : vec3 = (0, 0, 1);\n";
        for (name, value) in CONSTANTS {
            s += &format!("const {name} : rgb = {value};\n");
        }
        s += "uniform I : rgb = (0.9, 0.9, 0.8);\n";
        for (i, name) in NAMES.iter().enumerate() {
            s += &format!(
                "texture {name} : 2d {} mipmap repeat = image(\"missing-{i}.png\");\n",
                if self.rgba[i] { "rgba8" } else { "rgb8" }
            );
        }
        s += "texture Ncube : cube rgb8 bilinear clamp = normalize_cube(32);\n";
        s += "texture Env : 2d rgb8 bilinear clamp = image(\"missing-env.png\");\n";
        s += "shader g : s → c = kd * max(0, N·L);\n";
        s += "let Ln = expand(Ncube δ Lt s x);\nlet Hn = expand(Ncube δ Ht s x);\n";
        s += "texture Ns : cube signed16 bilinear clamp = normalize_cube(32, 16);\n";
        s += "shader c : s → scalar = max(0, N·L);\n";
        for n in [4, 8, 16] {
            s += &format!("texture Tx{n} : 1d r8 bilinear clamp = exponent_table({n});\n");
        }
        // The texture-shading statement and the texgen only where they are
        // read: a statement nothing reads is still planned. (The compiler
        // computes a bake itself, so the combiner targets plan it too.)
        if self.uses(&|c| matches!(c, Colour::Baked)) {
            s += "shader ramp : s → c = ka + s.x * ks;\n";
            s += "texture Bk : 2d rgba8 bilinear clamp = bake(ramp);\n";
        }
        if self.uses(&|c| matches!(c, Colour::SphereMap)) {
            s += "u x ← πR R s x;\n";
        }
        s += "framebuffer C : rgba8, depth;\n";
        s += &match &self.first_alpha {
            Some(a) => format!("C δπx ← rgba({}, {});\n", self.first.text(self), a.text(self)),
            None => format!("C δπx ← {};\n", self.first.text(self)),
        };
        for (how, a, b) in &self.more {
            s += &match how {
                Accumulate::Add => format!("C δπx ← (C δπx) ⊕[add] ({});\n", a.text(self)),
                Accumulate::Modulate => format!("C δπx ← (C δπx) ⊕ ({});\n", a.text(self)),
                Accumulate::Affine => format!("C δπx ← (C δπx) * ({}) + ({});\n", a.text(self), b.text(self)),
                Accumulate::DstAlphaAdd => {
                    format!("C δπx ← (C δπx) ⊕[add] ((α C δπx) * ({}));\n", a.text(self))
                }
                Accumulate::DstAlphaModulate => {
                    format!("C δπx ← rgba((α C δπx) * ({}), α C δπx);\n", a.text(self))
                }
            };
        }
        s
    }
}

// ---- the independent plan validator ---------------------------------------

/// Why `planned` cannot run on `profile`, if it cannot: checked pass by pass
/// against the profile's own numbers and seeds/003 Appendix B.
/// `z p` or `z p − b` (b a constant) of an interpolated clip position
/// `p`: s/q of texture coordinates generated per vertex (s = z·½ + w·(½ − b),
/// q = w), which every texture unit divides (projective texturing) — the
/// GeForce 256 shadow map's ramp coordinate (rule `alpha_ramp_shadow_map`).
fn projective_depth(m: &shadec::ir::Module, coords: Handle<Expr>) -> bool {
    let depth = match m.exprs[coords] {
        Expr::Binary { op: shadec::ir::BinaryOp::Sub, lhs, rhs }
            if matches!(m.exprs[rhs], Expr::Constant(_)) =>
        {
            lhs
        }
        _ => coords,
    };
    matches!(m.exprs[depth], Expr::Depth(p) if matches!(m.exprs[p], Expr::Interpolate { .. }))
}

pub(crate) fn validate_plan(planned: &Planned, profile: &Profile) -> Result<(), String> {
    let m = &planned.module;
    for (i, pass) in planned.plan.passes.iter().enumerate() {
        let at = |what: String| format!("pass {}: {what}", i + 1);
        // A `bake` table is the compiler's work (issue 18): the target only
        // samples it, so only its format must be one the target reads.
        let baked = pass.baked
            && matches!(pass.geometry, shadec::pipeline::Geometry::Texels)
            && matches!(&pass.target, RenderTarget::Texture { .. });
        if baked {
            if let RenderTarget::Texture { name } = &pass.target {
                if m.textures.iter().any(|t| t.name == *name && t.format.is_wide()) && !profile.float_textures
                {
                    return Err(at(format!(
                        "bakes `{name}` in a 16-bit/float format the target cannot sample"
                    )));
                }
            }
            continue;
        }
        if pass.textures.len() > profile.texture_units as usize {
            return Err(at(format!("{} textures on {} units", pass.textures.len(), profile.texture_units)));
        }
        if pass.vertex.interpolants.len() > profile.interpolants as usize {
            return Err(at(format!(
                "{} interpolants, the target has {}",
                pass.vertex.interpolants.len(),
                profile.interpolants
            )));
        }
        // A texture indexed by a value computed per fragment needs texture
        // shaders (NV_texture_shader's dependent and dot-product lookups).
        for t in &pass.textures {
            let coords = Handle::<Expr>::new(t.coords as usize);
            let computed = m.info(coords).freq == Frequency::Fragment
                && !matches!(m.exprs[coords], Expr::Interpolate { .. })
                && !projective_depth(m, coords);
            if computed && profile.texture_shaders.is_none() {
                return Err(at(format!(
                    "`{}` is indexed by a per-fragment value, and the target has no texture shaders",
                    t.texture
                )));
            }
        }
        let written = match &pass.target {
            RenderTarget::Texture { name } | RenderTarget::Temporary { name } => {
                m.textures.iter().find(|t| t.name == *name)
            }
            RenderTarget::Framebuffer { .. } => None,
        };
        if let Some(t) = written {
            if t.format.is_wide() && !profile.float_textures {
                return Err(at(format!(
                    "renders into `{}`, a 16-bit/float texture the target cannot write",
                    t.name
                )));
            }
        }
        if let Some(limits) = profile.combiner_limits() {
            if !pass.baked && planned.setups[i].combiners().is_none() {
                return Err(at("the plan holds no combiner setup for it".to_string()));
            }
            let units: Vec<Handle<Expr>> =
                pass.textures.iter().map(|t| Handle::new(t.lookup as usize)).collect();
            let input = codegen::PassInput {
                module: m,
                value: Handle::new(pass.fragment.output as usize),
                units: &units,
            };
            let generated = codegen::generate(&input, &limits)
                .map_err(|e| at(format!("the combiner generator refuses it: {e}")))?;
            validate::validate(&generated.config, &limits)
                .map_err(|e| at(format!("Appendix B rejects its setup: {e:?}")))?;
        }
    }
    Ok(())
}

// ---- the differential check -----------------------------------------------

fn scene() -> Scene {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/kilgard_torus.ron")).unwrap();
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene/kilgard_torus.ron")).unwrap()
}

/// Checks one program on one target: a located refusal, or a valid plan
/// whose f32 render matches the meaning. `Err` says what broke.
fn check(source: &str, target: &str, scene: &Scene) -> Result<Outcome, String> {
    let profile = Profile::builtin(target).unwrap();
    let (program, diags) = shadec::parser::check(source);
    if let Some(d) = diags.iter().find(|d| d.is_error()) {
        return Err(format!("the generator wrote a program that does not check: {}", d.message));
    }
    let (module, lower) = shadec::ir::lower(&program);
    if let Some(d) = lower.iter().find(|d| d.is_error()) {
        return Err(format!("the generator wrote a program that does not lower: {}", d.message));
    }
    let planned = match shadec::driver::plan(&module, &program, &profile, Some(source), &Default::default()) {
        Ok(p) => p,
        Err(errors) => {
            for d in &errors {
                if d.primary.span.end as usize > source.len()
                    || d.primary.span.start == d.primary.span.end && d.primary.span.start == 0
                {
                    return Err(format!("a refusal without a location: {}", d.message));
                }
                if d.help.as_deref().is_none_or(str::is_empty) {
                    return Err(format!("a refusal without help: {}", d.message));
                }
            }
            return Ok(Outcome::Refused);
        }
    };
    validate_plan(&planned, &profile).map_err(|e| format!("an accepted plan the target cannot run: {e}"))?;
    let assets = scene.build().unwrap();
    // Approximations with output bounds (the rule's bound carried to the
    // output, `lowering::sensitivity`) are held to them against the
    // program's meaning; without (per vertex: it depends on the mesh; an
    // error inside a coordinate) the reference is the lowered program's
    // own meaning, so that the planner and the backends are still checked
    // against a meaning, not against themselves.
    let approximations = &planned.plan.approximations;
    let unbounded = approximations.iter().any(|a| a.output_bound.is_none());
    let bound = approximations.iter().filter_map(|a| a.output_bound).sum::<f64>() as f32;
    let meant = if unbounded { &planned.module } else { &module };
    let meaning =
        shadec::meaning::plan(meant, scene.lights.len()).map_err(|e| format!("no meaning: {e:?}"))?;
    // The meaning in f32 too, through the same texture unit: what differs
    // is then the plan's structure, not the filtering, which an amplified
    // value (`(2A)·(2A)`) would magnify past any fixed tolerance.
    // Both with the 8-bit framebuffers unrounded: a split stores its
    // passes' partial results in 8 bits where the meaning's one pass does
    // not, a rounding a later pass may amplify (`(A·A)·x^8` over three
    // passes: 2/255), which is the hardware's, not the split's (the
    // three-way suite holds the rounded renders to wgpu and the reference).
    let reference = PlanRenderer::new(&meaning, &program, scene, &assets)
        .and_then(|mut r| {
            r.set_unrounded_targets(true);
            r.render(Precision::F32, W, H, &mut |_, _| {})
        })
        .map_err(|e| format!("meaning: {e}"))?;
    let mut renderer =
        PlanRenderer::new(&planned, &program, scene, &assets).map_err(|e| format!("plan: {e}"))?;
    renderer.set_unrounded_targets(true);
    let frame = renderer.render(Precision::F32, W, H, &mut |_, _| {}).map_err(|e| format!("plan: {e}"))?;
    // The batched fragment stage shades as one fragment at a time does (issue 22).
    for mode in [Precision::F32, Precision::Fixed9] {
        let mut frame = |batched| {
            renderer.set_batched(batched);
            renderer.render(mode, W, H, &mut |_, _| {}).map_err(|e| format!("plan, {}: {e}", mode.name()))
        };
        // f32 batches run lane code in f32 (issue 37): a stated tolerance.
        let check = if mode == Precision::F32 {
            crate::render_batch::close_frames
        } else {
            crate::render_batch::same_frames
        };
        check(&frame(true)?, &frame(false)?)
            .map_err(|e| format!("batched and one at a time differ in {}: {e}", mode.name()))?;
    }
    let e = compare(&reference.image, &frame.image);
    if e.max_abs > TOLERANCE + bound {
        return Err(format!(
            "the plan's f32 render is {:.1}/255 from the meaning (RMSE {:.4}) over {} passes",
            e.max_abs * 255.0,
            e.rmse,
            planned.plan.passes.len()
        ));
    }
    let split = planned.plan.passes.iter().any(|p| p.reason.contains(" split into "));
    Ok(Outcome::Planned { passes: planned.plan.passes.len(), split })
}

#[derive(Debug, PartialEq)]
enum Outcome {
    Refused,
    /// Passes, and whether a statement was split into several.
    Planned {
        passes: usize,
        split: bool,
    },
}

/// Checks `source` on every target; counts plans per target into `planned`.
fn check_all_targets(source: &str, scene: &Scene, planned: &mut [usize; 4]) -> Result<(), String> {
    for (i, target) in TARGETS.iter().enumerate() {
        let outcome = check(source, target, scene).map_err(|e| format!("{target}: {e}\n{source}"))?;
        planned[i] += matches!(outcome, Outcome::Planned { .. }) as usize;
    }
    Ok(())
}

fn cases() -> u32 {
    std::env::var("SHADEC_DIFFERENTIAL_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(CASES)
}

#[test]
fn generated_programs_plan_validly_and_render_their_meaning() {
    let scene = scene();
    let config = ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() };
    // A fixed seed, so that CI runs the same programs every time; random
    // ones with SHADEC_DIFFERENTIAL_RANDOM=1 (a failure prints its program).
    let mut runner = if std::env::var_os("SHADEC_DIFFERENTIAL_RANDOM").is_some() {
        proptest::test_runner::TestRunner::new(config)
    } else {
        let rng =
            proptest::test_runner::TestRng::deterministic_rng(proptest::test_runner::RngAlgorithm::ChaCha);
        proptest::test_runner::TestRunner::new_with_rng(config, rng)
    };
    let planned = std::cell::RefCell::new([0usize; 4]);
    let result = runner.run(&program(), |p| {
        let source = p.source();
        check_all_targets(&source, &scene, &mut planned.borrow_mut()).map_err(TestCaseError::fail)
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    eprintln!(
        "{} programs; planned per target {TARGETS:?}: {:?} (the rest refused, located)",
        cases(),
        planned.borrow()
    );
}

/// The generator reaches what it should: over a fixed sample, every target
/// plans some programs, and a combiner target splits some of them.
#[test]
fn the_generator_covers_plans_and_splits() {
    let scene = scene();
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let mut planned = [0usize; 4];
    let mut split = [0usize; 4];
    for _ in 0..64 {
        let p = program().new_tree(&mut runner).unwrap().current();
        let source = p.source();
        for (i, target) in TARGETS.iter().enumerate() {
            if let Ok(Outcome::Planned { split: s, .. }) = check(&source, target, &scene) {
                planned[i] += 1;
                split[i] += s as usize;
            }
        }
    }
    assert!(planned.iter().all(|&n| n > 0), "planned per target {planned:?}");
    // Splits are rarer since the generator packs more into a pass (the
    // named tests below and tests/planner_split.rs split on purpose).
    assert!(
        split[0] + split[1] > 0,
        "the combiner targets split none of them: {split:?} (planned {planned:?})"
    );
}

/// The generator reaches the lowering (issue 18): over a fixed sample, the
/// combiner targets' plans use each rule family the generated forms call
/// for, so the suite above holds them to their output bounds (or to the
/// lowered program's meaning) on programs nobody wrote by hand.
#[test]
fn the_generator_reaches_every_lowering_rule_family() {
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    let mut rules = std::collections::BTreeSet::new();
    for _ in 0..1500 {
        let source = program().new_tree(&mut runner).unwrap().current().source();
        for target in ["geforce256", "geforce3"] {
            let profile = Profile::builtin(target).unwrap();
            if let Ok(c) = shadec::driver::compile(&source, &profile, &Default::default()) {
                rules.extend(c.planned.plan.approximations.iter().map(|a| format!("{target} {}", a.rule)));
            }
        }
    }
    eprintln!("rules in generated plans: {rules:?}");
    for want in [
        "geforce256 normalization_cube_map",
        "geforce256 table_function",
        "geforce256 signed_texture_compression",
        "geforce256 baked_table",
        "geforce256 power_by_squaring",
        "geforce3 normalization_cube_map",
        "geforce3 baked_table",
        "geforce3 range_compression",
        "geforce3 baked_table_2d",
    ] {
        assert!(rules.contains(want), "no generated plan used {want}: {rules:?}");
    }
}

// ---- regressions the suite found ------------------------------------------

/// Issue 16's reproducer: a sum of two three-texture products on
/// geforce256 renders one term into a temporary; its first pass tested
/// depth `Equal` against the temporary's cleared depth buffer, so the term
/// was lost (55 % of pixels, up to 128/255) and the plan's own exact render
/// could not see it.
#[test]
fn a_temporary_keeps_its_term() {
    let source = "texture A, B, D, G, H, I : 2d rgb8 = image(\"layer.png\");\nC δπx ← (A δu x) * (B δu x) * (D δu x) + (G δu x) * (H δu x) * (I δu x);\n";
    let scene = scene();
    assert_eq!(check(source, "geforce256", &scene), Ok(Outcome::Planned { passes: 5, split: true }));
    for target in TARGETS {
        assert!(matches!(check(source, target, &scene), Ok(Outcome::Planned { .. })), "{target}");
    }
}

/// Found by the generator (issue 22's session): a render-to-texture inside
/// another moved the inner temporary's passes into the outer temporary, so
/// `temp0` was read by a pass and never rendered. Nested temporaries keep
/// their own targets.
#[test]
fn a_temporary_inside_a_temporary_is_rendered() {
    let source = "texture A : 2d rgb8 = image(\"a.png\");\ntexture Env : 2d rgb8 = image(\"env.png\");\n\
        const kd : rgb = (0.8, 0.6, 0.4);\nuniform I : rgb = (0.9, 0.9, 0.8);\nvector R : reflection in eye;\n\
        u x ← πR R s x;\nC δπx ← A δu x;\n\
        C δπx ← (C δπx) ⊕[add] (((kd + Env δu x) * I) ⊕[subtract] ((A δu x) ⊕[add] (A δu x)));\n";
    let scene = scene();
    check_all_targets(source, &scene, &mut [0; 4]).unwrap();
    // The second statement is a blend the program writes: GL clamps its
    // source, which may be negative, so the whole source is computed
    // before the blend. On geforce256 it does not fit a pass, and its part
    // `kd + Env` (up to 1.8) fits neither a combiner register nor an 8-bit
    // temporary: refused, and it says why.
    let profile = Profile::builtin("geforce256").unwrap();
    let err = shadec::driver::compile(source, &profile, &Default::default()).map(|c| c.planned).unwrap_err();
    let text = format!("{} {}", err[0].message, err[0].help.clone().unwrap_or_default());
    assert!(text.contains("range [0.4, 1.8]") && text.contains("[−1, 1]"), "{text}");
}

/// The fixed seed's clamped intermediate (issue 33): `B2 ⊕[add] (A
/// ⊕[subtract] saturate(Env + kd))` on geforce256 (two units) stored the
/// possibly negative difference in the 8-bit framebuffer and added `B2`
/// after it, 129.8/255 off the meaning where the difference was negative.
/// Now `B2` is written first and the difference is blended as an add of
/// its part above 0 and a reverse subtract of its part below 0
/// (EXT_blend_subtract), which GL's clamp of each source leaves exact.
#[test]
fn a_difference_below_zero_is_taken_off_by_the_blender() {
    let source = "texture A, B2 : 2d rgb8 = image(\"a.png\");\n\
        texture Env : 2d rgb8 bilinear clamp = image(\"env.png\");\n\
        const kd : rgb = (0.8, 0.6, 0.4);\n\
        C δπx ← (B2 δu x) ⊕[add] ((A δu x) ⊕[subtract] saturate((Env δu x) + kd));\n";
    check_all_targets(source, &scene(), &mut [0; 4]).unwrap();
    let profile = Profile::builtin("geforce256").unwrap();
    let planned = shadec::driver::compile(source, &profile, &Default::default()).unwrap().planned;
    let blends: Vec<&str> = planned.plan.passes.iter().map(|p| p.blend.name()).collect();
    assert_eq!(blends, ["replace", "add", "reverse_subtract"], "{}", planned.plan.to_ron());
}

/// A modulation by a factor that may pass 1, written as arithmetic
/// (`C ← C · 2B`): GL would clamp a blend's source to [0, 1], so
/// `C·min(1, 2B)` is not the statement. It is blended as `2·C·B`
/// (GL_DST_COLOR, GL_SRC_COLOR), exact up to 2.
#[test]
fn a_modulation_past_one_is_doubled_by_the_blender() {
    let source = "texture A, B, D : 2d rgb8 = image(\"a.png\");\n\
        C δπx ← (A δu x) * (D δu x);\nC δπx ← (C δπx) * (2 * (B δu x));\n";
    check_all_targets(source, &scene(), &mut [0; 4]).unwrap();
    // geforce256's two units cannot fuse the statements: the second blends.
    let profile = Profile::builtin("geforce256").unwrap();
    let planned = shadec::driver::compile(source, &profile, &Default::default()).unwrap().planned;
    let blends: Vec<&str> = planned.plan.passes.iter().map(|p| p.blend.name()).collect();
    assert_eq!(blends, ["replace", "modulate_2x"], "{}", planned.plan.to_ron());
}

/// The same modulation written as the blend `(C δπx) ⊕ 2B` (Pipeline
/// Grammar, eq. (9)) means GL's blend on the `rgba8` framebuffer: the
/// source clamped to [0, 1] (OpenGL 1.2.1 §4.1.8), as the hardware runs
/// it. The plan is the pass as written, and it agrees with the meaning,
/// which clamps the source too.
#[test]
fn a_blend_the_program_writes_clamps_its_source_as_gl_does() {
    let source = "texture A, B, D : 2d rgb8 = image(\"a.png\");\n\
        C δπx ← (A δu x) * (D δu x);\nC δπx ← (C δπx) ⊕ (2 * (B δu x));\n";
    check_all_targets(source, &scene(), &mut [0; 4]).unwrap();
    let profile = Profile::builtin("geforce256").unwrap();
    let planned = shadec::driver::compile(source, &profile, &Default::default()).unwrap().planned;
    let blends: Vec<&str> = planned.plan.passes.iter().map(|p| p.blend.name()).collect();
    assert_eq!(blends, ["replace", "modulate"], "{}", planned.plan.to_ron());
}

/// A term that may be negative added by arithmetic (`C ← C + (B − D)`):
/// an add would have its source clamped to 0 where the term is negative,
/// so the blender adds its part above 0 and takes off its part below 0
/// by reverse subtract (EXT_blend_subtract, GL_FUNC_REVERSE_SUBTRACT).
#[test]
fn a_negative_term_is_taken_off_by_reverse_subtract() {
    let source = "texture A, B, D : 2d rgb8 = image(\"a.png\");\n\
        C δπx ← (A δu x) * (D δu x);\nC δπx ← (C δπx) + ((B δu x) - (D δu x));\n";
    check_all_targets(source, &scene(), &mut [0; 4]).unwrap();
    let profile = Profile::builtin("geforce256").unwrap();
    let planned = shadec::driver::compile(source, &profile, &Default::default()).unwrap().planned;
    let blends: Vec<&str> = planned.plan.passes.iter().map(|p| p.blend.name()).collect();
    assert!(blends.contains(&"reverse_subtract"), "{}", planned.plan.to_ron());
}

/// Kilgard 2000's three passes on the GeForce 256 as the example writes
/// them: pass 2 modulates by ambient + diffuse, whose range reaches 1.1;
/// GL clamps that blend's source, and so does the program's meaning, so
/// the example still plans in its three passes (decal; modulate;
/// destination-alpha add) and the plan's render agrees with the meaning.
#[test]
fn kilgard_plans_on_geforce256_with_the_blend_source_clamped() {
    let source =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/kilgard_bump_mapping.shd"))
            .unwrap();
    let outcome = check(&source, "geforce256", &scene()).unwrap();
    assert_eq!(outcome, Outcome::Planned { passes: 3, split: false });
    let profile = Profile::builtin("geforce256").unwrap();
    let planned = shadec::driver::compile(&source, &profile, &Default::default()).unwrap().planned;
    let blends: Vec<&str> = planned.plan.passes.iter().map(|p| p.blend.name()).collect();
    assert_eq!(blends, ["replace", "modulate", "dst_alpha_add"], "{}", planned.plan.to_ron());
}

/// A split is held to the clamps between passes (8-bit framebuffer and
/// temporaries): `(diffuse + specular) · decal` with the sum above 1 is
/// not rendered as `clamp(sum) · decal` (91.5/255 off the meaning on the
/// bump torus before); a split whose stored values stay in [0, 1] plans.
#[test]
fn a_split_never_stores_a_value_its_clamp_would_change() {
    let decl = "texture A, B, D : 2d rgb8 = image(\"a.png\");\n";
    let profile = Profile::builtin("geforce256").unwrap();
    let compile = |statement: &str| {
        shadec::driver::compile(&format!("{decl}{statement}\n"), &profile, &Default::default())
            .map(|c| c.planned)
    };
    // (A + B) reaches 2: not stored and then modulated by D (2 passes,
    // clamp(A + B)·D), but D first, then doubled by (A + B)/2 (GL_DST_COLOR,
    // GL_SRC_COLOR: 2 passes, exact up to 2); before that blend, D
    // distributed: B, ·D, + A·D (3 passes).
    let planned = compile("C δπx ← ((A δu x) + (B δu x)) * (D δu x);").unwrap();
    let blends: Vec<_> = planned.plan.passes.iter().map(|p| p.blend).collect();
    use shadec::pipeline::BlendMode;
    assert_eq!(blends, [BlendMode::Replace, BlendMode::Modulate2x]);
    // (A·B + B·D)·½ stays in [0, 1]: it splits.
    let planned = compile("C δπx ← ((A δu x) * (B δu x) + (B δu x) * (D δu x)) * 0.5;").unwrap();
    assert!(planned.plan.passes.len() > 1);
    for (k, pass) in planned.plan.passes.iter().enumerate() {
        assert!(pass.reason.contains("split"), "pass {k}: {}", pass.reason);
    }
}

/// `(diffuse + specular) ⊕ decal` with an rgb sum above 1 and an rgba
/// decal (seeds/000 (7), `phong_taylor_renormalized.shd`): the sum is
/// written with alpha 1. It was distributed through that conversion — `A`
/// with alpha 1, modulated by the decal, `B ⊕ decal` added with alpha 0;
/// since a factor up to 2 is blended doubled, the decal is written first
/// and modulated by the sum halved, alpha ½ (`modulate_2x`, two passes) —
/// and the bit-faithful render of the plan, 8-bit clamps between passes
/// included, agrees with the meaning.
#[test]
fn a_decal_is_distributed_over_an_rgb_sum_written_as_rgba() {
    let source = "texture A, B : 2d rgb8 = image(\"a.png\");\ntexture T : 2d rgba8 = image(\"decal.png\");\n\
        const k : rgb = (0.9, 0.8, 0.7);\nC δπx ← ((A δu x) + k * (B δu x)) ⊕ (T δu x);\n";
    let profile = Profile::builtin("geforce256").unwrap();
    let planned = shadec::driver::compile(source, &profile, &Default::default()).unwrap().planned;
    let blends: Vec<_> = planned.plan.passes.iter().map(|p| p.blend).collect();
    use shadec::pipeline::BlendMode;
    assert_eq!(blends, [BlendMode::Replace, BlendMode::Modulate2x]);
    let scene = scene();
    let (program, _) = shadec::parser::check(source);
    let (module, _) = shadec::ir::lower(&program);
    let assets = scene.build().unwrap();
    let render = |p: &Planned, precision| {
        PlanRenderer::new(p, &program, &scene, &assets)
            .and_then(|r| r.render(precision, 64, 48, &mut |_, _| {}))
            .unwrap()
            .image
    };
    let meaning = shadec::meaning::plan(&module, scene.lights.len()).unwrap();
    let err = compare(&render(&meaning, Precision::Exact), &render(&planned, Precision::Fixed9));
    // 8-bit texels and framebuffer, 9-bit registers: a few steps, not the
    // clamp of a sum up to 1.9 (which would be off by up to 0.9).
    assert!(err.max_abs < 4.0 / 255.0, "{err:?}");
}

/// A pass the combiner generator cannot realize is split further or
/// refused, never planned (issue 16 item 2): as written, `x^8` of the dot
/// product of two interpolated signed vectors has no setup (interpolated
/// colours are unsigned), so with `--no-approx` geforce3 refuses it at the
/// part responsible; with the lowering (issue 18) both vectors travel
/// range-compressed and are expanded in the combiners (seeds/003 §5.2).
#[test]
fn a_pass_the_combiners_cannot_compute_is_refused_where_it_is() {
    let source = "vector N : normal;\nvector H : half(0);\nC δπx ← max(0, (δ N s x)·(δ H s x))^8;\n";
    let profile = Profile::builtin("geforce3").unwrap();
    let exact = shadec::driver::PlanOptions {
        lowering: shadec::lowering::LowerOptions { approximate: false, ..Default::default() },
        ..Default::default()
    };
    let err = shadec::driver::compile(source, &profile, &exact).map(|c| c.planned).unwrap_err();
    assert_eq!(err[0].code, "cannot-split");
    assert!(
        err[0].message.contains("has no register-combiner setup the code generator can build"),
        "{}",
        err[0].message
    );
    // The secondary label points at the interpolated signed vector.
    let part = &err[0].secondary[0];
    assert_eq!(&source[part.span.start as usize..part.span.end as usize], "(δ N s x)");
    // The help is the code generator's own remedy for that part.
    assert!(
        err[0].help.as_deref().is_some_and(|h| h.contains("normalization cube map")),
        "{:?}",
        err[0].help
    );
    // Lowered: one pass, both interpolants range-compressed, within the
    // plan validator and the meaning on the scene.
    let planned = shadec::driver::compile(source, &profile, &Default::default()).unwrap().planned;
    let rules: Vec<&str> = planned.plan.approximations.iter().map(|a| a.rule.as_str()).collect();
    assert_eq!(rules, ["range_compression", "range_compression"]);
    assert_eq!(planned.plan.passes.len(), 1);
    check_all_targets(source, &scene(), &mut [0; 4]).unwrap();
}

/// No example is planned for a combiner target with a pass its generator
/// cannot realize: each plans with every pass generated, or is refused.
#[test]
fn every_accepted_example_plan_runs_on_its_combiner_target() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
    let mut accepted = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "shd") {
            continue;
        }
        let source = std::fs::read_to_string(&path).unwrap();
        for target in ["geforce256", "geforce3"] {
            let profile = Profile::builtin(target).unwrap();
            if let Ok(planned) =
                shadec::driver::compile(&source, &profile, &Default::default()).map(|c| c.planned)
            {
                validate_plan(&planned, &profile)
                    .unwrap_or_else(|e| panic!("{} on {target}: {e}", path.display()));
                accepted += 1;
            }
        }
    }
    assert!(accepted >= 20, "only {accepted} example plans on the combiner targets");
}

/// The order factors are written in does not decide the combiner setup
/// (issue 16 item 5): `2 * A * B` maps to `scale_by_two()` as `A * B * 2`
/// does (it was refused: "range [0, 2] may leave [−1, 1]").
#[test]
fn a_scale_factor_maps_to_the_output_scale_in_any_position() {
    let profile = Profile::builtin("geforce256").unwrap();
    let decl = "texture A, B : 2d rgb8 = image(\"x.png\");\n";
    for statement in [
        "C δπx ← 2 * (A δu x) * (B δu x);",
        "C δπx ← (A δu x) * 2 * (B δu x);",
        "C δπx ← (A δu x) * (B δu x) * 2;",
    ] {
        let planned = shadec::driver::compile(&format!("{decl}{statement}\n"), &profile, &Default::default())
            .map(|c| c.planned)
            .unwrap();
        assert_eq!(planned.plan.passes.len(), 1, "{statement}");
        assert!(planned.setups[0].combiners().is_some(), "{statement}");
        let generated = shadec::backends::combiners::setup::of(&planned, 0).unwrap();
        assert_eq!(generated.stages, 1, "{statement}");
    }
}

/// `bake(f)` is computed by the compiler, not the target (issue 18): a table
/// of `sqrt` — which no combiner computes — plans on every target, its
/// texel pass marked `baked`, and renders the meaning (the generated suite
/// found 17 of 32 sampled programs refused on geforce256 for their table).
#[test]
fn a_bake_is_computed_by_the_compiler_on_every_target() {
    let source = "const kd : rgb = (0.8, 0.6, 0.4);\nshader f : s → c = sqrt(s.x) * kd;\ntexture Bk : 2d rgba8 bilinear clamp = bake(f);\ntexture A : 2d rgb8 = image(\"missing.png\");\nC δπx ← (Bk δu x).rgb * (A δu x);\n";
    let scene = scene();
    for target in TARGETS {
        assert!(
            matches!(check(source, target, &scene), Ok(Outcome::Planned { .. })),
            "{target}: {:?}",
            check(source, target, &scene)
        );
        let planned =
            shadec::driver::compile(source, &Profile::builtin(target).unwrap(), &Default::default())
                .map(|c| c.planned)
                .unwrap();
        let baked: Vec<bool> = planned.plan.passes.iter().map(|p| p.baked).collect();
        assert_eq!(baked, [true, false], "{target}");
    }
}

/// Found by the suite: an rgb statement split into a scalar part and a
/// texture (`spec⁴ · 0.1 · Env` on geforce256) wrote the scalar into alpha
/// in its first pass, where the statement's alpha is 1; a later `α C` read
/// then differed by 190/255. The alpha-writing pass writes the part as rgb.
#[test]
fn a_split_rgb_statement_keeps_alpha_one() {
    let source = "vector Ht : half(0) in tangent;\nvector R : reflection in eye;\nconst Nt : vec3 = (0, 0, 1);\ntexture A : 2d rgb8 = image(\"missing-0.png\");\ntexture Ncube : cube rgb8 bilinear clamp = normalize_cube(32);\ntexture Env : 2d rgb8 bilinear clamp = image(\"missing-env.png\");\nlet Hn = expand(Ncube δ Ht s x);\nu x ← πR R s x;\nframebuffer C : rgba8, depth;\nC δπx ← max(0, Nt·Hn)^4 * 0.1 * Env δu x;\nC δπx ← rgba((α C δπx) * (A δu x), α C δπx);\n";
    let scene = scene();
    assert_eq!(check(source, "geforce256", &scene), Ok(Outcome::Planned { passes: 3, split: true }));
    for target in TARGETS {
        check(source, target, &scene).unwrap_or_else(|e| panic!("{target}: {e}"));
    }
}
