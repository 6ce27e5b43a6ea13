//! Snapshot tests (insta) of the diagnostics people and editors see: the
//! rustc-like rendering and the LSP JSON, for every input in
//! `tests/diagnostics/*.shd`. Review changes with `cargo insta review` or
//! `INSTA_UPDATE=always cargo test --test diagnostics` and `git diff`.

mod common;

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
        let lsp = serde_json::to_string_pretty(&file.to_lsp(&format!("file:///{name}.shd"), &diagnostics)).unwrap();
        insta::assert_snapshot!(format!("{name}.human"), human);
        insta::assert_snapshot!(format!("{name}.lsp"), lsp);
    }
}
