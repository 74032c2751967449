//! The report's plots as SVG: the geometry is computed here, the markup is written by the
//! `discovery.svg` and `heatmap.svg` templates (escaped like the page). The same text is saved as
//! a standalone file and inlined in `index.html`, where cell tooltips (`<title>`) work.

use std::fmt;

use askama::Template;

use crate::analysis::{Discovery, DiscoveryPoint, PairRates};

/// A coordinate in SVG user units, written with at most one decimal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Px(pub f64);

impl fmt::Display for Px {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = (self.0 * 10.0).round() / 10.0;
        if v.fract() == 0.0 { write!(f, "{}", v as i64) } else { write!(f, "{v:.1}") }
    }
}

pub struct Frame {
    pub left: Px,
    pub right: Px,
    pub top: Px,
    pub bottom: Px,
}

pub struct Tick {
    pub pos: Px,
    pub tick_end: Px,
    pub text_x: Px,
    pub text_y: Px,
    pub label: String,
}

pub struct Marker {
    pub pos: Px,
    pub text_x: Px,
    pub text_y: Px,
    pub label: String,
}

pub struct Series {
    pub name: String,
    pub color: &'static str,
    /// `x,y` pairs separated by spaces.
    pub points: String,
    pub key_x0: Px,
    pub key_x1: Px,
    pub key_y: Px,
    pub text_x: Px,
    pub text_y: Px,
}

pub struct Text {
    pub x: Px,
    pub y: Px,
    pub text: String,
}

pub struct Rect {
    pub x: Px,
    pub y: Px,
    pub w: Px,
    pub h: Px,
}

#[derive(Template)]
#[template(path = "discovery.svg")]
pub struct DiscoverySvg {
    pub title: String,
    pub width: u32,
    pub height: u32,
    pub frame: Frame,
    pub x_ticks: Vec<Tick>,
    pub y_ticks: Vec<Tick>,
    pub markers: Vec<Marker>,
    pub series: Vec<Series>,
    pub x_label: Text,
    pub y_label: Text,
}

/// Tick values 0, step, 2·step, … up to the first at or above `max`, with a 1-2-5 step giving
/// about `target` intervals.
pub fn nice_ticks(max: f64, target: usize) -> Vec<f64> {
    let max = max.max(1.0);
    let raw = max / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
    let step = step.max(1.0); // counts: whole numbers only
    let n = (max / step).ceil() as usize;
    (0..=n).map(|i| i as f64 * step).collect()
}

fn count_label(v: f64) -> String {
    format!("{}", v.round() as i64)
}

/// The discovery curve: failure modes and distinct cores found against inferences.
pub fn discovery(d: &Discovery) -> String {
    let (width, height) = (560u32, 300u32);
    let frame = Frame {
        left: Px(52.0),
        right: Px(f64::from(width) - 18.0),
        top: Px(14.0),
        bottom: Px(f64::from(height) - 46.0),
    };
    let xs = nice_ticks(d.inferences as f64, 5);
    let y_max = d.points.iter().map(|p| p.failure_modes.max(p.cores)).max().unwrap_or(0);
    let ys = nice_ticks(y_max as f64, 5);
    let (x_hi, y_hi) = (*xs.last().unwrap_or(&1.0), *ys.last().unwrap_or(&1.0));
    let x = |v: f64| frame.left.0 + (frame.right.0 - frame.left.0) * v / x_hi;
    let y = |v: f64| frame.bottom.0 - (frame.bottom.0 - frame.top.0) * v / y_hi;
    let x_ticks = xs
        .iter()
        .map(|&v| Tick {
            pos: Px(x(v)),
            tick_end: Px(frame.bottom.0 + 4.0),
            text_x: Px(x(v)),
            text_y: Px(frame.bottom.0 + 17.0),
            label: count_label(v),
        })
        .collect();
    let y_ticks = ys
        .iter()
        .map(|&v| Tick {
            pos: Px(y(v)),
            tick_end: Px(frame.left.0),
            text_x: Px(frame.left.0 - 6.0),
            text_y: Px(y(v) + 4.0),
            label: count_label(v),
        })
        .collect();
    type Count = fn(&DiscoveryPoint) -> usize;
    let step_line = |value: Count| {
        let mut pts: Vec<String> = Vec::new();
        let mut prev: Option<usize> = None;
        for p in &d.points {
            let px = Px(x(p.inferences as f64));
            if let Some(before) = prev {
                pts.push(format!("{px},{}", Px(y(before as f64))));
            }
            pts.push(format!("{px},{}", Px(y(value(p) as f64))));
            prev = Some(value(p));
        }
        pts.join(" ")
    };
    let lines: [(&str, &'static str, Count); 2] =
        [("failure modes", "#c92a2a", |p| p.failure_modes), ("distinct cores", "#3b5bdb", |p| p.cores)];
    let series = lines
        .iter()
        .enumerate()
        .map(|(i, &(name, color, value))| {
            let key_y = frame.top.0 + 12.0 + 18.0 * i as f64;
            Series {
                name: name.to_string(),
                color,
                points: step_line(value),
                key_x0: Px(frame.left.0 + 12.0),
                key_x1: Px(frame.left.0 + 32.0),
                key_y: Px(key_y),
                text_x: Px(frame.left.0 + 38.0),
                text_y: Px(key_y + 4.0),
            }
        })
        .collect();
    let markers = d
        .phase_starts
        .iter()
        .map(|(at, phase)| {
            let pos = x(*at as f64);
            Marker {
                pos: Px(pos),
                text_x: Px(pos + 4.0),
                text_y: Px(frame.top.0 + 12.0),
                label: super::phase_name(*phase),
            }
        })
        .collect();
    let svg = DiscoverySvg {
        title: "Failure modes and distinct cores found against inferences".into(),
        width,
        height,
        x_label: Text {
            x: Px((frame.left.0 + frame.right.0) / 2.0),
            y: Px(f64::from(height) - 8.0),
            text: "inferences".into(),
        },
        y_label: Text { x: Px(14.0), y: Px((frame.top.0 + frame.bottom.0) / 2.0), text: "found".into() },
        frame,
        x_ticks,
        y_ticks,
        markers,
        series,
    };
    svg.render().expect("the discovery template renders")
}

pub struct Cell {
    pub x: Px,
    pub y: Px,
    pub fill: String,
    pub title: String,
}

pub struct Stop {
    pub offset: String,
    pub color: String,
}

#[derive(Template)]
#[template(path = "heatmap.svg")]
pub struct HeatmapSvg {
    pub title: String,
    pub width: u32,
    pub height: u32,
    pub row_labels: Vec<Text>,
    pub col_labels: Vec<Text>,
    pub grid: Rect,
    pub cell: Px,
    pub cells: Vec<Cell>,
    pub legend: Rect,
    pub legend_stops: Vec<Stop>,
    pub legend_ticks: Vec<Text>,
}

/// The colour of a failure rate: pale (0) through orange to dark red (1).
pub fn heat(fr: f64) -> String {
    const STOPS: [(f64, [f64; 3]); 3] =
        [(0.0, [255.0, 245.0, 235.0]), (0.5, [253.0, 141.0, 60.0]), (1.0, [165.0, 15.0, 21.0])];
    let fr = fr.clamp(0.0, 1.0);
    let i = if fr <= STOPS[1].0 { 0 } else { 1 };
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let t = (fr - a.0) / (b.0 - a.0);
    let c: Vec<u8> = (0..3).map(|k| (a.1[k] + t * (b.1[k] - a.1[k])).round() as u8).collect();
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// Width of a label at 12 px, estimated (no font metrics here): generous, so labels never clip.
fn label_width(s: &str) -> f64 {
    s.chars().count() as f64 * 7.2
}

/// The concept × concept heatmap of pair failure rates.
pub fn heatmap(p: &PairRates) -> String {
    let k = p.concepts.len();
    let cell = 18.0;
    let longest = p.concepts.iter().map(|c| label_width(c)).fold(40.0, f64::max);
    let (sin, cos) = (55f64.to_radians().sin(), 55f64.to_radians().cos());
    let left = longest + 14.0;
    let top = longest * sin + 16.0;
    let grid = cell * k as f64;
    let overhang = longest * cos - cell * 0.5;
    let legend_x = left + grid + 22.0;
    let width = (legend_x + 60.0).max(left + grid + overhang + 8.0).ceil();
    let height = (top + grid.max(120.0) + 12.0).ceil();
    let row_labels = p
        .concepts
        .iter()
        .enumerate()
        .map(|(i, c)| Text { x: Px(left - 6.0), y: Px(top + cell * i as f64 + cell * 0.5 + 4.0), text: c.clone() })
        .collect();
    let col_labels = p
        .concepts
        .iter()
        .enumerate()
        .map(|(j, c)| Text { x: Px(left + cell * j as f64 + cell * 0.5), y: Px(top - 6.0), text: c.clone() })
        .collect();
    let mut cells = Vec::new();
    for (i, row) in p.cells.iter().enumerate() {
        for (j, c) in row.iter().enumerate() {
            let Some(c) = c else { continue };
            let sets = if c.n == 1 { "set" } else { "sets" };
            let title = if i == j {
                format!("{}: F(c) {:.0}% over {} {sets}", p.concepts[i], 100.0 * c.fr, c.n)
            } else {
                format!("{} + {}: {:.0}% over {} {sets}", p.concepts[i], p.concepts[j], 100.0 * c.fr, c.n)
            };
            cells.push(Cell { x: Px(left + cell * j as f64), y: Px(top + cell * i as f64), fill: heat(c.fr), title });
        }
    }
    let legend_h = grid.clamp(120.0, 240.0);
    let legend_stops =
        [0.0, 0.25, 0.5, 0.75, 1.0].iter().map(|&v| Stop { offset: format!("{v}"), color: heat(v) }).collect();
    let legend_ticks = [0.0, 0.5, 1.0]
        .iter()
        .map(|&v| Text {
            x: Px(legend_x + 20.0),
            y: Px(top + legend_h * (1.0 - v) + 4.0),
            text: format!("{:.0}%", 100.0 * v),
        })
        .collect();
    let svg = HeatmapSvg {
        title: "Mean failure rate of the evaluated sets holding each pair of concepts".into(),
        width: width as u32,
        height: height as u32,
        row_labels,
        col_labels,
        grid: Rect { x: Px(left), y: Px(top), w: Px(grid), h: Px(grid) },
        cell: Px(cell),
        cells,
        legend: Rect { x: Px(legend_x), y: Px(top), w: Px(14.0), h: Px(legend_h) },
        legend_stops,
        legend_ticks,
    };
    svg.render().expect("the heatmap template renders")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_use_1_2_5_steps_and_cover_the_maximum() {
        assert_eq!(nice_ticks(1000.0, 5), vec![0.0, 200.0, 400.0, 600.0, 800.0, 1000.0]);
        assert_eq!(nice_ticks(37.0, 5), vec![0.0, 10.0, 20.0, 30.0, 40.0]);
        assert_eq!(nice_ticks(0.0, 5), vec![0.0, 1.0]);
        assert_eq!(nice_ticks(3.0, 5), vec![0.0, 1.0, 2.0, 3.0]);
    }

    #[test]
    fn coordinates_print_short_and_colours_span_the_scale() {
        assert_eq!(Px(12.0).to_string(), "12");
        assert_eq!(Px(12.349).to_string(), "12.3");
        assert_eq!(heat(0.0), "#fff5eb");
        assert_eq!(heat(1.0), "#a50f15");
        assert_eq!(heat(0.5), "#fd8d3c");
    }

    #[test]
    fn heatmap_escapes_names_and_titles_every_cell() {
        let p = crate::analysis::PairRates {
            concepts: vec!["a<b".into(), "c".into()],
            cells: vec![
                vec![Some(crate::analysis::PairRate { fr: 1.0, n: 2 }), None],
                vec![None, Some(crate::analysis::PairRate { fr: 0.0, n: 1 })],
            ],
        };
        let svg = heatmap(&p);
        assert!(svg.contains("a&#60;b") && !svg.contains("a<b"), "{svg}");
        assert_eq!(svg.matches("<title>").count(), 3, "{svg}");
        assert!(svg.contains("F(c) 100% over 2 sets"));
    }
}
