//! A flat sum or product is not nesting: long runs of `+` or `*`
//! are built balanced, so only true nesting meets the expression depth
//! limit, and that limit is a located error, not a stack overflow.

use shadec::parser::{self, ast::ExprKind, MAX_EXPR_DEPTH};
use shadec::profile::Profile;

/// A shader summing `n` lit terms, each with its own weight.
fn wide_sum(n: usize) -> String {
    let mut s = String::from("vector N : normal;\n");
    for l in 0..8 {
        s += &format!("vector L{l} : light({l});\n");
    }
    s += "texture T0 : 2d rgba8;\n";
    let terms: Vec<String> =
        (0..n).map(|i| format!("{:.3} * max(0, N·L{})", (i % 997 + 1) as f64 / 1000.0, i % 8)).collect();
    s += &format!("shader p : s → c = {};\n", terms.join(" + "));
    s + "C δπx ← (δ p s x) ⊕ (T0 δu x);\n"
}

fn depth(e: &parser::ast::Expr) -> usize {
    let mut deepest = 0;
    let mut stack = vec![(e, 1)];
    while let Some((e, d)) = stack.pop() {
        deepest = deepest.max(d);
        if let ExprKind::Binary { lhs, rhs, .. } = &e.kind {
            stack.push((lhs, d + 1));
            stack.push((rhs, d + 1));
        }
    }
    deepest
}

fn only_statement_value(src: &str) -> parser::ast::Expr {
    let (program, diags) = parser::parse(src);
    assert!(diags.is_empty(), "{diags:?}");
    program
        .items
        .into_iter()
        .find_map(|item| match item.kind {
            parser::ast::ItemKind::Statement(st) => Some(st.value),
            _ => None,
        })
        .expect("one statement")
}

#[test]
fn a_ten_thousand_term_sum_plans_on_wgsl_geforce256_and_geforce3() {
    let src = wide_sum(10_000);
    for target in ["wgsl", "geforce256", "geforce3"] {
        let profile = Profile::builtin(target).unwrap();
        let plan = shadec::compile(&src, &profile).unwrap_or_else(|d| panic!("{target}: {d:?}"));
        assert!(!plan.passes.is_empty(), "{target}");
    }
}

#[test]
fn long_runs_are_balanced_and_short_ones_keep_their_order() {
    let sum = |n: usize| format!("const a = 1;\nC xs ← {};", vec!["a"; n].join(" + "));
    // Up to 64 terms nest to the left exactly as written.
    assert_eq!(depth(&only_statement_value(&sum(64))), 64);
    let short = only_statement_value("C xs ← a + b + c;");
    assert_eq!(parser::print::sexpr(&short), "(+ (+ a b) c)");
    // Longer: the logarithm of the length, and every term kept.
    let long = only_statement_value(&sum(20_000));
    assert_eq!(depth(&long), 1 + 15, "⌈log₂ 20 000⌉ levels of `+` above the leaves");
    assert_eq!(parser::print::sexpr(&long).matches(" a").count() + 1, 20_000 + 1);
    let product = only_statement_value(&format!("C xs ← {};", vec!["a"; 5000].join(" * ")));
    assert_eq!(depth(&product), 1 + 13);
}

#[test]
fn true_nesting_beyond_the_limit_is_a_located_error() {
    // Unary minus nests: each one is an operand of the next.
    let src = format!("const a = 1;\nC xs ← {}a;", "-".repeat(MAX_EXPR_DEPTH + 5));
    let (_, diags) = parser::parse(&src);
    let d = diags.iter().find(|d| d.code == "nesting-too-deep").expect("refused");
    assert!(d.message.contains(&format!("more than {MAX_EXPR_DEPTH} levels")), "{}", d.message);
    let start = d.primary.span.start as usize;
    assert!(start > src.find('←').unwrap(), "points into the statement, not at 0");
    // A flat run inside the nesting counts its logarithm, not its length.
    let flat = format!("const a = 1;\nC xs ← {}({});", "-".repeat(900), vec!["a"; 10_000].join(" + "));
    let (_, diags) = parser::parse(&flat);
    assert!(diags.is_empty(), "{diags:?}");
}

/// A program whose global `let`s each use the one before, `n` long.
fn let_chain(n: usize) -> String {
    let mut s = String::from("vector N : normal;\nvector L : light(0);\nlet a0 = 0.5;\n");
    for i in 1..n {
        s += &format!("let a{i} = a{} * 0.999;\n", i - 1);
    }
    s + &format!("shader p : s → c = a{} * max(0, N·L);\nC δπx ← δ p s x;\n", n - 1)
}

#[test]
fn a_chain_of_lets_longer_than_64_is_not_a_cycle() {
    // 64 was the old bound on nesting definitions, reported as "defined in
    // terms of itself"; a chain is no cycle at any length.
    for n in [65, 300] {
        let profile = Profile::builtin("wgsl").unwrap();
        let plan = shadec::compile(&let_chain(n), &profile).unwrap_or_else(|d| panic!("{n}: {d:?}"));
        assert!(!plan.passes.is_empty());
    }
}

#[test]
fn a_true_cycle_is_one_located_error() {
    let src = "vector N : normal;\nlet a = b * 2;\nlet b = a + 0.5;\nshader p : s → c = a * N.x;\nC δπx ← δ p s x;\n";
    let profile = Profile::builtin("wgsl").unwrap();
    let diags = shadec::compile(src, &profile).expect_err("a cycle");
    let cycles: Vec<_> = diags.iter().filter(|d| d.code == "cycle").collect();
    assert_eq!(cycles.len(), 1, "{diags:?}");
    assert!(cycles[0].message.contains("defined in terms of itself"), "{}", cycles[0].message);
}
