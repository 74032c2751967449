//! The report's plots, drawn with `plotters` on its SVG backend (which escapes every text it
//! writes). The same text is saved as a standalone file and inlined in `index.html`.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::analysis::{Discovery, DiscoveryPoint, PairRates};

const FONT: &str = "system-ui, DejaVu Sans, Arial, sans-serif";
const INK: RGBColor = RGBColor(0x1f, 0x23, 0x28);
const MUTED: RGBColor = RGBColor(0x59, 0x63, 0x6e);
const GRID: RGBColor = RGBColor(0xe9, 0xec, 0xef);
const HATCH: RGBColor = RGBColor(0xd5, 0xda, 0xe0);
const FRAME: RGBColor = RGBColor(0xde, 0xe2, 0xe6);
const MODES: RGBColor = RGBColor(0xc9, 0x2a, 0x2a);
const CORES: RGBColor = RGBColor(0x3b, 0x5b, 0xdb);
const MARKER: RGBColor = RGBColor(0x86, 0x8e, 0x96);

/// Text of `px` pixels: the SVG backend writes `font-size` as the size given divided by 1.24.
fn text(px: f64, color: RGBColor) -> TextStyle<'static> {
    (FONT, px * 1.24).into_font().color(&color)
}

/// A drawing error as the report states it (the SVG backend writes to a string and has no
/// fonts to load, so this is not expected to happen).
fn drawing<E: std::fmt::Debug>(what: &str) -> impl Fn(E) -> String + '_ {
    move |e| format!("cannot draw the {what}: {e:?}")
}

/// Plotters writes no title: one after the root tag names the plot for screen readers and as
/// the standalone file's tooltip. `title` is ours, plain text without markup characters.
fn titled(svg: String, title: &str) -> String {
    match svg.find(">\n") {
        Some(i) => format!("{}<title>{title}</title>\n{}", &svg[..i + 2], &svg[i + 2..]),
        None => svg,
    }
}

/// Tick values 0, step, 2·step, … up to the first at or above `max`, with the smallest 1-2-5
/// step giving at most `target + 1` intervals (so the axis ends close above the data).
pub fn nice_ticks(max: f64, target: usize) -> Vec<f64> {
    let max = max.max(1.0);
    let target = target.max(1);
    let mag = 10f64.powf((max / target as f64).log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|s| (max / s).ceil() as usize <= target + 1)
        .unwrap_or(10.0 * mag);
    let step = step.max(1.0); // counts: whole numbers only
    let n = (max / step).ceil() as usize;
    (0..=n).map(|i| i as f64 * step).collect()
}

const DISCOVERY_TITLE: &str = "Failure modes and distinct cores found against inferences";

/// The discovery curve: failure modes and distinct cores found against inferences.
pub fn discovery(d: &Discovery) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (560, 300)).into_drawing_area();
        draw_discovery(&root, d).map_err(drawing("discovery curve"))?;
        root.present().map_err(drawing("discovery curve"))?;
    }
    Ok(titled(svg, DISCOVERY_TITLE))
}

fn draw_discovery<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &Discovery,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    // Axes end on a round number at or above the data, so the last tick closes the frame.
    let xs = nice_ticks(d.inferences as f64, 5);
    let y_max = d.points.iter().map(|p| p.failure_modes.max(p.cores)).max().unwrap_or(0);
    let ys = nice_ticks(y_max as f64, 5);
    let x_hi = xs.last().copied().unwrap_or(1.0) as u64;
    let y_hi = ys.last().copied().unwrap_or(1.0) as u64;
    let mut chart = ChartBuilder::on(root)
        .margin_top(14)
        .margin_right(18)
        .margin_left(6)
        .margin_bottom(6)
        .x_label_area_size(40)
        .y_label_area_size(46)
        .build_cartesian_2d(0..x_hi, 0..y_hi)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .light_line_style(TRANSPARENT)
        .bold_line_style(GRID)
        .axis_style(MUTED)
        .x_labels(xs.len())
        .y_labels(ys.len())
        .label_style(text(12.0, MUTED))
        .axis_desc_style(text(12.0, INK))
        .x_desc("inferences")
        .y_desc("found")
        .draw()?;
    for &(at, phase) in &d.phase_starts {
        let style = ShapeStyle::from(MARKER).stroke_width(1);
        chart.draw_series(DashedLineSeries::new([(at, 0), (at, y_hi)], 4, 3, style))?;
        let label = Text::new(super::phase_name(phase), (4, 4), text(12.0, MUTED));
        chart.draw_series(std::iter::once(EmptyElement::at((at, y_hi)) + label))?;
    }
    // A step line: flat until the next point, then up. Cores are drawn thinner on top, so where
    // the two counts agree the failure modes' red still shows around the blue.
    type Count = fn(&DiscoveryPoint) -> usize;
    let steps = |value: Count| {
        let mut pts = Vec::new();
        for (i, p) in d.points.iter().enumerate() {
            if i > 0 {
                pts.push((p.inferences, value(&d.points[i - 1]) as u64));
            }
            pts.push((p.inferences, value(p) as u64));
        }
        pts
    };
    let lines: [(&str, RGBColor, u32, Count); 2] =
        [("failure modes", MODES, 4, |p| p.failure_modes), ("distinct cores", CORES, 2, |p| p.cores)];
    for (name, color, width, value) in lines {
        chart
            .draw_series(LineSeries::new(steps(value), color.stroke_width(width)))?
            .label(name)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(3)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(WHITE)
        .label_font(text(12.0, INK))
        .draw()?;
    Ok(())
}

/// The colour of a failure rate: pale (0) through orange to dark red (1).
pub fn heat(fr: f64) -> RGBColor {
    const STOPS: [(f64, [f64; 3]); 3] =
        [(0.0, [255.0, 245.0, 235.0]), (0.5, [253.0, 141.0, 60.0]), (1.0, [165.0, 15.0, 21.0])];
    let fr = fr.clamp(0.0, 1.0);
    let i = if fr <= STOPS[1].0 { 0 } else { 1 };
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let t = (fr - a.0) / (b.0 - a.0);
    let c = |k: usize| (a.1[k] + t * (b.1[k] - a.1[k])).round() as u8;
    RGBColor(c(0), c(1), c(2))
}

/// Width of a label at 12 px, estimated (no font metrics here): generous, so labels never clip.
fn label_width(s: &str) -> i32 {
    (s.chars().count() as f64 * 7.2).ceil() as i32
}

const CELL: i32 = 18;
const HEATMAP_TITLE: &str = "Mean failure rate of the evaluated sets holding each pair of concepts";

/// Where the heatmap's parts go, in pixels.
struct Layout {
    left: i32,
    top: i32,
    grid: i32,
    legend_x: i32,
    legend_h: i32,
    /// The baseline of the line that says how many concepts are not drawn (when some are not).
    note_y: Option<i32>,
    width: u32,
    height: u32,
}

impl Layout {
    fn of(p: &PairRates, hidden: usize) -> Layout {
        let longest = p.concepts.iter().map(|c| label_width(c)).fold(40, i32::max);
        // Column labels stand upright above the grid, row labels to its left.
        let (left, top) = (longest + 14, longest + 14);
        let grid = CELL * p.concepts.len() as i32;
        let legend_x = left + grid + 22;
        let legend_h = grid.clamp(120, 240);
        let bottom = top + grid.max(legend_h);
        let note_y = (hidden > 0).then_some(bottom + 18);
        let width = (legend_x + 60) as u32;
        let height = (bottom + if hidden > 0 { 30 } else { 12 }) as u32;
        Layout { left, top, grid, legend_x, legend_h, note_y, width, height }
    }
}

/// The line under a heatmap that leaves `hidden` concepts out.
pub fn hidden_note(shown: usize, hidden: usize) -> String {
    format!(
        "{hidden} more concepts not drawn: these {shown} are those of the cores, then those in the most failure modes"
    )
}

/// The concept × concept heatmap of pair failure rates; pairs never evaluated are hatched.
/// `hidden`: how many concepts of the run `p` leaves out (said in a line under the grid).
pub fn heatmap(p: &PairRates, hidden: usize) -> Result<String, String> {
    let layout = Layout::of(p, hidden);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (layout.width, layout.height)).into_drawing_area();
        draw_heatmap(&root, p, &layout, hidden).map_err(drawing("pair heatmap"))?;
        root.present().map_err(drawing("pair heatmap"))?;
    }
    Ok(titled(svg, HEATMAP_TITLE))
}

fn draw_heatmap<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &PairRates,
    l: &Layout,
    hidden: usize,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let label = text(12.0, INK);
    if let Some(y) = l.note_y {
        let note = text(12.0, MUTED).pos(Pos::new(HPos::Left, VPos::Center));
        root.draw(&Text::new(hidden_note(p.concepts.len(), hidden), (l.left, y), note))?;
    }
    for (i, c) in p.concepts.iter().enumerate() {
        let middle = CELL * i as i32 + CELL / 2;
        let row = label.pos(Pos::new(HPos::Right, VPos::Center));
        root.draw(&Text::new(c.as_str(), (l.left - 6, l.top + middle), row))?;
        let column = label.pos(Pos::new(HPos::Left, VPos::Center)).transform(FontTransform::Rotate270);
        root.draw(&Text::new(c.as_str(), (l.left + middle, l.top - 6), column))?;
    }
    // The hatch under the grid shows through wherever no evaluated set holds the pair.
    let (x0, y0, g) = (l.left, l.top, l.grid);
    for t in (6..2 * g).step_by(6) {
        let from = (x0 + (t - g).max(0), y0 + t.min(g));
        let to = (x0 + t.min(g), y0 + (t - g).max(0));
        root.draw(&PathElement::new([from, to], HATCH.stroke_width(1)))?;
    }
    root.draw(&Rectangle::new([(x0, y0), (x0 + g, y0 + g)], FRAME.stroke_width(1)))?;
    for (i, row) in p.cells.iter().enumerate() {
        for (j, c) in row.iter().enumerate() {
            let Some(c) = c else { continue };
            let (x, y) = (x0 + CELL * j as i32, y0 + CELL * i as i32);
            root.draw(&Rectangle::new([(x, y), (x + CELL, y + CELL)], WHITE.filled()))?;
            root.draw(&Rectangle::new([(x + 1, y + 1), (x + CELL - 1, y + CELL - 1)], heat(c.fr).filled()))?;
        }
    }
    // The legend: a column of thin bands from 0 % (bottom) to 100 % (top).
    let (lx, h) = (l.legend_x, l.legend_h);
    const BANDS: i32 = 48;
    for b in 0..BANDS {
        let (lo, hi) = (y0 + h - h * (b + 1) / BANDS, y0 + h - h * b / BANDS);
        let fr = (f64::from(b) + 0.5) / f64::from(BANDS);
        root.draw(&Rectangle::new([(lx, lo), (lx + 14, hi)], heat(fr).filled()))?;
    }
    root.draw(&Rectangle::new([(lx, y0), (lx + 14, y0 + h)], FRAME.stroke_width(1)))?;
    let tick = text(12.0, MUTED).pos(Pos::new(HPos::Left, VPos::Center));
    for v in [0, 50, 100] {
        root.draw(&Text::new(format!("{v}%"), (lx + 20, y0 + h - h * v / 100), tick.clone()))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::PairRate;

    #[test]
    fn ticks_use_1_2_5_steps_and_cover_the_maximum() {
        assert_eq!(nice_ticks(1000.0, 5), vec![0.0, 200.0, 400.0, 600.0, 800.0, 1000.0]);
        assert_eq!(nice_ticks(37.0, 5), vec![0.0, 10.0, 20.0, 30.0, 40.0]);
        assert_eq!(nice_ticks(0.0, 5), vec![0.0, 1.0]);
        assert_eq!(nice_ticks(3.0, 5), vec![0.0, 1.0, 2.0, 3.0]);
        assert_eq!(nice_ticks(1092.0, 5), vec![0.0, 200.0, 400.0, 600.0, 800.0, 1000.0, 1200.0]);
        assert_eq!(nice_ticks(52.0, 5), vec![0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0]);
    }

    #[test]
    fn colours_span_the_scale() {
        assert_eq!(heat(0.0), RGBColor(0xff, 0xf5, 0xeb));
        assert_eq!(heat(0.5), RGBColor(0xfd, 0x8d, 0x3c));
        assert_eq!(heat(1.0), RGBColor(0xa5, 0x0f, 0x15));
    }

    #[test]
    fn heatmap_escapes_names_and_colours_each_evaluated_pair() {
        let p = PairRates {
            concepts: vec!["a<b".into(), "c".into()],
            cells: vec![vec![Some(PairRate { fr: 1.0, n: 2 }), None], vec![None, Some(PairRate { fr: 0.0, n: 1 })]],
        };
        let svg = heatmap(&p, 0).unwrap();
        assert!(svg.contains("a&lt;b") && !svg.contains("a<b"), "{svg}");
        assert!(svg.contains(&format!("<title>{HEATMAP_TITLE}</title>")), "{svg}");
        // One cell at 100 % and one at 0 %: each colour once in the grid, once in the legend's ends.
        assert_eq!(svg.matches("fill=\"#A50F15\"").count(), 1, "{svg}");
        assert_eq!(svg.matches("fill=\"#FFF5EB\"").count(), 1, "{svg}");
    }

    #[test]
    fn a_heatmap_that_leaves_concepts_out_says_how_many() {
        let p = PairRates { concepts: vec!["a".into()], cells: vec![vec![Some(PairRate { fr: 0.5, n: 1 })]] };
        let whole = heatmap(&p, 0).unwrap();
        let cut = heatmap(&p, 459).unwrap();
        assert!(!whole.contains("not drawn"));
        assert!(cut.contains(&hidden_note(1, 459)), "{cut}");
        assert!(cut.contains("459 more concepts not drawn"));
    }

    #[test]
    fn discovery_has_both_lines_a_legend_and_phase_markers() {
        let point = |inferences, failure_modes, cores| DiscoveryPoint { inferences, failure_modes, cores };
        let d = Discovery {
            points: vec![point(0, 0, 0), point(40, 1, 1), point(90, 3, 1), point(120, 3, 2)],
            phase_starts: vec![(100, crate::journal::Phase::Shrink)],
            inferences: 120,
        };
        let svg = discovery(&d).unwrap();
        for needle in
            ["failure modes", "distinct cores", "inferences", "found", "shrink\n</text>", "stroke=\"#C92A2A\""]
        {
            assert!(svg.contains(needle), "`{needle}` missing:\n{svg}");
        }
        assert!(svg.starts_with("<svg ") && svg.trim_end().ends_with("</svg>"));
        // A run that spent nothing still draws its (empty) axes.
        let empty = Discovery { points: vec![point(0, 0, 0)], phase_starts: Vec::new(), inferences: 0 };
        assert!(discovery(&empty).unwrap().contains("inferences"));
        let one = Discovery { points: vec![point(0, 0, 0), point(1, 1, 1)], phase_starts: Vec::new(), inferences: 1 };
        assert!(discovery(&one).unwrap().contains("distinct cores"));
        let big = Discovery {
            points: vec![point(0, 0, 0), point(98_765, 412, 37)],
            phase_starts: Vec::new(),
            inferences: 98_765,
        };
        assert!(discovery(&big).unwrap().contains("100000"));
    }
}
