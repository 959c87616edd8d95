"""Biaxial read-out (issue 15): force vectors from a 3-axis sensor, 1e5 readings at once, against
SciPy's ``least_squares`` one reading at a time on the same model.

The paper's cilium with a tip radius (``Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)``), a
3-axis sensor at the element (noise 0.15 µT per axis), span 0.1 mN; readings at random forces
(0.1–0.95 of the span, any direction) plus noise. Times, interleaved in this process (min and
median of the runs):

* **build**: ``BiaxialReadout(...)`` (bend sweep, the grid's fields, the interpolant, the
  mid-point check), at the default grid 65 × 128 and at 33 × 64;
* **estimate** / **read**: ``.estimate`` (vectors only) and ``.read`` (covariance, σ, flags) of
  1e5 readings: the coarse search and the batched least squares (magcilia.fitting.fit_batch;
  since issue 27 the interpolant (whitened residuals and Jacobian in one pass) and the coarse
  search compiled, and fit_batch's iterations as its one compiled step, fitting/compiled.py),
  and the
  same with the compiled kernels off (their NumPy references, as before issue 27; issue 27's
  target: <= 2 us a reading);
* **anchor**: ``scipy.optimize.least_squares`` (its default trust-region reflective method,
  2-point Jacobian) per reading on the same interpolant (``BiaxialReadout.model``), started at
  the same coarse-grid node, on a subset, scaled to 1e5 readings. SciPy's least_squares has
  no vectorised form for many independent problems, so this is its ordinary use.

Run: python benchmarks/bench_biaxial.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from _timing import interleaved, numpy_reference
from scipy.optimize import least_squares

import magcilia as mc
from magcilia.device.magnetometer import Magnetometer

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_field import cpu_name

SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)
SENSOR = Magnetometer(field_range=1e-3, resolution=1e-9, noise=1.5e-7, rate=100.0)
SPAN = 1e-4  # N


def readings(r: mc.BiaxialReadout, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.1, 0.95, n) * SPAN
    phi = rng.uniform(-np.pi, np.pi, n)
    truth = np.stack([f * np.cos(phi), f * np.sin(phi)], -1)
    clean = r.model(truth[:, 0], truth[:, 1])
    return truth, clean + rng.standard_normal(clean.shape) * SENSOR.sigma


def anchor(r: mc.BiaxialReadout, fields: np.ndarray) -> np.ndarray:
    """least_squares per reading on the same model, from the coarse search's best node."""
    sigma = r.sigma
    coarse = r._coarse  # the same start as ours
    best, _ = coarse.search(fields, np.broadcast_to(1.0 / sigma**2, fields.shape))
    out = np.empty((fields.shape[0], 2))
    reach = r.forces[-1]

    def residual(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        shrink = min(1.0, reach / max(float(np.hypot(x[0], x[1])), 1e-300))  # the model's disc
        return (r.model(x[0] * shrink, x[1] * shrink) - y) / sigma

    for i, y in enumerate(fields):
        f0, p0 = coarse.force[best[i]], coarse.azimuth[best[i]]
        sol = least_squares(residual, [f0 * np.cos(p0), f0 * np.sin(p0)], args=(y,),
                            x_scale=SPAN * 0.01)
        out[i] = sol.x
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer readings and runs")
    args = parser.parse_args()
    n = 20_000 if args.quick else 100_000
    n_anchor = 100 if args.quick else 500
    repeat = 2 if args.quick else 5

    builds = interleaved({
        "build 65x128": lambda: mc.BiaxialReadout(SETUP, SENSOR, span=SPAN),
        "build 33x64": lambda: mc.BiaxialReadout(SETUP, SENSOR, span=SPAN, table_size=(33, 64)),
    }, repeat=max(2, repeat // 2))
    r = mc.BiaxialReadout(SETUP, SENSOR, span=SPAN)
    truth, fields = readings(r, n)
    sub = fields[:n_anchor]
    r.read(fields[:10])  # compile (or load) the kernels before timing
    times = interleaved({
        "estimate": lambda: r.estimate(fields),
        "read": lambda: r.read(fields),
        "read, NumPy": numpy_reference(lambda: r.read(fields)),
        "anchor": lambda: anchor(r, sub),
    }, repeat=repeat)

    res = r.read(fields)
    ours_sub = res.vector[:n_anchor]
    theirs = anchor(r, sub)
    diff = float(np.max(np.hypot(*(ours_sub - theirs).T)))
    err = np.hypot(*(res.vector - truth).T)
    print(f"magcilia biaxial benchmark, one thread; {cpu_name()}, Python "
          f"{platform.python_version()}; load average {os.getloadavg()[0]:.2f} at the start")
    print(f"biaxial read-out, {n} readings, 3-axis sensor (noise {SENSOR.noise[0] * 1e6:.3g} µT), "
          f"span {SPAN * 1e3:g} mN; {r.report()}")
    counts = {k: c for k, c in res.counts().items() if c and k not in ("readings", "estimated")}
    print(f"flags: {counts}; median |error| {np.median(err) * 1e9:.3g} nN, "
          f"median σ|F| {np.median(res.sigma_magnitude) * 1e9:.3g} nN")
    for name, t in builds.items():
        print(f"  {name:<14} min {min(t):8.3f} s   median {statistics.median(t):8.3f} s")
    for name in ("estimate", "read", "read, NumPy"):
        t = times[name]
        print(f"  {name:<14} min {min(t):8.3f} s   median {statistics.median(t):8.3f} s   "
              f"{min(t) / n * 1e6:7.2f} µs/reading")
    per = min(times["anchor"]) / n_anchor
    print(f"  {'anchor':<14} min {min(times['anchor']):8.3f} s for {n_anchor} readings: "
          f"{per * 1e6:7.1f} µs/reading, {per * n:.1f} s for {n} (least_squares per reading)")
    print(f"ratio anchor/read: {per * n / min(times['read']):.0f}x; anchor/estimate: "
          f"{per * n / min(times['estimate']):.0f}x; largest difference from the anchor "
          f"{diff * 1e9:.3g} nN")
    cpu = []
    for _ in range(3):
        c0 = time.process_time()
        r.read(fields)
        cpu.append(time.process_time() - c0)
    print(f"  read, this process's CPU time (min of 3; on a shared machine closer to a quiet "
          f"run's wall time): {min(cpu) / n * 1e6:.2f} µs/reading")
    t0 = time.perf_counter()
    r.read(fields[:1])
    print(f"one reading through .read: {(time.perf_counter() - t0) * 1e3:.2f} ms; compiled "
          f"read {min(times['read, NumPy']) / min(times['read']):.2f}x its NumPy path; load "
          f"average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
