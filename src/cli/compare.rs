//! `revelio compare RUN_DIR… [--csv FILE] [--html FILE]`: the paper's Table 2 across finished
//! runs (domain, model, algorithm, PFM, MFR, Div with 95 % intervals, failure modes, minimal
//! failure modes, spend), as a terminal table, a CSV file and a standalone HTML page.
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use crate::analysis::compare::{Rate, Row, RunFacts, row};
use crate::diag::terminal_safe;
use crate::run::summary;

#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// Finished `revelio search` run folders
    #[arg(required = true)]
    pub run_dirs: Vec<PathBuf>,
    /// Also write the table as CSV to FILE
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Also write the table as an HTML page to FILE
    #[arg(long, value_name = "FILE")]
    pub html: Option<PathBuf>,
    /// Print JSON instead of the table
    #[arg(long)]
    pub json: bool,
}

pub fn rows(dirs: &[PathBuf]) -> Result<Vec<Row>, crate::run::RunError> {
    dirs.iter()
        .map(|dir| {
            let (config, s) = summary::load_run(dir)?;
            Ok(row(&RunFacts {
                run: dir.display().to_string(),
                domain: s.domain.clone(),
                model: config.model.clone(),
                algo: s.algo.name().to_string(),
                seed: config.params.seed,
                budget: config.params.budget,
                shrink: config.params.shrink,
                sets: s.metrics.sets,
                inferences: s.metrics.inferences,
                failures: s.metrics.failures,
                failure_modes: s.failure_modes.iter().map(|r| r.concepts.clone()).collect(),
                shrunk_cores: s.shrink.is_some().then_some(s.cores.len()),
                calls: s.spend.calls,
                cost_usd: s.spend.cost_usd,
            }))
        })
        .collect()
}

pub fn run(args: CompareArgs) -> ExitCode {
    let rows = match rows(&args.run_dirs) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {}", terminal_safe(&e.to_string()));
            return ExitCode::from(e.exit_code());
        }
    };
    type Render = fn(&[Row]) -> String;
    let files: [(Option<&PathBuf>, Render); 2] = [(args.csv.as_ref(), csv), (args.html.as_ref(), html)];
    for (path, render) in files {
        if let Some(p) = path
            && let Err(e) = std::fs::write(p, render(&rows))
        {
            eprintln!("error: cannot write `{}`: {}", p.display(), e.to_string().to_lowercase());
            return ExitCode::from(1);
        }
    }
    let mut out = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut out, &rows).map_err(std::io::Error::from).and_then(|_| writeln!(out))
    } else {
        print_table(&mut out, &rows)
    };
    match written {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            eprintln!("error: cannot write the table: {e}");
            ExitCode::from(1)
        }
        _ => ExitCode::SUCCESS,
    }
}

/// The run's total budget, its shrink share included (as `--budget` counts it since run format
/// 3; a format 2 folder reads as its budget plus its shrink). The CSV and JSON keep `shrink`.
fn budget_text(r: &Row) -> String {
    r.budget.to_string()
}

fn rate(r: &Rate) -> String {
    format!("{:.1}% [{:.1}, {:.1}]", 100.0 * r.value, 100.0 * r.low, 100.0 * r.high)
}

fn div(r: &Option<Rate>) -> String {
    r.as_ref().map_or_else(|| "-".into(), |r| format!("{:.2} [{:.2}, {:.2}]", r.value, r.low, r.high))
}

/// The table for the terminal. Names and paths come from the run folders, which whoever shared
/// them controls: each is escaped ([`terminal_safe`]) before it is measured and printed.
pub fn print_table(w: &mut impl Write, rows: &[Row]) -> std::io::Result<()> {
    let safe: Vec<[String; 4]> =
        rows.iter().map(|r| [&r.domain, &r.model, &r.algo, &r.run].map(|s| terminal_safe(s).into_owned())).collect();
    let mw = safe.iter().map(|[_, model, ..]| model.len()).max().unwrap_or(5).max(5);
    writeln!(
        w,
        "{:<8}  {:<mw$}  {:<8}  {:>4}  {:>11}  {:>22}  {:>22}  {:>18}  {:>5}  {:>5}  {:>6}  {:>9}  run",
        "domain",
        "model",
        "algo",
        "seed",
        "budget",
        "PFM [95% CI]",
        "MFR [95% CI]",
        "Div [95% CI]",
        "modes",
        "cores",
        "calls",
        "spend"
    )?;
    for (r, [domain, model, algo, run]) in rows.iter().zip(&safe) {
        writeln!(
            w,
            "{:<8}  {:<mw$}  {:<8}  {:>4}  {:>11}  {:>22}  {:>22}  {:>18}  {:>5}  {:>5}  {:>6}  {:>9}  {}",
            domain,
            model,
            algo,
            r.seed,
            budget_text(r),
            rate(&r.pfm),
            rate(&r.mfr),
            div(&r.div),
            r.failure_modes,
            r.cores,
            r.calls,
            format!("${:.4}", r.cost_usd),
            run
        )?;
    }
    Ok(())
}

/// A CSV field, quoted when it holds a comma, quote or newline.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_string() }
}

pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "run,domain,model,algo,seed,budget,shrink,pfm,pfm_low,pfm_high,mfr,mfr_low,mfr_high,div,div_low,div_high,failure_modes,cores,sets,inferences,calls,cost_usd\n",
    );
    for r in rows {
        let d = |f: fn(&Rate) -> f64| r.div.as_ref().map_or_else(String::new, |x| format!("{:.4}", f(x)));
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{},{},{},{},{},{},{:.4}\n",
            field(&r.run),
            field(&r.domain),
            field(&r.model),
            field(&r.algo),
            r.seed,
            r.budget,
            r.shrink,
            r.pfm.value,
            r.pfm.low,
            r.pfm.high,
            r.mfr.value,
            r.mfr.low,
            r.mfr.high,
            d(|x| x.value),
            d(|x| x.low),
            d(|x| x.high),
            r.failure_modes,
            r.cores,
            r.sets,
            r.inferences,
            r.calls,
            r.cost_usd
        ));
    }
    s
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The page `compare --html FILE` writes: links to each run's report relative to FILE's folder.
pub fn html(rows: &[Row]) -> String {
    html_in(rows, Path::new("."), "Runs compared")
}

/// Where a run's report is, seen from a page in `dir`: relative when the run lies below it,
/// else absolute.
fn report_link(dir: &Path, run: &str) -> String {
    let report = Path::new(run).join("report").join("index.html");
    let abs = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    match abs(&report).strip_prefix(abs(dir)) {
        Ok(rel) => rel.display().to_string(),
        Err(_) => abs(&report).display().to_string(),
    }
}

/// The comparison page for a page in `dir` (`compare --html`'s folder, a campaign's `out`):
/// the table — fitting a 1280-px window, long model ids wrapping — a link to each run's report,
/// and the spend per model.
pub fn html_in(rows: &[Row], dir: &Path, title: &str) -> String {
    let mut s = format!(
        "<!doctype html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>Revelio: {}</title>\n<style>\nbody{{font-family:system-ui,sans-serif;margin:1.5rem;color:#222;max-width:1240px}}\ntable{{border-collapse:collapse;width:100%;table-layout:auto;font-size:.9rem}}\nth,td{{padding:.3rem .45rem;border-bottom:1px solid #ddd;text-align:right;vertical-align:top}}\nth{{background:#f4f4f4}}\ntd.t,th.t{{text-align:left}}\ntd.m{{overflow-wrap:anywhere;min-width:8rem;max-width:16rem}}\ntd.n{{white-space:nowrap}}\n.ci{{color:#777;font-size:.85em;white-space:nowrap}}\n</style>\n</head>\n<body>\n<h1>{}</h1>\n<table>\n<thead><tr><th class=\"t\">domain</th><th class=\"t\">model</th><th class=\"t\">algorithm</th><th>seed</th><th>budget</th><th>PFM</th><th>MFR</th><th>Div</th><th>failure modes</th><th>cores</th><th>calls</th><th>spend</th><th class=\"t\">run</th></tr></thead>\n<tbody>\n",
        esc(title),
        esc(title)
    );
    let cell = |r: &Rate| {
        format!("{:.1}%<br><span class=\"ci\">[{:.1}, {:.1}]</span>", 100.0 * r.value, 100.0 * r.low, 100.0 * r.high)
    };
    for r in rows {
        let d = r.div.as_ref().map_or_else(
            || "-".to_string(),
            |x| format!("{:.2}<br><span class=\"ci\">[{:.2}, {:.2}]</span>", x.value, x.low, x.high),
        );
        let run = Path::new(&r.run).file_name().map_or_else(|| r.run.clone(), |n| n.to_string_lossy().into_owned());
        s.push_str(&format!(
            "<tr><td class=\"t\">{}</td><td class=\"t m\">{}</td><td class=\"t\">{}</td><td>{}</td><td class=\"n\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>${:.4}</td><td class=\"t m\"><a href=\"{}\">{}</a></td></tr>\n",
            esc(&r.domain),
            esc(&r.model),
            esc(&r.algo),
            r.seed,
            esc(&budget_text(r)),
            cell(&r.pfm),
            cell(&r.mfr),
            d,
            r.failure_modes,
            r.cores,
            r.calls,
            r.cost_usd,
            esc(&report_link(dir, &r.run)),
            esc(&run)
        ));
    }
    s.push_str("</tbody>\n</table>\n");
    let mut per_model: Vec<(&str, u64, f64)> = Vec::new();
    for r in rows {
        match per_model.iter_mut().find(|(m, ..)| *m == r.model) {
            Some(e) => {
                e.1 += r.calls;
                e.2 += r.cost_usd;
            }
            None => per_model.push((&r.model, r.calls, r.cost_usd)),
        }
    }
    s.push_str("<h2>Spend per model</h2>\n<table>\n<thead><tr><th class=\"t\">model</th><th>calls</th><th>spend</th></tr></thead>\n<tbody>\n");
    for (m, calls, cost) in &per_model {
        s.push_str(&format!("<tr><td class=\"t m\">{}</td><td>{calls}</td><td>${cost:.4}</td></tr>\n", esc(m)));
    }
    s.push_str("</tbody>\n</table>\n<p>PFM: share of evaluated sets that are failure modes; MFR: share of inferences answered wrongly; Div: mean pairwise Jaccard distance of the failure modes. Brackets: 95&nbsp;% intervals (Wilson for PFM and MFR, jackknife for Div). Budget: the run's model calls, every phase included (the shrink phase's share is the CSV's <code>shrink</code>). Cores: for a run that shrank its failure modes, the distinct minimal failure modes the shrink phase confirmed (a smallest set that still fails); for one that did not, its failure modes with no smaller failure mode inside them. Calls and spend: every phase of the run.</p>\n</body>\n</html>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::compare::RunFacts;

    fn sample() -> Vec<Row> {
        vec![row(&RunFacts {
            run: "runs/a,b".into(),
            domain: "driving".into(),
            model: "sim:<x>".into(),
            algo: "gpts".into(),
            seed: 3,
            budget: 1000,
            shrink: 250,
            sets: 200,
            inferences: 1000,
            failures: 250,
            failure_modes: vec![vec!["a".into()], vec!["b".into(), "c".into()], vec!["a".into(), "c".into()]],
            shrunk_cores: None,
            calls: 1000,
            cost_usd: 0.5,
        })]
    }

    #[test]
    fn csv_quotes_fields_and_html_escapes() {
        let c = csv(&sample());
        let line = c.lines().nth(1).unwrap();
        assert!(line.starts_with("\"runs/a,b\",driving,sim:<x>,gpts,3,1000,250,0.0150,"), "{line}");
        assert_eq!(line.split(',').count(), c.lines().next().unwrap().split(',').count() + 1, "one quoted comma");
        let h = html(&sample());
        assert!(h.contains("sim:&lt;x&gt;") && !h.contains("sim:<x>"));
        assert!(h.contains("<td>3</td><td>2</td>"), "3 failure modes, 2 cores");
        assert!(h.contains("<td>3</td><td class=\"n\">1000</td>"), "seed and the total budget, shrink included");
        assert!(h.contains("href=\"runs/a,b/report/index.html\""), "a link to the run's report");
        assert!(h.contains("td.m{overflow-wrap:anywhere"), "long model ids wrap");
        let mut t = Vec::new();
        print_table(&mut t, &sample()).unwrap();
        let t = String::from_utf8(t).unwrap();
        assert!(t.contains("25.0% [22.4, 27.8]"), "{t}");
    }

    #[test]
    fn the_table_escapes_names_and_paths_from_run_folders() {
        let mut rows = sample();
        rows[0].model = "m\u{1b}]0;owned\u{7}".into();
        rows[0].domain = "d\u{9b}2J".into();
        rows[0].run = "runs/\u{1b}[2J".into();
        let mut t = Vec::new();
        print_table(&mut t, &rows).unwrap();
        let t = String::from_utf8(t).unwrap();
        assert!(!t.contains(['\u{1b}', '\u{7}', '\u{9b}']), "{t:?}");
        assert!(
            t.contains("m\\u{1b}]0;owned\\u{7}") && t.contains("d\\u{9b}2J") && t.contains("runs/\\u{1b}[2J"),
            "{t}"
        );
    }
}
