"""Arrays of cilia: forward field and inverse, side by side with magpylib (issue 15), one thread.

An 8 × 8 array of the paper's cilium (n·k = 2·5 = 10 dipoles each, tip radius 50 µm, E = 1 MPa,
2 mm pitch) over 64 three-axis sensors, one under each cilium; the cilia bent by seeded random
horizontal tip forces (exact elastica, turned to their azimuths). Every contender runs in this
process, interleaved; min and median per call and the ratio of the minima are printed.

  (a) forward field at the 64 sensors (target ≤ 1 ms): ``CiliaArray.field(poses)`` (layout of
      the 640 dipoles from the 64 shapes, the sensors-inside check, the compiled superposition),
      the same dipoles as a ``magpylib.Collection`` of 640 ``Dipole`` objects (``getB`` at the 64
      sensor positions), magpylib's vectorised core ``core.dipole_Hfield`` × μ0 on the 40 960
      observer–dipole pairs summed per sensor (the fastest ordinary use), and magcilia's NumPy
      reference (compiled kernels off);
  (b) inverse: 64 force vectors from the 192 readings (target ≤ 20 ms after construction; the
      construction, tables and checks, timed apart): ``ArrayReadout.read`` of one set, the same
      per set of 32 sets read at once (``read`` of samples (32, 192): one batched fit), beside
      SciPy's ``least_squares`` (trust region, 2-point Jacobian) on the same model evaluated
      through magpylib's core, from the same linear start.

Run: python benchmarks/bench_array.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path

import magpylib as magpy
import numpy as np
from scipy.optimize import least_squares

import magcilia as mc
from magcilia.constants import MU0
from magcilia.device.array import CiliaArray
from magcilia.device.magnetometer import Magnetometer
from magcilia.model import compiled
from magcilia.readout.array import ArrayReadout, loaded_poses

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_field import cpu_name, interleaved, numpy_reference

SPAN = 2e-5  # N
PART = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0,
                    name="3-axis")


def build(rows: int = 8) -> tuple[CiliaArray, np.ndarray]:
    setup = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0.0, 0.0, 0.0))
    array = CiliaArray.grid(setup, rows, rows, 2e-3, sensor=PART)
    forces = np.random.default_rng(0).uniform(-0.7, 0.7, (len(array), 2)) * SPAN
    return array, forces


def forward_bench(repeat: int) -> None:
    array, forces = build()
    poses = loaded_poses(array, forces)
    pos, mom, _ = array.dipoles(poses)
    obs = np.asarray(array.sensor_positions)
    coll = magpy.Collection(*[magpy.misc.Dipole(position=p, moment=m)
                              for p, m in zip(pos, mom, strict=True)])
    m_rep = np.tile(mom, (obs.shape[0], 1))

    def magpylib_core() -> np.ndarray:
        r = (obs[:, None, :] - pos[None, :, :]).reshape(-1, 3)
        h = magpy.core.dipole_Hfield(r, m_rep)
        return MU0 * h.reshape(obs.shape[0], pos.shape[0], 3).sum(axis=1)

    fns: dict[str, Callable[[], object]] = {
        "magcilia array.field": lambda: array.field(poses),
        "magcilia, no check": lambda: array.field(poses, check=False),
        "magpylib Collection": lambda: coll.getB(obs),
        "magpylib core": magpylib_core,
        "magcilia NumPy": numpy_reference(lambda: array.field(poses)),
    }
    ours = array.field(poses)
    err = max(float(np.abs(np.asarray(fn()) - ours).max() / np.abs(ours).max())
              for fn in list(fns.values())[1:])
    res = interleaved(fns, repeat, number=20)
    print(f"(a) forward field, {len(array)} cilia x {array.n_sensors} sensors, n*k = 10 "
          f"({pos.shape[0]} dipoles; target <= 1 ms): us per call, min [median], ratio of min "
          f"times; max rel. diff. {err:.1e}")
    base = res["magcilia array.field"][0]
    for name, (t_min, t_med) in res.items():
        print(f"    {name:<22} {t_min * 1e6:9.1f} [{t_med * 1e6:9.1f}]  {t_min / base:7.2f}x")


def inverse_bench(repeat: int) -> None:
    array, forces = build()
    t0 = time.perf_counter()
    readout = ArrayReadout(array, SPAN)
    t_build = time.perf_counter() - t0
    field = array.field(loaded_poses(array, forces))
    readings = array.readings(field, rng=1)
    obs = np.asarray(array.sensor_positions)
    sigma = array.sigma.reshape(-1)
    n_c = len(array)
    lay = array.layout

    def magpylib_model(x: np.ndarray) -> np.ndarray:
        f = x.reshape(n_c, 2) * SPAN
        xx, zz, th, phi = readout._frames(f)
        pos, mom = lay.planar_dipoles(xx, zz, th, phi)
        r = (obs[:, None, :] - pos[None, :, :]).reshape(-1, 3)
        h = magpy.core.dipole_Hfield(r, np.tile(mom, (obs.shape[0], 1)))
        b = MU0 * h.reshape(obs.shape[0], pos.shape[0], 3).sum(axis=1)
        return np.asarray(array.to_sensor(b).reshape(-1))

    y = readings.reshape(-1)
    jw = readout.jacobian / sigma[:, None] * SPAN
    start = np.linalg.solve(jw.T @ jw, jw.T @ ((y - readout.rest.reshape(-1)) / sigma))

    def scipy_magpylib() -> np.ndarray:
        sol = least_squares(lambda x: (y - magpylib_model(x)) / sigma, start, method="trf",
                            x_scale="jac")
        return np.asarray(sol.x.reshape(n_c, 2) * SPAN)

    est = readout.read(readings)
    other = scipy_magpylib()
    diff = float(np.abs(other - est.force).max() / est.sigma.min())
    batch = 32
    samples = np.array([array.readings(field, rng=k) for k in range(batch)]).reshape(batch, -1)
    res = interleaved({"magcilia ArrayReadout.read": lambda: readout.read(readings)}, repeat,
                      number=5)
    per_set = interleaved({"magcilia read of 32 sets, per set": lambda: readout.read(samples)},
                          max(1, repeat // 3), number=1)
    res.update({k: (t_min / batch, t_med / batch) for k, (t_min, t_med) in per_set.items()})
    slow = interleaved({"scipy least_squares + magpylib core": scipy_magpylib}, 1, number=1)
    within = float(np.mean(np.abs(est.force - forces) <= 2.0 * est.sigma))
    print(f"(b) inverse, {n_c} force vectors from {y.size} readings (target <= 20 ms after "
          f"construction): ms per call, min [median], ratio of min times; construction "
          f"{t_build * 1e3:.0f} ms (tables, crosstalk matrix, reach and singularity checks); "
          f"{est.iterations} iterations; components within 2 sigma {within:.0%}; scipy vs "
          f"magcilia max diff {diff:.1e} sigma")
    base = res["magcilia ArrayReadout.read"][0]
    for name, (t_min, t_med) in {**res, **slow}.items():
        print(f"    {name:<36} {t_min * 1e3:9.2f} [{t_med * 1e3:9.2f}]  {t_min / base:8.1f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    args = parser.parse_args()
    repeat = 3 if args.quick else 9
    print(f"magcilia array benchmark, one thread; {cpu_name()}, Python "
          f"{platform.python_version()}, magpylib {magpy.__version__}, numba "
          f"{'on' if compiled.kernels() is not None else 'off'}")
    forward_bench(repeat)
    inverse_bench(repeat)


if __name__ == "__main__":
    main()
