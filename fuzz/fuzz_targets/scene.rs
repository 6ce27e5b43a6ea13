//! `cargo fuzz run scene`: the property of [`shadec_fuzz::scene`] on every
//! input (fuzz/README.md). `tests/fuzz_replay.rs` replays its corpus.

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shadec_fuzz::scene(data));
