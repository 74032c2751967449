//! Shrinking failure modes to minimal cores.
//!
//! A failure mode found at size 4 usually owes its failure to a smaller core: every superset of a
//! failing pair fails too, so a search reports the pair many times over. After the search, the
//! shrink phase takes the strongest failure mode not yet explained by a core, first re-tests it
//! with the sequential test (a root that no longer fails is *refuted*, not shrunk), then drops its
//! concepts one at a time (delta debugging with complements of size one): a subset that is valid
//! and still fails by the sequential test replaces the set, and the drops start over on it; the
//! set is a core when every one-smaller valid subset passes (1-minimal). Subsets outside the
//! search space — invalid in the lattice, or without a determined ground truth — are never
//! evaluated. Evidence is shared: a subset the search (or an earlier shrink) evaluated is topped
//! up, not evaluated again, so its decision is the same each time it is asked.
//!
//! Drop order: concepts least associated with failure first — by the mean failure rate of every
//! evaluated set that holds the concept, ties to the concept index. Dropping a bystander first
//! leaves the core in place, so the shrink reaches it in fewer tests; the final 1-minimality
//! check tests every one-smaller subset whatever the order.
//!
//! A 1-minimal failing set is a core only when it fails *more* than each of its tested one-smaller
//! subsets ([`lifts`]: a one-sided two-proportion test at 99 %, sequential: while it does not
//! lift, the one of the two with fewer observations gets m more, up to twice the rule's M). A set at
//! τ + 0.02 over a subset at τ − 0.02 is the subset's borderline rate measured twice, not a
//! failure mode that needs the added concept: "pedestrian + police officer fails, neither alone"
//! would be a false finding when the pedestrian alone fails 58 % of the time. Such a set is
//! [`Shrunk::NotDistinct`], recorded with that subset in [`Found::not_distinct`].
//!
//! A shrink that the budget cuts short (it cannot pay the first m observations of a new subset)
//! yields a core marked not minimal; the roots after it are shrunk only as far as the evidence
//! already gathered settles them ([`run`]). All decisions are pure functions of the
//! observations, so a resumed run shrinks the same way.

use std::collections::HashMap;

use crate::ir::{ConceptId, ConceptSet};

use super::{Drive, Driver, Evaluate, Searched, SetStats, Space};

/// A failing set none of whose one-smaller valid subsets fails.
#[derive(Debug, Clone, PartialEq)]
pub struct Core {
    /// The core and every observation of it (search and shrink).
    pub stats: SetStats,
    /// Whether every one-smaller valid subset was tested and passes (false: the budget ran out
    /// first, and the set is only as small as the shrink got — or, for a failure mode of the
    /// search sent to confirmation last of all, the shrink never reached it).
    pub minimal: bool,
    /// The failure mode it was shrunk from.
    pub root: ConceptSet,
}

/// What shrinking one failure mode gave.
#[derive(Debug, Clone, PartialEq)]
pub enum Shrunk {
    Core(Core),
    /// The failure mode did not fail by the sequential test (its stats after the re-test).
    Refuted(SetStats),
    /// The budget could not pay for re-testing it.
    Unaffordable,
    /// The shrink reached a 1-minimal failing set (`stats`) that does not fail significantly more
    /// than its one-smaller subset `by`, which passes: no distinct failure mode, only `by`'s
    /// rate near τ (or the observations the lift test asked for took the set below τ).
    NotDistinct {
        stats: SetStats,
        by: ConceptSet,
    },
    /// The shrink reached a 1-minimal failing set (`stats`) whose lift over its passing
    /// one-smaller subset `by` was not settled when the budget ran out: neither a core nor shown
    /// to be no more than `by`. The shrink phase reports nothing of it (a minimal one stays a
    /// failure mode no core explains, for confirmation to judge); the search sets `by`'s family
    /// aside as for [`Shrunk::NotDistinct`].
    Undecided {
        stats: SetStats,
        by: ConceptSet,
    },
}

/// z of the one-sided two-proportion test ("`set` fails more often than `sub`") at 99 %: the
/// test looks again after every batch of m, so a single look's 95 % would be too lenient.
pub const LIFT_Z: f64 = 2.326;

/// The lift test may take the set and its subset to this many times the rule's M: at 40
/// observations each a 0.85 pair over a 0.5 part fails the test one time in six, at 80 one time
/// in a hundred and fifty. Only an undecided test goes that far; a set that truly adds nothing
/// is then set aside for good.
pub const LIFT_MAX_FACTOR: u32 = 2;

/// Whether `set` fails significantly more often than `sub` (pooled two-proportion z-test,
/// one-sided, [`LIFT_Z`]); true when either has no answered observation (nothing to compare).
pub fn lifts(set: &SetStats, sub: &SetStats) -> bool {
    let (n1, n0) = (f64::from(set.answered()), f64::from(sub.answered()));
    if n1 == 0.0 || n0 == 0.0 {
        return true;
    }
    let (w1, w0) = (f64::from(set.wrong), f64::from(sub.wrong));
    let pooled = (w1 + w0) / (n1 + n0);
    let se = (pooled * (1.0 - pooled) * (1.0 / n1 + 1.0 / n0)).sqrt();
    if se == 0.0 {
        return w1 / n1 > w0 / n0;
    }
    (w1 / n1 - w0 / n0) / se >= LIFT_Z
}

/// Shrink the failing set `root` to a 1-minimal failing subset, testing through `driver` (its
/// rule decides "still fails"; its budget bounds the cost). The one-smaller subsets are tested
/// in drop order, [`Drive::lookahead`] of them together (one at a time unless the driver fills
/// its calls to a width); the first in drop order that fails replaces the set, as one at a time.
pub async fn shrink<D: Drive>(driver: &mut D, space: &Space, root: ConceptSet) -> Searched<Shrunk, D::Eval> {
    // "Fails" as the driver's rule says: FR ≥ τ, or established above τ − δ with a zone.
    let rule = driver.rule();
    let Some(stats) = driver.test(root).await? else { return Ok(Shrunk::Unaffordable) };
    if !rule.fails(&stats) {
        return Ok(Shrunk::Refuted(stats));
    }
    let mut current = root;
    let mut minimal = true;
    loop {
        'shrink: loop {
            let subs: Vec<ConceptSet> = driver
                .with_history(|history| drop_order(history, current))
                .into_iter()
                .map(|c| current.without(c))
                .filter(|sub| !sub.is_empty() && space.contains(*sub))
                .collect();
            for group in subs.chunks(driver.lookahead()) {
                driver.evaluate(group).await?;
                for &sub in group {
                    match driver.get(sub) {
                        None => {
                            minimal = false;
                            break 'shrink;
                        }
                        Some(s) if rule.fails(&s) => {
                            current = sub;
                            continue 'shrink;
                        }
                        Some(_) => {}
                    }
                }
            }
            break;
        }
        // The lift test, sequential too: while a passing subset is not significantly exceeded,
        // the one of the two with fewer observations gets m more, up to LIFT_MAX_FACTOR·M.
        let (m, max) = (driver.rule().samples, LIFT_MAX_FACTOR * driver.rule().max_samples);
        // The part whose lift test asked for the latest observations.
        let mut asked_by = None;
        loop {
            let stats = driver.get(current).expect("a kept subset was evaluated");
            if !rule.fails(&stats) {
                // Observations the lift test asked for took it below τ: it fails no more than
                // that part.
                return Ok(match asked_by {
                    Some(by) => Shrunk::NotDistinct { stats, by },
                    None => Shrunk::Refuted(stats),
                });
            }
            let flat = current.one_smaller().find_map(|sub| driver.get(sub).filter(|t| !lifts(&stats, t)));
            let Some(t) = flat else { return Ok(Shrunk::Core(Core { stats, minimal, root })) };
            if rule.fails(&t) {
                // More observations took the subset above τ: shrink on from it.
                current = t.set;
                break;
            }
            let (n, n_by) = (stats.observations(), t.observations());
            let (more, has) = if n <= n_by && n < max {
                (current, n)
            } else if n_by < max {
                (t.set, n_by)
            } else if n < max {
                (current, n)
            } else {
                return Ok(Shrunk::NotDistinct { stats, by: t.set });
            };
            if !driver.observe_more(more, m.min(max - has)).await? {
                return Ok(Shrunk::Undecided { stats, by: t.set });
            }
            asked_by = Some(t.set);
        }
    }
}

/// Whether `core` and every one-smaller valid subset of it are settled by the driver's rule.
fn settled<E: Evaluate>(driver: &Driver<'_, E>, space: &Space, core: ConceptSet) -> bool {
    let rule = driver.rule();
    let done = |s: ConceptSet| driver.stats(s).is_some_and(|st| rule.settled(st));
    done(core) && core.one_smaller().filter(|s| space.contains(*s)).all(done)
}

/// Every evaluated set of `history`, by its concepts.
fn by_set(history: &[SetStats]) -> HashMap<ConceptSet, &SetStats> {
    history.iter().map(|s| (s.set, s)).collect()
}

/// Whether every valid one-smaller subset of `s` was evaluated and passes, or fails at an
/// observed rate at least `margin` below `s`'s (an infinite margin: passes).
fn over_parts(
    by_set: &HashMap<ConceptSet, &SetStats>,
    space: &Space,
    threshold: f64,
    margin: f64,
    s: &SetStats,
) -> bool {
    let top = s.fr().unwrap_or(0.0);
    s.set.one_smaller().filter(|sub| space.contains(*sub)).all(|sub| {
        by_set
            .get(&sub)
            .and_then(|t| t.fr().map(|f| (t, f)))
            .is_some_and(|(t, f)| !t.is_failure_mode(threshold) || f + margin < top)
    })
}

/// The cores a run without a shrink phase reports: its failure modes whose every valid
/// one-smaller subset was evaluated and passes.
pub fn minimal_failures(history: &[SetStats], space: &Space, threshold: f64) -> Vec<ConceptSet> {
    let by_set = by_set(history);
    history
        .iter()
        .filter(|s| s.is_failure_mode(threshold) && over_parts(&by_set, space, threshold, f64::INFINITY, s))
        .map(|s| s.set)
        .collect()
}

/// The minimal failure modes of `history` ([`minimal_failures`]) that hold none of `cores`:
/// what fresh confirmation takes as candidates beside the cores, and what `interact` keeps a
/// share of its budget for ([`super::budget::Plan::search_cap`]).
pub fn unexplained_failures(
    history: &[SetStats],
    space: &Space,
    threshold: f64,
    cores: &[ConceptSet],
) -> Vec<ConceptSet> {
    let mut loose = minimal_failures(history, space, threshold);
    loose.retain(|&m| !cores.iter().any(|c| c.is_subset_of(m)));
    loose
}

/// Of `sets`, strongest first, those that share no concept with a set kept before them, and the
/// others (in order): the failure modes no core explains that fresh confirmation triages, and
/// the ones it sends last ([`super::confirm::Candidate::last`]). Where several share a concept
/// they mostly fail through it — a part near τ (`pedestrian` at 0.6 beside anything) screened
/// beside many others before its family was explained, which a round of sixteen picks does far
/// more often than one pick at a time — and each one triaged takes its calls, and e-BH's
/// tolerance, from the real modes: the strongest stands for them. Measured (release, 20 seeds,
/// width 16): driving_recognition 30 → 41 % recovered, driving_many 28 → 33 % (docs/search.md,
/// "Parallel interact").
pub fn disjoint_strongest(sets: impl IntoIterator<Item = ConceptSet>) -> (Vec<ConceptSet>, Vec<ConceptSet>) {
    let mut seen = ConceptSet::default();
    let (mut kept, mut left) = (Vec::new(), Vec::new());
    for s in sets {
        if s.intersects(seen) {
            left.push(s);
        } else {
            seen = seen.union(s);
            kept.push(s);
        }
    }
    (kept, left)
}

/// Failure modes of `history` that fail through a part near τ and lift well above it — a
/// pedestrian at 0.45 that read 0.65 on its forty search answers, and the pedestrian in hard rain
/// at 0.95 — which [`unexplained_failures`] misses (a subset fails) while the shrink takes the
/// part for the core: failure modes, not minimal, whose every valid one-smaller subset was
/// evaluated and either passes or fails with an observed rate at least `margin` below the set's;
/// holding no core of `cores` except such a subset. Fresh confirmation judges them with the
/// others (a part refuted there leaves the set as the core). Measured (release, 20 seeds of the
/// seven shipped profiles, width 16, margin 2δ = 0.2): 1.1 [0.1, 2.1] points more recovered,
/// graded 2.2 [0.1, 4.4], core precision and FDP unchanged (1.0 and 0); margin δ gave 0.7
/// [-0.6, 1.9] (docs/search.md, "What a finding promises").
pub fn lifted_failures(
    history: &[SetStats],
    space: &Space,
    threshold: f64,
    margin: f64,
    cores: &[ConceptSet],
) -> Vec<ConceptSet> {
    let by_set = by_set(history);
    history
        .iter()
        .filter(|s| s.is_failure_mode(threshold) && over_parts(&by_set, space, threshold, margin, s))
        .filter(|s| {
            let top = s.fr().unwrap_or(0.0);
            let below = |sub: &ConceptSet| by_set.get(sub).and_then(|t| t.fr()).is_some_and(|f| f + margin < top);
            let failing = s.set.one_smaller().any(|sub| by_set.get(&sub).is_some_and(|t| t.is_failure_mode(threshold)));
            let explained = cores.iter().any(|c| c.is_subset_of(s.set) && !(c.len() + 1 == s.set.len() && below(c)));
            failing && !explained
        })
        .map(|s| s.set)
        .collect()
}

/// The concepts of `set` in the order the shrink tries to drop them: lowest mean failure rate
/// among the evaluated sets holding the concept first, then concept index.
pub fn drop_order(history: &[SetStats], set: ConceptSet) -> Vec<ConceptId> {
    let association = |c: ConceptId| {
        let frs: Vec<f64> = history.iter().filter(|s| s.set.contains(c)).filter_map(SetStats::fr).collect();
        if frs.is_empty() { 0.0 } else { frs.iter().sum::<f64>() / frs.len() as f64 }
    };
    let mut order: Vec<(f64, ConceptId)> = set.iter().map(|c| (association(c), c)).collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    order.into_iter().map(|(_, c)| c).collect()
}

/// Failure modes of `history` strongest first: by the lower bound of the 95 % interval (more
/// evidence of a higher rate), then FR, then fewer concepts (closer to a core, cheaper to
/// shrink), then the canonical set order.
pub fn roots(history: &[SetStats], threshold: f64) -> Vec<ConceptSet> {
    let mut modes: Vec<&SetStats> = history.iter().filter(|s| s.is_failure_mode(threshold)).collect();
    modes.sort_by(|a, b| {
        b.wilson95()[0]
            .total_cmp(&a.wilson95()[0])
            .then(b.value().total_cmp(&a.value()))
            .then(a.set.len().cmp(&b.set.len()))
            .then(a.set.cmp(&b.set))
    });
    modes.into_iter().map(|s| s.set).collect()
}

/// What the shrink phase found.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Found {
    /// Distinct cores, highest FR first (ties: higher interval lower bound, more answered
    /// observations, canonical order).
    pub cores: Vec<Core>,
    /// Roots that did not fail when re-tested, in the order they were tried.
    pub refuted: Vec<SetStats>,
    /// Failing sets the shrink reached that fail no more than a passing one-smaller subset
    /// ([`Shrunk::NotDistinct`]): each with that subset, in the order they were found.
    pub not_distinct: Vec<(SetStats, SetStats)>,
}

impl Found {
    /// Drop the not-distinct sets that hold a reported core: such a set is that core's superset,
    /// not a loose end — also when the core was established later, on fresh observations, against
    /// the search's own evidence that it did not lift over its part.
    pub fn drop_held_not_distinct(&mut self) {
        let cores = &self.cores;
        self.not_distinct.retain(|(s, _)| !cores.iter().any(|c| c.stats.set.is_subset_of(s.set)));
    }
}

/// The shrink phase: shrink `roots` (strongest first, see [`roots`]) in turn, skipping every root
/// that already contains a core (its family is explained). Once the budget cannot start another
/// test, the remaining roots are still shrunk on the evidence already gathered: a core is kept
/// only when the shrink needed no new observation and the core and every one-smaller valid
/// subset are settled by the rule (`--algo interact` confirms its cores during the search and
/// leaves this phase little or no budget: they are reported this way).
pub async fn run<E: Evaluate>(driver: &mut Driver<'_, E>, space: &Space, roots: &[ConceptSet]) -> Searched<Found, E> {
    let budget = driver.budget();
    run_capped(driver, space, roots, move |_| budget).await
}

/// [`run`] with a budget that depends on the cores found so far: `cap(k)` is what the phase
/// may spend in all while it holds k cores (a run keeps fresh confirmation's share for each:
/// [`super::budget::Plan::shrink_cap`]).
pub async fn run_capped<E: Evaluate>(
    driver: &mut Driver<'_, E>,
    space: &Space,
    roots: &[ConceptSet],
    cap: impl Fn(usize) -> u64,
) -> Searched<Found, E> {
    let mut found = Found::default();
    driver.set_budget(cap(0));
    // Not distinct: (set, part).
    let mut flat: Vec<(ConceptSet, ConceptSet)> = Vec::new();
    for &root in roots {
        if found.cores.iter().any(|c| c.stats.set.is_subset_of(root)) {
            continue;
        }
        let paid = driver.can_start();
        let before = driver.spent();
        match shrink(driver, space, root).await? {
            Shrunk::Core(core) if paid => found.cores.push(core),
            Shrunk::Core(core) => {
                if core.minimal && driver.spent() == before && settled(driver, space, core.stats.set) {
                    found.cores.push(core);
                }
            }
            Shrunk::Refuted(s) => found.refuted.push(s),
            Shrunk::NotDistinct { stats, by } => {
                if !flat.iter().any(|(s, _)| *s == stats.set) {
                    flat.push((stats.set, by));
                }
            }
            // A lift test the budget could not finish says nothing about the set and its part.
            Shrunk::Undecided { .. } | Shrunk::Unaffordable => {}
        }
        driver.set_budget(cap(found.cores.len()));
    }
    // A core tested again later (as a subset of another root) has more observations now.
    for c in &mut found.cores {
        if let Some(s) = driver.stats(c.stats.set) {
            c.stats = s.clone();
        }
    }
    // With every observation gathered.
    let now = |s: ConceptSet| driver.stats(s).cloned().unwrap_or_else(|| SetStats::new(s));
    found.not_distinct = flat.into_iter().map(|(s, by)| (now(s), now(by))).collect();
    found.drop_held_not_distinct();
    sort_cores(&mut found.cores);
    Ok(found)
}

/// Cores in the order a run reports them: highest FR first, then higher interval lower bound,
/// more answered observations, canonical order.
pub fn sort_cores(cores: &mut [Core]) {
    cores.sort_by(|a, b| {
        let (x, y) = (&a.stats, &b.stats);
        y.value()
            .total_cmp(&x.value())
            .then(y.wilson95()[0].total_cmp(&x.wilson95()[0]))
            .then(y.answered().cmp(&x.answered()))
            .then(x.set.cmp(&y.set))
    });
}

/// For each failure mode, the first core (in `cores` order) it contains; and for each core, how
/// many of the failure modes contain it.
pub fn families(modes: &[ConceptSet], cores: &[ConceptSet]) -> (Vec<Option<usize>>, Vec<usize>) {
    let family = modes.iter().map(|m| cores.iter().position(|c| c.is_subset_of(*m))).collect();
    let supersets = cores.iter().map(|c| modes.iter().filter(|m| c.is_subset_of(**m)).count()).collect();
    (family, supersets)
}
