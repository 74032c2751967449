//! `revelio campaign` through the binary: an 8-cell grid against sim profiles run in two shards
//! and then without `--shard` equals the grid run in one go (same cells, same summaries), the
//! rerun adds no observation, and the campaign folder gets `index.html` and `compare.csv`; a cell
//! is the run `revelio search` makes alone with its flags; a dry run writes nothing.
use std::path::Path;
use std::process::Command;

fn campaign(file: &Path, extra: &[&str]) -> (i32, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_revelio"))
        .args(["campaign"])
        .arg(file)
        .args(extra)
        .args(["--no-cache", "--concurrency", "8"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    (
        o.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&o.stdout).into(),
        String::from_utf8_lossy(&o.stderr).into(),
    )
}

fn write_file(dir: &Path, name: &str, out: &Path) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(
        &p,
        format!(
            "out = {:?}\nbudget = 20\nsamples = 2\nrenderer = \"none\"\ndomains = [\"domains/driving.rev\"]\nmodels = [\"sim:examples/sim/driving_paper.toml\", \"sim:examples/sim/driving_fog.toml\"]\nalgos = [\"random\", \"beam\"]\nseeds = [0, 1]\n",
            out.display().to_string()
        ),
    )
    .unwrap();
    p
}

fn cells(out: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(out)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().is_dir())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn lines(dir: &Path) -> usize {
    std::fs::read_to_string(dir.join("journal.jsonl")).unwrap().lines().count()
}

#[test]
fn sharded_campaign_equals_unsharded() {
    let tmp = tempfile::tempdir().unwrap();
    let (one, split) = (tmp.path().join("one"), tmp.path().join("split"));
    let (f1, f2) = (write_file(tmp.path(), "one.toml", &one), write_file(tmp.path(), "split.toml", &split));

    let dry = campaign(&f1, &["--dry-run"]);
    assert_eq!(dry.0, 0, "{}", dry.2);
    assert!(dry.1.contains("total: at most 160 calls"), "8 cells × budget 20, every phase included: {}", dry.1);
    assert!(!one.exists(), "a dry run writes nothing");

    let all = campaign(&f1, &[]);
    assert_eq!(all.0, 0, "{}", all.2);
    // A cell is the run `revelio search` makes alone with the same flags: the same observations
    // and summary.
    let alone = tmp.path().join("alone");
    let o = Command::new(env!("CARGO_BIN_EXE_revelio"))
        .args(["search", "domains/driving.rev", "--model", "sim:examples/sim/driving_fog.toml", "--algo", "beam"])
        .args(["--seed", "1", "--budget", "20", "--samples", "2", "--renderer", "none", "--no-cache"])
        .args(["--concurrency", "8", "--json", "--out"])
        .arg(&alone)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    let cell = one.join("driving-sim-driving_fog-beam-s1");
    let sorted = |d: &Path| {
        let mut v: Vec<String> =
            std::fs::read_to_string(d.join("journal.jsonl")).unwrap().lines().map(String::from).collect();
        v.sort();
        v
    };
    assert_eq!(sorted(&cell), sorted(&alone), "the cell's observations are the lone search's");
    let summary = |d: &Path| std::fs::read_to_string(d.join("summary.json")).unwrap();
    assert_eq!(summary(&cell), summary(&alone), "the cell's summary is the lone search's");
    for shard in ["0/2", "1/2"] {
        let r = campaign(&f2, &["--shard", shard]);
        assert_eq!(r.0, 0, "{}", r.2);
        assert!(r.2.contains(&format!("shard {shard}: 4 of 8 cells")), "{}", r.2);
    }
    assert!(!split.join("index.html").exists(), "shards write no comparison");
    let names = cells(&split);
    assert_eq!(names.len(), 8);
    assert_eq!(names, cells(&one));
    let before: Vec<usize> = names.iter().map(|n| lines(&split.join(n))).collect();
    let merged = campaign(&f2, &[]);
    assert_eq!(merged.0, 0, "{}", merged.2);
    let after: Vec<usize> = names.iter().map(|n| lines(&split.join(n))).collect();
    assert_eq!(before, after, "the rerun without --shard adds nothing");
    for n in &names {
        let read = |d: &Path| std::fs::read_to_string(d.join(n).join("summary.json")).unwrap();
        assert_eq!(read(&one), read(&split), "cell {n}");
        assert!(split.join(n).join("report/index.html").exists(), "{n}");
    }
    let index = std::fs::read_to_string(split.join("index.html")).unwrap();
    assert!(index.contains("Spend per model"), "{index}");
    assert!(index.contains("href=\"driving-sim-driving_fog-beam-s1/report/index.html\""), "{index}");
    let csv = std::fs::read_to_string(split.join("compare.csv")).unwrap();
    assert_eq!(csv.lines().count(), 9, "a header and 8 cells: {csv}");
}

/// A campaign's dry run of an API model needs no key: nothing is sent.
#[test]
fn a_dry_run_of_an_api_model_needs_no_key() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("api.toml");
    std::fs::write(
        &file,
        format!(
            "out = {:?}\nbudget = 30\nrenderer = \"none\"\ndomains = [\"domains/driving.rev\"]\nmodels = [\"openai:gpt-4.1-mini\"]\nalgos = [\"random\"]\n",
            tmp.path().join("out").display().to_string()
        ),
    )
    .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_revelio"))
        .args(["campaign"])
        .arg(&file)
        .arg("--dry-run")
        .env_remove("OPENAI_API_KEY")
        .env_remove("OPENAI_BASE_URL")
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert_eq!(o.status.code(), Some(0), "{stderr}");
    assert!(stdout.contains("total: at most 30 calls, about $"), "{stdout}");
    assert!(!tmp.path().join("out").exists(), "a dry run writes nothing");
}
