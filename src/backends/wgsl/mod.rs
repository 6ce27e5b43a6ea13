//! The WGSL backend: pass plans as WGSL through naga.
//!
//! - `codegen`: one `naga::Module` per pass of a plan (vertex entry point
//!   `vs_main`, fragment entry point `fs_main`), following
//!   `pipeline::PassInterface`, validated by naga; `--precision exact|f32|fixed9` (`fixed9`: the register combiners).
//! - `emit`: the modules written as WGSL (one document, a header comment per
//!   pass with its source line), SPIR-V and GLSL.
//! - `rc1`: legacy `!!RC1.0` combiner setups as WGSL, bit-exact with the
//!   fixed9 emulator (`shadec translate`); `ts1`: with a `!!TS1.0` texture
//!   shader in front, its stages too.
//! - `validate`: naga validation, one validator for every module above and
//!   for the runner.
//!
//! Running the modules on wgpu is the executor `crate::gpu`'s work.

pub mod codegen;
pub mod emit;
pub mod rc1;
pub mod ts1;
pub mod validate;

pub use codegen::{generate, PassShader, FRAGMENT_ENTRY, VERTEX_ENTRY};
