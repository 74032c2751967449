//! Ablation sweeps (`revelio bench search --sweep PARAM=v1,v2,…`, paper appendix on beam width,
//! beam budget, observations per set, τ and λ): which parameter, its values applied to the
//! search parameters, and the SVG plot of PFM and MFR (mean ± sd over seeds) per algorithm
//! against the swept value.

use plotters::prelude::*;
use serde::{Deserialize, Serialize};

use crate::search::Params;

/// A sweepable search parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SweepParam {
    BeamWidth,
    BeamBudget,
    Samples,
    Threshold,
    Lambda,
}

impl SweepParam {
    pub const ALL: [SweepParam; 5] =
        [SweepParam::BeamWidth, SweepParam::BeamBudget, SweepParam::Samples, SweepParam::Threshold, SweepParam::Lambda];

    pub fn name(self) -> &'static str {
        match self {
            SweepParam::BeamWidth => "beam_width",
            SweepParam::BeamBudget => "beam_budget",
            SweepParam::Samples => "samples",
            SweepParam::Threshold => "threshold",
            SweepParam::Lambda => "lambda",
        }
    }

    /// `params` with this parameter set to `v` (checked by `Params::validate` afterwards).
    pub fn apply(self, params: &Params, v: f64) -> Params {
        let mut p = params.clone();
        match self {
            SweepParam::BeamWidth => p.beam_width = v as usize,
            SweepParam::BeamBudget => p.beam_budget = v as u64,
            SweepParam::Samples => p.samples = v as u32,
            SweepParam::Threshold => p.threshold = v,
            SweepParam::Lambda => p.lambda = v,
        }
        p
    }

    fn integer(self) -> bool {
        matches!(self, SweepParam::BeamWidth | SweepParam::BeamBudget | SweepParam::Samples)
    }
}

/// A parsed `--sweep PARAM=v1,v2,…`.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    pub param: SweepParam,
    pub values: Vec<f64>,
}

impl std::str::FromStr for Sweep {
    type Err = String;

    fn from_str(s: &str) -> Result<Sweep, String> {
        let (name, values) = s.split_once('=').ok_or_else(|| format!("expected PARAM=v1,v2,…, got `{s}`"))?;
        let names = SweepParam::ALL.map(SweepParam::name).join(", ");
        let param = match SweepParam::ALL.into_iter().find(|p| p.name() == name.trim()) {
            Some(p) => p,
            None if name.trim() == "kernel" => {
                return Err(format!(
                    "the GP kernel cannot be swept yet: GPTS has only the paper's DotProduct + White kernel; sweepable: {names}"
                ));
            }
            None => return Err(format!("unknown parameter `{}`; sweepable: {names}", name.trim())),
        };
        let mut out = Vec::new();
        for v in values.split(',') {
            let x: f64 = v.trim().parse().map_err(|_| format!("`{}` is not a number", v.trim()))?;
            if !x.is_finite() || x < 0.0 || (param.integer() && x.fract() != 0.0) {
                let kind = if param.integer() { "a whole number ≥ 0" } else { "a number ≥ 0" };
                return Err(format!("`{}` for `{}` must be {kind}", v.trim(), param.name()));
            }
            out.push(x);
        }
        if out.len() < 2 {
            return Err(format!("a sweep needs at least two values of `{}`", param.name()));
        }
        Ok(Sweep { param, values: out })
    }
}

/// One point: an algorithm at one value, mean and sd over seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Point {
    pub algo: String,
    pub value: f64,
    pub pfm: (f64, f64),
    pub mfr: (f64, f64),
    /// `None` when no seed found two failure modes.
    pub div: Option<(f64, f64)>,
}

const COLOURS: [RGBColor; 4] =
    [RGBColor(0x1f, 0x77, 0xb4), RGBColor(0xd6, 0x27, 0x28), RGBColor(0x2c, 0xa0, 0x2c), BLACK];

/// PFM and MFR (%) against the swept value, one line per algorithm, ± sd bars.
pub fn plot(param: SweepParam, points: &[Point]) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (960, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let panels = root.split_evenly((1, 2));
        let xs: Vec<f64> = points.iter().map(|p| p.value).collect();
        let (lo, hi) = xs.iter().fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        let pad = ((hi - lo) * 0.05).max(1e-9);
        let mut algos: Vec<&str> = Vec::new();
        for p in points {
            if !algos.contains(&p.algo.as_str()) {
                algos.push(&p.algo);
            }
        }
        for (panel, (title, pick)) in panels
            .iter()
            .zip([("PFM (%)", (|p: &Point| p.pfm) as fn(&Point) -> (f64, f64)), ("MFR (%)", |p: &Point| p.mfr)])
        {
            let ymax = points.iter().map(|p| pick(p).0 + pick(p).1).fold(1.0_f64, f64::max) * 1.1;
            let mut chart = ChartBuilder::on(panel)
                .caption(format!("{title} vs {}", param.name()), ("sans-serif", 18))
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(48)
                .build_cartesian_2d((lo - pad)..(hi + pad), 0.0..ymax)
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc(param.name())
                .y_desc(title)
                .light_line_style(WHITE.mix(0.0))
                .draw()
                .map_err(|e| e.to_string())?;
            for (k, algo) in algos.iter().enumerate() {
                let colour = COLOURS[k % COLOURS.len()];
                let mine: Vec<&Point> = points.iter().filter(|p| p.algo == *algo).collect();
                chart
                    .draw_series(LineSeries::new(mine.iter().map(|p| (p.value, pick(p).0)), colour.stroke_width(2)))
                    .map_err(|e| e.to_string())?
                    .label(*algo)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
                chart
                    .draw_series(mine.iter().map(|p| {
                        let (m, sd) = pick(p);
                        ErrorBar::new_vertical(p.value, (m - sd).max(0.0), m, m + sd, colour.filled(), 6)
                    }))
                    .map_err(|e| e.to_string())?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::LowerRight)
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK.mix(0.3))
                .draw()
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweeps_parse_and_name_their_mistakes() {
        let s: Sweep = "beam_width=1,5,10".parse().unwrap();
        assert_eq!(s, Sweep { param: SweepParam::BeamWidth, values: vec![1.0, 5.0, 10.0] });
        assert_eq!(SweepParam::BeamWidth.apply(&Params::default(), 3.0).beam_width, 3);
        assert_eq!(SweepParam::Threshold.apply(&Params::default(), 0.8).threshold, 0.8);
        assert!("beam_width=1.5,2".parse::<Sweep>().unwrap_err().contains("whole number"));
        assert!("width=1,2".parse::<Sweep>().unwrap_err().starts_with("unknown parameter `width`"));
        assert!("kernel=dot,rbf".parse::<Sweep>().unwrap_err().contains("cannot be swept yet"));
        assert!("lambda=0.5".parse::<Sweep>().unwrap_err().contains("at least two"));
        assert!("lambda".parse::<Sweep>().is_err());
    }

    #[test]
    fn plot_draws_one_line_per_algorithm() {
        let p = |algo: &str, value: f64, pfm: f64| Point {
            algo: algo.into(),
            value,
            pfm: (pfm, 2.0),
            mfr: (pfm / 2.0, 1.0),
            div: None,
        };
        // Value-major, as `bench search --sweep` produces them.
        let pts = vec![p("beam", 1.0, 10.0), p("gpts", 1.0, 20.0), p("beam", 5.0, 30.0), p("gpts", 5.0, 25.0)];
        let svg = plot(SweepParam::BeamWidth, &pts).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("PFM (%) vs beam_width"), "{}", &svg[..200]);
        assert_eq!(svg.matches("\nbeam\n").count(), 2, "one legend entry per algorithm and panel");
        assert_eq!(svg.matches("\ngpts\n").count(), 2);
        assert_eq!(svg.matches("stroke-width=\"2\"").count(), 8, "per panel: a line and a legend key per algorithm");
    }
}
