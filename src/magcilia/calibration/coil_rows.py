"""The sensitivity rows of a coil calibration: what each applied uniform field tells about the
parameters (issue 29, item 1; the plan and the identifiability table build on them).

A coil reading applies a known uniform field B (a Helmholtz pair, T, board frame) and reads the
sensor: the cilium's field in the shape B bends it to (:func:`magcilia.bend` with
``actuation=Actuation.uniform(B)``) plus B itself, the *direct* field, times the sensor's scale
(the AMR output ``gain · S · B_x``, or the three components ``gain · B`` of a 3-axis part), plus
an offset per axis (the Earth's field, the part's own offset, the cilium's rest field: the
experiment's nuisances). The rows here are the derivatives of that reading with respect to the
parameters, by central differences of the forward model; the tilt rig's rows
(:func:`~magcilia.calibration.plan.tilt_jacobian`) are extended to the same parameters, so that
rows of both stimuli add into one Fisher information.

Parameters (:data:`COIL_PARAMETERS`): the geometry (height, base radius, x, y, z), the
magnetization scale, Young's modulus and ``gain`` (the sensor's scale relative to its nominal:
the amplifier's gain for the AMR output, a common gain of the three axes of a 3-axis part).

All SI: T, V, m, Pa.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: every parameter a coil or tilt row can be differentiated by, in the tables' order
COIL_PARAMETERS = ("height", "base_radius", "x", "y", "z", "magnetization_scale",
                   "youngs_modulus", "gain")
#: the lengths that scale together without changing any coil or tilt reading (the scale symmetry)
LENGTHS = ("height", "base_radius", "x", "y", "z")
#: the base radius is differentiated at a fixed taper (the tip radius in proportion): the mould
#: sets the cone's shape, and only then does scaling every length leave the readings exactly
#: unchanged (a tip radius held at an assumed value breaks the symmetry by an amount that only
#: the assumption carries)
FIXED_TAPER = True
#: relative step of the central differences (lengths: of max(|value|, 1 mm))
STEP = 1e-4
#: what a reading measures: the AMR output (V, one row) or a 3-axis part's field (T, three rows)
MEASURES = ("output", "field")


def nominal(setup: Setup, name: str) -> float:
    """The setup's value of a :data:`COIL_PARAMETERS` name, SI (``gain``: the amplifier's)."""
    if name == "youngs_modulus":
        return float(setup.youngs_modulus)
    if name == "gain":
        return float(setup.sensor.gain)
    return float(setup.params()[name])


def with_value(setup: Setup, name: str, value: float) -> Setup:
    """``setup`` with one :data:`COIL_PARAMETERS` value changed (SI); the base radius at a fixed
    taper (the tip radius in proportion: :data:`FIXED_TAPER`)."""
    if name == "youngs_modulus":
        return setup.replace(youngs_modulus=value, youngs_modulus_sigma=0.0)
    if name == "base_radius" and FIXED_TAPER:
        ratio = setup.params()["tip_radius"] / setup.params()["base_radius"]
        return setup.replace(base_radius=value, tip_radius=ratio * value)
    return setup.replace(**{name: value})


def coil_fields(setup: Setup, fields: ArrayLike) -> F64:
    """The total field at the sensing element (cilium + applied), T, shape (c, 3), for applied
    uniform fields ``fields`` (c, 3), T: the cilium bent by each field, plus the field."""
    from magcilia.device.actuation import Actuation
    from magcilia.mechanics import bend

    b = v.finite_array("fields", fields, unit="T")
    if b.ndim != 2 or b.shape[1] != 3:
        raise v.fail("fields", f"an array of shape {b.shape}", "applied fields of shape (c, 3), T")
    out = np.empty((b.shape[0], 3))
    for i, applied in enumerate(b):
        shape = bend(setup, actuation=Actuation.uniform(applied))
        out[i] = np.asarray(setup.field(shape), dtype=np.float64).reshape(3) + applied
    return out


def readings(setup: Setup, total: F64, measure: str) -> F64:
    """What the sensor reads of total fields ``total`` (c, 3), T, offsets aside: shape (c, 1) in V
    (``gain · S · B_x``) for ``"output"``, (c, 3) in T (``gain · B``) for ``"field"``."""
    if measure == "output":
        return np.asarray(setup.sensor.scale * total[:, :1], dtype=np.float64)
    return np.asarray(setup.sensor.gain * total, dtype=np.float64)


def coil_jacobian(setup: Setup, fields: ArrayLike, *, measure: str = "output",
                  parameters: Sequence[str] = COIL_PARAMETERS) -> F64:
    """Sensitivity of each coil reading to the parameters.

    Parameters
    ----------
    setup : Setup
        Where the derivatives are taken (SI; needs a positive tip radius: a field's couple on a
        sharp cone is singular at the tip).
    fields : array-like, shape (c, 3)
        Applied uniform fields, T.
    measure : {"output", "field"}
        The AMR output (one row, V per SI unit) or three field components (T per SI unit).
    parameters : sequence of str
        Among :data:`COIL_PARAMETERS`.

    Returns
    -------
    ndarray, shape (c, r, q)
        r = 1 (output) or 3 (field), q = len(parameters); offsets not included.
    """
    measure = v.choice("measure", measure, MEASURES)
    b = v.finite_array("fields", fields, unit="T")
    names = _names(parameters)
    base = coil_fields(setup, b)
    r = 1 if measure == "output" else 3
    out = np.empty((b.shape[0], r, len(names)))
    for j, name in enumerate(names):
        p = nominal(setup, name)
        if name == "gain":  # the reading is proportional to the gain: exact
            out[:, :, j] = readings(setup, base, measure) / p
            continue
        h = STEP * max(abs(p), 1e-3 if name in LENGTHS else abs(p) or 1.0)
        up = readings(setup, coil_fields(with_value(setup, name, p + h), b), measure)
        down = readings(setup, coil_fields(with_value(setup, name, p - h), b), measure)
        out[:, :, j] = (up - down) / (2.0 * h)
    return out


def tilt_fields(setup: Setup, angles: F64, azimuths: F64) -> F64:
    """The cilium's field at the element for rigid tilts (rad), T, shape (c, 3)."""
    out = np.empty((angles.size, 3))
    for az in np.unique(azimuths):
        sel = azimuths == az
        out[sel] = setup.field(angles[sel], azimuth=float(az))
    return out


def tilt_rows(setup: Setup, angles: ArrayLike, azimuths: ArrayLike, *, measure: str = "output",
              parameters: Sequence[str] = COIL_PARAMETERS) -> F64:
    """The tilt rig's rows over the same parameters as :func:`coil_jacobian` (central
    differences of :meth:`Setup.field` along rigid tilts, as
    :func:`~magcilia.calibration.plan.tilt_jacobian`, the base radius at a fixed taper): a rigid
    tilt does not bend the cilium (the modulus column is zero) and the reading is proportional to
    the gain. Angles and azimuths rad, shape (c,); returns shape (c, r, q)."""
    measure = v.choice("measure", measure, MEASURES)
    names = _names(parameters)
    a = v.finite_array("angles", angles, ndim=1)
    phi = v.finite_array("azimuths", azimuths, ndim=1)
    if phi.size != a.size:
        raise v.fail("azimuths", f"{phi.size} values", f"one azimuth per angle ({a.size})")
    r = 1 if measure == "output" else 3
    out = np.zeros((a.size, r, len(names)))
    for j, name in enumerate(names):
        p = nominal(setup, name)
        if name == "gain":
            out[:, :, j] = readings(setup, tilt_fields(setup, a, phi), measure) / p
        elif name != "youngs_modulus":
            h = STEP * max(abs(p), 1e-3 if name in LENGTHS else abs(p) or 1.0)
            up = readings(setup, tilt_fields(with_value(setup, name, p + h), a, phi), measure)
            down = readings(setup, tilt_fields(with_value(setup, name, p - h), a, phi), measure)
            out[:, :, j] = (up - down) / (2.0 * h)
    return out


def _names(parameters: Sequence[str]) -> tuple[str, ...]:
    names = tuple(parameters)
    for n in names:
        if n not in COIL_PARAMETERS:
            raise v.fail("parameters", n, "names among " + ", ".join(COIL_PARAMETERS))
    if len(set(names)) != len(names) or not names:
        raise v.fail("parameters", list(names), "one or more distinct names among "
                     + ", ".join(COIL_PARAMETERS))
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


__all__ = ["COIL_PARAMETERS", "FIXED_TAPER", "LENGTHS", "MEASURES", "STEP", "coil_fields",
           "coil_jacobian",
           "nominal", "readings", "sphere_directions", "tilt_fields", "tilt_rows",
           "with_value"]
