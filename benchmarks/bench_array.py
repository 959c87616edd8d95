"""Arrays of cilia: forward map and inverse beside their anchors (issues 15 and 27), one thread.

(a) Forward, 64 cilia x 64 sensors: an 8 x 8 array of the paper's cilium (n*k = 2*5 = 10 dipoles
    each, tip radius 50 um, E = 1 MPa, 2 mm pitch), one 3-axis sensor under each cilium, bent by
    seeded random horizontal tip forces. The read-out's forward map, forces -> field at the 64
    sensors through the load tables (``ArrayReadout.field``: one fused kernel, issue 27's target
    <= 0.2 ms), beside the path it replaced (the tables' frames, ``ArrayLayout.planar_dipoles``
    and the compiled segment sum, the results checked equal), and the exact-shape route
    ``CiliaArray.field(poses)`` beside magpylib (a ``Collection`` of the 640 ``Dipole``s, and its
    vectorised core ``dipole_Hfield`` x mu0 over the 40 960 pairs, summed per sensor).
(b) Inverse at 1 kHz (issue 27: <= 1 ms per frame, warm-started, analytic Jacobian): the 16
    cilia over 16 magnetometers of examples/array.toml (32 force components from 48 readings),
    a stream of frames 1 ms apart, every cilium's load turning and swelling slowly (0.2-0.8 of
    the span, 1-5 Hz), the exact elastica's field at every frame, the sensors' noise. Per frame:
    magcilia one frame per call warm from the frame before (``ArrayReadout.stream().read``, the
    live path), the whole stream in one ``read`` (blocks warm-chained), one frame per call cold
    (from rest); the anchor, what an ordinary user writes: SciPy ``least_squares`` (trf) one
    frame at a time on the same whitened residuals and Tikhonov rows, with the same analytic
    Jacobian, warm from the frame before. The 64 x 64 array's inverse the same way, fewer
    frames.

Every contender runs in this process, interleaved; min and median per call and the ratio of the
minima are printed, with the machine and its load (the machine is shared: compare ratios).

Run: python benchmarks/bench_array.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import math
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
from magcilia.model.array import segment_field
from magcilia.model.array_tabulated import table_field
from magcilia.readout.array import ArrayReadout, field_for_loads, loaded_poses

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_field import cpu_name, interleaved

SPAN = 2e-5  # N
PART = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0,
                    name="3-axis")


def grid(rows: int = 8) -> tuple[CiliaArray, np.ndarray]:
    setup = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0.0, 0.0, 0.0))
    array = CiliaArray.grid(setup, rows, rows, 2e-3, sensor=PART)
    forces = np.random.default_rng(0).uniform(-0.7, 0.7, (len(array), 2)) * SPAN
    return array, forces


def cpu_time(fn: Callable[[], object]) -> float:
    """This process's CPU time (s) of one call of ``fn``."""
    t0 = time.process_time()
    fn()
    return time.process_time() - t0


def show(title: str, res: dict[str, tuple[float, float]], base: str, unit: float,
         label: str) -> None:
    print(title)
    ref = res[base][0]
    for name, (t_min, t_med) in res.items():
        print(f"    {name:<46} {t_min / unit:9.3f} [{t_med / unit:9.3f}] {label}  "
              f"{t_min / ref:7.2f}x")


def forward_bench(repeat: int) -> None:
    array, forces = grid()
    readout = ArrayReadout(array, SPAN)
    lay = array.layout
    obs = np.asarray(array.sensor_positions)

    def before() -> np.ndarray:  # the tables' frames, the layout's dipoles, the segment sum
        pos, mom = lay.planar_dipoles(*readout._frames(forces[None]))
        return np.asarray(segment_field(obs, pos[0], mom[0], lay.starts).sum(axis=0))

    poses = loaded_poses(array, forces)
    pos, mom, _ = array.dipoles(poses)
    coll = magpy.Collection(*[magpy.misc.Dipole(position=p, moment=m)
                              for p, m in zip(pos, mom, strict=True)])
    m_rep = np.tile(mom, (obs.shape[0], 1))

    def magpylib_core() -> np.ndarray:
        r = (obs[:, None, :] - pos[None, :, :]).reshape(-1, 3)
        h = magpy.core.dipole_Hfield(r, m_rep)
        return np.asarray(MU0 * h.reshape(obs.shape[0], pos.shape[0], 3).sum(axis=1))

    ours = readout.field(forces)
    diff = float(np.abs(before() - ours).max() / np.abs(ours).max())
    exact = array.field(poses)
    diff_exact = max(float(np.abs(np.asarray(fn()) - exact).max() / np.abs(exact).max())
                     for fn in (lambda: coll.getB(obs), magpylib_core))
    res = interleaved({
        "ArrayReadout.field (tables, fused kernel)": lambda: readout.field(forces),
        "the path before (frames, dipoles, segments)": before,
        "CiliaArray.field(poses) (exact shapes)": lambda: array.field(poses),
        "magpylib Collection.getB (exact shapes)": lambda: coll.getB(obs),
        "magpylib core dipole_Hfield (exact shapes)": magpylib_core,
    }, repeat, number=20)
    show(f"(a) forward map, {len(array)} cilia x {array.n_sensors} sensors, {pos.shape[0]} "
         f"dipoles (issue 27: <= 0.2 ms): ms per call, min [median], ratio of min times; the "
         f"fused kernel vs the path before: max rel. diff. {diff:.1e}; magpylib vs "
         f"CiliaArray.field {diff_exact:.1e}", res,
         "ArrayReadout.field (tables, fused kernel)", 1e-3, "ms")


def stream(array: CiliaArray, frames: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Forces (frames, C, 2) 1 ms apart and their noisy readings (frames, 3 S)."""
    rng = np.random.default_rng(seed)
    c_n = len(array)
    t = np.arange(frames) * 1e-3
    f_turn = rng.uniform(1.0, 5.0, c_n)
    f_size = rng.uniform(1.0, 3.0, c_n)
    phase = rng.uniform(-np.pi, np.pi, (2, c_n))
    size = SPAN * (0.5 + 0.3 * np.sin(2 * np.pi * f_size * t[:, None] + phase[0]))
    ang = 2 * np.pi * f_turn * t[:, None] + phase[1]
    forces = np.stack([size * np.cos(ang), size * np.sin(ang)], axis=-1)
    fields = np.array([field_for_loads(array, f) for f in forces])
    return forces, array.readings(fields, rng=rng).reshape(frames, -1)


def inverse_bench(name: str, array: CiliaArray, span: float, frames: int, repeat: int) -> None:
    readout = ArrayReadout(array, span)
    forces, y = stream(array, frames, seed=1)
    c_n = len(array)
    model = readout._model[0]
    spans = np.repeat(readout.span, 2)
    w = 1.0 / readout.sigma
    root_alpha = math.sqrt(readout.regularization)

    def residuals(x: np.ndarray, yk: np.ndarray) -> np.ndarray:
        f, _ = table_field(model, (x * spans).reshape(1, c_n, 2))
        return np.concatenate([w * (f[0] - yk), root_alpha * x])

    def jacobian(x: np.ndarray, _yk: np.ndarray) -> np.ndarray:
        _, jac = table_field(model, (x * spans).reshape(1, c_n, 2), jacobian=True)
        assert jac is not None
        return np.concatenate([w[:, None] * jac[0] * spans, root_alpha * np.eye(2 * c_n)])

    first = readout.read(y[0])

    def scipy_warm() -> np.ndarray:
        x = (first.force / readout.span[:, None]).reshape(-1)
        out = np.empty((frames - 1, c_n, 2))
        for k in range(1, frames):
            x = least_squares(residuals, x, jac=jacobian, args=(y[k],), method="trf").x
            out[k - 1] = x.reshape(c_n, 2) * readout.span[:, None]
        return out

    def warm_one_by_one() -> np.ndarray:
        s = readout.stream()
        s.read(y[0])
        return np.array([s.read(y[k]).force for k in range(1, frames)])

    def batch() -> np.ndarray:
        return np.asarray(readout.read(y[1:]).force)

    def cold() -> np.ndarray:
        return np.array([readout.read(y[k]).force for k in range(1, frames)])

    ours = warm_one_by_one()
    est = readout.read(y[1:])
    sig = est.sigma
    diffs = {"batch": batch(), "cold": cold(), "scipy": scipy_warm()}
    gap = {k: float(np.max(np.abs(v - ours) / sig)) for k, v in diffs.items()}
    within = float(np.mean(np.abs(ours - forces[1:]) <= 2.0 * sig))
    warm_iter = [readout.read(y[k], start=ours[k - 2] if k > 1 else first.force).iterations
                 for k in range(1, frames)]
    cold_iter = [readout.read(y[k]).iterations for k in range(1, frames)]
    n = frames - 1
    fns: dict[str, Callable[[], object]] = {
        "magcilia, one frame per call, warm (stream)": warm_one_by_one,
        "magcilia, all frames in one read (warm blocks)": batch,
        "magcilia, one frame per call, cold": cold,
        "SciPy least_squares + analytic Jacobian, warm": scipy_warm,
    }
    res = {k: (t_min / n, t_med / n) for k, (t_min, t_med) in
           interleaved(fns, repeat).items()}
    cpu = {k: min(cpu_time(fns[k]) for _ in range(3)) / n for k in
           ("magcilia, one frame per call, warm (stream)",
            "magcilia, all frames in one read (warm blocks)")}
    show(f"(b) inverse, {name}: {c_n} force vectors from {y.shape[1]} readings, {n} frames 1 ms "
         f"apart (issue 27: <= 1 ms per frame): ms per frame, min [median], ratio of min times; "
         f"iterations per frame warm {np.mean(warm_iter):.2f}, cold {np.mean(cold_iter):.2f}; "
         f"components within 2 sigma of the truth {within:.0%}; largest difference from the warm "
         f"stream, in sigma: batch {gap['batch']:.1e}, cold {gap['cold']:.1e}, SciPy "
         f"{gap['scipy']:.1e}", res, "magcilia, one frame per call, warm (stream)", 1e-3, "ms")
    print("    this process's CPU time per frame (min of 3; on a shared machine closer to a quiet "
          "run's wall time): " + ", ".join(f"{k} {t * 1e3:.3f} ms" for k, t in cpu.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    args = parser.parse_args()
    repeat = 3 if args.quick else 7
    print(f"magcilia array benchmark, one thread; {cpu_name()}, Python "
          f"{platform.python_version()}, magpylib {magpy.__version__}, numba "
          f"{'on' if compiled.kernels() is not None else 'off'}; load average "
          f"{os.getloadavg()[0]:.2f} at the start")
    forward_bench(repeat)
    example = mc.presets.load("array")
    inverse_bench("examples/array.toml (4 x 4)", example, 2e-5, 41 if args.quick else 201,
                  repeat)
    array, _ = grid()
    inverse_bench("8 x 8 grid of (a)", array, SPAN, 11 if args.quick else 41, repeat)
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
