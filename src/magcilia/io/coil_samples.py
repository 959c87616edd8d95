"""A coil recording's samples: which the sensor's checks drop, their applied fields per condition,
and the note that counts the dropped ones (for :mod:`magcilia.io.reduction`).

A coil recording (``actuation_x_T``, ``actuation_y_T``, ``actuation_z_T`` beside the observable,
:mod:`magcilia.io.columns`) is grouped by its applied field; a sample whose total field at the
element leaves the sensor's linear range or may flip the AMR element is dropped and counted
(:data:`COIL_DROP`), whatever the saturation policy: the coil drives the field there on purpose.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from magcilia.constants import GAUSS
from magcilia.device.sensor import Sensor, SensorFlag

F64 = NDArray[np.float64]

#: the sensor flags (:meth:`magcilia.device.sensor.Sensor.check`) that drop a coil recording's
#: sample: its total field (applied + cilium + background) beyond the linear range, on the
#: sensitive axis or in magnitude (the datasheet's range is for the total field), or beyond the
#: field that may flip the AMR element
COIL_DROP = SensorFlag.BEYOND_RANGE | SensorFlag.TOTAL_BEYOND_RANGE | SensorFlag.FLIPPED_RISK


def coil_flagged(sensor: Sensor, applied: F64, volt: F64 | None, sr: F64 | None,
                 fields: tuple[F64, F64, F64] | None, bad: NDArray[np.bool_]
                 ) -> NDArray[np.bool_]:
    """Which coil samples (``applied`` (3, s), T) the sensor's checks drop (:data:`COIL_DROP`):
    the total field at the element is the 3-axis reading itself (``fields``, T), or for a
    single-axis output (``volt``, V) the applied field with B_x replaced by the reading's
    ((V − offset)/scale, times the set/reset polarity ``sr``); ``bad`` samples (s,) are not
    judged."""
    if fields is not None:
        total = np.stack(fields)
    else:
        assert volt is not None
        total = applied.copy()
        with np.errstate(over="ignore", invalid="ignore"):
            total[0] = (volt - sensor.offset) / sensor.scale * (
                1.0 if sr is None else np.where(sr < 0.0, -1.0, 1.0))
    total = np.where(bad | ~np.isfinite(total).all(axis=0), 0.0, total)
    flags = sensor.check(total.T)
    return np.asarray(flags & np.uint8(COIL_DROP) != 0)


def applied_fields(known: dict[tuple[float, float, float], int], ids: F64) -> F64:
    """The applied field (c, 3), T, of conditions numbered ``ids`` (c,) in ``known`` (the
    distinct fields in µT → their number, :func:`magcilia.io.columns.actuation_ids`)."""
    table = np.zeros((len(known), 3))
    for key, i in known.items():
        table[i] = key
    return np.asarray(table[np.round(ids).astype(np.intp)] * 1e-6, dtype=np.float64)


def coil_note(flagged: int, sensor: Sensor) -> str:
    """The recording's note on ``flagged`` dropped coil samples."""
    return (f"{flagged} coil sample(s) dropped: the total field at the element beyond the "
            f"sensor's linear range (±{sensor.field_range / GAUSS:g} gauss) or its flip field "
            f"({sensor.flip_field / GAUSS:g} gauss); lower the coil's field or pass the sensor "
            "that was used")
