//! Analyses of a finished run, above the runtime: recognition vs. reasoning and lift
//! ([`probe`]), transfer to other models ([`transfer`]), runs compared ([`compare`]), ablation sweeps and their plot ([`sweep`]), and the drivers that ask a run's sets
//! again through the one observe pipeline ([`reask`]). The computations are pure functions of
//! observations; only `reask` does I/O (through `run`).

pub mod compare;
pub mod probe;
pub mod reask;
pub mod sweep;
#[cfg(test)]
mod tests;
pub mod transfer;
