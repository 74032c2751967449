//! Stopping a run cleanly: on Ctrl-C, or when the model keeps failing, no new model call starts,
//! the calls in flight finish and are journaled, the journal is synced, and the run ends with an
//! error that says how to resume (the same command).
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// Why a run stopped early.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StopReason {
    /// Ctrl-C (SIGINT).
    Interrupted,
    /// `count` model calls in a row ended in `api_error`; `last` is the last one's message.
    ApiErrors { count: u32, last: String },
    /// `--max-cost`: the next call's worst case would pass the cap of `cap` dollars.
    CostCap { cap: String, spent: String },
}

/// A shared stop request; cheap to clone. The first reason given wins.
#[derive(Clone, Default)]
pub struct Stop(Arc<Inner>);

#[derive(Default)]
struct Inner {
    requested: AtomicBool,
    reason: Mutex<Option<StopReason>>,
}

impl Stop {
    pub fn request(&self, reason: StopReason) {
        let mut r = self.0.reason.lock().unwrap_or_else(|p| p.into_inner());
        if r.is_none() {
            *r = Some(reason);
        }
        self.0.requested.store(true, Ordering::SeqCst);
    }

    pub fn requested(&self) -> bool {
        self.0.requested.load(Ordering::SeqCst)
    }

    pub fn reason(&self) -> Option<StopReason> {
        self.0.reason.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Request a stop on the first Ctrl-C (the calls in flight still finish and are journaled);
    /// `on_second` runs on a second one (the CLI exits at once: the journal is safe at any byte).
    /// Needs a tokio runtime.
    pub fn on_ctrl_c(&self, on_second: impl Fn() + Send + 'static) {
        let stop = self.clone();
        tokio::spawn(async move {
            if tokio::signal::ctrl_c().await.is_err() {
                return;
            }
            eprintln!("\nstopping: waiting for the model calls in flight to finish (Ctrl-C again to quit at once)");
            stop.request(StopReason::Interrupted);
            if tokio::signal::ctrl_c().await.is_ok() {
                on_second();
            }
        });
    }
}
