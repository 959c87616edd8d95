"""Benchmark: a 3-experiment physical calibration (issue 14's target: ≤ 2 s on one core).

Three experiments of the paper's cilium, generated with the exact Cylinder-stack field: 3-axis
field data tilted toward azimuths 0 and 90° and the single-axis output toward 45°, 17 angles each,
a manual height prior. Times ``calibrate(model="physical")`` (64 Latin-hypercube starts, batched
Levenberg–Marquardt, polish) and, as an anchor, SciPy's ``least_squares`` run one start at a time
from the same 64 starts over the same residuals.

Run: ``PYTHONPATH=src python benchmarks/bench_joint.py``
"""

from __future__ import annotations

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
    data = experiments(np.random.default_rng(0))
    initial = TRUTH.replace(height=3.0e-3, base_radius=0.2e-3, x=1.0e-3, y=1.5e-3, z=0.5e-3)
    layout = mc.calibration.converged_layout(TRUTH)
    priors = {"height": (3.3e-3, 0.15e-3)}
    mc.calibrate(data, model="physical", initial=initial, priors=priors, layout=layout, rng=0)
    times = []
    for seed in range(5):
        t0 = time.perf_counter()
        fit = mc.calibrate(data, model="physical", initial=initial, priors=priors,
                           layout=layout, rng=seed)
        times.append(time.perf_counter() - t0)
    truth = TRUTH.params()
    print(f"layout n={layout.n_loops}, k={layout.dipoles_per_loop} (error {layout.error:.2g})")
    print(f"calibrate(model='physical'), 3 experiments, {STARTS} starts: median "
          f"{np.median(times):.3f} s (min {min(times):.3f} s; target <= 2 s), chi2/dof "
          f"{fit.chi2 / fit.dof:.3f}")
    for n in JOINT_PARAMETERS:
        print(f"  {n:<12} truth {truth[n] * 1e3:.4f} mm, fit {fit.values[n] * 1e3:.4f} "
              f"± {fit.stderr[n] * 1e3:.4f} mm")
    box = {n: mc.calibration.DEFAULT_BOUNDS[n] for n in JOINT_PARAMETERS}
    problem = JointProblem(data, initial, layout, box, JOINT_PARAMETERS, priors)
    lo, hi = problem.bounds[:, 0], problem.bounds[:, 1]
    starts = latin_hypercube(STARTS, lo, hi, np.random.default_rng(0))
    t0 = time.perf_counter()
    best = np.inf
    for x0 in starts:
        sol = least_squares(lambda z: problem.residuals(z)[0], x0, bounds=(lo, hi),
                            x_scale=hi - lo, method="trf")
        best = min(best, 2 * sol.cost)
    anchor = time.perf_counter() - t0
    print(f"anchor: scipy least_squares from the same {STARTS} starts one by one: {anchor:.3f} s "
          f"(best chi2 {best:.6g} vs {fit.chi2:.6g})")


if __name__ == "__main__":
    main()
