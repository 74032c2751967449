//! `revelio lattice FILE [--max-size N] [--json] [--list]`: counts of valid concept sets per size,
//! or the sets themselves in canonical order.

use std::io::{self, Write};
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::process::ExitCode;

use crate::ir::{ConceptSet, Domain};
use crate::lattice::{self, Diagram, Validity};

#[derive(clap::Args, Debug)]
pub struct LatticeArgs {
    /// The domain file (`.rev`)
    pub file: PathBuf,
    /// Largest number of concepts in a set
    #[arg(long, default_value_t = lattice::DEFAULT_MAX_SIZE as u32, value_parser = clap::value_parser!(u32).range(1..=512))]
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
    // Exact counts from the diagram, for any size of domain; only a listing is bounded.
    let diagram = Diagram::build(&Validity::new(&domain), max);
    let counts = diagram.counts();
    if args.list && diagram.total() > u128::from(args.max_sets) {
        let validity = Validity::new(&domain);
        let too_large =
            lattice::count_within(&domain, &validity, max, args.max_sets, &mut lattice::quiet).err().unwrap_or_else(
                || lattice::TooLarge { domain: domain.name.clone(), max_size: max, limit: args.max_sets, fits: None },
            );
        eprintln!("{}", too_large.plain());
        return ExitCode::from(1);
    }
    let out = &mut io::BufWriter::new(io::stdout().lock());
    let result = if args.list {
        write_list(&diagram, &domain, args.json, out)
    } else {
        write_counts(&domain, &counts, args.json, out)
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
pub fn write_counts(domain: &Domain, counts: &[u128], json: bool, out: &mut impl Write) -> io::Result<()> {
    let max_size = counts.len() - 1;
    let total = counts.iter().fold(0u128, |a, c| a.saturating_add(*c));
    if json {
        // A count past 64 bits (hundreds of concepts, large sets) is written as a string of digits.
        let num =
            |n: u128| u64::try_from(n).map_or_else(|_| serde_json::json!(n.to_string()), |n| serde_json::json!(n));
        let sizes: Vec<_> = (1..=max_size).map(|k| serde_json::json!({ "size": k, "sets": num(counts[k]) })).collect();
        let v = serde_json::json!({
            "domain": domain.name,
            "concepts": domain.concepts.len(),
            "max_size": max_size,
            "sizes": sizes,
            "total": num(total),
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
pub fn write_list(diagram: &Diagram, domain: &Domain, json: bool, out: &mut impl Write) -> io::Result<()> {
    for size in 1..=diagram.max_size() {
        let written = diagram.try_for_each_of_size(size, |s| match write_set(domain, s, json, out) {
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
        let counted = |size| Diagram::build(&Validity::new(&d), size).counts();
        insta::assert_snapshot!(text(|o| write_counts(&d, &counted(5), false, o)));
        insta::assert_snapshot!(text(|o| write_counts(&d, &counted(3), true, o)));
    }

    #[test]
    fn list_is_the_lattice_in_canonical_order() {
        let d = driving();
        let listed = text(|o| write_list(&Diagram::build(&Validity::new(&d), 3), &d, false, o));
        let lattice = crate::lattice::Lattice::enumerate(&d, 3);
        let expected: Vec<String> = lattice.sets.iter().map(|s| d.set_names(*s).join(" ")).collect();
        assert_eq!(listed.lines().collect::<Vec<_>>(), expected);
        let json = text(|o| write_list(&Diagram::build(&Validity::new(&d), 2), &d, true, o));
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
        let d = driving();
        let err = write_list(&Diagram::build(&Validity::new(&d), 3), &d, false, &mut w).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::BrokenPipe);
        assert_eq!(w.0, 4, "no write after the failing one");
    }
}
