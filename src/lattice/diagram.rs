//! The valid family as a decision diagram: exact counts, membership, uniform sampling and
//! enumeration of the valid sets of any size of domain, without listing them.
//!
//! **Structure.** One level per concept, in index order; a node at level `i` decides concept
//! `i` and has two children at level `i + 1` — concept left out (`lo`) and concept taken (`hi`)
//! — or a dead end. A path from the root to the end is a set; the sets that reach the end are
//! exactly the sets [`Validity`] accepts (plus the empty set, which every count leaves out).
//! This is a zero-suppressed-style diagram built top-down (frontier-based, Minato's method):
//! a node *is* the state of every validity rule after the concepts decided so far, and two
//! prefixes with the same state share one node. Each rule's state is small:
//!
//! | rule | state while its concepts are being decided |
//! |---|---|
//! | `at_most N of M` | how many of `M` are taken (dead past `N`) |
//! | `forbids M` | how many of `M` are taken (dead at all of them) |
//! | `c requires any of M`, relation targets | open / `c` taken and unmet / met |
//! | modifier `m` with providers `P` | `m` taken?, is the last provider taken fine or lacking |
//!
//! A rule's state returns to a single "done" value after its last concept (or dies there), so
//! the width of a level is the number of distinct states of the rules whose concepts straddle
//! it: one node per level for independent concepts, a few hundred for the shipped domains (69 driving, 240 delivery, 560 indoor).
//!
//! **Counts.** Every node holds the number of valid completions by size, up to `max_size`
//! (128-bit, exact); the root's counts are the lattice's counts per size. Sampling walks down,
//! taking a child with probability proportional to its count, so a draw is exactly uniform over
//! the valid sets of a size; a draw that must contain given concepts recounts with those
//! concepts forced (one pass over the nodes).

use std::collections::HashMap;
use std::ops::ControlFlow;

use rand::{Rng, RngExt};

use super::Validity;
use crate::ir::{ConceptId, ConceptSet};

/// No child: every set through this edge is invalid.
const DEAD: u32 = u32::MAX;

/// One validity rule, as the diagram tracks it.
#[derive(Debug, Clone)]
enum Rule {
    /// At most `max` of `members` (forbids: at most `|members| − 1`).
    AtMost { members: ConceptSet, max: u16 },
    /// `concept` (when taken) needs one of `any` taken.
    Requires { concept: ConceptId, any: ConceptSet },
    /// Modifier `m` (when taken) needs a provider, and the highest taken provider must not be
    /// lacking.
    Modifier { m: ConceptId, providers: ConceptSet, lacking: ConceptSet },
}

// Requires states.
const OPEN: u16 = 0;
const NEED: u16 = 1;
const MET: u16 = 2;
// Modifier states: bit 0 = modifier taken; bits 1–2 = last provider none (0) / fine (1) /
// lacking (2).
const M_TAKEN: u16 = 1;

impl Rule {
    /// The concept after which the rule's state no longer changes.
    fn last(&self) -> u32 {
        let (a, b) = match self {
            Rule::AtMost { members, .. } => (members.last(), None),
            Rule::Requires { concept, any } => (any.last(), Some(*concept)),
            Rule::Modifier { m, providers, .. } => (providers.last(), Some(*m)),
        };
        a.into_iter().chain(b).map(|c| c.0).max().unwrap_or(0)
    }

    /// The state after deciding concept `c` (`take`), or `None` when the set is already invalid.
    fn step(&self, state: u16, c: ConceptId, take: bool) -> Option<u16> {
        match *self {
            Rule::AtMost { members, max } => {
                if take && members.contains(c) {
                    if state >= max { None } else { Some(state + 1) }
                } else {
                    Some(state)
                }
            }
            Rule::Requires { concept, any } => Some(if state == MET || (take && any.contains(c)) {
                MET
            } else if c == concept {
                if take { NEED } else { MET }
            } else {
                state
            }),
            Rule::Modifier { m, providers, lacking } => {
                let mut s = state;
                if c == m {
                    if !take {
                        // Left out: the rule holds whatever comes; one "done" state.
                        return Some(u16::MAX);
                    }
                    s |= M_TAKEN;
                }
                if s == u16::MAX {
                    return Some(s);
                }
                if take && providers.contains(c) {
                    s = (s & M_TAKEN) | if lacking.contains(c) { 4 } else { 2 };
                }
                Some(s)
            }
        }
    }

    /// Whether the final state (after [`Rule::last`]) is satisfied.
    fn holds(&self, state: u16) -> bool {
        match self {
            Rule::AtMost { .. } => true,
            Rule::Requires { .. } => state != NEED,
            Rule::Modifier { .. } => state == u16::MAX || state & M_TAKEN == 0 || state >> 1 == 1,
        }
    }
}

/// The valid sets of a domain (see the module docs).
#[derive(Debug, Clone)]
pub struct Diagram {
    /// `levels[i][node] = [lo, hi]`: node indices at level `i + 1` (or [`DEAD`]). The last level
    /// has one node, the end.
    levels: Vec<Vec<[u32; 2]>>,
    /// Largest set size counted.
    max_size: usize,
    /// `counts[i][node * (max_size + 1) + k]`: completions of exactly `k` more concepts.
    counts: Vec<Vec<u128>>,
}

impl Diagram {
    /// Build the diagram of the valid sets for `validity`, counting sets of up to `max_size`.
    pub fn build(validity: &Validity, max_size: usize) -> Diagram {
        let n = validity.universe().last().map_or(0, |c| c.index() + 1);
        let mut rules: Vec<Rule> = Vec::new();
        for &(_, members, max) in validity.at_most() {
            // A bound at or past the members' number never binds.
            if (max as usize) < members.len() {
                rules.push(Rule::AtMost { members, max: max as u16 });
            }
        }
        for &(_, all) in validity.forbids() {
            rules.push(Rule::AtMost { members: all, max: (all.len().max(1) - 1) as u16 });
        }
        for &(_, concept, any) in validity.requires() {
            rules.push(Rule::Requires { concept, any });
        }
        for t in validity.modifier_targets() {
            rules.push(Rule::Modifier { m: t.modifier, providers: t.providers, lacking: t.lacking });
        }
        for &(concept, _, providers) in validity.relation_targets() {
            rules.push(Rule::Requires { concept, any: providers });
        }
        // Rules that never change a state (a concept past the universe) cannot be tracked.
        let last: Vec<u32> = rules.iter().map(Rule::last).collect();
        // Which rules each concept touches (the others keep their state).
        let touches = |r: &Rule, c: ConceptId| match r {
            Rule::AtMost { members, .. } => members.contains(c),
            Rule::Requires { concept, any } => *concept == c || any.contains(c),
            Rule::Modifier { m, providers, .. } => *m == c || providers.contains(c),
        };
        let by_concept: Vec<Vec<usize>> =
            (0..n).map(|c| (0..rules.len()).filter(|&r| touches(&rules[r], ConceptId(c as u32))).collect()).collect();
        let initial = |r: &Rule| match r {
            Rule::AtMost { .. } => 0,
            Rule::Requires { .. } => OPEN,
            Rule::Modifier { .. } => 0,
        };
        let mut states: Vec<Vec<u16>> = vec![rules.iter().map(initial).collect()];
        let mut levels = Vec::with_capacity(n + 1);
        for (c, touched) in by_concept.iter().enumerate() {
            let id = ConceptId(c as u32);
            let mut next: HashMap<Vec<u16>, u32> = HashMap::new();
            let mut next_states: Vec<Vec<u16>> = Vec::new();
            let mut level = Vec::with_capacity(states.len());
            for state in &states {
                let mut children = [DEAD; 2];
                'child: for (take, child) in [false, true].into_iter().zip(&mut children) {
                    let mut s = state.clone();
                    for &r in touched {
                        match rules[r].step(s[r], id, take) {
                            Some(v) => s[r] = v,
                            None => continue 'child,
                        }
                        if last[r] == c as u32 {
                            if !rules[r].holds(s[r]) {
                                continue 'child;
                            }
                            s[r] = initial(&rules[r]);
                        }
                    }
                    let len = next_states.len() as u32;
                    *child = *next.entry(s.clone()).or_insert_with(|| {
                        next_states.push(s);
                        len
                    });
                }
                level.push(children);
            }
            levels.push(level);
            states = next_states;
        }
        debug_assert!(states.len() <= 1, "every rule is closed after its last concept");
        // `forbids` of no concept rules out every set.
        if validity.forbids().iter().any(|(_, all)| all.is_empty())
            && let Some(first) = levels.first_mut()
        {
            first.iter_mut().for_each(|c| *c = [DEAD; 2]);
        }
        let mut d = Diagram { levels, max_size, counts: Vec::new() };
        d.counts = d.count_with(ConceptSet::EMPTY);
        d
    }

    /// Number of concepts (levels).
    pub fn concepts(&self) -> usize {
        self.levels.len()
    }

    /// Number of nodes (the diagram's size).
    pub fn nodes(&self) -> usize {
        self.levels.iter().map(Vec::len).sum()
    }

    pub fn max_size(&self) -> usize {
        self.max_size
    }

    /// Counts per node, bottom-up, of the valid completions that take every concept of `forced`.
    fn count_with(&self, forced: ConceptSet) -> Vec<Vec<u128>> {
        let w = self.max_size + 1;
        let n = self.levels.len();
        let mut counts: Vec<Vec<u128>> = vec![Vec::new(); n + 1];
        // The end: one node, the empty completion.
        let mut end = vec![0u128; w];
        end[0] = 1;
        counts[n] = end;
        for i in (0..n).rev() {
            let force = forced.contains(ConceptId(i as u32));
            let (now, below) = counts.split_at_mut(i + 1);
            let below = &below[0];
            let mut level = vec![0u128; self.levels[i].len() * w];
            for (node, &[lo, hi]) in self.levels[i].iter().enumerate() {
                let row = &mut level[node * w..(node + 1) * w];
                if lo != DEAD && !force {
                    let lo = &below[lo as usize * w..(lo as usize + 1) * w];
                    for k in 0..w {
                        row[k] = row[k].saturating_add(lo[k]);
                    }
                }
                if hi != DEAD {
                    let hi = &below[hi as usize * w..(hi as usize + 1) * w];
                    for k in 1..w {
                        row[k] = row[k].saturating_add(hi[k - 1]);
                    }
                }
            }
            now[i] = level;
        }
        counts
    }

    /// Valid sets per size, `[k]` for size `k` (`[0] = 0`): exact (saturating at 2¹²⁸).
    pub fn counts(&self) -> Vec<u128> {
        self.root_counts(&self.counts)
    }

    fn root_counts(&self, counts: &[Vec<u128>]) -> Vec<u128> {
        let mut c =
            counts[0].get(..self.max_size + 1).map(<[u128]>::to_vec).unwrap_or_else(|| vec![0; self.max_size + 1]);
        c[0] = 0;
        c
    }

    /// Total valid sets of 1 to `max_size` concepts.
    pub fn total(&self) -> u128 {
        self.counts().iter().fold(0u128, |a, b| a.saturating_add(*b))
    }

    /// Valid sets per size that contain every concept of `subset`.
    pub fn counts_containing(&self, subset: ConceptSet) -> Vec<u128> {
        self.root_counts(&self.count_with(subset))
    }

    /// Whether `set` is valid and of 1 to `max_size` concepts.
    pub fn contains(&self, set: ConceptSet) -> bool {
        if set.is_empty() || set.len() > self.max_size || set.last().is_some_and(|c| c.index() >= self.levels.len()) {
            return false;
        }
        let mut node = 0u32;
        for (i, level) in self.levels.iter().enumerate() {
            node = level[node as usize][usize::from(set.contains(ConceptId(i as u32)))];
            if node == DEAD {
                return false;
            }
        }
        true
    }

    /// A valid set of exactly `size` concepts that contains `subset`, uniformly at random among
    /// them; `None` when there is none.
    pub fn sample_containing(&self, subset: ConceptSet, size: usize, rng: &mut impl Rng) -> Option<ConceptSet> {
        if subset.is_empty() {
            return self.walk(&self.counts, ConceptSet::EMPTY, size, rng);
        }
        let counts = self.count_with(subset);
        self.walk(&counts, subset, size, rng)
    }

    /// A valid set of exactly `size` concepts, uniformly at random; `None` when there is none.
    pub fn sample(&self, size: usize, rng: &mut impl Rng) -> Option<ConceptSet> {
        self.walk(&self.counts, ConceptSet::EMPTY, size, rng)
    }

    /// A valid set of 1 to `max_size` concepts, uniformly at random over all of them.
    pub fn sample_any(&self, rng: &mut impl Rng) -> Option<ConceptSet> {
        let counts = self.counts();
        let total = counts.iter().fold(0u128, |a, b| a.saturating_add(*b));
        if total == 0 {
            return None;
        }
        let mut r = below(rng, total);
        let size = counts.iter().position(|&c| {
            if r < c {
                return true;
            }
            r -= c;
            false
        })?;
        self.sample(size, rng)
    }

    fn walk(&self, counts: &[Vec<u128>], forced: ConceptSet, size: usize, rng: &mut impl Rng) -> Option<ConceptSet> {
        let w = self.max_size + 1;
        if size == 0 || size > self.max_size || counts[0].get(size).is_none_or(|&c| c == 0) {
            return None;
        }
        let mut set = ConceptSet::EMPTY;
        let (mut node, mut left) = (0usize, size);
        for (i, level) in self.levels.iter().enumerate() {
            let [lo, hi] = level[node];
            let next = &counts[i + 1];
            let via_hi = if hi == DEAD || left == 0 { 0 } else { next[hi as usize * w + left - 1] };
            let force = forced.contains(ConceptId(i as u32));
            let via_lo = if lo == DEAD || force { 0 } else { next[lo as usize * w + left] };
            if via_hi > 0 && below(rng, via_hi.saturating_add(via_lo)) < via_hi {
                set.insert(ConceptId(i as u32));
                node = hi as usize;
                left -= 1;
            } else {
                node = lo as usize;
            }
        }
        Some(set)
    }

    /// Calls `visit` on every valid set of exactly `size` concepts, in canonical order (by
    /// sorted concept indices), until it breaks. Cost: the sets visited times the depth.
    pub fn try_for_each_of_size<B>(
        &self,
        size: usize,
        mut visit: impl FnMut(ConceptSet) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        if size == 0 || size > self.max_size {
            return ControlFlow::Continue(());
        }
        self.dfs(0, 0, size, ConceptSet::EMPTY, &mut visit)
    }

    fn dfs<B>(
        &self,
        level: usize,
        node: u32,
        left: usize,
        set: ConceptSet,
        visit: &mut impl FnMut(ConceptSet) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        let w = self.max_size + 1;
        if self.counts[level][node as usize * w + left] == 0 {
            return ControlFlow::Continue(());
        }
        if level == self.levels.len() {
            return visit(set);
        }
        let [lo, hi] = self.levels[level][node as usize];
        // Taking the concept first gives the lexicographic order of sorted indices.
        if hi != DEAD && left > 0 {
            self.dfs(level + 1, hi, left - 1, set.with(ConceptId(level as u32)), visit)?;
        }
        if lo != DEAD {
            self.dfs(level + 1, lo, left, set, visit)?;
        }
        ControlFlow::Continue(())
    }

    /// Concepts that appear in at least one valid set of 1 to `max_size` concepts.
    pub fn support(&self) -> ConceptSet {
        let w = self.max_size + 1;
        // Reachable nodes, with the least number of concepts taken on the way in.
        let mut reach: Vec<u32> = vec![0];
        let mut taken: Vec<usize> = vec![0];
        let mut out = ConceptSet::EMPTY;
        for (i, level) in self.levels.iter().enumerate() {
            let next_len = self.counts[i + 1].len() / w;
            let mut next = vec![usize::MAX; next_len];
            for (&node, &t) in reach.iter().zip(&taken) {
                let [lo, hi] = level[node as usize];
                if hi != DEAD && t < self.max_size {
                    let rest = &self.counts[i + 1][hi as usize * w..(hi as usize + 1) * w];
                    if rest[..w - t - 1].iter().any(|&c| c > 0) {
                        out.insert(ConceptId(i as u32));
                        next[hi as usize] = next[hi as usize].min(t + 1);
                    }
                }
                if lo != DEAD {
                    let rest = &self.counts[i + 1][lo as usize * w..(lo as usize + 1) * w];
                    if rest[..w - t].iter().any(|&c| c > 0) {
                        next[lo as usize] = next[lo as usize].min(t);
                    }
                }
            }
            reach.clear();
            taken.clear();
            for (node, &t) in next.iter().enumerate() {
                if t != usize::MAX {
                    reach.push(node as u32);
                    taken.push(t);
                }
            }
        }
        out
    }
}

/// Uniform in `0..n` (n > 0) for 128-bit counts.
fn below(rng: &mut impl Rng, n: u128) -> u128 {
    if n <= u64::MAX as u128 {
        return rng.random_range(0..n as u64) as u128;
    }
    // Rejection over the smallest power of two at or above n.
    let bits = 128 - (n - 1).leading_zeros();
    loop {
        let x = (rng.next_u64() as u128 | (rng.next_u64() as u128) << 64) >> (128 - bits);
        if x < n {
            return x;
        }
    }
}
