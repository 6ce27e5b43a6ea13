//! Lowering to the IR: every example lowers; types, frequencies and ranges
//! follow the δ rules of seeds/001; type and frequency errors have spans;
//! identical subexpressions are one node.

use proptest::prelude::*;
use shadec::diag::Diagnostic;
use shadec::ir::{self, Expr, Frequency, Handle, Module, Range, Ty, Usage};

fn examples() -> Vec<(String, String)> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
    let mut v: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "shd"))
        .map(|p| {
            (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    v.sort();
    v
}

/// Checks, then lowers; the source must check clean.
#[track_caller]
fn lower(src: &str) -> (Module, Vec<Diagnostic>) {
    let (program, d) = shadec::parser::check(src);
    assert!(d.iter().all(|d| !d.is_error()), "does not check:\n{src}\n{d:#?}");
    ir::lower(&program)
}

#[track_caller]
fn lower_ok(src: &str) -> Module {
    let (m, d) = lower(src);
    let errors: Vec<_> = d.iter().filter(|d| d.is_error()).collect();
    assert!(errors.is_empty(), "lowering errors:\n{src}\n{errors:#?}");
    m
}

/// The single error lowering reports, and the source text it points at.
#[track_caller]
fn lower_err(src: &str) -> (Diagnostic, &str) {
    let (_, d) = lower(src);
    let errors: Vec<_> = d.into_iter().filter(|d| d.is_error()).collect();
    assert_eq!(errors.len(), 1, "expected one error:\n{src}\n{errors:#?}");
    let e = errors.into_iter().next().unwrap();
    let text = &src[e.primary.span.range()];
    (e, text)
}

fn nodes(m: &Module, pred: impl Fn(&Expr) -> bool) -> Vec<Handle<Expr>> {
    m.exprs.arena().iter().filter(|(_, e)| pred(e)).map(|(h, _)| h).collect()
}

const LIGHTING: &str = "
vector N : normal;
vector L : light(0);
const kd : rgb = (0.8, 0.6, 0.4);
texture T : 2d rgba8 = image(\"t.png\");
shader p : s → c = kd * max(0, N·L);
";

fn with(stmt: &str) -> String {
    format!("{LIGHTING}{stmt}\n")
}

#[test]
fn every_example_lowers_without_errors() {
    for (name, src) in examples() {
        let (m, d) = lower(&src);
        let errors: Vec<_> = d.iter().filter(|d| d.is_error()).collect();
        assert!(errors.is_empty(), "{name}: {errors:#?}");
        // Every statement, plus one texel pass per `= bake(f)` texture (seeds/001 (13)).
        let n_statements = shadec::parser::parse(&src)
            .0
            .items
            .iter()
            .filter(|i| matches!(i.kind, shadec::parser::ast::ItemKind::Statement(_)))
            .count();
        let n_baked =
            src.lines().filter(|l| !l.trim_start().starts_with("//") && l.contains("= bake(")).count();
        assert_eq!(m.statements.len(), n_statements + n_baked, "{name}: a statement went missing");
        assert_eq!(m.info.len(), m.exprs.len(), "{name}: every node has its info");
        // Operands precede their users.
        for (h, e) in m.exprs.arena().iter() {
            for o in e.operands() {
                assert!(o < h, "{name}: {o:?} used by {h:?}");
            }
        }
    }
}

#[test]
fn gouraud_colour_is_per_vertex_then_per_fragment() {
    let src = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/gouraud.shd")).unwrap();
    let m = lower_ok(&src);
    let st = &m.statements[0];
    assert_eq!(st.freq, Frequency::Fragment);
    // The written value widens the interpolated rgb colour to rgba.
    let Expr::Convert { value, to: Ty::Rgba } = m.exprs[st.value] else { panic!("{:?}", m.exprs[st.value]) };
    let Expr::Interpolate { value: colour, to: Frequency::Fragment } = m.exprs[value] else {
        panic!("{:?}", m.exprs[value])
    };
    assert_eq!(m.info(value).freq, Frequency::Fragment);
    assert_eq!(m.info(colour).freq, Frequency::Vertex);
    assert_eq!(m.info(colour).ty, Ty::Rgb);
    // Every dot product is per vertex.
    let dots = nodes(&m, |e| matches!(e, Expr::Binary { op: ir::BinaryOp::Dot, .. }));
    assert!(!dots.is_empty());
    assert!(dots.iter().all(|h| m.info(*h).freq == Frequency::Vertex));
}

#[test]
fn shader_after_delta_is_per_fragment_and_before_is_per_vertex() {
    let frag = lower_ok(&with("C δπx ← p δ s x;"));
    let dot = nodes(&frag, |e| matches!(e, Expr::Binary { op: ir::BinaryOp::Dot, .. }));
    assert_eq!(dot.len(), 1);
    assert_eq!(frag.info(dot[0]).freq, Frequency::Fragment);
    // The operands are the interpolated N and L.
    let Expr::Binary { lhs, rhs, .. } = frag.exprs[dot[0]] else { unreachable!() };
    assert!(matches!(frag.exprs[lhs], Expr::Interpolate { .. }));
    assert!(matches!(frag.exprs[rhs], Expr::Interpolate { .. }));

    let vert = lower_ok(&with("C δπx ← δ p s x;"));
    let dot = nodes(&vert, |e| matches!(e, Expr::Binary { op: ir::BinaryOp::Dot, .. }));
    assert_eq!(vert.info(dot[0]).freq, Frequency::Vertex);
}

#[test]
fn delta_twice_is_an_error() {
    let src = with("C δπx ← δ δ p s x;");
    let (e, _) = lower_err(&src);
    assert_eq!(e.code, "delta-twice");
    let src = with("C δπx ← T δ δ u x;");
    let (e, text) = lower_err(&src);
    assert_eq!(e.code, "delta-twice", "{e:#?}");
    assert_eq!(text, "δ");
}

#[test]
fn embm_delta_distributes_over_a_sum() {
    let src = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/embm.shd")).unwrap();
    let m = lower_ok(&src);
    let st = m.statements.iter().find(|s| s.freq == Frequency::Fragment).unwrap();
    let u = Usage::of(&m, st);
    assert_eq!(u.texture_units(), 2);
    assert_eq!(u.dependent_lookups.len(), 1, "T is indexed by T′'s result");
    let offsets = nodes(&m, |e| matches!(e, Expr::Binary { op: ir::BinaryOp::Add, .. }));
    assert_eq!(offsets.len(), 1);
    assert_eq!(m.info(offsets[0]).freq, Frequency::Fragment);
    assert_eq!(m.info(offsets[0]).ty, Ty::Vec2);
}

#[test]
fn per_fragment_value_into_per_vertex_target_is_an_error() {
    let src = with("u x ← T δu x;");
    let (e, text) = lower_err(&src);
    assert_eq!(e.code, "frequency");
    assert!(e.message.contains("per-vertex target"), "{}", e.message);
    assert_eq!(text, "δ");
}

#[test]
fn per_vertex_value_into_per_fragment_target_needs_delta() {
    let src = with("C δπx ← p s x;");
    let (e, text) = lower_err(&src);
    assert_eq!(e.code, "frequency");
    assert_eq!(e.message, "a per-vertex value is assigned to a per-fragment target");
    assert_eq!(text, "p s x");
    assert!(e.help.unwrap().contains("δ p s x"));
}

#[test]
fn screen_pass_value_in_fragment_statement_is_an_error() {
    let src = with("C δπx ← (C xs) ⊕ (T δu x);");
    let (e, _) = lower_err(&src);
    assert_eq!(e.code, "frequency", "{e:#?}");
}

#[test]
fn dot_of_colour_and_scalar_is_a_type_error_with_span() {
    let src = with("C δπx ← rgb(kd · 0.5, 0, 0) ⊕ (T δu x);");
    let (e, text) = lower_err(&src);
    assert_eq!(e.code, "type-mismatch");
    assert_eq!(e.message, "dot product of a colour (rgb) with a scalar");
    assert_eq!(text, "kd · 0.5");
}

#[test]
fn texture_indexed_by_a_colour_is_an_error_with_span() {
    let src = with("C δπx ← T kd;");
    let (e, text) = lower_err(&src);
    assert_eq!(e.code, "bad-index");
    assert!(e.message.contains("indexed by a colour"), "{}", e.message);
    assert_eq!(text, "T kd");
}

#[test]
fn identical_subexpressions_are_one_node() {
    let once = lower_ok(&with("C δπx ← T δu x;"));
    let twice = lower_ok(&with("let a = T δu x;\nC δπx ← a ⊕ (T δu x);"));
    let lookups = nodes(&twice, |e| matches!(e, Expr::Lookup { .. }));
    assert_eq!(lookups.len(), 1);
    // The second program adds exactly one node: the ⊕.
    assert_eq!(twice.exprs.len(), once.exprs.len() + 1);
    assert_eq!(Usage::of(&twice, &twice.statements[0]).texture_units(), 1);
}

#[test]
fn kilgard_shares_the_normal_map_and_fits_geforce256() {
    let src =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/kilgard_bump_mapping.shd"))
            .unwrap();
    let m = lower_ok(&src);
    let units: Vec<usize> = m.statements.iter().map(|s| Usage::of(&m, s).texture_units()).collect();
    assert_eq!(units, vec![1, 2, 2]);
    // Tn δu x is one node although passes 2 and 3 both use it.
    let tn = m.textures.iter().position(|t| t.name == "Tn").unwrap() as u32;
    assert_eq!(nodes(&m, |e| matches!(e, Expr::Lookup { texture, .. } if *texture == tn)).len(), 1);
    let p = shadec::profile::Profile::builtin("geforce256").unwrap();
    assert!(shadec::profile::fit(&m, &p).is_empty());
}

#[test]
fn chained_multitexture_needs_four_units() {
    let src =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/chained_multitexture.shd"))
            .unwrap();
    let m = lower_ok(&src);
    assert_eq!(Usage::of(&m, &m.statements[0]).texture_units(), 4);
    let gf1 = shadec::profile::fit(&m, &shadec::profile::Profile::builtin("geforce256").unwrap());
    assert_eq!(gf1.len(), 1);
    assert!(!gf1[0].is_error(), "a capacity overflow is a warning: the planner splits");
    assert_eq!(
        gf1[0].message,
        "does not fit in one pass on geforce256: needs 4 texture units; it has 2; the pass planner will split it"
    );
    assert_eq!(gf1[0].primary.span, m.statements[0].span);
    assert_eq!(gf1[0].secondary.len(), 4, "one label per lookup");
    for p in ["geforce3", "multitexture", "wgsl"] {
        assert!(shadec::profile::fit(&m, &shadec::profile::Profile::builtin(p).unwrap()).is_empty(), "{p}");
    }
}

#[test]
fn missing_capabilities_are_errors() {
    let src = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/embm.shd")).unwrap();
    let m = lower_ok(&src);
    let d = shadec::profile::fit(&m, &shadec::profile::Profile::builtin("geforce256").unwrap());
    assert!(d.iter().any(|d| d.is_error() && d.message.contains("dependent lookup")), "{d:#?}");
    assert!(shadec::profile::fit(&m, &shadec::profile::Profile::builtin("geforce3").unwrap()).is_empty());
}

#[test]
fn constants_fold() {
    let m = lower_ok(&with("const a = 2;\nC δπx ← rgb(a * 0.25, sqrt(0.25), max(0, -1)) ⊕ (T δu x);"));
    let consts: Vec<_> = m
        .exprs
        .arena()
        .iter()
        .filter_map(|(_, e)| match e {
            Expr::Constant(c) if c.ty == Ty::Rgb => Some(c.values().to_vec()),
            _ => None,
        })
        .collect();
    assert!(consts.contains(&vec![0.5, 0.5, 0.0]), "{consts:?}");
    assert!(nodes(&m, |e| matches!(e, Expr::Math { .. } | Expr::Compose { .. })).is_empty());
}

#[test]
fn ranges_follow_the_hardware_classes() {
    let src = "
vector L : light(0) in tangent;
texture Ncube : cube rgb8 = normalize_cube(32);
texture Tn : 2d rgba8 = image(\"n.png\");
let Ln = expand(Ncube δ L s x);
C δπx ← rgb(max(0, Ln · expand((Tn δu x).rgb)), Ln.z, 2 * Ln.z);
";
    let m = lower_ok(src);
    let find = |pred: &dyn Fn(&Expr) -> bool| nodes(&m, pred)[0];
    let lookup = find(&|e| matches!(e, Expr::Lookup { texture: 0, .. }));
    assert_eq!(m.info(lookup).range(), Range::Unsigned);
    let expand = find(&|e| matches!(e, Expr::Math { fun: ir::MathFunction::Expand, .. }));
    assert_eq!(m.info(expand).range(), Range::Signed);
    let max = find(&|e| matches!(e, Expr::Math { fun: ir::MathFunction::Max, .. }));
    assert_eq!(m.info(max).range(), Range::Unsigned);
    let twice = find(&|e| matches!(e, Expr::Binary { op: ir::BinaryOp::Mul, .. }));
    assert_eq!(m.info(twice).range(), Range::Unbounded);
}

#[test]
fn texture_shading_is_per_texel_and_fat_textures_feed_shaders() {
    let src = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/texture_shading.shd"))
        .unwrap();
    let m = lower_ok(&src);
    assert_eq!(m.statements[0].freq, Frequency::Texel);
    assert_eq!(m.info(m.statements[0].value).freq, Frequency::Texel);
    assert_eq!(m.statements[1].freq, Frequency::Fragment);

    // On a mesh, `s δu` is `s` at the surface point of the texel (seeds/001
    // Section 3.7): the statement is indexed by `δu x`, rasterizing the mesh
    // in texture space, and the roles are interpolated per texel.
    let index = m.statements[0].index;
    let Expr::Interpolate { value, to: Frequency::Texel } = m.exprs[index] else {
        panic!("index {:?}", m.exprs[index])
    };
    assert!(matches!(m.exprs[value], Expr::TexCoord { .. }), "{:?}", m.exprs[value]);
    let per_texel_roles = nodes(&m, |e| matches!(e, Expr::Interpolate { to: Frequency::Texel, .. }));
    assert_eq!(per_texel_roles.len(), 4, "δu x, N, L, V");
    assert!(nodes(&m, |e| matches!(e, Expr::Vector { site: ir::Site::Texel, .. })).is_empty());

    // With no mesh in the program, the bundle stays a function of the
    // texel coordinate (a table, where `s.x` is the coordinate).
    let table = "texture T : 2d rgba8;\nshader p : s → c = rgb(s.x, s.y, 0);\nT δu ← p s δu;\n";
    let m = lower_ok(table);
    assert!(matches!(m.exprs[m.statements[0].index], Expr::TexelCoord));

    // Two vertex streams: which surface is ambiguous, and said so.
    let two = "vector N : normal;\nvector L : light(0);\ntexture T : 2d rgba8;\nshader p : s → c = rgb(N·L, 0, 0);\nT δu ← p s δu;\nC δπx ← T δu x;\nC δπx′ ← T δu x′;\n";
    let (e, text) = lower_err(two);
    assert_eq!((e.code, text), ("ambiguous-surface", "N"), "{e:#?}");

    let src = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/fat_texture_map.shd"))
        .unwrap();
    let m = lower_ok(&src);
    let members = nodes(&m, |e| matches!(e, Expr::FatMember { .. }));
    assert!(!members.is_empty());
    assert!(members.iter().all(|h| m.info(*h).freq == Frequency::Fragment));
}

#[test]
fn unsupported_forms_say_so() {
    let src = "
shader q(n: scalar) : s → c = rgb(n, n, n);
C δπx ← δ q s x;
";
    let (e, _) = lower_err(src);
    assert_eq!(e.code, "not-supported");
    assert!(e.message.contains("cannot be set where it is used yet"), "{}", e.message);
}

// Lowering never panics on a program that checks: random statements over a
// fixed set of declarations.
const DECLS: &str = "
vector N : normal;
vector L : light(0);
vector H = normalize(L + N);
const kd : rgb = (0.8, 0.6, 0.4);
uniform g : scalar = 0.5;
texture T : 2d rgba8 = image(\"t.png\");
texture Tc : cube rgb8 = normalize_cube(8);
texture Ts : 2d signed8 = bumps(4);
texture Tf : 2d rgba16f;
framebuffer C2 : depth;
shader p : s → c = kd * max(0, N·L);
let a = T δu x;
";

fn atom() -> impl Strategy<Value = String> {
    prop::sample::select(vec![
        "N",
        "L",
        "H",
        "kd",
        "g",
        "a",
        "x",
        "xs",
        "u x",
        "s x",
        "δ s x",
        "δu",
        "δu x",
        "π x",
        "δπx",
        "T δu x",
        "Tc δ L s x",
        "Ts δu x",
        "Tf δu x",
        "C δπx",
        "C xs",
        "α C δπx",
        "z C2 xs",
        "0",
        "1",
        "0.5",
        "(1, 2)",
        "(0, 0, 1)",
        "(1, 1, 1, 1)",
        "s",
        "p s x",
        "p δ s x",
        "δ p s x",
        "p s δu",
        "p T δu x",
        "u",
        "δ x",
        "πl π⁻¹ xs",
    ])
    .prop_map(str::to_string)
}

fn expr() -> impl Strategy<Value = String> {
    atom().prop_recursive(4, 24, 3, |inner| {
        prop_oneof![
            (
                inner.clone(),
                prop::sample::select(vec!["+", "-", "*", "/", "·", "^", "⊕", "⊕[add]", "<", "∧"]),
                inner.clone()
            )
                .prop_map(|(a, op, b)| format!("({a}) {op} ({b})")),
            (
                prop::sample::select(vec![
                    "δ",
                    "T",
                    "Tc",
                    "p",
                    "π",
                    "πR",
                    "α",
                    "z",
                    "N",
                    "s",
                    "u",
                    "C",
                    "normalize",
                    "expand",
                    "saturate"
                ]),
                inner.clone()
            )
                .prop_map(|(f, a)| format!("{f} ({a})")),
            (
                prop::sample::select(vec!["max", "min", "dot", "pow", "rgba", "mix", "clamp"]),
                prop::collection::vec(inner.clone(), 1..4)
            )
                .prop_map(|(f, args)| format!("{f}({})", args.join(", "))),
            (inner.clone(), prop::sample::select(vec!["x", "xy", "rgb", "a", "z", "xyzw"]))
                .prop_map(|(a, c)| format!("({a}).{c}")),
            (inner.clone(), inner.clone(), inner.clone())
                .prop_map(|(c, a, b)| format!("({c}) ? ({a}) : ({b})")),
        ]
    })
}

fn target() -> impl Strategy<Value = String> {
    prop::sample::select(vec![
        "C δπx",
        "α C δπx",
        "C xs",
        "T δu",
        "Tf δu x",
        "Tf δπx",
        "u' x",
        "C2 δπl x",
        "z C xs",
    ])
    .prop_map(str::to_string)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]
    #[test]
    fn lowering_never_panics((t, e) in (target(), expr())) {
        let src = format!("{DECLS}{t} ← {e};\n");
        let (program, d) = shadec::parser::check(&src);
        if d.iter().all(|d| !d.is_error()) {
            let (m, diags) = ir::lower(&program);
            // Every error has a span inside the text; every statement kept is typed.
            for d in &diags {
                prop_assert!((d.primary.span.end as usize) <= src.len());
            }
            prop_assert_eq!(m.info.len(), m.exprs.len());
            let profile = shadec::profile::Profile::builtin("geforce256").unwrap();
            let _ = shadec::profile::fit(&m, &profile);
            let _ = ir::dump::dump(&m, Some(&src));
        }
    }
}

#[test]
fn long_chains_and_cycles_do_not_overflow() {
    let chain = vec!["(T δu x)"; 900].join(" ⊕ ");
    let m = lower_ok(&with(&format!("C δπx ← {chain};")));
    assert_eq!(m.statements.len(), 1);
    let sum = vec!["g"; 990].join(" + ");
    let src = format!("uniform g : scalar = 0.5;\nlet a = {sum};\nlet b = a * a;\nC δπx ← rgb(b, b, b);\n");
    lower_ok(&src);
    let src = "let a = b + 1;\nlet b = a * 2;\nC δπx ← rgb(a, a, a);\n";
    let (e, text) = lower_err(src);
    assert_eq!(e.code, "cycle");
    assert_eq!(text, "a");
}

#[test]
fn a_vector_outside_the_parameter_vector_is_an_error() {
    let src = "
vector N : normal;
vector L : light(0);
vector V : view;
params s′ : N, L;
shader p : s → c = rgb(N·V, 0, 0);
C δπx ← δ p s′ x;
";
    let (e, text) = lower_err(src);
    assert_eq!(e.code, "not-a-member");
    assert_eq!(text, "V");
    // The same shader on the full `s` lowers.
    lower_ok(&src.replace("s′ x", "s x"));
}

#[test]
fn statement_frequencies_follow_the_target() {
    let read = |name: &str| {
        std::fs::read_to_string(format!("{}/examples/{name}.shd", env!("CARGO_MANIFEST_DIR"))).unwrap()
    };
    let freqs = |m: &Module| m.statements.iter().map(|s| s.freq).collect::<Vec<_>>();
    use Frequency::*;
    // (15), (16), (2): rasterize into texture space, shade the texels, texture the surface.
    assert_eq!(freqs(&lower_ok(&read("solid_mapping"))), vec![Texel, Texel, Fragment]);
    // (5), (6): the fat framebuffer, then a screen pass.
    let deferred = lower_ok(&read("deferred_shading"));
    assert_eq!(freqs(&deferred), vec![Fragment, Screen]);
    assert!(matches!(deferred.exprs[deferred.statements[0].value], Expr::Bundle(_)));
    // (9), (10): `C δxs` writes fragments too.
    assert_eq!(freqs(&lower_ok(&read("multipass"))), vec![Fragment, Fragment]);
    // Texgen runs per vertex and types its coordinate set.
    // `TF = bake(fresnel)` shades TF's texels first (its declaration comes first).
    let dp = lower_ok(&read("dual_paraboloid_mirror"));
    assert_eq!(&freqs(&dp)[..4], &[Texel, Vertex, Vertex, Vertex]);
    let u2 = dp.texcoord_sets.iter().find(|t| t.name == "u''").unwrap();
    assert_eq!((u2.ty, u2.generated), (Ty::Scalar, true));
}

#[test]
fn unused_shaders_and_lets_are_type_checked_too() {
    let src = "
vector N : normal;
const kd : rgb = (1, 0, 0);
texture T : 2d rgba8 = image(\"t.png\");
shader q : s → c = kd · N.x;
C δπx ← T δu x;
";
    let (e, text) = lower_err(src);
    assert_eq!(e.code, "type-mismatch");
    assert_eq!(text, "kd · N.x");
    let src = "
texture T : 2d rgba8 = image(\"t.png\");
const kd : rgb = (1, 0, 0);
let a = T kd;
C δπx ← T δu x;
";
    let (e, text) = lower_err(src);
    assert_eq!(e.code, "bad-index");
    assert_eq!(text, "T kd");
}

/// seeds/001 (9) written literally as a program's first pass modulates the
/// cleared framebuffer: black, and a located warning says so (issue 16, item 7).
#[test]
fn a_bare_modulate_of_an_unwritten_framebuffer_warns() {
    let src = with("C δπx ← (C δπx) ⊕ (δ p s x);");
    let (_, d) = lower(&src);
    let warnings: Vec<&Diagnostic> = d.iter().filter(|d| d.code == "modulate-cleared").collect();
    assert_eq!(warnings.len(), 1, "{d:#?}");
    let w = warnings[0];
    assert!(!w.is_error());
    assert_eq!(&src[w.primary.span.range()], "(C δπx)");
    assert_eq!(w.message, "`⊕` modulates the framebuffer `C`, which no earlier statement writes: it is still cleared to 0, so the result is black");
    assert_eq!(
        w.help.as_deref(),
        Some("to accumulate into `C`, write `⊕[add]`; to modulate what an earlier pass drew, write `C` first (e.g. `C δπx ← …;` before this statement)")
    );
    // The help is true: either fix is quiet.
    for fixed in ["C δπx ← (C δπx) ⊕[add] (δ p s x);", "C δπx ← T δu x;\nC δπx ← (C δπx) ⊕ (δ p s x);"]
    {
        let (_, d) = lower(&with(fixed));
        assert!(d.iter().all(|d| d.code != "modulate-cleared"), "{fixed}: {d:#?}");
    }
    // Another framebuffer, written only later, in a screen pass: warned too
    // (not the incoming `C xs`, which is not modulated by itself).
    let (_, d) = lower(&with("framebuffer C′ : rgba8;\nC xs ← (C′ xs) ⊕ (C xs);\nC′ δπx ← T δu x;"));
    let w: Vec<_> = d.iter().filter(|d| d.code == "modulate-cleared").map(|d| d.message.clone()).collect();
    assert_eq!(w.len(), 1, "{d:#?}");
    assert!(w[0].contains("framebuffer `C'`"), "{w:?}"); // names print by their key (ASCII primes)
                                                         // A framebuffer as the incoming colour (right operand) is not modulated by itself.
    let (_, d) = lower(&with("C δπx ← T δu x ⊕ (C δπx);"));
    assert!(d.iter().all(|d| d.code != "modulate-cleared"), "{d:#?}");
}

/// A constant tuple scaled by scalars is a vec3, not a colour: the error
/// at the statement labels the tuple with the `rgb(…)` that fixes it, and
/// that fix lowers.
#[test]
fn a_tuple_scaled_into_a_framebuffer_is_labelled_with_its_rgb() {
    let head = "vector N : normal;\nvector L : light;\nshader d : s → scalar = max(0, N·L);\n";
    let src = format!("{head}C δπx ← (0.8, 0.75, 0.7) * 0.5 * δ d s x;\n");
    let (e, _) = lower_err(&src);
    assert_eq!(e.code, "type-mismatch");
    let label =
        e.secondary.iter().find(|l| l.message.contains("rgb(0.8, 0.75, 0.7)")).expect("a label at the tuple");
    assert_eq!(&src[label.span.range()], "(0.8, 0.75, 0.7)");
    lower_ok(&format!("{head}C δπx ← rgb(0.8, 0.75, 0.7) * 0.5 * δ d s x;\n"));
}

/// Fog by `length(V)` of the `view` vector is a constant: the binder
/// normalizes every role but `position` and `intensity`, so its length
/// is one. A located warning says so, and its help (a `position in eye`
/// vector) is quiet and varies with the distance.
#[test]
fn the_length_of_a_unit_vector_warns_and_names_the_position_vector() {
    let src = "vector V : view;\nshader f : s → c = exp(-0.15 * length(V));\nC δπx ← δ f s x;\n";
    let (_, d) = lower(src);
    let w: Vec<&Diagnostic> = d.iter().filter(|d| d.code == "unit-length").collect();
    assert_eq!(w.len(), 1, "{d:#?}");
    assert!(!w[0].is_error());
    let file = shadec::diag::SourceFile::new("fog.shd".to_string(), src.to_string());
    insta::assert_snapshot!("unit_length_warning", file.render(&d, false));
    // Interpolated (`length(δ V)` inside a per-pixel shader) too, once.
    let (_, d) = lower("vector L : light;\nshader a : s → c = 1 / (1 + length(L));\nC δπx ← a δ s x;\n");
    assert_eq!(d.iter().filter(|d| d.code == "unit-length").count(), 1, "{d:#?}");
    // The help's form is quiet; a computed vector is not judged.
    for quiet in [
        "vector P : position in eye;\nshader f : s → c = exp(-0.15 * length(P));\nC δπx ← δ f s x;\n",
        "vector L : light;\nvector V : view;\nvector H = L + V;\nshader f : s → c = length(H) / 2;\nC δπx ← δ f s x;\n",
    ] {
        let (_, d) = lower(quiet);
        assert!(d.iter().all(|d| d.code != "unit-length"), "{quiet}: {d:#?}");
    }
}

/// Generator sizes are bounded where the texture is declared (issue 16,
/// item 8): `normalize_cube(100000)` took 15 s and 3 GB to build; now it is
/// a located error before anything is built.
#[test]
fn a_huge_normalization_cube_is_a_located_error_at_once() {
    let src =
        "texture Ncube : cube rgb8 = normalize_cube(100000);\nvector L : light;\nC δπx ← Ncube δ L s x;\n";
    let start = std::time::Instant::now();
    let (e, text) = lower_err(src);
    assert!(start.elapsed() < std::time::Duration::from_secs(1), "{:?}", start.elapsed());
    assert_eq!(e.code, "too-large");
    assert_eq!(e.message, "a cube face of 100000×100000 texels is larger than the limit of 1024×1024");
    assert!(text.contains("100000"), "{text}");
    assert!(e.help.as_deref().is_some_and(|h| h.contains("from 1 to 1024")), "{:?}", e.help);
    let rendered = shadec::diag::SourceFile::new("t.shd", src).render(&[e], false);
    assert!(rendered.contains("t.shd:1:43"), "{rendered}");
    // Nor does compiling build it.
    let start = std::time::Instant::now();
    let refused = shadec::compile(src, &shadec::profile::Profile::builtin("wgsl").unwrap()).unwrap_err();
    assert_eq!(refused[0].code, "too-large");
    assert!(start.elapsed() < std::time::Duration::from_secs(1), "{:?}", start.elapsed());

    // The limit is allowed, through a `const` too; bits are 8 or 16; a cube generator needs a cube.
    lower_ok("const n = 1024;\ntexture Ncube : cube rgb8 = normalize_cube(n, 16);\nvector L : light;\nC δπx ← Ncube δ L s x;\n");
    for (source, code, message) in [
        (
            "cube rgb8 = normalize_cube(1025)",
            "too-large",
            "a cube face of 1025×1025 texels is larger than the limit of 1024×1024",
        ),
        (
            "cube rgb8 = normalize_cube(0)",
            "bad-generator",
            "a cube face of 0 texels per side is not a whole number from 1 to 1024",
        ),
        (
            "cube rgb8 = normalize_cube(31.5)",
            "bad-generator",
            "a cube face of 31.5 texels per side is not a whole number from 1 to 1024",
        ),
        ("cube rgb8 = normalize_cube(32, 12)", "bad-generator", "the bits of `normalize_cube` are 8 or 16"),
        (
            "2d rgb8 = normalize_cube(32)",
            "bad-generator",
            "`normalize_cube` makes a cube map, but the texture is declared `2d`",
        ),
    ] {
        let src = format!("texture Ncube : {source};\nvector L : light;\nC δπx ← Ncube δu x;\n");
        let (_, d) = lower(&src);
        let e = d.iter().find(|d| d.is_error()).unwrap_or_else(|| panic!("{source}: no error"));
        assert_eq!((e.code, e.message.as_str()), (code, message), "{source}");
        assert!(e.help.is_some(), "{source}");
    }
}

/// Texture attributes are lowered into the IR (issue 17): the binder and
/// the cost model read one rule — `nearest` wins, a mipmapped texture is
/// trilinear unless `bilinear` is said, cube maps and `clamp` clamp.
#[test]
fn texture_attributes_are_in_the_ir() {
    use shadec::textures::{Filter, Wrap};
    let m = lower_ok(
        "texture A : 2d rgba8 mipmap repeat = image(\"a.png\");\n\
         texture B : 2d rgba8 mipmap bilinear = image(\"b.png\");\n\
         texture Cn : cube rgb8 nearest = normalize_cube(32);\n\
         texture D : 2d rgba8 clamp = image(\"d.png\");\n\
         C δπx ← A δu x * B δu x * D δu x;\n",
    );
    let s = |name: &str| m.textures.iter().find(|t| t.name == name).unwrap().sampling;
    assert_eq!(s("A"), ir::Sampling { filter: Filter::Trilinear, wrap: Wrap::Repeat, mipmap: true });
    assert_eq!(s("B"), ir::Sampling { filter: Filter::Bilinear, wrap: Wrap::Repeat, mipmap: true });
    assert_eq!(s("Cn"), ir::Sampling { filter: Filter::Nearest, wrap: Wrap::ClampToEdge, mipmap: false });
    assert_eq!(s("D"), ir::Sampling { filter: Filter::Bilinear, wrap: Wrap::ClampToEdge, mipmap: false });
}

/// A screen pass reading a framebuffer no statement writes reads its clear
/// value, 0, everywhere: a black picture with no error. A located warning
/// at the first read names it; a framebuffer written by any statement
/// (before or after), and `C` accumulated into, are not warned about.
#[test]
fn reading_a_framebuffer_no_statement_writes_warns_once_at_the_read() {
    let src = "framebuffer F : rgba8;\nC xs ← F xs;\nC xs ← 0.5 * (F xs);\n";
    let (_, d) = lower(src);
    let w: Vec<&Diagnostic> = d.iter().filter(|d| d.code == "read-cleared").collect();
    assert_eq!(w.len(), 1, "{d:#?}");
    assert!(!w[0].is_error());
    assert_eq!(&src[w[0].primary.span.range()], "F xs");
    let file = shadec::diag::SourceFile::new("post.shd".to_string(), src.to_string());
    insta::assert_snapshot!("read_cleared_warning", file.render(&d, false));
    for quiet in [
        "framebuffer F : rgba8;\nF δπx ← 0.5;\nC xs ← F xs;\n",
        "framebuffer F : rgba8;\nC xs ← F xs;\nF δπx ← 0.5;\n",
        "C δπx ← (C δπx) ⊕[add] 0.25;\n",
    ] {
        let (_, d) = lower(quiet);
        assert!(d.iter().all(|d| d.code != "read-cleared"), "{quiet}: {d:#?}");
    }
}

/// A shader parameter without a default cannot be set anywhere yet: the
/// error says so at the parameter, and its help declares it a default or
/// a uniform, either of which checks.
#[test]
fn a_shader_parameter_without_a_default_gets_a_default_or_a_uniform() {
    let src = "vector N : normal;\nvector L : light;\nshader d(k: scalar) : s → c = k * max(0, N·L);\nC δπx ← δ d s x;\n";
    let (_, d) = lower(src);
    let e = d.iter().find(|d| d.is_error()).expect("an error");
    assert_eq!(&src[e.primary.span.range()], "k");
    assert_eq!(
        e.help.as_deref(),
        Some("give it one, `k: scalar = …`; for a value the scene sets, declare `uniform k : scalar = …;` and drop the parameter")
    );
    lower_ok(&src.replace("(k: scalar)", "(k: scalar = 0.5)"));
    lower_ok(&src.replace("shader d(k: scalar)", "uniform k : scalar = 0.5;\nshader d"));
}
