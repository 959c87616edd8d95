"""Scalar measures of how an output curve differs from a reference or from measurements, shared
by the one-at-a-time sweeps, the Sobol analysis and the tolerance study (SI: V, V², rad)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.io.recordings import Measurement

F64 = NDArray[np.float64]

#: the paper's 33 tilt angles over 0..85°, rad
DEFAULT_ANGLES = np.radians(np.linspace(0.0, 85.0, 33))
MEASURES = ("rms", "shape", "cost")


# -- measures ------------------------------------------------------------------------------------
def offset_cost(model: ArrayLike, measured: ArrayLike) -> F64:
    """Calibration cost with the output offset solved in closed form, V².

    ``cost = Σ_a (y_a − u_a − c)²`` minimised over the constant c (so c = mean(y − u)): the
    paper's sum of squared errors with the DC bias fitted jointly (``calibrate(bias="offset")``).

    Parameters
    ----------
    model : array-like, shape (..., a)
        Model outputs, V (any offset they carry cancels).
    measured : array-like, shape (a,)
        Measured per-angle means, V.

    Returns
    -------
    ndarray, shape (...)
        Cost per model curve, V².
    """
    r = np.asarray(measured, dtype=np.float64) - np.asarray(model, dtype=np.float64)
    r = r - r.mean(axis=-1, keepdims=True)
    return np.asarray(np.einsum("...a,...a->...", r, r), dtype=np.float64)


def rms_change(curves: ArrayLike, reference: ArrayLike) -> F64:
    """RMS over angles of ``curves − reference``, V, shape (...) for curves (..., a)."""
    d = np.asarray(curves, dtype=np.float64) - np.asarray(reference, dtype=np.float64)
    return np.asarray(np.sqrt(np.mean(d * d, axis=-1)), dtype=np.float64)


def shape_change(curves: ArrayLike, reference: ArrayLike) -> F64:
    """Offset-free RMS change, V, shape (...): RMS over angles of ``curves − reference`` after
    removing its mean, i.e. the part of the change that a fitted output offset cannot absorb
    (``shape² = rms² − mean²``)."""
    d = np.asarray(curves, dtype=np.float64) - np.asarray(reference, dtype=np.float64)
    d = d - d.mean(axis=-1, keepdims=True)
    return np.asarray(np.sqrt(np.mean(d * d, axis=-1)), dtype=np.float64)


def data_angles(data: Measurement | None) -> F64 | None:
    if data is None:
        return None
    if not isinstance(data, Measurement):
        raise v.fail("data", type(data).__name__, "a magcilia Measurement (use read_measurements)")
    data.require_single_path("the sensitivity analysis (data=, CLI: --data)",
                             "give a recording of the single-axis output at azimuth 0, or "
                             "leave the data out")
    if len(data) < 2:
        raise v.fail("data", f"{len(data)} angle(s)", "a recording with at least 2 angles")
    return np.asarray(data.angles, dtype=np.float64)


def check_angles(angles: ArrayLike | None) -> F64:
    """Tilt angles, rad, shape (a,): finite, non-empty; None gives :data:`DEFAULT_ANGLES`."""
    if angles is None:
        return DEFAULT_ANGLES.copy()
    ang = v.finite_array("angles", angles, ndim=1, unit="rad")
    if ang.size < 1:
        raise v.fail("angles", "an empty array", "at least one tilt angle in rad")
    return ang
