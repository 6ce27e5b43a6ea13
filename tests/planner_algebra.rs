//! Algebra in the planner (issue 34): before refusing a statement for
//! resources the planner plans its equivalent forms — a product
//! distributed over a sum or a `lerp`, a sum split across δ, a tuple read
//! by channel as its components, a common factor taken out, a clamp left
//! to the framebuffer's — and keeps the cheapest. Each named case failed
//! before; each rewritten plan is validated pass by pass
//! (`differential::validate_plan`) and rendered against the program's
//! meaning (`shadec::meaning`). The property test multiplies generated
//! programs out with an expander written here, on the generator's own
//! tree (not the planner's IR), and asserts the planner's verdict is the
//! same on both forms on every target.

use std::path::Path;

use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use shadec::diag::Diagnostic;
use shadec::numerics::Precision;
use shadec::pipeline::Planned;
use shadec::profile::Profile;
use shadec::renderer::plan::{compare, PlanRenderer};
use shadec::scene::Scene;

const TARGETS: &[&str] = &["geforce256", "geforce3", "multitexture", "wgsl"];
const W: u32 = 48;
const H: u32 = 36;
/// Both renders rounded to RGBA8 once, and f32 arithmetic in another
/// order (blends instead of one sum), as `tests/differential.rs` allows.
const TOLERANCE: f32 = 2.0 / 255.0;

fn compile(source: &str, target: &str) -> Result<Planned, Vec<Diagnostic>> {
    let profile = Profile::builtin(target).unwrap();
    shadec::driver::compile(source, &profile, &Default::default()).map(|c| c.planned)
}

pub(crate) fn scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    Scene::parse(&text, Path::new("/nonexistent-shadec-scene").join(name).as_path()).unwrap()
}

pub(crate) fn f32_render(planned: &Planned, source: &str, scene: &Scene) -> shadec::renderer::Framebuffer {
    let (program, _) = shadec::parser::check(source);
    let assets = scene.build().unwrap();
    PlanRenderer::new(planned, &program, scene, &assets)
        .and_then(|mut r| {
            // The plan's arithmetic, not the 8-bit store every plan shares.
            r.set_unrounded_targets(true);
            r.render(Precision::F32, W, H, &mut |_, _| {})
        })
        .unwrap()
        .image
}

/// A plan of `source` on `target`: every pass realized on the target, and
/// its f32 render within the tolerance (plus the plan's stated output
/// bounds) of the program's meaning in f32.
fn plans_and_renders_its_meaning(source: &str, target: &str, scene: &Scene) -> Planned {
    let planned = compile(source, target).unwrap_or_else(|e| panic!("refused on {target}: {e:#?}"));
    let profile = Profile::builtin(target).unwrap();
    crate::differential::validate_plan(&planned, &profile).unwrap_or_else(|e| panic!("{target}: {e}"));
    let (program, _) = shadec::parser::check(source);
    let (written, _) = shadec::ir::lower(&program);
    let meaning = shadec::meaning::plan(&written, scene.lights.len()).unwrap();
    let bound = planned.plan.approximations.iter().filter_map(|a| a.output_bound).sum::<f64>() as f32;
    let e = compare(&f32_render(&meaning, source, scene), &f32_render(&planned, source, scene));
    assert!(
        e.max_abs <= TOLERANCE + bound,
        "{target}: {:.1}/255 from the meaning over {} passes",
        e.max_abs * 255.0,
        planned.plan.passes.len()
    );
    planned
}

fn reasons(planned: &Planned) -> String {
    planned.plan.passes.iter().map(|p| p.reason.clone()).collect::<Vec<_>>().join("\n")
}

// ---- a product over an affine lerp ----------------------------------------

/// A base texture lit per vertex, with fog and a detail texture mixed in by
/// a constant amount: `base · light · lerp(fog, 2·detail, f)`.
const LERP_OVER_PRODUCT: &str = "\
vector N : normal;
vector L : light(0);
texture Base : 2d rgb8 mipmap trilinear repeat = image(\"missing-base.png\");
texture Fog : 2d rgb8 bilinear repeat = image(\"missing-fog.png\");
texture Detail : 2d rgb8 mipmap trilinear repeat = image(\"missing-detail.png\");
const kd : rgb = (0.8, 0.8, 0.8);
const f = 0.3;
shader light : s → c = kd * max(0, N·L);
C δπx ← Base δu x * δ light s x * lerp(Fog δu x, 2 * Detail δu x, f);
";

/// The same, multiplied out by hand.
const LERP_MULTIPLIED_OUT: &str = "\
vector N : normal;
vector L : light(0);
texture Base : 2d rgb8 mipmap trilinear repeat = image(\"missing-base.png\");
texture Fog : 2d rgb8 bilinear repeat = image(\"missing-fog.png\");
texture Detail : 2d rgb8 mipmap trilinear repeat = image(\"missing-detail.png\");
const kd : rgb = (0.8, 0.8, 0.8);
const f = 0.3;
shader light : s → c = kd * max(0, N·L);
C δπx ← Base δu x * δ light s x * Fog δu x * (1 - f) + Base δu x * δ light s x * (2 * Detail δu x) * f;
";

#[test]
fn a_product_over_a_lerp_is_multiplied_out_instead_of_refused() {
    let scene = scene("kilgard_torus.ron");
    // Refused before with "a part that cannot be divided further needs 3
    // texture units" on geforce256, and for `2·detail` leaving [−1, 1] on
    // geforce3, while multiplied out by hand it plans.
    for target in ["geforce256", "geforce3", "multitexture", "wgsl"] {
        let by_hand = plans_and_renders_its_meaning(LERP_MULTIPLIED_OUT, target, &scene);
        let planned = plans_and_renders_its_meaning(LERP_OVER_PRODUCT, target, &scene);
        assert!(planned.plan.approximations.is_empty(), "{target}: exact algebra, no approximation");
        assert!(
            planned.plan.passes.len() <= by_hand.plan.passes.len(),
            "{target}: {} passes, by hand {}",
            planned.plan.passes.len(),
            by_hand.plan.passes.len()
        );
        if target != "wgsl" {
            assert!(reasons(&planned).contains("as written"), "{target}: {}", reasons(&planned));
        }
    }
    // Two passes since a factor up to 2 is blended doubled (`modulate_2x`).
    assert_eq!(compile(LERP_OVER_PRODUCT, "geforce256").unwrap().plan.passes.len(), 2);
    assert_eq!(compile(LERP_OVER_PRODUCT, "geforce3").unwrap().plan.passes.len(), 1);
}

// ---- a sum of lights inside one δ -----------------------------------------

/// GL's per-vertex lighting of three attenuated lights (Pipeline Grammar,
/// eq. (1): `δ p s x`), modulating a base texture; each light's term lies
/// in [0, 1], their sum (with the ambient) does not.
const LIGHTS_INSIDE_DELTA: &str = "\
vector N : normal;
vector L0 : light(0);
vector L1 : light(1);
vector L2 : light(2);
texture Base : 2d rgb8 mipmap trilinear repeat = image(\"missing-base.png\");
const ka : rgb = (0.1, 0.1, 0.1);
const c0 : rgb = (0.9, 0.3, 0.3);
const c1 : rgb = (0.3, 0.9, 0.3);
const c2 : rgb = (0.3, 0.3, 0.9);
const a0 = 0.8;
const a1 = 0.6;
const a2 = 0.5;
shader lights : s → c = ka + a0 * c0 * max(0, N·L0) + a1 * c1 * max(0, N·L1) + a2 * c2 * max(0, N·L2);
C δπx ← Base δu x * δ lights s x;
";

#[test]
fn a_sum_of_lights_inside_delta_is_split_across_it() {
    let scene = scene("adaptive_sphere_4lights.ron");
    for target in TARGETS {
        let planned = plans_and_renders_its_meaning(LIGHTS_INSIDE_DELTA, target, &scene);
        assert!(planned.plan.approximations.is_empty(), "{target}: δ(a + b) = δa + δb is exact");
    }
    let geforce256 = compile(LIGHTS_INSIDE_DELTA, "geforce256").unwrap();
    assert!(reasons(&geforce256).contains("as written it"), "{}", reasons(&geforce256));
}

/// The same lights with the scene's unbounded intensities: no 8-bit
/// interpolant holds a term, split or not, so it stays refused — located,
/// and saying what was tried.
#[test]
fn lights_of_unbounded_intensity_are_refused_saying_what_was_tried() {
    let source = "\
vector N : normal;
vector L0 : light(0);
vector L1 : light(1);
vector I0 : intensity(0);
vector I1 : intensity(1);
texture Base : 2d rgb8 = image(\"missing-base.png\");
shader lights : s → c = I0 * max(0, N·L0) + I1 * max(0, N·L1);
C δπx ← Base δu x * δ lights s x;
";
    let errors = compile(source, "geforce256").unwrap_err();
    let d = &errors[0];
    assert_ne!(d.primary.span.start, d.primary.span.end, "{d:?}");
    let help = d.help.as_deref().unwrap_or_default();
    assert!(help.contains("equivalent forms"), "{help}");
    assert!(compile(source, "wgsl").is_ok());
}

/// The same lights planned for a scene: each intensity is bounded by what
/// its light delivers there (colour over constant attenuation, 0.9 on
/// this scene), so the sum splits across δ into terms the 8-bit
/// interpolants hold, and the plan renders the program's meaning.
#[test]
fn lights_of_intensity_bounded_by_the_scene_plan_for_it() {
    let source = "\
vector N : normal;
vector L0 : light(0);
vector L1 : light(1);
vector I0 : intensity(0);
vector I1 : intensity(1);
texture Base : 2d rgb8 = image(\"missing-base.png\");
shader lights : s → c = I0 * max(0, N·L0) + I1 * max(0, N·L1);
C δπx ← Base δu x * δ lights s x;
";
    let scene = scene("adaptive_sphere_4lights.ron");
    let assets = scene.build().unwrap();
    let options = shadec::driver::PlanOptions {
        scene: Some(shadec::driver::ForScene::unspecialized(&scene, &assets)),
        ..Default::default()
    };
    let (program, _) = shadec::parser::check(source);
    let (written, _) = shadec::ir::lower(&program);
    let meaning = shadec::meaning::plan(&written, scene.lights.len()).unwrap();
    for target in ["geforce256", "geforce3"] {
        let profile = Profile::builtin(target).unwrap();
        let planned = shadec::driver::compile(source, &profile, &options)
            .unwrap_or_else(|e| panic!("{target}: {e:#?}"))
            .planned;
        crate::differential::validate_plan(&planned, &profile).unwrap_or_else(|e| panic!("{target}: {e}"));
        assert!(planned.plan.approximations.is_empty(), "{target}: exact");
        let e = compare(&f32_render(&meaning, source, &scene), &f32_render(&planned, source, &scene));
        assert!(e.max_abs <= TOLERANCE, "{target}: {:.1}/255 from the meaning", e.max_abs * 255.0);
    }
}

// ---- a tuple read by channel ----------------------------------------------

const TUPLE: &str = "\
vector N : normal;
vector L : light(0);
vector H : half(0);
texture Base : 2d rgb8 mipmap trilinear repeat = image(\"missing-base.png\");
const ks : rgb = (0.5, 0.5, 0.5);
shader terms : s → c = (max(0, normalize(N)·normalize(L)), max(0, normalize(N)·normalize(H))^8, 0);
let t = terms δ s x;
C δπx ← Base δu x * t.r + ks * t.g;
";

const SCALARS: &str = "\
vector N : normal;
vector L : light(0);
vector H : half(0);
texture Base : 2d rgb8 mipmap trilinear repeat = image(\"missing-base.png\");
const ks : rgb = (0.5, 0.5, 0.5);
shader diffuse : s → c = max(0, normalize(N)·normalize(L));
shader specular : s → c = max(0, normalize(N)·normalize(H))^8;
C δπx ← Base δu x * diffuse δ s x + ks * specular δ s x;
";

fn rules(planned: &Planned) -> Vec<String> {
    let mut r: Vec<String> = planned.plan.approximations.iter().map(|a| a.rule.clone()).collect();
    r.dedup();
    r
}

#[test]
fn a_tuple_read_by_channel_plans_per_pixel_like_its_scalars() {
    let scene = scene("bench_sphere.ron");
    for target in ["geforce256", "geforce3"] {
        let tuple = plans_and_renders_its_meaning(TUPLE, target, &scene);
        let scalars = plans_and_renders_its_meaning(SCALARS, target, &scene);
        // Before: `per_vertex` (Gouraud), 18/255 off on 5 % of the pixels.
        assert_eq!(rules(&tuple), rules(&scalars), "{target}");
        assert!(!rules(&tuple).iter().any(|r| r == "per_vertex"), "{target}: {:?}", rules(&tuple));
        assert_eq!(tuple.plan.passes.len(), scalars.plan.passes.len(), "{target}");
        let e = compare(&f32_render(&scalars, SCALARS, &scene), &f32_render(&tuple, TUPLE, &scene));
        assert!(e.max_abs <= 1.0 / 255.0, "{target}: {:.1}/255 from the scalar form", e.max_abs * 255.0);
    }
}

// ---- the framebuffer's clamp ----------------------------------------------

/// `saturate` of a sum written into an 8-bit framebuffer, which clamps it
/// anyway: the sum splits into added passes once the clamp is left there.
#[test]
fn a_clamp_the_framebuffer_applies_anyway_is_left_to_it() {
    let source = "\
texture A : 2d rgb8 = image(\"missing-a.png\");
texture B : 2d rgb8 = image(\"missing-b.png\");
texture D : 2d rgb8 = image(\"missing-d.png\");
C δπx ← saturate(A δu x * B δu x + D δu x * A δu x + B δu x * D δu x);
";
    let scene = scene("kilgard_torus.ron");
    for target in ["geforce256", "multitexture", "wgsl"] {
        let planned = plans_and_renders_its_meaning(source, target, &scene);
        assert!(planned.plan.approximations.is_empty(), "{target}");
    }
}

// ---- the property: the verdict does not depend on how it is written --------

/// A colour of the generated subset, as a tree the expander below reads.
#[derive(Clone, Debug)]
enum Colour {
    /// `T{i} δu x` (rgb8; T3 is rgba8, read `.rgb`).
    Texture(usize),
    /// A constant scalar factor (tenths).
    Number(u8),
    /// `δ lights{mask} s x`: the lights of `mask` summed inside one δ,
    /// scaled by a tenth inside the shader.
    Lights(u8, u8),
    Mul(Box<Colour>, Box<Colour>),
    Add(Box<Colour>, Box<Colour>),
    /// `lerp(a, b, f)` with `f` a constant (tenths) or T3's alpha.
    Lerp(Box<Colour>, Box<Colour>, Option<u8>),
    /// `(δ pair s x).r` (`.g`): a channel of a tuple a shader returns,
    /// interpolated (its light 0 and light 1 terms).
    Channel(u8),
}

/// How the generated colour is written into `C` (after `C δπx ← T4 δu x;`
/// for all but the first): replaced, modulated in by the blend the
/// program writes (GL clamps its source), multiplied in (arithmetic, up
/// to what the colour reaches), added by the blend.
#[derive(Clone, Copy, Debug)]
enum Written {
    Replace,
    Blended,
    Multiplied,
    Added,
}

impl Written {
    fn statement(self, value: &str) -> String {
        match self {
            Written::Replace => format!("C δπx ← {value};\n"),
            Written::Blended => format!("C δπx ← T4 δu x;\nC δπx ← (C δπx) ⊕ ({value});\n"),
            Written::Multiplied => format!("C δπx ← T4 δu x;\nC δπx ← (C δπx) * ({value});\n"),
            Written::Added => format!("C δπx ← T4 δu x;\nC δπx ← (C δπx) ⊕[add] ({value});\n"),
        }
    }
}

fn written_as() -> impl Strategy<Value = Written> {
    prop_oneof![
        5 => Just(Written::Replace),
        1 => Just(Written::Blended),
        1 => Just(Written::Multiplied),
        1 => Just(Written::Added),
    ]
}

const LIGHT_COLOURS: [&str; 3] = ["(0.9, 0.4, 0.3)", "(0.3, 0.9, 0.4)", "(0.4, 0.3, 0.9)"];

fn leaf() -> impl Strategy<Value = Colour> {
    prop_oneof![
        3 => (0usize..6).prop_map(Colour::Texture),
        2 => (1u8..8, 3u8..9).prop_map(|(m, k)| Colour::Lights(m, k)),
        1 => (0u8..2).prop_map(Colour::Channel),
    ]
}

fn colour() -> impl Strategy<Value = Colour> {
    prop_oneof![
        4 => written_freely(),
        1 => nested_lerps(),
    ]
}

/// Any program of the subset, up to three levels deep.
fn written_freely() -> impl Strategy<Value = Colour> {
    leaf().prop_recursive(3, 8, 2, |inner| {
        prop_oneof![
            3 => (inner.clone(), inner.clone()).prop_map(|(a, b)| Colour::Mul(Box::new(a), Box::new(b))),
            // A factor repeated (`a·a`, `a·T·T`): its terms repeat when
            // multiplied out.
            1 => inner.clone().prop_map(|a| Colour::Mul(Box::new(a.clone()), Box::new(a))),
            1 => (inner.clone(), 0usize..4).prop_map(|(a, i)| {
                let t = || Box::new(Colour::Texture(i));
                Colour::Mul(Box::new(Colour::Mul(Box::new(a), t())), t())
            }),
            // A number scales a colour (a sum of numbers folds into one
            // constant, which past 1 no constant register holds).
            // Past 1 too (`4·T0·T1·T2`: scaled in last on a clamped target).
            1 => (prop_oneof![3 => 2u8..10, 1 => prop_oneof![Just(20u8), Just(30), Just(40)]], inner.clone())
                .prop_map(|(k, a)| Colour::Mul(Box::new(Colour::Number(k)), Box::new(a))),
            2 => (inner.clone(), inner.clone()).prop_map(|(a, b)| Colour::Add(Box::new(a), Box::new(b))),
            2 => (inner.clone(), inner, prop::option::of(1u8..10))
                // A lerp of equal operands is its operand: multiplied out, it
                // needs like terms collected ((1 − f) + f = 1), which is not
                // one of the planner's rewrites.
                .prop_filter("a lerp of equal operands", |(a, b, _)| written(a) != written(b))
                .prop_map(|(a, b, f)| Colour::Lerp(Box::new(a), Box::new(b), f)),
        ]
    })
}

/// The class of issue 34's counterexample, which the free generator
/// reaches rarely: `lerp(lerp(δ lights, T, f), δ lights′, g)·Tⱼⁿ`, lerps
/// nested (either side), sums of lights inside δ, a factor repeated up to
/// three times.
fn nested_lerps() -> impl Strategy<Value = Colour> {
    let lights = || (1u8..8, 3u8..9).prop_map(|(m, k)| Colour::Lights(m, k));
    let amount = || prop::option::of(1u8..10);
    (lights(), 0usize..4, amount(), lights(), amount(), any::<bool>(), 0usize..4, 1usize..4).prop_map(
        |(l, i, f, l2, g, inside_first, j, n)| {
            let inner = Colour::Lerp(Box::new(l), Box::new(Colour::Texture(i)), f);
            let outer = if inside_first {
                Colour::Lerp(Box::new(inner), Box::new(l2), g)
            } else {
                Colour::Lerp(Box::new(l2), Box::new(inner), g)
            };
            (0..n).fold(outer, |c, _| Colour::Mul(Box::new(c), Box::new(Colour::Texture(j))))
        },
    )
}

fn tenth(k: u8) -> String {
    format!("{:.1}", k as f64 / 10.0)
}

fn texture(i: usize) -> String {
    if i == 3 {
        "(T3 δu x).rgb".into()
    } else {
        format!("T{i} δu x")
    }
}

/// The source text of `c`, as written.
fn written(c: &Colour) -> String {
    match c {
        Colour::Texture(i) => texture(*i),
        Colour::Number(k) => tenth(*k),
        Colour::Lights(mask, k) => format!("δ lights{mask}_{k} s x"),
        Colour::Channel(ch) => format!("(δ pair s x).{}", if *ch == 0 { 'r' } else { 'g' }),
        Colour::Mul(a, b) => format!("({} * {})", written(a), written(b)),
        Colour::Add(a, b) => format!("({} + {})", written(a), written(b)),
        // `mix` is `lerp` (GLSL's name): spelled so when the amount is
        // T3's alpha, so that both spellings are generated.
        Colour::Lerp(a, b, f) => {
            let name = if f.is_none() { "mix" } else { "lerp" };
            format!("{name}({}, {}, {})", written(a), written(b), factor(*f))
        }
    }
}

fn factor(f: Option<u8>) -> String {
    f.map_or("(T3 δu x).a".into(), tenth)
}

/// `c` multiplied out: its terms, each a list of factors (source text),
/// independent of the planner — lerps as `a·(1 − f) + b·f`, a sum of
/// lights inside δ as one δ per light (interpolation is linear).
fn expand(c: &Colour) -> Vec<Vec<String>> {
    match c {
        Colour::Texture(_) | Colour::Number(_) | Colour::Channel(_) => vec![vec![written(c)]],
        Colour::Lights(mask, k) => (0..3)
            .filter(|l| mask & (1 << l) != 0)
            .map(|l| vec![tenth(*k), format!("δ light{l} s x")])
            .collect(),
        Colour::Mul(a, b) => {
            let (a, b) = (expand(a), expand(b));
            a.iter().flat_map(|x| b.iter().map(move |y| [x.clone(), y.clone()].concat())).collect()
        }
        Colour::Add(a, b) => [expand(a), expand(b)].concat(),
        Colour::Lerp(a, b, f) => {
            let f = factor(*f);
            let keep = format!("(1 - {f})");
            let mut out: Vec<Vec<String>> =
                expand(a).into_iter().map(|t| [t, vec![keep.clone()]].concat()).collect();
            out.extend(expand(b).into_iter().map(|t| [t, vec![f.clone()]].concat()));
            out
        }
    }
}

fn expanded(c: &Colour) -> String {
    expand(c).iter().map(|t| t.join(" * ")).collect::<Vec<_>>().join(" + ")
}

/// The declarations every generated program shares: four textures, three
/// lights, one shader per light and one per (set of lights, scale).
fn declarations(c: &Colour) -> String {
    let mut s = String::from("vector N : normal;\n");
    for l in 0..3 {
        s += &format!("vector L{l} : light({l});\n");
    }
    for i in 0..3 {
        s += &format!("texture T{i} : 2d rgb8 = image(\"missing-t{i}.png\");\n");
    }
    s += "texture T3 : 2d rgba8 = image(\"missing-t3.png\");\n";
    for i in 4..6 {
        s += &format!("texture T{i} : 2d rgb8 = image(\"missing-t{i}.png\");\n");
    }
    s += "shader pair : s → c = (0.8 * max(0, N·L0), 0.6 * max(0, N·L1), 0);\n";
    for (l, c) in LIGHT_COLOURS.iter().enumerate() {
        s += &format!("shader light{l} : s → c = {c} * max(0, N·L{l});\n");
    }
    let mut used = Vec::new();
    collect_lights(c, &mut used);
    used.sort();
    used.dedup();
    for (mask, k) in used {
        let terms: Vec<String> = (0..3)
            .filter(|l| mask & (1 << l) != 0)
            .map(|l| format!("{} * max(0, N·L{l})", LIGHT_COLOURS[l]))
            .collect();
        s += &format!("shader lights{mask}_{k} : s → c = {} * ({});\n", tenth(k), terms.join(" + "));
    }
    s
}

fn collect_lights(c: &Colour, out: &mut Vec<(u8, u8)>) {
    match c {
        Colour::Lights(m, k) => out.push((*m, *k)),
        Colour::Mul(a, b) | Colour::Add(a, b) | Colour::Lerp(a, b, _) => {
            collect_lights(a, out);
            collect_lights(b, out);
        }
        _ => {}
    }
}

/// The planner's verdict on a program: planned exactly, planned with an
/// approximation (a per-vertex fall-back, a table), or refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Verdict {
    Exact,
    Approximate,
    Refused,
}

fn fine_verdict(source: &str, target: &str) -> Verdict {
    match compile(source, target) {
        Ok(planned) => {
            let profile = Profile::builtin(target).unwrap();
            crate::differential::validate_plan(&planned, &profile)
                .unwrap_or_else(|e| panic!("an accepted plan {target} cannot run: {e}\n{source}"));
            if planned.plan.approximations.is_empty() {
                Verdict::Exact
            } else {
                Verdict::Approximate
            }
        }
        Err(_) => Verdict::Refused,
    }
}

/// Whether the program plans on `target` (exactly or not).
fn verdict(source: &str, target: &str) -> bool {
    fine_verdict(source, target) != Verdict::Refused
}

/// With `SHADEC_ALGEBRA_DUMP=DIR`, each generated program and its
/// expansion written to `DIR/NNNNN_w.shd` and `DIR/NNNNN_m.shd`, and the
/// verdicts of `driver::compile` on them to `DIR/verdicts.txt` (`NNNNN
/// target as-written multiplied-out`): a debugging aid (`shadec check
/// --target` on them, for one). The program's number.
fn dump(original: &str, multiplied: &str) -> usize {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    let Some(dir) = std::env::var_os("SHADEC_ALGEBRA_DUMP") else { return n };
    let dir = Path::new(&dir);
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join(format!("{n:05}_w.shd")), original).unwrap();
    std::fs::write(dir.join(format!("{n:05}_m.shd")), multiplied).unwrap();
    n
}

fn dump_verdicts(n: usize, target: &str, a: Verdict, b: Verdict) {
    use std::io::Write as _;
    let Some(dir) = std::env::var_os("SHADEC_ALGEBRA_DUMP") else { return };
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(Path::new(&dir).join("verdicts.txt"))
        .unwrap();
    writeln!(f, "{n:05} {target} {a:?} {b:?}").unwrap();
}

fn cases() -> u32 {
    // 1 500 in CI: under a minute and a half in a debug build on two busy
    // cores. Run to 5 000 with `SHADEC_ALGEBRA_CASES=5000`
    // (docs/pass-plan.md lists what it finds).
    std::env::var("SHADEC_ALGEBRA_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(1500)
}

/// The property's seed (every byte of it): 34 in CI, another with
/// `SHADEC_ALGEBRA_SEED=N` (0 to 255), other programs.
fn seed() -> u8 {
    std::env::var("SHADEC_ALGEBRA_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(34)
}

#[test]
fn the_verdict_on_a_program_is_its_verdict_multiplied_out() {
    let config = Config { cases: cases(), failure_persistence: None, ..Config::default() };
    // A fixed seed: the same programs in CI every time.
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[seed(); 32]);
    let mut runner = TestRunner::new_with_rng(config, rng);
    let counts = std::cell::RefCell::new([[0usize; 2]; 4]);
    let result = runner.run(&(colour(), written_as()), |(c, how)| {
        let terms = expand(&c);
        if terms.len() > 12 {
            return Ok(()); // past what the planner multiplies out (`algebra::MAX_TERMS`)
        }
        // Lighting modulates textures; a product of two lightings (two
        // interpolated colours per term, after expansion three or more
        // where the written form merged them inside one δ) needs δ sums
        // merged back, δa + δb = δ(a + b), which the planner does not try.
        if terms.iter().any(|t| t.iter().filter(|f| f.contains("δ ")).count() > 1) {
            return Ok(());
        }
        let decls = declarations(&c);
        let original = format!("{decls}{}", how.statement(&written(&c)));
        let multiplied = format!("{decls}{}", how.statement(&expanded(&c)));
        let n = dump(&original, &multiplied);
        for (i, target) in TARGETS.iter().enumerate() {
            let (a, b) = (fine_verdict(&original, target), fine_verdict(&multiplied, target));
            dump_verdicts(n, target, a, b);
            if a != b && std::env::var_os("SHADEC_ALGEBRA_LIST").is_some() {
                // Every counterexample listed, none shrunk: a debugging aid.
                let kind = match (a, b) {
                    (Verdict::Refused, _) | (_, Verdict::Refused) => "COUNTEREXAMPLE",
                    _ => "APPROXIMATION",
                };
                eprintln!("{kind} {target} {how:?} as written {a:?}, multiplied out {b:?}: {c:?}");
                continue;
            }
            // The finer verdict: a form that plans exactly is found
            // whichever way the program is written, and an approximation
            // is taken on both or on neither.
            prop_assert_eq!(
                a,
                b,
                "{}: as written {:?}, multiplied out {:?}\n{}\n{}",
                target,
                a,
                b,
                original,
                multiplied
            );
            let mut counts = counts.borrow_mut();
            counts[i][0] += (a == Verdict::Exact) as usize;
            counts[i][1] += (a == Verdict::Approximate) as usize;
        }
        Ok(())
    });
    if let Err(e) = result {
        panic!("{e}");
    }
    let counts = counts.into_inner();
    eprintln!(
        "[exact, approximate] per target {TARGETS:?}: {counts:?} of {} programs (seed {})",
        cases(),
        seed()
    );
    // The property must not hold by everything being refused, nor by
    // everything being approximated.
    let planned: Vec<usize> = counts.iter().map(|c| c[0] + c[1]).collect();
    assert!(planned[0] > 0 && planned[1] > 0, "{planned:?}");
    assert!(counts.iter().all(|c| c[0] > 0), "{counts:?}");
}

/// The generator reaches issue 34's class on every run: a lerp nested in
/// a lerp, under a product, with a repeated factor and a sum of lights
/// inside δ.
#[test]
fn the_algebra_generator_writes_nested_lerps_over_repeated_factors() {
    let mut runner = TestRunner::deterministic();
    let mut class = 0;
    for _ in 0..64 {
        let text = written(&colour().new_tree(&mut runner).unwrap().current());
        let nested = ["lerp(lerp(", "mix(lerp(", "lerp(mix(", "mix(mix(", ", lerp(", ", mix("]
            .iter()
            .any(|p| text.contains(p));
        let repeated = (0..4).any(|i| text.matches(&format!("T{i} δu x")).count() > 1);
        class += (nested && repeated && text.contains("δ lights")) as usize;
    }
    assert!(class >= 8, "{class}");
}

/// The generator reaches the forms the algebra handles since the
/// thirteenth session on every run: constant scales past 1, tuples read
/// by channel, and the statement written as a blend, a product or an add
/// onto what `C` holds (sums of several-pass terms through temporaries).
#[test]
fn the_algebra_generator_writes_scales_channels_and_blends() {
    let mut runner = TestRunner::deterministic();
    let (mut scaled, mut channels, mut onto) = (0, 0, 0);
    for _ in 0..128 {
        let (c, how) = (colour(), written_as()).new_tree(&mut runner).unwrap().current();
        let text = written(&c);
        scaled += ["(2.0 *", "(3.0 *", "(4.0 *"].iter().any(|k| text.contains(k)) as usize;
        channels += text.contains("δ pair s x") as usize;
        onto += !matches!(how, Written::Replace) as usize;
    }
    assert!(scaled >= 2 && channels >= 8 && onto >= 24, "{scaled} {channels} {onto}");
}

/// The generator reaches products over sums and lerps on every run.
#[test]
fn the_algebra_generator_writes_products_over_sums() {
    let mut runner = TestRunner::deterministic();
    let mut distributed = 0;
    for _ in 0..32 {
        let c = colour().new_tree(&mut runner).unwrap().current();
        distributed += (expand(&c).len() > 1 && written(&c).contains('*')) as usize;
    }
    assert!(distributed >= 8, "{distributed}");
}

/// The property test's counterexample at 2 000 cases:
/// `(T0·T2 + T1)·lerp(δl, T0, a)` multiplied out is a sum of four products
/// whose selectors `T0·T2` and `T1` share no single factor, so factoring by
/// one shared factor did not find the written form again and the verdicts
/// differed. Grouping the terms by a product (`algebra::product_by_groups`)
/// does.
#[test]
fn a_sum_grouped_by_a_product_is_factored_back() {
    let t = |i| Box::new(Colour::Texture(i));
    for f in [None, Some(3)] {
        let lerp = Colour::Lerp(Box::new(Colour::Lights(1, 5)), t(0), f);
        let c = Colour::Mul(Box::new(Colour::Add(Box::new(Colour::Mul(t(0), t(2))), t(1))), Box::new(lerp));
        let decls = declarations(&c);
        let original = format!("{decls}{}", Written::Replace.statement(&written(&c)));
        let multiplied = format!("{decls}{}", Written::Replace.statement(&expanded(&c)));
        for target in TARGETS {
            let (a, b) = (verdict(&original, target), verdict(&multiplied, target));
            assert_eq!(a, b, "{target}: as written {a}, multiplied out {b}\n{original}\n{multiplied}");
        }
    }
}

fn mul(a: Colour, b: Colour) -> Colour {
    Colour::Mul(Box::new(a), Box::new(b))
}

fn lerp(a: Colour, b: Colour, f: Option<u8>) -> Colour {
    Colour::Lerp(Box::new(a), Box::new(b), f)
}

/// `lerp(lerp(δ lights, T0, 0.4), δ lights′, T3.a)·T1·T1·T1`: nested
/// lerps over a product of a repeated factor, with sums of lights inside
/// δ. Refused before on geforce256 ("a part that cannot be divided
/// further needs 3 texture units") while its expansion by hand planned:
/// multiplied out, the outer lerp's `1 − 0.4` came after the δ, so it
/// stayed a constant of its own — a third general combiner in every term
/// of the first light — instead of going into the interpolant as a
/// constant before the δ did.
#[test]
fn nested_lerps_over_a_repeated_factor_plan_like_their_expansion() {
    let scene = scene("adaptive_sphere_4lights.ron");
    for (first, second) in [((1, 3), (7, 8)), ((3, 8), (3, 8)), ((7, 8), (1, 3))] {
        let inner = lerp(Colour::Lights(first.0, first.1), Colour::Texture(0), Some(4));
        let outer = lerp(inner, Colour::Lights(second.0, second.1), None);
        let c = mul(mul(mul(outer, Colour::Texture(1)), Colour::Texture(1)), Colour::Texture(1));
        let decls = declarations(&c);
        let original = format!("{decls}{}", Written::Replace.statement(&written(&c)));
        let multiplied = format!("{decls}{}", Written::Replace.statement(&expanded(&c)));
        let by_hand = plans_and_renders_its_meaning(&multiplied, "geforce256", &scene);
        let planned = plans_and_renders_its_meaning(&original, "geforce256", &scene);
        assert!(planned.plan.approximations.is_empty(), "{original}");
        assert!(
            planned.plan.passes.len() <= by_hand.plan.passes.len(),
            "{} passes, by hand {}\n{original}",
            planned.plan.passes.len(),
            by_hand.plan.passes.len()
        );
        for target in TARGETS {
            let (a, b) = (verdict(&original, target), verdict(&multiplied, target));
            assert_eq!(a, b, "{target}: as written {a}, multiplied out {b}\n{original}\n{multiplied}");
        }
    }
}

/// `(T0·T1 + T2·T3)²`: the sum reaches 2, so rendering it and modulating
/// by it again stores it clamped at 1 (refused before, saying that a part
/// "needs 4 texture units"). Multiplied out with like terms collected it
/// is `(T0·T1)² + 2·T0·T1·T2·T3 + (T2·T3)²`, exact through the 8-bit
/// clamps: `T2·T3` rendered, modulated by `T0·T1` doubled (2× modulate),
/// the squares added.
#[test]
fn the_square_of_a_sum_of_products_plans_exactly_multiplied_out() {
    let scene = scene("kilgard_torus.ron");
    let s = "(T0 δu x * T1 δu x + T2 δu x * (T3 δu x).rgb)";
    let source = format!("{}C δπx ← {s} * {s};\n", SQUARE_DECLARATIONS);
    for target in TARGETS {
        let planned = plans_and_renders_its_meaning(&source, target, &scene);
        assert!(planned.plan.approximations.is_empty(), "{target}");
    }
    let planned = compile(&source, "geforce256").unwrap();
    assert_eq!(planned.plan.passes.len(), 4, "{}", reasons(&planned));
    assert!(reasons(&planned).contains("multiplied out"), "{}", reasons(&planned));
    assert!(reasons(&planned).contains("2× modulate"), "{}", reasons(&planned));
}

const SQUARE_DECLARATIONS: &str = "\
texture T0 : 2d rgb8 = image(\"missing-t0.png\");
texture T1 : 2d rgb8 = image(\"missing-t1.png\");
texture T2 : 2d rgb8 = image(\"missing-t2.png\");
texture T3 : 2d rgba8 = image(\"missing-t3.png\");
";

/// `(T0·T1 + T2·T3)³` was refused on geforce256 "for the clamps": multiplied
/// out, its cross terms `3·T0²·T1²·T2·T3` reach 3, which no modulation
/// blends exactly — but the hardware adds them exactly: each product is
/// rendered into an 8-bit temporary (it stays in [0, 1]) and three times
/// its lookup added, the add's source clamped as the sum's is. The refusal was
/// untrue; it plans, and renders the program's meaning.
#[test]
fn the_cube_of_a_sum_of_products_plans_through_temporaries() {
    let scene = scene("kilgard_torus.ron");
    let s = "(T0 δu x * T1 δu x + T2 δu x * (T3 δu x).rgb)";
    let source = format!("{}C δπx ← {s} * {s} * {s};\n", SQUARE_DECLARATIONS);
    for target in TARGETS {
        let planned = plans_and_renders_its_meaning(&source, target, &scene);
        assert!(planned.plan.approximations.is_empty(), "{target}");
    }
    let planned = compile(&source, "geforce256").unwrap();
    assert!(reasons(&planned).contains("temporary"), "{}", reasons(&planned));
}

/// The widened generator's first finding: `mix(δ l₇, mix(δ l₄, T3, a), a)·T1³`
/// plans as written (each light sum fits an interpolant), but multiplied
/// out, one δ per light, it was refused on geforce256 — factoring found
/// the shared factors again but not `δl0 + δl1 + δl2` = `δ(l0 + l1 + l2)`.
/// Interpolants summed are merged back into one δ where the sum stays in
/// [0, 1] (`algebra::delta_sums_merged`).
#[test]
fn interpolants_summed_merge_back_into_one_delta() {
    let scene = scene("adaptive_sphere_4lights.ron");
    let inner = lerp(Colour::Lights(4, 3), Colour::Texture(3), None);
    let outer = lerp(Colour::Lights(7, 3), inner, None);
    let c = mul(mul(mul(outer, Colour::Texture(1)), Colour::Texture(1)), Colour::Texture(1));
    let decls = declarations(&c);
    let original = format!("{decls}C δπx ← {};\n", written(&c));
    let multiplied = format!("{decls}C δπx ← {};\n", expanded(&c));
    let planned = plans_and_renders_its_meaning(&multiplied, "geforce256", &scene);
    assert!(reasons(&planned).contains("merged into one δ"), "{}", reasons(&planned));
    for target in TARGETS {
        let (a, b) = (verdict(&original, target), verdict(&multiplied, target));
        assert_eq!(a, b, "{target}: as written {a}, multiplied out {b}\n{original}\n{multiplied}");
    }
}

// ---- the property's counterexamples past its CI count ----------------------

/// `c` written `how`, as written and multiplied out: both plan on
/// `target` (each pass realized), and where `render` both render within
/// the tolerance of the program's meaning.
fn both_plan(c: &Colour, how: Written, target: &str, render: bool) {
    let decls = declarations(c);
    let original = format!("{decls}{}", how.statement(&written(c)));
    let multiplied = format!("{decls}{}", how.statement(&expanded(c)));
    for source in [&original, &multiplied] {
        if render {
            plans_and_renders_its_meaning(source, target, &scene("kilgard_torus.ron"));
        } else {
            assert!(verdict(source, target), "refused on {target}:\n{source}");
        }
    }
}

fn add(a: Colour, b: Colour) -> Colour {
    Colour::Add(Box::new(a), Box::new(b))
}

/// `(T0 + T1)·mix(T0, T1, a)` multiplied out is four products in which
/// `T0` selects three terms: grouped back only around the rest of a term
/// (`algebra::product_by_groups`), and only with `C`, which every term
/// shares, taken out first. Refused multiplied out on geforce3 before.
#[test]
fn a_product_whose_selectors_recur_in_its_cofactors_is_grouped_back() {
    let t = |i| Colour::Texture(i);
    let c = mul(add(t(0), t(1)), lerp(t(0), t(1), None));
    both_plan(&c, Written::Multiplied, "geforce3", true);
}

/// A shader summing three lights, scaled: each channel stays below 1
/// (`0.6·(0.9 + 0.3 + 0.4)` = 0.96) where the hull over the channels
/// gave 1.62 (`ir::valid`'s channel ranges), and a constant that would
/// take an interpolant past 1 stays a combiner's scale. Refused as
/// written on geforce256 before, while multiplied out it planned.
#[test]
fn lights_summed_in_one_shader_are_bounded_channel_by_channel() {
    let t = || Colour::Texture(0);
    let scaled = |c: Colour| mul(Colour::Number(20), c);
    both_plan(&scaled(mul(mul(Colour::Lights(7, 6), t()), t())), Written::Replace, "geforce256", true);
    both_plan(&scaled(mul(Colour::Lights(7, 8), t())), Written::Replace, "geforce256", true);
}

/// `T0 + T0·(1 − a) + δl·a` is `T0 + lerp(T0, δl, a)`, in [0, 2] where its
/// terms' bounds add to more: the pair read back as a lerp
/// (`algebra::lerps_recovered`). Refused multiplied out on geforce256 before.
#[test]
fn a_lerp_among_other_terms_is_read_back_as_a_lerp() {
    let t = || Colour::Texture(0);
    let c = add(t(), lerp(t(), Colour::Lights(1, 3), None));
    both_plan(&c, Written::Multiplied, "geforce256", true);
}

/// `T0⁴·(δg + δg)` multiplied out with like terms collected is
/// `2·T0⁴·δg`, whose partial products leave [0, 1] in a temporary; kept
/// apart, each `T0⁴·δg` fits. Refused as written on geforce256 before.
#[test]
fn like_terms_are_also_kept_apart() {
    let t = || Colour::Texture(0);
    let c = mul(mul(mul(mul(t(), t()), t()), t()), add(Colour::Channel(1), Colour::Channel(1)));
    both_plan(&c, Written::Multiplied, "geforce256", false);
}

/// `C ← T4; C ← C·(T0 + T1)²` fuses into one pass on multitexture; its
/// expansion fuses too once the fused value is tried in its forms
/// (`rewrite::fused_rewritten`), grouped back into `T4·(T0 + T1)²`.
///
/// `(T0 + T1)²` no longer: GL clamps the texture environment's `T0 + T1`
/// to [0, 1] after its stage (seventeenth session), so neither form
/// plans on multitexture. `mix(T0, T1, a)²` stays in [0, 1] throughout:
/// its expansion fuses into one pass as `T4·mix(T0, T1, a)²`.
#[test]
fn statements_fuse_in_an_equivalent_form() {
    let t = |i| Colour::Texture(i);
    let c = mul(lerp(t(0), t(1), None), lerp(t(0), t(1), None));
    both_plan(&c, Written::Multiplied, "multitexture", true);
    let decls = declarations(&c);
    let planned =
        compile(&format!("{decls}{}", Written::Multiplied.statement(&expanded(&c))), "multitexture").unwrap();
    assert_eq!(planned.plan.passes.len(), 1, "{}", reasons(&planned));
    assert!(reasons(&planned).contains("fused"), "{}", reasons(&planned));
    assert!(stage_clamps_change(&planned).is_empty());
    let sum = mul(add(t(0), t(1)), add(t(0), t(1)));
    verdicts_agree(&sum, Written::Multiplied, "multitexture");
}

/// `c` written `how`: the same verdict as written and multiplied out on
/// `target`, and a plan of either computes no stage result the texture
/// environment would clamp.
fn verdicts_agree(c: &Colour, how: Written, target: &str) {
    let decls = declarations(c);
    let original = format!("{decls}{}", how.statement(&written(c)));
    let multiplied = format!("{decls}{}", how.statement(&expanded(c)));
    let (a, b) = (verdict(&original, target), verdict(&multiplied, target));
    assert_eq!(a, b, "{target}: as written {a}, multiplied out {b}\n{original}\n{multiplied}");
    for source in [&original, &multiplied] {
        if let Ok(planned) = compile(source, target) {
            let wide = stage_clamps_change(&planned);
            assert!(target != "multitexture" || wide.is_empty(), "{wide:?}\n{source}");
        }
    }
}

/// `T0 + 0.3·δl0 + (δ pair).r`: the Gouraud rule takes the interpolated
/// terms as one part however the sum is parenthesized
/// (`lowering::per_vertex::gouraud`), as it does for
/// `T0 + (δ lights + (δ pair).r)`. Refused multiplied out on geforce256
/// before; both plan with the measured `per_vertex` approximation.
#[test]
fn gouraud_takes_the_interpolated_terms_of_a_sum_together() {
    let c = add(Colour::Texture(0), add(Colour::Lights(1, 3), Colour::Channel(0)));
    both_plan(&c, Written::Multiplied, "geforce256", false);
}

/// A scalar written into `C` is splatted to rgba: its forms are found
/// under the splat as under `rgb → rgba` (`mix(0.2·g, g + g, a)`, `g` an
/// interpolated channel). Refused as written on geforce3 before.
#[test]
fn a_scalar_statement_is_rewritten_under_its_splat() {
    let g = || Colour::Channel(0);
    let c = lerp(mul(Colour::Number(2), g()), add(g(), g()), None);
    both_plan(&c, Written::Replace, "geforce3", true);
}

/// `lerp(lerp(T0, δl, a), T0, a)` multiplied out has `(1 − a)²` and
/// `a·(1 − a)`: the inner lerp read back with the `(1 − a)` both of its
/// terms share taken out, then the outer one around it. Refused
/// multiplied out on multitexture before.
#[test]
fn lerps_nested_on_one_weight_are_read_back_level_by_level() {
    let t = || Colour::Texture(0);
    let c = lerp(lerp(t(), Colour::Lights(1, 3), None), t(), None);
    both_plan(&c, Written::Multiplied, "multitexture", false);
}

/// `C·(mix(T1, T2, a)·T1·T1·(δ l₀₂·T3 + T2))`: the sum of two lights inside
/// one δ is in [0, 0.91] channel by channel (`0.7·(0.9 + 0.4)` at most),
/// so `δ l₀₂·T3 + T2` stays below 2 and is modulated in halved and
/// doubled. Multiplied out, one δ per light, each light's term was bounded
/// by the hull of its colour (0.63 each, 2.26 with `T2`), past the 2× of
/// a modulation, and refused on geforce3: interpolants sharing a cofactor
/// now merge back into one δ (`δa·X + δb·X` = `δ(a + b)·X`,
/// `algebra::delta_sums_merged`) in the product factored back.
#[test]
fn lights_summed_inside_delta_merge_back_around_a_shared_cofactor() {
    let t = |i| Colour::Texture(i);
    let lit = add(mul(Colour::Lights(5, 7), t(3)), t(2));
    let c = mul(mul(mul(lerp(t(1), t(2), None), t(1)), t(1)), lit);
    both_plan(&c, Written::Multiplied, "geforce3", true);
}

/// `C ⊕[add] 3·mix(T0, (δ pair).r, T3.a)` plans on geforce256 (the add's
/// source clamped by GL as the sum is); its expansion
/// `3·T0·(1 − a) + 3·(δ pair).r·a` was refused there: the lerp read back
/// with the 3 taken out kept the channel of the rgb interpolant, one
/// general combiner more than the scalar interpolant of that channel the
/// written form gets.
#[test]
fn a_constant_past_one_over_a_lerp_added_onto_c_plans_multiplied_out() {
    let c = mul(Colour::Number(30), lerp(Colour::Texture(0), Colour::Channel(0), None));
    both_plan(&c, Written::Added, "geforce256", true);
}

/// `C ⊕ mix(T0, T1, a)²` was refused as written on geforce256 ("needs 3
/// texture units") while its expansion plans: the blend clamps the
/// expansion's source (its terms' bounds add to 4), and an 8-bit
/// temporary holds that clamped sum. The square lies in [0, 1], so it is
/// its own clamp: its multiplied-out form clamped is an equivalent form
/// (`rewrite::own_clamp_forms`), planned the same way.
#[test]
fn a_value_in_unit_range_is_planned_in_its_forms_clamped() {
    let m = || lerp(Colour::Texture(0), Colour::Texture(1), None);
    both_plan(&mul(m(), m()), Written::Blended, "geforce256", true);
}

/// `C ⊕[add] 3·((δ pair).r·T1·T1) + (δ pair).g`: multiplied out,
/// `3·(δ pair).r·T1·T1` computed the 3 first, past the general combiners'
/// [−1, 1] before `T1` brought it down, and was refused on geforce3 where
/// written it plans. A term's constants past 1 are multiplied in last.
#[test]
fn a_scale_past_one_is_multiplied_in_last() {
    let t = |i| Colour::Texture(i);
    let c = add(mul(Colour::Number(30), mul(mul(Colour::Channel(0), t(1)), t(1))), Colour::Channel(1));
    both_plan(&c, Written::Added, "geforce3", true);
}

/// `C ⊕[add] lerp(mix((δ pair).r, T5, a), 0.6·δ l₀ + T4 + T2, 0.8)`
/// planned in 4 passes on geforce256 until a channel of an interpolated
/// tuple was read as its own interpolant in the statement itself (the
/// canonical rewrite), after which neither it nor its expansion planned:
/// the tuple's one interpolant was never tried. That reading is now one
/// more form, beside the statement as written.
#[test]
fn a_channel_read_as_an_interpolant_is_a_form_not_a_rewrite() {
    let t = |i| Colour::Texture(i);
    let inner = lerp(Colour::Channel(0), t(5), None);
    let other = add(mul(Colour::Number(6), Colour::Lights(1, 8)), add(t(4), t(2)));
    both_plan(&lerp(inner, other, Some(8)), Written::Added, "geforce256", true);
}

// ---- the property's counterexamples at 2 000 and 5 000 (sixteenth session) --

/// `C ⊕[add] (T4·2·T0)²` plans on multitexture in one pass (the second
/// stage squares the first's result); multiplied out, `T4·2·T0·T4·2·T0`
/// takes a stage per factor, five with the fused `T4`, and was refused.
/// A product whose factors all repeat is also tried as the square it is
/// (`algebra::squared`), `(T4·T0·2)²`.
///
/// Since the texture environment's clamp after each stage is modelled
/// (seventeenth session), `T4·T0·2` leaves [0, 1] before it is squared,
/// which GL clamps: neither form plans on multitexture, and no plan of
/// either reads a clamped stage result.
#[test]
fn a_product_of_repeated_factors_is_planned_as_its_square() {
    let t = |i| Colour::Texture(i);
    let twice = || mul(t(4), mul(Colour::Number(20), t(0)));
    for target in TARGETS {
        verdicts_agree(&mul(twice(), twice()), Written::Added, target);
    }
}

/// `C·4·lerp((δ p).g, δ l₂ + T1, 0.4)` was refused on geforce256 and
/// multitexture while its expansion `4·(δ p).g·0.6 + 4·0.5·δl₂·0.4 +
/// 4·T1·0.4` planned with the Gouraud fall-back, which took its two
/// interpolated terms as one part. The fall-back reads a lerp and a
/// constant over a sum as their terms (`lowering::per_vertex`), so the
/// written form gives it the same part.
#[test]
fn gouraud_reads_a_lerp_and_a_scale_as_their_terms() {
    let c = mul(
        Colour::Number(40),
        lerp(Colour::Channel(1), add(Colour::Lights(4, 5), Colour::Texture(1)), Some(4)),
    );
    both_plan(&c, Written::Multiplied, "geforce256", false);
    // On multitexture the 4 scales a stage's result, which GL clamps
    // after the stage: as written the Gouraud part plans as `T4·v +
    // 1.6·T4·T1` (a partial sum the output's clamp covers); multiplied
    // out, no form found keeps each stage in [0, 1], and it is refused
    // (docs/pass-plan.md lists it). Neither reads a clamped stage result.
    let decls = declarations(&c);
    for text in [written(&c), expanded(&c)] {
        if let Ok(planned) =
            compile(&format!("{decls}{}", Written::Multiplied.statement(&text)), "multitexture")
        {
            let wide = stage_clamps_change(&planned);
            assert!(wide.is_empty(), "{wide:?}\n{text}");
        }
    }
}

/// `C·T5·(δ l₀₁₂ + (δ p).g)` planned (Gouraud, one part for the sum) on
/// geforce256, geforce3 and multitexture, and its expansion `T5·0.8·δl₀ +
/// T5·0.8·δl₁ + T5·0.8·δl₂ + T5·(δ p).g` did not: each term's
/// interpolants were a part of their own, five interpolants. Terms that
/// share their per-fragment factors (`T5` here) are one part times them.
#[test]
fn gouraud_takes_terms_sharing_a_lookup_as_one_part() {
    let c = mul(Colour::Texture(5), add(Colour::Lights(7, 8), Colour::Channel(1)));
    for target in ["geforce256", "geforce3"] {
        both_plan(&c, Written::Multiplied, target, false);
    }
}

/// `C·(T5·δ l₁₂ + T4 + T3)` with `l₁₂ = 0.8·((0.3, 0.9, 0.4)·d₁ + (0.4,
/// 0.3, 0.9)·d₂)`, which reaches 1.04 in blue: planned on multitexture
/// as written, the interpolant read as if GL did not clamp a vertex
/// colour to [0, 1], while the expansion (each light in [0, 1]) was
/// refused. The texture environment now refuses a colour interpolant
/// that may leave [0, 1], located at it: both forms get one verdict, and
/// the refusal says why.
#[test]
fn a_vertex_colour_past_one_is_not_read_unclamped_on_the_texture_environment() {
    let t = |i| Colour::Texture(i);
    let c = add(mul(t(5), Colour::Lights(6, 8)), add(t(4), t(3)));
    let decls = declarations(&c);
    let original = format!("{decls}{}", Written::Multiplied.statement(&written(&c)));
    let multiplied = format!("{decls}{}", Written::Multiplied.statement(&expanded(&c)));
    assert_eq!(verdict(&original, "multitexture"), verdict(&multiplied, "multitexture"));
    // The light alone, replacing `C`: not planned as written — split
    // across δ (each light in [0, 1]), the reason saying why not as
    // written, or refused, located, saying so.
    let alone = format!("{}C δπx ← δ lights6_8 s x;\n", declarations(&Colour::Lights(6, 8)));
    let why = match compile(&alone, "multitexture") {
        Ok(planned) => reasons(&planned),
        Err(errors) => {
            let d = errors.iter().find(|d| d.is_error()).unwrap();
            assert_ne!(d.primary.span.start, d.primary.span.end, "{d:?}");
            format!("{} {}", d.message, d.primary.message)
        }
    };
    assert!(why.contains("clamps to [0, 1] as a vertex colour"), "{why}");
    // Within [0, 1] it plans as written.
    let dim = format!("{}C δπx ← δ lights6_5 s x;\n", declarations(&Colour::Lights(6, 5)));
    let planned = compile(&dim, "multitexture").unwrap_or_else(|e| panic!("{e:#?}"));
    assert!(reasons(&planned).contains("as written"), "{}", reasons(&planned));
}

// ---- the property's counterexamples at 5 000 (seventeenth session) --------

/// `C·(T0·T3 + mix(δ l₀₂, T3, a))` plans on geforce256 in one 2×
/// modulation (the sum is at most 2); its expansion `T0·T3 + 0.5·δl₀·(1 −
/// a) + 0.5·δl₂·(1 − a) + T3·a` was refused: read back as lerps, one
/// light's term paired with `T3·a` and the other's stayed apart, bounded
/// past 2, and merged into one δ the lights were no longer read back as a
/// lerp. The expansion is now also factored after its interpolants merge
/// around the `(1 − a)` they share.
#[test]
fn lights_merged_around_a_shared_weight_are_read_back_as_a_lerp() {
    let t = |i| Colour::Texture(i);
    let c = add(mul(t(0), t(3)), lerp(Colour::Lights(5, 5), t(3), None));
    both_plan(&c, Written::Multiplied, "geforce256", true);
}

// ---- the texture environment's clamp after each stage -----------------

/// The passes of `planned` whose output the texture environment computes
/// otherwise than the plan's IR means: GL clamps each stage's result to
/// [0, 1] (OpenGL 1.3, Section 3.8.13) and the framebuffer clamps the
/// pass's, so a pass is exact when, at every sample, its output with every
/// per-fragment operation's result clamped equals its output clamped once.
/// Checked by evaluating each pass (`ir::eval::apply`, the IR's one
/// semantics) at samples of its leaves — each lane at either end of the
/// leaf's range or between, from a fixed seed — both ways; independent of
/// the planner's own rule for which stage results may leave [0, 1]
/// (`planner::fit`). A pass whose clamps change its value, with the sample.
fn stage_clamps_change(planned: &Planned) -> Vec<String> {
    use shadec::ir::eval::{apply, canonical, value, Value};
    use shadec::ir::{Expr, Handle};
    let m = &planned.module;
    let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let clamp = |v: Value| v.map(|x| x.clamp(0.0, 1.0));
    let mut out = Vec::new();
    for (n, p) in planned.plan.passes.iter().enumerate() {
        let root = Handle::new(p.fragment.output as usize);
        let nodes = m.reachable(&[root]);
        for sample in 0..256 {
            let mut exact: Vec<Option<Value>> = vec![None; m.exprs.len()];
            let mut staged: Vec<Option<Value>> = vec![None; m.exprs.len()];
            for &h in &nodes {
                let e = &m.exprs[h];
                let info = m.info(h);
                if shadec::ir::eval::is_computation(e) {
                    let operands = |vals: &Vec<Option<Value>>| -> Vec<Value> {
                        e.operands().iter().map(|o| vals[o.index()].unwrap_or([f64::NAN; 4])).collect()
                    };
                    let a = apply(m, e, info.ty, &operands(&exact));
                    let mut b = apply(m, e, info.ty, &operands(&staged));
                    let stage = matches!(
                        e,
                        Expr::Binary { .. } | Expr::Combine { .. } | Expr::Math { .. } | Expr::Unary { .. }
                    );
                    if stage && info.freq.is_sample() {
                        b = clamp(b);
                    }
                    exact[h.index()] = Some(a);
                    staged[h.index()] = Some(b);
                    continue;
                }
                let v = match e {
                    Expr::Constant(c) => value(c),
                    _ => {
                        // A leaf: each lane at one end of its range or
                        // between (the first samples all at one end).
                        let (lo, hi) = (info.interval.lo.max(-4.0), info.interval.hi.min(4.0));
                        let mut lane = || match (sample, next() % 3) {
                            (0, _) | (_, 0) => lo,
                            (1, _) | (_, 1) => hi,
                            _ => lo + (hi - lo) * (next() % 1024) as f64 / 1023.0,
                        };
                        canonical(info.ty, [lane(), lane(), lane(), lane()])
                    }
                };
                exact[h.index()] = Some(v);
                staged[h.index()] = Some(v);
            }
            let (a, b) = (exact[root.index()].unwrap(), staged[root.index()].unwrap());
            let (a, b) = (clamp(a), clamp(b));
            if a.iter().zip(&b).any(|(x, y)| (x - y).abs() > 1e-6) {
                out.push(format!("pass {}: {a:?} clamped once, {b:?} clamped at each stage", n + 1));
                break;
            }
        }
    }
    out
}

/// The check above is not vacuous: `0.5·((T0 + T1)·T2)` planned for
/// wgsl, one pass whose partial sum reaches 2 before the 0.5 brings it
/// down, is found to change under the texture environment's clamps; a
/// product that stays in [0, 1] is not.
#[test]
fn the_stage_clamp_check_finds_a_partial_sum_past_one() {
    let t = |i| Colour::Texture(i);
    let plan = |c: &Colour| {
        let source = format!("{}{}", declarations(c), Written::Replace.statement(&written(c)));
        compile(&source, "wgsl").unwrap()
    };
    let wide = plan(&mul(Colour::Number(5), mul(add(t(0), t(1)), t(2))));
    assert_eq!(wide.plan.passes.len(), 1, "{}", reasons(&wide));
    assert!(!stage_clamps_change(&wide).is_empty(), "{}", reasons(&wide));
    let dim = plan(&mul(Colour::Number(5), mul(mul(t(0), t(1)), t(2))));
    assert!(stage_clamps_change(&dim).is_empty(), "{}", reasons(&dim));
}

/// `C ← T4; C ← C·(T5·δ l₁₂ + T4 + T3)` was planned on multitexture as
/// one pass of stages computing `T4·(T5·δl + T4 + T3)`, whose partial sum
/// reaches 3: GL clamps each stage's result to [0, 1], so the pass
/// computed `T4·min(1, …)`. The fit now refuses a value whose
/// intermediate results leave [0, 1] on the texture environment
/// (`planner::fit`): the statement is split where the clamps do not
/// change it, or refused, located, saying so.
#[test]
fn the_texture_environment_clamps_after_each_stage() {
    let t = |i| Colour::Texture(i);
    let c = add(mul(t(5), Colour::Lights(6, 5)), add(t(4), t(3)));
    let decls = declarations(&c);
    let source = format!("{decls}{}", Written::Multiplied.statement(&written(&c)));
    match compile(&source, "multitexture") {
        Ok(planned) => {
            let wide = stage_clamps_change(&planned);
            assert!(wide.is_empty(), "{wide:?}\n{}", reasons(&planned));
            plans_and_renders_its_meaning(&source, "multitexture", &scene("kilgard_torus.ron"));
        }
        Err(errors) => {
            let d = errors.iter().find(|d| d.is_error()).unwrap();
            assert_ne!(d.primary.span.start, d.primary.span.end, "{d:?}");
            let text = format!("{} {} {:?}", d.message, d.primary.message, d.help);
            assert!(text.contains("clamp"), "{text}");
        }
    }
    // A sum that stays in [0, 1] is one pass still.
    let dim = mul(t(5), Colour::Lights(6, 5));
    let source = format!("{}{}", declarations(&dim), Written::Multiplied.statement(&written(&dim)));
    let planned = compile(&source, "multitexture").unwrap_or_else(|e| panic!("{e:#?}"));
    assert_eq!(planned.plan.passes.len(), 1, "{}", reasons(&planned));
    assert!(stage_clamps_change(&planned).is_empty());
}

// ---- the property's counterexamples at 5 000 (eighteenth session) ---------

/// `C·(T1·(δ l₂ + T5²))` on multitexture: multiplied out,
/// `T1·δl₂ + T1·T5²` reaches 1.36 and fits one pass of four stages, but
/// its half does not (a fifth stage), so the 2× modulation that applies a
/// factor past 1 exactly had no pass, and the statement was refused where
/// its expansion written by hand planned. A factor that fits but whose
/// half does not is now split like one that does not fit: its terms
/// halved into a temporary, modulated in 2×.
#[test]
fn a_factor_past_one_whose_half_does_not_fit_goes_through_a_temporary() {
    let t = |i| Colour::Texture(i);
    let c = mul(t(1), add(Colour::Lights(4, 4), mul(t(5), t(5))));
    both_plan(&c, Written::Multiplied, "multitexture", false);
    verdicts_agree(&c, Written::Multiplied, "multitexture");
}

/// `C·lerp(T0 + T0, T4, 0.9)` multiplied out, `0.2·T0 + 0.9·T4` (up to
/// 1.1): its half was `(0.2·T0 + 0.9·T4)·½`, whose sum the texture
/// environment clamps at its stage before the ½; halved term by term,
/// `0.1·T0 + 0.45·T4`, it fits. Refused multiplied out before.
#[test]
fn a_sum_is_halved_term_by_term() {
    let t = |i| Colour::Texture(i);
    let c = lerp(add(t(0), t(0)), t(4), Some(9));
    both_plan(&c, Written::Multiplied, "multitexture", false);
    verdicts_agree(&c, Written::Multiplied, "multitexture");
}

/// `C·2·(T2 + (δ pair).g)` multiplied out reads `δ(1.2·p.g)` per vertex,
/// in [0, 1.2]: on the texture environment a scalar interpolant is a
/// vertex colour's channel, which GL clamps to [0, 1] (OpenGL 1.2.1,
/// Section 2.13.9), as it clamps an rgb one. It planned (as `min(1, …)`)
/// multiplied out while written it was refused; then both were refused,
/// for what the hardware does. With the hardware's scale 4 taken out
/// (`algebra::factored::scales_taken_out`) the interpolant is
/// `δ(0.5·p.g)`, within [0, 1], and both plan, rendering the meaning.
#[test]
fn a_scalar_interpolant_past_one_is_a_clamped_vertex_colour_on_the_texture_environment() {
    let c = mul(Colour::Number(20), add(Colour::Texture(2), Colour::Channel(1)));
    verdicts_agree(&c, Written::Multiplied, "multitexture");
    let decls = declarations(&c);
    let scene = scene("kilgard_torus.ron");
    for text in [written(&c), expanded(&c)] {
        let source = format!("{decls}{}", Written::Multiplied.statement(&text));
        plans_and_renders_its_meaning(&source, "multitexture", &scene);
    }
}

/// `C ⊕ lerp(lerp(T3, δ l₀₁₂, 0.1), T5, 0.6)`: the blend's source is
/// `saturate(rgba(x, 1))`, and the texture environment's clamp of `x`'s
/// partial sums of terms ≥ 0 is that saturate's; only the widening's
/// operand was exempt, so multiplied out it was refused, and written it
/// planned only with a per-vertex approximation.
#[test]
fn a_clamped_source_exempts_the_partial_sums_under_it() {
    let c = lerp(lerp(Colour::Texture(3), Colour::Lights(7, 7), Some(1)), Colour::Texture(5), Some(6));
    both_plan(&c, Written::Blended, "multitexture", false);
    verdicts_agree(&c, Written::Blended, "multitexture");
}

/// `C·mix(T5, lerp(T2, δ l₀₁₂, 0.6)·T0, a)` on geforce256: multiplied
/// out, the three lights merge back into `δ(0.36·(l₀ + l₁ + l₂))`, at most
/// 0.58 in each channel, but a constant colour below the channel walk's
/// depth counted as its hull, 0.97, and `0.4·T2` beside it passed 1. A
/// constant's channels are now known at any depth (`ir::valid`).
#[test]
fn a_constant_colour_s_channels_are_known_at_any_depth() {
    let t = |i| Colour::Texture(i);
    let c = lerp(t(5), mul(lerp(t(2), Colour::Lights(7, 6), Some(6)), t(0)), None);
    both_plan(&c, Written::Multiplied, "geforce256", true);
}

/// `C ⊕ lerp(lerp(δ l₀₁₂, T2, 0.3), δ l₀₂, 0.3)·T2²` on multitexture: the
/// same, on the texture environment (its merged interpolant in [0, 0.71]).
#[test]
fn merged_lights_are_bounded_channel_by_channel_on_the_texture_environment() {
    let t = |i| Colour::Texture(i);
    let inner = lerp(lerp(Colour::Lights(7, 6), t(2), Some(3)), Colour::Lights(5, 6), Some(3));
    both_plan(&mul(mul(inner, t(2)), t(2)), Written::Blended, "multitexture", false);
}

/// `C·4·lerp((δ pair).g, δ l₂ + T1, 0.4)` multiplied out: `4·T1·0.4` took
/// two stages where `1.6·T1` takes one, and with the fused `T4` the pass
/// needed five. A term's constants left outside its δ are folded into one.
#[test]
fn a_term_s_constants_are_folded_into_one() {
    let c = mul(
        Colour::Number(40),
        lerp(Colour::Channel(1), add(Colour::Lights(4, 5), Colour::Texture(1)), Some(4)),
    );
    both_plan(&c, Written::Multiplied, "multitexture", false);
}

/// `C·2·mix(T0, mix(δ l₂, T5, a), a)` multiplied out: `2·T0·(1 − a) +
/// 1.2·δl₂·(1 − a)·a + 2·T5·a²`, whose 1.2 cannot go into the δ (1.08)
/// and whose lerps read back with their scales inside leave [0, 1]
/// mid-product. With the greatest coefficient taken out and applied last
/// (`algebra::scale_taken_out`), the 0.6 left goes into the δ and the
/// lerps read back as written. Refused multiplied out before.
#[test]
fn a_constant_scale_is_taken_out_of_a_sum_and_applied_last() {
    let c = mul(
        Colour::Number(20),
        lerp(Colour::Texture(0), lerp(Colour::Lights(4, 6), Colour::Texture(5), None), None),
    );
    both_plan(&c, Written::Multiplied, "multitexture", false);
    verdicts_agree(&c, Written::Multiplied, "multitexture");
}

/// `C·(4·lerp(T4, T3, 0.7))` multiplied out, `1.2·T4 + 2.8·T3`: its
/// greatest coefficient taken out leaves `0.43·T4 + T3`, up to 1.43, which
/// no lerp reads back, so the verdict depended on how the program was
/// written. The hardware's scale 4, or the coefficients' sum (the same
/// here), leaves `0.3·T4 + 0.7·T3`, the lerp as written
/// (`algebra::factored::scales_taken_out`). Found at 5 000 cases, seed 7.
#[test]
fn a_hardware_scale_is_taken_out_of_a_sum_when_the_greatest_coefficient_is_not_one() {
    let c = mul(Colour::Number(40), lerp(Colour::Texture(4), Colour::Texture(3), Some(7)));
    fine_verdicts_agree(&c, Written::Multiplied);
}

/// Lights inside δ scaled past 1, `C·(3·δ(0.4·(l₀ + l₂))·T4)`: multiplied
/// out each light's coefficient is 1.2, and with it taken out the lights
/// merge back into one δ up to 1.3 (green), past what an 8-bit
/// interpolant holds, so multitexture fell back per vertex where the
/// program as written is exact. With 2 taken out (a hardware scale) the
/// merged δ is `δ(0.6·(l₀ + l₂))`, within [0, 1]. So too
/// `C·(2·δ(0.7·(l₀ + l₁))·T3³)`, and `C·(0.8·4·δ(0.6·(l₀ + l₁)))` and
/// `C·(4·δ(0.6·(l₀ + l₁))·T3)` (4, or the coefficients' sum). Found at
/// 5 000 cases, seeds 7, 1 and 200.
#[test]
fn a_hardware_scale_taken_out_leaves_the_lights_merged_in_one_interpolant() {
    let t3 = || Colour::Texture(3);
    for c in [
        mul(Colour::Number(30), mul(Colour::Lights(5, 4), Colour::Texture(4))),
        mul(mul(Colour::Number(20), Colour::Lights(3, 7)), mul(mul(t3(), t3()), t3())),
        mul(Colour::Number(8), mul(Colour::Number(40), Colour::Lights(3, 6))),
        mul(Colour::Number(40), mul(Colour::Lights(3, 6), t3())),
    ] {
        fine_verdicts_agree(&c, Written::Multiplied);
    }
}

/// `c` written `how` gets the same finer verdict (exact, approximated,
/// refused) as written and multiplied out on every target.
fn fine_verdicts_agree(c: &Colour, how: Written) {
    let decls = declarations(c);
    let original = format!("{decls}{}", how.statement(&written(c)));
    let multiplied = format!("{decls}{}", how.statement(&expanded(c)));
    for target in TARGETS {
        let (a, b) = (fine_verdict(&original, target), fine_verdict(&multiplied, target));
        assert_eq!(a, b, "{target}: as written {a:?}, multiplied out {b:?}\n{original}\n{multiplied}");
    }
}

/// `exposure·tint·(2·Det)·δp`, a held-out program's statement with its
/// exposure declared a colour: on multitexture `2·Det` leaves [0, 1] at
/// its own stage, which the texture environment clamps, so it took two
/// passes (the product, then a 2× modulation). The scale applied by the
/// pass's last stage instead (ARB_texture_env_combine's RGB_SCALE, applied
/// before the stage's clamp) is exact: the framebuffer's clamp of
/// `2·x` is the meaning's, min(1, 2·x). One pass, rendering its meaning.
#[test]
fn a_constant_scale_mid_product_is_applied_by_the_last_stage() {
    let source = "vector N : normal;\nvector L : light;\nuniform tint : rgb = (1.0, 0.85, 0.7);\n\
                  uniform exposure : c = 0.8;\ntexture Det : 2d rgb8 = image(\"missing-det.png\");\n\
                  shader p : s → c = max(0, N·L);\nC δπx ← exposure * tint * (2 * Det δu x) * δ p s x;\n";
    let planned = plans_and_renders_its_meaning(source, "multitexture", &scene("kilgard_torus.ron"));
    assert_eq!(planned.plan.passes.len(), 1, "{}", reasons(&planned));
}

/// The one pass of the plan above came from a split (the scale moved to
/// the last stage), and its reason said "statement 1 as written": the
/// piece's reason was dropped for a group of one pass. It says what was
/// done now.
#[test]
fn a_split_into_one_pass_says_why() {
    let source = "vector N : normal;\nvector L : light;\nuniform tint : rgb = (1.0, 0.85, 0.7);\n\
                  uniform exposure : c = 0.8;\ntexture Det : 2d rgb8 = image(\"missing-det.png\");\n\
                  shader p : s → c = max(0, N·L);\nC δπx ← exposure * tint * (2 * Det δu x) * δ p s x;\n";
    let planned = compile(source, "multitexture").unwrap();
    let why = reasons(&planned);
    assert!(why.contains("applied last, by the pass's last stage"), "{why}");
    assert!(!why.contains("as written"), "{why}");
}

// ---- the property's counterexample at 5 000 (nineteenth session) ----------

/// `C·(mix((δ pair).g, δ l₀₁, a) + mix(lerp(δ l₁, T4, 0.9), T2, a))` on
/// geforce3 plans as written (each lerp halved into one temporary, a 2×
/// modulation); multiplied out, its six terms were read back as one lerp
/// of two sums, whose pass needs three interpolated colours, and it was
/// refused. A lerp of sums is also tried as a sum of two lerps
/// (`algebra::lerps_of_sums_split`), each of a group of its terms.
#[test]
fn a_lerp_of_sums_is_split_into_a_sum_of_lerps() {
    let t = |i| Colour::Texture(i);
    for k in [5, 8] {
        let first = lerp(Colour::Channel(1), Colour::Lights(3, k), None);
        let second = lerp(lerp(Colour::Lights(2, k), t(4), Some(9)), t(2), None);
        let c = add(first, second);
        both_plan(&c, Written::Multiplied, "geforce3", true);
        verdicts_agree(&c, Written::Multiplied, "geforce3");
    }
}

/// `C·mix((δ pair).r, T4 + T5, a)` was refused on geforce256 written and
/// multiplied out ("needs 3 texture units"): as `mix((δ pair).r, T4, a) +
/// T5·a`, two lerps of two lookups each, it plans through one temporary
/// (halved, a 2× modulation). Multiplied out, the lerp is read back
/// inside the product by `C` first (`C·(a·(T4 + T5) + (δ pair).r·(1 −
/// a))`), then split the same way. The first counterexample of the finer
/// verdict once the split above was in (the written form planned).
#[test]
fn a_lerp_of_a_sum_is_split_onto_two_texture_units() {
    let c = lerp(Colour::Channel(0), add(Colour::Texture(4), Colour::Texture(5)), None);
    both_plan(&c, Written::Multiplied, "geforce256", true);
    verdicts_agree(&c, Written::Multiplied, "geforce256");
}

/// `C·(T2³·δ l₀₁₂)` on geforce3, the three lights scaled by 0.8 inside
/// one shader: split across δ, the 0.8 was folded into each light's colour
/// (`δ(0.72·…)`), no coefficient left to halve, and no split of the
/// product fit exactly, so the statement fell back per vertex; multiplied
/// out by hand (`0.8·δ light0 + …`) it planned exactly through one
/// temporary. The scalar over a sum inside δ now stays outside the
/// interpolants, `δ(k·(a + b))` = `k·(δa + δb)`, and both plan exactly —
/// the property's first finer difference at 5 000 cases.
#[test]
fn a_scale_over_lights_summed_inside_delta_stays_outside_the_interpolants() {
    let t2 = || Colour::Texture(2);
    let c = mul(mul(mul(t2(), t2()), t2()), Colour::Lights(7, 8));
    for how in [Written::Multiplied, Written::Blended] {
        let decls = declarations(&c);
        let original = format!("{decls}{}", how.statement(&written(&c)));
        let multiplied = format!("{decls}{}", how.statement(&expanded(&c)));
        for source in [&original, &multiplied] {
            assert_eq!(fine_verdict(source, "geforce3"), Verdict::Exact, "{how:?}:\n{source}");
        }
    }
}

/// `C·lerp(δl₀₁ + T2 + δl₀₂, (δ pair).r + δl₀, 0.2)` (lights ×0.3, ×0.6,
/// ×0.6) planned exactly as written on geforce256, geforce3 and
/// multitexture and fell back per vertex multiplied out: its seven terms'
/// sum is below 2 channel by channel (what a temporary holds halved), but
/// `ir::valid` followed channels only four operations down, and below
/// that the partial sum's hull — red's bound in every channel — was added
/// to the green terms. Each node now keeps its channels. The finer
/// verdict's counterexample at 5 000 cases.
#[test]
fn a_long_multiplied_out_sum_is_bounded_channel_by_channel() {
    let c = lerp(
        add(add(Colour::Lights(3, 3), Colour::Texture(2)), Colour::Lights(5, 6)),
        add(Colour::Channel(0), Colour::Lights(1, 6)),
        Some(2),
    );
    let decls = declarations(&c);
    let original = format!("{decls}{}", Written::Multiplied.statement(&written(&c)));
    let multiplied = format!("{decls}{}", Written::Multiplied.statement(&expanded(&c)));
    for target in ["geforce256", "geforce3", "multitexture"] {
        for source in [&original, &multiplied] {
            assert_eq!(fine_verdict(source, target), Verdict::Exact, "{target}:\n{source}");
        }
    }
    plans_and_renders_its_meaning(&multiplied, "geforce3", &scene("kilgard_torus.ron"));
}

/// Kilgard's self-shadowing term blending two maps, `lerp(Night·0.3, Day,
/// saturate(4·(N·L) + 0.5))`: `4·(N·L)` leaves [−1, 1] before the 0.5
/// brings it back, so the combiners refused it per fragment and the term
/// was tabulated (`baked_table` over a per-vertex argument). As
/// `saturate(4·(N·L + 0.125))` the offset is added before
/// `scale_by_four` in one general combiner (Kilgard 2000, Section 4.2):
/// planned per fragment with no table and no per-vertex fall-back (the
/// vectors interpolated range-compressed, as every per-fragment N·L on
/// the combiners), rendering its meaning within that bound, as wgsl does.
#[test]
fn a_clamped_affine_term_takes_a_combiner_scale_instead_of_a_table() {
    let source = "\
vector N : normal;
vector L : light;
texture Day : 2d rgb8 mipmap trilinear repeat = image(\"missing-day.png\");
texture Night : 2d rgb8 mipmap trilinear repeat = image(\"missing-night.png\");
shader k : s → scalar = saturate(4 * (N·L) + 0.5);
C δπx ← lerp(Night δu x * 0.3, Day δu x, k δ s x);
";
    let scene = scene("kilgard_torus.ron");
    for target in ["geforce256", "geforce3", "wgsl"] {
        let planned = plans_and_renders_its_meaning(source, target, &scene);
        let rules: Vec<&str> = planned.plan.approximations.iter().map(|a| a.rule.as_str()).collect();
        assert!(rules.iter().all(|r| *r == "range_compression"), "{target}: {rules:?}");
    }
}

/// `c` written `how` plans exactly on `target` both as written and
/// multiplied out (the property's finer verdict, for one program).
fn both_exact(c: &Colour, how: Written, target: &str) {
    let decls = declarations(c);
    let original = format!("{decls}{}", how.statement(&written(c)));
    let multiplied = format!("{decls}{}", how.statement(&expanded(c)));
    let (a, b) = (fine_verdict(&original, target), fine_verdict(&multiplied, target));
    assert!(
        a == Verdict::Exact && b == Verdict::Exact,
        "{target}: as written {a:?}, multiplied out {b:?}\n{original}\n{multiplied}"
    );
}

/// `C·(mix(T0, δl₀₂·0.8, a) + δl₀₁·0.3)` on multitexture: exact as written
/// (the lerp read back around `0.8·δl₀`, the rest merged into one δ,
/// through a halved temporary), and approximated per vertex multiplied
/// out, `T0·(1 − a) + 0.8·δl₀·a + 0.8·δl₂·a + 0.3·δl₀ + 0.3·δl₁`: that
/// value is its own multiplied-out form with its constants outside the
/// interpolants, so that form (`None`, the same value) was never factored
/// or merged — only the one with the constants moved into the δs, whose
/// lerp `mix(T0, δ(0.8·l₀), a)` does not halve into the temporary. The
/// value itself is now factored and merged as that form would be.
#[test]
fn a_sum_multiplied_out_by_hand_is_factored_as_written() {
    let c = add(lerp(Colour::Texture(0), Colour::Lights(5, 8), None), Colour::Lights(3, 3));
    both_exact(&c, Written::Multiplied, "multitexture");
}

// ---- the property's differences left at 5 000 cases (algebra13) -----------

/// `4·mix((δ pair).r, 0.3·(δ pair).g, a)` written whole into `C`: a scalar
/// widened to rgba. Exact as written on geforce256 and geforce3; multiplied
/// out (`1.2·(δ pair).g·a + 4·(δ pair).r·(1 − a)`) no scale was taken out,
/// since only an rgb value was looked at under the widening, and it was
/// refused. Found by the property at 5 000 cases.
#[test]
fn a_scalar_widened_to_rgba_has_its_scale_taken_out() {
    let c =
        mul(Colour::Number(40), lerp(Colour::Channel(0), mul(Colour::Number(3), Colour::Channel(1)), None));
    for target in ["geforce256", "geforce3"] {
        both_exact(&c, Written::Replace, target);
    }
    fine_verdicts_agree(&c, Written::Replace);
}

/// `C·mix(T2, T1, a)²` on geforce256: exact as written, refused multiplied
/// out. Found by the property at 5 000 cases (seed 200). As written, the
/// square lies in [0, 1] and is its own clamp: multiplied out into an
/// 8-bit temporary, clamped there, then modulated in. Written out by hand
/// its four terms' hulls add to 4, so the value was not taken for one in
/// [0, 1]; its form factored back, `mix(T2, T1, a)·mix(T2, T1, a)`, says
/// it is, and now the value's range is the narrowest of its forms'.
#[test]
fn the_square_of_a_lerp_multiplied_out_plans_as_written() {
    let m = || lerp(Colour::Texture(2), Colour::Texture(1), None);
    let c = mul(m(), m());
    both_exact(&c, Written::Multiplied, "geforce256");
    both_plan(&c, Written::Multiplied, "geforce256", true);
    fine_verdicts_agree(&c, Written::Multiplied);
}

/// `C·mix(mix(T1, T2, a), T0², a)` on geforce256: exact as written, refused
/// multiplied out (found by the property at 5 000 cases, seed 7) — the
/// same family: in [0, 1] as its lerps read back say, not as its terms'
/// hulls added do.
#[test]
fn nested_lerps_of_a_square_multiplied_out_are_their_own_clamp() {
    let t = |i| Colour::Texture(i);
    let c = lerp(lerp(t(1), t(2), None), mul(t(0), t(0)), None);
    both_exact(&c, Written::Multiplied, "geforce256");
    both_plan(&c, Written::Multiplied, "geforce256", true);
    fine_verdicts_agree(&c, Written::Multiplied);
}

/// `C·(2·T1⁴)` on geforce256: exact as written (`T1·T1` squared in the
/// second general combiner, doubled by its output scale), refused
/// multiplied out, `2·T1·T1·T1·T1`: its square took the 2 as `√2` inside,
/// `(T1·T1·√2)²`, whose half leaves the [−1, 1] the combiners clamp to,
/// and the product in a row needs three combiners. The square with the
/// scale applied last, `(T1·T1)²·2`, is a form too now. Found by the
/// property at 5 000 cases (seed 200).
#[test]
fn a_power_scaled_past_one_is_squared_with_its_scale_last() {
    let t1 = || Colour::Texture(1);
    let c = mul(Colour::Number(20), mul(mul(t1(), t1()), mul(t1(), t1())));
    both_exact(&c, Written::Multiplied, "geforce256");
    both_plan(&c, Written::Multiplied, "geforce256", true);
    fine_verdicts_agree(&c, Written::Multiplied);
}

/// `C·(δ(0.8·(l₀ + l₁)) + lerp(T2, (δ pair).g, 0.2))` on geforce3 and
/// multitexture: exact as written, per vertex multiplied out. Found by
/// the property at 5 000 cases (seed 200). Multiplied out,
/// `0.8·δl₀ + 0.8·δl₁ + 0.8·T2 + 0.2·(δ pair).g` is at most 1.96 (green),
/// halved into a temporary and modulated in 2×; the temporary's terms
/// take passes of their own, and what the temporary held was bounded by
/// the terms' hulls added, 0.36 + 0.36 + 0.4 + 0.06 = 1.18, past the 1 it
/// stores: every split was refused at the clamps. The clamps are now
/// followed channel by channel (`planner::clamps`): at most 0.98. Both
/// forms render their meaning under two lights.
#[test]
fn lights_beside_a_lerp_multiplied_out_plan_as_written() {
    let c = add(Colour::Lights(3, 8), lerp(Colour::Texture(2), Colour::Channel(1), Some(2)));
    let decls = declarations(&c);
    let two_lights = scene("adaptive_cube_2lights.ron");
    for target in ["geforce3", "multitexture"] {
        both_exact(&c, Written::Multiplied, target);
        for text in [written(&c), expanded(&c)] {
            let source = format!("{decls}{}", Written::Multiplied.statement(&text));
            let planned = plans_and_renders_its_meaning(&source, target, &two_lights);
            let broken = channel_ranges_broken(&planned);
            assert!(broken.is_empty(), "{target}: {broken:?}\n{source}");
        }
    }
    fine_verdicts_agree(&c, Written::Multiplied);
}

/// Where the channels do not save it, the split is still refused: the
/// same sum with both lights red-heavy, `0.8·(δl₀ + δl₀′) + 0.8·T2 +
/// 0.2·(δ pair).g` with `l₀′` light 0 again, reaches 0.72 + 0.72 + 0.8 +
/// 0.12 = 2.36 in red — its half past 1, which no temporary holds (it
/// plans with the lights per vertex). Planned or not, no plan may store a
/// channel past 1 in a temporary.
#[test]
fn a_sum_past_two_in_one_channel_is_not_halved_into_a_temporary() {
    let c = add(Colour::Lights(3, 8), lerp(Colour::Texture(2), Colour::Channel(1), Some(2)));
    let red = expanded(&c).replace("δ light1 s x", "δ light0 s x");
    assert!(red.matches("δ light0 s x").count() == 2, "{red}");
    let source = format!("{}{}", declarations(&c), Written::Multiplied.statement(&red));
    for target in ["geforce3", "multitexture"] {
        if let Ok(planned) = compile(&source, target) {
            let broken = channel_ranges_broken(&planned);
            assert!(broken.is_empty(), "{target}: {broken:?}\n{}", reasons(&planned));
            // An approximation (the merged δ per vertex) is measured on its
            // own; an exact plan renders the meaning.
            if planned.plan.approximations.is_empty() {
                plans_and_renders_its_meaning(&source, target, &scene("adaptive_cube_2lights.ron"));
            }
        }
    }
}

/// The check below on plans whose temporaries and passes are bounded
/// channel by channel (coloured lights summed, merged back, halved into a
/// temporary; a long sum; a lerp of sums), written and multiplied out, on
/// every target that plans them: no node computes a channel past its
/// range, no temporary holds a colour channel past 1. And the check is not
/// vacuous: a range narrowed by hand (a light's colour declared dimmer in
/// the module than the shader computes) is found.
#[test]
fn channel_ranges_hold_what_the_passes_compute() {
    let t = |i| Colour::Texture(i);
    let programs = [
        (add(Colour::Lights(3, 8), lerp(t(2), Colour::Channel(1), Some(2))), Written::Multiplied),
        (
            lerp(
                add(add(Colour::Lights(3, 3), t(2)), Colour::Lights(5, 6)),
                add(Colour::Channel(0), Colour::Lights(1, 6)),
                Some(2),
            ),
            Written::Multiplied,
        ),
        (mul(Colour::Number(20), mul(Colour::Lights(7, 8), t(0))), Written::Replace),
        (lerp(t(5), mul(lerp(t(2), Colour::Lights(7, 6), Some(6)), t(0)), None), Written::Multiplied),
        (add(Colour::Lights(7, 7), Colour::Lights(1, 8)), Written::Multiplied),
    ];
    let mut checked = 0;
    for (c, how) in &programs {
        let decls = declarations(c);
        for text in [written(c), expanded(c)] {
            let source = format!("{decls}{}", how.statement(&text));
            for target in TARGETS {
                let Ok(planned) = compile(&source, target) else { continue };
                let broken = channel_ranges_broken(&planned);
                assert!(broken.is_empty(), "{target}: {broken:?}\n{source}\n{}", reasons(&planned));
                checked += 1;
            }
        }
    }
    assert!(checked >= 30, "{checked} plans checked");
    // Not vacuous: with its leaves sampled past their ranges (each up to
    // 1.3 times its bound), the plan of the first program is found out.
    let (c, how) = &programs[0];
    let source = format!("{}{}", declarations(c), how.statement(&expanded(c)));
    let planned = compile(&source, "geforce3").unwrap();
    assert!(!channel_ranges_sampled(&planned, 1.3).is_empty());
}

/// The channel ranges the planner reasons with (`ExprInfo::channels`, the
/// split's clamps followed channel by channel) are sound for what the
/// passes compute: every node of every pass of `planned`, evaluated
/// (`ir::eval::apply`, the IR's one semantics) at samples of its leaves —
/// a vector of unit length (as the IR's range of a dot product assumes),
/// any other leaf each channel at either end of its channel's range or
/// between, an interpolant its vertex value — lies within its range in
/// each channel; and what each temporary holds after its passes' blends,
/// unclamped, stays in [0, 1] in red, green and blue (what an 8-bit
/// temporary stores exactly; only for plans without a saturated
/// read-back, whose temporary may hold more). Independent of the planner's
/// interval arithmetic: a bound smaller than a value computed is found.
fn channel_ranges_broken(planned: &Planned) -> Vec<String> {
    channel_ranges_sampled(planned, 1.0)
}

/// [`channel_ranges_broken`] with each leaf's channel sampled up to
/// `stretch` times its upper bound (1: within its range).
fn channel_ranges_sampled(planned: &Planned, stretch: f64) -> Vec<String> {
    use shadec::ir::eval::{apply, canonical, is_computation, value, Value};
    use shadec::ir::{Expr, Handle, Ty};
    use shadec::pipeline::RenderTarget;
    let m = &planned.module;
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let mut out = Vec::new();
    for sample in 0..512 {
        let mut vals: Vec<Option<Value>> = vec![None; m.exprs.len()];
        let mut temps: std::collections::HashMap<String, [f32; 4]> = Default::default();
        for p in &planned.plan.passes {
            let root = Handle::new(p.fragment.output as usize);
            for h in m.reachable(&[root]) {
                if vals[h.index()].is_some() {
                    continue;
                }
                let (e, info) = (&m.exprs[h], m.info(h));
                let v = match e {
                    Expr::Constant(c) => value(c),
                    Expr::Interpolate { value, .. } if vals[value.index()].is_some() => {
                        vals[value.index()].unwrap()
                    }
                    _ if is_computation(e) => {
                        let ops: Vec<Value> =
                            e.operands().iter().map(|o| vals[o.index()].unwrap_or([f64::NAN; 4])).collect();
                        apply(m, e, info.ty, &ops)
                    }
                    _ if info.ty == Ty::Vec3 && info.interval.lo >= -1.0 && info.interval.hi <= 1.0 => {
                        let mut d = [0.0; 3].map(|_: f64| (next() % 2001) as f64 / 1000.0 - 1.0);
                        let n = d.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-6);
                        d = d.map(|x| x / n);
                        canonical(info.ty, [d[0], d[1], d[2], 0.0])
                    }
                    _ => {
                        let c = info.channels;
                        let mut lane = |i: usize| {
                            let (lo, hi) = (c[i].lo.max(-4.0), c[i].hi.min(4.0) * stretch);
                            match (sample, next() % 3) {
                                (0, _) | (_, 0) => lo,
                                (1, _) | (_, 1) => hi,
                                _ => lo + (hi - lo) * (next() % 1024) as f64 / 1023.0,
                            }
                        };
                        canonical(info.ty, [lane(0), lane(1), lane(2), lane(3)])
                    }
                };
                let lanes = if info.ty.width() == 1 { 1 } else { info.ty.width().min(4) };
                for (i, (&x, c)) in v.iter().zip(info.channels).enumerate().take(lanes) {
                    if !x.is_nan() && (x < c.lo - 1e-9 || x > c.hi + 1e-9) {
                        out.push(format!(
                            "sample {sample}: %{} = {e:?} lane {i}: {x} outside {c:?}",
                            h.index()
                        ));
                    }
                }
                vals[h.index()] = Some(v);
            }
            let RenderTarget::Temporary { name } = &p.target else { continue };
            let src = vals[root.index()].unwrap_or([f64::NAN; 4]).map(|x| x as f32);
            let held = temps.get(name).copied().unwrap_or([0.0; 4]);
            let after = p.state.blend.blend(&src, &held);
            if after[..3].iter().any(|x| !(-1e-6..=1.0 + 1e-6).contains(x)) {
                out.push(format!("sample {sample}: temporary {name} holds {after:?}"));
            }
            temps.insert(name.clone(), after);
        }
        if out.len() > 8 {
            break;
        }
    }
    out
}

/// `C·(δ(0.7·(l₀ + l₁ + l₂)) + δ(0.8·l₀))`: per vertex as written on the
/// three fixed-function targets (the written δ reaches 1.12), exact
/// multiplied out, one δ per light. The written form finds the
/// multiplied-out form's plan. Found by the property at 5 000 cases
/// (seed 7). The written `δ(0.8·l₀)` is one interpolant of its own
/// shader, `δ((0.8·l₀).rgb)`, where multiplied out by hand it is
/// `0.8·δl₀`, a like term of `0.7·δl₀` (collected, `1.5·δl₀`, beside the
/// other two lights merged into one δ: the plan that fits). Now the
/// written form is also tried with the scale kept outside its δ.
#[test]
fn two_sums_of_lights_plan_as_their_lights_multiplied_out() {
    let c = add(Colour::Lights(7, 7), Colour::Lights(1, 8));
    for target in ["geforce256", "geforce3", "multitexture"] {
        both_exact(&c, Written::Multiplied, target);
    }
    fine_verdicts_agree(&c, Written::Multiplied);
}

/// `lerp(δl₀·0.4 + T4·T2², mix(δ(0.7·(l₀ + l₂)), (δ pair).r, 0.8), a)`
/// added onto `C` (`⊕[add]`): refused as written on geforce256, exact
/// multiplied out. Found by the property at 5 000 cases (seed 7); plans
/// exactly both ways with the scales kept outside one-term δs (the
/// written `δ(0.4·l₀)`) and a scalar's scale taken out under its widening.
#[test]
fn nested_lerps_added_onto_the_framebuffer_plan_as_multiplied_out() {
    let t = |i| Colour::Texture(i);
    let c = lerp(
        add(Colour::Lights(1, 4), mul(mul(t(4), t(2)), t(2))),
        lerp(Colour::Lights(5, 7), Colour::Channel(0), Some(8)),
        None,
    );
    both_exact(&c, Written::Added, "geforce256");
    fine_verdicts_agree(&c, Written::Added);
}
