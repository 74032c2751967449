//! `revelio bench search --sweep PARAM=v1,v2,…`: every algorithm over the bench's seeds at each
//! value of one search parameter (GPTS alone for `kernel`, the only one it changes); a table of
//! PFM, MFR and Div (mean ± sd over seeds) and an SVG plot (`--plot FILE`, default
//! `sweep-PARAM.svg`).
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use crate::analysis::sweep::{Point, Sweep, plot};
use crate::diag::TerminalSafe;
use crate::ir::{ConceptSet, Domain};
use crate::run::observe::World;
use crate::search::interval::mean_sd;
use crate::search::{Params, Space};
use crate::vlm::Model;
use crate::vlm::sim::Profile;

use super::{RunFigures, SearchBenchArgs, bench_one};

/// What `bench search` prepared: the domain, its world and search space, the sim model and its
/// planted modes, and a scratch folder for the runs.
pub struct Bench {
    pub domain: Arc<Domain>,
    pub world: Arc<dyn World>,
    pub model: Arc<dyn Model>,
    pub space: Space,
    pub planted: Vec<ConceptSet>,
    /// The profile itself, for the bench's precision figures.
    pub truth: Profile,
    pub tmp: PathBuf,
}

fn stat(xs: &[f64]) -> Option<(f64, f64)> {
    (!xs.is_empty()).then(|| mean_sd(xs))
}

pub fn run(args: &SearchBenchArgs, sweep: &Sweep, base: &Params, b: &Bench) -> ExitCode {
    let mut points = Vec::new();
    let changed = sweep.param.algos();
    let algos = if args.algos.is_empty() { changed.to_vec() } else { args.algos.clone() };
    if let Some(a) = algos.iter().find(|a| !changed.contains(a)) {
        eprintln!(
            "error: `--sweep {}` changes only {}; `--algos` names `{}`",
            sweep.param.name(),
            changed.iter().map(|a| a.name()).collect::<Vec<_>>().join(", "),
            a.name()
        );
        return ExitCode::from(2);
    }
    for &value in &sweep.values {
        let at = sweep.param.apply(base, value);
        // The beam phase of GPTS cannot outgrow the search phase.
        let at = Params { beam_budget: at.beam_budget.min(at.plan().search), ..at };
        if let Err(e) = at.validate() {
            eprintln!("error: `--sweep {}={value}`: {e}", sweep.param.name());
            return ExitCode::from(2);
        }
        for &algo in &algos {
            let mut rows = Vec::new();
            for seed in 0..args.seeds {
                let params = super::run_params(args, &at, algo, seed);
                let out = b.tmp.join(format!("{}-{value}-{}-{seed}", sweep.param.name(), algo.name()));
                match bench_one(args, &b.domain, &b.world, &b.model, &b.space, params, out, &b.planted, &b.truth) {
                    Ok(r) => rows.push(r),
                    Err(e) => {
                        eprintln!("error: {e}");
                        return ExitCode::from(1);
                    }
                }
            }
            let col = |f: &dyn Fn(&RunFigures) -> Option<f64>| rows.iter().filter_map(f).collect::<Vec<f64>>();
            points.push(Point {
                algo: algo.name().to_string(),
                value,
                pfm: stat(&col(&|r| Some(r.pfm))).unwrap_or_default(),
                mfr: stat(&col(&|r| Some(r.mfr))).unwrap_or_default(),
                div: stat(&col(&|r| r.div)),
            });
        }
    }
    let path = args.plot.clone().unwrap_or_else(|| PathBuf::from(format!("sweep-{}.svg", sweep.param.name())));
    match plot(sweep, &points) {
        Ok(svg) => {
            if let Err(e) = std::fs::write(&path, svg) {
                eprintln!("error: cannot write `{}`: {}", path.display(), e.to_string().to_lowercase());
                return ExitCode::from(1);
            }
        }
        Err(e) => {
            eprintln!("error: cannot draw the sweep plot: {e}");
            return ExitCode::from(1);
        }
    }
    let mut w = std::io::stdout().lock();
    let written = if args.json {
        serde_json::to_writer_pretty(&mut w, &points).map_err(std::io::Error::from).and_then(|_| writeln!(w))
    } else {
        let mut safe = TerminalSafe(&mut w);
        print(&mut safe, args, sweep, &points).and_then(|()| writeln!(safe, "plot: {}", path.display()))
    };
    match written {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            eprintln!("error: cannot write the report: {e}");
            ExitCode::from(1)
        }
        _ => ExitCode::SUCCESS,
    }
}

fn print(w: &mut impl Write, args: &SearchBenchArgs, sweep: &Sweep, points: &[Point]) -> std::io::Result<()> {
    writeln!(
        w,
        "sweep of {} over {} seeds × budget {} against `{}`, renderer {}",
        sweep.param.name(),
        args.seeds,
        args.params.budget,
        args.profile.display(),
        super::bench_renderer(args)
    )?;
    writeln!(w, "{:>12}  {:<8}  {:>13}  {:>13}  {:>11}", sweep.param.name(), "algo", "PFM %", "MFR %", "Div")?;
    for p in points {
        writeln!(
            w,
            "{:>12}  {:<8}  {:>13}  {:>13}  {:>11}",
            p.value.to_string(),
            p.algo,
            format!("{:.1} ± {:.1}", p.pfm.0, p.pfm.1),
            format!("{:.1} ± {:.1}", p.mfr.0, p.mfr.1),
            p.div.map_or_else(|| "-".into(), |(m, sd)| format!("{m:.2} ± {sd:.2}"))
        )?;
    }
    Ok(())
}
