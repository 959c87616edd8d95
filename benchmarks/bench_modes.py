"""Bending modes and the frequency response, side by side with SciPy on the same problem.

Measures, in one run and on one thread (min and median of interleaved repeats), for the
force-sensor cilium (examples/force-sensor.toml):
  * ``mc.modes`` in vacuum and in water (3 modes, 24 elements, the frequency found
    self-consistently per mode in water), target <= 5 ms (issue 28);
  * the anchor: ``scipy.linalg.eigh`` of the full generalized eigenproblem on the same assembled
    matrices (all modes; its assembly not timed), and the independent reference model of the
    tests, the Euler-Bernoulli ODE by shooting (``solve_ivp`` + ``brentq``) for the first three
    vacuum frequencies (accuracy compared, one run timed);
  * ``mc.frequency_response`` at 200 frequencies (a tip force about rest, in water: the static
    slope through bend and the field model, the modal gains, the bandwidth and the settling
    time), target <= 20 ms (issue 28).

Run: python benchmarks/bench_modes.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import itertools
import math
import statistics
import time
from pathlib import Path

import numpy as np
import scipy.linalg
from _timing import interleaved
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import magcilia as mc
from magcilia.mechanics.beam import mesh

ROOT = Path(__file__).resolve().parents[1]


def stats(t: list[float]) -> tuple[float, float]:
    return min(t), statistics.median(t)


def shooting(setup: mc.Setup, count: int = 3) -> np.ndarray:
    """The first ``count`` vacuum frequencies (Hz) by shooting on (EI w'')'' = ρ A ω² w."""
    c, e, rho = setup.cilium, setup.youngs_modulus, setup.material.density
    knots = np.asarray(c.shape[0]) * c.height
    radii = c.radius(knots)

    def tip(omega: float) -> float:
        def rhs(s: float, y: np.ndarray) -> np.ndarray:
            r = float(np.interp(s, knots, radii))
            ei, rho_a = e * math.pi * r**4 / 4, rho * math.pi * r * r
            return np.array([y[1], y[2] / ei, y[3], rho_a * omega**2 * y[0],
                             y[5], y[6] / ei, y[7], rho_a * omega**2 * y[4]])

        y = np.array([0, 0, 1, 0, 0, 0, 0, 1], dtype=float)
        for a, b in itertools.pairwise(knots):
            y = solve_ivp(rhs, (a, b), y, rtol=1e-10, atol=1e-30, method="DOP853").y[:, -1]
        return float(y[2] * y[7] - y[3] * y[6])

    grid = np.geomspace(2 * math.pi * 20, 2 * math.pi * 1500 * count, 40 * count)
    values = [tip(w) for w in grid]
    roots = []
    for a, b, fa, fb in zip(grid[:-1], grid[1:], values[:-1], values[1:], strict=True):
        if fa * fb < 0:
            roots.append(brentq(tip, a, b, xtol=1e-10))
        if len(roots) == count:
            break
    return np.array(roots) / (2 * math.pi)


def matrices(setup: mc.Setup, elements: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """The stiffness and mass matrices ``mc.modes`` assembles (vacuum, no gravity)."""
    grid = mesh(setup.cilium, elements)
    r2 = grid.radius**2
    stiff = grid.assemble(0.25 * math.pi * setup.youngs_modulus * r2 * r2, "stiffness")
    mass = grid.assemble(setup.material.density * math.pi * r2, "mass")
    return stiff, mass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a short smoke run")
    args = parser.parse_args()
    repeat = 5 if args.quick else 200
    setup = mc.load_setup(ROOT / "examples" / "force-sensor.toml")
    freq = np.geomspace(1.0, 5000.0, 200)
    stiff, mass = matrices(setup)
    for run in (lambda: mc.modes(setup), lambda: mc.modes(setup, "water"),  # warm caches
                lambda: mc.frequency_response(setup, freq, fluid="water")):
        run()

    times = interleaved({
        "modes (vacuum)": lambda: mc.modes(setup),
        "modes (water)": lambda: mc.modes(setup, "water"),
        "scipy.linalg.eigh, same matrices": lambda: scipy.linalg.eigh(stiff, mass),
        "frequency_response, 200 points (water)":
            lambda: mc.frequency_response(setup, freq, fluid="water"),
    }, repeat)
    for name, t in times.items():
        lo, med = stats(t)
        print(f"{name:<42} {lo * 1e3:8.3f} ms (median {med * 1e3:.3f})")
    t0 = time.perf_counter()
    reference = shooting(setup)
    shoot = time.perf_counter() - t0
    ours = mc.modes(setup).frequencies
    exact = np.sqrt(scipy.linalg.eigh(stiff, mass, eigvals_only=True)[:3]) / (2 * math.pi)
    print(f"{'shooting (solve_ivp + brentq), 3 modes':<42} {shoot * 1e3:8.1f} ms (one run)")
    print("frequencies (Hz):", np.array2string(ours, precision=6),
          "| shooting:", np.array2string(reference, precision=6),
          "| rel. diff:", np.array2string(ours / reference - 1, precision=2))
    print("modes against eigh on the same matrices, rel. diff:",
          np.array2string(ours / exact - 1, precision=2))
    vac, water = (stats(times[k])[0] for k in ("modes (vacuum)", "modes (water)"))
    resp = stats(times["frequency_response, 200 points (water)"])[0]
    eigh = stats(times["scipy.linalg.eigh, same matrices"])[0]
    print(f"modes: {vac * 1e3:.2f} / {water * 1e3:.2f} ms (target <= 5 ms); "
          f"{vac / eigh:.2f}x the full eigh; {shoot / vac:.0f}x faster than shooting")
    print(f"frequency response of 200 points: {resp * 1e3:.2f} ms (target <= 20 ms)")
    print(f"load: {os.getloadavg()[0]:.2f} (1-min average)")


if __name__ == "__main__":
    main()
