"""The forward model a single-output read-out inverts: the sensor output at values of a measurand,
with or without a known actuation acting (its bending and its direct field at the element), and
the checks and text of such a compensation."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.device.actuation import Actuation
from magcilia.device.sensor import SensorFlag, flag_names
from magcilia.device.setup import Setup
from magcilia.mechanics import Flow, output_at, poses_at

F64 = NDArray[np.float64]

#: the sensing element in the board frame, m (the README's sensor frame: the origin)
ELEMENT = (0.0, 0.0, 0.0)


def direct_field(actuation: Actuation) -> F64:
    """The actuation's own field at the sensing element (the origin), T, shape (3,): what it adds
    to the reading whatever the cilium does."""
    b = np.asarray(actuation.field(np.array(ELEMENT)), dtype=np.float64)
    if not np.all(np.isfinite(b)):
        raise v.fail("actuation", "a field that is not finite at the sensing element",
                     "a source away from the element (the origin)")
    return b


def model_fields(setup: Setup, quantity: str, values: ArrayLike, flow: Flow | None,
                 actuation: Actuation) -> F64:
    """The total field at the element, T, shape (a, 3), for ``values`` (shape (a,), SI) of a
    measurand read while ``actuation`` acts: the cilium's field in the shape that the load and
    the actuation together bend it to (:func:`magcilia.bend_sweep` with ``actuation=``; a rigid
    tilt, ``"angle"``, is not bent by it) plus the actuation's :func:`direct_field`."""
    direct = direct_field(actuation)
    pose, azimuth = poses_at(setup, quantity, values, flow, actuation)
    return np.asarray(setup.field(pose, azimuth=azimuth) + direct, dtype=np.float64)


def model_output(setup: Setup, quantity: str, values: ArrayLike, flow: Flow | None = None,
                 actuation: Actuation | None = None) -> F64:
    """The model's sensor output (V), shape (a,), at ``values`` (shape (a,), SI) of a measurand:
    :func:`magcilia.mechanics.output_at` without an actuation (exactly), else
    ``sensor.voltage(B_x)`` of :func:`model_fields` (the actuation's bending and direct field
    included)."""
    if actuation is None:
        return output_at(setup, quantity, values, flow)
    return np.asarray(setup.sensor.voltage(
        model_fields(setup, quantity, values, flow, actuation)[:, 0]), dtype=np.float64)


def check_actuated(setup: Setup, fields: F64, actuation: Actuation) -> int:
    """:meth:`Sensor.check` of the total fields ``fields`` (a, 3), T, at the element under
    ``actuation``: raises where the element's magnetization may flip (FLIPPED_RISK anywhere) or
    where B_x is beyond the range over every value (the read-out would see nothing); returns the
    union of the flags (int) otherwise."""
    sensor = setup.sensor
    flags = sensor.check(fields)
    union = int(np.bitwise_or.reduce(flags)) if flags.size else 0
    direct = direct_field(actuation) / 1e-4
    what = "a direct field of (" + ", ".join(f"{c:.4g}" for c in direct) + ") G at the element"
    if union & SensorFlag.FLIPPED_RISK:
        peak = float(np.max(np.linalg.norm(fields, axis=-1))) / 1e-4
        raise v.fail("actuation", what, f"a field that keeps |B| at the element within the "
                     f"{sensor.name}'s {sensor.flip_field / 1e-4:.3g} G flip field (it reaches "
                     f"{peak:.4g} G): lower the field or its scale, or pulse set/reset and use a "
                     "sensor with a wider range")
    if np.all(flags & np.uint8(SensorFlag.BEYOND_RANGE)):
        bx = float(np.min(np.abs(fields[:, 0]))) / 1e-4
        raise v.fail("actuation", what, f"a field that keeps B_x within the {sensor.name}'s "
                     f"±{sensor.field_range / 1e-4:.3g} G range (|B_x| ≥ {bx:.4g} G over the "
                     "whole span): lower the field along x, buck it with the offset strap, or "
                     "use a sensor with a wider range")
    return union


def compensation_text(setup: Setup, actuation: Actuation, flags: int) -> str:
    """One line: the actuation compensated, its direct field at the element (gauss) and output
    (mV), and the sensor's flags under it."""
    b = direct_field(actuation)
    volts = setup.sensor.scale * b[0]
    text = (f"compensating {actuation.describe()}: direct field ("
            + ", ".join(f"{c / 1e-4:.4g}" for c in b)
            + f") G at the element ({volts * 1e3:+.4g} mV), its bending modelled")
    if flags:
        text += f"; sensor flags {flag_names(flags)}"
    return text
