//! The docs cannot drift from the compiler: `docs/language.md` embeds
//! `grammar/shade.pest` verbatim, and every ```shd example of `docs/*.md`
//! and `README.md` checks without errors or warnings and lowers to the IR
//! without errors (issue 16, item 7).

const DOC: &str = include_str!("../docs/language.md");
const GRAMMAR: &str = include_str!("../grammar/shade.pest");

/// `UPDATE_DOCS=1 cargo test --test suite docs::` rewrites the grammar section.
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
    panic!("docs/language.md does not embed grammar/shade.pest as it is now; run `UPDATE_DOCS=1 cargo test --test suite docs::`");
}

/// Every ```` ```shd ```` block of `docs/*.md` and `README.md`: the file,
/// the 1-based line of its first source line, and its text preceded by as
/// many empty lines as precede it in the file.
fn shd_blocks() -> Vec<(String, usize, String)> {
    let root = env!("CARGO_MANIFEST_DIR");
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(format!("{root}/docs"))
        .expect("docs/ exists")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    files.sort();
    files.push(format!("{root}/README.md").into());
    let mut blocks = Vec::new();
    for path in files {
        let text = std::fs::read_to_string(&path).unwrap();
        let name = path.strip_prefix(root).unwrap().display().to_string();
        let mut open: Option<(usize, String)> = None;
        for (i, line) in text.lines().enumerate() {
            match &mut open {
                // Blank lines first, so a diagnostic's line is the file's.
                None if line.trim_end() == "```shd" => open = Some((i + 2, "\n".repeat(i + 1))),
                None => {}
                Some(_) if line.starts_with("```") => {
                    let (at, body) = open.take().unwrap();
                    blocks.push((name.clone(), at, body));
                }
                Some((_, body)) => {
                    body.push_str(line);
                    body.push('\n');
                }
            }
        }
        assert!(open.is_none(), "{name}: a ```shd block is not closed");
    }
    blocks
}

#[test]
fn every_example_in_the_docs_checks_and_lowers() {
    let blocks = shd_blocks();
    let in_reference = blocks.iter().filter(|(f, ..)| f == "docs/language.md").count();
    assert!(in_reference >= 11, "one example per construct in docs/language.md, found {in_reference}");
    let mut failures = Vec::new();
    for (file, line, block) in &blocks {
        let (program, mut diagnostics) = shadec::parser::check(block);
        // The front end's warnings too (unused names): an example shows clean code.
        let front_clean = diagnostics.is_empty();
        if front_clean {
            diagnostics.extend(shadec::ir::lower(&program).1.into_iter().filter(|d| d.is_error()));
        }
        if !diagnostics.is_empty() {
            let source =
                shadec::diag::SourceFile::new(format!("{file} (the block at line {line})"), block.as_str());
            failures.push(source.render(&diagnostics, false));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} ```shd blocks do not check:\n{}",
        failures.len(),
        blocks.len(),
        failures.join("\n")
    );
}
