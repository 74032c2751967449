//! The valid concept lattice (being built).
pub mod lints;

use crate::ir::{ConceptSet, Domain};

/// All valid concept sets of a domain up to a maximum size.
pub struct Lattice {
    pub sets: Vec<ConceptSet>,
}

impl Lattice {
    pub fn enumerate(_domain: &Domain, _max_size: usize) -> Lattice {
        unimplemented!("lattice::Lattice::enumerate")
    }
}
