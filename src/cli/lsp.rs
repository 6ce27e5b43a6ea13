//! `shadec lsp`: the language server (`shadec::lsp`) on stdin/stdout.

use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct LspArgs {
    /// Accepted and ignored: editors (VS Code's client among them) pass it
    /// to say the protocol runs on standard input and output, the only
    /// transport there is.
    #[arg(long)]
    pub stdio: bool,
}

/// `shadec lsp`: the language server until the client exits.
pub fn run(_args: &LspArgs) -> ExitCode {
    match shadec::lsp::run() {
        Ok(true) => ExitCode::SUCCESS,
        // LSP 3.17, `exit`: status 1 when no `shutdown` came first; the
        // client gone (standard output closed) is no orderly end either.
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: shadec lsp: cannot write to the client: {e}");
            ExitCode::from(1)
        }
    }
}
