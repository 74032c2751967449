//! The `revelio` command line. Each subcommand lives in its own file with its clap `Args` and a
//! `run` function returning the process exit code (0 ok, 1 findings/errors, 2 usage errors).

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod emit;
pub mod lattice;
pub mod oracle;
pub mod render;

#[derive(Parser, Debug)]
#[command(name = "revelio", version, about = "Find interpretable failure modes of vision-language models")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Count or list the valid concept sets of a domain
    Lattice(lattice::LatticeArgs),
    /// Show the ground truth (question, expected answer, deciding rule) of a concept set
    Oracle(oracle::OracleArgs),
    /// Emit one sampled scene of a concept set: a Scenic program, an image prompt, or JSON
    Emit(emit::EmitArgs),
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
        Command::Lattice(args) => lattice::run(args),
        Command::Oracle(args) => oracle::run(args),
        Command::Emit(a) => emit::run(a),
        Command::Render(args) => render::run(args),
    }
}

/// Compile a domain file for a subcommand, printing diagnostics to stderr on failure.
/// (Replaced by the front end.)
pub fn load_domain(path: &std::path::Path) -> Result<crate::ir::Domain, ExitCode> {
    eprintln!("error: cannot compile `{}`: the front end is not built yet", path.display());
    Err(ExitCode::from(1))
}
