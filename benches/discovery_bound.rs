//! What any search could find on `revelio bench scale`'s 250-concept domain (issue 34's target:
//! its planted pair and triple found as cores in 9 of 10 seeds), bounded by an idealised
//! discovery: every call screens a set of five concepts and nothing is spent on escalating,
//! explaining, shrinking or confirming. The answers are the bench's own sim model (its profile,
//! [`revelio::cli::bench::scale::profile`]: base error 0.05, each of the five parts 0.3–0.35
//! alone). The discovery knows what a real search does not, read from that profile: the base
//! error, the parts' mean rate alone and their share of the concepts (5 of 250). It keeps, per concept, the
//! probability that it is a part (a spike-and-slab posterior, updated after each answer with the
//! other concepts of the set at their current probabilities), screens by Thompson sampling
//! (each concept drawn a part with its probability; the drawn ones first, the set filled at
//! random) and sets a concept aside once its probability passes the naming level. A mode is
//! *met* when its parts are all named or a screened set held the whole mode: what a search needs
//! before it can find the mode at all. The search must then still put the parts together (when
//! they were only named), shrink and confirm, so a search's recovery is below these shares.
//!
//! `cargo bench --bench discovery_bound` (200 runs of 1 000 calls at two naming levels; about
//! four seconds once built). Figures are in docs/search.md ("Lattices past `--max-sets`").

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use revelio::ir::{ConceptId, ConceptSet};
use revelio::vlm::sim::Profile;

const CONCEPTS: usize = 250;
const SIZE: usize = 5;
const RUNS: u64 = 200;
/// The calls after which the shares are read.
const CHECKPOINTS: [usize; 4] = [300, 500, 700, 1000];

/// What the discovery is told (a real search is not): the prior share of parts among the
/// concepts, the rate a part fails at alone, and the base error.
#[derive(Clone, Copy)]
struct Told {
    prior: f64,
    slab: f64,
    base: f64,
}

/// One run: per checkpoint, whether the pair and the triple were each met — its parts all named,
/// or the mode itself screened (a set holding it, answering at the mode's rate) — and how many
/// concepts that are no part were named.
fn run(
    profile: &Profile,
    told: &Told,
    seed: u64,
    named_at: f64,
    pair: ConceptSet,
    triple: ConceptSet,
) -> Vec<(bool, bool, usize)> {
    let Told { prior, slab, base } = *told;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let parts = pair.union(triple);
    let mut odds = vec![(prior / (1.0 - prior)).ln(); CONCEPTS];
    let mut named = ConceptSet::EMPTY;
    let mut screened = (false, false);
    let mut out = Vec::new();
    for t in 0..=*CHECKPOINTS.last().unwrap() {
        let p: Vec<f64> = odds.iter().map(|l| 1.0 / (1.0 + (-l).exp())).collect();
        for (c, &pc) in p.iter().enumerate() {
            if pc > named_at {
                named = named.with(ConceptId(c as u32));
            }
        }
        if CHECKPOINTS.contains(&t) {
            let false_named = named.difference(parts).len();
            out.push((screened.0 || pair.is_subset_of(named), screened.1 || triple.is_subset_of(named), false_named));
        }
        // Thompson sampling: the concepts drawn a part first, then the others, each group in a
        // random order; named ones are set aside.
        let mut keyed: Vec<(bool, f64, usize)> = (0..CONCEPTS)
            .filter(|&c| !named.contains(ConceptId(c as u32)))
            .map(|c| (rng.random::<f64>() < p[c], rng.random::<f64>(), c))
            .collect();
        keyed.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.total_cmp(&b.1)));
        let set: Vec<usize> = keyed.iter().take(SIZE).map(|k| k.2).collect();
        let bits = set.iter().fold(ConceptSet::EMPTY, |s, &c| s.with(ConceptId(c as u32)));
        screened = (screened.0 || pair.is_subset_of(bits), screened.1 || triple.is_subset_of(bits));
        let wrong = rng.random::<f64>() < profile.error_for(bits);
        for (i, &c) in set.iter().enumerate() {
            // The chance the set fails if `c` is a part, and if it is not (another part may be in
            // the set: the set fails at about a part's rate then).
            let none_other: f64 = set.iter().enumerate().filter(|&(j, _)| j != i).map(|(_, &o)| 1.0 - p[o]).product();
            let if_not = none_other * base + (1.0 - none_other) * slab;
            odds[c] += if wrong { (slab / if_not).ln() } else { ((1.0 - slab) / (1.0 - if_not)).ln() };
        }
    }
    out
}

fn main() {
    let domain = revelio::check::compile_source("generated.rev", &revelio::cli::bench::scale::generated(CONCEPTS))
        .expect("the generated domain compiles");
    let profile = Profile::parse(&revelio::cli::bench::scale::profile(), "generated profile", &domain)
        .expect("the bench's profile parses");
    let planted = profile.planted(revelio::search::Params::default().threshold, |_| true);
    let (pair, triple) = match planted.as_slice() {
        [a, b] if a.len() == 2 && b.len() == 3 => (*a, *b),
        _ => panic!("the bench's profile plants a pair and a triple, got {planted:?}"),
    };
    let parts = pair.union(triple);
    let slab = parts.iter().map(|c| profile.error_for(ConceptSet::single(c))).sum::<f64>() / parts.len() as f64;
    let told = Told { prior: parts.len() as f64 / CONCEPTS as f64, slab, base: profile.base_error };
    println!("idealised discovery on `bench scale`'s 250-concept profile, {RUNS} runs: share of runs that");
    println!("met each mode within the calls (its parts all named, P(part) above the naming level, or");
    println!("the whole mode screened), and concepts named that are no part (mean per run)\n");
    println!("| naming level | calls | pair met | triple met | named, no part |");
    println!("|---|---|---|---|---|");
    for named_at in [0.5, 0.8] {
        let runs: Vec<Vec<(bool, bool, usize)>> =
            (0..RUNS).map(|seed| run(&profile, &told, seed, named_at, pair, triple)).collect();
        for (k, calls) in CHECKPOINTS.iter().enumerate() {
            let share = |f: &dyn Fn(&(bool, bool, usize)) -> bool| {
                runs.iter().filter(|r| f(&r[k])).count() as f64 / RUNS as f64 * 100.0
            };
            let false_named = runs.iter().map(|r| r[k].2).sum::<usize>() as f64 / RUNS as f64;
            println!(
                "| {named_at} | {calls} | {:.0} % | {:.0} % | {false_named:.1} |",
                share(&|r| r.0),
                share(&|r| r.1)
            );
        }
    }
}
