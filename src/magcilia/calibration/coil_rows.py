"""The sensitivity rows of a calibration by coil and tilt: what each reading tells about the
parameters (issue 29, item 1; the coil plan and the identifiability table build on them).

A coil reading applies a known uniform field B (a Helmholtz pair, T, board frame) and reads the
sensor: the cilium's field in the shape B bends it to plus B itself, the *direct* field (the AMR
output ``S · B_x`` with the sensitivity S fitted, or the three components of a 3-axis part), plus
an offset per axis (the Earth's field, the part's own offset, the cilium's rest field: the
experiment's nuisances). A tilt reading is the paper's: the rigid cilium tilted. The rows come
from the one calibration model, :class:`~magcilia.calibration.problem.Problem` with a
:class:`~magcilia.calibration.experiments.CoilExperiment` (and a tilt path), by central
differences of :meth:`Problem.model` over a population of perturbed parameter vectors (one
batched call), so the plan is about exactly what ``calibrate`` fits.

Parameters (:data:`CALIBRATION_PARAMETERS`, the Problem's names): the geometry (height, base
radius, x, y, z), the magnetization scale, Young's modulus and, for the AMR output, the bridge
sensitivity (a 3-axis part's scale is taken as calibrated). The base radius is differentiated at
a fixed taper (:data:`FIXED_TAPER`).

All SI: T, V, m, Pa, V/V/T.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: every parameter a coil or tilt row can be differentiated by, in the tables' order (the
#: sensitivity only for the AMR output)
CALIBRATION_PARAMETERS = ("height", "base_radius", "x", "y", "z", "magnetization_scale",
                          "youngs_modulus", "sensitivity")
#: the lengths that scale together without changing any coil or tilt reading (the scale symmetry)
LENGTHS = ("height", "base_radius", "x", "y", "z")
#: the base radius is differentiated at a fixed taper (the tip radius in proportion): the mould
#: sets the cone's shape, and only then does scaling every length leave the readings exactly
#: unchanged (a tip radius held at an assumed value breaks the symmetry by an amount that only
#: the assumption carries)
FIXED_TAPER = True
#: relative step of the central differences (lengths: of max(|value|, 1 mm)); 1e-3: the bend's
#: own tolerance makes a smaller step noisier, the truncation error (~step²) stays below it
STEP = 1e-3
#: what a reading measures: the AMR output (V, one row) or a 3-axis part's field (T, three rows)
MEASURES = ("output", "field")


def parameters_for(measure: str) -> tuple[str, ...]:
    """:data:`CALIBRATION_PARAMETERS` of a measure: without the sensitivity for ``"field"``."""
    measure = v.choice("measure", measure, MEASURES)
    return tuple(n for n in CALIBRATION_PARAMETERS
                 if measure == "output" or n != "sensitivity")


def nominal(setup: Setup, name: str) -> float:
    """The setup's value of a :data:`CALIBRATION_PARAMETERS` name, SI."""
    if name == "youngs_modulus":
        return float(setup.youngs_modulus)
    if name == "sensitivity":
        return float(setup.sensor.sensitivity)
    return float(setup.params()[name])


def _measurement(measure: str, fields: F64 | None = None, angles: F64 | None = None,
                 azimuths: F64 | None = None) -> object:
    """A recording of the conditions with zero readings (only the model is asked of it)."""
    from magcilia.io.recordings import Measurement

    a = (fields if fields is not None else angles).shape[0]  # type: ignore[union-attr]
    zero = np.zeros(a)
    ints = (np.ones(a, np.int64), np.zeros(a, np.int64), np.zeros(a, np.int64))
    tilt = zero if angles is None else angles
    phi = zero if azimuths is None else azimuths
    if measure == "field":
        return Measurement(tilt, np.full(a, np.nan), np.full(a, np.nan), *ints, azimuths=phi,
                           fields=np.zeros((a, 3)), field_sem=np.ones((a, 3)), actuation=fields)
    return Measurement(tilt, zero, np.ones(a), *ints, azimuths=phi, actuation=fields)


def _problem(setup: Setup, measure: str, names: tuple[str, ...], fields: F64 | None,
             angles: F64 | None, azimuths: F64 | None) -> object:
    """The one calibration Problem of a coil experiment (the candidates, or a single zero field
    so that the coil parameters exist) and optionally a tilt path."""
    from magcilia.calibration.experiments import experiment
    from magcilia.calibration.problem import Problem

    coil = fields if fields is not None else np.zeros((1, 3))
    terms = [experiment(_measurement(measure, fields=coil))]  # type: ignore[arg-type]
    if angles is not None:
        terms.append(experiment(_measurement(measure, angles=angles,  # type: ignore[arg-type]
                                             azimuths=azimuths)))
    bounds = dict.fromkeys(names, (-math.inf, math.inf))
    return Problem(terms, setup.replace(offset=0.0), names, bounds)


def _differences(setup: Setup, measure: str, names: tuple[str, ...], fields: F64 | None,
                 angles: F64 | None, azimuths: F64 | None) -> tuple[F64, F64]:
    """The model rows (d,) at the setup and their derivatives (d, q), central differences of
    :meth:`Problem.model` in one batched call (the base radius at a fixed taper)."""
    problem = _problem(setup, measure, names, fields, angles, azimuths)
    p = np.array([nominal(setup, n) for n in names])
    h = np.array([STEP * max(abs(x), 1e-3 if n in LENGTHS else abs(x) or 1.0)
                  for n, x in zip(names, p, strict=True)])
    P = np.tile(p, (2 * p.size + 1, 1))
    for j in range(p.size):
        P[1 + 2 * j, j] += h[j]
        P[2 + 2 * j, j] -= h[j]
    u = problem.model(P)  # type: ignore[attr-defined]
    jac = ((u[1::2] - u[2::2]) / (2.0 * h[:, None])).T
    tip = setup.params()["tip_radius"]
    if FIXED_TAPER and "base_radius" in names and tip > 0:
        ht = STEP * tip
        up = _problem(setup.replace(tip_radius=tip + ht), measure, names, fields, angles,
                      azimuths).model(p[None])  # type: ignore[attr-defined]
        down = _problem(setup.replace(tip_radius=tip - ht), measure, names, fields, angles,
                        azimuths).model(p[None])  # type: ignore[attr-defined]
        ratio = tip / setup.params()["base_radius"]
        jac[:, names.index("base_radius")] += ratio * (up[0] - down[0]) / (2.0 * ht)
    return np.asarray(u[0], dtype=np.float64), np.asarray(jac, dtype=np.float64)


def _per_condition(values: F64, c: int, measure: str) -> F64:
    """Rows of one experiment (d, ...) → (c, r, ...): a field experiment's rows are component
    major (all B_x, then B_y, then B_z)."""
    if measure == "output":
        return values.reshape(c, 1, *values.shape[1:])
    return np.moveaxis(values.reshape(3, c, *values.shape[1:]), 0, 1)


def coil_totals(setup: Setup, fields: ArrayLike) -> F64:
    """The total field at the sensing element (the bent cilium's + the applied), T, shape (c, 3),
    for applied uniform fields ``fields`` (c, 3), T: the Problem's coil model, 3-axis."""
    b = _fields(fields)
    problem = _problem(setup, "field", ("height",), b, None, None)
    u = problem.model(np.array([[nominal(setup, "height")]]))  # type: ignore[attr-defined]
    return np.asarray(np.asarray(u[0], dtype=np.float64).reshape(3, b.shape[0]).T)


def _fields(fields: ArrayLike) -> F64:
    b = v.finite_array("fields", fields, unit="T")
    if b.ndim != 2 or b.shape[1] != 3 or b.shape[0] < 1:
        raise v.fail("fields", f"an array of shape {b.shape}", "applied fields of shape (c, 3), T")
    return b


def calibration_rows(setup: Setup, *, fields: ArrayLike | None = None,
                     angles: ArrayLike | None = None, azimuths: ArrayLike | None = None,
                     measure: str = "output", parameters: Sequence[str] | None = None
                     ) -> tuple[F64 | None, F64 | None]:
    """Sensitivity of each coil and tilt reading to the parameters.

    Parameters
    ----------
    setup : Setup
        Where the derivatives are taken (SI; a positive tip radius for coil readings: a field's
        couple on a sharp cone is singular at the tip).
    fields : array-like, shape (c, 3), optional
        Applied uniform fields of the coil readings, T.
    angles, azimuths : array-like, shape (t,), optional
        Rigid tilts of the tilt readings, rad (azimuths default 0).
    measure : {"output", "field"}
        The AMR output (one row per reading, V per SI unit) or a 3-axis part's three components.
    parameters : sequence of str, optional
        Among :func:`parameters_for` the measure (default all of them).

    Returns
    -------
    coil, tilt : ndarray, shape (c, r, q) and (t, r, q), or None where not asked
        r = 1 (output) or 3 (field); offsets not included.
    """
    measure = v.choice("measure", measure, MEASURES)
    names = _names(parameters_for(measure) if parameters is None else parameters, measure)
    b = None if fields is None else _fields(fields)
    a = None if angles is None else v.finite_array("angles", angles, ndim=1)
    phi = None
    if a is not None:
        phi = (np.zeros(a.size) if azimuths is None
               else v.finite_array("azimuths", azimuths, ndim=1))
        if phi.size != a.size:
            raise v.fail("azimuths", f"{phi.size} values", f"one azimuth per angle ({a.size})")
    if b is None and a is None:
        raise v.fail("fields", "nothing", "coil fields, tilt angles or both")
    _, jac = _differences(setup, measure, names, b, a, phi)
    r = 1 if measure == "output" else 3
    nc = 1 if b is None else b.shape[0]
    coil = None if b is None else _per_condition(jac[: r * nc], nc, measure)
    tilt = None if a is None else _per_condition(jac[r * nc:], a.size, measure)
    return coil, tilt


def coil_jacobian(setup: Setup, fields: ArrayLike, *, measure: str = "output",
                  parameters: Sequence[str] | None = None) -> F64:
    """The coil readings' rows of :func:`calibration_rows`, shape (c, r, q)."""
    coil, _ = calibration_rows(setup, fields=fields, measure=measure, parameters=parameters)
    assert coil is not None
    return coil


def tilt_rows(setup: Setup, angles: ArrayLike, azimuths: ArrayLike | None = None, *,
              measure: str = "output", parameters: Sequence[str] | None = None) -> F64:
    """The tilt readings' rows of :func:`calibration_rows` (a rigid tilt does not bend the
    cilium: the modulus column is zero), shape (t, r, q)."""
    _, tilt = calibration_rows(setup, angles=angles, azimuths=azimuths, measure=measure,
                               parameters=parameters)
    assert tilt is not None
    return tilt


def _names(parameters: Sequence[str], measure: str) -> tuple[str, ...]:
    names = tuple(parameters)
    allowed = parameters_for(measure)
    for n in names:
        if n not in allowed:
            raise v.fail("parameters", n, f"names among {', '.join(allowed)} (measure {measure})")
    if len(set(names)) != len(names) or not names:
        raise v.fail("parameters", list(names), "one or more distinct names among "
                     + ", ".join(allowed))
    return names


def sphere_directions(polar_step: float = math.radians(30.0),
                      azimuth_step: float = math.radians(45.0)) -> F64:
    """Unit vectors on a polar × azimuth grid (rad steps), the poles once: shape (d, 3)."""
    thetas = np.arange(0.0, math.pi + 1e-9, polar_step)
    phis = np.arange(0.0, 2 * math.pi - 1e-9, azimuth_step)
    out = []
    for t in thetas:
        for p in (phis if 1e-9 < t < math.pi - 1e-9 else phis[:1]):
            out.append((math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)))
    return np.asarray(out, dtype=np.float64)


__all__ = ["CALIBRATION_PARAMETERS", "FIXED_TAPER", "LENGTHS", "MEASURES", "STEP",
           "calibration_rows", "coil_jacobian", "coil_totals", "nominal", "parameters_for",
           "sphere_directions", "tilt_rows"]
