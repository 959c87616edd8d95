"""Large-deflection bending and read-out speed, side by side with SciPy, PyElastica and NumPy.

Measures, in one run and on one thread (min and median of interleaved repeats):
  * one static equilibrium of the issue's tapered cilium (L = 3 mm, r 0.2 -> 0.05 mm, E = 2 MPa)
    under a dead tip force with P L^2 / (E I0) = 1, at 1e-6 relative tip accuracy or better
    (checked against a run with far more collocation nodes), warm (its grid cached), target
    <= 0.1 ms (issue 27);
  * the same bend as the first call in a fresh process (after ``import magcilia``, ``mc.bend``
    and the setup, each timed and printed apart: the bend's figure holds its grid, Chebyshev
    references and every first use of NumPy/LAPACK in it), over several processes, with whether
    it imported ``scipy.linalg``, target <= 0.3 ms (issue 27);
  * SciPy ``solve_bvp`` on the same elastica boundary-value problem (dimensionless, vectorised
    right-hand side, straight-rod initial guess, the loosest ``tol`` that reaches 1e-6 at the tip),
    interleaved with it;
  * a force sweep of 513 loads (a read-out table's) through ``bend_sweep``;
  * 16 cilia (a calibration's population) under 9 tip forces and under 9 water speeds at once
    (``mechanics.batched.sweep_batch``), against a loop of ``bend_sweep`` over the same sets;
  * PyElastica (Cosserat rod, 50 elements, explicit position-Verlet with analytical linear
    damping) reaching the same static tip by damped dynamics to 1 %: wall time, steps, ratio;
  * read-out throughput on 1e6 readings: ``Readout.estimate`` (value only) and ``Readout.read``
    (value, 1-σ and flags), against ``np.interp`` over the same table (value only), samples/s
    (target >= 1e7 for ``read``).

Run: python benchmarks/bench_mechanics.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import math
import statistics
import subprocess
import sys
import time
import warnings

import numpy as np
from _timing import interleaved, numpy_reference
from bench_startup import load, machine
from scipy.integrate import solve_bvp

import magcilia as mc

E = 2.0e6
L = 3e-3
R0, R1 = 2e-4, 5e-5
I0 = math.pi * R0**4 / 4


def setup() -> mc.Setup:
    return mc.Setup.paper(height=L, base_radius=R0, tip_radius=R1, youngs_modulus=E,
                          position=(1.4727e-3, 1.9891e-3, 0.3804e-3), n_loops=12,
                          dipoles_per_loop=4)


def stats(t: list[float]) -> tuple[float, float]:
    return min(t), statistics.median(t)


def bvp(alpha: float, tol: float) -> np.ndarray:
    """Tip (m, (3,)) of the tapered elastica by SciPy's ``solve_bvp``: y = (θ, m, x, z) over
    t = s / L, m = M L / (E I0); θ' = m / (I/I0), m' = −α cos θ, x' = sin θ, z' = cos θ;
    θ(0) = x(0) = z(0) = 0, m(1) = 0."""
    lam = R1 / R0

    def fun(t: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.vstack([y[1] / (1.0 - (1.0 - lam) * t) ** 4, -alpha * np.cos(y[0]),
                          np.sin(y[0]), np.cos(y[0])])

    def bc(ya: np.ndarray, yb: np.ndarray) -> np.ndarray:
        return np.array([ya[0], yb[1], ya[2], ya[3]])

    t = np.linspace(0.0, 1.0, 11)
    y0 = np.zeros((4, t.size))
    y0[3] = t  # the straight rod
    sol = solve_bvp(fun, bc, t, y0, tol=tol, max_nodes=100_000)
    if sol.status != 0:
        raise RuntimeError(f"solve_bvp failed: {sol.message}")
    return np.array([sol.y[2, -1], 0.0, sol.y[3, -1]]) * L


def relative(tip: np.ndarray, ref: np.ndarray) -> float:
    return float(np.linalg.norm(tip - ref) / np.linalg.norm(ref))


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


def bending(s: mc.Setup, quick: bool) -> tuple[float, np.ndarray]:
    """The bend rows; returns the force (N) and the reference tip (m)."""
    force = E * I0 / L**2  # P L^2 / (E I0) = 1
    print(f"tapered cilium L = 3 mm, r 0.2 -> 0.05 mm, E = 2 MPa; tip force {force * 1e3:.4g} mN "
          "(P L^2 / E I0 = 1); one thread")
    ref = mc.bend(s, force=force, nodes=120).tip
    shape = mc.bend(s, force=force)
    tol = next(t for t in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7) if relative(bvp(1.0, t), ref) <= 1e-6)
    times = interleaved({"ours": lambda: mc.bend(s, force=force),
                         "bvp": lambda: bvp(1.0, tol)}, 20 if quick else 100)
    (o_min, o_med), (b_min, b_med) = stats(times["ours"]), stats(times["bvp"])
    a_min, a_med = stats(interleaved({"alone": lambda: mc.bend(s, force=force)},
                                     100 if quick else 1000)["alone"])
    print(f"  magcilia.bend warm (Chebyshev collocation, {shape.nodes} nodes, Newton from the "
          f"saturated linear-beam guess, {shape.iterations} iterations): interleaved with "
          f"solve_bvp min {o_min * 1e3:.3f} ms, median {o_med * 1e3:.3f} ms; repeated alone min "
          f"{a_min * 1e3:.3f} ms, median {a_med * 1e3:.3f} ms; tip error "
          f"{relative(shape.tip, ref):.1e} [target <= 0.1 ms at 1e-6]")
    first = first_calls(7 if quick else 15)
    bent, med = first["bend"], {k: statistics.median(t) * 1e3 for k, t in first.items()}
    print(f"  magcilia.bend first call in a fresh process ({len(bent)} processes, after import "
          f"and the setup): min {min(bent) * 1e3:.3f} ms, median {med['bend']:.3f} ms "
          f"[target <= 0.3 ms]; scipy.linalg imported by it in {sum(first['scipy']):.0f} of "
          f"{len(bent)}")
    print(f"    not counted in it (medians): import magcilia {med['import']:.1f} ms, mc.bend's "
          f"lazy import of magcilia.mechanics {med['mechanics']:.1f} ms, Setup.paper "
          f"{med['setup']:.2f} ms")
    print(f"  SciPy solve_bvp (vectorised, tol {tol:g}): min {b_min * 1e3:.3f} ms, median "
          f"{b_med * 1e3:.3f} ms; tip error {relative(bvp(1.0, tol), ref):.1e}")
    print(f"  ratio solve_bvp / magcilia: min {b_min / o_min:.3g}x, median {b_med / o_med:.3g}x")
    forces = np.linspace(0.0, 2e-4, 513)
    sweep = stats(interleaved({"sweep": lambda: mc.bend_sweep(s, forces=forces)},
                              3 if quick else 10)["sweep"])
    print(f"  magcilia.bend_sweep, 513 forces 0..0.2 mN (each predicted from its neighbours): "
          f"min {sweep[0] * 1e3:.1f} ms ({sweep[0] / 512 * 1e6:.0f} µs per load), median "
          f"{sweep[1] * 1e3:.1f} ms")
    batches(quick)
    return force, ref


def batches(quick: bool) -> None:
    """Many cilia under many loads (a calibration's population): ``sweep_batch`` against a loop
    of ``bend_sweep`` over the same sets (the same shapes, checked)."""
    from magcilia.mechanics.batched import sweep_batch
    from magcilia.mechanics.planar import _sweep_plane

    base = mc.Setup.paper(ring="rms", tip_radius=5e-5, youngs_modulus=0.5e6)
    rng = np.random.default_rng(0)
    n = 16
    sets = (rng.uniform(3.1e-3, 3.4e-3, n), rng.uniform(1.7e-4, 1.9e-4, n),
            np.exp(rng.uniform(math.log(4e5), math.log(6e5), n)))
    for label, loads, flow in (("tip forces 0..20 uN", np.linspace(0.0, 2e-5, 9), None),
                               ("water speeds 0..0.3 m/s", np.linspace(0.0, 0.3, 9),
                                mc.Flow.uniform(0.3, mc.WATER))):
        def loop(loads: np.ndarray = loads, flow: mc.Flow | None = flow) -> list:
            out = []
            for h, r, e in zip(*sets, strict=True):
                s = base.replace(height=float(h), base_radius=float(r), youngs_modulus=float(e))
                out.append(_sweep_plane(s, forces=loads) if flow is None
                           else _sweep_plane(s, speeds=loads, flow=flow))
            return out

        first = sweep_batch(base, *sets, loads, flow=flow)
        err = max(float(np.abs(first.points[i] - ref.points).max() / sets[0][i])
                  for i, ref in enumerate(loop()))
        # the next populations, each from the last one's solutions and inverse Jacobians (as a
        # calibration's problem keeps them)
        last = sweep_batch(base, *(x * 1.01 for x in sets), loads, flow=flow, start=first.theta)
        near = tuple(x * 1.02 for x in sets)
        times = interleaved({
            "batch": lambda loads=loads, flow=flow: sweep_batch(base, *sets, loads, flow=flow),
            "warm": lambda loads=loads, flow=flow, near=near, last=last: sweep_batch(
                base, *near, loads, flow=flow, start=last.theta, start_inverse=last.inverse),
            "loop": loop}, 3 if quick else 10)
        (b, _), (w, _), (lp, _) = (stats(times[k]) for k in ("batch", "warm", "loop"))
        print(f"  mechanics.batched.sweep_batch, {n} cilia x 9 {label}: {b * 1e3:.1f} ms, "
              f"{w * 1e3:.1f} ms from a nearby population's solutions (1 % apart); a loop of "
              f"bend_sweep {lp * 1e3:.1f} ms ({lp / b:.1f}x / {lp / w:.1f}x); points within "
              f"{err:.0e} L of the loop's")


#: what :func:`first_calls` runs in each fresh process: the setup of :func:`setup`, then one
#: timed bend (its tip printed too, to check that it is the warm bend's)
_FIRST_CALL = """
import os
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[var] = "1"
import math, time
t_import = time.perf_counter()
import magcilia as mc
t_bend = time.perf_counter()
bend = mc.bend  # the lazy import of magcilia.mechanics
t_setup = time.perf_counter()
s = mc.Setup.paper(height={L!r}, base_radius={R0!r}, tip_radius={R1!r}, youngs_modulus={E!r},
                   position=(1.4727e-3, 1.9891e-3, 0.3804e-3), n_loops=12, dipoles_per_loop=4)
force = {force!r}
t0 = time.perf_counter()
shape = bend(s, force=force)
t1 = time.perf_counter()
print(t1 - t0, *shape.tip.tolist(), t_bend - t_import, t_setup - t_bend, t0 - t_setup,
      "scipy.linalg" in __import__("sys").modules, mc.__file__)
"""


def first_calls(processes: int) -> dict[str, list[float]]:
    """Wall times (s) in each of ``processes`` fresh interpreters (one after another, this
    magcilia): ``"bend"`` the first ``bend`` (checked to give the warm bend's tip to 1e-12
    relative), and apart from it ``"import"`` (``import magcilia``), ``"mechanics"`` (the lazy
    import behind ``mc.bend``) and ``"setup"`` (``Setup.paper``); ``"scipy"`` counts the
    processes whose bend imported ``scipy.linalg`` (1.0 each)."""
    force = E * I0 / L**2
    code = _FIRST_CALL.format(L=L, R0=R0, R1=R1, E=E, force=force)
    warm = mc.bend(setup(), force=force).tip
    out: dict[str, list[float]] = {"bend": [], "import": [], "mechanics": [], "setup": [],
                                   "scipy": []}
    for _ in range(processes):
        words = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                               check=True).stdout.split()
        if words[-1] != mc.__file__:
            raise RuntimeError(f"the fresh process imported {words[-1]}, not {mc.__file__}")
        if relative(np.array([float(x) for x in words[1:4]]), warm) > 1e-12:
            raise RuntimeError(f"the first call's tip {words[1:4]} is not the warm bend's {warm}")
        for key, word in zip(("bend", "import", "mechanics", "setup"), words[:1] + words[4:7],
                             strict=True):
            out[key].append(float(word))
        out["scipy"].append(1.0 if words[7] == "True" else 0.0)
    return out


def readout(s: mc.Setup, quick: bool) -> None:
    t0 = time.perf_counter()
    r = mc.Readout(s, quantity="force", span=(0.0, 2e-4))
    build = time.perf_counter() - t0
    table = r.table
    n = 1_000_000
    lo, hi = sorted(r.output_range)
    volts = np.random.default_rng(0).uniform(lo, hi, n)
    print(f"Readout force table ({table.volts.size} points, 0..0.2 mN): built in {build:.3g} s, "
          f"table error {r.table_error:.2g} N; {n:.0e} readings, samples/s (min | median time):")
    times = interleaved({
        "np.interp": lambda: np.interp(volts, table.volts, table.values),
        "estimate": lambda: r.estimate(volts),
        "read": lambda: r.read(volts, noise=1e-4),
        "read NumPy": numpy_reference(lambda: r.read(volts, noise=1e-4)),
    }, 5 if quick else 15)
    anchor = stats(times["np.interp"])
    for name, label in (("np.interp", "np.interp over the table (value)"),
                        ("estimate", "Readout.estimate (value)"),
                        ("read", "Readout.read (value, sigma, flags)"),
                        ("read NumPy", "Readout.read, its NumPy path (reference)")):
        best, med = stats(times[name])
        ratio = "" if name == "np.interp" else (f"; {anchor[0] / best:.3g}x np.interp (min), "
                                                f"{anchor[1] / med:.3g}x (median)")
        print(f"  {label}: {n / best:.3g} | {n / med:.3g}{ratio}")
    est = stats(times["estimate"])
    print(f"  read / estimate time: {stats(times['read'])[0] / est[0]:.2f} (min) "
          "[target read >= 1e7 samples/s]")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats, shorter budgets")
    args = parser.parse_args()
    print(f"{machine()}, one thread; {load()} before")
    s = setup()
    force, tip = bending(s, args.quick)
    readout(s, args.quick)
    pe = pyelastica(s, force, tip, 50, 20.0 if args.quick else 120.0)
    if pe is None:
        print("PyElastica not installed: skipped (pip install pyelastica)")
        print(f"{load()} after")
        return
    wall, steps, final, per_step = pe
    t_ours = stats(interleaved({"ours": lambda: mc.bend(s, force=force)}, 20)["ours"])[1]
    print(f"PyElastica 50 elements, damped dynamics: within 1 % after {steps} steps, "
          f"{wall:.3g} s ({per_step * 1e6:.1f} µs/step); settled tip error "
          f"{final * 100:.2f} % (discretisation, shear and extension)")
    print(f"  ratio PyElastica / magcilia.bend (median): {wall / t_ours:.3g}x")
    print(f"{load()} after")


if __name__ == "__main__":
    main()
