//! Snapshot tests (insta) of the diagnostics people and editors see: the
//! rustc-like rendering and the LSP JSON, for every input in
//! `tests/diagnostics/*.shd`. Review changes with `cargo insta review` or
//! `INSTA_UPDATE=always cargo test --test diagnostics` and `git diff`.

use shadec::diag::SourceFile;

fn inputs() -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/diagnostics"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "shd"))
        .collect();
    v.sort();
    v
}

#[test]
fn rendered_diagnostics() {
    let inputs = inputs();
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
