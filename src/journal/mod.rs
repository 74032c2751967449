//! The run folder: `config.json` (the resolved configuration), the append-only `journal.jsonl`
//! (one line per observation), content-addressed `images/<sha256>.png`, and `summary.json`.
//!
//! Resuming: opening an existing folder with the same configuration loads every finished
//! observation; the search replays its decisions against them and only asks the model for the
//! rest. A folder made with a different configuration is refused, naming the differing fields.
//!
//! Durability: each line is written with one `write` call on an append-mode file, so a killed
//! process (even `kill -9`) leaves every finished line in the kernel's page cache and at most one
//! torn last line, which [`Journal::open`] drops (and truncates away) on resume. The file is
//! fsynced every [`SYNC_EVERY`] lines and at the end of each search step, so a power loss costs at
//! most that many observations (paid again on resume). `config.json`, images and `summary.json`
//! are written to a temporary file and renamed, so they are either absent or complete.
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::ir::Domain;
use crate::outcome::{Answer, Outcome, Usage};

/// Lines between fsyncs of the journal.
pub const SYNC_EVERY: usize = 64;

/// Which part of a run an observation belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    Search,
    Validate,
    /// Shrinking failure modes to cores after the search (more observations of search sets
    /// continue their indices; subsets start at 0).
    Shrink,
}

/// One observation, as one journal line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    pub phase: Phase,
    /// Concept names of the set, in index order.
    pub set: Vec<String>,
    /// Observation index within the set (and phase).
    pub obs: u32,
    /// The scene sampler's seed for this observation.
    pub seed: u64,
    /// SHA-256 of the image (or of the scene JSON with `--renderer none`).
    pub image: String,
    /// SHA-256 of the prompt text.
    pub prompt: String,
    pub raw: String,
    /// The parsed option, when the reply named exactly one.
    pub parsed: Option<u32>,
    pub answer: Answer,
    pub expected: u32,
    pub outcome: Outcome,
    pub usage: Usage,
    pub latency_ms: u64,
    pub cached: bool,
}

/// A run folder's journal, open for appending.
pub struct Journal {
    dir: PathBuf,
    file: Mutex<Writer>,
    /// Observations finished before this process started.
    pub records: Vec<Record>,
    /// Whether `open` dropped a torn last line.
    pub dropped_torn_line: bool,
}

struct Writer {
    file: File,
    unsynced: usize,
}

/// SHA-256 over the texts of a domain's source files in load order, identifying what a run
/// searched. Names are left out: the same file reached by a relative or an absolute path is the
/// same domain.
pub fn domain_hash(domain: &Domain) -> String {
    crate::hash::parts_hex(domain.files.iter().map(|f| f.text.as_bytes()))
}

fn io_err(what: &str, path: &Path, e: std::io::Error) -> String {
    format!("cannot {what} `{}`: {}", path.display(), e.to_string().to_lowercase())
}

/// Write a file atomically (temporary file, then rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(|e| io_err("write", &tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| io_err("write", path, e))
}

impl Journal {
    /// Open or create the run folder `dir` for a run with configuration `config` (any
    /// serialisable value; compared field by field with the folder's `config.json`).
    pub fn open<C: Serialize>(dir: &Path, config: &C) -> Result<Journal, String> {
        let config =
            serde_json::to_value(config).map_err(|e| format!("cannot serialise the run configuration: {e}"))?;
        let config_path = dir.join("config.json");
        if config_path.exists() {
            let text = std::fs::read_to_string(&config_path).map_err(|e| io_err("read", &config_path, e))?;
            let old: serde_json::Value = serde_json::from_str(&text)
                .map_err(|e| format!("cannot resume `{}`: config.json is not valid JSON: {e}", dir.display()))?;
            let diffs = differences(&old, &config);
            if !diffs.is_empty() {
                return Err(format!(
                    "cannot resume `{}`: it holds a run with a different configuration ({}); use another `--out` folder or the same settings",
                    dir.display(),
                    diffs.join(", ")
                ));
            }
        } else {
            if dir.exists() && std::fs::read_dir(dir).map_err(|e| io_err("read", dir, e))?.next().is_some() {
                return Err(format!(
                    "`{}` is not empty and holds no run (no config.json); choose another `--out` folder",
                    dir.display()
                ));
            }
            std::fs::create_dir_all(dir.join("images")).map_err(|e| io_err("create", dir, e))?;
            let text = serde_json::to_string_pretty(&config).expect("JSON values serialise");
            write_atomic(&config_path, text.as_bytes())?;
        }
        std::fs::create_dir_all(dir.join("images")).map_err(|e| io_err("create", &dir.join("images"), e))?;
        let path = dir.join("journal.jsonl");
        let mut file = OpenOptions::new()
            .read(true)
            .append(true)
            .create(true)
            .open(&path)
            .map_err(|e| io_err("open", &path, e))?;
        let mut text = Vec::new();
        file.read_to_end(&mut text).map_err(|e| io_err("read", &path, e))?;
        let (records, good_len) = parse_journal(&text, &path)?;
        let dropped_torn_line = good_len < text.len();
        if dropped_torn_line {
            file.set_len(good_len as u64).map_err(|e| io_err("truncate", &path, e))?;
            file.sync_all().map_err(|e| io_err("sync", &path, e))?;
        }
        file.seek(SeekFrom::End(0)).map_err(|e| io_err("seek", &path, e))?;
        Ok(Journal {
            dir: dir.to_path_buf(),
            file: Mutex::new(Writer { file, unsynced: 0 }),
            records,
            dropped_torn_line,
        })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Append one observation (one `write` call).
    pub fn append(&self, record: &Record) -> Result<(), String> {
        let mut line = serde_json::to_vec(record).expect("records serialise");
        line.push(b'\n');
        let path = self.dir.join("journal.jsonl");
        let mut w = self.file.lock().unwrap_or_else(|e| e.into_inner());
        w.file.write_all(&line).map_err(|e| io_err("append to", &path, e))?;
        w.unsynced += 1;
        if w.unsynced >= SYNC_EVERY {
            w.file.sync_data().map_err(|e| io_err("sync", &path, e))?;
            w.unsynced = 0;
        }
        Ok(())
    }

    /// Flush the journal to disk (end of a search step).
    pub fn sync(&self) -> Result<(), String> {
        let mut w = self.file.lock().unwrap_or_else(|e| e.into_inner());
        if w.unsynced > 0 {
            w.file.sync_data().map_err(|e| io_err("sync", &self.dir.join("journal.jsonl"), e))?;
            w.unsynced = 0;
        }
        Ok(())
    }

    /// Store an image under its content hash (no-op when present); returns the hash.
    pub fn store_image(&self, png: &[u8]) -> Result<String, String> {
        let hash = crate::hash::sha256_hex(png);
        let path = self.dir.join("images").join(format!("{hash}.png"));
        if !path.exists() {
            write_atomic(&path, png)?;
        }
        Ok(hash)
    }

    /// Write a JSON file into the run folder atomically.
    pub fn write_json<T: Serialize>(&self, name: &str, value: &T) -> Result<(), String> {
        let mut text = serde_json::to_string_pretty(value).map_err(|e| format!("cannot serialise `{name}`: {e}"))?;
        text.push('\n');
        write_atomic(&self.dir.join(name), text.as_bytes())
    }
}

/// Parse journal bytes; returns the records and the length of the valid prefix. Only the last
/// line may be torn (no newline, or unparseable): it is dropped. A bad line before it is an error.
fn parse_journal(text: &[u8], path: &Path) -> Result<(Vec<Record>, usize), String> {
    let mut records = Vec::new();
    let mut start = 0;
    let mut line_no = 0;
    while start < text.len() {
        line_no += 1;
        let Some(nl) = text[start..].iter().position(|&b| b == b'\n') else { break };
        let line = &text[start..start + nl];
        let end = start + nl + 1;
        match serde_json::from_slice::<Record>(line) {
            Ok(r) => records.push(r),
            Err(_) if end == text.len() => break,
            Err(e) => return Err(format!("cannot resume: line {line_no} of `{}` is corrupt: {e}", path.display())),
        }
        start = end;
    }
    Ok((records, start))
}

/// Top-level fields (and nested ones, dotted) that differ between two configurations.
fn differences(old: &serde_json::Value, new: &serde_json::Value) -> Vec<String> {
    fn walk(prefix: &str, a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<String>) {
        match (a, b) {
            (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
                let keys: BTreeMap<&String, ()> = x.keys().chain(y.keys()).map(|k| (k, ())).collect();
                for k in keys.keys() {
                    let name = if prefix.is_empty() { (*k).clone() } else { format!("{prefix}.{k}") };
                    let null = serde_json::Value::Null;
                    walk(&name, x.get(*k).unwrap_or(&null), y.get(*k).unwrap_or(&null), out);
                }
            }
            _ if a != b => out.push(format!("`{prefix}` was {a}, now {b}")),
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk("", old, new, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(obs: u32) -> Record {
        Record {
            phase: Phase::Search,
            set: vec!["a".into(), "b".into()],
            obs,
            seed: 7,
            image: "i".into(),
            prompt: "p".into(),
            raw: "Answer: A".into(),
            parsed: Some(0),
            answer: Answer::Option(0),
            expected: 1,
            outcome: Outcome::Wrong,
            usage: Usage::default(),
            latency_ms: 3,
            cached: false,
        }
    }

    #[test]
    fn torn_last_line_is_dropped_and_appends_continue() {
        let dir = tempfile::tempdir().unwrap();
        let run = dir.path().join("run");
        let cfg = serde_json::json!({"seed": 1});
        let j = Journal::open(&run, &cfg).unwrap();
        for i in 0..3 {
            j.append(&record(i)).unwrap();
        }
        j.sync().unwrap();
        drop(j);
        let path = run.join("journal.jsonl");
        let full = std::fs::read(&path).unwrap();
        // Cut inside the third line.
        std::fs::write(&path, &full[..full.len() - 10]).unwrap();
        let j = Journal::open(&run, &cfg).unwrap();
        assert!(j.dropped_torn_line);
        assert_eq!(j.records, vec![record(0), record(1)]);
        j.append(&record(2)).unwrap();
        drop(j);
        assert_eq!(std::fs::read(&path).unwrap(), full);
        let j = Journal::open(&run, &cfg).unwrap();
        assert!(!j.dropped_torn_line);
        assert_eq!(j.records.len(), 3);
    }

    #[test]
    fn corrupt_middle_line_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let cfg = serde_json::json!({});
        drop(Journal::open(dir.path(), &cfg).unwrap());
        let line = serde_json::to_string(&record(0)).unwrap();
        std::fs::write(dir.path().join("journal.jsonl"), format!("{line}\n{{oops\n{line}\n")).unwrap();
        let e = Journal::open(dir.path(), &cfg).err().unwrap();
        assert!(e.starts_with("cannot resume: line 2 of `"), "{e}");
    }

    #[test]
    fn different_configuration_is_refused_naming_fields() {
        let dir = tempfile::tempdir().unwrap();
        let a = serde_json::json!({"model": "sim:a", "params": {"budget": 1000, "seed": 0}});
        drop(Journal::open(dir.path(), &a).unwrap());
        let b = serde_json::json!({"model": "sim:b", "params": {"budget": 500, "seed": 0}});
        let e = Journal::open(dir.path(), &b).err().unwrap();
        assert_eq!(
            e,
            format!(
                "cannot resume `{}`: it holds a run with a different configuration (`model` was \"sim:a\", now \"sim:b\", `params.budget` was 1000, now 500); use another `--out` folder or the same settings",
                dir.path().display()
            )
        );
        assert!(Journal::open(dir.path(), &a).is_ok());
    }

    #[test]
    fn non_run_folder_is_refused_and_images_are_content_addressed() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("notes.txt"), "x").unwrap();
        let e = Journal::open(dir.path(), &serde_json::json!({})).err().unwrap();
        assert!(e.ends_with("is not empty and holds no run (no config.json); choose another `--out` folder"), "{e}");
        let run = dir.path().join("r");
        let j = Journal::open(&run, &serde_json::json!({})).unwrap();
        let h = j.store_image(b"png bytes").unwrap();
        assert_eq!(h, crate::hash::sha256_hex(b"png bytes"));
        assert_eq!(std::fs::read(run.join("images").join(format!("{h}.png"))).unwrap(), b"png bytes");
    }
}
