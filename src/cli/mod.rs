//! The `revelio` command line. Each subcommand lives in its own file with its clap `Args` and a
//! `run` function returning the process exit code (0 ok, 1 findings/errors, 2 usage errors).

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod render;

#[derive(Parser, Debug)]
#[command(name = "revelio", version, about = "Find interpretable failure modes of vision-language models")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Draw a concept set with the builtin renderer (or a contact sheet)
    Render(render::RenderArgs),
}

pub fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    match cli.command {
        Command::Render(args) => render::run(args),
    }
}

/// Compile a domain file for a subcommand, printing diagnostics to stderr on failure.
/// (Replaced by the front end.)
pub fn load_domain(path: &std::path::Path) -> Result<crate::ir::Domain, ExitCode> {
    eprintln!("error: cannot compile `{}`: the front end is not built yet", path.display());
    Err(ExitCode::from(1))
}
