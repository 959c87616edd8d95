"""``optimise_design``: where the time goes, and the screen against the exact metrics it spares.

Times, on the README's example (the force-sensor preset, ``min_force`` 0.1 uN, seed 0):

* **screen**: the proxy metrics of N designs at once (``TiltBatch`` over 73 tilt angles, closed-form
  compliance, vectorised range) per design;
* **anchor**: the exact force metric of one design (``bend_sweep`` over 151 forces and the field
  model: what ``design_metrics`` does for the force), per design;
* the whole search in process (``workers=1``) for N designs screened and 64 refined;
* **robust**: the calibration-free error of one design (64 devices × 33 forces through the
  exact batched bend and field model, :mod:`magcilia.design.robust`) against the exact force
  metric above, and the whole robust search (``--objective robust``, ``min_force`` twice the
  preset's; 64 refined, 3 polish rounds; ``--quick``: 16 devices, 16 refined, 1 round).

Run: python benchmarks/bench_optimise.py [--designs N] [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import time

import numpy as np

import magcilia as mc
from magcilia.design import FORCE, sensor_choices
from magcilia.design.exact import ExactTask, evaluate
from magcilia.design.optimise import _bounds, _sample
from magcilia.design.robust import RobustSpec, calibration_free_error
from magcilia.design.screen import screen as _screen


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--designs", type=int, default=4096)
    parser.add_argument("--quick", action="store_true", help="256 designs (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.designs = min(args.designs, 256)
    setup = mc.Setup.paper(tip_radius=5e-5, layout="converged")  # the force-sensor preset
    choices = sensor_choices(("HMC1021Z",), setup)
    searched, fixed = _bounds(setup, None)
    values, index = _sample(searched, fixed, args.designs, 1, np.random.default_rng(0))
    n = values["height"].size
    _screen(setup, {k: a[:16] for k, a in values.items()}, index[:16], choices, FORCE, 0.0,
            (0.5, 500.0), mc.WATER)  # compile and warm up
    t = time.perf_counter()
    _screen(setup, values, index, choices, FORCE, 0.0, (0.5, 500.0), mc.WATER)
    screen = (time.perf_counter() - t) / n
    task = ExactTask(setup, choices[0], FORCE, 0.0, (0.5, 500.0), mc.WATER, 151,
                 choices[0].rated_total)  # the layout resolved, as every candidate's
    evaluate(task)
    runs = []
    for _ in range(5):
        t = time.perf_counter()
        evaluate(task)
        runs.append(time.perf_counter() - t)
    exact = min(runs)
    print(f"screen: {screen * 1e6:.1f} us per design ({n} designs)")
    print(f"anchor, exact force metric: {exact * 1e3:.1f} ms per design")
    print(f"ratio: the screen is {exact / screen:.0f}x cheaper per design")
    t = time.perf_counter()
    result = mc.optimise_design(setup, min_force=1e-7, n=args.designs, refine=64, rng=0,
                                workers=1)
    total = time.perf_counter() - t
    print(f"whole search, in process: {total:.2f} s ({result.screened} screened, "
          f"{len(result.designs)} refined; chosen range "
          f"{'' if result.best.reached else '>= '}{result.best.range * 1e3:.4g} mN, "
          f"minimum {result.best.minimum * 1e3:.4g} mN)")
    spec = RobustSpec(samples=64)
    span = 1.2e-4  # N: the preset's range is >= 0.13 mN
    calibration_free_error(setup, span, spec)
    runs = []
    for _ in range(3):
        t = time.perf_counter()
        calibration_free_error(setup, span, spec)
        runs.append(time.perf_counter() - t)
    print(f"robust: calibration-free error, 64 devices: {min(runs) * 1e3:.1f} ms per design "
          f"({min(runs) / exact:.2f}x the exact force metric)")
    quick = args.quick
    t = time.perf_counter()
    robust = mc.optimise_design(setup, "robust", min_force=2.4e-7, n=args.designs,
                                refine=16 if quick else 64, polish=1 if quick else 3,
                                samples=16 if quick else 64, rng=0, workers=1)
    print(f"robust: whole search, in process: {time.perf_counter() - t:.2f} s "
          f"({robust.screened} screened, {len(robust.designs)} refined; calibration-free error "
          f"{robust.best.error * 100:.3g} % against the preset's "
          f"{robust.reference.error * 100:.3g} % RMS of the range)")


if __name__ == "__main__":
    main()
