//! The forms of [`super::forms`] equal their value for any leaves.

use super::*;
use crate::ir::eval::{Env, Evaluator};
use crate::numerics::Precision;

fn module(source: &str) -> Module {
    let (program, diags) = crate::parser::check(source);
    assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
    crate::ir::lower(&program).0
}

/// Every lookup and interpolant a value fixed by its node: the forms
/// must agree for any such leaves.
struct Leaves(f64);
impl Env for Leaves {
    fn lookup(&mut self, texture: u32, _: crate::ir::eval::Value, _: Ty) -> crate::ir::eval::Value {
        let v = (texture as f64 * 0.37 + self.0).fract();
        [v, 1.0 - v, 0.25, 0.6]
    }
    fn interpolate(&mut self, _: Handle<Expr>, value: Handle<Expr>, _: Frequency) -> crate::ir::eval::Value {
        let v = (value.index() as f64 * 0.29 + self.0).fract();
        [v, v * 0.5, 1.0 - v, 1.0]
    }
}

fn value(m: &Module, h: Handle<Expr>, leaf: f64) -> crate::ir::eval::Value {
    let mut e = Evaluator::new(m, &[h], Precision::Exact);
    e.eval(&mut Leaves(leaf)).values[0]
}

#[test]
fn a_product_over_a_lerp_multiplies_out_to_the_same_value() {
    let mut m = module(
        "texture A : 2d rgb8;\ntexture B : 2d rgba8;\nconst f = 0.3;\n\
         C δπx ← A δu x * lerp((B δu x).rgb, 2 * A δu x, (B δu x).a);\n",
    );
    let v = m.statements[0].value;
    let forms = forms(&mut m, v, MAX_TERMS);
    assert!(forms.iter().any(|f| f.what == "multiplied out"), "{forms:?}");
    for f in &forms {
        for leaf in [0.1, 0.5, 0.9] {
            let (a, b) = (value(&m, v, leaf), value(&m, f.value, leaf));
            for i in 0..4 {
                assert!((a[i] - b[i]).abs() < 1e-12, "{}: {a:?} against {b:?}", f.what);
            }
        }
    }
}

#[test]
fn a_channel_of_a_tuple_is_its_component() {
    let mut m = module("texture A : 2d rgb8;\nlet t = ((A δu x).g, 0.5, 0);\nC δπx ← t.r + t.g;\n");
    let v = m.statements[0].value;
    let c = canonical(&mut m, v).expect("the swizzles go");
    let swizzles = m.reachable(&[c]).into_iter().filter(|h| {
        matches!(&m.exprs[*h], Expr::Swizzle { value, .. } if matches!(m.exprs[*value], Expr::Compose { .. }))
    });
    assert_eq!(swizzles.count(), 0);
}

#[test]
fn a_sum_of_products_factors_back_into_a_product_of_sums() {
    let mut m = module(
        "texture A : 2d rgb8;\ntexture B : 2d rgb8;\ntexture D : 2d rgb8;\n\
         C δπx ← A δu x * B δu x * D δu x + A δu x * B δu x * A δu x + A δu x * D δu x + A δu x * A δu x;\n",
    );
    let st = m.statements[0].value;
    let Expr::Convert { value, .. } = m.exprs[st] else { panic!("rgb written as rgba") };
    for keep in [false, true] {
        let f = product_of_sums(&mut m, value, keep).expect("(A·B + A)·(D + A)");
        for leaf in [0.1, 0.5, 0.9] {
            let (a, b) = (self::value(&m, value, leaf), self::value(&m, f, leaf));
            assert!((0..4).all(|i| (a[i] - b[i]).abs() < 1e-12), "{a:?} against {b:?}");
        }
        let Expr::Binary { op: BinaryOp::Mul, .. } = m.exprs[f] else { panic!("{:?}", m.exprs[f]) };
    }
}

#[test]
fn a_common_factor_is_taken_out_once() {
    let mut m = module("texture A : 2d rgb8;\ntexture B : 2d rgb8;\ntexture D : 2d rgb8;\nC δπx ← A δu x * B δu x + D δu x * A δu x;\n");
    let st = m.statements[0].value;
    let Expr::Convert { value, .. } = m.exprs[st] else { panic!("rgb written as rgba") };
    let f = factor(&mut m, value).expect("A is shared");
    let Expr::Binary { op: BinaryOp::Mul, .. } = m.exprs[f] else { panic!("{:?}", m.exprs[f]) };
}
