//! The integration tests, one binary (issue 17: 40 binaries each linked
//! wgpu, naga and the whole crate separately: minutes of linking and
//! gigabytes of disk on two cores). Each file in tests/ is a module;
//! `cargo test --test suite <module>::` runs one of them.

mod adaptive_common;
mod combiners_common;
mod common;
mod common_lsp;

mod adaptive_error;
mod adaptive_sphere;
mod bad_input;
mod bench;
mod cli_check;
mod cli_emulate;
mod cli_render;
mod cli_wgsl;
mod colour_typing;
mod combiners_appendix;
mod combiners_codegen;
mod combiners_coverage;
mod combiners_emulator;
mod combiners_rc1;
mod combiners_snapshots;
mod cost_model;
mod determinism;
mod diagnostics;
mod differential;
mod docs;
mod editor_nvim;
mod gpu_runner;
mod hard_cases;
mod ir_cli;
mod ir_lower;
mod ir_profiles;
mod ir_snapshots;
mod layering;
mod lowering;
mod lsp;
mod lsp_robust;
mod planner;
mod planner_split;
mod raster_fill;
mod raster_interp;
mod raster_robust;
mod raster_state;
mod render_batch;
mod render_combiners;
mod render_plan;
mod roundtrip;
mod specialize_lights;
mod texture_shaders;
mod wgsl_agreement;
mod wgsl_gpu;
mod wgsl_snapshots;
mod wgsl_texture_targets;
