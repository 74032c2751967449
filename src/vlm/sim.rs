//! The offline `sim` model: answers from the ground truth in [`Query::truth`], wrong with a
//! profile's planted failure modes, a base error rate and a rate of unparseable replies. It is the
//! default model for demos, tests and search-quality benchmarks: it costs nothing, and because a
//! reply is a pure function of `Truth::key` a resumed run sees exactly the replies it would have
//! seen.
//!
//! Profile format (TOML):
//! ```toml
//! name = "example"
//! base_error = 0.05   # chance of a wrong answer when no mode matches the set
//! unparsed = 0.0      # chance of a reply that cannot be parsed
//! latency_ms = 0      # artificial delay per call, at most 60000 (one minute)
//! dilution = 0.0      # share of a mode's effect lost per concept in the set beyond the mode's
//! renderer = "none"  # what `revelio bench search` renders this profile's scenes with:
//!                     # "none" (default) or "builtin" (repeated scenes then measured)
//! [[mode]]
//! concepts = ["debris_far", "town_town02"]  # matches a set that holds all of them
//! error = 0.9
//! answer = "go"       # optional: the wrong option it gives (an option name of the domain)
//! [recognition]       # chance the model recognises a concept (default 1.0)
//! debris_far = 0.1
//! ```
//! Probe statements (`revelio probe`) are answered per concept: a recognised concept gets its
//! positive statement marked True and its counterfactual False; an unrecognised one the inverse,
//! so a concept with recognition r has a recognition rate R near r. Whether a concept is
//! recognised is drawn independently of the safety answer, which stays the one the plain prompt
//! gets for the same observation.
//! The most specific matching mode wins (most concepts; ties: the highest error). With
//! `dilution = d`, a set holding k concepts beyond the winning mode's is answered wrongly with
//! chance `base_error + (error − base_error)·(1 − d)^k`: other things in the scene draw the
//! model's attention, so a mode's effect fades in crowded scenes (real models' random 4–5-concept
//! sets fail far less often than the pairs and triples a guided search finds; paper Table 2 and
//! appendix F). The default 0 keeps a mode's error in every superset.
//!
//! **Scenes.** A reply is a pure function of the scene shown ([`crate::vlm::Truth::key`]: the
//! image hash, or the scene hash without a renderer), as a deterministic model's would be: a
//! scene shown twice gets the same answer twice, and the profile's rates hold in expectation
//! over distinct scenes (each scene's draw is independent of every other's). A run never shows
//! a set one image twice (`run::distinct`), so a set's failure rate is measured over distinct
//! scenes.
//!
//! A wrong answer is a uniformly chosen wrong option, unless the winning mode plants one with
//! `answer` ("says go instead of slow"): then it is that option. Where the planted option is the
//! expected one for a set (or the set's question has no such option), the set still errs with
//! the same chance, by a uniformly chosen other option: a set's error rate is always
//! [`Profile::error_for`], which the benchmarks take as the ground truth. Without `answer` the
//! random draws are exactly those of a profile that never had it.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Deserialize;

use crate::ir::{ConceptSet, Domain};
use crate::outcome::{Answer, Usage};
use crate::vlm::{BoxFuture, Model, Query, Reply};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ProfileFile {
    name: String,
    #[serde(default)]
    base_error: f64,
    #[serde(default)]
    unparsed: f64,
    #[serde(default)]
    latency_ms: u64,
    #[serde(default)]
    dilution: f64,
    #[serde(default)]
    renderer: Option<String>,
    #[serde(default)]
    mode: Vec<ModeFile>,
    #[serde(default)]
    recognition: std::collections::BTreeMap<String, f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModeFile {
    concepts: Vec<String>,
    error: f64,
    #[serde(default)]
    answer: Option<String>,
}

/// The longest artificial delay a profile may ask for: real APIs answer within a minute, and a
/// larger value would only make `ask` and `search` hang.
pub const MAX_LATENCY_MS: u64 = 60_000;

/// A planted failure mode: sets holding all of `concepts` are answered wrongly with chance
/// `error`, with the option named `answer` where it is given and wrong for the set.
#[derive(Debug, Clone, PartialEq)]
pub struct Mode {
    pub concepts: ConceptSet,
    pub error: f64,
    pub answer: Option<String>,
}

/// A checked sim profile.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    pub name: String,
    pub base_error: f64,
    pub unparsed: f64,
    pub latency_ms: u64,
    /// Share of a mode's excess error lost per concept beyond the mode's (0 = none).
    pub dilution: f64,
    /// The renderer `revelio bench search` draws this profile's scenes with (`none`, `builtin`).
    pub renderer: String,
    pub modes: Vec<Mode>,
    /// Chance the model recognises a concept in a probe statement (concepts not listed: 1).
    pub recognition: std::collections::BTreeMap<String, f64>,
    /// SHA-256 hex of the profile text, so that editing a profile changes the model id (and a
    /// run folder refuses to resume with different answers).
    pub hash: String,
}

impl Profile {
    /// Parse and check a profile against a domain. `origin` names the file in errors.
    pub fn parse(text: &str, origin: &str, domain: &Domain) -> Result<Profile, String> {
        let file: ProfileFile = toml::from_str(text)
            .map_err(|e| format!("invalid sim profile `{origin}`: {}", e.to_string().trim_end()))?;
        let rate = |what: &str, x: f64| {
            if (0.0..=1.0).contains(&x) {
                Ok(x)
            } else {
                Err(format!("invalid sim profile `{origin}`: `{what}` must be between 0 and 1, got {x}"))
            }
        };
        let base_error = rate("base_error", file.base_error)?;
        let unparsed = rate("unparsed", file.unparsed)?;
        let dilution = rate("dilution", file.dilution)?;
        if file.latency_ms > MAX_LATENCY_MS {
            return Err(format!(
                "invalid sim profile `{origin}`: `latency_ms` must be at most {MAX_LATENCY_MS} (one minute), got {}",
                file.latency_ms
            ));
        }
        let renderer = file.renderer.unwrap_or_else(|| "none".into());
        if !matches!(renderer.as_str(), "none" | "builtin") {
            return Err(format!(
                "invalid sim profile `{origin}`: `renderer` must be \"none\" or \"builtin\", got \"{renderer}\""
            ));
        }
        let mut modes = Vec::with_capacity(file.mode.len());
        for (i, m) in file.mode.iter().enumerate() {
            if m.concepts.is_empty() {
                return Err(format!("invalid sim profile `{origin}`: mode {} has no concepts", i + 1));
            }
            let mut set = ConceptSet::EMPTY;
            for name in &m.concepts {
                set = set.union(domain.parse_set(&[name]).map_err(|e| format!("invalid sim profile `{origin}`: {e}"))?);
            }
            if let Some(a) = &m.answer {
                let mut names: Vec<&str> =
                    domain.questions.iter().flat_map(|q| q.options.iter().map(|o| o.name.as_str())).collect();
                names.sort_unstable();
                names.dedup();
                if !names.contains(&a.as_str()) {
                    let known = names.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ");
                    return Err(format!(
                        "invalid sim profile `{origin}`: mode {} answers `{a}`, which is no option of the domain's questions (options: {known})",
                        i + 1
                    ));
                }
            }
            modes.push(Mode { concepts: set, error: rate("error", m.error)?, answer: m.answer.clone() });
        }
        let mut recognition = std::collections::BTreeMap::new();
        for (name, &r) in &file.recognition {
            domain.parse_set(&[name]).map_err(|e| format!("invalid sim profile `{origin}`: {e}"))?;
            recognition.insert(name.clone(), rate("recognition", r)?);
        }
        let hash = crate::hash::sha256_hex(text.as_bytes());
        Ok(Profile {
            name: file.name,
            base_error,
            unparsed,
            latency_ms: file.latency_ms,
            dilution,
            renderer,
            modes,
            recognition,
            hash,
        })
    }

    /// The distinct failure modes the profile plants: its modes with error ≥ `threshold` none of
    /// whose smaller valid subsets (by `valid`) already fails. A mode that holds a failing subset
    /// is a superset of that failure mode, not another one: in `driving_gemini.toml`,
    /// `{cone, far, weather_wet, on_lane}` (0.95) holds `{cone, far, weather_wet}` (0.7).
    pub fn planted(&self, threshold: f64, valid: impl Fn(ConceptSet) -> bool) -> Vec<ConceptSet> {
        self.modes
            .iter()
            .filter(|m| m.error >= threshold)
            .map(|m| m.concepts)
            .filter(|&m| !m.proper_subsets().any(|s| valid(s) && self.error_for(s) >= threshold))
            .collect()
    }

    /// The chance of a wrong answer for a set: the most specific matching mode's error (most
    /// concepts; ties go to the highest error), diluted by the set's other concepts, else the
    /// base error.
    pub fn error_for(&self, set: ConceptSet) -> f64 {
        self.winner(set).map_or(self.base_error, |m| {
            let extra = set.len().saturating_sub(m.concepts.len()) as i32;
            self.base_error + (m.error - self.base_error) * (1.0 - self.dilution).powi(extra)
        })
    }

    /// The mode that decides a set's answers: the most specific matching one (most concepts;
    /// ties go to the highest error, then to the last listed).
    pub fn winner(&self, set: ConceptSet) -> Option<&Mode> {
        self.modes
            .iter()
            .filter(|m| m.concepts.is_subset_of(set))
            .max_by(|a, b| a.concepts.len().cmp(&b.concepts.len()).then(a.error.total_cmp(&b.error)))
    }
}

/// The sim model for one profile.
pub struct SimModel {
    pub profile: Profile,
}

impl SimModel {
    /// The reply to a query, without the artificial latency.
    pub fn answer(&self, query: &Query) -> Reply {
        let Some(truth) = &query.truth else {
            return Reply {
                raw: "the sim model needs the ground truth of each query; it cannot answer real images".into(),
                thinking: None,
                answer: Answer::ApiError,
                usage: Usage::default(),
                latency_ms: 0,
                cached: false,
                attempts: 1,
                rate_limited: 0,
                waited_ms: 0,
            };
        };
        let mut rng = ChaCha8Rng::seed_from_u64(truth.key);
        let n = query.options.len().max(1) as u32;
        let (raw, answer) = if rng.random_bool(self.profile.unparsed) {
            ("I am not able to tell from this image which option applies.".to_string(), Answer::Unparsed)
        } else {
            let wrong = n > 1 && rng.random_bool(self.profile.error_for(truth.set));
            let planted = self
                .profile
                .winner(truth.set)
                .and_then(|m| m.answer.as_deref())
                .and_then(|a| truth.option_names.iter().position(|o| o == a))
                .map(|i| i as u32)
                .filter(|&i| i != truth.expected && i < n);
            let pick = if let (true, Some(i)) = (wrong, planted) {
                i
            } else if wrong {
                // A uniformly chosen wrong option: draw among the n-1 others and skip the expected.
                let k = rng.random_range(0..n - 1);
                if k >= truth.expected { k + 1 } else { k }
            } else {
                truth.expected.min(n - 1)
            };
            let letter = crate::vlm::prompt::letter(pick as usize);
            let text = query.options.get(pick as usize).map_or("", |s| s.as_str());
            (
                format!(
                    "{}Looking at the scene, the best match is option {letter}: {text}\nAnswer: {letter}",
                    self.marks(truth)
                ),
                Answer::Option(pick),
            )
        };
        let usage = Usage {
            input_tokens: (query.prompt.len() / 4) as u64,
            output_tokens: (raw.len() / 4) as u64,
            thinking_tokens: 0,
            cost_usd: 0.0,
        };
        Reply {
            raw,
            thinking: None,
            answer,
            usage,
            latency_ms: self.profile.latency_ms,
            cached: false,
            attempts: 1,
            rate_limited: 0,
            waited_ms: 0,
        }
    }
}

impl SimModel {
    /// The `Sk: True/False` lines of a probe reply (empty for the plain prompt). Drawn from
    /// their own stream, so the safety answer is the one the plain prompt gets.
    fn marks(&self, truth: &crate::vlm::Truth) -> String {
        let mut out = String::new();
        let mut rng = ChaCha8Rng::seed_from_u64(truth.key ^ 0x5245_434f_474e_4953);
        let mut recognised = std::collections::BTreeMap::new();
        for (i, s) in truth.statements.iter().enumerate() {
            let r = self.profile.recognition.get(&s.concept).copied().unwrap_or(1.0);
            // One draw per concept and observation: both of its statements agree.
            let seen = *recognised.entry(s.concept.as_str()).or_insert_with(|| rng.random_bool(r));
            let mark = if seen == s.positive { "True" } else { "False" };
            out.push_str(&format!("S{}: {mark}\n", i + 1));
        }
        out
    }
}

impl Model for SimModel {
    fn id(&self) -> String {
        format!("sim:{}@{}", self.profile.name, &self.profile.hash[..12])
    }

    fn ask<'a>(&'a self, query: &'a Query) -> BoxFuture<'a, Reply> {
        Box::pin(async move {
            if self.profile.latency_ms > 0 {
                tokio::time::sleep(Duration::from_millis(self.profile.latency_ms)).await;
            }
            self.answer(query)
        })
    }
}

/// Load a sim profile (TOML) checked against the domain's concept names.
pub fn load(path: &Path, domain: &Domain) -> Result<Arc<dyn Model>, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("cannot read sim profile `{}`: {}", path.display(), e.to_string().to_lowercase()))?;
    let profile = Profile::parse(&text, &path.display().to_string(), domain)?;
    Ok(Arc::new(SimModel { profile }))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::vlm::Truth;

    pub(crate) fn names_domain(names: &[&str]) -> Domain {
        crate::ir::testkit::domain(names)
    }

    fn query(set: ConceptSet, expected: u32, key: u64) -> Query {
        Query {
            image: None,
            image_hash: String::new(),
            prompt: "Q?".into(),
            options: vec!["stop".into(), "slow".into(), "go".into()],
            truth: Some(Truth {
                set,
                concepts: vec![],
                expected,
                option_names: vec!["stop".into(), "slow".into(), "go".into()],
                key,
                statements: vec![],
            }),
        }
    }

    #[test]
    fn most_specific_mode_wins_then_highest_error() {
        let d = names_domain(&["debris_far", "town_town02", "obstruction_far", "fog"]);
        let text = r#"
name = "t"
base_error = 0.05
[[mode]]
concepts = ["debris_far"]
error = 0.3
[[mode]]
concepts = ["debris_far", "town_town02"]
error = 0.9
[[mode]]
concepts = ["obstruction_far", "town_town02"]
error = 0.0
[[mode]]
concepts = ["fog", "town_town02"]
error = 0.7
"#;
        let p = Profile::parse(text, "t.toml", &d).unwrap();
        let s = |names: &[&str]| d.parse_set(names).unwrap();
        assert_eq!(p.error_for(s(&["fog"])), 0.05);
        assert_eq!(p.error_for(s(&["debris_far", "fog"])), 0.3);
        assert_eq!(p.error_for(s(&["debris_far", "town_town02"])), 0.9);
        assert_eq!(p.error_for(s(&["obstruction_far", "town_town02", "fog"])), 0.7);
    }

    #[test]
    fn dilution_fades_a_mode_with_each_extra_concept() {
        let d = names_domain(&["debris_far", "town_town02", "fog", "cone"]);
        let text = "name = \"t\"\nbase_error = 0.1\ndilution = 0.5\n[[mode]]\nconcepts = [\"debris_far\", \"town_town02\"]\nerror = 0.9\n";
        let p = Profile::parse(text, "t.toml", &d).unwrap();
        let s = |names: &[&str]| d.parse_set(names).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(p.error_for(s(&["debris_far", "town_town02"])), 0.9), "the mode itself is undiluted");
        assert!(close(p.error_for(s(&["debris_far", "town_town02", "fog"])), 0.5));
        assert!(close(p.error_for(s(&["debris_far", "town_town02", "fog", "cone"])), 0.3));
        assert!(close(p.error_for(s(&["fog", "cone"])), 0.1), "no mode: the base error");
        let e = Profile::parse("name = \"t\"\ndilution = 2\n", "p.toml", &d).unwrap_err();
        assert_eq!(e, "invalid sim profile `p.toml`: `dilution` must be between 0 and 1, got 2");
    }

    #[test]
    fn a_profile_names_its_bench_renderer() {
        let d = names_domain(&["a"]);
        assert_eq!(Profile::parse("name = \"t\"\n", "p.toml", &d).unwrap().renderer, "none");
        assert_eq!(Profile::parse("name = \"t\"\nrenderer = \"builtin\"\n", "p.toml", &d).unwrap().renderer, "builtin");
        let e = Profile::parse("name = \"t\"\nrenderer = \"carla\"\n", "p.toml", &d).unwrap_err();
        assert_eq!(e, "invalid sim profile `p.toml`: `renderer` must be \"none\" or \"builtin\", got \"carla\"");
    }

    #[test]
    fn unknown_concept_suggests_a_name() {
        let d = names_domain(&["debris_far", "town_town02"]);
        let e = Profile::parse("name = \"t\"\n[[mode]]\nconcepts = [\"debris_farr\"]\nerror = 1.0\n", "p.toml", &d)
            .unwrap_err();
        assert_eq!(
            e,
            "invalid sim profile `p.toml`: unknown concept `debris_farr` in domain `test`; did you mean `debris_far`?"
        );
        let e =
            Profile::parse("name = \"t\"\n[[mode]]\nconcepts = [\"zzz\"]\nerror = 1.0\n", "p.toml", &d).unwrap_err();
        assert_eq!(e, "invalid sim profile `p.toml`: unknown concept `zzz` in domain `test`");
    }

    #[test]
    fn malformed_profiles_name_the_problem() {
        let d = names_domain(&["a"]);
        let e = Profile::parse("name = \"t\"\nbase_error = \n", "p.toml", &d).unwrap_err();
        assert!(e.starts_with("invalid sim profile `p.toml`: ") && e.contains("line 2"), "{e}");
        let e = Profile::parse("name = \"t\"\nbase_eror = 0.1\n", "p.toml", &d).unwrap_err();
        assert!(e.contains("unknown field `base_eror`"), "{e}");
        let e = Profile::parse("name = \"t\"\nbase_error = 1.5\n", "p.toml", &d).unwrap_err();
        assert_eq!(e, "invalid sim profile `p.toml`: `base_error` must be between 0 and 1, got 1.5");
        let e = Profile::parse("name = \"t\"\n[[mode]]\nconcepts = []\nerror = 0.5\n", "p.toml", &d).unwrap_err();
        assert_eq!(e, "invalid sim profile `p.toml`: mode 1 has no concepts");
        let e = Profile::parse(&format!("name = \"t\"\nlatency_ms = {}\n", i64::MAX), "p.toml", &d).unwrap_err();
        assert_eq!(
            e,
            format!("invalid sim profile `p.toml`: `latency_ms` must be at most 60000 (one minute), got {}", i64::MAX)
        );
        assert!(Profile::parse("name = \"t\"\nlatency_ms = 60000\n", "p.toml", &d).is_ok());
    }

    #[test]
    fn replies_are_deterministic_and_wrong_at_the_planted_rate() {
        let d = names_domain(&["a", "b"]);
        let p = Profile::parse("name = \"t\"\n[[mode]]\nconcepts = [\"a\"]\nerror = 0.8\n", "p", &d).unwrap();
        let m = SimModel { profile: p };
        let set = d.parse_set(&["a"]).unwrap();
        let mut wrong = 0;
        for key in 0..2000 {
            let r = m.answer(&query(set, 1, key));
            assert_eq!(r, m.answer(&query(set, 1, key)));
            assert!(r.raw.ends_with(&format!(
                "\nAnswer: {}",
                match r.answer {
                    Answer::Option(o) => crate::vlm::prompt::letter(o as usize),
                    _ => unreachable!(),
                }
            )));
            if r.answer != Answer::Option(1) {
                wrong += 1;
            }
        }
        assert!((1500..1700).contains(&wrong), "{wrong}");
        // No mode and no base error: always right.
        let other = d.parse_set(&["b"]).unwrap();
        assert!((0..200).all(|k| m.answer(&query(other, 2, k)).answer == Answer::Option(2)));
    }

    /// A domain with the driving question's options, for profiles that plant an answer.
    fn options_domain(names: &[&str]) -> Domain {
        let mut d = names_domain(names);
        let options = ["stop", "slow", "go"]
            .iter()
            .map(|o| crate::ir::AnswerOption { name: (*o).into(), text: format!("answer {o}") })
            .collect();
        d.questions.push(crate::ir::Question {
            name: "drive".into(),
            text: "Q?".into(),
            options,
            span: Default::default(),
        });
        d
    }

    #[test]
    fn a_planted_answer_is_the_wrong_option_given() {
        let d = options_domain(&["a", "b"]);
        let text = "name = \"t\"\n[[mode]]\nconcepts = [\"a\"]\nerror = 0.8\nanswer = \"go\"\n";
        let m = SimModel { profile: Profile::parse(text, "p", &d).unwrap() };
        assert_eq!(m.profile.modes[0].answer.as_deref(), Some("go"));
        let set = d.parse_set(&["a"]).unwrap();
        let answers: Vec<Answer> = (0..2000).map(|k| m.answer(&query(set, 1, k)).answer).collect();
        let wrong = answers.iter().filter(|&&a| a != Answer::Option(1)).count();
        assert!((1500..1700).contains(&wrong), "{wrong}");
        assert!(answers.iter().all(|&a| a == Answer::Option(1) || a == Answer::Option(2)), "wrong is always `go`");
        // Where `go` is the expected answer the set errs as often, by the other options.
        let wrong: Vec<Answer> =
            (0..2000).map(|k| m.answer(&query(set, 2, k)).answer).filter(|&a| a != Answer::Option(2)).collect();
        assert!((1500..1700).contains(&wrong.len()), "{}", wrong.len());
        assert!(wrong.contains(&Answer::Option(0)) && wrong.contains(&Answer::Option(1)));
        // Without `answer` the replies are those of the same profile before `answer` existed.
        let plain = SimModel {
            profile: Profile::parse("name = \"t\"\n[[mode]]\nconcepts = [\"a\"]\nerror = 0.8\n", "p", &d).unwrap(),
        };
        let spread: Vec<Answer> = (0..2000).map(|k| plain.answer(&query(set, 1, k)).answer).collect();
        assert!(spread.contains(&Answer::Option(0)) && spread.contains(&Answer::Option(2)));
        let right = |v: &[Answer]| v.iter().map(|&a| a == Answer::Option(1)).collect::<Vec<_>>();
        assert_eq!(right(&spread), right(&answers), "the same draws decide right or wrong");
    }

    #[test]
    fn an_unknown_planted_answer_is_refused() {
        let d = options_domain(&["a"]);
        let text = "name = \"t\"\n[[mode]]\nconcepts = [\"a\"]\nerror = 0.8\nanswer = \"brake\"\n";
        let e = Profile::parse(text, "p.toml", &d).unwrap_err();
        assert_eq!(
            e,
            "invalid sim profile `p.toml`: mode 1 answers `brake`, which is no option of the domain's questions (options: `go`, `slow`, `stop`)"
        );
    }

    #[test]
    fn probe_statements_follow_the_recognition_table() {
        use crate::vlm::Statement;
        let d = names_domain(&["a", "b"]);
        let text = "name = \"t\"\n[recognition]\na = 0.0\n";
        let m = SimModel { profile: Profile::parse(text, "p", &d).unwrap() };
        let st = |c: &str, positive: bool| Statement { concept: c.into(), positive, text: String::new() };
        let mut q = query(d.parse_set(&["a", "b"]).unwrap(), 0, 3);
        let plain = m.answer(&q);
        q.truth.as_mut().unwrap().statements = vec![st("a", true), st("a", false), st("b", true), st("b", false)];
        let r = m.answer(&q);
        assert!(r.raw.starts_with("S1: False\nS2: True\nS3: True\nS4: False\n"), "{}", r.raw);
        assert_eq!(r.answer, plain.answer, "the safety answer does not depend on the statements");
        let e = Profile::parse("name = \"t\"\n[recognition]\nzz = 0.5\n", "p", &d).unwrap_err();
        assert_eq!(e, "invalid sim profile `p`: unknown concept `zz` in domain `test`");
        let e = Profile::parse("name = \"t\"\n[recognition]\na = 2.0\n", "p", &d).unwrap_err();
        assert_eq!(e, "invalid sim profile `p`: `recognition` must be between 0 and 1, got 2");
    }

    #[test]
    fn unparsed_replies_and_missing_truth() {
        let d = names_domain(&["a"]);
        let p = Profile::parse("name = \"t\"\nunparsed = 1.0\n", "p", &d).unwrap();
        let m = SimModel { profile: p };
        assert_eq!(m.answer(&query(ConceptSet::EMPTY, 0, 1)).answer, Answer::Unparsed);
        let mut q = query(ConceptSet::EMPTY, 0, 1);
        q.truth = None;
        assert_eq!(m.answer(&q).answer, Answer::ApiError);
    }
}
