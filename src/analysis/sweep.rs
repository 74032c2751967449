//! Ablation sweeps (`revelio bench search --sweep PARAM=v1,v2,…`, paper appendix D on beam
//! width, beam budget, observations per set, τ, λ and the GP kernel): which parameter, its values
//! applied to the search parameters, and the SVG plot of PFM and MFR (mean ± sd over seeds) per
//! algorithm against the swept value (the kernels side by side).

use plotters::prelude::*;
use serde::{Deserialize, Serialize};

use crate::search::gp::Kernel;
use crate::search::{Algo, Params};

/// A sweepable search parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SweepParam {
    BeamWidth,
    BeamBudget,
    Samples,
    Threshold,
    Lambda,
    /// GPTS's GP kernel: `dot` (the paper's) or `rbf` (its ablation).
    Kernel,
}

/// One value of a swept parameter: a number, or a kernel's name.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SweepValue {
    Number(f64),
    Kernel(Kernel),
}

impl std::fmt::Display for SweepValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SweepValue::Number(x) => write!(f, "{x}"),
            SweepValue::Kernel(k) => f.write_str(k.name()),
        }
    }
}

impl SweepParam {
    pub const ALL: [SweepParam; 6] = [
        SweepParam::BeamWidth,
        SweepParam::BeamBudget,
        SweepParam::Samples,
        SweepParam::Threshold,
        SweepParam::Lambda,
        SweepParam::Kernel,
    ];

    pub fn name(self) -> &'static str {
        match self {
            SweepParam::BeamWidth => "beam_width",
            SweepParam::BeamBudget => "beam_budget",
            SweepParam::Samples => "samples",
            SweepParam::Threshold => "threshold",
            SweepParam::Lambda => "lambda",
            SweepParam::Kernel => "kernel",
        }
    }

    /// `params` with this parameter set to `v` (checked by `Params::validate` afterwards). A
    /// value of the wrong type (a kernel for a number, or the other way round) leaves `params`
    /// as they are; parsing never makes one.
    pub fn apply(self, params: &Params, v: SweepValue) -> Params {
        let mut p = params.clone();
        match (self, v) {
            (SweepParam::BeamWidth, SweepValue::Number(v)) => p.beam_width = v as usize,
            (SweepParam::BeamBudget, SweepValue::Number(v)) => p.beam_budget = v as u64,
            (SweepParam::Samples, SweepValue::Number(v)) => p.samples = v as u32,
            (SweepParam::Threshold, SweepValue::Number(v)) => p.threshold = v,
            (SweepParam::Lambda, SweepValue::Number(v)) => p.lambda = v,
            (SweepParam::Kernel, SweepValue::Kernel(k)) => p.kernel = k,
            _ => {}
        }
        p
    }

    /// The algorithms the parameter changes: all of them, except the kernel (GPTS's alone).
    pub fn algos(self) -> &'static [Algo] {
        match self {
            SweepParam::Kernel => &[Algo::Gpts],
            _ => &Algo::ALL,
        }
    }

    fn integer(self) -> bool {
        matches!(self, SweepParam::BeamWidth | SweepParam::BeamBudget | SweepParam::Samples)
    }
}

/// A parsed `--sweep PARAM=v1,v2,…`.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    pub param: SweepParam,
    pub values: Vec<SweepValue>,
}

impl Sweep {
    /// Where `v` sits on the plot's x axis: the number itself, or a kernel's position in the
    /// sweep.
    pub fn x(&self, v: SweepValue) -> f64 {
        match v {
            SweepValue::Number(x) => x,
            SweepValue::Kernel(_) => self.values.iter().position(|w| *w == v).unwrap_or(0) as f64,
        }
    }
}

impl std::str::FromStr for Sweep {
    type Err = String;

    fn from_str(s: &str) -> Result<Sweep, String> {
        let (name, values) = s.split_once('=').ok_or_else(|| format!("expected PARAM=v1,v2,…, got `{s}`"))?;
        let names = SweepParam::ALL.map(SweepParam::name).join(", ");
        let Some(param) = SweepParam::ALL.into_iter().find(|p| p.name() == name.trim()) else {
            return Err(format!("unknown parameter `{}`; sweepable: {names}", name.trim()));
        };
        let mut out = Vec::new();
        for v in values.split(',') {
            if param == SweepParam::Kernel {
                out.push(SweepValue::Kernel(v.parse()?));
                continue;
            }
            let x: f64 = v.trim().parse().map_err(|_| format!("`{}` is not a number", v.trim()))?;
            if !x.is_finite() || x < 0.0 || (param.integer() && x.fract() != 0.0) {
                let kind = if param.integer() { "a whole number ≥ 0" } else { "a number ≥ 0" };
                return Err(format!("`{}` for `{}` must be {kind}", v.trim(), param.name()));
            }
            out.push(SweepValue::Number(x));
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
    pub value: SweepValue,
    pub pfm: (f64, f64),
    pub mfr: (f64, f64),
    /// `None` when no seed found two failure modes.
    pub div: Option<(f64, f64)>,
}

const COLOURS: [RGBColor; 4] =
    [RGBColor(0x1f, 0x77, 0xb4), RGBColor(0xd6, 0x27, 0x28), RGBColor(0x2c, 0xa0, 0x2c), BLACK];

/// PFM and MFR (%) against the swept value, one line per algorithm, ± sd bars. Kernels stand
/// side by side at 0, 1, …, labelled by name.
pub fn plot(sweep: &Sweep, points: &[Point]) -> Result<String, String> {
    let param = sweep.param;
    let categorical = param == SweepParam::Kernel;
    let label = |x: &f64| match sweep.values.get(x.round() as usize) {
        Some(v) if categorical && (x - x.round()).abs() < 1e-9 => v.to_string(),
        _ if categorical => String::new(),
        _ => format!("{x}"),
    };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (960, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let panels = root.split_evenly((1, 2));
        let xs: Vec<f64> = points.iter().map(|p| sweep.x(p.value)).collect();
        let (lo, hi) = xs.iter().fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        let pad = if categorical { 0.5 } else { ((hi - lo) * 0.05).max(1e-9) };
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
            let mut mesh = chart.configure_mesh();
            if categorical {
                mesh.x_labels(sweep.values.len() * 2 + 1);
            }
            mesh.x_label_formatter(&label)
                .x_desc(param.name())
                .y_desc(title)
                .light_line_style(WHITE.mix(0.0))
                .draw()
                .map_err(|e| e.to_string())?;
            for (k, algo) in algos.iter().enumerate() {
                let colour = COLOURS[k % COLOURS.len()];
                let mine: Vec<&Point> = points.iter().filter(|p| p.algo == *algo).collect();
                chart
                    .draw_series(LineSeries::new(
                        mine.iter().map(|p| (sweep.x(p.value), pick(p).0)),
                        colour.stroke_width(2),
                    ))
                    .map_err(|e| e.to_string())?
                    .label(*algo)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
                chart
                    .draw_series(mine.iter().map(|p| {
                        let (m, sd) = pick(p);
                        ErrorBar::new_vertical(sweep.x(p.value), (m - sd).max(0.0), m, m + sd, colour.filled(), 6)
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
        let n = SweepValue::Number;
        let s: Sweep = "beam_width=1,5,10".parse().unwrap();
        assert_eq!(s, Sweep { param: SweepParam::BeamWidth, values: vec![n(1.0), n(5.0), n(10.0)] });
        assert_eq!(SweepParam::BeamWidth.apply(&Params::default(), n(3.0)).beam_width, 3);
        assert_eq!(SweepParam::Threshold.apply(&Params::default(), n(0.8)).threshold, 0.8);
        assert!("beam_width=1.5,2".parse::<Sweep>().unwrap_err().contains("whole number"));
        assert!("width=1,2".parse::<Sweep>().unwrap_err().starts_with("unknown parameter `width`"));
        let k: Sweep = "kernel=dot, rbf".parse().unwrap();
        assert_eq!(k.values, vec![SweepValue::Kernel(Kernel::Dot), SweepValue::Kernel(Kernel::Rbf)]);
        assert_eq!(SweepParam::Kernel.apply(&Params::default(), k.values[1]).kernel, Kernel::Rbf);
        assert_eq!((k.x(k.values[0]), k.x(k.values[1])), (0.0, 1.0));
        assert_eq!(SweepParam::Kernel.algos(), &[Algo::Gpts]);
        assert_eq!(
            "kernel=dot,matern".parse::<Sweep>().unwrap_err(),
            "unknown kernel `matern`: expected one of dot, rbf"
        );
        assert!("lambda=0.5".parse::<Sweep>().unwrap_err().contains("at least two"));
        assert!("lambda".parse::<Sweep>().is_err());
    }

    #[test]
    fn plot_draws_one_line_per_algorithm() {
        let p = |algo: &str, value: f64, pfm: f64| Point {
            algo: algo.into(),
            value: SweepValue::Number(value),
            pfm: (pfm, 2.0),
            mfr: (pfm / 2.0, 1.0),
            div: None,
        };
        // Value-major, as `bench search --sweep` produces them.
        let pts = vec![p("beam", 1.0, 10.0), p("gpts", 1.0, 20.0), p("beam", 5.0, 30.0), p("gpts", 5.0, 25.0)];
        let sweep: Sweep = "beam_width=1,5".parse().unwrap();
        let svg = plot(&sweep, &pts).unwrap();
        assert!(svg.starts_with("<svg") && svg.contains("PFM (%) vs beam_width"), "{}", &svg[..200]);
        assert_eq!(svg.matches("\nbeam\n").count(), 2, "one legend entry per algorithm and panel");
        assert_eq!(svg.matches("\ngpts\n").count(), 2);
        assert_eq!(svg.matches("stroke-width=\"2\"").count(), 8, "per panel: a line and a legend key per algorithm");
    }

    #[test]
    fn a_kernel_sweep_labels_its_axis_with_the_kernels() {
        let sweep: Sweep = "kernel=dot,rbf".parse().unwrap();
        let p = |value: SweepValue, pfm: f64| Point {
            algo: "gpts".into(),
            value,
            pfm: (pfm, 1.0),
            mfr: (pfm, 1.0),
            div: None,
        };
        let svg = plot(&sweep, &[p(sweep.values[0], 40.0), p(sweep.values[1], 20.0)]).unwrap();
        assert!(svg.contains("PFM (%) vs kernel"));
        assert_eq!(svg.matches("\ndot\n").count(), 2, "the x axis names each kernel on both panels");
        assert_eq!(svg.matches("\nrbf\n").count(), 2);
    }
}
