//! Sequential sampling and the shrink phase through the journaled runner: resume, budgets,
//! `summary.json`.
use super::runner;
use super::tests::{block_on, config, journal_lines, killed_copy, setup};
use crate::search::Algo;

#[test]
fn a_run_killed_during_the_shrink_phase_resumes_to_the_same_summary() {
    use rand::{RngExt, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    let full = dir.path().join("full");
    let (s, space) = setup(&full, 8);
    let mut cfg = config(&s, Algo::Gpts);
    cfg.params.budget = 350;
    cfg.params.shrink = 150;
    let reference = block_on(runner::search(&s, &cfg, &space)).unwrap().summary;
    let shrink = reference.shrink.as_ref().expect("the shrink phase ran");
    assert!(shrink.inferences > 0 && shrink.inferences <= 150, "{shrink:?}");
    assert!(!reference.cores.is_empty());
    let summary_json = std::fs::read(full.join("summary.json")).unwrap();
    let journal = std::fs::read(full.join("journal.jsonl")).unwrap();
    let text = String::from_utf8(journal.clone()).unwrap();
    let start = text.find("\"phase\":\"shrink\"").map(|i| text[..i].rfind('\n').map_or(0, |n| n + 1)).unwrap();
    assert_eq!(text[start..].lines().filter(|l| l.contains("\"phase\":\"shrink\"")).count() as u64, shrink.inferences);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(14);
    let cuts =
        [start, start + 1, journal.len() - 1].into_iter().chain((0..5).map(|_| rng.random_range(start..journal.len())));
    for (k, cut) in cuts.enumerate() {
        let (run, kept) = killed_copy(&full, &journal[..cut], &dir.path().join(format!("killed{k}")));
        let (s, space) = setup(&run, 8);
        let r = block_on(runner::search(&s, &cfg, &space)).unwrap();
        assert_eq!(r.summary, reference, "cut at byte {cut}");
        assert_eq!(std::fs::read(run.join("summary.json")).unwrap(), summary_json, "cut at byte {cut}");
        assert_eq!(r.replayed, kept, "every finished observation is replayed, none asked twice");
        assert_eq!(journal_lines(&run), journal_lines(&full));
    }
}

#[test]
fn summary_json_carries_intervals_cores_and_families() {
    let dir = tempfile::tempdir().unwrap();
    let (s, space) = setup(dir.path(), 8);
    let mut cfg = config(&s, Algo::Beam);
    cfg.params.budget = 350;
    cfg.params.shrink = 150;
    cfg.params.max_samples = Some(15);
    let r = block_on(runner::search(&s, &cfg, &space)).unwrap();
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("summary.json")).unwrap()).unwrap();
    for list in ["sets", "failure_modes", "cores"] {
        for row in v[list].as_array().unwrap() {
            let ci = row["ci95"].as_array().unwrap();
            let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
            let fr = row["fr"].as_f64().unwrap_or(0.5);
            assert!(0.0 <= lo && lo <= fr && fr <= hi && hi <= 1.0, "{list}: {row}");
        }
    }
    // Search: never more than M per set, never past the budget; some set was topped up.
    let sets = &r.summary.sets;
    assert!(sets.iter().all(|x| (5..=15).contains(&x.observations)));
    assert!(sets.iter().any(|x| x.observations > 5));
    assert!(r.summary.metrics.inferences <= 200);
    // Cores: ordered by FR, each counting the failure modes that contain it.
    let cores = &r.summary.cores;
    assert!(!cores.is_empty());
    assert!(cores.windows(2).all(|w| w[0].set.fr >= w[1].set.fr));
    let contains = |big: &[String], small: &[String]| small.iter().all(|c| big.contains(c));
    for (i, c) in cores.iter().enumerate() {
        let n = r.summary.failure_modes.iter().filter(|m| contains(&m.concepts, &c.set.concepts)).count();
        assert_eq!(c.supersets, n);
        assert!(contains(&c.shrunk_from, &c.set.concepts));
        assert_eq!(v["cores"][i]["supersets"], n);
    }
    for m in &r.summary.failure_modes {
        match m.core {
            Some(i) => assert!(contains(&m.concepts, &cores[i].set.concepts)),
            None => assert!(cores.iter().all(|c| !contains(&m.concepts, &c.set.concepts))),
        }
    }
    // {c2, c5} is the planted pair: it is a core.
    assert!(cores.iter().any(|c| c.set.concepts == ["c2", "c5"]), "{cores:?}");
    let lines = journal_lines(dir.path());
    let shrink_lines = lines.iter().filter(|l| l.contains("\"phase\":\"shrink\"")).count() as u64;
    assert_eq!(shrink_lines, r.summary.shrink.as_ref().unwrap().inferences);
}

/// Issue 29: `--budget` caps every phase of every algorithm, the shrink phase and fresh
/// confirmation included; the paper's algorithms search with `budget − shrink`.
#[test]
fn every_algorithm_makes_at_most_budget_model_calls_with_shrink_on() {
    let dir = tempfile::tempdir().unwrap();
    for algo in Algo::ALL {
        for max_samples in [None, Some(15)] {
            let out = dir.path().join(format!("{algo:?}-{max_samples:?}"));
            let (s, space) = setup(&out, 4);
            let mut cfg = config(&s, algo);
            cfg.params.budget = 200;
            cfg.params.shrink = 50;
            cfg.params.beam_budget = 75;
            cfg.params.batch = 4;
            cfg.params.max_samples = max_samples;
            let r = block_on(runner::search(&s, &cfg, &space)).unwrap();
            let what = format!("{algo:?} {max_samples:?}");
            let lines = journal_lines(&out).len() as u64;
            assert!(lines <= 200, "{what}: {lines} model calls");
            assert_eq!(lines, r.summary.calls_made(), "{what}");
            if algo != Algo::Interact {
                assert!(r.summary.metrics.inferences <= 150, "{what}: the search phase is budget − shrink");
            }
            let sh = r.summary.shrink.as_ref().expect("the shrink phase ran");
            let c = r.summary.confirmation.as_ref().expect("fresh confirmation ran");
            let plan = cfg.params.plan();
            assert_eq!(
                sh.budget,
                // The shrink phase's cores: the candidates but the unexplained minimal failure modes.
                plan.shrink_cap(r.summary.metrics.inferences, c.candidates - c.unexplained),
                "{what}: the shrink phase gets what is left but fresh confirmation's share per candidate and one more"
            );
            assert_eq!(
                c.budget,
                200 - r.summary.metrics.inferences - sh.inferences,
                "{what}: confirmation gets the rest"
            );
            assert_eq!(r.summary.budget, Some(200));
        }
    }
}

#[test]
fn sequential_validation_tops_up_undecided_sets_only() {
    let dir = tempfile::tempdir().unwrap();
    let (s, space) = setup(dir.path(), 4);
    let cfg = config(&s, Algo::Beam);
    let r = block_on(runner::search(&s, &cfg, &space)).unwrap();
    let v = block_on(runner::validate(&s, &cfg, &r.summary, 5, 10, Some(30))).unwrap();
    assert_eq!(v.max_samples, Some(30));
    let rule = crate::search::Rule::sequential(10, 30, cfg.params.threshold);
    for x in &v.sets {
        let o = x.validation.observations;
        assert!((10..=30).contains(&o), "{o}");
        let settled = !rule.straddles(x.validation.wrong, x.validation.answered);
        assert!(o == 30 || settled, "stopped early only once settled: {x:?}");
    }
    let lines = journal_lines(dir.path());
    let n = lines.iter().filter(|l| l.contains("\"phase\":\"validate\"")).count() as u32;
    assert_eq!(n, v.sets.iter().map(|x| x.validation.observations).sum::<u32>());
    assert_eq!(block_on(runner::validate(&s, &cfg, &r.summary, 5, 10, Some(30))).unwrap(), v, "resumes");
    let e = block_on(runner::validate(&s, &cfg, &r.summary, 5, 10, Some(4))).unwrap_err();
    assert_eq!(e.exit_code(), 2, "a usage error");
    assert_eq!(e.to_string(), "invalid `--max-samples`: must be at least `--samples` (10), got 4");
}

/// Raising `--budget` and `--shrink` on a run with sequential sampling and a shrink phase extends
/// it: the search replays its decisions (top-ups included) and goes on, the shrink phase works on
/// the larger search's failure modes, and the result is the larger run's. Lowering the shrink
/// budget, or raising it at the search's expense, is refused as lowering the budget is.
#[test]
fn raising_the_budgets_extends_a_sequential_run_with_its_shrink_phase() {
    let dir = tempfile::tempdir().unwrap();
    for algo in [Algo::Random, Algo::Beam, Algo::Gpts] {
        let (small, big) = (dir.path().join(format!("{algo:?}")), dir.path().join(format!("{algo:?}-fresh")));
        let (s, space) = setup(&small, 4);
        let mut cfg = config(&s, algo);
        cfg.params.max_samples = Some(15);
        cfg.params.budget = 140;
        cfg.params.beam_budget = 50;
        cfg.params.shrink = 40;
        let first = block_on(runner::search(&s, &cfg, &space)).unwrap();
        assert!(first.summary.shrink.as_ref().is_some_and(|sh| sh.inferences > 0), "{algo:?}: the shrink phase ran");
        let searched = first.summary.metrics.inferences;
        cfg.params.budget = 290;
        cfg.params.shrink = 80;
        let extended = block_on(runner::search(&s, &cfg, &space)).unwrap();
        assert!(extended.replayed >= searched, "{algo:?}: the smaller search's observations are all reused");
        let (f, _) = setup(&big, 4);
        let fresh = block_on(runner::search(&f, &cfg, &space)).unwrap();
        assert_eq!(extended.summary, fresh.summary, "{algo:?}");
        // The extended folder holds every observation the fresh run made (and the smaller run's
        // shrink phase, where it tested what the larger one did not).
        let kept = journal_lines(&small);
        assert!(journal_lines(&big).iter().all(|l| kept.contains(l)), "{algo:?}");
        cfg.params.shrink = 40;
        let e = block_on(runner::search(&s, &cfg, &space)).err().unwrap().to_string();
        assert!(e.contains("with `--shrink 40`: the run set aside 80 for shrinking and gave its search 210"), "{e}");
        // Moving budget from the search to the shrink phase would cut the search short: refused.
        cfg.params.shrink = 100;
        let e = block_on(runner::search(&s, &cfg, &space)).err().unwrap().to_string();
        assert!(e.contains("the search may not get less (now 190)"), "{e}");
    }
}
