//! The `shadec` CLI: argument parsing in `args.rs`, one module per subcommand.
//!
//! NOTE (combiners branch): a minimal clap wiring so that `shadec emulate`
//! can be tested end to end; the main CLI replaces it at merge.

pub mod emulate;

use std::process::ExitCode;

use clap::Parser as _;

#[derive(clap::Parser)]
#[command(name = "shadec", version, about = "A compiler for the shading-pipeline grammar")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand)]
enum Command {
    /// Run a register-combiner setup (!!RC1.0 or RON) on images.
    Emulate(emulate::EmulateArgs),
}

pub fn main() -> ExitCode {
    let cli = Cli::parse();
    match &cli.command {
        Command::Emulate(args) => emulate::run(args),
    }
}
