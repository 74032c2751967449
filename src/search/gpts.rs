//! GP Thompson sampling (paper Algorithm 2): a beam phase, then rounds of fit → draw → evaluate.
//!
//! Each round fits the surrogate on the multi-hot vectors of every evaluated set and their
//! observed failure rates, makes `batch` Thompson draws with fresh randomness from the run's
//! ChaCha stream (never a fixed `random_state`: reusing one draw would pick the same argmax every
//! round), and evaluates the distinct argmaxes over all unexplored valid sets in parallel. Ties go
//! to the set earliest in the lattice order. When the beam phase produced no data (a beam budget
//! of 0) the first round draws uniformly, since a fit on no data says nothing.
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::ir::ConceptSet;

use super::gp::{Draw, Gp};
use super::{Driver, Evaluate, Params, Space};

/// Salt for the GPTS random stream, so it differs from Random's stream for the same seed.
const STREAM: u64 = 0x6770_7473_0000_0001;

pub async fn run<E: Evaluate>(params: &Params, space: &Space, driver: &mut Driver<'_, E>) -> Result<(), String> {
    let total = driver.remaining();
    let beam_sets = (params.beam_budget / u64::from(params.samples)) as usize;
    driver.set_max_sets(beam_sets.min(total));
    super::beam::run(params, space, driver).await?;
    driver.set_max_sets(total);

    let mut rng = ChaCha8Rng::seed_from_u64(params.seed ^ STREAM);
    let mut unexplored: Vec<u32> = (0..space.sets.len() as u32).collect();
    while driver.remaining() > 0 {
        unexplored.retain(|&i| !driver.seen(space.sets[i as usize]));
        if unexplored.is_empty() {
            break;
        }
        let picks = if driver.history.is_empty() {
            let n = params.batch.min(unexplored.len());
            rand::seq::index::sample(&mut rng, unexplored.len(), n)
                .into_iter()
                .map(|k| space.sets[unexplored[k] as usize])
                .collect()
        } else {
            let x: Vec<ConceptSet> = driver.history.iter().map(|s| s.set).collect();
            let y: Vec<f64> = driver.history.iter().map(|s| s.value()).collect();
            let model = Gp::fit(&x, &y, space.dim).map_err(|e| format!("cannot fit the gaussian process: {e}"))?;
            let mut picks: Vec<ConceptSet> = Vec::with_capacity(params.batch);
            for _ in 0..params.batch {
                let draw = model.draw(&mut rng);
                let best = argmax(&unexplored, space, &draw);
                if !picks.contains(&best) {
                    picks.push(best);
                }
            }
            picks
        };
        driver.evaluate(&picks).await?;
    }
    Ok(())
}

fn argmax(candidates: &[u32], space: &Space, draw: &Draw) -> ConceptSet {
    let mut best = (candidates[0], f64::NEG_INFINITY);
    for &i in candidates {
        let v = draw.score(space.sets[i as usize]);
        if v > best.1 {
            best = (i, v);
        }
    }
    space.sets[best.0 as usize]
}
