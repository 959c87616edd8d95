"""Benchmark: posterior sampling of a correlated six-parameter Gaussian until every parameter has
1000 effective samples (issue 14's target: ≤ 60 s on one core; about 0.5 s unloaded).

The same problem as tests/calibration/test_posterior.py's six-parameter test, which checks the
result (converged, the spread) but not the time: speed depends on the machine, so it lives here.
Times ``sample_posterior`` (emcee's ensemble sampler behind it) on one thread, the best and the
median of ``--repeat`` runs, and prints the effective sample size and the sampler's steps.

Run: ``python benchmarks/bench_posterior.py [--repeat 5] [--quick]``
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import time

import numpy as np

from magcilia.calibration import sample_posterior

TARGET = 60.0  # s, issue 14


def problem() -> tuple[np.ndarray, np.ndarray]:
    """The mean (6,) and covariance (6, 6) of the test's Gaussian."""
    gen = np.random.default_rng(1)
    a = gen.standard_normal((6, 6))
    return gen.standard_normal(6), a @ a.T + 0.5 * np.eye(6)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="one repeat (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.repeat = 1
    mu, cov = problem()
    prec = np.linalg.inv(cov)

    def log_prob(P: np.ndarray) -> np.ndarray:
        d = P - mu
        return -0.5 * np.einsum("ni,ij,nj->n", d, prec, d)

    times = []
    for seed in range(args.repeat):
        t0 = time.perf_counter()
        post = sample_posterior(log_prob, mu, names=[f"p{i}" for i in range(6)],
                                bounds=np.c_[mu - 100, mu + 100], n_effective=1000, rng=seed)
        times.append(time.perf_counter() - t0)
        print(f"seed {seed}: {times[-1]:.3f} s, converged {post.converged}, min ESS "
              f"{post.ess.min():.0f}, {post.steps} steps")
    best, median = min(times), float(np.median(times))
    print(f"six parameters, 1000 effective samples: best {best:.3f} s, median {median:.3f} s "
          f"(target <= {TARGET:g} s: {'met' if median <= TARGET else 'MISSED'})")


if __name__ == "__main__":
    main()
