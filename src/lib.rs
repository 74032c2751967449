//! Revelio: find interpretable failure modes of vision-language models.
//!
//! Pipeline (see README "Repository layout"; `tests/layout.rs` keeps it a straight line):
//! [`diag`] and [`outcome`] at the bottom → [`ir`] → [`syntax`] (pest, with recovery) →
//! [`check`] (resolution, types) → [`anchor`] → [`lattice`] → [`oracle`] → [`lint`] /
//! [`sample`] → [`emit`] → [`search`] (pure algorithms) → [`net`] → [`render`] → [`vlm`] →
//! [`journal`] → [`run`] → [`analysis`] → [`cli`]. The core (`diag` … `search`) does no I/O; files, network
//! and GPU live in `net`, `render`, `vlm`, `journal`, `run` and `cli`.

pub mod analysis;
pub mod anchor;
pub mod check;
pub mod cli;
pub mod diag;
#[cfg(test)]
mod editor_sync;
pub mod emit;
pub mod fmt;
pub mod ir;
pub mod journal;
pub mod lattice;
pub mod lint;
pub mod lsp;
pub mod net;
pub mod oracle;
pub mod outcome;
pub mod render;
pub mod run;
pub mod sample;
pub mod scene;
pub mod search;
pub mod syntax;
pub mod vlm;
