//! A synthetic world (no oracle, no sampler) for testing the runtime.
use crate::ir::{Camera, ConceptSet, Domain};

/// A world without oracle or sampler: three options, the expected one fixed per set, and a
/// scene that only records the set and seed (in `environment.variant` too, so every seed is a
/// distinct scene).
pub struct FakeWorld(pub Domain);

impl crate::run::observe::World for FakeWorld {
    fn task(&self, set: ConceptSet) -> Result<crate::run::observe::Task, String> {
        Ok(crate::run::observe::Task {
            question: "What should the car do?".into(),
            options: vec!["stop".into(), "slow down".into(), "continue".into()],
            option_names: vec!["stop".into(), "slow".into(), "go".into()],
            expected: (set.low_bits() % 3) as u32,
        })
    }

    fn scene(&self, set: ConceptSet, seed: u64) -> Result<crate::scene::Scene, String> {
        Ok(crate::scene::Scene {
            domain: self.0.name.clone(),
            domain_hash: String::new(),
            concepts: self.0.set_names(set).into_iter().map(String::from).collect(),
            seed,
            world: Default::default(),
            environment: [("variant".to_string(), seed as f64)].into(),
            entities: vec![],
            extras: vec![],
            stage: vec![],
            camera: Camera::default(),
        })
    }
}
