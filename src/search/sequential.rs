//! The sequential test: how many observations a set gets.
//!
//! A set first gets `samples` (m) observations. With `max_samples` M > m, a set whose 95 % Wilson
//! interval ([`super::interval::wilson`]) still straddles τ — lower bound below τ, upper bound at
//! or above it — gets more, one batch at a time, until the interval clears τ or the set holds M
//! observations. The classification stays the paper's: a failure mode is a set whose observed FR
//! is ≥ τ. Because the Wilson interval always contains the observed rate, a set whose interval
//! cleared τ is classified on the same side; a set that reached M undecided is classified by its
//! observed rate, now from M observations instead of m.
//!
//! A batch is the fewest further observations that *could* clear the interval: k more wrong
//! answers, or k more correct ones, whichever clears it with the smaller k (at most M − n). Any
//! smaller batch could not settle the set whatever the model answers, so no round is wasted on
//! one. At τ = 0.6 this is 1 observation after 5/5 (6/6 clears it) or 1/5 (1/6 clears it), and 6
//! after 3/5. Non-answers (unparsed, refusals, API errors) count as observations — they spend
//! budget and count toward M — but give the interval nothing.
//!
//! With M = m (the default, `--max-samples` unset) no set gets more than m: the paper's fixed
//! estimator, bit for bit.
//!
//! Every rule tests the 95 % interval except where [`Rule::with_z`] narrows it: `--algo interact`
//! triages at 80 % (`interact::TRIAGE_Z`) and confirms what the triage finds at 95 %.
//!
//! With an indifference zone ([`Rule::with_zone`]) the rule tests the anytime-valid interval
//! ([`super::cs`]) against τ − δ and τ + δ instead of τ: a set is settled once it is established
//! above τ − δ (it fails, [`Rule::fails`]) or below τ + δ (it passes). Interact confirms its cores
//! this way (its triage uses the zone with the 80 % Wilson interval), and so does a sequential
//! `validate`; the paper's searches keep the Wilson test against τ.

use super::cs;
use super::interval::{Z95, wilson_z};
use super::metrics::SetStats;

/// How many observations a set gets (m, M) and the threshold the interval is tested against.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rule {
    /// Observations every set gets first (m).
    pub samples: u32,
    /// Most observations a set can get (M ≥ m; M = m: the paper's fixed count).
    pub max_samples: u32,
    /// Failure threshold τ.
    pub threshold: f64,
    /// The normal quantile of the interval tested against τ ([`Z95`]: the 95 % interval).
    pub z: f64,
    /// An indifference zone δ: a set is settled when its interval lies above τ − δ (it fails)
    /// or below τ + δ (it passes). `None`: the interval is tested against τ itself (the paper's
    /// searches).
    pub zone: Option<f64>,
    /// Whether the interval is the 95 % anytime-valid confidence sequence ([`super::cs`]; `z`
    /// is then unused) rather than the fixed-n Wilson interval at `z`.
    pub anytime: bool,
}

impl Rule {
    /// The paper's estimator: exactly `samples` observations per set.
    pub fn fixed(samples: u32, threshold: f64) -> Rule {
        Rule { samples, max_samples: samples, threshold, z: Z95, zone: None, anytime: false }
    }

    /// The sequential rule: m observations, then up to M while the 95 % interval straddles τ.
    pub fn sequential(samples: u32, max_samples: u32, threshold: f64) -> Rule {
        Rule { samples, max_samples, threshold, z: Z95, zone: None, anytime: false }
    }

    /// The same rule with a fixed-n Wilson interval at `z`.
    pub fn with_z(self, z: f64) -> Rule {
        Rule { z, anytime: false, ..self }
    }

    /// The interval of `wrong` of `answered` this rule tests.
    pub fn interval(&self, wrong: u32, answered: u32) -> [f64; 2] {
        if self.anytime { cs::interval(wrong, answered) } else { wilson_z(wrong, answered, self.z) }
    }

    /// The same rule decided by the anytime-valid test with indifference zone `delta` (a
    /// later [`Rule::with_z`] keeps the zone with a Wilson interval: a triage).
    pub fn with_zone(self, delta: f64) -> Rule {
        Rule { zone: Some(delta), anytime: true, ..self }
    }

    /// Whether the set counts as failing under this rule: established above τ − δ by the
    /// confidence sequence (with a zone), or the paper's observed FR ≥ τ (without).
    pub fn fails(&self, s: &SetStats) -> bool {
        match self.zone {
            Some(delta) => self.interval(s.wrong, s.answered())[0] > self.threshold - delta,
            None => s.is_failure_mode(self.threshold),
        }
    }

    pub fn is_sequential(&self) -> bool {
        self.max_samples > self.samples
    }

    /// Whether `wrong` failures out of `answered` leave the set undecided: τ inside the rule's
    /// interval (95 % unless [`Rule::with_z`] set another), or with a zone, the interval
    /// reaching both below τ − δ and above τ + δ.
    pub fn straddles(&self, wrong: u32, answered: u32) -> bool {
        let [lo, hi] = self.interval(wrong, answered);
        if let Some(delta) = self.zone {
            return lo <= self.threshold - delta && hi >= self.threshold + delta;
        }
        lo < self.threshold && self.threshold <= hi
    }

    /// Whether a set needs no more observations: it has M, or at least m and an interval clear
    /// of τ.
    pub fn settled(&self, s: &SetStats) -> bool {
        self.next(s) == 0
    }

    /// The next batch for a set with these observations: m − n before the first m are in, then
    /// the fewest observations that could clear the interval (capped at M − n), 0 once settled.
    pub fn next(&self, s: &SetStats) -> u32 {
        let n = s.observations();
        if n < self.samples {
            return self.samples - n;
        }
        if n >= self.max_samples || !self.straddles(s.wrong, s.answered()) {
            return 0;
        }
        let left = self.max_samples - n;
        let (w, a) = (s.wrong, s.answered());
        (1..=left).find(|&k| !self.straddles(w + k, a + k) || !self.straddles(w, a + k)).unwrap_or(left)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::ConceptSet;
    use crate::outcome::Outcome;

    fn st(wrong: u32, correct: u32, unparsed: u32) -> SetStats {
        let mut s = SetStats::new(ConceptSet::from_bits(1));
        (0..wrong).for_each(|_| s.add(Outcome::Wrong));
        (0..correct).for_each(|_| s.add(Outcome::Correct));
        (0..unparsed).for_each(|_| s.add(Outcome::Unparsed));
        s
    }

    #[test]
    fn fixed_rule_is_the_papers_m() {
        let r = Rule::fixed(5, 0.6);
        assert_eq!(r.next(&st(0, 0, 0)), 5);
        assert_eq!(r.next(&st(1, 1, 0)), 3);
        assert_eq!(r.next(&st(3, 2, 0)), 0, "3/5 straddles 0.6 but M = m");
        assert!(!r.is_sequential());
    }

    #[test]
    fn batches_are_the_fewest_observations_that_could_settle() {
        let r = Rule::sequential(5, 20, 0.6);
        assert_eq!(r.next(&st(0, 0, 0)), 5, "first the m observations");
        assert_eq!(r.next(&st(0, 5, 0)), 0, "0/5: [0, 0.43] clears 0.6");
        assert_eq!(r.next(&st(5, 0, 0)), 1, "5/5: [0.57, 1]; 6/6 clears");
        assert_eq!(r.next(&st(1, 4, 0)), 1, "1/5: [0.04, 0.62]; 1/6 clears");
        assert_eq!(r.next(&st(3, 2, 0)), 6, "3/5: 3/11 clears from below before 13/15 from above");
        // Non-answers count toward M but say nothing.
        assert_eq!(r.next(&st(0, 0, 5)), 3, "nothing answered: 0/3 would clear 0.6");
        assert_eq!(r.next(&st(0, 0, 20)), 0, "M reached");
        // Near M the batch is capped.
        assert_eq!(r.next(&st(11, 7, 0)), 2, "11/18 cannot settle in the 2 left; they still inform the rate");
    }

    #[test]
    fn a_narrower_interval_settles_sooner() {
        let full = Rule::sequential(5, 40, 0.6);
        let triage = full.with_z(1.281_551_565_544_601);
        // 1/5: [0.04, 0.62] at 95 % straddles 0.6; [0.06, 0.49] at 80 % does not.
        assert_eq!(full.next(&st(1, 4, 0)), 1);
        assert_eq!(triage.next(&st(1, 4, 0)), 0);
        // 5/5 settles at 80 % ([0.75, 1]), not at 95 % ([0.57, 1]).
        assert_eq!(full.next(&st(5, 0, 0)), 1);
        assert!(triage.settled(&st(5, 0, 0)));
        // 3/5 straddles both; the narrower one needs fewer to settle.
        assert!(triage.next(&st(3, 2, 0)) < full.next(&st(3, 2, 0)));
        assert_eq!(Rule::fixed(5, 0.6).with_z(1.0).next(&st(3, 2, 0)), 0, "M = m stays the paper's m");
    }

    /// Every batch is the smallest that can settle: one fewer could not, whatever the answers.
    #[test]
    fn no_smaller_batch_can_settle() {
        let r = Rule::sequential(5, 30, 0.6);
        for a in 5..30 {
            for w in 0..=a {
                let s = st(w, a - w, 0);
                let k = r.next(&s);
                if k <= 1 {
                    continue;
                }
                let j = k - 1;
                for extra_wrong in 0..=j {
                    assert!(r.straddles(w + extra_wrong, a + j), "{w}/{a} + {extra_wrong}/{j} settles before {k}");
                }
            }
        }
    }
}
