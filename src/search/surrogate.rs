//! The interaction surrogate of `--algo interact`: Bayesian regression of a set's failure rate on
//! concept indicators and their pairwise products, with a horseshoe prior sampled by Gibbs (as in
//! BOCS, Baptista & Poloczek 2018), plus one indicator per confirmed core.
//!
//! ```text
//! f(S) = β₀ + Σ_{i∈S} βᵢ + Σ_{i<j∈S} βᵢⱼ + Σ_{cores C⊆S} β_C
//! FR(S) ~ N(f(S), σ²/n_S)            n_S: answered observations of S
//! βₖ ~ N(0, σ²·τ_g²·λₖ²)             main effects and pairs (group g), horseshoe: λₖ, τ_g ~ C⁺(0, 1)
//! β₀, β_C ~ N(0, 1)                  bias and cores: not shrunk
//! p(σ²) ∝ 1/σ²
//! ```
//!
//! The paper's DotProduct GP is the first two terms with one shared variance; it cannot say "A and
//! B fail together, neither alone". The pairwise terms can, and the horseshoe lets the few pairs
//! that matter stand out of the ~450 that do not. A third option, `Prior::Ridge`, keeps λₖ = 1:
//! one Gaussian variance per group (a GP with the set kernel σ₀² + σ₁²·|S∩S'| + σ₂²·C(|S∩S'|, 2)).
//! `docs/search.md` compares them.
//!
//! Every feature is the indicator of a sub-pattern of S, so φ(S)·diag(D)·φ(S') sums the prior
//! variances of the features of S ∩ S': the kernel costs O(|S ∩ S'|²), and the Gaussian step of
//! the sampler works in observation space — an n×n Cholesky (Bhattacharya, Chakraborty & Mallick
//! 2016) instead of a p×p one — whenever n < p (p ≈ 450 on the driving domain). With more
//! observations than features it switches to the p×p precision (Rue 2001). Both are exact draws
//! from the same Gaussian conditional, checked against each other and against the closed form.

use std::f64::consts::TAU;

use faer::linalg::triangular_solve::{solve_lower_triangular_in_place, solve_upper_triangular_in_place};
use faer::{Mat, Par, Side};
use rand::distr::Open01;
use rand::{Rng, RngExt};

use crate::ir::ConceptSet;

/// No feature: the two concepts never occur together in a valid set.
const NONE: u32 = u32::MAX;

/// Prior variance of the unshrunk coefficients (bias and cores), on the failure-rate scale.
const FIXED_VARIANCE: f64 = 1.0;

/// Variances are kept in this range so that a horseshoe scale collapsing toward 0 or escaping
/// toward ∞ cannot make a Cholesky factor singular or overflow.
const VARIANCE_RANGE: (f64, f64) = (1e-12, 1e6);

/// Which interactions the regression holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// Concept indicators only (the paper's linear model, with a sparsity prior).
    Linear,
    /// Concept indicators and their pairwise products.
    Pairwise,
}

/// The prior on main effects and pairs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Prior {
    /// One half-Cauchy scale per coefficient and per group: sparse.
    Horseshoe,
    /// One half-Cauchy scale per group only: a Gaussian (ridge) prior whose width is learned.
    Ridge,
}

/// Kinds of features, in the order of their indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Bias,
    Main,
    Pair,
    Core,
}

/// The feature map φ(S): the bias, one indicator per concept, one per pair of concepts that occur
/// together in some valid set, and one per confirmed core.
#[derive(Debug, Clone)]
pub struct Basis {
    d: usize,
    /// `pair[i·d + j]` (i < j): the feature index of the pair, or [`NONE`].
    pair: Vec<u32>,
    pairs: usize,
    cores: Vec<ConceptSet>,
}

impl Basis {
    /// The basis for a search space: `sets` are its valid sets over `d` concepts.
    pub fn new(sets: &[ConceptSet], d: usize, order: Order) -> Basis {
        let mut pair = vec![NONE; d * d];
        let mut pairs = 0;
        if order == Order::Pairwise {
            let mut seen = vec![false; d * d];
            let mut ids = Vec::with_capacity(8);
            for s in sets {
                ids.clear();
                ids.extend(s.iter().map(|c| c.index()));
                for (k, &i) in ids.iter().enumerate() {
                    for &j in &ids[k + 1..] {
                        seen[i * d + j] = true;
                    }
                }
            }
            // Pair features in (i, j) order, so indices do not depend on the order of `sets`.
            for (ij, s) in seen.iter().enumerate() {
                if *s {
                    pair[ij] = (1 + d + pairs) as u32;
                    pairs += 1;
                }
            }
        }
        Basis { d, pair, pairs, cores: Vec::new() }
    }

    /// Number of features.
    pub fn len(&self) -> usize {
        1 + self.d + self.pairs + self.cores.len()
    }

    pub fn is_empty(&self) -> bool {
        false
    }

    pub fn dim(&self) -> usize {
        self.d
    }

    /// Number of pair features.
    pub fn pairs(&self) -> usize {
        self.pairs
    }

    pub fn cores(&self) -> &[ConceptSet] {
        &self.cores
    }

    /// Add the indicator "contains `core`": the core's whole effect gets one coefficient, so the
    /// pairs need not explain it (a triple's effect spread over its three pairs would send the
    /// search to other sets holding those pairs).
    pub fn add_core(&mut self, core: ConceptSet) {
        if !self.cores.contains(&core) {
            self.cores.push(core);
        }
    }

    fn kind(&self, k: usize) -> Kind {
        if k == 0 {
            Kind::Bias
        } else if k <= self.d {
            Kind::Main
        } else if k <= self.d + self.pairs {
            Kind::Pair
        } else {
            Kind::Core
        }
    }

    /// Calls `f` with the index of every feature of `set`. Since every feature is the indicator
    /// of a sub-pattern, the features shared by S and S' are exactly those of S ∩ S'.
    fn for_each(&self, set: ConceptSet, mut f: impl FnMut(usize)) {
        f(0);
        let mut rest = set.iter().map(|c| c.index());
        while let Some(i) = rest.next() {
            f(1 + i);
            for j in rest.clone() {
                let p = self.pair[i * self.d + j];
                if p != NONE {
                    f(p as usize);
                }
            }
        }
        let first_core = 1 + self.d + self.pairs;
        for (k, c) in self.cores.iter().enumerate() {
            if c.is_subset_of(set) {
                f(first_core + k);
            }
        }
    }

    /// Σ of `values` over the features of `set`.
    fn sum(&self, set: ConceptSet, values: &[f64]) -> f64 {
        let mut s = 0.0;
        self.for_each(set, |k| s += values[k]);
        s
    }
}

/// Observed failure rates: set, rate, and the weight of the rate (answered observations: the
/// rate of n answers has variance σ²/n).
#[derive(Debug, Clone, Default)]
pub struct Data {
    pub sets: Vec<ConceptSet>,
    pub rates: Vec<f64>,
    pub weights: Vec<f64>,
}

impl Data {
    pub fn push(&mut self, set: ConceptSet, rate: f64, weight: f64) {
        self.sets.push(set);
        self.rates.push(rate);
        self.weights.push(weight);
    }

    pub fn len(&self) -> usize {
        self.sets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sets.is_empty()
    }
}

/// The Gaussian conditional of the coefficients given their prior variances `D` and the noise
/// σ²: N(μ, Σ) with Σ = (ΦᵀWΦ/σ² + D⁻¹)⁻¹ and μ = ΣΦᵀWy/σ² (W = diag(weights)). Built in
/// observation space when n < p, in feature space otherwise.
pub struct Conditional<'a> {
    basis: &'a Basis,
    data: &'a Data,
    prior: Vec<f64>,
    /// √(wₐ)/σ: the row scale of Φ̃ = W^½Φ/σ.
    scale: Vec<f64>,
    factor: Factor,
}

enum Factor {
    /// Lower Cholesky factor of M = Φ̃DΦ̃ᵀ + I (n×n).
    Observations(Mat<f64>),
    /// Lower Cholesky factor of A = Φ̃ᵀΦ̃ + D⁻¹ (p×p) and the mean A⁻¹Φ̃ᵀα.
    Features(Mat<f64>, Vec<f64>),
}

impl<'a> Conditional<'a> {
    /// `prior[k]`: the prior variance of coefficient k (> 0); `noise`: σ² per observation.
    pub fn new(basis: &'a Basis, data: &'a Data, prior: Vec<f64>, noise: f64) -> Conditional<'a> {
        assert_eq!(prior.len(), basis.len(), "one prior variance per feature");
        let scale: Vec<f64> = data.weights.iter().map(|w| (w / noise).sqrt()).collect();
        let n = data.len();
        let factor = if n < basis.len() {
            let mut m = Mat::<f64>::zeros(n, n);
            for a in 0..n {
                for b in 0..=a {
                    let shared = data.sets[a].intersection(data.sets[b]);
                    m[(a, b)] = scale[a] * scale[b] * basis.sum(shared, &prior);
                }
                m[(a, a)] += 1.0;
            }
            Factor::Observations(cholesky(&m))
        } else {
            let p = basis.len();
            let mut a = Mat::<f64>::zeros(p, p);
            let mut rhs = vec![0.0; p];
            let mut feats = Vec::with_capacity(32);
            for (r, &set) in data.sets.iter().enumerate() {
                feats.clear();
                basis.for_each(set, |k| feats.push(k));
                let s2 = scale[r] * scale[r];
                for &k in &feats {
                    rhs[k] += s2 * data.rates[r];
                    for &l in &feats {
                        if l <= k {
                            a[(k, l)] += s2;
                        }
                    }
                }
            }
            for (k, v) in prior.iter().enumerate() {
                a[(k, k)] += 1.0 / v;
            }
            let l = cholesky(&a);
            let mut mean = Mat::from_fn(p, 1, |k, _| rhs[k]);
            solve_lower_triangular_in_place(l.as_ref(), mean.as_mut(), Par::Seq);
            solve_upper_triangular_in_place(l.as_ref().transpose(), mean.as_mut(), Par::Seq);
            Factor::Features(l, (0..p).map(|k| mean[(k, 0)]).collect())
        };
        Conditional { basis, data, prior, scale, factor }
    }

    /// Φ̃ᵀz scattered into feature space, times D: the map from observation space back to
    /// coefficients.
    fn back(&self, z: &Mat<f64>) -> Vec<f64> {
        let mut out = vec![0.0; self.basis.len()];
        for (a, &set) in self.data.sets.iter().enumerate() {
            let v = self.scale[a] * z[(a, 0)];
            self.basis.for_each(set, |k| out[k] += v);
        }
        out.iter_mut().zip(&self.prior).for_each(|(o, d)| *o *= d);
        out
    }

    /// M⁻¹r in place (observation space).
    fn solve(l: &Mat<f64>, r: &mut Mat<f64>) {
        solve_lower_triangular_in_place(l.as_ref(), r.as_mut(), Par::Seq);
        solve_upper_triangular_in_place(l.as_ref().transpose(), r.as_mut(), Par::Seq);
    }

    /// The posterior mean μ of the coefficients.
    pub fn mean(&self) -> Vec<f64> {
        match &self.factor {
            Factor::Observations(l) => {
                let n = self.data.len();
                let mut r = Mat::from_fn(n, 1, |a, _| self.scale[a] * self.data.rates[a]);
                Self::solve(l, &mut r);
                self.back(&r)
            }
            Factor::Features(_, mean) => mean.clone(),
        }
    }

    /// The posterior variance of f(set) = φ(set)·β.
    pub fn variance(&self, set: ConceptSet) -> f64 {
        match &self.factor {
            Factor::Observations(l) => {
                // φᵀΣφ = φᵀDφ − k̃ᵀM⁻¹k̃ with k̃ₐ = scaleₐ·φ(Sₐ)ᵀDφ(set).
                let n = self.data.len();
                let mut k = Mat::from_fn(n, 1, |a, _| {
                    self.scale[a] * self.basis.sum(self.data.sets[a].intersection(set), &self.prior)
                });
                solve_lower_triangular_in_place(l.as_ref(), k.as_mut(), Par::Seq);
                let explained: f64 = (0..n).map(|a| k[(a, 0)] * k[(a, 0)]).sum();
                self.basis.sum(set, &self.prior) - explained
            }
            Factor::Features(l, _) => {
                let p = self.basis.len();
                let mut phi = Mat::<f64>::zeros(p, 1);
                self.basis.for_each(set, |k| phi[(k, 0)] = 1.0);
                solve_lower_triangular_in_place(l.as_ref(), phi.as_mut(), Par::Seq);
                (0..p).map(|k| phi[(k, 0)] * phi[(k, 0)]).sum()
            }
        }
    }

    /// One exact draw from N(μ, Σ).
    pub fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> Vec<f64> {
        let p = self.basis.len();
        match &self.factor {
            Factor::Observations(l) => {
                // u ~ N(0, D), δ ~ N(0, I), v = Φ̃u + δ, β = u + DΦ̃ᵀM⁻¹(α − v).
                let u: Vec<f64> = self.prior.iter().map(|d| d.sqrt() * normal(rng)).collect();
                let n = self.data.len();
                let mut r = Mat::<f64>::zeros(n, 1);
                for a in 0..n {
                    let v = self.scale[a] * self.basis.sum(self.data.sets[a], &u) + normal(rng);
                    r[(a, 0)] = self.scale[a] * self.data.rates[a] - v;
                }
                Self::solve(l, &mut r);
                self.back(&r).iter().zip(&u).map(|(b, u)| b + u).collect()
            }
            Factor::Features(l, mean) => {
                // β = μ + L⁻ᵀz: Cov = (LLᵀ)⁻¹ = Σ.
                let mut z = Mat::from_fn(p, 1, |_, _| normal(rng));
                solve_upper_triangular_in_place(l.as_ref().transpose(), z.as_mut(), Par::Seq);
                (0..p).map(|k| mean[k] + z[(k, 0)]).collect()
            }
        }
    }
}

/// Lower Cholesky factor of a symmetric positive definite matrix given by its lower triangle.
/// Both matrices factored here are ⪰ I or ⪰ diag(1/D) with D bounded, so the factorisation
/// cannot fail on finite input; a non-finite entry would be a bug upstream.
fn cholesky(m: &Mat<f64>) -> Mat<f64> {
    let llt = m.llt(Side::Lower).expect("a matrix ⪰ I (or ⪰ D⁻¹ with bounded D) is positive definite");
    llt.L().to_owned()
}

/// The Gibbs state of the horseshoe (or ridge) regression. Kept across search rounds: each round
/// adds one observation, so a few sweeps from the previous state suffice (a warm-started chain).
#[derive(Debug, Clone)]
pub struct Gibbs {
    prior: Prior,
    /// Local scales λₖ² and their auxiliaries νₖ (Makalic & Schmidt 2016), per feature; unused
    /// for the bias and cores.
    lambda2: Vec<f64>,
    nu: Vec<f64>,
    /// Global scales τ_g² and auxiliaries ξ_g for main effects (0) and pairs (1).
    tau2: [f64; 2],
    xi: [f64; 2],
    sigma2: f64,
    beta: Vec<f64>,
}

impl Gibbs {
    pub fn new(prior: Prior) -> Gibbs {
        Gibbs {
            prior,
            lambda2: Vec::new(),
            nu: Vec::new(),
            tau2: [0.1; 2],
            xi: [1.0; 2],
            sigma2: 0.2,
            beta: Vec::new(),
        }
    }

    /// Grow the per-feature state to the basis (new cores start from the prior).
    fn fit_to(&mut self, basis: &Basis) {
        let p = basis.len();
        self.lambda2.resize(p, 1.0);
        self.nu.resize(p, 1.0);
        self.beta.resize(p, 0.0);
    }

    fn group(kind: Kind) -> Option<usize> {
        match kind {
            Kind::Main => Some(0),
            Kind::Pair => Some(1),
            Kind::Bias | Kind::Core => None,
        }
    }

    /// Prior variances of the coefficients at the current state.
    pub fn prior_variances(&self, basis: &Basis) -> Vec<f64> {
        (0..basis.len())
            .map(|k| match Self::group(basis.kind(k)) {
                Some(g) => clamp(self.sigma2 * self.tau2[g] * self.lambda2.get(k).copied().unwrap_or(1.0)),
                None => FIXED_VARIANCE,
            })
            .collect()
    }

    pub fn noise(&self) -> f64 {
        self.sigma2
    }

    pub fn tau2(&self) -> [f64; 2] {
        self.tau2
    }

    /// The conditional of the coefficients at the current state.
    pub fn conditional<'a>(&self, basis: &'a Basis, data: &'a Data) -> Conditional<'a> {
        Conditional::new(basis, data, self.prior_variances(basis), self.sigma2)
    }

    /// `sweeps` Gibbs sweeps, each: σ², the local and the global scales given β, then β given
    /// them. Returns the conditional of β at the final state, from which the last β was drawn:
    /// further draws from it are draws at the same state of the chain (Thompson draws of a batch).
    pub fn sweep<'a, R: Rng + ?Sized>(
        &mut self,
        basis: &'a Basis,
        data: &'a Data,
        sweeps: usize,
        rng: &mut R,
    ) -> Conditional<'a> {
        self.fit_to(basis);
        for _ in 1..sweeps {
            self.update_scales(basis, data, rng);
            self.beta = self.conditional(basis, data).draw(rng);
        }
        if sweeps > 0 {
            self.update_scales(basis, data, rng);
        }
        let conditional = self.conditional(basis, data);
        if sweeps > 0 {
            self.beta = conditional.draw(rng);
        }
        conditional
    }

    /// σ² | β, scales; then λₖ² (horseshoe), νₖ; then τ_g², ξ_g.
    fn update_scales<R: Rng + ?Sized>(&mut self, basis: &Basis, data: &Data, rng: &mut R) {
        let p = basis.len();
        // σ² | β, scales ~ IG((n + p_s)/2, (Σ wₐ·resₐ² + Σ_shrunk βₖ²/(τ²λ²))/2).
        let mut rss = 0.0;
        for (a, &set) in data.sets.iter().enumerate() {
            let r = data.rates[a] - basis.sum(set, &self.beta);
            rss += data.weights[a] * r * r;
        }
        let mut penalty = 0.0;
        let mut shrunk = 0usize;
        for k in 0..p {
            if let Some(g) = Self::group(basis.kind(k)) {
                penalty += self.beta[k] * self.beta[k] / (self.tau2[g] * self.lambda2[k]);
                shrunk += 1;
            }
        }
        let shape = (data.len() + shrunk) as f64 / 2.0;
        self.sigma2 = clamp(inv_gamma(rng, shape, (rss + penalty) / 2.0));

        let mut group_sum = [0.0; 2];
        let mut group_len = [0usize; 2];
        for k in 0..p {
            if let Some(g) = Self::group(basis.kind(k)) {
                let b2 = self.beta[k] * self.beta[k];
                if self.prior == Prior::Horseshoe {
                    self.lambda2[k] =
                        clamp(inv_gamma(rng, 1.0, 1.0 / self.nu[k] + b2 / (2.0 * self.tau2[g] * self.sigma2)));
                    self.nu[k] = inv_gamma(rng, 1.0, 1.0 + 1.0 / self.lambda2[k]);
                }
                group_sum[g] += b2 / self.lambda2[k];
                group_len[g] += 1;
            }
        }
        for g in 0..2 {
            if group_len[g] == 0 {
                continue;
            }
            let shape = (group_len[g] as f64 + 1.0) / 2.0;
            self.tau2[g] = clamp(inv_gamma(rng, shape, 1.0 / self.xi[g] + group_sum[g] / (2.0 * self.sigma2)));
            self.xi[g] = inv_gamma(rng, 1.0, 1.0 + 1.0 / self.tau2[g]);
        }
    }
}

fn clamp(v: f64) -> f64 {
    v.clamp(VARIANCE_RANGE.0, VARIANCE_RANGE.1)
}

/// A Thompson draw as a function of sets: bias, concept weights, a dense d×d table of pair
/// weights (0 where there is no pair feature), and the cores' weights.
#[derive(Debug, Clone)]
pub struct Draw {
    d: usize,
    bias: f64,
    main: Vec<f64>,
    pair: Vec<f64>,
    cores: Vec<(ConceptSet, f64)>,
}

impl Draw {
    pub fn new(basis: &Basis, beta: &[f64]) -> Draw {
        let d = basis.d;
        let pair = basis.pair.iter().map(|&p| if p == NONE { 0.0 } else { beta[p as usize] }).collect();
        let first_core = 1 + d + basis.pairs;
        Draw {
            d,
            bias: beta[0],
            main: beta[1..=d].to_vec(),
            pair,
            cores: basis.cores.iter().enumerate().map(|(k, c)| (*c, beta[first_core + k])).collect(),
        }
    }

    /// f(set) without the core terms: what the draw says about a set that holds no confirmed
    /// core. O(|set|²).
    pub fn score_open(&self, set: ConceptSet) -> f64 {
        let mut s = self.bias;
        let mut rest = set.iter().map(|c| c.index());
        while let Some(i) = rest.next() {
            s += self.main[i];
            let row = &self.pair[i * self.d..(i + 1) * self.d];
            for j in rest.clone() {
                s += row[j];
            }
        }
        s
    }

    /// f(set) with the core terms.
    pub fn score(&self, set: ConceptSet) -> f64 {
        self.score_open(set) + self.cores.iter().filter(|(c, _)| c.is_subset_of(set)).map(|(_, w)| w).sum::<f64>()
    }
}

/// A standard normal variate (Box–Muller; `rand` without `rand_distr` has none).
pub fn normal<R: Rng + ?Sized>(rng: &mut R) -> f64 {
    let u: f64 = rng.sample(Open01);
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (TAU * v).cos()
}

/// A Gamma(shape, 1) variate (Marsaglia & Tsang 2000; shape < 1 by the boost Γ(a) = Γ(a+1)·U^(1/a)).
pub fn gamma<R: Rng + ?Sized>(rng: &mut R, shape: f64) -> f64 {
    if shape < 1.0 {
        let u: f64 = rng.sample(Open01);
        return gamma(rng, shape + 1.0) * u.powf(1.0 / shape);
    }
    let d = shape - 1.0 / 3.0;
    let c = 1.0 / (9.0 * d).sqrt();
    loop {
        let x = normal(rng);
        let v = (1.0 + c * x).powi(3);
        if v <= 0.0 {
            continue;
        }
        let u: f64 = rng.sample(Open01);
        if u.ln() < 0.5 * x * x + d - d * v + d * v.ln() {
            return d * v;
        }
    }
}

/// An inverse-gamma variate with the given shape and scale: scale / Gamma(shape, 1).
pub fn inv_gamma<R: Rng + ?Sized>(rng: &mut R, shape: f64, scale: f64) -> f64 {
    if shape == 1.0 {
        // Exponential: −ln U, cheaper than the rejection sampler.
        let u: f64 = rng.sample(Open01);
        return scale / -u.ln();
    }
    scale / gamma(rng, shape)
}

#[cfg(test)]
mod tests;
