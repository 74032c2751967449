//! The run folder's format: what a run writes beside its journal and what the report and the
//! analyses read back. For now it holds [`Spend`]; the run's configuration, summary, rows and
//! validation are to join it here.
use serde::{Deserialize, Serialize};

use crate::outcome::Usage;

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
