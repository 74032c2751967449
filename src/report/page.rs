//! `index.html`: the page's view model ([`super::view`]) written as HTML by one function per
//! section. Every text is plain until written, and every text from the run goes through [`Esc`];
//! only the two SVG plots (drawn by plotters, which escapes their text) are inserted as markup.

use std::collections::BTreeMap;
use std::fmt::{self, Write};

use super::files::ImageRef;
use super::view::{CoreView, IndexPage, ModeRow, ObsView, VisibilityView, index_page, interval};
use super::{Findings, Run};
use crate::analysis::probe::{Mechanism, ProbeReport};
use crate::analysis::transfer::{Transfer, TransferReport, pooled_counts};
use crate::analysis::{anytime95, wilson95};
use crate::ir::Domain;
use crate::search::interval::pct;

pub fn render(
    run: &Run,
    domain: Option<&Domain>,
    f: &Findings<'_>,
    images: &BTreeMap<String, ImageRef>,
    discovery: &str,
    heatmap: &str,
) -> Result<String, String> {
    let page = index_page(run, domain, f, images, discovery, heatmap);
    let mut html = String::new();
    write_page(&mut html, &page).map_err(|e| format!("cannot write the report page: {e}"))?;
    Ok(html)
}

/// A text escaped for HTML content and quoted attribute values alike.
pub struct Esc<'s>(pub &'s str);

impl fmt::Display for Esc<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut rest = self.0;
        while let Some(i) = rest.find(['&', '<', '>', '"', '\'']) {
            f.write_str(&rest[..i])?;
            f.write_str(match rest.as_bytes()[i] {
                b'&' => "&#38;",
                b'<' => "&#60;",
                b'>' => "&#62;",
                b'"' => "&#34;",
                _ => "&#39;",
            })?;
            rest = &rest[i + 1..];
        }
        f.write_str(rest)
    }
}

const STYLE: &str = include_str!("templates/style.css");

fn write_page(out: &mut String, p: &IndexPage<'_>) -> fmt::Result {
    write!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <link rel=\"icon\" href=\"data:,\">\n<title>{}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n<main>\n",
        Esc(&p.title)
    )?;
    write_header(out, p)?;
    write_nav(out, p)?;
    write_metrics(out, p)?;
    write_cores(out, p)?;
    if !p.borderline.is_empty() {
        writeln!(out, "<section id=\"borderline\">\n<h2>Borderline ({})</h2>", p.borderline.len())?;
        writeln!(
            out,
            "<p class=\"note\">Candidate cores whose fresh observations reached {} with their interval still reaching both below τ − δ and above τ + δ: near the threshold, neither failure modes nor passing. More observations would settle them.</p>",
            Esc(&p.borderline_cap)
        )?;
        out.push_str("<div class=\"card\">");
        write_modes(out, &p.borderline)?;
        out.push_str("</div>\n</section>\n\n");
    }
    if !p.others.is_empty() {
        writeln!(out, "<section id=\"others\">\n<h2>Other failure modes ({})</h2>", p.others.len())?;
        let again = if p.refuted.is_empty() && p.not_distinct.is_empty() {
            ""
        } else {
            " Those refuted on re-test or not distinct are listed again below, with the reason."
        };
        write!(
            out,
            "<p class=\"note\">Failure modes that contain none of the cores above.{again}</p>\n<div class=\"card\">"
        )?;
        write_modes(out, &p.others)?;
        out.push_str("</div>\n</section>\n\n");
    }
    if !p.refuted.is_empty() {
        writeln!(out, "<section id=\"refuted\">\n<h2>Refuted on re-test ({})</h2>", p.refuted.len())?;
        out.push_str("<p class=\"note\">Failure modes of the search that passed when the shrink phase tested them again: their search observations overstated their failure rate.</p>\n<div class=\"card\">");
        write_modes(out, &p.refuted)?;
        out.push_str("</div>\n</section>\n\n");
    }
    write_not_distinct(out, p)?;
    write_concepts(out, p)?;
    write_pairs(out, p)?;
    write_discovery_and_outcomes(out, p)?;
    write_visibility(out, &p.visibility)?;
    if let Some(probe) = p.probe {
        write_probe(out, probe)?;
    }
    if let Some(t) = p.transfer {
        write_transfer(out, t)?;
    }
    out.push_str("<section id=\"files\">\n<h2>Files</h2>\n<div class=\"card\">\n<ul class=\"files\">\n");
    for (href, what) in &p.files {
        writeln!(out, "<li><a href=\"{}\">{}</a> — {}</li>", Esc(href), Esc(href), Esc(what))?;
    }
    out.push_str("</ul>\n</div>\n</section>\n\n");
    for n in &p.notes {
        writeln!(out, "<p class=\"note\">{}</p>", Esc(n))?;
    }
    let mut sources = vec!["config.json", "summary.json", "journal.jsonl"];
    if let Some(file) = &p.validation_file {
        sources.push(file);
    }
    if p.probe.is_some() {
        sources.push("probe.json");
    }
    if p.transfer.is_some() {
        sources.push("transfer.json");
    }
    let (last, rest) = sources.split_last().expect("three sources at least");
    writeln!(
        out,
        "<footer>Written by revelio {} from the run folder's {} and {}. Static: no network, no scripts.</footer>\n</main>\n</body>\n</html>",
        Esc(p.version),
        Esc(&rest.join(", ")),
        Esc(last)
    )
}

fn write_header(out: &mut String, p: &IndexPage<'_>) -> fmt::Result {
    writeln!(out, "<header>\n<h1>Revelio run report</h1>\n<p class=\"sub\">{}</p>", Esc(&p.subtitle))?;
    out.push_str("<div class=\"card\">\n<dl class=\"kv\">\n");
    for (label, value) in &p.header {
        writeln!(out, "<div><dt>{}</dt><dd>{}</dd></div>", Esc(label), Esc(value))?;
    }
    writeln!(out, "</dl>\n<p class=\"params\">{}</p>\n</div>\n</header>\n", Esc(&p.params))
}

fn write_nav(out: &mut String, p: &IndexPage<'_>) -> fmt::Result {
    out.push_str("<nav>\n<a href=\"#metrics\">Metrics</a><a href=\"#cores\">Cores</a>");
    if !p.borderline.is_empty() {
        out.push_str("<a href=\"#borderline\">Borderline</a>");
    }
    if !p.others.is_empty() {
        out.push_str("<a href=\"#others\">Other failure modes</a>");
    }
    if !p.refuted.is_empty() {
        out.push_str("<a href=\"#refuted\">Refuted</a>");
    }
    if !p.not_distinct.is_empty() {
        out.push_str("<a href=\"#not-distinct\">Not distinct</a>");
    }
    out.push_str("<a href=\"#concepts\">Concepts</a><a href=\"#pairs\">Pairs</a><a href=\"#discovery\">Discovery</a><a href=\"#outcomes\">Outcomes</a><a href=\"#visibility\">Visibility</a>");
    if p.probe.is_some() {
        out.push_str("<a href=\"#probe\">Recognition</a>");
    }
    if p.transfer.is_some() {
        out.push_str("<a href=\"#transfer\">Transfer</a>");
    }
    out.push_str("<a href=\"#files\">Files</a>\n</nav>\n\n");
    Ok(())
}

fn write_metrics(out: &mut String, p: &IndexPage<'_>) -> fmt::Result {
    out.push_str("<section id=\"metrics\">\n<h2>Metrics</h2>\n<div class=\"stats\">\n");
    for m in &p.metrics {
        writeln!(
            out,
            "<div class=\"stat\"><div class=\"label\">{}</div><div class=\"value\">{}</div><div class=\"detail\">{}</div></div>",
            Esc(&m.label),
            Esc(&m.value),
            Esc(&m.detail)
        )?;
    }
    writeln!(out, "</div>\n<p class=\"note\">{}</p>\n</section>\n", Esc(&p.metrics_note))
}

fn write_cores(out: &mut String, p: &IndexPage<'_>) -> fmt::Result {
    writeln!(out, "<section id=\"cores\">\n<h2>Failure modes by core ({})</h2>", p.cores.len())?;
    writeln!(out, "<p class=\"note\">{}</p>", Esc(&p.cores_note))?;
    if p.cores.is_empty() {
        writeln!(out, "<div class=\"card\">No failure mode reached FR ≥ {}.</div>", p.threshold)?;
    }
    for c in &p.cores {
        write_core(out, c)?;
    }
    out.push_str("</section>\n\n");
    Ok(())
}

fn write_core(out: &mut String, c: &CoreView) -> fmt::Result {
    writeln!(
        out,
        "<article class=\"card core\" id=\"{}\" data-concepts=\"{}\">\n<div class=\"core-head\">\n<span class=\"rank\">#{}</span>",
        Esc(&c.anchor),
        Esc(&c.key),
        c.rank
    )?;
    out.push_str("<div class=\"chips\">");
    for name in &c.concepts {
        write!(out, "<span class=\"chip\">{}</span>", Esc(name))?;
    }
    writeln!(
        out,
        "</div>\n<div class=\"rate\"><div class=\"fr\">{}</div><div class=\"ci\">95% CI {} · {}</div></div>\n</div>",
        Esc(&c.fr),
        Esc(&c.ci),
        Esc(c.basis)
    )?;
    for line in c.evidence.iter().chain(&c.part) {
        writeln!(out, "<p class=\"note\">{}</p>", Esc(line))?;
    }
    writeln!(
        out,
        "<div class=\"facts\">\n<span><b>{}</b> wrong of <b>{}</b> answered ({})</span>",
        c.wrong, c.answered, c.basis
    )?;
    writeln!(out, "<span>validated: <b>{}</b></span>", Esc(&c.validated))?;
    writeln!(out, "<span><b>{}</b> failure modes of the search contain it</span>", c.supersets)?;
    if let Some(from) = &c.shrunk_from {
        writeln!(out, "<span>shrunk from <code>{}</code></span>", Esc(from))?;
    }
    if !c.minimal {
        out.push_str(
            "<span>not shown minimal: the shrink budget ran out before every smaller subset was tested (or before the shrink reached it)</span>\n",
        );
    }
    if let Some(v) = &c.visibility {
        writeln!(out, "<span class=\"vis\">visibility: {}</span>", Esc(v))?;
    }
    out.push_str("</div>\n");
    if let Some(v) = &c.verdict {
        writeln!(out, "<div class=\"verdict\">\n<p><b>Expected:</b> {}</p>", Esc(&v.expected))?;
        write!(out, "<p><b>Deciding rule:</b> <code>{}</code>", Esc(&v.rule))?;
        if !v.rationale.is_empty() {
            write!(out, " — {}", Esc(&v.rationale))?;
        }
        writeln!(
            out,
            "</p>\n<p class=\"why\">{}</p>\n<details><summary>question asked</summary><pre>{}</pre></details>\n</div>",
            Esc(&v.explanation),
            Esc(&v.question)
        )?;
    }
    if let Some(e) = &c.verdict_error {
        writeln!(out, "<p class=\"note\">{}</p>", Esc(e))?;
    }
    if c.observations.is_empty() {
        out.push_str("<p class=\"note\">No observation of this exact set is in the journal.</p>\n");
    }
    out.push_str("<div class=\"obs-grid\">\n");
    for o in &c.observations {
        write_observation(out, c, o)?;
    }
    out.push_str("</div>\n");
    if !c.superset_rows.is_empty() {
        let open = if c.superset_rows.len() <= 6 { " open" } else { "" };
        writeln!(
            out,
            "<details{open}><summary>{} larger failure modes containing this core</summary>",
            c.superset_rows.len()
        )?;
        write_modes(out, &c.superset_rows)?;
        out.push_str("</details>\n");
    }
    out.push_str("</article>\n");
    Ok(())
}

fn write_observation(out: &mut String, c: &CoreView, o: &ObsView) -> fmt::Result {
    out.push_str("<div class=\"obs\">\n");
    match &o.image {
        Some(img) => writeln!(
            out,
            "<a href=\"{}\" title=\"full size\"><img src=\"{}\" width=\"{}\" height=\"{}\" alt=\"{} observation {} of {}\"></a>",
            Esc(&img.full),
            Esc(&img.thumb),
            img.width,
            img.height,
            Esc(&o.phase),
            o.obs,
            Esc(&c.title)
        )?,
        None => writeln!(out, "<div class=\"noimg\">{}</div>", Esc(&o.no_image))?,
    }
    writeln!(
        out,
        "<div class=\"body\">\n<div class=\"line\"><span class=\"badge {}\">{}</span><span class=\"mono\">{} #{}</span></div>",
        o.class,
        Esc(&o.outcome),
        Esc(&o.phase),
        o.obs
    )?;
    writeln!(out, "<div class=\"line\"><span>expected</span><b>{}</b></div>", Esc(&o.expected))?;
    writeln!(out, "<div class=\"line\"><span>given</span><b>{}</b></div>", Esc(&o.given))?;
    writeln!(out, "<p class=\"reply\">{}</p>", Esc(&o.reply))?;
    if o.resamples > 0 {
        writeln!(
            out,
            "<div class=\"line vis\"><span>resampled</span><b>{} scene{} redrawn</b></div>",
            o.resamples,
            if o.resamples == 1 { "" } else { "s" }
        )?;
    }
    for seen in &o.seen {
        writeln!(out, "<div class=\"seen\">{}</div>", Esc(seen))?;
    }
    if let Some(full) = &o.full {
        writeln!(
            out,
            "<details><summary>full reply ({} characters)</summary><pre>{}</pre></details>",
            o.chars,
            Esc(full)
        )?;
    }
    out.push_str("</div>\n</div>\n");
    Ok(())
}

/// Failing sets that do not lift over a passing part, each beside that part.
fn write_not_distinct(out: &mut String, p: &IndexPage<'_>) -> fmt::Result {
    if p.not_distinct.is_empty() {
        return Ok(());
    }
    writeln!(out, "<section id=\"not-distinct\">\n<h2>Not distinct ({})</h2>", p.not_distinct.len())?;
    out.push_str("<p class=\"note\">Sets that fail, but not significantly more often than a part of them one concept smaller that passes (one-sided two-proportion test at 99%, each topped up to twice the sequential test's limit while undecided): the part's failure rate sits near the threshold, and the extra concept adds nothing. They are no failure mode of their own.</p>\n<div class=\"card\">");
    out.push_str("<table class=\"tbl\">\n<thead><tr><th class=\"num\">#</th><th>concepts</th><th class=\"num\">FR</th><th class=\"num\">95% CI</th><th class=\"num\">n</th><th>passing part</th><th class=\"num\">FR</th><th class=\"num\">95% CI</th><th class=\"num\">n</th></tr></thead>\n<tbody>\n");
    for (set, by) in &p.not_distinct {
        writeln!(
            out,
            "<tr><td class=\"num\">{}</td><td>{}</td>{}<td>{}</td>{}</tr>",
            set.rank,
            Concepts(&set.concepts),
            RateCells(set),
            Concepts(&by.concepts),
            RateCells(by)
        )?;
    }
    out.push_str("</tbody>\n</table>\n</div>\n</section>\n\n");
    Ok(())
}

/// Concept names as `<code>a</code> + <code>b</code>`.
struct Concepts<'a>(&'a [String]);

impl fmt::Display for Concepts<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, name) in self.0.iter().enumerate() {
            let sep = if i > 0 { " + " } else { "" };
            write!(f, "{sep}<code>{}</code>", Esc(name))?;
        }
        Ok(())
    }
}

/// A row's FR, 95 % CI and n cells.
struct RateCells<'a>(&'a ModeRow);

impl fmt::Display for RateCells<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = self.0;
        write!(
            f,
            "<td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td>",
            Esc(&m.fr),
            Esc(&m.ci),
            m.answered
        )
    }
}

/// A table of failure modes (the larger ones of a core, the others, the refuted).
fn write_modes(out: &mut String, rows: &[ModeRow]) -> fmt::Result {
    out.push_str("<table class=\"tbl\">\n<thead><tr><th class=\"num\">#</th><th>concepts</th><th class=\"num\">FR</th><th class=\"num\">95% CI</th><th class=\"num\">n</th><th class=\"num\">validated</th></tr></thead>\n<tbody>\n");
    for m in rows {
        writeln!(
            out,
            "<tr><td class=\"num\">{}</td><td>{}</td>{}<td class=\"num\">{}</td></tr>",
            m.rank,
            Concepts(&m.concepts),
            RateCells(m),
            Esc(&m.validated)
        )?;
    }
    out.push_str("</tbody>\n</table>\n");
    Ok(())
}

fn write_concepts(out: &mut String, p: &IndexPage<'_>) -> fmt::Result {
    out.push_str("<section id=\"concepts\">\n<h2>Concepts</h2>\n<p class=\"note\">F(c): the mean failure rate of the evaluated sets that contain concept c; n: how many such sets. A concept the search rarely combined has a wide margin of error.</p>\n<div class=\"card\">\n<table class=\"tbl\">\n<thead><tr><th>concept</th><th class=\"num\">F(c)</th><th></th><th class=\"num\">n sets</th><th class=\"num\">failure modes</th></tr></thead>\n<tbody>\n");
    for r in &p.concepts {
        writeln!(
            out,
            "<tr><td><code>{}</code></td><td class=\"num\">{}</td><td><div class=\"bar\"><span style=\"width: {}%\"></span></div></td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            Esc(&r.concept),
            Esc(&r.f),
            Esc(&r.bar),
            r.n,
            r.failure_modes
        )?;
    }
    write_more(out, 5, p.concepts_total - p.concepts.len(), "concepts, lower F(c)", "concepts.csv")?;
    out.push_str("</tbody>\n</table>\n</div>\n</section>\n\n");
    Ok(())
}

fn write_pairs(out: &mut String, p: &IndexPage<'_>) -> fmt::Result {
    out.push_str("<section id=\"pairs\">\n<h2>Pair failure rates</h2>\n<p class=\"note\">Cell (a, b): the mean failure rate of the evaluated sets holding both a and b (the diagonal is F(c)); hatched where no evaluated set holds both. The table under the plot gives each pair's rate and count.</p>\n");
    if let Some(note) = &p.heatmap_note {
        writeln!(out, "<p class=\"note\">{}</p>", Esc(note))?;
    }
    writeln!(out, "<div class=\"card plot\">{}", p.heatmap)?;
    writeln!(out, "<details><summary>{} evaluated pairs, highest rate first</summary>", p.pairs_total)?;
    out.push_str("<table class=\"tbl\">\n<thead><tr><th>concepts</th><th class=\"num\">FR</th><th class=\"num\">n sets</th></tr></thead>\n<tbody>\n");
    for r in &p.pairs {
        writeln!(
            out,
            "<tr><td><code>{}</code></td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            Esc(&r.pair),
            Esc(&r.fr),
            r.n
        )?;
    }
    write_more(out, 3, p.pairs_total - p.pairs.len(), "pairs, lower rates", "pairs.csv")?;
    out.push_str("</tbody>\n</table>\n</details>\n</div>\n</section>\n\n");
    Ok(())
}

/// The last row of a table cut at [`super::scale::TABLE_ROWS`]: how many rows are not shown
/// and the file that holds them (nothing when none is left out).
fn write_more(out: &mut String, columns: usize, more: usize, what: &str, file: &str) -> fmt::Result {
    if more == 0 {
        return Ok(());
    }
    writeln!(
        out,
        "<tr class=\"more\"><td colspan=\"{columns}\">{more} more {what}: every row is in <a href=\"{file}\">{file}</a></td></tr>"
    )
}

fn write_discovery_and_outcomes(out: &mut String, p: &IndexPage<'_>) -> fmt::Result {
    out.push_str("<div class=\"two\">\n<section id=\"discovery\">\n<h2>Discovery</h2>\n<p class=\"note\">Failure modes and distinct cores found against inferences spent (validation excluded). A failure mode counts at its last observation, a core at the first failure mode that contains it.</p>\n");
    writeln!(out, "<div class=\"card plot\">{}</div>\n</section>\n", p.discovery)?;
    out.push_str("<section id=\"outcomes\">\n<h2>Outcomes</h2>\n<p class=\"note\">Every observation by phase. Only correct and wrong answers enter a failure rate; the rest are counted here.</p>\n<div class=\"card\">\n<table class=\"tbl\">\n<thead><tr><th>outcome</th>");
    for phase in &p.outcome_phases {
        write!(out, "<th class=\"num\">{}</th>", Esc(phase))?;
    }
    out.push_str("</tr></thead>\n<tbody>\n");
    for r in &p.outcome_rows {
        write!(out, "<tr><td><span class=\"badge {}\">{}</span></td>", r.class, Esc(&r.outcome))?;
        for n in &r.counts {
            write!(out, "<td class=\"num\">{n}</td>")?;
        }
        out.push_str("</tr>\n");
    }
    out.push_str("</tbody>\n</table>\n</div>\n</section>\n</div>\n\n");
    Ok(())
}

/// `12/20`: wrong of answered, the counts behind a rate.
fn counts(wrong: u64, answered: u64) -> String {
    format!("{wrong}/{answered}")
}

fn write_visibility(out: &mut String, v: &VisibilityView) -> fmt::Result {
    out.push_str("<section id=\"visibility\">\n<h2>Visibility</h2>\n<p class=\"note\">The builtin renderer measures, in the image it shows, each placed entity's visible pixels after occlusion and its contrast against its surround. A scene in which an entity that a concept placed is not visible by the domain's thresholds is drawn again with the next seed; if it stays hidden the observation is <b>invisible</b>: never shown to the model, neither failure nor success. Each scene counts once, however many models a transfer showed it to; a scene whose concepts place no entity (a weather, a town) has nothing to measure.</p>\n<div class=\"card\">\n");
    let measured: u64 = v.phases.iter().map(|(_, s)| s.measured).sum();
    if measured == 0 {
        out.push_str("<p class=\"note\">No scene of this run has visibility figures: its renderer does not measure them (only the builtin one does), or the run predates them.</p>\n");
    }
    out.push_str("<table class=\"tbl\">\n<thead><tr><th>phase</th><th class=\"num\">scenes</th><th class=\"num\">measured</th><th class=\"num\">resampled</th><th class=\"num\">scenes redrawn</th><th class=\"num\">invisible</th></tr></thead>\n<tbody>\n");
    for (phase, s) in &v.phases {
        writeln!(
            out,
            "<tr><td>{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            Esc(phase),
            s.scenes,
            s.measured,
            s.resampled,
            s.redraws,
            s.invisible
        )?;
    }
    out.push_str("</tbody>\n</table>\n");
    if v.cores.is_empty() {
        out.push_str("<p class=\"note\">No core's scene needed resampling.</p>\n");
    } else {
        out.push_str("<h3>Cores whose scenes needed resampling</h3>\n<table class=\"tbl\">\n<thead><tr><th>core</th><th class=\"num\">scenes</th><th class=\"num\">resampled</th><th class=\"num\">scenes redrawn</th><th class=\"num\">invisible</th></tr></thead>\n<tbody>\n");
        for (anchor, key, s) in &v.cores {
            writeln!(
                out,
                "<tr><td><a href=\"#{}\"><code>{}</code></a></td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
                Esc(anchor),
                Esc(key),
                s.scenes,
                s.resampled,
                s.redraws,
                s.invisible
            )?;
        }
        out.push_str("</tbody>\n</table>\n");
    }
    if !v.concepts.is_empty() {
        writeln!(
            out,
            "<details><summary>visible pixels and contrast of each concept's entities ({} concepts, fewest pixels first)</summary>",
            v.concepts.len()
        )?;
        out.push_str("<table class=\"tbl\">\n<thead><tr><th>concept</th><th class=\"num\">entities measured</th><th class=\"num\">min px</th><th class=\"num\">median px</th><th class=\"num\">median contrast</th></tr></thead>\n<tbody>\n");
        for c in &v.concepts {
            writeln!(
                out,
                "<tr><td><code>{}</code></td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{:.3}</td></tr>",
                Esc(&c.concept),
                c.n,
                c.min_pixels,
                c.median_pixels,
                c.median_contrast
            )?;
        }
        out.push_str("</tbody>\n</table>\n</details>\n");
    }
    out.push_str("</div>\n</section>\n\n");
    Ok(())
}

fn mechanism_class(m: Option<Mechanism>) -> &'static str {
    match m {
        Some(Mechanism::Recognition) => "o-wrong",
        Some(Mechanism::Reasoning) => "o-correct",
        _ => "o-other",
    }
}

fn write_probe(out: &mut String, p: &ProbeReport) -> fmt::Result {
    let a = &p.analysis;
    let t = &a.thresholds;
    writeln!(
        out,
        "<section id=\"probe\">\n<h2>Recognition vs reasoning</h2>\n<p class=\"note\">From <code>probe.json</code> (<code>revelio probe</code>, paper appendix G): {} sets × {} observations asked of <code>{}</code> with the safety question and, for each concept present, its probe statement and its counterfactual, marked True or False in the same reply. R(c): the share of c's statements marked right; F(c): the mean failure rate of the probed sets holding c, over n sets. A concept the model sees (R ≥ {:.0}%) yet fails on is a <b>reasoning</b> failure; one it does not see (R ≤ {:.0}%) a <b>recognition</b> failure; between, mixed. A statement the reply left unmarked is unanswered, never guessed.</p>",
        p.top,
        p.samples,
        Esc(&p.model),
        100.0 * t.high,
        100.0 * t.low
    )?;
    out.push_str("<div class=\"card\">\n<table class=\"tbl\">\n<thead><tr><th>concept</th><th class=\"num\">R(c)</th><th class=\"num\">95% CI</th><th class=\"num\">statements right</th><th class=\"num\">F(c)</th><th class=\"num\">n sets</th><th>mechanism</th></tr></thead>\n<tbody>\n");
    for c in &a.concepts {
        let m = &c.marks;
        let (right, answered) = (u64::from(m.pos_correct + m.neg_correct), u64::from(m.pos_total + m.neg_total));
        writeln!(
            out,
            "<tr><td><code>{}</code></td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td><td><span class=\"badge {}\">{}</span></td></tr>",
            Esc(&c.concept),
            Esc(&pct(c.recognition)),
            Esc(&interval(anytime95(right, answered))),
            Esc(&counts(right, answered)),
            Esc(&pct(c.failure)),
            c.n,
            mechanism_class(c.mechanism),
            Esc(c.mechanism.map_or("no answer", |m| m.name()))
        )?;
    }
    out.push_str("</tbody>\n</table>\n");
    if p.unanswered_statements > 0 {
        writeln!(
            out,
            "<p class=\"note\">{} statements were left unmarked by the replies.</p>",
            p.unanswered_statements
        )?;
    }
    out.push_str("</div>\n");
    writeln!(
        out,
        "<h3>Lift</h3>\n<p class=\"note\">Lift(A, B) = the mean FR of the probed sets holding both − the independence prediction F(A) + F(B) − F(A)·F(B): positive when A and B fail together more than apart (synergy), negative when they fail less (interference). Pairs whose concepts are each in ≥ {} probed sets; n: sets holding both — with few, read the sign, not the size. Largest |lift| first.</p>\n<div class=\"card\">",
        t.min_n
    )?;
    if a.pairs.is_empty() {
        writeln!(
            out,
            "<p class=\"note\">No pair has both concepts in ≥ {} probed sets and a set holding both.</p>",
            t.min_n
        )?;
    } else {
        out.push_str("<table class=\"tbl\">\n<thead><tr><th>pair</th><th class=\"num\">joint FR</th><th class=\"num\">independent</th><th class=\"num\">lift</th><th class=\"num\">n sets</th></tr></thead>\n<tbody>\n");
        for r in &a.pairs {
            writeln!(
                out,
                "<tr><td><code>{}</code> + <code>{}</code></td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{:+.1}</td><td class=\"num\">{}</td></tr>",
                Esc(&r.a),
                Esc(&r.b),
                Esc(&pct(Some(r.joint))),
                Esc(&pct(Some(r.independent))),
                100.0 * r.lift,
                r.n
            )?;
        }
        out.push_str("</tbody>\n</table>\n");
    }
    writeln!(out, "<details><summary>the {} probed sets and their failure rates</summary>", p.sets.len())?;
    out.push_str("<table class=\"tbl\">\n<thead><tr><th class=\"num\">#</th><th>concepts</th><th class=\"num\">FR</th><th class=\"num\">95% CI</th><th class=\"num\">wrong/answered</th></tr></thead>\n<tbody>\n");
    for (i, s) in p.sets.iter().enumerate() {
        writeln!(
            out,
            "<tr><td class=\"num\">{}</td><td><code>{}</code></td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            i + 1,
            Esc(&s.concepts.join(" + ")),
            Esc(&pct(s.fr)),
            Esc(&interval(anytime95(u64::from(s.wrong), u64::from(s.answered)))),
            Esc(&counts(u64::from(s.wrong), u64::from(s.answered)))
        )?;
    }
    writeln!(
        out,
        "</tbody>\n</table>\n</details>\n<p class=\"note\">Probe spend: {}</p>\n</div>\n</section>\n",
        Esc(&p.spend.line())
    )
}

/// One set's row of the transfer table: its FR on the search, then on each model.
fn write_transfer_rows(out: &mut String, t: &Transfer, lines: &[crate::analysis::transfer::SetLine]) -> fmt::Result {
    for (i, s) in lines.iter().enumerate() {
        write!(
            out,
            "<tr><td class=\"num\">{}</td><td><code>{}</code></td><td class=\"num\">{}</td>",
            i + 1,
            Esc(&s.concepts.join(" + ")),
            Esc(&pct(s.source_fr))
        )?;
        for m in 0..t.models.len() {
            let (wrong, n) = (u64::from(s.wrong(m)), u64::from(s.answered.get(m).copied().unwrap_or(0)));
            let hit = s.target_fr.get(m).copied().flatten().is_some_and(|f| f >= t.threshold);
            write!(
                out,
                "<td class=\"num{}\">{} <span class=\"ci\">{}</span></td>",
                if hit { " hit" } else { "" },
                Esc(&pct(s.target_fr.get(m).copied().flatten())),
                Esc(&interval(anytime95(wrong, n)))
            )?;
        }
        out.push_str("</tr>\n");
    }
    Ok(())
}

fn write_transfer(out: &mut String, r: &TransferReport) -> fmt::Result {
    let t = &r.transfer;
    writeln!(
        out,
        "<section id=\"transfer\">\n<h2>Transfer to other models</h2>\n<p class=\"note\">From <code>transfer.json</code> (<code>revelio transfer</code>, paper RQ3): the run's top {} sets and {} random valid sets, {} observations each, asked of every model on the same scenes — each image rendered once and shown to all. M1 is the run's own model, asked again on those scenes. A set transfers to a model when its FR there is ≥ τ = {:.0}% (shaded). Brackets are 95% intervals: anytime-valid per set, Wilson for the pooled MFR.</p>\n<div class=\"card\">",
        t.sets.len(),
        t.random.len(),
        t.samples,
        100.0 * t.threshold
    )?;
    out.push_str("<table class=\"tbl\">\n<thead><tr><th>model</th><th></th><th class=\"num\">MFR transferred</th><th class=\"num\">MFR random</th><th class=\"num\">ratio</th><th class=\"num\">transfers</th><th class=\"num\">spend</th></tr></thead>\n<tbody>\n");
    for (m, row) in t.targets.iter().enumerate() {
        let (tw, tn) = pooled_counts(&t.sets, m);
        let (rw, rn) = pooled_counts(&t.random, m);
        writeln!(
            out,
            "<tr><td class=\"num\">M{}</td><td><code>{}</code></td><td class=\"num\">{} <span class=\"ci\">{}</span></td><td class=\"num\">{} <span class=\"ci\">{}</span></td><td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
            m + 1,
            Esc(&row.model),
            Esc(&pct(row.transferred_mfr)),
            Esc(&interval(wilson95(tw, tn))),
            Esc(&pct(row.random_mfr)),
            Esc(&interval(wilson95(rw, rn))),
            Esc(&row.ratio.map_or_else(|| "–".into(), |x| format!("{x:.1}×"))),
            Esc(&format!("{}/{}", row.transfers, t.sets.len())),
            Esc(&r.spend.get(m).map_or_else(|| "–".into(), |s| format!("${:.4}", s.cost_usd)))
        )?;
    }
    out.push_str("</tbody>\n</table>\n</div>\n<div class=\"card\">\n<table class=\"tbl\">\n<thead><tr><th class=\"num\">#</th><th>transferred set</th><th class=\"num\">search</th>");
    for m in 1..=t.models.len() {
        write!(out, "<th class=\"num\">M{m}</th>")?;
    }
    out.push_str("</tr></thead>\n<tbody>\n");
    write_transfer_rows(out, t, &t.sets)?;
    out.push_str("</tbody>\n</table>\n");
    writeln!(out, "<details><summary>the {} random sets (the baseline)</summary>", t.random.len())?;
    out.push_str(
        "<table class=\"tbl\">\n<thead><tr><th class=\"num\">#</th><th>random set</th><th class=\"num\">search</th>",
    );
    for m in 1..=t.models.len() {
        write!(out, "<th class=\"num\">M{m}</th>")?;
    }
    out.push_str("</tr></thead>\n<tbody>\n");
    write_transfer_rows(out, t, &t.random)?;
    out.push_str("</tbody>\n</table>\n</details>\n</div>\n</section>\n\n");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_covers_text_and_both_quotes() {
        assert_eq!(Esc("a<b> & \"c\" 'd'").to_string(), "a&#60;b&#62; &#38; &#34;c&#34; &#39;d&#39;");
        assert_eq!(Esc("plain – ünïcode").to_string(), "plain – ünïcode");
    }
}
