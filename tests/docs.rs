//! Documentation that cannot drift (issue 33). Every `revelio …` command in a fenced `sh` or
//! `console` block of `README.md` and `docs/*.md` runs here against the shipped files, in the
//! order the page shows them, one scratch folder per page; a `console` block's shown output is
//! compared with what the command prints. Every ```` ```rev ```` block checks clean, or parses
//! when it is marked ```` ```rev fragment ````. A command too slow for the suite runs in the
//! reduced form [`REDUCED`] names, its shown output compared on the lines [`STABLE`] lists (the
//! rest are the full run's figures); one that cannot run here is in
//! [`NOT_RUN`] with the reason; a command in neither fails the test, and so does an entry of
//! either that no page shows any more. docs/testing.md says how to mark a block.

mod common;

use std::collections::BTreeSet;
use std::path::Path;
use std::process::{Command, Stdio};

use wiremock::matchers::method;
use wiremock::{Mock, ResponseTemplate};

/// Commands run in a reduced form: (as the page shows it, as the test runs it, why). The reduced
/// form may be several commands, one per line (a run folder made first). `$MOCK` is the mock
/// model server's address. Their shown output is compared only on the lines [`STABLE`] lists
/// (the figures are the full run's). Keep them small: a cold CI run stays well under 30 minutes.
const REDUCED: &[(&str, &str, &str)] = &[
    // README.md
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 1000 --shrink 250 --algos interact,random --concurrency 16 --latency-ms 500 --renderer none",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 40 --shrink 10 --algos interact,random --concurrency 16 --latency-ms 0 --renderer none",
        "2 000 calls at 500 ms each",
    ),
    (
        "revelio bench search --profile examples/sim/P.toml --seeds 20 --budget 1000 --shrink 250 --batch 16 --concurrency 16 --algos interact --renderer none --json",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 60 --shrink 20 --batch 16 --concurrency 16 --algos interact --renderer none --json",
        "`P` is any profile; 15 profiles × 20 seeds × 1000 calls",
    ),
    (
        "revelio campaign examples/campaign_200ms.toml --no-cache --concurrency 16",
        "revelio campaign examples/campaign_200ms.toml --no-cache --concurrency 16 --dry-run",
        "1 518 calls at 200 ms each",
    ),
    (
        "revelio bench scale --concepts 250 --search-seeds 10",
        "revelio bench scale --concepts 250 --search-seeds 0",
        "ten 1 000-call searches",
    ),
    (
        "revelio search domains/driving.rev --model sim:examples/sim/driving_paper.toml --algo gpts --out runs/demo",
        "revelio search domains/driving.rev --model sim:examples/sim/driving_paper.toml --algo gpts --out runs/demo --budget 40 --renderer none",
        "1000 rendered inferences take minutes",
    ),
    (
        "revelio search domains/driving.rev --model sim:examples/sim/driving_paper.toml --algo gpts --budget 1250 --shrink 250 --out runs/demo",
        "revelio search domains/driving.rev --model sim:examples/sim/driving_paper.toml --algo gpts --budget 30 --shrink 10 --out runs/demo",
        "1250 rendered inferences; the figure's builtin renderer still draws these",
    ),
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --algos interact --seeds 10 --budget 1000 --shrink 250 --renderer none",
        "revelio bench search --profile examples/sim/driving_paper.toml --algos interact --seeds 1 --budget 200 --shrink 50 --renderer none",
        "ten 1 000-call searches",
    ),
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --sweep beam_width=1,5,10",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 60 --sweep beam_width=1,5 --algos random,beam",
        "3 values × 4 algorithms × 5 seeds × 1000 inferences",
    ),
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --sweep kernel=dot,rbf",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 20 --sweep kernel=dot,rbf",
        "2 kernels × 5 seeds × 1000 inferences",
    ),
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 5 --budget 1000",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 30",
        "4 algorithms × 5 seeds × 1000 inferences",
    ),
    (
        "revelio bench lsp --domain domains/driving.rev --rounds 20",
        "revelio bench lsp --domain domains/driving.rev --rounds 2",
        "a latency benchmark: two rounds show it runs",
    ),
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 10 --budget 1250 --shrink 250 --batch 1",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 60 --shrink 20 --algos random,beam",
        "4 algorithms × 10 seeds × 1250 inferences",
    ),
    (
        "revelio search domains/driving.rev --model sim:examples/sim/driving_slow.toml --renderer none --concurrency 32 --algo gpts --batch 6 --shrink 0",
        "revelio search domains/driving.rev --model sim:examples/sim/driving_slow.toml --renderer none --concurrency 32 --algo gpts --batch 6 --shrink 0 --budget 32",
        "1000 inferences of 1 s each",
    ),
    // docs/lattice.md
    (
        "revelio bench scale",
        "revelio bench scale --concepts 12 --max-size 3",
        "generated domains of up to 250 concepts",
    ),
    // docs/models.md
    (
        "revelio ask domains/driving.rev debris_far --model openai:zai-org/GLM-4.6V-Flash --base-url http://localhost:8000/v1 --model-config examples/models/paper.toml",
        "revelio ask domains/driving.rev debris_far --model openai:zai-org/GLM-4.6V-Flash --base-url $MOCK/v1 --model-config examples/models/paper.toml",
        "the mock server stands for the local vLLM server",
    ),
    // docs/porting.md
    (
        "revelio bench search --profile examples/sim/delivery.toml --domain domains/delivery.rev --seeds 3 --budget 1250 --shrink 250 --batch 1 --renderer none",
        "revelio bench search --profile examples/sim/delivery.toml --domain domains/delivery.rev --seeds 1 --budget 60 --shrink 20 --algos random,beam --renderer none",
        "4 algorithms × 3 seeds × 1250 inferences",
    ),
    // docs/report.md
    (
        "revelio compare runs/beam runs/random runs/gpts --csv table.csv --html table.html",
        "revelio search domains/driving.rev --model sim:examples/sim/driving_recognition.toml --renderer none --budget 50 --algo beam --out runs/beam
         revelio search domains/driving.rev --model sim:examples/sim/driving_recognition.toml --renderer none --budget 50 --algo random --out runs/random
         revelio search domains/driving.rev --model sim:examples/sim/driving_recognition.toml --renderer none --budget 30 --algo gpts --out runs/gpts
         revelio compare runs/beam runs/random runs/gpts --csv table.csv --html table.html",
        "the page names three runs of 600 inferences it does not make",
    ),
    // docs/search.md
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 5 --budget 1000 --max-samples 20",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 60 --max-samples 20 --shrink 20 --algos random,beam",
        "8 searches × 5 seeds × 1000 inferences",
    ),
    (
        "revelio bench search --profile examples/sim/P.toml --seeds 10 --budget 1250 --shrink 250 --batch 1",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 60 --shrink 20 --algos random,beam",
        "`P` is any profile; 4 algorithms × 10 seeds × 1250 inferences",
    ),
    (
        "revelio bench search --profile examples/sim/P.toml --seeds 10 --budget 1250 --shrink 250 --batch 1 --renderer none",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 60 --shrink 20 --batch 1 --renderer none",
        "`P` is any profile; 4 algorithms × 10 seeds × 1250 inferences on sixteen profiles",
    ),
    (
        "revelio bench search --domain domains/indoor.rev --profile examples/sim/P.toml --seeds 10 --budget 1250 --shrink 250 --batch 1",
        "revelio bench search --profile examples/sim/indoor_stress.toml --domain domains/indoor.rev --seeds 1 --budget 60 --shrink 20 --algos random,beam",
        "`P` is any indoor profile; 4 algorithms × 10 seeds × 1250 inferences",
    ),
    (
        "revelio bench search --domain domains/delivery.rev --profile examples/sim/delivery.toml --seeds 10 --budget 1250 --shrink 250 --batch 1",
        "revelio bench search --profile examples/sim/delivery.toml --domain domains/delivery.rev --seeds 1 --budget 60 --shrink 20 --algos random,beam --renderer none",
        "4 algorithms × 10 seeds × 1250 inferences",
    ),
    (
        "revelio bench search --profile examples/sim/driving_robust.toml --seeds 10 --budget 1250 --shrink 250 --batch 1",
        "revelio bench search --profile examples/sim/driving_robust.toml --seeds 1 --budget 60 --shrink 20 --algos random,beam",
        "4 algorithms × 10 seeds × 1250 inferences",
    ),
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 5 --budget 300 --sweep kernel=dot,rbf",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 20 --sweep kernel=dot,rbf",
        "2 kernels × 5 seeds × 300 inferences",
    ),
    // docs/benchmarks.md
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 2 --budget 600 --sweep beam_width=1,5",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 60 --sweep beam_width=1,5 --algos random,beam",
        "2 values × 4 algorithms × 2 seeds × 600 inferences",
    ),
    (
        "revelio bench search --profile examples/sim/P.toml",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 30",
        "`P` is any profile; 4 algorithms × 5 seeds × 1000 inferences",
    ),
    (
        "revelio search domains/driving.rev --model sim:examples/sim/driving_slow.toml --renderer none --concurrency 32 --shrink 0 --algo A",
        "revelio search domains/driving.rev --model sim:examples/sim/driving_slow.toml --renderer none --concurrency 32 --shrink 0 --algo beam --budget 32",
        "`A` is an algorithm; 1000 inferences of 1 s each",
    ),
    (
        "revelio search domains/driving.rev --model sim:examples/sim/driving_slow.toml --renderer none --concurrency 32 --shrink 0 --algo gpts --batch 1",
        "revelio search domains/driving.rev --model sim:examples/sim/driving_slow.toml --renderer none --concurrency 32 --shrink 0 --algo gpts --batch 1 --budget 10",
        "1000 sequential inferences of 1 s each",
    ),
    (
        "revelio bench search --profile examples/sim/P.toml --seeds 5 --budget 1000",
        "revelio bench search --profile examples/sim/indoor_stress.toml --domain domains/indoor.rev --seeds 1 --budget 60 --shrink 20 --algos random,beam",
        "`P` is any profile; 4 algorithms × 5 seeds × 1000 inferences",
    ),
    (
        "revelio search domains/driving.rev --model sim:examples/sim/P.toml --algo random --renderer none --seed S",
        "revelio search domains/driving.rev --model sim:examples/sim/driving_fog.toml --algo random --renderer none --seed 4 --budget 60",
        "`P` is any profile, `S` a seed; 1250 inferences",
    ),
    (
        "revelio bench search --profile examples/sim/P.toml --seeds 5 --budget 1000 --max-samples 20",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 60 --max-samples 20 --shrink 20 --algos random,beam",
        "`P` is any profile; 8 searches × 5 seeds × 1000 inferences",
    ),
    (
        "revelio bench search --profile examples/sim/P.toml --seeds 5 --budget 1000 --max-samples 20 --shrink 250",
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 1 --budget 60 --max-samples 20 --shrink 20 --algos random,beam",
        "`P` is any profile; 8 searches × 5 seeds × 1250 inferences",
    ),
];

/// The lines of a [`REDUCED`] command's shown output that do not depend on the reduction: each
/// must be in the page's shown output and in what the reduced form prints, in this order, with
/// numbers redacted (`#`) and runs of spaces made one (`…` stands for any text). The shown output's other lines are the
/// full command's figures. A reduced command whose page shows its output needs an entry.
const STABLE: &[(&str, &[&str])] = &[
    (
        "revelio compare runs/beam runs/random runs/gpts --csv table.csv --html table.html",
        &[
            "domain model algo seed budget PFM [#% CI] MFR [#% CI] Div [#% CI] modes cores calls spend run",
            "driving sim:driving-recognition@d#fa#e beam # … $# runs/beam",
            "driving sim:driving-recognition@d#fa#e random # … $# runs/random",
            "driving sim:driving-recognition@d#fa#e gpts # … $# runs/gpts",
        ],
    ),
    (
        "revelio bench search --profile examples/sim/driving_robust.toml --seeds 10 --budget 1250 --shrink 250 --batch 1",
        &[
            "planted modes: share of seeds recovered / exact; reach: the most any search recovers of a mode whose parts carry no signal (# inferences)",
            "mode error reach random beam…",
            "town_town# + cone + far + weather_wet # #% #% / #% #% / #%…",
        ],
    ),
    (
        "revelio bench search --profile examples/sim/delivery.toml --domain domains/delivery.rev --seeds 3 --budget 1250 --shrink 250 --batch 1 --renderer none",
        &["algo PFM % MFR % …", "random # [#–#] # [#–#] …", "beam # [#–#] # [#–#] …"],
    ),
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 2 --budget 600 --sweep beam_width=1,5",
        &["beam_width algo PFM % MFR % Div", "# random # ± # # ± # # ± #", "plot: sweep-beam_width.svg"],
    ),
    (
        "revelio bench search --profile examples/sim/driving_paper.toml --seeds 5 --budget 300 --sweep kernel=dot,rbf",
        &[
            "sweep of kernel over # seeds × budget # against `examples/sim/driving_paper.toml`, renderer none",
            "kernel algo PFM % MFR % Div",
            "plot: sweep-kernel.svg",
        ],
    ),
];

/// Commands not run: (as the page shows it, why).
const NOT_RUN: &[(&str, &str)] = &[
    ("revelio lsp", "a server on stdin/stdout: tests/lsp.rs drives it like an editor"),
    (
        "revelio bench search --renderer none|builtin",
        "a synopsis of one flag; the benches it describes are shown in full and run",
    ),
    (
        "revelio bench search --profile examples/sim/PROFILE.toml --domain domains/DOMAIN.rev --seeds 10 --budget 1000 --shrink B --algos interact --renderer none --json",
        "a template: PROFILE, DOMAIN and B are placeholders the table below it fills; bench search itself runs reduced in the page's other commands",
    ),
    (
        "revelio bench search --profile examples/sim/PROFILE.toml --domain domains/DOMAIN.rev --seeds 10 --budget 1000 --shrink S --batch 16 --concurrency 16 --algos interact --renderer none --json",
        "a template: PROFILE, DOMAIN and S are placeholders the table below it fills; bench search itself runs reduced in the page's other commands",
    ),
    (
        "revelio search domains/driving.rev --model openai:gpt-4.1-mini --algo random --batch-api",
        "a provider's batch endpoint: tests/batch.rs runs --batch-api against mocks of all three batch APIs",
    ),
    (
        "revelio validate runs/driving-random-s0 --batch-api",
        "a provider's batch endpoint on the run above: tests/batch.rs runs it against the mocks",
    ),
    (
        "revelio probe runs/driving-random-s0 --batch-api",
        "a provider's batch endpoint on the run above: tests/batch.rs runs it against the mocks",
    ),
    (
        "revelio transfer runs/driving-random-s0 --model anthropic:claude-sonnet-4-6 --batch-api",
        "a provider's batch endpoint on the run above: tests/batch.rs runs it against the mocks",
    ),
    (
        "revelio campaign grid.toml --shard ${SLURM_ARRAY_TASK_ID}/8 --max-cost 5",
        "runs inside a Slurm job array (the shell fills the shard); tests/campaign.rs runs shards and merges them",
    ),
    (
        "revelio bench search … --sweep PARAM=v1,v2,… [--plot FILE]",
        "a synopsis; the sweeps it describes are shown in full and run",
    ),
];

/// The mock model server's reply: one body that every provider's parser reads (OpenAI
/// `choices`, Anthropic `content`, Gemini `candidates`, Bedrock Converse `output`).
fn reply() -> serde_json::Value {
    let text = "The lane ahead is clear.\nAnswer: C";
    serde_json::json!({
        "choices": [{"message": {"content": text}, "finish_reason": "stop"}],
        "usage": {"prompt_tokens": 900, "completion_tokens": 12},
        "content": [{"type": "text", "text": text}], "stop_reason": "end_turn",
        "candidates": [{"content": {"parts": [{"text": text}]}, "finishReason": "STOP"}],
        "output": {"message": {"content": [{"text": text}]}}, "stopReason": "end_turn",
    })
}

/// One fenced block of a page.
#[derive(Debug)]
struct Block {
    page: String,
    /// Line of the opening fence (1-based).
    line: usize,
    /// The info string: `sh`, `console`, `rev fragment`, …
    info: String,
    body: Vec<String>,
}

fn pages() -> Vec<String> {
    let root = common::root();
    let mut pages = vec!["README.md".to_string()];
    let mut docs: Vec<String> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".md"))
        .map(|n| format!("docs/{n}"))
        .collect();
    docs.sort();
    pages.extend(docs);
    pages
}

fn blocks(page: &str, text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<Block> = None;
    for (i, l) in text.lines().enumerate() {
        match (open.take(), l.strip_prefix("```")) {
            (None, Some(info)) => {
                open = Some(Block { page: page.into(), line: i + 1, info: info.trim().into(), body: vec![] })
            }
            (Some(b), Some(_)) => out.push(b),
            (Some(mut b), None) => {
                b.body.push(l.to_string());
                open = Some(b);
            }
            (None, None) => {}
        }
    }
    assert!(open.is_none(), "{page}: a fenced block is never closed");
    out
}

/// A `revelio` command a page shows, and the output it shows under it (`console` blocks).
#[derive(Debug)]
struct Shown {
    page: String,
    line: usize,
    command: String,
    output: Option<Vec<String>>,
}

/// The command of a shell line, continuations joined and the comment dropped; `cargo run
/// [--release] --` stands for `revelio`. None for a line that runs something else.
fn revelio_line(line: &str) -> Option<String> {
    let line = line.trim();
    let line = ["cargo run --release --", "cargo run --"]
        .iter()
        .find_map(|p| line.strip_prefix(p).map(|rest| format!("revelio{rest}")))
        .unwrap_or_else(|| line.to_string());
    if line != "revelio" && !line.starts_with("revelio ") {
        return None;
    }
    Some(strip_comment(&line).split_whitespace().collect::<Vec<_>>().join(" "))
}

/// `line` up to a `#` that starts a word outside quotes.
fn strip_comment(line: &str) -> &str {
    let (mut quote, mut prev_space) = (None, true);
    for (i, c) in line.char_indices() {
        match (quote, c) {
            (None, '#') if prev_space => return line[..i].trim_end(),
            (None, '\'' | '"') => quote = Some(c),
            (Some(q), c) if c == q => quote = None,
            _ => {}
        }
        prev_space = c.is_whitespace();
    }
    line.trim_end()
}

/// Lines with `\` continuations joined, with the line each starts on.
fn joined(body: &[String]) -> Vec<(usize, String)> {
    let mut out: Vec<(usize, String)> = Vec::new();
    let mut cont = false;
    for (i, l) in body.iter().enumerate() {
        if cont {
            let last = out.last_mut().unwrap();
            last.1.push(' ');
            last.1.push_str(l.trim());
        } else {
            out.push((i, l.clone()));
        }
        cont = l.trim_end().ends_with('\\');
        if cont {
            let last = out.last_mut().unwrap();
            let t = last.1.trim_end().trim_end_matches('\\').to_string();
            last.1 = t;
        }
    }
    out
}

fn shown_commands(b: &Block) -> Vec<Shown> {
    let at = |i: usize| b.line + 1 + i;
    let mut out = Vec::new();
    match b.info.as_str() {
        "sh" => {
            for (i, l) in joined(&b.body) {
                if let Some(command) = revelio_line(&l) {
                    out.push(Shown { page: b.page.clone(), line: at(i), command, output: None });
                }
            }
        }
        "console" => {
            let lines = joined(&b.body);
            let mut k = 0;
            while k < lines.len() {
                let (i, l) = &lines[k];
                let Some(cmd) = l.strip_prefix("$ ") else {
                    panic!("{}:{}: a console block starts each command with `$ `", b.page, at(*i))
                };
                let mut output = Vec::new();
                k += 1;
                while k < lines.len() && !lines[k].1.starts_with("$ ") {
                    output.push(lines[k].1.clone());
                    k += 1;
                }
                // A blank line between two commands is the page's layout, not output.
                while output.last().is_some_and(|l: &String| l.trim().is_empty()) {
                    output.pop();
                }
                let command = match revelio_line(cmd) {
                    Some(c) => c,
                    // `$ cat FILE` followed by its text: the page writes that file.
                    None if cmd.starts_with("cat ") => cmd.trim().to_string(),
                    None => panic!("{}:{}: a console block runs only `revelio` and `cat`", b.page, at(*i)),
                };
                out.push(Shown { page: b.page.clone(), line: at(*i), command, output: Some(output) });
            }
        }
        _ => {}
    }
    out
}

/// Split a command line into words: single and double quotes, backslash escapes.
fn words(line: &str) -> Vec<String> {
    let (mut out, mut cur, mut quote, mut any) = (Vec::new(), String::new(), None, false);
    let mut chars = line.chars();
    while let Some(c) = chars.next() {
        match (quote, c) {
            (None, c) if c.is_whitespace() => {
                if any {
                    out.push(std::mem::take(&mut cur));
                    any = false;
                }
            }
            (None, '\'' | '"') => (quote, any) = (Some(c), true),
            (Some(q), c) if c == q => quote = None,
            (Some('\''), c) => cur.push(c),
            (_, '\\') => {
                cur.extend(chars.next());
                any = true;
            }
            (_, c) => {
                cur.push(c);
                any = true;
            }
        }
    }
    assert!(quote.is_none(), "unclosed quote in `{line}`");
    if any {
        out.push(cur);
    }
    out
}

/// The builtin renderer's scene cache every page's scratch folder shares (through a link at
/// `$XDG_CACHE_HOME/revelio/images/builtin`), as a user who follows the pages on one machine
/// shares one: the search page's interact search draws few of the scenes the README's first
/// command drew before it (42 → 17 s alone). Only the scenes are shared — a page's reply cache
/// stays its own, so what a command prints does not depend on which page ran first — and a
/// cached scene is the same image and figures as a drawn one (`src/render/scene_cache.rs`).
static SCENES: std::sync::OnceLock<tempfile::TempDir> = std::sync::OnceLock::new();

/// Runs commands in one scratch folder holding copies of the shipped files.
struct Scratch {
    dir: tempfile::TempDir,
    mock: String,
}

/// What a command printed.
#[derive(Clone)]
struct Ran {
    code: i32,
    stdout: String,
    stderr: String,
}

impl Scratch {
    fn new(mock: &str) -> Scratch {
        let dir = tempfile::tempdir().unwrap();
        let root = common::root();
        for folder in ["domains", "examples", "stdlib"] {
            copy_tree(&root.join(folder), &dir.path().join(folder));
        }
        copy_tree(&root.join("tests/doc_files"), dir.path());
        let images = dir.path().join(".cache/revelio/images");
        std::fs::create_dir_all(&images).unwrap();
        let scenes = SCENES.get_or_init(|| tempfile::tempdir().unwrap());
        std::os::unix::fs::symlink(scenes.path(), images.join("builtin")).unwrap();
        Scratch { dir, mock: mock.to_string() }
    }

    /// One command line: `revelio ARGS [< IN] [> OUT] [| head -N]`.
    fn run(&self, line: &str) -> Result<Ran, String> {
        let line = line.replace("$MOCK", &self.mock);
        let mut w = words(&line);
        let mut head = None;
        if let Some(p) = w.iter().position(|x| x == "|") {
            match &w[p + 1..] {
                [h, n] if h == "head" && n.starts_with('-') => head = n[1..].parse::<usize>().ok(),
                _ => return Err(format!("only `| head -N` may follow a command: `{line}`")),
            }
            w.truncate(p);
        }
        let redirect = |w: &mut Vec<String>, op: &str| {
            let p = w.iter().position(|x| x == op)?;
            let file = w.get(p + 1).cloned();
            w.drain(p..(p + 2).min(w.len()));
            file
        };
        let stdin = redirect(&mut w, "<");
        let stdout_to = redirect(&mut w, ">");
        if let Some(bad) = w.iter().find(|x| ["|", "<", ">", "&&", ";", "||"].contains(&x.as_str())) {
            return Err(format!("`{bad}` is not supported here: `{line}`"));
        }
        assert_eq!(w[0], "revelio");
        let d = self.dir.path();
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_revelio"));
        cmd.args(&w[1..]).current_dir(d).env("XDG_CACHE_HOME", d.join(".cache")).env("NO_COLOR", "1");
        for base in ["OPENAI_BASE_URL", "ANTHROPIC_BASE_URL", "GEMINI_BASE_URL", "BEDROCK_BASE_URL"] {
            cmd.env(base, &self.mock);
        }
        for key in
            ["OPENAI_API_KEY", "ANTHROPIC_API_KEY", "GEMINI_API_KEY", "AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY"]
        {
            cmd.env(key, "docs-test-key");
        }
        cmd.env("AWS_REGION", "us-east-1").env_remove("AWS_SESSION_TOKEN");
        match &stdin {
            Some(f) => cmd.stdin(std::fs::File::open(d.join(f)).map_err(|e| format!("`< {f}`: {e}"))?),
            None => cmd.stdin(Stdio::null()),
        };
        let o = cmd.output().unwrap();
        let mut stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        if let Some(f) = stdout_to {
            std::fs::write(d.join(f), &stdout).unwrap();
            stdout.clear();
        }
        if let Some(n) = head {
            stdout = stdout.lines().take(n).map(|l| format!("{l}\n")).collect();
        }
        Ok(Ran { code: o.status.code().unwrap_or(-1), stdout, stderr: String::from_utf8_lossy(&o.stderr).into_owned() })
    }
}

fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.is_dir() {
            copy_tree(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

/// A word that is a duration (`13.8s`, `250ms`, `1.2µs`, trailing punctuation kept) becomes
/// `<time>`: the one part of a shown output that differs from run to run.
fn redact(line: &str) -> String {
    let out: Vec<String> = line
        .split(' ')
        .map(|w| {
            let lead = w.len() - w.trim_start_matches('(').len();
            let (open, w) = w.split_at(lead);
            let core = w.trim_end_matches([',', '.', ')', ';']);
            let num = core.trim_end_matches("ms").trim_end_matches("µs").trim_end_matches('s');
            let is_time = num.len() < core.len()
                && !num.is_empty()
                && num.chars().all(|c| c.is_ascii_digit() || c == '.')
                && num.chars().next().is_some_and(|c| c.is_ascii_digit());
            if is_time { format!("{open}<time>{}", &w[core.len()..]) } else { format!("{open}{w}") }
        })
        .collect();
    out.join(" ").trim_end().to_string()
}

/// Does `line` match `pat`, where `…` in `pat` stands for any text?
fn line_matches(pat: &str, line: &str) -> bool {
    let parts: Vec<&str> = pat.split('…').collect();
    if parts.len() == 1 {
        return pat == line;
    }
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !line.starts_with(first) || !line[first.len()..].ends_with(last) {
        return false;
    }
    let mut rest = &line[first.len()..line.len() - last.len()];
    for p in &parts[1..parts.len() - 1] {
        match rest.find(p) {
            Some(i) => rest = &rest[i + p.len()..],
            None => return false,
        }
    }
    true
}

/// Do the shown lines match the printed ones? A shown line that is only `…` stands for any
/// number of lines.
fn output_matches(shown: &[String], printed: &[String]) -> bool {
    match shown.split_first() {
        None => printed.is_empty(),
        Some((s, rest)) if s.trim() == "…" => (0..=printed.len()).any(|k| output_matches(rest, &printed[k..])),
        Some((s, rest)) => {
            printed.split_first().is_some_and(|(p, prest)| line_matches(s, p) && output_matches(rest, prest))
        }
    }
}

/// Run one page's commands in order; the failures, each with where it is shown.
fn run_page(page: &str, shown: &[Shown], mock: &str) -> Vec<String> {
    let scratch = Scratch::new(mock);
    let mut failures = Vec::new();
    for s in shown {
        let at = format!("{}:{}: `{}`", page, s.line, s.command);
        if let Some(file) = s.command.strip_prefix("cat ") {
            let mut text = s.output.clone().unwrap_or_default().join("\n");
            text.push('\n');
            std::fs::write(scratch.dir.path().join(file.trim()), text).unwrap();
            continue;
        }
        if NOT_RUN.iter().any(|(c, _)| *c == s.command) {
            continue;
        }
        let reduced = REDUCED.iter().find(|(c, _, _)| *c == s.command);
        let lines: Vec<&str> = match reduced {
            Some((_, r, _)) => r.lines().map(str::trim).collect(),
            None => vec![s.command.as_str()],
        };
        let mut last = None;
        for l in lines {
            let started = std::time::Instant::now();
            let ran = run_once(&scratch, l);
            // For whoever trims the suite (`-- --nocapture`); never asserted.
            eprintln!("{:6.1}s  {page}:{}  {l}", started.elapsed().as_secs_f64(), s.line);
            match ran {
                Ok(r) if r.code != 0 && !shows_error(s) => {
                    failures.push(format!("{at} (run as `{l}`) exited {}:\n{}{}", r.code, r.stdout, r.stderr));
                    break;
                }
                Ok(r) => last = Some(r),
                Err(e) => {
                    failures.push(format!("{at}: {e}"));
                    break;
                }
            }
        }
        let (Some(r), Some(output)) = (last, &s.output) else { continue };
        if reduced.is_some() {
            // A command shown with nothing under it (the next `$` follows) shows no output.
            if !output.is_empty() {
                failures.extend(compare_stable(&at, &s.command, output, &r));
            }
            continue;
        }
        let printed: Vec<String> = format!("{}{}", r.stdout, r.stderr).lines().map(redact).collect();
        let want: Vec<String> = output.iter().map(|l| redact(l)).collect();
        if !output_matches(&want, &printed) {
            failures.push(format!("{at}: the page shows\n{}\nbut it prints\n{}", want.join("\n"), printed.join("\n")));
        }
        if shows_error(s) && r.code == 0 {
            failures.push(format!("{at}: the page shows an error, but it exited 0"));
        }
    }
    failures
}

/// A reduced command's shown output against what its reduced form printed: the lines [`STABLE`]
/// lists must be in both, in that order.
fn compare_stable(at: &str, command: &str, output: &[String], r: &Ran) -> Vec<String> {
    let Some((_, want)) = STABLE.iter().find(|(c, _)| *c == command) else {
        return vec![format!(
            "{at}: the page shows the full command's output but the test runs it reduced; list the lines that do not depend on the reduction in STABLE; the reduced form prints:\n{}{}",
            r.stdout, r.stderr
        )];
    };
    let shown: Vec<String> = output.iter().map(|l| shape(l)).collect();
    let printed: Vec<String> = format!("{}{}", r.stdout, r.stderr).lines().map(shape).collect();
    let mut failures = Vec::new();
    for (what, lines) in [("the page shows", &shown), ("the reduced form prints", &printed)] {
        if let Some(missing) = not_in_order(want, lines) {
            failures
                .push(format!("{at}: {what} no line `{missing}` (STABLE; numbers are `#`) in:\n{}", lines.join("\n")));
        }
    }
    failures
}

/// The first of `want` not found in `lines` after the one before it (`…` stands for any text).
fn not_in_order<'a>(want: &[&'a str], lines: &[String]) -> Option<&'a str> {
    let mut rest = lines.iter();
    want.iter().copied().find(|w| !rest.any(|l| line_matches(w, l)))
}

/// A line with its durations and numbers redacted (`#`) and its runs of spaces made one: what
/// stays when a smaller budget or fewer seeds change every figure.
fn shape(line: &str) -> String {
    let line = redact(line);
    let mut out = String::new();
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        if !c.is_ascii_digit() {
            out.push(c);
            continue;
        }
        out.push('#');
        while let Some(&n) = chars.peek() {
            let after_point = n == '.' && chars.clone().nth(1).is_some_and(|d| d.is_ascii_digit());
            if !(n.is_ascii_digit() || after_point) {
                break;
            }
            chars.next();
        }
    }
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// `revelio bench …` lines run or running, with what they printed: a bench reads only the
/// shipped files and writes no run folder, so the same line shown on several pages (or as a
/// figure's command) runs once; a second caller waits for the first.
type Once = std::sync::Arc<std::sync::OnceLock<Result<Ran, String>>>;
static BENCHES: std::sync::Mutex<Vec<(String, Once)>> = std::sync::Mutex::new(Vec::new());

/// `scratch.run(line)`, or a bench's result from its first run.
fn run_once(scratch: &Scratch, line: &str) -> Result<Ran, String> {
    if !line.starts_with("revelio bench ") {
        return scratch.run(line);
    }
    let cell = {
        let mut benches = BENCHES.lock().unwrap();
        match benches.iter().find(|(l, _)| l == line) {
            Some((_, c)) => c.clone(),
            None => {
                let c = Once::default();
                benches.push((line.to_string(), c.clone()));
                c
            }
        }
    };
    cell.get_or_init(|| scratch.run(line)).clone()
}

/// A shown output with an error in it: the command is expected to exit 1.
fn shows_error(s: &Shown) -> bool {
    s.output.as_ref().is_some_and(|o| {
        o.iter().any(|l| l.starts_with("error") || l.contains(": error[") || l.trim_start().starts_with("× "))
    })
}

fn all_blocks() -> Vec<Block> {
    let root = common::root();
    pages().iter().flat_map(|p| blocks(p, &std::fs::read_to_string(root.join(p)).unwrap())).collect()
}

/// Every command shown runs (as written, or as [`REDUCED`] says), and shows what it prints.
#[test]
fn every_command_shown_runs() {
    let blocks = all_blocks();
    // A `revelio` line in a block no test reads would escape it.
    for b in &blocks {
        let runs = b.body.iter().any(|l| revelio_line(l.trim_start_matches("$ ")).is_some());
        assert!(
            !runs || ["sh", "console"].contains(&b.info.as_str()),
            "{}:{}: a block with `revelio` commands is marked ```sh (commands) or ```console (commands and output), not ```{}",
            b.page,
            b.line,
            b.info
        );
    }
    let shown: Vec<Shown> = blocks.iter().flat_map(shown_commands).collect();
    assert!(shown.len() > 40, "the pages show {} commands; the extraction is broken", shown.len());
    run_all(shown);
}

/// Run commands, pages side by side (each in its own folder), a page's commands in order; fail
/// with every command that failed.
fn run_all(shown: Vec<Shown>) {
    let rt = tokio::runtime::Runtime::new().unwrap();
    let server = rt.block_on(async {
        let s = common::mock_server().await;
        Mock::given(method("POST")).respond_with(ResponseTemplate::new(200).set_body_json(reply())).mount(&s).await;
        s
    });
    let mock = server.uri();
    let mut by_page: Vec<(String, Vec<Shown>)> = Vec::new();
    for s in shown {
        match by_page.iter_mut().find(|(p, _)| *p == s.page) {
            Some((_, v)) => v.push(s),
            None => by_page.push((s.page.clone(), vec![s])),
        }
    }
    // The longest page first (threads pop from the end): a long page started last runs alone at
    // the end while the other threads idle. A command that searches (a debug build spends
    // seconds preparing a search of the driving lattice before its first call) or renders
    // weighs as five quick ones.
    let heavy = ["search", "campaign", "bench", "probe", "transfer", "validate", "render", "ask"];
    let weight = |shown: &[Shown]| -> usize {
        shown.iter().map(|s| if heavy.iter().any(|h| s.command.contains(h)) { 5 } else { 1 }).sum()
    };
    by_page.sort_by_cached_key(|(page, shown)| (weight(shown), std::cmp::Reverse(page.clone())));
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()).clamp(1, 4);
    let queue = std::sync::Mutex::new(by_page);
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                loop {
                    let Some((page, shown)) = queue.lock().unwrap().pop() else { break };
                    let f = run_page(&page, &shown, &mock);
                    failures.lock().unwrap().extend(f);
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    assert!(failures.is_empty(), "{} shown commands fail:\n\n{}", failures.len(), failures.join("\n\n"));
}

/// The pages whose figures must name their commands, and where: README.md's figure table,
/// docs/benchmarks.md in full.
const FIGURE_PAGES: &[(&str, bool)] = &[("README.md", true), ("docs/benchmarks.md", false)];

/// The text of a page outside its fenced blocks.
fn prose(text: &str) -> String {
    let mut out = String::new();
    let mut fenced = false;
    for l in text.lines() {
        if l.starts_with("```") {
            fenced = !fenced;
        } else if !fenced {
            out.push_str(l);
            out.push('\n');
        }
    }
    out
}

/// The inline code spans of `text`, whitespace (line breaks too) collapsed.
fn code_spans(text: &str) -> Vec<String> {
    text.split('`').skip(1).step_by(2).map(|s| s.split_whitespace().collect::<Vec<_>>().join(" ")).collect()
}

/// A span that names a command that produced a figure: `revelio …` with a flag or a path
/// (after `time`, `/usr/bin/time -v` or `cargo run [--release] --`), or `cargo bench --bench X`.
/// `cargo build --bench X` (a bench built to be run by hand) stands for `cargo bench --bench X`,
/// and a built binary's path (`target-dev/debug/revelio …`) for `revelio …`.
fn figure_command(span: &str) -> Option<String> {
    let s = span.strip_prefix("/usr/bin/time -v ").or_else(|| span.strip_prefix("time ")).unwrap_or(span);
    let s = s.split(' ').skip_while(|w| w.contains('=') && !w.starts_with('-')).collect::<Vec<_>>().join(" ");
    if let Some(name) = s.strip_prefix("cargo bench --bench ").or_else(|| s.strip_prefix("cargo build --bench ")) {
        // `cargo bench --bench NAME` names the tool, not a figure.
        return Some(format!("cargo bench --bench {name}")).filter(|_| name.chars().any(|c| c.is_ascii_lowercase()));
    }
    let (first, rest) = s.split_once(' ').unwrap_or((&s, ""));
    if first.contains('/') && first.ends_with("/revelio") {
        return revelio_line(&format!("revelio {rest}"));
    }
    revelio_line(&s).filter(|c| c.contains(" --") || c.contains('/'))
}

/// The per-stage pages: each table of figures there names the commands that produced them in a
/// code span of its section above it (the heading included) or of the table itself.
const STAGE_PAGES: &[&str] = &["docs/gp.md", "docs/lattice.md", "docs/models.md", "docs/render.md", "docs/sampling.md"];

/// A table cell holding a measurement: a number with a unit of time, rate or memory (`2.7 ms`,
/// `116 /s`, `5.9s`, `28 MB`; not a limit such as `≤ 20 MB`).
fn is_measurement(cell: &str) -> bool {
    const UNITS: &[&str] = &["ns", "µs", "ms", "s", "/s", "KB", "MB", "GB", "min"];
    let num = |n: &str| {
        n.chars().next().is_some_and(|c| c.is_ascii_digit())
            && n.chars().all(|c| c.is_ascii_digit() || ".–-".contains(c))
    };
    let words: Vec<&str> = cell.split_whitespace().map(|w| w.trim_matches(|c| "*,;()≈".contains(c))).collect();
    // `≤ 20 MB` is a limit, not a measurement.
    let limit = |i: usize| i > 0 && ["≤", "<", "≥", ">"].contains(&words[i - 1]);
    words.iter().enumerate().any(|(i, w)| {
        (num(w) && !limit(i) && words.get(i + 1).is_some_and(|u| UNITS.contains(u)))
            || UNITS.iter().any(|u| w.strip_suffix(u).is_some_and(num))
    })
}

/// The figure commands of a per-stage page's tables of figures, and the tables that name none.
fn stage_figure_commands(page: &str) -> (Vec<Shown>, Vec<String>) {
    let text = std::fs::read_to_string(common::root().join(page)).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let (mut out, mut failures) = (Vec::new(), Vec::new());
    let (mut section, mut in_fence, mut i) = (String::new(), false, 0);
    while i < lines.len() {
        let l = lines[i];
        if l.starts_with("```") {
            in_fence = !in_fence;
        }
        if in_fence || !l.starts_with('|') {
            if l.starts_with('#') && !in_fence {
                section.clear();
            }
            if !in_fence {
                section.push_str(l);
                section.push('\n');
            }
            i += 1;
            continue;
        }
        let start = i;
        while i < lines.len() && lines[i].starts_with('|') {
            i += 1;
        }
        let table = lines[start..i].join("\n");
        if !lines[start + 1..i].iter().any(|row| row.split('|').any(is_measurement)) {
            continue;
        }
        let commands: Vec<String> =
            code_spans(&format!("{section}{table}")).iter().filter_map(|s| figure_command(s)).collect();
        if commands.is_empty() {
            failures.push(format!(
                "{page}:{}: a table of figures whose section names no command that produced them",
                start + 1
            ));
        }
        for command in commands {
            if !out.iter().any(|s: &Shown| s.command == command) {
                out.push(Shown { page: page.into(), line: start + 1, command, output: None });
            }
        }
    }
    (out, failures)
}

/// The figure commands of a page: every such span of the page, or of its tables with a
/// `Command` column (where each row must have one).
fn figure_commands(page: &str, tables_only: bool) -> (Vec<Shown>, Vec<String>) {
    let text = std::fs::read_to_string(common::root().join(page)).unwrap();
    let (mut out, mut failures) = (Vec::new(), Vec::new());
    let mut column = None;
    let mut in_fence = false;
    for (i, l) in text.lines().enumerate() {
        if l.starts_with("```") {
            in_fence = !in_fence;
        }
        let cells: Vec<&str> = l.trim().trim_matches('|').split('|').map(str::trim).collect();
        if in_fence || !l.starts_with('|') {
            column = None;
        } else if column.is_none() {
            column = Some(cells.iter().position(|c| *c == "Command"));
        } else if let Some(Some(k)) = column
            && !l.starts_with("|---")
        {
            let cell = cells.get(k).copied().unwrap_or("");
            let spans: Vec<String> = code_spans(cell).iter().filter_map(|s| figure_command(s)).collect();
            if spans.is_empty() {
                failures.push(format!("{page}:{}: a figure without the command that produced it: {l}", i + 1));
            }
            if tables_only {
                out.extend(spans.into_iter().map(|command| Shown {
                    page: page.into(),
                    line: i + 1,
                    command,
                    output: None,
                }));
            }
        }
    }
    if !tables_only {
        for span in code_spans(&prose(&text)) {
            if let Some(command) = figure_command(&span) {
                // The line its first word is on, for the failure message.
                let first = span.split(' ').take(3).collect::<Vec<_>>().join(" ");
                let line = text.find(&first).map_or(0, |at| text[..at].matches('\n').count() + 1);
                out.push(Shown { page: page.into(), line, command, output: None });
            }
        }
    }
    (out, failures)
}

/// Every figure in README.md's figure table and in docs/benchmarks.md, and every table of
/// figures on a per-stage page ([`STAGE_PAGES`]), names the command that produced it, and that
/// command runs — in the reduced form [`REDUCED`] gives (fewer seeds, a
/// smaller budget), never timed; a `cargo bench --bench X` names a bench that exists.
#[test]
fn every_figure_names_a_command_that_runs() {
    let mut shown = Vec::new();
    let mut failures = Vec::new();
    for (page, tables_only) in FIGURE_PAGES {
        let (s, f) = figure_commands(page, *tables_only);
        shown.extend(s);
        failures.extend(f);
    }
    for page in STAGE_PAGES {
        let (s, f) = stage_figure_commands(page);
        shown.extend(s);
        failures.extend(f);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    let manifest = std::fs::read_to_string(common::root().join("Cargo.toml")).unwrap();
    // A figure's command that a page also shows in a block runs in `every_command_shown_runs`.
    let mut seen: BTreeSet<String> = all_blocks().iter().flat_map(shown_commands).map(|s| s.command).collect();
    assert!(shown.len() >= 8, "only {} figure commands found; the extraction is broken", shown.len());
    let mut runs = Vec::new();
    for s in shown {
        if let Some(bench) = s.command.strip_prefix("cargo bench --bench ") {
            let name = bench.split(' ').next().unwrap();
            assert!(
                manifest.contains(&format!("[[bench]]\nname = \"{name}\"")),
                "{}: `{}` names no bench of Cargo.toml",
                s.page,
                s.command
            );
        } else if seen.insert(s.command.clone()) {
            // A page's figures run in its order in one folder (`revelio report runs/demo` reads
            // the run the row above makes), apart from the folder of its blocks.
            runs.push(Shown { page: format!("{} (figures)", s.page), ..s });
        }
    }

    run_all(runs);
}

/// Every entry of [`REDUCED`] and [`NOT_RUN`] names a command some page still shows.
#[test]
fn no_stale_mapping() {
    let mut texts: BTreeSet<String> = all_blocks().iter().flat_map(shown_commands).map(|s| s.command).collect();
    for (page, tables_only) in FIGURE_PAGES {
        texts.extend(figure_commands(page, *tables_only).0.into_iter().map(|s| s.command));
    }
    for page in STAGE_PAGES {
        texts.extend(stage_figure_commands(page).0.into_iter().map(|s| s.command));
    }
    let stale: Vec<&str> =
        REDUCED.iter().map(|r| r.0).chain(NOT_RUN.iter().map(|n| n.0)).filter(|c| !texts.contains(*c)).collect();
    assert!(stale.is_empty(), "REDUCED/NOT_RUN name commands no page shows any more: {stale:#?}");
    let loose: Vec<&str> = STABLE.iter().map(|s| s.0).filter(|c| !REDUCED.iter().any(|r| r.0 == *c)).collect();
    assert!(loose.is_empty(), "STABLE names commands REDUCED does not: {loose:?}");
    let dup: Vec<&str> = REDUCED.iter().map(|r| r.0).filter(|c| NOT_RUN.iter().any(|n| n.0 == *c)).collect();
    assert!(dup.is_empty(), "both reduced and not run: {dup:?}");
}

/// Every ```` ```rev ```` block is a whole file that checks clean; a ```` ```rev fragment ````
/// parses (a line that is only `…` stands for text left out).
#[test]
fn every_rev_block_checks() {
    let mut failures = Vec::new();
    let mut count = 0;
    for b in all_blocks() {
        let fragment = match b.info.as_str() {
            "rev" => false,
            "rev fragment" => true,
            i if i.starts_with("rev") => {
                failures.push(format!("{}:{}: unknown marking ```{i} (```rev or ```rev fragment)", b.page, b.line));
                continue;
            }
            _ => continue,
        };
        count += 1;
        let text: String = b.body.iter().filter(|l| l.trim() != "…").map(|l| format!("{l}\n")).collect();
        let errors: Vec<String> = if fragment {
            revelio::syntax::parse(0, &text).diagnostics.iter().map(|d| format!("  {} {}", d.code, d.message)).collect()
        } else {
            match revelio::check::compile_source("snippet.rev", &text) {
                Ok(_) => vec![],
                Err(d) => d.iter().filter(|d| d.is_error()).map(|d| format!("  {} {}", d.code, d.message)).collect(),
            }
        };
        if !errors.is_empty() {
            let what = if fragment { "does not parse" } else { "does not check (mark a part ```rev fragment)" };
            failures.push(format!("{}:{}: {what}:\n{}", b.page, b.line, errors.join("\n")));
        }
    }
    assert!(count > 10, "only {count} rev blocks found");
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// The matcher itself: `…` lines and `…` inside a line, durations redacted.
#[test]
fn shown_output_matching() {
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    assert!(output_matches(&s(&["a", "…", "d"]), &s(&["a", "b", "c", "d"])));
    assert!(output_matches(&s(&["a", "…"]), &s(&["a"])));
    assert!(!output_matches(&s(&["a", "…", "e"]), &s(&["a", "b", "d"])));
    assert!(!output_matches(&s(&["a"]), &s(&["a", "b"])));
    assert!(line_matches("question: You are … stationary. …", "question: You are driving. All stationary. Then"));
    assert!(!line_matches("x … y", "x z"));
    assert_eq!(redact("in 13.8s (2.5ms each), 5 sets"), "in <time> (<time> each), 5 sets");
    assert_eq!(redact("town_town02s 5s"), "town_town02s <time>");
    assert_eq!(shape("random      4.5 [0.0–10.7]   1.6×, in 13.8s"), "random # [#–#] #×, in <time>");
    assert_eq!(not_in_order(&["a", "c"], &s(&["a", "b", "c"])), None);
    assert!(is_measurement(" **2.7 ms** (target < 5 ms) ") && is_measurement("63–87 /s") && is_measurement("in 5.9s"));
    assert!(!is_measurement("`Gp::draw`, d = 30") && !is_measurement("174 436") && !is_measurement("3.9×"));
    assert!(!is_measurement("inline requests (≤ 20 MB a batch)"));
    assert_eq!(figure_command("target-dev/debug/revelio bench scale").unwrap(), "revelio bench scale");
    assert_eq!(figure_command("CARGO_X=3 cargo build --bench sample").unwrap(), "cargo bench --bench sample");
    assert_eq!(not_in_order(&["c", "a"], &s(&["a", "b", "c"])), Some("a"));
    assert_eq!(words(r#"revelio a 'b c' "d e" f\ g"#), ["revelio", "a", "b c", "d e", "f g"]);
    assert_eq!(revelio_line("revelio x --format plain   # a comment").unwrap(), "revelio x --format plain");
    assert_eq!(revelio_line("cargo run --release -- search d.rev").unwrap(), "revelio search d.rev");
    assert_eq!(revelio_line("cargo test"), None);
}

/// Concept names on the command line that the domain lacks: the checker's "did you mean",
/// exit 1 (an input error), for every command that takes them.
#[test]
fn unknown_concepts_get_did_you_mean() {
    let scratch = Scratch::new("http://127.0.0.1:9");
    for line in [
        "revelio oracle domains/driving.rev pedestrain",
        "revelio emit scene domains/driving.rev pedestrain",
        "revelio emit prompt domains/driving.rev pedestrain",
        "revelio emit scenic domains/driving.rev pedestrain",
        "revelio render domains/driving.rev pedestrain -o x.png",
        "revelio ask domains/driving.rev pedestrain --model sim:examples/sim/driving_paper.toml",
    ] {
        let r = scratch.run(line).unwrap();
        assert_eq!(r.code, 1, "{line}: {}", r.stderr);
        assert!(
            r.stderr.contains("unknown concept `pedestrain` in domain `driving`; did you mean `pedestrian`?"),
            "{line}: {}",
            r.stderr
        );
    }
    // `lattice` takes no concept: a stray name is a usage error.
    let r = scratch.run("revelio lattice domains/driving.rev pedestrian").unwrap();
    assert_eq!(r.code, 2, "{}", r.stderr);
}
