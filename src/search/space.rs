//! The search space: the valid concept sets of a domain (from the lattice), indexed so that
//! beam search can ask for a set's valid one-concept extensions and GPTS can score every
//! unexplored set.
use std::collections::HashMap;

use crate::ir::{ConceptId, ConceptSet};

pub struct Space {
    /// Valid non-empty sets in the lattice's canonical order (ties in GPTS go to the earliest).
    pub sets: Vec<ConceptSet>,
    /// Number of concepts in the domain (the width of the multi-hot vectors).
    pub dim: usize,
    index: HashMap<ConceptSet, u32>,
}

impl Space {
    pub fn new(sets: Vec<ConceptSet>, dim: usize) -> Space {
        let sets: Vec<ConceptSet> = sets.into_iter().filter(|s| !s.is_empty()).collect();
        let index = sets.iter().enumerate().map(|(i, s)| (*s, i as u32)).collect();
        Space { sets, dim, index }
    }

    pub fn contains(&self, set: ConceptSet) -> bool {
        self.index.contains_key(&set)
    }

    pub fn position(&self, set: ConceptSet) -> Option<usize> {
        self.index.get(&set).map(|&i| i as usize)
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
