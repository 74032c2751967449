//! Fresh confirmation: the candidate cores a search selected are confirmed only on observations
//! made after they were selected, and the confirmed list as a whole is held to a false discovery
//! rate q.
//!
//! Why fresh: the observations that made a set stand out among hundreds are, by selection, the
//! lucky ones (the winner's curse); counting them again as confirmation inflates every rate. So
//! each candidate gets new observations — the caller hands in the first index past everything
//! the search asked of it, and a run asks them in a phase of their own, whose scene seeds are a
//! separate stream — and only those enter its confirmed rate, its interval and its e-value.
//!
//! The procedure, in rounds: the first [`WINDOW`] candidates (strongest first) that are still
//! open — neither confirmed by e-BH over the current e-values (the candidates not yet asked
//! count with e = 1) nor established below τ + δ, and holding fewer than the cap — get m fresh
//! observations each, while the budget lasts.
//! The e-value of a candidate is the confidence sequence's e-value against "its rate is at most
//! τ − δ" ([`super::cs::e_above`]); e-values stay valid at whatever round their candidate
//! stopped, and e-BH ([`super::ebh`]) is valid under any dependence, so the candidates it
//! rejects at the end are the confirmed cores, with a false discovery rate of at most q (a
//! confirmed core is false when its rate is ≤ τ − δ).
//!
//! A candidate that reaches the cap with its interval still straddling the zone is
//! **borderline**: neither a core nor a passing set, reported as near the threshold.

use crate::ir::ConceptSet;

use super::cs::{self, Verdict};
use super::{Ask, Evaluate, SearchError, Searched, SetStats};

/// Candidates observed at once: the strongest [`WINDOW`] still open get the next round, the
/// others wait until one of them is settled. Spread over every candidate at once, a budget that
/// pays 20 observations each settles none of them when e-BH's bars are high (a family of 16
/// asks e ≥ 320 of its first rejection: about 30 observations of a 0.85 mode); candidates taken
/// strongest first settle the likeliest ones before the budget runs out.
pub const WINDOW: usize = 4;

/// What confirmation concluded about one candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Rejected by e-BH at q: a confirmed core.
    Confirmed,
    /// Its fresh interval lies below τ + δ: not a failure mode.
    Passes,
    /// It reached the cap with its interval straddling the zone (or established above τ − δ
    /// but not rejected by e-BH across the candidates).
    Borderline,
    /// The budget ran out before it reached the cap or a decision.
    Unfinished,
}

/// One candidate after confirmation.
#[derive(Debug, Clone, PartialEq)]
pub struct Checked {
    /// The fresh observations only.
    pub stats: SetStats,
    /// Its e-value against "rate ≤ τ − δ", from `stats`.
    pub e: f64,
    pub status: Status,
}

/// How confirmation is run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plan {
    pub tau: f64,
    pub delta: f64,
    /// False discovery rate q of e-BH.
    pub q: f64,
    /// Observations per round (m).
    pub batch: u32,
    /// Most fresh observations a candidate gets.
    pub cap: u32,
    /// Inferences confirmation may spend.
    pub budget: u64,
}

/// Confirm `candidates` (set, first fresh observation index), strongest first: returns one
/// [`Checked`] per candidate, in the input order, and the inferences spent.
pub async fn confirm<E: Evaluate>(
    eval: &mut E,
    candidates: &[(ConceptSet, u32)],
    plan: Plan,
) -> Searched<(Vec<Checked>, u64), E> {
    let mut stats: Vec<SetStats> = candidates.iter().map(|(s, _)| SetStats::new(*s)).collect();
    let mut spent = 0u64;
    let p0 = plan.tau - plan.delta;
    let e_of = |s: &SetStats| cs::e_above(s.wrong, s.answered(), p0);
    let mut stopped_by_budget = false;
    loop {
        let e: Vec<f64> = stats.iter().map(e_of).collect();
        let rejected = super::ebh::ebh(&e, plan.q);
        let mut asks = Vec::new();
        let mut left = plan.budget - spent;
        let mut open = 0;
        for (i, s) in stats.iter().enumerate() {
            let n = s.observations();
            let verdict = cs::verdict(s.wrong, s.answered(), plan.tau, plan.delta);
            if rejected[i] || n >= plan.cap || (n > 0 && verdict == Verdict::Passes) {
                continue;
            }
            if open == WINDOW {
                break;
            }
            open += 1;
            let k = u64::from(plan.batch.min(plan.cap - n)).min(left);
            if k == 0 {
                stopped_by_budget = true;
                continue;
            }
            let start = candidates[i].1 + n;
            asks.push((i, Ask { set: s.set, obs: start..start + k as u32 }));
            left -= k;
        }
        if asks.is_empty() {
            break;
        }
        let plain: Vec<Ask> = asks.iter().map(|(_, a)| a.clone()).collect();
        let got = eval.evaluate(&plain).await.map_err(SearchError::Eval)?;
        for ((i, a), s) in asks.iter().zip(got) {
            spent += u64::from(a.len());
            stats[*i].merge(&s);
        }
    }
    let e: Vec<f64> = stats.iter().map(e_of).collect();
    let rejected = super::ebh::ebh(&e, plan.q);
    let checked = stats
        .into_iter()
        .zip(e)
        .zip(rejected)
        .map(|((s, e), rejected)| {
            let verdict = cs::verdict(s.wrong, s.answered(), plan.tau, plan.delta);
            let status = if rejected {
                Status::Confirmed
            } else if s.answered() > 0 && verdict == Verdict::Passes {
                Status::Passes
            } else if s.observations() >= plan.cap || !stopped_by_budget {
                Status::Borderline
            } else {
                Status::Unfinished
            };
            Checked { stats: s, e, status }
        })
        .collect();
    Ok((checked, spent))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::outcome::Outcome;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A fake model: each set fails at its rate, answers drawn from (set, index), and every
    /// index asked is recorded so the test can check none repeats the search's.
    struct Rates {
        rates: Vec<(ConceptSet, f64)>,
        asked: Vec<(ConceptSet, u32)>,
    }

    impl Evaluate for Rates {
        type Error = ();
        async fn evaluate(&mut self, asks: &[Ask]) -> Result<Vec<SetStats>, ()> {
            Ok(asks
                .iter()
                .map(|a| {
                    let p = self.rates.iter().find(|(s, _)| *s == a.set).unwrap().1;
                    let mut s = SetStats::new(a.set);
                    for i in a.obs.clone() {
                        self.asked.push((a.set, i));
                        let mut rng = ChaCha8Rng::seed_from_u64(a.set.low_bits() as u64 * 1_000_003 + u64::from(i));
                        s.add(if rng.random::<f64>() < p { Outcome::Wrong } else { Outcome::Correct });
                    }
                    s
                })
                .collect())
        }
    }

    fn block_on<T>(f: impl std::future::Future<Output = T>) -> T {
        tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(f)
    }

    fn plan(budget: u64) -> Plan {
        Plan { tau: 0.6, delta: 0.1, q: 0.05, batch: 5, cap: 40, budget }
    }

    #[test]
    fn strong_candidates_are_confirmed_weak_ones_are_not_and_indices_are_fresh() {
        let sets: Vec<ConceptSet> = (0..5).map(|i| ConceptSet::from_bits(1 << i)).collect();
        let rates = [0.95, 0.9, 0.05, 0.1, 0.4];
        let mut eval = Rates { rates: sets.iter().copied().zip(rates).collect(), asked: Vec::new() };
        let candidates: Vec<(ConceptSet, u32)> = sets.iter().map(|s| (*s, 20)).collect();
        let (checked, spent) = block_on(confirm(&mut eval, &candidates, plan(1000))).unwrap();
        let status: Vec<Status> = checked.iter().map(|c| c.status).collect();
        assert_eq!(&status[..4], &[Status::Confirmed, Status::Confirmed, Status::Passes, Status::Passes]);
        assert_ne!(status[4], Status::Confirmed, "a 0.4 set is never confirmed");
        assert!(eval.asked.iter().all(|(_, i)| *i >= 20), "only indices past the search's");
        assert_eq!(spent, eval.asked.len() as u64);
        assert!(checked.iter().all(|c| c.stats.observations() <= 40));
        let mut seen = std::collections::HashSet::new();
        assert!(eval.asked.iter().all(|k| seen.insert(*k)), "no observation asked twice");
    }

    #[test]
    fn a_tight_budget_settles_the_strongest_candidates_first() {
        // Two real modes first, eight weak sets after them; 100 calls pay 10 observations each
        // spread evenly, and e ≥ 100 (e-BH's bar for two of ten) takes more than 10 observations.
        let sets: Vec<ConceptSet> = (0..10).map(|i| ConceptSet::from_bits(1 << i)).collect();
        let rates = [0.95, 0.95, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3];
        let mut eval = Rates { rates: sets.iter().copied().zip(rates).collect(), asked: Vec::new() };
        let candidates: Vec<(ConceptSet, u32)> = sets.iter().map(|s| (*s, 0)).collect();
        let (checked, spent) = block_on(confirm(&mut eval, &candidates, plan(100))).unwrap();
        assert!(spent <= 100);
        let status: Vec<Status> = checked.iter().map(|c| c.status).collect();
        assert_eq!(&status[..2], &[Status::Confirmed, Status::Confirmed], "{checked:?}");
        assert!(status[2..].iter().all(|s| *s != Status::Confirmed));
    }

    #[test]
    fn the_budget_bounds_the_spend() {
        let sets: Vec<ConceptSet> = (0..6).map(|i| ConceptSet::from_bits(1 << i)).collect();
        let mut eval = Rates { rates: sets.iter().map(|s| (*s, 0.55)).collect(), asked: Vec::new() };
        let candidates: Vec<(ConceptSet, u32)> = sets.iter().map(|s| (*s, 0)).collect();
        let (checked, spent) = block_on(confirm(&mut eval, &candidates, plan(37))).unwrap();
        assert_eq!(spent, 37);
        assert!(checked.iter().any(|c| c.status == Status::Unfinished));
        assert!(checked.iter().all(|c| c.status != Status::Confirmed));
    }
}
