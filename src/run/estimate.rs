//! What a command will spend, before it spends it (`--dry-run`): the model calls it makes — a
//! maximum where sampling is sequential or a budget caps a search that may stop earlier — and
//! the tokens and dollars they come to, estimated from the real prompts of the sets it would ask
//! about and the renderer's image size, at the model's prices ([`crate::vlm::cost`]). Nothing
//! here writes a file or opens a connection.
use serde::Serialize;

use crate::ir::{ConceptSet, Domain};
use crate::vlm::Model;
use crate::vlm::cost::{ESTIMATED_REPLY_TOKENS, Pricing, estimate_image_tokens, estimate_text_tokens};

use super::observe::World;

/// One model's share of a command's calls.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    /// The phase or command (`search`, `validate`, `probe`, `transfer`).
    pub what: String,
    pub model: String,
    pub calls: u64,
    /// `calls` is a maximum (sequential sampling, a budget the search may not use up).
    pub at_most: bool,
    pub input_tokens: u64,
    pub output_tokens: u64,
    /// `None`: an API model without a price (its model config gives none and Revelio knows no
    /// list price); 0 for a model that costs nothing (`sim`).
    pub cost_usd: Option<f64>,
}

impl Estimate {
    /// `calls` calls of `model` with prompts like `prompts` (a sample of the real ones) and an
    /// image of `image` pixels.
    pub fn new(
        what: &str,
        model: &dyn Model,
        calls: u64,
        at_most: bool,
        prompts: &[String],
        image: Option<(u32, u32)>,
    ) -> Estimate {
        let pricing: Option<Pricing> = model.pricing();
        let image_tokens =
            image.map_or(0, |(w, h)| estimate_image_tokens(w, h, pricing.and_then(|p| p.image_max_side)));
        let per_call = if prompts.is_empty() {
            0.0
        } else {
            prompts.iter().map(|p| estimate_text_tokens(p) as f64).sum::<f64>() / prompts.len() as f64
        };
        let input_tokens = (calls as f64 * (per_call + image_tokens as f64)).round() as u64;
        let output_tokens = calls * pricing.map_or(ESTIMATED_REPLY_TOKENS, |p| p.expected_output_tokens());
        let cost_usd = match pricing {
            None => Some(0.0),
            Some(p) if p.prices.input_per_mtok > 0.0 || p.prices.output_per_mtok > 0.0 => {
                Some(p.prices.cost(input_tokens, output_tokens))
            }
            Some(_) => None,
        };
        Estimate { what: what.into(), model: model.id(), calls, at_most, input_tokens, output_tokens, cost_usd }
    }

    /// `search: at most 1,250 calls to M, about 190,400 input / 20,000 output tokens, about $0.12`.
    pub fn line(&self) -> String {
        let bound = if self.at_most { "at most " } else { "" };
        let cost = match self.cost_usd {
            Some(c) if c >= 0.01 || c == 0.0 => format!("about ${c:.2}"),
            Some(c) => format!("about ${c:.4}"),
            None => {
                "no price known (give `price_input_per_mtok` / `price_output_per_mtok` in the model config)".to_string()
            }
        };
        format!(
            "{}: {bound}{} calls to {}, about {} input / {} output tokens, {cost}",
            self.what,
            thousands(self.calls),
            self.model,
            thousands(self.input_tokens),
            thousands(self.output_tokens)
        )
    }
}

/// The sum line of several estimates: `total: at most N calls, about $X`.
pub fn total_line(all: &[Estimate]) -> String {
    let calls: u64 = all.iter().map(|e| e.calls).sum();
    let bound = if all.iter().any(|e| e.at_most) { "at most " } else { "" };
    let cost = all.iter().filter_map(|e| e.cost_usd).fold(0.0, |a, b| a + b);
    let unpriced = all.iter().filter(|e| e.cost_usd.is_none() && e.calls > 0).count();
    let note = if unpriced > 0 { format!(" (+ {unpriced} without a price)") } else { String::new() };
    let cost = if cost > 0.0 && cost < 0.01 { format!("{cost:.4}") } else { format!("{cost:.2}") };
    format!(
        "total: {bound}{} calls, about ${cost}{note}; nothing was written and no model was called",
        thousands(calls)
    )
}

/// The image a renderer spec draws, in pixels (`None`: no image is sent).
pub fn image_size(renderer: &str, domain: &Domain) -> Option<(u32, u32)> {
    match renderer {
        "none" => None,
        "builtin" => Some((domain.camera.width, domain.camera.height)),
        // Image generators draw about a megapixel.
        _ => Some((1024, 1024)),
    }
}

/// The safety prompts of up to 64 of `sets`, spread evenly over them (sets without a ground
/// truth left out).
pub fn sample_prompts(world: &dyn World, sets: &[ConceptSet]) -> Vec<String> {
    let step = sets.len().div_ceil(64).max(1);
    sets.iter()
        .step_by(step)
        .filter_map(|s| world.task(*s).ok())
        .map(|t| crate::vlm::prompt::build(&t.question, &t.options))
        .collect()
}

/// `1234567` as `1,234,567`.
pub fn thousands(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thousands_separators() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1000), "1,000");
        assert_eq!(thousands(1_234_567), "1,234,567");
    }
}
