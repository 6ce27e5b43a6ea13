//! Every command-line argument of `shadec` (clap derive; doc comments are the help text).

use std::path::PathBuf;

use clap::{Parser, Subcommand, ValueEnum};
use shadec::numerics::Precision;

/// shadec — compile shading pipelines written in the notation of "A graphics
/// pipeline grammar" to register combiners and WGSL.
///
/// Every command that writes a file takes -o/--output; `shadec COMMAND
/// --help` describes each command and its flags.
///
/// Exit status, for every command: 0 on success, 1 when the input (a
/// program, a scene, a combiner setup) has errors, 2 on usage or I/O errors.
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
    /// target (`--emit plan`, as RON or JSON: --plan-format), or shaders for
    /// its passes (`--emit wgsl|spirv|glsl`, through naga) or combiner setups
    /// (`--emit combiners`).
    ///
    /// Exit status: 0 on success, 1 when the program has errors, 2 on usage
    /// or I/O errors.
    Compile(CompileArgs),
    /// Print a program in canonical form (Unicode, or ASCII with --ascii);
    /// with --check, only say whether files are; with -w, rewrite them in
    /// place.
    ///
    /// Exit status: 0 on success (with --check: every file is in canonical
    /// form), 1 when a file has syntax errors (with --check: or is not in
    /// canonical form; each such file is named), 2 on usage or I/O errors.
    Fmt(FmtArgs),
    /// Run a register-combiner setup (`!!RC1.0` or RON) on images, as the
    /// hardware would (Kilgard 2000, Section 4.2, Appendix B), and write the
    /// final combiner's RGBA as a PNG.
    ///
    /// Exit status: 0 on success, 1 when the setup is malformed or does not
    /// fit the profile, 2 on usage or I/O errors (a missing or unreadable
    /// image, images of different sizes, an unwritable output).
    Emulate(super::emulate::EmulateArgs),
    /// Render a scene with a program's pass plan on the CPU (or, with
    /// --backend wgpu, on a GPU), in `fixed9` (what the old hardware
    /// showed), `f32` or `exact`; print the pass plan,
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
    ///
    /// Exit status: 0 after the client's `shutdown` and `exit`, 1 when
    /// `exit` came without `shutdown` (as LSP 3.17 says), 2 when standard
    /// input or output fails.
    Lsp(super::lsp::LspArgs),
}

#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// Files or folders (searched recursively for `*.shd`).
    #[arg(required = true, value_name = "FILE|DIR")]
    pub paths: Vec<PathBuf>,
    /// How to print diagnostics: rustc-style (`human`), one line each
    /// (`short`), or one JSON document of LSP diagnostics (`json`).
    #[arg(long, visible_alias = "diagnostics-format", value_enum, default_value_t = Format::Human)]
    pub format: Format,
    /// Write the report (the per-file lines and the summary, or the JSON
    /// document) here, atomically, instead of to standard output;
    /// diagnostics still go to standard error.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Treat warnings as errors.
    #[arg(long)]
    pub deny_warnings: bool,
    /// Also plan each program for a target profile, as `compile` and
    /// `render` do, and report what they would refuse and every
    /// approximation the plan takes: a built-in name (geforce256, geforce3,
    /// multitexture, wgsl) or a `.ron` file. Without it, a program's own
    /// `target X;` line is used (docs/language.md, "Which target").
    #[arg(long, value_name = "PROFILE")]
    pub target: Option<String>,
    /// Judge each program on this scene, as `render` and `compile --scene`
    /// do: one pass per scene light, the scene's uniforms folded, every
    /// approximation measured there (without it, on the built-in torus);
    /// image files looked for beside the program, then beside the scene.
    #[arg(long, value_name = "SCENE.ron")]
    pub scene: Option<PathBuf>,
    #[command(flatten)]
    pub quality: Quality,
}

/// What the plan may give up, and what stands in for missing inputs: the
/// same flags, and the same verdict, for `check`, `compile` and `render`.
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct Quality {
    /// Refuse what the target cannot compute instead of lowering it into
    /// tables and approximations (docs/lowering.md).
    #[arg(long)]
    pub no_approx: bool,
    /// Accept only approximations whose error is at most E (a fraction of
    /// full intensity, 0.0039 = 1/255): a rule's stated bound, or for a
    /// per-vertex fall-back its error measured on the scene (without one,
    /// on the built-in torus), which otherwise has a budget of 48/255. Of
    /// the lowerings within E, the one the cost model predicts fastest.
    #[arg(long, value_name = "E")]
    pub max_error: Option<f64>,
    /// Bind a procedural stand-in (a brick checkerboard; golf-ball dimples
    /// for a height field) for an image file that is missing, instead of
    /// refusing the program.
    #[arg(long)]
    pub stand_ins: bool,
}

impl Quality {
    /// The lowering these flags ask for.
    pub fn lowering(&self) -> shadec::lowering::LowerOptions {
        shadec::lowering::LowerOptions { approximate: !self.no_approx, max_error: self.max_error, only: None }
    }
}

#[derive(Debug, clap::Args)]
pub struct CompileArgs {
    /// The program to compile.
    pub file: PathBuf,
    /// What to write.
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
    /// How to print diagnostics (on standard error): rustc-style (`human`,
    /// the default), one line each (`short`), or LSP JSON (`json`).
    #[arg(long, value_enum, value_name = "FORMAT")]
    pub diagnostics_format: Option<Format>,
    /// With `--emit plan`: the plan's format, `ron` (the default) or `json`
    /// (schema in docs/pass-plan.md).
    #[arg(long, value_enum, value_name = "FORMAT")]
    pub plan_format: Option<PlanFormat>,
    /// The older flag that set both at once: `human`, `short` and `ron`
    /// print diagnostics that way and a plan as RON; `json` prints both as
    /// JSON. --diagnostics-format and --plan-format win over it.
    #[arg(long, value_enum, hide = true)]
    pub format: Option<CompileFormat>,
    #[command(flatten)]
    pub quality: Quality,
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

/// The format of a pass plan.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PlanFormat {
    /// RON, the plan's native format.
    Ron,
    /// JSON, with the same fields.
    Json,
}

/// `compile --format`, kept for older scripts: one value for two formats.
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
    /// The programs: one to print, or several with --check or -w.
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
    /// Spell every symbol in ASCII (`delta`, `pi`, `<-`, `(+)`, `(.)`).
    #[arg(long)]
    pub ascii: bool,
    /// Write the canonical form here (atomically) instead of standard output.
    #[arg(short, long, value_name = "OUT", conflicts_with_all = ["check", "write"])]
    pub output: Option<PathBuf>,
    /// Write nothing; exit with 1, naming each file that is not in canonical
    /// form and its first line that differs.
    #[arg(long, conflicts_with = "write")]
    pub check: bool,
    /// Rewrite each file in place (atomically) in canonical form; a file
    /// already in canonical form is left untouched.
    #[arg(short, long)]
    pub write: bool,
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

#[cfg(test)]
mod tests {
    use clap::CommandFactory as _;

    use super::Cli;

    /// The help is plain text and complete: every subcommand says what its
    /// exit status means, every flag and argument has a line of help, and
    /// none shows rustdoc's link syntax.
    #[test]
    fn every_command_and_flag_has_plain_help() {
        let cli = Cli::command();
        cli.clone().debug_assert();
        let mut missing = Vec::new();
        for sub in cli.get_subcommands() {
            let name = sub.get_name();
            let about = sub.get_long_about().map(|s| s.to_string()).unwrap_or_default();
            if !about.contains("Exit status:") {
                missing.push(format!("{name}: no exit-status paragraph"));
            }
            for arg in sub.get_arguments() {
                let id = arg.get_id().as_str();
                if id == "help" {
                    continue;
                }
                let help = arg.get_help().map(|s| s.to_string()).unwrap_or_default();
                if help.trim().is_empty() && !arg.is_hide_set() {
                    missing.push(format!("{name} {id}: no help"));
                }
                let values: Vec<String> = arg
                    .get_possible_values()
                    .iter()
                    .filter_map(|v| v.get_help().map(|h| h.to_string()))
                    .collect();
                for text in std::iter::once(&help).chain(&values) {
                    if text.contains("[`") {
                        missing.push(format!("{name} {id}: rustdoc link syntax in `{text}`"));
                    }
                }
            }
            if about.contains("[`") {
                missing.push(format!("{name}: rustdoc link syntax in its description"));
            }
        }
        assert!(missing.is_empty(), "{}", missing.join("\n"));
    }

    /// The one output convention: every command that writes a file takes
    /// `-o/--output` (the language server writes only to standard output).
    #[test]
    fn every_command_that_writes_takes_dash_o() {
        let cli = Cli::command();
        for sub in cli.get_subcommands().filter(|s| s.get_name() != "lsp") {
            let output = sub.get_arguments().find(|a| a.get_id() == "output");
            let output = output.unwrap_or_else(|| panic!("{} has no --output", sub.get_name()));
            assert_eq!(output.get_short(), Some('o'), "{}", sub.get_name());
            assert_eq!(output.get_long(), Some("output"), "{}", sub.get_name());
        }
    }
}
