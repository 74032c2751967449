//! The RBF + White GP of the paper's kernel ablation (appendix D, "Varying the Gaussian Process
//! kernel"): scikit-learn's `GaussianProcessRegressor(kernel=RBF() + WhiteKernel())` with its
//! defaults (`normalize_y=False`, `alpha=1e-10`, one L-BFGS-B run from `length_scale=1`,
//! `noise_level=1`, bounds `1e-5..1e5`). On multi-hot vectors ‖x − x'‖² = |S △ S'|, so
//!
//! ```text
//! k(S, S') = exp(−|S △ S'| / (2ℓ²)) + noise·δ(S, S')
//! ```
//!
//! Unlike the dot-product kernel this one has no small weight space, so the GP is fitted in
//! function space (n×n, n = evaluated sets: a few hundred in a search). Its Thompson draw is
//! still exact over the whole lattice, without an N×N covariance, by two facts (`docs/gp.md`):
//!
//! - **An exact finite feature map on small sets.** With β = 1/ℓ²,
//!   exp(−|S △ S'|β/2) = e^{−(|S|+|S'|)β/2}·e^{|S∩S'|β} and e^{mβ} = Σ_{t≤m} C(m,t)(e^β − 1)^t, so
//!   k(S, S') = Σ_{T ⊆ S∩S'} φ_T(S)·φ_T(S') with φ_T(S) = e^{−(|S|−|T|)β/2}·(1 − e^{−β})^{|T|/2}
//!   for every T ⊆ S. A prior draw is f(S) = Σ_{T⊆S} φ_T(S)·z_T with one independent standard
//!   normal z_T per concept set T — 2^|S| terms per set, exact for sets up to [`MAX_DRAW_SET`].
//!   z_T is a counter-based normal (a hash of the draw's key and T), so the draw is defined on
//!   the whole lattice without storing it.
//! - **Matheron's rule** turns a joint prior draw into a joint posterior draw:
//!   f_post(·) = f(·) + k(·, X)·(K + s2·I)⁻¹·(y − f(X) − ε), ε ~ N(0, s2·I), s2 = noise + alpha.
//!
//! Scoring a set is then O(2^|S| + n), and every unexplored valid set is scored from one joint
//! sample of the latent function (noise excluded, as for the dot-product draw).

use std::f64::consts::{PI, TAU};

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rand::{Rng, RngExt};

use super::gp::{ALPHA, BOUNDS, GpError, StandardNormals, check_data, maximise};
use crate::ir::{ConceptId, ConceptSet};

/// The largest set an exact draw can score (it sums over the set's 2^|S| subsets) and a fit
/// accepts.
pub const MAX_DRAW_SET: usize = 16;

/// A fitted RBF + White GP.
#[derive(Debug, Clone)]
pub struct RbfGp {
    d: usize,
    length_scale: f64,
    noise_level: f64,
    lml: f64,
    x: Vec<ConceptSet>,
    y: DVector<f64>,
    chol: Cholesky<f64, Dyn>,
    /// (K + s2·I)⁻¹·y.
    alpha: DVector<f64>,
    /// exp(−v/(2ℓ²)) for every symmetric-difference size v.
    decay: Vec<f64>,
}

/// |S △ S'|, the squared distance of the multi-hot vectors.
fn distance(a: ConceptSet, b: ConceptSet) -> usize {
    a.symmetric_difference(b).len()
}

/// exp(−v/(2ℓ²)) for v = 0..=MAX_CONCEPTS.
fn decay(length_scale: f64) -> Vec<f64> {
    let scale = 2.0 * length_scale * length_scale;
    (0..=crate::ir::MAX_CONCEPTS).map(|v| (-(v as f64) / scale).exp()).collect()
}

/// Log marginal likelihood and its gradient in θ = (log ℓ, log noise), as scikit-learn computes
/// them: ∂LML/∂θ = ½·tr((ααᵀ − K⁻¹)·∂K/∂θ) with ∂K/∂log ℓ = K_rbf ∘ D/ℓ² and ∂K/∂log noise =
/// noise·I. A kernel matrix that is not positive definite has likelihood −∞ (scikit-learn's
/// convention), so the optimiser backs off.
fn lml_and_grad(x: &[ConceptSet], y: &DVector<f64>, theta: [f64; 2]) -> (f64, [f64; 2]) {
    let (length_scale, noise) = (theta[0].exp(), theta[1].exp());
    let table = decay(length_scale);
    let n = x.len();
    let mut k = DMatrix::from_fn(n, n, |i, j| table[distance(x[i], x[j])]);
    for i in 0..n {
        k[(i, i)] += noise + ALPHA;
    }
    let Some(chol) = k.cholesky() else { return (f64::NEG_INFINITY, [0.0, 0.0]) };
    let alpha = chol.solve(y);
    let logdet: f64 = 2.0 * chol.l_dirty().diagonal().iter().map(|v| v.ln()).sum::<f64>();
    let lml = -0.5 * y.dot(&alpha) - 0.5 * logdet - 0.5 * n as f64 * (2.0 * PI).ln();
    let kinv = chol.inverse();
    let l2 = length_scale * length_scale;
    let mut g_length = 0.0;
    for i in 0..n {
        for j in 0..n {
            let v = distance(x[i], x[j]);
            if v > 0 {
                g_length += (alpha[i] * alpha[j] - kinv[(i, j)]) * table[v] * v as f64 / l2;
            }
        }
    }
    let g_noise = 0.5 * noise * (alpha.dot(&alpha) - kinv.trace());
    (lml, [0.5 * g_length, g_noise])
}

impl RbfGp {
    /// Fits ℓ and the noise by maximising the log marginal likelihood (from scikit-learn's start
    /// ℓ = 1, noise = 1, within its bounds) and conditions on the data.
    pub fn fit(x: &[ConceptSet], y: &[f64], d: usize) -> Result<RbfGp, GpError> {
        check(x, y, d)?;
        let yv = DVector::from_column_slice(y);
        let [length_scale, noise_level] =
            maximise(|th| lml_and_grad(x, &yv, th)).map(|t| t.exp().clamp(BOUNDS.0, BOUNDS.1));
        RbfGp::condition(x, yv, d, length_scale, noise_level)
    }

    /// Conditions on the data with fixed hyperparameters (scikit-learn's `optimizer=None`).
    pub fn with_params(
        x: &[ConceptSet],
        y: &[f64],
        d: usize,
        length_scale: f64,
        noise_level: f64,
    ) -> Result<RbfGp, GpError> {
        for (name, value) in [("length_scale", length_scale), ("noise_level", noise_level)] {
            if !(value.is_finite() && value > 0.0) {
                return Err(GpError::BadHyperparameter { name, value });
            }
        }
        check(x, y, d)?;
        RbfGp::condition(x, DVector::from_column_slice(y), d, length_scale, noise_level)
    }

    fn condition(
        x: &[ConceptSet],
        y: DVector<f64>,
        d: usize,
        length_scale: f64,
        noise_level: f64,
    ) -> Result<RbfGp, GpError> {
        let (lml, _) = lml_and_grad(x, &y, [length_scale.ln(), noise_level.ln()]);
        let table = decay(length_scale);
        let n = x.len();
        let mut k = DMatrix::from_fn(n, n, |i, j| table[distance(x[i], x[j])]);
        for i in 0..n {
            k[(i, i)] += noise_level + ALPHA;
        }
        // The kernel matrix is ⪰ (noise + alpha)·I in exact arithmetic; a failure here means
        // the rates overflowed, not a bad kernel.
        let chol = k.cholesky().ok_or(GpError::Overflow)?;
        let alpha = chol.solve(&y);
        if !(lml.is_finite() && alpha.iter().all(|v| v.is_finite())) {
            return Err(GpError::Overflow);
        }
        Ok(RbfGp { d, length_scale, noise_level, lml, x: x.to_vec(), y, chol, alpha, decay: table })
    }

    /// Posterior mean and variance of the latent failure rate at `set` (noise excluded, as
    /// [`super::gp::Gp::predict`]).
    pub fn predict(&self, set: ConceptSet) -> (f64, f64) {
        let ks = DVector::from_iterator(self.x.len(), self.x.iter().map(|&xi| self.decay[distance(set, xi)]));
        let v = self.chol.l_dirty().solve_lower_triangular(&ks).expect("a Cholesky factor has a non-zero diagonal");
        (ks.dot(&self.alpha), (1.0 - v.dot(&v)).max(0.0))
    }

    /// One Thompson sample of the latent function over every set (Matheron's rule on an exact
    /// prior draw), using the caller's RNG: a fresh draw per call. O(n²).
    pub fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> RbfDraw {
        let prior = Prior::new(rng.random(), self.length_scale);
        let s = (self.noise_level + ALPHA).sqrt();
        let noise: Vec<f64> = StandardNormals::new(rng).take(self.x.len()).collect();
        let residual = DVector::from_iterator(
            self.x.len(),
            self.x.iter().zip(self.y.iter()).zip(&noise).map(|((&xi, &yi), &e)| yi - prior.at(xi) - s * e),
        );
        RbfDraw { prior, x: self.x.clone(), weights: self.chol.solve(&residual), decay: self.decay.clone() }
    }

    /// The RBF length scale ℓ (scikit-learn's `length_scale`).
    pub fn length_scale(&self) -> f64 {
        self.length_scale
    }

    /// The White kernel's noise variance (scikit-learn's `noise_level`).
    pub fn noise_level(&self) -> f64 {
        self.noise_level
    }

    /// Log marginal likelihood at the GP's hyperparameters.
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.lml
    }

    pub fn dim(&self) -> usize {
        self.d
    }
}

fn check(x: &[ConceptSet], y: &[f64], d: usize) -> Result<(), GpError> {
    check_data(x, y, d)?;
    match x.iter().find(|s| s.len() > MAX_DRAW_SET) {
        Some(s) => Err(GpError::SetTooLarge { size: s.len(), max: MAX_DRAW_SET }),
        None => Ok(()),
    }
}

/// One joint draw from the RBF prior: f(S) = Σ_{T⊆S} φ_T(S)·z_T.
#[derive(Debug, Clone, PartialEq)]
struct Prior {
    key: u64,
    /// φ for |S| = s, |T| = t at `coef[s][t]`.
    coef: Vec<Vec<f64>>,
}

impl Prior {
    fn new(key: u64, length_scale: f64) -> Prior {
        let beta = 1.0 / (length_scale * length_scale);
        // ln(1 − e^{−β}), accurate for tiny β (a huge ℓ) and exactly 0 for a huge β.
        let ln_keep = (-(-beta).exp_m1()).ln();
        let coef = (0..=MAX_DRAW_SET)
            .map(|s| (0..=s).map(|t| (-((s - t) as f64) * beta / 2.0 + t as f64 / 2.0 * ln_keep).exp()).collect())
            .collect();
        Prior { key, coef }
    }

    /// # Panics
    /// If `set` holds more than [`MAX_DRAW_SET`] concepts (GPTS rejects such lattices up front).
    fn at(&self, set: ConceptSet) -> f64 {
        let coef = &self.coef[set.len()];
        // Every submask T of the set, the set itself first, the empty set last.
        let mut sum = 0.0;
        let ids: Vec<ConceptId> = set.iter().collect();
        let full = (1u64 << ids.len()) - 1;
        let mut t = full;
        loop {
            let sub = ConceptSet::from_ids(ids.iter().enumerate().filter(|(i, _)| t >> i & 1 == 1).map(|(_, c)| *c));
            sum += coef[t.count_ones() as usize] * normal(self.key, sub);
            if t == 0 {
                return sum;
            }
            t = (t - 1) & full;
        }
    }
}

/// SplitMix64's output function: a bijective mix of 64 bits.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The standard normal z_T of the draw `key` (Box–Muller on two hashed uniforms).
fn normal(key: u64, set: ConceptSet) -> f64 {
    let t = set.low_bits();
    let mut h = mix(mix(key ^ t as u64) ^ (t >> 64) as u64);
    if !set.fits_128() {
        // Wider sets mix in every word; sets of 128 concepts or fewer keep their old draws.
        h = set.words()[2..].iter().fold(h, |h, w| mix(h ^ w));
    }
    let (a, b) = (mix(h), mix(h ^ 0x5851_F42D_4C95_7F2D));
    const UNIT: f64 = 1.0 / (1u64 << 53) as f64;
    let u = ((a >> 11) + 1) as f64 * UNIT; // (0, 1]: ln(u) is finite
    let v = (b >> 11) as f64 * UNIT;
    (-2.0 * u.ln()).sqrt() * (TAU * v).cos()
}

/// One Thompson sample of the latent failure-rate function of an [`RbfGp`].
#[derive(Debug, Clone, PartialEq)]
pub struct RbfDraw {
    prior: Prior,
    x: Vec<ConceptSet>,
    /// (K + s2·I)⁻¹·(y − f(X) − ε).
    weights: DVector<f64>,
    decay: Vec<f64>,
}

impl RbfDraw {
    /// The sampled function at `set`: O(2^|set| + n).
    ///
    /// # Panics
    /// If `set` holds more than [`MAX_DRAW_SET`] concepts.
    pub fn score(&self, set: ConceptSet) -> f64 {
        let update: f64 =
            self.x.iter().zip(self.weights.iter()).map(|(&xi, w)| self.decay[distance(set, xi)] * w).sum();
        self.prior.at(set) + update
    }
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

    fn data(n: usize, d: u32, seed: u64) -> (Vec<ConceptSet>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let k = rng.random_range(1..=4);
                let s = (0..k).fold(ConceptSet::EMPTY, |s, _| s.with(ConceptId(rng.random_range(0..d))));
                // A pair effect the dot-product kernel cannot represent.
                let pair = s.contains(ConceptId(0)) && s.contains(ConceptId(1));
                let f = if pair { 0.9 } else { 0.1 } + 0.1 * (rng.random::<f64>() - 0.5);
                (s, (f.clamp(0.0, 1.0) * 5.0).round() / 5.0)
            })
            .unzip()
    }

    #[test]
    fn the_feature_map_reproduces_the_kernel() {
        // Σ_{T ⊆ S∩S'} φ_T(S)·φ_T(S') = exp(−|S △ S'|/(2ℓ²)) for every size pair, at ℓ from the
        // lower bound's neighbourhood to the upper bound.
        for length_scale in [0.05, 0.3, 1.0, 2.7, 40.0, 1e5] {
            let prior = Prior::new(0, length_scale);
            let table = decay(length_scale);
            for (a, b) in [
                (set(&[]), set(&[])),
                (set(&[1]), set(&[1])),
                (set(&[1, 2, 3]), set(&[2, 3, 4, 5])),
                (set(&[0, 9]), set(&[7])),
                (set(&[0, 1, 2, 3, 4]), set(&[0, 1, 2, 3, 4])),
            ] {
                let (s, t) = (a.len(), b.len());
                let m = a.intersection(b).len();
                let binom = |n: usize, k: usize| (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64);
                let sum: f64 = (0..=m).map(|k| binom(m, k) * prior.coef[s][k] * prior.coef[t][k]).sum();
                let want = table[distance(a, b)];
                assert!((sum - want).abs() < 1e-12 * want.max(1e-300).max(1.0), "ℓ {length_scale}: {sum} vs {want}");
            }
        }
    }

    #[test]
    fn draws_have_the_posterior_mean_and_covariance() {
        let (x, y) = data(25, 8, 1);
        let gp = RbfGp::with_params(&x, &y, 8, 1.3, 0.05).unwrap();
        let probes = [set(&[]), set(&[0, 1]), set(&[0, 1, 5]), set(&[2, 3, 4, 6, 7]), x[3]];
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        const N: usize = 20_000;
        let mut sums = [[0.0; 2]; 5];
        let mut cross = 0.0;
        for _ in 0..N {
            let draw = gp.draw(&mut rng);
            let v: Vec<f64> = probes.iter().map(|&s| draw.score(s)).collect();
            for (acc, x) in sums.iter_mut().zip(&v) {
                acc[0] += x;
                acc[1] += x * x;
            }
            cross += v[1] * v[2];
        }
        let mut means = Vec::new();
        for (acc, &s) in sums.iter().zip(&probes) {
            let (mean, var) = gp.predict(s);
            let emp_mean = acc[0] / N as f64;
            let emp_var = acc[1] / N as f64 - emp_mean * emp_mean;
            assert!((emp_mean - mean).abs() < 5.0 * (var / N as f64).sqrt() + 1e-9, "{s:?}: {emp_mean} vs {mean}");
            assert!((emp_var - var).abs() < 5.0 * var * (2.0 / N as f64).sqrt() + 1e-9, "{s:?}: {emp_var} vs {var}");
            means.push(emp_mean);
        }
        // The joint draw: the covariance of two overlapping sets is the posterior's,
        // k(a, b) − k(a, X)(K + s2·I)⁻¹k(X, b).
        let (a, b) = (probes[1], probes[2]);
        let ka = DVector::from_iterator(x.len(), x.iter().map(|&xi| gp.decay[distance(a, xi)]));
        let kb = DVector::from_iterator(x.len(), x.iter().map(|&xi| gp.decay[distance(b, xi)]));
        let cov = gp.decay[distance(a, b)] - ka.dot(&gp.chol.solve(&kb));
        let emp = cross / N as f64 - means[1] * means[2];
        let (va, vb) = (gp.predict(a).1, gp.predict(b).1);
        assert!((emp - cov).abs() < 5.0 * (va * vb).sqrt() * (2.0 / N as f64).sqrt(), "cov {emp} vs {cov}");
    }

    #[test]
    fn hashed_normals_are_standard_and_independent() {
        let z: Vec<f64> = (0..100_000u128).map(|t| normal(7, ConceptSet::from_bits(t << 3 | 1))).collect();
        let mean = z.iter().sum::<f64>() / z.len() as f64;
        let var = z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / z.len() as f64;
        let lag: f64 = z.windows(2).map(|w| w[0] * w[1]).sum::<f64>() / (z.len() - 1) as f64;
        assert!(mean.abs() < 0.02 && (var - 1.0).abs() < 0.02 && lag.abs() < 0.02, "{mean} {var} {lag}");
        let s = ConceptSet::from_bits(5);
        assert_ne!(normal(7, s), normal(8, s), "a fresh key is a fresh draw");
        assert_eq!(normal(7, s), normal(7, s));
    }

    #[test]
    fn fit_is_a_stationary_maximum_and_learns_the_pair() {
        let (x, y) = data(60, 6, 3);
        let gp = RbfGp::fit(&x, &y, 6).unwrap();
        let yv = DVector::from_column_slice(&y);
        let th = [gp.length_scale().ln(), gp.noise_level().ln()];
        let (lml, grad) = lml_and_grad(&x, &yv, th);
        assert_eq!(lml, gp.log_marginal_likelihood());
        for (i, g) in grad.iter().enumerate() {
            let at_bound = th[i] <= BOUNDS.0.ln() + 1e-12 || th[i] >= BOUNDS.1.ln() - 1e-12;
            assert!(at_bound || g.abs() < 1e-5, "gradient {grad:?} at {th:?}");
        }
        for (dx, dy) in [(0.01, 0.0), (-0.01, 0.0), (0.0, 0.01), (0.0, -0.01)] {
            assert!(lml_and_grad(&x, &yv, [th[0] + dx, th[1] + dy]).0 < lml);
        }
        assert!(gp.predict(set(&[0, 1])).0 > gp.predict(set(&[0])).0 + 0.3, "the pair fails, its parts do not");
    }

    #[test]
    fn draws_are_fresh_and_reproducible_per_seed() {
        let (x, y) = data(20, 6, 4);
        let gp = RbfGp::fit(&x, &y, 6).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (a, b) = (gp.draw(&mut rng), gp.draw(&mut rng));
        assert_ne!(a, b);
        assert_eq!(a, gp.draw(&mut ChaCha8Rng::seed_from_u64(5)));
        assert_eq!(a.score(set(&[1, 2])), a.score(set(&[2, 1])));
    }

    #[test]
    fn bad_input_is_rejected_with_clear_errors() {
        let x = [set(&[0]), set(&[1])];
        assert_eq!(RbfGp::fit(&[], &[], 3).unwrap_err(), GpError::Empty);
        assert_eq!(RbfGp::fit(&x, &[0.5], 3).unwrap_err(), GpError::LengthMismatch { sets: 2, rates: 1 });
        let err = RbfGp::with_params(&x, &[0.5, 0.1], 3, 0.0, 1.0).unwrap_err();
        assert_eq!(err.to_string(), "hyperparameter `length_scale` must be a positive finite number, got `0`");
        let big = ConceptSet::from_ids((0..17).map(ConceptId));
        let err = RbfGp::fit(&[big], &[0.5], 20).unwrap_err();
        assert_eq!(err.to_string(), "a set of `17` concepts is too large for an exact RBF Thompson draw (at most 16)");
        assert_eq!(RbfGp::fit(&x, &[1e300, 1e300], 3).unwrap_err(), GpError::Overflow);
    }
}
