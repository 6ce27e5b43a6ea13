//! Parser unit tests: the tree shape of every construct, Unicode = ASCII,
//! and errors with recovery.

use super::ast::*;
use super::print::{self, sexpr};
use super::{check, parse};

/// The value of the single statement in `src`, as an S-expression.
fn value(src: &str) -> String {
    let (p, d) = parse(&format!("C xs ← {src};"));
    assert!(d.is_empty(), "{src}: {d:#?}");
    match &p.items[0].kind {
        ItemKind::Statement(s) => sexpr(&s.value),
        other => panic!("not a statement: {other:?}"),
    }
}

fn target(src: &str) -> String {
    let (p, d) = parse(&format!("{src} ← 0;"));
    assert!(d.is_empty(), "{src}: {d:#?}");
    match &p.items[0].kind {
        ItemKind::Statement(s) => {
            let channel = s.target.channel.as_ref().map(|c| format!("{:?} ", c.value)).unwrap_or_default();
            format!("{channel}{} @ {}", s.target.table.key(), sexpr(&s.target.index))
        }
        other => panic!("not a statement: {other:?}"),
    }
}

fn errors(src: &str) -> Vec<(&'static str, String)> {
    let (_, d) = check(src);
    d.into_iter().filter(|d| d.is_error()).map(|d| (d.code, d.message)).collect()
}

#[test]
fn application_is_right_to_left_without_parentheses() {
    assert_eq!(value("T δ u x"), "(T (δ (u x)))");
    assert_eq!(value("T δu x"), "(T (δ (u x)))");
    assert_eq!(value("p T δu x"), "(p (T (δ (u x))))");
    assert_eq!(value("max(0, N·L)"), "(max (tuple 0 (· N L)))");
}

#[test]
fn projections_take_subscripts_stars_and_inverses() {
    assert_eq!(value("δπx"), "(δ (π x))");
    assert_eq!(value("δπ x"), "(δ (π x))");
    assert_eq!(value("πl x"), "(πl x)");
    assert_eq!(value("π_l x"), "(πl x)");
    assert_eq!(value("πR R s x"), "(πR (R (s x)))");
    assert_eq!(value("z Cl πl π⁻¹ xs"), "(z (Cl (πl (π⁻¹ xs))))");
    assert_eq!(value("δπ* x"), "(δ (π* x))");
    assert_eq!(value("pi_l pi^-1 xs"), "(πl (π⁻¹ xs))");
}

#[test]
fn ascii_spelling_gives_the_same_tree() {
    let pairs = [
        ("C δπx ← T δu x ⊕ δ p s x;", "C delta pi x <- T delta u x (+) delta p s x;"),
        ("α C xs ← (z C xs) > (z Cl πl π⁻¹ xs);", "alpha C xs <- (z C xs) > (z Cl pi_l pi^-1 xs);"),
        ("σ C δπx ← (σ C δπx) ∨ N·L ≥ 0;", "stencil C delta pi x <- (stencil C delta pi x) OR N (.) L >= 0;"),
        ("C δπx ← T‴ δu‴ x ⊕[add] T′ δu’ x;", "C delta pi x <- T''' delta u''' x (+)[add] T' delta u' x;"),
        ("shader p : s → c = 1;", "shader p : s -> c = 1;"),
    ];
    for (uni, ascii) in pairs {
        let (mut a, da) = parse(uni);
        let (mut b, db) = parse(ascii);
        assert!(da.is_empty() && db.is_empty(), "{da:?} {db:?}");
        a.erase_spans();
        b.erase_spans();
        assert_eq!(a, b, "{uni} vs {ascii}");
    }
}

#[test]
fn targets_are_a_table_its_channel_and_its_index() {
    assert_eq!(target("C δπx"), "C @ (δ (π x))");
    assert_eq!(target("C xs"), "C @ xs");
    assert_eq!(target("T δu"), "T @ (δ u)");
    assert_eq!(target("T δu x"), "T @ (δ (u x))");
    assert_eq!(target("u x"), "u @ x");
    assert_eq!(target("Cl δ πl x"), "Cl @ (δ (πl x))");
    assert_eq!(target("α C xs"), "Alpha C @ xs");
    assert_eq!(target("σ C δπx"), "Stencil C @ (δ (π x))");
    assert_eq!(target("C δπ* x"), "C @ (δ (π* x))");
}

#[test]
fn precedence_follows_the_grammar() {
    assert_eq!(value("a + b * c·d^e"), "(+ a (* b (· c (^ d e))))");
    assert_eq!(value("1 – α C xs"), "(- 1 (α (C xs)))");
    assert_eq!(
        value("(α C xs)*(C xs) + (1 − α C xs)*(C′ xs)"),
        "(+ (* (α (C xs)) (C xs)) (* (- 1 (α (C xs))) (C′ xs)))"
    );
    assert_eq!(value("a ⊕ b ⊕[add] c + d"), "(⊕[add] (⊕ a b) (+ c d))");
    assert_eq!(value("a > b ∨ c ∧ d"), "(∨ (> a b) (∧ c d))");
    assert_eq!(value("-x^2"), "(neg (^ x 2))");
    assert_eq!(value("x^-2^y"), "(^ x (neg (^ 2 y)))");
    assert_eq!(value("-a * b"), "(* (neg a) b)");
    assert_eq!(value("a^-b*c"), "(* (^ a (neg b)) c)");
    assert_eq!(value("1 - (1 - V·N)^n"), "(- 1 (^ (- 1 (· V N)) n))");
}

#[test]
fn stars_mark_names_only_when_glued_and_followed_by_space() {
    assert_eq!(value("δ p s* x"), "(δ (p (s* x)))");
    assert_eq!(value("T* δu* x"), "(T* (δ (u* x)))");
    assert_eq!(value("kd*x"), "(* kd x)");
    assert_eq!(value("kd * x"), "(* kd x)");
}

#[test]
fn selects_nest_to_the_right_and_may_omit_the_else() {
    assert_eq!(value("a ? b : c ? d : e"), "(? a b (? c d e))");
    assert_eq!(value("(σ C δπx) ? (δ p s′ x)"), "(? (σ (C (δ (π x)))) (δ (p (s′ x))))");
    assert_eq!(value("a ? b : c ? d"), "(? a b (? c d))");
}

#[test]
fn swizzles_and_tuples() {
    assert_eq!(value("L.z"), "(.z L)");
    assert_eq!(value("(T δu x).a"), "(.a (T (δ (u x))))");
    assert_eq!(value("T δu x.a"), "(.a (T (δ (u x))))");
    assert_eq!(value("expand(v).rgb"), "(.rgb (expand v))");
    assert_eq!(value("f (v.rgb)"), "(f (.rgb v))");
    assert_eq!(value("(0.8, 0.6, 0.4)"), "(tuple 0.8 0.6 0.4)");
    assert_eq!(value("((x))"), "x");
}

#[test]
fn combine_modes_have_aliases_and_suggestions() {
    assert_eq!(value("a ⊕[signed_add] b"), "(⊕[add_signed] a b)");
    assert_eq!(value("a (+)[dot3] b"), "(⊕[dot3] a b)");
    let (_, d) = parse("C xs ← a ⊕[modulat] b;");
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].message, "unknown ⊕ mode `modulat`");
    assert!(d[0].help.as_deref().unwrap().starts_with("did you mean `modulate`?"));
}

#[test]
fn declarations_parse_into_their_parts() {
    let src = r#"
        target geforce3;
        texture N′, E : cube signed8 mipmap trilinear = normalize_cube(32, 16);
        framebuffer Cl : depth;
        vector L : light(1) in tangent;
        vector H = normalize(L + V);
        params s′ : N, L;
        const kd : rgb = (0.8, 0.6, 0.4);
        uniform ks : rgb;
        let s_self = 8 * max(0, L.z);
        shader p(n: scalar = 32) : s → c { let d = N·H; d^n }
    "#;
    let (p, d) = parse(src);
    assert!(d.is_empty(), "{d:#?}");
    assert_eq!(p.items.len(), 10);
    let ItemKind::Texture(t) = &p.items[1].kind else { panic!() };
    assert_eq!(t.names.iter().map(Name::key).collect::<Vec<_>>(), ["N'", "E"]);
    assert_eq!((t.kind.value, t.format.as_ref().unwrap().value), (TextureKind::Cube, TextureFormat::Signed8));
    assert_eq!(
        t.attrs.iter().map(|a| a.value).collect::<Vec<_>>(),
        [TextureAttr::Mipmap, TextureAttr::Trilinear]
    );
    let ItemKind::Vector(v) = &p.items[3].kind else { panic!() };
    let role = v.role.as_ref().unwrap();
    assert_eq!(
        (role.kind.value, role.index.as_ref().unwrap().value, role.space.as_ref().unwrap().value),
        (VectorKind::Light, 1, Space::Tangent)
    );
    let ItemKind::Shader(s) = &p.items[9].kind else { panic!() };
    assert_eq!((s.params.len(), s.lets.len(), s.block, s.output.value), (1, 1, true, Type::Color));
    assert_eq!(sexpr(&s.body), "(^ d n)");
}

#[test]
fn spans_point_at_the_source_text() {
    let src = "const k = 1;\nC δπx ← T δu x;";
    let (p, _) = parse(src);
    let ItemKind::Statement(s) = &p.items[1].kind else { panic!() };
    assert_eq!(&src[s.value.span.range()], "T δu x");
    assert_eq!(&src[s.target.span.range()], "C δπx");
    assert_eq!(&src[s.target.table.span.range()], "C");
    assert_eq!(&src[p.items[1].span.range()], "C δπx ← T δu x;");
    let src = "C xs ← kd * (N·L);";
    let (p, _) = parse(src);
    let ItemKind::Statement(s) = &p.items[0].kind else { panic!() };
    assert_eq!(&src[s.value.span.range()], "kd * (N·L)");
}

#[test]
fn every_error_is_reported_not_only_the_first() {
    let src = "C xs ← a +;\nC xs = b;\nC xs ← c;\nC xs ← ⊗;\n";
    let (_, d) = parse(src);
    let lines: Vec<usize> =
        d.iter().map(|d| src[..d.primary.span.start as usize].matches('\n').count() + 1).collect();
    assert_eq!(lines, [1, 2, 4], "{d:#?}");
    assert!(d[1].help.as_deref().unwrap().contains("assign with `←`"));
    assert!(d[2].help.as_deref().unwrap().contains("multiply with `*`"));
    let (_, d) = parse("C xs ← a ⋄ b;");
    assert!(d[0].help.as_deref().unwrap().contains("not a symbol of the language"), "{d:?}");
}

#[test]
fn a_missing_semicolon_is_blamed_with_a_hint() {
    // The next line starts a statement: the `;` is missing at the line's end.
    let (p, d) = parse("C xs ← a\nC xs ← b;");
    assert_eq!(d.len(), 1);
    assert_eq!(d[0].message, "expected `;` at the end of this line");
    assert_eq!(d[0].primary.span.start as usize, "C xs ← a".len());
    assert_eq!(p.items.len(), 2);
    // Two statements on one line: the second `←` is blamed, with the hint.
    let (_, d) = parse("C xs ← a C xs ← b;");
    assert_eq!(d[0].message, "expected an operator, an expression or `;`, found `←`");
    assert!(d[0].help.as_deref().unwrap().contains("previous statement lacks its `;`"));
}

#[test]
fn names_resolve_with_suggestions() {
    let src = "vector N : normal;\nvector L : light;\nC δπx ← δ normalise(N)·L;\nC δπx ← T δu x;";
    let e = errors(src);
    assert_eq!(
        e,
        [
            ("unknown-name", "unknown name `normalise`".to_string()),
            ("unknown-name", "unknown name `T`".to_string())
        ]
    );
    let (_, d) = check(src);
    assert_eq!(d[0].help.as_deref(), Some("did you mean `normalize`?"));
}

#[test]
fn families_of_the_paper_need_no_declaration() {
    assert!(errors("C′ δπx′ ← T δu‴ x*;\ntexture T : 2d;").is_empty());
}

#[test]
fn duplicates_and_bad_targets_are_errors() {
    let e = errors("const k = 1;\nconst k = 2;\nk xs ← 1;\ntexture u : 2d;");
    assert_eq!(
        e.iter().map(|(c, _)| *c).collect::<Vec<_>>(),
        ["duplicate-name", "bad-target", "reserved-name"]
    );
}

#[test]
fn unknown_profiles_and_words_are_suggested() {
    let (_, d) = check("target geforce265;");
    assert_eq!(d[0].message, "unknown target profile `geforce265`");
    assert!(d[0].help.as_deref().unwrap().starts_with("did you mean `geforce256`?"));
    let (_, d) = parse("texture T : 2D;");
    assert!(d[0].help.as_deref().unwrap().starts_with("did you mean `2d`?"));
}

#[test]
fn unused_declarations_warn() {
    let (_, d) = check("const k = 1;\nC xs ← 0;");
    assert_eq!(d.len(), 1);
    assert!(!d[0].is_error());
    assert_eq!(d[0].message, "constant `k` is never used");
}

#[test]
fn printing_is_canonical_and_stable() {
    let src = "C δπx ← (δ p s x) ⊕ (T δu x);\nu x ← πR R s x;\n";
    let (p, _) = parse(src);
    let printed = print::program(&p, print::Style::Unicode);
    assert_eq!(printed, "C δπx ← δ p s x ⊕ T δu x;\nu x ← πR R s x;\n");
    let ascii = print::program(&p, print::Style::Ascii);
    assert_eq!(ascii, "C delta pi x <- delta p s x (+) T delta u x;\nu x <- pi_R R s x;\n");
}

#[test]
fn comments_inside_items_are_kept_on_their_lines() {
    let src = "shader h(n = 8) : s → c {\n    // the diffuse term\n    let d = N·L;  // (23)\n    let e = d +  # mid-expression\n        1;\n    d * e  /* result */\n    // closing\n}\nC δπx ← (δ h s x) // inside a statement\n    ⊕ T δu x;\n";
    let (p, diags) = parse(src);
    assert!(diags.is_empty(), "{diags:?}");
    let printed = print::program(&p, print::Style::Unicode);
    assert_eq!(
        printed,
        "shader h(n = 8) : s → c {\n    // the diffuse term\n    let d = N·L;  // (23)\n    # mid-expression\n    let e = d + 1;\n    d * e  /* result */\n    // closing\n}\n// inside a statement\nC δπx ← δ h s x ⊕ T δu x;\n"
    );
    // Printing again changes nothing.
    let (again, _) = parse(&printed);
    assert_eq!(print::program(&again, print::Style::Unicode), printed);
}

/// `fmt` loses no comment of any example, and is idempotent on them.
#[test]
fn every_example_keeps_every_comment() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/examples");
    let comments = |text: &str| {
        let mut all: Vec<String> = super::split::comments_in(text, 0).into_iter().map(|c| c.text).collect();
        all.sort();
        all
    };
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "shd") {
            continue;
        }
        let src = std::fs::read_to_string(&path).unwrap();
        let (p, _) = parse(&src);
        let printed = print::program(&p, print::Style::Unicode);
        assert_eq!(comments(&printed), comments(&src), "{}", path.display());
        let (again, _) = parse(&printed);
        assert_eq!(print::program(&again, print::Style::Unicode), printed, "{}", path.display());
    }
}

#[test]
fn the_deepest_allowed_nesting_parses_in_a_small_stack() {
    // 64 levels is the limit (MAX_NESTING); it must parse in a 2 MiB thread
    // stack (the test harness default), with pest's stack guard untouched.
    let src = format!("C xs ← {}x{};", "(".repeat(64), ")".repeat(64));
    let (_, d) = parse(&src);
    assert!(d.is_empty(), "{d:#?}");
    let src = format!("C xs ← {}x{};", "max(0, ".repeat(63), ")".repeat(63));
    let (_, d) = parse(&src);
    assert!(d.is_empty(), "{d:#?}");
}

/// Small programs parse on the calling thread, large ones in parallel: both
/// ways give the same items, with errors, in source order.
#[test]
fn pieces_parse_the_same_on_one_thread_and_in_parallel() {
    use super::{parse_pieces, split::split_items, PARALLEL_ITEMS};
    let mut source = String::new();
    for entry in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/examples")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "shd") {
            source += &std::fs::read_to_string(path).unwrap();
            source += "\nC xs ← (x;\nlet broken = 1 +;\n";
        }
    }
    let pieces = split_items(&source);
    assert!(pieces.len() > 4 * PARALLEL_ITEMS, "{} pieces", pieces.len());
    let one_thread = parse_pieces(&source, &pieces, false);
    let parallel = parse_pieces(&source, &pieces, true);
    assert!(one_thread.iter().flatten().any(|p| p.is_err()), "no piece with an error");
    assert!(one_thread == parallel, "the parallel parse differs from the sequential one");
}
