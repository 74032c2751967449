//! The one observation pipeline: oracle → sample → render → hash → query → outcome → journal.
//!
//! `revelio search`, `revelio validate` and `revelio ask` all observe through [`Observer`], so
//! what `ask` shows is what a search sends: the same scene for the same seed, the same image
//! prompt (the text `revelio emit prompt` prints), the same image bytes and the same model
//! prompt. The steps are public on their own so that later commands compose them without a
//! second copy:
//!
//! - [`Observer::task`]: the oracle's question, options and expected option for a set;
//! - [`Observer::stimulus`]: sample the scene for a seed, build its image prompt, render and hash
//!   it — done once and shown to any number of models (transfer) or prompts (probe);
//! - [`Observer::query`]: the model query for a stimulus and a task;
//! - [`Observer::record`]: the outcome and the journal line of a reply;
//! - [`Observer::observe`]: all of it for one observation, journaled when a journal is given.
//!
//! A scene the image generator blocks (a safety filter, a text-only reply) is an observation of
//! its own: outcome `image_blocked`, no model call, not an answer.
//!
//! The visibility guard: when the renderer measures visibility (the builtin one does), a scene in
//! which an entity a concept placed is not visible by the domain's thresholds (`visible` items)
//! is sampled again with the next seed (`seed + 1`, `seed + 2`, …) up to [`RESAMPLES`] times. If
//! every scene tried hides one, the observation's outcome is `invisible`: no model is asked, the
//! last image and its figures are journaled. Like `image_blocked` it takes its slot among the
//! set's observations (so it counts against the search budget: a set the renderer cannot show
//! still costs its rendering and cannot be searched forever), but it is neither a failure nor a
//! success and not a model call.
//!
//! Distinct scenes: one scene is one piece of evidence, so a run never shows a set the same image
//! twice. Given the run's [`Shown`] register, [`Observer::distinct_stimulus`] treats a scene whose
//! image hash (the scene's content hash without a renderer) the set has already shown like a
//! hidden one: it samples again with the next seed, up to [`REPEATS`] times. If every scene tried
//! repeats one, the observation's outcome is `repeated`: no model is asked, and like `invisible`
//! it takes its slot but counts neither as a failure nor as a success, so a set's n counts
//! distinct images only.
use std::sync::Arc;

use crate::hash::sha256_hex as sha256;
use crate::ir::{ConceptSet, Domain};
use crate::journal::{Journal, JournalError, Phase, Record};
use crate::outcome::{Answer, Outcome};
use crate::render::{EntityVisibility, Renderer};
use crate::scene::{Scene, SceneEntity};
use crate::vlm::cost::Purse;
use crate::vlm::{Model, Query, Reply, Truth};

use super::distinct::Shown;
use super::render_pool::RenderPool;

/// The code for an entity a concept places that draws nothing, so that no renderer figure can
/// say whether it is seen; `allow R0108` (with a reason) accepts it, in the guard too.
pub const UNDRAWN: &str = "R0108";

/// How many times a scene with an invisible entity is sampled again before the observation is
/// recorded as `invisible`.
pub const RESAMPLES: u32 = 5;

/// How many times a scene whose image the set has already shown in the run is sampled again
/// before the observation is recorded as `repeated`.
pub const REPEATS: u32 = 5;

/// Where an observation sits in a run: the journal's key.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObsKey {
    pub phase: Phase,
    pub set: ConceptSet,
    /// Observation index within the set and phase.
    pub index: u32,
}

/// What the model is asked about a set, and the right answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Task {
    pub question: String,
    pub options: Vec<String>,
    /// The options' identifiers (`stop`, `yes`), in the same order: a sim profile's planted
    /// `answer` names one.
    pub option_names: Vec<String>,
    pub expected: u32,
}

/// Ground truth and scenes for concept sets: the domain's oracle and sampler in a run.
pub trait World: Send + Sync {
    fn task(&self, set: ConceptSet) -> Result<Task, String>;
    fn scene(&self, set: ConceptSet, seed: u64) -> Result<Scene, String>;
}

/// The compiled domain's oracle and scene sampler, built once per process.
pub struct DomainWorld {
    oracle: crate::oracle::Oracle<'static>,
    sampler: crate::sample::Sampler<'static>,
}

impl DomainWorld {
    /// The sampler and oracle borrow the domain for the whole process (a run searches one domain),
    /// so the domain is leaked once here rather than re-hashing its sources for every scene.
    pub fn new(domain: &Domain) -> DomainWorld {
        let domain: &'static Domain = Box::leak(Box::new(domain.clone()));
        DomainWorld { oracle: crate::oracle::Oracle::new(domain), sampler: crate::sample::Sampler::new(domain) }
    }
}

impl World for DomainWorld {
    fn task(&self, set: ConceptSet) -> Result<Task, String> {
        let d = self.sampler.domain();
        let v = self.oracle.evaluate(set).map_err(|e| e.to_string())?;
        let q = &d.questions[v.question.index()];
        Ok(Task {
            question: q.text.clone(),
            options: q.options.iter().map(|o| o.text.clone()).collect(),
            option_names: q.options.iter().map(|o| o.name.clone()).collect(),
            expected: v.expected,
        })
    }

    fn scene(&self, set: ConceptSet, seed: u64) -> Result<Scene, String> {
        self.sampler.sample(set, seed).map_err(|e| e.0)
    }
}

/// A sampled, rendered scene: what a model is shown. Rendered once; any number of queries may
/// show it.
#[derive(Debug, Clone)]
pub struct Stimulus {
    pub set: ConceptSet,
    /// The sampler's seed.
    pub seed: u64,
    pub scene: Scene,
    /// The image-generation prompt of the scene (`revelio emit prompt` prints the same text).
    pub image_prompt: String,
    /// The encoded image; `None` without a renderer (the model sees only the prompt) or when the
    /// image generator blocked the scene.
    pub image: Option<Arc<Vec<u8>>>,
    /// SHA-256 of the image, or without a renderer of the scene JSON with its seed left out
    /// ([`scene_hash`]); empty when blocked.
    pub image_hash: String,
    /// The image generator's reason when it refused to draw the scene.
    pub blocked: Option<String>,
    /// The renderer's visibility figures of the image (empty when it cannot measure them).
    pub visibility: Vec<EntityVisibility>,
    /// Scenes sampled again because an entity was not visible (`seed` is the last one).
    pub resamples: u32,
    /// Why the scene is not shown: the entities still not visible after the resamples.
    pub invisible: Option<String>,
    /// Scenes sampled again because the set had already shown their image in the run.
    pub repeats: u32,
    /// Every scene tried repeated an image the set had already shown: it is not shown again.
    pub repeated: bool,
}

/// One finished observation.
#[derive(Debug, Clone)]
pub struct Observation {
    pub key: ObsKey,
    pub outcome: Outcome,
    /// The model's reply; `None` when the image was blocked and no model was asked.
    pub reply: Option<Reply>,
    /// The journal line (appended when the observation was made with a journal).
    pub record: Record,
}

/// Why an observation could not be made. A failed model call is not an error here: it is an
/// observation with outcome `api_error`.
#[derive(Debug, thiserror::Error)]
pub enum ObserveError {
    #[error("{{{set}}} has no ground truth: {message}")]
    Task { set: String, message: String },
    #[error("cannot sample a scene for {{{set}}}: {message}")]
    Scene { set: String, message: String },
    #[error("cannot render {{{set}}}: {message}")]
    Render { set: String, message: String },
    #[error(transparent)]
    Journal(#[from] JournalError),
    /// The caller's hook on the image shown failed (`ask --save` could not write it).
    #[error("{0}")]
    Shown(String),
    /// `--max-cost`: the call's worst case would pass the cap; it was not sent.
    #[error("the spend cap of ${cap:.4} is reached (${spent:.4} spent)")]
    CostCap { cap: f64, spent: f64 },
}

/// What a caller does with the image an observation shows, before the model is asked (so a
/// failed call still leaves it): `revelio ask --save` writes it to a file.
pub type OnImage<'a> = &'a (dyn Fn(&[u8]) -> Result<(), String> + Sync);

/// The observation pipeline of one domain, renderer included.
pub struct Observer {
    domain: Arc<Domain>,
    world: Arc<dyn World>,
    renderer: Option<Arc<dyn Renderer>>,
    /// `--max-cost`: every call reserves its worst case here first ([`Observer::ask`]).
    purse: Option<Arc<Purse>>,
}

impl Observer {
    /// A renderer that computes on the calling thread (the builtin one) is moved onto dedicated
    /// render threads behind a bounded queue, so it never stalls the async workers that carry
    /// the model calls.
    pub fn new(domain: Arc<Domain>, world: Arc<dyn World>, renderer: Option<Arc<dyn Renderer>>) -> Observer {
        let renderer = renderer.map(|r| if r.blocking() { RenderPool::wrap(r) } else { r });
        Observer { domain, world, renderer, purse: None }
    }

    /// The same pipeline with every model call under the spend cap `purse`.
    pub fn with_purse(mut self, purse: Option<Arc<Purse>>) -> Observer {
        self.purse = purse;
        self
    }

    /// Ask `model` one query, under the spend cap when there is one: the call's worst case is
    /// reserved first ([`crate::vlm::cost::Pricing::worst_case`]) and the call is not sent when
    /// it would pass the cap. A model without prices (`sim`) is never capped.
    pub async fn ask(&self, model: &dyn Model, query: &Query) -> Result<Reply, ObserveError> {
        let (Some(purse), Some(pricing)) = (&self.purse, model.pricing()) else {
            return Ok(model.ask(query).await);
        };
        let image = query.image.as_deref().map(|b| crate::render::png_size(b).unwrap_or((4096, 4096)));
        let Some(reservation) = purse.reserve(pricing.worst_case(&query.prompt, image)) else {
            return Err(ObserveError::CostCap { cap: purse.cap(), spent: purse.spent() });
        };
        let reply = model.ask(query).await;
        purse.settle(reservation, if reply.cached { 0.0 } else { reply.usage.cost_usd });
        Ok(reply)
    }

    pub fn domain(&self) -> &Arc<Domain> {
        &self.domain
    }

    fn names(&self, set: ConceptSet) -> String {
        self.domain.set_names(set).join(", ")
    }

    /// The oracle's question, options and expected option for `set`.
    pub fn task(&self, set: ConceptSet) -> Result<Task, ObserveError> {
        self.world.task(set).map_err(|message| ObserveError::Task { set: self.names(set), message })
    }

    /// Sample the scene of `set` for `seed`, build its image prompt, render and hash it; while
    /// the renderer reports an entity a concept placed as not visible, sample again with the
    /// next seed (at most [`RESAMPLES`] times).
    pub async fn stimulus(&self, set: ConceptSet, seed: u64) -> Result<Stimulus, ObserveError> {
        self.distinct_stimulus(set, seed, None).await
    }

    /// [`Observer::stimulus`], and with `shown`, a scene whose image `set` has already shown
    /// in the run is sampled again with the next seed too (at most [`REPEATS`] times); the
    /// image finally shown is registered in `shown`. The seeds tried are `seed`, `seed + 1`, …
    /// whichever guard asked for the next one.
    pub async fn distinct_stimulus(
        &self,
        set: ConceptSet,
        seed: u64,
        shown: Option<&Shown>,
    ) -> Result<Stimulus, ObserveError> {
        let (mut resamples, mut repeats) = (0, 0);
        loop {
            let mut stimulus = self.draw(set, seed.wrapping_add(u64::from(resamples + repeats))).await?;
            (stimulus.resamples, stimulus.repeats) = (resamples, repeats);
            if stimulus.invisible.is_some() {
                // No seed draws an entity with no part at all: say so at once.
                if resamples == RESAMPLES || never_drawn(&self.domain, &stimulus.scene) {
                    return Ok(stimulus);
                }
                resamples += 1;
                continue;
            }
            if let Some(shown) = shown.filter(|_| stimulus.blocked.is_none())
                && !shown.claim(set, &stimulus.image_hash)
            {
                if repeats == REPEATS {
                    stimulus.repeated = true;
                    return Ok(stimulus);
                }
                repeats += 1;
                continue;
            }
            return Ok(stimulus);
        }
    }

    /// One scene for one seed, rendered and judged visible or not.
    async fn draw(&self, set: ConceptSet, seed: u64) -> Result<Stimulus, ObserveError> {
        let scene =
            self.world.scene(set, seed).map_err(|message| ObserveError::Scene { set: self.names(set), message })?;
        // Exactly the text `revelio emit prompt` prints for this scene.
        let image_prompt = crate::emit::prompt(&self.domain, &scene)
            .map_err(|e| ObserveError::Scene { set: self.names(set), message: e.to_string() })?;
        let mut stimulus = Stimulus {
            set,
            seed,
            scene,
            image_prompt,
            image: None,
            image_hash: String::new(),
            blocked: None,
            visibility: Vec::new(),
            resamples: 0,
            invisible: None,
            repeats: 0,
            repeated: false,
        };
        match &self.renderer {
            None => stimulus.image_hash = scene_hash(&stimulus.scene),
            Some(r) => match r.render(&stimulus.scene, &stimulus.image_prompt).await {
                Ok(img) => {
                    stimulus.image_hash = sha256(&img.png);
                    stimulus.image = Some(Arc::new(img.png));
                    if let Some(seen) = img.visibility {
                        stimulus.invisible =
                            unseen(&self.domain, &stimulus.scene, &seen).map(|why| format!("not visible: {why}"));
                        stimulus.visibility = seen;
                    }
                }
                Err(e) if e.blocked => stimulus.blocked = Some(e.message),
                Err(e) => return Err(ObserveError::Render { set: self.names(set), message: e.message }),
            },
        }
        Ok(stimulus)
    }

    /// The query that shows `stimulus` with `task`'s question; `key` seeds the `sim` model's
    /// answer: the image hash (the scene hash without a renderer), so the sim answers as a
    /// deterministic model would — the same scene, the same answer.
    pub fn query(&self, stimulus: &Stimulus, task: &Task) -> Query {
        Query {
            image: stimulus.image.clone(),
            image_hash: stimulus.image_hash.clone(),
            prompt: crate::vlm::prompt::build(&task.question, &task.options),
            options: task.options.clone(),
            truth: Some(Truth {
                set: stimulus.set,
                concepts: self.domain.set_names(stimulus.set).into_iter().map(String::from).collect(),
                expected: task.expected,
                option_names: task.option_names.clone(),
                key: scene_key(&stimulus.image_hash, stimulus.seed),
                statements: Vec::new(),
            }),
        }
    }

    /// The outcome and journal line of a reply (`None`: the image was blocked, an entity was
    /// not visible or the image repeated one the set had shown, nobody asked).
    pub fn record(
        &self,
        key: ObsKey,
        stimulus: &Stimulus,
        task: &Task,
        query: &Query,
        reply: Option<Reply>,
    ) -> Observation {
        let (outcome, raw) = match (&reply, &stimulus.blocked, &stimulus.invisible) {
            (Some(r), _, _) => (Outcome::from_answer(r.answer, task.expected), r.raw.clone()),
            (None, Some(blocked), _) => (Outcome::ImageBlocked, blocked.clone()),
            (None, None, Some(why)) => (Outcome::Invisible, why.clone()),
            (None, None, None) if stimulus.repeated => (
                Outcome::Repeated,
                format!(
                    "repeated: the {} scenes tried all show an image already shown for the set",
                    stimulus.repeats + 1
                ),
            ),
            (None, None, None) => (Outcome::ImageBlocked, String::new()),
        };
        let record = Record {
            phase: key.phase,
            set: self.domain.set_names(key.set).into_iter().map(String::from).collect(),
            obs: key.index,
            seed: stimulus.seed,
            image: stimulus.image_hash.clone(),
            prompt: sha256(query.prompt.as_bytes()),
            raw,
            parsed: match reply.as_ref().map(|r| r.answer) {
                Some(Answer::Option(o)) => Some(o),
                _ => None,
            },
            answer: reply.as_ref().map(|r| r.answer),
            expected: task.expected,
            outcome,
            usage: reply.as_ref().map(|r| r.usage).unwrap_or_default(),
            latency_ms: reply.as_ref().map_or(0, |r| r.latency_ms),
            cached: reply.as_ref().is_some_and(|r| r.cached),
            model: None,
            visibility: stimulus.visibility.clone(),
            resamples: stimulus.resamples,
            repeats: stimulus.repeats,
            attempts: reply.as_ref().map_or(0, |r| r.attempts),
            rate_limited: reply.as_ref().map_or(0, |r| r.rate_limited),
            waited_ms: reply.as_ref().map_or(0, |r| r.waited_ms),
        };
        Observation { key, outcome, reply, record }
    }

    /// One observation, start to end: oracle → sample → render → hash → query → outcome, and,
    /// with a journal, the image stored and the line appended.
    pub async fn observe(
        &self,
        model: &dyn Model,
        key: ObsKey,
        seed: u64,
        journal: Option<&Journal>,
    ) -> Result<Observation, ObserveError> {
        let task = self.task(key.set)?;
        self.observe_task(model, key, seed, &task, journal, None).await
    }

    /// [`Observer::observe`] with the task already looked up (a set's observations share it).
    pub async fn observe_task(
        &self,
        model: &dyn Model,
        key: ObsKey,
        seed: u64,
        task: &Task,
        journal: Option<&Journal>,
        on_image: Option<OnImage<'_>>,
    ) -> Result<Observation, ObserveError> {
        let stimulus = self.stimulus(key.set, seed).await?;
        self.show(model, key, &stimulus, task, journal, on_image).await
    }

    /// Show a stimulus: the image stored (with a journal) and handed to `on_image`, the model
    /// asked unless the scene is not shown (blocked, invisible, repeated), the outcome recorded
    /// and, with a journal, the line appended.
    pub async fn show(
        &self,
        model: &dyn Model,
        key: ObsKey,
        stimulus: &Stimulus,
        task: &Task,
        journal: Option<&Journal>,
        on_image: Option<OnImage<'_>>,
    ) -> Result<Observation, ObserveError> {
        if let (Some(j), Some(png)) = (journal, &stimulus.image) {
            j.store_image(png)?;
        }
        if let (Some(hook), Some(png)) = (on_image, &stimulus.image) {
            hook(png).map_err(ObserveError::Shown)?;
        }
        let query = self.query(stimulus, task);
        let reply = match (&stimulus.blocked, &stimulus.invisible, stimulus.repeated) {
            (None, None, false) => Some(self.ask(model, &query).await?),
            _ => None,
        };
        let observation = self.record(key, stimulus, task, &query, reply);
        if let Some(j) = journal {
            j.append(&observation.record)?;
        }
        Ok(observation)
    }
}

/// The hash that stands for a scene shown without a renderer: SHA-256 of its JSON with the seed
/// left out, so two seeds that sample the same scene give the same hash (the same scene, shown
/// twice).
pub fn scene_hash(scene: &Scene) -> String {
    let mut content = scene.clone();
    content.seed = 0;
    sha256(&serde_json::to_vec(&content).expect("scenes serialise"))
}

/// The `sim` model's key for a scene: the first 64 bits of its image (or scene) hash; the
/// sampler seed when there is no hash (a blocked image, which no model is shown).
pub fn scene_key(image_hash: &str, seed: u64) -> u64 {
    image_hash.get(..16).and_then(|h| u64::from_str_radix(h, 16).ok()).unwrap_or(seed)
}

/// The entities a concept placed that `seen` reports as not visible by the domain's thresholds,
/// with their figures (`None`: all visible). An entity with nothing drawn (no part in its look)
/// cannot be measured: it is named as such, unless the domain accepts it with `allow R0108`.
pub fn unseen(domain: &Domain, scene: &Scene, seen: &[EntityVisibility]) -> Option<String> {
    let accept_undrawn = domain.allow.iter().any(|a| a.code == UNDRAWN);
    let hidden: Vec<String> = scene
        .entities
        .iter()
        .zip(seen)
        .filter(|(e, _)| e.concept.is_some())
        .filter_map(|(e, v)| {
            if e.draws_nothing() {
                return (!accept_undrawn)
                    .then(|| format!("`{}` ({}) draws nothing, so it cannot be measured", e.name, e.kind));
            }
            let t = domain.visibility.threshold(&e.kind, e.concept.as_deref());
            (!t.holds(v.pixels, v.contrast)).then(|| {
                let by = e.drawn_by.as_ref().map(|s| format!(" (drawn by stage `{}`)", s.stage)).unwrap_or_default();
                format!(
                    "`{}` ({}){by} has {} px at contrast {:.3}, needs {} px at {:.3}",
                    e.name, e.kind, v.pixels, v.contrast, t.pixels, t.contrast
                )
            })
        })
        .collect();
    (!hidden.is_empty()).then(|| hidden.join("; "))
}

/// Whether a placed entity of `scene` that draws nothing, and that the domain does not accept
/// undrawn, would draw nothing in every scene: no part to draw (its concept's `shape { … }` or
/// its kind's look, conditions aside) and no `drawn_by`, so resampling cannot help. An entity
/// whose parts all have a `when` that failed here may be drawn with another seed.
pub fn never_drawn(domain: &Domain, scene: &Scene) -> bool {
    if domain.allow.iter().any(|a| a.code == UNDRAWN) {
        return false;
    }
    scene.entities.iter().filter(|e| e.draws_nothing()).any(|e| {
        let Some(c) = e.concept.as_ref().and_then(|c| domain.concepts.iter().find(|k| &k.name == c)) else {
            return false;
        };
        let kind = domain.kinds.iter().find(|k| k.name == e.kind);
        let parts = c.render.shape.as_deref().or(kind.map(|k| k.shape.as_slice())).unwrap_or_default();
        parts.is_empty() && c.render.drawn_by.is_none()
    })
}

/// One line of figures for an entity a concept placed: its pixels and contrast against the
/// threshold the domain sets for it, and whether the guard would show it (`None` for scenery).
/// `e` is the scene's entity that `v` measures. An entity that draws nothing has no figures:
/// the line says so, as the guard and R0108 do, and whether `allow R0108` accepts it.
pub fn figure_line(domain: &Domain, e: &SceneEntity, v: &EntityVisibility) -> Option<String> {
    let concept = e.concept.as_deref()?;
    let head = format!("`{}` ({}, concept `{concept}`)", e.name, e.kind);
    if e.draws_nothing() {
        let verdict = if domain.allow.iter().any(|a| a.code == UNDRAWN) {
            format!("accepted by `allow {UNDRAWN}`")
        } else {
            format!("NOT visible ({UNDRAWN})")
        };
        return Some(format!("{head}: draws nothing, so it cannot be measured: {verdict}"));
    }
    let t = domain.visibility.threshold(&e.kind, Some(concept));
    let verdict = if t.holds(v.pixels, v.contrast) { "visible" } else { "NOT visible" };
    Some(format!(
        "{head}: {} px at contrast {:.3}, needs {} px at {:.3}: {verdict}",
        v.pixels, v.contrast, t.pixels, t.contrast
    ))
}

/// The figure lines of a scene's placed entities, in scene order ([`figure_line`]).
pub fn figure_lines(domain: &Domain, scene: &Scene, seen: &[EntityVisibility]) -> Vec<String> {
    scene.entities.iter().zip(seen).filter_map(|(e, v)| figure_line(domain, e, v)).collect()
}
