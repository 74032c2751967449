//! Diversity-aware beam search (paper Algorithm 1).
//!
//! Level t expands every frontier set by each concept that keeps it valid; the candidates are
//! evaluated in a fixed order (frontier rank, then concept index; duplicates reached from two
//! frontier sets are evaluated once), all of a level concurrently, until the budget runs out. The
//! next frontier is chosen greedily by value FR − λ·max Jaccard to the sets already chosen at this
//! level; ties go to the earlier candidate.
use crate::ir::ConceptSet;

use super::{Drive, Driver, Evaluate, Params, Searched, SetStats, Space};

pub async fn run<E: Evaluate>(params: &Params, space: &Space, driver: &mut Driver<'_, E>) -> Searched<(), E> {
    let mut frontier = vec![ConceptSet::EMPTY];
    for _level in 0..params.max_depth {
        let mut candidates: Vec<ConceptSet> = Vec::new();
        for f in &frontier {
            for c in space.extensions(*f) {
                if !candidates.contains(&c) {
                    candidates.push(c);
                }
            }
        }
        if candidates.is_empty() || !driver.can_start() {
            break;
        }
        let stats = driver.evaluate(&candidates).await?;
        if stats.len() < candidates.len() {
            // The budget ran out inside this level.
            break;
        }
        frontier = select(&stats, params.beam_width, params.lambda);
    }
    Ok(())
}

/// Greedy MMR selection of up to `width` sets.
pub fn select(candidates: &[SetStats], width: usize, lambda: f64) -> Vec<ConceptSet> {
    let mut chosen: Vec<ConceptSet> = Vec::with_capacity(width);
    let mut taken = vec![false; candidates.len()];
    while chosen.len() < width {
        let mut best: Option<(usize, f64)> = None;
        for (i, c) in candidates.iter().enumerate() {
            if taken[i] {
                continue;
            }
            let sim = chosen.iter().map(|s| c.set.jaccard(*s)).fold(0.0, f64::max);
            let v = c.value() - lambda * sim;
            if best.is_none_or(|(_, bv)| v > bv) {
                best = Some((i, v));
            }
        }
        let Some((i, _)) = best else { break };
        taken[i] = true;
        chosen.push(candidates[i].set);
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::outcome::Outcome;

    fn st(bits: u128, wrong: u32, n: u32) -> SetStats {
        let mut s = SetStats::new(ConceptSet::from_bits(bits));
        (0..n).for_each(|i| s.add(if i < wrong { Outcome::Wrong } else { Outcome::Correct }));
        s
    }

    #[test]
    fn selection_trades_failure_rate_for_diversity() {
        let c = [st(0b0011, 5, 5), st(0b0101, 5, 5), st(0b1100, 4, 5), st(0b1000_0001, 3, 5)];
        // λ = 0: pure failure rate, ties to the earlier candidate.
        assert_eq!(select(&c, 2, 0.0), vec![ConceptSet::from_bits(0b0011), ConceptSet::from_bits(0b0101)]);
        // λ = 1: {0,2} shares one of three concepts with {0,1} (penalty 1/3), {2,3} none.
        assert_eq!(select(&c, 2, 1.0), vec![ConceptSet::from_bits(0b0011), ConceptSet::from_bits(0b1100)]);
        assert_eq!(select(&c, 9, 0.5).len(), 4);
    }
}
