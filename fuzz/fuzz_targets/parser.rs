//! The parser and checker must not panic on any input, and every diagnostic
//! must point inside the text. Run with `cargo fuzz run parser` (nightly).
//! The same property runs in `cargo test` as a proptest over mutated
//! examples (`tests/bad_input.rs`).

#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let (program, diagnostics) = shadec::parser::check(text);
    for d in &diagnostics {
        assert!(d.primary.span.end as usize <= text.len());
    }
    if diagnostics.iter().all(|d| !d.is_error()) {
        // Whatever parses cleanly prints to text that parses to the same tree.
        let mut program = program;
        program.erase_spans();
        let printed = shadec::parser::print::program(&program, shadec::parser::print::Style::Unicode);
        let (mut again, d) = shadec::parser::parse(&printed);
        assert!(d.is_empty(), "printed text does not parse: {printed}");
        again.erase_spans();
        assert_eq!(again, program);
    }
});
