//! `revelio probe`, `transfer` and `compare` as a user runs them, on a sim search of the driving
//! domain: exit codes, the files they write, the journal phases, and resuming.

use std::path::Path;
use std::process::Command;

fn revelio(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_revelio"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("XDG_CACHE_HOME", std::env::temp_dir().join("revelio-explain-test-cache"))
        .output()
        .unwrap()
}

fn ok(args: &[&str]) -> String {
    let o = revelio(args);
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

fn phases(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("journal.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["phase"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn probe_transfer_and_compare_on_a_sim_run() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let run_s = run.to_str().unwrap();
    let profile = "sim:examples/sim/driving_recognition.toml";
    ok(&[
        "search",
        "domains/driving.rev",
        "--model",
        profile,
        "--renderer",
        "none",
        "--algo",
        "beam",
        "--budget",
        "300",
        "--out",
        run_s,
        "--json",
    ]);

    let table = ok(&["probe", run_s, "--top", "12", "--samples", "4", "--min-n", "2"]);
    assert!(table.contains("concept") && table.contains("mechanism"), "{table}");
    let probe: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("probe.json")).unwrap()).unwrap();
    assert_eq!(probe["top"], 12);
    assert!(probe["analysis"]["concepts"].as_array().unwrap().iter().any(|c| c["mechanism"].is_string()));
    let probed = phases(&run).iter().filter(|p| *p == "probe").count();
    assert_eq!(probed, 48);
    // Resumed: nothing asked again.
    ok(&["probe", run_s, "--top", "12", "--samples", "4", "--min-n", "2", "--json"]);
    assert_eq!(phases(&run).iter().filter(|p| *p == "probe").count(), 48);

    let table =
        ok(&["transfer", run_s, "--model", "sim:examples/sim/driving_paper.toml", "--top", "3", "--samples", "4"]);
    assert!(table.contains("M2  sim:driving-paper@"), "{table}");
    let t: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("transfer.json")).unwrap()).unwrap();
    assert_eq!(t["models"].as_array().unwrap().len(), 2);
    assert_eq!(t["sets"].as_array().unwrap().len(), 3);
    assert_eq!(t["random"].as_array().unwrap().len(), 3);
    assert_eq!(phases(&run).iter().filter(|p| *p == "transfer").count(), 2 * 6 * 4);

    // A probed and transferred run still validates and compares.
    ok(&["validate", run_s, "--top", "2", "--samples", "2", "--json"]);
    let csv = tmp.path().join("t.csv");
    let html = tmp.path().join("t.html");
    let out = ok(&["compare", run_s, "--csv", csv.to_str().unwrap(), "--html", html.to_str().unwrap()]);
    assert!(out.contains("PFM [95% CI]") && out.contains("beam"), "{out}");
    assert_eq!(std::fs::read_to_string(&csv).unwrap().lines().count(), 2);
    assert!(std::fs::read_to_string(&html).unwrap().contains("<table>"));

    // Bad input: clear errors and exit codes.
    let o = revelio(&["probe", run_s, "--low", "0.9"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("invalid `--low`"));
    let o = revelio(&["compare", tmp.path().join("nope").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("is not a run folder"));
}

#[test]
fn probe_starts_from_a_shrunk_runs_cores() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    let run_s = run.to_str().unwrap();
    ok(&[
        "search",
        "domains/driving.rev",
        "--model",
        "sim:examples/sim/driving_recognition.toml",
        "--renderer",
        "none",
        "--algo",
        "beam",
        "--budget",
        "300",
        "--shrink",
        "200",
        "--out",
        run_s,
        "--json",
    ]);
    let read = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(run.join(f)).unwrap()).unwrap()
    };
    let summary = read("summary.json");
    let cores: Vec<&serde_json::Value> = summary["cores"].as_array().unwrap().iter().map(|c| &c["concepts"]).collect();
    assert!(!cores.is_empty(), "the sim profile plants modes the shrink confirms");
    let top = cores.len() + 2;
    ok(&["probe", run_s, "--top", &top.to_string(), "--samples", "2", "--min-n", "2", "--json"]);
    let probe = read("probe.json");
    let probed: Vec<&serde_json::Value> = probe["sets"].as_array().unwrap().iter().map(|s| &s["concepts"]).collect();
    assert_eq!(probed.len(), top);
    assert_eq!(probed[..cores.len()], cores[..], "cores first, in the summary's order");
    assert!(probed[cores.len()..].iter().all(|s| !cores.contains(s)), "each set once");

    // Compare counts the shrink's cores, not the minimal failure modes.
    let out = ok(&["compare", run_s, "--json"]);
    let rows: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(rows[0]["cores"].as_u64().unwrap() as usize, cores.len(), "{out}");
}
