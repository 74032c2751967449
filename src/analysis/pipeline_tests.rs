//! End to end on the driving domain with sim models: probe and transfer through the observe
//! pipeline, journaled and resumed.
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::probe::{Mechanism, Thresholds, analyse};
use super::reask::{self, Reask};
use crate::ir::{ConceptSet, Domain};
use crate::journal::{Journal, Phase};
use crate::render::{RenderError, Rendered, Renderer};
use crate::run::observe::{DomainWorld, Observer, World};
use crate::run::progress::ProgressTo;
use crate::run::{ObsKey, Stop};
use crate::scene::Scene;
use crate::vlm::sim::{Profile, SimModel};
use crate::vlm::{BoxFuture, Model};

fn driving() -> Domain {
    crate::check::compile_source("domains/driving.rev", include_str!("../../domains/driving.rev"))
        .unwrap_or_else(|d| panic!("domains/driving.rev does not compile: {d:?}"))
}

fn sim(text: &str, d: &Domain) -> Arc<dyn Model> {
    Arc::new(SimModel { profile: Profile::parse(text, "p.toml", d).unwrap() })
}

/// A renderer that counts its renders and draws the scene's seed and concepts as bytes.
struct Counting(AtomicUsize);

impl Renderer for Counting {
    fn id(&self) -> String {
        "counting".into()
    }

    fn render<'a>(&'a self, scene: &'a Scene, _prompt: &'a str) -> BoxFuture<'a, Result<Rendered, RenderError>> {
        self.0.fetch_add(1, Ordering::SeqCst);
        let png = format!("{}:{}", scene.seed, scene.concepts.join(",")).into_bytes();
        Box::pin(async move { Ok(Rendered { png, cached: false, visibility: None }) })
    }
}

fn reask(d: &Domain, dir: &std::path::Path, renderer: Option<Arc<dyn Renderer>>) -> Reask {
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(d));
    let journal = Journal::open(dir).unwrap();
    if journal.config().is_none() {
        journal.write_config(&serde_json::json!({})).unwrap();
    }
    Reask {
        observer: Arc::new(Observer::new(Arc::new(d.clone()), world, renderer)),
        journal: Arc::new(journal),
        seed: 7,
        concurrency: 4,
        stop: Stop::default(),
        progress: ProgressTo::Off,
    }
}

fn sets(d: &Domain, names: &[&[&str]]) -> Vec<ConceptSet> {
    let world = DomainWorld::new(d);
    names
        .iter()
        .map(|n| {
            let s = d.parse_set(n).unwrap();
            assert!(world.task(s).is_ok(), "{n:?} has a ground truth");
            s
        })
        .collect()
}

fn block_on<F: std::future::Future>(f: F) -> F::Output {
    tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap().block_on(f)
}

const PROBE_PROFILE: &str = r#"
name = "planted"
base_error = 0.05
[[mode]]
concepts = ["debris_far"]
error = 0.9
[[mode]]
concepts = ["cyclist"]
error = 0.9
[[mode]]
concepts = ["cone", "weather_wet"]
error = 0.95
[[mode]]
concepts = ["pedestrian"]
error = 0.9
[[mode]]
concepts = ["weather_foggy"]
error = 0.9
[[mode]]
concepts = ["pedestrian", "weather_foggy"]
error = 0.0
[recognition]
debris_far = 0.1
"#;

#[test]
fn probe_classifies_planted_mechanisms_and_lift_signs() {
    let d = driving();
    let dir = tempfile::tempdir().unwrap();
    let model = sim(PROBE_PROFILE, &d);
    let chosen = sets(
        &d,
        &[
            &["debris_far"],
            &["debris_far", "weather_cloudy"],
            &["cyclist"],
            &["cyclist", "weather_cloudy"],
            &["cone"],
            &["cone", "weather_cloudy"],
            &["weather_wet"],
            &["weather_wet", "garbage_bin"],
            &["cone", "weather_wet"],
            &["pedestrian"],
            &["pedestrian", "garbage_bin"],
            &["weather_foggy"],
            &["weather_foggy", "garbage_bin"],
            &["pedestrian", "weather_foggy"],
        ],
    );
    let r = reask(&d, dir.path(), None);
    let t = Thresholds { min_n: 2, ..Thresholds::default() };
    let (probed, _) = block_on(reask::probe(&r, model.clone(), &chosen, 40)).unwrap();
    let a = analyse(&probed, &t);
    let row = |c: &str| a.concepts.iter().find(|r| r.concept == c).unwrap();
    assert_eq!(row("debris_far").mechanism, Some(Mechanism::Recognition), "{:?}", row("debris_far"));
    assert!(row("debris_far").failure.unwrap() > 0.7);
    assert_eq!(row("cyclist").mechanism, Some(Mechanism::Reasoning), "{:?}", row("cyclist"));
    assert!(row("cyclist").failure.unwrap() > 0.7);
    assert_eq!(row("cyclist").recognition, Some(1.0));
    assert_eq!(row("cyclist").marks.unanswered, 0, "every sim statement is parsed");
    let pair = |x: &str, y: &str| a.pairs.iter().find(|p| (p.a == x && p.b == y) || (p.a == y && p.b == x)).unwrap();
    assert!(pair("cone", "weather_wet").lift > 0.3, "{:?}", pair("cone", "weather_wet"));
    assert!(pair("pedestrian", "weather_foggy").lift < -0.3, "{:?}", pair("pedestrian", "weather_foggy"));

    // Journaled under phase `probe`; a second run asks nothing and gets the same answer.
    drop(r);
    let lines = Journal::open(dir.path()).unwrap().records;
    assert_eq!(lines.len(), chosen.len() * 40);
    assert!(lines.iter().all(|l| l.phase == Phase::Probe && l.model.is_none()));
    let r = reask(&d, dir.path(), None);
    let (again, _) = block_on(reask::probe(&r, model, &chosen, 40)).unwrap();
    assert_eq!(again, probed);
    drop(r);
    assert_eq!(Journal::open(dir.path()).unwrap().records.len(), chosen.len() * 40);
}

#[test]
fn probe_statements_are_each_concepts_pair_in_a_seeded_order() {
    let d = driving();
    let s = d.parse_set(&["debris_far", "cyclist"]).unwrap();
    let a = reask::statements(&d, s, 1);
    assert_eq!(a.len(), 4);
    assert_eq!(a.iter().filter(|x| x.positive).count(), 2);
    assert_eq!(a, reask::statements(&d, s, 1));
    let orders: std::collections::HashSet<Vec<bool>> =
        (0..20).map(|k| reask::statements(&d, s, k).iter().map(|x| x.positive).collect()).collect();
    assert!(orders.len() > 1, "the order depends on the seed");
}

#[test]
fn transfer_between_two_sim_profiles_same_images_rendered_once() {
    let d = driving();
    let dir = tempfile::tempdir().unwrap();
    let source = sim(
        "name = \"src\"\nbase_error = 0.0\n[[mode]]\nconcepts = [\"debris_far\"]\nerror = 1.0\n[[mode]]\nconcepts = [\"cyclist\"]\nerror = 1.0\n",
        &d,
    );
    let target = sim(
        "name = \"tgt\"\nbase_error = 0.0\n[[mode]]\nconcepts = [\"debris_far\"]\nerror = 0.95\n[[mode]]\nconcepts = [\"cone\"]\nerror = 1.0\n",
        &d,
    );
    let chosen = sets(&d, &[&["debris_far"], &["cyclist"]]);
    let counting = Arc::new(Counting(AtomicUsize::new(0)));
    let r = reask(&d, dir.path(), Some(counting.clone()));
    let models = vec![source.clone(), target.clone()];
    let (stats, _) = block_on(reask::transfer(&r, &models, &chosen, 20)).unwrap();
    assert_eq!(counting.0.load(Ordering::SeqCst), 2 * 20, "one render per scene for both models");
    assert!(stats[1][0].fr().unwrap() >= 0.6, "the shared mode transfers");
    assert!(stats[1][1].fr().unwrap() < 0.2, "the source-only mode does not");
    assert_eq!(stats[0][1].fr(), Some(1.0));
    let names = |s: ConceptSet| d.set_names(s).into_iter().map(String::from).collect::<Vec<_>>();
    let table = super::transfer::table(
        "src",
        &[source.id(), target.id()],
        0.6,
        20,
        &chosen.iter().map(|&s| names(s)).collect::<Vec<_>>(),
        &[Some(1.0), Some(1.0)],
        &stats,
        &[],
        &[vec![], vec![]],
    );
    assert_eq!(table.targets[1].transfers, 1);
    drop(r);

    // Same image for the same observation on both models, each line naming its model.
    let records = Journal::open(dir.path()).unwrap().records;
    assert_eq!(records.len(), 2 * 2 * 20);
    let mut by_obs: std::collections::HashMap<(Vec<String>, u32), Vec<&crate::journal::Record>> = Default::default();
    for rec in &records {
        assert_eq!(rec.phase, Phase::Transfer);
        by_obs.entry((rec.set.clone(), rec.obs)).or_default().push(rec);
    }
    for recs in by_obs.values() {
        assert_eq!(recs.len(), 2);
        assert_eq!(recs[0].image, recs[1].image);
        assert_eq!(recs[0].seed, recs[1].seed);
        assert_ne!(recs[0].model, recs[1].model);
        assert!(recs.iter().all(|r| r.model.is_some()));
    }

    // Resumed: nothing rendered or asked again; a third model is asked on the same scenes.
    let third = sim("name = \"third\"\nbase_error = 0.0\n", &d);
    let r = reask(&d, dir.path(), Some(counting.clone()));
    let (again, _) = block_on(reask::transfer(&r, &models, &chosen, 20)).unwrap();
    assert_eq!(counting.0.load(Ordering::SeqCst), 40);
    assert_eq!(again[1][0].fr(), stats[1][0].fr());
    let (with_third, _) = block_on(reask::transfer(&r, &[source, target, third], &chosen, 20)).unwrap();
    assert_eq!(counting.0.load(Ordering::SeqCst), 80, "the new model's scenes are rendered once");
    assert_eq!(with_third[2][0].fr(), Some(0.0));
    drop(r);
    let records = Journal::open(dir.path()).unwrap().records;
    let seed_of = |model: &str| {
        let mut v: Vec<(u32, String)> = records
            .iter()
            .filter(|r| r.model.as_deref().is_some_and(|m| m.starts_with(model)) && r.set == ["debris_far"])
            .map(|r| (r.obs, r.image.clone()))
            .collect();
        v.sort();
        v
    };
    assert_eq!(seed_of("sim:third"), seed_of("sim:src"), "the third model saw the same images");
    let key = ObsKey { phase: Phase::Transfer, set: chosen[0], index: 0 };
    assert_eq!(records.iter().find(|r| r.obs == 0 && r.set == ["debris_far"]).unwrap().seed, {
        crate::run::eval::observation_seed(7, key)
    });
}

/// A renderer that draws every entity a concept placed hidden (0 visible pixels).
struct Hiding;

impl Renderer for Hiding {
    fn id(&self) -> String {
        "hiding".into()
    }

    fn render<'a>(&'a self, scene: &'a Scene, _prompt: &'a str) -> BoxFuture<'a, Result<Rendered, RenderError>> {
        let seen = scene
            .entities
            .iter()
            .map(|e| crate::render::EntityVisibility {
                entity: e.name.clone(),
                concept: e.concept.clone(),
                pixels: 0,
                contrast: 0.0,
            })
            .collect();
        let png = format!("{}:{}", scene.seed, scene.concepts.join(",")).into_bytes();
        Box::pin(async move { Ok(Rendered { png, cached: false, visibility: Some(seen) }) })
    }
}

/// A model that counts the questions it is asked.
struct Asked(AtomicUsize, Arc<dyn Model>);

impl Model for Asked {
    fn id(&self) -> String {
        self.1.id()
    }

    fn ask<'a>(&'a self, query: &'a crate::vlm::Query) -> BoxFuture<'a, crate::vlm::Reply> {
        self.0.fetch_add(1, Ordering::SeqCst);
        self.1.ask(query)
    }
}

/// The visibility guard holds in probe and transfer as in a search: a scene whose entity stays
/// hidden after every redraw is recorded `invisible`, costs no call and counts in no rate.
#[test]
fn probe_and_transfer_show_no_model_a_scene_whose_entity_stays_hidden() {
    let d = driving();
    let dir = tempfile::tempdir().unwrap();
    let asked = Arc::new(Asked(AtomicUsize::new(0), sim("name = \"m\"\nbase_error = 0.5\n", &d)));
    let chosen = sets(&d, &[&["debris_far"]]);
    let r = reask(&d, dir.path(), Some(Arc::new(Hiding)));
    let (probed, spend) = block_on(reask::probe(&r, asked.clone(), &chosen, 3)).unwrap();
    let (stats, spends) = block_on(reask::transfer(&r, &[asked.clone() as Arc<dyn Model>], &chosen, 3)).unwrap();
    assert_eq!(asked.0.load(Ordering::SeqCst), 0, "no model saw a scene it could not see");
    assert_eq!((probed[0].answered, probed[0].wrong, spend.calls), (0, 0, 0));
    assert_eq!((stats[0][0].answered(), stats[0][0].fr(), spends[0].calls), (0, None, 0));
    drop(r);
    let records = Journal::open(dir.path()).unwrap().records;
    assert_eq!(records.len(), 6);
    for rec in &records {
        assert_eq!((rec.outcome, rec.answer, rec.resamples), (crate::outcome::Outcome::Invisible, None, 5));
        assert!(rec.raw.starts_with("not visible: "), "{}", rec.raw);
    }
}
