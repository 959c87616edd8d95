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

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]


def placement_in_tilt_frame(x: ArrayLike, y: ArrayLike,
                            azimuth: ArrayLike) -> tuple[F64, F64] | tuple[float, float]:
    """The base centre's (x, y), m, in the frame where a tilt toward ``azimuth`` (rad) is a tilt
    toward +x: ``R(−φ) · (x, y)``. Arrays broadcast."""
    c, s = np.cos(azimuth), np.sin(azimuth)
    return c * x + s * y, -s * x + c * y  # type: ignore[return-value]


def field_from_tilt_frame(b: ArrayLike, azimuth: ArrayLike) -> F64:
    """A field (..., 3), T, found in the turned frame, back in the sensor's frame: ``R(φ) · B``
    (``azimuth`` broadcasts against ``b[..., 0]``)."""
    b = np.asarray(b, dtype=np.float64)
    c, s = np.cos(azimuth), np.sin(azimuth)
    out = np.empty(np.broadcast_shapes(b.shape, (*np.shape(c), 3) if np.ndim(c) else b.shape))
    out[..., 0] = c * b[..., 0] - s * b[..., 1]
    out[..., 1] = s * b[..., 0] + c * b[..., 1]
    out[..., 2] = b[..., 2]
    return out
