//! The semantics of `apply` and the evaluator, case by case: range
//! mappings, broadcasting, comparisons, the texture environment, discards,
//! unanswered leaves, and Kilgard 2000's diffuse and specular by hand.

use super::*;
use crate::ir::{valid, FbChannel, Statement, Uniform};
use crate::numerics::Precision;
use crate::span::Span;
use proptest::prelude::*;

fn node(m: &mut Module, e: Expr) -> Handle<Expr> {
    let info = valid::infer(m, &e).unwrap_or_else(|err| panic!("{e:?}: {err:?}"));
    let (h, new) = m.exprs.insert(e, Span::DETACHED);
    if new {
        m.info.push(info);
    }
    h
}

fn k(m: &mut Module, ty: Ty, v: &[f64]) -> Handle<Expr> {
    node(m, Expr::Constant(Constant::new(ty, v)))
}

fn uniform(m: &mut Module, name: &str, ty: Ty) -> Handle<Expr> {
    m.uniforms.push(Uniform { name: name.into(), ty, default: None, span: Span::DETACHED });
    node(m, Expr::Uniform(m.uniforms.len() as u32 - 1))
}

/// `apply` on a node whose operands are constants, and what `fold` makes of it.
fn ap(m: &Module, e: &Expr) -> (Value, Option<Constant>) {
    let ty = valid::infer(m, e).unwrap().ty;
    let ops: Vec<Value> = e
        .operands()
        .iter()
        .map(|h| match &m.exprs[*h] {
            Expr::Constant(c) => value(c),
            _ => panic!("not a constant"),
        })
        .collect();
    (apply(m, e, ty, &ops), valid::fold(m, e, ty))
}

#[track_caller]
fn close(a: &[f64], b: &[f64]) {
    assert_eq!(a.len(), b.len(), "{a:?} vs {b:?}");
    for (x, y) in a.iter().zip(b) {
        assert!((x - y).abs() < 1e-12, "{a:?} vs {b:?}");
    }
}

/// `apply`'s value, checked against `fold`'s constant (which must exist).
#[track_caller]
fn folds(m: &Module, e: Expr, want: &[f64]) {
    let (v, c) = ap(m, &e);
    close(&v[..want.len()], want);
    let c = c.unwrap_or_else(|| panic!("{e:?} does not fold"));
    close(c.values(), want);
}

fn math(fun: MathFunction, args: &[Handle<Expr>]) -> Expr {
    Expr::Math { fun, args: args.to_vec() }
}

#[test]
fn range_mappings_of_seeds_003_table_3() {
    let mut m = Module::default();
    let x = k(&mut m, Ty::Scalar, &[0.75]);
    folds(&m, math(MathFunction::Expand, &[x]), &[0.5]);
    folds(&m, math(MathFunction::HalfBias, &[x]), &[0.25]);
    folds(&m, math(MathFunction::Compress, &[x]), &[0.875]);
    let c = k(&mut m, Ty::Rgb, &[0.0, 0.5, 1.0]);
    folds(&m, math(MathFunction::Expand, &[c]), &[-1.0, 0.0, 1.0]);
}

#[test]
fn arithmetic_broadcasts_scalars_and_dot_sums_the_width() {
    let mut m = Module::default();
    let kd = k(&mut m, Ty::Rgb, &[0.8, 0.6, 0.4]);
    let half = k(&mut m, Ty::Scalar, &[0.5]);
    let two = k(&mut m, Ty::Scalar, &[2.0]);
    folds(&m, Expr::Binary { op: BinaryOp::Mul, lhs: kd, rhs: half }, &[0.4, 0.3, 0.2]);
    folds(&m, Expr::Binary { op: BinaryOp::Sub, lhs: half, rhs: kd }, &[-0.3, -0.1, 0.1]);
    folds(&m, Expr::Binary { op: BinaryOp::Pow, lhs: kd, rhs: two }, &[0.64, 0.36, 0.16]);
    folds(&m, Expr::Binary { op: BinaryOp::Dot, lhs: kd, rhs: kd }, &[0.64 + 0.36 + 0.16]);
    folds(&m, Expr::Binary { op: BinaryOp::Dot, lhs: half, rhs: two }, &[1.0]);
    folds(&m, Expr::Unary { op: UnaryOp::Neg, value: kd }, &[-0.8, -0.6, -0.4]);
    folds(&m, math(MathFunction::Max, &[half, kd]), &[0.8, 0.6, 0.5]);
    let hi = k(&mut m, Ty::Scalar, &[0.7]);
    folds(&m, math(MathFunction::Clamp, &[kd, half, hi]), &[0.7, 0.6, 0.5]);
    folds(&m, math(MathFunction::Mix, &[kd, half, half]), &[0.65, 0.55, 0.45]);
    folds(&m, math(MathFunction::Step, &[half, kd]), &[1.0, 1.0, 0.0]);
    let v = k(&mut m, Ty::Vec3, &[3.0, 0.0, 4.0]);
    folds(&m, math(MathFunction::Length, &[v]), &[5.0]);
    folds(&m, math(MathFunction::Normalize, &[v]), &[0.6, 0.0, 0.8]);
    // A scalar result is splatted in every lane (the layout of `Value`).
    let (d, _) = ap(&m, &math(MathFunction::Length, &[v]));
    assert_eq!(d, [5.0; 4]);
    // 1/0 is an operation, not a constant: fold keeps only finite results.
    let zero = k(&mut m, Ty::Scalar, &[0.0]);
    let (inf, c) = ap(&m, &Expr::Binary { op: BinaryOp::Div, lhs: two, rhs: zero });
    assert_eq!((inf[0], c), (f64::INFINITY, None));
}

#[test]
fn cross_and_glsl_reflect() {
    let mut m = Module::default();
    let x = k(&mut m, Ty::Vec3, &[1.0, 0.0, 0.0]);
    let y = k(&mut m, Ty::Vec3, &[0.0, 1.0, 0.0]);
    folds(&m, math(MathFunction::Cross, &[x, y]), &[0.0, 0.0, 1.0]);
    folds(&m, math(MathFunction::Cross, &[y, x]), &[0.0, 0.0, -1.0]);
    // reflect(I, N) = I − 2(N·I)N: a ray going down bounces up off a floor.
    let i = k(&mut m, Ty::Vec3, &[1.0, -1.0, 0.5]);
    folds(&m, math(MathFunction::Reflect, &[i, y]), &[1.0, 1.0, 0.5]);
    let n = k(&mut m, Ty::Vec3, &[0.6, 0.8, 0.0]);
    let d = 0.6 - 0.8;
    folds(&m, math(MathFunction::Reflect, &[i, n]), &[1.0 - 2.0 * d * 0.6, -1.0 - 2.0 * d * 0.8, 0.5]);
}

#[test]
fn comparisons_logic_and_selection_are_zero_or_one() {
    let mut m = Module::default();
    let a = k(&mut m, Ty::Scalar, &[0.25]);
    let b = k(&mut m, Ty::Scalar, &[0.75]);
    let zero = k(&mut m, Ty::Scalar, &[0.0]);
    for (op, want) in [
        (BinaryOp::Lt, 1.0),
        (BinaryOp::Le, 1.0),
        (BinaryOp::Gt, 0.0),
        (BinaryOp::Ge, 0.0),
        (BinaryOp::Eq, 0.0),
        (BinaryOp::Ne, 1.0),
        (BinaryOp::And, 1.0),
        (BinaryOp::Or, 1.0),
    ] {
        folds(&m, Expr::Binary { op, lhs: a, rhs: b }, &[want]);
    }
    folds(&m, Expr::Binary { op: BinaryOp::And, lhs: a, rhs: zero }, &[0.0]);
    folds(&m, Expr::Unary { op: UnaryOp::Not, value: zero }, &[1.0]);
    folds(&m, Expr::Unary { op: UnaryOp::Not, value: b }, &[0.0]);
    let c = k(&mut m, Ty::Rgb, &[0.1, 0.2, 0.3]);
    folds(&m, Expr::Select { cond: a, accept: c, reject: Some(b) }, &[0.1, 0.2, 0.3]);
    folds(&m, Expr::Select { cond: zero, accept: c, reject: Some(b) }, &[0.75, 0.75, 0.75]);
    // `c ? a` keeps the destination where c fails: no value, and never folded.
    let (v, f) = ap(&m, &Expr::Select { cond: zero, accept: c, reject: None });
    assert!(v[..3].iter().all(|x| x.is_nan()) && f.is_none());
    let (v, f) = ap(&m, &Expr::Select { cond: a, accept: c, reject: None });
    close(&v[..3], &[0.1, 0.2, 0.3]);
    assert!(f.is_none());
}

#[test]
fn normalize_of_zero_is_zero() {
    // docs/numerics.md: the half vector of L = −V, a zero-length normal.
    let m = Module::default();
    let h = Handle::new(0);
    assert_eq!(super::math(&m, MathFunction::Normalize, &[h], Ty::Vec3, &[[0.0; 4]]), [0.0; 4]);
    let v = super::math(&m, MathFunction::Normalize, &[h], Ty::Vec3, &[[3.0, 0.0, 4.0, 0.0]]);
    close(&v[..3], &[0.6, 0.0, 0.8]);
}

#[test]
fn swizzle_compose_convert() {
    let mut m = Module::default();
    let c = k(&mut m, Ty::Rgba, &[0.1, 0.2, 0.3, 0.4]);
    let s = k(&mut m, Ty::Scalar, &[0.5]);
    folds(&m, Expr::Swizzle { value: c, pattern: [3, 2, 0, 0], len: 2, ty: Ty::Vec2 }, &[0.4, 0.3]);
    folds(&m, Expr::Swizzle { value: c, pattern: [3, 0, 0, 0], len: 1, ty: Ty::Scalar }, &[0.4]);
    let rgb = k(&mut m, Ty::Rgb, &[0.1, 0.2, 0.3]);
    folds(&m, Expr::Compose { ty: Ty::Rgba, components: vec![rgb, s] }, &[0.1, 0.2, 0.3, 0.5]);
    folds(&m, Expr::Compose { ty: Ty::Vec3, components: vec![s, s, s] }, &[0.5, 0.5, 0.5]);
    folds(&m, Expr::Convert { value: rgb, to: Ty::Rgba }, &[0.1, 0.2, 0.3, 1.0]);
    folds(&m, Expr::Convert { value: s, to: Ty::Rgb }, &[0.5, 0.5, 0.5]);
}

#[test]
fn combine_modes_follow_the_texture_environment() {
    use CombineMode::*;
    let mut m = Module::default();
    // Left: the texture (Ct, At); right: the incoming fragment (Cf, Af).
    let t = k(&mut m, Ty::Rgba, &[0.2, 0.4, 0.6, 0.25]);
    let f = k(&mut m, Ty::Rgba, &[1.0, 0.8, 0.4, 0.5]);
    let comb = |mode| Expr::Combine { mode, lhs: t, rhs: f };
    folds(&m, comb(Modulate), &[0.2, 0.32, 0.24, 0.125]);
    folds(&m, comb(Add), &[1.2, 1.2, 1.0, 0.75]);
    folds(&m, comb(AddSigned), &[0.7, 0.7, 0.5, 0.25]);
    folds(&m, comb(Subtract), &[-0.8, -0.4, 0.2, -0.25]);
    // decal: Cf(1 − At) + Ct·At, Af.
    folds(&m, comb(Decal), &[0.8, 0.7, 0.45, 0.5]);
    // blend: Cf(1 − Ct) + Cc·Ct with GL's default Cc = 0; Af·At.
    folds(&m, comb(Blend), &[0.8, 0.48, 0.16, 0.125]);
    folds(&m, comb(Replace), &[0.2, 0.4, 0.6, 0.25]);
    // interpolate: Ct·At + Cf(1 − At), in every lane.
    folds(&m, comb(Interpolate), &[0.8, 0.7, 0.45, 0.25 * 0.25 + 0.5 * 0.75]);
    // dot3: 4((Ct − ½)·(Cf − ½)) over r, g, b, splatted; dot3_rgb keeps At·Af.
    let d = 4.0 * (-0.3 * 0.5 + -0.1 * 0.3 + 0.1 * -0.1);
    folds(&m, comb(Dot3Rgb), &[d, d, d, 0.125]);
    folds(&m, comb(Dot3Rgba), &[d, d, d, d]);
    let t3 = k(&mut m, Ty::Rgb, &[1.0, 0.5, 0.75]);
    let f3 = k(&mut m, Ty::Rgb, &[1.0, 1.0, 0.25]);
    folds(&m, Expr::Combine { mode: Dot3Rgb, lhs: t3, rhs: f3 }, &[0.75, 0.75, 0.75]);
    // No alpha: At = 1, so decal and interpolate give the texture.
    folds(&m, Expr::Combine { mode: Decal, lhs: t3, rhs: f3 }, &[1.0, 0.5, 0.75]);
    folds(&m, Expr::Combine { mode: Interpolate, lhs: t3, rhs: f3 }, &[1.0, 0.5, 0.75]);
    // replace with an rgb texture widened to rgba keeps the fragment's alpha (GL's RGB base format).
    // (A constant would fold to an rgba constant first: take an rgb texel, here a uniform.)
    let texel = uniform(&mut m, "texel", Ty::Rgb);
    let wide = node(&mut m, Expr::Convert { value: texel, to: Ty::Rgba });
    let t1 = [1.0, 0.5, 0.75, 1.0];
    let fv = [1.0, 0.8, 0.4, 0.5];
    for (mode, want) in
        [(Replace, [1.0, 0.5, 0.75, 0.5]), (Decal, [1.0, 0.5, 0.75, 0.5]), (Modulate, [1.0, 0.4, 0.3, 0.5])]
    {
        let v = apply(&m, &Expr::Combine { mode, lhs: wide, rhs: f }, Ty::Rgba, &[t1, fv]);
        close(&v, &want);
    }
    let v = apply(&m, &Expr::Combine { mode: Replace, lhs: t, rhs: f }, Ty::Rgba, &[t1, fv]);
    close(&v, &t1);
    // A scalar broadcasts (Kilgard's `C ⊕[add] (α C) * specular`); results are not clamped.
    let s = k(&mut m, Ty::Scalar, &[0.75]);
    folds(&m, Expr::Combine { mode: Add, lhs: f, rhs: s }, &[1.75, 1.55, 1.15, 1.25]);
}

#[test]
fn select_without_reject_discards_per_root() {
    let mut m = Module::default();
    let c = uniform(&mut m, "c", Ty::Scalar);
    let a = uniform(&mut m, "a", Ty::Rgb);
    let b = k(&mut m, Ty::Rgb, &[0.0, 0.0, 1.0]);
    let keep = node(&mut m, Expr::Select { cond: c, accept: a, reject: None });
    let not_c = node(&mut m, Expr::Unary { op: UnaryOp::Not, value: c });
    // Takes `keep` only where c holds, so never discards.
    let guarded = node(&mut m, Expr::Select { cond: not_c, accept: b, reject: Some(keep) });
    let sum = node(&mut m, Expr::Binary { op: BinaryOp::Add, lhs: keep, rhs: b });
    let mut ev = Evaluator::new(&m, &[keep, guarded, sum, b], Precision::Exact);
    struct U(f64);
    impl Env for U {
        fn uniform(&mut self, id: UniformId) -> Option<Value> {
            Some(if id == 0 { [self.0, 0.0, 0.0, 0.0] } else { [0.1, 0.2, 0.3, 0.0] })
        }
    }
    let r = ev.eval(&mut U(1.0));
    assert_eq!(r.discard, &[false, false, false, false]);
    close(&r.values[0][..3], &[0.1, 0.2, 0.3]);
    close(&r.values[2][..3], &[0.1, 0.2, 1.3]);
    let r = ev.eval(&mut U(0.0));
    assert_eq!(r.discard, &[true, false, true, false]);
    assert!(r.values[0][0].is_nan());
    close(&r.values[1][..3], &[0.0, 0.0, 1.0]);
    assert_eq!(ev.discarded(keep), Some(true));
    assert_eq!(ev.value(c), Some([0.0; 4]), "scalars are splatted");
}

#[test]
fn unanswered_leaves_are_nan_and_uniforms_default() {
    let (program, d) = crate::parser::check(
        "uniform g : scalar = 0.25;\ntexture T : 2d rgba8;\nframebuffer C : rgba8;\nC δπx ← (T δu x) * g;\n",
    );
    assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
    let (m, d) = crate::ir::lower(&program);
    assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
    let g = m.exprs.find(&Expr::Uniform(0)).unwrap();
    let mut ev = Evaluator::new(&m, &[m.statements[0].value, g], Precision::Exact);
    let r = ev.eval(&mut ());
    assert!(r.values[0].iter().all(|x| x.is_nan()));
    assert_eq!(r.values[1], [0.25; 4]);
    // Only the fragment side is reachable: δ stops the walk.
    assert_eq!(ev.interpolants().len(), 1);
    assert!(matches!(m.exprs[ev.interpolants()[0].1], Expr::TexCoord { .. }));
    assert_eq!(ev.value(ev.interpolants()[0].1), None);
}

fn kilgard() -> Module {
    let src = include_str!("../../../examples/kilgard_bump_mapping.shd");
    let (program, d) = crate::parser::check(src);
    assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
    let (m, d) = crate::ir::lower(&program);
    assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
    m
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

/// One fragment of Kilgard's passes: L and H interpolated, the
/// normalization cube map, a normal-map texel, the framebuffer.
struct Fragment<'m> {
    m: &'m Module,
    l: [f64; 3],
    h: [f64; 3],
    normal_texel: Value,
    c: Value,
    /// Round every input to f32 (so both precisions see the same inputs).
    f32_inputs: bool,
}

impl Fragment<'_> {
    fn input(&self, v: Value) -> Value {
        if self.f32_inputs {
            v.map(|x| x as f32 as f64)
        } else {
            v
        }
    }
}

impl Env for Fragment<'_> {
    fn interpolate(&mut self, _node: Handle<Expr>, value: Handle<Expr>, _to: Frequency) -> Value {
        let v = match &self.m.exprs[value] {
            Expr::Vector { vector, .. } => match self.m.vectors[*vector as usize].name.as_str() {
                "L" => [self.l[0], self.l[1], self.l[2], 0.0],
                "H" => [self.h[0], self.h[1], self.h[2], 0.0],
                _ => NAN,
            },
            Expr::TexCoord { .. } => [0.25, 0.75, 0.0, 0.0],
            Expr::Project { .. } => [10.0, 20.0, 0.5, 1.0],
            _ => NAN,
        };
        self.input(v)
    }

    fn lookup(&mut self, texture: TextureId, coords: Value, _: Ty) -> Value {
        let v = match self.m.textures[texture as usize].name.as_str() {
            // A normalization cube map: the range-compressed direction (seeds/003 App. D).
            "Ncube" => {
                let n = normalize([coords[0], coords[1], coords[2]]);
                [(n[0] + 1.0) / 2.0, (n[1] + 1.0) / 2.0, (n[2] + 1.0) / 2.0, 0.0]
            }
            "Tn" => self.normal_texel,
            "Tdecal" => [0.2, 0.4, 0.6, 1.0],
            _ => NAN,
        };
        self.input(v)
    }

    fn framebuffer(&mut self, _: FramebufferId, channel: FbChannel, position: Value) -> Value {
        assert_eq!(position, [10.0, 20.0, 0.5, 1.0]);
        match channel {
            FbChannel::Color => self.input(self.c),
            FbChannel::Alpha => [self.input(self.c)[3]; 4],
            _ => NAN,
        }
    }
}

fn roots(m: &Module) -> Vec<Handle<Expr>> {
    m.statements.iter().map(|s: &Statement| s.value).collect()
}

#[test]
fn kilgard_diffuse_and_specular_by_hand() {
    let m = kilgard();
    let roots = roots(&m);
    // Pass 2's value is C ⊕ rgba(diffuse, s_self): find the diffuse term.
    let Expr::Combine { rhs, .. } = m.exprs[roots[1]] else { panic!("pass 2 is a combine") };
    let Expr::Compose { components, .. } = &m.exprs[rhs] else { panic!("rgba(diffuse, s_self)") };
    let diffuse = components[0];
    let mut ev = Evaluator::new(&m, &roots, Precision::Exact);
    let mut env = Fragment {
        m: &m,
        l: [0.99f64.sqrt(), 0.0, 0.1],
        h: [0.0, 0.6, 0.8],
        // N′ = (0.6, 0, 0.8), range-compressed; denormalization factor ½.
        normal_texel: [0.8, 0.5, 0.9, 0.5],
        c: [0.5, 0.5, 0.5, 1.0],
        f32_inputs: false,
    };
    let r = ev.eval(&mut env);
    assert_eq!(r.discard, &[false; 3]);
    close(&r.values[0], &[0.2, 0.4, 0.6, 1.0]);
    // s_self = saturate(8 Lz) = 0.8; L·N′ = 0.6 √0.99 + 0.08;
    // diffuse = Iambient + Kdiffuse · s_self · max(0, L·N′) · N′.a.
    let s_self = 0.8;
    let ln = 0.6 * 0.99f64.sqrt() + 0.8 * 0.1;
    let want: Vec<f64> = [0.9, 1.0, 1.0].iter().map(|kd| 0.1 + kd * s_self * ln * 0.5).collect();
    let values = r.values.to_vec();
    close(&ev.value(diffuse).unwrap()[..3], &want);
    // Modulated into the framebuffer (0.5, 0.5, 0.5, 1), s_self into alpha.
    close(&values[1], &[0.5 * want[0], 0.5 * want[1], 0.5 * want[2], s_self]);
    // Pass 3: Hz ≥ 0, so C + (α C) · max(0, H·N′)^8 with H·N′ = 0.64.
    let spec = 0.64f64.powi(8);
    close(&values[2], &[0.5 + spec, 0.5 + spec, 0.5 + spec, 1.0 + spec]);
    // Hz < 0: the specular term is forced to zero (Appendix H's mux).
    env.h = [0.0, 0.6, -0.8];
    let r = ev.eval(&mut env);
    close(&r.values[2], &[0.5, 0.5, 0.5, 1.0]);
}

fn unit() -> impl Strategy<Value = f64> {
    (-1.0f32..=1.0).prop_map(f64::from)
}
fn unsigned() -> impl Strategy<Value = f64> {
    (0.0f32..=1.0).prop_map(f64::from)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// F32 differs from Exact by accumulated f32 rounding only.
    #[test]
    fn f32_is_exact_up_to_rounding(
        l in [unit(), unit(), unit()],
        h in [unit(), unit(), unit()],
        n in [unsigned(), unsigned(), unsigned(), unsigned()],
        c in [unsigned(), unsigned(), unsigned(), unsigned()],
    ) {
        prop_assume!(l.iter().any(|x| x.abs() > 1e-3) && h.iter().any(|x| x.abs() > 1e-3));
        let m = kilgard();
        let roots = roots(&m);
        let mut env = Fragment { m: &m, l, h, normal_texel: n, c, f32_inputs: true };
        let mut exact = Evaluator::new(&m, &roots, Precision::Exact);
        let mut f32 = Evaluator::new(&m, &roots, Precision::F32);
        let e = exact.eval(&mut env).values.to_vec();
        let f = f32.eval(&mut env).values.to_vec();
        for (a, b) in e.iter().flatten().zip(f.iter().flatten()) {
            prop_assert!((a - b).abs() <= 1e-5 * (1.0 + a.abs()), "{e:?} vs {f:?}");
        }
    }

    /// One operation on f32 inputs: F32 is the exact result rounded once.
    #[test]
    fn one_operation_rounds_once(a in -1e3f32..1e3, b in -1e3f32..1e3) {
        prop_assume!(b != 0.0);
        let mut m = Module::default();
        let (ua, ub) = (uniform(&mut m, "a", Ty::Scalar), uniform(&mut m, "b", Ty::Scalar));
        let ops: Vec<Handle<Expr>> = [BinaryOp::Add, BinaryOp::Sub, BinaryOp::Mul, BinaryOp::Div]
            .into_iter()
            .map(|op| node(&mut m, Expr::Binary { op, lhs: ua, rhs: ub }))
            .collect();
        struct Ab(f64, f64);
        impl Env for Ab {
            fn uniform(&mut self, id: UniformId) -> Option<Value> {
                Some([if id == 0 { self.0 } else { self.1 }; 4])
            }
        }
        let mut env = Ab(a.into(), b.into());
        let e = Evaluator::new(&m, &ops, Precision::Exact).eval(&mut env).values.to_vec();
        let f = Evaluator::new(&m, &ops, Precision::F32).eval(&mut env).values.to_vec();
        let native = [a + b, a - b, a * b, a / b];
        for k in 0..4 {
            prop_assert_eq!(f[k][0], e[k][0] as f32 as f64);
            prop_assert_eq!(f[k][0], f64::from(native[k]));
        }
    }
}
