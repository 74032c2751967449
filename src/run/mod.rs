//! The search runtime at the I/O edge: the journaled evaluator that turns a concept set into
//! observations (scene → image → model → outcome, [`eval`]) and the runner that drives a whole run
//! on a run folder ([`runner`]). The algorithms it drives live in [`crate::search`] and do no I/O.

pub mod eval;
pub mod runner;
#[cfg(test)]
mod shrink_tests;
#[cfg(test)]
mod testkit;
#[cfg(test)]
mod tests;
