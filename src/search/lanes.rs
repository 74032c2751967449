//! Steps side by side: several failing sets explained at once, each in a [`Lane`] of the one
//! [`Driver`].
//!
//! A step of explaining (a shrink's next subset, a confirmation's top-up) asks about a few sets;
//! one at a time, a call filled to the width around it screens new sets with the rest
//! ([`Driver::fill_to`]), and the search's budget goes to screening before the explaining is
//! done. Side by side, a lane is a [`Drive`] that *submits* its asks instead of calling: [`Hub::run`]
//! polls every lane in a fixed order until each has submitted or finished, then makes one call
//! with every lane's asks (filled towards the width only with what is left), records it, and polls
//! again. No lane waits on anything but that call, so the decisions stay a pure function of the
//! seed and the answers: a resumed run replays them, whatever the concurrency.
//!
//! Lanes share the history (a set one lane tested is settled for the others) and the budget (a
//! lane sees what is left after the asks submitted before it in the same round).

use std::cell::{Cell, RefCell};
use std::pin::Pin;
use std::task::{Context, Poll, Waker};

use crate::ir::ConceptSet;

use super::{Ask, Drive, Driver, Evaluate, Purpose, Rule, SearchError, Searched, SetStats};

/// A lane's work: a future over the hub's lanes, with the lane's result.
pub type LaneWork<'h, T, E> = Pin<Box<dyn Future<Output = Searched<T, E>> + 'h>>;

/// The driver the lanes share, and the asks submitted in the current round.
pub struct Hub<'a, 'e, E> {
    driver: RefCell<&'a mut Driver<'e, E>>,
    /// Asks submitted this round, with their purposes, in the order the lanes submitted them.
    pending: RefCell<Vec<(Option<Purpose>, Vec<Ask>)>>,
    /// Observations those asks hold.
    pending_obs: Cell<u64>,
    /// Calls made so far; a lane's asks are answered once this passes its round.
    round: Cell<u64>,
    /// Lanes waiting this round for work that other lanes' calls may bring ([`Lane::idle`]).
    idle: Cell<usize>,
    /// Every lane left was idle: no call will bring work any more.
    drained: Cell<bool>,
    /// Lanes that asked in the last call, at first every lane (a lane's lookahead is its share
    /// of the width).
    asking: Cell<usize>,
}

impl<'a, 'e, E: Evaluate> Hub<'a, 'e, E> {
    /// A hub over `driver` for `lanes` lanes.
    pub fn new(driver: &'a mut Driver<'e, E>, lanes: usize) -> Self {
        Hub {
            driver: RefCell::new(driver),
            pending: RefCell::new(Vec::new()),
            pending_obs: Cell::new(0),
            round: Cell::new(0),
            idle: Cell::new(0),
            drained: Cell::new(false),
            asking: Cell::new(lanes.max(1)),
        }
    }

    /// A lane asking under `rule` (and the driver's purpose until it sets its own).
    pub fn lane(&self, rule: Rule) -> Lane<'_, 'a, 'e, E> {
        let purpose = self.driver.borrow().purpose;
        Lane { hub: self, rule, purpose }
    }

    /// Run `lanes` to the end side by side; their results, in lane order. An evaluator's error
    /// ends every lane (what was answered before it is recorded).
    #[allow(clippy::await_holding_refcell_ref, reason = "no lane is polled while the call is made")]
    pub async fn run<T>(&self, mut lanes: Vec<LaneWork<'_, T, E>>) -> Searched<Vec<T>, E> {
        let mut out: Vec<Option<T>> = lanes.iter().map(|_| None).collect();
        let mut cx = Context::from_waker(Waker::noop());
        loop {
            for (lane, done) in lanes.iter_mut().zip(out.iter_mut()) {
                if done.is_none()
                    && let Poll::Ready(result) = lane.as_mut().poll(&mut cx)
                {
                    *done = Some(result?);
                }
            }
            let parts = self.pending.take();
            if parts.is_empty() {
                let live = out.iter().filter(|o| o.is_none()).count();
                if live == 0 {
                    return Ok(out.into_iter().flatten().collect());
                }
                if self.idle.get() == live && !self.drained.get() {
                    // Every lane left waits for work: none will come.
                    self.drained.set(true);
                    continue;
                }
                return Err(SearchError::Search("a lane waited without asking anything (a bug)".into()));
            }
            self.asking.set(parts.len());
            self.idle.set(0);
            self.pending_obs.set(0);
            self.driver.borrow_mut().call_parts(parts).await?;
            self.round.set(self.round.get() + 1);
        }
    }
}

/// One lane of a [`Hub`]: its own rule and purpose over the shared driver.
pub struct Lane<'h, 'a, 'e, E> {
    hub: &'h Hub<'a, 'e, E>,
    rule: Rule,
    purpose: Option<Purpose>,
}

impl<E: Evaluate> Lane<'_, '_, '_, E> {
    /// The sets the driver's filler added to the calls since they were last taken
    /// ([`Driver::take_filled`]).
    pub fn take_filled(&self) -> Vec<ConceptSet> {
        self.hub.driver.borrow_mut().take_filled()
    }

    /// Wait for the next call, asking nothing: true once it is made (it may have brought work,
    /// e.g. sets the filler added), false when every lane left was waiting too (none will).
    pub async fn idle(&self) -> bool {
        let hub = self.hub;
        hub.idle.set(hub.idle.get() + 1);
        Woken { calls: &hub.round, drained: &hub.drained, round: hub.round.get() }.await
    }
}

/// Ready once the hub has made the call of round `round` (true), or found every lane idle
/// (false).
struct Woken<'h> {
    calls: &'h Cell<u64>,
    drained: &'h Cell<bool>,
    round: u64,
}

impl Future for Woken<'_> {
    type Output = bool;

    fn poll(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<bool> {
        if self.calls.get() > self.round {
            Poll::Ready(true)
        } else if self.drained.get() {
            Poll::Ready(false)
        } else {
            Poll::Pending
        }
    }
}

impl<E: Evaluate> Drive for Lane<'_, '_, '_, E> {
    type Eval = E;

    fn rule(&self) -> Rule {
        self.rule
    }

    fn set_rule(&mut self, rule: Rule) {
        self.rule = rule;
    }

    fn set_purpose(&mut self, purpose: Option<Purpose>) {
        self.purpose = purpose;
    }

    /// What the driver has left after the asks submitted earlier this round.
    fn remaining(&self) -> u64 {
        self.hub.driver.borrow().remaining().saturating_sub(self.hub.pending_obs.get())
    }

    fn set_budget(&mut self, budget: u64) {
        self.hub.driver.borrow_mut().set_budget(budget);
    }

    fn get(&self, set: ConceptSet) -> Option<SetStats> {
        self.hub.driver.borrow().stats(set).cloned()
    }

    fn with_history<R>(&self, f: impl FnOnce(&[SetStats]) -> R) -> R {
        f(&self.hub.driver.borrow().history)
    }

    /// The lane's share of the width, over m.
    fn lookahead(&self) -> usize {
        match self.hub.driver.borrow().width() {
            Some(width) => (width / (self.rule.samples.max(1) as usize * self.hub.asking.get())).max(1),
            None => 1,
        }
    }

    async fn call(&mut self, asks: Vec<Ask>) -> Searched<(), E> {
        let obs: u64 = asks.iter().map(|a| u64::from(a.len())).sum();
        self.hub.pending_obs.set(self.hub.pending_obs.get() + obs);
        self.hub.pending.borrow_mut().push((self.purpose, asks));
        // Never drained while this lane's asks wait: the hub calls whenever any lane asked.
        Woken { calls: &self.hub.round, drained: &self.hub.drained, round: self.hub.round.get() }.await;
        Ok(())
    }
}
