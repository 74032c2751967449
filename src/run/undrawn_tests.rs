//! An entity that draws nothing in the visibility guard and the figures: named as such, never
//! resampled when no seed can draw it, and accepted by `allow R0108`.
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use super::observe::{DomainWorld, Observer, RESAMPLES, figure_lines, never_drawn};
use super::tests::block_on;
use crate::ir::{ConceptSet, Domain};
use crate::render::{EntityVisibility, RenderError, Rendered, Renderer};
use crate::scene::Scene;
use crate::vlm::BoxFuture;

const UNDRAWN: &str = include_str!("../../tests/corpus/render/undrawn.rev");

fn compile(text: &str) -> Domain {
    crate::check::compile_source("undrawn.rev", text).unwrap_or_else(|d| panic!("{d:?}"))
}

/// `allow R0108` with a reason, as the corpus file's header suggests.
fn allowed() -> Domain {
    compile(&UNDRAWN.replacen("visible {", "/// The `steps` stage draws the stairs.\nallow R0108\nvisible {", 1))
}

fn set(d: &Domain, names: &[&str]) -> ConceptSet {
    d.parse_set(names).unwrap()
}

/// A renderer that counts its renders and reports every entity with `pixels` at full contrast.
struct Seen(AtomicUsize, u32);

impl Renderer for Seen {
    fn id(&self) -> String {
        "seen".into()
    }

    fn render<'a>(&'a self, scene: &'a Scene, _prompt: &'a str) -> BoxFuture<'a, Result<Rendered, RenderError>> {
        self.0.fetch_add(1, Ordering::SeqCst);
        let seen = scene
            .entities
            .iter()
            .map(|e| EntityVisibility {
                entity: e.name.clone(),
                concept: e.concept.clone(),
                pixels: self.1,
                contrast: 1.0,
            })
            .collect();
        let png = format!("{}:{}", scene.seed, scene.concepts.join(",")).into_bytes();
        Box::pin(async move { Ok(Rendered { png, cached: false, visibility: Some(seen) }) })
    }
}

fn observer(d: &Domain, renderer: Arc<Seen>) -> Observer {
    Observer::new(Arc::new(d.clone()), Arc::new(DomainWorld::new(d)), Some(renderer))
}

/// Issue 31: the guard does not resample a scene whose entity has no part to draw (no seed can
/// draw it): one render, and the same message as after resampling.
#[test]
fn the_guard_fails_at_once_for_an_entity_no_seed_can_draw() {
    let d = compile(UNDRAWN);
    let r = Arc::new(Seen(AtomicUsize::new(0), 1000));
    let s = block_on(observer(&d, r.clone()).stimulus(set(&d, &["stairs"]), 0)).unwrap();
    assert_eq!((s.resamples, r.0.load(Ordering::SeqCst)), (0, 1));
    assert_eq!(
        s.invisible.as_deref(),
        Some("not visible: `stairs` (Staircase) draws nothing, so it cannot be measured")
    );
    assert!(never_drawn(&d, &s.scene));

    // An entity that is drawn but hidden is still resampled: another seed may show it.
    let r = Arc::new(Seen(AtomicUsize::new(0), 0));
    let s = block_on(observer(&d, r.clone()).stimulus(set(&d, &["crate"]), 0)).unwrap();
    assert!(s.invisible.is_some());
    assert_eq!((s.resamples, r.0.load(Ordering::SeqCst)), (RESAMPLES, RESAMPLES as usize + 1));
    assert!(!never_drawn(&d, &s.scene));

    // Accepted with `allow R0108`: shown, nothing to fail at once about.
    let d = allowed();
    let r = Arc::new(Seen(AtomicUsize::new(0), 1000));
    let s = block_on(observer(&d, r.clone()).stimulus(set(&d, &["stairs"]), 0)).unwrap();
    assert_eq!((s.invisible, s.resamples), (None, 0));
    assert!(!never_drawn(&d, &s.scene));
}

/// Issue 31: `render --figures` and `ask` say that an entity draws nothing (and whether
/// `allow R0108` accepts it) instead of "0 px at contrast 0.000".
#[test]
fn the_figures_say_an_entity_draws_nothing() {
    let lines = |d: &Domain| {
        let scene = crate::sample::Sampler::new(d).sample(set(d, &["crate", "stairs"]), 0).unwrap();
        let seen: Vec<EntityVisibility> = scene
            .entities
            .iter()
            .map(|e| EntityVisibility { entity: e.name.clone(), concept: e.concept.clone(), pixels: 0, contrast: 0.0 })
            .collect();
        figure_lines(d, &scene, &seen)
    };
    assert_eq!(
        lines(&compile(UNDRAWN)),
        [
            "`crate` (Crate, concept `crate`): 0 px at contrast 0.000, needs 25 px at 0.030: NOT visible",
            "`stairs` (Staircase, concept `stairs`): draws nothing, so it cannot be measured: NOT visible (R0108)",
        ]
    );
    assert_eq!(
        lines(&allowed())[1],
        "`stairs` (Staircase, concept `stairs`): draws nothing, so it cannot be measured: accepted by `allow R0108`"
    );
}
