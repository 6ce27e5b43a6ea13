//! The language reference cannot drift from the grammar: `docs/language.md`
//! embeds `grammar/shade.pest` verbatim, and every ```shd example in it checks
//! without errors or warnings.

const DOC: &str = include_str!("../docs/language.md");
const GRAMMAR: &str = include_str!("../grammar/shade.pest");

/// `UPDATE_DOCS=1 cargo test --test docs` rewrites the grammar section.
#[test]
fn the_reference_embeds_the_grammar_verbatim() {
    let section = format!("```pest\n{GRAMMAR}```");
    if DOC.contains(&section) {
        return;
    }
    if std::env::var_os("UPDATE_DOCS").is_some() {
        let start = DOC.find("```pest\n").expect("docs/language.md has a ```pest block");
        let end = start + DOC[start..].find("\n```").expect("the block is closed") + 4;
        let updated = format!("{}{section}{}", &DOC[..start], &DOC[end..]);
        std::fs::write(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/language.md"), updated).unwrap();
        return;
    }
    panic!("docs/language.md does not embed grammar/shade.pest as it is now; run `UPDATE_DOCS=1 cargo test --test docs`");
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
