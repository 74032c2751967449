//! The run folder's lock: an exclusive OS file lock on `DIR/lock`, held for as long as the
//! journal is open. The OS releases it when the process ends, even on `kill -9`, so a stale lock
//! never needs cleaning up; the file itself stays and only says who held it last.

use std::fs::{File, TryLockError};
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

use super::JournalError;

/// The lock file's name inside a run folder.
pub const LOCK_FILE: &str = "lock";

/// A held lock; dropping it releases the folder.
#[derive(Debug)]
pub struct RunLock {
    _file: File,
}

/// Whether a process holds `dir`'s lock now (a run in progress). Read-only: the lock file is
/// not created, and a shared lock is taken and let go at once when free.
pub fn held(dir: &Path) -> bool {
    let Ok(file) = File::open(dir.join(LOCK_FILE)) else { return false };
    matches!(file.try_lock_shared(), Err(TryLockError::WouldBlock))
}

impl RunLock {
    /// Lock `dir` (which must exist) or say who holds it.
    pub fn acquire(dir: &Path) -> Result<RunLock, JournalError> {
        let path = dir.join(LOCK_FILE);
        let io = |action, source| JournalError::Io { action, path: path.clone(), source };
        // Not through a link: a planted `lock` must not make us truncate another file.
        let mut file = super::safe::open_rw(&path, false).map_err(|e| io("open", e))?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let holder = super::safe::read_open(&file, super::safe::MAX_LOCK_BYTES).unwrap_or_default();
                // Printed to a terminal: a planted note must not carry escape sequences there.
                let holder = crate::diag::terminal_safe(&String::from_utf8_lossy(&holder)).into_owned();
                let holder = holder.trim();
                let holder =
                    if holder.is_empty() { "it has not written its pid yet".to_string() } else { holder.to_string() };
                return Err(JournalError::Locked { dir: dir.to_path_buf(), holder });
            }
            Err(TryLockError::Error(e)) => return Err(io("lock", e)),
        }
        let who = format!("pid {}{}", std::process::id(), command_line());
        file.set_len(0)
            .and_then(|()| file.seek(SeekFrom::Start(0)))
            .and_then(|_| file.write_all(who.as_bytes()))
            .map_err(|e| io("write", e))?;
        Ok(RunLock { _file: file })
    }
}

/// `, revelio search …` (the subcommand and its first argument), to recognise the holder.
fn command_line() -> String {
    let args: Vec<String> = std::env::args().skip(1).take(2).collect();
    if args.is_empty() { String::new() } else { format!(", `revelio {}`", args.join(" ")) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn held_sees_a_lock_without_taking_it() {
        let dir = tempfile::tempdir().unwrap();
        assert!(!held(dir.path()), "no lock file");
        let lock = RunLock::acquire(dir.path()).unwrap();
        assert!(held(dir.path()));
        drop(lock);
        assert!(!held(dir.path()));
        let again = RunLock::acquire(dir.path());
        assert!(again.is_ok(), "looking did not keep it");
    }
}
