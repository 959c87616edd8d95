"""The sensors a design may use: the setup's single-axis element or a 3-axis magnetometer at the
same point (:class:`SensorChoice`, :func:`sensor_choices`), with their noise, full scale, rated
total field and flip field.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.device.magnetometer import MAGNETOMETERS, Magnetometer
from magcilia.device.sensor import Sensor
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: the single-axis sensor (the setup's own) by name in ``sensors``
SINGLE_AXIS = "HMC1021Z"


@dataclass(frozen=True)
class SensorChoice:
    """A sensor a design may use: the setup's single-axis element (``sensor``) or a 3-axis
    :class:`~magcilia.device.magnetometer.Magnetometer` at the same point (the element's place
    below the case top: the setup's depth), its axes turned by the part's rotation.

    Attributes
    ----------
    name : str
    sensor : Sensor or Magnetometer
    """

    name: str
    sensor: Sensor | Magnetometer

    @property
    def axes(self) -> int:
        """1 for the single-axis element, 3 for a magnetometer."""
        return 1 if isinstance(self.sensor, Sensor) else 3

    def sigma(self, bandwidth: tuple[float, float]) -> F64:
        """RMS field noise of one reading per board axis, T, shape (3,) (inf: axis not read).
        A magnetometer's noise at its rate with its LSB's quantisation (LSB/√12) added."""
        s = self.sensor
        if isinstance(s, Sensor):
            return np.array([s.noise_rms(*bandwidth), math.inf, math.inf])
        return np.sqrt(np.asarray(s.noise) ** 2 + np.asarray(s.resolution) ** 2 / 12.0)

    @property
    def full_scale(self) -> F64:
        """Range per read axis, T, shape (3,) (inf: axis not read)."""
        s = self.sensor
        if isinstance(s, Sensor):
            return np.array([s.field_range, math.inf, math.inf])
        return np.asarray(s.field_range, dtype=np.float64)

    @property
    def rated_total(self) -> float:
        """Rated range of the total field |B|, T: the single-axis element's range (its datasheet
        states it for the total applied field), inf for a magnetometer (per-axis ranges)."""
        return self.sensor.field_range if isinstance(self.sensor, Sensor) else math.inf

    def total_limit(self, field: float | None) -> float:
        """The rated range of |B| in force, T: ``field`` (the ``"field"`` constraint) when
        given, else :attr:`rated_total`."""
        return self.rated_total if field is None else float(field)

    @property
    def flip(self) -> float:
        """|B| beyond which the element may flip, T (inf for a magnetometer: not modelled)."""
        return self.sensor.flip_field if isinstance(self.sensor, Sensor) else math.inf

    def reading(self, b: F64) -> F64:
        """Board-frame fields (..., 3), T, on the sensor's axes (the single axis: x, y and z
        of the board; only x is read)."""
        if isinstance(self.sensor, Sensor):
            return b
        return b @ self.sensor.rotation


def sensor_choices(sensors: Sequence[str | Sensor | Magnetometer], setup: Setup
                   ) -> tuple[SensorChoice, ...]:
    """The checked ``sensors`` of :func:`~magcilia.design.optimise.optimise_design`:
    ``"HMC1021Z"`` (the setup's own single-axis sensor, its gain and bridge as given), a name of
    :data:`~magcilia.device.magnetometer.MAGNETOMETERS` (the preset's defaults), a
    :class:`~magcilia.Sensor` or a :class:`~magcilia.device.magnetometer.Magnetometer`."""
    if isinstance(sensors, (str, Sensor, Magnetometer)):
        sensors = (sensors,)
    out: list[SensorChoice] = []
    for item in sensors:
        if isinstance(item, (Sensor, Magnetometer)):
            out.append(SensorChoice(item.name, item))
        elif isinstance(item, str) and item.upper() == SINGLE_AXIS:
            out.append(SensorChoice(setup.sensor.name, setup.sensor))
        elif isinstance(item, str):
            try:
                part = Magnetometer.preset(item)
            except MagciliaError:
                raise v.fail("sensor", item, f"{SINGLE_AXIS} (the setup's single-axis sensor) "
                             "or a 3-axis preset (" + ", ".join(MAGNETOMETERS) + ")") from None
            out.append(SensorChoice(item.upper(), part))
        else:
            raise v.fail("sensor", type(item).__name__, "a name, a Sensor or a Magnetometer")
    if not out:
        raise v.fail("sensors", "none", f"at least one sensor (e.g. {SINGLE_AXIS!r})")
    names = [c.name for c in out]
    if len(set(names)) != len(names):
        raise v.fail("sensors", names, "distinct sensors")
    return tuple(out)
