//! Random search: sets drawn uniformly from the valid lattice, without repeats.
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{Driver, Evaluate, Params, Space};

pub async fn run<E: Evaluate>(params: &Params, space: &Space, driver: &mut Driver<'_, E>) -> Result<(), String> {
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let n = ((driver.remaining() / u64::from(params.samples)) as usize).min(space.sets.len());
    // All draws are made up front — as many as the budget could pay at m observations each — and
    // evaluated in order: with the fixed count as one batch at full concurrency; with sequential
    // sampling the driver works through them in chunks until the budget is spent. The order is a
    // pure function of the seed.
    let picks: Vec<_> =
        rand::seq::index::sample(&mut rng, space.sets.len(), n).into_iter().map(|i| space.sets[i]).collect();
    driver.evaluate(&picks).await?;
    Ok(())
}
