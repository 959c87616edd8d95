"""Field-model throughput and latency, side by side with magpylib (issue 17), one thread.

Every contender runs in this process, interleaved (one run of each in turn), and the min and median
of the runs are printed with the ratio of the minima:

  (a) dipole·observer pairs per second, 1e6 and 1e7 pairs (few and many dipoles): magcilia's
      compiled kernel (``model.kernels.dipole_field``), a plain numba reference kernel over the
      same structure of arrays (one loop over all dipoles per observer, no blocking: what one
      would write first; target ≥ 0.9× of it), magpylib's vectorised core
      ``core.dipole_Hfield`` × μ0 on the same pairs (observer − dipole vectors formed and the
      field summed per observer, in blocks of ~1e6 pairs) and magcilia's NumPy reference
      (targets: ≥ 950 M pairs/s, ≥ 25× magpylib). The bound it is measured against: each pair
      costs one divide and one square root (the slow operations) and 26 other flops; a loop of
      just the divide and square root, compiled alike, gives the machine's ceiling for them, and
      the clock is printed beside it;
  (b) one ``setup.output`` call, 33 angles, n·k = 10 (target ≤ 20 µs), beside magpylib's path
      feature: the 10 ``Dipole`` objects given a 33-pose path (position and orientation arrays),
      and one ``Collection`` of them rotated along a 33-pose path, each one ``getB`` call;
  (c) the batch model (``TiltBatch.output``): evaluations per second of a 128-member population
      with n and k mixed in 1..10, 33 angles, compiled vs the NumPy reference;
  (d) the kernels' first-call cost with a cold numba cache (compile) and a warm one (load), each
      in a fresh process.

Run: python benchmarks/bench_field.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import math
import platform
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import magpylib as magpy
import numpy as np
from _timing import numpy_reference
from scipy.spatial.transform import Rotation

import magcilia as mc
from magcilia.constants import MU0
from magcilia.model.batch import TiltBatch
from magcilia.model.kernels import dipole_field

ANGLES = np.radians(np.linspace(0.0, 85.0, 33))


def interleaved(fns: dict[str, Callable[[], object]], repeat: int,
                number: int = 1) -> dict[str, tuple[float, float]]:
    """(min, median) seconds per call of each function, over ``repeat`` interleaved runs of
    ``number`` calls."""
    times: dict[str, list[float]] = {name: [] for name in fns}
    for fn in fns.values():
        fn()  # warm up (compile, caches)
    for _ in range(repeat):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            for _ in range(number):
                fn()
            times[name].append((time.perf_counter() - t0) / number)
    return {name: (min(t), float(np.median(t))) for name, t in times.items()}


#: flops of one dipole·observer pair in the kernel, besides its divide and square root:
#: r (3), r² (5), ir³ (1), m·r (5), q (3), the three components (6) and their sums (3)
PAIR_FLOPS = 26


def _plain_kernel(observers, positions, moments, out):  # type: ignore[no-untyped-def]
    """The reference: per observer, one loop over all dipoles (numba source; components first,
    as the compiled kernel takes them)."""
    n_obs, n_dip = observers.shape[0], positions.shape[1]
    for i in range(n_obs):
        x, y, z = observers[i, 0], observers[i, 1], observers[i, 2]
        bx, by, bz = 0.0, 0.0, 0.0
        for j in range(n_dip):
            rx, ry, rz = x - positions[0, j], y - positions[1, j], z - positions[2, j]
            ir2 = 1.0 / (rx * rx + ry * ry + rz * rz)
            ir3 = ir2 * math.sqrt(ir2)
            q = 3.0 * (moments[0, j] * rx + moments[1, j] * ry + moments[2, j] * rz) * ir3 * ir2
            bx += q * rx - moments[0, j] * ir3
            by += q * ry - moments[1, j] * ir3
            bz += q * rz - moments[2, j] * ir3
        out[i, 0] = bx
        out[i, 1] = by
        out[i, 2] = bz


def _bound_kernel(r2, passes):  # type: ignore[no-untyped-def]
    """The divide and square root of ``passes × r2.size`` pairs, nothing else, over an array
    that stays in the L1 cache (numba source)."""
    total = 0.0
    for _ in range(passes):
        for j in range(r2.size):
            ir2 = 1.0 / r2[j]
            total += ir2 * math.sqrt(ir2)
    return total


def _njit(fn: Callable[..., object]) -> Callable[..., object]:
    import numba

    return numba.njit(fn, error_model="numpy", nogil=True,  # type: ignore[no-any-return]
                      fastmath={"reassoc", "contract"})


def clock_mhz() -> str:
    """The CPU clock now (``/proc/cpuinfo``'s "cpu MHz", the first core), or "?"."""
    try:
        lines = Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines()
        return next(ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("cpu MHz"))
    except (OSError, StopIteration):
        return "?"


def pairs_bench(n_obs: int, n_dip: int, repeat: int) -> None:
    rng = np.random.default_rng(0)
    obs = rng.uniform(-2e-3, 2e-3, (n_obs, 3))
    pos = rng.uniform(-1e-3, 1e-3, (n_dip, 3)) + np.array([0.0, 0.0, 3e-3])
    mom = rng.normal(size=(n_dip, 3)) * 1e-6
    block = max(1, 1_000_000 // n_dip)  # observers per magpylib call (memory stays ~100 MB)
    m_rep = np.tile(mom, (block, 1))

    def magpylib_core() -> np.ndarray:
        out = np.empty((n_obs, 3))
        for start in range(0, n_obs, block):
            o = obs[start:start + block]
            r = (o[:, None, :] - pos[None, :, :]).reshape(-1, 3)
            h = magpy.core.dipole_Hfield(r, m_rep[:r.shape[0]])
            out[start:start + block] = MU0 * h.reshape(o.shape[0], n_dip, 3).sum(axis=1)
        return out

    plain, bound = _njit(_plain_kernel), _njit(_bound_kernel)
    pos_t, mom_t = np.ascontiguousarray(pos.T), np.ascontiguousarray(mom.T)
    plain_out = np.empty((n_obs, 3))
    r2 = 1.0 + rng.random(1000)  # 8 kB
    fns = {"magcilia": lambda: dipole_field(obs, pos, mom),
           "plain numba": lambda: plain(obs, pos_t, mom_t, plain_out),
           "div+sqrt only": lambda: bound(r2, n_obs * n_dip // r2.size),
           "magpylib core": magpylib_core,
           "magcilia NumPy": numpy_reference(lambda: dipole_field(obs, pos, mom))}
    res = interleaved(fns, repeat)
    ours, ref = dipole_field(obs, pos, mom), magpylib_core()
    err = float(np.abs(ours - ref).max() / np.abs(ref).max())
    pairs = n_obs * n_dip
    print(f"(a) {pairs:.0e} pairs ({n_obs} observers x {n_dip} dipoles), Mpairs/s from the min "
          f"[median] time, ratio of min times; max rel. diff. vs magpylib {err:.1e}; per pair "
          f"1 divide + 1 sqrt + {PAIR_FLOPS} flops; clock {clock_mhz()} MHz; magcilia at "
          f"{pairs * (PAIR_FLOPS + 2) / res['magcilia'][0] / 1e9:.1f} GFLOP/s, "
          f"{res['div+sqrt only'][0] / res['magcilia'][0]:.2f} of the divide+sqrt bound, "
          f"{res['plain numba'][0] / res['magcilia'][0]:.2f}x the plain kernel (target >= 0.9)")
    base = res["magcilia"][0]
    for name, (t_min, t_med) in res.items():
        print(f"    {name:<16} {pairs / t_min / 1e6:9.1f} [{pairs / t_med / 1e6:9.1f}]  "
              f"{t_min / base:7.1f}x")


def output_bench(repeat: int) -> None:
    setup = mc.Setup.paper()  # n = 2, k = 5: n·k = 10
    spec = setup.spec
    body, weights = spec.body_dipoles
    rot = Rotation.from_rotvec(ANGLES[:, None] * np.array([0.0, 1.0, 0.0]))
    # each dipole with a 33-pose path: positions and orientations (moment along its local z)
    dips = [magpy.misc.Dipole(moment=(0.0, 0.0, m), position=rot.apply(p) + spec.base_centre,
                              orientation=rot) for p, m in zip(body, weights, strict=True)]
    # one Collection of the dipoles, rotated about the base centre along a 33-pose path
    coll = magpy.Collection(*[magpy.misc.Dipole(moment=(0.0, 0.0, m), position=p + spec.base_centre)
                              for p, m in zip(body, weights, strict=True)])
    coll.rotate_from_angax(np.degrees(ANGLES), "y", anchor=spec.base_centre, start=0)
    origin = np.zeros(3)
    fns = {
        "magcilia setup.output": lambda: setup.output(ANGLES),
        "magpylib Dipole paths": lambda: spec.scale * magpy.getB(dips, origin, sumup=True)[:, 0],
        "magpylib Collection path": lambda: spec.scale * coll.getB(origin)[:, 0],
        "magcilia NumPy": numpy_reference(lambda: setup.output(ANGLES)),
    }
    for fn in list(fns.values())[1:3]:
        np.testing.assert_allclose(fn(), setup.output(ANGLES), rtol=1e-12)
    res = interleaved(fns, repeat, number=200)
    print("(b) one setup.output call, 33 angles, n*k = 10 (target <= 20 us): us per call, min "
          "[median], ratio of min times")
    base = res["magcilia setup.output"][0]
    for name, (t_min, t_med) in res.items():
        print(f"    {name:<26} {t_min * 1e6:9.1f} [{t_med * 1e6:9.1f}]  {t_min / base:7.1f}x")


def batch_bench(repeat: int) -> None:
    rng = np.random.default_rng(1)
    size = 128
    params = {"height": rng.uniform(2e-3, 4e-3, size), "base_radius": rng.uniform(1e-4, 3e-4, size),
              "x": rng.uniform(-3e-3, 3e-3, size), "y": rng.uniform(-3e-3, 3e-3, size),
              "z": rng.uniform(0.0, 1e-3, size), "n_loops": rng.integers(1, 11, size),
              "dipoles_per_loop": rng.integers(1, 11, size),
              "magnetization_scale": rng.uniform(0.1, 1.0, size)}
    batch = TiltBatch(mc.Setup.paper(), ANGLES)
    fns = {"compiled": lambda: batch.output(params),
           "NumPy": numpy_reference(lambda: batch.output(params))}
    ours, ref = fns["compiled"](), fns["NumPy"]()
    err = float((np.abs(ours - ref).max(axis=1) / np.abs(ref).max(axis=1)).max())
    res = interleaved(fns, repeat, number=5)
    print(f"(c) TiltBatch.output, {size} sets (n, k in 1..10), 33 angles: evaluations/s from the "
          f"min [median] time, ratio of min times; max rel. diff. {err:.1e}")
    base = res["compiled"][0]
    for name, (t_min, t_med) in res.items():
        print(f"    {name:<10} {size / t_min:12.0f} [{size / t_med:12.0f}]  {t_min / base:7.1f}x  "
              f"({t_min * 1e6:.0f} us per population)")


FIRST_CALL = """
import time
t0 = time.perf_counter()
import numpy as np, magcilia as mc
from magcilia.model.kernels import dipole_field
t1 = time.perf_counter()
mc.Setup.paper().output(np.radians(np.linspace(0.0, 85.0, 33)))
t2 = time.perf_counter()
dipole_field(np.zeros((2, 3)), np.ones((3, 3)), np.ones((3, 3)))
t3 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2)
"""


def cache_bench() -> None:
    print("(d) first calls in a fresh process, s (tilt: numba import + tilt kernel; dipole: "
          "dipole kernel)")
    with tempfile.TemporaryDirectory() as cache_dir:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache_dir}
        for label in ("cold cache (compile)", "warm cache (load)   "):
            out = subprocess.run([sys.executable, "-c", FIRST_CALL], env=env, check=True,
                                 capture_output=True, text=True).stdout.split()
            t_import, t_tilt, t_dipole = (float(x) for x in out)
            print(f"    {label}: tilt {t_tilt:6.3f}  dipole {t_dipole:6.3f}  total "
                  f"{t_tilt + t_dipole:6.3f}   (import magcilia {t_import:.3f})")


def cpu_name() -> str:
    """The processor's model name (Linux), else the machine type."""
    try:
        lines = Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines()
        return next(ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("model name"))
    except (OSError, StopIteration):
        return platform.machine()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    args = parser.parse_args()
    repeat = 3 if args.quick else 7
    print(f"magcilia field benchmark, one thread; {cpu_name()}, Python "
          f"{platform.python_version()}, magpylib {magpy.__version__}")
    sizes = [(1000, 1000)] if args.quick else [(1000, 1000), (10_000, 1000), (100, 100_000)]
    for n_obs, n_dip in sizes:
        pairs_bench(n_obs, n_dip, repeat)
    output_bench(repeat)
    batch_bench(repeat)
    cache_bench()


if __name__ == "__main__":
    main()
