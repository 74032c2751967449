//! `revelio check PATH...`: compile `.rev` files (folders are searched recursively) and report
//! every diagnostic as human (miette), plain or JSON output. `-` checks standard input (an
//! editor's unsaved buffer), named by `--stdin-filename` so that its `use "…"` paths resolve
//! and its diagnostics name the file. Also home of the diagnostic renderers the other
//! subcommands use through [`super::load_domain`].

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use miette::{GraphicalReportHandler, GraphicalTheme, LabeledSpan, NamedSource, SourceSpan};

use super::common::{collect_rev_files, compile_path_with, compile_text_with, write_stdout};
use crate::check::{self, Compiled};
use crate::diag::{Diagnostic, Severity};
use crate::ir::{SourceFile, Span};

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// `.rev` files or folders (searched recursively for `*.rev`), or `-` for standard input
    #[arg(required = true, value_name = "PATH")]
    pub paths: Vec<PathBuf>,
    /// The file name the text read from `-` stands for: `use "…"` paths resolve from its folder
    /// and diagnostics name it (default `<stdin>`)
    #[arg(long, value_name = "NAME")]
    pub stdin_filename: Option<PathBuf>,
    /// Output format: `human` (annotated source), `plain` (one line each) or `json` (one object
    /// per line)
    #[arg(long, value_enum, default_value_t = Format::Human)]
    pub format: Format,
    /// Also render N scenes of every valid singleton and pair with the builtin renderer and
    /// warn (R0107) about concepts and combinations whose entities are not visible in at least
    /// 10% of them, and (R0108) about entities that draw nothing
    #[arg(long, value_name = "N")]
    pub render: Option<u32>,
    /// With `--render`: render every singleton but only a seeded sample of the pairs, K sets in
    /// all
    #[arg(long, value_name = "K", requires = "render")]
    pub render_sample: Option<usize>,
    /// With `--render`: also render a seeded sample of K larger valid sets (3 concepts up to
    /// `--max-size`), whose entities may hide one another in ways no pair shows
    #[arg(long, value_name = "K", requires = "render")]
    pub render_sets: Option<usize>,
    /// With `--render`: print the visibility figures (min / median pixels and contrast of the
    /// placed entities) of every set rendered
    #[arg(long, requires = "render")]
    pub figures: bool,
    /// With `--render`: draw every scene, taking none from the cache of scenes drawn before (under
    /// `$XDG_CACHE_HOME/revelio`, shared with the runs)
    #[arg(long, requires = "render")]
    pub no_cache: bool,
    /// Seed of `--render-sample` and `--render-sets` [default: 0]
    #[arg(long)]
    pub seed: Option<u64>,
    /// Largest concept set the lattice lints judge
    #[arg(long, default_value_t = crate::lattice::DEFAULT_MAX_SIZE as u32, value_parser = clap::value_parser!(u32).range(1..=512))]
    pub max_size: u32,
    /// Most valid sets the lattice lints enumerate; a larger lattice is reported (R0070)
    #[arg(long, default_value_t = crate::lattice::DEFAULT_MAX_SETS)]
    pub max_sets: u64,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Human,
    Plain,
    Json,
}

pub fn run(args: CheckArgs) -> ExitCode {
    let stdin = args.paths.iter().filter(|p| p.as_os_str() == "-").count();
    if stdin > 1 || (stdin == 0 && args.stdin_filename.is_some()) {
        eprintln!("error: `-` (standard input) may be given once, and `--stdin-filename` only with it");
        return ExitCode::from(2);
    }
    let paths: Vec<PathBuf> = args.paths.iter().filter(|p| p.as_os_str() != "-").cloned().collect();
    let mut files = match collect_rev_files(&paths) {
        Ok(f) => f,
        Err(msg) => {
            eprintln!("error: {msg}");
            return ExitCode::from(2);
        }
    };
    if args.render == Some(0) {
        eprintln!("error: `--render` needs at least 1 scene per set");
        return ExitCode::from(2);
    }
    let limits = crate::lint::Limits { max_size: args.max_size as usize, max_sets: args.max_sets };
    let mut compiled: Vec<Compiled> = files.iter().map(|f| compile_path_with(f, Some(limits))).collect();
    if stdin == 1 {
        let name = args.stdin_filename.clone().unwrap_or_else(|| PathBuf::from("<stdin>"));
        compiled.push(match crate::source::read_bounded(std::io::stdin(), &name.to_string_lossy()) {
            Ok(text) => compile_text_with(&name, &text, Some(limits)),
            Err(r) => Compiled {
                domain: None,
                diagnostics: vec![r.diagnostic(None)],
                files: Vec::new(),
                references: Vec::new(),
            },
        });
        files.push(name);
    }
    if args.seed.is_some() && args.render_sample.is_none() && args.render_sets.is_none() {
        eprintln!("error: `--seed` chooses the sets of `--render-sample` or `--render-sets`; give one of them");
        return ExitCode::from(2);
    }
    let mut figures = String::new();
    if let Some(scenes) = args.render {
        let plan = render_plan(scenes, &args);
        for c in &mut compiled {
            match render_lint(c, plan, crate::run::setup::cache_root(None, args.no_cache)) {
                Ok((diags, lines)) => {
                    if args.figures {
                        figures.push_str(&lines);
                    }
                    c.diagnostics.extend(diags);
                    check::sort_diagnostics(&mut c.diagnostics);
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    return ExitCode::from(1);
                }
            }
        }
    }
    let mut reports: Vec<Report> = compiled.iter().flat_map(reports_of).collect();
    reports.sort_by(|a, b| a.key().cmp(&b.key()));
    reports.dedup_by(|a, b| a.key() == b.key());
    let errors = reports.iter().filter(|r| r.diag.is_error()).count();
    let allowed = reports.iter().filter(|r| r.allowed).count();
    let warnings = reports.len() - errors - allowed;
    let out = match args.format {
        Format::Human => {
            let theme = if std::io::IsTerminal::is_terminal(&std::io::stdout()) {
                GraphicalTheme::unicode()
            } else {
                GraphicalTheme::unicode_nocolor()
            };
            let mut s: String = reports.iter().filter(|r| !r.allowed).map(|r| r.human(&theme)).collect();
            let _ = writeln!(s, "{}", summary(files.len(), errors, warnings, allowed));
            s
        }
        Format::Plain => reports.iter().filter(|r| !r.allowed).map(Report::plain).collect(),
        Format::Json => reports.iter().map(|r| r.json() + "\n").collect(),
    };
    // Figures before the diagnostics: the summary line stays last.
    write_stdout(&(figures + &out));
    if errors > 0 { ExitCode::from(1) } else { ExitCode::SUCCESS }
}

#[cfg(feature = "render")]
type Plan = crate::run::visible::Plan;
/// Without the renderer there is nothing to plan (`--render` is refused by [`render_lint`]).
#[cfg(not(feature = "render"))]
#[derive(Clone, Copy)]
struct Plan;

#[cfg(feature = "render")]
fn render_plan(scenes: u32, args: &CheckArgs) -> Plan {
    let seed = args.seed.unwrap_or(0);
    Plan {
        scenes,
        sample: args.render_sample.map(|k| (k, seed)),
        larger: args.render_sets.map(|count| crate::run::visible::Larger {
            count,
            max_size: args.max_size as usize,
            seed,
        }),
    }
}

#[cfg(not(feature = "render"))]
fn render_plan(_: u32, _: &CheckArgs) -> Plan {
    Plan
}

/// R0107 and R0108 for a domain file that compiled without errors (used modules have no
/// lattice), and the figures of every set rendered, a line each.
#[cfg(feature = "render")]
fn render_lint(
    c: &Compiled,
    plan: Plan,
    cache: Option<std::path::PathBuf>,
) -> Result<(Vec<Diagnostic>, String), String> {
    let Some(domain) = c.domain.as_ref().filter(|d| !d.name.is_empty()) else { return Ok((Vec::new(), String::new())) };
    // The scene cache a run's builtin renderer uses ([`crate::render::scene_cache`]).
    let renderer = crate::render::BuiltinRenderer::new(None)
        .map_err(|e| e.message)?
        .with_cache(cache.map(|c| crate::run::setup::images_dir(&c)).as_deref());
    let tallies = crate::run::visible::survey(domain, &renderer, plan)
        .map_err(|e| format!("cannot render `{}` for the visibility lint: {e}", domain.name))?;
    let figures: String = tallies
        .iter()
        .map(|t| format!("figures {}: {}\n", crate::oracle::set_text(domain, t.set), t.figures_text()))
        .collect();
    Ok((crate::run::visible::lint(domain, &tallies), figures))
}

#[cfg(not(feature = "render"))]
fn render_lint(_: &Compiled, _: Plan, _: Option<std::path::PathBuf>) -> Result<(Vec<Diagnostic>, String), String> {
    Err("`--render` needs the builtin renderer, and this build of revelio has none (built without the `render` feature)".into())
}

fn summary(files: usize, errors: usize, warnings: usize, allowed: usize) -> String {
    let plural = |n: usize, w: &str| if n == 1 { format!("1 {w}") } else { format!("{n} {w}s") };
    let mut s =
        format!("checked {}: {}, {}", plural(files, "file"), plural(errors, "error"), plural(warnings, "warning"));
    if allowed > 0 {
        let _ = write!(s, " ({allowed} allowed)");
    }
    s
}

/// The reports of one compilation; lints silenced by the domain's `allow` items are marked.
pub fn reports_of(c: &Compiled) -> Vec<Report<'_>> {
    let allowed: Vec<&str> = c.domain.iter().flat_map(|d| d.allow.iter().map(|a| a.code.as_str())).collect();
    c.diagnostics
        .iter()
        .map(|d| {
            let mut r = Report::new(&c.files, d);
            r.allowed = d.severity == Severity::Warning && allowed.contains(&d.code);
            r
        })
        .collect()
}

/// A diagnostic with the source files it points into, ready to render.
pub struct Report<'a> {
    pub diag: &'a Diagnostic,
    files: &'a [SourceFile],
    /// A lattice lint the domain silences with `allow CODE`: counted, shown only in JSON.
    pub allowed: bool,
}

/// Line and column (1-based; columns count characters) of a byte offset.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rfind('\n').map_or(before, |i| &before[i + 1..]).chars().count() + 1;
    (line, col)
}

impl<'a> Report<'a> {
    pub fn new(files: &'a [SourceFile], diag: &'a Diagnostic) -> Self {
        Report { diag, files, allowed: false }
    }

    fn file(&self, span: Span) -> Option<&'a SourceFile> {
        self.files.get(span.file as usize)
    }

    /// Sort and dedup key: file name, position, code, message.
    fn key(&self) -> (String, u32, u32, &'static str, String) {
        match self.diag.span {
            Some(s) => (
                self.file(s).map(|f| f.name.clone()).unwrap_or_default(),
                s.start,
                s.end,
                self.diag.code,
                self.diag.message.clone(),
            ),
            None => (String::new(), 0, 0, self.diag.code, self.diag.message.clone()),
        }
    }

    fn location(&self, span: Span) -> Option<(String, usize, usize)> {
        let f = self.file(span)?;
        let (line, col) = line_col(&f.text, span.start as usize);
        Some((f.name.clone(), line, col))
    }

    /// `file:line:col: severity[CODE]: message`, then `  help: …` and `  note: …` lines.
    pub fn plain(&self) -> String {
        let d = self.diag;
        let mut s = match d.span.and_then(|sp| self.location(sp)) {
            Some((file, line, col)) => format!("{file}:{line}:{col}: "),
            None => String::new(),
        };
        let _ = writeln!(s, "{}[{}]: {}", severity_word(d.severity), d.code, d.message);
        for r in &d.related {
            if let Some((file, line, col)) = self.location(r.span) {
                let _ = writeln!(s, "  note: {file}:{line}:{col}: {}", r.message);
            }
        }
        if let Some(h) = &d.help {
            let _ = writeln!(s, "  help: {h}");
        }
        s
    }

    /// One JSON object (no newline).
    pub fn json(&self) -> String {
        let d = self.diag;
        let place = |span: Span| {
            let f = self.file(span);
            let text = f.map_or("", |f| f.text.as_str());
            let (line, column) = line_col(text, span.start as usize);
            let (end_line, end_column) = line_col(text, span.end as usize);
            serde_json::json!({
                "file": f.map(|f| f.name.clone()),
                "span": { "start": span.start, "end": span.end },
                "line": line, "column": column, "end_line": end_line, "end_column": end_column,
            })
        };
        let mut obj = serde_json::json!({
            "code": d.code,
            "severity": severity_word(d.severity),
            "allowed": self.allowed,
            "message": d.message,
            "label": d.label,
            "help": d.help,
            "related": d.related.iter().map(|r| {
                let mut p = place(r.span);
                p["message"] = serde_json::Value::String(r.message.clone());
                p
            }).collect::<Vec<_>>(),
        });
        let loc = match d.span {
            Some(s) => place(s),
            None => serde_json::json!({
                "file": null, "span": null, "line": null, "column": null, "end_line": null, "end_column": null
            }),
        };
        if let (Some(o), serde_json::Value::Object(l)) = (obj.as_object_mut(), loc) {
            o.extend(l);
        }
        obj.to_string()
    }

    /// miette's graphical rendering, with `theme`.
    pub fn human(&self, theme: &GraphicalTheme) -> String {
        let handler = GraphicalReportHandler::new_themed(theme.clone()).with_links(false).with_width(100);
        let mut out = String::new();
        let _ = handler.render_report(&mut out, &MietteDiag::new(self));
        out.push('\n');
        out
    }
}

fn severity_word(s: Severity) -> &'static str {
    match s {
        Severity::Error => "error",
        Severity::Warning => "warning",
    }
}

/// Adapter from our diagnostic to miette's trait. Related spans in the primary's file become
/// secondary labels; those in other files become related reports with their own source.
struct MietteDiag {
    message: String,
    code: &'static str,
    severity: miette::Severity,
    help: Option<String>,
    source: Option<NamedSource<String>>,
    labels: Vec<LabeledSpan>,
    related: Vec<MietteDiag>,
}

impl MietteDiag {
    fn new(r: &Report) -> Self {
        let d = r.diag;
        let primary_file = d.span.map(|s| s.file);
        let mut labels = Vec::new();
        let mut related = Vec::new();
        if let Some(s) = d.span {
            let label = (!d.label.is_empty()).then(|| d.label.clone());
            labels.push(LabeledSpan::new_primary_with_span(label, to_source_span(s)));
        }
        for l in &d.related {
            if Some(l.span.file) == primary_file {
                labels.push(LabeledSpan::new_with_span(Some(l.message.clone()), to_source_span(l.span)));
            } else {
                related.push(MietteDiag {
                    message: l.message.clone(),
                    code: d.code,
                    severity: miette::Severity::Advice,
                    help: None,
                    source: named_source(r, l.span.file),
                    labels: vec![LabeledSpan::new_primary_with_span(None, to_source_span(l.span))],
                    related: Vec::new(),
                });
            }
        }
        MietteDiag {
            message: d.message.clone(),
            code: d.code,
            severity: match d.severity {
                Severity::Error => miette::Severity::Error,
                Severity::Warning => miette::Severity::Warning,
            },
            help: d.help.clone(),
            source: primary_file.and_then(|f| named_source(r, f)),
            labels,
            related,
        }
    }
}

fn named_source(r: &Report, file: u32) -> Option<NamedSource<String>> {
    r.files.get(file as usize).map(|f| NamedSource::new(f.name.clone(), f.text.clone()))
}

fn to_source_span(s: Span) -> SourceSpan {
    SourceSpan::from(s.start as usize..s.end.max(s.start) as usize)
}

impl std::fmt::Debug for MietteDiag {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::fmt::Display for MietteDiag {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for MietteDiag {}

impl miette::Diagnostic for MietteDiag {
    fn code<'a>(&'a self) -> Option<Box<dyn std::fmt::Display + 'a>> {
        Some(Box::new(self.code))
    }
    fn severity(&self) -> Option<miette::Severity> {
        Some(self.severity)
    }
    fn help<'a>(&'a self) -> Option<Box<dyn std::fmt::Display + 'a>> {
        self.help.as_ref().map(|h| Box::new(h) as Box<dyn std::fmt::Display>)
    }
    fn source_code(&self) -> Option<&dyn miette::SourceCode> {
        self.source.as_ref().map(|s| s as &dyn miette::SourceCode)
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = LabeledSpan> + '_>> {
        if self.labels.is_empty() { None } else { Some(Box::new(self.labels.iter().cloned())) }
    }
    fn related<'a>(&'a self) -> Option<Box<dyn Iterator<Item = &'a dyn miette::Diagnostic> + 'a>> {
        if self.related.is_empty() {
            None
        } else {
            Some(Box::new(self.related.iter().map(|r| r as &dyn miette::Diagnostic)))
        }
    }
}

/// Render all diagnostics of a compilation as human output (for `load_domain`).
pub fn render_human(compiled: &Compiled, theme: &GraphicalTheme) -> String {
    reports_of(compiled).iter().filter(|r| !r.allowed).map(|r| r.human(theme)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::common::compile_path;
    use std::path::Path;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn exit_codes() {
        let dir = tempfile::tempdir().unwrap();
        let lib = write(dir.path(), "lib.rev", "/// A tag.\ntag Shiny\n");
        let bad = write(dir.path(), "bad.rev", "kind K: Shinny {}\n");
        let run_on = |paths: Vec<PathBuf>| {
            run(CheckArgs {
                paths,
                stdin_filename: None,
                format: Format::Plain,
                max_size: crate::lattice::DEFAULT_MAX_SIZE as u32,
                max_sets: crate::lattice::DEFAULT_MAX_SETS,
                render: None,
                render_sample: None,
                render_sets: None,
                figures: false,
                no_cache: false,
                seed: None,
            })
        };
        assert_eq!(run_on(vec![lib.clone()]), ExitCode::SUCCESS);
        assert_eq!(run_on(vec![lib, bad]), ExitCode::from(1));
        assert_eq!(run_on(vec![dir.path().to_path_buf()]), ExitCode::from(1), "folders are searched");
        assert_eq!(run_on(vec![dir.path().join("nope.rev")]), ExitCode::from(2));
    }

    #[test]
    fn folders_are_searched_recursively_in_order() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("b")).unwrap();
        write(dir.path(), "b/z.rev", "");
        write(dir.path(), "a.rev", "");
        write(dir.path(), "notes.txt", "");
        let files = collect_rev_files(&[dir.path().to_path_buf()]).unwrap();
        let names: Vec<String> =
            files.iter().map(|f| f.strip_prefix(dir.path()).unwrap().to_string_lossy().into_owned()).collect();
        assert_eq!(names, ["a.rev", "b/z.rev"]);
    }

    #[test]
    fn plain_and_json_lines() {
        let dir = tempfile::tempdir().unwrap();
        let f = write(dir.path(), "d.rev", "tag A\ntag A\n");
        let c = compile_path(&f, false);
        let r = Report::new(&c.files, &c.diagnostics[0]);
        let name = f.display();
        assert_eq!(
            r.plain(),
            format!(
                "{name}:2:5: error[R0021]: `A` is already declared as a tag\n  note: {name}:1:5: first declared here\n  help: rename one of them; names are global across all loaded modules\n"
            )
        );
        let j: serde_json::Value = serde_json::from_str(&r.json()).unwrap();
        assert_eq!(j["code"], "R0021");
        assert_eq!(j["span"]["start"], 10);
        assert_eq!((j["line"].as_u64(), j["column"].as_u64(), j["end_column"].as_u64()), (Some(2), Some(5), Some(6)));
        assert_eq!(j["related"][0]["line"], 1);
        assert_eq!(j["allowed"], false);
    }

    #[test]
    fn line_and_column() {
        assert_eq!(line_col("ab\ncd", 0), (1, 1));
        assert_eq!(line_col("ab\ncd", 4), (2, 2));
        assert_eq!(line_col("é\nx", 3), (2, 1));
        assert_eq!(line_col("éx", 2), (1, 2));
    }
}
