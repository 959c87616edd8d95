"""Where a first ``mc.bend`` in a fresh process spends its time, and the floor under it (issue 27
item 6: <= 0.3 ms; ``bench_mechanics`` prints the figure itself).

Each round starts fresh interpreters (this one, the tree under test first on ``PYTHONPATH``, one
thread), interleaved:

* the first bend of ``bench_mechanics``'s cilium (L = 3 mm, r 0.2 -> 0.05 mm, E = 2 MPa, a tip
  force with P L^2 / E I0 = 1) taken apart: after ``import magcilia``, ``mc.bend`` and the setup,
  each step of ``mechanics.planar._bend_plane`` called in turn and timed (the checks; the grid
  and sections, with the shipped Chebyshev table's read; the load case's statics, with the
  influence matrix, NumPy's first matrix product; the point-force maps; the load case and
  Newton's start; Newton, with NumPy's first LAPACK solve; the shape); then, in the same
  process, the same steps again with every cache emptied (NumPy warm: the arithmetic alone) and
  once more with the caches full (a warm bend);
* the floor: fresh interpreters that only ``import numpy`` and time a first
  ``numpy.linalg.solve`` of 4 x 4, a first 34 x 34 matrix product, and that product then a
  34 x 34 solve (what any first bend pays for OpenBLAS/LAPACK, whatever its own code);
* a first ``mc.bend`` itself, for the sum's check.

Printed: medians (and min) over the rounds, microseconds.

Run: python benchmarks/bench_bend_first.py [--quick] [--rounds N]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, in the children too

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

from bench_startup import load, machine

SRC = Path(__file__).resolve().parents[1] / "src"

_HEAD = """
import os
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[var] = "1"
import json, math, time
T = time.perf_counter
"""

#: the first bend, step by step (the steps of mechanics.planar._bend_plane for a tip force)
_STEPS = _HEAD + """
import magcilia as mc
mc.bend
import numpy as np
from magcilia.mechanics import chebyshev_tables, elastica, planar, sections
from magcilia.mechanics.shape import BentShape, Load
L, R0, E = 3e-3, 2e-4, 2e6
s = mc.Setup.paper(height=L, base_radius=R0, tip_radius=5e-5, youngs_modulus=E,
                   position=(1.4727e-3, 1.9891e-3, 0.3804e-3), n_loops=12, dipoles_per_loop=4)
force = E * math.pi * R0**4 / 4 / L**2

def steps():
    t = [T()]
    f, at, direction = planar._check(s, force, None, 0.5 * math.pi, None)
    nodes = sections.check_nodes(None)
    load = Load(f, direction, at, None)
    t.append(T())
    sections.sections(s.cilium, at, True, nodes)
    t.append(T())
    static = planar._static(s.cilium, s.youngs_modulus, at, True, nodes)
    t.append(T())
    static.maps
    t.append(T())
    case = planar._Case(s, at, direction, True, None, nodes)
    guess = case.guess(f, 0.0)
    t.append(T())
    sol = case.solve((0.0, 0.0), (f, 0.0), np.zeros(case.grid.s.size), guess)
    t.append(T())
    s_out, th, pts = case.shape_data(sol, f, 0.0)
    BentShape._solved(s_out, th[None], pts[None], load, sol.residual, sol.iterations,
                      int(case.grid.s.size))
    t.append(T())
    return [(b - a) * 1e6 for a, b in zip(t, t[1:])]

first = steps()
for cached in (chebyshev_tables.read, planar._static, sections.sections, elastica._grid,
               elastica._reference, elastica._coefficients, elastica._uniform_reference):
    cached.cache_clear()
cleared = steps()
warm = steps()
print(json.dumps({"first": first, "cleared": cleared, "warm": warm}))
"""

_BEND = _HEAD + """
import magcilia as mc
bend = mc.bend
L, R0, E = 3e-3, 2e-4, 2e6
s = mc.Setup.paper(height=L, base_radius=R0, tip_radius=5e-5, youngs_modulus=E,
                   position=(1.4727e-3, 1.9891e-3, 0.3804e-3), n_loops=12, dipoles_per_loop=4)
force = E * math.pi * R0**4 / 4 / L**2
t0 = T()
bend(s, force=force)
print(json.dumps({"bend": (T() - t0) * 1e6}))
"""

_FLOOR = _HEAD + """
import numpy as np
rng = np.random.default_rng(0)
a4, b4 = rng.random((4, 4)) + 4.0 * np.eye(4), rng.random(4)
a, b = rng.random((34, 34)) + 34.0 * np.eye(34), rng.random(34)
out = {}
if "{which}" == "solve4":
    t0 = T(); np.linalg.solve(a4, b4); out["solve 4x4 first"] = (T() - t0) * 1e6
    t0 = T(); np.linalg.solve(a4, b4); out["solve 4x4 again"] = (T() - t0) * 1e6
else:
    t0 = T(); a @ a; out["product 34x34 first"] = (T() - t0) * 1e6
    t0 = T(); np.linalg.solve(a, b); out["then solve 34x34 first"] = (T() - t0) * 1e6
    t0 = T(); np.linalg.solve(a, b); out["solve 34x34 again"] = (T() - t0) * 1e6
print(json.dumps(out))
"""

STEP_NAMES = ("checks (Setup, force, at; Load)", "grid and sections (shipped table read)",
              "statics: EI, influence matrix (first BLAS product)", "point-force maps",
              "load case and Newton's start", "Newton (first LAPACK solve; 4 steps)",
              "shape (output products, BentShape)")


def run(code: str) -> dict[str, object]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env=env).stdout
    return dict(json.loads(out.splitlines()[-1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 rounds (a smoke run)")
    parser.add_argument("--rounds", type=int, default=None, help="rounds (default 15)")
    args = parser.parse_args()
    rounds = args.rounds or (5 if args.quick else 15)
    print(f"{machine()}, one thread; {load()} before; {rounds} rounds of fresh processes")
    runs: dict[str, list[dict[str, object]]] = {"steps": [], "bend": [], "solve4": [],
                                                 "product": []}
    for _ in range(rounds):
        runs["steps"].append(run(_STEPS))
        runs["bend"].append(run(_BEND))
        runs["solve4"].append(run(_FLOOR.replace("{which}", "solve4")))
        runs["product"].append(run(_FLOOR.replace("{which}", "product")))

    def med(values: list[float]) -> str:
        return f"{statistics.median(values):7.1f} (min {min(values):6.1f})"

    bends = [float(r["bend"]) for r in runs["bend"]]  # type: ignore[arg-type]
    print(f"first mc.bend, median (min), us: {med(bends)}")
    kinds = {k: [[float(x) for x in r[k]] for r in runs["steps"]]  # type: ignore[attr-defined]
             for k in ("first", "cleared", "warm")}
    print(f"  {'step':52s} {'first call':>22s} {'NumPy warm, no caches':>22s} "
          f"{'warm':>8s}")
    for i, name in enumerate(STEP_NAMES):
        print(f"  {name:52s} {med([r[i] for r in kinds['first']]):>22s} "
              f"{med([r[i] for r in kinds['cleared']]):>22s} "
              f"{statistics.median(r[i] for r in kinds['warm']):8.1f}")
    totals = {k: [sum(r) for r in v] for k, v in kinds.items()}
    print(f"  {'sum of the steps':52s} {med(totals['first']):>22s} "
          f"{med(totals['cleared']):>22s} {statistics.median(totals['warm']):8.1f}")
    print("floor (fresh processes after import numpy only), median (min), us:")
    for key in ("solve4", "product"):
        for name in runs[key][0]:
            print(f"  {name:28s} {med([float(r[name]) for r in runs[key]])}")  # type: ignore[arg-type]
    print(load() + " after")


if __name__ == "__main__":
    main()
