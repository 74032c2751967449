//! The weight-space GP against scikit-learn's `GaussianProcessRegressor(DotProduct() +
//! WhiteKernel())` on the datasets of `tests/gp/fixture.json` (made by `tests/gp/make_fixture.py`),
//! and the kernel ablation's RBF GP against `RBF() + WhiteKernel()` (`tests/gp/rbf_fixture.json`).

use revelio::ir::{ConceptId, ConceptSet};
use revelio::search::gp::{BOUNDS, Gp};
use revelio::search::gp_rbf::RbfGp;
use serde::Deserialize;

/// The datasets of a fixture, with scikit-learn's GP of one kernel (`R`) on each.
#[derive(Deserialize)]
struct Fixture<R> {
    datasets: Vec<Dataset<R>>,
}

#[derive(Deserialize)]
struct Dataset<R> {
    name: String,
    d: usize,
    x: Vec<Vec<u32>>,
    y: Vec<f64>,
    test_x: Vec<Vec<u32>>,
    fitted: R,
    fixed: Vec<R>,
}

/// scikit-learn's GP at one θ; `var` is its predicted std², which includes `noise_level`.
#[derive(Deserialize)]
struct Reference {
    sigma0: f64,
    noise_level: f64,
    lml: f64,
    mean: Vec<f64>,
    var: Vec<f64>,
}

const TOL: f64 = 1e-6;

fn fixture() -> Fixture<Reference> {
    serde_json::from_str(include_str!("gp/fixture.json")).expect("tests/gp/fixture.json parses")
}

fn sets(ids: &[Vec<u32>]) -> Vec<ConceptSet> {
    ids.iter().map(|s| ConceptSet::from_ids(s.iter().map(|&c| ConceptId(c)))).collect()
}

/// Absolute error for values of magnitude ≤ 1, relative above.
fn assert_close(what: &str, ours: f64, theirs: f64) {
    assert!((ours - theirs).abs() <= TOL * theirs.abs().max(1.0), "{what}: ours {ours}, scikit-learn {theirs}");
}

/// A GP's predictions at the test sets against scikit-learn's `mean` and `var` there.
fn assert_predictions(
    case: &str,
    predict: impl Fn(ConceptSet) -> (f64, f64),
    noise_level: f64,
    test_x: &[ConceptSet],
    (mean_ref, var_ref): (&[f64], &[f64]),
) {
    for (i, &set) in test_x.iter().enumerate() {
        let (mean, var) = predict(set);
        assert_close(&format!("{case}: mean at test set {i}"), mean, mean_ref[i]);
        assert_close(&format!("{case}: variance at test set {i}"), var + noise_level, var_ref[i]);
    }
}

fn assert_gp_predictions(case: &str, gp: &Gp, test_x: &[ConceptSet], r: &Reference) {
    assert_predictions(case, |s| gp.predict(s), gp.noise_level(), test_x, (&r.mean, &r.var));
}

/// Our fitted optimum against scikit-learn's (see `fitted_optimum_is_at_least_as_good_as_scikit_learns`):
/// `best` is our LML at our θ `ours`, `lml_at` our LML at any θ, `theirs` and `their_lml`
/// scikit-learn's θ and LML.
fn assert_optimum(
    name: &str,
    best: f64,
    ours: [f64; 2],
    theirs: [f64; 2],
    their_lml: f64,
    lml_at: impl Fn(f64, f64) -> f64,
) {
    assert!(best >= their_lml - TOL, "{name}: lml {best} < scikit-learn's {their_lml}");
    let flat = 1e-5 * best.abs().max(1.0);
    assert!(
        best - lml_at(theirs[0], theirs[1]) <= flat,
        "{name}: scikit-learn's θ {theirs:?} is far from our optimum {ours:?}"
    );
    for i in 0..2 {
        let mut mixed = ours;
        mixed[i] = theirs[i];
        let agree = (ours[i].ln() - theirs[i].ln()).abs() <= 1e-3;
        assert!(
            agree || best - lml_at(mixed[0], mixed[1]) <= flat,
            "{name}: hyperparameter {i}: {ours:?} vs {theirs:?}"
        );
    }
    for v in ours {
        assert!((BOUNDS.0..=BOUNDS.1).contains(&v), "{name}: {ours:?} outside the bounds");
    }
}

#[test]
fn fixed_hyperparameters_match_scikit_learn() {
    for ds in fixture().datasets {
        let (x, test_x) = (sets(&ds.x), sets(&ds.test_x));
        for r in &ds.fixed {
            let case = format!("{} at sigma0={} noise={}", ds.name, r.sigma0, r.noise_level);
            let gp = Gp::with_params(&x, &ds.y, ds.d, r.sigma0, r.noise_level).unwrap();
            assert_close(&format!("{case}: lml"), gp.log_marginal_likelihood(), r.lml);
            assert_gp_predictions(&case, &gp, &test_x, r);
        }
    }
}

#[test]
fn predictions_at_scikit_learns_optimum_match() {
    for ds in fixture().datasets {
        let r = &ds.fitted;
        let gp = Gp::with_params(&sets(&ds.x), &ds.y, ds.d, r.sigma0, r.noise_level).unwrap();
        assert_close(&format!("{}: lml", ds.name), gp.log_marginal_likelihood(), r.lml);
        assert_gp_predictions(&ds.name, &gp, &sets(&ds.test_x), r);
    }
}

/// L-BFGS-B stops once an iteration improves −LML by less than ftol·max(|f|, 1) (scipy's default
/// ftol ≈ 2.2e-9) or the projected gradient is below gtol = 1e-5, so its θ is only as accurate as
/// the LML surface is curved: where the surface is flat along a hyperparameter it may stop far
/// from the optimum in θ at a likelihood that is optimal to ~1e-6. So we require at least its
/// likelihood, that its θ be near-optimal for our likelihood too (the same optimum, not another
/// local one), and each hyperparameter to agree to 0.1% unless the likelihood is flat along it
/// between the two values (see docs/gp.md).
#[test]
fn fitted_optimum_is_at_least_as_good_as_scikit_learns() {
    for ds in fixture().datasets {
        let (r, x, name) = (&ds.fitted, sets(&ds.x), &ds.name);
        let lml_at = |sigma0: f64, noise: f64| {
            Gp::with_params(&x, &ds.y, ds.d, sigma0, noise).unwrap().log_marginal_likelihood()
        };
        let gp = Gp::fit(&x, &ds.y, ds.d).unwrap();
        let (ours, theirs) = ([gp.sigma0(), gp.noise_level()], [r.sigma0, r.noise_level]);
        let best = gp.log_marginal_likelihood();
        println!(
            "{name}: ours θ={ours:?} lml={best}; scikit-learn θ={theirs:?} lml={} (ours there {})",
            r.lml,
            lml_at(theirs[0], theirs[1])
        );
        assert_optimum(name, best, ours, theirs, r.lml, lml_at);
    }
}

// The kernel ablation's RBF + White GP against scikit-learn's `GaussianProcessRegressor(RBF() +
// WhiteKernel())` on the same datasets (`tests/gp/rbf_fixture.json`, made by
// `tests/gp/make_fixture.py rbf`).

#[derive(Deserialize)]
struct RbfReference {
    length_scale: f64,
    noise_level: f64,
    lml: f64,
    mean: Vec<f64>,
    var: Vec<f64>,
}

fn rbf_fixture() -> Fixture<RbfReference> {
    serde_json::from_str(include_str!("gp/rbf_fixture.json")).expect("tests/gp/rbf_fixture.json parses")
}

fn assert_rbf_predictions(case: &str, gp: &RbfGp, test_x: &[ConceptSet], r: &RbfReference) {
    assert_predictions(case, |s| gp.predict(s), gp.noise_level(), test_x, (&r.mean, &r.var));
}

#[test]
fn rbf_at_fixed_and_fitted_hyperparameters_matches_scikit_learn() {
    for ds in rbf_fixture().datasets {
        let (x, test_x) = (sets(&ds.x), sets(&ds.test_x));
        for r in ds.fixed.iter().chain([&ds.fitted]) {
            let case = format!("rbf {} at length_scale={} noise={}", ds.name, r.length_scale, r.noise_level);
            let gp = RbfGp::with_params(&x, &ds.y, ds.d, r.length_scale, r.noise_level).unwrap();
            assert_close(&format!("{case}: lml"), gp.log_marginal_likelihood(), r.lml);
            assert_rbf_predictions(&case, &gp, &test_x, r);
        }
    }
}

/// As for the dot-product kernel: at least scikit-learn's likelihood, its θ near-optimal under
/// ours, each hyperparameter equal to 0.1 % unless the likelihood is flat along it.
#[test]
fn rbf_fitted_optimum_is_at_least_as_good_as_scikit_learns() {
    for ds in rbf_fixture().datasets {
        let (r, x, name) = (&ds.fitted, sets(&ds.x), &ds.name);
        let lml_at =
            |l: f64, noise: f64| RbfGp::with_params(&x, &ds.y, ds.d, l, noise).unwrap().log_marginal_likelihood();
        let gp = RbfGp::fit(&x, &ds.y, ds.d).unwrap();
        let (ours, theirs) = ([gp.length_scale(), gp.noise_level()], [r.length_scale, r.noise_level]);
        let best = gp.log_marginal_likelihood();
        println!("rbf {name}: ours θ={ours:?} lml={best}; scikit-learn θ={theirs:?} lml={}", r.lml);
        assert_optimum(name, best, ours, theirs, r.lml, lml_at);
    }
}
