"""Sensitivity and firmware benchmarks (issues 4, 17 and 27), single thread, anchors side by side.

Measures, in one run:
  * a Sobol analysis over the calibration bounds (7 inputs, N = 2^14 -> 147 456 model evaluations,
    33 angles each; target: <= 5 s per 1e5 evaluations on one core, issue 17): magcilia's
    ``sobol_indices`` against its anchor (issue 27), what a user would write with SALib itself
    and a cached vectorised model: ``SALib.sample.sobol.sample`` once, the model evaluated once
    on the whole sample matrix (magcilia's ``tilt_output_batch``, integers rounded as magcilia
    rounds them), ``SALib.analyze.sobol.analyze`` (100 bootstraps) - same N, interleaved, min
    and median of the runs, the indices compared; and the evaluations one sample at a time
    through ``setup.replace(...).output`` (a subset of 2000, extrapolated), the model without
    its batch path;
  * the C approximation's evaluation cost per sample (piecewise-linear, 2 corners; float and
    fixed-point, forward and inverse), compiled with ``cc -O2``, beside the Python evaluation.

Run: python benchmarks/bench_sensitivity.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import platform
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from _timing import interleaved
from bench_field import cpu_name
from SALib.analyze import sobol as salib_analyze
from SALib.sample import sobol as salib_sample

import magcilia as mc
from magcilia.analysis import DEFAULT_ANGLES, rms_change
from magcilia.calibration import DEFAULT_BOUNDS, INTEGER
from magcilia.model.batch import tilt_output_batch

HARNESS = (r"""#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdint.h>
#include <time.h>
#include "approx.h"
#include "approxq.h"
#define N %(n)d
static double now(void) { struct timespec t; clock_gettime(CLOCK_MONOTONIC, &t);
                          return t.tv_sec + 1e-9 * t.tv_nsec; }
int main(void)
{
    static float tf[N], vf[N]; static int32_t tq[N], vq[N];
    volatile float sf = 0.0f; volatile int32_t sq = 0; double t0, t1;
    for (int i = 0; i < N; ++i) {
        float t = %(lo).9ef + (%(hi).9ef - %(lo).9ef)"""
           r""" * (float)((int)(((long long)i * 7919) %% N)) / (float)N;
        tf[i] = t; vf[i] = a_output(t);
        tq[i] = (int32_t)(t * (float)(1L << AQ_ANGLE_FRAC_BITS));
        vq[i] = aq_output_q(tq[i]);
    }
    t0 = now(); for (int i = 0; i < N; ++i) sf += a_output(tf[i]); t1 = now();
    printf("float_output %%.3f\n", 1e9 * (t1 - t0) / N);
    t0 = now(); for (int i = 0; i < N; ++i) sf += a_angle(vf[i]); t1 = now();
    printf("float_angle %%.3f\n", 1e9 * (t1 - t0) / N);
    t0 = now(); for (int i = 0; i < N; ++i) sq += aq_output_q(tq[i]); t1 = now();
    printf("fixed_output %%.3f\n", 1e9 * (t1 - t0) / N);
    t0 = now(); for (int i = 0; i < N; ++i) sq += aq_angle_q(vq[i]); t1 = now();
    printf("fixed_angle %%.3f\n", 1e9 * (t1 - t0) / N);
    return (int)(sf != sf) + (int)(sq == 12345);
}
""")


def sobol_bench(n_base: int, subset: int, repeat: int) -> None:
    setup = mc.Setup.paper()
    angles = DEFAULT_ANGLES
    names = list(DEFAULT_BOUNDS)
    problem = {"num_vars": len(names), "names": names,
               "bounds": [[lo - 0.5, hi + 0.5] if n in INTEGER else [lo, hi]
                          for n, (lo, hi) in DEFAULT_BOUNDS.items()]}
    ref = setup.output(angles)

    def rounded(x: np.ndarray) -> np.ndarray:
        for j, n in enumerate(names):
            if n in INTEGER:
                x[:, j] = np.clip(np.rint(x[:, j]), *DEFAULT_BOUNDS[n])
        return x

    def model(x: np.ndarray) -> np.ndarray:  # the cached, vectorised model: one call
        return np.asarray(rms_change(tilt_output_batch(
            setup, {n: x[:, j] for j, n in enumerate(names)}, angles), ref))

    def salib_cached() -> dict[str, np.ndarray]:
        x = rounded(salib_sample.sample(problem, n_base, calc_second_order=False, seed=1))
        y = model(x)
        return dict(salib_analyze.analyze(problem, y, calc_second_order=False, num_resamples=100,
                                          conf_level=0.95, print_to_console=False, seed=2))

    ours = mc.sobol_indices(setup, n_base=n_base, rng=0)
    theirs = salib_cached()
    times = interleaved({"magcilia sobol_indices": lambda: mc.sobol_indices(
        setup, n_base=n_base, rng=0), "SALib + cached model": salib_cached}, repeat)
    X = rounded(salib_sample.sample(problem, n_base, calc_second_order=False, seed=1))
    t0 = time.perf_counter()
    y_batch = model(X)
    t_batch = time.perf_counter() - t0
    sub = X[:subset]
    t0 = time.perf_counter()
    y_single = np.array([
        rms_change(
            setup.replace(**{n: float(row[j]) for j, n in enumerate(names)}).output(angles), ref)
        for row in sub])
    t_sub = time.perf_counter() - t0
    t_single = t_sub * X.shape[0] / subset
    agree = float(np.abs(y_single - y_batch[:subset]).max() / np.abs(y_batch).max())
    # the two analyses draw different scrambled sequences: their indices agree within the
    # intervals
    gap = max(float(np.max(np.abs(ours.S1 - theirs["S1"]) / np.hypot(ours.S1_conf,
                                                                      theirs["S1_conf"]))),
              float(np.max(np.abs(ours.ST - theirs["ST"]) / np.hypot(ours.ST_conf,
                                                                      theirs["ST_conf"]))))
    n_eval = ours.n_evaluations
    print(f"Sobol over the calibration bounds: N = {n_base}, {n_eval} evaluations x "
          f"{angles.size} angles, 100 bootstraps; min [median] of {repeat} interleaved runs")
    t_ours = times["magcilia sobol_indices"]
    t_salib = times["SALib + cached model"]
    for name, t in times.items():
        print(f"  {name:<32} {min(t):7.3f} s [{statistics.median(t):7.3f}] = "
              f"{1e5 * min(t) / n_eval:.3f} s per 1e5 evaluations (target <= 5 s per 1e5)")
    print(f"  ratio SALib + cached model / magcilia: {min(t_salib) / min(t_ours):.2f}x; "
          f"indices differ by at most {gap:.2f} of their combined 95 % intervals")
    print(f"  model alone, batch, whole matrix:  {t_batch:8.3f} s  "
          f"({1e6 * t_batch / X.shape[0]:.2f} us/sample)")
    print(f"  one sample at a time (setup.replace().output): {t_single:8.2f} s  "
          f"({1e6 * t_sub / subset:.1f} us/sample; {subset} samples timed, extrapolated; "
          f"{t_single / t_batch:.0f}x the batch model); max relative difference {agree:.1e}")
    print("  " + ours.report().replace("\n", "\n  "))


def c_bench(n: int) -> None:
    cc = shutil.which("cc") or shutil.which("gcc")
    setup = mc.Setup.paper()
    approx = mc.piecewise_linear(setup, corners=2)
    t = np.linspace(*approx.angle_range, 100_000)
    t0 = time.perf_counter()
    for _ in range(10):
        approx(t)
    t_py = (time.perf_counter() - t0) / 10 / t.size
    t0 = time.perf_counter()
    for _ in range(10):
        setup.output(t[:1000])
    t_model = (time.perf_counter() - t0) / 10 / 1000
    t0 = time.perf_counter()
    for i in range(200):
        setup.output(t[i:i + 1])
    t_model1 = (time.perf_counter() - t0) / 200
    print("Read-out evaluation cost per sample (piecewise-linear, 2 corners)")
    print(f"  Python PiecewiseLinear, vectorised 1e5:  {1e9 * t_py:9.1f} ns")
    print(f"  full model setup.output, vectorised 1e3: {1e9 * t_model:9.1f} ns")
    print(f"  full model setup.output, one angle/call: {1e9 * t_model1:9.1f} ns")
    if cc is None:
        print("  C: no compiler found (cc/gcc); skipped")
        return
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        (d / "approx.h").write_text(mc.to_c_header(approx, name="a"))
        (d / "approxq.h").write_text(mc.to_c_header(approx, name="aq", fixed_point=True))
        lo, hi = approx.angle_range
        (d / "h.c").write_text(HARNESS % {"n": n, "lo": lo, "hi": hi})
        subprocess.run([cc, "-std=c99", "-O2", "-o", str(d / "h"), str(d / "h.c")], check=True)
        best: dict[str, float] = {}
        for _ in range(3):
            out = subprocess.run([str(d / "h")], capture_output=True, text=True, check=False).stdout
            for line in out.splitlines():
                key, val = line.split()
                best[key] = min(best.get(key, np.inf), float(val))
    for key, val in best.items():
        print(f"  C (cc -O2) {key:<13}                 {val:9.2f} ns")
    print(f"  ratio full model (one angle/call) / C float output: "
          f"{1e9 * t_model1 / best['float_output']:.0f}x")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="N = 2^11 and fewer C samples")
    args = ap.parse_args()
    n_base = 2**11 if args.quick else 2**14
    print(f"magcilia sensitivity benchmark, one thread; {cpu_name()}, Python "
          f"{platform.python_version()}; load average {os.getloadavg()[0]:.2f} at the start")
    sobol_bench(n_base, subset=500 if args.quick else 2000, repeat=2 if args.quick else 5)
    print()
    c_bench(1_000_000 if args.quick else 10_000_000)


if __name__ == "__main__":
    main()
