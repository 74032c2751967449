//! Revelio: find interpretable failure modes of vision-language models.
//!
//! Pipeline (see README "Architecture" and docs/architecture.md; `tests/layout.rs` keeps it a
//! straight line): [`diag`], [`hash`], [`date`] and [`outcome`] at the bottom → [`ir`] →
//! [`syntax`] (pest, with recovery) → [`check`] (resolution, types) → [`anchor`] → [`lattice`] →
//! [`oracle`] → [`lint`] / [`sample`] → [`emit`] → [`search`] (pure algorithms) → [`net`],
//! [`source`] → [`render`] → [`vlm`] → [`journal`] → [`run`] → [`analysis`] → [`report`] →
//! [`fmt`] → [`lsp`] → [`cli`]. The core (`diag` … `search`) does no I/O; files, network and GPU
//! live in `net`, `source`, `render`,
//! `vlm`, `journal`, `run`, `report` and `cli`.

pub mod analysis;
pub mod anchor;
pub mod check;
pub mod cli;
pub mod date;
pub mod diag;
#[cfg(test)]
mod editor_sync;
pub mod emit;
pub mod fmt;
pub mod hash;
pub mod ir;
pub mod journal;
pub mod lattice;
pub mod lint;
pub mod lsp;
pub mod net;
pub mod oracle;
pub mod outcome;
pub mod render;
pub mod report;
pub mod run;
pub mod sample;
pub mod scene;
pub mod search;
pub mod source;
pub mod syntax;
pub mod vlm;
