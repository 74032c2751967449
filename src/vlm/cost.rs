//! Token and money accounting per model, kept as running totals the progress bar and the run
//! summary read while calls are in flight; the prices of the documented models; what a call may
//! cost at most ([`Pricing::worst_case`]) and the spend cap that reserves it before a call is
//! sent ([`Purse`], `--max-cost`); and the token estimates of `--dry-run`.
//!
//! Token estimates: a prompt's text is about 4 bytes a token ([`estimate_text_tokens`]); an
//! image about one token per 750 pixels after the model config's `image_max_side`
//! ([`estimate_image_tokens`], Anthropic's published rule, near OpenAI's and Gemini's for
//! images of a few hundred pixels a side). A reply in the prompt's answer format is about
//! [`ESTIMATED_REPLY_TOKENS`] tokens, plus the thinking budget when thinking is on. The worst
//! case a `--max-cost` reserves is never an estimate: a prompt's bytes (no tokenizer makes more
//! tokens than bytes), twice the image estimate, and the whole output cap (`max_tokens`, plus
//! `thinking_budget` where the provider bills it on top).

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

/// Built-in prices (US dollars per million input and output tokens) of the models the README
/// and the docs name, for a model config that gives none; a config's `price_input_per_mtok` /
/// `price_output_per_mtok` always win. Matched on the model name after the provider prefix,
/// longest entry first (`gpt-4.1-mini` before `gpt-4.1`); Bedrock ids match on the Anthropic
/// name they contain. Published list prices, standard tier, as of 2025-11; docs/models.md says
/// which of them were confirmed on the providers' own pages when last checked (2026-11-27).
const BUILTIN_PRICES: &[(&str, f64, f64)] = &[
    ("gpt-4.1-nano", 0.10, 0.40),
    ("gpt-4.1-mini", 0.40, 1.60),
    ("gpt-4.1", 2.00, 8.00),
    ("gpt-4o-mini", 0.15, 0.60),
    ("gpt-4o", 2.50, 10.00),
    ("gpt-5-mini", 0.25, 2.00),
    ("gpt-5-nano", 0.05, 0.40),
    ("gpt-5", 1.25, 10.00),
    ("claude-haiku-4-5", 1.00, 5.00),
    ("claude-sonnet-4-6", 3.00, 15.00),
    ("claude-sonnet-4-5", 3.00, 15.00),
    ("claude-sonnet-4", 3.00, 15.00),
    ("claude-opus-4-1", 15.00, 75.00),
    ("gemini-3-flash-preview", 0.50, 3.00),
    ("gemini-3-pro-preview", 2.00, 12.00),
    ("gemini-2.5-flash-lite", 0.10, 0.40),
    ("gemini-2.5-flash", 0.30, 2.50),
    ("gemini-2.5-pro", 1.25, 10.00),
];

/// The built-in price of `spec` (`provider:model`), if Revelio knows it.
pub fn builtin_prices(spec: &str) -> Option<Prices> {
    let name = spec.split_once(':').map_or(spec, |(_, n)| n);
    let mut known: Vec<&(&str, f64, f64)> = BUILTIN_PRICES.iter().collect();
    known.sort_by_key(|(n, ..)| std::cmp::Reverse(n.len()));
    known
        .into_iter()
        .find(|(n, ..)| name == *n || name.starts_with(&format!("{n}-")) || name.contains(&format!(".{n}")))
        .map(|&(_, i, o)| Prices { input_per_mtok: i, output_per_mtok: o })
}

/// A reply in the prompt's answer format (`…\nAnswer: B`), in tokens: what a dry run assumes a
/// model writes without thinking.
pub const ESTIMATED_REPLY_TOKENS: u64 = 16;

/// About 4 bytes a token for English prompt text.
pub fn estimate_text_tokens(text: &str) -> u64 {
    (text.len() as u64).div_ceil(4)
}

/// About one token per 750 pixels, after downscaling to `max_side` (aspect kept).
pub fn estimate_image_tokens(width: u32, height: u32, max_side: Option<u32>) -> u64 {
    let (mut w, mut h) = (f64::from(width), f64::from(height));
    if let Some(m) = max_side.map(f64::from) {
        let scale = (m / w.max(h)).min(1.0);
        w *= scale;
        h *= scale;
    }
    ((w * h) / 750.0).ceil() as u64
}

/// What one call of a model costs: its prices and its output bounds.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pricing {
    pub prices: Prices,
    /// `max_tokens`: the most output tokens one reply may have.
    pub max_output_tokens: u64,
    /// A fixed thinking budget billed as output (Anthropic `budget_tokens`, Gemini
    /// `thinkingBudget`), 0 when none.
    pub thinking_budget: u64,
    /// Longest image side sent (`image_max_side`).
    pub image_max_side: Option<u32>,
    /// Whether thinking is on (a dry run then expects the thinking budget, or a quarter of
    /// `max_tokens`, to be spent).
    pub thinking: bool,
}

impl Pricing {
    /// The most one call with this prompt and image may cost: every byte a token, twice the
    /// image estimate, the whole output cap.
    pub fn worst_case(&self, prompt: &str, image: Option<(u32, u32)>) -> f64 {
        let image = image.map_or(0, |(w, h)| 2 * estimate_image_tokens(w, h, self.image_max_side) + 100);
        let input = prompt.len() as u64 + image;
        self.prices.cost(input, self.max_output_tokens + self.thinking_budget)
    }

    /// The output tokens a dry run expects of one reply.
    pub fn expected_output_tokens(&self) -> u64 {
        let thinking = match (self.thinking, self.thinking_budget) {
            (false, _) => 0,
            (true, 0) => self.max_output_tokens / 4,
            (true, b) => b,
        };
        (ESTIMATED_REPLY_TOKENS + thinking).min(self.max_output_tokens.max(1) + self.thinking_budget)
    }
}

/// A spend cap shared by every call of a command (or of a campaign): before a call is sent its
/// worst case is reserved, and refused when what is spent and reserved would pass the cap;
/// when the call ends the reservation is replaced by what it cost. So the spend never passes
/// the cap, whatever finishes in which order. Amounts in micro-dollars.
#[derive(Debug)]
pub struct Purse {
    cap: u64,
    state: std::sync::Mutex<PurseState>,
}

#[derive(Debug, Default)]
struct PurseState {
    spent: u64,
    reserved: u64,
}

/// A reservation: hand it back to [`Purse::settle`] with what the call cost.
#[derive(Debug)]
#[must_use]
pub struct Reservation(u64);

fn micro(usd: f64) -> u64 {
    (usd.max(0.0) * 1e6).ceil() as u64
}

impl Purse {
    /// A cap of `cap_usd`, of which `spent_usd` is already spent (a resumed run's journal).
    pub fn new(cap_usd: f64, spent_usd: f64) -> Purse {
        Purse { cap: micro(cap_usd), state: std::sync::Mutex::new(PurseState { spent: micro(spent_usd), reserved: 0 }) }
    }

    /// Count `usd` already spent (a run folder opened later in a campaign).
    pub fn add_spent(&self, usd: f64) {
        self.state.lock().unwrap_or_else(|p| p.into_inner()).spent += micro(usd);
    }

    /// Reserve `worst_usd`, or `None` when it would pass the cap.
    pub fn reserve(&self, worst_usd: f64) -> Option<Reservation> {
        let amount = micro(worst_usd);
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        if s.spent + s.reserved + amount > self.cap {
            return None;
        }
        s.reserved += amount;
        Some(Reservation(amount))
    }

    /// The call ended having cost `cost_usd` (0 for a cached reply).
    pub fn settle(&self, r: Reservation, cost_usd: f64) {
        let mut s = self.state.lock().unwrap_or_else(|p| p.into_inner());
        s.reserved -= r.0;
        s.spent += micro(cost_usd);
    }

    /// Dollars spent so far.
    pub fn spent(&self) -> f64 {
        self.state.lock().unwrap_or_else(|p| p.into_inner()).spent as f64 / 1e6
    }

    pub fn cap(&self) -> f64 {
        self.cap as f64 / 1e6
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
    fn builtin_prices_match_the_longest_name() {
        assert_eq!(builtin_prices("openai:gpt-4.1-mini").unwrap().input_per_mtok, 0.40);
        assert_eq!(builtin_prices("openai:gpt-4.1").unwrap().input_per_mtok, 2.00);
        assert_eq!(builtin_prices("anthropic:claude-haiku-4-5-20251001").unwrap().output_per_mtok, 5.00);
        assert_eq!(
            builtin_prices("bedrock:us.anthropic.claude-haiku-4-5-20251001-v1:0").unwrap().output_per_mtok,
            5.00
        );
        assert_eq!(builtin_prices("openai:my-local-qwen"), None);
    }

    #[test]
    fn a_purse_never_passes_its_cap() {
        let p = Purse::new(1.0, 0.25);
        let a = p.reserve(0.5).expect("0.75 of 1.00");
        assert!(p.reserve(0.3).is_none(), "0.25 spent + 0.5 reserved + 0.3 > 1.0");
        p.settle(a, 0.1);
        assert!((p.spent() - 0.35).abs() < 1e-9);
        let b = p.reserve(0.65).expect("exactly the cap");
        assert!(p.reserve(0.000_001).is_none());
        p.settle(b, 0.0);
        assert!((p.spent() - 0.35).abs() < 1e-9);
    }

    #[test]
    fn worst_case_bounds_the_estimate() {
        let pricing = Pricing {
            prices: Prices { input_per_mtok: 1.0, output_per_mtok: 4.0 },
            max_output_tokens: 1000,
            thinking_budget: 0,
            image_max_side: None,
            thinking: false,
        };
        let prompt = "What should the car do?\n(A) stop\n(B) go\nAnswer with the letter.";
        let expected = pricing.prices.cost(
            estimate_text_tokens(prompt) + estimate_image_tokens(640, 360, None),
            pricing.expected_output_tokens(),
        );
        assert!(pricing.worst_case(prompt, Some((640, 360))) > 10.0 * expected);
        assert_eq!(estimate_image_tokens(1280, 720, Some(640)), 308);
        let mut png = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR".to_vec();
        png.extend(640u32.to_be_bytes());
        png.extend(360u32.to_be_bytes());
        assert_eq!(crate::render::png_size(&png), Some((640, 360)));
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
