//! `cargo fuzz run vp1`: the property of [`shadec_fuzz::vp1`] on every
//! input (fuzz/README.md). `tests/fuzz_replay.rs` replays its corpus.

#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| shadec_fuzz::vp1(data));
