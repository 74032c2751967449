//! The visibility lint of `revelio check --render N` (R0107): sample N scenes of every valid
//! singleton and pair (or a seeded sample of them), and of a seeded sample of larger sets if
//! asked, draw each with the builtin renderer and count the scenes in which an entity a concept
//! placed is not visible by the domain's thresholds — the scenes the observe pipeline would
//! resample or record as `invisible`. An entity that draws nothing cannot be measured: it is
//! named (R0108), not counted hidden; one whose concept says `drawn_by STAGE` is measured by
//! that stage's parts. Each set's figures are kept for `--figures`.

use std::collections::BTreeSet;

use crate::diag::{Diagnostic, Severity};
use crate::ir::{ConceptSet, Domain};
use crate::lattice::Lattice;
use crate::render::BuiltinRenderer;

use super::observe::unseen;

/// The lint code.
pub const CODE: &str = "R0107";
pub use super::observe::UNDRAWN;

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
    /// Also render this many larger valid sets (3 concepts up to `max_size`), a sample chosen
    /// with the seed: occlusion among three or more entities that no pair shows.
    pub larger: Option<Larger>,
}

/// The larger sets of a [`Plan`].
#[derive(Debug, Clone, Copy)]
pub struct Larger {
    pub count: usize,
    pub max_size: usize,
    pub seed: u64,
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
    /// Entities of the set drawn with no part at all: (entity, kind, concept).
    pub undrawn: Vec<(String, String, String)>,
    /// The figures of every placed entity in every scene: (pixels, contrast).
    pub figures: Vec<(u32, f64)>,
}

impl Tally {
    /// `min / median` pixels and contrast over every placed entity of every scene, as one line.
    pub fn figures_text(&self) -> String {
        let mut px: Vec<u32> = self.figures.iter().map(|f| f.0).collect();
        let mut co: Vec<f64> = self.figures.iter().map(|f| f.1).collect();
        if px.is_empty() {
            return "nothing measured".into();
        }
        px.sort_unstable();
        co.sort_by(f64::total_cmp);
        let (n, mid) = (px.len(), px.len() / 2);
        let median_px =
            if n % 2 == 1 { f64::from(px[mid]) } else { (f64::from(px[mid - 1]) + f64::from(px[mid])) / 2.0 };
        let median_co = if n % 2 == 1 { co[mid] } else { (co[mid - 1] + co[mid]) / 2.0 };
        format!(
            "pixels min {} median {median_px}, contrast min {:.3} median {median_co:.3} ({} figures, {} scenes, {} not visible)",
            px[0], co[0], n, self.scenes, self.invisible
        )
    }
}

/// Count invisible scenes per set; returns every set rendered.
pub fn survey(domain: &Domain, renderer: &BuiltinRenderer, plan: Plan) -> Result<Vec<Tally>, String> {
    use rand::SeedableRng;
    use rand::seq::SliceRandom;
    let lattice = Lattice::enumerate(domain, 2);
    let (singles, mut pairs): (Vec<ConceptSet>, Vec<ConceptSet>) = lattice.sets.iter().partition(|s| s.len() == 1);
    if let Some((n, seed)) = plan.sample {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        pairs.shuffle(&mut rng);
        pairs.truncate(n.saturating_sub(singles.len()));
        pairs.sort();
    }
    let mut larger: Vec<ConceptSet> = Vec::new();
    if let Some(l) = plan.larger.filter(|l| l.count > 0 && l.max_size >= 3) {
        let all = Lattice::enumerate(domain, l.max_size);
        larger = all.sets.iter().copied().filter(|s| s.len() >= 3).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(l.seed);
        larger.shuffle(&mut rng);
        larger.truncate(l.count);
        larger.sort_by_key(|s| (s.len(), *s));
    }
    let sampler = crate::sample::Sampler::new(domain);
    let mut out = Vec::new();
    for set in singles.into_iter().chain(pairs).chain(larger) {
        // A set without entities (weather, town) cannot hide one.
        let mut t = Tally {
            set,
            scenes: 0,
            invisible: 0,
            example: String::new(),
            example_seed: 0,
            undrawn: Vec::new(),
            figures: Vec::new(),
        };
        for seed in 0..u64::from(plan.scenes) {
            let scene = sampler.sample(set, seed).map_err(|e| e.0)?;
            if scene.entities.iter().all(|e| e.concept.is_none()) {
                break;
            }
            let seen = renderer.render_visibility(&scene).map_err(|e| e.message)?;
            t.scenes += 1;
            for e in scene.entities.iter().filter(|e| e.draws_nothing()) {
                let Some(concept) = &e.concept else { continue };
                let key = (e.name.clone(), e.kind.clone(), concept.clone());
                if !t.undrawn.contains(&key) {
                    t.undrawn.push(key);
                }
            }
            t.figures.extend(
                scene
                    .entities
                    .iter()
                    .zip(&seen)
                    .filter(|(e, _)| e.concept.is_some() && !e.draws_nothing())
                    .map(|(_, v)| (v.pixels, v.contrast)),
            );
            // Judged on what can be measured: an undrawn entity is R0108's, not R0107's.
            let why = if t.undrawn.is_empty() {
                unseen(domain, &scene, &seen)
            } else {
                let (drawn, seen): (Vec<_>, Vec<_>) =
                    scene.entities.iter().cloned().zip(seen).filter(|(e, _)| !e.draws_nothing()).unzip();
                unseen(domain, &crate::scene::Scene { entities: drawn, ..scene.clone() }, &seen)
            };
            if let Some(why) = why {
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
///
/// Then R0108 for each entity a concept places that draws nothing (once per concept and
/// entity), unless the domain has `allow R0108`.
pub fn lint(domain: &Domain, tallies: &[Tally]) -> Vec<Diagnostic> {
    let mut out = hidden(domain, tallies);
    if domain.allow.iter().any(|a| a.code == UNDRAWN) {
        return out;
    }
    let mut named: Vec<&(String, String, String)> = Vec::new();
    for u in tallies.iter().flat_map(|t| &t.undrawn) {
        if named.contains(&u) {
            continue;
        }
        named.push(u);
        let (entity, kind, concept) = u;
        let span = domain.concepts.iter().find(|c| &c.name == concept).map(|c| c.span);
        out.push(
            Diagnostic::new(
                UNDRAWN,
                Severity::Warning,
                span,
                format!("`{entity}` ({kind}) of concept `{concept}` draws nothing, so its visibility cannot be measured"),
            )
            .with_help(format!(
                "give `{kind}` a look with at least one part; if a `stage` draws it, name that stage with `drawn_by STAGE` in concept `{concept}` so that it is measured; or accept it unmeasured with `allow R0108` and a `///` reason"
            )),
        );
    }
    out
}

/// The R0107 warnings of [`lint`].
fn hidden(domain: &Domain, tallies: &[Tally]) -> Vec<Diagnostic> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_min_and_median_over_every_entity_and_scene() {
        let mut t = Tally {
            set: ConceptSet::EMPTY,
            scenes: 2,
            invisible: 1,
            example: String::new(),
            example_seed: 0,
            undrawn: Vec::new(),
            figures: vec![(30, 0.5), (10, 0.1), (20, 0.3), (40, 0.2)],
        };
        assert_eq!(
            t.figures_text(),
            "pixels min 10 median 25, contrast min 0.100 median 0.250 (4 figures, 2 scenes, 1 not visible)"
        );
        t.figures.pop();
        assert!(t.figures_text().starts_with("pixels min 10 median 20, contrast min 0.100 median 0.300"));
        t.figures.clear();
        assert_eq!(t.figures_text(), "nothing measured");
    }
}
