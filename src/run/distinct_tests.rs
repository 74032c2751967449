//! Distinct scenes end to end: a set is never shown the same image twice in a run, the sim
//! answers a scene as a deterministic model would, and the reply cache never answers a repeat.
use std::collections::{HashMap, HashSet};
use std::sync::{Arc, Mutex};

use super::observe::{ObsKey, Observer, World};
use super::runner::{self, Setup};
use super::summary::RunConfig;
use super::testkit::FakeWorld;
use super::tests::{PROFILE, block_on};
use crate::ir::ConceptSet;
use crate::journal::{Phase, Record};
use crate::outcome::Outcome;
use crate::search::{Algo, Params, Space};
use crate::vlm::sim::{Profile, SimModel};
use crate::vlm::{BoxFuture, Model, Query, Reply};

/// A world with `scenes` distinct scenes per set: the seed is taken modulo `scenes`.
struct FewScenes {
    inner: FakeWorld,
    scenes: u64,
}

impl World for FewScenes {
    fn task(&self, set: ConceptSet) -> Result<super::Task, String> {
        self.inner.task(set)
    }

    fn scene(&self, set: ConceptSet, seed: u64) -> Result<crate::scene::Scene, String> {
        let mut scene = self.inner.scene(set, seed % self.scenes)?;
        scene.seed = seed;
        Ok(scene)
    }
}

fn records(dir: &std::path::Path) -> Vec<Record> {
    let text = std::fs::read_to_string(dir.join("journal.jsonl")).unwrap();
    text.lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

/// The images each set showed to the model, with how often each.
fn shown(records: &[Record]) -> HashMap<(Vec<String>, String), usize> {
    let mut out = HashMap::new();
    for r in records.iter().filter(|r| r.outcome.asked_a_model()) {
        *out.entry((r.set.clone(), r.image.clone())).or_default() += 1;
    }
    out
}

fn run(dir: &std::path::Path, scenes: u64, model: Arc<dyn Model>, budget: u64) -> runner::RunReport {
    let d = crate::ir::testkit::numbered(6);
    let world = Arc::new(FewScenes { inner: FakeWorld(d.clone()), scenes });
    let space = Space::new(crate::ir::testkit::lattice(6, 2), 6);
    let mut s = Setup::new(Arc::new(d), world, model, None, dir);
    s.concurrency = 4;
    let params = Params { algo: Algo::Random, budget, beam_budget: budget / 2, samples: 5, ..Params::default() };
    let cfg = RunConfig::new(
        &s.domain,
        std::path::Path::new("/t.rev"),
        "sim:t.toml",
        s.model.as_ref(),
        Default::default(),
        "none",
        params,
    );
    block_on(runner::search(&s, &cfg, &space)).unwrap()
}

fn sim() -> Arc<dyn Model> {
    let d = crate::ir::testkit::numbered(6);
    Arc::new(SimModel { profile: Profile::parse(PROFILE, "t.toml", &d).unwrap() })
}

/// With three scenes per set and five observations each, every set shows its three scenes once
/// and records the other two observations `repeated`: no model asked, not counted in n, and the
/// summary names the sets.
#[test]
fn a_set_with_few_scenes_shows_each_once_and_counts_distinct_images_only() {
    let dir = tempfile::tempdir().unwrap();
    let r = run(dir.path(), 3, sim(), 50);
    let recs = records(dir.path());
    assert_eq!(recs.len(), 50);
    assert!(shown(&recs).values().all(|&n| n == 1), "no image shown twice for a set");
    let repeated: Vec<&Record> = recs.iter().filter(|r| r.outcome == Outcome::Repeated).collect();
    assert_eq!(repeated.len(), 20, "10 sets × (5 observations − 3 scenes)");
    assert!(repeated.iter().all(|r| r.answer.is_none() && r.repeats == super::observe::REPEATS));
    assert!(
        r.summary.sets.iter().all(|s| s.answered + s.unanswered.get(&Outcome::Unparsed).copied().unwrap_or(0) == 3)
    );
    assert_eq!(r.summary.spend.calls, 30, "no model call for a repeated scene");
    assert_eq!(r.summary.repeated_scenes.len(), 10);
    assert!(r.summary.repeated_scenes.iter().all(|row| (row.distinct, row.repeated) == (3, 2)));
    let line = super::summary::repeated_line(&r.summary.repeated_scenes).unwrap();
    assert!(line.starts_with("10 sets could not show distinct scenes (n counts distinct images only"), "{line}");
    // A scene is re-drawn with the next seed before it is given up: seeds 0, 1, 2 (mod 3) all
    // turn up as a set's first three observations, whatever order they were drawn in.
    let again = run(&dir.path().join("again"), 3, sim(), 50);
    assert_eq!(again.summary, r.summary, "which observation re-draws does not depend on timing");
    // The field is optional when read: a summary written before it loads.
    let mut v = serde_json::to_value(&r.summary).unwrap();
    v.as_object_mut().unwrap().remove("repeated_scenes");
    let old: super::summary::Summary = serde_json::from_value(v).unwrap();
    assert!(old.repeated_scenes.is_empty());
}

/// Where seeds collide (two seeds, one scene) the observation re-draws with the next seed
/// instead of repeating; with plenty of scenes, nothing is recorded `repeated`.
#[test]
fn a_repeated_scene_is_drawn_again_with_the_next_seed() {
    let dir = tempfile::tempdir().unwrap();
    let r = run(dir.path(), 1 << 40, sim(), 60);
    let recs = records(dir.path());
    assert!(shown(&recs).values().all(|&n| n == 1));
    assert!(r.summary.repeated_scenes.is_empty());
    assert!(recs.iter().all(|r| r.repeats == 0 && r.outcome != Outcome::Repeated));
}

/// The sim answers from the scene: two seeds that draw the same scene get the same reply, and
/// its error rate holds across distinct scenes.
#[test]
fn the_sim_gives_the_same_answer_for_the_same_scene() {
    let d = crate::ir::testkit::numbered(6);
    let world: Arc<dyn World> = Arc::new(FewScenes { inner: FakeWorld(d.clone()), scenes: 7 });
    let observer = Observer::new(Arc::new(d.clone()), world, None);
    let model = sim();
    let set = d.parse_set(&["c2"]).unwrap();
    let key = ObsKey { phase: Phase::Search, set, index: 0 };
    let mut by_image: HashMap<String, HashSet<String>> = HashMap::new();
    let mut wrong = 0;
    for seed in 0..700 {
        let o = block_on(observer.observe(model.as_ref(), key, seed, None)).unwrap();
        by_image.entry(o.record.image.clone()).or_default().insert(o.record.raw.clone());
        wrong += u32::from(o.outcome == Outcome::Wrong);
    }
    assert_eq!(by_image.len(), 7);
    assert!(by_image.values().all(|replies| replies.len() == 1), "one scene, one answer");
    // Across many distinct scenes, {c2} is wrong at its planted 0.4 (less the 5 % unparsed).
    let world: Arc<dyn World> = Arc::new(FakeWorld(d.clone()));
    let observer = Observer::new(Arc::new(d.clone()), world, None);
    let wrong_many = (0..2000)
        .filter(|&seed| block_on(observer.observe(model.as_ref(), key, seed, None)).unwrap().outcome == Outcome::Wrong)
        .count();
    assert!((640..880).contains(&wrong_many), "{wrong_many}");
    assert!(wrong % 100 == 0, "each of the 7 scenes answered the same way 100 times: {wrong}");
}

/// A model behind the reply cache, as the API clients use it: it records whether each query was
/// served from the cache.
struct Cached {
    inner: Arc<dyn Model>,
    cache: crate::vlm::cache::ReplyCache,
    hits: Mutex<u32>,
}

impl Model for Cached {
    fn id(&self) -> String {
        self.inner.id()
    }

    fn ask<'a>(&'a self, query: &'a Query) -> BoxFuture<'a, Reply> {
        Box::pin(async move {
            let key = self.cache.key(&query.image_hash, &query.prompt);
            if let Some(hit) = self.cache.get(&key) {
                *self.hits.lock().unwrap() += 1;
                return hit;
            }
            let reply = self.inner.ask(query).await;
            self.cache.put(&key, &reply).unwrap();
            reply
        })
    }
}

/// Within a run the reply cache never answers a repeat (the repeat is never asked); another run
/// with the same scenes is served from it as before.
#[test]
fn the_reply_cache_never_answers_a_within_run_repeat() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let model = |c: &std::path::Path| {
        Arc::new(Cached {
            inner: sim(),
            cache: crate::vlm::cache::ReplyCache::new(c, &sim().id()),
            hits: Mutex::new(0),
        })
    };
    let first = model(&cache);
    let r = run(&dir.path().join("a"), 2, first.clone(), 50);
    assert_eq!(*first.hits.lock().unwrap(), 0, "no within-run repeat reached the cache");
    assert_eq!(r.summary.spend.cached, 0);
    assert!(records(&dir.path().join("a")).iter().all(|rec| !rec.cached));
    // Another run, the same scenes: cross-run hits are served.
    let second = model(&cache);
    let again = run(&dir.path().join("b"), 2, second.clone(), 50);
    let parsed =
        r.summary.spend.calls - r.summary.metrics.unanswered.get(&Outcome::Unparsed).copied().unwrap_or(0) as u64;
    assert_eq!(*second.hits.lock().unwrap() as u64, parsed, "every parsed reply of the first run is served");
    assert_eq!(again.summary.spend.cached, parsed);
}
