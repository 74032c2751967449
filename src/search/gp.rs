//! Gaussian-process surrogate of the failure rate over concept sets (GPTS, paper Algorithm 2).
//!
//! The model is scikit-learn's `GaussianProcessRegressor(kernel=DotProduct() + WhiteKernel())`
//! with its defaults (`normalize_y=False`, `alpha=1e-10`, one L-BFGS-B run from `sigma_0=1`,
//! `noise_level=1` within the bounds `1e-5..1e5`): a concept set is the multi-hot vector
//! x ∈ {0,1}^d and
//!
//! ```text
//! k(x, x') = σ0² + x·x' + noise·δ(x, x')
//! ```
//!
//! A dot-product GP is Bayesian linear regression on the features φ(x) = [σ0, x] with weights
//! w ~ N(0, I), so everything here is done in weight space: the cost is O(n·k² + d³) for n
//! observations of sets of size k over d concepts, never an n×n (or lattice-sized) matrix. A
//! Thompson draw is one weight vector, so scoring a set costs O(|set|). See `docs/gp.md`.
//!
//! The paper's kernel ablation (appendix D) swaps in RBF + White: that GP lives in
//! [`super::gp_rbf`]; [`Kernel`] names the choice and this module's optimiser fits both.

use std::f64::consts::{PI, TAU};

use nalgebra::{DMatrix, DVector};
use rand::distr::Open01;
use rand::{Rng, RngExt};

use crate::ir::{ConceptSet, MAX_CONCEPTS};

/// scikit-learn's default `alpha`: jitter added to the kernel diagonal of the training data only.
pub const ALPHA: f64 = 1e-10;
/// scikit-learn's default hyperparameter bounds for both `sigma_0` and `noise_level`.
pub const BOUNDS: (f64, f64) = (1e-5, 1e5);

/// The GP kernel of GPTS (`--kernel`): the paper's DotProduct + White (the default), or RBF +
/// White (its appendix D ablation).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kernel {
    #[default]
    Dot,
    Rbf,
}

impl Kernel {
    pub const ALL: [Kernel; 2] = [Kernel::Dot, Kernel::Rbf];

    pub fn name(self) -> &'static str {
        match self {
            Kernel::Dot => "dot",
            Kernel::Rbf => "rbf",
        }
    }

    /// The kernel as scikit-learn writes it.
    pub fn formula(self) -> &'static str {
        match self {
            Kernel::Dot => "DotProduct + White",
            Kernel::Rbf => "RBF + White",
        }
    }

    pub fn is_default(&self) -> bool {
        *self == Kernel::Dot
    }
}

impl std::fmt::Display for Kernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Kernel {
    type Err = String;
    fn from_str(s: &str) -> Result<Kernel, String> {
        Kernel::ALL.into_iter().find(|k| k.name() == s.trim()).ok_or_else(|| {
            let names: Vec<&str> = Kernel::ALL.iter().map(|k| k.name()).collect();
            format!("unknown kernel `{}`: expected one of {}", s.trim(), names.join(", "))
        })
    }
}

/// Why a GP could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GpError {
    #[error("no observations to fit the gaussian process on")]
    Empty,
    #[error("`{sets}` concept sets but `{rates}` failure rates; every set needs exactly one rate")]
    LengthMismatch { sets: usize, rates: usize },
    #[error("failure rate `{value}` of observation {index} is not a finite number")]
    NonFiniteTarget { index: usize, value: f64 },
    #[error("`{d}` concepts exceed the maximum of {MAX_CONCEPTS}")]
    TooManyConcepts { d: usize },
    #[error("concept set of observation {index} contains concept {concept}, but only `{d}` concepts exist")]
    ConceptOutOfRange { index: usize, concept: usize, d: usize },
    #[error("hyperparameter `{name}` must be a positive finite number, got `{value}`")]
    BadHyperparameter { name: &'static str, value: f64 },
    #[error("the failure rates are too large to fit: the marginal likelihood overflows")]
    Overflow,
    #[error("a set of `{size}` concepts is too large for an exact RBF Thompson draw (at most {max})")]
    SetTooLarge { size: usize, max: usize },
}

/// Check the training data: as many rates as sets, at least one, finite rates, concepts < `d`.
pub(super) fn check_data(x: &[ConceptSet], y: &[f64], d: usize) -> Result<(), GpError> {
    if x.len() != y.len() {
        return Err(GpError::LengthMismatch { sets: x.len(), rates: y.len() });
    }
    if x.is_empty() {
        return Err(GpError::Empty);
    }
    if d > MAX_CONCEPTS {
        return Err(GpError::TooManyConcepts { d });
    }
    for (index, (&set, &value)) in x.iter().zip(y).enumerate() {
        if !value.is_finite() {
            return Err(GpError::NonFiniteTarget { index, value });
        }
        if let Some(concept) = set.iter().map(|c| c.index()).find(|&c| c >= d) {
            return Err(GpError::ConceptOutOfRange { index, concept, d });
        }
    }
    Ok(())
}

/// A fitted GP: hyperparameters plus the Gaussian posterior N(mean, cov) of the weights
/// [w_bias, w_1, …, w_d] (the bias feature is σ0, so the bias contributes σ0·w_bias).
#[derive(Debug, Clone)]
pub struct Gp {
    d: usize,
    sigma0: f64,
    noise_level: f64,
    lml: f64,
    mean: DVector<f64>,
    cov: DMatrix<f64>,
    /// Lower Cholesky factor L of the posterior precision A = L·Lᵀ; a draw is mean + L⁻ᵀ·z.
    precision_chol: DMatrix<f64>,
}

/// One Thompson sample of the latent failure-rate function (observation noise excluded, see
/// `docs/gp.md`): a linear function of the multi-hot vector.
#[derive(Debug, Clone, PartialEq)]
pub struct Draw {
    bias: f64,
    weights: Vec<f64>,
}

impl Draw {
    /// The sampled function at `set`: bias + the weights of the set's concepts. O(|set|).
    ///
    /// # Panics
    /// If `set` contains a concept ≥ the `d` the GP was fitted with (a caller bug: sets and the
    /// GP come from the same domain).
    pub fn score(&self, set: ConceptSet) -> f64 {
        set.iter().fold(self.bias, |acc, c| acc + self.weights[c.index()])
    }

    /// The sampled constant term σ0·w_bias.
    pub fn bias(&self) -> f64 {
        self.bias
    }

    /// The sampled per-concept weights (index = concept id).
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }
}

impl Gp {
    /// Fits the hyperparameters by maximising the log marginal likelihood (as scikit-learn does)
    /// and conditions on the data.
    pub fn fit(x: &[ConceptSet], y: &[f64], d: usize) -> Result<Gp, GpError> {
        let stats = Stats::new(x, y, d)?;
        // exp(ln 1e-5) is not exactly 1e-5: report a hyperparameter on its bound as the bound.
        let spec = Spectrum::new(&stats);
        let [sigma0, noise_level] =
            maximise(|th| spec.lml_and_grad(th[0], th[1])).map(|t| t.exp().clamp(BOUNDS.0, BOUNDS.1));
        Gp::condition(&stats, sigma0, noise_level)
    }

    /// Conditions on the data with fixed hyperparameters (scikit-learn's `optimizer=None`).
    pub fn with_params(x: &[ConceptSet], y: &[f64], d: usize, sigma0: f64, noise_level: f64) -> Result<Gp, GpError> {
        for (name, value) in [("sigma0", sigma0), ("noise_level", noise_level)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(GpError::BadHyperparameter { name, value });
            }
        }
        Gp::condition(&Stats::new(x, y, d)?, sigma0, noise_level)
    }

    fn condition(stats: &Stats, sigma0: f64, noise_level: f64) -> Result<Gp, GpError> {
        let lml = Spectrum::new(stats).lml_and_grad(sigma0.ln(), noise_level.ln()).0;
        let s2 = noise_level + ALPHA;
        let (d, n) = (stats.d, stats.n as f64);
        // Posterior precision A = I + ΦᵀΦ/s2 and mean A⁻¹Φᵀy/s2 with Φ = [σ0·1, X].
        let mut a = DMatrix::identity(d + 1, d + 1);
        a[(0, 0)] += sigma0 * sigma0 * n / s2;
        for i in 0..d {
            a[(0, i + 1)] = sigma0 * stats.counts[i] / s2;
            a[(i + 1, 0)] = a[(0, i + 1)];
            for j in 0..d {
                a[(i + 1, j + 1)] += stats.gram[(i, j)] / s2;
            }
        }
        let mut rhs = DVector::zeros(d + 1);
        rhs[0] = sigma0 * stats.sum_y / s2;
        rhs.rows_mut(1, d).copy_from(&(&stats.xty / s2));
        if !(lml.is_finite() && a.iter().chain(rhs.iter()).all(|v| v.is_finite())) {
            return Err(GpError::Overflow);
        }
        // A ⪰ I, so Cholesky cannot fail on finite input.
        let chol = a.cholesky().ok_or(GpError::Overflow)?;
        Ok(Gp {
            d,
            sigma0,
            noise_level,
            lml,
            mean: chol.solve(&rhs),
            cov: chol.inverse(),
            precision_chol: chol.unpack(),
        })
    }

    /// Posterior mean and variance of the latent failure rate f(set) — the variance of f, without
    /// the observation noise (scikit-learn's `predict(return_std=True)` adds `noise_level`).
    ///
    /// # Panics
    /// If `set` contains a concept ≥ `d` (a caller bug, see [`Draw::score`]).
    pub fn predict(&self, set: ConceptSet) -> (f64, f64) {
        let idx: Vec<usize> = set.iter().map(|c| c.index() + 1).collect();
        assert!(idx.iter().all(|&i| i <= self.d), "concept set {set:?} has concepts outside the {} fitted", self.d);
        let s = self.sigma0;
        let mean = s * self.mean[0] + idx.iter().map(|&i| self.mean[i]).sum::<f64>();
        let cross: f64 = idx.iter().map(|&i| self.cov[(0, i)]).sum();
        let block: f64 = idx.iter().flat_map(|&i| idx.iter().map(move |&j| (i, j))).map(|ij| self.cov[ij]).sum();
        (mean, s * s * self.cov[(0, 0)] + 2.0 * s * cross + block)
    }

    /// One Thompson sample of the latent function, using the caller's RNG (so every call is a
    /// fresh, independent draw — unlike scikit-learn's `sample_y`, which defaults to
    /// `random_state=0`). O(d²).
    pub fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> Draw {
        let mut z = DVector::from_iterator(self.d + 1, StandardNormals::new(rng).take(self.d + 1));
        // Cov(L⁻ᵀz) = (L·Lᵀ)⁻¹ = A⁻¹, the posterior covariance.
        let solved = self.precision_chol.tr_solve_lower_triangular_mut(&mut z);
        debug_assert!(solved, "a Cholesky factor of a matrix ⪰ I has a non-zero diagonal");
        let w = &self.mean + z;
        Draw { bias: self.sigma0 * w[0], weights: w.as_slice()[1..].to_vec() }
    }

    /// The kernel's constant term σ0 (scikit-learn's `sigma_0`).
    pub fn sigma0(&self) -> f64 {
        self.sigma0
    }

    /// The White kernel's noise variance (scikit-learn's `noise_level`).
    pub fn noise_level(&self) -> f64 {
        self.noise_level
    }

    /// Log marginal likelihood of the training data at the GP's hyperparameters (scikit-learn's
    /// `log_marginal_likelihood_value_`).
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.lml
    }

    /// Number of concepts (the width of the multi-hot encoding).
    pub fn dim(&self) -> usize {
        self.d
    }
}

/// Standard normal variates by the Box–Muller transform (`rand` without `rand_distr` has no
/// normal distribution); both variates of each pair are used.
pub(super) struct StandardNormals<'a, R: Rng + ?Sized> {
    rng: &'a mut R,
    spare: Option<f64>,
}

impl<'a, R: Rng + ?Sized> StandardNormals<'a, R> {
    pub(super) fn new(rng: &'a mut R) -> Self {
        StandardNormals { rng, spare: None }
    }
}

impl<R: Rng + ?Sized> Iterator for StandardNormals<'_, R> {
    type Item = f64;
    fn next(&mut self) -> Option<f64> {
        if let Some(z) = self.spare.take() {
            return Some(z);
        }
        // Open01 keeps ln(u) finite.
        let u: f64 = self.rng.sample(Open01);
        let v: f64 = self.rng.random();
        let r = (-2.0 * u.ln()).sqrt();
        self.spare = Some(r * (TAU * v).sin());
        Some(r * (TAU * v).cos())
    }
}

/// Sufficient statistics of the data: everything the weight-space GP needs, O(d²) in size.
struct Stats {
    n: usize,
    d: usize,
    /// Xᵀ1: how many observations contain each concept.
    counts: DVector<f64>,
    /// Xᵀy.
    xty: DVector<f64>,
    /// XᵀX: how many observations contain both concepts.
    gram: DMatrix<f64>,
    sum_y: f64,
    yy: f64,
}

impl Stats {
    fn new(x: &[ConceptSet], y: &[f64], d: usize) -> Result<Stats, GpError> {
        check_data(x, y, d)?;
        let mut s = Stats {
            n: x.len(),
            d,
            counts: DVector::zeros(d),
            xty: DVector::zeros(d),
            gram: DMatrix::zeros(d, d),
            sum_y: 0.0,
            yy: 0.0,
        };
        for (&set, &value) in x.iter().zip(y) {
            let idx: Vec<usize> = set.iter().map(|c| c.index()).collect();
            for &i in &idx {
                s.counts[i] += 1.0;
                s.xty[i] += value;
                for &j in &idx {
                    s.gram[(i, j)] += 1.0;
                }
            }
            s.sum_y += value;
            s.yy += value * value;
        }
        Ok(s)
    }
}

/// The data in the eigenbasis of XᵀX = V·diag(λ)·Vᵀ, which makes the log marginal likelihood
/// and its gradient O(d) per evaluation for any (σ0, noise).
///
/// With B = s2·I + XXᵀ (s2 = noise + alpha), Woodbury gives vᵀB⁻¹w = (vᵀw − Σ pᵥ·p_w/(λ+s2))/s2
/// for p = Vᵀ·Xᵀv, and Sylvester gives log|B| = (n−d)·log s2 + Σ log(λ+s2). The bias adds the
/// rank-one σ0²·11ᵀ, handled by Sherman–Morrison and the matrix determinant lemma.
struct Spectrum {
    n: f64,
    eig: Vec<f64>,
    /// Vᵀ·Xᵀ1 and Vᵀ·Xᵀy.
    p1: Vec<f64>,
    py: Vec<f64>,
    sum_y: f64,
    yy: f64,
}

impl Spectrum {
    fn new(s: &Stats) -> Spectrum {
        let (eig, p1, py) = if s.d == 0 {
            // nalgebra's eigensolver rejects a 0×0 matrix; with no concepts only the bias is left.
            (Vec::new(), Vec::new(), Vec::new())
        } else {
            let eigen = s.gram.clone().symmetric_eigen();
            let vt = eigen.eigenvectors.transpose();
            (
                // XᵀX ⪰ 0; rounding may leave tiny negative eigenvalues.
                eigen.eigenvalues.iter().map(|&l| l.max(0.0)).collect(),
                (&vt * &s.counts).iter().copied().collect(),
                (&vt * &s.xty).iter().copied().collect(),
            )
        };
        Spectrum { n: s.n as f64, eig, p1, py, sum_y: s.sum_y, yy: s.yy }
    }

    /// Log marginal likelihood and its gradient with respect to (log σ0, log noise).
    fn lml_and_grad(&self, log_sigma0: f64, log_noise: f64) -> (f64, [f64; 2]) {
        let noise = log_noise.exp();
        let (s2, t, n, d) = (noise + ALPHA, (2.0 * log_sigma0).exp(), self.n, self.eig.len() as f64);
        // Σ pᵥ·p_w·rᵏ for r = 1/(λ+s2), k = 1, 2 (the second for derivatives in s2).
        let (mut s11, mut s1y, mut syy, mut t11, mut t1y, mut tyy, mut logdet_b, mut tr_b) =
            (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, (n - d) * s2.ln(), (n - d) / s2);
        for ((&l, &p1), &py) in self.eig.iter().zip(&self.p1).zip(&self.py) {
            let r = 1.0 / (l + s2);
            (s11, s1y, syy) = (s11 + p1 * p1 * r, s1y + p1 * py * r, syy + py * py * r);
            (t11, t1y, tyy) = (t11 + p1 * p1 * r * r, t1y + p1 * py * r * r, tyy + py * py * r * r);
            logdet_b += (l + s2).ln();
            tr_b += r;
        }
        // a = 1ᵀB⁻¹1, b = 1ᵀB⁻¹y, c = yᵀB⁻¹y and their derivatives in s2.
        let (a, b, c) = ((n - s11) / s2, (self.sum_y - s1y) / s2, (self.yy - syy) / s2);
        let (da, db, dc) = ((t11 - a) / s2, (t1y - b) / s2, (tyy - c) / s2);
        let q = 1.0 + t * a;
        let quad = c - t * b * b / q;
        let lml = -0.5 * (quad + logdet_b + q.ln() + n * (2.0 * PI).ln());
        let g_sigma0 = t * (b * b / (q * q) - a / q);
        let dquad = dc - t * (2.0 * b * db / q - b * b * t * da / (q * q));
        let g_noise = -0.5 * noise * (dquad + tr_b + t * da / q);
        (lml, [g_sigma0, g_noise])
    }
}

/// Maximises a log marginal likelihood `lml_and_grad(θ) → (LML, ∇LML)` over two log
/// hyperparameters θ (log σ0 or log length scale, then log noise) within [`BOUNDS`], from
/// scikit-learn's start θ = (0, 0): projected Newton with an Armijo backtracking line search
/// (Hessian by central differences of the analytic gradient, shifted to be positive definite
/// where the surface is not concave), with variables at a bound that the gradient pushes out
/// of held fixed. Runs to a far tighter tolerance than L-BFGS-B's defaults.
pub(super) fn maximise(lml_and_grad: impl Fn([f64; 2]) -> (f64, [f64; 2])) -> [f64; 2] {
    const MAX_ITER: usize = 200;
    let (lo, hi) = (BOUNDS.0.ln(), BOUNDS.1.ln());
    // Minimise f = −LML.
    let eval = |th: [f64; 2]| {
        let (l, g) = lml_and_grad(th);
        (-l, [-g[0], -g[1]])
    };
    let mut theta = [0.0, 0.0];
    let (mut f, mut g) = eval(theta);
    for _ in 0..MAX_ITER {
        let free = [0, 1].map(|i| !((theta[i] <= lo && g[i] > 0.0) || (theta[i] >= hi && g[i] < 0.0)));
        let pg = [0, 1].map(|i| if free[i] { g[i] } else { 0.0 });
        if pg[0].abs().max(pg[1].abs()) <= 1e-12 * f.abs().max(1.0) {
            break;
        }
        let p = newton_direction(hessian(&eval, theta), pg, free);
        let slope = |next: [f64; 2]| g[0] * (next[0] - theta[0]) + g[1] * (next[1] - theta[1]);
        let mut step = 1.0;
        let accepted = loop {
            let next = [0, 1].map(|i| (theta[i] + step * p[i]).clamp(lo, hi));
            let (fn_, gn) = eval(next);
            if fn_ <= f + 1e-4 * slope(next) && slope(next) < 0.0 {
                break Some((next, fn_, gn));
            }
            step *= 0.5;
            if step < 1e-20 {
                break None;
            }
        };
        // No decrease along a descent direction: θ is optimal to machine precision.
        let Some((next, fn_, gn)) = accepted else { break };
        (theta, f, g) = (next, fn_, gn);
    }
    theta
}

fn hessian(eval: &impl Fn([f64; 2]) -> (f64, [f64; 2]), theta: [f64; 2]) -> [[f64; 2]; 2] {
    const H: f64 = 1e-5;
    let column = |i: usize| {
        let shifted = |sign: f64| {
            let mut th = theta;
            th[i] += sign * H;
            eval(th).1
        };
        let (plus, minus) = (shifted(1.0), shifted(-1.0));
        [0, 1].map(|j| (plus[j] - minus[j]) / (2.0 * H))
    };
    let (c0, c1) = (column(0), column(1));
    let off = 0.5 * (c0[1] + c1[0]);
    [[c0[0], off], [off, c1[1]]]
}

/// Newton direction −H⁻¹g restricted to the free variables, with H shifted by a multiple of the
/// identity where it is not safely positive definite (so the direction is always a descent one).
fn newton_direction(h: [[f64; 2]; 2], g: [f64; 2], free: [bool; 2]) -> [f64; 2] {
    let mut h = h;
    for i in 0..2 {
        if !free[i] {
            h[i] = [0.0; 2];
            h[0][i] = 0.0;
            h[1][i] = 0.0;
            h[i][i] = 1.0;
        }
    }
    let (tr, det) = (h[0][0] + h[1][1], h[0][0] * h[1][1] - h[0][1] * h[1][0]);
    let disc = (0.25 * tr * tr - det).max(0.0).sqrt();
    let (lmin, lmax) = (0.5 * tr - disc, 0.5 * tr + disc);
    let floor = 1e-8 * lmax.abs().max(1.0);
    let shift = if lmin < floor { floor - lmin } else { 0.0 };
    let (a, b, c) = (h[0][0] + shift, h[0][1], h[1][1] + shift);
    let det = a * c - b * b;
    let p = [-(c * g[0] - b * g[1]) / det, -(a * g[1] - b * g[0]) / det];
    [0, 1].map(|i| if free[i] { p[i] } else { 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::ConceptId;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn set(ids: &[u32]) -> ConceptSet {
        ConceptSet::from_ids(ids.iter().map(|&i| ConceptId(i)))
    }

    /// Random sets of 1–5 concepts over `d` with noisy additive failure rates in [0, 1].
    fn data(n: usize, d: u32, seed: u64) -> (Vec<ConceptSet>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let w: Vec<f64> = (0..d).map(|_| rng.random::<f64>() * 0.3 - 0.1).collect();
        (0..n)
            .map(|_| {
                let k = rng.random_range(1..=5);
                let s = (0..k).fold(ConceptSet::EMPTY, |s, _| s.with(ConceptId(rng.random_range(0..d))));
                let f = 0.1 + s.iter().map(|c| w[c.index()]).sum::<f64>() + 0.1 * (rng.random::<f64>() - 0.5);
                (s, (f.clamp(0.0, 1.0) * 5.0).round() / 5.0)
            })
            .unzip()
    }

    /// Function-space GP with explicit n×n matrices: the textbook formulas (Rasmussen &
    /// Williams, Algorithm 2.1) that the weight-space version must reproduce.
    struct Direct {
        lml: f64,
        grad: [f64; 2],
        x: Vec<ConceptSet>,
        alpha: DVector<f64>,
        chol: nalgebra::Cholesky<f64, nalgebra::Dyn>,
        sigma0: f64,
    }

    impl Direct {
        fn new(x: &[ConceptSet], y: &[f64], sigma0: f64, noise: f64) -> Direct {
            let n = x.len();
            let k = |a: ConceptSet, b: ConceptSet| sigma0 * sigma0 + a.intersection(b).len() as f64;
            let kmat = DMatrix::from_fn(n, n, |i, j| k(x[i], x[j]) + if i == j { noise + ALPHA } else { 0.0 });
            let chol = kmat.cholesky().unwrap();
            let yv = DVector::from_column_slice(y);
            let alpha = chol.solve(&yv);
            let logdet: f64 = 2.0 * chol.l().diagonal().iter().map(|v| v.ln()).sum::<f64>();
            let lml = -0.5 * yv.dot(&alpha) - 0.5 * logdet - 0.5 * n as f64 * (2.0 * PI).ln();
            let kinv = chol.inverse();
            let outer = &alpha * alpha.transpose() - &kinv;
            let dk_sigma = DMatrix::from_element(n, n, 2.0 * sigma0 * sigma0);
            let dk_noise = DMatrix::identity(n, n) * noise;
            let grad = [0.5 * (&outer * dk_sigma).trace(), 0.5 * (&outer * dk_noise).trace()];
            Direct { lml, grad, x: x.to_vec(), alpha, chol, sigma0 }
        }

        fn predict(&self, s: ConceptSet) -> (f64, f64) {
            let k = |a: ConceptSet, b: ConceptSet| self.sigma0 * self.sigma0 + a.intersection(b).len() as f64;
            let ks = DVector::from_iterator(self.x.len(), self.x.iter().map(|&xi| k(xi, s)));
            (ks.dot(&self.alpha), k(s, s) - ks.dot(&self.chol.solve(&ks)))
        }
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1.0)
    }

    #[test]
    fn weight_space_matches_direct_gp() {
        let (x, y) = data(40, 12, 1);
        let probes = [set(&[]), set(&[0]), set(&[1, 2, 3]), set(&[11, 4]), x[0], x[7]];
        for (sigma0, noise) in [(1.0, 1.0), (0.3, 0.05), (2.5, 1e-3), (1e-5, 1e-5), (1e3, 10.0)] {
            let gp = Gp::with_params(&x, &y, 12, sigma0, noise).unwrap();
            let direct = Direct::new(&x, &y, sigma0, noise);
            assert!(close(gp.log_marginal_likelihood(), direct.lml, 1e-9), "{} vs {}", gp.lml, direct.lml);
            let (_, grad) = Spectrum::new(&Stats::new(&x, &y, 12).unwrap()).lml_and_grad(sigma0.ln(), noise.ln());
            for (g, dg) in grad.into_iter().zip(direct.grad) {
                assert!(close(g, dg, 1e-6), "gradient {grad:?} vs {:?}", direct.grad);
            }
            for s in probes {
                let ((m, v), (dm, dv)) = (gp.predict(s), direct.predict(s));
                assert!(close(m, dm, 1e-8) && close(v, dv, 1e-6), "({m}, {v}) vs ({dm}, {dv}) at {s:?}");
            }
        }
    }

    #[test]
    fn more_concepts_than_observations() {
        let (x, y) = data(6, 40, 2);
        let gp = Gp::with_params(&x, &y, 40, 0.7, 0.2).unwrap();
        let direct = Direct::new(&x, &y, 0.7, 0.2);
        assert!(close(gp.log_marginal_likelihood(), direct.lml, 1e-9));
        let ((m, v), (dm, dv)) = (gp.predict(set(&[3, 39])), direct.predict(set(&[3, 39])));
        assert!(close(m, dm, 1e-9) && close(v, dv, 1e-9));
    }

    #[test]
    fn fit_reaches_a_stationary_maximum() {
        let (x, y) = data(200, 30, 3);
        let gp = Gp::fit(&x, &y, 30).unwrap();
        let spec = Spectrum::new(&Stats::new(&x, &y, 30).unwrap());
        let th = [gp.sigma0().ln(), gp.noise_level().ln()];
        let (lml, grad) = spec.lml_and_grad(th[0], th[1]);
        assert_eq!(lml, gp.log_marginal_likelihood());
        for (i, g) in grad.iter().enumerate() {
            let at_bound = th[i] <= BOUNDS.0.ln() + 1e-12 || th[i] >= BOUNDS.1.ln() - 1e-12;
            assert!(at_bound || g.abs() < 1e-6, "gradient {grad:?} at {th:?}");
        }
        for (dx, dy) in [(0.01, 0.0), (-0.01, 0.0), (0.0, 0.01), (0.0, -0.01)] {
            assert!(spec.lml_and_grad(th[0] + dx, th[1] + dy).0 < lml);
        }
    }

    #[test]
    fn exactly_linear_data_drives_noise_to_its_lower_bound() {
        let (x, _) = data(60, 8, 4);
        let y: Vec<f64> = x.iter().map(|s| 0.2 + s.iter().map(|c| 0.05 * c.0 as f64).sum::<f64>()).collect();
        let gp = Gp::fit(&x, &y, 8).unwrap();
        assert!(close(gp.noise_level(), BOUNDS.0, 1e-9), "noise {}", gp.noise_level());
        let (m, _) = gp.predict(set(&[1, 6]));
        assert!((m - 0.55).abs() < 1e-3, "mean {m}");
    }

    #[test]
    fn draws_have_the_posterior_mean_and_variance() {
        let (x, y) = data(30, 10, 5);
        let gp = Gp::with_params(&x, &y, 10, 0.8, 0.05).unwrap();
        let probes = [set(&[]), set(&[2]), set(&[0, 5, 9]), set(&[1, 3, 4, 7, 8])];
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        const N: usize = 40_000;
        let mut sums = [[0.0; 2]; 4];
        for _ in 0..N {
            let draw = gp.draw(&mut rng);
            for (acc, &s) in sums.iter_mut().zip(&probes) {
                let v = draw.score(s);
                acc[0] += v;
                acc[1] += v * v;
            }
        }
        for (acc, &s) in sums.iter().zip(&probes) {
            let (mean, var) = gp.predict(s);
            let emp_mean = acc[0] / N as f64;
            let emp_var = acc[1] / N as f64 - emp_mean * emp_mean;
            // 5 standard errors: mean's is √(var/N); the variance's is var·√(2/N).
            assert!((emp_mean - mean).abs() < 5.0 * (var / N as f64).sqrt(), "{s:?}: {emp_mean} vs {mean}");
            assert!((emp_var - var).abs() < 5.0 * var * (2.0 / N as f64).sqrt(), "{s:?}: {emp_var} vs {var}");
        }
    }

    #[test]
    fn draws_are_fresh_and_reproducible_per_seed() {
        let (x, y) = data(20, 10, 7);
        let gp = Gp::fit(&x, &y, 10).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let (a, b) = (gp.draw(&mut rng), gp.draw(&mut rng));
        assert_ne!(a, b);
        assert_eq!(a, gp.draw(&mut ChaCha8Rng::seed_from_u64(8)));
        assert_eq!(a.score(set(&[1, 2])), a.bias() + a.weights()[1] + a.weights()[2]);
    }

    #[test]
    fn box_muller_is_standard_normal() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let z: Vec<f64> = StandardNormals::new(&mut rng).take(100_000).collect();
        let mean = z.iter().sum::<f64>() / z.len() as f64;
        let var = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / z.len() as f64;
        let within_one = z.iter().filter(|v| v.abs() < 1.0).count() as f64 / z.len() as f64;
        assert!(mean.abs() < 0.02 && (var - 1.0).abs() < 0.02, "mean {mean}, var {var}");
        assert!((within_one - 0.682_689).abs() < 0.01, "P(|z| < 1) = {within_one}");
    }

    #[test]
    fn degenerate_data_fit_without_failing() {
        // No concepts at all: only the bias is learnt.
        let gp = Gp::fit(&[ConceptSet::EMPTY; 3], &[0.2, 0.4, 0.6], 0).unwrap();
        let direct = Direct::new(&[ConceptSet::EMPTY; 3], &[0.2, 0.4, 0.6], gp.sigma0(), gp.noise_level());
        assert!(close(gp.log_marginal_likelihood(), direct.lml, 1e-9));
        assert!(close(gp.predict(ConceptSet::EMPTY).0, direct.predict(ConceptSet::EMPTY).0, 1e-9));
        // One observation, the widest domain.
        let gp = Gp::fit(&[set(&[0, 511])], &[1.0], MAX_CONCEPTS).unwrap();
        let (mean, var) = gp.predict(set(&[511]));
        assert!(mean.is_finite() && var > 0.0);
        assert!(gp.draw(&mut ChaCha8Rng::seed_from_u64(1)).score(set(&[0, 511])).is_finite());
    }

    #[test]
    fn bad_input_is_rejected_with_clear_errors() {
        let x = [set(&[0]), set(&[1])];
        assert_eq!(Gp::fit(&[], &[], 3).unwrap_err(), GpError::Empty);
        assert_eq!(Gp::fit(&x, &[0.5], 3).unwrap_err(), GpError::LengthMismatch { sets: 2, rates: 1 });
        let err = Gp::fit(&x, &[0.5, f64::NAN], 3).unwrap_err();
        assert_eq!(err.to_string(), "failure rate `NaN` of observation 1 is not a finite number");
        let err = Gp::fit(&x, &[0.5, 0.1], 1).unwrap_err();
        assert_eq!(err.to_string(), "concept set of observation 1 contains concept 1, but only `1` concepts exist");
        let past = MAX_CONCEPTS + 1;
        assert_eq!(Gp::fit(&x, &[0.5, 0.1], past).unwrap_err(), GpError::TooManyConcepts { d: past });
        let err = Gp::with_params(&x, &[0.5, 0.1], 3, 1.0, -1.0).unwrap_err();
        assert_eq!(err.to_string(), "hyperparameter `noise_level` must be a positive finite number, got `-1`");
        assert_eq!(Gp::fit(&x, &[1e300, 1e300], 3).unwrap_err(), GpError::Overflow);
    }
}
