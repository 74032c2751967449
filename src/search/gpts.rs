//! GP Thompson sampling (paper Algorithm 2): a beam phase, then rounds of fit → draw → evaluate.
//!
//! Each round fits the surrogate on the multi-hot vectors of every evaluated set and their
//! observed failure rates, makes `batch` Thompson draws with fresh randomness from the run's
//! ChaCha stream (never a fixed `random_state`: reusing one draw would pick the same argmax every
//! round), and evaluates the distinct argmaxes over all unexplored valid sets in parallel. Ties go
//! to the set earliest in the lattice order. When the beam phase produced no data (a beam budget
//! of 0) the first round draws uniformly, since a fit on no data says nothing.
//!
//! The surrogate is the paper's DotProduct + White GP ([`Gp`], drawn in weight space) unless
//! `--kernel rbf` asks for its ablation's RBF + White ([`RbfGp`], an exact joint draw by
//! Matheron's rule); both are scored over every unexplored valid set.
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::ir::ConceptSet;

use super::gp::{Gp, GpError, Kernel};
use super::gp_rbf::RbfGp;
use super::{Drive, Driver, Evaluate, Params, SearchError, Searched, Space};

/// A fitted surrogate of the chosen kernel.
enum Fitted {
    Dot(Gp),
    Rbf(RbfGp),
}

impl Fitted {
    fn fit(kernel: Kernel, x: &[ConceptSet], y: &[f64], d: usize) -> Result<Fitted, GpError> {
        Ok(match kernel {
            Kernel::Dot => Fitted::Dot(Gp::fit(x, y, d)?),
            Kernel::Rbf => Fitted::Rbf(RbfGp::fit(x, y, d)?),
        })
    }

    /// The argmax of one fresh Thompson draw over the unexplored sets.
    fn pick(&self, rng: &mut ChaCha8Rng, explored: &[bool], space: &Space) -> Option<ConceptSet> {
        match self {
            Fitted::Dot(gp) => {
                let draw = gp.draw(rng);
                argmax(explored, space, |s| draw.score(s))
            }
            Fitted::Rbf(gp) => {
                let draw = gp.draw(rng);
                argmax(explored, space, |s| draw.score(s))
            }
        }
    }
}

/// Salt for the GPTS random stream, so it differs from Random's stream for the same seed.
const STREAM: u64 = 0x6770_7473_0000_0001;

pub async fn run<E: Evaluate>(params: &Params, space: &Space, driver: &mut Driver<'_, E>) -> Searched<(), E> {
    let total = driver.budget();
    driver.set_budget(params.beam_budget.min(total));
    super::beam::run(params, space, driver).await?;
    driver.set_budget(total);

    let mut rng = ChaCha8Rng::seed_from_u64(params.seed ^ STREAM);
    // Explored flags by lattice position: one pass over the history now, then only the picks of
    // each round are marked (no per-round hash lookups over the whole lattice).
    let mut explored = vec![false; space.sets.len()];
    let mut left = space.sets.len();
    let mark = |explored: &mut [bool], set: ConceptSet, left: &mut usize| {
        if let Some(i) = space.position(set).filter(|&i| !explored[i]) {
            explored[i] = true;
            *left -= 1;
        }
    };
    for s in &driver.history {
        mark(&mut explored, s.set, &mut left);
    }
    while driver.can_start() && left > 0 {
        let picks: Vec<ConceptSet> = if driver.history.is_empty() {
            let open: Vec<usize> = (0..space.sets.len()).filter(|&i| !explored[i]).collect();
            let n = params.batch.min(open.len());
            rand::seq::index::sample(&mut rng, open.len(), n).into_iter().map(|k| space.sets[open[k]]).collect()
        } else {
            let x: Vec<ConceptSet> = driver.history.iter().map(|s| s.set).collect();
            let y: Vec<f64> = driver.history.iter().map(|s| s.value()).collect();
            let model = Fitted::fit(params.kernel, &x, &y, space.dim)
                .map_err(|e| SearchError::Search(format!("cannot fit the gaussian process: {e}")))?;
            // More draws than unexplored sets or than the budget pays for only repeat argmaxes:
            // each costs a pass over the lattice, so a huge `--batch` would spin.
            let affordable = driver.remaining() / u64::from(params.samples.max(1));
            let draws = params.batch.min(left).min(usize::try_from(affordable).unwrap_or(usize::MAX));
            let mut picks: Vec<ConceptSet> = Vec::with_capacity(draws);
            for _ in 0..draws {
                if let Some(best) = model.pick(&mut rng, &explored, space).filter(|b| !picks.contains(b)) {
                    picks.push(best);
                }
            }
            picks
        };
        driver.evaluate(&picks).await?;
        for p in picks {
            mark(&mut explored, p, &mut left);
        }
    }
    Ok(())
}

/// The unexplored set with the highest drawn score; ties go to the earliest in lattice order.
fn argmax(explored: &[bool], space: &Space, score: impl Fn(ConceptSet) -> f64) -> Option<ConceptSet> {
    let mut best: Option<(usize, f64)> = None;
    for (i, set) in space.sets.iter().enumerate() {
        if explored[i] {
            continue;
        }
        let v = score(*set);
        if best.is_none_or(|(_, b)| v > b) {
            best = Some((i, v));
        }
    }
    best.map(|(i, _)| space.sets[i])
}
