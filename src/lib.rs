//! Revelio: find interpretable failure modes of vision-language models.
//!
//! Pipeline (see README "Architecture"): `.rev` source → [`syntax`] (pest, with recovery) →
//! [`check`] (resolution, types) → [`ir::Domain`] → [`lattice`] / [`oracle`] / [`sample`] /
//! [`emit`] → [`render`] → [`vlm`] → [`search`] → [`journal`]. The core (syntax … search) does
//! no I/O; files, network and GPU live in `cli`, `vlm`, `render` and `journal`.

pub mod anchor;
pub mod check;
pub mod cli;
#[cfg(test)]
mod editor_sync;
pub mod emit;
pub mod fmt;
pub mod ir;
pub mod journal;
pub mod lattice;
pub mod oracle;
pub mod render;
pub mod sample;
pub mod scene;
pub mod search;
pub mod syntax;
pub mod vlm;
