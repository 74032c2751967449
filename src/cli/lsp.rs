//! `revelio lsp`: the language server, on standard input/output (see `src/lsp/`). Editors start
//! it; setup notes for VS Code, Neovim, Helix and Zed are in `editors/README.md`.

use std::process::ExitCode;

#[derive(clap::Args, Debug)]
pub struct LspArgs {
    /// Milliseconds of quiet after the last edit before lattice lints run (they also run on
    /// save)
    #[arg(long, default_value_t = crate::lsp::DEFAULT_LINT_DELAY_MS)]
    pub lint_delay_ms: u64,
    /// Accepted for editors that pass it; standard input/output is the only transport
    #[arg(long, hide = true)]
    pub stdio: bool,
}

pub fn run(args: LspArgs) -> ExitCode {
    let options = crate::lsp::Options {
        lint_delay: std::time::Duration::from_millis(args.lint_delay_ms),
        ..crate::lsp::Options::default()
    };
    match crate::lsp::run_stdio(options) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
