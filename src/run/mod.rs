//! The search runtime at the I/O edge: the one observation pipeline ([`observe`]), the journaled
//! evaluator that runs observations concurrently ([`eval`]), model and renderer setup
//! ([`setup`]), the runner that drives a whole run on a run folder ([`runner`]), and the run
//! folder's format ([`summary`]). The algorithms it drives live in [`crate::search`] and do no
//! I/O.
//!
//! Exit codes of the commands built on it: 0 success, 1 an error in the input or the run
//! (including a run stopped by repeated model-call failures, or one that ended with a large
//! share of them), 2 a usage error (a bad flag value, an unknown model or renderer spec), 130
//! interrupted by Ctrl-C after journaling the calls in flight.

pub mod campaign;
#[cfg(test)]
mod confirm_tests;
pub mod distinct;
#[cfg(test)]
mod distinct_tests;
pub mod estimate;
pub mod eval;
pub mod observe;
pub mod progress;
pub mod render_pool;
pub mod runner;
pub mod setup;
#[cfg(test)]
mod shrink_tests;
pub mod stop;
pub mod summary;
#[cfg(test)]
mod testkit;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod undrawn_tests;
#[cfg(feature = "render")]
pub mod visible;

use std::path::PathBuf;

pub use observe::{ObsKey, Observation, ObserveError, Observer, Stimulus, Task, World};
pub use stop::{Stop, StopReason};

use crate::journal::JournalError;

/// Default for `--max-api-errors`: model calls in a row that may end in `api_error` (after each
/// call's own bounded retries) before the run stops.
pub const MAX_API_ERRORS: u32 = 10;

/// A finished run whose share of `api_error` observations reaches this ends with exit 1.
pub const API_ERROR_SHARE_LIMIT: f64 = 0.1;

/// Why a run folder cannot be resumed with this configuration.
#[derive(Debug, thiserror::Error)]
pub enum ResumeError {
    #[error(
        "cannot resume `{}`: it holds a run with a different configuration ({}); use another `--out` folder or the same settings",
        dir.display(), diffs.join(", ")
    )]
    Differs { dir: PathBuf, diffs: Vec<String> },
    #[error(
        "cannot resume `{}`: it was written by an older revelio (run folder format {found}; this one reads format {expected}); start a new `--out` folder",
        dir.display()
    )]
    Format { dir: PathBuf, found: u64, expected: u64 },
    #[error("cannot resume `{}`: config.json is not a run configuration: {message}", dir.display())]
    BadConfig { dir: PathBuf, message: String },
    #[error(
        "cannot resume `{}` with `--budget {now}`: it is a run of {was} model calls and has made {made}; give `--budget {was}` or more (or leave it out), or use another `--out` folder",
        dir.display()
    )]
    BudgetLowered { dir: PathBuf, was: u64, now: u64, made: u64 },
    #[error(
        "cannot resume `{}` with `--budget {now}`: it was written when `--budget` left out the shrink phase, and its {search} search and {shrink} shrink calls are `--budget {} --shrink {shrink}` now; leave `--budget` out to go on, or give a larger one to extend it",
        dir.display(), search + shrink
    )]
    OldBudgetRule { dir: PathBuf, search: u64, shrink: u64, now: u64 },
    #[error(
        "cannot resume `{}` with `--shrink {}`: the run set aside {} for shrinking and gave its search {}; the search may not get less (now {}) nor the shrink phase (raise `--budget` with `--shrink`)",
        dir.display(), shrink.1, shrink.0, search.0, search.1
    )]
    SearchCut { dir: PathBuf, shrink: (u64, u64), search: (u64, u64) },
    #[error("cannot resume: line {line} of `{}` names a set this domain does not have: {message}", dir.join("journal.jsonl").display())]
    UnknownSet { dir: PathBuf, line: usize, message: String },
}

/// Why a run (search or validation) ended without its result.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A value the user gave (a flag) is out of range.
    #[error("{0}")]
    Usage(String),
    #[error(transparent)]
    Journal(#[from] JournalError),
    #[error(transparent)]
    Resume(#[from] ResumeError),
    #[error(transparent)]
    Observe(ObserveError),
    /// A search algorithm failed (its message).
    #[error("{0}")]
    Search(String),
    #[error("{}", stopped_message(.0))]
    Stopped(StopReason),
}

impl From<ObserveError> for RunError {
    /// A call the spend cap kept back stops the run like Ctrl-C: what is in flight is journaled.
    fn from(e: ObserveError) -> RunError {
        match e {
            ObserveError::CostCap { cap, spent } => {
                RunError::Stopped(StopReason::CostCap { cap: format!("{cap:.4}"), spent: format!("{spent:.4}") })
            }
            e => RunError::Observe(e),
        }
    }
}

fn stopped_message(r: &StopReason) -> String {
    match r {
        StopReason::Interrupted => "interrupted; the calls in flight were journaled".to_string(),
        StopReason::ApiErrors { count, last } => {
            format!("stopped after {count} model calls in a row failed; the last: {last}")
        }
        StopReason::CostCap { cap, spent } => format!(
            "stopped at the spend cap: ${spent} spent of `--max-cost {cap}` (the next call could pass it); the calls in flight were journaled"
        ),
    }
}

impl RunError {
    /// The process exit code for this error (see the module docs).
    pub fn exit_code(&self) -> u8 {
        match self {
            RunError::Usage(_) => 2,
            RunError::Stopped(StopReason::Interrupted) => 130,
            _ => 1,
        }
    }

    /// Whether the run folder holds everything done so far and the same command resumes it.
    pub fn resumable(&self) -> bool {
        matches!(self, RunError::Stopped(_))
    }
}
