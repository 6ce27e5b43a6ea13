//! Snapshot tests (insta) of the diagnostics people and editors see: the
//! rustc-like rendering and the LSP JSON, for every input in
//! `tests/diagnostics/*.shd`. Review changes with `cargo insta review` or
//! `INSTA_UPDATE=always cargo test --test diagnostics` and `git diff`.

use crate::common;

mod battery;

use shadec::diag::SourceFile;

#[test]
fn rendered_diagnostics() {
    let inputs = common::shd_files("tests/diagnostics");
    assert!(inputs.len() >= 8);
    for path in inputs {
        let name = path.file_stem().unwrap().to_str().unwrap().to_string();
        let text = std::fs::read_to_string(&path).unwrap();
        let (_, diagnostics) = shadec::parser::check(&text);
        assert!(!diagnostics.is_empty(), "{name}: every input here has something to report");
        let file = SourceFile::new(format!("{name}.shd"), text);
        let human = file.render(&diagnostics, false);
        let lsp =
            serde_json::to_string_pretty(&file.to_lsp(&format!("file:///{name}.shd"), &diagnostics)).unwrap();
        insta::assert_snapshot!(format!("{name}.human"), human);
        insta::assert_snapshot!(format!("{name}.lsp"), lsp);
    }
}

/// The first error's message and help of `text` (parsed, then lowered).
fn first_error(text: &str) -> (String, String) {
    let (program, mut diagnostics) = shadec::parser::check(text);
    if !diagnostics.iter().any(|d| d.is_error()) {
        diagnostics = shadec::ir::lower(&program).1;
    }
    let d = diagnostics.into_iter().find(|d| d.is_error()).expect("an error");
    (d.message, d.help.unwrap_or_default())
}

/// Help lines that used to mislead ("Diagnostics that never
/// mislead"), each with its exact text.
#[test]
fn help_for_symbols_in_the_wrong_place_says_where_they_belong() {
    // It said "`→` is not a symbol of the language; the symbols are … → …".
    let (_, help) = first_error("vector N : normal;\nvector L : light;\nC δπx ← N → L;\n");
    assert_eq!(
        help,
        "`→` (ASCII `->`) only separates a shader's argument from its result type: `shader d : s → c = …`"
    );
    let (_, help) = first_error("texture T : 2d rgb8;\nC δπx ← ⊕ T δu x;\n");
    assert_eq!(help, "`⊕` (ASCII `(+)`) combines the values on its two sides: `a ⊕ b`, `a ⊕[add] b`");
}

#[test]
fn text_pasted_from_the_papers_symbol_font_gets_the_symbols() {
    // seeds/001 (1) as a PDF's Symbol font pastes it: d→δ, p→π, ¬→←.
    let (message, help) = first_error("vector N : normal;\nC d p x ¬ d p s x;\n");
    assert_eq!(message, "expected an expression or `←` (or `<-`), found `¬`");
    assert!(help.starts_with("did you mean `←` (ASCII `<-`)? Text pasted from a PDF set in the Symbol font shows ← as `¬`, ⊕ as `Å`, δ as `d` and π as `p`"), "{help}");
    // With `←` fixed, the `d` and `p` are δ and π, not "did you mean `N`?".
    let (message, help) = first_error("vector N : normal;\nC d p x ← N;\n");
    assert_eq!(message, "unknown name `d`");
    assert_eq!(
        help,
        "did you mean `δ` (ASCII `delta`)? Text pasted from a PDF set in the Symbol font shows δ as `d`"
    );
    let (message, help) = first_error("vector N : normal;\nC δ p x ← N;\n");
    assert_eq!(message, "unknown name `p`");
    assert_eq!(
        help,
        "did you mean `π` (ASCII `pi`)? Text pasted from a PDF set in the Symbol font shows π as `p`"
    );
    // The alpha and stencil channels as printed: `a C xs`, `s C δπx`.
    let (message, help) = first_error("texture T : 2d rgba8;\nC δπx ← a C δπx * (T δu x);\n");
    assert_eq!(message, "unknown name `a`");
    assert_eq!(help, "did you mean `α` (ASCII `alpha`), the framebuffer's alpha channel? Pipeline Grammar as printed (the Symbol font) shows `α` as `a`");
    let (message, help) = first_error("C δπx ← 1;\ns C δπx ← 1;\n");
    assert_eq!(message, "`s` is not a table");
    assert!(help.starts_with("did you mean `σ` (ASCII `stencil`)"), "{help}");
}

#[test]
fn a_transposed_name_is_suggested() {
    let (message, help) =
        first_error("vector Light : light;\nvector N : normal;\nC δπx ← max(0, N·Ligth);\n");
    assert_eq!(message, "unknown name `Ligth`");
    assert_eq!(help, "did you mean `Light`?");
}

#[test]
fn an_unclosed_parenthesis_says_where_it_opened() {
    let text = "vector N : normal;\nvector L : light;\nC δπx ← max(0, (N·L);\n";
    let (_, diagnostics) = shadec::parser::check(text);
    let d = diagnostics.iter().find(|d| d.is_error()).unwrap();
    let opened =
        d.secondary.iter().find(|l| l.message == "this `(` is never closed").expect("a label at the `(`");
    assert_eq!(&text[opened.span.start as usize..opened.span.end as usize], "(");
    assert_eq!(opened.span.start as usize, text.find("max(").unwrap() + 3);
    assert_eq!(d.help.as_deref(), Some("close the `(` opened here with `)` before the statement ends"));
    // `(+)` and `(.)` are operators, not brackets; a string's `(` does not count.
    let (_, diagnostics) =
        shadec::parser::check("texture T : 2d rgb8 = image(\"a(b.png\");\nC δπx ← (T δu x) (+) (T δu x;\n");
    let d = diagnostics.iter().find(|d| d.is_error()).unwrap();
    assert_eq!(d.secondary.len(), 1, "{d:?}");
}

/// A missing `;` is one error at the end of its line; the statement on the
/// next line is a new statement, and no "unknown name" cascade follows
/// (50 statements each missing its `;` reported one error).
#[test]
fn each_missing_semicolon_is_reported_where_it_belongs() {
    let mut text = String::from("vector N : normal;\nvector L : light\ntexture T : 2d rgb8\n");
    for _ in 0..50 {
        text += "C δπx ← (C δπx) ⊕[add] (T δu x) * max(0, N·L)\n";
    }
    let (program, diagnostics) = shadec::parser::check(&text);
    let errors: Vec<_> = diagnostics.iter().filter(|d| d.is_error()).collect();
    assert_eq!(errors.len(), 52, "{:#?}", errors.iter().map(|d| &d.message).collect::<Vec<_>>());
    assert!(
        errors.iter().all(|d| d.message == "expected `;` at the end of this line"),
        "{:?}",
        errors[0].message
    );
    // The first is at the end of line 2, after `light`.
    assert_eq!(errors[0].primary.span.start as usize, text.find("light\n").unwrap() + "light".len());
    assert_eq!(program.items.len(), 53, "every item still parses");
    // A statement continued on the next line is not cut.
    let (_, diagnostics) = shadec::parser::check("texture T : 2d rgb8;\nC δπx ← (T δu x)\n    * 0.5;\n");
    assert!(diagnostics.iter().all(|d| !d.is_error()), "{diagnostics:?}");
}

/// Pipeline Grammar, eq. (28) as the paper prints it, `ρ = 1 − (1 − V·N)^n`: the help
/// offers the definition as a shader, and following it gives a program
/// that checks.
#[test]
fn a_definition_written_as_the_paper_writes_it_gets_a_help_that_leads_to_a_clean_program() {
    let text = "vector N : normal;\nvector V : view;\nρ = 1 − (1 − V·N)^n;\n";
    let (message, help) = first_error(text);
    assert_eq!(message, "expected an expression or `←` (or `<-`), found `=`");
    let shader = "shader ρ(n: scalar = 1) : s → c = 1 − (1 − V·N)^n;";
    assert_eq!(
        help,
        format!("to define `ρ` as a function of the shading parameters (as Pipeline Grammar, eq. (28) does), write it as a shader: `{shader}`, then use it in a statement such as `C δπx ← δ ρ s x;`; to assign into a table, write `←` (ASCII `<-`)")
    );
    // Follow the help: replace the line by the shader, add the statement.
    let fixed = format!("vector N : normal;\nvector V : view;\n{shader}\nC δπx ← δ ρ s x;\n");
    let (program, diagnostics) = shadec::parser::check(&fixed);
    assert!(diagnostics.is_empty(), "{diagnostics:?}");
    let (_, lowered) = shadec::ir::lower(&program);
    assert!(lowered.iter().all(|d| !d.is_error()), "{lowered:?}");
    // Declared names are not made parameters; a name that is not a word gets no such help.
    let (_, help) = first_error(
        "vector N : normal;\nvector V : view;\nconst n = 8;\nρ = 1 − (1 − V·N)^n;\nC δπx ← δ ρ s x;\n",
    );
    assert!(help.contains("`shader ρ : s → c = 1 − (1 − V·N)^n;`"), "{help}");
    let (_, help) = first_error("vector N : normal;\nC δπx = N;\n");
    assert_eq!(help, "assign with `←` (ASCII `<-`): `C δπx ← T δu x;`");
}

/// `p(16) δ s x`: shader parameters cannot be set where the shader is used
/// (examples/GAPS.md item 6); the help says so and shows the declaration's
/// own parameter, not "to multiply, write `*`" alone.
#[test]
fn setting_shader_parameters_where_used_says_it_cannot_yet() {
    let decl =
        "vector N : normal;\nvector L : light(0);\nshader p(n: scalar = 32) : s → c = max(0, N·L)^n;\n";
    let (message, help) = first_error(&format!("{decl}C δπx ← p(16) δ s x;\n"));
    assert_eq!(message, "`p(16)`: a shader's parameters cannot be set where it is used");
    assert_eq!(
        help,
        "set the value as the parameter's default where `p` is declared, `shader p(n: scalar = 16) : …`, and use it as `p δ s x`; for two values declare two shaders (examples/GAPS.md item 6); to multiply instead, write `*`"
    );
    // Following it checks.
    let fixed = format!("{}C δπx ← p δ s x;\n", decl.replace("= 32", "= 16"));
    assert!(shadec::parser::check(&fixed).1.is_empty());
    // The parameter's own name; a shader without parameters; a shader not declared.
    let (_, help) = first_error(&format!(
        "{}C δπx ← p(16) δ s x;\n",
        decl.replace("(n: scalar = 32)", "(e = 32)").replace("^n", "^e")
    ));
    assert!(help.contains("`shader p(e = 16) : …`"), "{help}");
    let (_, help) = first_error(&format!(
        "{}C δπx ← p(16) δ s x;\n",
        decl.replace("(n: scalar = 32)", "").replace("^n", "")
    ));
    assert_eq!(help, "the shader `p` has no parameters: remove `(16)` and write `p δ s x`");
    let (message, _) = first_error("C δπx ← q(2) δ s x;\n");
    assert_eq!(message, "`q(2)`: a shader's parameters cannot be set where it is used");
}

/// Every diagnostic of a generated expression — atoms of every type
/// (scalar, vec2, vec3, rgb, rgba) under every operator and built-in
/// function, with any number of arguments, in a shader and a statement —
/// has a help line and a span inside the text: no type error is left with
/// only its message ("`clamp` takes 3 argument(s), got 1" had no help).
mod generated_type_errors {
    use proptest::prelude::*;

    const HEAD: &str = "vector N : normal;\nvector L : light(0);\ntexture T : 2d rgba8 = image(\"missing.png\");\nconst k : rgb = (0.5, 0.4, 0.3);\n";

    fn atom() -> impl Strategy<Value = String> {
        prop::sample::select(vec![
            "0.5",
            "N",
            "L",
            "k",
            "(T δu x)",
            "(T δu x).a",
            "vec2(0.2, 0.3)",
            "(0.1, 0.2, 0.3)",
            "N·L",
            "(T δu x).rgb",
        ])
        .prop_map(String::from)
    }

    fn expr() -> impl Strategy<Value = String> {
        atom().prop_recursive(3, 12, 3, |inner| {
            let funs = [
                "max",
                "min",
                "clamp",
                "mix",
                "lerp",
                "normalize",
                "pow",
                "step",
                "smoothstep",
                "reflect",
                "cross",
                "dot",
                "saturate",
                "rgb",
                "rgba",
                "vec2",
                "vec3",
                "length",
                "sqrt",
                "expand",
            ];
            prop_oneof![
                (
                    inner.clone(),
                    prop::sample::select(vec!["+", "-", "*", "/", "·", "^", ">", "⊕", "⊕[add]", "AND"]),
                    inner.clone()
                )
                    .prop_map(|(a, op, b)| format!("({a} {op} {b})")),
                (prop::sample::select(funs.to_vec()), prop::collection::vec(inner.clone(), 1..4))
                    .prop_map(|(f, args)| format!("{f}({})", args.join(", "))),
                inner.prop_map(|a| format!("¬({a})")),
            ]
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]
        #[test]
        fn every_diagnostic_has_a_help_and_a_span(e in expr(), f in expr()) {
            let text = format!("{HEAD}shader d : s → c = {e};\nC δπx ← d δ s x * {f};\n");
            let (program, mut diagnostics) = shadec::parser::check(&text);
            if !diagnostics.iter().any(|d| d.is_error()) {
                diagnostics.extend(shadec::ir::lower(&program).1);
            }
            for d in &diagnostics {
                prop_assert!(d.help.as_deref().is_some_and(|h| !h.is_empty()), "no help: {} [{}]\n{text}", d.message, d.code);
                let s = d.primary.span;
                prop_assert!(s.end as usize <= text.len() && s.start <= s.end, "{d:?}\n{text}");
            }
        }
    }
}

/// `check` reports every error at once: a syntax error in one statement
/// does not hide a type error in another; a statement that reads a name
/// whose declaration did not parse gets no error of its own (its error may
/// be the declaration's echo).
#[test]
fn a_syntax_error_does_not_hide_a_type_error_elsewhere() {
    let text = "texture T : 2d rgb8;\ntexture D : 2d rgb8\nlet k = ⊕ 2;\nC δπx ← T δu x ⊕ ;\nC δπx ← clamp(T δu x, 0);\nC δπx ← k * (D δu x);\n";
    let front = shadec::driver::front(text);
    let errors: Vec<(usize, String)> = front
        .diagnostics
        .iter()
        .filter(|d| d.is_error())
        .map(|d| (text[..d.primary.span.start as usize].matches('\n').count() + 1, d.message.clone()))
        .collect();
    assert!(front.module.is_none());
    let on_line = |n: usize| errors.iter().filter(|(l, _)| *l == n).count();
    // Line 2 misses its `;`, lines 3-4 are broken, line 5 calls `clamp` with
    // two arguments (a lowering error), line 6 reads the broken `k`.
    assert!(errors.iter().any(|(l, m)| *l == 5 && m.contains("clamp")), "{errors:#?}");
    assert_eq!((on_line(2), on_line(5), on_line(6)), (1, 1, 0), "{errors:#?}");
    assert!(on_line(3) >= 1 && on_line(4) >= 1, "{errors:#?}");
}

/// A framebuffer used without its declaration (the light's depth map of a
/// shadow map) is not "did you mean `L`?" (a vector): the help declares a
/// framebuffer, at the assignment and at the read.
#[test]
fn an_undeclared_light_framebuffer_gets_a_framebuffer_declaration() {
    let text = "vector N : normal;\nvector L : light;\nCl δπl x ← 1;\nC δπx ← (z δπl x) ≤ (z Cl δπl x) ? max(0, N·L) : 0;\n";
    let (_, diagnostics) = shadec::parser::check(text);
    let unknown: Vec<_> = diagnostics.iter().filter(|d| d.code == "unknown-name").collect();
    assert_eq!(unknown.len(), 2, "{diagnostics:#?}");
    for d in unknown {
        let help = d.help.as_deref().unwrap_or_default();
        assert!(help.contains("`framebuffer Cl : depth;`") && !help.contains("`L`"), "{help}");
    }
    // A misspelt framebuffer is still suggested.
    let (message, help) = first_error("framebuffer Cl : depth;\nCk δπl x ← 1;\nC δπx ← z Cl δπl x;\n");
    assert_eq!((message.as_str(), help.as_str()), ("unknown name `Ck`", "did you mean `Cl`?"));
}

/// A refusal caused by a uniform with no bound names the uniform, and its
/// help is true: declared a colour (`: c`), the statement plans.
#[test]
fn a_refusal_for_an_unbounded_uniform_names_it_and_its_help_plans() {
    let program = |decl: &str| {
        format!("vector N : normal;\nvector L : light;\n{decl}\ntexture Det : 2d rgb8 = image(\"detail.png\");\nshader p : s → c = max(0, N·L);\nC δπx ← exposure * (2 * Det δu x) * δ p s x;\n")
    };
    let profile = shadec::profile::Profile::resolve("geforce3").unwrap();
    let refused = shadec::driver::compile(&program("uniform exposure = 0.8;"), &profile, &Default::default());
    let help = refused.err().and_then(|d| d.into_iter().find_map(|d| d.help)).unwrap_or_default();
    assert!(
        help.contains("`exposure` is a uniform with no bound")
            && help.contains("`uniform exposure : c = …;`"),
        "{help}"
    );
    let followed =
        shadec::driver::compile(&program("uniform exposure : c = 0.8;"), &profile, &Default::default());
    assert!(
        followed.is_ok(),
        "{:?}",
        followed.err().map(|d| d.into_iter().map(|d| d.message).collect::<Vec<_>>())
    );
}
