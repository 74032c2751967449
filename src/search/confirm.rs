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
//! The procedure ([`confirm`]): a **triage** gives every candidate m fresh observations; its
//! **weight** is the likelihood ratio of its search's answers (at most [`SEARCH_WEIGHT_CAP`])
//! times its triage's, each of a mode at τ + δ against a set at τ − δ — fixed before any
//! further observation. Then, in rounds, the first [`WINDOW`] candidates of the highest
//! weight that are still open — neither confirmed by weighted e-BH over the current e-values
//! nor established below τ + δ, and holding fewer than the cap — get m more fresh observations
//! each, while the budget lasts; once none under the cap is open, the open ones go on up to the
//! extended cap ([`EXTEND_FACTOR`]) with the calls left. The candidates e-BH could not confirm
//! even if every answer still to come were a mode's at τ + δ ([`within_reach`]) wait through
//! both passes and get the calls left after them; the candidates sent last
//! ([`Candidate::last`]) skip the triage and get only the calls left after that.
//! The e-value of a candidate is the one-sided mixture's e-value against "its rate is at most
//! τ − δ" ([`super::cs::e_above`]) over the observations after its triage; e-values stay valid
//! at whatever round their candidate stopped, and weighted e-BH ([`super::ebh::ebh_weighted`])
//! is valid under any dependence when its weights are fixed before its e-values' observations
//! — the weights come from the search's and the triage's answers only — so the candidates it
//! rejects at the end are the confirmed cores, with a false discovery rate of at most q (a
//! confirmed core is false when its rate is ≤ τ − δ).
//!
//! Why a triage: most candidates of a graded landscape are near-misses (a part at 0.45 with
//! anything), each needing 15–40 observations to be established below τ + δ, and with equal
//! weights every one of them raises the bar of the real ones. Five answers tell a 0.85 mode
//! from a 0.45 near-miss most of the time (4 or 5 of 5 wrong: 84 % against 13 %), so the
//! triage spends the confirmation's calls, and e-BH's tolerance, where a mode is likely.
//!
//! A candidate that reaches the cap with its interval still straddling the zone is
//! **borderline**: neither a core nor a passing set, reported as near the threshold.

use crate::ir::ConceptSet;

use super::cs::{self, Verdict};
use super::{Ask, Evaluate, SearchError, Searched, SetStats};

/// Candidates observed at once: the strongest [`WINDOW`] still open get the next round, the
/// others wait until one of them is settled. Spread over every candidate at once, a budget that
/// pays 20 observations each settles none of them when e-BH's bars are high (a family of 16
/// asks e ≥ 320 of its first rejection: over 20 observations of a 0.85 mode); candidates taken
/// strongest first settle the likeliest ones before the budget runs out.
pub const WINDOW: usize = 4;

/// Once every candidate has had its turn up to the cap and the budget has calls left, the
/// candidates still open (neither confirmed nor passing) go on, strongest first, up to this many
/// times the cap. A mode at 0.75, just past τ + δ, shows above τ − δ after about 25 observations
/// on average but often needs more than 40; the calls a run keeps for confirmation are mostly
/// left over (runs ended at 840-960 of 1 000).
pub const EXTEND_FACTOR: u32 = 2;

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
    /// Its confirmation's observations (after its triage): its confirmed rate and interval.
    pub stats: SetStats,
    /// Its triage's observations (fresh too, but they set its weight, so they are not counted
    /// in its e-value).
    pub triage: SetStats,
    /// Its e-BH weight, before scaling: search weight × the triage's likelihood ratio.
    pub weight: f64,
    /// Its e-value against "rate ≤ τ − δ", from `stats` (e-BH counts it only once `stats`'
    /// interval lies above τ − δ).
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
    /// Most fresh observations a candidate gets while other candidates wait for their turn.
    pub cap: u32,
    /// Most fresh observations a candidate gets once every candidate has had its turn and the
    /// budget has calls left ([`EXTEND_FACTOR`] × the cap by default; the cap itself under
    /// `--max-samples`).
    pub extended: u32,
    /// Inferences confirmation may spend.
    pub budget: u64,
}

/// One candidate sent to confirmation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    pub set: ConceptSet,
    /// Its first fresh observation index: past everything the search asked of it.
    pub first: u32,
    /// Its search weight ([`search_weight`]): from the search's data only.
    pub weight: f64,
    /// Sent last: no triage (its weight is its search weight alone), and observed only once
    /// every other candidate is settled, in passes of its own after theirs.
    /// A failure mode no core explains that shares a concept with a stronger one
    /// ([`crate::search::shrink::disjoint_strongest`]) mostly fails through that concept, but not
    /// always: a planted pair beside a near-threshold part it shares a concept with.
    pub last: bool,
}

/// Most a candidate's search evidence multiplies its weight: the search's observations chose it
/// (the winner's curse), so they may order the candidates but not outweigh fresh evidence.
pub const SEARCH_WEIGHT_CAP: f64 = 20.0;

/// The likelihood ratio of `k` wrong in `n` between a mode at τ + δ (0.7 at the defaults: the
/// weakest mode a search must find) and a set at τ − δ (0.5): how much more a mode than a
/// near-miss explains those answers. Against a mode at 0.85 instead, a 0.7 mode's answers had no
/// drift (0.7·ln(0.85/0.5) + 0.3·ln(0.15/0.5) ≈ 0.01 an answer) and its weight was a random walk:
/// `chain_barrier_far` (0.7) on driving_recognition, 93 search answers and 3 of 5 in triage,
/// weighed 0.001 of a family summing to ~100 and was never confirmed (driving_recognition seed
/// 5). Against 0.7 every rate ≥ τ + δ drifts up (+0.08 an answer at 0.7, +0.21 at 0.85) and a
/// near-miss at 0.3 down (−0.26).
pub fn likelihood_ratio(k: u32, n: u32, tau: f64, delta: f64) -> f64 {
    let (p1, p0) = (tau + delta, tau - delta);
    if !(0.0 < p0 && p0 < p1 && p1 < 1.0) {
        return 1.0;
    }
    let (k, n) = (f64::from(k.min(n)), f64::from(n));
    let ln = k * (p1 / p0).ln() + (n - k) * ((1.0 - p1) / (1.0 - p0)).ln();
    ln.clamp(-700.0, 700.0).exp()
}

/// A candidate's weight from the search's observations of it only (`search`: what chose it):
/// their likelihood ratio, at most [`SEARCH_WEIGHT_CAP`]. Confirmation multiplies it by its
/// triage's.
pub fn search_weight(search: &SetStats, plan: &Plan) -> f64 {
    likelihood_ratio(search.wrong, search.answered(), plan.tau, plan.delta).min(SEARCH_WEIGHT_CAP)
}

/// Which candidates e-BH could still confirm: those whose weight, scaled as e-BH scales it (to
/// a mean of 1), times the e-value they would show at the extended cap if every observation
/// still to come were a mode's at τ + δ, at its expected count, reaches e-BH's lowest bar with
/// `most` candidates rejected, K/(most·q) — 1/q when `most` is the whole family K. Before any
/// confirmation observation that is the e-value of a mode at τ + δ at the extended cap (184 at
/// 56 of 80 at the defaults, so a weight of 0.11 of the mean); a candidate at 20 of 40 would
/// show about 1.3 (48 of 80). The others wait: before this rule a candidate weighted 0.006 of
/// the mean, which needs an e-value near 3 300, took 65 calls in the first pass, and the budget
/// ran out before the extension of the modes (driving_recognition seed 3: `debris_far`, at 0.8,
/// borderline at 34 of 49). `most` is the candidates the passes it limits observe (those not
/// sent last): counting the ones sent last, which those passes never observe, would lower the
/// bar for the others as if they too could be confirmed there (driving_many seed 10: nine sent
/// last, of little weight, halved the mean weight and put `debris_far + weather_foggy`, 0.10 of
/// the ten others' mean, in reach; its 25 calls were the ones two modes' extension then lacked,
/// and 4 of 19 were confirmed instead of 7). Whom it defers depends only on weights fixed
/// before confirmation and on each candidate's own past observations, so every e-value stays
/// valid at the point its candidate stops.
pub fn within_reach(weights: &[f64], stats: &[SetStats], plan: &Plan, most: usize) -> Vec<bool> {
    let scaled = super::ebh::scaled_weights(weights).filter(|_| plan.q > 0.0 && most > 0);
    let Some(scaled) = scaled else {
        return vec![true; weights.len()];
    };
    let n = plan.extended.max(plan.cap);
    let bar = weights.len() as f64 / (most as f64 * plan.q);
    scaled
        .iter()
        .zip(stats)
        .map(|(w, s)| {
            let rest = n.saturating_sub(s.answered());
            let k = s.wrong + ((plan.tau + plan.delta) * f64::from(rest)).round() as u32;
            w * cs::e_above(k, n, plan.tau - plan.delta) >= bar
        })
        .collect()
}

/// Confirm `candidates` (strongest search evidence first): returns one [`Checked`] per
/// candidate, in the input order, and the inferences spent.
///
/// 1. **Triage**: every candidate not sent last ([`Candidate::last`]) gets m fresh observations
///    (one parallel round). Its weight is its search weight times the triage's likelihood
///    ratio (a candidate sent last: its search weight) — fixed before any of step 2.
/// 2. **Confirmation**: in rounds, the [`WINDOW`] open candidates of the highest weight get m
///    more fresh observations each, up to the cap, while the budget lasts; then, with the calls
///    left, the ones still open up to the extended cap ([`Plan::extended`]); both passes take
///    only the candidates [`within_reach`] (judged each round), the others get what is left in
///    two passes after, and the candidates sent last what is left after those, in two passes
///    more. A candidate's e-value comes from these observations only; weighted e-BH
///    ([`super::ebh::ebh_weighted`]) over them, with the weights of step 1, decides which are
///    confirmed. A candidate is open while it is neither confirmed nor established below
///    τ + δ (on every fresh observation, triage included).
pub async fn confirm<E: Evaluate>(
    eval: &mut E,
    candidates: &[Candidate],
    plan: Plan,
) -> Searched<(Vec<Checked>, u64), E> {
    let p0 = plan.tau - plan.delta;
    let mut spent = 0u64;
    // Step 1: triage, strongest first while the budget lasts: m fresh observations each, in
    // one parallel round.
    let mut triage: Vec<SetStats> = candidates.iter().map(|c| SetStats::new(c.set)).collect();
    let mut asks = Vec::new();
    // A candidate the budget could not triage is unfinished, not borderline.
    let mut stopped_by_budget = false;
    for (i, c) in candidates.iter().enumerate().filter(|(_, c)| !c.last) {
        let k = u64::from(super::budget::triage_each(plan.batch, plan.cap)).min(plan.budget - spent);
        if k == 0 {
            stopped_by_budget = true;
            break;
        }
        asks.push((i, Ask { set: c.set, obs: c.first..c.first + k as u32 }));
        spent += k;
    }
    if !asks.is_empty() {
        let plain: Vec<Ask> = asks.iter().map(|(_, a)| a.clone()).collect();
        let got = eval.evaluate(&plain).await.map_err(SearchError::Eval)?;
        for ((i, _), s) in asks.iter().zip(got) {
            triage[*i].merge(&s);
        }
    }
    let weights: Vec<f64> = candidates
        .iter()
        .zip(&triage)
        .map(|(c, t)| c.weight * likelihood_ratio(t.wrong, t.answered(), plan.tau, plan.delta))
        .collect();
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&a, &b| weights[b].total_cmp(&weights[a]).then(a.cmp(&b)));
    // Step 2: confirmation proper, on observations past the triage's.
    let mut stats: Vec<SetStats> = candidates.iter().map(|c| SetStats::new(c.set)).collect();
    let fresh = |i: usize, stats: &[SetStats]| {
        let mut all = triage[i].clone();
        all.merge(&stats[i]);
        all
    };
    // A candidate's e-value counts only once its confirmation's own interval lies above τ − δ:
    // a confirmed core is then always established above τ − δ on the observations it reports,
    // and the product with that indicator is still an e-value (it is never larger), so e-BH
    // keeps its guarantee.
    let e_of = |s: &SetStats| cs::e_above(s.wrong, s.answered(), p0);
    let counted = |s: &SetStats| if cs::interval(s.wrong, s.answered())[0] > p0 { e_of(s) } else { 0.0 };
    // The passes, as (cap, only those within reach, the ones sent last too): the candidates
    // within reach (judged each round) up to `plan.cap`, then up to `plan.extended` (the
    // e-values stay valid at any stopping point, so the candidates still open at the cap may go
    // on), then all of them but the ones sent last the same way, then all; each pass starts once
    // no candidate of the one before is open and the budget has calls left.
    let passes = [
        (plan.cap, true, false),
        (plan.extended, true, false),
        (plan.cap, false, false),
        (plan.extended, false, false),
        (plan.cap, false, true),
        (plan.extended, false, true),
    ];
    let first_passes = candidates.iter().filter(|c| !c.last).count();
    let mut pass = 0;
    loop {
        let (cap, only_reach, with_last) = passes[pass];
        let e: Vec<f64> = stats.iter().map(counted).collect();
        let rejected = super::ebh::ebh_weighted(&e, &weights, plan.q);
        let reach = within_reach(&weights, &stats, &plan, first_passes);
        let mut asks = Vec::new();
        let mut left = plan.budget - spent;
        let mut open = 0;
        for &i in &order {
            let s = &stats[i];
            let n = s.observations();
            let all = fresh(i, &stats);
            let verdict = cs::verdict(all.wrong, all.answered(), plan.tau, plan.delta);
            if rejected[i]
                || n >= cap
                || (only_reach && !reach[i])
                || (candidates[i].last && !with_last)
                || (all.answered() > 0 && verdict == Verdict::Passes)
            {
                continue;
            }
            if open == WINDOW {
                break;
            }
            open += 1;
            let k = u64::from(plan.batch.min(cap - n)).min(left);
            if k == 0 {
                stopped_by_budget = true;
                continue;
            }
            let start = candidates[i].first + triage[i].observations() + n;
            asks.push((i, Ask { set: s.set, obs: start..start + k as u32 }));
            left -= k;
        }
        if asks.is_empty() {
            if pass + 1 < passes.len() && spent < plan.budget && !stopped_by_budget {
                pass += 1;
                continue;
            }
            break;
        }
        let plain: Vec<Ask> = asks.iter().map(|(_, a)| a.clone()).collect();
        let got = eval.evaluate(&plain).await.map_err(SearchError::Eval)?;
        for ((i, a), s) in asks.iter().zip(got) {
            spent += u64::from(a.len());
            stats[*i].merge(&s);
        }
    }
    let rejected = super::ebh::ebh_weighted(&stats.iter().map(counted).collect::<Vec<_>>(), &weights, plan.q);
    let e: Vec<f64> = stats.iter().map(e_of).collect();
    let checked = (0..candidates.len())
        .map(|i| {
            let all = fresh(i, &stats);
            let verdict = cs::verdict(all.wrong, all.answered(), plan.tau, plan.delta);
            let status = if rejected[i] {
                Status::Confirmed
            } else if all.answered() > 0 && verdict == Verdict::Passes {
                Status::Passes
            } else if stats[i].observations() >= plan.cap {
                Status::Borderline
            } else {
                Status::Unfinished
            };
            Checked { stats: stats[i].clone(), triage: triage[i].clone(), weight: weights[i], e: e[i], status }
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

    /// A fake model answering wrong where `wrong(set, index)` says; every index asked is
    /// recorded so a test can check none repeats the search's.
    struct Fake<F> {
        wrong: F,
        asked: Vec<(ConceptSet, u32)>,
    }

    impl<F: FnMut(ConceptSet, u32) -> bool> Evaluate for Fake<F> {
        type Error = ();
        async fn evaluate(&mut self, asks: &[Ask]) -> Result<Vec<SetStats>, ()> {
            Ok(asks
                .iter()
                .map(|a| {
                    let mut s = SetStats::new(a.set);
                    for i in a.obs.clone() {
                        self.asked.push((a.set, i));
                        s.add(if (self.wrong)(a.set, i) { Outcome::Wrong } else { Outcome::Correct });
                    }
                    s
                })
                .collect())
        }
    }

    /// Each set fails at its rate, answers drawn from (set, index).
    fn at_rates(rates: Vec<(ConceptSet, f64)>) -> Fake<impl FnMut(ConceptSet, u32) -> bool> {
        let wrong = move |set: ConceptSet, i: u32| {
            let p = rates.iter().find(|(s, _)| *s == set).unwrap().1;
            let mut rng = ChaCha8Rng::seed_from_u64(set.low_bits() as u64 * 1_000_003 + u64::from(i));
            rng.random::<f64>() < p
        };
        Fake { wrong, asked: Vec::new() }
    }

    fn block_on<T>(f: impl std::future::Future<Output = T>) -> T {
        tokio::runtime::Builder::new_current_thread().build().unwrap().block_on(f)
    }

    /// Candidates of equal weight, their fresh indices from `first`.
    fn plain(sets: &[ConceptSet], first: u32) -> Vec<Candidate> {
        sets.iter().map(|&set| Candidate { set, first, weight: 1.0, last: false }).collect()
    }

    fn plan(budget: u64) -> Plan {
        Plan { tau: 0.6, delta: 0.1, q: 0.05, batch: 5, cap: 40, extended: 40, budget }
    }

    #[test]
    fn calls_left_after_every_turn_take_open_candidates_past_the_cap() {
        // A mode just past τ + δ and a near-miss: at the cap of 40 the mode is still open.
        let sets: Vec<ConceptSet> = [5, 0, 2].iter().map(|i| ConceptSet::from_bits(1 << i)).collect();
        let rates = [0.74, 0.2, 0.95];
        let run = |extended| {
            let mut eval = at_rates(sets.iter().copied().zip(rates).collect());
            let plan = Plan { extended, ..plan(1000) };
            let (checked, spent) = block_on(confirm(&mut eval, &plain(&sets, 20), plan)).unwrap();
            assert_eq!(spent, eval.asked.len() as u64);
            checked
        };
        let capped = run(40);
        assert_eq!(capped[0].status, Status::Borderline, "{:?}", capped[0]);
        assert_eq!(capped[0].stats.observations(), 40);
        let extended = run(80);
        assert_eq!(extended[0].status, Status::Confirmed, "{:?}", extended[0]);
        let n = extended[0].stats.observations();
        assert!(n > 40 && n <= 80, "{n}");
        // The others are settled under the cap and get nothing more.
        for i in 1..3 {
            assert_eq!(extended[i], capped[i]);
        }
    }

    #[test]
    fn a_candidate_out_of_reach_waits_until_the_others_are_settled() {
        // At the defaults a mode at τ + δ shows e ≈ 184 at 56 of 80, so a candidate is in reach
        // when its weight is at least 1 / (0.05 · 184) ≈ 0.11 of the mean.
        let plan80 = Plan { extended: 80, ..plan(1000) };
        let none = |k: usize| vec![SetStats::new(ConceptSet::from_bits(1)); k];
        assert_eq!(within_reach(&[1.0, 1.0, 1.0], &none(3), &plan80, 3), vec![true; 3]);
        let weak = [10.0, 10.0, 0.2];
        assert_eq!(within_reach(&weak, &none(3), &plan80, 3), vec![true, true, false], "0.03 of the mean");
        assert_eq!(within_reach(&[10.0, 10.0, 1.0], &none(3), &plan80, 3), vec![true; 3], "0.14 of the mean");
        assert_eq!(within_reach(&[0.0, 0.0], &none(2), &plan80, 2), vec![true; 2], "no weights: plain e-BH");
        // Three weak candidates sent last do not bring a weak one into reach: counted as if they
        // could be confirmed too, the bar would drop to 1/q (0.5 would then be 0.14 of the mean).
        let with_last = [10.0, 10.0, 0.5, 0.1, 0.1, 0.1];
        assert!(!within_reach(&with_last[..3], &none(3), &plan80, 3)[2]);
        assert!(!within_reach(&with_last, &none(6), &plan80, 3)[2]);
        assert!(within_reach(&with_last, &none(6), &plan80, 6)[2]);
        // What a candidate showed counts: at 20 of 40, the 40 to come at 0.7 make 48 of 80
        // (e ≈ 1.3), out of reach at the mean weight; at 28 of 40, 56 of 80 as before.
        let shown = |k: u32| {
            let mut s = SetStats::new(ConceptSet::from_bits(1));
            (0..40).for_each(|i| s.add(if i < k { Outcome::Wrong } else { Outcome::Correct }));
            s
        };
        assert_eq!(within_reach(&[1.0, 1.0], &[shown(20), shown(28)], &plan80, 2), vec![false, true]);
        // The 0.74 mode of the test above needs more than the cap of 40; a near-miss weighted
        // 1/2000 of it must not take calls from its extension.
        let (mode, weak) = (ConceptSet::from_bits(1 << 5), ConceptSet::from_bits(1));
        let mut eval = at_rates(vec![(mode, 0.74), (weak, 0.62)]);
        let candidates = [
            Candidate { set: weak, first: 20, weight: 0.01, last: false },
            Candidate { set: mode, first: 20, weight: 20.0, last: false },
        ];
        let (checked, _) = block_on(confirm(&mut eval, &candidates, plan80)).unwrap();
        assert_eq!(checked[1].status, Status::Confirmed, "{checked:?}");
        assert!(checked[1].stats.observations() > 40, "{checked:?}");
        let last_mode = eval.asked.iter().rposition(|(s, _)| *s == mode).unwrap();
        let first_weak = eval.asked.iter().position(|(s, i)| *s == weak && *i >= 25);
        assert!(first_weak.is_none_or(|w| w > last_mode), "{:?}", eval.asked);
    }

    #[test]
    fn a_candidate_sent_last_skips_the_triage_and_waits_for_the_others() {
        let sets: Vec<ConceptSet> = (0..3).map(|i| ConceptSet::from_bits(1 << i)).collect();
        // Two triaged candidates (a mode and a near-miss), then a mode sent last, weighted by
        // its search alone.
        let rates = [0.9, 0.3, 0.9];
        let candidates: Vec<Candidate> =
            sets.iter().enumerate().map(|(i, &set)| Candidate { set, first: 10, weight: 4.0, last: i == 2 }).collect();
        let mut eval = at_rates(sets.iter().copied().zip(rates).collect());
        let plan = Plan { extended: 80, ..plan(1000) };
        let (checked, spent) = block_on(confirm(&mut eval, &candidates, plan)).unwrap();
        assert_eq!(spent, eval.asked.len() as u64);
        assert_eq!(checked[2].triage.observations(), 0, "not triaged");
        assert_eq!(checked[2].weight, 4.0, "its search weight: {checked:?}");
        assert_ne!(checked[0].weight, 4.0, "the others' weights hold their triage's");
        assert_eq!(checked[0].status, Status::Confirmed, "{checked:?}");
        assert_eq!(checked[2].status, Status::Confirmed, "{checked:?}");
        // Its first observation comes after every other candidate's last: the mode's, and the
        // near-miss's, out of reach once its triage weighed it down.
        let first_last = eval.asked.iter().position(|(s, _)| *s == sets[2]).unwrap();
        let last_other = eval.asked.iter().rposition(|(s, _)| *s != sets[2]).unwrap();
        assert!(last_other < first_last, "{:?}", eval.asked);
        assert!(checked[1].stats.observations() > 0, "the near-miss was observed: {checked:?}");
        // With no calls left for it, it is unfinished, not borderline.
        let mut eval = at_rates(sets.iter().copied().zip(rates).collect());
        let (checked, _) = block_on(confirm(&mut eval, &candidates, Plan { budget: spent - 20, ..plan })).unwrap();
        assert_eq!(checked[2].status, Status::Unfinished, "{checked:?}");
    }

    #[test]
    fn strong_candidates_are_confirmed_weak_ones_are_not_and_indices_are_fresh() {
        let sets: Vec<ConceptSet> = (0..5).map(|i| ConceptSet::from_bits(1 << i)).collect();
        let rates = [0.95, 0.9, 0.05, 0.1, 0.4];
        let mut eval = at_rates(sets.iter().copied().zip(rates).collect());
        let candidates = plain(&sets, 20);
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
        // Two real modes among eight weak sets, the modes last in the search's order: the
        // triage (50 calls) weights them highest, so the other 100 go to them first and both
        // are confirmed, where spreading the calls evenly (15 each) would confirm neither.
        let sets: Vec<ConceptSet> = (0..10).map(|i| ConceptSet::from_bits(1 << i)).collect();
        let rates = [0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.3, 0.95, 0.95];
        let mut eval = at_rates(sets.iter().copied().zip(rates).collect());
        let candidates = plain(&sets, 0);
        let (checked, spent) = block_on(confirm(&mut eval, &candidates, plan(150))).unwrap();
        assert!(spent <= 150);
        let status: Vec<Status> = checked.iter().map(|c| c.status).collect();
        assert_eq!(&status[8..], &[Status::Confirmed, Status::Confirmed], "{checked:?}");
        assert!(status[..8].iter().all(|s| *s != Status::Confirmed));
        assert!(checked.iter().all(|c| c.triage.observations() == 5), "every candidate triaged");
        let mean_weak = checked[..8].iter().map(|c| c.weight).sum::<f64>() / 8.0;
        assert!(checked[8].weight > mean_weak && checked[9].weight > mean_weak, "{checked:?}");
    }

    /// The false discovery rate holds by simulation, triage weights included: 200 runs of 20
    /// candidates, 16 at τ − δ exactly (the null's edge, the hardest nulls) and 4 at 0.85; the
    /// mean false share of the confirmed is at most q (with room for the simulation's error),
    /// and the real ones are found.
    #[test]
    fn weighted_confirmation_keeps_the_false_discovery_rate() {
        let sets: Vec<ConceptSet> = (0..20).map(|i| ConceptSet::from_bits(1 << i)).collect();
        let (mut fdp, mut found, runs) = (0.0, 0usize, 200);
        for run in 0..runs {
            let rates: Vec<f64> = (0..20).map(|i| if i % 5 == 4 { 0.85 } else { 0.5 }).collect();
            let mut eval = at_rates(sets.iter().copied().zip(rates.clone()).collect());
            // A different stream per run: the fake model's answers depend on the index.
            let candidates: Vec<Candidate> =
                sets.iter().map(|&set| Candidate { set, first: run * 1000, weight: 1.0, last: false }).collect();
            let (checked, _) = block_on(confirm(&mut eval, &candidates, plan(600))).unwrap();
            let confirmed: Vec<usize> = (0..20).filter(|&i| checked[i].status == Status::Confirmed).collect();
            let false_ones = confirmed.iter().filter(|&&i| rates[i] <= 0.5).count();
            if !confirmed.is_empty() {
                fdp += false_ones as f64 / confirmed.len() as f64;
            }
            found += confirmed.len() - false_ones;
        }
        let fdr = fdp / f64::from(runs);
        assert!(fdr <= 0.05 + 0.02, "false discovery rate {fdr}");
        assert!(found as f64 / f64::from(runs * 4) >= 0.5, "power {found}");
    }

    #[test]
    fn a_confirmed_core_is_established_above_the_zone_on_its_own_observations() {
        // 16 of 20 passes a lone candidate's bar (the one-sided e-value is past 20) while its
        // two-sided interval still reaches below τ − δ; it is confirmed at 20 of 25, whose
        // interval lies above.
        assert!(cs::e_above(16, 20, 0.5) >= 20.0 && cs::interval(16, 20)[0] <= 0.5);
        assert!(cs::interval(20, 25)[0] > 0.5);
        let set = ConceptSet::from_bits(1);
        let plan = Plan { extended: 40, ..plan(1000) };
        // Wrong on four indices of every five.
        let mut four_in_five = Fake { wrong: |_, i: u32| i % 5 < 4, asked: Vec::new() };
        let (checked, spent) =
            block_on(confirm(&mut four_in_five, &[Candidate { set, first: 0, weight: 1.0, last: false }], plan))
                .unwrap();
        assert_eq!(checked[0].status, Status::Confirmed, "{checked:?}");
        assert_eq!((checked[0].stats.wrong, checked[0].stats.observations()), (20, 25));
        assert_eq!(spent, 30, "five in triage, 25 after it");
    }

    #[test]
    fn candidates_the_budget_could_not_triage_are_unfinished() {
        let sets: Vec<ConceptSet> = (0..3).map(|i| ConceptSet::from_bits(1 << i)).collect();
        let mut eval = at_rates(sets.iter().map(|s| (*s, 0.55)).collect());
        let (checked, spent) = block_on(confirm(&mut eval, &plain(&sets, 0), plan(7))).unwrap();
        assert_eq!(spent, 7);
        assert_eq!(checked[2].triage.observations(), 0);
        assert_eq!(checked[2].status, Status::Unfinished, "{checked:?}");
    }

    #[test]
    fn the_budget_bounds_the_spend() {
        let sets: Vec<ConceptSet> = (0..6).map(|i| ConceptSet::from_bits(1 << i)).collect();
        let mut eval = at_rates(sets.iter().map(|s| (*s, 0.55)).collect());
        let candidates = plain(&sets, 0);
        let (checked, spent) = block_on(confirm(&mut eval, &candidates, plan(37))).unwrap();
        assert_eq!(spent, 37);
        assert!(checked.iter().any(|c| c.status == Status::Unfinished));
        assert!(checked.iter().all(|c| c.status != Status::Confirmed));
    }
}
