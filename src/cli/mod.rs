//! The `shadec` CLI: argument parsing in `args.rs`, one module per subcommand.

use std::process::ExitCode;

pub fn main() -> ExitCode {
    ExitCode::SUCCESS
}
