//! Token and money accounting per model, kept as running totals the progress bar and the run
//! summary read while calls are in flight.

use std::sync::atomic::{AtomicU64, Ordering};

use serde::Serialize;

use crate::outcome::Usage;

/// Prices in US dollars per million tokens (thinking tokens are billed as output).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Prices {
    pub input_per_mtok: f64,
    pub output_per_mtok: f64,
}

/// What a batch API charges of the live price: OpenAI Batch, Anthropic Message Batches and
/// Gemini batch mode all bill half the standard rate for input and output tokens.
pub const BATCH_DISCOUNT: f64 = 0.5;

impl Prices {
    /// The prices of the same model called through its provider's batch API.
    pub fn batch(self) -> Prices {
        Prices {
            input_per_mtok: self.input_per_mtok * BATCH_DISCOUNT,
            output_per_mtok: self.output_per_mtok * BATCH_DISCOUNT,
        }
    }

    pub fn cost(&self, input_tokens: u64, output_tokens: u64) -> f64 {
        (input_tokens as f64 * self.input_per_mtok + output_tokens as f64 * self.output_per_mtok) / 1e6
    }
}

/// A snapshot of a model's running totals.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Spend {
    /// Calls answered by the provider (cached replies excluded).
    pub calls: u64,
    /// Replies served from the cache.
    pub cached: u64,
    /// Calls that ended in an API error.
    pub errors: u64,
    pub input_tokens: u64,
    pub output_tokens: u64,
    pub thinking_tokens: u64,
    pub cost_usd: f64,
}

/// Lock-free running totals (cost kept in micro-dollars so it can be an atomic integer).
#[derive(Debug, Default)]
pub struct Ledger {
    calls: AtomicU64,
    cached: AtomicU64,
    errors: AtomicU64,
    input: AtomicU64,
    output: AtomicU64,
    thinking: AtomicU64,
    micro_usd: AtomicU64,
}

impl Ledger {
    pub fn record(&self, usage: &Usage, cached: bool, error: bool) {
        if cached {
            self.cached.fetch_add(1, Ordering::Relaxed);
            return;
        }
        self.calls.fetch_add(1, Ordering::Relaxed);
        if error {
            self.errors.fetch_add(1, Ordering::Relaxed);
        }
        self.input.fetch_add(usage.input_tokens, Ordering::Relaxed);
        self.output.fetch_add(usage.output_tokens, Ordering::Relaxed);
        self.thinking.fetch_add(usage.thinking_tokens, Ordering::Relaxed);
        self.micro_usd.fetch_add((usage.cost_usd * 1e6).round() as u64, Ordering::Relaxed);
    }

    pub fn snapshot(&self) -> Spend {
        Spend {
            calls: self.calls.load(Ordering::Relaxed),
            cached: self.cached.load(Ordering::Relaxed),
            errors: self.errors.load(Ordering::Relaxed),
            input_tokens: self.input.load(Ordering::Relaxed),
            output_tokens: self.output.load(Ordering::Relaxed),
            thinking_tokens: self.thinking.load(Ordering::Relaxed),
            cost_usd: self.micro_usd.load(Ordering::Relaxed) as f64 / 1e6,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prices_per_million_tokens() {
        let p = Prices { input_per_mtok: 3.0, output_per_mtok: 15.0 };
        assert!((p.cost(1_000, 200) - 0.006).abs() < 1e-12);
        assert_eq!(Prices::default().cost(10, 10), 0.0);
        assert!((p.batch().cost(1_000, 200) - 0.003).abs() < 1e-12);
    }

    #[test]
    fn ledger_totals_exclude_cached_replies() {
        let l = Ledger::default();
        let u = Usage { input_tokens: 100, output_tokens: 50, thinking_tokens: 20, cost_usd: 0.25 };
        l.record(&u, false, false);
        l.record(&u, true, false);
        l.record(&Usage::default(), false, true);
        let s = l.snapshot();
        assert_eq!((s.calls, s.cached, s.errors, s.input_tokens, s.thinking_tokens), (2, 1, 1, 100, 20));
        assert!((s.cost_usd - 0.25).abs() < 1e-9);
    }
}
