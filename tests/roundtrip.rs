//! Printing and re-parsing gives the same AST: on every example, and on
//! generated programs (proptest), in Unicode and in ASCII.

use crate::common;

use proptest::prelude::*;
use shadec::parser::ast::*;
use shadec::parser::parse;
use shadec::parser::print::{self, Style};
use shadec::span::Span;

fn reparse(text: &str) -> Program {
    let (mut p, d) = parse(text);
    assert!(d.is_empty(), "printed text does not re-parse:\n{text}\n{d:#?}");
    p.erase_spans();
    p
}

fn assert_round_trip(mut program: Program) {
    program.erase_spans();
    for style in [Style::Unicode, Style::Ascii] {
        let text = print::program(&program, style);
        let again = reparse(&text);
        assert_eq!(again, program, "{style:?} round trip changed the tree:\n{text}");
        assert_eq!(print::program(&again, style), text, "printing is not idempotent");
    }
}

#[test]
fn every_example_round_trips() {
    let mut n = 0;
    for path in common::examples() {
        let text = std::fs::read_to_string(&path).unwrap();
        let (program, d) = parse(&text);
        assert!(d.is_empty(), "{}: {d:#?}", path.display());
        assert_round_trip(program);
        n += 1;
    }
    assert!(n >= 25, "expected the examples of every technique, found {n}");
}

// ---------------------------------------------------------------- generators

const NAMES: &[&str] = &["a", "kd", "N", "L", "T", "u", "x", "xs", "s", "p", "Cl", "n_dot_l", "ρ", "T2"];

fn name() -> impl Strategy<Value = Name> {
    (prop::sample::select(NAMES), 0u8..4, any::<bool>()).prop_map(|(base, primes, star)| Name {
        base: base.to_string(),
        primes,
        star,
        span: Span::DETACHED,
    })
}

fn word<T: std::fmt::Debug + Clone + 'static>(values: Vec<T>) -> impl Strategy<Value = Word<T>> {
    prop::sample::select(values).prop_map(|value| Word { value, span: Span::DETACHED })
}

fn func() -> impl Strategy<Value = Func> {
    let kind = prop_oneof![
        Just(FuncKind::Delta),
        (prop::option::of(prop::sample::select(vec!["l", "R", "1"])), any::<bool>(), any::<bool>()).prop_map(
            |(sub, star, inverse)| {
                FuncKind::Projection(Projection { subscript: sub.map(str::to_string), star, inverse })
            }
        ),
        prop::sample::select(vec![Channel::Alpha, Channel::Depth, Channel::Stencil])
            .prop_map(FuncKind::Channel),
        name().prop_map(FuncKind::Name),
    ];
    kind.prop_map(|kind| Func { kind, span: Span::DETACHED })
}

fn e(kind: ExprKind) -> Expr {
    Expr { kind, span: Span::DETACHED }
}

fn expr() -> impl Strategy<Value = Expr> {
    let leaf = prop_oneof![
        (0u32..4000).prop_map(|n| e(ExprKind::Number(n as f64 / 8.0))),
        (0.0f64..1e6).prop_map(|v| e(ExprKind::Number(v))),
        "[a-z./\" \\\\]{0,8}".prop_map(|s| e(ExprKind::String(s))),
        name().prop_map(|n| e(ExprKind::Name(n))),
    ];
    leaf.prop_recursive(6, 48, 4, |inner| {
        let b = |x: Expr| Box::new(x);
        prop_oneof![
            prop::collection::vec(inner.clone(), 2..4).prop_map(|v| e(ExprKind::Tuple(v))),
            (func(), inner.clone()).prop_map(move |(func, arg)| e(ExprKind::Apply { func, arg: b(arg) })),
            (inner.clone(), prop::sample::select(vec!["x", "z", "xyz", "a", "rgb"]))
                .prop_map(move |(base, c)| e(ExprKind::Swizzle { base: b(base), components: c.to_string() })),
            (prop::sample::select(vec![UnaryOp::Neg, UnaryOp::Not]), inner.clone())
                .prop_map(move |(op, x)| e(ExprKind::Unary { op, operand: b(x) })),
            (
                prop::sample::select(vec![
                    BinaryOp::Or,
                    BinaryOp::And,
                    BinaryOp::Lt,
                    BinaryOp::Le,
                    BinaryOp::Gt,
                    BinaryOp::Ge,
                    BinaryOp::Eq,
                    BinaryOp::Ne,
                    BinaryOp::Add,
                    BinaryOp::Sub,
                    BinaryOp::Mul,
                    BinaryOp::Div,
                    BinaryOp::Dot,
                    BinaryOp::Pow,
                ]),
                inner.clone(),
                inner.clone()
            )
                .prop_map(move |(op, l, r)| e(ExprKind::Binary { op, lhs: b(l), rhs: b(r) })),
            (
                prop::option::of(word(vec![CombineMode::Add, CombineMode::Decal, CombineMode::AddSigned])),
                inner.clone(),
                inner.clone()
            )
                .prop_map(move |(mode, l, r)| e(ExprKind::Combine {
                    mode,
                    lhs: b(l),
                    rhs: b(r)
                })),
            (inner.clone(), inner.clone(), prop::option::of(inner.clone())).prop_map(move |(c, t, o)| e(
                ExprKind::Select { cond: b(c), then: b(t), otherwise: o.map(b) }
            )),
        ]
    })
}

fn item() -> impl Strategy<Value = Item> {
    let statement = (
        prop::option::of(word(vec![Channel::Alpha, Channel::Depth, Channel::Stencil])),
        name(),
        expr(),
        expr(),
    )
        .prop_map(|(channel, table, index, value)| {
            ItemKind::Statement(Statement {
                target: Target { channel, table, index, span: Span::DETACHED },
                value,
            })
        });
    let constant = (name(), prop::option::of(word(vec![Type::Rgb, Type::Scalar, Type::Color])), expr())
        .prop_map(|(name, ty, value)| ItemKind::Const(ConstDecl { name, ty, value }));
    let shader = (name(), name(), expr(), prop::collection::vec((name(), expr()), 0..3), any::<bool>())
        .prop_map(|(name, input, body, lets, block)| {
            let block = block || !lets.is_empty();
            let lets = lets.into_iter().map(|(name, value)| LetDecl { name, value }).collect();
            ItemKind::Shader(ShaderDecl {
                name,
                params: vec![],
                input,
                output: Word { value: Type::Color, span: Span::DETACHED },
                lets,
                body,
                block,
            })
        });
    let texture =
        (prop::collection::vec(name(), 1..3), prop::option::of(expr())).prop_map(|(names, source)| {
            ItemKind::Texture(TextureDecl {
                names,
                kind: Word { value: TextureKind::Cube, span: Span::DETACHED },
                format: Some(Word { value: TextureFormat::Signed16, span: Span::DETACHED }),
                attrs: vec![Word { value: TextureAttr::Mipmap, span: Span::DETACHED }],
                source,
            })
        });
    // Comments are kept without trailing white space, as the parser stores them.
    let comment = prop_oneof!["// [a-zδ]{0,5}( [a-z]{1,5})?", "# [a-z]{1,5}", "/\\* [a-z\n]{0,6} \\*/"]
        .prop_map(|c| c.trim_end().to_string());
    let comments = (prop::collection::vec(comment.clone(), 0..3), prop::option::of(comment), any::<bool>())
        .prop_map(|(leading, trailing, blank_line_before)| Comments {
            leading,
            trailing,
            blank_line_before,
            block: vec![],
        });
    (prop_oneof![4 => statement, 1 => constant, 1 => shader, 1 => texture], comments)
        .prop_map(|(kind, comments)| Item { kind, span: Span::DETACHED, comments })
}

fn program() -> impl Strategy<Value = Program> {
    (prop::collection::vec(item(), 1..6), prop::collection::vec("// [a-z]{1,8}", 0..2)).prop_map(
        |(mut items, trailing_comments)| {
            // The first item has nothing before it to be separated from.
            items[0].comments.blank_line_before = false;
            Program { items, trailing_comments, ..Program::default() }
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn generated_programs_round_trip(program in program()) {
        assert_round_trip(program);
    }
}
