//! The properties the fuzz targets check, one function per target, each
//! taking the fuzzer's bytes. They panic on a violation, as libFuzzer
//! expects; `cargo fuzz run TARGET` (fuzz_targets/) calls them, and
//! `tests/fuzz_replay.rs` runs every file of `fuzz/corpus/TARGET/` through
//! the same function in the ordinary test suite, so CI replays the corpora
//! without a fuzzer.
//!
//! What each one holds, on any input:
//! - `parser`: no panic; every diagnostic points inside the text; a clean
//!   program prints to text that parses to the same tree.
//! - `rc1`, `ts1`: no panic; an accepted `!!RC1.0` / `!!TS1.0` text prints
//!   and reads back to the same setup.
//! - `vp1`: no panic; an accepted `!!VP1.0` program prints and reads back
//!   to the same program, and the interpreter runs it on any attributes.
//! - `scene`: no panic; an accepted scene's RON prints and reads back.
//! - `pipeline`: a program that checks clean is planned for geforce256,
//!   geforce3 and wgsl; every accepted pass of a combiner target generates a
//!   setup that prints as `!!RC1.0` and reads back, validated, to the same
//!   setup, and a vertex program that validates where one is emitted;
//!   every plan's WGSL generates and validates (no internal error).
//! - `lsp`: the server's frame reader consumes any bytes; a document edited
//!   by the bytes is analysed after every edit, and hover and completion
//!   answer at any offset, without a panic.

use std::path::Path;

use shadec::backends::combiners::{rc1, ts1};
use shadec::driver::{self, PlanOptions};
use shadec::profile::{CombinerLimits, Profile};

/// The longest input a target reads: past it, the time goes to the size,
/// not to new paths.
pub const MAX_INPUT: usize = 16 << 10;

fn text(data: &[u8]) -> Option<&str> {
    if data.len() > MAX_INPUT {
        return None;
    }
    std::str::from_utf8(data).ok()
}

/// The `.shd` parser and checker.
pub fn parser(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let (program, diagnostics) = shadec::parser::check(text);
    for d in &diagnostics {
        assert!(d.primary.span.end as usize <= text.len(), "a diagnostic past the end: {d:?}");
    }
    if diagnostics.iter().any(|d| d.is_error()) {
        return;
    }
    let mut program = program;
    program.erase_spans();
    let printed = shadec::parser::print::program(&program, shadec::parser::print::Style::Unicode);
    let (mut again, d) = shadec::parser::parse(&printed);
    assert!(d.is_empty(), "printed text does not parse: {printed}");
    again.erase_spans();
    assert_eq!(again, program, "printed text parses to another tree: {printed}");
}

/// The `!!RC1.0` reader (NV_register_combiners, as nvparse reads it).
pub fn rc1(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let Ok(config) = rc1::parse_and_validate(text, &CombinerLimits::GEFORCE3) else { return };
    let printed = rc1::print(&config);
    let again = rc1::parse_and_validate(&printed, &CombinerLimits::GEFORCE3)
        .unwrap_or_else(|e| panic!("printed !!RC1.0 does not read back: {e:?}\n{printed}"));
    assert_eq!(again, config, "printed !!RC1.0 reads back to another setup:\n{printed}");
}

/// The `!!TS1.0` reader (NV_texture_shader, as nvparse reads it).
pub fn ts1(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let Ok(program) = ts1::parse_file(text) else { return };
    let printed = ts1::print(&program);
    let again = ts1::parse_file(&printed)
        .unwrap_or_else(|e| panic!("printed !!TS1.0 does not read back: {e:?}\n{printed}"));
    assert_eq!(again, program, "printed !!TS1.0 reads back to another program:\n{printed}");
}

/// The `!!VP1.0` reader (NV_vertex_program) and interpreter.
pub fn vp1(data: &[u8]) {
    use shadec::backends::vertex_program as vp;
    let Some(text) = text(data) else { return };
    let Ok(program) = vp::parse_file(text) else { return };
    let printed = vp::print(&program);
    let again = vp::parse_file(&printed)
        .unwrap_or_else(|e| panic!("printed !!VP1.0 does not read back: {e:?}\n{printed}"));
    assert_eq!(again, program, "printed !!VP1.0 reads back to another program:\n{printed}");
    let seeds = [0.0f32, 1.0, -1.5, 1.0e30, f32::NAN, f32::INFINITY, -0.0, 95.5];
    let attributes = std::array::from_fn(|k| [0, 1, 2, 3].map(|c| seeds[(k + c) % seeds.len()]));
    let parameters = std::array::from_fn(|k| [0, 1, 2, 3].map(|c| seeds[(k * 3 + c) % seeds.len()]));
    let _ = vp::emulate::run(&program, &attributes, &parameters);
}

/// The scene reader (RON, docs/scenes.md). Only what is written is read:
/// meshes and textures are built by `render`, not here.
pub fn scene(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let _ = shadec::scene::Scene::parse(text, Path::new("fuzz.ron"));
}

/// Source → plan on three targets → combiner setups and WGSL.
pub fn pipeline(data: &[u8]) {
    let Some(text) = text(data) else { return };
    if driver::front(text).has_errors() {
        return;
    }
    for target in ["geforce256", "geforce3", "wgsl"] {
        let Ok(profile) = Profile::builtin(target) else { panic!("no built-in profile {target}") };
        let Ok(compilation) = driver::compile(text, &profile, &PlanOptions::default()) else { continue };
        let planned = &compilation.planned;
        if let Some(limits) = planned.combiners {
            for (i, pass) in planned.plan.passes.iter().enumerate() {
                if pass.baked {
                    continue;
                }
                let generated = shadec::backends::combiners::setup::of(planned, i)
                    .unwrap_or_else(|e| panic!("{target}: accepted pass {i} does not generate: {e}\n{text}"));
                let printed = rc1::print(&generated.config);
                let again = rc1::parse_and_validate(&printed, &limits).unwrap_or_else(|e| {
                    panic!("{target}: pass {i}'s !!RC1.0 does not read back: {e:?}\n{printed}")
                });
                assert_eq!(
                    again, generated.config,
                    "{target}: pass {i}'s !!RC1.0 reads back to another setup"
                );
                if let Ok(e) = shadec::backends::vertex_program::emit::emit_pass(planned, i) {
                    let errors = shadec::backends::vertex_program::validate(&e.program);
                    assert!(
                        errors.is_empty(),
                        "{target}: pass {i}'s vertex program breaks the spec: {errors:?}"
                    );
                }
            }
        }
        wgsl(planned, text, target);
    }
}

#[cfg(feature = "wgsl")]
fn wgsl(planned: &shadec::pipeline::Planned, text: &str, target: &str) {
    use shadec::numerics::Precision;
    for precision in [Precision::F32, Precision::Fixed9] {
        if let Err(ds) = shadec::backends::wgsl::codegen::generate(planned, Some(text), precision) {
            let internal: Vec<_> = ds.iter().filter(|d| d.code == "internal-error").collect();
            assert!(
                internal.is_empty(),
                "{target} {precision}: WGSL does not validate: {internal:?}\n{text}"
            );
        }
    }
}

#[cfg(not(feature = "wgsl"))]
fn wgsl(_: &shadec::pipeline::Planned, _: &str, _: &str) {}

/// The language server: the frame reader over the raw bytes, then the
/// bytes read as a document and a sequence of edits and requests.
pub fn lsp(data: &[u8]) {
    use shadec::lsp::transport::Reader;
    if data.len() > MAX_INPUT {
        return;
    }
    let mut reader = Reader::new(vec![data.to_vec()].into_iter());
    let mut n = 0;
    while reader.next_message().is_some() {
        n += 1;
        assert!(n <= data.len() + 1, "the frame reader makes messages from nothing");
    }
    edits(data);
}

/// The first half of the bytes is the document; the rest, three bytes an
/// operation: an edit (insert or delete at an offset) or a hover or
/// completion there.
fn edits(data: &[u8]) {
    use shadec::lsp::{analysis, completion, documents::Document, hover};
    let (doc, ops) = data.split_at(data.len() / 2);
    let mut text = String::from_utf8_lossy(doc).into_owned();
    for (version, op) in ops.chunks_exact(3).take(16).enumerate() {
        let at = floor_char_boundary(&text, usize::from(op[1]) * text.len().max(1) / 255);
        match op[0] % 4 {
            0 => text.insert_str(at, ["δ", "←", ";", "(", " x", "T δu x", "\n"][usize::from(op[2]) % 7]),
            1 => {
                let end = floor_char_boundary(&text, at + usize::from(op[2] % 16));
                text.replace_range(at..end, "");
            }
            kind => {
                let analysis = analysis::analyze("fuzz.shd", &text, None);
                let document = Document { version: version as i32, analysis };
                if kind == 2 {
                    let _ = hover::hover(&document, at);
                } else {
                    let _ = completion::complete(&document, at);
                }
            }
        }
    }
}

fn floor_char_boundary(text: &str, mut at: usize) -> usize {
    at = at.min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    at
}
