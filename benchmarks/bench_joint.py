"""Benchmark: a 3-experiment physical calibration (issue 14's target: ≤ 2 s on one core).

Three experiments of the paper's cilium, generated with the exact Cylinder-stack field: 3-axis
field data tilted toward azimuths 0 and 90° and the single-axis output toward 45°, 17 angles each,
a manual height prior. Times, interleaved in one process on one thread (min and median of 5),
``calibrate(model="physical")`` (64 Latin-hypercube starts, batched Levenberg–Marquardt, polish)
and, as the anchor, SciPy's ``least_squares`` run one start at a time from the same 64 starts over
the same residuals; then the posterior of the geometry (``posterior=True``: emcee until every
parameter has 1000 effective samples; issue 14's target ≤ 60 s on one core).

Then the joint fit with load experiments (issue 27, item 2): the tests' synthetic data
(tests/calibration/test_joint_loads.py: 3-axis tilts toward 0 and 90°, 9 tip forces 0–20 µN and
9 water speeds 0–0.3 m/s on a 50 µm tip, E = 0.5 MPa; the Young's modulus fitted too), the fit
and its posterior, interleaved against the previous load model as the anchor: the same problem
with each parameter set bent by its own ``bend_sweep`` and its field from ``Setup.field``, one set
at a time (what ``Problem`` did before the batched bends; ``--quick``: 300 effective samples).

Run: ``python benchmarks/bench_joint.py [--quick]``
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import time

import numpy as np
from scipy.optimize import least_squares

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.calibration import JointProblem
from magcilia.calibration.joint import JOINT_PARAMETERS, STARTS, PhysicalLayout
from magcilia.calibration.multistart import latin_hypercube
from magcilia.calibration.problem import Problem
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
    parser.add_argument("--loads-only", action="store_true",
                        help="only the fit and posterior with load experiments")
    args = parser.parse_args()
    if args.loads_only:
        loads(args.quick)
        return
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
    loads(args.quick)


#: the load case: the truth and start of tests/calibration/test_joint_loads.py
LOAD_TRUTH = mc.Setup.paper(ring="rms", tip_radius=5e-5, youngs_modulus=0.5e6).replace(
    n_loops=64, dipoles_per_loop=5)
LOAD_INITIAL = LOAD_TRUTH.replace(height=3.0e-3, base_radius=0.2e-3, x=1.0e-3, y=1.5e-3,
                                  z=0.5e-3, youngs_modulus=2.5e6)
FORCES = np.linspace(0.0, 2e-5, 9)  # N
SPEEDS = np.linspace(0.0, 0.3, 9)  # m/s


def load_experiments(rng: np.random.Generator) -> list[Measurement]:
    """Two tilt paths (field, azimuths 0 and 90°), 9 tip forces and 9 water speeds (field)."""
    def one(b: np.ndarray, name: str, phi: float = 0.0, angles: np.ndarray | None = None,
            **loads: object) -> Measurement:
        a = b.shape[0]
        return Measurement(
            angles=np.zeros(a) if angles is None else angles, volts=np.full(a, np.nan),
            sem=np.full(a, np.nan), counts=np.full(a, 100), saturated=np.zeros(a, np.int64),
            nonfinite=np.zeros(a, np.int64), source=name, azimuths=np.full(a, phi),
            fields=b + rng.normal(0.0, 10e-6, 3) + rng.normal(0.0, NOISE, b.shape),
            field_sem=np.full((a, 3), NOISE), **loads)  # type: ignore[arg-type]

    tilts = [one(LOAD_TRUTH.field(ANGLES, azimuth=phi), f"tilt{i}", phi, ANGLES)
             for i, phi in enumerate((0.0, math.pi / 2))]
    force = one(LOAD_TRUTH.field(mc.bend_sweep(LOAD_TRUTH, forces=FORCES)), "force",
                forces=FORCES)
    flow = one(LOAD_TRUTH.field(mc.bend_sweep(LOAD_TRUTH, speeds=SPEEDS, flow=mc.Flow.uniform(
        0.3, mc.WATER))), "flow", speeds=SPEEDS, metadata={"fluid": "water"})
    return [*tilts, force, flow]


def _loop_load_fields(self: Problem, prm: dict[str, np.ndarray]) -> np.ndarray:
    """The anchor: the load blocks' fields one parameter set at a time (``bend_sweep`` and
    ``Setup.field`` per set and block), as ``Problem`` computed them before issue 27."""
    n = prm["x"].size
    out = np.full((n, sum(3 * b[2].size for b in self.table.loads)), np.nan)
    for i in range(n):
        try:
            setup = self.base.replace(**{k: float(prm[k][i]) for k in (
                "height", "base_radius", "x", "y", "z", "youngs_modulus")})
            col = 0
            for e_i, phi, loads, _ in self.table.loads:
                if self.measurements[e_i].forces is not None:
                    shapes = mc.bend_sweep(setup, forces=loads)
                else:
                    shapes = mc.bend_sweep(setup, speeds=loads, flow=mc.Flow.uniform(
                        float(np.max(np.abs(loads))) or 1.0, self.fluids[e_i]))
                out[i, col:col + 3 * loads.size] = setup.field(shapes, azimuth=phi).ravel()
                col += 3 * loads.size
        except MagciliaError:
            out[i] = np.nan
    return out


@contextlib.contextmanager
def anchored(use: bool):  # type: ignore[no-untyped-def]
    """Within it, ``Problem`` computes the load blocks by the anchor's loop (when ``use``)."""
    batched = Problem._load_fields
    if use:
        Problem._load_fields = _loop_load_fields  # type: ignore[method-assign]
    try:
        yield
    finally:
        Problem._load_fields = batched  # type: ignore[method-assign]


def loads(quick: bool) -> None:
    data = load_experiments(np.random.default_rng(1))
    layout = PhysicalLayout(64, 5)
    truth = {**LOAD_TRUTH.params(), "youngs_modulus": LOAD_TRUTH.youngs_modulus}

    def fit(anchor: bool, seed: int, posterior: bool | int = False) -> tuple[float, object]:
        with anchored(anchor):
            t0 = time.perf_counter()
            r = mc.calibrate(data, model="physical", initial=LOAD_INITIAL, layout=layout,
                             rng=seed, posterior=posterior)
            return time.perf_counter() - t0, r

    fit(False, 0)  # caches
    times: dict[bool, list[float]] = {False: [], True: []}
    results = {}
    for seed in range(1 if quick else 3):
        for anchor in (False, True):
            t, r = fit(anchor, seed)
            times[anchor].append(t)
            results[anchor] = r
    print("joint fit with load experiments (tilts 0 and 90 deg x 17 angles, 9 tip forces, 9 "
          "water speeds; height, base radius, x, y, z and the Young's modulus), min / median of "
          f"{len(times[False])} interleaved:")
    ours, anchor = np.array(times[False]), np.array(times[True])
    print(f"  batched bends (mechanics.batched)          {ours.min():.3f} / "
          f"{np.median(ours):.3f} s, chi2 {results[False].chi2:.6g}")
    print(f"  anchor: one bend_sweep and Setup.field per set  {anchor.min():.3f} / "
          f"{np.median(anchor):.3f} s, chi2 {results[True].chi2:.6g}")
    print(f"  ratio anchor/ours  {anchor.min() / ours.min():.2f} / "
          f"{np.median(anchor) / np.median(ours):.2f}")
    fitted = results[False]
    for n in ("height", "base_radius", "youngs_modulus"):
        print(f"  {n:<15} truth {truth[n]:.5g}, fit {fitted.values[n]:.5g} "
              f"± {fitted.stderr[n]:.2g}")
    target = 300 if quick else 1000
    print(f"posterior with load experiments ({target} effective samples asked, 60 s limit):")
    for anchor in (False, True):
        t, r = fit(anchor, 0, posterior=target)
        post = r.posterior
        assert post is not None
        label = "anchor (the loop per set)" if anchor else "batched bends"
        print(f"  {label:<27} min ESS {post.ess.min():.0f} in {post.seconds:.2f} s of sampling "
              f"({t:.2f} s with the fit), {post.ess.min() / post.seconds:.0f} ESS/s, "
              f"converged {post.converged}")


if __name__ == "__main__":
    main()
