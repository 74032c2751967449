//! The evaluator: asked observations of concept sets (indices `k..n` of a set, so more
//! observations of a set continue its earlier ones), each: sample a scene → render → ask the
//! model → compare with the oracle's expected option. Observations of a set, and all sets of a
//! batch, run concurrently up to `concurrency` (a semaphore); every finished observation is
//! appended to the journal at once, and observations already in the journal are replayed instead
//! of asked again.
use std::collections::HashMap;
use std::sync::Arc;

use tokio::sync::Semaphore;

use crate::hash::sha256_hex;
use crate::ir::{ConceptSet, Domain};
use crate::journal::{Journal, Phase, Record};
use crate::render::Renderer;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};

use crate::outcome::{Answer, Outcome, Usage};
use crate::vlm::{Model, Query, Truth};

use crate::search::{Ask, Evaluate, SetStats};

/// What the model is asked about a set, and the right answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Task {
    pub question: String,
    pub options: Vec<String>,
    pub expected: u32,
}

/// Ground truth and scenes for concept sets: the domain's oracle and sampler in a run.
pub trait World: Send + Sync {
    fn task(&self, set: ConceptSet) -> Result<Task, String>;
    fn scene(&self, set: ConceptSet, seed: u64) -> Result<Scene, String>;
}

/// The compiled domain's oracle and scene sampler, built once per run.
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
            expected: v.expected,
        })
    }

    fn scene(&self, set: ConceptSet, seed: u64) -> Result<Scene, String> {
        self.sampler.sample(set, seed).map_err(|e| e.0)
    }
}

/// SplitMix64 finaliser: mixes run seed, phase, set and observation index into one seed.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of one observation: a pure function of the run seed, the phase, the set and the
/// observation index, so a resumed run samples the same scenes. Validation gets its own stream
/// (fresh scenes for the same sets).
pub fn observation_seed(run_seed: u64, phase: Phase, set: ConceptSet, obs: u32) -> u64 {
    let p = match phase {
        Phase::Search => 0x5345_4152_4348,
        Phase::Validate => 0x5641_4c49_4441,
        Phase::Shrink => 0x5348_5249_4e4b,
    };
    let mut h = mix(run_seed ^ p);
    h = mix(h ^ set.0 as u64);
    h = mix(h ^ (set.0 >> 64) as u64);
    mix(h ^ u64::from(obs))
}

type Key = (Phase, ConceptSet, u32);

/// Shared pieces of every observation task.
struct Shared {
    domain: Arc<Domain>,
    world: Arc<dyn World>,
    model: Arc<dyn Model>,
    renderer: Option<Arc<dyn Renderer>>,
    journal: Arc<Journal>,
    seed: u64,
}

pub struct Evaluator {
    shared: Arc<Shared>,
    semaphore: Arc<Semaphore>,
    replay: HashMap<Key, (Outcome, Usage, bool)>,
    pub phase: Phase,
    pub threshold: f64,
    /// Inferences done / failure modes so far (indicatif; hidden when stderr is not a terminal).
    pub progress: indicatif::ProgressBar,
    /// Every set's observations in this process, by phase, for the failure-mode count.
    totals: HashMap<(Phase, ConceptSet), SetStats>,
    failure_modes: usize,
    /// Observations served from the journal instead of the model.
    pub replayed: u64,
    /// Tokens and money of every observation evaluated (replayed ones as journaled).
    pub spend: Spend,
}

/// Tokens and money of a run's observations: the model's usage summed over the journal, so a
/// resumed run reports what the uninterrupted one would.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Spend {
    /// Observations answered by a model call (cache hits included).
    pub calls: u64,
    /// Of the calls, how many the reply cache served (free).
    pub cached: u64,
    pub input_tokens: u64,
    /// Output tokens, thinking included.
    pub output_tokens: u64,
    pub thinking_tokens: u64,
    pub cost_usd: f64,
}

impl Spend {
    pub fn add(&mut self, u: &Usage, cached: bool) {
        self.calls += 1;
        self.cached += u64::from(cached);
        self.input_tokens += u.input_tokens;
        self.output_tokens += u.output_tokens;
        self.thinking_tokens += u.thinking_tokens;
        self.cost_usd += u.cost_usd;
    }

    /// `1 234 input / 567 output tokens, $0.0123` (and the cache hits, if any).
    pub fn line(&self) -> String {
        let cached = if self.cached > 0 { format!(" ({} cached)", self.cached) } else { String::new() };
        format!(
            "{} calls{cached}, {} input / {} output tokens ({} thinking), ${:.4}",
            self.calls, self.input_tokens, self.output_tokens, self.thinking_tokens, self.cost_usd
        )
    }
}

pub struct EvaluatorConfig {
    pub domain: Arc<Domain>,
    pub world: Arc<dyn World>,
    pub model: Arc<dyn Model>,
    pub renderer: Option<Arc<dyn Renderer>>,
    pub journal: Arc<Journal>,
    pub seed: u64,
    pub threshold: f64,
    pub concurrency: usize,
    pub phase: Phase,
}

impl Evaluator {
    pub fn new(c: EvaluatorConfig) -> Result<Evaluator, String> {
        let mut replay = HashMap::new();
        for r in &c.journal.records {
            // A failed call is not a paid answer: a resumed run asks again (the newer line wins).
            if r.outcome == Outcome::ApiError {
                continue;
            }
            let set = c.domain.parse_set(&r.set).map_err(|e| format!("cannot resume from the journal: {e}"))?;
            replay.insert((r.phase, set, r.obs), (r.outcome, r.usage, r.cached));
        }
        Ok(Evaluator {
            shared: Arc::new(Shared {
                domain: c.domain,
                world: c.world,
                model: c.model,
                renderer: c.renderer,
                journal: c.journal,
                seed: c.seed,
            }),
            semaphore: Arc::new(Semaphore::new(c.concurrency.max(1))),
            replay,
            phase: c.phase,
            threshold: c.threshold,
            progress: indicatif::ProgressBar::hidden(),
            totals: HashMap::new(),
            failure_modes: 0,
            replayed: 0,
            spend: Spend::default(),
        })
    }

    /// Count a set's new observations toward the progress bar's failure modes (the shrink phase
    /// re-tests known ones: not counted).
    fn set_done(&mut self, stats: &SetStats) {
        if self.phase == Phase::Shrink {
            return;
        }
        let total = self.totals.entry((self.phase, stats.set)).or_insert_with(|| SetStats::new(stats.set));
        let before = total.is_failure_mode(self.threshold);
        total.merge(stats);
        let after = total.is_failure_mode(self.threshold);
        if before != after {
            if after {
                self.failure_modes += 1
            } else {
                self.failure_modes -= 1
            }
            self.show_progress();
        }
    }

    fn spent(&mut self, usage: &Usage, cached: bool) {
        self.spend.add(usage, cached);
        self.progress.inc(1);
        if usage.cost_usd > 0.0 || usage.input_tokens > 0 {
            self.show_progress();
        }
    }

    fn show_progress(&self) {
        let s = &self.spend;
        self.progress.set_message(format!(
            "{} failure modes · {} tokens · ${:.4}",
            self.failure_modes,
            s.input_tokens + s.output_tokens,
            s.cost_usd
        ));
    }
}

impl Evaluate for Evaluator {
    async fn evaluate(&mut self, asks: &[Ask]) -> Result<Vec<SetStats>, String> {
        let mut stats: Vec<SetStats> = asks.iter().map(|a| SetStats::new(a.set)).collect();
        let mut tasks = tokio::task::JoinSet::new();
        for (i, ask) in asks.iter().enumerate() {
            let set = ask.set;
            let task = Arc::new(self.shared.world.task(set)?);
            let prompt = Arc::new(crate::vlm::prompt::build(&task.question, &task.options));
            for obs in ask.obs.clone() {
                if let Some((o, usage, cached)) = self.replay.get(&(self.phase, set, obs)).cloned() {
                    stats[i].add(o);
                    self.replayed += 1;
                    self.spent(&usage, cached);
                    continue;
                }
                let (shared, sem, phase) = (self.shared.clone(), self.semaphore.clone(), self.phase);
                let (task, prompt) = (task.clone(), prompt.clone());
                tasks.spawn(async move {
                    let _permit = sem.acquire_owned().await.expect("the semaphore is never closed");
                    observe(&shared, phase, set, obs, &task, &prompt).await.map(|o| (i, o))
                });
            }
            if stats[i].observations() == ask.len() {
                self.set_done(&stats[i].clone());
            }
        }
        let mut first_error = None;
        while let Some(joined) = tasks.join_next().await {
            match joined {
                Ok(Ok((i, (outcome, usage, cached)))) => {
                    stats[i].add(outcome);
                    self.spent(&usage, cached);
                    if stats[i].observations() == asks[i].len() {
                        self.set_done(&stats[i].clone());
                    }
                }
                Ok(Err(e)) => {
                    first_error.get_or_insert(e);
                    tasks.abort_all();
                }
                Err(e) if e.is_cancelled() => {}
                Err(e) => {
                    first_error.get_or_insert(format!("an observation task failed: {e}"));
                    tasks.abort_all();
                }
            }
        }
        self.shared.journal.sync()?;
        if let Some(e) = first_error {
            return Err(e);
        }
        Ok(stats)
    }
}

/// One observation: scene → image → model → outcome, journaled.
async fn observe(
    shared: &Shared,
    phase: Phase,
    set: ConceptSet,
    obs: u32,
    task: &Task,
    prompt: &str,
) -> Result<(Outcome, Usage, bool), String> {
    let names = || shared.domain.set_names(set).join(", ");
    let seed = observation_seed(shared.seed, phase, set, obs);
    let scene = shared.world.scene(set, seed).map_err(|e| format!("cannot sample a scene for {{{}}}: {e}", names()))?;
    let (image, image_hash) = match &shared.renderer {
        Some(r) => {
            let image_prompt = scene_prompt(&shared.domain, set);
            let png =
                r.render(&scene, &image_prompt).await.map_err(|e| format!("cannot render {{{}}}: {e}", names()))?.png;
            let hash = shared.journal.store_image(&png)?;
            (Some(Arc::new(png)), hash)
        }
        None => (None, sha256_hex(&serde_json::to_vec(&scene).expect("scenes serialise"))),
    };
    let query = Query {
        image,
        image_hash: image_hash.clone(),
        prompt: prompt.to_string(),
        options: task.options.clone(),
        truth: Some(Truth {
            set,
            concepts: shared.domain.set_names(set).into_iter().map(String::from).collect(),
            expected: task.expected,
            key: seed,
        }),
    };
    let reply = shared.model.ask(&query).await;
    let outcome = Outcome::from_answer(reply.answer, task.expected);
    shared.journal.append(&Record {
        phase,
        set: query.truth.as_ref().map(|t| t.concepts.clone()).unwrap_or_default(),
        obs,
        seed,
        image: image_hash,
        prompt: sha256_hex(prompt.as_bytes()),
        raw: reply.raw,
        parsed: match reply.answer {
            Answer::Option(o) => Some(o),
            _ => None,
        },
        answer: reply.answer,
        expected: task.expected,
        outcome,
        usage: reply.usage,
        latency_ms: reply.latency_ms,
        cached: reply.cached,
    })?;
    Ok((outcome, reply.usage, reply.cached))
}

/// The image-generation prompt of a set: its concepts' prompt snippets in index order (the
/// paper's indoor scenes), falling back to the description.
pub fn scene_prompt(domain: &Domain, set: ConceptSet) -> String {
    set.iter()
        .map(|c| {
            let c = &domain.concepts[c.index()];
            c.render.prompt.as_deref().unwrap_or(&c.description).trim().to_string()
        })
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}
