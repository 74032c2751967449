//! `revelio bench scale [--concepts 30,60,120,250] [--max-size 5]`: how `check` (with the
//! lattice lints) and `lattice` grow with the number of concepts, on generated domains of
//! independent concepts and no constraints (the worst case for a lattice: every set is valid).
//!
//! Each row: the valid sets of up to `--max-size` concepts (exact, from the lattice's diagram),
//! the time of `check` (compile and lint) and its peak memory, and the time to count the lattice.
//! Peak memory is the process's resident high-water mark, reset before each row
//! (`/proc/self/clear_refs`; shown as `—` where the kernel does not offer it).

use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

use crate::lattice::{Diagram, Validity};
use crate::lint::{Limits, lint_domain_with};

#[derive(clap::Args, Debug)]
pub struct ScaleBenchArgs {
    /// Domain sizes to generate (concepts), comma-separated
    #[arg(long, value_delimiter = ',', default_values_t = [30u32, 60, 120, 250],
          value_parser = clap::value_parser!(u32).range(1..=crate::ir::MAX_CONCEPTS as i64))]
    pub concepts: Vec<u32>,
    /// Largest number of concepts in a set
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=16))]
    pub max_size: u32,
    /// Most valid sets the lints enumerate (past it they judge a stated sample)
    #[arg(long, default_value_t = crate::lattice::DEFAULT_MAX_SETS)]
    pub max_sets: u64,
}

/// A domain of `n` independent concepts, each setting a world attribute, and one rule.
pub fn generated(n: usize) -> String {
    let mut t = String::from("domain generated\nworld { on: bool = false }\n");
    for i in 0..n {
        t.push_str(&format!("concept c{i} {{ description \"c\" probe \"p\" not \"n\" set world.on = true }}\n"));
    }
    t.push_str("question q { text \"q\" option a \"a\" option b \"b\" }\n");
    t.push_str("rules priority {\n  rule first { when has c0 expect q.b }\n  rule rest { expect q.a }\n}\n");
    t
}

struct Row {
    concepts: usize,
    sets: u128,
    check_s: f64,
    check_mb: Option<f64>,
    lints: usize,
    lattice_s: f64,
    nodes: usize,
}

pub fn run(args: &ScaleBenchArgs) -> ExitCode {
    let mut rows = Vec::new();
    let max_size = args.max_size as usize;
    for n in args.concepts.iter().map(|&n| n as usize) {
        let text = generated(n);
        reset_peak();
        let started = Instant::now();
        let domain = match crate::check::compile_source("generated.rev", &text) {
            Ok(d) => d,
            Err(diags) => {
                eprintln!("error: the generated domain of {n} concepts does not compile: {diags:?}");
                return ExitCode::from(1);
            }
        };
        let limits = Limits { max_size, max_sets: args.max_sets };
        let lints = lint_domain_with(&domain, limits, &mut crate::lattice::quiet).len();
        let check_s = started.elapsed().as_secs_f64();
        let check_mb = peak_mb();
        let started = Instant::now();
        let diagram = Diagram::build(&Validity::new(&domain), max_size);
        let sets = diagram.total();
        let lattice_s = started.elapsed().as_secs_f64();
        rows.push(Row { concepts: n, sets, check_s, check_mb, lints, lattice_s, nodes: diagram.nodes() });
    }
    let mut w = std::io::stdout().lock();
    match print(&mut w, max_size, &rows) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            eprintln!("error: cannot write the table: {e}");
            ExitCode::from(1)
        }
        _ => ExitCode::SUCCESS,
    }
}

fn print(w: &mut impl Write, max_size: usize, rows: &[Row]) -> std::io::Result<()> {
    writeln!(
        w,
        "| concepts | valid sets (≤ {max_size}) | `check` with lints | lints | `lattice` count | diagram nodes |"
    )?;
    writeln!(w, "|---|---|---|---|---|---|")?;
    for r in rows {
        let mb = r.check_mb.map_or("—".to_string(), |m| format!("{m:.0} MB"));
        writeln!(
            w,
            "| {} | {} | {:.2} s / {mb} | {} | {:.4} s | {} |",
            r.concepts, r.sets, r.check_s, r.lints, r.lattice_s, r.nodes
        )?;
    }
    Ok(())
}

/// Reset the resident-memory high-water mark (Linux; elsewhere a no-op).
fn reset_peak() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The resident-memory high-water mark in MB, where the kernel reports it.
fn peak_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_domains_compile_with_every_concept_independent() {
        let d = crate::check::compile_source("g.rev", &generated(200)).unwrap();
        assert_eq!(d.concepts.len(), 200);
        let diagram = Diagram::build(&Validity::new(&d), 2);
        assert_eq!(diagram.counts(), vec![0, 200, 200 * 199 / 2]);
    }
}
