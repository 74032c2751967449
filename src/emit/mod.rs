//! Emitters: a sampled [`Scene`](crate::scene::Scene) as a Scenic program for the CARLA model
//! ([`scenic`](mod@scenic)), an image-generation prompt ([`prompt`](mod@prompt)), or JSON (`revelio emit scene`).

pub mod prompt;
pub mod scenic;
mod template;

pub use prompt::prompt;
pub use scenic::{ScenicOptions, scenic};

/// Why a scene cannot be emitted.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct EmitError(pub String);
