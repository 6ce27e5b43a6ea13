//! The WGSL backend (issue 5): pass plans as WGSL through naga, and a
//! headless wgpu runner that renders them offscreen.
//!
//! - `runner` (feature `gpu`): render a list of passes — WGSL or a
//!   `naga::Module`, vertices, textures, uniforms and the GL-style
//!   fixed-function state of `renderer::RenderState` — into one RGBA8 target
//!   and read it back. Works on Mesa's lavapipe where there is no GPU.
//!
//! The IR → `naga::Module` code generator is not written yet.

#[cfg(feature = "gpu")]
pub mod runner;
