//! The visibility lint of `revelio check --render N` (R0107): sample N scenes of every valid
//! singleton and pair (or a seeded sample of them), draw each with the builtin renderer and
//! count the scenes in which an entity a concept placed is not visible by the domain's
//! thresholds — the scenes the observe pipeline would resample or record as `invisible`.

use std::collections::BTreeSet;

use crate::diag::{Diagnostic, Severity};
use crate::ir::{ConceptSet, Domain};
use crate::lattice::Lattice;
use crate::render::BuiltinRenderer;

use super::observe::unseen;

/// The lint code.
pub const CODE: &str = "R0107";

/// A set is reported when at least this share of its scenes hides an entity.
pub const MAX_SHARE: f64 = 0.1;

/// What to render.
#[derive(Debug, Clone, Copy)]
pub struct Plan {
    /// Scenes per set (seeds `0..scenes`).
    pub scenes: u32,
    /// Render only this many of the singletons and pairs, chosen with `seed` (every singleton
    /// is kept; pairs are sampled).
    pub sample: Option<(usize, u64)>,
}

/// One set's count.
#[derive(Debug, Clone, PartialEq)]
pub struct Tally {
    pub set: ConceptSet,
    pub scenes: u32,
    pub invisible: u32,
    /// The first reason seen (which entity, how many pixels, which contrast).
    pub example: String,
    pub example_seed: u64,
}

/// Count invisible scenes per set; returns every set rendered.
pub fn survey(domain: &Domain, renderer: &BuiltinRenderer, plan: Plan) -> Result<Vec<Tally>, String> {
    let lattice = Lattice::enumerate(domain, 2);
    let (singles, mut pairs): (Vec<ConceptSet>, Vec<ConceptSet>) = lattice.sets.iter().partition(|s| s.len() == 1);
    if let Some((n, seed)) = plan.sample {
        use rand::SeedableRng;
        use rand::seq::SliceRandom;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        pairs.shuffle(&mut rng);
        pairs.truncate(n.saturating_sub(singles.len()));
        pairs.sort();
    }
    let sampler = crate::sample::Sampler::new(domain);
    let mut out = Vec::new();
    for set in singles.into_iter().chain(pairs) {
        // A set without entities (weather, town) cannot hide one.
        let mut t = Tally { set, scenes: 0, invisible: 0, example: String::new(), example_seed: 0 };
        for seed in 0..u64::from(plan.scenes) {
            let scene = sampler.sample(set, seed).map_err(|e| e.0)?;
            if scene.entities.iter().all(|e| e.concept.is_none()) {
                break;
            }
            let (_, seen) = renderer.render_seen(&scene).map_err(|e| e.message)?;
            t.scenes += 1;
            if let Some(why) = unseen(domain, &scene, &seen) {
                if t.invisible == 0 {
                    t.example = why;
                    t.example_seed = seed;
                }
                t.invisible += 1;
            }
        }
        if t.scenes > 0 {
            out.push(t);
        }
    }
    Ok(out)
}

/// R0107 warnings from a survey: each singleton invisible in at least [`MAX_SHARE`] of its
/// scenes, and each pair that is although neither of its concepts is alone (a combination
/// such as stairs at night). Pointed at the concept (the first of a pair).
pub fn lint(domain: &Domain, tallies: &[Tally]) -> Vec<Diagnostic> {
    let too_often = |t: &Tally| f64::from(t.invisible) >= MAX_SHARE * f64::from(t.scenes) && t.invisible > 0;
    let bad_single: BTreeSet<usize> = tallies
        .iter()
        .filter(|t| t.set.len() == 1 && too_often(t))
        .flat_map(|t| t.set.iter().map(|c| c.index()))
        .collect();
    tallies
        .iter()
        .filter(|t| too_often(t) && (t.set.len() == 1 || t.set.iter().all(|c| !bad_single.contains(&c.index()))))
        .map(|t| {
            let first = t.set.iter().next().expect("a set rendered has a concept");
            let what = if t.set.len() == 1 { "concept" } else { "combination" };
            Diagnostic::new(
                CODE,
                Severity::Warning,
                Some(domain.concepts[first.index()].span),
                format!(
                    "{what} {} is not visible in {} of {} rendered scenes (seed {}: {})",
                    crate::oracle::set_text(domain, t.set),
                    t.invisible,
                    t.scenes,
                    t.example_seed,
                    t.example
                ),
            )
            .with_help(
                "move its entity where the camera sees it (region, distance, scenery in front of it); `revelio render FILE CONCEPT… --seed N` shows the scene",
            )
        })
        .collect()
}
