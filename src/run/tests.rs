//! End-to-end runs on synthetic domains: sim model, journal, resume, validation.
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::runner::{self, Setup};
use super::summary;
use super::summary::RunConfig;
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
    let mut s = Setup::new(Arc::new(d), world, Arc::new(model), None, out);
    s.concurrency = concurrency;
    (s, space)
}

pub(super) fn config(s: &Setup, algo: Algo) -> RunConfig {
    let params = Params { algo, budget: 200, beam_budget: 100, ..Params::default() };
    RunConfig::new(&s.domain, Path::new("/t.rev"), "sim:t.toml", s.model.as_ref(), Default::default(), "none", params)
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

/// A run folder `run` as a run killed after writing `journal` would leave it: `full`'s
/// configuration and that journal prefix. Returns the folder and how many whole lines it kept.
pub(super) fn killed_copy(full: &Path, journal: &[u8], run: &Path) -> (PathBuf, u64) {
    std::fs::create_dir_all(run).unwrap();
    std::fs::copy(full.join("config.json"), run.join("config.json")).unwrap();
    std::fs::write(run.join("journal.jsonl"), journal).unwrap();
    (run.to_path_buf(), journal.iter().filter(|&&b| b == b'\n').count() as u64)
}

/// A run killed at any byte of its journal resumes to the uninterrupted run's summary (at
/// another concurrency: picks in rounds of `batch`, which the run records).
fn resume_after_a_crash_at_any_point_gives_the_same_summary(algo: Algo, batch: usize) {
    use rand::{RngExt, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("full");
    let (s, space) = setup(&full, 8);
    let mut cfg = config(&s, algo);
    cfg.params.batch = batch;
    let reference = block_on(runner::search(&s, &cfg, &space)).unwrap().summary;
    let journal = std::fs::read(full.join("journal.jsonl")).unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let cuts =
        [0, 1, journal.len() - 1, journal.len()].into_iter().chain((0..6).map(|_| rng.random_range(0..journal.len())));
    for (k, cut) in cuts.enumerate() {
        let (run, kept) = killed_copy(&full, &journal[..cut], &dir.path().join(format!("crash{k}")));
        let (s, space) = setup(&run, 3);
        let r = block_on(runner::search(&s, &cfg, &space)).unwrap();
        assert_eq!(r.summary, reference, "cut at byte {cut}");
        assert_eq!(r.replayed, kept, "every finished observation is replayed, none asked twice");
        assert_eq!(r.dropped_torn_line, cut > 0 && journal[cut - 1] != b'\n');
        assert_eq!(journal_lines(&run), journal_lines(&full));
    }
}

#[test]
fn gpts_resumes_after_a_crash_at_any_point() {
    resume_after_a_crash_at_any_point_gives_the_same_summary(Algo::Gpts, 1);
}

#[test]
fn interact_resumes_after_a_crash_at_any_point() {
    resume_after_a_crash_at_any_point_gives_the_same_summary(Algo::Interact, 1);
}

/// Issue 29: a parallel interact run (every call filled to a width of 8) resumed at another
/// concurrency equals the uninterrupted run.
#[test]
fn parallel_interact_resumes_after_a_crash_at_any_point() {
    resume_after_a_crash_at_any_point_gives_the_same_summary(Algo::Interact, 8);
}

#[test]
fn a_different_configuration_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (s, space) = setup(dir.path(), 4);
    block_on(runner::search(&s, &config(&s, Algo::Random), &space)).unwrap();
    let mut other = config(&s, Algo::Random);
    other.params.seed = 9;
    let e = block_on(runner::search(&s, &other, &space)).err().unwrap().to_string();
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
    // This test is about what a resume does with failed calls, not about stopping early.
    s.max_api_errors = 0;
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

/// Every model query and image prompt a run makes, and the threads renders ran on.
#[derive(Default)]
struct Log {
    prompts: std::sync::Mutex<Vec<(u64, String, String)>>,
    image_prompts: std::sync::Mutex<Vec<(u64, String)>>,
    render_threads: std::sync::Mutex<Vec<String>>,
}

/// A renderer that records what it is given and draws a fixed image per scene; scenes of a set
/// holding `block` are refused like an image generator's safety filter.
struct Recorder {
    log: Arc<Log>,
    block: Option<String>,
    blocking: bool,
}

impl crate::render::Renderer for Recorder {
    fn id(&self) -> String {
        "recorder".into()
    }
    fn render<'a>(
        &'a self,
        scene: &'a crate::scene::Scene,
        prompt: &'a str,
    ) -> crate::net::BoxFuture<'a, Result<crate::render::Rendered, crate::render::RenderError>> {
        Box::pin(async move {
            self.log.image_prompts.lock().unwrap().push((scene.seed, prompt.to_string()));
            let name = std::thread::current().name().unwrap_or("").to_string();
            self.log.render_threads.lock().unwrap().push(name);
            if self.block.as_ref().is_some_and(|b| scene.concepts.contains(b)) {
                return Err(crate::render::RenderError::blocked(
                    "the image was blocked by the provider (IMAGE_SAFETY)",
                ));
            }
            Ok(crate::render::Rendered {
                png: format!("png of {}", scene.seed).into_bytes(),
                cached: false,
                visibility: None,
            })
        })
    }
    fn blocking(&self) -> bool {
        self.blocking
    }
}

/// The sim model, recording every query it is asked.
struct Asked {
    sim: SimModel,
    log: Arc<Log>,
}

impl crate::vlm::Model for Asked {
    fn id(&self) -> String {
        self.sim.id()
    }
    fn ask<'a>(&'a self, q: &'a crate::vlm::Query) -> crate::vlm::BoxFuture<'a, crate::vlm::Reply> {
        Box::pin(async move {
            let key = q.truth.as_ref().map_or(0, |t| t.key);
            self.log.prompts.lock().unwrap().push((key, q.prompt.clone(), q.image_hash.clone()));
            self.sim.answer(q)
        })
    }
}

/// Bug: `ask` built its own image prompt (`emit::prompt`) while a search sent another one. Now
/// both observe through one pipeline: for the seed of any journaled observation, `ask`'s path
/// gives the image generator the text `revelio emit prompt` prints, and the model the same image
/// and prompt the search sent.
#[test]
fn ask_observes_exactly_what_a_search_sends() {
    use crate::run::observe::{DomainWorld, ObsKey, Observer};
    let d = crate::lattice::testkit::driving();
    let dir = tempfile::tempdir().unwrap();
    let log = Arc::new(Log::default());
    let world: Arc<dyn crate::run::World> = Arc::new(DomainWorld::new(&d));
    let sim = || SimModel { profile: Profile::parse("name = \"t\"\nbase_error = 0.3\n", "t.toml", &d).unwrap() };
    let model = Arc::new(Asked { sim: sim(), log: log.clone() });
    let renderer = Arc::new(Recorder { log: log.clone(), block: None, blocking: false });
    let (space, _) =
        runner::search_space(crate::lattice::Lattice::enumerate(&d, 3).sets, d.concepts.len(), world.as_ref());
    let mut s = Setup::new(Arc::new(d.clone()), world.clone(), model.clone(), Some(renderer.clone()), dir.path());
    s.concurrency = 4;
    let params = Params { algo: Algo::Random, budget: 20, beam_budget: 10, ..Params::default() };
    let cfg =
        RunConfig::new(&d, Path::new("/d.rev"), "sim:t.toml", model.as_ref(), Default::default(), "recorder", params);
    block_on(runner::search(&s, &cfg, &space)).unwrap();
    let searched_prompts = log.image_prompts.lock().unwrap().clone();
    let searched = log.prompts.lock().unwrap().clone();
    assert_eq!(searched.len(), 20);
    let journal: Vec<crate::journal::Record> = std::fs::read_to_string(dir.path().join("journal.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let observer = Observer::new(Arc::new(d.clone()), world, Some(renderer));
    for r in journal.iter().take(5) {
        let set = d.parse_set(&r.set).unwrap();
        let scene = crate::sample::sample(&d, set, r.seed).unwrap();
        let emitted = crate::emit::prompt(&d, &scene).unwrap();
        let (_, sent_image_prompt) = searched_prompts.iter().find(|(seed, _)| *seed == r.seed).unwrap();
        assert_eq!(*sent_image_prompt, emitted, "the image generator gets what `revelio emit prompt` prints");
        let key = ObsKey { phase: crate::journal::Phase::Search, set, index: 0 };
        let asked = block_on(observer.observe(model.as_ref(), key, r.seed, None)).unwrap();
        assert_eq!(asked.record.image, r.image, "same image");
        assert_eq!(asked.record.prompt, r.prompt, "same model prompt");
        assert_eq!(asked.record.raw, r.raw, "same (simulated) reply");
        let (_, again) = log.image_prompts.lock().unwrap().last().cloned().unwrap();
        assert_eq!(again, emitted);
    }
}

/// Bug: the builtin renderer ran on the async workers. A blocking renderer whose second frame
/// waits for a model call to finish deadlocks a one-worker runtime if renders run inline; on the
/// render threads the model call proceeds and the frame completes.
#[test]
fn a_blocking_renderer_never_holds_an_async_worker() {
    struct Stalling {
        renders: std::sync::atomic::AtomicUsize,
        answered: Arc<(std::sync::Mutex<bool>, std::sync::Condvar)>,
        threads: std::sync::Mutex<Vec<String>>,
    }
    impl crate::render::Renderer for Stalling {
        fn id(&self) -> String {
            "stalling".into()
        }
        fn render<'a>(
            &'a self,
            scene: &'a crate::scene::Scene,
            _: &'a str,
        ) -> crate::net::BoxFuture<'a, Result<crate::render::Rendered, crate::render::RenderError>> {
            Box::pin(async move {
                self.threads.lock().unwrap().push(std::thread::current().name().unwrap_or("").to_string());
                if self.renders.fetch_add(1, std::sync::atomic::Ordering::SeqCst) > 0 {
                    let (lock, cv) = &*self.answered;
                    let (done, timeout) = cv
                        .wait_timeout_while(lock.lock().unwrap(), std::time::Duration::from_secs(10), |a| !*a)
                        .unwrap();
                    if timeout.timed_out() && !*done {
                        return Err(crate::render::RenderError::new("stalled: no model call finished while rendering"));
                    }
                }
                Ok(crate::render::Rendered { png: vec![scene.seed as u8], cached: false, visibility: None })
            })
        }
        fn blocking(&self) -> bool {
            true
        }
    }
    struct Signals {
        sim: SimModel,
        answered: Arc<(std::sync::Mutex<bool>, std::sync::Condvar)>,
    }
    impl crate::vlm::Model for Signals {
        fn id(&self) -> String {
            self.sim.id()
        }
        fn ask<'a>(&'a self, q: &'a crate::vlm::Query) -> crate::vlm::BoxFuture<'a, crate::vlm::Reply> {
            Box::pin(async move {
                // An HTTP call: it needs the runtime to make progress.
                tokio::time::sleep(std::time::Duration::from_millis(5)).await;
                let (lock, cv) = &*self.answered;
                *lock.lock().unwrap() = true;
                cv.notify_all();
                self.sim.answer(q)
            })
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let (mut s, space) = setup(dir.path(), 2);
    let answered = Arc::new((std::sync::Mutex::new(false), std::sync::Condvar::new()));
    let renderer = Arc::new(Stalling { renders: 0.into(), answered: answered.clone(), threads: Default::default() });
    let sim = SimModel { profile: Profile::parse(PROFILE, "t.toml", &s.domain).unwrap() };
    s.model = Arc::new(Signals { sim, answered });
    s.renderer = Some(renderer.clone());
    let mut cfg = config(&s, Algo::Random);
    cfg.params.budget = 10;
    cfg.params.beam_budget = 5;
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
    rt.block_on(runner::search(&s, &cfg, &space)).unwrap();
    let threads = renderer.threads.lock().unwrap();
    assert_eq!(threads.len(), 10);
    assert!(threads.iter().all(|t| t.starts_with("revelio-render-")), "{threads:?}");
}

/// Bug: a higher `--budget` on an existing run folder was refused. Now it extends the run: every
/// observation of the smaller run is replayed, and the result is the larger run's.
#[test]
fn raising_the_budget_extends_a_run() {
    let dir = tempfile::tempdir().unwrap();
    for algo in [Algo::Random, Algo::Beam, Algo::Gpts] {
        let (small, big) = (dir.path().join(format!("{algo:?}")), dir.path().join(format!("{algo:?}-fresh")));
        let (s, space) = setup(&small, 4);
        let mut cfg = config(&s, algo);
        cfg.params.budget = 100;
        cfg.params.beam_budget = 50;
        let first = block_on(runner::search(&s, &cfg, &space)).unwrap();
        cfg.params.budget = 250;
        let extended = block_on(runner::search(&s, &cfg, &space)).unwrap();
        assert_eq!(extended.replayed, 100, "{algo:?}: the smaller run's observations are all reused");
        assert_eq!(extended.summary.metrics.inferences, 250);
        let (f, _) = setup(&big, 4);
        let fresh = block_on(runner::search(&f, &cfg, &space)).unwrap();
        assert_eq!(extended.summary, fresh.summary, "{algo:?}");
        assert_eq!(first.history[..], fresh.history[..first.history.len()], "{algo:?}");
        let written: RunConfig =
            serde_json::from_str(&std::fs::read_to_string(small.join("config.json")).unwrap()).unwrap();
        assert_eq!(written.params.budget, 250);
        // Going back down would silently cut the run short: refused.
        cfg.params.budget = 100;
        let e = block_on(runner::search(&s, &cfg, &space)).err().unwrap().to_string();
        assert!(e.contains("with `--budget 100`: it is a run of 250 model calls and has made 250"), "{e}");
    }
}

/// Bug: validation ranked tied sets by a seeded shuffle, the search table by answered count and
/// set order. Now validation takes the table's order; each setting writes its own file.
#[test]
fn validation_follows_the_search_table_and_keeps_every_setting() {
    let dir = tempfile::tempdir().unwrap();
    let (s, space) = setup(dir.path(), 4);
    let cfg = config(&s, Algo::Beam);
    let r = block_on(runner::search(&s, &cfg, &space)).unwrap();
    let modes = &r.summary.failure_modes;
    let tied = modes.windows(2).filter(|w| w[0].fr == w[1].fr).count();
    assert!(modes.len() >= 4 && tied >= 2, "the profile should give tied failure modes: {modes:?}");
    let v = block_on(runner::validate(&s, &cfg, &r.summary, modes.len(), 3, None)).unwrap();
    let order: Vec<&Vec<String>> = v.sets.iter().map(|x| &x.search.concepts).collect();
    assert_eq!(order, modes.iter().map(|m| &m.concepts).collect::<Vec<_>>());
    let first = std::fs::read(dir.path().join(summary::validation_file(modes.len(), 3, None))).unwrap();
    block_on(runner::validate(&s, &cfg, &r.summary, 2, 6, None)).unwrap();
    assert_eq!(std::fs::read(dir.path().join(summary::validation_file(modes.len(), 3, None))).unwrap(), first);
    assert!(dir.path().join("validation-top2-samples6.json").exists());
}

/// Bug: with stderr not a terminal the progress bar was hidden and a log showed nothing. Plain
/// lines now report progress, with the effective concurrency.
#[test]
fn progress_goes_to_plain_lines_when_there_is_no_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let (mut s, space) = setup(dir.path(), 3);
    let lines = Arc::new(std::sync::Mutex::new(Vec::new()));
    s.progress =
        crate::run::progress::ProgressTo::Lines { every: std::time::Duration::from_millis(20), to: lines.clone() };
    block_on(runner::search(&s, &config(&s, Algo::Beam), &space)).unwrap();
    let text = String::from_utf8(lines.lock().unwrap().clone()).unwrap();
    let last = text.lines().last().unwrap_or_default();
    assert!(last.starts_with("search: 200/200 inferences · "), "{text}");
    assert!(last.contains(" · concurrency 3 · "), "{last}");
    assert!(last.contains(" failure modes · "), "a search counts its failure modes: {last}");
}

/// Issue 30: progress lines of probe and transfer counted "0 failure modes" they never look
/// for; a phase says what it counts, or counts nothing.
#[test]
fn progress_lines_say_what_the_phase_counts() {
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build().unwrap();
    let _guard = rt.enter();
    let line = |label: &'static str| {
        let to = Arc::new(std::sync::Mutex::new(Vec::new()));
        let mut p = crate::run::progress::Progress::start(
            &crate::run::progress::ProgressTo::Lines { every: std::time::Duration::from_secs(60), to: to.clone() },
            label,
            1500,
            4,
        );
        p.finish();
        String::from_utf8(to.lock().unwrap().clone()).unwrap()
    };
    assert!(line("probe").starts_with("probe: 0/1,500 inferences · 0 tokens · "), "{}", line("probe"));
    assert!(!line("transfer").contains("failure modes"), "{}", line("transfer"));
    assert!(line("validate").contains(" · 0 sets failing at FR ≥ 80% · "), "{}", line("validate"));
}

/// Issue 12: a blocked image is an outcome of its own — journaled, no model call, not an
/// answer, counted in the summary — and the search goes on.
#[test]
fn a_blocked_image_is_recorded_and_the_run_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let (mut s, space) = setup(dir.path(), 4);
    let log = Arc::new(Log::default());
    let sim = SimModel { profile: Profile::parse(PROFILE, "t.toml", &s.domain).unwrap() };
    s.model = Arc::new(Asked { sim, log: log.clone() });
    s.renderer = Some(Arc::new(Recorder { log: log.clone(), block: Some("c3".into()), blocking: true }));
    let cfg = config(&s, Algo::Random);
    let r = block_on(runner::search(&s, &cfg, &space)).unwrap();
    let blocked = r.summary.metrics.unanswered.get(&Outcome::ImageBlocked).copied().unwrap_or(0);
    assert!(blocked > 0 && blocked % 5 == 0, "{:?}", r.summary.metrics);
    assert_eq!(r.summary.metrics.inferences, 200);
    assert_eq!(log.prompts.lock().unwrap().len() as u64, 200 - blocked, "no model call for a blocked image");
    let text = std::fs::read_to_string(dir.path().join("journal.jsonl")).unwrap();
    let records: Vec<crate::journal::Record> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    for rec in records.iter().filter(|r| r.set.contains(&"c3".to_string())) {
        assert_eq!((rec.outcome, rec.answer, rec.image.as_str()), (Outcome::ImageBlocked, None, ""));
        assert!(rec.raw.contains("IMAGE_SAFETY"), "{}", rec.raw);
    }
    assert!(r.summary.failure_modes.iter().all(|m| !m.concepts.contains(&"c3".to_string())));
    assert_eq!(r.summary.spend.calls, 200 - blocked);
    // A resume replays the blocks like any other outcome.
    let again = block_on(runner::search(&s, &cfg, &space)).unwrap();
    assert_eq!(again.replayed, 200);
}

/// Issue 12: a run in which every call fails stops after `max_api_errors` in a row, with the
/// last error; what it did is journaled and the same command resumes it.
#[test]
fn repeated_api_errors_stop_the_run_and_it_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let (mut s, space) = setup(dir.path(), 4);
    let sim = || SimModel { profile: Profile::parse(PROFILE, "t.toml", &s.domain).unwrap() };
    let outage = Arc::new(Outage { sim: sim(), down: true.into() });
    s.model = outage.clone();
    s.max_api_errors = 10;
    let cfg = config(&s, Algo::Gpts);
    let e = block_on(runner::search(&s, &cfg, &space)).err().unwrap();
    assert_eq!(e.exit_code(), 1);
    assert!(e.resumable());
    assert!(
        e.to_string().starts_with("stopped after 10 model calls in a row failed; the last: 503 service unavailable"),
        "{e}"
    );
    let lines = journal_lines(dir.path());
    assert!((10..=13).contains(&lines.len()), "the calls in flight finish and are journaled: {}", lines.len());
    outage.down.store(false, std::sync::atomic::Ordering::SeqCst);
    let up = block_on(runner::search(&s, &cfg, &space)).unwrap();
    let fresh = tempfile::tempdir().unwrap();
    let (f, _) = setup(fresh.path(), 4);
    assert_eq!(up.summary, block_on(runner::search(&f, &config(&f, Algo::Gpts), &space)).unwrap().summary);
    assert_eq!(runner::api_error_warning(0, 200), None);
    assert!(runner::api_error_warning(20, 200).unwrap().starts_with("10% of the observations (20 of 200)"));
}

/// A Ctrl-C (the stop handle) lets the calls in flight finish and journals them.
#[test]
fn a_stop_request_journals_the_calls_in_flight() {
    let dir = tempfile::tempdir().unwrap();
    let (s, space) = setup(dir.path(), 4);
    s.stop.request(crate::run::StopReason::Interrupted);
    let e = block_on(runner::search(&s, &config(&s, Algo::Random), &space)).err().unwrap();
    assert_eq!(e.exit_code(), 130);
    assert_eq!(journal_lines(dir.path()).len(), 0, "nothing new starts after a stop");
}

/// Issue 12: the endpoint is part of what a run is; a resume against another one is refused,
/// and a folder of the first run format (scenes seeded by the path as typed) is refused too.
#[test]
fn resumes_check_the_endpoint_and_the_folder_format() {
    let dir = tempfile::tempdir().unwrap();
    let (s, space) = setup(dir.path(), 4);
    let mut cfg = config(&s, Algo::Random);
    cfg.endpoint = Some("http://localhost:8000/v1".into());
    block_on(runner::search(&s, &cfg, &space)).unwrap();
    cfg.endpoint = Some("http://localhost:9000/v1".into());
    let e = block_on(runner::search(&s, &cfg, &space)).err().unwrap().to_string();
    assert!(e.contains("`endpoint` was \"http://localhost:8000/v1\", now \"http://localhost:9000/v1\""), "{e}");
    // Where the domain file is and how `--model` was spelled may change.
    cfg.endpoint = Some("http://localhost:8000/v1".into());
    cfg.domain_file = "/elsewhere/t.rev".into();
    cfg.model_spec = "sim:./t.toml".into();
    assert_eq!(block_on(runner::search(&s, &cfg, &space)).unwrap().replayed, 200);

    let old = tempfile::tempdir().unwrap();
    let mut v = serde_json::to_value(&cfg).unwrap();
    v.as_object_mut().unwrap().remove("format");
    std::fs::write(old.path().join("config.json"), v.to_string()).unwrap();
    let (o, _) = setup(old.path(), 4);
    let e = block_on(runner::search(&o, &cfg, &space)).err().unwrap().to_string();
    assert!(e.contains("was written by an older revelio (run folder format 1; this one reads format 3)"), "{e}");
}

/// Issue 29: a folder of format 2, whose `--budget` left out the shrink phase, reads as the same
/// run with `budget + shrink`; resumed so, it adds nothing; resumed with its old `--budget` it is
/// refused with what changed and how to go on.
#[test]
fn a_run_of_the_old_budget_rule_reads_as_budget_plus_shrink() {
    let dir = tempfile::tempdir().unwrap();
    let (s, space) = setup(dir.path(), 4);
    let mut cfg = config(&s, Algo::Random);
    cfg.params.budget = 250;
    cfg.params.shrink = 50;
    let first = block_on(runner::search(&s, &cfg, &space)).unwrap();
    let lines = journal_lines(dir.path());
    // Written by the older revelio: format 2, `budget` the search's alone.
    let mut v = serde_json::to_value(&cfg).unwrap();
    v["format"] = 2.into();
    v["params"]["budget"] = 200.into();
    std::fs::write(dir.path().join("config.json"), v.to_string()).unwrap();
    let read = crate::run::summary::read_config(dir.path()).unwrap().unwrap();
    assert_eq!((read.format, read.params.budget, read.params.shrink), (2, 250, 50));
    let (_, summary) = crate::run::summary::load_run(dir.path()).unwrap();
    assert_eq!(summary.metrics.inferences, first.summary.metrics.inferences, "report and compare read it");
    let note = runner::old_rule_note(dir.path(), &read).unwrap();
    assert!(note.contains("its 200 search and 50 shrink calls are `--budget 250 --shrink 50` now"), "{note}");
    let mut old = cfg.clone();
    old.params.budget = 200;
    let e = block_on(runner::search(&s, &old, &space)).err().unwrap().to_string();
    assert!(
        e.contains("with `--budget 200`: it was written when `--budget` left out the shrink phase")
            && e.contains("`--budget 250 --shrink 50` now; leave `--budget` out to go on"),
        "{e}"
    );
    let again = block_on(runner::search(&s, &cfg, &space)).unwrap();
    assert_eq!(again.summary, first.summary);
    assert_eq!(journal_lines(dir.path()), lines, "nothing asked again");
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("config.json")).unwrap()).unwrap();
    assert_eq!((written["format"].as_u64(), written["params"]["budget"].as_u64()), (Some(3), Some(250)));
}
