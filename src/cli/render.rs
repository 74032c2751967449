//! `revelio render`: draw one concept set with the builtin renderer, a contact sheet of seeds
//! (`--grid`), of every valid single concept (`--all`), or print the adapter (`--info`).

use std::path::PathBuf;
use std::process::ExitCode;

use image::RgbaImage;

use crate::ir::{ConceptSet, Domain};
use crate::lattice::Lattice;
use crate::render::{BuiltinRenderer, encode_png, encode_png_small, sheet};

#[derive(clap::Args, Debug)]
pub struct RenderArgs {
    /// The domain file (`domains/driving.rev`).
    #[arg(required_unless_present = "info")]
    pub file: Option<PathBuf>,
    /// Concepts of the set to draw (none: the domain's baseline scene — its world defaults,
    /// stage and seeded extras, with no concept).
    pub concepts: Vec<String>,
    /// Scene seed (positions, extras, rain pattern).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output PNG.
    #[arg(short, long, default_value = "render.png")]
    pub output: PathBuf,
    /// Image (or tile) size `WxH`; default: the domain camera's.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Draw a contact sheet of K seeds (seed, seed+1, …).
    #[arg(long, value_name = "K", conflicts_with = "all")]
    pub grid: Option<u32>,
    /// Draw a contact sheet with one tile per concept (alone, or in its smallest valid set).
    #[arg(long, conflicts_with = "concepts")]
    pub all: bool,
    /// Print the graphics adapter the builtin renderer uses, and exit.
    #[arg(long)]
    pub info: bool,
    /// Print each placed entity's visibility figures (pixels and contrast, against the domain's
    /// `visible` thresholds) for every image drawn
    #[arg(long)]
    pub figures: bool,
}

/// Parse `WxH` (e.g. `640x360`).
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("invalid size `{s}`: expected WIDTHxHEIGHT, e.g. `640x360`");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h) = (w.trim().parse::<u32>().map_err(|_| bad())?, h.trim().parse::<u32>().map_err(|_| bad())?);
    crate::render::builtin::check_size(w, h).map_err(|e| e.message)?;
    Ok((w, h))
}

/// Most tiles in one sheet: keeps a typo in `--grid` from rendering for minutes.
const MAX_TILES: u32 = 400;

pub fn run(args: RenderArgs) -> ExitCode {
    let renderer = match BuiltinRenderer::new(args.size) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    if args.info {
        println!("{}", renderer.adapter());
        return ExitCode::SUCCESS;
    }
    let Some(file) = &args.file else {
        eprintln!("error: a domain file is required");
        return ExitCode::from(2);
    };
    let domain = match crate::cli::load_domain(file) {
        Ok(d) => d,
        Err(code) => return code,
    };
    // A concept the domain lacks is an input error (1), not a usage error like a bad `--grid`.
    if let (false, Err(e)) = (args.all, domain.parse_set(&args.concepts)) {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    let jobs = match plan(&domain, &args) {
        Ok(j) => j,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let as_sheet = args.grid.is_some() || args.all;
    // Sheets are kept and shared, so they get the slower, smaller encoding.
    let encode = if as_sheet { encode_png_small } else { encode_png };
    match draw(&domain, &renderer, &jobs, as_sheet) {
        Ok((img, figures)) => match encode(&img).map_err(|e| e.message).and_then(|png| {
            std::fs::write(&args.output, png).map_err(|e| format!("cannot write `{}`: {e}", args.output.display()))
        }) {
            Ok(()) => {
                if args.figures {
                    print!("{figures}");
                }
                println!("wrote {} ({}x{})", args.output.display(), img.width(), img.height());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::from(1)
            }
        },
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

/// One image to draw: a set, a seed, and its caption on a sheet.
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    pub set: ConceptSet,
    pub seed: u64,
    pub caption: String,
}

/// What to draw, from the arguments (errors here are usage errors).
pub fn plan(domain: &Domain, args: &RenderArgs) -> Result<Vec<Job>, String> {
    if args.all {
        return Ok(concept_sheet(domain)
            .into_iter()
            .map(|set| Job { set, seed: args.seed, caption: caption(domain, set) })
            .collect());
    }
    let set = domain.parse_set(&args.concepts).map_err(|e| e.to_string())?;
    let label = if args.concepts.is_empty() { "(baseline)".to_string() } else { args.concepts.join(" ") };
    match args.grid {
        None => Ok(vec![Job { set, seed: args.seed, caption: label }]),
        Some(k) if k == 0 || k > MAX_TILES => Err(format!("`--grid {k}` is out of range: expected 1..={MAX_TILES}")),
        Some(k) => Ok((0..k as u64)
            .map(|i| {
                let seed = args.seed.wrapping_add(i);
                Job { set, seed, caption: format!("seed {seed}") }
            })
            .collect()),
    }
}

/// Largest set tried when looking for a valid set that shows a concept.
const SHEET_MAX_SET: usize = 3;

/// One set per concept, in declaration order: the concept alone when that is valid, else the
/// first smallest valid set holding it (a modifier needs a target, `child_reaching` needs an
/// open cabinet). Concepts valid in no set up to [`SHEET_MAX_SET`] concepts are left out.
pub fn concept_sheet(domain: &Domain) -> Vec<ConceptSet> {
    let lattice = Lattice::enumerate(domain, SHEET_MAX_SET);
    domain
        .concepts
        .iter()
        .filter_map(|c| (1..=SHEET_MAX_SET).find_map(|k| lattice.of_size(k).iter().copied().find(|s| s.contains(c.id))))
        .collect()
}

/// A sheet caption: the concepts of the set, joined by `+`.
fn caption(domain: &Domain, set: ConceptSet) -> String {
    domain.set_names(set).join(" + ")
}

/// Render the jobs: one image, or a captioned contact sheet; and the visibility figures of
/// every placed entity, a block per image.
pub fn draw(
    domain: &Domain,
    renderer: &BuiltinRenderer,
    jobs: &[Job],
    as_sheet: bool,
) -> Result<(RgbaImage, String), String> {
    let mut tiles = Vec::with_capacity(jobs.len());
    let mut figures = String::new();
    let sampler = crate::sample::Sampler::new(domain);
    for job in jobs {
        // No concept: the baseline every concept is seen against (outside the lattice).
        let scene = if job.set.is_empty() { sampler.backdrop(job.seed) } else { sampler.sample(job.set, job.seed) }
            .map_err(|e| format!("cannot sample `{}` with seed {}: {e}", job.caption, job.seed))?;
        let (mut img, seen) = renderer.render_seen(&scene).map_err(|e| e.message)?;
        let lines: Vec<String> =
            crate::run::observe::figure_lines(domain, &scene, &seen).into_iter().map(|l| format!("  {l}\n")).collect();
        let entities = if lines.is_empty() { "  no entity placed\n".to_string() } else { lines.concat() };
        figures.push_str(&format!("{} (seed {}):\n{entities}", job.caption, job.seed));
        if as_sheet {
            sheet::caption(&mut img, &job.caption);
        }
        tiles.push(img);
    }
    match tiles.len() {
        0 => Err("nothing to render: no concept of the domain is in a valid set".to_string()),
        1 if !as_sheet => Ok((tiles.remove(0), figures)),
        n => {
            let (w, h) = tiles[0].dimensions();
            Ok((sheet::grid(&tiles, sheet::columns_for(n, w, h)), figures))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(concepts: &[&str], grid: Option<u32>) -> RenderArgs {
        RenderArgs {
            file: None,
            concepts: concepts.iter().map(|s| s.to_string()).collect(),
            seed: 4,
            output: PathBuf::from("x.png"),
            size: None,
            grid,
            all: false,
            info: false,
            figures: false,
        }
    }

    #[test]
    fn no_concepts_plan_the_baseline_scene() {
        let d = crate::sample::fixture::driving();
        let jobs = plan(&d, &args(&[], None)).unwrap();
        assert_eq!(jobs, [Job { set: ConceptSet::EMPTY, seed: 4, caption: "(baseline)".into() }]);
        let grid = plan(&d, &args(&[], Some(2))).unwrap();
        assert!(grid.iter().all(|j| j.set.is_empty()) && grid.len() == 2);
        // The baseline samples (as the backdrop) where the empty set has no scene.
        assert!(crate::sample::sample(&d, ConceptSet::EMPTY, 4).is_err());
        let scene = crate::sample::Sampler::new(&d).backdrop(4).unwrap();
        assert!(scene.entities.is_empty() && !scene.stage.is_empty());
        assert_eq!(
            plan(&d, &args(&["pedestrain"], None)).unwrap_err(),
            d.parse_set(&["pedestrain"]).unwrap_err().to_string()
        );
    }

    #[test]
    fn sizes_parse_and_reject_nonsense() {
        assert_eq!(parse_size("320x180"), Ok((320, 180)));
        assert_eq!(parse_size("64X48"), Ok((64, 48)));
        assert_eq!(parse_size("wide").unwrap_err(), "invalid size `wide`: expected WIDTHxHEIGHT, e.g. `640x360`");
        assert!(parse_size("0x10").unwrap_err().contains("out of range"));
        assert!(parse_size("100000x10").unwrap_err().contains("out of range"));
    }
}
