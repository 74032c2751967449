//! The depth-first enumeration of valid sets, on the narrowest word that holds the domain.
//!
//! Sets are [`MAX_CONCEPTS`](crate::ir::MAX_CONCEPTS) wide ([`ConceptSet`], eight 64-bit words),
//! but the shipped domains have about 30 concepts: walking their lattices on eight words made
//! every mask test eight words wide, and the enumeration three times slower than with the
//! 128-bit sets before. So the walk compiles [`Validity`]'s masks once more, onto a `u64`
//! (domains of up to 64 concepts), a `u128` (up to 128) or the full set ([`Bits`]), and widens
//! to a [`ConceptSet`] only the sets it emits. Tests compare the three widths set for set.
//!
//! The rules are [`Validity`]'s, mask for mask. At-most and forbids are monotone (a violating set
//! has only violating supersets), so a branch is cut as soon as one fails; and since the walk
//! only extends sets that passed them, only the constraints that hold the concept just added are
//! tested. Requires, relation targets and modifier targets can be repaired by a later concept:
//! they are checked on each emitted set, and cut a branch only once no remaining concept could
//! repair them ([`Validity::hopeless`]).

use std::ops::ControlFlow;

use super::Validity;
use crate::ir::ConceptSet;

/// A set of concepts as one or more machine words.
pub(crate) trait Bits: Copy + PartialEq {
    const ZERO: Self;
    fn narrow(s: ConceptSet) -> Self;
    fn widen(self) -> ConceptSet;
    fn with(self, c: u32) -> Self;
    fn and(self, o: Self) -> Self;
    fn is_zero(self) -> bool;
    fn count(self) -> u32;
    /// The highest concept in a non-empty set.
    fn top(self) -> Self;
}

/// One machine word: `$narrow` takes its part of a set (a `u64`'s is within the low 128 bits).
macro_rules! word_bits {
    ($word:ty, $narrow:expr) => {
        impl Bits for $word {
            const ZERO: Self = 0;
            fn narrow(s: ConceptSet) -> Self {
                $narrow(s)
            }
            fn widen(self) -> ConceptSet {
                ConceptSet::from_bits(u128::from(self))
            }
            fn with(self, c: u32) -> Self {
                self | 1 << c
            }
            fn and(self, o: Self) -> Self {
                self & o
            }
            fn is_zero(self) -> bool {
                self == 0
            }
            fn count(self) -> u32 {
                self.count_ones()
            }
            fn top(self) -> Self {
                1 << (<$word>::BITS - 1 - self.leading_zeros())
            }
        }
    };
}

word_bits!(u64, |s: ConceptSet| s.words()[0]);
word_bits!(u128, ConceptSet::low_bits);

impl Bits for ConceptSet {
    const ZERO: Self = ConceptSet::EMPTY;
    fn narrow(s: ConceptSet) -> Self {
        s
    }
    fn widen(self) -> ConceptSet {
        self
    }
    fn with(self, c: u32) -> Self {
        ConceptSet::with(self, crate::ir::ConceptId(c))
    }
    fn and(self, o: Self) -> Self {
        self.intersection(o)
    }
    fn is_zero(self) -> bool {
        self.is_empty()
    }
    fn count(self) -> u32 {
        self.len() as u32
    }
    fn top(self) -> Self {
        self.last().map_or(ConceptSet::EMPTY, ConceptSet::single)
    }
}

/// [`Validity`]'s rules on words of type `W`.
pub(crate) struct Rules<W> {
    /// Concepts `0..n` are walked.
    n: u32,
    /// Per concept: the at-most constraints `(members, max)` it is a member of.
    at_most: Vec<Vec<(W, u32)>>,
    /// Per concept: the forbids constraints it is one of the members of.
    forbids: Vec<Vec<W>>,
    /// A forbids constraint of no members: every set violates it.
    forbids_all: bool,
    /// Requires constraints and relation targets alike: `(concept, any of)`.
    requires: Vec<(W, W)>,
    /// Modifiers: `(modifier, providers, lacking)`.
    modifiers: Vec<(W, W, W)>,
    /// `suffix[c]`: concepts `c..n`, what can still repair a requirement.
    suffix: Vec<W>,
}

impl<W: Bits> Rules<W> {
    pub(crate) fn new(v: &Validity) -> Rules<W> {
        let n = v.universe().last().map_or(0, |c| c.0 + 1);
        let w = W::narrow;
        let single = |c: crate::ir::ConceptId| W::ZERO.with(c.0);
        let mut at_most = vec![Vec::new(); n as usize];
        for &(_, members, max) in v.at_most() {
            for c in members.iter().filter(|c| c.0 < n) {
                at_most[c.index()].push((w(members), max));
            }
        }
        let mut forbids = vec![Vec::new(); n as usize];
        for &(_, all) in v.forbids() {
            for c in all.iter().filter(|c| c.0 < n) {
                forbids[c.index()].push(w(all));
            }
        }
        let requires = v
            .requires()
            .iter()
            .map(|&(_, c, any)| (single(c), w(any)))
            .chain(v.relation_targets().iter().map(|&(c, _, providers)| (single(c), w(providers))))
            .collect();
        let modifiers =
            v.modifier_targets().iter().map(|t| (single(t.modifier), w(t.providers), w(t.lacking))).collect();
        let suffix =
            (0..=n).map(|c| w(v.universe().intersection(ConceptSet::from_concept(crate::ir::ConceptId(c))))).collect();
        let forbids_all = v.forbids().iter().any(|(_, all)| all.is_empty());
        Rules { n, at_most, forbids, forbids_all, requires, modifiers, suffix }
    }

    /// Call `visit(set, size)` on every valid set of 1 to `max_size` concepts, in lexicographic
    /// order of sorted concept indices, until it breaks.
    pub(crate) fn walk<B>(
        &self,
        max_size: usize,
        visit: &mut impl FnMut(W, usize) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        if max_size == 0 || self.forbids_all {
            return ControlFlow::Continue(());
        }
        self.dfs(W::ZERO, 0, 1, max_size, visit)
    }

    /// Whether the monotone constraints still hold once `c` joins `s` (which satisfied them).
    fn monotone_ok(&self, s: W, c: u32) -> bool {
        self.at_most[c as usize].iter().all(|&(m, max)| s.and(m).count() <= max)
            && self.forbids[c as usize].iter().all(|&all| !all_in(all, s))
    }

    /// Whether every requirement and modifier target of `s` is met.
    fn closure_ok(&self, s: W) -> bool {
        self.requires.iter().all(|&(c, any)| s.and(c).is_zero() || !s.and(any).is_zero())
            && self.modifiers.iter().all(|&(m, providers, lacking)| {
                let p = s.and(providers);
                s.and(m).is_zero() || (!p.is_zero() && p.top().and(lacking).is_zero())
            })
    }

    /// Whether some requirement or modifier of `s` is unmet and no concept of `rest` can meet it.
    fn hopeless(&self, s: W, rest: W) -> bool {
        let unmet = |needs: W| s.and(needs).is_zero() && rest.and(needs).is_zero();
        self.requires.iter().any(|&(c, any)| !s.and(c).is_zero() && unmet(any))
            || self.modifiers.iter().any(|&(m, providers, _)| !s.and(m).is_zero() && unmet(providers))
    }

    fn dfs<B>(
        &self,
        set: W,
        next: u32,
        size: usize,
        max_size: usize,
        visit: &mut impl FnMut(W, usize) -> ControlFlow<B>,
    ) -> ControlFlow<B> {
        for c in next..self.n {
            let s = set.with(c);
            if !self.monotone_ok(s, c) {
                continue;
            }
            if self.closure_ok(s) {
                visit(s, size)?;
            }
            if size < max_size && !self.hopeless(s, self.suffix[c as usize + 1]) {
                self.dfs(s, c + 1, size + 1, max_size, visit)?;
            }
        }
        ControlFlow::Continue(())
    }
}

/// Whether every concept of `all` is in `s`.
fn all_in<W: Bits>(all: W, s: W) -> bool {
    all.and(s) == all
}
