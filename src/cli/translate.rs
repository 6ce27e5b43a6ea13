//! `shadec translate CONFIG --emit wgsl [-o OUT]`: a legacy register-combiner
//! setup (`!!RC1.0`, or RON) as a WGSL shader evaluating it exactly as the
//! fixed9 emulator does (`backends::wgsl::rc1`).

use std::path::PathBuf;
use std::process::ExitCode;

use super::emulate::{load_config, profile_limits, texture_shader, Failure};

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum TranslateEmit {
    /// One WGSL module: `vs_main` (pass-through) and `fs_main` (the combiners).
    Wgsl,
}

#[derive(Clone, Debug, clap::Args)]
pub struct TranslateArgs {
    /// The combiner setup: `!!RC1.0` text, or a `.ron` CombinerConfig.
    pub config: PathBuf,
    /// What to write.
    #[arg(long, value_enum, default_value = "wgsl")]
    pub emit: TranslateEmit,
    /// The profile whose combiner limits the setup must fit (built-in name
    /// or `.ron` file).
    #[arg(long, value_name = "PROFILE", default_value = "geforce3")]
    pub profile: String,
    /// A `!!TS1.0` texture-shader program in front of the combiners (instead
    /// of one at the top of CONFIG).
    #[arg(long, value_name = "TS_FILE")]
    pub texture_shader: Option<PathBuf>,
    /// Accept what NV2A (the Xbox GPU) runs beyond NV_register_combiners:
    /// dot products in the alpha portion, computed as the product of the two
    /// alpha inputs (docs/combiners.md). Off by default.
    #[arg(long)]
    pub permissive: bool,
    /// Write here (atomically) instead of standard output.
    #[arg(short, long, value_name = "OUT")]
    pub output: Option<PathBuf>,
}

/// `shadec translate`: a combiner setup as a WGSL module.
pub fn run(args: &TranslateArgs) -> ExitCode {
    #[cfg(feature = "wgsl")]
    if let Some(code) = vertex_program(args) {
        return code;
    }
    let loaded = profile_limits(&args.profile).and_then(|limits| {
        let limits = if args.permissive { limits.permissive() } else { limits };
        load_config(&args.config, &limits)
    });
    let loaded = loaded.and_then(|mut c| {
        texture_shader(args.texture_shader.as_deref(), &mut c, &args.config)?;
        Ok(c)
    });
    let config = match loaded {
        Ok(c) => c,
        Err(Failure::Config(message)) => {
            eprint!("{message}");
            if !message.ends_with('\n') {
                eprintln!();
            }
            return ExitCode::from(super::EXIT_SOURCE_ERRORS);
        }
        Err(Failure::Io(message)) => {
            eprintln!("error: {message}");
            return ExitCode::from(super::EXIT_USAGE_OR_IO);
        }
    };
    #[cfg(not(feature = "wgsl"))]
    {
        let _ = config;
        eprintln!("error: this shadec was built without the `wgsl` feature: rebuild with default features to translate");
        ExitCode::from(super::EXIT_USAGE_OR_IO)
    }
    #[cfg(feature = "wgsl")]
    translate(args, &config)
}

#[cfg(feature = "wgsl")]
fn translate(args: &TranslateArgs, config: &shadec::backends::combiners::config::CombinerConfig) -> ExitCode {
    let title = args.config.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    match args.emit {
        TranslateEmit::Wgsl => match shadec::backends::wgsl::rc1::translate(config, &title) {
            Ok(text) => super::write_output(args.output.as_deref(), &text),
            Err(e) => {
                eprintln!("error[internal-error]: {e}\n  = help: this is a bug in shadec, not in the setup: please report it with the setup");
                ExitCode::from(super::EXIT_SOURCE_ERRORS)
            }
        },
    }
}

/// A `!!VP1.0` / `!!VP1.1` file (NV_vertex_program) as a WGSL vertex stage
/// (a `!!VSP1.0` vertex state program: as a compute shader);
/// `None` when the file is not a vertex program.
#[cfg(feature = "wgsl")]
fn vertex_program(args: &TranslateArgs) -> Option<ExitCode> {
    use shadec::backends::vertex_program as vp;
    let text = shadec::io::read_text(&args.config).ok()?;
    // Every NV_vertex_program header, and ARB's, which the reader names.
    // (also behind a comment, which the reader then points at).
    let headers = ["!!VP1.", "!!VSP1.", "!!ARBvp"];
    let head = text.trim_start();
    let behind_comment = !text.contains("!!RC1.0") && headers.iter().any(|h| text.contains(h));
    if !headers.iter().any(|h| head.starts_with(h)) && !behind_comment {
        return None;
    }
    let name = args.config.display().to_string();
    Some(match vp::parse_file(&text) {
        Ok(program) => super::write_output(args.output.as_deref(), &vp::wgsl::translate(&program, &name)),
        Err(diagnostics) => {
            let file = shadec::diag::SourceFile::new(name, text.clone());
            eprint!("{}", file.render(&diagnostics, false));
            ExitCode::from(super::EXIT_SOURCE_ERRORS)
        }
    })
}
