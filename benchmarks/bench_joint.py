"""Benchmark: a 3-experiment physical calibration (issue 14's target: ≤ 2 s on one core).

Three experiments of the paper's cilium, generated with the exact Cylinder-stack field: 3-axis
field data tilted toward azimuths 0 and 90° and the single-axis output toward 45°, 17 angles each,
a manual height prior. Times, interleaved in one process on one thread (min and median of 5),
``calibrate(model="physical")`` (64 Latin-hypercube starts, batched Levenberg–Marquardt, polish)
and, as the anchor, SciPy's ``least_squares`` run one start at a time from the same 64 starts over
the same residuals; then the posterior of the geometry (``posterior=True``: emcee until every
parameter has 1000 effective samples; issue 14's target ≤ 60 s on one core).

Run: ``python benchmarks/bench_joint.py [--quick]``
"""

from __future__ import annotations

import argparse
import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import time

import numpy as np
from scipy.optimize import least_squares

import magcilia as mc
from magcilia.calibration import JointProblem
from magcilia.calibration.joint import JOINT_PARAMETERS, STARTS
from magcilia.calibration.multistart import latin_hypercube
from magcilia.io.recordings import Measurement
from magcilia.model.azimuth import field_from_tilt_frame, placement_in_tilt_frame
from magcilia.model.exact import exact_field

TRUTH = mc.Setup.paper(ring="rms")
ANGLES = np.radians(np.linspace(0.0, 80.0, 17))
NOISE = 0.2e-6  # T


def experiments(rng: np.random.Generator) -> list[Measurement]:
    out = []
    a = ANGLES.size
    for phi, kind in ((0.0, "field"), (np.pi / 2, "field"), (np.pi / 4, "output")):
        x, y = placement_in_tilt_frame(TRUTH.position[0], TRUTH.position[1], phi)
        turned = TRUTH.replace(position=(float(x), float(y), TRUTH.position[2]))
        b = field_from_tilt_frame(exact_field(turned, ANGLES, n_slices=2000), phi)
        common = {"angles": ANGLES, "counts": np.full(a, 100), "saturated": np.zeros(a, int),
                  "nonfinite": np.zeros(a, int), "azimuths": np.full(a, phi),
                  "source": f"{kind} at {np.degrees(phi):g} deg"}
        if kind == "field":
            out.append(Measurement(volts=np.full(a, np.nan), sem=np.full(a, np.nan),
                                   fields=b + rng.normal(0.0, NOISE, b.shape) + 30e-6,
                                   field_sem=np.full((a, 3), NOISE), **common))
        else:
            volts = 75.0 * b[:, 0] + 0.01 + rng.normal(0.0, 75.0 * NOISE, a)
            out.append(Measurement(volts=volts, sem=np.full(a, 75.0 * NOISE), **common))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 seeds instead of 5")
    args = parser.parse_args()
    data = experiments(np.random.default_rng(0))
    initial = TRUTH.replace(height=3.0e-3, base_radius=0.2e-3, x=1.0e-3, y=1.5e-3, z=0.5e-3)
    layout = mc.calibration.converged_layout(TRUTH)
    priors = {"height": (3.3e-3, 0.15e-3)}
    box = {n: mc.calibration.DEFAULT_BOUNDS[n] for n in JOINT_PARAMETERS}
    problem = JointProblem(data, initial, layout, box, JOINT_PARAMETERS, priors)
    lo, hi = problem.bounds[:, 0], problem.bounds[:, 1]

    def ours(seed: int) -> tuple[float, float]:
        t0 = time.perf_counter()
        fit = mc.calibrate(data, model="physical", initial=initial, priors=priors,
                           layout=layout, rng=seed)
        return time.perf_counter() - t0, fit.chi2

    def anchor(seed: int) -> tuple[float, float]:
        starts = latin_hypercube(STARTS, lo, hi, np.random.default_rng(seed))
        t0 = time.perf_counter()
        best = np.inf
        for x0 in starts:
            sol = least_squares(lambda z: problem.residuals(z)[0], x0, bounds=(lo, hi),
                                x_scale=hi - lo, method="trf")
            best = min(best, 2 * sol.cost)
        return time.perf_counter() - t0, best

    ours(0)  # numba's kernels loaded, the layout's tables built
    runs: dict[str, list[tuple[float, float]]] = {"ours": [], "anchor": []}
    for seed in range(2 if args.quick else 5):
        runs["ours"].append(ours(seed))
        runs["anchor"].append(anchor(seed))
    t = {k: np.array([r[0] for r in v]) for k, v in runs.items()}
    chi2 = {k: np.array([r[1] for r in v]) for k, v in runs.items()}
    print(f"layout n={layout.n_loops}, k={layout.dipoles_per_loop} (error {layout.error:.2g})")
    print(f"3 experiments (field 0 deg, field 90 deg, output 45 deg; 17 angles each), {STARTS} "
          "starts, min / median of 5 interleaved runs:")
    print(f"  calibrate(model='physical')             {t['ours'].min():.3f} / "
          f"{np.median(t['ours']):.3f} s (target <= 2 s), best chi2 {chi2['ours'].min():.6g}")
    print(f"  anchor: scipy least_squares, one start at a time  {t['anchor'].min():.3f} / "
          f"{np.median(t['anchor']):.3f} s, best chi2 {chi2['anchor'].min():.6g}")
    print(f"  ratio anchor/ours  {t['anchor'].min() / t['ours'].min():.2f} / "
          f"{np.median(t['anchor']) / np.median(t['ours']):.2f}")
    t0 = time.perf_counter()
    fit = mc.calibrate(data, model="physical", initial=initial, priors=priors, layout=layout,
                       rng=0, posterior=True)
    total = time.perf_counter() - t0
    post = fit.posterior
    assert post is not None
    print(f"posterior: {post.samples.shape[0]} samples, min ESS {post.ess.min():.0f} "
          f"(target >= 1000) in {post.seconds:.2f} s of sampling ({total:.2f} s with the fit; "
          "target <= 60 s)")
    truth = TRUTH.params()
    for i, n in enumerate(post.names):
        print(f"  {n:<12} truth {truth[n] * 1e3:.4f} mm, fit {fit.values[n] * 1e3:.4f} "
              f"± {fit.stderr[n] * 1e3:.4f} mm, posterior {post.mean[i] * 1e3:.4f} "
              f"± {post.sd[i] * 1e3:.4f} mm")


if __name__ == "__main__":
    main()
