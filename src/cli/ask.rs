//! `revelio ask FILE CONCEPT... --model M`: render one scene of a concept set, ask the model
//! once, and show the question, the reply, the parsed option, the expected option and the
//! verdict. The quickest check that a model, its key and its settings work. `--save FILE` keeps
//! the image, so an author can look at what the model was shown.
//!
//! Exit codes: 0 when the model replied (whatever the verdict), 1 when the call, the domain or
//! the scene failed or a concept the domain does not declare, 2 for usage errors (bad flags).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use crate::diag::terminal_safe;
use crate::ir::{ConceptSet, Domain};
use crate::journal::Phase;
use crate::outcome::{Answer, Outcome};
use crate::run::observe::{DomainWorld, ObsKey, Observer};
use crate::run::setup::{self, Parts};
use crate::vlm::{Reply, prompt};

#[derive(clap::Args, Debug)]
pub struct AskArgs {
    /// The domain file (`.rev`).
    pub file: PathBuf,
    /// Concept names of the set to show the model.
    #[arg(required = true)]
    pub concepts: Vec<String>,
    /// The model, e.g. `gemini:gemini-3-flash-preview`, `openai:Qwen/Qwen3-VL-8B-Instruct`.
    #[arg(long, short)]
    pub model: String,
    /// Scene seed: the `seed` of a journal line shows that observation's scene and prompt again.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// `builtin`, `none`, `imagegen:gemini:MODEL` or `imagegen:openai:MODEL`.
    #[arg(long, default_value = "builtin")]
    pub renderer: String,
    /// Write the rendered image (PNG) to this file, also when the scene is not shown because an
    /// entity is not visible; a symbolic link there is refused, not followed.
    #[arg(long, value_name = "FILE")]
    pub save: Option<PathBuf>,
    #[command(flatten)]
    pub model_opts: super::common::ModelFlags,
    /// Do not send the call when its worst case (its input, `max_tokens` and any thinking
    /// budget) could cost more than this many US dollars
    #[arg(long, value_name = "USD", value_parser = super::common::parse_usd)]
    pub max_cost: Option<f64>,
}

pub fn run(args: AskArgs) -> ExitCode {
    let domain = match crate::cli::load_domain(&args.file) {
        Ok(d) => d,
        Err(code) => return code,
    };
    let set = match domain.parse_set(&args.concepts) {
        Ok(s) => s,
        Err(e) => {
            // A concept the domain lacks is an input error (1), with the checker's "did you mean".
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let runtime = match tokio::runtime::Builder::new_multi_thread().enable_all().build() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: cannot start the async runtime: {e}");
            return ExitCode::from(1);
        }
    };
    match runtime.block_on(ask(&domain, set, &args)) {
        Ok(report) => {
            print!("{report}");
            ExitCode::SUCCESS
        }
        Err((code, e)) => {
            eprintln!("error: {e}");
            ExitCode::from(code)
        }
    }
}

/// One observation through the pipeline a search uses (no journal); the report, or the exit
/// code and message.
async fn ask(domain: &Domain, set: ConceptSet, args: &AskArgs) -> Result<String, (u8, String)> {
    if args.save.is_some() && args.renderer == "none" {
        return Err((2, "`--save` writes the image shown, and `--renderer none` renders none".into()));
    }
    let verdict = crate::oracle::evaluate(domain, set).map_err(|e| (1, e.to_string()))?;
    let cache = args.model_opts.cache();
    let Parts { model, renderer, .. } =
        setup::build_parts(domain, &args.model, &args.renderer, &args.model_opts.settings(), cache.as_deref(), None)
            .map_err(|e| (e.exit_code(), e.to_string()))?;
    let purse = args.max_cost.map(|cap| Arc::new(crate::vlm::cost::Purse::new(cap, 0.0)));
    let observer =
        Observer::new(Arc::new(domain.clone()), Arc::new(DomainWorld::new(domain)), renderer).with_purse(purse);
    let task = observer.task(set).map_err(|e| (1, e.to_string()))?;
    let key = ObsKey { phase: Phase::Search, set, index: 0 };
    // The image is written before the model is asked, so a failed call still leaves it.
    let saved = std::sync::OnceLock::new();
    let save = |png: &[u8]| {
        let path = args.save.as_deref().unwrap_or(std::path::Path::new(""));
        save(path, png)?;
        let (w, h) = crate::render::png_size(png).unwrap_or_default();
        // As `render` says it: on stdout, also when the scene is then not shown.
        let _ = saved.set(format!("wrote {} ({w}x{h})\n", path.display()));
        Ok(())
    };
    let hook: Option<crate::run::observe::OnImage<'_>> = args.save.as_ref().map(|_| &save as _);
    // The stimulus kept, for the figures of the scene the model was shown.
    let stimulus = observer.stimulus(set, args.seed).await.map_err(|e| (1, e.to_string()))?;
    let o = observer.show(model.as_ref(), key, &stimulus, &task, None, hook).await.map_err(|e| (1, e.to_string()))?;
    let Some(wrote) = saved.get().cloned().or_else(|| args.save.is_none().then(String::new)) else {
        return Err((1, "no image was rendered, so there is nothing to `--save`".to_string()));
    };
    let rule = domain.rules.get(verdict.rule.index()).map_or("?", |r| r.name.as_str());
    let prompt_text = prompt::build(&task.question, &task.options);
    let result = match o.reply {
        // No resample: an entity that can never be drawn (the guard does not try another seed).
        None if o.outcome == Outcome::Invisible && o.record.resamples == 0 => Err((
            1,
            format!(
                "this scene was not shown to `{}`: an entity is {} (no other seed can draw it, so none was tried)",
                model.id(),
                o.record.raw
            ),
        )),
        None if o.outcome == Outcome::Invisible => Err((
            1,
            format!(
                "this scene was not shown to `{}`: after {} resamples (seeds {}..={}) an entity is still {}",
                model.id(),
                o.record.resamples,
                args.seed,
                o.record.seed,
                o.record.raw
            ),
        )),
        None => Err((
            1,
            format!(
                "the image generator blocked this scene, so `{}` was not asked: {}",
                model.id(),
                terminal_safe(&o.record.raw)
            ),
        )),
        Some(reply) if reply.answer == Answer::ApiError => {
            Err((1, format!("`{}` failed: {}", model.id(), terminal_safe(&reply.raw))))
        }
        Some(reply) => {
            let mut out = report(&model.id(), &prompt_text, &task.options, &reply, task.expected, rule);
            // What the model was shown: each placed entity's figures (none without a renderer).
            let seen = &o.record.visibility;
            for line in crate::run::observe::figure_lines(domain, &stimulus.scene, seen) {
                out.push_str(&format!("figures    {line}\n"));
            }
            Ok(out)
        }
    };
    match result {
        Ok(out) => Ok(out + &wrote),
        Err(e) => {
            print!("{wrote}");
            Err(e)
        }
    }
}

/// Write the PNG to `path`, never through a symbolic link (it may point anywhere).
fn save(path: &std::path::Path, png: &[u8]) -> Result<(), String> {
    if crate::journal::safe::is_link(path) {
        return Err(format!(
            "cannot write `{}`: it is a symbolic link, and `--save` writes through none",
            path.display()
        ));
    }
    crate::journal::safe::write_atomic(path, png).map_err(|e| format!("cannot write `{}`: {e}", path.display()))
}

fn option_label(i: u32, options: &[String]) -> String {
    let text = options.get(i as usize).map_or("?", String::as_str);
    format!("{} ({text})", prompt::letter(i as usize))
}

/// The human-readable result of one question.
fn report(model: &str, prompt_text: &str, options: &[String], reply: &Reply, expected: u32, rule: &str) -> String {
    // Reply and thinking are the model's text: escaped before they reach the terminal.
    let indent = |s: &str| terminal_safe(s.trim()).lines().collect::<Vec<_>>().join("\n           ");
    let parsed = match reply.answer {
        Answer::Option(i) => option_label(i, options),
        other => serde_json::to_value(other).ok().and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default(),
    };
    let verdict = Outcome::from_answer(reply.answer, expected);
    let verdict = serde_json::to_value(verdict).ok().and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default();
    let mut out = String::new();
    out.push_str(&format!("model      {model}\n"));
    out.push_str(&format!("prompt     {}\n", indent(prompt_text)));
    if let Some(t) = &reply.thinking {
        let short: String = t.chars().take(600).collect();
        let more = if t.chars().count() > 600 { " …" } else { "" };
        out.push_str(&format!("thinking   {}{more}\n", indent(&short)));
    }
    out.push_str(&format!("reply      {}\n", indent(&reply.raw)));
    out.push_str(&format!("parsed     {parsed}\n"));
    out.push_str(&format!("expected   {} by rule `{rule}`\n", option_label(expected, options)));
    out.push_str(&format!("verdict    {verdict}\n"));
    let u = &reply.usage;
    let source = if reply.cached {
        "from the cache".to_string()
    } else {
        let s = if reply.attempts == 1 { "" } else { "s" };
        format!("{:.1} s, {} attempt{s}", reply.latency_ms as f64 / 1000.0, reply.attempts)
    };
    out.push_str(&format!(
        "usage      {} input / {} output tokens ({} thinking), ${:.4}, {source}\n",
        u.input_tokens, u.output_tokens, u.thinking_tokens, u.cost_usd
    ));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::outcome::Usage;

    #[test]
    fn report_layout() {
        let options = vec!["Stop".to_string(), "Slow down".to_string(), "Continue".to_string()];
        let reply = Reply {
            raw: "Debris lies in the lane.\nAnswer: B".into(),
            thinking: Some("The object is small.".into()),
            answer: Answer::Option(1),
            usage: Usage { input_tokens: 1290, output_tokens: 262, thinking_tokens: 250, cost_usd: 0.00143 },
            latency_ms: 2345,
            cached: false,
            attempts: 2,
            rate_limited: 0,
            waited_ms: 0,
        };
        let p = prompt::build("What should the ego vehicle do?", &options);
        insta::assert_snapshot!(report(
            "gemini:gemini-3-flash-preview@thinking=low",
            &p,
            &options,
            &reply,
            0,
            "debris_in_lane"
        ));
    }

    #[cfg(unix)]
    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn save_writes_the_image_shown_and_never_through_a_link() {
        let domain = crate::cli::load_domain(std::path::Path::new("domains/driving.rev")).unwrap();
        let set = domain.parse_set(&["debris_far"]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let mut a = args(String::new(), dir.path());
        a.model = "sim:examples/sim/driving_paper.toml".into();
        a.model_opts.base_url = None;
        a.renderer = "builtin".into();
        let png = dir.path().join("shown.png");
        a.save = Some(png.clone());
        let out = ask(&domain, set, &a).await.unwrap();
        assert!(out.contains("verdict"), "{out}");
        assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
        // A link at the name is refused, and what it points to is untouched.
        let target = dir.path().join("keep.txt");
        std::fs::write(&target, "keep").unwrap();
        let link = dir.path().join("link.png");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        a.save = Some(link);
        let (code, e) = ask(&domain, set, &a).await.unwrap_err();
        assert_eq!(code, 1);
        assert!(e.contains("link.png") && e.contains("symbolic link"), "{e}");
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep");
        // Without a renderer there is no image to save.
        a.renderer = "none".into();
        a.save = Some(dir.path().join("none.png"));
        let (code, e) = ask(&domain, set, &a).await.unwrap_err();
        assert_eq!((code, e.as_str()), (2, "`--save` writes the image shown, and `--renderer none` renders none"));
        assert!(!dir.path().join("none.png").exists());
    }

    /// Echoes the request headers back, so a leak of the key would show in the reply.
    struct Echo(u16);

    impl wiremock::Respond for Echo {
        fn respond(&self, r: &wiremock::Request) -> wiremock::ResponseTemplate {
            let headers: String =
                r.headers.iter().map(|(k, v)| format!("{k}: {}\n", v.to_str().unwrap_or(""))).collect();
            let body = if self.0 == 200 {
                serde_json::json!({"choices": [{"message": {"content": format!("{headers}\nAnswer: A")}, "finish_reason": "stop"}],
                                   "usage": {"prompt_tokens": 900, "completion_tokens": 40}})
            } else {
                serde_json::json!({"error": {"message": format!("invalid key in {headers}"), "type": "invalid_request_error"}})
            };
            wiremock::ResponseTemplate::new(self.0).set_body_json(body)
        }
    }

    fn args(base: String, cache: &std::path::Path) -> AskArgs {
        AskArgs {
            file: "driving.rev".into(),
            concepts: vec![],
            model: "openai:glm-4.6v-flash".into(),
            seed: 3,
            renderer: "none".into(),
            save: None,
            model_opts: super::super::common::ModelFlags {
                base_url: Some(base),
                cache_dir: Some(cache.to_path_buf()),
                ..Default::default()
            },
            max_cost: None,
        }
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn asks_a_mock_and_never_shows_the_key() {
        const KEY: &str = "sk-ask-CANARY-3f9e61";
        // SAFETY: no other test in this crate reads or writes `OPENAI_API_KEY`, and Rust's own
        // environment accessors are serialised.
        #[allow(unsafe_code)]
        unsafe {
            std::env::set_var("OPENAI_API_KEY", KEY)
        };
        let domain = crate::lattice::testkit::driving();
        let set = domain.parse_set(&["debris_near"]).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let mut outputs = Vec::new();
        for status in [200, 401] {
            // A server of its own, not one lent from wiremock's pool (tests/common/mod.rs, `mock_server`).
            let server = wiremock::MockServer::builder().start().await;
            wiremock::Mock::given(wiremock::matchers::method("POST")).respond_with(Echo(status)).mount(&server).await;
            let mut a = args(server.uri(), dir.path());
            // The 200 reply was cached; the error case must reach the server.
            a.model_opts.no_cache = status == 401;
            let result = ask(&domain, set, &a).await.map_err(|(_, e)| e);
            let sent = &server.received_requests().await.unwrap()[0];
            assert_eq!(sent.headers.get("authorization").unwrap(), &format!("Bearer {KEY}"));
            match (status, result) {
                (200, Ok(out)) => {
                    assert!(out.contains("parsed     A (answer stop)"), "{out}");
                    assert!(out.contains("expected   A (answer stop) by rule `near_in_lane`"), "{out}");
                    assert!(out.contains("verdict    correct"), "{out}");
                    assert!(out.contains("[redacted]"), "{out}");
                    outputs.push(out);
                }
                (401, Err(e)) => {
                    assert!(e.contains("HTTP 401"), "{e}");
                    outputs.push(e);
                }
                (s, r) => panic!("status {s}: {r:?}"),
            }
        }
        let mut files = vec![dir.path().to_path_buf()];
        while let Some(p) = files.pop() {
            if p.is_dir() {
                files.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
            } else {
                outputs.push(String::from_utf8_lossy(&std::fs::read(&p).unwrap()).into_owned());
            }
        }
        assert!(outputs.len() >= 3, "the parsed reply was cached");
        for o in outputs {
            assert!(!o.contains(KEY), "the key leaked: {o}");
        }
    }
}
