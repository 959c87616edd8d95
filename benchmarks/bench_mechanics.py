"""Large-deflection bending and read-out speed, side by side with PyElastica (issue 5).

Measures, in one run and on one thread:
  * one static equilibrium of the issue's tapered cilium (L = 3 mm, r 0.2 -> 0.05 mm, E = 2 MPa)
    under a dead tip force with P L^2 / (E I0) = 1, at 1e-6 relative tip accuracy (checked against
    a run with far more collocation nodes): median time (target <= 2 ms);
  * PyElastica (Cosserat rod, 50 elements, explicit position-Verlet with analytical linear
    damping) reaching the same static tip by damped dynamics to 1 %: wall time, steps, ratio;
  * read-out throughput of ``Readout.estimate`` (the table fast path), samples/s (target >= 1e7).

Run: python benchmarks/bench_mechanics.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import math
import time
import warnings

import numpy as np

import magcilia as mc

E = 2.0e6
L = 3e-3


def setup() -> mc.Setup:
    return mc.Setup.paper(height=L, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=E,
                          position=(1.4727e-3, 1.9891e-3, 0.3804e-3), n_loops=12,
                          dipoles_per_loop=4)


def ours(s: mc.Setup, force: float, repeat: int) -> tuple[float, float, np.ndarray]:
    shape = mc.bend(s, force=force)
    fine = mc.bend(s, force=force, nodes=120)
    err = float(np.linalg.norm(shape.tip - fine.tip) / np.linalg.norm(fine.tip))
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        mc.bend(s, force=force)
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), err, fine.tip


def pyelastica(s: mc.Setup, force: float, tip: np.ndarray, n_elem: int, budget: float
               ) -> tuple[float, int, float, float] | None:
    """Wall time and steps until the damped tip stays within 1 % of ``tip``; final error."""
    try:
        import elastica as ea
    except ImportError:
        return None

    class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping):  # type: ignore[misc]
        pass

    sim = Sim()
    s_mid = (np.arange(n_elem) + 0.5) / n_elem * L
    density = 1500.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rod = ea.CosseratRod.straight_rod(
            n_elem, np.zeros(3), np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), L,
            s.cilium.radius(s_mid), density, youngs_modulus=E)
    sim.append(rod)
    sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,),
                             constrained_director_idx=(0,))
    sim.add_forcing_to(rod).using(ea.EndpointForces, np.zeros(3), np.array([force, 0.0, 0.0]),
                                  ramp_up_time=1e-3)
    dt = 0.3 * (L / n_elem) / math.sqrt(E / density)  # CFL of the axial/shear waves
    omega1 = 3.5 * math.sqrt(E * (1e-4) ** 2 / (4 * density)) / L**2  # first bending mode
    sim.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=2 * omega1,
                          time_step=dt)
    sim.finalize()
    stepper = ea.PositionVerlet()
    t_sim, steps, chunk = 0.0, 0, 250
    history: list[tuple[float, int, float]] = []
    t0 = time.perf_counter()
    while time.perf_counter() - t0 < budget:
        for _ in range(chunk):
            t_sim = stepper.step(sim, t_sim, dt)
        steps += chunk
        err = float(np.linalg.norm(rod.position_collection[:, -1] - tip) / np.linalg.norm(tip))
        history.append((time.perf_counter() - t0, steps, err))
        if len(history) > 40 and max(abs(h[2] - err) for h in history[-40:]) < 1e-5:
            break  # settled
    settled = [i for i, h in enumerate(history) if h[2] >= 0.01]
    first_ok = settled[-1] + 1 if settled else 0
    if first_ok >= len(history):
        return math.inf, steps, history[-1][2], (history[-1][0] / steps)
    wall, n_steps, _ = history[first_ok]
    return wall, n_steps, history[-1][2], history[-1][0] / steps


def readout_throughput(s: mc.Setup, n: int, repeat: int) -> tuple[float, float, float]:
    t0 = time.perf_counter()
    r = mc.Readout(s, quantity="force", span=(0.0, 2e-4))
    build = time.perf_counter() - t0
    lo, hi = sorted(r.output_range)
    volts = np.random.default_rng(0).uniform(lo, hi, n)
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        r.estimate(volts)
        best = min(best, time.perf_counter() - t0)
    return n / best, build, r.table_error


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats, shorter budgets")
    args = parser.parse_args()
    s = setup()
    i0 = math.pi * (2e-4) ** 4 / 4
    force = E * i0 / L**2  # P L^2 / (E I0) = 1
    print(f"tapered cilium L = 3 mm, r 0.2 -> 0.05 mm, E = 2 MPa; tip force {force * 1e3:.4g} mN "
          "(P L^2 / E I0 = 1)")
    t_ours, err, tip = ours(s, force, 30 if args.quick else 300)
    print(f"magcilia.bend (Chebyshev collocation + Newton): median {t_ours * 1e3:.3f} ms, "
          f"tip relative error {err:.1e} (vs 120 nodes); tip = ({tip[0] * 1e3:.5f}, "
          f"{tip[2] * 1e3:.5f}) mm [target <= 2 ms at 1e-6]")
    pe = pyelastica(s, force, tip, 50, 20.0 if args.quick else 120.0)
    if pe is None:
        print("PyElastica not installed: skipped (pip install pyelastica)")
    else:
        wall, steps, final, per_step = pe
        print(f"PyElastica 50 elements, damped dynamics: within 1 % after {steps} steps, "
              f"{wall:.3g} s ({per_step * 1e6:.1f} µs/step); settled tip error "
              f"{final * 100:.2f} % (discretisation, shear and extension)")
        print(f"ratio PyElastica / magcilia: {wall / t_ours:.3g}x")
    thr, build, table_err = readout_throughput(s, 1_000_000 if args.quick else 10_000_000,
                                               3 if args.quick else 5)
    print(f"Readout force table (257 points, 0..0.2 mN): built in {build:.3g} s, table error "
          f"{table_err:.2g} N; estimate: {thr:.3g} samples/s [target >= 1e7]")


if __name__ == "__main__":
    main()
