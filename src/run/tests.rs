//! End-to-end runs on synthetic domains: sim model, journal, resume, validation.
use std::sync::Arc;

use super::runner::{self, RunConfig, Setup};
use super::testkit::FakeWorld;
use crate::ir::testkit::{lattice, numbered};
use crate::outcome::Outcome;
use crate::search::{Algo, Params, Space};
use crate::vlm::sim::{Profile, SimModel};

pub(super) const PROFILE: &str = "name = \"t\"\nbase_error = 0.1\nunparsed = 0.05\n[[mode]]\nconcepts = [\"c2\", \"c5\"]\nerror = 0.9\n[[mode]]\nconcepts = [\"c2\"]\nerror = 0.4\n";

pub(super) fn setup(out: &std::path::Path, concurrency: usize) -> (Setup, Space) {
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

pub(super) fn config(s: &Setup, algo: Algo) -> RunConfig {
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

pub(super) fn journal_lines(dir: &std::path::Path) -> Vec<String> {
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
    for algo in Algo::ALL {
        let (a, b) = (dir.path().join(format!("{algo:?}a")), dir.path().join(format!("{algo:?}b")));
        let (sa, space) = setup(&a, 8);
        let ra = block_on(runner::search(&sa, &config(&sa, algo), &space)).unwrap();
        let (sb, space) = setup(&b, 3);
        let rb = block_on(runner::search(&sb, &config(&sb, algo), &space)).unwrap();
        assert_eq!(ra.summary, rb.summary);
        // Interact confirms cores sequentially (batches of 1–6 observations): the budget may
        // end less than m short of 200, never past it.
        let spent = ra.summary.metrics.inferences;
        if algo == Algo::Interact {
            assert!((196..=200).contains(&spent), "{spent}")
        } else {
            assert_eq!(spent, 200)
        }
        assert_eq!(journal_lines(&a), journal_lines(&b));
        assert_eq!(journal_lines(&a).len() as u64, spent);
        assert_eq!(std::fs::read(a.join("summary.json")).unwrap(), std::fs::read(b.join("summary.json")).unwrap());
    }
}

/// A run killed at any byte of its journal resumes to the uninterrupted run's summary.
fn resume_after_a_crash_at_any_point_gives_the_same_summary(algo: Algo) {
    use rand::{RngExt, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("full");
    let (s, space) = setup(&full, 8);
    let cfg = config(&s, algo);
    let reference = block_on(runner::search(&s, &cfg, &space)).unwrap().summary;
    let journal = std::fs::read(full.join("journal.jsonl")).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let cuts =
        [0, 1, journal.len() - 1, journal.len()].into_iter().chain((0..6).map(|_| rng.random_range(0..journal.len())));
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
fn gpts_resumes_after_a_crash_at_any_point() {
    resume_after_a_crash_at_any_point_gives_the_same_summary(Algo::Gpts);
}

#[test]
fn interact_resumes_after_a_crash_at_any_point() {
    resume_after_a_crash_at_any_point_gives_the_same_summary(Algo::Interact);
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
    let v = block_on(runner::validate(&s, &cfg, &r.summary, 3, 20, None)).unwrap();
    assert_eq!(v.sets.len(), 3);
    assert!(v.sets.iter().all(|x| x.validation.observations == 20));
    let chosen_min = v.sets.iter().filter_map(|x| x.search.fr).fold(1.0, f64::min);
    let others = r.summary.sets.iter().filter(|row| !v.sets.iter().any(|x| x.search.concepts == row.concepts));
    assert!(others.filter_map(|row| row.fr).all(|fr| fr <= chosen_min), "the top sets by search FR are validated");
    // {c2, c5} fails at 0.9 when answered: validated FR near it and consistent.
    let top = &v.sets[0];
    assert_eq!(top.search.concepts.iter().filter(|c| *c == "c2" || *c == "c5").count(), 2, "{:?}", top.search.concepts);
    assert!(v.consistent >= 1);
    let lines = journal_lines(dir.path());
    assert_eq!(lines.iter().filter(|l| l.contains("\"phase\":\"validate\"")).count(), 60);
    // Resuming validation asks nothing new.
    let again = block_on(runner::validate(&s, &cfg, &r.summary, 3, 20, None)).unwrap();
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
                r.answer = crate::outcome::Answer::ApiError;
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

pub(super) fn block_on<T>(f: impl std::future::Future<Output = T>) -> T {
    tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap().block_on(f)
}
