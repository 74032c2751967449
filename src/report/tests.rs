//! The report on synthetic run folders (the real-run and browser checks are in `tests/report.rs`).
use std::path::{Path, PathBuf};

use super::*;
use crate::journal::{Journal, Phase, Record};
use crate::lattice::testkit::driving;
use crate::outcome::{Answer, Outcome};
use crate::run::runner::summarize;
use crate::run::summary::Spend;
use crate::run::summary::{RunConfig, ValidatedSet, Validation};
use crate::search::{Params, SetStats};

const HOSTILE: &str = "<script>alert(\"x\")</script> & <img src=x onerror=alert(1)> Answer: C";

fn png(shade: u8) -> Vec<u8> {
    let img = image::RgbImage::from_fn(64, 36, |x, y| image::Rgb([shade, (x * 4) as u8, (y * 7) as u8]));
    let mut out = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).unwrap();
    out
}

/// One set's observations: its concepts and outcomes (wrong answers name option C, right ones A).
struct Set(&'static [&'static str], &'static [Outcome]);

const SETS: &[Set] = &[
    Set(
        &["intersection_ego", "obstruction_near"],
        &[Outcome::Wrong, Outcome::Wrong, Outcome::Correct, Outcome::Wrong, Outcome::Wrong],
    ),
    Set(&["intersection_ego", "obstruction_near", "cone"], &[Outcome::Wrong; 5]),
    Set(&["debris_far"], &[Outcome::Wrong, Outcome::Wrong, Outcome::Wrong, Outcome::Correct, Outcome::Correct]),
    Set(&["town_town01"], &[Outcome::Correct, Outcome::Correct, Outcome::Unparsed, Outcome::Correct, Outcome::Correct]),
];

struct Fixture {
    _tmp: tempfile::TempDir,
    dir: PathBuf,
}

/// A run folder written through the journal, as a search would leave it.
fn fixture(renderer: &str) -> Fixture {
    let d = driving();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let config = RunConfig {
        format: crate::run::summary::RUN_FORMAT,
        domain_file: "driving.rev".into(),
        domain: d.name.clone(),
        domain_hash: d.identity().to_string(),
        model_spec: "sim:test.toml".into(),
        model: "sim:test@0".into(),
        endpoint: None,
        model_settings: Default::default(),
        renderer: renderer.into(),
        params: Params::default(),
    };
    let journal = Journal::open(&dir).unwrap();
    journal.write_config(&config).unwrap();
    let mut history = Vec::new();
    let mut shade = 0u8;
    for Set(names, outcomes) in SETS {
        let set = d.parse_set(names).unwrap();
        let mut stats = SetStats::new(set);
        for (i, &outcome) in outcomes.iter().enumerate() {
            shade = shade.wrapping_add(37);
            let image = if renderer == "none" {
                crate::hash::sha256_hex(format!("scene {shade}").as_bytes())
            } else {
                journal.store_image(&png(shade)).unwrap()
            };
            let (answer, raw) = match outcome {
                Outcome::Correct => (Answer::Option(0), "Answer: A".to_string()),
                Outcome::Wrong if i == 0 => (Answer::Option(2), HOSTILE.to_string()),
                Outcome::Wrong if i == 1 => {
                    (Answer::Option(2), format!("{} Answer: C", "The lane looks clear. ".repeat(12)))
                }
                Outcome::Wrong => (Answer::Option(2), "<think>a lamp is green</think>Answer: C".to_string()),
                _ => (Answer::Unparsed, "I cannot tell.".to_string()),
            };
            journal
                .append(&Record {
                    seed: i as u64,
                    image,
                    prompt: "p".into(),
                    raw,
                    answer: Some(answer),
                    latency_ms: 1,
                    ..Record::test(Phase::Search, names, i as u32, outcome)
                })
                .unwrap();
            stats.add(outcome);
        }
        history.push(stats);
    }
    journal.sync().unwrap();
    let summary = summarize(&d, &config, 1000, &history, &Default::default(), Spend::default());
    journal.write_json("summary.json", &summary).unwrap();
    Fixture { _tmp: tmp, dir }
}

fn validate(f: &Fixture, concepts: &[&str], wrong: u32, answered: u32) {
    let row = |w: u32, n: u32| SetRow {
        concepts: concepts.iter().map(|s| s.to_string()).collect(),
        fr: Some(f64::from(w) / f64::from(n)),
        ci95: crate::search::interval::wilson(w, n),
        wrong: w,
        answered: n,
        observations: n,
        unanswered: Default::default(),
        core: None,
    };
    let v = Validation {
        top: 1,
        samples: answered,
        max_samples: None,
        sets: vec![ValidatedSet { search: row(4, 5), validation: row(wrong, answered) }],
        mean_fr: f64::from(wrong) / f64::from(answered),
        sd_fr: 0.0,
        consistent: 0,
        spend: Spend::default(),
        repeated_scenes: Vec::new(),
    };
    let name = crate::run::summary::validation_file(v.top, v.samples, v.max_samples);
    std::fs::write(f.dir.join(name), serde_json::to_string(&v).unwrap()).unwrap();
}

/// Local files an HTML page links (`src` and `href` values that are not anchors).
fn linked_files(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for attr in ["src=\"", "href=\""] {
        for part in html.split(attr).skip(1) {
            let value = part.split('"').next().unwrap();
            if !value.starts_with('#') && !value.starts_with("data:") {
                out.push(value.to_string());
            }
        }
    }
    out
}

fn write_report(f: &Fixture, out: &Path) -> String {
    let run = load(&f.dir).unwrap();
    let d = driving();
    write(&run, Some(&d), out).unwrap();
    std::fs::read_to_string(out.join("index.html")).unwrap()
}

#[test]
fn page_shows_every_core_with_its_images_and_escapes_replies() {
    let f = fixture("builtin");
    validate(&f, &["intersection_ego", "obstruction_near"], 15, 20);
    let out = f.dir.join("report");
    let html = write_report(&f, &out);
    // Cores stand in as minimal failure modes: {light_green, obstruction_near} (one superset),
    // then {debris_far}.
    let cores: Vec<&str> = html.split("data-concepts=\"").skip(1).map(|p| p.split('"').next().unwrap()).collect();
    assert_eq!(cores, ["intersection_ego + obstruction_near", "debris_far"]);
    // A GPTS run lists GPTS's parameters, not interact's.
    let params = html.split("parameters: ").nth(1).expect("a parameters line").split('<').next().unwrap();
    assert!(params.contains("beam_budget 500") && params.contains("seed 0"), "{params}");
    assert!(!params.contains("surrogate") && !params.contains("supersets"), "{params}");
    // No reply reaches the page unescaped.
    assert!(!html.contains("<script") && !html.contains("<img src=x"), "an unescaped reply");
    assert!(
        html.contains("&#60;script&#62;alert(&#34;x&#34;)&#60;/script&#62; &#38; &#60;img src=x onerror=alert(1)&#62;")
    );
    // Thinking is left out of the preview but kept in the full text.
    assert!(html.contains("<p class=\"reply\">Answer: C</p>"), "thinking shown in a preview");
    assert!(html.contains("&#60;think&#62;a lamp is green&#60;/think&#62;Answer: C</pre>"));
    // Expected and given answers, the deciding rule and the validated FR.
    assert!(html.contains("<b>A · stop</b>") && html.contains("<b>C · go</b>"));
    assert!(
        html.contains("<code>near_in_lane</code>"),
        "{}",
        html.split("class=\"verdict\"").nth(1).unwrap_or("no verdict")
    );
    assert!(html.contains("validated: <b>75% [53–89%] of 20</b>"), "validated FR missing");
    assert!(html.contains("validated: <b>not among the top 1 validated</b>"));
    let links = linked_files(&html);
    let images = links.iter().filter(|l| l.starts_with("thumbs/")).count();
    assert_eq!(images, 10, "five observations of each core");
    for l in &links {
        assert!(out.join(l).is_file(), "the page links a missing file `{l}`");
    }
    // Full-size images are the run's own files (linked or copied).
    for l in links.iter().filter(|l| l.starts_with("images/")) {
        assert_eq!(std::fs::read(out.join(l)).unwrap(), std::fs::read(f.dir.join(l)).unwrap());
    }
}

#[test]
fn cores_and_intervals_from_the_summary_are_used_when_present() {
    let f = fixture("builtin");
    let path = f.dir.join("summary.json");
    let mut s: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    // As a shrunk run writes them: a core is a set row with its supersets (itself included).
    s["cores"] = serde_json::json!([{
        "concepts": ["obstruction_near"], "fr": 0.9, "ci95": [0.6, 0.98], "wrong": 9, "answered": 10,
        "observations": 10, "supersets": 2, "minimal": false,
        "shrunk_from": ["intersection_ego", "obstruction_near", "cone"]
    }]);
    s["shrink"] = serde_json::json!({"budget": 100, "inferences": 42, "max_samples": 20, "new_sets": 3, "refuted": [
        {"concepts": ["cone"], "fr": 0.2, "ci95": [0.05, 0.5], "wrong": 2, "answered": 10, "observations": 10}
    ], "not_distinct": [
        {"concepts": ["debris_far", "cone"], "fr": 0.62, "ci95": [0.47, 0.75], "wrong": 25, "answered": 40, "observations": 40,
         "by": {"concepts": ["debris_far"], "fr": 0.55, "ci95": [0.4, 0.69], "wrong": 22, "answered": 40, "observations": 40}}
    ]});
    for m in s["failure_modes"].as_array_mut().unwrap() {
        m["ci95"] = serde_json::json!([0.11, 0.22]);
    }
    let borderline = serde_json::json!({"concepts": ["pedestrian", "cone"], "fr": 0.65, "ci95": [0.45, 0.82],
        "wrong": 52, "answered": 80, "observations": 80, "e_value": 3.0, "status": "borderline"});
    s["borderline"] = serde_json::json!([borderline.clone()]);
    s["confirmation"] = serde_json::json!({"q": 0.05, "delta": 0.1, "cap": 40, "extended": 80, "budget": 90,
        "inferences": 80, "candidates": 1, "confirmed": 0, "checked": [borderline]});
    std::fs::write(&path, s.to_string()).unwrap();
    let run = load(&f.dir).unwrap();
    let findings = run.findings();
    assert!(findings.shrunk);
    assert_eq!(findings.cores.len(), 1);
    assert_eq!(findings.mode_core, vec![Some(0), Some(0), None]);
    let out = f.dir.join("report");
    let html = write_report(&f, &out);
    assert!(html.contains("data-concepts=\"obstruction_near\""));
    assert!(html.contains("95% CI [60–98%]"));
    assert!(html.contains("[11–22%]"), "the summary's intervals are shown");
    assert!(html.contains("<b>9</b> wrong of <b>10</b> answered"));
    assert!(html.contains("<b>2</b> failure modes of the search contain it"));
    assert!(html.contains("shrunk from <code>intersection_ego + obstruction_near + cone</code>"));
    assert!(html.contains("the shrink budget ran out"));
    assert!(html.contains("shrunk in 42 inferences"));
    let refuted = html.split("id=\"refuted\"").nth(1).expect("a 'refuted' section");
    assert!(refuted.contains("<code>cone</code>"));
    let flat = html.split("id=\"not-distinct\"").nth(1).expect("a 'not distinct' section");
    let flat = flat.split("</section>").next().unwrap();
    assert!(flat.contains("<code>debris_far</code> + <code>cone</code>"), "the set");
    assert!(
        flat.contains("62%") && flat.contains("55%") && flat.contains("[40–69%]"),
        "the set's and its part's rates"
    );
    assert!(html.contains("href=\"#not-distinct\""), "in the navigation");
    let borderline = html.split("id=\"borderline\"").nth(1).expect("a 'borderline' section");
    let borderline = borderline.split("</section>").next().unwrap();
    assert!(borderline.contains("<code>pedestrian</code> + <code>cone</code>"), "{borderline}");
    assert!(
        borderline.contains("the per-set cap of 40 observations (80 once every candidate had had its turn"),
        "the caps it reached"
    );
    assert!(html.contains("href=\"#borderline\""), "in the navigation");
    // {debris_far} contains no core: it is listed under the other failure modes.
    let others = html.split("id=\"others\"").nth(1).expect("an 'other failure modes' section");
    assert!(others.contains("<code>debris_far</code>"));
    let csv = std::fs::read_to_string(out.join("failure_modes.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 4);
    assert!(lines[0].starts_with("rank,concepts,size,fr,ci95_lo,ci95_hi,wrong,answered,observations,core,"));
    assert_eq!(
        lines[1],
        "1,intersection_ego + obstruction_near + cone,3,1.0000,0.1100,0.2200,5,5,5,obstruction_near,,,,"
    );
}

#[test]
fn csv_tables_hold_every_set_and_outcome() {
    let f = fixture("builtin");
    let out = f.dir.join("report");
    assert!(write_report(&f, &out).contains("validated: <b>run not validated</b>"));
    let sets = std::fs::read_to_string(out.join("sets.csv")).unwrap();
    let lines: Vec<&str> = sets.lines().collect();
    assert_eq!(lines[0], "order,concepts,size,fr,ci95_lo,ci95_hi,wrong,answered,observations,failure_mode,unparsed");
    assert_eq!(lines.len(), 1 + SETS.len());
    assert_eq!(lines[4], "4,town_town01,1,0.0000,0.0000,0.6838,0,4,5,false,1");
}

#[test]
fn a_run_without_images_shows_none_and_links_nothing_missing() {
    let f = fixture("none");
    let out = f.dir.join("report");
    let html = write_report(&f, &out);
    assert!(!html.contains("<img"));
    assert!(html.contains("no image (renderer none)"));
    for l in linked_files(&html) {
        assert!(out.join(&l).is_file(), "the page links a missing file `{l}`");
    }
}

#[test]
fn a_refresh_removes_images_no_longer_shown_and_nothing_else() {
    let f = fixture("builtin");
    let out = f.dir.join("elsewhere");
    std::fs::create_dir_all(out.join("images")).unwrap();
    let stale = out.join("images").join(format!("{}.png", "0".repeat(64)));
    let mine = out.join("images").join("mine.png");
    std::fs::write(&stale, b"old").unwrap();
    std::fs::write(&mine, b"keep").unwrap();
    write_report(&f, &out);
    assert!(!stale.exists() && mine.exists());
    let thumbs = std::fs::read_dir(out.join("thumbs")).unwrap().count();
    assert_eq!(thumbs, 10);
    // Written again, nothing changes.
    let before = std::fs::read_to_string(out.join("index.html")).unwrap();
    assert_eq!(write_report(&f, &out), before);
}

#[test]
fn the_run_folder_itself_is_refused_and_a_missing_run_is_named() {
    let f = fixture("builtin");
    let run = load(&f.dir).unwrap();
    let e = write(&run, None, &f.dir).unwrap_err();
    assert!(e.starts_with("the report cannot be written into the run folder"), "{e}");
    let e = load(&f.dir.join("nope")).err().unwrap();
    assert!(e.contains("nope` is not a run folder"), "{e}");
    // Without the domain the page still renders, with letters only.
    let html = {
        write(&run, None, &f.dir.join("report")).unwrap();
        std::fs::read_to_string(f.dir.join("report/index.html")).unwrap()
    };
    assert!(html.contains("<b>A</b>") && !html.contains("near_in_lane"));
}

#[test]
fn invisible_observations_are_counted_and_an_unknown_outcome_is_a_clear_error() {
    let f = fixture("builtin");
    let path = f.dir.join("journal.jsonl");
    let invisible = Record {
        seed: 5,
        image: crate::hash::sha256_hex(b"unseen"),
        prompt: "p".into(),
        raw: "`debris` stayed hidden in 4 scenes".into(),
        resamples: 4,
        ..Record::test(Phase::Search, &["debris_far"], 5, Outcome::Invisible)
    };
    let mut text = std::fs::read_to_string(&path).unwrap();
    text.push_str(&serde_json::to_string(&invisible).unwrap());
    text.push('\n');
    std::fs::write(&path, &text).unwrap();
    let html = write_report(&f, &f.dir.join("report"));
    let breakdown = html.split("<thead><tr><th>outcome</th>").nth(1).expect("an outcome breakdown");
    assert!(breakdown.contains("<span class=\"badge o-other\">invisible</span></td><td class=\"num\">1</td>"));

    // A journal from a later revelio may hold an outcome this one does not know: the report
    // names the line instead of failing obscurely (or dropping it as a torn last line).
    let unknown = text.replacen("\"outcome\":\"invisible\"", "\"outcome\":\"melted\"", 1);
    assert_ne!(unknown, text);
    std::fs::write(&path, format!("{unknown}{}\n", text.lines().next().unwrap())).unwrap();
    let e = load(&f.dir).err().expect("an unknown outcome is refused");
    assert!(e.contains("journal.jsonl") && e.contains(&format!("line {}", text.lines().count())), "{e}");
}

/// A probe, a transfer and visibility figures in a run folder: the sections show them, escaped,
/// with their counts and intervals; the CSV tables hold them; a damaged `probe.json` costs its
/// section only.
#[test]
fn probe_transfer_and_visibility_sections() {
    use crate::analysis::probe::{Marks, ProbeReport, ProbedSet, Thresholds};
    use crate::analysis::transfer::{TransferReport, table};
    use crate::render::EntityVisibility;

    let f = fixture("builtin");
    // Visibility: the first observation of the first core was drawn three times before its
    // debris showed; a search observation of {debris_far} stayed invisible.
    let path = f.dir.join("journal.jsonl");
    let mut lines: Vec<Record> =
        std::fs::read_to_string(&path).unwrap().lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    lines[0].resamples = 3;
    lines[0].visibility = vec![
        EntityVisibility {
            entity: "debris".into(),
            concept: Some("obstruction_near".into()),
            pixels: 412,
            contrast: 0.2134,
        },
        EntityVisibility { entity: "tree_3".into(), concept: None, pixels: 90, contrast: 0.5 },
    ];
    let mut hidden = lines[11].clone();
    (hidden.obs, hidden.outcome, hidden.answer, hidden.resamples) = (5, Outcome::Invisible, None, 5);
    lines.push(hidden);
    let text: String = lines.iter().map(|r| serde_json::to_string(r).unwrap() + "\n").collect();
    std::fs::write(&path, text).unwrap();

    let probed = |concepts: &[&str], wrong: u32, marks: &[(&str, Marks)]| ProbedSet {
        concepts: concepts.iter().map(|c| c.to_string()).collect(),
        wrong,
        answered: 5,
        marks: marks.iter().map(|(c, m)| (c.to_string(), *m)).collect(),
    };
    let seen = Marks { pos_correct: 5, pos_total: 5, neg_correct: 4, neg_total: 5, unanswered: 0 };
    let blind = Marks { pos_correct: 1, pos_total: 5, neg_correct: 0, neg_total: 4, unanswered: 1 };
    let sets = [
        probed(&["debris_far"], 4, &[("debris_far", blind)]),
        probed(&["<b>cone</b>", "debris_far"], 5, &[("debris_far", blind), ("<b>cone</b>", seen)]),
        probed(&["<b>cone</b>"], 1, &[("<b>cone</b>", seen)]),
    ];
    let t = Thresholds { min_n: 1, ..Thresholds::default() };
    let probe = ProbeReport::new("sim:<evil>@1".into(), &sets, 5, &t, Spend::default());
    std::fs::write(f.dir.join("probe.json"), serde_json::to_string(&probe).unwrap()).unwrap();
    let d = driving();
    let stats = |w: u32, r: u32| {
        let mut s = SetStats::new(d.parse_set(&["debris_far"]).unwrap());
        (0..w).for_each(|_| s.add(Outcome::Wrong));
        (0..r).for_each(|_| s.add(Outcome::Correct));
        s
    };
    let names = vec![vec!["debris_far".to_string()]];
    let transfer = TransferReport {
        transfer: table(
            "sim:test@0",
            &["sim:test@0".into(), "sim:other@1".into()],
            0.6,
            10,
            &names,
            &[Some(0.6)],
            &[vec![stats(7, 3)], vec![stats(2, 8)]],
            &[vec!["town_town01".to_string()]],
            &[vec![stats(1, 9)], vec![stats(1, 9)]],
        ),
        spend: vec![Spend::default(); 2],
    };
    std::fs::write(f.dir.join("transfer.json"), serde_json::to_string(&transfer).unwrap()).unwrap();

    let out = f.dir.join("report");
    let html = write_report(&f, &out);
    // Visibility on the card and in its section.
    assert!(html.contains("<div class=\"seen\">debris (obstruction_near): 412 px · contrast 0.213</div>"));
    assert!(!html.contains("tree_3"), "scenery is not a concept's entity");
    assert!(html.contains("<b>3 scenes redrawn</b>"));
    assert!(html.contains("visibility: 1 of 5 observations needed resampling (3 scenes redrawn)"));
    assert!(
        html.contains("visibility: 1 of 6 observations needed resampling (5 scenes redrawn); 1 stayed invisible (never shown to the model)"),
        "{{debris_far}}'s card"
    );
    let vis = html.split("<section id=\"visibility\">").nth(1).expect("a visibility section");
    assert!(
        vis.contains("<tr><td>search</td><td class=\"num\">21</td><td class=\"num\">1</td><td class=\"num\">2</td><td class=\"num\">8</td><td class=\"num\">1</td></tr>"),
        "{}",
        &vis[..vis.find("</table>").unwrap()]
    );
    assert!(vis.contains("<a href=\"#core-1\"><code>intersection_ego + obstruction_near</code></a>"));
    // Recognition vs reasoning, escaped.
    let p = html.split("<section id=\"probe\">").nth(1).expect("a probe section");
    assert!(
        p.contains("<code>sim:&#60;evil&#62;@1</code>") && !html.contains("<evil>") && !html.contains("<b>cone</b>")
    );
    assert!(p.contains(
        "<tr><td><code>debris_far</code></td><td class=\"num\">11%</td><td class=\"num\">[0–44%]</td><td class=\"num\">2/18</td><td class=\"num\">90%</td><td class=\"num\">2</td><td><span class=\"badge o-wrong\">recognition</span></td></tr>"
    ), "{p}");
    assert!(p.contains("<span class=\"badge o-correct\">reasoning</span>"));
    assert!(p.contains("<code>&#60;b&#62;cone&#60;/b&#62;</code> + <code>debris_far</code>"), "the lift table");
    assert!(p.contains("2 statements were left unmarked"));
    // Transfer: MFRs with intervals, a set's FR per model, the random baseline.
    let t = html.split("<section id=\"transfer\">").nth(1).expect("a transfer section");
    assert!(t.contains("<td class=\"num\">70% <span class=\"ci\">[40–89%]</span></td><td class=\"num\">10% <span class=\"ci\">[2–40%]</span></td><td class=\"num\">7.0×</td><td class=\"num\">1/1</td>"), "{t}");
    assert!(t.contains("<td class=\"num hit\">70%") && t.contains("<td class=\"num\">20%"));
    assert!(t.contains("<code>town_town01</code>"));
    for nav in ["#visibility", "#probe", "#transfer"] {
        assert!(html.contains(&format!("<a href=\"{nav}\">")), "{nav} in the navigation");
    }
    let csv = std::fs::read_to_string(out.join("recognition.csv")).unwrap();
    assert!(csv.lines().any(|l| l.starts_with("debris_far,0.1111,0.0043,0.4421,2,18,2,0.9000,2,recognition")), "{csv}");
    let csv = std::fs::read_to_string(out.join("transfer.csv")).unwrap();
    assert_eq!(
        csv.lines().next().unwrap(),
        "kind,rank,concepts,search_fr,fr sim:test@0,answered sim:test@0,fr sim:other@1,answered sim:other@1"
    );
    assert_eq!(csv.lines().nth(1).unwrap(), "transferred,1,debris_far,0.6000,0.7000,10,0.2000,10");
    assert_eq!(csv.lines().nth(2).unwrap(), "random,1,town_town01,,0.1000,10,0.1000,10");

    // A damaged probe.json: the report says so and shows the rest; its table is removed.
    std::fs::write(f.dir.join("probe.json"), "{ not json").unwrap();
    let html = write_report(&f, &out);
    assert!(!html.contains("<section id=\"probe\">") && html.contains("<section id=\"transfer\">"));
    assert!(html.contains("Left out: invalid `probe.json` in"), "a note names the damaged file");
    assert!(!out.join("recognition.csv").exists());
}

/// A run over `n` independent concepts: `sets` evaluated pairs and triples spread over every
/// concept (three observations each, no images), failing wherever `c1` and `c2` meet.
fn wide_fixture(n: usize, sets: usize) -> (Fixture, Domain) {
    let d = crate::lattice::testkit::independent(n);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let config = RunConfig {
        format: crate::run::summary::RUN_FORMAT,
        domain_file: "wide.rev".into(),
        domain: d.name.clone(),
        domain_hash: d.identity().to_string(),
        model_spec: "sim:test.toml".into(),
        model: "sim:test@0".into(),
        endpoint: None,
        model_settings: Default::default(),
        renderer: "none".into(),
        params: Params::default(),
    };
    let journal = Journal::open(&dir).unwrap();
    journal.write_config(&config).unwrap();
    let mut history = Vec::new();
    let mut x = 12345u64;
    let mut next = |m: usize| {
        x = x.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((x >> 33) as usize) % m
    };
    for k in 0..sets {
        // Every concept turns up; one set in ten holds the failing pair (the first alone).
        let mut ids = if k == 0 {
            vec![1, 2]
        } else if k % 10 == 0 {
            vec![1, 2, k % n]
        } else {
            vec![k % n, next(n)]
        };
        if k % 2 == 0 && k > 0 {
            ids.push(next(n));
        }
        let set = crate::ir::ConceptSet::from_ids(ids.into_iter().map(|i| crate::ir::ConceptId(i as u32)));
        if set.len() < 2 {
            continue;
        }
        let names: Vec<String> = d.set_names(set).into_iter().map(String::from).collect();
        let fails = names.contains(&"c1".to_string()) && names.contains(&"c2".to_string());
        let mut stats = SetStats::new(set);
        for i in 0..3u32 {
            let outcome = if fails { Outcome::Wrong } else { Outcome::Correct };
            journal
                .append(&Record {
                    seed: u64::from(i),
                    image: crate::hash::sha256_hex(format!("{k} {i}").as_bytes()),
                    prompt: "p".into(),
                    raw: "Answer: A".into(),
                    answer: Some(Answer::Option(u32::from(fails))),
                    latency_ms: 1,
                    ..Record::test(Phase::Search, &names.iter().map(String::as_str).collect::<Vec<_>>(), i, outcome)
                })
                .unwrap();
            stats.add(outcome);
        }
        history.push(stats);
    }
    journal.sync().unwrap();
    let summary = summarize(&d, &config, 1_000_000, &history, &Default::default(), Spend::default());
    journal.write_json("summary.json", &summary).unwrap();
    (Fixture { _tmp: tmp, dir }, d)
}

#[test]
fn a_report_over_500_concepts_summarises_its_heatmap_and_tables() {
    use super::scale::{HEATMAP_CONCEPTS, TABLE_ROWS};
    let (f, d) = wide_fixture(500, 1500);
    let out = f.dir.join("report");
    let run = load(&f.dir).unwrap();
    write(&run, Some(&d), &out).unwrap();
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let svg = std::fs::read_to_string(out.join("heatmap.svg")).unwrap();
    // Every concept is in an evaluated set; the heatmap draws at most K of them, the failing
    // pair's among them, and says how many it leaves out.
    let findings = run.findings();
    assert_eq!(findings.concepts.len(), 500);
    let drawn: Vec<&str> = (0..500)
        .map(|i| format!("c{i}"))
        .filter(|c| svg.contains(&format!("\n{c}\n</text>")))
        .map(|c| {
            if c == "c1" {
                "c1"
            } else if c == "c2" {
                "c2"
            } else {
                "other"
            }
        })
        .collect();
    assert_eq!(drawn.len(), HEATMAP_CONCEPTS, "{} concepts labelled", drawn.len());
    assert!(drawn.contains(&"c1") && drawn.contains(&"c2"), "the core's concepts are drawn");
    assert!(svg.contains(&super::svg::hidden_note(HEATMAP_CONCEPTS, 500 - HEATMAP_CONCEPTS)), "no hidden line");
    assert!(html.contains(&format!("The plot draws {HEATMAP_CONCEPTS} of the 500 concepts")));
    // The tables stop at their cap with a line saying how many rows the CSV files hold besides.
    let concepts = html.split("<section id=\"concepts\">").nth(1).unwrap().split("</section>").next().unwrap();
    assert_eq!(concepts.matches("<tr><td><code>").count(), TABLE_ROWS);
    assert!(concepts.contains(&format!("{} more concepts, lower F(c)", 500 - TABLE_ROWS)), "{concepts}");
    let pairs_total = super::scale::ranked_pairs(&findings.pairs).len();
    let pairs = html.split("<section id=\"pairs\">").nth(1).unwrap().split("</section>").next().unwrap();
    assert_eq!(pairs.matches("<tr><td><code>").count(), TABLE_ROWS);
    assert!(pairs.contains(&format!("{} more pairs, lower rates", pairs_total - TABLE_ROWS)));
    assert!(pairs.contains(&format!("<summary>{pairs_total} evaluated pairs")));
    assert_eq!(std::fs::read_to_string(out.join("concepts.csv")).unwrap().lines().count(), 501);
    assert_eq!(std::fs::read_to_string(out.join("pairs.csv")).unwrap().lines().count(), pairs_total + 1);
    // Bounded: every pair drawn would be 250 000 cells, megabytes of SVG in the page.
    assert!(svg.len() < 200_000, "heatmap.svg is {} bytes", svg.len());
    assert!(html.len() < 600_000, "index.html is {} bytes", html.len());
}

#[test]
fn a_report_of_few_concepts_draws_and_lists_every_one() {
    let f = fixture("none");
    let html = write_report(&f, &f.dir.join("report"));
    assert!(!html.contains("The plot draws") && !html.contains("<tr class=\"more\">"));
    let svg = std::fs::read_to_string(f.dir.join("report/heatmap.svg")).unwrap();
    assert!(!svg.contains("not drawn"));
}
