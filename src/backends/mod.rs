//! Code generators and the machines they target.
//!
//! - `combiners`: NV_register_combiners (Kilgard 2000, Section 4.2, Appendix B).
//! - `wgsl`: WGSL through naga, and a headless wgpu runner (feature `gpu`).

pub mod combiners;
pub mod readers;
pub mod vertex_program;
#[cfg(feature = "wgsl")]
pub mod wgsl;
