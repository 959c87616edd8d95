"""Channels: one sensitive axis at one point, what one single-axis field reading sees.

A 3-axis :class:`~magcilia.device.magnetometer.Magnetometer` is three channels at one point
(named ``NAME.x``, ``NAME.y``, ``NAME.z``: the ``inputs`` of a read-out that reads it), two
single-axis elements (HMC1021Z turned 90°, or side by side) are two. :class:`Channel` holds the
point, the axis, the noise and the range (all SI: m, T); :func:`channels` expands sensors into
them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from magcilia import _validate as v
from magcilia._display import Display, Item, scaled
from magcilia.device.magnetometer import Magnetometer
from magcilia.device.sensor import DEFAULT_BANDWIDTH, Sensor


@dataclass(frozen=True, repr=False)
class Channel(Display):
    """One sensitive axis at one point: what one single-axis reading sees (all SI).

    Parameters
    ----------
    position : (3,) floats
        Sensing point, m, in the board frame (the paper's element is the origin, +z up).
    axis : (3,) floats
        Sensitive direction in the board frame (normalised here): the reading is ``axis · B``.
    sigma : float
        RMS noise of one reading, T (> 0).
    field_range : float
        Linear range ±field_range, T; readings beyond it are SATURATED (default: none).
    name : str
        For reports and errors.
    resolution : float
        One LSB of a digital part's reading, T (0: analog); a reading within half an LSB of the
        range is saturated (:func:`~magcilia.device.sensor.beyond_range`).

    Examples
    --------
    >>> c = Channel((0.0, 0.0, 0.0), (0.0, 2.0, 0.0), 1e-7, name="y")
    >>> c.axis
    (0.0, 1.0, 0.0)
    """

    position: Any
    axis: Any
    sigma: float
    field_range: float = math.inf
    name: str = "channel"
    resolution: float = 0.0

    def __post_init__(self) -> None:
        pos = v.vector3("position", self.position)
        axis = v.vector3("axis", self.axis, unit="")
        norm = float(np.linalg.norm(axis))
        if norm == 0.0:
            raise v.fail("axis", tuple(axis), "a non-zero direction (x, y, z)")
        object.__setattr__(self, "position", tuple(float(p) for p in pos))
        object.__setattr__(self, "axis", tuple(float(a) for a in axis / norm))
        object.__setattr__(self, "sigma", v.positive("sigma", self.sigma, "T", "noise"))
        rng = v.real("field_range", self.field_range, "T") if math.isfinite(
            float(self.field_range)) else math.inf
        if not rng > 0.0:
            raise v.fail("field_range", self.field_range, "a positive field in T (or inf)")
        object.__setattr__(self, "field_range", rng)
        object.__setattr__(self, "resolution",
                           v.non_negative("resolution", self.resolution, "T", "field"))

    @classmethod
    def of_magnetometer(cls, sensor: Magnetometer) -> tuple[Channel, Channel, Channel]:
        """The three channels of a 3-axis sensor: its axes (rotation columns), per-axis noise
        and range, named ``NAME.x``, ``.y``, ``.z``."""
        if not isinstance(sensor, Magnetometer):
            raise v.fail("sensor", type(sensor).__name__, "a magcilia Magnetometer")
        rot = np.asarray(sensor.rotation)
        return tuple(cls(sensor.position, rot[:, i], float(sensor.noise[i]),  # type: ignore[return-value]
                         float(sensor.field_range[i]), f"{sensor.name}.{'xyz'[i]}",
                         float(sensor.resolution[i]))
                     for i in range(3))

    @classmethod
    def of_sensor(cls, sensor: Sensor, position: ArrayLike = (0.0, 0.0, 0.0),
                  axis: ArrayLike = (1.0, 0.0, 0.0),
                  bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH,
                  name: str = "HMC1021Z") -> Channel:
        """A single-axis AMR element (:class:`~magcilia.Sensor`) at ``position`` (m) with its
        sensitive axis along ``axis`` (the paper's element: the origin, +x): σ is the sensor's
        noise over ``bandwidth`` (Hz), in T; the range its ``field_range``."""
        if not isinstance(sensor, Sensor):
            raise v.fail("sensor", type(sensor).__name__, "a magcilia.Sensor")
        sigma = sensor.noise_rms(*bandwidth)
        return cls(position, axis, sigma, sensor.field_range, name)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"name": self.name, "position": list(self.position), "axis": list(self.axis),
                "sigma": self.sigma,
                "field_range": self.field_range if math.isfinite(self.field_range) else None,
                "resolution": self.resolution, "units": "SI"}

    def report(self) -> str:
        """One line: name, position (mm), axis, noise and range (gauss)."""
        rng = "no range" if not math.isfinite(self.field_range) else \
            f"range ±{self.field_range / 1e-4:.4g} G"
        return (f"{self.name}: at (" + ", ".join(f"{p * 1e3:.4g}" for p in self.position)
                + ") mm, axis (" + ", ".join(f"{a:.3g}" for a in self.axis)
                + f"), noise {self.sigma / 1e-4:.3g} G RMS, {rng}")

    def _display_items(self) -> list[Item]:
        return [("", self.name),
                ("at", "(" + ", ".join(f"{p * 1e3:.4g}" for p in self.position) + ") mm"),
                ("axis", "(" + ", ".join(f"{a:.3g}" for a in self.axis) + ")"),
                ("noise", scaled(self.sigma, 1e-4, "G"))]


ChannelLike = Channel | Magnetometer


def channels(sensors: ChannelLike | Sequence[ChannelLike]) -> tuple[Channel, ...]:
    """The channels of one sensor or a sequence of them (a Magnetometer gives three)."""
    items = [sensors] if isinstance(sensors, (Channel, Magnetometer)) else list(sensors)
    out: list[Channel] = []
    for i, item in enumerate(items):
        if isinstance(item, Magnetometer):
            out.extend(Channel.of_magnetometer(item))
        elif isinstance(item, Channel):
            out.append(item)
        else:
            raise v.fail(f"sensors[{i}]", type(item).__name__,
                         "a Magnetometer or a Channel (Channel.of_sensor for an HMC1021Z)")
    if not out:
        raise v.fail("sensors", "an empty list", "at least one Magnetometer or Channel")
    return tuple(out)
