//! A battery of realistic mistakes — typos, wrong arrows, ASCII and Unicode
//! mixed, wrong types, missing declarations, bad swizzles, wrong generator
//! arguments, a target without the capability, a missing `;`, unbalanced
//! parentheses — each as a newcomer writes it. Each must give exactly one
//! diagnostic, an error, underlining the mistake itself (no cascade: no
//! "unknown name" for a declaration that failed, no second error for the
//! same slip), with a help that is true: where the help proposes a
//! rewrite, the test applies it and the error is gone. The human rendering
//! of each is an insta snapshot (`tests/snapshots/diagnostics_battery__<name>.snap`).

use shadec::diag::SourceFile;

/// A rewrite the help proposes: text the help must quote, and the edits
/// (first occurrence of each `from` replaced by `to`) that apply it.
struct Fix {
    quotes: &'static [&'static str],
    edits: &'static [(&'static str, &'static str)],
    /// Whether the rewritten program checks clean; false only where the
    /// rewrite names a file (`image("…")`) this test cannot provide.
    clean: bool,
}

struct Mistake {
    name: &'static str,
    source: &'static str,
    /// The error's code.
    code: &'static str,
    /// Line (1-based) and text of the primary label's span.
    at: (usize, &'static str),
    fix: Option<Fix>,
}

const fn fix(quotes: &'static [&'static str], edits: &'static [(&'static str, &'static str)]) -> Option<Fix> {
    Some(Fix { quotes, edits, clean: true })
}

const SHADING: &str = "vector N : normal;\nvector L : light;\n";

fn mistakes() -> Vec<Mistake> {
    vec![
        Mistake {
            name: "vector_kind_unknown_keeps_its_name_declared",
            source: "vector N : normal;\nvector L : lite;\nshader d : s → c = max(0, N·L);\nC δπx ← δ d s x * L δ s x.z;\n",
            code: "unknown-word",
            at: (2, "lite"),
            fix: None,
        },
        Mistake {
            name: "vector_kind_transposed",
            source: "vector N : normal;\nvector L : ligth;\nshader d : s → c = max(0, N·L);\nC δπx ← δ d s x;\n",
            code: "unknown-word",
            at: (2, "ligth"),
            fix: fix(&["`light`"], &[("ligth", "light")]),
        },
        Mistake {
            name: "name_transposed",
            source: "vector N : normal;\nvector Light : light;\nshader d : s → c = max(0, N·Ligth);\nC δπx ← δ d s x;\n",
            code: "unknown-name",
            at: (3, "Ligth"),
            fix: fix(&["`Light`"], &[("N·Ligth", "N·Light")]),
        },
        Mistake {
            name: "swizzle_letter_outside_both_sets",
            source: "vector N : normal;\nvector L : light;\nshader diffuse : s → c = max(0, N.xyq·L);\nC δπx ← diffuse δ s x;\n",
            code: "bad-swizzle",
            at: (3, ".xyq"),
            fix: None,
        },
        Mistake {
            name: "swizzle_mixes_the_two_sets",
            source: "texture T : 2d rgba8;\nC δπx ← T δu x.rgz;\n",
            code: "bad-swizzle",
            at: (2, ".rgz"),
            fix: fix(&["`.rgb`"], &[(".rgz", ".rgb")]),
        },
        Mistake {
            name: "period_for_the_dot_product",
            source: "vector N : normal;\nvector L : light;\nshader d : s → c = max(0, N.L);\nC δπx ← d δ s x;\n",
            code: "bad-swizzle",
            at: (3, ".L"),
            fix: fix(&["`N·L`"], &[("N.L", "N·L")]),
        },
        Mistake {
            name: "scalar_swizzled",
            source: "vector N : normal;\nvector L : light;\nshader d : s → c = (N·L).xyz;\nC δπx ← d δ s x;\n",
            code: "bad-swizzle",
            at: (3, "(N·L).xyz"),
            fix: fix(&["without the swizzle"], &[(".xyz", "")]),
        },
        Mistake {
            name: "fourth_component_of_a_vec3",
            source: "vector N : normal;\nshader d : s → c = N.w;\nC δπx ← d δ s x;\n",
            code: "bad-swizzle",
            at: (2, "N.w"),
            fix: None,
        },
        Mistake {
            name: "assignment_arrow_in_a_shader_type",
            source: "vector N : normal;\nvector L : light;\nshader d : s ← c = max(0, N·L);\nC δπx ← d δ s x;\n",
            code: "syntax",
            at: (3, "←"),
            fix: fix(&["`shader d : s → c = …`"], &[("s ← c", "s → c")]),
        },
        Mistake {
            name: "ascii_type_arrow_for_assignment",
            source: "texture T : 2d rgb8;\nC δπx -> T δu x;\n",
            code: "syntax",
            at: (2, "->"),
            fix: fix(&["`<-`"], &[("->", "<-")]),
        },
        Mistake {
            name: "type_arrow_for_assignment",
            source: "texture T : 2d rgb8;\nC δπx → T δu x;\n",
            code: "syntax",
            at: (2, "→"),
            fix: fix(&["`←`"], &[("→", "←")]),
        },
        Mistake {
            name: "equals_for_assignment",
            source: "texture T : 2d rgb8;\nC δπx = T δu x;\n",
            code: "syntax",
            at: (2, "="),
            fix: fix(&["`←`"], &[("C δπx =", "C δπx ←")]),
        },
        Mistake {
            name: "symbol_font_arrow",
            source: "shader p : s → c = 1;\nC δπx ¬ δ p s x;\n",
            code: "syntax",
            at: (2, "¬"),
            fix: fix(&["did you mean `←`"], &[("¬", "←")]),
        },
        Mistake {
            name: "missing_semicolon",
            source: "vector N : normal\nvector L : light;\nshader d : s → c = max(0, N·L);\nC δπx ← δ d s x;\n",
            code: "syntax",
            at: (1, ""),
            fix: fix(&["`;`"], &[("normal\n", "normal;\n")]),
        },
        Mistake {
            name: "broken_line_without_semicolon",
            source: "texture T : 2d rgb8;\nC δπx ← (T δu x) *\nC δπx ← (C δπx) ⊕[add] T δu x;\n",
            code: "syntax",
            at: (2, ""),
            fix: None,
        },
        Mistake {
            name: "unclosed_parenthesis",
            source: "vector N : normal;\nvector L : light;\nshader d : s → c = max(0, N·L;\nC δπx ← d δ s x;\n",
            code: "syntax",
            at: (3, ";"),
            fix: fix(&["close the `(`"], &[("N·L;", "N·L);")]),
        },
        Mistake {
            name: "extra_closing_parenthesis",
            source: "vector N : normal;\nvector L : light;\nshader d : s → c = max(0, N·L));\nC δπx ← d δ s x;\n",
            code: "syntax",
            at: (3, ")"),
            fix: fix(&["no matching opening bracket"], &[("N·L))", "N·L)")]),
        },
        Mistake {
            name: "built_in_inside_a_chain",
            source: "vector N : normal;\nvector L : light;\nC δπx ← δ max(0, N·L) s x;\n",
            code: "value-applied",
            at: (3, "max(0, N·L)"),
            fix: fix(
                &["`shader p : s → c = max(0, N·L);`", "`p s x`"],
                &[("C δπx ← δ max(0, N·L) s x;", "shader p : s → c = max(0, N·L);\nC δπx ← δ p s x;")],
            ),
        },
        Mistake {
            name: "built_in_inside_a_chain_with_p_taken",
            source: "vector N : normal;\nvector L : light;\nshader p : s → c = 1;\nC δπx ← p δ s x * max(0, N·L) δ s x;\n",
            code: "value-applied",
            at: (4, "max(0, N·L)"),
            fix: fix(
                &["`shader p′ : s → c = max(0, N·L);`", "`p′ δ s x`"],
                &[("max(0, N·L) δ s x;", "p′ δ s x;\nshader p′ : s → c = max(0, N·L);")],
            ),
        },
        Mistake {
            name: "shader_parameter_set_where_used",
            source: "vector N : normal;\nvector H : half;\nshader spec(n: scalar = 32) : s → c = max(0, N·H)^n;\nC δπx ← spec(16) δ s x;\n",
            code: "not-supported",
            at: (4, "spec(16)"),
            fix: fix(
                &["`shader spec(n: scalar = 16) : …`", "`spec δ s x`"],
                &[("= 32", "= 16"), ("spec(16) δ s x", "spec δ s x")],
            ),
        },
        Mistake {
            name: "number_applied_to_a_value",
            source: "texture T : 2d rgb8;\nC δπx ← 0.5 T δu x;\n",
            code: "not-a-function",
            at: (2, "0.5"),
            fix: fix(&["write `*` after the number"], &[("0.5 T", "0.5 * T")]),
        },
        Mistake {
            name: "multiplication_sign",
            source: "texture T : 2d rgb8;\ntexture T′ : 2d rgb8;\nC δπx ← T δu x × T′ δu x;\n",
            code: "syntax",
            at: (3, "×"),
            fix: fix(&["`*`"], &[("×", "*")]),
        },
        Mistake {
            name: "rgba_normal_map_dotted_with_a_vector",
            source: "vector L : light in tangent;\ntexture Tn : 2d rgba8 = bumps(8);\ntexture Ncube : cube rgb8 bilinear clamp = normalize_cube(32);\nC δπx ← max(0, expand(Tn δu x) · expand(Ncube δ L s x));\n",
            code: "type-mismatch",
            at: (4, "expand(Tn δu x) · expand(Ncube δ L s x)"),
            fix: fix(&["`.rgb`", "`rgb8`"], &[("2d rgba8", "2d rgb8")]),
        },
        Mistake {
            name: "delta_over_a_per_fragment_coordinate",
            source: "vector N : normal;\nvector H : half;\nshader nh : s → scalar = max(0, N·H);\ntexture Rough : 2d rgb8 = bumps(4);\ntexture Pow : 2d r8 bilinear clamp;\nPow δu ← 0.5;\nC δπx ← Pow δ(vec2(nh δ s x, (Rough δu x).g));\n",
            code: "delta-twice",
            at: (7, "δ"),
            fix: fix(&["remove this δ", "`T (…)`"], &[("Pow δ(vec2", "Pow (vec2")]),
        },
        Mistake {
            name: "colour_indexing_a_3d_table",
            source: "shader grade : s → c = rgb(s.x, s.y, s.z);\ntexture Lut : 3d rgba8 bilinear clamp = bake(grade);\nframebuffer Scene : rgba8, depth;\nScene δπx ← 0.5;\nC xs ← Lut ((Scene xs).rgb);\n",
            code: "bad-index",
            at: (5, "Lut ((Scene xs).rgb)"),
            fix: fix(&["`Lut vec3(c)`"], &[("Lut ((Scene xs).rgb)", "Lut vec3((Scene xs).rgb)")]),
        },
        Mistake {
            name: "signed_2d_bump_map_read_as_a_normal",
            source: "vector L : light in tangent;\ntexture Tn : 2d signed8 mipmap trilinear repeat = bumps(8);\ntexture Ncube : cube rgb8 bilinear clamp = normalize_cube(32);\nC δπx ← max(0, (Tn δu x).rgb · expand(Ncube δ L s x));\nC δπx ← (C δπx) ⊕[add] 0.1;\n",
            code: "bad-swizzle",
            at: (4, "(Tn δu x).rgb"),
            fix: fix(
                &["`vec3(n.x, n.y, sqrt(max(0, 1 - n·n)))`"],
                &[("(Tn δu x).rgb", "vec3((Tn δu x).x, (Tn δu x).y, sqrt(max(0, 1 - (Tn δu x)·(Tn δu x))))")],
            ),
        },
        Mistake {
            name: "cube_map_indexed_by_texture_coordinates",
            source: "texture Env : cube rgb8;\nC δπx ← Env δu x;\n",
            code: "bad-index",
            at: (2, "Env δu x"),
            fix: fix(
                &["`vector R : reflection;`", "`Env δ R s x`"],
                &[("C δπx ← Env δu x;", "vector R : reflection;\nC δπx ← Env δ R s x;")],
            ),
        },
        Mistake {
            name: "normalization_cube_declared_2d",
            source: "vector L : light;\ntexture Ncube : 2d rgb8 = normalize_cube(32);\nC δπx ← Ncube δ L s x;\n",
            code: "bad-generator",
            at: (2, "normalize_cube"),
            fix: fix(&["`texture Ncube : cube … = normalize_cube(…);`"], &[(": 2d", ": cube")]),
        },
        Mistake {
            name: "normalization_cube_too_large",
            source: "vector L : light;\ntexture Ncube : cube rgb8 = normalize_cube(2000);\nC δπx ← Ncube δ L s x;\n",
            code: "too-large",
            at: (2, "(2000)"),
            fix: fix(&["`normalize_cube(32)`"], &[("(2000)", "(32)")]),
        },
        Mistake {
            name: "normalization_cube_bits",
            source: "vector L : light;\ntexture Ncube : cube rgb8 = normalize_cube(32, 12);\nC δπx ← Ncube δ L s x;\n",
            code: "bad-generator",
            at: (2, "12"),
            fix: fix(&["`normalize_cube(size, 8)`"], &[(", 12)", ", 8)")]),
        },
        Mistake {
            name: "file_name_without_quotes",
            source: "texture T : 2d rgb8 = image(brick.png);\nC δπx ← T δu x;\n",
            code: "syntax",
            at: (1, "brick.png"),
            fix: Some(Fix {
                quotes: &["`\"brick.png\"`"],
                edits: &[("(brick.png)", "(\"brick.png\")")],
                clean: false,
            }),
        },
        Mistake {
            name: "texture_format_typo",
            source: "texture T : 2d rgb16;\nC δπx ← T δu x;\n",
            code: "unknown-word",
            at: (1, "rgb16"),
            fix: fix(&["`rgba16`"], &[("rgb16", "rgba16")]),
        },
        Mistake {
            name: "combine_mode_typo",
            source: "texture T : 2d rgb8;\nC δπx ← T δu x;\nC δπx ← (C δπx) ⊕[ad] T δu x;\n",
            code: "unknown-word",
            at: (3, "ad"),
            fix: fix(&["`add`"], &[("[ad]", "[add]")]),
        },
        Mistake {
            name: "target_profile_typo",
            source: "target geforce2;\ntexture T : 2d rgb8;\nC δπx ← T δu x;\n",
            code: "unknown-profile",
            at: (1, "geforce2"),
            fix: fix(&["`geforce3`"], &[("geforce2", "geforce3")]),
        },
        Mistake {
            name: "texture_read_per_vertex",
            source: "target geforce256;\ntexture T : 2d rgb8;\nC δπx ← δ T u x;\n",
            code: "unsupported-by-target",
            at: (3, "T u x"),
            fix: fix(&["`T δu x`"], &[("δ T u x", "T δu x")]),
        },
        Mistake {
            name: "cube_map_on_a_target_without_cube_maps",
            source: "target multitexture;\ntexture Env : cube rgb8;\nvector R : reflection;\nC δπx ← Env δ R s x;\n",
            code: "unsupported-by-target",
            at: (4, "Env δ R s x"),
            fix: fix(&["geforce256"], &[("multitexture", "geforce256")]),
        },
        Mistake {
            name: "ascii_words_run_together",
            source: "texture T : 2d rgb8;\nC deltapi x <- T delta u x;\n",
            code: "unknown-name",
            at: (2, "deltapi"),
            fix: fix(&["`delta pi`"], &[("deltapi", "delta pi")]),
        },
        Mistake {
            name: "texture_coordinates_run_together",
            source: "texture T : 2d rgb8;\nC δπx ← T δux;\n",
            code: "unknown-name",
            at: (2, "ux"),
            fix: fix(&["`u x`"], &[("δux", "δu x")]),
        },
        Mistake {
            name: "framebuffer_read_without_an_index",
            source: "texture T : 2d rgb8;\nC δπx ← T δu x;\nC δπx ← T δu x * C;\n",
            code: "type-mismatch",
            at: (3, "C"),
            fix: fix(&["`C δπx`"], &[("* C;", "* C δπx;")]),
        },
        Mistake {
            name: "texture_not_declared",
            source: "C δπx ← T δu x;\n",
            code: "unknown-name",
            at: (1, "T"),
            fix: Some(Fix {
                quotes: &["`texture T : 2d rgba8 = image(\"file.png\");`"],
                edits: &[("C δπx", "texture T : 2d rgba8 = image(\"file.png\");\nC δπx")],
                clean: false,
            }),
        },
        Mistake {
            name: "image_for_a_3d_texture",
            source: "vector P : position in object;\ntexture Wood : 3d rgb8 bilinear repeat = image(\"wood.png\");\nC δπx ← Wood δ P s x;\n",
            code: "bad-generator",
            at: (2, "image"),
            fix: Some(Fix {
                quotes: &["`2d`"],
                edits: &[("3d rgb8", "2d rgb8"), ("Wood δ P s x", "Wood δu x")],
                clean: false,
            }),
        },
        Mistake {
            name: "stencil_written_with_a_fraction",
            source: "target geforce256;\nframebuffer C : rgba8, depth, stencil;\nC δπx ← 1;\nσ C δπx ← 0.5;\nC δπx ← (σ C δπx) ? 0.2;\n",
            code: "unsupported-stencil",
            at: (4, "σ C δπx ← 0.5"),
            fix: fix(&["`σ C δπx ← 1;`"], &[("← 0.5", "← 1")]),
        },
        Mistake {
            name: "family_name_declared",
            source: "texture u : 2d rgb8;\nC δπx ← u δu x;\n",
            code: "reserved-name",
            at: (1, "u"),
            fix: None,
        },
    ]
}

/// The line (1-based) of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset].matches('\n').count() + 1
}

fn errors_of(source: &str) -> Vec<shadec::diag::Diagnostic> {
    shadec::verdict::check(source, None).expect("the profile resolves").diagnostics
}

#[test]
fn each_realistic_mistake_gives_one_located_error_with_a_true_help() {
    let mistakes = mistakes();
    assert!(mistakes.len() >= 25, "{} mistakes", mistakes.len());
    let failures: Vec<String> = mistakes.iter().filter_map(|m| judge(m).err()).collect();
    assert!(failures.is_empty(), "{} of the mistakes fail:\n\n{}", failures.len(), failures.join("\n\n"));
}

/// One mistake judged: its one error, where it is, its help, the rewrite.
fn judge(m: &Mistake) -> Result<(), String> {
    let found = errors_of(m.source);
    let file = SourceFile::new(format!("{}.shd", m.name), m.source);
    let human = file.render(&found, false);
    insta::with_settings!({ snapshot_path => "../snapshots", prepend_module_to_snapshot => false }, {
        insta::assert_snapshot!(format!("diagnostics_battery__{}", m.name), human);
    });
    let fail = |why: String| Err(format!("{}: {why}\n{human}", m.name));
    let [d] = found.as_slice() else { return fail(format!("{} diagnostics, not one", found.len())) };
    if !d.is_error() || d.code != m.code {
        return fail(format!("expected an error `{}`", m.code));
    }
    let span = d.primary.span.start as usize..d.primary.span.end as usize;
    let at = (line_of(m.source, span.start), &m.source[span]);
    if at != m.at {
        return fail(format!("located at {at:?}, not {:?}", m.at));
    }
    let help = d.help.as_deref().unwrap_or_default();
    if help.is_empty() {
        return fail("no help".into());
    }
    let Some(f) = &m.fix else { return Ok(()) };
    if let Some(q) = f.quotes.iter().find(|q| !help.contains(*q)) {
        return fail(format!("the help does not quote {q}"));
    }
    let mut fixed = m.source.to_string();
    for (from, to) in f.edits {
        if !fixed.contains(from) {
            return fail(format!("`{from}` is not in the program"));
        }
        fixed = fixed.replacen(from, to, 1);
    }
    let after = errors_of(&fixed);
    let rendered = SourceFile::new("fixed.shd", fixed.as_str()).render(&after, false);
    if after.iter().any(|e| e.code == d.code && e.message == d.message) {
        return fail(format!("the help's rewrite leaves the error:\n{rendered}"));
    }
    if f.clean && after.iter().any(|e| e.is_error()) {
        return fail(format!("the help's rewrite does not check:\n{fixed}\n{rendered}"));
    }
    Ok(())
}

/// Fifty broken statements, each without its `;`: each line its own
/// located error (the missing-`;` recovery holds when the statements are
/// broken too; it gave one error for all fifty).
#[test]
fn fifty_broken_lines_without_semicolons_give_fifty_located_errors() {
    let text = "C δπx ← ⊕ ⊕\n".repeat(50);
    let (_, diagnostics) = shadec::parser::check(&text);
    assert_eq!(diagnostics.len(), 50, "{diagnostics:#?}");
    for (k, d) in diagnostics.iter().enumerate() {
        assert!(d.is_error());
        assert_eq!(line_of(&text, d.primary.span.start as usize), k + 1);
        assert_eq!(&text[d.primary.span.start as usize..d.primary.span.end as usize], "⊕");
    }
}

/// A failed declaration's name stays declared: its uses, and a shader
/// whose body failed, raise nothing more, with any prefix of the file.
#[test]
fn a_failed_declaration_poisons_its_name_instead_of_leaving_it_unknown() {
    let text = format!(
        "{SHADING}texture T, T′ : 2x rgb8;\nshader d : s → c = max(0, N.q·L);\nconst k = (1, 2;\nC δπx ← T δu x * T′ δu x * d δ s x * k;\n"
    );
    let (_, diagnostics) = shadec::parser::check(&text);
    let codes: Vec<&str> = diagnostics.iter().map(|d| d.code).collect();
    assert_eq!(codes, ["unknown-word", "bad-swizzle", "syntax"], "{diagnostics:#?}");
}

/// Messages of the planner and the target check, each as a user met it:
/// an unbounded range is not printed as `[-inf, inf]` (an intensity is
/// never negative: the analysis only knows no bound), the note on what the
/// lowering removes is a sentence, and one read shared by two statements
/// is said once per statement, not twice.
#[test]
fn target_messages_name_ranges_in_words_and_say_each_thing_once() {
    let intensity = "target geforce3;\nvector N : normal;\nvector L : light;\nvector I : intensity;\ntexture T : 2d rgb8;\nC δπx ← T δu x * (I δ s x) * max(0, N δ s x · L δ s x);\n";
    let shared_read = "target multitexture;\ntexture Env : cube rgb8 = normalize_cube(32);\nvector R : reflection;\nshader e : s → c = 1;\nC δπx ← Env δ R s x * e δ s x;\nC δπx ← (C δπx) ⊕[add] Env δ R s x;\n";
    for (name, source) in [("unbounded_range", intensity), ("one_read_in_two_statements", shared_read)] {
        let found = errors_of(source);
        let human = SourceFile::new(format!("{name}.shd"), source).render(&found, false);
        let errors: Vec<_> = found.iter().filter(|d| d.is_error()).collect();
        // The range is refused once; the shared read, which the planner now
        // computes per vertex within its budget, is one warning per
        // statement that reads it — never two for one place.
        let expected = if name == "unbounded_range" { 1 } else { 0 };
        assert_eq!(errors.len(), expected, "{name}: errors:\n{human}");
        let mut places: Vec<_> =
            found.iter().map(|d| (d.code, d.primary.span.start, d.primary.span.end)).collect();
        let n = places.len();
        places.sort();
        places.dedup();
        assert_eq!(places.len(), n, "{name}: a diagnostic said twice:\n{human}");
        for d in &errors {
            let text = format!("{} {}", d.message, d.help.as_deref().unwrap_or_default());
            assert!(
                !text.contains("inf]") && !text.contains("[-inf") && !text.contains("[−inf"),
                "{name}: {text}"
            );
            assert!(!text.contains("as written it also this"), "{name}: {text}");
        }
        insta::with_settings!({ snapshot_path => "../snapshots", prepend_module_to_snapshot => false }, {
            insta::assert_snapshot!(format!("diagnostics_battery__{name}"), human);
        });
    }
}
