"""Reference values for `tests/gp.rs` from scikit-learn's GaussianProcessRegressor.

The Rust GPs must reproduce `GaussianProcessRegressor(kernel=DotProduct() + WhiteKernel())`
(`src/search/gp.rs`) and, for the kernel ablation, `GaussianProcessRegressor(kernel=RBF() +
WhiteKernel())` (`src/search/gp_rbf.rs`), with all other defaults (normalize_y=False,
alpha=1e-10, one L-BFGS-B run from sigma_0=1 or length_scale=1 and noise_level=1, bounds
1e-5..1e5). Regenerate with:

    python3 -m venv /tmp/sk-venv && /tmp/sk-venv/bin/pip install scikit-learn
    /tmp/sk-venv/bin/python tests/gp/make_fixture.py > tests/gp/fixture.json
    /tmp/sk-venv/bin/python tests/gp/make_fixture.py rbf > tests/gp/rbf_fixture.json

Concept sets are written as lists of concept indices; `var` is scikit-learn's predicted
`std ** 2`, which includes the WhiteKernel's noise_level (the Rust `predict` returns the
variance of the latent function without it). The first hyperparameter is written as `sigma0`
(DotProduct) or `length_scale` (RBF).
"""

import json
import sys
import warnings

import numpy as np
import scipy
import sklearn
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, DotProduct, WhiteKernel

D = 30
# Per kernel: how to build it at a first hyperparameter, that hyperparameter's names in
# scikit-learn and in the fixture, and the fixed values to check.
KERNELS = {
    "dot": (lambda p: DotProduct(sigma_0=p), "k1__sigma_0", "sigma0", [(1.0, 1.0), (0.3, 0.05), (2.0, 1e-3)]),
    "rbf": (lambda p: RBF(length_scale=p), "k1__length_scale", "length_scale", [(1.0, 1.0), (0.5, 0.05), (3.0, 1e-3)]),
}
KERNEL = KERNELS[sys.argv[1] if len(sys.argv) > 1 else "dot"]


def random_sets(rng, n, d, sizes=(1, 5)):
    return [sorted(int(c) for c in rng.choice(d, rng.integers(sizes[0], sizes[1] + 1), replace=False)) for _ in range(n)]


def multi_hot(sets, d):
    x = np.zeros((len(sets), d))
    for i, s in enumerate(sets):
        x[i, s] = 1.0
    return x


def failure_rates(rng, sets, d, m=5):
    """Observed failure rates over m VLM answers: additive concept effects, clipped, binomial."""
    w = rng.normal(0.0, 0.15, d)
    p = np.clip([0.1 + w[s].sum() for s in sets], 0.0, 1.0)
    return rng.binomial(m, p) / m


def summary(gp, x_test):
    mean, std = gp.predict(x_test, return_std=True)
    params = gp.kernel_.get_params()
    return {
        KERNEL[2]: params[KERNEL[1]],
        "noise_level": params["k2__noise_level"],
        "lml": gp.log_marginal_likelihood_value_,
        "mean": mean.tolist(),
        "var": (std**2).tolist(),
    }


def dataset(name, sets, y, test_sets):
    x, x_test = multi_hot(sets, D), multi_hot(test_sets, D)
    with warnings.catch_warnings():
        # A hyperparameter ending on its bound is one of the cases under test.
        warnings.simplefilter("ignore", ConvergenceWarning)
        fitted = GaussianProcessRegressor(kernel=KERNEL[0](1.0) + WhiteKernel()).fit(x, y)
    fixed = [
        summary(
            GaussianProcessRegressor(kernel=KERNEL[0](p) + WhiteKernel(noise_level=nl), optimizer=None).fit(x, y),
            x_test,
        )
        for p, nl in KERNEL[3]
    ]
    return {
        "name": name,
        "d": D,
        "x": sets,
        "y": [float(v) for v in y],
        "test_x": test_sets,
        "fitted": summary(fitted, x_test),
        "fixed": fixed,
    }


def main():
    rng = np.random.default_rng(20261122)
    test_sets = [[], [0], [29], [3, 17], [1, 2, 3, 4, 5]] + random_sets(rng, 10, D)
    out = []
    for n in (20, 200):
        sets = random_sets(rng, n, D)
        out.append(dataset(f"fr_n{n}", sets, failure_rates(rng, sets, D), test_sets))
    # Exactly additive rates: no residual noise, so noise_level ends on its lower bound.
    sets = random_sets(rng, 80, D)
    w = rng.uniform(-0.05, 0.2, D)
    out.append(dataset("additive_noise_at_bound", sets, np.array([0.1 + w[s].sum() for s in sets]), test_sets))
    # A model that never fails: both hyperparameters are pushed to their lower bounds.
    sets = random_sets(rng, 50, D)
    out.append(dataset("never_fails", sets, np.zeros(len(sets)), test_sets))
    json.dump(
        {
            "generator": " ".join(["tests/gp/make_fixture.py"] + sys.argv[1:]),
            "versions": {"sklearn": sklearn.__version__, "scipy": scipy.__version__, "numpy": np.__version__},
            "datasets": out,
        },
        sys.stdout,
        indent=1,
    )
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
