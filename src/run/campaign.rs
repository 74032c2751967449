//! A campaign file (`revelio campaign FILE.toml`): a grid of domains × models × algorithms ×
//! seeds, each cell an ordinary search run folder under `out`, named from its parts. This module
//! reads the file and lays out the cells and shards; `cli::campaign` runs them.
//!
//! ```toml
//! out = "runs/paper-grid"
//! budget = 1000
//! renderer = "none"          # optional, as in `search` (default `builtin`)
//! domains = ["domains/driving.rev"]
//! models = ["sim:examples/sim/driving_paper.toml", "openai:gpt-4.1-mini"]
//! algos = ["interact", "gpts"]
//! seeds = [0, 1, 2]
//! # optional: samples, max_samples, shrink, threshold, model_config, base_url, thinking
//! ```
//! Paths are relative to the current directory, as on the command line. Cells are listed in
//! the file's order (domains, then models, algorithms, seeds); shard `I/N` (I from 0) holds the
//! cells whose position modulo N is I, so the shards of one file are fixed and disjoint and
//! together hold every cell.
use std::path::{Path, PathBuf};

use serde::Deserialize;

/// The campaign file as written.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Campaign {
    pub out: PathBuf,
    pub budget: u64,
    #[serde(default = "builtin")]
    pub renderer: String,
    pub domains: Vec<PathBuf>,
    pub models: Vec<String>,
    pub algos: Vec<String>,
    #[serde(default = "seed_zero")]
    pub seeds: Vec<u64>,
    pub samples: Option<u32>,
    pub max_samples: Option<u32>,
    pub shrink: Option<u64>,
    pub threshold: Option<f64>,
    /// Per-model settings (thinking, temperature, prices…), as `search --model-config`.
    pub model_config: Option<PathBuf>,
    /// The models' endpoint, as `search --base-url` (a vLLM or SGLang server).
    pub base_url: Option<String>,
    pub thinking: Option<String>,
}

fn builtin() -> String {
    "builtin".into()
}

fn seed_zero() -> Vec<u64> {
    vec![0]
}

/// One cell of the grid.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Cell {
    pub domain: PathBuf,
    pub model: String,
    pub algo: String,
    pub seed: u64,
    /// The run folder's name under `out`: `DOMAIN-MODEL-ALGO-sSEED`.
    pub name: String,
}

/// `--shard I/N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Shard, String> {
        let bad = || format!("expected `I/N` with 0 ≤ I < N (e.g. `0/4`), got `{s}`");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) =
            (i.trim().parse::<usize>().map_err(|_| bad())?, n.trim().parse::<usize>().map_err(|_| bad())?);
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// A name part safe in a folder name: letters, digits, `.`, `_` and `-` kept, the rest `-`.
fn slug(s: &str) -> String {
    let out: String = s.chars().map(|c| if c.is_ascii_alphanumeric() || "._-".contains(c) { c } else { '-' }).collect();
    out.trim_matches(|c| c == '-' || c == '.').to_string()
}

/// A model's part of a cell name: `sim:examples/sim/driving_paper.toml` → `sim-driving_paper`,
/// `openai:gpt-4.1-mini` → `openai-gpt-4.1-mini`.
pub fn model_slug(spec: &str) -> String {
    match spec.split_once(':') {
        Some(("sim", path)) => {
            format!("sim-{}", slug(&Path::new(path).file_stem().unwrap_or_default().to_string_lossy()))
        }
        Some((provider, name)) => format!("{}-{}", slug(provider), slug(name)),
        None => slug(spec),
    }
}

impl Campaign {
    /// Read and check a campaign file.
    pub fn parse(text: &str, origin: &str) -> Result<Campaign, String> {
        let c: Campaign =
            toml::from_str(text).map_err(|e| format!("invalid campaign file `{origin}`: {}", e.message()))?;
        for (what, empty) in [
            ("domains", c.domains.is_empty()),
            ("models", c.models.is_empty()),
            ("algos", c.algos.is_empty()),
            ("seeds", c.seeds.is_empty()),
        ] {
            if empty {
                return Err(format!("invalid campaign file `{origin}`: `{what}` is empty"));
            }
        }
        if c.budget == 0 {
            return Err(format!("invalid campaign file `{origin}`: `budget` must be at least 1"));
        }
        let cells = c.cells();
        for (i, a) in cells.iter().enumerate() {
            if let Some(b) = cells[..i].iter().find(|b| b.name == a.name) {
                return Err(format!(
                    "invalid campaign file `{origin}`: two cells would share the run folder `{}` ({} {} and {} {}); list each domain, model, algorithm and seed once",
                    a.name,
                    a.domain.display(),
                    a.model,
                    b.domain.display(),
                    b.model
                ));
            }
        }
        Ok(c)
    }

    /// Every cell, in the file's order.
    pub fn cells(&self) -> Vec<Cell> {
        let mut out = Vec::new();
        for d in &self.domains {
            let stem = slug(&d.file_stem().unwrap_or_default().to_string_lossy());
            for m in &self.models {
                for a in &self.algos {
                    for &seed in &self.seeds {
                        let name = format!("{stem}-{}-{}-s{seed}", model_slug(m), slug(a));
                        out.push(Cell { domain: d.clone(), model: m.clone(), algo: a.clone(), seed, name });
                    }
                }
            }
        }
        out
    }

    /// The cells of `shard` (all without one).
    pub fn shard(&self, shard: Option<Shard>) -> Vec<Cell> {
        let all = self.cells();
        match shard {
            None => all,
            Some(s) => all.into_iter().enumerate().filter(|(i, _)| i % s.count == s.index).map(|(_, c)| c).collect(),
        }
    }

    /// The `revelio search` arguments of a cell (after `search`).
    pub fn search_args(&self, cell: &Cell) -> Vec<String> {
        let mut a: Vec<String> = vec![
            cell.domain.display().to_string(),
            "--model".into(),
            cell.model.clone(),
            "--algo".into(),
            cell.algo.clone(),
            "--seed".into(),
            cell.seed.to_string(),
            "--budget".into(),
            self.budget.to_string(),
            "--renderer".into(),
            self.renderer.clone(),
            "--out".into(),
            self.out.join(&cell.name).display().to_string(),
        ];
        let mut opt = |flag: &str, v: Option<String>| {
            if let Some(v) = v {
                a.push(flag.into());
                a.push(v);
            }
        };
        opt("--samples", self.samples.map(|v| v.to_string()));
        opt("--max-samples", self.max_samples.map(|v| v.to_string()));
        opt("--shrink", self.shrink.map(|v| v.to_string()));
        opt("--threshold", self.threshold.map(|v| v.to_string()));
        opt("--model-config", self.model_config.as_ref().map(|p| p.display().to_string()));
        opt("--base-url", self.base_url.clone());
        opt("--thinking", self.thinking.clone());
        a
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = r#"
        out = "runs/grid"
        budget = 100
        renderer = "none"
        domains = ["domains/driving.rev"]
        models = ["sim:examples/sim/driving_paper.toml", "openai:gpt-4.1-mini"]
        algos = ["interact", "gpts"]
        seeds = [0, 1]
    "#;

    #[test]
    fn cells_are_named_from_their_parts_and_shards_are_disjoint() {
        let c = Campaign::parse(FILE, "c.toml").unwrap();
        let cells = c.cells();
        assert_eq!(cells.len(), 8);
        assert_eq!(cells[0].name, "driving-sim-driving_paper-interact-s0");
        assert_eq!(cells[7].name, "driving-openai-gpt-4.1-mini-gpts-s1");
        let shards: Vec<Vec<Cell>> = (0..3).map(|i| c.shard(Some(Shard { index: i, count: 3 }))).collect();
        let mut names: Vec<String> = shards.iter().flatten().map(|c| c.name.clone()).collect();
        assert_eq!(names.len(), 8, "disjoint");
        names.sort();
        let mut all: Vec<String> = cells.iter().map(|c| c.name.clone()).collect();
        all.sort();
        assert_eq!(names, all, "together every cell");
        let args = c.search_args(&cells[0]);
        assert!(args.windows(2).any(|w| w == ["--out", "runs/grid/driving-sim-driving_paper-interact-s0"]));
    }

    #[test]
    fn bad_files_and_shards_are_refused() {
        assert_eq!("1/4".parse::<Shard>(), Ok(Shard { index: 1, count: 4 }));
        for bad in ["4/4", "1", "a/2", "0/0"] {
            assert!(bad.parse::<Shard>().unwrap_err().contains("expected `I/N`"), "{bad}");
        }
        let e = Campaign::parse(&FILE.replace("seeds = [0, 1]", "seeds = [0, 0]"), "c.toml").unwrap_err();
        assert!(e.contains("two cells would share the run folder `driving-sim-driving_paper-interact-s0`"), "{e}");
        let e = Campaign::parse(&FILE.replace("budget = 100", "budget = 100\nbugdet = 3"), "c.toml").unwrap_err();
        assert!(e.starts_with("invalid campaign file `c.toml`: unknown field `bugdet`"), "{e}");
        let e = Campaign::parse(&FILE.replace(r#"algos = ["interact", "gpts"]"#, "algos = []"), "c.toml").unwrap_err();
        assert_eq!(e, "invalid campaign file `c.toml`: `algos` is empty");
    }
}
