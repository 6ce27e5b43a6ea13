//! IR → register combiners (issue 4 parts 5 and 6): every supported
//! operation compiles to a valid config that, emulated in f32 on random
//! texels, matches the expression evaluated directly; Kilgard's passes 2
//! and 3 compile to configs bit-identical in fixed9 to his Appendix G and H
//! setups; unsupported operations and running out of stages are errors.

mod combiners_common;
use combiners_common as common;

use shadec::backends::combiners::emulator::{emulate, Inputs, Precision};
use shadec::backends::combiners::{generate, validate, CodegenError, CombinerConfig, CombinerLimits, Generated, PassInput};
use shadec::ir::{self, BinaryOp, Expr, Handle, MathFunction, Module, Ty, UnaryOp};

// ---------------------------------------------------------------------------
// Helpers.

fn lower(src: &str) -> Module {
    let (program, d) = shadec::parser::check(src);
    assert!(d.iter().all(|d| !d.is_error()), "does not check:\n{src}\n{d:#?}");
    let (m, d) = ir::lower(&program);
    let errors: Vec<_> = d.iter().filter(|d| d.is_error()).collect();
    assert!(errors.is_empty(), "lowering errors:\n{src}\n{errors:#?}");
    m
}

/// A pass reading textures A (unit 0) and B (unit 1); `value` is the
/// fragment colour.
fn program(value: &str) -> String {
    format!(
        "target geforce3;
vector N : normal;
vector L : light(0);
const kd : rgb = (0.8, 0.6, 0.4);
texture A : 2d rgba8 = image(\"a.png\");
texture B : 2d rgba8 = image(\"b.png\");
framebuffer C : rgba8;
shader p : s → c = kd * max(0, N·L);
let a = A δu x;
let b = B δu x;
let g = δ p s x;
C δπx ← {value};
"
    )
}

fn lookups(m: &Module) -> Vec<Handle<Expr>> {
    let mut units: Vec<(u32, Handle<Expr>)> = m
        .exprs
        .arena()
        .iter()
        .filter_map(|(h, e)| match e {
            Expr::Lookup { texture, .. } => Some((*texture, h)),
            _ => None,
        })
        .collect();
    units.sort();
    units.into_iter().map(|(_, h)| h).collect()
}

fn value_src_keeps_splat(value: &str) -> bool {
    value.starts_with("splat ")
}

fn compile(value_src: &str, limits: &CombinerLimits) -> (Module, Handle<Expr>, Result<Generated, CodegenError>) {
    let value = value_src.strip_prefix("splat ").unwrap_or(value_src);
    let m = lower(&program(value));
    let mut v = m.statements.last().unwrap().value;
    // A scalar statement value is splatted to rgba (alpha = the scalar); test
    // the scalar itself (rgb broadcast, alpha 1) unless asked not to.
    if let Expr::Convert { value, .. } = &m.exprs[v] {
        if m.info(*value).ty == Ty::Scalar && !value_src_keeps_splat(value_src) {
            v = *value;
        }
    }
    let units = lookups(&m);
    let r = generate(&PassInput { module: &m, value: v, units: &units }, limits);
    (m, v, r)
}

/// A fixed-seed xorshift generator.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn bytes(&mut self, n: usize) -> Vec<u8> {
        (0..n).map(|_| (self.next() >> 24) as u8).collect()
    }
}

/// Random RGBA8 images, with the edge values 0, 128, 255 (and 127) in
/// every channel of the first pixels.
fn images(n: usize, count: usize, seed: u64) -> Vec<Vec<u8>> {
    let mut rng = Rng(seed);
    let edges = [0u8, 127, 128, 255];
    (0..count)
        .map(|k| {
            let mut img = rng.bytes(n * 4);
            // Every combination of edge values across the images' first pixels.
            for p in 0..edges.len().pow(count as u32).min(n) {
                let e = edges[(p / edges.len().pow(k as u32)) % edges.len()];
                for ch in 0..4 {
                    img[p * 4 + ch] = if (p + ch) % 5 == 4 { img[p * 4 + ch] } else { e };
                }
            }
            img
        })
        .collect()
}

// ---------------------------------------------------------------------------
// A reference evaluator for the node kinds the tests use (f64).

struct Env<'a> {
    texels: &'a [[f64; 4]],
    units: &'a [Handle<Expr>],
    primary: Option<(Handle<Expr>, [f64; 4])>,
}

fn eval(m: &Module, h: Handle<Expr>, env: &Env) -> [f64; 4] {
    let ev = |x: Handle<Expr>| eval(m, x, env);
    let map = |v: [f64; 4], f: &dyn Fn(f64) -> f64| v.map(f);
    let zip = |a: [f64; 4], b: [f64; 4], f: &dyn Fn(f64, f64) -> f64| {
        let mut o = [0.0; 4];
        for i in 0..4 {
            o[i] = f(a[i], b[i]);
        }
        o
    };
    // Scalars are stored broadcast in all four components.
    match &m.exprs[h] {
        Expr::Constant(c) => {
            let v = c.values();
            if v.len() == 1 {
                [v[0]; 4]
            } else {
                [v[0], v[1], v[2], *v.get(3).unwrap_or(&1.0)]
            }
        }
        Expr::Lookup { .. } => {
            let u = env.units.iter().position(|u| *u == h).expect("bound");
            env.texels[u]
        }
        Expr::Interpolate { .. } => {
            let (ph, v) = env.primary.expect("a primary colour");
            assert_eq!(ph, h);
            v
        }
        Expr::Swizzle { value, pattern, len, .. } => {
            let v = ev(*value);
            match &pattern[..*len as usize] {
                [0, 1, 2] => [v[0], v[1], v[2], 1.0],
                [i] => [v[*i as usize]; 4],
                p => panic!("swizzle {p:?}"),
            }
        }
        Expr::Convert { value, to } => {
            let v = ev(*value);
            if m.info(*value).ty == Ty::Rgb && *to == Ty::Rgba {
                [v[0], v[1], v[2], 1.0]
            } else {
                v
            }
        }
        Expr::Compose { components, .. } => {
            let c = ev(components[0]);
            let a = ev(components[1]);
            [c[0], c[1], c[2], a[0]]
        }
        Expr::Unary { op: UnaryOp::Neg, value } => map(ev(*value), &|x| -x),
        Expr::Binary { op, lhs, rhs } => {
            let (a, b) = (ev(*lhs), ev(*rhs));
            match op {
                BinaryOp::Add => zip(a, b, &|x, y| x + y),
                BinaryOp::Sub => zip(a, b, &|x, y| x - y),
                BinaryOp::Mul => zip(a, b, &|x, y| x * y),
                BinaryOp::Pow => zip(a, b, &|x, y| x.powf(y)),
                // The IR takes a dot product as one of unit vectors, in [−1, 1] (the
                // combiners clamp it there, seeds/003 Section 4.2.2).
                BinaryOp::Dot => [(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0); 4],
                BinaryOp::Ge => [f64::from(u8::from(a[0] >= b[0])); 4],
                BinaryOp::Gt => [f64::from(u8::from(a[0] > b[0])); 4],
                BinaryOp::Lt => [f64::from(u8::from(a[0] < b[0])); 4],
                BinaryOp::Le => [f64::from(u8::from(a[0] <= b[0])); 4],
                op => panic!("{op:?}"),
            }
        }
        Expr::Math { fun, args } => {
            let a: Vec<[f64; 4]> = args.iter().map(|x| ev(*x)).collect();
            match fun {
                MathFunction::Expand => map(a[0], &|x| 2.0 * x - 1.0),
                MathFunction::HalfBias => map(a[0], &|x| x - 0.5),
                MathFunction::Compress => map(a[0], &|x| (x + 1.0) / 2.0),
                MathFunction::Saturate => map(a[0], &|x| x.clamp(0.0, 1.0)),
                MathFunction::Max => zip(a[0], a[1], &|x, y| x.max(y)),
                MathFunction::Mix => {
                    let mut o = [0.0; 4];
                    for i in 0..4 {
                        o[i] = a[0][i] * (1.0 - a[2][i]) + a[1][i] * a[2][i];
                    }
                    o
                }
                f => panic!("{f:?}"),
            }
        }
        Expr::Select { cond, accept, reject } => {
            if ev(*cond)[0] != 0.0 {
                ev(*accept)
            } else {
                ev(reject.expect("two-way"))
            }
        }
        e => panic!("{e:?}"),
    }
}

/// The pass's RGBA8 output per the DSL: saturate, scalar broadcast, alpha
/// 1 unless the value is rgba.
fn reference(m: &Module, v: Handle<Expr>, env: &Env) -> [f64; 4] {
    let x = eval(m, v, env);
    let a = if m.info(v).ty == Ty::Rgba { x[3] } else { 1.0 };
    [x[0], x[1], x[2], a].map(|c| c.clamp(0.0, 1.0) * 255.0)
}

/// Compiles `value`, emulates it in f32 and compares with the reference.
/// Returns the largest difference in 8-bit levels.
#[track_caller]
fn check(value: &str, tolerance: f64) -> Generated {
    let (m, v, r) = compile(value, &CombinerLimits::GEFORCE3);
    let g = r.unwrap_or_else(|e| panic!("{value}: {e} ({})", e.help()));
    assert!(validate(&g.config, &CombinerLimits::GEFORCE3).is_ok());
    let units = lookups(&m);
    let (w, h) = (64, 32);
    let n = w * h;
    let imgs = images(n, 3, 0x5eed_0000 + value.len() as u64);
    let inputs = Inputs {
        width: w,
        height: h,
        textures: [Some(&imgs[0]), Some(&imgs[1]), None, None],
        primary: Some(&imgs[2]),
        ..Inputs::default()
    };
    let out = emulate(&g.config, &inputs, Precision::F32).unwrap();
    let texel = |img: &[u8], p: usize| [0, 1, 2, 3].map(|c| f64::from(img[p * 4 + c]) / 255.0);
    let mut worst = 0.0f64;
    for p in 0..n {
        let texels = [texel(&imgs[0], p), texel(&imgs[1], p)];
        let env = Env { texels: &texels, units: &units, primary: g.primary.map(|h| (h, texel(&imgs[2], p))) };
        let want = reference(&m, v, &env);
        for c in 0..4 {
            let d = (f64::from(out[p * 4 + c]) - want[c]).abs();
            worst = worst.max(d);
            assert!(d <= tolerance, "{value}: pixel {p} channel {c}: emulated {} want {:.3}\n{}", out[p * 4 + c], want[c], g.config.to_ron());
        }
    }
    g
}

// ---------------------------------------------------------------------------
// Every supported operation, emulated in f32 against the reference.
// f32 emulation rounds only at the output: ½ level, plus f32 noise.

const TOL: f64 = 0.5 + 1e-3;

#[test]
fn products_and_leaves() {
    check("a", TOL);
    check("a * b", TOL);
    check("a.rgb * b.a", TOL);
    check("a.a", TOL);
    check("kd * a.rgb", TOL);
    check("1 - a.rgb", TOL);
    check("rgba(a.rgb * b.rgb, a.a * b.a)", TOL);
}

#[test]
fn three_and_more_factors_use_the_ef_product() {
    let g = check("a.rgb * b.rgb * a.a", TOL);
    assert_eq!(g.stages, 0, "A · (E·F) needs no general combiner");
    let g = check("kd * a.a * b.rgb * b.a * a.rgb", TOL);
    assert!(g.stages >= 1);
}

#[test]
fn sums_and_differences() {
    let g = check("a.rgb + b.rgb", TOL);
    assert_eq!(g.stages, 0, "C + D in the final combiner");
    check("a.rgb * b.a + kd", TOL);
    check("a.rgb - b.rgb", TOL);
    check("b.rgb - a.rgb * b.a", TOL);
    check("a.rgb * b.rgb + b.rgb * a.a + kd * a.a", TOL);
}

#[test]
fn dot_products_signed_and_unsigned() {
    check("expand(a.rgb) · expand(b.rgb)", TOL);
    check("max(0, expand(a.rgb) · expand(b.rgb))", TOL);
    check("a.rgb · b.rgb", TOL);
    check("kd * max(0, expand(a.rgb) · expand(b.rgb))", TOL);
    check("rgba(kd, max(0, expand(a.rgb) · expand(b.rgb)))", TOL);
}

#[test]
fn range_expansion_half_bias_and_compression() {
    check("expand(a.rgb) * b.rgb", TOL);
    check("-expand(a.rgb) * b.rgb", TOL);
    check("half_bias(a.rgb) + half_bias(b.rgb)", TOL);
    check("compress(expand(a.rgb) · expand(b.rgb))", TOL);
    check("expand(a.rgb * b.rgb)", TOL);
    check("half_bias(a.rgb * b.a)", TOL);
}

#[test]
fn saturation_scale_and_bias() {
    check("saturate(8 * expand(b.b))", TOL);
    check("saturate(4 * half_bias(a.a))", TOL);
    check("2 * (a.rgb * b.rgb)", TOL);
    check("saturate(4 * (a.rgb * b.rgb))", TOL);
    check("0.5 * (a.rgb + b.rgb)", TOL);
    check("a.rgb + 0.5", TOL);
    check("a.rgb - 0.5", TOL);
    check("(0.3, 0.6, 0.9) * a.rgb + (0.2, 0.1, 0)", TOL);
    check("0.3 * a.rgb", TOL);
}

#[test]
fn comparisons_through_the_mux() {
    check("a.a ≥ 0.5 ? a.rgb : b.rgb", TOL);
    check("a.a < 0.5 ? a.rgb : b.rgb", TOL);
    check("expand(b.b) ≥ 0 ? a.rgb : 0", TOL);
    check("expand(a.rgb) · expand(b.rgb) ≥ 0 ? kd : b.rgb", TOL);
    check("a.a ≥ 0.5", TOL);
}

#[test]
fn blue_to_alpha_and_alpha_reads() {
    // .b in an rgb computation goes through an alpha portion.
    check("a.rgb * expand(b.b) + b.rgb * a.a", TOL);
    check("a.rgb * b.b", TOL);
    check("rgba(a.rgb, expand(a.rgb) · expand(b.rgb))", TOL);
}

#[test]
fn mix_is_a_lerp() {
    let g = check("mix(a.rgb, b.rgb, a.a)", TOL);
    assert_eq!(g.stages, 0, "A·B + (1 − A)·C");
    check("mix(a.rgb, b.rgb, a.a) * b.a", TOL);
}

/// Powers of two by repeated squaring: the final combiner squares twice
/// (E·F, then EF·EF), general combiners the rest. In f32 the rounding is
/// only at the output.
#[test]
fn exponents_by_repeated_squaring() {
    let g = check("max(0, expand(a.rgb) · expand(b.rgb))^4", TOL);
    assert_eq!(g.stages, 1, "the dot product; then EF · EF");
    check("max(0, expand(a.rgb) · expand(b.rgb))^8", TOL);
    check("max(0, expand(a.rgb) · expand(b.rgb))^16", TOL);
    check("a.rgb^2", TOL);
    check("kd * a.a^4", TOL);
    check("expand(b.b) ≥ 0 ? max(0, expand(a.rgb) · expand(b.rgb))^8 : 0", TOL);
}

/// A scalar statement value is splatted to rgba by the IR: alpha is the
/// scalar too (G needs it in an alpha register).
#[test]
fn a_splatted_scalar_writes_alpha_too() {
    check("splat max(0, expand(a.rgb) · expand(b.rgb))^4", TOL);
    check("splat a.a * b.b", TOL);
}

#[test]
fn interpolated_colours_go_to_primary() {
    let g = check("g * a.rgb", TOL);
    assert!(g.primary.is_some() && g.secondary.is_none());
    assert_eq!(g.config.final_combiner.a.source, shadec::backends::combiners::FinalSource::Register(shadec::backends::combiners::Register::Primary));
}

#[test]
fn constants_go_to_constant_colours() {
    let (m, _, r) = compile("kd * a.rgb + (0.2, 0.1, 0)", &CombinerLimits::GEFORCE3);
    let g = r.unwrap();
    assert_eq!(g.config.constant0.map(|c| [c[0], c[1], c[2]]), Some([0.2, 0.1, 0.0]));
    assert_eq!(g.config.constant1.map(|c| [c[0], c[1], c[2]]), Some([0.8, 0.6, 0.4]));
    assert!(g.constants.iter().all(|c| matches!(c.map(|h| &m.exprs[h]), Some(Expr::Constant(_)))));
    // 0, 1, ½ need no constant colour.
    let (_, _, r) = compile("a.rgb * 0.5 + b.rgb * (1 - a.a)", &CombinerLimits::GEFORCE3);
    let g = r.unwrap();
    assert_eq!((g.config.constant0, g.config.constant1), (None, None));
}

#[test]
fn spare_registers_are_reused() {
    // Four dependent products: each result dies when the next is computed.
    let (_, _, r) = compile("expand(a.rgb) * expand(b.rgb) * expand(a.a) * expand(b.a) * expand(b.b)", &CombinerLimits::GEFORCE3);
    let g = r.unwrap();
    let written: std::collections::HashSet<_> =
        g.config.general.iter().flat_map(|s| [s.rgb.ab_output, s.rgb.sum_output]).flatten().collect();
    assert!(g.stages >= 3);
    assert_eq!(written.len(), 1, "one spare register suffices: {written:?}");
}

// ---------------------------------------------------------------------------
// Errors.

#[track_caller]
fn error(value: &str, limits: &CombinerLimits) -> (CodegenError, String) {
    let src = program(value);
    let (_, _, r) = compile(value, limits);
    let src = src.as_str();
    let e = r.expect_err(value);
    let text = e.span().map(|s| src[s.range()].to_string()).unwrap_or_default();
    (e, text)
}

#[test]
fn unsupported_operations_name_the_node_and_suggest_a_lookup() {
    let (e, text) = error("a.rgb / (b.a + 0.5)", &CombinerLimits::GEFORCE3);
    assert!(matches!(e, CodegenError::Unsupported { .. }), "{e:?}");
    assert_eq!(text, "a.rgb / (b.a + 0.5)");
    assert!(e.help().contains("lookup texture"), "{}", e.help());

    let (e, text) = error("sqrt(a.a) * a.rgb", &CombinerLimits::GEFORCE3);
    assert!(matches!(e, CodegenError::Unsupported { .. }));
    assert_eq!(text, "sqrt(a.a)");
    assert!(e.help().contains("lookup texture"));

    let (e, text) = error("a.a ^ 3", &CombinerLimits::GEFORCE3);
    assert!(matches!(e, CodegenError::Unsupported { .. }));
    assert_eq!(text, "a.a ^ 3");
    assert!(e.help().contains("lookup texture"));

    let (e, text) = error("normalize(expand(a.rgb)) · expand(b.rgb)", &CombinerLimits::GEFORCE3);
    assert!(matches!(e, CodegenError::Unsupported { .. }));
    assert_eq!(text, "normalize(expand(a.rgb))");
    assert!(e.help().contains("normalization cube map"), "{}", e.help());

    let (e, _) = error("a.r * b.rgb", &CombinerLimits::GEFORCE3);
    assert!(matches!(e, CodegenError::Unsupported { .. }));

    let (e, text) = error("a.a ≥ 0.3 ? a.rgb : b.rgb", &CombinerLimits::GEFORCE3);
    assert!(matches!(e, CodegenError::Unsupported { .. }));
    assert_eq!(text, "a.a ≥ 0.3");
    let d = e.to_diagnostic();
    assert!(d.is_error());
}

#[test]
fn intermediate_values_outside_the_combiner_range_are_errors() {
    // (a + b) may reach 2; the general combiners would clamp it before the product.
    let (e, text) = error("(a.rgb + b.rgb) * expand(a.a)", &CombinerLimits::GEFORCE3);
    assert!(matches!(e, CodegenError::Range { .. }), "{e:?}");
    assert_eq!(text, "(a.rgb + b.rgb)");
    // With an explicit clamp it compiles.
    check("saturate(a.rgb + b.rgb) * expand(a.a)", TOL);
}

#[test]
fn running_out_of_general_combiners_is_its_own_error() {
    let value = "expand(a.rgb) * expand(b.rgb) * expand(a.a) * expand(b.a)";
    let (e, _) = error(value, &CombinerLimits::GEFORCE256);
    assert_eq!(e, CodegenError::OutOfStages { needed: 3, available: 2 });
    let (_, _, r) = compile(value, &CombinerLimits::GEFORCE3);
    assert_eq!(r.unwrap().stages, 3);
}

// ---------------------------------------------------------------------------
// Golden test (issue 4 part 6): Kilgard's passes 2 and 3.

struct Kilgard {
    m: Module,
    /// `rgba(diffuse, s_self)`: the right operand of pass 2's modulate.
    pass2: Handle<Expr>,
    /// `specular`: pass 3's fragment colour (its α C factor is the blend's
    /// GL_DST_ALPHA).
    pass3: Handle<Expr>,
    normal_map: Handle<Expr>,
    l_cube: Handle<Expr>,
    h_cube: Handle<Expr>,
}

fn kilgard() -> Kilgard {
    let src = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/kilgard_bump_mapping.shd")).unwrap();
    let m = lower(&src);
    let rhs = |h: Handle<Expr>| match &m.exprs[h] {
        Expr::Combine { rhs, .. } => *rhs,
        e => panic!("{e:?}"),
    };
    let pass2 = rhs(m.statements[1].value);
    let pass3 = match &m.exprs[rhs(m.statements[2].value)] {
        // (α C δπx) * specular
        Expr::Binary { op: BinaryOp::Mul, lhs, rhs } => {
            assert!(matches!(m.exprs[*lhs], Expr::FramebufferRead { .. }));
            *rhs
        }
        e => panic!("{e:?}"),
    };
    let texture = |name: &str| m.textures.iter().position(|t| t.name == name).unwrap() as u32;
    let lookup = |tex: u32, vector: &str| {
        let v = m.vectors.iter().position(|x| x.name == vector);
        m.exprs
            .arena()
            .iter()
            .find(|(_, e)| match e {
                Expr::Lookup { texture, coords } if *texture == tex => match (v, &m.exprs[*coords]) {
                    (None, _) => true,
                    (Some(v), Expr::Interpolate { value, .. }) => matches!(m.exprs[*value], Expr::Vector { vector, .. } if vector as usize == v),
                    _ => false,
                },
                _ => false,
            })
            .map(|(h, _)| h)
            .unwrap()
    };
    let (tn, ncube) = (texture("Tn"), texture("Ncube"));
    Kilgard { normal_map: lookup(tn, ""), l_cube: lookup(ncube, "L"), h_cube: lookup(ncube, "H"), pass2, pass3, m }
    .fix()
}

impl Kilgard {
    /// `lookup(tn, "")` found the normal map (no vector in its coordinates).
    fn fix(self) -> Kilgard {
        assert_ne!(self.l_cube, self.h_cube);
        self
    }
}

/// Runs both configs in fixed9 on the same random 8-bit texels (plus edge
/// values) and compares the given channels.
#[track_caller]
fn same_outputs(generated: &CombinerConfig, appendix: &CombinerConfig, channels: &[usize], what: &str) {
    let (w, h) = (256, 64);
    let n = w * h;
    let imgs = images(n, 2, 0x00c0_ffee);
    let inputs = Inputs { width: w, height: h, textures: [Some(&imgs[0]), Some(&imgs[1]), None, None], ..Inputs::default() };
    let a = emulate(generated, &inputs, Precision::Fixed9).unwrap();
    let b = emulate(appendix, &inputs, Precision::Fixed9).unwrap();
    let mut differ = 0;
    for p in 0..n {
        for &c in channels {
            if a[p * 4 + c] != b[p * 4 + c] {
                differ += 1;
                if differ < 5 {
                    eprintln!("{what}: pixel {p} channel {c}: generated {} appendix {} (t0 {:?} t1 {:?})", a[p * 4 + c], b[p * 4 + c], &imgs[0][p * 4..p * 4 + 4], &imgs[1][p * 4..p * 4 + 4]);
                }
            }
        }
    }
    assert_eq!(differ, 0, "{what}: {differ} channel values differ");
}

#[test]
fn golden_pass_2_is_appendix_g() {
    let k = kilgard();
    let units = [k.normal_map, k.l_cube];
    let g = generate(&PassInput { module: &k.m, value: k.pass2, units: &units }, &CombinerLimits::GEFORCE256).unwrap();
    assert_eq!(g.stages, 2, "Appendix G uses both general combiners");
    let appendix = CombinerConfig::from_ron(&common::data("appendix_g.ron")).unwrap();
    // Appendix G defines all four channels: rgb = ambient + diffuse, alpha = s_self.
    same_outputs(&g.config, &appendix, &[0, 1, 2, 3], "pass 2 vs Appendix G");
    // And the nvparse transcription.
    let rc = shadec::backends::combiners::rc1::parse_and_validate(&common::data("appendix_g.rc"), &CombinerLimits::GEFORCE256).unwrap();
    same_outputs(&g.config, &rc, &[0, 1, 2, 3], "pass 2 vs appendix_g.rc");
}

#[test]
fn golden_pass_3_is_appendix_h() {
    let k = kilgard();
    let units = [k.normal_map, k.h_cube];
    let g = generate(&PassInput { module: &k.m, value: k.pass3, units: &units }, &CombinerLimits::GEFORCE256).unwrap();
    assert_eq!(g.stages, 2, "Appendix H uses both general combiners");
    let appendix = CombinerConfig::from_ron(&common::data("appendix_h.ron")).unwrap();
    // Only rgb: the pass's value `specular` is a scalar, whose alpha the DSL
    // leaves at 1 (an rgb/scalar output), while Appendix H writes
    // out.a = zero. With glBlendFunc(GL_DST_ALPHA, GL_ONE) the written alpha
    // only matters if destination alpha is written in pass 3, which the
    // paper does not rely on.
    same_outputs(&g.config, &appendix, &[0, 1, 2], "pass 3 vs Appendix H");
    let rc = shadec::backends::combiners::rc1::parse_and_validate(&common::data("appendix_h.rc"), &CombinerLimits::GEFORCE256).unwrap();
    same_outputs(&g.config, &rc, &[0, 1, 2], "pass 3 vs appendix_h.rc");
}

/// The golden configs are, up to unused state, Kilgard's: print them for
/// the record (`cargo test -- --nocapture golden_configs`).
#[test]
fn golden_configs_print_as_rc() {
    let k = kilgard();
    for (value, cube) in [(k.pass2, k.l_cube), (k.pass3, k.h_cube)] {
        let units = [k.normal_map, cube];
        let g = generate(&PassInput { module: &k.m, value, units: &units }, &CombinerLimits::GEFORCE256).unwrap();
        let text = shadec::backends::combiners::rc1::print(&g.config);
        println!("{text}");
        assert!(shadec::backends::combiners::rc1::parse_and_validate(&text, &CombinerLimits::GEFORCE256).is_ok());
    }
}
