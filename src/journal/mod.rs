//! The run folder: `config.json` (the resolved configuration), the append-only `journal.jsonl`
//! (one line per observation), content-addressed `images/<sha256>.png`, `summary.json`, and the
//! `lock` file that keeps a second process out.
//!
//! Resuming: opening an existing folder loads every finished observation; the runner compares
//! the folder's configuration with its own (see `run::runner`) and the search replays its
//! decisions against the journal, asking the model only for the rest.
//!
//! One process at a time: [`Journal::open`] takes an exclusive lock on `lock` (an OS file lock,
//! released when the process ends, however it ends) and writes its pid there, so a second
//! process on the same folder is refused with an error that names the holder instead of paying
//! for the same observations twice.
//!
//! Durability: each line is written with one `write` call on an append-mode file, so a killed
//! process (even `kill -9`) leaves every finished line in the kernel's page cache and at most one
//! torn last line (one without its newline), which [`Journal::open`] drops (and truncates away)
//! on resume. A complete line that does not parse is not a torn write but damage: opening stops
//! with `corrupt journal line N` and leaves the file as it is, unless asked
//! ([`OnCorrupt::SetAside`], the commands' `--set-aside-corrupt`) to move such lines into
//! `journal.corrupt` beside it and go on. The file is
//! fsynced every [`SYNC_EVERY`] lines and at the end of each search step, so a power loss costs at
//! most that many observations (paid again on resume). `config.json`, images and `summary.json`
//! are written to a temporary file and renamed, so they are either absent or complete.
//!
//! A run folder is untrusted input (it may have been downloaded): every file in it is read and
//! written through [`safe`], which follows no link, reads only regular files and reads no
//! further than a bound.

pub mod lock;
pub mod safe;

use std::fs::File;
use std::io::{Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::outcome::{Answer, Outcome, Usage};
use crate::render::EntityVisibility;

pub use lock::RunLock;

/// Lines between fsyncs of the journal.
pub const SYNC_EVERY: usize = 64;

/// Which part of a run an observation belongs to. Observations are addressed by (phase, set,
/// observation index): each phase has its own scene stream, and a set's indices `0..n` in a phase
/// can be extended to `n..m` later (sequential sampling) without touching the first `n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    Search,
    Validate,
    /// Shrinking failure modes to cores after the search (more observations of search sets
    /// continue their indices; subsets start at 0).
    Shrink,
    /// `revelio probe`: the safety question with the recognition statements (paper appendix G).
    Probe,
    /// `revelio transfer`: a run's top sets and random sets asked of other models.
    Transfer,
    /// Fresh confirmation of a search's candidate cores: new scenes (a seed stream of its own,
    /// indices past the search's), asked after the candidates were selected.
    Confirm,
}

/// One observation, as one journal line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    pub phase: Phase,
    /// Concept names of the set, in index order.
    pub set: Vec<String>,
    /// Observation index within the set (and phase).
    pub obs: u32,
    /// The scene sampler's seed for this observation (`revelio ask FILE SET --seed SEED` shows
    /// the same scene and sends the same prompt).
    pub seed: u64,
    /// SHA-256 of the image (or of the scene JSON, seed left out, with `--renderer none`); empty when the image
    /// generator blocked the scene.
    pub image: String,
    /// SHA-256 of the prompt text.
    pub prompt: String,
    /// The model's reply, the call's error message, or the image generator's block message.
    pub raw: String,
    /// The parsed option, when the reply named exactly one.
    pub parsed: Option<u32>,
    /// How the model's reply ended; `None` when no model was asked (`image_blocked`,
    /// `invisible`).
    pub answer: Option<Answer>,
    pub expected: u32,
    pub outcome: Outcome,
    pub usage: Usage,
    pub latency_ms: u64,
    pub cached: bool,
    /// The model that answered, when it is not the run's own (phase `transfer`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// How visible each entity the concepts placed was in the image shown (builtin renderer;
    /// empty for renderers that cannot tell and in journals written before it was measured).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub visibility: Vec<EntityVisibility>,
    /// Scenes drawn again with the next seed because an entity was not visible; `seed` is the
    /// scene finally used.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub resamples: u32,
    /// Scenes drawn again with the next seed because the set had already shown their image in
    /// the run (outcome `repeated` when every one tried had); counted apart from `resamples`.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub repeats: u32,
    /// Attempts the model call took (1: no retry; 0: no call was made, a cached reply, or a
    /// journal written before it was recorded).
    #[serde(default)]
    pub attempts: u32,
    /// Of the retries, those after a rate limit (HTTP 429).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rate_limited: u32,
    /// Milliseconds spent waiting between attempts.
    #[serde(default, skip_serializing_if = "is_zero_u64")]
    pub waited_ms: u64,
}

fn is_zero_u64(n: &u64) -> bool {
    *n == 0
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

#[cfg(test)]
impl Record {
    /// A test's observation of `set` (concept names): its phase, index and outcome, one attempt,
    /// and empty or zero everywhere else (set what a test needs with `..Record::test(…)`).
    pub(crate) fn test(phase: Phase, set: &[&str], obs: u32, outcome: Outcome) -> Record {
        Record {
            phase,
            set: set.iter().map(|c| c.to_string()).collect(),
            obs,
            seed: 0,
            image: String::new(),
            prompt: String::new(),
            raw: String::new(),
            parsed: None,
            answer: None,
            expected: 0,
            outcome,
            usage: Usage::default(),
            latency_ms: 0,
            cached: false,
            model: None,
            visibility: Vec::new(),
            resamples: 0,
            repeats: 0,
            attempts: 1,
            rate_limited: 0,
            waited_ms: 0,
        }
    }
}

/// What can go wrong with a run folder.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error("cannot {action} `{}`: {}", path.display(), io_message(source))]
    Io { action: &'static str, path: PathBuf, source: std::io::Error },
    #[error(
        "corrupt journal line {line} in `{}`: {message}; the file is left as it is (`--set-aside-corrupt` moves such lines into `journal.corrupt` and goes on)",
        path.display()
    )]
    Corrupt { path: PathBuf, line: usize, message: String },
    #[error(
        "corrupt journal line {line} in `{}`: {message}; a command that resumes the run with `--set-aside-corrupt` moves such lines into `journal.corrupt`",
        path.display()
    )]
    CorruptRead { path: PathBuf, line: usize, message: String },
    #[error(
        "run folder `{}` is in use by another revelio process ({holder}); wait for it to finish or choose another `--out` folder",
        dir.display()
    )]
    Locked { dir: PathBuf, holder: String },
    #[error("`{}` is not empty and holds no run (no config.json); choose another `--out` folder", .0.display())]
    NotARun(PathBuf),
    #[error("cannot resume `{}`: config.json is not valid JSON: {message}", dir.display())]
    BadConfig { dir: PathBuf, message: String },
    #[error("cannot write `{name}`: {message}")]
    Encode { name: String, message: String },
}

/// An I/O error as one lowercase clause (only its first letter lowered: it may name a FIFO).
pub fn io_message(e: &std::io::Error) -> String {
    let s = e.to_string();
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_lowercase().chain(c).collect(),
        None => s,
    }
}

fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> JournalError {
    let path = path.to_path_buf();
    move |source| JournalError::Io { action, path, source }
}

/// A run folder's journal, open for appending, with the folder locked to this process.
pub struct Journal {
    dir: PathBuf,
    file: Mutex<Writer>,
    /// `config.json` as found on opening (`None`: a new run folder).
    config: Option<serde_json::Value>,
    /// Observations finished before this process started; record `i` is on line `i + 1`.
    pub records: Vec<Record>,
    /// Whether `open` dropped a torn last line.
    pub dropped_torn_line: bool,
    /// How many corrupt lines `open` moved into `journal.corrupt` ([`OnCorrupt::SetAside`]).
    pub set_aside: usize,
    _lock: RunLock,
}

/// What [`Journal::open_with`] does with a complete journal line that does not parse.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OnCorrupt {
    /// Stop with an error naming the line; the file is not touched.
    #[default]
    Refuse,
    /// Move such lines into `journal.corrupt` beside the journal and go on without them.
    SetAside,
}

/// The file corrupt journal lines are moved into.
pub const CORRUPT_FILE: &str = "journal.corrupt";

struct Writer {
    file: File,
    unsynced: usize,
}

/// Write a file atomically (temporary file, then rename), never through a link.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), JournalError> {
    safe::write_atomic(path, bytes).map_err(io("write", path))
}

impl Journal {
    /// Open (or create) the run folder `dir`: lock it, read its `config.json` if any, and load the
    /// journal. A folder that holds files but no run is refused, so a mistyped `--out` never
    /// writes into someone's documents.
    pub fn open(dir: &Path) -> Result<Journal, JournalError> {
        Journal::open_with(dir, OnCorrupt::Refuse)
    }

    /// What a user is told when opening set corrupt lines aside (`None`: none were).
    pub fn set_aside_note(&self) -> Option<String> {
        (self.set_aside > 0).then(|| {
            format!(
                "note: moved {} corrupt line(s) of `{}` into `{}`",
                self.set_aside,
                self.dir.join("journal.jsonl").display(),
                self.dir.join(CORRUPT_FILE).display()
            )
        })
    }

    /// [`Journal::open`], with `corrupt` deciding what a complete line that does not parse does.
    pub fn open_with(dir: &Path, corrupt: OnCorrupt) -> Result<Journal, JournalError> {
        let config_path = dir.join("config.json");
        if !config_path.exists() && holds_other_files(dir)? {
            return Err(JournalError::NotARun(dir.to_path_buf()));
        }
        std::fs::create_dir_all(dir).map_err(io("create", dir))?;
        let lock = RunLock::acquire(dir)?;
        // Another process may have started this run between the check above and the lock.
        let config = if config_path.exists() {
            let text = safe::read_text(&config_path, safe::MAX_JSON_BYTES).map_err(io("read", &config_path))?;
            Some(
                serde_json::from_str(&text)
                    .map_err(|e| JournalError::BadConfig { dir: dir.to_path_buf(), message: e.to_string() })?,
            )
        } else {
            None
        };
        let images = dir.join("images");
        safe::ensure_dir(&images).map_err(io("create", &images))?;
        let path = dir.join("journal.jsonl");
        let mut file = safe::open_rw(&path, true).map_err(io("open", &path))?;
        let text = safe::read_open(&file, safe::MAX_JOURNAL_BYTES).map_err(io("read", &path))?;
        let parsed = parse_journal(&text);
        let mut set_aside = 0;
        if let Some((line, message)) = parsed.corrupt {
            if corrupt == OnCorrupt::Refuse {
                return Err(JournalError::Corrupt { path, line, message });
            }
            set_aside = set_aside_corrupt(dir, &text)?;
            drop(file);
            file = safe::open_rw(&path, true).map_err(io("open", &path))?;
        } else if parsed.good_len < text.len() {
            file.set_len(parsed.good_len as u64).map_err(io("truncate", &path))?;
            file.sync_all().map_err(io("sync", &path))?;
        }
        let dropped_torn_line = parsed.good_len < text.len();
        file.seek(SeekFrom::End(0)).map_err(io("seek", &path))?;
        Ok(Journal {
            dir: dir.to_path_buf(),
            file: Mutex::new(Writer { file, unsynced: 0 }),
            config,
            records: parsed.records,
            dropped_torn_line,
            set_aside,
            _lock: lock,
        })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The folder's `config.json` as it was when opened (`None`: a new run folder).
    pub fn config(&self) -> Option<&serde_json::Value> {
        self.config.as_ref()
    }

    /// Write `config.json` (a new run, or a resumed one whose budget grew).
    pub fn write_config<C: Serialize>(&self, config: &C) -> Result<(), JournalError> {
        self.write_json("config.json", config)
    }

    /// Append one observation (one `write` call).
    pub fn append(&self, record: &Record) -> Result<(), JournalError> {
        let mut line = serde_json::to_vec(record).expect("records serialise");
        line.push(b'\n');
        let path = self.dir.join("journal.jsonl");
        let mut w = self.file.lock().unwrap_or_else(|e| e.into_inner());
        w.file.write_all(&line).map_err(io("append to", &path))?;
        w.unsynced += 1;
        if w.unsynced >= SYNC_EVERY {
            w.file.sync_data().map_err(io("sync", &path))?;
            w.unsynced = 0;
        }
        Ok(())
    }

    /// Flush the journal to disk (end of a search step, and before a stopped run exits).
    pub fn sync(&self) -> Result<(), JournalError> {
        let mut w = self.file.lock().unwrap_or_else(|e| e.into_inner());
        if w.unsynced > 0 {
            w.file.sync_data().map_err(io("sync", &self.dir.join("journal.jsonl")))?;
            w.unsynced = 0;
        }
        Ok(())
    }

    /// Store an image under its content hash (no-op when present); returns the hash.
    pub fn store_image(&self, png: &[u8]) -> Result<String, JournalError> {
        let hash = crate::hash::sha256_hex(png);
        let path = self.dir.join("images").join(format!("{hash}.png"));
        if !path.exists() {
            write_atomic(&path, png)?;
        }
        Ok(hash)
    }

    /// Write a JSON file into the run folder atomically.
    pub fn write_json<T: Serialize>(&self, name: &str, value: &T) -> Result<(), JournalError> {
        let mut text = serde_json::to_string_pretty(value)
            .map_err(|e| JournalError::Encode { name: name.to_string(), message: e.to_string() })?;
        text.push('\n');
        write_atomic(&self.dir.join(name), text.as_bytes())
    }
}

/// Whether `dir` exists and holds anything besides a lock file left by an earlier attempt.
fn holds_other_files(dir: &Path) -> Result<bool, JournalError> {
    if !dir.exists() {
        return Ok(false);
    }
    let mut entries = std::fs::read_dir(dir).map_err(io("read", dir))?;
    Ok(entries.any(|e| e.map_or(true, |e| e.file_name() != lock::LOCK_FILE)))
}

/// Read a run folder's journal without opening it for appending or locking the folder (reports
/// read finished runs). A torn last line is skipped, as [`Journal::open`] would drop it; a
/// corrupt line is an error.
pub fn read(dir: &Path) -> Result<Vec<Record>, JournalError> {
    let path = dir.join("journal.jsonl");
    let text = safe::read(&path, safe::MAX_JOURNAL_BYTES).map_err(io("read", &path))?;
    let parsed = parse_journal(&text);
    match parsed.corrupt {
        Some((line, message)) => Err(JournalError::CorruptRead { path, line, message }),
        None => Ok(parsed.records),
    }
}

/// A journal's bytes, parsed.
struct Parsed {
    records: Vec<Record>,
    /// Where the complete lines end: anything after is a torn last line.
    good_len: usize,
    /// The first complete line that does not parse: (line number, why).
    corrupt: Option<(usize, String)>,
}

/// Each complete line of `text` (without its newline), numbered from 1.
fn lines(text: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    text.split_inclusive(|&b| b == b'\n').filter_map(|l| l.strip_suffix(b"\n")).enumerate().map(|(i, l)| (i + 1, l))
}

/// Parse journal bytes. Only a last line without its newline is torn (a write cut short);
/// a complete line that does not parse is corrupt.
fn parse_journal(text: &[u8]) -> Parsed {
    let mut parsed = Parsed { records: Vec::new(), good_len: 0, corrupt: None };
    for (n, line) in lines(text) {
        match serde_json::from_slice::<Record>(line) {
            Ok(r) => parsed.records.push(r),
            Err(e) => {
                parsed.corrupt.get_or_insert((n, e.to_string()));
            }
        }
    }
    parsed.good_len = text.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
    parsed
}

/// Append the corrupt lines of `text` to `journal.corrupt` (synced), then replace the journal
/// with its good lines; returns how many lines moved. In that order, a crash in between leaves a
/// line in both files, never in neither.
fn set_aside_corrupt(dir: &Path, text: &[u8]) -> Result<usize, JournalError> {
    let (mut good, mut bad, mut moved) = (Vec::with_capacity(text.len()), Vec::new(), 0);
    for (_, line) in lines(text) {
        let to = if serde_json::from_slice::<Record>(line).is_ok() {
            &mut good
        } else {
            moved += 1;
            &mut bad
        };
        to.extend_from_slice(line);
        to.push(b'\n');
    }
    let aside_path = dir.join(CORRUPT_FILE);
    let mut aside = safe::open_rw(&aside_path, true).map_err(io("open", &aside_path))?;
    aside.write_all(&bad).and_then(|()| aside.sync_all()).map_err(io("write", &aside_path))?;
    write_atomic(&dir.join("journal.jsonl"), &good)?;
    Ok(moved)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(obs: u32) -> Record {
        Record {
            seed: 7,
            image: "i".into(),
            prompt: "p".into(),
            raw: "Answer: A".into(),
            parsed: Some(0),
            answer: Some(Answer::Option(0)),
            expected: 1,
            latency_ms: 3,
            ..Record::test(Phase::Search, &["a", "b"], obs, Outcome::Wrong)
        }
    }

    #[test]
    fn torn_last_line_is_dropped_and_appends_continue() {
        let dir = tempfile::tempdir().unwrap();
        let run = dir.path().join("run");
        let j = Journal::open(&run).unwrap();
        assert!(j.config().is_none());
        j.write_config(&serde_json::json!({"seed": 1})).unwrap();
        for i in 0..3 {
            j.append(&record(i)).unwrap();
        }
        j.sync().unwrap();
        drop(j);
        let path = run.join("journal.jsonl");
        let full = std::fs::read(&path).unwrap();
        // Cut inside the third line.
        std::fs::write(&path, &full[..full.len() - 10]).unwrap();
        let j = Journal::open(&run).unwrap();
        assert_eq!(j.config(), Some(&serde_json::json!({"seed": 1})));
        assert!(j.dropped_torn_line);
        assert_eq!(j.records, vec![record(0), record(1)]);
        j.append(&record(2)).unwrap();
        drop(j);
        assert_eq!(std::fs::read(&path).unwrap(), full);
        let j = Journal::open(&run).unwrap();
        assert!(!j.dropped_torn_line);
        assert_eq!(j.records.len(), 3);
    }

    #[test]
    fn corrupt_middle_line_is_an_error_naming_the_line() {
        let dir = tempfile::tempdir().unwrap();
        let j = Journal::open(dir.path()).unwrap();
        j.write_config(&serde_json::json!({})).unwrap();
        drop(j);
        let line = serde_json::to_string(&record(0)).unwrap();
        std::fs::write(dir.path().join("journal.jsonl"), format!("{line}\n{line}\n{{oops\n{line}\n")).unwrap();
        let e = Journal::open(dir.path()).err().unwrap();
        assert!(matches!(e, JournalError::Corrupt { line: 3, .. }), "{e:?}");
        assert!(e.to_string().starts_with("corrupt journal line 3 in `"), "{e}");
    }

    #[test]
    fn a_complete_last_line_that_does_not_parse_is_corrupt_not_torn() {
        let dir = tempfile::tempdir().unwrap();
        let j = Journal::open(dir.path()).unwrap();
        j.write_config(&serde_json::json!({})).unwrap();
        drop(j);
        let line = serde_json::to_string(&record(0)).unwrap();
        let path = dir.path().join("journal.jsonl");
        let damaged = format!("{line}\n{{oops\n");
        std::fs::write(&path, &damaged).unwrap();
        let e = Journal::open(dir.path()).err().unwrap();
        assert!(matches!(e, JournalError::Corrupt { line: 2, .. }), "{e:?}");
        assert!(matches!(read(dir.path()), Err(JournalError::CorruptRead { line: 2, .. })));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), damaged, "the file is left as it is");
        // Set aside: the bad lines move beside the journal, a torn tail is dropped as ever.
        std::fs::write(&path, format!("{line}\n{{oops\n{line}\n\n{line}\n{{\"torn")).unwrap();
        let j = Journal::open_with(dir.path(), OnCorrupt::SetAside).unwrap();
        assert_eq!((j.records.len(), j.set_aside, j.dropped_torn_line), (3, 2, true));
        j.append(&record(1)).unwrap();
        drop(j);
        assert_eq!(std::fs::read_to_string(dir.path().join(CORRUPT_FILE)).unwrap(), "{oops\n\n");
        let again = Journal::open(dir.path()).unwrap();
        assert_eq!(again.records.len(), 4);
        assert_eq!((again.set_aside, again.dropped_torn_line), (0, false));
    }

    #[cfg(unix)]
    #[test]
    fn planted_links_are_refused_and_their_targets_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim.txt");
        std::fs::write(&victim, "precious").unwrap();
        for name in [lock::LOCK_FILE, "journal.jsonl", "images"] {
            let run = dir.path().join(format!("run-{name}"));
            let j = Journal::open(&run).unwrap();
            j.write_config(&serde_json::json!({})).unwrap();
            drop(j);
            let at = run.join(name);
            if at.is_dir() {
                std::fs::remove_dir(&at).unwrap();
            } else {
                std::fs::remove_file(&at).unwrap();
            }
            std::os::unix::fs::symlink(&victim, &at).unwrap();
            let e = Journal::open(&run).err().unwrap().to_string();
            assert!(e.contains("symbolic link") && e.contains(name), "{name}: {e}");
            assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious", "{name}");
        }
    }

    #[test]
    fn journals_written_before_image_blocks_existed_still_read() {
        // `answer` was a plain value before it could be absent; both spellings read.
        let old = r#"{"phase":"search","set":["a"],"obs":0,"seed":1,"image":"i","prompt":"p","raw":"B","parsed":1,"answer":{"option":1},"expected":1,"outcome":"correct","usage":{"input_tokens":0,"output_tokens":0,"thinking_tokens":0,"cost_usd":0.0},"latency_ms":0,"cached":false}"#;
        let r: Record = serde_json::from_str(old).unwrap();
        assert_eq!(r.answer, Some(Answer::Option(1)));
    }

    #[test]
    fn non_run_folder_is_refused_and_images_are_content_addressed() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("notes.txt"), "x").unwrap();
        let e = Journal::open(dir.path()).err().unwrap();
        assert!(
            e.to_string().ends_with("is not empty and holds no run (no config.json); choose another `--out` folder"),
            "{e}"
        );
        assert!(!dir.path().join(lock::LOCK_FILE).exists(), "a refused folder is left as it was");
        let run = dir.path().join("r");
        let j = Journal::open(&run).unwrap();
        let h = j.store_image(b"png bytes").unwrap();
        assert_eq!(h, crate::hash::sha256_hex(b"png bytes"));
        assert_eq!(std::fs::read(run.join("images").join(format!("{h}.png"))).unwrap(), b"png bytes");
    }

    #[test]
    fn a_second_opener_is_refused_naming_the_holder() {
        let dir = tempfile::tempdir().unwrap();
        let first = Journal::open(dir.path()).unwrap();
        first.write_config(&serde_json::json!({})).unwrap();
        let e = Journal::open(dir.path()).err().unwrap();
        assert!(matches!(e, JournalError::Locked { .. }), "{e:?}");
        let msg = e.to_string();
        assert!(msg.contains(&format!("pid {}", std::process::id())), "{msg}");
        assert!(msg.contains("is in use by another revelio process"), "{msg}");
        drop(first);
        assert!(Journal::open(dir.path()).is_ok(), "the lock goes with the journal");
    }
}
