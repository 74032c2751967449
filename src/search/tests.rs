//! Algorithm tests on synthetic evaluators, and end-to-end runs (sim model, journal, resume).
use std::sync::Arc;

use super::testkit::{FakeWorld, lattice, numbered};
use super::*;
use crate::ir::ConceptSet;
use crate::vlm::Outcome;

/// Evaluates a set as `f(set)` wrong answers out of `m`; records what it was asked.
struct FnEval<F> {
    f: F,
    m: u32,
    asked: Vec<Vec<ConceptSet>>,
}

impl<F: Fn(ConceptSet) -> u32> Evaluate for FnEval<F> {
    async fn evaluate(&mut self, sets: &[ConceptSet]) -> Result<Vec<SetStats>, String> {
        self.asked.push(sets.to_vec());
        Ok(sets
            .iter()
            .map(|&s| {
                let mut st = SetStats::new(s);
                let w = (self.f)(s).min(self.m);
                (0..self.m).for_each(|i| st.add(if i < w { Outcome::Wrong } else { Outcome::Correct }));
                st
            })
            .collect())
    }
}

fn block_on<T>(f: impl std::future::Future<Output = T>) -> T {
    tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap().block_on(f)
}

fn bits(ids: &[u32]) -> ConceptSet {
    ConceptSet::from_ids(ids.iter().map(|&i| crate::ir::ConceptId(i)))
}

/// Planted landscape: {2, 5} fails always, {2} alone sometimes, {6, 7} fails always.
fn landscape(s: ConceptSet) -> u32 {
    if bits(&[2, 5]).is_subset_of(s) || bits(&[6, 7]).is_subset_of(s) {
        5
    } else if s.contains(crate::ir::ConceptId(2)) {
        2
    } else {
        0
    }
}

fn params(algo: Algo, budget: u64) -> Params {
    Params { algo, budget, beam_budget: budget / 2, ..Params::default() }
}

fn run_fn(p: &Params, space: &Space) -> (Vec<SetStats>, Vec<Vec<ConceptSet>>) {
    let mut e = FnEval { f: landscape, m: p.samples, asked: vec![] };
    let h = block_on(run(p, space, &mut e)).unwrap();
    (h, e.asked)
}

fn assert_sound(h: &[SetStats], space: &Space, p: &Params) {
    assert!(h.len() <= p.max_sets());
    let distinct: std::collections::HashSet<_> = h.iter().map(|s| s.set).collect();
    assert_eq!(distinct.len(), h.len(), "a set was evaluated twice");
    assert!(h.iter().all(|s| space.contains(s.set)), "an invalid set was evaluated");
}

#[test]
fn random_is_seeded_uniform_and_without_repeats() {
    let space = Space::new(lattice(8, 4), 8);
    let p = params(Algo::Random, 500);
    let (a, _) = run_fn(&p, &space);
    assert_eq!(a.len(), 100);
    assert_sound(&a, &space, &p);
    assert_eq!(a, run_fn(&p, &space).0);
    let (b, _) = run_fn(&Params { seed: 1, ..p.clone() }, &space);
    assert_ne!(a, b);
    // A budget larger than the lattice evaluates every valid set once.
    let all = run_fn(&params(Algo::Random, 100_000), &space).0;
    assert_eq!(all.len(), space.sets.len());
}

#[test]
fn beam_expands_levels_in_order_and_follows_the_failure_gradient() {
    let space = Space::new(lattice(8, 4), 8);
    let p = Params { beam_width: 2, ..params(Algo::Beam, 5 * 30) };
    let (h, asked) = run_fn(&p, &space);
    assert_sound(&h, &space, &p);
    // Level 1: the valid singletons in concept order.
    assert_eq!(asked[0], (0..8).map(|i| bits(&[i])).collect::<Vec<_>>());
    // Level 2 expands the frontier {2} (highest FR) then the most diverse runner-up {0}.
    assert_eq!(asked[1][0], bits(&[0, 2]), "frontier order: {:?}", &asked[1][..3]);
    assert!(asked[1].contains(&bits(&[2, 5])));
    assert!(h.iter().any(|s| s.set == bits(&[2, 5]) && s.is_failure_mode(0.6)));
    assert_eq!(h.len(), 30, "the budget is spent");
    assert_eq!(h, run_fn(&p, &space).0);
}

#[test]
fn beam_stops_at_max_depth() {
    let space = Space::new(lattice(6, 5), 6);
    let p = Params { max_depth: 1, ..params(Algo::Beam, 1000) };
    let (h, asked) = run_fn(&p, &space);
    assert_eq!(asked.len(), 1);
    assert_eq!(h.len(), 6);
}

#[test]
fn gpts_beats_random_on_a_planted_landscape() {
    let space = Space::new(lattice(10, 4), 10);
    let modes = |h: &[SetStats]| h.iter().filter(|s| s.is_failure_mode(0.6)).count();
    let p = params(Algo::Gpts, 300);
    let (g, _) = run_fn(&p, &space);
    assert_sound(&g, &space, &p);
    assert_eq!(g.len(), 60);
    let (r, _) = run_fn(&params(Algo::Random, 300), &space);
    assert!(modes(&g) > 2 * modes(&r), "gpts {} vs random {}", modes(&g), modes(&r));
    assert_eq!(g, run_fn(&p, &space).0, "gpts is reproducible");
}

#[test]
fn gpts_batches_distinct_argmaxes_and_runs_without_a_beam_phase() {
    let space = Space::new(lattice(10, 4), 10);
    let p = Params { batch: 4, beam_budget: 0, ..params(Algo::Gpts, 200) };
    let (h, asked) = run_fn(&p, &space);
    assert_sound(&h, &space, &p);
    assert_eq!(h.len(), 40);
    assert!(asked.iter().all(|b| (1..=4).contains(&b.len())));
    assert!(asked.iter().any(|b| b.len() > 1), "parallel rounds");
}

#[test]
fn params_are_validated() {
    let ok = Params::default();
    assert!(ok.validate().is_ok());
    let e = |p: Params| p.validate().unwrap_err();
    assert_eq!(e(Params { samples: 0, ..ok.clone() }), "invalid `--samples`: must be at least 1");
    assert_eq!(e(Params { threshold: 1.5, ..ok.clone() }), "invalid `--threshold`: must be between 0 and 1, got 1.5");
    assert_eq!(e(Params { beam_budget: 2000, ..ok.clone() }), "invalid `--beam-budget`: 2000 exceeds the budget 1000");
    assert_eq!(e(Params { budget: 3, ..ok }), "invalid `--budget`: 3 inferences cannot evaluate one set of 5 samples");
}

// ---- end to end: sim model, journal, resume ----

mod e2e {
    use super::*;
    use crate::search::runner::{self, RunConfig, Setup};
    use crate::vlm::sim::{Profile, SimModel};

    const PROFILE: &str = "name = \"t\"\nbase_error = 0.1\nunparsed = 0.05\n[[mode]]\nconcepts = [\"c2\", \"c5\"]\nerror = 0.9\n[[mode]]\nconcepts = [\"c2\"]\nerror = 0.4\n";

    fn setup(out: &std::path::Path, concurrency: usize) -> (Setup, Space) {
        let d = numbered(8);
        let model = SimModel { profile: Profile::parse(PROFILE, "t.toml", &d).unwrap() };
        let world = Arc::new(FakeWorld(d.clone()));
        let space = Space::new(lattice(8, 4), 8);
        let s = Setup {
            domain: Arc::new(d),
            world,
            model: Arc::new(model),
            renderer: None,
            concurrency,
            out: out.to_path_buf(),
            progress: false,
        };
        (s, space)
    }

    fn config(s: &Setup, algo: Algo) -> RunConfig {
        RunConfig {
            domain_file: "/t.rev".into(),
            domain: "test".into(),
            domain_hash: crate::journal::domain_hash(&s.domain),
            model_spec: "sim:t.toml".into(),
            model: s.model.id(),
            renderer: "none".into(),
            params: Params { algo, budget: 200, beam_budget: 100, ..Params::default() },
        }
    }

    fn journal_lines(dir: &std::path::Path) -> Vec<String> {
        let text = std::fs::read_to_string(dir.join("journal.jsonl")).unwrap();
        let mut lines: Vec<String> = text
            .lines()
            .map(|l| {
                let mut v: serde_json::Value = serde_json::from_str(l).unwrap();
                v["latency_ms"] = 0.into();
                v.to_string()
            })
            .collect();
        lines.sort();
        lines
    }

    #[test]
    fn same_seed_same_journal_and_summary() {
        let dir = tempfile::tempdir().unwrap();
        for algo in [Algo::Random, Algo::Beam, Algo::Gpts] {
            let (a, b) = (dir.path().join(format!("{algo:?}a")), dir.path().join(format!("{algo:?}b")));
            let (sa, space) = setup(&a, 8);
            let ra = block_on(runner::search(&sa, &config(&sa, algo), &space)).unwrap();
            let (sb, space) = setup(&b, 3);
            let rb = block_on(runner::search(&sb, &config(&sb, algo), &space)).unwrap();
            assert_eq!(ra.summary, rb.summary);
            assert_eq!(ra.summary.metrics.inferences, 200);
            assert_eq!(journal_lines(&a), journal_lines(&b));
            assert_eq!(journal_lines(&a).len(), 200);
            assert_eq!(std::fs::read(a.join("summary.json")).unwrap(), std::fs::read(b.join("summary.json")).unwrap());
        }
    }

    #[test]
    fn resume_after_a_crash_at_any_point_gives_the_same_summary() {
        use rand::{RngExt, SeedableRng};
        let dir = tempfile::tempdir().unwrap();
        let full = dir.path().join("full");
        let (s, space) = setup(&full, 8);
        let cfg = config(&s, Algo::Gpts);
        let reference = block_on(runner::search(&s, &cfg, &space)).unwrap().summary;
        let journal = std::fs::read(full.join("journal.jsonl")).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let cuts = [0, 1, journal.len() - 1, journal.len()]
            .into_iter()
            .chain((0..6).map(|_| rng.random_range(0..journal.len())));
        for (k, cut) in cuts.enumerate() {
            let run = dir.path().join(format!("crash{k}"));
            std::fs::create_dir_all(&run).unwrap();
            std::fs::copy(full.join("config.json"), run.join("config.json")).unwrap();
            std::fs::write(run.join("journal.jsonl"), &journal[..cut]).unwrap();
            let kept = journal[..cut].iter().filter(|&&b| b == b'\n').count() as u64;
            let (s, space) = setup(&run, 8);
            let r = block_on(runner::search(&s, &cfg, &space)).unwrap();
            assert_eq!(r.summary, reference, "cut at byte {cut}");
            assert_eq!(r.replayed, kept, "every finished observation is replayed, none asked twice");
            assert_eq!(r.dropped_torn_line, cut > 0 && journal[cut - 1] != b'\n');
            assert_eq!(journal_lines(&run), journal_lines(&full));
        }
    }

    #[test]
    fn a_different_configuration_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let (s, space) = setup(dir.path(), 4);
        block_on(runner::search(&s, &config(&s, Algo::Random), &space)).unwrap();
        let mut other = config(&s, Algo::Random);
        other.params.seed = 9;
        let e = block_on(runner::search(&s, &other, &space)).err().unwrap();
        assert!(e.contains("(`params.seed` was 0, now 9)"), "{e}");
    }

    #[test]
    fn validation_re_evaluates_the_top_sets_with_fresh_scenes() {
        let dir = tempfile::tempdir().unwrap();
        let (s, space) = setup(dir.path(), 4);
        let cfg = config(&s, Algo::Beam);
        let r = block_on(runner::search(&s, &cfg, &space)).unwrap();
        let v = block_on(runner::validate(&s, &cfg, &r.summary, 3, 20)).unwrap();
        assert_eq!(v.sets.len(), 3);
        assert!(v.sets.iter().all(|x| x.validation.observations == 20));
        let chosen_min = v.sets.iter().filter_map(|x| x.search.fr).fold(1.0, f64::min);
        let others = r.summary.sets.iter().filter(|row| !v.sets.iter().any(|x| x.search.concepts == row.concepts));
        assert!(others.filter_map(|row| row.fr).all(|fr| fr <= chosen_min), "the top sets by search FR are validated");
        // {c2, c5} fails at 0.9 when answered: validated FR near it and consistent.
        let top = &v.sets[0];
        assert_eq!(
            top.search.concepts.iter().filter(|c| *c == "c2" || *c == "c5").count(),
            2,
            "{:?}",
            top.search.concepts
        );
        assert!(v.consistent >= 1);
        let lines = journal_lines(dir.path());
        assert_eq!(lines.iter().filter(|l| l.contains("\"phase\":\"validate\"")).count(), 60);
        // Resuming validation asks nothing new.
        let again = block_on(runner::validate(&s, &cfg, &r.summary, 3, 20)).unwrap();
        assert_eq!(again, v);
        assert_eq!(journal_lines(dir.path()).len(), lines.len());
    }

    /// The sim model, failing every call while `down` is set.
    struct Outage {
        sim: SimModel,
        down: std::sync::atomic::AtomicBool,
    }

    impl crate::vlm::Model for Outage {
        fn id(&self) -> String {
            self.sim.id()
        }
        fn ask<'a>(&'a self, q: &'a crate::vlm::Query) -> crate::vlm::BoxFuture<'a, crate::vlm::Reply> {
            Box::pin(async move {
                let mut r = self.sim.answer(q);
                if self.down.load(std::sync::atomic::Ordering::SeqCst) {
                    r.answer = crate::vlm::Answer::ApiError;
                    r.raw = "503 service unavailable".into();
                }
                r
            })
        }
    }

    #[test]
    fn api_errors_are_asked_again_on_resume() {
        let dir = tempfile::tempdir().unwrap();
        let (mut s, space) = setup(dir.path(), 4);
        let sim = || SimModel { profile: Profile::parse(PROFILE, "t.toml", &s.domain).unwrap() };
        let outage = Arc::new(Outage { sim: sim(), down: true.into() });
        s.model = outage.clone();
        let cfg = config(&s, Algo::Random);
        let down = block_on(runner::search(&s, &cfg, &space)).unwrap();
        assert_eq!(down.summary.metrics.unanswered.get(&Outcome::ApiError), Some(&200));
        assert_eq!(down.summary.metrics.failure_modes, 0);
        outage.down.store(false, std::sync::atomic::Ordering::SeqCst);
        let up = block_on(runner::search(&s, &cfg, &space)).unwrap();
        assert_eq!(up.replayed, 0);
        assert_eq!(up.summary.metrics.unanswered.get(&Outcome::ApiError), None);
        let fresh = tempfile::tempdir().unwrap();
        let (s2, _) = setup(fresh.path(), 4);
        assert_eq!(up.summary, block_on(runner::search(&s2, &config(&s2, Algo::Random), &space)).unwrap().summary);
    }
}
