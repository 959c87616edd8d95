"""Field-model throughput and latency, side by side with magpylib (issue 2).

Measures, in one run and on one thread:
  * dipole·observer pairs per second of magcilia's kernel and of magpylib's
    ``func.dipole_field`` on the same 1e6 and 1e7 pair workloads (target: >= 10x magpylib);
  * latency of one ``setup.output`` call for 33 angles with n·k = 10 (target: <= 50 µs),
    beside magpylib ``Collection.getB`` of the same 10 ``Dipole`` objects at 33 poses.

Run: python benchmarks/bench_field.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import time
from collections.abc import Callable

import magpylib as magpy
import numpy as np

import magcilia as mc
from magcilia.model.kernels import dipole_field


def best_time(fn: Callable[[], object], repeat: int, number: int = 1) -> float:
    """Best wall time of ``number`` calls, over ``repeat`` runs, per call (s)."""
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        best = min(best, (time.perf_counter() - t0) / number)
    return float(best)


def throughput(n_obs: int, n_dip: int, repeat: int) -> tuple[float, float, float]:
    rng = np.random.default_rng(0)
    obs = rng.uniform(-2e-3, 2e-3, (n_obs, 3))
    pos = rng.uniform(-1e-3, 1e-3, (n_dip, 3)) + np.array([0.0, 0.0, 3e-3])
    mom = rng.normal(size=(n_dip, 3)) * 1e-6
    pairs = n_obs * n_dip
    t_ours = best_time(lambda: dipole_field(obs, pos, mom), repeat)
    # magpylib evaluates one (observer, dipole) pair per instance: same pairs, then summed
    o_rep = np.repeat(obs, n_dip, axis=0)
    p_rep = np.tile(pos, (n_obs, 1))
    m_rep = np.tile(mom, (n_obs, 1))

    def magpylib_run() -> np.ndarray:
        b = magpy.func.dipole_field("B", o_rep, m_rep, p_rep)
        return np.asarray(b).reshape(n_obs, n_dip, 3).sum(axis=1)

    t_ref = best_time(magpylib_run, max(1, repeat // 2))
    err = np.abs(dipole_field(obs, pos, mom) - magpylib_run()).max()
    scale = np.abs(magpylib_run()).max()
    return pairs / t_ours, pairs / t_ref, err / scale


def latency(repeat: int) -> tuple[float, float]:
    setup = mc.Setup.paper()  # n = 2, k = 5: n·k = 10
    angles = np.radians(np.linspace(0.0, 85.0, 33))
    t_ours = best_time(lambda: setup.output(angles), repeat, number=2000)
    # the baseline a user would write: magpylib Dipole objects, one getB per pose
    positions, moments = setup.dipoles(angles)
    dips = [magpy.misc.Dipole(moment=moments[0, i], position=positions[0, i])
            for i in range(positions.shape[1])]
    coll = magpy.Collection(*dips)

    def magpylib_run() -> np.ndarray:
        out = np.empty(angles.size)
        for a in range(angles.size):
            for i, d in enumerate(dips):
                d.position = positions[a, i]
                d.moment = moments[a, i]
            out[a] = 75.0 * coll.getB(np.zeros(3))[0]
        return out

    t_ref = best_time(magpylib_run, 3)
    np.testing.assert_allclose(magpylib_run(), setup.output(angles), rtol=1e-9)
    return t_ours, t_ref


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    args = parser.parse_args()
    repeat = 2 if args.quick else 5
    print("magcilia field benchmark (single thread)")
    print(f"{'workload':<26} {'magcilia Mpairs/s':>18} {'magpylib Mpairs/s':>18} "
          f"{'ratio':>7} {'max rel diff':>13}")
    workloads = [(1000, 1000), (10_000, 1000)] if not args.quick else [(1000, 1000)]
    for n_obs, n_dip in workloads:
        ours, ref, err = throughput(n_obs, n_dip, repeat)
        label = f"{n_obs * n_dip:.0e} pairs ({n_obs} obs x {n_dip} dip)"
        print(f"{label:<26} {ours / 1e6:18.1f} {ref / 1e6:18.1f} {ours / ref:6.1f}x {err:13.1e}")
    t_ours, t_ref = latency(repeat)
    print(f"setup.output, 33 angles, n*k = 10: {t_ours * 1e6:.1f} us per call "
          f"(target <= 50 us); magpylib Collection.getB per pose: {t_ref * 1e6:.0f} us "
          f"-> ratio {t_ref / t_ours:.0f}x")


if __name__ == "__main__":
    main()
