//! Bad input never panics: each case gives exit code 1 or 2 and a clear message
//! (issue 2, item 6). Exercised through the CLI, so a crash would show as a signal.

use crate::common;

use std::io::Write as _;

use common::{examples, shadec_in};
use proptest::prelude::*;

fn check_bytes(bytes: &[u8]) -> common::Run {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("input.shd");
    std::fs::File::create(&path).unwrap().write_all(bytes).unwrap();
    shadec_in(dir.path(), &["check", "input.shd"])
}

#[test]
fn empty_file_says_nothing_is_drawn() {
    let r = check_bytes(b"");
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains("error[no-statement]: the program has no statement"), "{}", r.stderr);
    assert!(r.stderr.contains("input.shd:1:1"), "{}", r.stderr);
}

#[test]
fn non_utf8_names_the_byte_offset() {
    let r = check_bytes(b"C xs \xe2\x86\x90 T\xff xs;");
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("input.shd: byte 10 (line 1) is not valid UTF-8"), "{}", r.stderr);
}

#[test]
fn random_bytes_are_rejected_cleanly() {
    // A fixed pseudo-random sequence (xorshift), so the test is repeatable.
    let mut state = 0x2545F4914F6CDD1Du64;
    let bytes: Vec<u8> = (0..4096)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state as u8
        })
        .collect();
    let r = check_bytes(&bytes);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("is not valid UTF-8"));
    // The same bytes made valid UTF-8 are a syntax error, not a crash.
    let text = String::from_utf8_lossy(&bytes).into_owned();
    let r = check_bytes(text.as_bytes());
    assert_eq!(r.code, 1, "{}", r.stderr);
    assert!(r.stderr.contains("error[syntax]"));
}

#[test]
fn a_megabyte_single_line_sum_is_not_nesting() {
    // A flat sum is built balanced (issue 37): 250 000 terms nest 18 deep.
    let mut src = String::from("const a = 1; C xs ← a");
    while src.len() < 1_000_000 {
        src.push_str(" + a");
    }
    src.push(';');
    let r = check_bytes(src.as_bytes());
    assert_eq!(r.code, 0, "{}", &r.stderr[..r.stderr.len().min(2000)]);
    assert!(!r.stderr.contains("nesting-too-deep"));
}

#[test]
fn ten_megabytes_of_statements_on_one_line_check_clean() {
    let mut src = String::from("const a = 1;");
    while src.len() < 10_000_000 {
        src.push_str(" C xs ← a + a·a;");
    }
    let r = check_bytes(src.as_bytes());
    assert_eq!(r.code, 0, "{}", &r.stderr[..r.stderr.len().min(2000)]);
}

#[test]
fn hundred_thousand_nested_parentheses_do_not_overflow() {
    let src = format!("C xs ← {}1{};", "(".repeat(100_000), ")".repeat(100_000));
    let r = check_bytes(src.as_bytes());
    assert_eq!(r.code, 1);
    assert!(
        r.stderr.contains("error[nesting-too-deep]: brackets nest more than 64 levels deep"),
        "{}",
        r.stderr
    );
    assert!(r.stderr.contains("input.shd:1:72"), "the error points at the 65th bracket: {}", r.stderr);
}

#[test]
fn long_application_and_unary_chains_are_bounded() {
    for src in [
        format!("const a = 1; C xs ← {}a;", "a ".repeat(200_000)),
        format!("const a = 1; C xs ← {}a;", "-".repeat(200_000)),
        format!("const a = 1; C xs ← a{};", "^a".repeat(200_000)),
        format!("const a = 1; C xs ← {}a;", "a ? a : ".repeat(200_000)),
        // Glued subscripts look ahead one atom; a chain of them must stay linear.
        format!("const a = 1; C xs ← {}x;", "πa ".repeat(200_000)),
    ] {
        let r = check_bytes(src.as_bytes());
        assert_eq!(r.code, 1, "{}", &r.stderr[..r.stderr.len().min(500)]);
        assert!(r.stderr.contains("nesting-too-deep"), "{}", &r.stderr[..r.stderr.len().min(500)]);
        assert!(r.stderr.contains("(this line has"), "long lines are shown as an excerpt");
    }
}

#[test]
fn unknown_symbols_get_a_suggestion() {
    let r =
        check_bytes("vector N : normal;\nvector L : light;\nC δπx ← max(0, N·normalise(L));\n".as_bytes());
    assert_eq!(r.code, 1);
    assert!(r.stderr.contains("error[unknown-name]: unknown name `normalise`"), "{}", r.stderr);
    assert!(r.stderr.contains("input.shd:3:18"), "{}", r.stderr);
    assert!(r.stderr.contains("help: did you mean `normalize`?"), "{}", r.stderr);
    let r = check_bytes("C xs ← a ⊗ b;".as_bytes());
    assert!(r.stderr.contains("help: multiply with `*`; take a dot product with `·`"), "{}", r.stderr);
}

#[test]
fn missing_files_and_folders_are_io_errors() {
    let dir = tempfile::tempdir().unwrap();
    let r = shadec_in(dir.path(), &["check", "nope.shd"]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("error: nope.shd: no such file or folder"), "{}", r.stderr);
    std::fs::create_dir(dir.path().join("empty")).unwrap();
    let r = shadec_in(dir.path(), &["check", "empty"]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("error: empty: no `.shd` files in this folder"), "{}", r.stderr);
    let r = shadec_in(dir.path(), &["fmt", "nope.shd"]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("nope.shd: cannot read"), "{}", r.stderr);
}

#[test]
fn usage_errors_exit_2() {
    let r = common::shadec(&["check"]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("required"), "{}", r.stderr);
    assert_eq!(common::shadec(&["frobnicate"]).code, 2);
}

// ---------------------------------------------------------------- mutated examples

const SYMBOLS: &[&str] = &[
    "δ", "π", "←", "⊕", "·", "′", "(", ")", "{", "}", ";", "*", "?", ":", "[", "]", "\"", "⁻¹", "x", " ",
    "\n", "#", "/*", "α",
];

fn corpus() -> Vec<String> {
    examples().iter().map(|p| std::fs::read_to_string(p).unwrap()).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Mutated examples: parsing and checking never panic, every span lies in
    /// the text on character boundaries, and rendering succeeds.
    #[test]
    fn mutated_examples_never_panic(
        pick in any::<prop::sample::Index>(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), 0usize..12, prop::sample::select(SYMBOLS)), 1..6),
    ) {
        let corpus = corpus();
        prop_assume!(!corpus.is_empty());
        let mut text = pick.get(&corpus).clone();
        for (at, delete, insert) in edits {
            let mut i = at.index(text.len() + 1);
            while !text.is_char_boundary(i) { i -= 1; }
            let mut j = (i + delete).min(text.len());
            while !text.is_char_boundary(j) { j -= 1; }
            text.replace_range(i..j, insert);
        }
        let (_, diagnostics) = shadec::parser::check(&text);
        for d in &diagnostics {
            for span in std::iter::once(d.primary.span).chain(d.secondary.iter().map(|l| l.span)) {
                prop_assert!(span.end as usize <= text.len() && span.start <= span.end);
                prop_assert!(text.is_char_boundary(span.start as usize) && text.is_char_boundary(span.end as usize));
            }
        }
        let file = shadec::diag::SourceFile::new("m.shd", text.clone());
        let _ = file.render(&diagnostics, false);
        let _ = file.to_lsp("file:///m.shd", &diagnostics);
    }
}
