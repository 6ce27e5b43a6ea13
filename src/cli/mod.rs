//! The `shadec` CLI: argument parsing in `args.rs`, one module per subcommand.
//!
//! Exit status everywhere: 0 success, 1 errors in the user's source, 2 usage
//! or I/O errors.

mod args;
mod bench;
mod check;
mod compile;
mod emulate;
mod fmt;
mod lsp;
mod render;
mod translate;

use std::process::ExitCode;

use clap::Parser as _;

pub use args::{Cli, Command};

/// Exit code of every command whose input has errors.
pub const EXIT_SOURCE_ERRORS: u8 = 1;
/// Exit code of every command misused, or failing to read or write a file.
pub const EXIT_USAGE_OR_IO: u8 = 2;

/// Parses the arguments and runs the subcommand.
/// A scene that did not load or build, reported: exit 2 when its file
/// cannot be read, else 1 (what it says is wrong with the scene).
fn scene_failed(e: shadec::scene::SceneError) -> ExitCode {
    eprintln!("error: {e}");
    let missing = matches!(e, shadec::scene::SceneError::Io(_));
    ExitCode::from(if missing { EXIT_USAGE_OR_IO } else { EXIT_SOURCE_ERRORS })
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    // Before any thread starts: a runtime directory for Mesa's drivers
    // where the environment has no valid one (their complaint is not ours).
    #[cfg(feature = "gpu")]
    if matches!(&cli.command, Command::Render(a) if a.backend == render::Backend::Wgpu)
        || matches!(&cli.command, Command::Bench(a) if a.backend == render::Backend::Wgpu)
    {
        shadec::gpu::runtime_dir::ensure();
    }
    match cli.command {
        Command::Bench(args) => bench::run(&args),
        Command::Check(args) => check::run(&args),
        Command::Compile(args) => compile::run(&args),
        Command::Fmt(args) => fmt::run(&args),
        Command::Emulate(args) => emulate::run(&args),
        Command::Render(args) => render::run(&args),
        Command::Translate(args) => translate::run(&args),
        Command::Lsp(args) => lsp::run(&args),
    }
}

/// Writes a command's result to `-o OUT` (atomically) or to standard output.
fn write_output(output: Option<&std::path::Path>, text: &str) -> ExitCode {
    match output {
        Some(path) => match shadec::io::write_atomic(path, text.as_bytes()) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(EXIT_USAGE_OR_IO)
            }
        },
        None => {
            print!("{text}");
            ExitCode::SUCCESS
        }
    }
}
