"""The fused tilt kernel (issue 27, item 1) against its bound and a plain numba reference, one
thread, interleaved in this process (min and median of the runs).

The kernel (``magcilia.model.compiled.tilt_batch``) lays out each parameter set's n·k ring dipoles
and sums their field at the sensing element tilted by each angle, angles innermost; its
derivative pass (``tilt_jacobian_batch``, the calibration's analytic Jacobian) does the same with
the gradient. Contenders, per dipole·angle pair:

* ``tilt_batch``: 1 divide + 1 square root + 18 other flops a pair (v (2), |v|² (4), m/r³ (2),
  3 (m·v)/r⁵ (3), the three sums (7));
* ``tilt_jacobian_batch`` (output and its 6 derivatives): 1 divide + 1 square root + 45 flops;
* a plain numba reference of ``tilt_batch``: per set and angle, one loop over all the dipoles with
  scalar sums (what one would write first), no work arrays, no blocking;
* the bound: a loop of just the divide and square root (compiled alike), the clock beside it;
* blocking: ``tilt_batch`` as shipped (angles in blocks of ``ANGLE_BLOCK``) against the same code
  with one block, at many angles (a sweep), where the blocks would matter if they did.

Populations: 256 parameter sets with n and k drawn in 1..10 (the calibration's), 33 angles; one set
at 100,000 angles.

Run: python benchmarks/bench_tilt_kernel.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import math
import types
from collections.abc import Callable

import numba
import numpy as np
from bench_field import _bound_kernel, clock_mhz, cpu_name, interleaved

import magcilia as mc
from magcilia.constants import MU0_OVER_4PI
from magcilia.model import compiled
from magcilia.model.batch import TiltBatch, pack

#: flops of one pair besides its divide and square root (see the module docstring)
VALUE_FLOPS, JACOBIAN_FLOPS = 18, 45


def _plain_tilt(params, angles, ring, share, out):  # type: ignore[no-untyped-def]
    """The reference: per set and angle, one loop over the dipoles (numba source); ``ring`` and
    ``share`` (N, n_max) are each set's ring radii (m) and moments (A·m² per dipole)."""
    ca, sa = np.empty(16), np.empty(16)
    for i in range(params.shape[0]):
        h, n, k = params[i, 0], int(params[i, 6]), int(params[i, 7])
        rx, ry, rz = -params[i, 3], -params[i, 4], -params[i, 5]
        for m in range(k):  # the ring's azimuths, once per set
            ca[m], sa[m] = math.cos(2.0 * math.pi * m / k), math.sin(2.0 * math.pi * m / k)
        for t in range(angles.size):
            c, s = math.cos(angles[t]), math.sin(angles[t])
            ox, oz = c * rx - s * rz, s * rx + c * rz
            bx, bz = 0.0, 0.0
            for j in range(n):
                pz = h * (j + 0.5) / n
                for m in range(k):
                    vx = ox - ring[i, j] * ca[m]
                    vy = ry - ring[i, j] * sa[m]
                    vz = oz - pz
                    ir2 = 1.0 / (vx * vx + vy * vy + vz * vz)
                    mr3 = share[i, j] * ir2 * math.sqrt(ir2)
                    q = 3.0 * vz * mr3 * ir2
                    bx += q * vx
                    bz += q * vz - mr3
            out[i, t] = MU0_OVER_4PI * (c * bx + s * bz)


def _population(size: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"height": rng.uniform(2e-3, 4e-3, size), "base_radius": rng.uniform(1e-4, 4e-4, size),
            "x": rng.choice([-1.0, 1.0], size) * rng.uniform(1e-3, 3e-3, size),
            "y": rng.uniform(-3e-3, 3e-3, size), "z": rng.uniform(0.0, 1e-3, size),
            "n_loops": rng.integers(1, 11, size), "dipoles_per_loop": rng.integers(1, 11, size)}


def _plain_inputs(setup: mc.Setup, packed: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Ring radii and per-dipole moments of each set (the layout, outside the timed loop)."""
    from magcilia.model import body

    size, n_max = packed.shape[0], int(packed[:, 6].max())
    ring, share = np.zeros((size, n_max)), np.zeros((size, n_max))
    for i in range(size):
        n, k = int(packed[i, 6]), int(packed[i, 7])
        u, rho = body.frustum_shape(packed[i, 2])
        radius, _ = body.slice_rings(u, rho[0] if rho.ndim > 1 else rho, n, setup.ring)
        mean2, _ = body.slice_means(u, rho[0] if rho.ndim > 1 else rho, n)
        ring[i, :n] = packed[i, 1] * radius
        share[i, :n] = packed[i, 8] * math.pi * packed[i, 0] * packed[i, 1] ** 2 * mean2 / (n * k)
    return ring, share


def _one_block() -> Callable[..., bool]:
    """``tilt_batch`` compiled with all angles in one block (``ANGLE_BLOCK`` = 2⁶²)."""
    glob = dict(compiled.tilt_batch.__globals__)
    glob["ANGLE_BLOCK"] = 1 << 62
    fn = types.FunctionType(compiled.tilt_batch.__code__, glob, "tilt_batch_one_block")
    return numba.njit(fn, error_model="numpy", nogil=True)  # type: ignore[no-any-return]


def population_bench(repeat: int) -> None:
    setup = mc.Setup.paper_initial()
    angles = np.radians(np.linspace(0.0, 85.0, 33))
    batch = TiltBatch(setup, angles)
    params = _population(256)
    spec = batch.spec
    packed = pack(spec, params)
    pairs = float((packed[:, 6] * packed[:, 7]).sum() * angles.size)
    jit = compiled.kernels()
    assert jit is not None
    out1, out3 = np.empty((256, angles.size, 1)), np.empty((256, angles.size, 1, 6))
    ring, share = _plain_inputs(setup, packed)
    plain = numba.njit(_plain_tilt, error_model="numpy", nogil=True,
                       fastmath={"reassoc", "contract"})
    plain_out = np.empty((256, angles.size))
    bound = numba.njit(_bound_kernel, error_model="numpy", nogil=True,
                       fastmath={"reassoc", "contract"})
    r2 = 1.0 + np.random.default_rng(0).random(1000)
    a = angles.copy()
    fns = {
        "tilt_batch": lambda: jit.tilt_batch(packed, a, spec.knots, spec.radii, False, False,
                                             spec.scale, out1),
        "tilt_jacobian_batch": lambda: jit.tilt_jacobian_batch(
            packed, a, spec.knots, spec.radii, False, False, spec.scale, out1, out3),
        "plain numba": lambda: plain(packed, a, ring, share, plain_out),
        "div+sqrt only": lambda: bound(r2, int(pairs) // r2.size),
    }
    res = interleaved(fns, repeat, number=5)
    jit.tilt_batch(packed, a, spec.knots, spec.radii, False, False, spec.scale, out1)
    ours = (out1[..., 0] - packed[:, 9:10]) / spec.scale
    plain(packed, a, ring, share, plain_out)
    err = float(np.abs(ours - plain_out).max() / np.abs(plain_out).max())
    t_val, t_jac, t_bound = res["tilt_batch"][0], res["tilt_jacobian_batch"][0], \
        res["div+sqrt only"][0]
    print(f"(a) 256 sets (n, k in 1..10), 33 angles: {pairs:.3g} dipole-angle pairs; clock "
          f"{clock_mhz()} MHz; max rel. diff. plain vs kernel {err:.1e}")
    print(f"    per pair: tilt_batch 1 divide + 1 sqrt + {VALUE_FLOPS} flops, "
          f"{pairs * (VALUE_FLOPS + 2) / t_val / 1e9:.1f} GFLOP/s, {t_bound / t_val:.2f} of the "
          f"divide+sqrt bound, {res['plain numba'][0] / t_val:.2f}x the plain kernel; "
          f"tilt_jacobian_batch 1 + 1 + {JACOBIAN_FLOPS} flops, "
          f"{pairs * (JACOBIAN_FLOPS + 2) / t_jac / 1e9:.1f} GFLOP/s, {t_bound / t_jac:.2f} of "
          f"the bound, {t_jac / t_val:.2f}x tilt_batch's time (one pass for 7 columns where "
          "forward differences take 6 passes)")
    print("    Mpairs/s from the min [median] time, ratio of min times")
    for name, (t_min, t_med) in res.items():
        print(f"    {name:<20} {pairs / t_min / 1e6:9.1f} [{pairs / t_med / 1e6:9.1f}]  "
              f"{t_min / t_val:7.2f}x")


def blocking_bench(repeat: int, n_angles: int) -> None:
    setup = mc.Setup.paper_initial()
    spec = TiltBatch(setup, [0.0]).spec
    angles = np.linspace(-0.5, 1.5, n_angles)
    packed = pack(spec, {"n_loops": np.array([10]), "dipoles_per_loop": np.array([10])})
    jit = compiled.kernels()
    assert jit is not None
    one = _one_block()
    out_a, out_b = np.empty((1, n_angles, 1)), np.empty((1, n_angles, 1))
    fns = {
        f"blocks of {compiled.ANGLE_BLOCK}": lambda: jit.tilt_batch(
            packed, angles, spec.knots, spec.radii, False, False, spec.scale, out_a),
        "one block": lambda: one(packed, angles, spec.knots, spec.radii, False, False,
                                 spec.scale, out_b),
    }
    res = interleaved(fns, repeat, number=3)
    np.testing.assert_array_equal(out_a, out_b)
    pairs = 100.0 * n_angles
    print(f"(b) one set, n*k = 100, {n_angles} angles: angle blocks (ANGLE_BLOCK) against one "
          "block, Mpairs/s min [median]")
    base = res[f"blocks of {compiled.ANGLE_BLOCK}"][0]
    for name, (t_min, t_med) in res.items():
        print(f"    {name:<20} {pairs / t_min / 1e6:9.1f} [{pairs / t_med / 1e6:9.1f}]  "
              f"{t_min / base:7.2f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    args = parser.parse_args()
    repeat = 3 if args.quick else 9
    print(f"magcilia tilt-kernel benchmark, one thread; {cpu_name()}; load average "
          f"{os.getloadavg()[0]:.2f}")
    population_bench(repeat)
    blocking_bench(repeat, 10_000 if args.quick else 100_000)


if __name__ == "__main__":
    main()
