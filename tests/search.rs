//! The search runtime on the real domains: sim profiles, all three algorithms through the
//! journaled runner, and the `revelio search` / `validate` commands end to end.
mod common;

use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use revelio::ir::Domain;
use revelio::lattice::Lattice;
use revelio::outcome::Outcome;
use revelio::run::observe::{DomainWorld, World};
use revelio::run::runner::{self, Setup};
use revelio::run::summary::RunConfig;
use revelio::search::{Algo, Params};
use revelio::vlm::Model;
use revelio::vlm::sim::{Profile, SimModel};

/// A shipped domain by name (`driving` → `domains/driving.rev`).
fn domain(name: &str) -> Domain {
    common::compile_shipped(&format!("domains/{name}.rev"))
}

fn profile(file: &str, d: &Domain) -> Profile {
    let path = format!("{}/examples/sim/{file}", env!("CARGO_MANIFEST_DIR"));
    Profile::parse(&std::fs::read_to_string(&path).unwrap(), file, d).unwrap()
}

#[test]
fn every_shipped_profile_loads_against_its_domain() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/sim");
    let mut n = 0;
    for e in std::fs::read_dir(dir).unwrap() {
        let name = e.unwrap().file_name().into_string().unwrap();
        // A profile is named after its domain: `driving_paper.toml` → `domains/driving.rev`.
        let stem = name.trim_end_matches(".toml");
        let d = &domain(stem.split('_').next().unwrap());
        let p = profile(&name, d);
        assert!(!p.modes.is_empty(), "{name} plants no failure mode");
        // Every planted mode must be reachable: some valid set contains it.
        let lattice = Lattice::enumerate(d, 5);
        for m in &p.modes {
            assert!(
                lattice.sets.iter().any(|s| m.concepts.is_subset_of(*s)),
                "{name}: mode {:?} is in no valid set",
                d.set_names(m.concepts)
            );
        }
        n += 1;
    }
    assert!(n >= 4);
}

/// The valid sets of up to five concepts of a domain, enumerated once per test binary and
/// domain name: every search of a shipped domain below searches the same space.
fn lattice(d: &Domain) -> &'static [revelio::ir::ConceptSet] {
    type Sets = &'static [revelio::ir::ConceptSet];
    static LATTICES: std::sync::Mutex<Vec<(String, Sets)>> = std::sync::Mutex::new(Vec::new());
    let mut all = LATTICES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, sets)) = all.iter().find(|(n, _)| *n == d.name) {
        return sets;
    }
    let sets: Sets = Lattice::enumerate(d, 5).sets.leak();
    all.push((d.name.clone(), sets));
    sets
}

fn run(d: &Domain, file: &str, algo: Algo, budget: u64, out: &Path) -> runner::RunReport {
    let model: Arc<dyn Model> = Arc::new(SimModel { profile: profile(file, d) });
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(d));
    let (space, _) = runner::search_space(lattice(d).to_vec(), d.concepts.len(), world.as_ref());
    let params = Params { algo, budget, beam_budget: budget / 2, ..Params::default() };
    let spec = format!("sim:{file}");
    let config =
        RunConfig::new(d, Path::new(&d.files[0].name), &spec, model.as_ref(), Default::default(), "none", params);
    let mut setup = Setup::new(Arc::new(d.clone()), world, model, None, out);
    setup.concurrency = 8;
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap();
    let r = rt.block_on(runner::search(&setup, &config, &space)).unwrap();
    assert!(r.history.iter().all(|s| space.contains(s.set)));
    r
}

/// [`run`] for each algorithm, side by side (each in `out/ALGO`), reports in `algos` order. The
/// searches share nothing but the domain and its lattice, and each is seeded, so running them at
/// once changes no result; it lets them use a core the other test thread leaves idle while it
/// waits on a subprocess or a sim latency.
fn run_each(d: &Domain, file: &str, algos: &[Algo], budget: u64, out: &Path) -> Vec<runner::RunReport> {
    std::thread::scope(|s| {
        let runs: Vec<_> =
            algos.iter().map(|&algo| s.spawn(move || run(d, file, algo, budget, &out.join(algo.name())))).collect();
        runs.into_iter().map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e))).collect()
    })
}

#[test]
fn all_algorithms_search_the_driving_domain() {
    let d = domain("driving");
    let dir = tempfile::tempdir().unwrap();
    let mut pfm = Vec::new();
    for r in run_each(&d, "driving_paper.toml", &[Algo::Random, Algo::Beam, Algo::Gpts], 1000, dir.path()) {
        assert_eq!(r.summary.metrics.inferences, 1000);
        assert_eq!(r.summary.metrics.sets, 200);
        pfm.push(r.summary.metrics.pfm);
    }
    // Guided search beats random on a profile with planted modes at the paper's budget (seeded:
    // deterministic).
    assert!(pfm[1] > pfm[0] && pfm[2] > pfm[0], "random {} beam {} gpts {}", pfm[0], pfm[1], pfm[2]);
}

/// The landscape the paper measured on its low-base-rate models (Gemini 3 Flash, minimal
/// thinking): far hazards and cyclists fail alone and in pairs, crowded scenes seldom do. There
/// both guided searches find at least 3× Random's share of failure modes at the paper's budget.
#[test]
fn guided_search_finds_three_times_random_on_the_gemini_minimal_landscape() {
    let d = domain("driving");
    let dir = tempfile::tempdir().unwrap();
    let pfm: Vec<f64> =
        run_each(&d, "driving_gemini_minimal.toml", &[Algo::Random, Algo::Beam, Algo::Gpts], 1000, dir.path())
            .iter()
            .map(|r| r.summary.metrics.pfm)
            .collect();
    let (random, beam, gpts) = (pfm[0], pfm[1], pfm[2]);
    assert!(random < 6.0, "random PFM {random} should stay near the paper's 3.5 %");
    assert!(beam >= 10.0 && beam >= 3.0 * random, "random {random} beam {beam}");
    assert!(gpts >= 10.0 && gpts >= 3.0 * random, "random {random} gpts {gpts}");
}

#[test]
fn beam_searches_the_indoor_domain_with_best_fit_questions() {
    let d = domain("indoor");
    let dir = tempfile::tempdir().unwrap();
    let r = run(&d, "indoor_paper.toml", Algo::Beam, 300, dir.path());
    assert_eq!(r.summary.metrics.sets, 60);
    let journal = std::fs::read_to_string(dir.path().join("journal.jsonl")).unwrap();
    assert_eq!(journal.lines().count(), 300);
}

fn revelio(args: &[&str]) -> (i32, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_revelio"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    (o.status.code().unwrap(), String::from_utf8_lossy(&o.stdout).into(), String::from_utf8_lossy(&o.stderr).into())
}

#[test]
fn search_command_resumes_refuses_other_configs_and_validates() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let out = out.to_str().unwrap();
    let base = [
        "search",
        "domains/driving.rev",
        "--model",
        "sim:examples/sim/driving_paper.toml",
        "--algo",
        "beam",
        "--budget",
        "100",
        "--renderer",
        "none",
        "--out",
        out,
    ];
    let (code, table, err) = revelio(&base);
    assert_eq!(code, 0, "{err}");
    assert!(table.contains("beam on `driving` with sim:driving-paper@"), "{table}");
    assert!(table.contains("PFM "), "{table}");
    let summary = std::fs::read(Path::new(out).join("summary.json")).unwrap();

    // Same command: resumes, asks nothing new, same summary.
    let mut json = base.to_vec();
    json.push("--json");
    let (code, stdout, err) = revelio(&json);
    assert_eq!(code, 0, "{err}");
    let lines = std::fs::read_to_string(Path::new(out).join("journal.jsonl")).unwrap().lines().count();
    // Every journaled observation replays, the shrink phase's (if the search found anything) too;
    // the search phase is the budget less the shrink budget (25), every phase within the budget.
    assert!((75..=100).contains(&lines), "{lines}");
    assert!(err.contains(&format!("{lines} observations replayed")), "{err}");
    let printed: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(printed, serde_json::from_slice::<serde_json::Value>(&summary).unwrap());

    // A higher budget extends the run; another seed is a different run and is refused.
    let mut more = base.to_vec();
    more[7] = "200";
    let (code, _, err) = revelio(&more);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains(&format!("extending {out} from 100 to 200 model calls")), "{err}");
    assert!(err.contains("observations replayed"), "{err}");
    more.extend(["--seed", "3"]);
    let (code, _, err) = revelio(&more);
    assert_eq!(code, 1);
    assert!(err.contains("`params.seed` was 0, now 3"), "{err}");

    let (code, report, err) = revelio(&["validate", out, "--top", "3", "--samples", "4"]);
    assert_eq!(code, 0, "{err}");
    assert!(report.contains("validated FR"), "{report}");
    assert!(Path::new(out).join("validation-top3-samples4.json").exists());
}

#[test]
fn bad_profiles_and_flags_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "name = \"x\"\n[[mode]]\nconcepts = [\"debris_farr\"]\nerror = 0.9\n").unwrap();
    let model = format!("sim:{}", bad.display());
    let (code, _, err) = revelio(&["search", "domains/driving.rev", "--model", &model, "--renderer", "none"]);
    assert_eq!(code, 2);
    assert!(err.contains("unknown concept `debris_farr` in domain `driving`; did you mean `debris_far`?"), "{err}");
    let (code, _, err) = revelio(&[
        "search",
        "domains/driving.rev",
        "--model",
        "sim:examples/sim/driving_paper.toml",
        "--threshold",
        "2",
    ]);
    assert_eq!(code, 2);
    assert!(err.contains("invalid `--threshold`: must be between 0 and 1, got 2"), "{err}");
    let sim = ["search", "domains/driving.rev", "--model", "sim:examples/sim/driving_paper.toml"];
    let (code, _, err) = revelio(&[&sim[..], &["--max-samples", "3"]].concat());
    assert_eq!(code, 2);
    assert!(err.contains("invalid `--max-samples`: must be at least `--samples` (5), got 3"), "{err}");
    let (code, _, err) = revelio(&[&sim[..], &["--shrink", "2"]].concat());
    assert_eq!(code, 2);
    assert!(
        err.contains("invalid `--shrink`: 2 inferences cannot test one subset of 5 samples (0 turns shrinking off)"),
        "{err}"
    );
}

#[test]
fn sequential_search_with_cores_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let out = out.to_str().unwrap();
    let (code, table, err) = revelio(&[
        "search",
        "domains/driving.rev",
        "--model",
        "sim:examples/sim/driving_paper.toml",
        "--algo",
        "gpts",
        "--budget",
        "400",
        "--max-samples",
        "20",
        "--renderer",
        "none",
        "--out",
        out,
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(table.contains("minimal failure modes (cores)"), "{table}");
    assert!(table.contains("shrink: "), "{table}");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(Path::new(out).join("summary.json")).unwrap()).unwrap();
    let search = summary["metrics"]["inferences"].as_u64().unwrap();
    assert!(search <= 300, "the search phase is budget − shrink");
    assert!(search + summary["shrink"]["inferences"].as_u64().unwrap() <= 400, "every phase within the budget");
    let cores = summary["cores"].as_array().unwrap();
    assert!(!cores.is_empty(), "{summary}");
    for c in cores {
        assert!(c["ci95"][0].as_f64().unwrap() <= c["fr"].as_f64().unwrap());
        assert!(c["supersets"].as_u64().is_some() && c["answered"].as_u64().unwrap() >= 5);
        let line = format!(
            " {}",
            c["concepts"].as_array().unwrap().iter().map(|x| x.as_str().unwrap()).collect::<Vec<_>>().join(" + ")
        );
        assert!(table.contains(&line), "{line} in {table}");
    }
    // Sequential validation against the run's τ.
    let (code, report, err) = revelio(&["validate", out, "--top", "3", "--samples", "5", "--max-samples", "20"]);
    assert_eq!(code, 0, "{err}");
    assert!(report.contains("5–20 samples (sequential)"), "{report}");
}

/// Bug 1 of issue 13: the scene stream hashed the domain file's path as typed. Every spelling of
/// the path now gives the same scenes, and a run started with one resumes with another.
#[test]
fn the_spelling_of_the_domain_path_does_not_change_the_scenes() {
    let abs = format!("{}/domains/driving.rev", env!("CARGO_MANIFEST_DIR"));
    let scenes: Vec<String> = ["domains/driving.rev", "./domains/driving.rev", "domains/../domains/driving.rev", &abs]
        .iter()
        .map(|p| {
            let (code, out, err) = revelio(&["emit", "scene", p, "debris_far", "weather_foggy", "--seed", "7"]);
            assert_eq!(code, 0, "{err}");
            out
        })
        .collect();
    assert!(scenes.windows(2).all(|w| w[0] == w[1]), "{scenes:#?}");

    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let out = out.to_str().unwrap();
    let args = |file: &'static str| {
        vec!["search", file, "--model", "sim:examples/sim/driving_paper.toml", "--renderer", "none", "--algo", "random"]
    };
    let mut first = args("domains/driving.rev");
    first.extend(["--budget", "40", "--out", out]);
    assert_eq!(revelio(&first).0, 0);
    let mut other = args("./domains/../domains/driving.rev");
    other.extend(["--budget", "40", "--out", out]);
    let (code, _, err) = revelio(&other);
    assert_eq!(code, 0, "{err}");
    // Everything the first run observed — its 30 search inferences and whatever its shrink and
    // confirmation phases asked (at 40 calls, fresh confirmation's 20 per candidate leave the
    // shrink phase nothing: `search::budget`) — is replayed, nothing asked again.
    let lines = std::fs::read_to_string(dir.path().join("run/journal.jsonl")).unwrap().lines().count();
    assert!((30..=40).contains(&lines), "the search ran, within the budget: {lines}");
    assert!(err.contains(&format!("{lines} observations replayed")), "{err}");
}

/// Issue 18: a concept drawn under the road is never seen. The search resamples its scenes, then
/// records each observation as `invisible` — no model call, never `wrong` — with the figures in
/// the journal; a concept that is seen is observed as usual.
#[test]
fn a_concept_drawn_under_the_road_is_recorded_invisible_never_wrong() {
    let path = format!("{}/domains/driving.rev", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap()
        + r#"
kind BuriedCrate: Placed {
  shape {
    box size (1.5m, 1.5m, 1m) at (0m, 0m, -2m) color #d02020
  }
}
concept crate_buried {
  description "A red crate drawn two metres under the lane: never visible."
  category "Road obstacles"
  add crate_buried: BuriedCrate in lane ahead_of ego { distance = 8m..12m }
  probe "A red crate is on my lane." not "There is no red crate on my lane."
  scenic "{id} = new Prop with blueprint 'static.prop.container', {at}"
  prompt "A red crate on the lane ahead."
}
"#;
    let d = revelio::check::compile_source(&path, &text).unwrap_or_else(|e| panic!("does not compile: {e:?}"));
    let buried = d.concepts.iter().position(|c| c.name == "crate_buried").unwrap();
    let seen = d.concepts.iter().position(|c| c.name == "obstruction_far").unwrap();
    let sets = [buried, seen].map(|i| revelio::ir::ConceptSet::from_bits(1 << i)).to_vec();
    // Every observation of the sim profile below is wrong, so a shown scene is `wrong`.
    let profile = "name = \"always wrong\"\nbase_error = 1.0\n";
    let model: Arc<dyn Model> = Arc::new(SimModel { profile: Profile::parse(profile, "wrong.toml", &d).unwrap() });
    let world: Arc<dyn World> = Arc::new(DomainWorld::new(&d));
    let (space, _) = runner::search_space(sets, d.concepts.len(), world.as_ref());
    let params = Params { algo: Algo::Random, budget: 10, beam_budget: 5, ..Params::default() };
    let out = tempfile::tempdir().unwrap();
    let renderer = revelio::render::build_renderer("builtin", &Default::default()).unwrap();
    let config =
        RunConfig::new(&d, Path::new(&path), "sim:wrong.toml", model.as_ref(), Default::default(), "builtin", params);
    let setup = Setup::new(Arc::new(d.clone()), world, model, renderer, out.path());
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().unwrap();
    let r = rt.block_on(runner::search(&setup, &config, &space)).unwrap();

    let journal = std::fs::read_to_string(out.path().join("journal.jsonl")).unwrap();
    let records: Vec<revelio::journal::Record> = journal.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(records.len(), 10);
    let (hidden, shown): (Vec<_>, Vec<_>) = records.iter().partition(|r| r.set == ["crate_buried"]);
    assert_eq!(hidden.len(), 5);
    for rec in &hidden {
        assert_eq!(rec.outcome, Outcome::Invisible, "{rec:?}");
        assert_eq!((rec.answer, rec.resamples), (None, revelio::run::observe::RESAMPLES));
        assert_eq!(rec.visibility.len(), 1);
        assert_eq!(rec.visibility[0].pixels, 0);
        assert!(rec.raw.contains("`crate_buried`"), "{}", rec.raw);
    }
    for rec in &shown {
        assert_eq!(rec.outcome, Outcome::Wrong, "{rec:?}");
        assert!(rec.visibility[0].pixels > 100, "{rec:?}");
    }
    assert_eq!(r.summary.metrics.inferences, 10);
    assert_eq!(r.summary.metrics.unanswered.get(&Outcome::Invisible), Some(&5));
    assert_eq!(r.summary.spend.calls, 5, "no model call for an invisible scene");
    assert!(r.summary.failure_modes.iter().all(|m| m.concepts != ["crate_buried"]));
    assert!(r.summary.failure_modes.iter().any(|m| m.concepts == ["obstruction_far"]));
}

/// Issue 18: the third domain, written only in `.rev`, searched as a new user would — its own
/// sim profile, the builtin renderer, the run report. Beam's first level asks every valid
/// single concept; every scene shown to the model meets the domain's `visible` thresholds and
/// is journaled with its figures; the search finds the profile's planted `residential +
/// dog_loose` (sim answers depend on the scene shown, as a deterministic model's would). No set
/// is shown the same image twice (issue 28: one scene, one piece of evidence).
#[test]
fn the_delivery_domain_is_searched_with_the_builtin_renderer() {
    let d = domain("delivery");
    assert!(d.visibility.kinds.is_empty() && d.visibility.concepts.is_empty(), "one threshold for every entity");
    let seen = d.visibility.default;
    assert_eq!((seen.pixels, seen.contrast), (40, 0.03), "the domain's own `visible` item, not the default");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let out_s = out.to_str().unwrap();
    // Seed 2: the sim answers by image, and on llvmpipe this seed's first level ranks `dog_loose`
    // (0.45 alone) among the beam's.
    let args = ["--algo", "beam", "--budget", "150", "--shrink", "0", "--seed", "2", "--out", out_s];
    let (code, table, err) = revelio(
        &[&["search", "domains/delivery.rev", "--model", "sim:examples/sim/delivery.toml"][..], &args].concat(),
    );
    assert_eq!(code, 0, "{err}");
    assert!(table.contains("beam on `delivery` with sim:delivery@"), "{table}");
    assert!(table.contains("residential + dog_loose"), "{table}");

    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["metrics"]["inferences"], 150);
    let sets = summary["sets"].as_array().unwrap();
    let singles = sets.iter().filter(|s| s["concepts"].as_array().unwrap().len() == 1).count();
    assert_eq!(singles, Lattice::enumerate(&d, 1).sets.len(), "beam's first level: every valid single concept");
    let names = |v: &serde_json::Value| -> Vec<String> {
        v["concepts"].as_array().unwrap().iter().map(|c| c.as_str().unwrap().to_string()).collect()
    };
    assert!(summary["failure_modes"].as_array().unwrap().iter().any(|m| names(m) == ["residential", "dog_loose"]));

    let journal = std::fs::read_to_string(out.join("journal.jsonl")).unwrap();
    let records: Vec<revelio::journal::Record> = journal.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(records.len(), 150);
    let mut shown = std::collections::HashSet::new();
    for r in records.iter().filter(|r| r.outcome.asked_a_model()) {
        assert!(shown.insert((r.set.clone(), r.image.clone())), "{:?} shown {} twice", r.set, r.image);
    }
    let sampler = revelio::sample::Sampler::new(&d);
    for r in &records {
        assert!(out.join("images").join(format!("{}.png", r.image)).is_file(), "{r:?}");
        // One figure per entity a concept placed in the scene shown.
        let set = d.parse_set(&r.set).unwrap();
        let placed = sampler.sample(set, r.seed).unwrap().entities.iter().filter(|e| e.concept.is_some()).count();
        assert_eq!(r.visibility.len(), placed, "{r:?}");
        if r.outcome != Outcome::Invisible {
            assert!(r.visibility.iter().all(|v| seen.holds(v.pixels, v.contrast)), "{r:?}");
        }
    }
    let report = std::fs::read_to_string(out.join("report/index.html")).unwrap();
    assert!(report.contains("delivery") && report.contains("dog_loose"), "the report names the domain and its finding");
}

/// `bench search` says, per planted mode, how often each algorithm recovered it, and how much of
/// such a mode any search could reach at this budget were its parts silent: a strong pair is
/// within reach, a four-concept needle (most of the driving lattice's 20 008 valid 4-sets are
/// out of reach of 150 inferences) is not.
#[test]
fn bench_reports_each_planted_mode_and_its_reach() {
    let dir = tempfile::tempdir().unwrap();
    let profile = dir.path().join("two.toml");
    std::fs::write(
        &profile,
        "name = \"two\"\nbase_error = 0.02\n\
         [[mode]]\nconcepts = [\"debris_far\", \"town_town02\"]\nerror = 0.95\n\
         [[mode]]\nconcepts = [\"cone\", \"far\", \"weather_wet\", \"town_town01\"]\nerror = 0.9\n\
         [[mode]]\nconcepts = [\"cyclist\"]\nerror = 0.65\n",
    )
    .unwrap();
    let args = ["bench", "search", "--profile", profile.to_str().unwrap(), "--seeds", "2", "--budget", "100"];
    let args: Vec<&str> = args.into_iter().chain(["--shrink", "50", "--algos", "random,interact"]).collect();
    let (code, out, err) = revelio(&[&args[..], &["--json"]].concat());
    assert_eq!(code, 0, "{err}");
    let results: serde_json::Value = serde_json::from_str(&out).unwrap();
    for r in results.as_array().unwrap() {
        let modes = r["planted"].as_array().unwrap();
        let sizes: Vec<usize> = modes.iter().map(|m| m["concepts"].as_array().unwrap().len()).collect();
        assert_eq!(sizes, [2, 4, 1], "{out}");
        assert_eq!(modes[0]["error"].as_f64(), Some(0.95));
        assert_eq!(modes[0]["reach"].as_f64(), Some(1.0), "356 pairs, 10 in each 5-set: 150 sets hold them all");
        let needle = modes[1]["reach"].as_f64().unwrap();
        assert!(needle > 0.0 && needle < 150.0 * 5.0 / 19_000.0, "{needle}");
        // The per-mode shares average to the run's recovered and exact.
        for (per, all) in [("recovered", "core_recovered"), ("exact", "exact")] {
            let mean: f64 = modes.iter().map(|m| m[per].as_f64().unwrap()).sum::<f64>() / 3.0;
            assert!((mean - r[all]["mean"].as_f64().unwrap()).abs() < 1e-9, "{per}: {out}");
        }
        // The modes a search must find leave out the one inside the zone (0.65 < τ + δ).
        let must: f64 = modes[..2].iter().map(|m| m["recovered"].as_f64().unwrap()).sum::<f64>() / 2.0;
        assert!((must - r["must_find"]["mean"].as_f64().unwrap()).abs() < 1e-9, "{out}");
        // Each mode's runs are recovered or lost at one step; so are the must-find modes'.
        let lost = |l: &serde_json::Value| {
            ["untested", "not_failing", "not_sent", "unconfirmed"].iter().map(|k| l[k].as_f64().unwrap()).sum::<f64>()
        };
        for m in modes {
            assert!((m["recovered"].as_f64().unwrap() + lost(&m["lost"]) - 1.0).abs() < 1e-9, "{m}");
        }
        assert!((must + lost(&r["must_find_lost"]) - 1.0).abs() < 1e-9, "{out}");
    }
    let (code, out, err) = revelio(&args);
    assert_eq!(code, 0, "{err}");
    let table = out.split("planted modes:").nth(1).unwrap_or_else(|| panic!("no planted table:\n{out}"));
    let header = table.lines().nth(1).unwrap();
    assert!(header.split_whitespace().eq(["mode", "error", "reach", "random", "interact"]), "{table}");
    assert!(table.contains("town_town02 + debris_far") && table.contains("  0.95   100%"), "{table}");
    assert!(table.contains("error ≥ τ + δ (0.70): recovered"), "{table}");
    let lost = table.split("where the modes not recovered were lost").nth(1).unwrap_or_else(|| panic!("{table}"));
    let rows: Vec<&str> = lost.lines().skip(2).take(2).collect();
    assert!(rows[0].starts_with("random ") && rows[1].starts_with("interact "), "{lost}");
    assert_eq!(rows[1].split_whitespace().filter(|w| w.ends_with('%')).count(), 4, "{lost}");
}

/// Issue 29: resuming never changes the plan silently. The same command with its flags left
/// out takes the run's recorded values and adds no journal line; a larger `--budget` says so
/// before its first model call; a smaller one is refused with the count made.
#[test]
fn a_resume_takes_the_recorded_plan_and_says_when_it_extends_it() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    let profile = dir.path().join("slow.toml");
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/sim/driving_paper.toml"))
        .unwrap()
        .replace("latency_ms = 0", "latency_ms = 1500");
    std::fs::write(&profile, text).unwrap();
    let model = format!("sim:{}", profile.display());
    let out = dir.path().join("run");
    let out_s = out.to_str().unwrap();
    let base = ["search", "domains/driving.rev", "--model", &model, "--out", out_s];
    let (code, table, err) = revelio(&[&base[..], &["--renderer", "none", "--budget", "32", "--seed", "3"]].concat());
    assert_eq!(code, 0, "{err}");
    assert!(table.starts_with("interact on `driving`"), "the default search: {table}");
    let lines = || std::fs::read_to_string(out.join("journal.jsonl")).unwrap().lines().count();
    let made = lines();
    assert!(made <= 32, "{made} model calls for `--budget 32`");
    assert!(table.contains(&format!("budget: {made} of 32 model calls (screening ")), "{table}");
    // No flags: the recorded renderer, budget, seed and width; nothing asked.
    let (code, _, err) = revelio(&base);
    assert_eq!(code, 0, "{err}");
    assert_eq!(lines(), made, "a rerun with no flags adds no journal line: {err}");
    assert!(!err.contains("extending"), "{err}");
    // Lower: refused with what the run holds.
    let (code, _, err) = revelio(&[&base[..], &["--budget", "20"]].concat());
    assert_eq!(code, 1);
    assert!(err.contains(&format!("it is a run of 32 model calls and has made {made}")), "{err}");
    // Higher: the extension is said before the first new call (each takes 1.5 s).
    let mut child = Command::new(env!("CARGO_BIN_EXE_revelio"))
        .args([&base[..], &["--budget", "1000"]].concat())
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let stderr = std::io::BufReader::new(child.stderr.take().unwrap());
    let mut said = None;
    for line in stderr.lines() {
        let line = line.unwrap();
        if line.contains("extending") {
            said = Some((line, lines()));
            break;
        }
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let (line, then) = said.expect("the extension is announced");
    assert_eq!(line, format!("extending {out_s} from 32 to 1 000 model calls"));
    assert_eq!(then, made, "no model call had been made when it was said");
}
