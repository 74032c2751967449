//! The surrogate against closed forms and planted signals: the interaction basis, the
//! conditional posterior, posterior draws, the horseshoe's Gibbs sampler and its variates.
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::ir::ConceptId;
use crate::ir::testkit::lattice;

fn set(ids: &[u32]) -> ConceptSet {
    ConceptSet::from_ids(ids.iter().map(|&i| ConceptId(i)))
}

/// The dense feature vector of a set, by brute force over the basis' definition.
fn phi(basis: &Basis, s: ConceptSet) -> Vec<f64> {
    let mut v = vec![0.0; basis.len()];
    basis.for_each(s, |k| v[k] = 1.0);
    v
}

/// The closed form in feature space: Σ = (ΦᵀWΦ/σ² + D⁻¹)⁻¹, μ = ΣΦᵀWy/σ².
fn reference(basis: &Basis, data: &Data, prior: &[f64], noise: f64) -> (DVector<f64>, DMatrix<f64>) {
    let p = basis.len();
    let mut a = DMatrix::from_diagonal(&DVector::from_iterator(p, prior.iter().map(|d| 1.0 / d)));
    let mut b = DVector::zeros(p);
    for (r, &s) in data.sets.iter().enumerate() {
        let f = DVector::from_vec(phi(basis, s));
        a += &f * f.transpose() * (data.weights[r] / noise);
        b += &f * (data.weights[r] * data.rates[r] / noise);
    }
    let cov = a.try_inverse().unwrap();
    (&cov * b, cov)
}

fn tiny(n: usize) -> (Basis, Data) {
    // Three concepts, 0 and 1 exclusive: features bias, 3 mains, pairs (0,2) and (1,2).
    let basis = Basis::new(&lattice(3, 3), 3, Order::Pairwise);
    let sets = [set(&[0]), set(&[0, 2]), set(&[1, 2]), set(&[2]), set(&[1]), set(&[0, 2]), set(&[1, 2]), set(&[0])];
    let mut data = Data::default();
    for (i, s) in sets.iter().cycle().take(n).enumerate() {
        data.push(*s, [0.2, 1.0, 0.4, 0.0, 0.6, 0.8][i % 6], (1 + i % 4) as f64);
    }
    (basis, data)
}

#[test]
fn basis_skips_pairs_that_never_occur_and_shares_features_of_the_intersection() {
    let (mut basis, _) = tiny(0);
    assert_eq!((basis.pairs(), basis.len()), (2, 6));
    basis.add_core(set(&[0, 2]));
    basis.add_core(set(&[0, 2]));
    assert_eq!(basis.len(), 7);
    let d: Vec<f64> = (0..basis.len()).map(|k| 0.5 + k as f64).collect();
    let all = lattice(3, 3);
    for a in &all {
        for b in &all {
            let brute: f64 = phi(&basis, *a).iter().zip(phi(&basis, *b)).zip(&d).map(|((x, y), d)| x * y * d).sum();
            assert!((basis.sum(a.intersection(*b), &d) - brute).abs() < 1e-12);
        }
    }
    assert_eq!(Basis::new(&all, 3, Order::Linear).len(), 4);
}

#[test]
fn conditional_matches_the_closed_form_in_both_spaces() {
    // n = 4 < p = 6: observation space; n = 8 ≥ p: feature space.
    for n in [4, 8] {
        let (basis, data) = tiny(n);
        let prior = vec![1.0, 0.3, 0.2, 0.5, 0.05, 0.7];
        let noise = 0.15;
        let cond = Conditional::new(&basis, &data, prior.clone(), noise);
        assert_eq!(matches!(cond.factor, Factor::Observations(_)), n < basis.len());
        let (mean, cov) = reference(&basis, &data, &prior, noise);
        for (k, m) in cond.mean().iter().enumerate() {
            assert!((m - mean[k]).abs() < 1e-9, "n = {n}, coefficient {k}: {m} vs {}", mean[k]);
        }
        for s in lattice(3, 3) {
            let f = DVector::from_vec(phi(&basis, s));
            let var = (f.transpose() * &cov * &f)[(0, 0)];
            assert!((cond.variance(s) - var).abs() < 1e-9, "n = {n}, set {s:?}");
        }
    }
}

#[test]
fn conditional_matches_a_hand_derived_posterior() {
    // One concept, linear: every observation is of {0}, so only f = β₀ + β₁ is identified. Its
    // prior is N(0, D₀ + D₁); with precision-weighted data s = Σw/σ², t = Σwy/σ² the posterior
    // is N(t/(1/V + s), 1/(1/V + s)) with V = D₀ + D₁.
    let basis = Basis::new(&[set(&[0])], 1, Order::Linear);
    let mut data = Data::default();
    data.push(set(&[0]), 0.8, 5.0);
    data.push(set(&[0]), 0.4, 10.0);
    let (d0, d1, noise) = (0.7, 0.2, 0.25);
    let cond = Conditional::new(&basis, &data, vec![d0, d1], noise);
    let (s, t) = (15.0 / noise, (0.8 * 5.0 + 0.4 * 10.0) / noise);
    let precision = 1.0 / (d0 + d1) + s;
    let mean = cond.mean();
    assert!((mean[0] + mean[1] - t / precision).abs() < 1e-12);
    assert!((cond.variance(set(&[0])) - 1.0 / precision).abs() < 1e-12);
    // The split between β₀ and β₁ follows the prior: β_k's share is D_k / V.
    assert!((mean[0] / (mean[0] + mean[1]) - d0 / (d0 + d1)).abs() < 1e-12);
}

#[test]
fn draws_have_the_conditional_mean_and_variance() {
    for n in [4, 8] {
        let (basis, data) = tiny(n);
        let cond = Conditional::new(&basis, &data, vec![1.0, 0.3, 0.2, 0.5, 0.05, 0.7], 0.15);
        let mut rng = ChaCha8Rng::seed_from_u64(n as u64);
        let probe = set(&[0, 2]);
        let draws = 40_000;
        let fs: Vec<f64> = (0..draws).map(|_| Draw::new(&basis, &cond.draw(&mut rng)).score(probe)).collect();
        let m = fs.iter().sum::<f64>() / draws as f64;
        let v = fs.iter().map(|f| (f - m).powi(2)).sum::<f64>() / (draws - 1) as f64;
        let (mean, var) = (basis.sum(probe, &cond.mean()), cond.variance(probe));
        assert!((m - mean).abs() < 5.0 * (var / draws as f64).sqrt(), "n = {n}: mean {m} vs {mean}");
        assert!((v / var - 1.0).abs() < 5.0 * (2.0 / draws as f64).sqrt(), "n = {n}: variance {v} vs {var}");
    }
}

#[test]
fn draw_scores_match_the_feature_sum() {
    let mut basis = Basis::new(&lattice(6, 4), 6, Order::Pairwise);
    basis.add_core(set(&[2, 3, 5]));
    let beta: Vec<f64> = (0..basis.len()).map(|k| (k as f64 * 0.37).sin()).collect();
    let draw = Draw::new(&basis, &beta);
    for s in lattice(6, 4) {
        let direct = basis.sum(s, &beta);
        assert!((draw.score(s) - direct).abs() < 1e-12);
        if !set(&[2, 3, 5]).is_subset_of(s) {
            assert!((draw.score_open(s) - direct).abs() < 1e-12);
        }
    }
}

#[test]
fn horseshoe_finds_a_planted_pair_and_shrinks_the_rest() {
    // Ten concepts; the failure rate is 0.05 + 0.85 when {2, 5} ⊆ S, observed 5 times per set.
    let sets = lattice(10, 4);
    let basis = Basis::new(&sets, 10, Order::Pairwise);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut data = Data::default();
    for k in 0..150 {
        let s = sets[(k * 7919) % sets.len()];
        let p = if set(&[2, 5]).is_subset_of(s) { 0.9 } else { 0.05 };
        let wrong = (0..5).filter(|_| rng.random_bool(p)).count();
        data.push(s, wrong as f64 / 5.0, 5.0);
    }
    assert!(data.sets.iter().filter(|s| set(&[2, 5]).is_subset_of(**s)).count() >= 5);
    let mut gibbs = Gibbs::new(Prior::Horseshoe);
    gibbs.sweep(&basis, &data, 200, &mut rng);
    // Average the chain's conditional means over further sweeps.
    let mut mean = vec![0.0; basis.len()];
    for _ in 0..100 {
        let cond = gibbs.sweep(&basis, &data, 1, &mut rng);
        for (m, v) in mean.iter_mut().zip(cond.mean()) {
            *m += v / 100.0;
        }
    }
    let pair = basis.pair[2 * 10 + 5] as usize;
    assert!((mean[pair] - 0.85).abs() < 0.15, "pair weight {}", mean[pair]);
    let others = (11..basis.len()).filter(|&k| k != pair).map(|k| mean[k].abs()).fold(0.0, f64::max);
    assert!(others < 0.1, "largest other pair weight {others}");
    assert!(gibbs.noise() < 0.5, "noise {}", gibbs.noise());
}

#[test]
fn gibbs_is_reproducible_per_seed_and_handles_no_data() {
    let (basis, data) = tiny(6);
    let run = |seed: u64| {
        let mut g = Gibbs::new(Prior::Horseshoe);
        g.sweep(&basis, &data, 5, &mut ChaCha8Rng::seed_from_u64(seed));
        g.beta.clone()
    };
    assert_eq!(run(1), run(1));
    assert_ne!(run(1), run(2));
    let mut g = Gibbs::new(Prior::Ridge);
    let empty = Data::default();
    g.sweep(&basis, &empty, 20, &mut ChaCha8Rng::seed_from_u64(0));
    assert!(g.beta.iter().all(|b| b.is_finite()));
    assert!(g.lambda2.iter().all(|l| *l == 1.0), "ridge keeps local scales at 1");
}

#[test]
fn variates_have_their_moments() {
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let n = 200_000;
    for shape in [0.5, 1.0, 2.5, 40.0] {
        let xs: Vec<f64> = (0..n).map(|_| gamma(&mut rng, shape)).collect();
        let m = xs.iter().sum::<f64>() / n as f64;
        let v = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n as f64;
        // Gamma(a, 1): mean a, variance a.
        assert!((m - shape).abs() < 5.0 * (shape / n as f64).sqrt(), "shape {shape}: mean {m}");
        assert!((v / shape - 1.0).abs() < 0.05, "shape {shape}: variance {v}");
    }
    // IG(1, b) = b / Exp(1): its median is b / ln 2.
    let mut ig: Vec<f64> = (0..n).map(|_| inv_gamma(&mut rng, 1.0, 2.0)).collect();
    ig.sort_by(f64::total_cmp);
    assert!((ig[n / 2] - 2.0 / 2f64.ln()).abs() < 0.05);
    let zs: Vec<f64> = (0..n).map(|_| normal(&mut rng)).collect();
    let m = zs.iter().sum::<f64>() / n as f64;
    let v = zs.iter().map(|z| z * z).sum::<f64>() / n as f64;
    assert!(m.abs() < 0.02 && (v - 1.0).abs() < 0.02);
}
