//! `revelio fmt [--check [--diff]] [PATH…]`: rewrite `.rev` files in the canonical layout
//! (folders are searched recursively; no PATH means the current folder). `-` formats standard
//! input to standard output. With `--check` nothing is written: the files that are not
//! formatted are listed (with `--diff`, shown as a unified diff of what `revelio fmt` would
//! change) and the exit code is 1.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use super::check::Report;
use super::common::{collect_rev_files, write_stdout};
use crate::ir::SourceFile;

#[derive(clap::Args, Debug)]
pub struct FmtArgs {
    /// `.rev` files or folders (searched recursively), or `-` for standard input; the current
    /// folder when none is given
    #[arg(value_name = "PATH")]
    pub paths: Vec<PathBuf>,
    /// Write nothing; list the files that are not formatted and exit with 1 if there are any
    #[arg(long)]
    pub check: bool,
    /// With `--check`: print what formatting would change, as a unified diff (`git apply`
    /// reads it), instead of the file names
    #[arg(long, requires = "check")]
    pub diff: bool,
}

pub fn run(args: FmtArgs) -> ExitCode {
    if args.paths.iter().any(|p| p.as_os_str() == "-") {
        if args.paths.len() > 1 {
            eprintln!("error: `-` (standard input) cannot be combined with other paths");
            return ExitCode::from(2);
        }
        return stdin(args.check, args.diff);
    }
    let paths = if args.paths.is_empty() { vec![PathBuf::from(".")] } else { args.paths };
    let files = match collect_rev_files(&paths) {
        Ok(f) => f,
        Err(msg) => {
            eprintln!("error: {msg}");
            return ExitCode::from(2);
        }
    };
    let (mut changed, mut failed) = (0, 0);
    for f in &files {
        match file(f, args.check, args.diff) {
            Ok(true) => changed += 1,
            Ok(false) => {}
            Err(()) => failed += 1,
        }
    }
    let plural = |n: usize| if n == 1 { "1 file".to_string() } else { format!("{n} files") };
    if args.check {
        if changed > 0 {
            eprintln!("{} of {} not formatted; run `revelio fmt` to fix", plural(changed), files.len());
        }
    } else if changed > 0 {
        eprintln!("formatted {} ({} already formatted)", plural(changed), files.len() - changed - failed);
    }
    if failed > 0 || (args.check && changed > 0) { ExitCode::from(1) } else { ExitCode::SUCCESS }
}

/// Format one file; `Ok(true)` when it was (or, with `check`, would be) changed.
fn file(path: &Path, check: bool, diff: bool) -> Result<bool, ()> {
    let name = path.display().to_string();
    // Under the bounds `check` reads with: a FIFO named `*.rev` in a folder is not opened, and
    // a file past the size limit is refused, not read whole.
    let text = crate::source::read(path, &name).map_err(|r| eprintln!("error: {}", r.message))?;
    let formatted = format_or_report(&name, &text)?;
    if formatted == text {
        return Ok(false);
    }
    if diff {
        write_stdout(&crate::fmt::diff::unified(&name, &text, &formatted));
    } else if check {
        println!("{name}");
    } else {
        std::fs::write(path, &formatted).map_err(|e| {
            eprintln!("error: cannot write `{name}`: {}", e.to_string().to_lowercase());
        })?;
    }
    Ok(true)
}

fn stdin(check: bool, diff: bool) -> ExitCode {
    let text = match crate::source::read_bounded(std::io::stdin(), "<stdin>") {
        Ok(t) => t,
        Err(r) => {
            eprintln!("error: {}", r.message);
            return ExitCode::from(1);
        }
    };
    let Ok(formatted) = format_or_report("<stdin>", &text) else { return ExitCode::from(1) };
    if check {
        if formatted != text {
            if diff {
                write_stdout(&crate::fmt::diff::unified("<stdin>", &text, &formatted));
            }
            eprintln!("standard input is not formatted; run `revelio fmt -` to fix");
            return ExitCode::from(1);
        }
    } else {
        write_stdout(&formatted);
    }
    ExitCode::SUCCESS
}

/// The formatted text, or the syntax errors printed to stderr.
fn format_or_report(name: &str, text: &str) -> Result<String, ()> {
    crate::fmt::format(text).map_err(|errors| {
        let files = [SourceFile { name: name.to_string(), text: text.to_string() }];
        let theme = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            miette::GraphicalTheme::unicode()
        } else {
            miette::GraphicalTheme::unicode_nocolor()
        };
        for d in &errors {
            eprint!("{}", Report::new(&files, d).human(&theme));
        }
        eprintln!("error: `{name}` was not formatted: fix its syntax errors first");
    })
}
