//! `revelio lsp`: a language server on standard input/output.
//!
//! Built on `lsp-server` (the synchronous transport rust-analyzer uses) and `lsp-types`: the
//! server is one loop over incoming messages, finished lint jobs and a timer, with no async
//! runtime — requests are answered in order from state that is always up to date, because the
//! front end runs on every change (a domain compiles in milliseconds). Lattice lints enumerate
//! the lattice (a tenth of a second or more), so they run on a worker thread, debounced after
//! the last change ([`Options::lint_delay`]) and at once on save; a result for an older text is
//! dropped. Editing a module rechecks every open document that loads it.
//!
//! Features: diagnostics (with codes, related spans, `allow`ed lints hidden), hover, go to
//! definition and find references (into `use`d files and the stdlib), completion, quick fixes,
//! document symbols, formatting and semantic tokens. Positions are UTF-16 unless the client
//! offers UTF-8 or UTF-32 (`positionEncoding`).

mod actions;
mod analysis;
pub mod bench;
mod complete;
mod diagnostics;
mod hover;
mod index;
mod server;
mod symbols;
#[cfg(test)]
mod tests;
mod text;
mod tokens;

use std::path::PathBuf;
use std::time::Duration;

use lsp_server::Connection;

pub use analysis::default_cache;

/// How the server behaves.
#[derive(Debug, Clone)]
pub struct Options {
    /// Where the embedded stdlib is written for go-to-definition (`None`: nowhere).
    pub cache: Option<PathBuf>,
    /// Quiet time after the last edit before lattice lints run (a client may override it with
    /// the initialization option `lintDelayMs`).
    pub lint_delay: Duration,
}

impl Default for Options {
    fn default() -> Self {
        Options { cache: Some(default_cache()), lint_delay: Duration::from_millis(DEFAULT_LINT_DELAY_MS) }
    }
}

/// The default debounce of lattice lints.
pub const DEFAULT_LINT_DELAY_MS: u64 = 300;

/// Serve on standard input/output until the client says `exit`.
pub fn run_stdio(options: Options) -> Result<(), String> {
    let (conn, io) = Connection::stdio();
    server::serve(&conn, options)?;
    drop(conn);
    io.join().map_err(|e| format!("the connection failed: {}", e.to_string().to_lowercase()))
}

/// Serve on an existing connection (an in-memory one for benchmarks and tests).
pub fn serve(conn: &Connection, options: Options) -> Result<(), String> {
    server::serve(conn, options)
}
