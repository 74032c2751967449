//! Random search: sets drawn uniformly from the valid lattice, without repeats.
//!
//! The draws are a seeded Fisher–Yates shuffle cut short, so the first n picks do not depend on
//! how many are drawn: raising the budget of a run extends its sequence of sets instead of
//! drawing a different one (the journal replays the first part). A sampled space (a lattice past
//! `--max-sets`) draws from the lattice's diagram instead, a repeat drawn again: the same
//! prefix property, in memory that grows with the draws.
use std::collections::{HashMap, HashSet};

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Drive, Driver, Evaluate, Params, Searched, Space};

pub async fn run<E: Evaluate>(params: &Params, space: &Space, driver: &mut Driver<'_, E>) -> Searched<(), E> {
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let n = (driver.remaining() / u64::from(params.samples)) as usize;
    if space.is_sampled() {
        let picks = distinct_draws(&mut rng, space, n);
        driver.evaluate(&picks).await?;
        return Ok(());
    }
    let n = n.min(space.sets.len());
    // All draws are made up front — as many as the budget could pay at m observations each — and
    // evaluated in order: with the fixed count as one batch at full concurrency; with sequential
    // sampling the driver works through them in chunks until the budget is spent. The order is a
    // pure function of the seed, and a prefix of the order drawn under a larger budget.
    let picks: Vec<_> = shuffled_prefix(&mut rng, space.sets.len(), n).into_iter().map(|i| space.sets[i]).collect();
    driver.evaluate(&picks).await?;
    Ok(())
}

/// `n` distinct sets drawn uniformly from a sampled space, in draw order (fewer when the draws
/// keep repeating: a lattice not much larger than `n`).
pub fn distinct_draws(rng: &mut ChaCha8Rng, space: &Space, n: usize) -> Vec<crate::ir::ConceptSet> {
    let mut seen = HashSet::new();
    let mut picks = Vec::with_capacity(n);
    let mut misses = 0;
    while picks.len() < n && misses < 64 + n {
        match space.draw(rng) {
            Some(s) if seen.insert(s) => picks.push(s),
            Some(_) => misses += 1,
            None => break,
        }
    }
    picks
}

/// The first `n` of a uniform random permutation of `0..len`: a Fisher–Yates shuffle that
/// keeps only the positions it has touched (memory O(n), not O(len)).
pub fn shuffled_prefix(rng: &mut ChaCha8Rng, len: usize, n: usize) -> Vec<usize> {
    let mut moved: HashMap<usize, usize> = HashMap::new();
    (0..n.min(len))
        .map(|i| {
            let j = rng.random_range(i..len);
            let at_j = moved.get(&j).copied().unwrap_or(j);
            let at_i = moved.get(&i).copied().unwrap_or(i);
            moved.insert(j, at_i);
            at_j
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_longer_draw_extends_a_shorter_one_without_repeats() {
        let draw = |n| shuffled_prefix(&mut ChaCha8Rng::seed_from_u64(7), 1000, n);
        let (short, long) = (draw(50), draw(400));
        assert_eq!(short[..], long[..50]);
        let mut all = draw(1000);
        all.sort_unstable();
        assert_eq!(all, (0..1000).collect::<Vec<_>>());
        assert_eq!(draw(5000).len(), 1000);
    }
}
