//! naga validation, in one place: the flags and capabilities every WGSL
//! module of the compiler is checked under, so that the code generator,
//! the `!!RC1.0`/`!!TS1.0` translations and the wgpu runner cannot drift
//! apart in what they accept.
//!
//! The capabilities are naga's defaults: what WebGPU guarantees, so a
//! module that validates here runs on any wgpu adapter.

use naga::valid::{Capabilities, ModuleInfo, ValidationError, ValidationFlags, Validator};
use naga::WithSpan;

/// The validator every generated or translated module goes through: all
/// checks, WebGPU's baseline capabilities.
pub fn validator() -> Validator {
    Validator::new(ValidationFlags::all(), Capabilities::default())
}

/// Validates `module` under [`validator`].
pub fn validate(module: &naga::Module) -> Result<ModuleInfo, WithSpan<ValidationError>> {
    validator().validate(module)
}

/// Parses WGSL `text` and validates it; the error is naga's message,
/// rendered against the text, prefixed with the step that refused it.
pub fn parse_and_validate(text: &str) -> Result<(naga::Module, ModuleInfo), String> {
    let module = naga::front::wgsl::parse_str(text)
        .map_err(|e| format!("does not parse:\n{}", e.emit_to_string(text)))?;
    let info = validate(&module).map_err(|e| format!("does not validate:\n{}", e.emit_to_string(text)))?;
    Ok((module, info))
}
