"""Tilt toward any azimuth: the paper's model turned about the vertical axis.

A rigid tilt toward azimuth φ (the axis leans along ``(sin θ cos φ, sin θ sin φ, cos θ)``; φ = 0 is
the paper's path, toward +x) is the tilt toward +x seen in a frame turned by φ about the vertical
axis through the sensing element (the origin). The cilium is a body of revolution whose dipole
rings are laid out from the bending direction, so turning the world by −φ maps the experiment onto
the φ = 0 model exactly (the rings turn with it: for odd k a tilt toward φ = π is not the model's
tilt by −θ, whose rings keep their place; both are the same body to the model's accuracy):
the base centre ``(x, y)`` becomes :func:`placement_in_tilt_frame`, and the field found there
turns back by +φ (:func:`field_from_tilt_frame`). z and the sensor depth do not change.

Examples
--------
>>> import numpy as np
>>> [round(float(c), 12) for c in placement_in_tilt_frame(1.0, 0.0, np.pi / 2)]
[0.0, -1.0]
>>> field_from_tilt_frame(np.array([[1.0, 0.0, 2.0]]), np.pi / 2).round(12)
array([[0., 1., 2.]])
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]


def turn_xy(x: ArrayLike, y: ArrayLike, azimuth: ArrayLike, *, inverse: bool = False
            ) -> tuple[Any, Any]:
    """(x, y) turned about the vertical axis by ``azimuth`` (rad, counter-clockwise seen from
    +z): ``R(φ) · (x, y)``, or ``R(−φ) · (x, y)`` with ``inverse`` (the sine's sign flipped
    exactly, so a turn and its inverse are exact mirrors). Arrays broadcast; the one rotation
    about z of the house (:func:`turn_about_z` for vectors)."""
    c, s = np.cos(azimuth), np.sin(azimuth)
    if inverse:
        s = -s
    return c * x - s * y, s * x + c * y


def turn_about_z(vectors: ArrayLike, azimuth: ArrayLike, *, inverse: bool = False) -> F64:
    """Vectors (..., 3) turned about the vertical axis by ``azimuth`` (rad; ``inverse``: by
    −``azimuth``), z unchanged (:func:`turn_xy`); ``azimuth`` broadcasts against
    ``vectors[..., 0]``."""
    b = np.asarray(vectors, dtype=np.float64)
    x, y = turn_xy(b[..., 0], b[..., 1], azimuth, inverse=inverse)
    out = np.empty(np.broadcast_shapes(b.shape, (*np.shape(x), 3)))
    out[..., 0] = x
    out[..., 1] = y
    out[..., 2] = b[..., 2]
    return out


def placement_in_tilt_frame(x: ArrayLike, y: ArrayLike,
                            azimuth: ArrayLike) -> tuple[F64, F64] | tuple[float, float]:
    """The base centre's (x, y), m, in the frame where a tilt toward ``azimuth`` (rad) is a tilt
    toward +x: ``R(−φ) · (x, y)`` (:func:`turn_xy`). Arrays broadcast."""
    return turn_xy(x, y, azimuth, inverse=True)


def field_from_tilt_frame(b: ArrayLike, azimuth: ArrayLike) -> F64:
    """A field (..., 3), T, found in the turned frame, back in the sensor's frame: ``R(φ) · B``
    (``azimuth`` broadcasts against ``b[..., 0]``; :func:`turn_about_z`)."""
    return turn_about_z(b, azimuth)
