//! `revelio bench scale [--concepts 30,60,120,250] [--max-size 5]`: how `check` (with the
//! lattice lints) and `lattice` grow with the number of concepts, on generated domains of
//! independent concepts and no constraints (the worst case for a lattice: every set is valid).
//!
//! Each row: the valid sets of up to `--max-size` concepts (exact, from the lattice's diagram),
//! the time of `check` (compile and lint) and its peak memory, and the time to count the lattice.
//! Peak memory is the process's resident high-water mark, reset before each row
//! (`/proc/self/clear_refs`; shown as `—` where the kernel does not offer it).
//!
//! The search columns (`--search-seeds` > 0): the default search (`--algo interact`, budget
//! `--budget`, zero latency, `--renderer none`, the default shrink share) against a sim model
//! with a planted pair and a planted triple whose every concept fails at 0.3–0.35 alone
//! ([`profile`]): its mean time and the peak memory over the seeds, and in how many seeds each
//! planted mode was reported exactly as a core. A lattice past `--max-sets` is searched as a
//! sampled space (never listed), as `revelio search` does.

use std::io::Write;
use std::process::ExitCode;
use std::time::Instant;

use std::sync::Arc;

use crate::ir::ConceptSet;
use crate::lattice::{Diagram, Lattice, Validity};
use crate::lint::{Limits, lint_domain_with};
use crate::run::observe::{DomainWorld, World};
use crate::run::runner::{self, Setup};
use crate::run::setup::ModelSettings;
use crate::run::summary::RunConfig;
use crate::search::{Algo, Params, Space};
use crate::vlm::Model;
use crate::vlm::sim::{Profile, SimModel};

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
    /// Seeds of the default search per domain size (0: no search columns)
    #[arg(long, default_value_t = 1)]
    pub search_seeds: u64,
    /// The search's budget (model calls)
    #[arg(long, default_value_t = 1000)]
    pub budget: u64,
}

/// The planted modes' concepts: a pair and a triple (indices below 30, so every size has them).
const PAIR: [usize; 2] = [5, 9];
const TRIPLE: [usize; 3] = [13, 17, 21];
/// Fewest concepts a domain needs to hold the planted modes (concepts are `c0`…).
const PLANTED_WITHIN: usize = 22;

/// A sim profile for [`generated`]: base error 0.05, the pair and the triple failing at 0.9, each
/// of their concepts alone at 0.3–0.35 (a signal a search can follow).
pub fn profile() -> String {
    let mut t = String::from("name = \"scale\"\nbase_error = 0.05\n");
    let mut mode = |concepts: &[usize], error: f64| {
        let names: Vec<String> = concepts.iter().map(|c| format!("\"c{c}\"")).collect();
        t.push_str(&format!("[[mode]]\nconcepts = [{}]\nerror = {error}\n", names.join(", ")));
    };
    mode(&PAIR, 0.9);
    mode(&TRIPLE, 0.9);
    for (c, e) in PAIR.iter().chain(&TRIPLE).zip([0.3, 0.35, 0.3, 0.33, 0.35]) {
        mode(&[*c], e);
    }
    t
}

/// The search columns of one row.
struct Searched {
    seconds: f64,
    peak_mb: Option<f64>,
    /// Seeds that reported the pair, the triple, exactly as a core.
    pair: usize,
    triple: usize,
    seeds: u64,
}

/// The default search on the generated domain of `n` concepts, `seeds` times.
fn search(domain: crate::ir::Domain, args: &ScaleBenchArgs, diagram: Diagram) -> Result<Searched, String> {
    let n = domain.concepts.len();
    let profile = Profile::parse(&profile(), "generated profile", &domain)?;
    let model: Arc<dyn Model> = Arc::new(SimModel { profile });
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&domain));
    let max_size = args.max_size as usize;
    let space = if diagram.total() <= u128::from(args.max_sets) {
        runner::search_space(Lattice::enumerate(&domain, max_size).sets, n, world.as_ref()).0
    } else {
        let w = world.clone();
        Space::sampled(Arc::new(diagram), Arc::new(move |s| w.task(s).is_ok()), n)
    };
    let set = |ids: &[usize]| ConceptSet::from_ids(ids.iter().map(|&i| crate::ir::ConceptId(i as u32)));
    let (pair, triple) = (set(&PAIR), set(&TRIPLE));
    let domain = Arc::new(domain);
    let tmp = std::env::temp_dir().join(format!("revelio-scale-{}-{n}", std::process::id()));
    let mut out = Searched { seconds: 0.0, peak_mb: None, pair: 0, triple: 0, seeds: args.search_seeds };
    reset_peak();
    for seed in 0..args.search_seeds {
        let d = Params::default();
        let params = Params {
            algo: Algo::Interact,
            budget: args.budget,
            shrink: Params::default_shrink(args.budget),
            max_size,
            seed,
            batch: crate::run::setup::DEFAULT_CONCURRENCY,
            ..d
        };
        let config = RunConfig::new(
            &domain,
            std::path::Path::new("generated.rev"),
            "sim:scale",
            model.as_ref(),
            ModelSettings::default(),
            "none",
            params,
        );
        let renderer = crate::render::build_renderer("none", &Default::default())?;
        let dir = tmp.join(seed.to_string());
        let setup = Setup::new(domain.clone(), world.clone(), model.clone(), renderer, dir);
        let started = Instant::now();
        let r = super::super::common::runtime()
            .block_on(runner::search(&setup, &config, &space))
            .map_err(|e| e.to_string())?;
        out.seconds += started.elapsed().as_secs_f64() / args.search_seeds as f64;
        let cores: Vec<ConceptSet> = r.found.cores.iter().map(|c| c.stats.set).collect();
        out.pair += usize::from(cores.contains(&pair));
        out.triple += usize::from(cores.contains(&triple));
    }
    out.peak_mb = peak_mb();
    let _ = std::fs::remove_dir_all(&tmp);
    Ok(out)
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
    search: Option<Searched>,
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
        let nodes = diagram.nodes();
        let search = if args.search_seeds == 0 {
            None
        } else if n < PLANTED_WITHIN {
            eprintln!(
                "note: no search on the generated domain of {n} concepts: its planted modes need at least {PLANTED_WITHIN}"
            );
            None
        } else {
            match search(domain, args, diagram) {
                Ok(s) => Some(s),
                Err(e) => {
                    eprintln!("error: the search on the generated domain of {n} concepts failed: {e}");
                    return ExitCode::from(1);
                }
            }
        };
        rows.push(Row { concepts: n, sets, check_s, check_mb, lints, lattice_s, nodes, search });
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
    let searched = rows.iter().any(|r| r.search.is_some());
    let (head, rule) = if searched {
        (" search (interact, zero latency) | pair / triple found as cores |", "---|---|")
    } else {
        ("", "")
    };
    writeln!(
        w,
        "| concepts | valid sets (≤ {max_size}) | `check` with lints | lints | `lattice` count | diagram nodes |{head}"
    )?;
    writeln!(w, "|---|---|---|---|---|---|{rule}")?;
    for r in rows {
        let mb = |m: Option<f64>| m.map_or("—".to_string(), |m| format!("{m:.0} MB"));
        let search = match &r.search {
            Some(s) => format!(" {:.1} s / {} | {} / {} of {} |", s.seconds, mb(s.peak_mb), s.pair, s.triple, s.seeds),
            None if searched => " — | — |".to_string(),
            None => String::new(),
        };
        writeln!(
            w,
            "| {} | {} | {:.2} s / {} | {} | {:.4} s | {} |{search}",
            r.concepts,
            r.sets,
            r.check_s,
            mb(r.check_mb),
            r.lints,
            r.lattice_s,
            r.nodes
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
