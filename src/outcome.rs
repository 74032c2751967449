//! What one observation came to: the model's [`Answer`] (an option, or why there is none), the
//! [`Outcome`] recorded against the expected option, and the [`Usage`] it cost. Shared by the
//! model clients, the search algorithms (failure rates count outcomes), the journal and reports,
//! so it sits below all of them and imports nothing.

use serde::{Deserialize, Serialize};

/// How a model's reply ended, before comparing with the expected answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Answer {
    /// A parsed option index.
    Option(u32),
    /// No option could be read from the reply.
    Unparsed,
    /// The reply names more than one option.
    Ambiguous,
    /// The model declined to answer.
    Refusal,
    /// The provider blocked the prompt or reply (safety filters).
    Blocked,
    /// The reply was cut off (max tokens) before an answer.
    Truncated,
    /// The call failed (after bounded retries).
    ApiError,
}

/// The outcome recorded for an observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    Correct,
    Wrong,
    Unparsed,
    Ambiguous,
    Refusal,
    Blocked,
    Truncated,
    ApiError,
    /// The image generator refused to draw the scene (a safety filter, a text-only reply): no
    /// model was asked, so it is neither an answer nor a failed call.
    ImageBlocked,
    /// An entity a concept placed stayed unseen (hidden or washed out) in every scene tried for
    /// the observation: no model was asked, so it is neither an answer nor a failed call.
    Invisible,
    /// Every scene tried for the observation showed an image (or, without a renderer, a scene)
    /// already shown for its set in the run: no model was asked, so one scene is not counted
    /// twice. Neither an answer nor a failed call.
    Repeated,
}

impl Outcome {
    /// The outcome's one name, as the journal, `summary.json`, the terminal, the CSV tables and
    /// the docs spell it (`api_error`); the report shows it with spaces.
    pub fn name(self) -> &'static str {
        match self {
            Outcome::Correct => "correct",
            Outcome::Wrong => "wrong",
            Outcome::Unparsed => "unparsed",
            Outcome::Ambiguous => "ambiguous",
            Outcome::Refusal => "refusal",
            Outcome::Blocked => "blocked",
            Outcome::Truncated => "truncated",
            Outcome::ApiError => "api_error",
            Outcome::ImageBlocked => "image_blocked",
            Outcome::Invisible => "invisible",
            Outcome::Repeated => "repeated",
        }
    }

    /// Whether a model was asked (and so the observation is a model call, paid or cached).
    pub fn asked_a_model(self) -> bool {
        !matches!(self, Outcome::ImageBlocked | Outcome::Invisible | Outcome::Repeated)
    }
}

impl Outcome {
    pub fn from_answer(a: Answer, expected: u32) -> Outcome {
        match a {
            Answer::Option(o) if o == expected => Outcome::Correct,
            Answer::Option(_) => Outcome::Wrong,
            Answer::Unparsed => Outcome::Unparsed,
            Answer::Ambiguous => Outcome::Ambiguous,
            Answer::Refusal => Outcome::Refusal,
            Answer::Blocked => Outcome::Blocked,
            Answer::Truncated => Outcome::Truncated,
            Answer::ApiError => Outcome::ApiError,
        }
    }
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Usage {
    pub input_tokens: u64,
    /// Output tokens including thinking tokens.
    pub output_tokens: u64,
    /// Of the output tokens, how many were thinking.
    pub thinking_tokens: u64,
    /// Cost in US dollars from the model's configured prices (0 when unknown or cached).
    pub cost_usd: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_outcome_has_one_name_the_journal_spells_too() {
        let all = [
            Outcome::Correct,
            Outcome::Wrong,
            Outcome::Unparsed,
            Outcome::Ambiguous,
            Outcome::Refusal,
            Outcome::Blocked,
            Outcome::Truncated,
            Outcome::ApiError,
            Outcome::ImageBlocked,
            Outcome::Invisible,
            Outcome::Repeated,
        ];
        for o in all {
            assert_eq!(serde_json::to_value(o).unwrap(), serde_json::Value::from(o.name()), "{o:?}");
        }
    }
}
