//! `--emit ir` dumps of a few examples, reviewed and committed
//! (`INSTA_UPDATE=always cargo test --test ir_snapshots` re-blesses them).

fn dump(name: &str) -> String {
    let path = format!("{}/examples/{name}.shd", env!("CARGO_MANIFEST_DIR"));
    let src = std::fs::read_to_string(path).unwrap();
    let (program, d) = shadec::parser::check(&src);
    assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
    let (module, d) = shadec::ir::lower(&program);
    assert!(d.iter().all(|d| !d.is_error()), "{d:#?}");
    shadec::ir::dump::dump(&module, Some(&src))
}

macro_rules! snapshot {
    ($($test:ident => $name:literal),* $(,)?) => {$(
        #[test]
        fn $test() {
            insta::assert_snapshot!($name, dump($name));
        }
    )*};
}

snapshot! {
    gouraud => "gouraud",
    fragment_lighting => "fragment_lighting",
    kilgard_bump_mapping => "kilgard_bump_mapping",
    chained_multitexture => "chained_multitexture",
    embm => "embm",
    texture_shading => "texture_shading",
    shadow_mask => "shadow_mask",
}
