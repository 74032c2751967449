//! Seeded scene sampler (being built).
use crate::ir::{ConceptSet, Domain};
use crate::scene::Scene;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SampleError(pub String);

pub fn sample(_domain: &Domain, _set: ConceptSet, _seed: u64) -> Result<Scene, SampleError> {
    unimplemented!("sample::sample")
}
