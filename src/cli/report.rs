//! `revelio report RUN_DIR [-o DIR]`: write the run's static report (`RUN_DIR/report/` by
//! default): `index.html`, `failure_modes.csv`, `sets.csv`, the plots as SVG and the images its
//! failure modes show. `search` and `validate` refresh it when they finish ([`refresh`]).
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use crate::diag::{TerminalSafe, terminal_safe};
use crate::ir::Domain;

#[derive(clap::Args, Debug)]
pub struct ReportArgs {
    /// A finished `revelio search` run folder
    pub run_dir: PathBuf,
    /// Folder to write the report into [default: RUN_DIR/report]
    #[arg(short = 'o', long = "out")]
    pub out: Option<PathBuf>,
}

pub fn run(args: ReportArgs) -> ExitCode {
    let run = match crate::report::load(&args.run_dir) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {}", terminal_safe(&e.to_string()));
            // As `validate`: a folder that holds no finished run is a usage error.
            return ExitCode::from(2);
        }
    };
    let domain = run_domain(&run.config.domain_file, &run.config.domain_hash);
    let out = args.out.unwrap_or_else(|| args.run_dir.join("report"));
    match crate::report::write(&run, domain.as_ref(), &out) {
        Ok(w) => {
            println!("report: {}", terminal_safe(&w.index.display().to_string()));
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// The run's domain when its file still compiles to what the run searched; otherwise a note
/// and `None` (the report then leaves out the oracle's explanations).
fn run_domain(file: &str, hash: &str) -> Option<Domain> {
    let path = Path::new(file);
    if !path.is_file() {
        // The path comes from the run folder's `config.json`.
        let file = terminal_safe(file);
        eprintln!("note: the domain file `{file}` is gone; the report leaves out the oracle's explanations");
        return None;
    }
    let domain = crate::cli::load_domain(path).ok()?;
    if domain.identity().to_string() != hash {
        eprintln!(
            "note: `{}` changed since the run; the report leaves out the oracle's explanations",
            terminal_safe(file)
        );
        return None;
    }
    Some(domain)
}

/// Rewrite `RUN_DIR/report` at the end of `search` or `validate` and say where it is (on
/// stderr with `--json`, whose stdout is the JSON alone). A failure costs the run nothing: it
/// is reported as a warning, and `revelio report` can try again.
pub fn refresh(run_dir: &Path, domain: &Domain, json: bool) {
    let written =
        crate::report::load(run_dir).and_then(|run| crate::report::write(&run, Some(domain), &run_dir.join("report")));
    match written {
        Ok(w) if json => eprintln!("report: {}", terminal_safe(&w.index.display().to_string())),
        // A closed stdout (`| head`) is no reason to panic here.
        Ok(w) => drop(writeln!(TerminalSafe(std::io::stdout()), "report: {}", w.index.display())),
        Err(e) => eprintln!(
            "warning: the run is complete but its report was not written: {e}; `revelio report {}` tries again",
            run_dir.display()
        ),
    }
}
