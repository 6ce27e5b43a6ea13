//! `cargo fuzz run rc1`: the property of [`shadec_fuzz::rc1`] on every
//! input (fuzz/README.md). `tests/fuzz_replay.rs` replays its corpus.

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shadec_fuzz::rc1(data));
