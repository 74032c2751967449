//! Distinct scenes: the images each concept set has shown in a run, so that no set is shown the
//! same image twice (one scene is one piece of evidence, however often it is drawn).
//!
//! [`Shown`] is the run's register: image hashes (scene hashes without a renderer) per set,
//! over every phase the evaluator observes in (search, shrink, validate: a validation's scenes
//! are fresh ones), filled from the journal when a run resumes and by
//! [`super::observe::Observer::distinct_stimulus`] as scenes are drawn.
//!
//! Determinism: which of two observations of a set keeps a scene they both drew, and which draws
//! again, must not depend on which finished rendering first. [`Turns`] orders them: observation
//! k of a set draws its scene only once every earlier observation of the set in the same
//! evaluation has claimed its own (model calls still overlap freely). A resumed run then draws
//! what the first one drew: a later observation avoided every image an earlier one kept, so an
//! observation done again (an `api_error`, a call killed in flight) meets none of its own scenes
//! in the register.

use std::collections::{HashMap, HashSet};
use std::sync::Mutex;

use tokio::sync::oneshot;

use crate::ir::{ConceptSet, Domain};
use crate::journal::{Phase, Record};
use crate::outcome::Outcome;

/// The images each set has shown in a run.
#[derive(Debug, Default)]
pub struct Shown {
    sets: Mutex<HashMap<ConceptSet, HashSet<String>>>,
}

impl Shown {
    /// The images the journal's lines showed to the model, in the phases the evaluator observes
    /// (probe and transfer re-show scenes to another prompt or model; a failed call is asked
    /// again on resume, with the scene it drew before). Lines of sets the domain does not know
    /// are skipped (the evaluator refuses them with their line number).
    pub fn from_journal(domain: &Domain, records: &[Record]) -> Shown {
        let shown = Shown::default();
        for r in records {
            if matches!(r.phase, Phase::Probe | Phase::Transfer)
                || !r.outcome.asked_a_model()
                || r.outcome == Outcome::ApiError
                || r.image.is_empty()
            {
                continue;
            }
            if let Ok(set) = domain.parse_set(&r.set) {
                shown.claim(set, &r.image);
            }
        }
        shown
    }

    /// Register `image` as shown for `set`: `false` when it already was.
    pub fn claim(&self, set: ConceptSet, image: &str) -> bool {
        let mut sets = self.sets.lock().unwrap_or_else(|p| p.into_inner());
        sets.entry(set).or_default().insert(image.to_string())
    }

    /// How many distinct images `set` has shown.
    pub fn count(&self, set: ConceptSet) -> usize {
        self.sets.lock().unwrap_or_else(|p| p.into_inner()).get(&set).map_or(0, HashSet::len)
    }
}

/// Per-set turns for drawing scenes within one evaluation, in the order observations are handed
/// out.
#[derive(Debug, Default)]
pub struct Turns {
    last: HashMap<ConceptSet, oneshot::Receiver<()>>,
}

/// One observation's turn: wait for the previous observation of the set, draw, then pass it on.
#[derive(Debug)]
pub struct Turn {
    wait: Option<oneshot::Receiver<()>>,
    done: oneshot::Sender<()>,
}

impl Turns {
    /// The next observation of `set`'s turn.
    pub fn next(&mut self, set: ConceptSet) -> Turn {
        let (done, rx) = oneshot::channel();
        Turn { wait: self.last.insert(set, rx), done }
    }
}

impl Turn {
    /// Wait until the previous observation of the set has claimed its scene (or given up: a
    /// dropped turn passes it on too).
    pub async fn wait(&mut self) {
        if let Some(w) = &mut self.wait {
            let _ = w.await;
            self.wait = None;
        }
    }

    /// Pass the turn on: this observation's scene is claimed.
    pub fn pass(self) {
        let _ = self.done.send(());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_set_claims_an_image_once_and_sets_are_apart() {
        let d = crate::ir::testkit::domain(&["a", "b"]);
        let (a, b) = (d.parse_set(&["a"]).unwrap(), d.parse_set(&["b"]).unwrap());
        let shown = Shown::default();
        assert!(shown.claim(a, "h1"));
        assert!(!shown.claim(a, "h1"), "the same image again for the same set");
        assert!(shown.claim(b, "h1"), "another set may show the same image");
        assert!(shown.claim(a, "h2"));
        assert_eq!((shown.count(a), shown.count(b)), (2, 1));
    }

    #[test]
    fn turns_follow_the_order_they_were_handed_out() {
        let d = crate::ir::testkit::domain(&["a"]);
        let a = d.parse_set(&["a"]).unwrap();
        let mut turns = Turns::default();
        let (first, mut second) = (turns.next(a), turns.next(a));
        let rt = tokio::runtime::Builder::new_current_thread().enable_time().build().unwrap();
        rt.block_on(async {
            let waited = tokio::time::timeout(std::time::Duration::from_millis(20), second.wait()).await;
            assert!(waited.is_err(), "the second waits for the first");
        });
        first.pass();
        rt.block_on(second.wait());
        // A turn dropped without passing (an observation that failed) lets the next one go.
        let third = turns.next(a);
        let mut fourth = turns.next(a);
        drop(third);
        rt.block_on(fourth.wait());
    }
}
