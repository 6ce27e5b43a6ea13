//! Colour typing (issue 16, item 6): a light's `intensity(i)` is a colour,
//! `rgb(v)` reads a vec3 as a colour, and a shader `s → c` is typed by one
//! rule where it is declared and where it is used — the lighting idiom of
//! seeds/001 (1)-(3), `I * max(0, N·L)`, writes into a framebuffer.

use shadec::diag::Diagnostic;
use shadec::ir::{self, Expr, Module, Ty};

const DECLS: &str =
    "vector N : normal;\nvector L : light(0);\nvector I : intensity(0);\nconst kd : rgb = (0.8, 0.6, 0.4);\n";

/// Checks and lowers; every error of both.
fn errors(src: &str) -> Vec<Diagnostic> {
    let (program, mut d) = shadec::parser::check(src);
    let (_, lowered) = ir::lower(&program);
    d.extend(lowered);
    d.retain(|d| d.is_error());
    d
}

#[track_caller]
fn lower_ok(src: &str) -> Module {
    let e = errors(src);
    assert!(e.is_empty(), "errors in\n{src}\n{e:#?}");
    let (program, _) = shadec::parser::check(src);
    ir::lower(&program).0
}

/// The program, with the two directions it uses declared.
#[test]
fn the_lighting_idiom_writes_into_the_framebuffer() {
    let src = format!("{DECLS}shader d : s → c = I * max(0, N·L);\nC δπx ← d δ s x;\n");
    let m = lower_ok(&src);
    let st = &m.statements[0];
    // rgb widened to rgba (alpha 1) for the framebuffer's colour.
    assert_eq!(m.info(st.value).ty, Ty::Rgba);
    let Expr::Convert { value, to: Ty::Rgba } = m.exprs[st.value] else {
        panic!("not a widening: {:?}", m.exprs[st.value])
    };
    assert_eq!(m.info(value).ty, Ty::Rgb);
}

#[test]
fn an_intensity_vector_is_a_colour() {
    let m = lower_ok(&format!("{DECLS}C δπx ← I δ s x;\n"));
    let vectors: Vec<Ty> = m
        .exprs
        .arena()
        .iter()
        .filter(|(_, e)| matches!(e, Expr::Vector { .. }))
        .map(|(h, _)| m.info(h).ty)
        .collect();
    assert_eq!(vectors, vec![Ty::Rgb]);
}

#[test]
fn rgb_of_a_vec3_is_a_colour() {
    // A direction shown as a colour (a normal-map debug view).
    let m = lower_ok(&format!("{DECLS}C δπx ← rgb(N δ s x);\n"));
    let st = &m.statements[0];
    let Expr::Convert { value, to: Ty::Rgba } = m.exprs[st.value] else {
        panic!("not a widening: {:?}", m.exprs[st.value])
    };
    assert_eq!(m.info(value).ty, Ty::Rgb);
    // `rgb(I)` of a colour is the colour itself; `vec3(I)` reads it as a vector.
    lower_ok(&format!("{DECLS}shader d : s → c = rgb(I) * max(0, N·L);\nC δπx ← d δ s x;\n"));
    lower_ok(&format!("{DECLS}shader d : s → c = rgb(vec3(I) * max(0, N·L));\nC δπx ← d δ s x;\n"));
}

#[test]
fn a_vec3_into_a_framebuffer_says_how_to_convert() {
    let e = errors(&format!("{DECLS}C δπx ← N δ s x;\n"));
    assert_eq!(e.len(), 1, "{e:#?}");
    assert_eq!(e[0].message, "a vec3 is written into an rgba channel");
    assert!(e[0].help.as_deref().is_some_and(|h| h.contains("`rgb(v)`")), "{:?}", e[0].help);
}

/// A tuple is a vec3 (a direction); where a new user writes one as a
/// colour — blended by ⊕, scaling an rgba, written into the framebuffer —
/// the error's help names the colour form, and that form, written as the
/// help says, checks. A one-channel table baked from a colour shader says
/// how to make the value a scalar.
#[test]
fn a_tuple_where_a_colour_is_wanted_says_how_to_write_one() {
    let fb = "framebuffer D : rgba8, depth;\nD δπx ← kd;\n";
    for (wrong, right) in [
        ("C δπx ← (C δπx) ⊕[add] (0.05, 0.05, 0.05);", "C δπx ← (C δπx) ⊕[add] rgb(0.05, 0.05, 0.05);"),
        ("C xs ← (D xs) * (0.8, 0.9, 1.0);", "C xs ← (D xs) * rgb(0.8, 0.9, 1.0);"),
        ("C δπx ← (0.1, 0.1, 0.1);", "C δπx ← rgb(0.1, 0.1, 0.1);"),
    ] {
        let e = errors(&format!("{DECLS}{fb}{wrong}\n"));
        assert_eq!(e.len(), 1, "{wrong}: {e:#?}");
        assert!(
            e[0].help.as_deref().is_some_and(|h| h.contains("`rgb(r, g, b)`")),
            "{wrong}: {:?}",
            e[0].help
        );
        lower_ok(&format!("{DECLS}{fb}{right}\n"));
    }
    let table = "texture Tab : 2d r8 bilinear clamp = bake(lobe);\nC δπx ← Tab vec2(0.5, 0.5);\n";
    let e = errors(&format!("{DECLS}shader lobe : s → c = s.x ^ 24;\n{table}"));
    assert_eq!(e[0].message, "an rgb is written into the texture `Tab` of scalar texels");
    assert!(e[0].help.as_deref().is_some_and(|h| h.contains("`s → scalar`")), "{:?}", e[0].help);
    lower_ok(&format!("{DECLS}shader lobe : s → scalar = s.x ^ 24;\n{table}"));
}

/// A shader declared `s → c`, `s → rgb` or `s → rgba` that checks where it
/// is declared (unused: `check_unused` types it) checks where a statement
/// writes it into the framebuffer, for every body; and one that does not
/// check fails with the same message at both.
#[test]
fn a_colour_shader_checks_alike_where_declared_and_where_used() {
    let bodies = [
        "I * max(0, N·L)",
        "N",
        "kd * max(0, N·L)",
        "N·L",
        "rgb(N)",
        "I",
        "(N + L) * 0.5",
        "kd * I",
        "vec3(I)",
        "N.xy",
        "rgba(kd)",
        "(0.1, 0.2, 0.3)",
    ];
    let mut clean = 0;
    for out in ["c", "rgb", "rgba"] {
        for body in bodies {
            let decl = format!("{DECLS}shader d : s → {out} = {body};\n");
            let unused = format!("{decl}C δπx ← kd;\n");
            let used = format!("{decl}C δπx ← d δ s x;\n");
            let at_decl: Vec<String> = errors(&unused).into_iter().map(|d| d.message).collect();
            let at_use: Vec<String> = errors(&used).into_iter().map(|d| d.message).collect();
            assert_eq!(at_decl, at_use, "`s → {out} = {body}`: declared vs used");
            clean += at_decl.is_empty() as usize;
        }
    }
    // The rule is not vacuous: most bodies are colours, `N.xy` is not, nor an rgba as an rgb.
    assert!((20..36).contains(&clean), "{clean} clean");
}
