//! Writing compiled passes: WGSL (naga's WGSL writer), SPIR-V and GLSL.
//!
//! - **WGSL**: one document for the whole plan. A header names the program,
//!   target and fidelity; each pass starts with a line
//!   `// ==== pass N of M: TARGET ← BLEND [TEXTURES]` followed by its source
//!   statement(s) as comments (naga's writer drops comments, so the trace of
//!   the source sits above each module), then the pass's complete WGSL module
//!   (`vs_main`, `fs_main`). Each section is a valid WGSL module on its own:
//!   split at the `// ==== pass` lines ([`split_wgsl`]).
//! - **SPIR-V**: one binary module per pass, holding both entry points.
//! - **GLSL** (desktop 330): per pass a vertex and a fragment shader, in one
//!   text document with `// ==== pass N …: vertex shader` /
//!   `…: fragment shader` separators.

use naga::back;

use super::codegen::{PassShader, FRAGMENT_ENTRY, VERTEX_ENTRY};
use crate::diag::Diagnostic;
use crate::span::Span;

/// The separator line that starts each pass's section.
pub const PASS_MARK: &str = "// ==== ";

fn writer_error(what: &str, pass: &PassShader, e: impl std::fmt::Display) -> Diagnostic {
    Diagnostic::error(
        "internal-error",
        format!("compiler bug: naga's {what} writer failed on {}: {e}", pass.label),
        Span::DETACHED,
        "here",
    )
    .with_help("this is a bug in shadec, not in your program: please report it with the program")
}

/// One pass as WGSL, without header.
pub fn pass_wgsl(pass: &PassShader) -> Result<String, Diagnostic> {
    back::wgsl::write_string(&pass.module, &pass.info, back::wgsl::WriterFlags::empty())
        .map_err(|e| writer_error("WGSL", pass, e))
}

fn pass_header(pass: &PassShader) -> String {
    let mut s = format!("{PASS_MARK}{}\n", pass.label);
    for line in &pass.source {
        s += &format!("// {line}\n");
    }
    s
}

/// The whole plan as one WGSL document (see the module doc). `title` is
/// the first comment line (`FILE on TARGET, fidelity F`).
pub fn wgsl(title: &str, passes: &[PassShader]) -> Result<String, Diagnostic> {
    let mut out =
        format!("// shadec: {title} — {} pass{}\n", passes.len(), if passes.len() == 1 { "" } else { "es" });
    out += "// Each section is one WGSL module (vs_main, fs_main); its bindings: docs/pass-plan.md, \"WGSL bindings\".\n";
    for p in passes {
        out += "\n";
        out += &pass_header(p);
        out += &pass_wgsl(p)?;
    }
    Ok(out)
}

/// The sections of a WGSL document written by [`wgsl`]: (label, module text).
pub fn split_wgsl(doc: &str) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = Vec::new();
    for line in doc.lines() {
        if let Some(label) = line.strip_prefix(PASS_MARK) {
            out.push((label.to_string(), String::new()));
        } else if let Some((_, text)) = out.last_mut() {
            text.push_str(line);
            text.push('\n');
        }
    }
    out
}

/// One pass as a SPIR-V module (both entry points).
pub fn spirv(pass: &PassShader) -> Result<Vec<u32>, Diagnostic> {
    back::spv::write_vec(&pass.module, &pass.info, &back::spv::Options::default(), None)
        .map_err(|e| writer_error("SPIR-V", pass, e))
}

/// SPIR-V words as little-endian bytes (the file format).
pub fn spirv_bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// One pass as GLSL 330: (vertex shader, fragment shader).
pub fn glsl_pass(pass: &PassShader) -> Result<(String, String), Diagnostic> {
    let options = back::glsl::Options { version: back::glsl::Version::Desktop(330), ..Default::default() };
    let one = |stage: naga::ShaderStage, entry: &str| -> Result<String, Diagnostic> {
        let pipeline = back::glsl::PipelineOptions {
            shader_stage: stage,
            entry_point: entry.to_string(),
            multiview: None,
        };
        let mut s = String::new();
        let mut w = back::glsl::Writer::new(
            &mut s,
            &pass.module,
            &pass.info,
            &options,
            &pipeline,
            naga::proc::BoundsCheckPolicies::default(),
        )
        .map_err(|e| writer_error("GLSL", pass, e))?;
        w.write().map_err(|e| writer_error("GLSL", pass, e))?;
        Ok(s)
    };
    Ok((one(naga::ShaderStage::Vertex, VERTEX_ENTRY)?, one(naga::ShaderStage::Fragment, FRAGMENT_ENTRY)?))
}

/// The whole plan as one GLSL document (see the module doc).
pub fn glsl(title: &str, passes: &[PassShader]) -> Result<String, Diagnostic> {
    let mut out = format!(
        "// shadec: {title} — {} pass{} (GLSL 330)\n",
        passes.len(),
        if passes.len() == 1 { "" } else { "es" }
    );
    for p in passes {
        let (vs, fs) = glsl_pass(p)?;
        for (stage, text) in [("vertex shader", vs), ("fragment shader", fs)] {
            out += &format!("\n{PASS_MARK}{}: {stage}\n", p.label);
            for line in &p.source {
                out += &format!("// {line}\n");
            }
            out += &text;
        }
    }
    Ok(out)
}
