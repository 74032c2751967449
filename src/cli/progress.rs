//! The progress bar of the core's long work — counting and enumerating a lattice, judging it
//! for the lattice lints — which the core reports through a callback
//! ([`crate::lattice::Progress`]) because it cannot print. Drawn on stderr only when it is a
//! terminal, and cleared when the work ends.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

pub struct Work {
    bar: ProgressBar,
    what: &'static str,
}

impl Work {
    pub fn new() -> Work {
        let bar = if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr())
        } else {
            ProgressBar::hidden()
        };
        Work { bar, what: "" }
    }

    /// The callback to hand to the core.
    pub fn report(&mut self, what: &'static str, done: u64, total: u64) {
        if self.what != what {
            self.what = what;
            self.bar.reset();
            let style = if total == u64::MAX {
                ProgressStyle::with_template("{msg}: {pos}").ok()
            } else {
                ProgressStyle::with_template("{msg}: {bar:30} {pos}/{len} · ETA {eta}").ok()
            };
            if let Some(s) = style {
                self.bar.set_style(s);
            }
            self.bar.set_message(what);
        }
        if total != u64::MAX {
            self.bar.set_length(total);
        }
        self.bar.set_position(done);
    }
}

impl Default for Work {
    fn default() -> Work {
        Work::new()
    }
}

impl Drop for Work {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}
