//! 95 % intervals: the Wilson score interval of a failure rate, and Student's t interval of a
//! metric's mean over seeds (with the mean and sample sd it rests on).
//!
//! Why Wilson and not the Beta posterior: it is closed-form (no incomplete-beta inversion), it is
//! the interval Brown, Cai & DasGupta (2001) and Newcombe (1998) recommend for small n, it stays
//! inside [0, 1], it is never empty or zero-width at 0/n or n/n (5/5 gives [0.57, 1], not [1, 1]),
//! and it always contains the observed rate — so "the interval lies above τ" implies "FR ≥ τ",
//! and the sequential test ([`super::sequential`]) never contradicts the paper's classification.
//! No continuity correction.

/// A rate as a person reads it: `62%`, or `–` where there is none (no answered observation).
/// The one spelling of a percentage in the terminal tables and the report.
pub fn pct(f: Option<f64>) -> String {
    f.map_or_else(|| "–".into(), |f| format!("{:.0}%", 100.0 * f))
}

/// The standard normal quantile for a two-sided 95 % interval (Φ⁻¹(0.975)).
pub const Z95: f64 = 1.959_963_984_540_054;

/// Wilson score interval (95 %) of `k` successes in `n` trials; `[0, 1]` when `n = 0` (no
/// answer says nothing).
pub fn wilson(k: u32, n: u32) -> [f64; 2] {
    wilson_z(k, n, Z95)
}

/// The Wilson score interval of `k` successes in `n` trials at normal quantile `z` (two-sided
/// coverage 2Φ(z) − 1); `[0, 1]` when `n = 0`.
pub fn wilson_z(k: u32, n: u32, z: f64) -> [f64; 2] {
    if n == 0 {
        return [0.0, 1.0];
    }
    let (k, n) = (f64::from(k.min(n)), f64::from(n));
    let p = k / n;
    let z2 = z * z;
    let denom = 1.0 + z2 / n;
    let center = (p + z2 / (2.0 * n)) / denom;
    let half = z * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt() / denom;
    // At k = 0 and k = n the bounds are exactly 0 and 1; rounding must not move them.
    let lo = if k == 0.0 { 0.0 } else { (center - half).max(0.0) };
    let hi = if k == n { 1.0 } else { (center + half).min(1.0) };
    [lo, hi]
}

/// Two-sided 97.5 % quantiles of Student's t for 1..=30 degrees of freedom.
const T975: [f64; 30] = [
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131, 2.120,
    2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042,
];

/// Student's t quantile t(0.975, df); beyond 30 degrees of freedom a table-free approximation
/// (Cornish–Fisher, within 1e-3 of the exact value from df = 30 on).
pub fn t975(df: usize) -> f64 {
    match df {
        0 => f64::INFINITY,
        1..=30 => T975[df - 1],
        _ => {
            let (z, v) = (Z95, df as f64);
            z + (z.powi(3) + z) / (4.0 * v) + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * v * v)
        }
    }
}

/// Mean and sample standard deviation (0 for fewer than two values).
pub fn mean_sd(xs: &[f64]) -> (f64, f64) {
    if xs.is_empty() {
        return (0.0, 0.0);
    }
    let n = xs.len() as f64;
    let mean = xs.iter().sum::<f64>() / n;
    if xs.len() < 2 {
        return (mean, 0.0);
    }
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

/// Mean and 95 % interval of the mean of `xs` (Student's t, sample sd); the interval is the
/// point itself for one value and `None` for none.
pub fn mean_ci95(xs: &[f64]) -> Option<(f64, [f64; 2])> {
    if xs.is_empty() {
        return None;
    }
    let (mean, sd) = mean_sd(xs);
    if xs.len() < 2 {
        return Some((mean, [mean, mean]));
    }
    let half = t975(xs.len() - 1) * sd / (xs.len() as f64).sqrt();
    Some((mean, [mean - half, mean + half]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 2], b: [f64; 2], tol: f64) -> bool {
        (a[0] - b[0]).abs() <= tol && (a[1] - b[1]).abs() <= tol
    }

    /// Newcombe (1998), "Two-sided confidence intervals for the single proportion: comparison
    /// of seven methods", Statistics in Medicine 17, Table II, method 3 (Wilson score, no
    /// continuity correction), printed to four decimals.
    #[test]
    fn wilson_matches_newcombes_published_values() {
        let cases = [
            ((81, 263), [0.2553, 0.3662]),
            ((15, 148), [0.0624, 0.1605]),
            ((0, 20), [0.0000, 0.1611]),
            ((1, 29), [0.0061, 0.1718]),
        ];
        for ((k, n), want) in cases {
            let got = wilson(k, n);
            assert!(close(got, want, 5e-5), "{k}/{n}: {got:?} vs {want:?}");
        }
    }

    /// Wikipedia's worked example and the edges that matter at the paper's m = 5.
    #[test]
    fn wilson_at_small_counts() {
        // 5/5 does not clear τ = 0.6; 6/6 does; 0/5 clears it from below.
        let [lo, hi] = wilson(5, 5);
        assert!((lo - 0.5655).abs() < 1e-4 && hi == 1.0, "{lo} {hi}");
        assert!(wilson(6, 6)[0] > 0.6);
        assert!(wilson(0, 5)[1] < 0.6 && wilson(0, 5)[0] == 0.0);
        assert_eq!(wilson(0, 0), [0.0, 1.0]);
        // Symmetry: the interval of k/n mirrors that of (n−k)/n.
        let (a, b) = (wilson(3, 11), wilson(8, 11));
        assert!((a[0] - (1.0 - b[1])).abs() < 1e-12 && (a[1] - (1.0 - b[0])).abs() < 1e-12);
        // Always contains the observed rate.
        for n in 1..40 {
            for k in 0..=n {
                let [lo, hi] = wilson(k, n);
                let p = f64::from(k) / f64::from(n);
                assert!(lo <= p && p <= hi && 0.0 <= lo && hi <= 1.0, "{k}/{n}");
            }
        }
    }

    #[test]
    fn t_interval_of_a_mean() {
        assert_eq!(mean_ci95(&[]), None);
        assert_eq!(mean_ci95(&[2.0]), Some((2.0, [2.0, 2.0])));
        // Mean 2, sd √2.5 over 5 values: half-width 2.776 · 1.5811 / √5 = 1.9630.
        let (m, [lo, hi]) = mean_ci95(&[0.0, 1.0, 2.0, 3.0, 4.0]).unwrap();
        assert_eq!(m, 2.0);
        assert!((hi - 3.9630).abs() < 1e-3 && (lo - 0.0370).abs() < 1e-3, "{lo} {hi}");
        // The approximation beyond the table joins it and tends to z.
        assert!((t975(31) - 2.040).abs() < 1e-3 && (t975(60) - 2.000).abs() < 1e-3);
        assert!((t975(120) - 1.980).abs() < 1e-3 && (t975(100_000) - Z95).abs() < 1e-4);
    }
}
