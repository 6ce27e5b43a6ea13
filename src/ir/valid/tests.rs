use super::*;
use crate::ir::Frequency::*;

/// The interval of the value of the last statement of `source`.
fn statement_range(source: &str) -> Interval {
    let (program, _) = crate::parser::check(source);
    let (m, diags) = crate::ir::lower(&program);
    assert!(diags.iter().all(|d| !d.is_error()), "{diags:?}");
    let value = m.statements.last().unwrap().value;
    let root = match m.exprs[value] {
        Expr::Convert { value, .. } => value,
        _ => value,
    };
    m.info(root).interval
}

#[test]
fn formula_6_stays_within_unit_range_and_near_misses_do_not() {
    let decl = "vector L : light(0) in tangent;\nvector H : half(0) in tangent;\nlet w = δ L s x;\n";
    let range = |e: &str| statement_range(&format!("{decl}C δπx ← rgb({e});\n"));
    assert_eq!(range("w·w"), Interval::UNSIGNED, "a squared length");
    assert_eq!(range("w + 0.5 * w * (1 - w·w)"), Interval::SIGNED, "GeForce3 Phong, Formula 6");
    assert_eq!(range("w + (1 - w·w) * (w * 0.5)"), Interval::SIGNED, "any order and grouping");
    assert_eq!(range("0.5 * w * (1 - w·w) + w"), Interval::SIGNED, "either side of the sum");
    // Not Formula 6: another vector in the dot product, or another factor.
    let v = "vector V : view in tangent;\n";
    let other = statement_range(&format!("{decl}{v}C δπx ← rgb(w + 0.5 * w * (1 - w·(δ V s x)));\n"));
    assert!(other.hi > 1.0, "{other:?}");
    assert!(range("w + 0.6 * w * (1 - w·w)").hi > 1.0);
}

#[test]
fn coloured_lights_summed_are_bounded_channel_by_channel() {
    let decl = "vector N : normal;\nvector L0 : light(0);\nvector L1 : light(1);\n";
    let lights = "(0.9, 0.4, 0.3) * max(0, N·L0) + (0.3, 0.9, 0.4) * max(0, N·L1)";
    let sum = statement_range(&format!("{decl}shader l : s → c = {lights};\nC δπx ← δ l s x;\n"));
    // 0.9 + 0.3 in red and green, 0.7 in blue: not the hulls' 0.9 + 0.9.
    assert!((sum.hi - 1.3).abs() < 1e-9 && sum.lo == 0.0, "{sum:?}");
    let scaled = statement_range(&format!("{decl}shader l : s → c = 0.6 * ({lights});\nC δπx ← δ l s x;\n"));
    assert!((scaled.hi - 0.78).abs() < 1e-9, "{scaled:?}");
    // One channel read off a tuple: that channel's range.
    let g = statement_range(&format!(
        "{decl}shader p : s → c = (0.8 * max(0, N·L0), 0.6 * max(0, N·L1), 0);\nC δπx ← (δ p s x).g;\n"
    ));
    assert!((g.hi - 0.6).abs() < 1e-9, "{g:?}");
}

/// Channel ranges at any depth: a sum of seven coloured terms, three red
/// then four green, is at most 0.9 (red) — each node keeps its channels,
/// where a walk four operations down met the three red terms' sum as its
/// hull, 0.9 in every channel, and gave 0.9 + 0.8 in green.
#[test]
fn a_long_sum_of_coloured_terms_is_bounded_channel_by_channel() {
    let decl = "vector N : normal;\nvector L0 : light(0);\n";
    let red = vec!["(0.3, 0, 0) * max(0, N·L0)"; 3];
    let green = vec!["(0, 0.2, 0) * max(0, N·L0)"; 4];
    let sum = [red, green].concat().join(" + ");
    let range = statement_range(&format!("{decl}shader l : s → c = {sum};\nC δπx ← δ l s x;\n"));
    assert!((range.hi - 0.9).abs() < 1e-9 && range.lo == 0.0, "{range:?}");
}

#[test]
fn frequencies_join_up_to_one_sample_frequency() {
    assert_eq!(Constant.join(Uniform), Some(Uniform));
    assert_eq!(Uniform.join(Vertex), Some(Vertex));
    assert_eq!(Uniform.join(Fragment), Some(Fragment));
    assert_eq!(Fragment.join(Fragment), Some(Fragment));
    // Right of δ is per vertex: it never meets a per-sample value directly.
    assert_eq!(Vertex.join(Fragment), None);
    assert_eq!(Fragment.join(Texel), None);
    assert_eq!(Screen.join(Fragment), None);
}

#[test]
fn three_component_types_mix_and_scalars_broadcast() {
    assert_eq!(unify(Ty::Vec3, Ty::Rgb), Some(Ty::Rgb));
    assert_eq!(unify(Ty::Scalar, Ty::Rgba), Some(Ty::Rgba));
    assert_eq!(unify(Ty::Rgb, Ty::Rgba), None, "lowering widens rgb explicitly");
    assert_eq!(unify(Ty::Vec2, Ty::Vec3), None);
    assert_eq!(unify(Ty::Position, Ty::Scalar), None);
}

#[test]
fn texels_by_format() {
    assert_eq!(texel_type(TextureKind::Tex2d, TextureFormat::Rgba8), (Ty::Rgba, Interval::UNSIGNED));
    assert_eq!(texel_type(TextureKind::Cube, TextureFormat::Rgb8), (Ty::Rgb, Interval::UNSIGNED));
    // A signed 2-D map holds EMBM offsets (seeds/001 (8)); a signed cube map directions.
    assert_eq!(texel_type(TextureKind::Tex2d, TextureFormat::Signed8).0, Ty::Vec2);
    assert_eq!(texel_type(TextureKind::Cube, TextureFormat::Signed16), (Ty::Vec3, Interval::SIGNED));
    assert_eq!(texel_type(TextureKind::Tex1d, TextureFormat::R8).0, Ty::Scalar);
    assert_eq!(texel_type(TextureKind::Tex2d, TextureFormat::Rgba16f).1.class(), crate::ir::Range::Unbounded);
}

#[test]
fn intervals_classify() {
    assert_eq!(Interval::UNSIGNED.class(), crate::ir::Range::Unsigned);
    assert_eq!(Interval::SIGNED.class(), crate::ir::Range::Signed);
    assert_eq!(mul(Interval::SIGNED, Interval::UNSIGNED).class(), crate::ir::Range::Signed);
    assert_eq!(add(Interval::UNSIGNED, Interval::UNSIGNED).class(), crate::ir::Range::Unbounded);
    assert_eq!(div(Interval::UNSIGNED, Interval::UNSIGNED), Interval::ALL);
    assert_eq!(map_monotone(Interval::UNSIGNED, |x| 2.0 * x - 1.0), Interval::SIGNED);
}

#[test]
fn dot3_range_holds_what_eval_computes() {
    use crate::ir::eval::combine;
    let u = Interval::UNSIGNED;
    assert_eq!(dot3(u, u, false), Interval { lo: -3.0, hi: 3.0 });
    assert_eq!(dot3(u, u, true), Interval { lo: -1.0, hi: 1.0 });
    // Every corner of the unit cube pair lands inside, and the extremes are reached.
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for bits in 0..64u32 {
        let c = |k: u32| f64::from((bits >> k) & 1);
        let t = [c(0), c(1), c(2), 1.0];
        let f = [c(3), c(4), c(5), 1.0];
        let v = combine(CombineMode::Dot3Rgba, 4, &t, &f, false)[0];
        lo = lo.min(v);
        hi = hi.max(v);
    }
    assert_eq!((lo, hi), (-3.0, 3.0));
}
