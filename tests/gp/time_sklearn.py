"""Times scikit-learn on the workload of `benches/gp.rs`, for the comparison in docs/gp.md.

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 /tmp/sk-venv/bin/python tests/gp/time_sklearn.py
"""

import time
import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import DotProduct, WhiteKernel

D, N_OBS = 30, 200


def multi_hot(rng, n):
    x = np.zeros((n, D))
    for row in x:
        row[rng.choice(D, rng.integers(1, 6), replace=False)] = 1.0
    return x


def best_of(f, repeats=5):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    warnings.simplefilter("ignore", ConvergenceWarning)
    rng = np.random.default_rng(42)
    x = multi_hot(rng, N_OBS)
    y = np.clip(0.1 + x @ rng.uniform(-0.1, 0.2, D) + rng.uniform(-0.05, 0.05, N_OBS), 0, 1)
    y = np.round(y * 5) / 5

    def fit():
        return GaussianProcessRegressor(kernel=DotProduct() + WhiteKernel()).fit(x, y)

    print(f"fit n={N_OBS} d={D}: {best_of(fit) * 1e3:.1f} ms")
    gp = fit()
    for n in (1000, 2000):
        cands = multi_hot(rng, n)
        t = best_of(lambda: gp.sample_y(cands, random_state=rng.integers(1 << 31)).argmax(), repeats=3)
        print(f"sample_y + argmax over {n} sets: {t * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
