"""Exact-body synthetic coil recordings and a batched local fit over many noise draws (for the
coil calibration's coverage tests): the truth bent by mc.bend(..., actuation=) and its field from
the exact cylinder stack (magpylib), plus the applied field, offsets and Gaussian noise."""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

import magcilia as mc
from magcilia.calibration.coil_model import coil_bounds
from magcilia.calibration.joint import YOUNGS_BOUNDS, joint_problem
from magcilia.calibration.joint_result import joint_result
from magcilia.calibration.layout import converged_layout
from magcilia.calibration.problem import DEFAULT_BOUNDS
from magcilia.io.recordings import Measurement
from magcilia.model.exact import exact_field

F64 = NDArray[np.float64]
#: the force-sensor cilium (examples/force-sensor.toml: the paper's Table I cilium and placement,
#: a 0.05 mm tip, the composite's modulus 0.669 MPa from docs/stiffness.md), magnetized at 0.8 of
#: φ·M_Co (multi-domain particles below saturation, NOTES §2)
TRUTH = {"height": 3.2613e-3, "base_radius": 1.801e-4, "tip_radius": 5e-5,
         "youngs_modulus": 6.69e5, "magnetization_scale": 0.8}
OFFSETS = np.array([2e-5, -3e-5, 4e-5])  # the Earth's field and the part's own, T
NAMES = ("height", "base_radius", "x", "y", "z", "youngs_modulus", "magnetization_scale")


def truth(**kw: float) -> mc.Setup:
    return mc.Setup.paper(**{**TRUTH, **kw})


def exact_cilium(setup: mc.Setup, applied: F64, slices: int = 400) -> F64:
    """The cilium's own field at the element (a, 3), T, under each applied field: mc.bend with
    the uniform actuation, then the exact cylinder stack of the bent shape."""
    return np.array([exact_field(setup, mc.bend(setup, 0.0, actuation=mc.Actuation.uniform(b)),
                                 slices)[0] for b in applied])


def recording(applied: F64, cilium: F64, se: float, rng: np.random.Generator,
              source: str = "coil") -> Measurement:
    """A 3-axis coil recording: per-condition means with Gaussian noise of s.e. ``se`` (T)."""
    a = applied.shape[0]
    fields = cilium + applied + OFFSETS + se * rng.standard_normal((a, 3))
    return Measurement(np.zeros(a), np.full(a, np.nan), np.full(a, np.nan), np.full(a, 2000),
                       np.zeros(a, np.int64), np.zeros(a, np.int64), source=source,
                       fields=fields, field_sem=np.full((a, 3), se), actuation=applied)


def local_fits(setup: mc.Setup, recs: list[Measurement], heights: F64, sigma: float
               ) -> tuple[F64, F64]:
    """Each recording's fit with its height prior (``heights`` (S,) ± ``sigma``, m: a measured
    height, itself drawn around the truth), values (S, p) and the tool's standard errors (S, p),
    the local minimum from the truth by a trust-region least-squares fit (SciPy's, in coordinates
    relative to the truth, the Jacobian's columns by central differences in one model call; the
    recordings share one problem's model, only their data differ), the standard errors from the
    result the calibration gives
    (:func:`~magcilia.calibration.joint_result.joint_result` at each minimum)."""
    lay = converged_layout(setup)
    box = {**DEFAULT_BOUNDS, "youngs_modulus": YOUNGS_BOUNDS, **coil_bounds(setup)}
    box = {n: box[n] for n in NAMES}
    problems = [joint_problem([m], setup, lay, box, NAMES, {"height": (float(h), sigma)})
                for m, h in zip(recs, heights, strict=True)]
    first = problems[0]
    ry = np.stack([p.ry for p in problems])
    x0 = np.array([{**setup.params(), "youngs_modulus": setup.youngs_modulus}[n] for n in NAMES])

    def residuals(x: F64, which: NDArray[np.intp]) -> F64:
        r, _ = first.linear(first.model(x))
        r = r - first.ry + ry[which]
        return np.concatenate([r, (x[:, :1] - heights[which, None]) / sigma], axis=1)

    p = x0.size
    h = 1e-6
    best = []
    for i in range(len(recs)):  # a trust-region fit in coordinates relative to the truth
        one = np.array([i])

        def fun(z: F64, i: np.ndarray = one) -> F64:
            return residuals((x0 * (1.0 + z))[None], i)[0]

        def jac(z: F64, i: np.ndarray = one) -> F64:
            probe = x0 * (1.0 + np.concatenate([z + np.eye(p) * h, z - np.eye(p) * h]))
            r = residuals(probe, np.repeat(i, 2 * p))  # every column in one model call
            return np.asarray(((r[:p] - r[p:]) / (2.0 * h)).T)

        fit = least_squares(fun, np.zeros(p), jac=jac, method="trf", x_scale="jac",
                            bounds=(first.bounds[:, 0] / x0 - 1.0, first.bounds[:, 1] / x0 - 1.0),
                            xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=400)
        best.append(x0 * (1.0 + fit.x))
    results = [joint_result(p, lay, setup, box, x, False, time.perf_counter())
               for p, x in zip(problems, best, strict=True)]
    se = np.array([[r.uncertainty.stderr[n] for n in NAMES] for r in results])
    return np.array(best), se
