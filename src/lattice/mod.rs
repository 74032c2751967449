//! The valid concept lattice: every valid concept set of a domain up to a maximum size, as
//! fixed-width bitsets ([`ConceptSet`]).
//!
//! **Validity** ([`validity`]): a set is valid when it is non-empty, satisfies every constraint
//! (`at_most`, `requires`, `forbids`), and every modifier in it has a target entity (per
//! [`anchor::build`](crate::anchor::build)).
//!
//! **Canonical order** ([`canonical_cmp`]): sets are ordered by size, then lexicographically by
//! their concept indices sorted ascending — `{0,1} < {0,2} < {1,2} < {0,1,2}`. It depends only on
//! the domain's concept order, so it is the same in every run and on every machine.
//!
//! **Enumeration** (`walk.rs`): a depth-first search over concepts in index order. At-most and
//! forbids constraints are monotone (a violating set has only violating supersets), so they prune
//! the search as soon as they fail; requires constraints and modifier targets can be repaired by
//! a later concept, so they are checked on each emitted set and prune only once no remaining
//! concept could repair them. The search visits sets in lexicographic order, so bucketing them by
//! size yields the canonical order without sorting. It runs on one machine word for domains of
//! up to 64 concepts (two up to 128), widening only the sets it emits.
//!
//! **Bounds**: the lattice grows with the number of concepts to the power of the set size (128
//! unconstrained concepts have 275 million sets of up to five). [`Lattice::build`] counts the
//! valid sets first on the [`Diagram`], storing none, and refuses to materialise more than a limit
//! ([`DEFAULT_MAX_SETS`] unless raised with `--max-sets`) with [`TooLarge`], which names the
//! largest set size that fits. Long work reports to a [`Progress`] callback: the core cannot
//! print, the command line draws it.

mod diagram;
#[cfg(test)]
pub(crate) mod testkit;
mod validity;
mod walk;

use std::cmp::Ordering;
use std::ops::ControlFlow;

pub use diagram::Diagram;
pub use validity::{ModifierTarget, Validity, Violation, ViolationAt, describe_constraint, validate};

use walk::Bits;

use crate::diag::{Diagnostic, Severity, codes};
use crate::ir::{ConceptSet, Domain};

/// The default maximum set size (the paper's search depth).
pub const DEFAULT_MAX_SIZE: usize = 5;

/// The most valid sets a lattice is materialised with unless the user raises the limit
/// (`--max-sets`): 64 MB of sets (64 bytes each), and what a search and the lattice lints handle
/// in seconds to minutes. The shipped domains have 115 144 (driving), 61 262 (indoor) and
/// 59 051 (delivery).
pub const DEFAULT_MAX_SETS: u64 = 1_000_000;

/// Where long work reports how far it got: `(what, done, total)`. The core cannot print; the
/// command line passes a callback that draws a progress bar.
pub type Progress<'a> = &'a mut dyn FnMut(&'static str, u64, u64);

/// A [`Progress`] that shows nothing.
pub fn quiet(_: &'static str, _: u64, _: u64) {}

/// Items between two progress reports: often enough for a bar, rare enough to cost nothing.
pub const PROGRESS_EVERY: u64 = 1 << 16;

/// The lattice would hold more than the limit.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TooLarge {
    pub domain: String,
    pub max_size: usize,
    pub limit: u64,
    /// The largest set size whose lattice fits the limit, and its number of sets.
    pub fits: Option<(usize, u64)>,
}

impl std::fmt::Display for TooLarge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "domain `{}` has more than {} valid concept sets of up to {} concepts",
            self.domain, self.limit, self.max_size
        )
    }
}

impl TooLarge {
    /// The ways out, for a `help:` line.
    pub fn help(&self) -> String {
        let smaller = match self.fits {
            Some((size, sets)) => format!("search smaller sets (`--max-size {size}` gives {sets}), "),
            None => String::new(),
        };
        format!(
            "{smaller}add constraints (`exclusive`, `at_most`, `requires`, `forbids`) to rule out sets, or raise the limit with `--max-sets`"
        )
    }

    /// The error as plain text for a command line: `error[R0070]: …` and a `help:` line.
    pub fn plain(&self) -> String {
        format!("error[{}]: {self}\n  help: {}", codes::LATTICE_TOO_LARGE, self.help())
    }

    /// The error as a diagnostic (R0070).
    pub fn diagnostic(&self) -> Diagnostic {
        Diagnostic::new(codes::LATTICE_TOO_LARGE, Severity::Error, None, self.to_string()).with_help(self.help())
    }
}

/// Valid sets per size (`per_size[k]` for size `k`), counted without storing any.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Count {
    pub per_size: Vec<u64>,
    /// False when counting stopped at the limit: then `per_size` is a lower bound.
    pub complete: bool,
}

impl Count {
    pub fn total(&self) -> u64 {
        self.per_size.iter().sum()
    }
}

/// Count the valid sets of 1 to `max_size` concepts, stopping as soon as there are more than
/// `limit` (pass `u64::MAX` for no limit).
pub fn count(validity: &Validity, max_size: usize, limit: u64, progress: Progress) -> Count {
    let mut per_size = vec![0u64; max_size + 1];
    let mut total = 0u64;
    let stopped = try_for_each_valid_sized(validity, max_size, |_, k| {
        per_size[k] += 1;
        total += 1;
        if total.is_multiple_of(PROGRESS_EVERY) {
            progress("counting valid sets", total, limit);
        }
        if total > limit { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
    });
    Count { per_size, complete: stopped.is_continue() }
}

/// All valid concept sets of a domain up to a maximum size, in canonical order.
#[derive(Debug, Clone)]
pub struct Lattice {
    /// The sets in canonical order.
    pub sets: Vec<ConceptSet>,
    /// `offsets[k]..offsets[k + 1]` are the sets of size `k` (`offsets[0] = offsets[1] = 0`).
    offsets: Vec<usize>,
    max_size: usize,
    validity: Validity,
}

/// The exact counts per size, or [`TooLarge`] past `max_sets`, naming the largest set size that
/// fits. Counted on the lattice's [`Diagram`] (milliseconds for the shipped domains, and for any
/// size of domain), so nothing is enumerated and `progress` is not called.
pub fn count_within(
    domain: &Domain,
    validity: &Validity,
    max_size: usize,
    max_sets: u64,
    _progress: Progress,
) -> Result<Count, TooLarge> {
    let counts = Diagram::build(validity, max_size).counts();
    let limit = u128::from(max_sets);
    if counts.iter().sum::<u128>() <= limit {
        // Each count is at most the limit, a u64.
        return Ok(Count { per_size: counts.iter().map(|&c| c as u64).collect(), complete: true });
    }
    let mut fits = None;
    let mut total = 0u128;
    for (k, &c) in counts.iter().enumerate().take(max_size).skip(1) {
        total += c;
        if total > limit {
            break;
        }
        fits = Some((k, total as u64));
    }
    Err(TooLarge { domain: domain.name.clone(), max_size, limit: max_sets, fits })
}

impl Lattice {
    /// Enumerate every valid set of 1 to `max_size` concepts, however many there are (for
    /// domains known to be small; [`Lattice::build`] for any domain).
    pub fn enumerate(domain: &Domain, max_size: usize) -> Lattice {
        // The diagram counts in a millisecond, so every set goes straight to its place.
        let validity = Validity::new(domain);
        let counts = Diagram::build(&validity, max_size).counts();
        let counted =
            Count { per_size: counts.iter().map(|&c| u64::try_from(c).unwrap_or(u64::MAX)).collect(), complete: true };
        Lattice::materialise(validity, max_size, &counted, &mut quiet)
    }

    /// Enumerate every valid set of 1 to `max_size` concepts, unless there are more than
    /// `max_sets`: then say so, with the largest set size that fits, before storing any.
    pub fn build(domain: &Domain, max_size: usize, max_sets: u64, progress: Progress) -> Result<Lattice, TooLarge> {
        let validity = Validity::new(domain);
        let counted = count_within(domain, &validity, max_size, max_sets, progress)?;
        Ok(Lattice::materialise(validity, max_size, &counted, progress))
    }

    fn materialise(validity: Validity, max_size: usize, counted: &Count, progress: Progress) -> Lattice {
        let total = counted.total();
        // Each set goes straight to its place: offsets come from the counts.
        let mut offsets = Vec::with_capacity(max_size + 2);
        let mut at = 0usize;
        for k in 0..=max_size {
            offsets.push(at);
            at += counted.per_size.get(k).copied().unwrap_or(0) as usize;
        }
        offsets.push(at);
        let mut sets = vec![ConceptSet::EMPTY; at];
        let mut next = offsets.clone();
        let mut done = 0u64;
        let _ = try_for_each_valid_sized(&validity, max_size, |s, k| {
            // The counts and the walk agree (tests compare them on every test domain); a set
            // beyond its count would overwrite the next size's first.
            if next[k] < offsets[k + 1] {
                sets[next[k]] = s;
            }
            next[k] += 1;
            done += 1;
            if done.is_multiple_of(PROGRESS_EVERY) {
                progress("enumerating valid sets", done, total);
            }
            ControlFlow::<()>::Continue(())
        });
        debug_assert_eq!(next[..=max_size], offsets[1..], "the walk emitted the diagram's counts");
        Lattice { sets, offsets, max_size, validity }
    }

    pub fn max_size(&self) -> usize {
        self.max_size
    }

    /// Number of sets.
    pub fn len(&self) -> usize {
        self.sets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sets.is_empty()
    }

    /// Number of sets of each size: `counts()[k]` for size `k` (`counts()[0] = 0`).
    pub fn counts(&self) -> Vec<usize> {
        self.offsets.windows(2).map(|w| w[1] - w[0]).collect()
    }

    /// The sets of exactly `size` concepts, in canonical order.
    pub fn of_size(&self, size: usize) -> &[ConceptSet] {
        if size > self.max_size {
            return &[];
        }
        &self.sets[self.offsets[size]..self.offsets[size + 1]]
    }

    /// The compiled validity rules.
    pub fn validity(&self) -> &Validity {
        &self.validity
    }

    /// Whether `set` is valid (any size).
    pub fn is_valid(&self, set: ConceptSet) -> bool {
        self.validity.is_valid(set)
    }

    /// Whether `set` is in the lattice: valid and of at most `max_size` concepts.
    pub fn contains(&self, set: ConceptSet) -> bool {
        self.position(set).is_some()
    }

    /// The index of `set` in [`Lattice::sets`].
    pub fn position(&self, set: ConceptSet) -> Option<usize> {
        let bucket = self.of_size(set.len());
        let i = bucket.binary_search_by(|s| lexicographic_cmp(*s, set)).ok()?;
        Some(self.offsets[set.len()] + i)
    }

    /// The valid sets of at most `max_size` concepts that add one concept to `set`, in
    /// canonical order (for beam search). From the empty set: the valid singletons.
    pub fn extensions(&self, set: ConceptSet) -> Vec<ConceptSet> {
        if set.len() >= self.max_size {
            return Vec::new();
        }
        let free = self.validity.universe().difference(set);
        free.iter().map(|c| set.with(c)).filter(|s| self.validity.is_valid(*s)).collect()
    }

    /// Concepts that appear in at least one set.
    pub fn support(&self) -> ConceptSet {
        self.sets.iter().fold(ConceptSet::EMPTY, |acc, s| acc.union(*s))
    }
}

/// Canonical order of concept sets: by size, then lexicographically by sorted concept indices.
pub fn canonical_cmp(a: ConceptSet, b: ConceptSet) -> Ordering {
    a.len().cmp(&b.len()).then_with(|| lexicographic_cmp(a, b))
}

/// The canonical order of two sets of the same size.
fn lexicographic_cmp(a: ConceptSet, b: ConceptSet) -> Ordering {
    let Some(lowest) = a.symmetric_difference(b).first() else {
        return Ordering::Equal;
    };
    // Both sets agree below the lowest differing bit; the one holding it lists it first,
    // while the other lists a higher index at that position.
    if a.contains(lowest) { Ordering::Less } else { Ordering::Greater }
}

/// Call `visit` on every valid set of 1 to `max_size` concepts, in lexicographic order of sorted
/// concept indices (sizes interleaved), without storing them.
pub fn for_each_valid(validity: &Validity, max_size: usize, mut visit: impl FnMut(ConceptSet)) {
    let _ = try_for_each_valid(validity, max_size, |s| {
        visit(s);
        ControlFlow::<()>::Continue(())
    });
}

/// [`for_each_valid`] that stops as soon as `visit` breaks, returning its value.
pub fn try_for_each_valid<B>(
    validity: &Validity,
    max_size: usize,
    mut visit: impl FnMut(ConceptSet) -> ControlFlow<B>,
) -> ControlFlow<B> {
    try_for_each_valid_sized(validity, max_size, |s, _| visit(s))
}

/// [`try_for_each_valid`] that also passes each set's size (known to the walk, so the visitor
/// need not count eight words of bits).
pub fn try_for_each_valid_sized<B>(
    validity: &Validity,
    max_size: usize,
    mut visit: impl FnMut(ConceptSet, usize) -> ControlFlow<B>,
) -> ControlFlow<B> {
    // The narrowest word that holds every concept: the shipped domains fit one.
    let n = validity.universe().last().map_or(0, |c| c.index() + 1);
    if n <= 64 {
        walk::Rules::<u64>::new(validity).walk(max_size, &mut |s, k| visit(s.widen(), k))
    } else if n <= 128 {
        walk::Rules::<u128>::new(validity).walk(max_size, &mut |s, k| visit(s.widen(), k))
    } else {
        walk::Rules::<ConceptSet>::new(validity).walk(max_size, &mut visit)
    }
}

/// Call `visit` on every valid set of exactly `size` concepts, in canonical order, until it
/// breaks.
pub fn try_for_each_of_size<B>(
    validity: &Validity,
    size: usize,
    mut visit: impl FnMut(ConceptSet) -> ControlFlow<B>,
) -> ControlFlow<B> {
    try_for_each_valid_sized(validity, size, |s, k| if k == size { visit(s) } else { ControlFlow::Continue(()) })
}

#[cfg(test)]
mod tests {
    use super::testkit::*;
    use super::*;
    use crate::anchor;
    use crate::ir::{ConceptId, ConstraintRule, Selection};

    /// Every subset of `n` concepts with 1..=k members, by brute force.
    fn all_subsets(n: usize, k: usize) -> Vec<ConceptSet> {
        let mut out = vec![ConceptSet::EMPTY];
        for c in 0..n {
            let grown: Vec<ConceptSet> =
                out.iter().filter(|s| s.len() < k).map(|s| s.with(ConceptId(c as u32))).collect();
            out.extend(grown);
        }
        out.retain(|s| !s.is_empty());
        out
    }

    /// Reference validity written directly from the definitions, without masks.
    fn reference_valid(d: &Domain, s: ConceptSet) -> bool {
        let constraints = d.constraints.iter().all(|c| match c.rule {
            ConstraintRule::AtMost { members, max } => s.intersection(members).len() <= max as usize,
            ConstraintRule::Requires { concept, any_of } => !s.contains(concept) || !s.intersection(any_of).is_empty(),
            ConstraintRule::Forbids { all } => !all.is_subset_of(s),
        });
        !s.is_empty() && constraints && anchor::build(d, s).is_ok()
    }

    /// Small synthetic domains exercising every kind of rule.
    fn domains() -> Vec<Domain> {
        let mut out = vec![driving()];
        // Requires chains, forbids, at-most-2, and a modifier whose only provider comes later.
        let mut b = Dom::new(Selection::BestFit);
        let tag = b.tag("Thing");
        let thing = b.kind("Thing", &[tag], &[("distance", num(5.0))]);
        let bare = b.kind("Bare", &[], &[]);
        let m0 = b.modifier("closer", filter(&[thing], &[]), &[("distance", num(1.0))]);
        let a = b.concept("a", &[("x", thing, "lane", &[])]);
        let c1 = b.concept("b", &[("y", bare, "lane", &[])]);
        let c2 = b.concept("c", &[("z", thing, "lane", &[]), ("w", bare, "lane", &[])]);
        let c3 = b.world_concept("d", "w", num(1.0));
        let c4 = b.concept("e", &[]);
        // Any entity: targets `b`'s and `c`'s entities too, but `b`'s entity lacks `distance`.
        let m1 = b.modifier("anything", filter(&[], &[]), &[("distance", num(2.0))]);
        let m2 = b.modifier("global", world_filter(), &[("w", num(3.0))]);
        b.constraint("a_needs_d_or_e", ConstraintRule::Requires { concept: a, any_of: ConceptSet::from_ids([c3, c4]) });
        b.constraint("no_bcd", ConstraintRule::Forbids { all: ConceptSet::from_ids([c1, c2, c3]) });
        b.constraint("two_mods", ConstraintRule::AtMost { members: ConceptSet::from_ids([m0, m1, m2]), max: 2 });
        b.constraint("e_needs_m0", ConstraintRule::Requires { concept: c4, any_of: ConceptSet::single(m0) });
        out.push(b.build());
        // No constraints at all: the lattice is every set without a dangling modifier.
        let mut b = Dom::new(Selection::Priority);
        let k = b.kind("K", &[], &[("distance", num(1.0))]);
        for i in 0..6 {
            b.concept(&format!("c{i}"), &[("e", k, "lane", &[])]);
        }
        b.modifier("m", filter(&[k], &[]), &[("distance", num(2.0))]);
        out.push(b.build());
        // A modifier with no possible target and a concept excluded by a one-member at-most.
        let mut b = Dom::new(Selection::Priority);
        let k = b.kind("K", &[], &[]);
        let other = b.kind("Other", &[], &[]);
        let x = b.concept("x", &[("e", k, "lane", &[])]);
        b.concept("y", &[]);
        b.modifier("lost", filter(&[other], &[]), &[]);
        b.constraint("never_x", ConstraintRule::AtMost { members: ConceptSet::single(x), max: 0 });
        out.push(b.build());
        // Entities placed relative to entities of other concepts (`near owner`, `behind barrier`,
        // `on stool`): a set needs the concept that adds the target.
        for (name, text) in [
            ("walk_the_dog.rev", include_str!("../../tests/corpus/good/walk_the_dog.rev")),
            ("indoor.rev", include_str!("../../domains/indoor.rev")),
        ] {
            out.push(crate::check::compile_source(name, text).unwrap_or_else(|e| panic!("{name}: {e:?}")));
        }
        out
    }

    #[test]
    fn enumeration_matches_brute_force() {
        for d in domains() {
            let n = d.concepts.len();
            let k = if n > 12 { 3 } else { n };
            let lattice = Lattice::enumerate(&d, k);
            let expected: Vec<ConceptSet> = all_subsets(n, k).into_iter().filter(|s| reference_valid(&d, *s)).collect();
            let mut sorted = expected.clone();
            sorted.sort_by(|a, b| canonical_cmp(*a, *b));
            assert_eq!(lattice.sets, sorted, "domain with {n} concepts");
            for s in all_subsets(n, k) {
                assert_eq!(lattice.contains(s), reference_valid(&d, s), "{:?}", d.set_names(s));
                assert_eq!(lattice.is_valid(s), reference_valid(&d, s));
            }
        }
    }

    #[test]
    fn the_walk_emits_the_same_sets_on_every_word_width() {
        for d in domains() {
            let v = Validity::new(&d);
            let k = if d.concepts.len() > 12 { 4 } else { d.concepts.len() };
            fn walked<W: Bits>(v: &Validity, k: usize) -> Vec<(ConceptSet, usize)> {
                let mut out = Vec::new();
                let _ = walk::Rules::<W>::new(v).walk(k, &mut |s: W, size| {
                    out.push((s.widen(), size));
                    ControlFlow::<()>::Continue(())
                });
                out
            }
            let narrow = walked::<u64>(&v, k);
            assert!(narrow.iter().all(|&(s, size)| s.len() == size && v.is_valid(s)));
            assert_eq!(narrow, walked::<u128>(&v, k), "{}", d.name);
            assert_eq!(narrow, walked::<ConceptSet>(&v, k), "{}", d.name);
        }
        // Past 64 concepts the wider words are taken; the counts stay exact.
        let mut b = Dom::new(Selection::Priority);
        let kind = b.kind("K", &[], &[("distance", num(1.0))]);
        let ids: Vec<ConceptId> = (0..130).map(|i| b.concept(&format!("c{i}"), &[("e", kind, "lane", &[])])).collect();
        let m = b.modifier("m", filter(&[kind], &[]), &[("distance", num(2.0))]);
        b.constraint(
            "few",
            ConstraintRule::AtMost { members: ConceptSet::from_ids([ids[0], ids[70], ids[129]]), max: 1 },
        );
        b.constraint("apart", ConstraintRule::Forbids { all: ConceptSet::from_ids([ids[1], ids[65]]) });
        let d = b.build();
        let v = Validity::new(&d);
        let counted = count(&v, 2, u64::MAX, &mut quiet);
        let binom2 = |n: u64| n * (n - 1) / 2;
        // 131 concepts; the modifier alone is invalid; 3 pairs of `few` and 1 of `apart` are not.
        assert_eq!(counted.per_size, vec![0, 130, binom2(131) - 3 - 1]);
        assert!(!Lattice::build(&d, 2, u64::MAX, &mut quiet).unwrap().contains(ConceptSet::single(m)));
    }

    #[test]
    fn target_masks_agree_with_anchor_build() {
        for d in domains() {
            let v = Validity::new(&d);
            let n = d.concepts.len();
            for s in all_subsets(n, if n > 12 { 3 } else { n }) {
                assert_eq!(v.check_targets(s).is_ok(), anchor::build(&d, s).is_ok(), "{:?}", d.set_names(s));
            }
        }
    }

    #[test]
    fn canonical_order_is_size_then_lexicographic() {
        let ids = |v: &[u32]| ConceptSet::from_ids(v.iter().map(|&i| ConceptId(i)));
        let ordered = [ids(&[3]), ids(&[0, 1]), ids(&[0, 2]), ids(&[0, 9]), ids(&[1, 2]), ids(&[0, 1, 2])];
        for w in ordered.windows(2) {
            assert_eq!(canonical_cmp(w[0], w[1]), Ordering::Less, "{w:?}");
            assert_eq!(canonical_cmp(w[1], w[0]), Ordering::Greater);
        }
        // The brute-force order: compare the sorted index lists.
        let all = all_subsets(7, 7);
        for &a in all.iter().step_by(7) {
            for &b in &all {
                let key = |s: ConceptSet| (s.len(), s.iter().collect::<Vec<_>>());
                assert_eq!(canonical_cmp(a, b), key(a).cmp(&key(b)));
            }
        }
    }

    #[test]
    fn counts_positions_and_buckets_agree() {
        let d = driving();
        let lattice = Lattice::enumerate(&d, 3);
        let counts = lattice.counts();
        assert_eq!(counts.len(), 4);
        assert_eq!(counts.iter().sum::<usize>(), lattice.len());
        assert_eq!(counts[1], 24, "all but the four entity modifiers and the two lights are valid alone");
        for (i, s) in lattice.sets.iter().enumerate() {
            assert_eq!(lattice.position(*s), Some(i));
        }
        assert!(lattice.of_size(4).is_empty());
        let near = d.concept_by_name("near").unwrap().id;
        let cone = d.concept_by_name("cone").unwrap().id;
        assert!(!lattice.contains(ConceptSet::single(near)));
        assert!(lattice.contains(ConceptSet::from_ids([cone, near])));
        // Deterministic: a second enumeration is identical.
        assert_eq!(Lattice::enumerate(&d, 3).sets, lattice.sets);
    }

    #[test]
    fn build_counts_first_and_refuses_past_the_limit() {
        let d = driving();
        let full = Lattice::enumerate(&d, 3);
        let n = full.len() as u64;
        let mut reports = 0;
        let built = Lattice::build(&d, 3, n, &mut |_, _, _| reports += 1).unwrap();
        assert_eq!((&built.sets, built.counts()), (&full.sets, full.counts()));
        let err = Lattice::build(&d, 3, n - 1, &mut quiet).unwrap_err();
        assert_eq!(err.fits, Some((2, Lattice::enumerate(&d, 2).len() as u64)));
        assert_eq!(
            err.to_string(),
            format!("domain `test` has more than {} valid concept sets of up to 3 concepts", n - 1)
        );
        let d = err.diagnostic();
        assert_eq!(d.code, "R0070");
        assert!(d.help.unwrap().starts_with("search smaller sets (`--max-size 2` gives "));
        let counted = count(&Validity::new(&driving()), 3, u64::MAX, &mut quiet);
        assert_eq!(counted.per_size.iter().map(|&c| c as usize).collect::<Vec<_>>(), full.counts());
        assert!(counted.complete);
    }

    #[test]
    fn a_wide_unconstrained_domain_is_refused_by_counting() {
        // 128 concepts and no constraints: 275 million sets of up to five, which used to be
        // enumerated whole (minutes, gigabytes). Counting stops at the limit.
        let mut b = Dom::new(Selection::Priority);
        let k = b.kind("K", &[], &[]);
        for i in 0..128 {
            b.concept(&format!("c{i}"), &[("e", k, "lane", &[])]);
        }
        let d = b.build();
        let err = Lattice::build(&d, 5, DEFAULT_MAX_SETS, &mut quiet).unwrap_err();
        assert_eq!(err.fits, Some((3, 128 + 8128 + 341_376)));
        assert_eq!(Lattice::build(&d, 2, DEFAULT_MAX_SETS, &mut quiet).unwrap().len(), 128 + 8128);
        let mut last = 0;
        let built = Lattice::build(&d, 3, DEFAULT_MAX_SETS, &mut |_, done, _| last = last.max(done)).unwrap();
        assert_eq!(built.counts(), vec![0, 128, 8128, 341_376]);
        assert!(last >= PROGRESS_EVERY, "enumerating reported progress");
    }

    #[test]
    fn extensions_are_the_valid_one_concept_supersets() {
        let d = driving();
        let lattice = Lattice::enumerate(&d, 3);
        assert_eq!(lattice.extensions(ConceptSet::EMPTY), lattice.of_size(1));
        for &s in lattice.of_size(1).iter().chain(lattice.of_size(2)) {
            let expected: Vec<ConceptSet> =
                lattice.of_size(s.len() + 1).iter().copied().filter(|t| s.is_subset_of(*t)).collect();
            assert_eq!(lattice.extensions(s), expected, "{:?}", d.set_names(s));
        }
        assert!(lattice.of_size(3).iter().all(|s| lattice.extensions(*s).is_empty()));
    }

    #[test]
    fn validate_names_the_violation() {
        let d = driving();
        let set = |names: &[&str]| d.parse_set(names).unwrap();
        let err = validate(&d, set(&["town_town01", "town_town02"])).unwrap_err();
        assert_eq!(err.to_string(), "violates constraint `one_town` (at most 1 of `town_town01`, `town_town02`)");
        let err = validate(&d, set(&["cone", "near", "far"])).unwrap_err();
        assert_eq!(err.to_string(), "violates constraint `near_xor_far` (at most 1 of `near`, `far`)");
        let err = validate(&d, set(&["light_red"])).unwrap_err();
        assert_eq!(
            err.to_string(),
            "violates constraint `light_needs_intersection` (`light_red` requires `intersection_ego`)"
        );
        let err = validate(&d, set(&["near"])).unwrap_err();
        assert_eq!(err, Violation::NoTarget { modifier: "near".into() });
        assert_eq!(err.to_string(), "modifier `near` has no entity to apply to");
        assert_eq!(validate(&d, ConceptSet::EMPTY), Err(Violation::Empty));
        assert_eq!(validate(&d, ConceptSet::from_bits(1 << 100)), Err(Violation::UnknownConcept { index: 100 }));
        assert_eq!(validate(&d, set(&["cone", "near", "weather_foggy"])), Ok(()));
    }

    #[test]
    fn target_lacking_an_attribute_is_named() {
        let d = &domains()[1];
        let set = d.parse_set(&["b", "anything"]).unwrap();
        let err = validate(d, set).unwrap_err();
        assert_eq!(err.to_string(), "modifier `anything` sets `distance`, which its target `y` does not have");
        // With `c` (declared after `b`) the target is `c`'s last matching entity `w`, also bare.
        assert!(validate(d, d.parse_set(&["c", "anything"]).unwrap()).is_err());
        assert_eq!(validate(d, d.parse_set(&["a", "d", "anything"]).unwrap()), Ok(()));
    }

    #[test]
    fn diagram_counts_members_and_order_match_enumeration() {
        for d in domains() {
            let n = d.concepts.len();
            let k = if n > 12 { 4 } else { n };
            let lattice = Lattice::enumerate(&d, k);
            let diagram = Diagram::build(lattice.validity(), k);
            let counts: Vec<usize> = diagram.counts().iter().map(|&c| c as usize).collect();
            assert_eq!(counts, lattice.counts(), "domain with {n} concepts");
            assert_eq!(diagram.support(), lattice.support());
            for size in 1..=k {
                let mut listed = Vec::new();
                let _ = diagram.try_for_each_of_size(size, |s| {
                    listed.push(s);
                    ControlFlow::<()>::Continue(())
                });
                assert_eq!(listed, lattice.of_size(size), "sets of {size}");
            }
            for s in all_subsets(n, if n > 12 { 3 } else { n }) {
                assert_eq!(diagram.contains(s), lattice.contains(s), "{:?}", d.set_names(s));
            }
        }
    }

    #[test]
    fn diagram_counts_of_the_shipped_domains_are_the_enumerated_ones() {
        for (name, text) in [
            ("driving.rev", include_str!("../../domains/driving.rev")),
            ("indoor.rev", include_str!("../../domains/indoor.rev")),
        ] {
            let d = crate::check::compile_source(name, text).unwrap();
            let v = Validity::new(&d);
            let counted = count(&v, 5, u64::MAX, &mut quiet);
            let diagram = Diagram::build(&v, 5);
            assert_eq!(diagram.counts().iter().map(|&c| c as u64).collect::<Vec<_>>(), counted.per_size, "{name}");
        }
    }

    #[test]
    fn diagram_samples_uniformly_and_within_a_subset() {
        use rand::SeedableRng;
        let d = driving();
        let lattice = Lattice::enumerate(&d, 3);
        let diagram = Diagram::build(lattice.validity(), 3);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let pairs = lattice.of_size(2);
        let mut hits = std::collections::HashMap::new();
        let draws = pairs.len() * 200;
        for _ in 0..draws {
            let s = diagram.sample(2, &mut rng).unwrap();
            assert!(lattice.contains(s) && s.len() == 2);
            *hits.entry(s).or_insert(0usize) += 1;
        }
        assert_eq!(hits.len(), pairs.len(), "every pair drawn");
        // 200 expected per pair: a pair drawn under 120 or over 300 times means a bias.
        assert!(hits.values().all(|&h| (120..300).contains(&h)), "{:?}", hits.values().min());
        let cone = ConceptSet::single(d.concept_by_name("cone").unwrap().id);
        let with_cone: Vec<ConceptSet> = lattice.of_size(3).iter().copied().filter(|s| cone.is_subset_of(*s)).collect();
        assert_eq!(diagram.counts_containing(cone)[3] as usize, with_cone.len());
        for _ in 0..200 {
            let s = diagram.sample_containing(cone, 3, &mut rng).unwrap();
            assert!(with_cone.contains(&s));
        }
        let any = diagram.sample_any(&mut rng).unwrap();
        assert!(lattice.contains(any));
        assert_eq!(diagram.sample(4, &mut rng), None, "past max_size");
    }

    #[test]
    fn diagram_counts_wide_domains_exactly() {
        // 500 independent concepts (no constraints): C(500, k) sets of k.
        let mut b = Dom::new(Selection::Priority);
        let k = b.kind("K", &[], &[]);
        for i in 0..500 {
            b.concept(&format!("c{i}"), &[("e", k, "lane", &[])]);
        }
        let d = b.build();
        let diagram = Diagram::build(&Validity::new(&d), 5);
        let binom = |n: u128, k: u128| (0..k).fold(1u128, |a, i| a * (n - i) / (i + 1));
        assert_eq!(diagram.counts(), (0..=5).map(|k| if k == 0 { 0 } else { binom(500, k) }).collect::<Vec<_>>());
        assert_eq!(diagram.nodes(), 500, "one node per level");
        let last = ConceptSet::from_ids([ConceptId(3), ConceptId(499)]);
        assert!(diagram.contains(last));
        assert_eq!(diagram.counts_containing(last)[3], 498);
    }
}
