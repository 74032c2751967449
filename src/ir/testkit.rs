//! Test fixtures: tiny domains and lattices built in Rust, so later stages (search, runtime, models)
//! are tested without the front end.
use crate::ir::{Camera, Concept, ConceptId, ConceptKind, ConceptSet, Domain, Probe, RenderBindings, Selection, Span};

/// A domain whose concepts are `names` (in index order) with no constraints.
pub fn domain(names: &[&str]) -> Domain {
    Domain {
        name: "test".into(),
        files: vec![crate::ir::SourceFile { name: "test.rev".into(), text: names.join(",") }],
        units: vec![],
        relations: vec![],
        enums: vec![],
        tags: vec![],
        kinds: vec![],
        world: vec![],
        regions: vec![],
        presets: vec![],
        stage: vec![],
        concepts: names
            .iter()
            .enumerate()
            .map(|(i, n)| Concept {
                name: (*n).into(),
                id: ConceptId(i as u32),
                kind: ConceptKind::Concept,
                description: String::new(),
                category: String::new(),
                probe: Probe::default(),
                effects: vec![],
                target: None,
                render: RenderBindings::default(),
                span: Span::default(),
            })
            .collect(),
        constraints: vec![],
        questions: vec![],
        selection: Selection::Priority,
        rules: vec![],
        camera: Camera::default(),
        allow: vec![],
        visibility: Default::default(),
    }
}

/// A domain of `n` concepts `c0 … c{n-1}`.
pub fn numbered(n: usize) -> Domain {
    let names: Vec<String> = (0..n).map(|i| format!("c{i}")).collect();
    domain(&names.iter().map(String::as_str).collect::<Vec<_>>())
}

/// All sets of `1..=max_size` concepts out of `n`, except those holding both concept 0 and
/// concept 1 (an exclusive pair, so that validity matters).
pub fn lattice(n: usize, max_size: usize) -> Vec<ConceptSet> {
    let excl = ConceptSet::from_bits(0b11);
    (1u128..1 << n).map(ConceptSet::from_bits).filter(|s| s.len() <= max_size && s.intersection(excl) != excl).collect()
}
