//! The language reference cannot drift from the grammar: `docs/language.md`
//! embeds `grammar/shade.pest` verbatim, and every ```shd example in it checks
//! without errors or warnings.

const DOC: &str = include_str!("../docs/language.md");
const GRAMMAR: &str = include_str!("../grammar/shade.pest");

#[test]
fn the_reference_embeds_the_grammar_verbatim() {
    assert!(DOC.contains(&format!("```pest\n{GRAMMAR}```")), "re-generate the grammar section of docs/language.md");
}

#[test]
fn every_example_in_the_reference_checks_clean() {
    let blocks: Vec<&str> = DOC.split("```shd\n").skip(1).map(|b| b.split("```").next().unwrap()).collect();
    assert!(blocks.len() >= 11, "one example per construct, found {}", blocks.len());
    for block in blocks {
        let (_, diagnostics) = shadec::parser::check(block);
        let file = shadec::diag::SourceFile::new("docs/language.md", block);
        assert!(diagnostics.is_empty(), "{}", file.render(&diagnostics, false));
    }
}
