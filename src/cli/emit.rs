//! `revelio emit scenic|prompt|scene FILE CONCEPT... [--seed N]`: one sampled scene of a
//! concept set, as a Scenic program for CARLA, an image-generation prompt, or Scene JSON.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use crate::emit::{self, ScenicOptions};
use crate::sample;

/// Environment variable naming the folder of the CARLA `.xodr` maps.
pub const MAPS_ENV: &str = "REVELIO_CARLA_MAPS";

#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum EmitFormat {
    /// A Scenic 3 program for the CARLA world model
    Scenic,
    /// The image-generation prompt
    Prompt,
    /// The sampled scene as JSON
    Scene,
}

#[derive(clap::Args, Debug)]
pub struct EmitArgs {
    /// What to emit
    #[arg(value_enum)]
    pub format: EmitFormat,
    /// The domain file (`.rev`)
    pub file: PathBuf,
    /// The concept set, by concept name
    #[arg(required = true, num_args = 1..)]
    pub concepts: Vec<String>,
    /// Sampling seed (the same seed gives the same scene)
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Folder of the CARLA maps (`Town01.xodr`, …) for Scenic programs [default: $REVELIO_CARLA_MAPS,
    /// else the copies of CARLA's Town01/Town02 in the Revelio sources (`tests/scenic/maps`)]
    #[arg(long, value_name = "DIR")]
    pub map_dir: Option<PathBuf>,
}

pub fn run(args: EmitArgs) -> ExitCode {
    let domain = match crate::cli::load_domain(&args.file) {
        Ok(d) => d,
        Err(code) => return code,
    };
    let set = match domain.parse_set(&args.concepts) {
        Ok(s) => s,
        Err(e) => return fail(&e.to_string()),
    };
    let scene = match sample::sample(&domain, set, args.seed) {
        Ok(s) => s,
        Err(e) => return fail(&e.to_string()),
    };
    let text = match args.format {
        EmitFormat::Scene => serde_json::to_string_pretty(&scene).map_err(|e| emit::EmitError(e.to_string())),
        EmitFormat::Prompt => emit::prompt(&domain, &scene),
        EmitFormat::Scenic => {
            let dir = map_dir(args.map_dir.as_deref(), std::env::var_os(MAPS_ENV).map(PathBuf::from));
            let opts = ScenicOptions { map_dir: dir.to_string_lossy().into_owned() };
            let program = emit::scenic(&domain, &scene, &opts);
            if let Some(town) = program.as_deref().ok().and_then(program_town) {
                let map = dir.join(format!("{town}.xodr"));
                if !map.is_file() {
                    eprintln!(
                        "warning: map `{}` does not exist; Scenic will not compile this program until it does (set --map-dir or {MAPS_ENV})",
                        map.display()
                    );
                }
            }
            program
        }
    };
    match text {
        Ok(t) => {
            use std::io::Write as _;
            match writeln!(std::io::stdout().lock(), "{}", t.trim_end()) {
                // A closed pipe (`| head`) is the reader's choice, not an error.
                Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => fail(&format!("cannot write the output: {e}")),
                _ => ExitCode::SUCCESS,
            }
        }
        Err(e) => fail(&e.to_string()),
    }
}

fn fail(msg: &str) -> ExitCode {
    eprintln!("error: {msg}");
    ExitCode::from(1)
}

/// The maps folder: the flag, else the environment, else the checkout's `tests/scenic/maps`;
/// made absolute so the program compiles wherever it is saved.
fn map_dir(flag: Option<&Path>, env: Option<PathBuf>) -> PathBuf {
    let dir = flag
        .map(Path::to_path_buf)
        .or(env.filter(|p| !p.as_os_str().is_empty()))
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("tests").join("scenic").join("maps"));
    std::path::absolute(&dir).unwrap_or(dir)
}

/// The CARLA map name a program uses (its `param carla_map`).
fn program_town(program: &str) -> Option<&str> {
    program.lines().find_map(|l| l.strip_prefix("param carla_map = '")?.strip_suffix('\''))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_dir_prefers_flag_then_env() {
        let flag = map_dir(Some(Path::new("/a")), Some(PathBuf::from("/b")));
        assert_eq!(flag, PathBuf::from("/a"));
        assert_eq!(map_dir(None, Some(PathBuf::from("/b"))), PathBuf::from("/b"));
        let default = map_dir(None, Some(PathBuf::new()));
        assert!(default.is_absolute() && default.ends_with("tests/scenic/maps"));
        assert!(map_dir(Some(Path::new("rel")), None).is_absolute());
    }

    #[test]
    fn reads_the_town_back() {
        assert_eq!(program_town("x\nparam carla_map = 'Town02'\n"), Some("Town02"));
        assert_eq!(program_town("x"), None);
    }
}
