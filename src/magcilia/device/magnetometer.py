"""Three-axis magnetometers: a sensing point with three axes, a range, an LSB and noise per axis.

A :class:`Magnetometer` sits at ``position`` (m, in the frame of the README's "Coordinate frame":
+z up, out of the board) with its axes turned by ``rotation`` (a 3 × 3 matrix whose columns are
the sensor's x, y, z axes in that frame). A field ``B`` (T, frame coordinates) reads as
``rotation.T @ B`` on the sensor's axes; :meth:`Magnetometer.measure` adds white noise, clips
each axis at its full-scale range and rounds to the LSB, as the part's digital output does.

All SI: T, T per LSB, T RMS, Hz, m.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, scaled

F64 = NDArray[np.float64]


def _axes(name: str, value: ArrayLike, unit: str) -> tuple[float, float, float]:
    """A positive per-axis figure: one number for all three axes, or three."""
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (3,)) if np.ndim(value) == 0 \
        else v.finite_array(name, value, ndim=1, unit=unit)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0.0):
        raise v.fail(name, value, f"a positive number or three of them (x, y, z), {unit}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def rotation_matrix(rotation: ArrayLike | None) -> F64:
    """A checked rotation: None (identity), a 3 × 3 proper orthogonal matrix, or anything with
    ``as_matrix()`` (a ``scipy.spatial.transform.Rotation``)."""
    if rotation is None:
        return np.eye(3)
    if hasattr(rotation, "as_matrix"):
        rotation = rotation.as_matrix()
    mat = v.finite_array("rotation", rotation)
    if mat.shape != (3, 3) or not np.allclose(mat.T @ mat, np.eye(3), atol=1e-9) \
            or np.linalg.det(mat) < 0.0:
        raise v.fail("rotation", f"a {mat.shape} array", "a 3 × 3 rotation matrix (orthonormal "
                     "columns = the sensor's axes in the board frame, determinant +1) or a "
                     "scipy Rotation")
    return np.array(mat, dtype=np.float64)


@dataclass(frozen=True, eq=False, repr=False)
class Magnetometer(Display):
    """A three-axis magnetometer (all SI).

    Parameters
    ----------
    field_range : float or (3,) floats
        Full-scale range ±field_range per axis, T; readings beyond it saturate (clip).
    resolution : float or (3,) floats
        One LSB per axis, T.
    noise : float or (3,) floats
        RMS noise per axis at ``rate`` in the part's stated mode, T.
    rate : float
        Output data rate, Hz, at which ``noise`` holds.
    position : (3,) floats
        Sensing point, m, in the board frame (the single-axis sensor's element is the origin).
    rotation : (3, 3) array or scipy Rotation, optional
        The sensor's axes in the board frame (columns); default aligned with the board.
    name : str
        Part name, for reports.
    """

    field_range: Any
    resolution: Any
    noise: Any
    rate: float
    position: Any = (0.0, 0.0, 0.0)
    rotation: Any = None
    name: str = "magnetometer"

    def __post_init__(self) -> None:
        object.__setattr__(self, "field_range", _axes("field_range", self.field_range, "T"))
        object.__setattr__(self, "resolution", _axes("resolution", self.resolution, "T"))
        object.__setattr__(self, "noise", _axes("noise", self.noise, "T"))
        object.__setattr__(self, "rate", v.positive("rate", self.rate, "Hz", "frequency"))
        pos = v.vector3("position", self.position)
        object.__setattr__(self, "position", tuple(float(p) for p in pos))
        mat = rotation_matrix(self.rotation)
        mat.setflags(write=False)
        object.__setattr__(self, "rotation", mat)

    def replace(self, **changes: Any) -> Magnetometer:
        """A copy with some fields changed (e.g. ``position=``, ``rotation=``)."""
        return replace(self, **changes)

    @property
    def sigma(self) -> F64:
        """RMS noise per sensor axis, T, shape (3,)."""
        return np.array(self.noise)

    def to_sensor(self, field: ArrayLike) -> F64:
        """Field on the sensor's axes, T, shape (..., 3), from a board-frame field (..., 3)."""
        return np.asarray(field, dtype=np.float64) @ self.rotation

    def to_board(self, reading: ArrayLike) -> F64:
        """Board-frame field, T, shape (..., 3), from a reading on the sensor's axes (..., 3)."""
        return np.asarray(reading, dtype=np.float64) @ self.rotation.T

    def in_range(self, field: ArrayLike) -> NDArray[np.bool_]:
        """True where a board-frame field (..., 3), T, lies within range on all three axes,
        shape (...)."""
        return np.all(np.abs(self.to_sensor(field)) <= np.array(self.field_range), axis=-1)

    def measure(self, field: ArrayLike, rng: int | np.random.Generator | None = None,
                noisy: bool = True) -> F64:
        """What the part reports for a board-frame field (..., 3), T: on the sensor's axes, plus
        white noise (if ``noisy``), clipped at ±field_range and rounded to the LSB, T,
        shape (..., 3)."""
        reading = self.to_sensor(field)
        if noisy:
            reading = reading + np.random.default_rng(rng).standard_normal(reading.shape) \
                * self.sigma
        rng_ = np.array(self.field_range)
        lsb = np.array(self.resolution)
        return np.asarray(np.round(np.clip(reading, -rng_, rng_) / lsb) * lsb, dtype=np.float64)

    def _display_items(self) -> list[Item]:
        def gauss(vals: tuple[float, float, float]) -> str:
            if len(set(vals)) == 1:
                return scaled(vals[0], 1e-4, "G")
            return "/".join(f"{x / 1e-4:.4g}" for x in vals) + " G"

        return [("", self.name), ("range", "±" + gauss(self.field_range)),
                ("LSB", gauss(self.resolution)), ("noise", gauss(self.noise)),
                ("rate", f"{self.rate:g} Hz"),
                ("position", "(" + ", ".join(f"{p * 1e3:.4g}" for p in self.position) + ") mm"),
                *([("rotated", "yes")] if not np.allclose(self.rotation, np.eye(3)) else [])]
