//! The search space: the valid concept sets of a domain (from the lattice), indexed so that
//! beam search can ask for a set's valid one-concept extensions and GPTS can score every
//! unexplored set.
//!
//! A lattice past `--max-sets` is not listed: the space is then *sampled* ([`Space::sampled`]),
//! backed by the lattice's decision diagram ([`Diagram`]) — exact counts, membership and uniform
//! draws, with and without a given subset — so `--algo interact` and `--algo random` work from
//! draws and the patterns they track, at a cost that grows with their budget, not with the
//! lattice. `beam` and `gpts` need the listed sets ([`Space::is_sampled`] is refused for them).
use std::collections::HashMap;
use std::sync::Arc;

use rand::{Rng, RngExt};

use crate::ir::{ConceptId, ConceptSet};
use crate::lattice::Diagram;

/// Which valid sets a sampled space keeps (those with a ground truth).
pub type Keep = Arc<dyn Fn(ConceptSet) -> bool + Send + Sync>;

/// Draws that a sampled space tries before it gives up on a draw (every one rejected by
/// [`Keep`]: a lattice almost all of whose sets have no ground truth).
const TRIES: usize = 64;

pub struct Space {
    /// Valid non-empty sets in the lattice's canonical order (ties in GPTS go to the earliest);
    /// empty for a sampled space.
    pub sets: Vec<ConceptSet>,
    /// Number of concepts in the domain (the width of the multi-hot vectors).
    pub dim: usize,
    index: HashMap<ConceptSet, u32>,
    sampled: Option<(Arc<Diagram>, Keep)>,
}

impl Space {
    pub fn new(sets: Vec<ConceptSet>, dim: usize) -> Space {
        let sets: Vec<ConceptSet> = sets.into_iter().filter(|s| !s.is_empty()).collect();
        let index = sets.iter().enumerate().map(|(i, s)| (*s, i as u32)).collect();
        Space { sets, dim, index, sampled: None }
    }

    /// The valid sets of `diagram` that `keep` accepts, never listed.
    pub fn sampled(diagram: Arc<Diagram>, keep: Keep, dim: usize) -> Space {
        Space { sets: Vec::new(), dim, index: HashMap::new(), sampled: Some((diagram, keep)) }
    }

    /// Whether the space is drawn from, not listed.
    pub fn is_sampled(&self) -> bool {
        self.sampled.is_some()
    }

    /// The number of valid sets (for a sampled space, the diagram's exact count, before the
    /// sets without a ground truth are left out).
    pub fn total(&self) -> u128 {
        match &self.sampled {
            Some((d, _)) => d.total(),
            None => self.sets.len() as u128,
        }
    }

    /// Valid sets per size (`[0] = 0`), up to the largest size.
    pub fn counts(&self) -> Vec<u128> {
        match &self.sampled {
            Some((d, _)) => d.counts(),
            None => {
                let mut c = vec![0u128; self.sets.iter().map(|s| s.len()).max().unwrap_or(0) + 1];
                self.sets.iter().for_each(|s| c[s.len()] += 1);
                c
            }
        }
    }

    /// The number of valid sets of `size` concepts holding `subset` (for a sampled space, the
    /// diagram's exact count, before the sets without a ground truth are left out).
    pub fn count_containing(&self, subset: ConceptSet, size: usize) -> u128 {
        match &self.sampled {
            Some((d, _)) => d.counts_containing(subset).get(size).copied().unwrap_or(0),
            None => self.sets.iter().filter(|s| s.len() == size && subset.is_subset_of(**s)).count() as u128,
        }
    }

    pub fn contains(&self, set: ConceptSet) -> bool {
        match &self.sampled {
            Some((d, keep)) => d.contains(set) && keep(set),
            None => self.index.contains_key(&set),
        }
    }

    /// The set's place in the listed sets (`None` for a sampled space).
    pub fn position(&self, set: ConceptSet) -> Option<usize> {
        self.index.get(&set).map(|&i| i as usize)
    }

    /// A valid set, uniformly at random over all of them (a sampled space; a listed one draws
    /// from its list).
    pub fn draw(&self, rng: &mut impl Rng) -> Option<ConceptSet> {
        match &self.sampled {
            Some((d, keep)) => (0..TRIES).filter_map(|_| d.sample_any(rng)).find(|s| keep(*s)),
            None if self.sets.is_empty() => None,
            None => Some(self.sets[rng.random_range(0..self.sets.len())]),
        }
    }

    /// A valid set of `size` concepts holding `subset`, uniformly at random among them; `None`
    /// when there is none (or a listed space).
    pub fn draw_containing(&self, subset: ConceptSet, size: usize, rng: &mut impl Rng) -> Option<ConceptSet> {
        let (d, keep) = self.sampled.as_ref()?;
        (0..TRIES).map_while(|_| d.sample_containing(subset, size, rng)).find(|s| keep(*s))
    }

    /// Valid sets made by adding one concept to `set`, in concept index order (for the empty
    /// set: the valid singletons).
    pub fn extensions(&self, set: ConceptSet) -> impl Iterator<Item = ConceptSet> + '_ {
        (0..self.dim as u32)
            .map(ConceptId)
            .filter(move |&c| !set.contains(c))
            .map(move |c| set.with(c))
            .filter(|s| self.contains(*s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extensions_respect_validity_and_order() {
        let space = Space::new(crate::ir::testkit::lattice(4, 3), 4);
        let s = |bits: u128| ConceptSet::from_bits(bits);
        assert_eq!(space.extensions(ConceptSet::EMPTY).collect::<Vec<_>>(), vec![s(1), s(2), s(4), s(8)]);
        // Concepts 0 and 1 exclude each other.
        assert_eq!(space.extensions(s(1)).collect::<Vec<_>>(), vec![s(0b101), s(0b1001)]);
        assert_eq!(space.extensions(s(0b1101)).count(), 0, "max size 3");
    }
}
