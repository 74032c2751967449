//! `revelio lattice FILE [--max-size N] [--json] [--list]`: counts of valid concept sets per size,
//! or the sets themselves in canonical order.

use std::io::{self, Write};
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::process::ExitCode;

use crate::ir::{ConceptSet, Domain};
use crate::lattice::{self, Validity};

#[derive(clap::Args, Debug)]
pub struct LatticeArgs {
    /// The domain file (`.rev`)
    pub file: PathBuf,
    /// Largest number of concepts in a set
    #[arg(long, default_value_t = lattice::DEFAULT_MAX_SIZE as u32, value_parser = clap::value_parser!(u32).range(1..=128))]
    pub max_size: u32,
    /// Print JSON (with `--list`: one JSON array of concept names per line)
    #[arg(long)]
    pub json: bool,
    /// Print every valid set, one per line, smallest first, then by concept declaration order
    #[arg(long)]
    pub list: bool,
    /// Most valid sets counted or listed; a larger lattice is refused with the ways out
    #[arg(long, default_value_t = lattice::DEFAULT_MAX_SETS)]
    pub max_sets: u64,
}

pub fn run(args: LatticeArgs) -> ExitCode {
    let domain = match crate::cli::load_domain(&args.file) {
        Ok(d) => d,
        Err(code) => return code,
    };
    let max = args.max_size as usize;
    let validity = Validity::new(&domain);
    let counted = {
        let mut work = super::progress::Work::new();
        lattice::count_within(&domain, &validity, max, args.max_sets, &mut |w, d, t| work.report(w, d, t))
    };
    let counted = match counted {
        Ok(c) => c,
        Err(too_large) => {
            eprintln!("{}", too_large.plain());
            return ExitCode::from(1);
        }
    };
    let out = &mut io::BufWriter::new(io::stdout().lock());
    let result = if args.list {
        write_list(&domain, max, args.json, out)
    } else {
        write_counts(&domain, &counted, args.json, out)
    };
    match result.and_then(|()| out.flush()) {
        Ok(()) => ExitCode::SUCCESS,
        // A closed pipe (`revelio lattice --list … | head`) is the reader's choice, not an error.
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: cannot write the lattice: {e}");
            ExitCode::from(1)
        }
    }
}

/// Counts per size and the total.
pub fn write_counts(domain: &Domain, counted: &lattice::Count, json: bool, out: &mut impl Write) -> io::Result<()> {
    let counts = &counted.per_size;
    let max_size = counts.len() - 1;
    let total = counted.total();
    if json {
        let sizes: Vec<_> = (1..=max_size).map(|k| serde_json::json!({ "size": k, "sets": counts[k] })).collect();
        let v = serde_json::json!({
            "domain": domain.name,
            "concepts": domain.concepts.len(),
            "max_size": max_size,
            "sizes": sizes,
            "total": total,
        });
        return writeln!(out, "{v}");
    }
    writeln!(
        out,
        "domain `{}`: {} concepts, valid sets of up to {max_size} concepts",
        domain.name,
        domain.concepts.len()
    )?;
    let width = total.to_string().len();
    for (k, c) in counts.iter().enumerate().skip(1) {
        writeln!(out, "  size {k:>2}: {c:>width$}")?;
    }
    writeln!(out, "  total  : {total:>width$}")
}

/// Every valid set in canonical order, streamed size by size (nothing is stored, so any size
/// fits in memory).
pub fn write_list(domain: &Domain, max_size: usize, json: bool, out: &mut impl Write) -> io::Result<()> {
    let validity = Validity::new(domain);
    for size in 1..=max_size {
        let written = lattice::try_for_each_of_size(&validity, size, |s| match write_set(domain, s, json, out) {
            Ok(()) => ControlFlow::Continue(()),
            Err(e) => ControlFlow::Break(e),
        });
        if let ControlFlow::Break(e) = written {
            return Err(e);
        }
    }
    Ok(())
}

fn write_set(domain: &Domain, set: ConceptSet, json: bool, out: &mut impl Write) -> io::Result<()> {
    let names = domain.set_names(set);
    if json { writeln!(out, "{}", serde_json::Value::from(names)) } else { writeln!(out, "{}", names.join(" ")) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lattice::testkit::driving;

    fn text(f: impl FnOnce(&mut Vec<u8>) -> io::Result<()>) -> String {
        let mut buf = Vec::new();
        f(&mut buf).unwrap();
        String::from_utf8(buf).unwrap()
    }

    #[test]
    fn counts_human_and_json() {
        let d = driving();
        let counted = |size| lattice::count(&Validity::new(&d), size, u64::MAX, &mut lattice::quiet);
        insta::assert_snapshot!(text(|o| write_counts(&d, &counted(5), false, o)));
        insta::assert_snapshot!(text(|o| write_counts(&d, &counted(3), true, o)));
    }

    #[test]
    fn list_is_the_lattice_in_canonical_order() {
        let d = driving();
        let listed = text(|o| write_list(&d, 3, false, o));
        let lattice = crate::lattice::Lattice::enumerate(&d, 3);
        let expected: Vec<String> = lattice.sets.iter().map(|s| d.set_names(*s).join(" ")).collect();
        assert_eq!(listed.lines().collect::<Vec<_>>(), expected);
        let json = text(|o| write_list(&d, 2, true, o));
        let first: Vec<String> = serde_json::from_str(json.lines().nth(24).unwrap()).unwrap();
        assert_eq!(first, d.set_names(lattice.of_size(2)[0]));
    }

    #[test]
    fn list_stops_at_the_first_write_error() {
        struct Closed(usize);
        impl Write for Closed {
            fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
                self.0 += 1;
                if self.0 > 3 { Err(io::ErrorKind::BrokenPipe.into()) } else { Ok(buf.len()) }
            }
            fn flush(&mut self) -> io::Result<()> {
                Ok(())
            }
        }
        let mut w = Closed(0);
        let err = write_list(&driving(), 3, false, &mut w).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::BrokenPipe);
        assert_eq!(w.0, 4, "no write after the failing one");
    }
}
