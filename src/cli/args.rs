//! Every command-line argument of `shadec` (clap derive; doc comments are the help text).

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};
use shadec::numerics::Precision;

/// shadec — compile shading pipelines written in the notation of "A graphics
/// pipeline grammar" to register combiners and WGSL.
#[derive(Debug, Parser)]
#[command(name = "shadec", version, about, max_term_width = 100)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

// Parsed once per run: boxing the large argument structs would buy nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Parse and check programs; report every error with file:line:col.
    ///
    /// Exit status: 0 when every file is clean (warnings allowed), 1 when a
    /// file has errors, 2 on usage or I/O errors.
    Check(CheckArgs),
    /// Lower a program and print its IR (`--emit ir`), its pass plan for a
    /// target (`--emit plan --format ron|json`), or shaders for its passes
    /// (`--emit wgsl|spirv|glsl`, through naga).
    ///
    /// Exit status: 0 on success, 1 when the program has errors, 2 on usage
    /// or I/O errors.
    Compile(CompileArgs),
    /// Print a program in canonical form (Unicode, or ASCII with --ascii).
    Fmt(FmtArgs),
    /// Run a register-combiner setup (`!!RC1.0` or RON) on images, as the
    /// hardware would (Kilgard 2000, Section 4.2, Appendix B).
    Emulate(super::emulate::EmulateArgs),
    /// Render a scene with a program's pass plan on the CPU, in `fixed9`
    /// (what the old hardware showed), `f32` or `exact`; print the pass plan,
    /// the time per frame and the error against the exact reference. With no
    /// arguments: Kilgard's bump-mapped torus on geforce256 → shadec-out.png.
    ///
    /// Exit status: 0 on success, 1 when the program or scene has errors
    /// (shader errors with file:line:col), 2 on usage or I/O errors.
    Render(super::render::RenderArgs),
    /// Measure speed against error: every technique variant of the papers
    /// on its scene (time per frame, error against the exact reference), the
    /// adaptive-shading table of Adaptive Sample Shading and what specialization removes;
    /// writes report.md, speed_vs_error.png, adaptive.png and diff/*.png.
    /// With --program: that program's Pareto front per target (front.md,
    /// front.png).
    ///
    /// Exit status: 0 on success, 1 when a variant fails (with --program:
    /// the program has errors, or no target plans it), 2 on usage or I/O
    /// errors.
    Bench(super::bench::BenchArgs),
    /// Translate a legacy register-combiner setup (`!!RC1.0` or RON) to a
    /// WGSL shader that computes what the hardware does (fixed9, bit-exact
    /// with `shadec emulate`).
    ///
    /// Exit status: 0 on success, 1 when the setup has errors, 2 on usage
    /// or I/O errors.
    Translate(super::translate::TranslateArgs),
    /// Run the language server on standard input and output (LSP over
    /// JSON-RPC): diagnostics as you type, hover with each value's
    /// frequency, range, pass and texture unit on the target, navigation,
    /// rename, formatting, semantic tokens, inlay hints, completion and
    /// code actions. docs/editors.md shows how to use it from Neovim, VS
    /// Code and Helix.
    Lsp(super::lsp::LspArgs),
}

#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// Files or folders (searched recursively for `*.shd`).
    #[arg(required = true, value_name = "FILE|DIR")]
    pub paths: Vec<PathBuf>,
    /// How to print diagnostics.
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
    /// Treat warnings as errors.
    #[arg(long)]
    pub deny_warnings: bool,
    /// Also check each statement against a target profile: a built-in name
    /// (geforce256, geforce3, multitexture, wgsl) or a `.ron` file. Without
    /// it, a program's own `target X;` line is used.
    #[arg(long, value_name = "PROFILE")]
    pub target: Option<String>,
}

#[derive(Debug, clap::Args)]
pub struct CompileArgs {
    /// The program to compile.
    pub file: PathBuf,
    /// What to print.
    #[arg(long, value_enum, default_value_t = Emit::Ir)]
    pub emit: Emit,
    /// Target profile (built-in name or `.ron` file); defaults to the
    /// program's `target X;` line.
    #[arg(long, value_name = "PROFILE")]
    pub target: Option<String>,
    /// Write here (atomically) instead of standard output.
    #[arg(short, long, value_name = "OUT")]
    pub output: Option<PathBuf>,
    /// With `--emit wgsl|spirv|glsl`: the shader's arithmetic — `f32` (true
    /// normalize and pow; `exact` is the same on a GPU, which has no f64) or
    /// `fixed9` (alias `hardware`: the register combiners, each pass's
    /// generated setup as integer code). `--fidelity` is an older name.
    #[arg(long, visible_alias = "fidelity", value_enum, default_value_t = Precision::F32)]
    pub precision: Precision,
    /// With `--emit plan` or shaders: specialize for this scene (RON) — uniforms the
    /// scene sets are folded, terms they zero are removed with their
    /// textures and passes; what went is printed on standard error.
    #[arg(long, value_name = "SCENE.ron")]
    pub scene: Option<PathBuf>,
    /// With `--emit plan`: the document's format (`ron`, the default, or
    /// `json`). Diagnostics print as `human`, `short` or `json` (LSP).
    #[arg(long, value_enum, default_value_t = CompileFormat::Human)]
    pub format: CompileFormat,
    /// Refuse what the target cannot compute instead of lowering it into
    /// tables and approximations (docs/lowering.md).
    #[arg(long)]
    pub no_approx: bool,
    /// Accept only approximations whose stated error bound is at most E
    /// (an approximation with no bound of its own, such as a per-vertex
    /// one, is then refused); of the lowerings within E, the one the
    /// target's cost model predicts fastest (docs/cost-model.md).
    #[arg(long, value_name = "E")]
    pub max_error: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Emit {
    /// The typed IR: every value with its type, frequency, range and position.
    Ir,
    /// The pass plan for the target (docs/pass-plan.md): RON or JSON.
    Plan,
    /// WGSL, one module per pass in one document, each section headed by
    /// `// ==== pass N of M: …` and its source line (target defaults to `wgsl`).
    Wgsl,
    /// SPIR-V binary, one module per pass; needs `-o OUT`: one pass writes
    /// OUT, several write OUT's stem + `.passN` + extension (`a.pass1.spv`, …).
    Spirv,
    /// GLSL 330, a vertex and a fragment shader per pass, in one document.
    Glsl,
    /// Each pass's register-combiner setup as nvparse text (a combiner
    /// target): `!!RC1.0`, after a `!!TS1.0` texture shader where the pass
    /// has dependent lookups; `shadec emulate` and `translate` read it back.
    Combiners,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CompileFormat {
    /// Human-readable diagnostics; a plan prints as RON.
    Human,
    /// One-line diagnostics; a plan prints as RON.
    Short,
    /// LSP JSON diagnostics; a plan prints as JSON.
    Json,
    /// A plan as RON; human-readable diagnostics.
    Ron,
}

#[derive(Debug, clap::Args)]
pub struct FmtArgs {
    /// The program to print.
    pub file: PathBuf,
    /// Spell every symbol in ASCII (`delta`, `pi`, `<-`, `(+)`, `(.)`).
    #[arg(long)]
    pub ascii: bool,
    /// Write here (atomically) instead of standard output.
    #[arg(short, long, value_name = "OUT")]
    pub output: Option<PathBuf>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// rustc-like: the source line, the span underlined, a help line.
    Human,
    /// One line per diagnostic: `file:line:col: error[code]: message`.
    Short,
    /// One JSON document with LSP `Diagnostic` objects per file.
    Json,
}
