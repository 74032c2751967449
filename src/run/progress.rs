//! Progress of a run on stderr: an indicatif bar on a terminal; elsewhere (nohup, CI logs, a
//! pipe) a plain line every few seconds and one at the end, so a log shows the run is alive and
//! how far it got. Both name the phase, say what it counts (a search its failure modes, a
//! validation the sets failing at FR ≥ 80 %; probe and transfer count none) and show the
//! effective concurrency.
use std::io::{IsTerminal, Write};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::estimate::thousands;
use super::summary::Spend;

/// Where progress goes.
#[derive(Clone, Default)]
pub enum ProgressTo {
    /// Nowhere (`--json`, benchmarks, tests).
    #[default]
    Off,
    /// stderr: a bar on a terminal, else a plain line every `every`.
    Stderr { every: Duration },
    /// Plain lines every `every` into a buffer (tests).
    Lines { every: Duration, to: Arc<Mutex<Vec<u8>>> },
}

/// Seconds between plain progress lines on stderr when it is not a terminal.
pub const PLAIN_EVERY: Duration = Duration::from_secs(10);

struct State {
    label: &'static str,
    done: u64,
    total: u64,
    failure_modes: usize,
    tokens: u64,
    cost_usd: f64,
    concurrency: usize,
    started: Instant,
}

/// What a phase's count of failing sets is called (`None`: the phase counts none).
fn counted(label: &str) -> Option<&'static str> {
    match label {
        "search" | "shrink" => Some("failure modes"),
        "validate" => Some("sets failing at FR ≥ 80%"),
        _ => None,
    }
}

impl State {
    fn count(&self) -> String {
        counted(self.label).map_or_else(String::new, |what| format!("{} {what} · ", self.failure_modes))
    }

    fn line(&self) -> String {
        format!(
            "{}: {}/{} inferences · {}{} tokens · ${:.4} · concurrency {} · {:.0}s",
            self.label,
            thousands(self.done),
            thousands(self.total),
            self.count(),
            thousands(self.tokens),
            self.cost_usd,
            self.concurrency,
            self.started.elapsed().as_secs_f64()
        )
    }

    fn message(&self) -> String {
        format!(
            "{}{} tokens · ${:.4} · concurrency {}",
            self.count(),
            thousands(self.tokens),
            self.cost_usd,
            self.concurrency
        )
    }
}

enum Sink {
    Stderr,
    Buffer(Arc<Mutex<Vec<u8>>>),
}

impl Sink {
    fn write_line(&self, line: &str) {
        match self {
            Sink::Stderr => {
                let _ = writeln!(std::io::stderr().lock(), "{line}");
            }
            Sink::Buffer(b) => {
                let _ = writeln!(b.lock().unwrap_or_else(|p| p.into_inner()), "{line}");
            }
        }
    }
}

/// The progress of one phase of a run.
pub struct Progress {
    state: Arc<Mutex<State>>,
    bar: Option<indicatif::ProgressBar>,
    plain: Option<(Arc<Sink>, tokio::task::JoinHandle<()>)>,
}

impl Progress {
    /// Start showing progress of `total` inferences. Plain lines come from a timer task, so this
    /// must be called inside a tokio runtime.
    pub fn start(to: &ProgressTo, label: &'static str, total: u64, concurrency: usize) -> Progress {
        let state = Arc::new(Mutex::new(State {
            label,
            done: 0,
            total,
            failure_modes: 0,
            tokens: 0,
            cost_usd: 0.0,
            concurrency,
            started: Instant::now(),
        }));
        let (sink, every) = match to {
            ProgressTo::Off => return Progress { state, bar: None, plain: None },
            ProgressTo::Stderr { .. } if std::io::stderr().is_terminal() => {
                let bar = indicatif::ProgressBar::new(total);
                bar.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{prefix}: {bar:30} {pos}/{len} inferences · {msg} · ETA {eta}",
                    )
                    .expect("the template is valid"),
                );
                bar.set_prefix(label);
                bar.set_message(state.lock().unwrap_or_else(|p| p.into_inner()).message());
                return Progress { state, bar: Some(bar), plain: None };
            }
            ProgressTo::Stderr { every } => (Sink::Stderr, *every),
            ProgressTo::Lines { every, to } => (Sink::Buffer(to.clone()), *every),
        };
        let sink = Arc::new(sink);
        let (s, k) = (state.clone(), sink.clone());
        let ticker = tokio::spawn(async move {
            let mut tick = tokio::time::interval(every.max(Duration::from_millis(10)));
            tick.tick().await;
            loop {
                tick.tick().await;
                let line = s.lock().unwrap_or_else(|p| p.into_inner()).line();
                k.write_line(&line);
            }
        });
        Progress { state, bar: None, plain: Some((sink, ticker)) }
    }

    fn update(&self, f: impl FnOnce(&mut State)) {
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        f(&mut s);
        if let Some(bar) = &self.bar {
            bar.set_prefix(s.label);
            bar.set_position(s.done);
            bar.set_message(s.message());
        }
    }

    /// One more inference done (asked or replayed), with the run's spend so far.
    pub fn inc(&self, spend: &Spend) {
        self.update(|s| {
            s.done += 1;
            s.tokens = spend.input_tokens + spend.output_tokens;
            s.cost_usd = spend.cost_usd;
        });
    }

    /// The phase the line names (a search goes on into its shrink phase).
    pub fn set_label(&self, label: &'static str) {
        self.update(|s| s.label = label);
    }

    pub fn set_failure_modes(&self, n: usize) {
        self.update(|s| s.failure_modes = n);
    }

    /// Stop the timer and the bar; plain output ends with a last line.
    pub fn finish(&mut self) {
        if let Some(bar) = self.bar.take() {
            bar.finish_and_clear();
        }
        if let Some((sink, ticker)) = self.plain.take() {
            ticker.abort();
            let line = self.state.lock().unwrap_or_else(|p| p.into_inner()).line();
            sink.write_line(&line);
        }
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        self.finish();
    }
}
