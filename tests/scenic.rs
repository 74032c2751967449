//! Real-Scenic peer test: every program Revelio emits for the driving domain (and for a domain of
//! entities placed relative to each other, `tests/corpus/good/walk_the_dog.rev`) must compile and
//! sample in Scenic 3.1.1 (2D mode, the CARLA Town01/Town02 maps, Scenic's default iteration
//! limit). Needs Python 3 with `venv`; the first run installs Scenic into
//! `$CARGO_TARGET_DIR/scenic-venv` (or `target/scenic-venv`), later runs reuse it. The maps are
//! read from `$REVELIO_CARLA_MAPS`, else from the copies of CARLA's (MIT-licensed) OpenDRIVE
//! files kept in `tests/scenic/maps`, so a clean checkout needs nothing else.

mod common;

use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::OnceLock;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use revelio::emit::{ScenicOptions, scenic};
use revelio::ir::{ConceptSet, Domain};

const SCENIC: &str = "scenic==3.1.1";
const RANDOM_SETS_PER_TOWN: usize = 30;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn maps_dir() -> PathBuf {
    let dir = std::env::var_os("REVELIO_CARLA_MAPS")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("tests").join("scenic").join("maps"));
    for town in ["Town01", "Town02"] {
        let map = dir.join(format!("{town}.xodr"));
        assert!(map.is_file(), "CARLA map `{}` is missing (set REVELIO_CARLA_MAPS to the maps folder)", map.display());
    }
    std::path::absolute(&dir).unwrap()
}

/// The venv's Python with Scenic installed, made on first use (once per test binary: both tests
/// ask for it at once).
fn scenic_python() -> PathBuf {
    static PYTHON: OnceLock<Result<PathBuf, String>> = OnceLock::new();
    let python = PYTHON.get_or_init(|| common::python_venv("scenic-venv", &[SCENIC], "import scenic"));
    python.clone().unwrap_or_else(|e| {
        panic!("{e}\nthe Scenic peer test needs Python 3 with the venv module and PyPI access to install {SCENIC}")
    })
}

fn valid(d: &Domain, set: ConceptSet) -> bool {
    revelio::lattice::validate(d, set).is_ok()
}

fn sets_to_check(d: &Domain) -> Vec<ConceptSet> {
    let n = d.concepts.len() as u32;
    let mut sets: Vec<ConceptSet> =
        (0..n).map(|i| ConceptSet::single(revelio::ir::ConceptId(i))).filter(|s| valid(d, *s)).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(20_260_522);
    for town in ["town_town01", "town_town02"] {
        let town = d.concept_by_name(town).expect("driving has both town concepts").id;
        let mut found = 0;
        for _ in 0..100_000 {
            if found == RANDOM_SETS_PER_TOWN {
                break;
            }
            let size = 2 + (rng.next_u32() % 4) as usize;
            let mut set = ConceptSet::single(town);
            while set.len() < size {
                set = set.with(revelio::ir::ConceptId(rng.next_u32() % n));
            }
            if valid(d, set) && !sets.contains(&set) {
                sets.push(set);
                found += 1;
            }
        }
        assert_eq!(found, RANDOM_SETS_PER_TOWN, "too few valid random driving sets found");
    }
    sets
}

#[test]
fn emitted_driving_programs_compile_and_sample_in_scenic() {
    let domain = revelio::cli::load_domain(&repo().join("domains").join("driving.rev"))
        .unwrap_or_else(|code| panic!("domains/driving.rev does not compile (exit {code:?})"));
    let sets = sets_to_check(&domain);
    compile_and_sample(&domain, &sets);
}

/// Entities placed relative to other entities (a dog `near` its owner, a cone `behind` a
/// barrier, fragments that place them from their target with `{target}` and `{rel_…}`): every
/// valid set with such a relation, each program holding `require`s that Scenic checks.
#[test]
fn emitted_relation_programs_compile_and_sample_in_scenic() {
    let domain = revelio::cli::load_domain(&repo().join("tests").join("corpus").join("good").join("walk_the_dog.rev"))
        .unwrap_or_else(|code| panic!("walk_the_dog.rev does not compile (exit {code:?})"));
    let lattice = revelio::lattice::Lattice::enumerate(&domain, domain.concepts.len());
    let sets: Vec<ConceptSet> = lattice
        .sets
        .iter()
        .copied()
        .filter(|s| revelio::anchor::build(&domain, *s).is_ok_and(|g| g.entities.iter().any(|e| e.target.is_some())))
        .collect();
    assert!(sets.len() >= 30, "only {} sets with a relation", sets.len());
    compile_and_sample(&domain, &sets);
}

/// Emit one program per set (seed = its position), then compile and sample them all in Scenic.
fn compile_and_sample(domain: &Domain, sets: &[ConceptSet]) {
    let maps = maps_dir();
    let python = scenic_python();
    let opts = ScenicOptions { map_dir: maps.to_string_lossy().into_owned() };
    let dir = tempfile::tempdir().unwrap();
    let mut jobs = String::new();
    let mut names = Vec::new();
    for (i, set) in sets.iter().enumerate() {
        let label = domain.set_names(*set).join(" + ");
        let scene = revelio::sample::sample(domain, *set, i as u64).unwrap_or_else(|e| panic!("{label}: {e}"));
        let program = scenic(domain, &scene, &opts).unwrap_or_else(|e| panic!("{label}: {e}"));
        let town = program.lines().find_map(|l| l.strip_prefix("param carla_map = '")?.strip_suffix('\'')).unwrap();
        let path = dir.path().join(format!("set{i}.scenic"));
        std::fs::write(&path, &program).unwrap();
        let job = serde_json::json!({
            "name": i.to_string(),
            "path": path,
            "map": maps.join(format!("{town}.xodr")),
            "carla_map": town,
        });
        jobs.push_str(&format!("{job}\n"));
        names.push(label);
    }
    let mut child = Command::new(&python)
        .arg(repo().join("tests").join("scenic").join("harness.py"))
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("start the Scenic harness");
    child.stdin.take().unwrap().write_all(jobs.as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "the Scenic harness failed: {:?}", out.status);
    let mut failures = Vec::new();
    let mut seen = 0;
    for line in String::from_utf8(out.stdout).unwrap().lines() {
        let r: serde_json::Value = serde_json::from_str(line).unwrap();
        seen += 1;
        if r["ok"] != true {
            let i: usize = r["name"].as_str().unwrap().parse().unwrap();
            failures.push(format!(
                "{{{}}} (program {}): {}",
                names[i],
                dir.path().join(format!("set{i}.scenic")).display(),
                r["error"]
            ));
        }
    }
    assert_eq!(seen, sets.len(), "the harness answered {seen} of {} programs", sets.len());
    if !failures.is_empty() {
        // Keep the programs for inspection.
        let kept = dir.keep();
        panic!(
            "{} of {} programs failed in Scenic (kept in {}):\n{}",
            failures.len(),
            sets.len(),
            kept.display(),
            failures.join("\n")
        );
    }
}
