"""The least-squares core (issue 26): ``magcilia.fitting.fit_batch`` against SciPy's
``least_squares``, the ordinary way to fit many small problems (one call per problem).

1. Many small problems (calibration's local fits, the force-vector read-out): noisy decays
   a·exp(−b t) + c, 25 residuals, 3 bounded parameters; ``fit_batch`` with forward differences
   and with the analytic Jacobian, all problems at once, against ``least_squares`` (trf, the
   same analytic Jacobian, default tolerances) one problem at a time.
2. One large problem (the array inverse's shape): 128 parameters, 192 residuals of tanh(A x)
   plus 128 Tikhonov rows, analytic Jacobian, no bounds; ``fit_batch`` against ``least_squares``
   (trf).

Interleaved in one process on one thread; min and median of the repeats. Both must reach the
same cost (within 1e-6 relative, checked).

Run: ``python benchmarks/bench_fitting.py [--quick]``
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse

import numpy as np
from _timing import interleaved
from scipy.optimize import least_squares

from magcilia.fitting import fit_batch

T = np.linspace(0.0, 3.0, 25)
LOWER, UPPER = np.array([0.0, 0.0, -5.0]), np.array([10.0, 10.0, 5.0])


def decay(x: np.ndarray) -> np.ndarray:
    return x[:, 0:1] * np.exp(-x[:, 1:2] * T) + x[:, 2:3]


def decay_jacobian(x: np.ndarray) -> np.ndarray:
    e = np.exp(-x[:, 1:2] * T)
    return np.stack([e, -x[:, 0:1] * T * e, np.ones_like(e)], axis=-1)


def small(count: int, repeat: int) -> None:
    rng = np.random.default_rng(0)
    truths = rng.uniform([0.5, 0.2, -1.0], [2.0, 3.0, 1.0], (count, 3))
    data = decay(truths) + 0.01 * rng.standard_normal((count, T.size))
    x0 = np.tile([1.0, 1.0, 0.0], (count, 1))
    out: dict[str, np.ndarray] = {}

    def ours_fd() -> None:
        out["fd"] = fit_batch(lambda x, w: decay(x) - data[w], x0, LOWER, UPPER).cost

    def ours_jac() -> None:
        out["jac"] = fit_batch(lambda x, w: decay(x) - data[w], x0, LOWER, UPPER,
                               jacobian=lambda x, _: decay_jacobian(x)).cost

    def scipy() -> None:
        out["scipy"] = np.array([2 * least_squares(
            lambda p, i=i: decay(p[None])[0] - data[i], x0[i],
            jac=lambda p: decay_jacobian(p[None])[0], bounds=(LOWER, UPPER)).cost
            for i in range(count)])

    times = interleaved({"fit_batch, differences": ours_fd, "fit_batch, analytic": ours_jac,
                         "least_squares one by one": scipy}, repeat)
    for key in ("fd", "jac"):
        assert np.allclose(out[key], out["scipy"], rtol=1e-6), key
    print(f"1. {count} problems of 3 parameters and 25 residuals (same costs within 1e-6)")
    _table(times, "least_squares one by one")


def large(repeat: int) -> None:
    rng = np.random.default_rng(1)
    rows, dims, alpha = 192, 128, 1e-3
    a = rng.standard_normal((rows, dims)) / np.sqrt(dims)
    y = np.tanh(a @ rng.uniform(-0.5, 0.5, dims)) + 0.01 * rng.standard_normal(rows)
    reg = np.sqrt(alpha) * np.eye(dims)

    def res(x: np.ndarray) -> np.ndarray:
        return np.concatenate([np.tanh(x @ a.T) - y, np.sqrt(alpha) * x], axis=-1)

    def jac(x: np.ndarray) -> np.ndarray:
        d = 1.0 - np.tanh(x @ a.T) ** 2
        return np.concatenate([d[..., None] * a, np.broadcast_to(reg, (*x.shape[:-1], dims,
                                                                       dims))], axis=-2)

    inf = np.full(dims, np.inf)
    out: dict[str, float] = {}

    def ours() -> None:
        out["ours"] = float(fit_batch(lambda x, _: res(x), np.zeros(dims), -inf, inf,
                                      jacobian=lambda x, _: jac(x), damping=1e-12).cost[0])

    def scipy() -> None:
        out["scipy"] = 2 * float(least_squares(res, np.zeros(dims), jac=jac).cost)

    times = interleaved({"fit_batch, analytic": ours, "least_squares": scipy}, repeat)
    assert abs(out["ours"] - out["scipy"]) <= 1e-6 * out["scipy"], out
    print(f"2. one problem of {dims} parameters and {rows + dims} residuals (same cost within "
          "1e-6)")
    _table(times, "least_squares")


def _table(times: dict[str, list[float]], anchor: str) -> None:
    ref = float(np.median(times[anchor]))
    for name, ts in times.items():
        med = float(np.median(ts))
        print(f"  {name:28s} min {1e3 * min(ts):8.2f} ms, median {1e3 * med:8.2f} ms"
              + ("" if name == anchor else f"  ({ref / med:.1f}x faster than the anchor)"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    repeat = 3 if args.quick else 7
    print("least-squares core benchmark, one thread")
    small(100 if args.quick else 1000, repeat)
    large(repeat)


if __name__ == "__main__":
    main()
