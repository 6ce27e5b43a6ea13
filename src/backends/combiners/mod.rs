//! The register-combiner machine of Kilgard 2000 ("A Practical and
//! Robust Bump-mapping Technique for Today's GPUs"), Section 4.2 and
//! Appendix B: the NV_register_combiners state as data ([`CombinerConfig`],
//! Tables 2-6), its validity rules ([`validate()`]), NVIDIA's `!!RC1.0` text
//! format ([`rc1`]), the `!!TS1.0` texture shaders in front of them
//! ([`ts1`]), and a CPU emulator with a bit-faithful 8-bit + sign
//! precision model and an f32 one ([`emulator`]), and the code generator
//! from the IR ([`codegen`]). docs/combiners.md records
//! every emulation decision.

pub mod codegen;
pub mod config;
pub mod emulator;
pub mod rc1;
pub mod setup;
pub mod ts1;
pub mod validate;

pub use codegen::{generate, CodegenError, CombinerRealizer, Generated, PassInput};
pub use config::{
    Bias, Color, CombinerConfig, CombinerLimits, ComponentUsage, FinalCombiner, FinalInput, FinalSource,
    GeneralInput, GeneralPortion, GeneralStage, InputMapping, PortionKind, Register, Scale,
};
pub use emulator::{emulate, Inputs, PixelEmulator, PixelRegisters, Precision};
pub use validate::{validate, Place, ValidationError};
