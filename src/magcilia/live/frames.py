"""What the dashboard sends each browser: output samples averaged into display bins
(:func:`decimate`, :func:`display_factor`) and packed into binary frames (:func:`encode_frame`,
:func:`decode_frame`). Pure functions: arrays in, bytes out (the server is
:mod:`magcilia.live.dashboard`; the page's ``dashboard.js`` reads the same layout).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.live.history import LiveSamples

F64 = NDArray[np.float64]

#: most points per trace over the whole window
MAX_POINTS = 2000
#: columns of a frame, in order: s since the start, raw output in mV, the estimate and its σ
#: in display units, flag bits (ReadoutFlag, OR over the bin)
FRAME_COLUMNS = ("time", "raw_mV", "value", "sigma", "flags")
#: header of a frame (float64 each): format version, frame id, points, wall time at which the
#: newest sample arrived (s, time.time()), wall time sent, seconds per point, samples lost
FRAME_HEADER = ("version", "frame", "points", "received", "sent", "bin_seconds", "lost")
FRAME_VERSION = 1


def display_factor(window: float, rate: float, points: int = MAX_POINTS) -> int:
    """Output samples per display point so that ``window`` s at ``rate`` Hz fit in ``points``.

    Parameters
    ----------
    window : float
        Seconds shown, s.
    rate : float
        Output samples per second, Hz.
    points : int
        Most points per trace.
    """
    return max(1, math.ceil(window * rate / points - 1e-9))


def decimate(samples: LiveSamples, factor: int, start: int = 0) -> F64:
    """Average consecutive samples into display bins.

    Parameters
    ----------
    samples : LiveSamples
        Output samples (m of them).
    factor : int
        Samples per bin.
    start : int
        Index of the first sample of the first bin; a trailing partial bin is left out.

    Returns
    -------
    ndarray, shape (5, k)
        Rows ``time`` (s, mean), ``raw`` (V, mean), ``value`` and ``sigma`` (SI, mean of the
        unflagged samples; NaN where all are flagged), ``flags`` (bitwise OR of the bin's
        flags, so the worst flag stays), with ``k = (m − start) // factor``.
    """
    factor = v.integer("factor", factor, 1)
    k = max(0, (len(samples) - start) // factor)
    stop = start + k * factor
    out = np.empty((5, k))
    if k == 0:
        return out

    def bins(x: NDArray[Any]) -> NDArray[Any]:
        return np.asarray(x[start:stop]).reshape(k, factor)

    out[0] = bins(samples.time).mean(axis=1)
    out[1] = bins(samples.raw).mean(axis=1)
    value, sigma = bins(samples.value), bins(samples.sigma)
    good = np.isfinite(value)
    count = good.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        out[2] = np.where(good, value, 0.0).sum(axis=1) / count
        out[3] = np.where(good, sigma, 0.0).sum(axis=1) / count
    out[2:4, count == 0] = np.nan
    out[4] = np.bitwise_or.reduce(bins(samples.flags).astype(np.uint16), axis=1)
    return out


def encode_frame(frame: int, columns: F64, *, received: float, sent: float,
                 bin_seconds: float, lost: int = 0) -> bytes:
    """A binary frame: little-endian float64, the :data:`FRAME_HEADER` then the columns.

    Parameters
    ----------
    frame : int
        Frame id (the browser sends it back once drawn).
    columns : ndarray, shape (5, k)
        :data:`FRAME_COLUMNS` in display units.
    received : float
        Wall time at which the newest sample arrived, s (:func:`time.time`).
    sent : float
        Wall time of sending, s.
    bin_seconds : float
        Seconds per point, s.
    lost : int
        Output samples this browser missed since the last frame (it fell behind).
    """
    columns = np.asarray(columns, dtype="<f8")
    if columns.ndim != 2 or columns.shape[0] != len(FRAME_COLUMNS):
        raise v.fail("columns", columns.shape, f"an array of shape ({len(FRAME_COLUMNS)}, k)")
    header = np.array([FRAME_VERSION, frame, columns.shape[1], received, sent, bin_seconds,
                       lost], dtype="<f8")
    return header.tobytes() + columns.tobytes()


def decode_frame(data: bytes) -> tuple[dict[str, float], F64]:
    """The header (:data:`FRAME_HEADER` names) and columns (shape (5, k)) of a frame."""
    raw = np.frombuffer(data, dtype="<f8")
    n = len(FRAME_HEADER)
    if raw.size < n or raw[0] != FRAME_VERSION:
        raise v.fail("frame", f"{len(data)} bytes", f"a version-{FRAME_VERSION} dashboard frame")
    header = dict(zip(FRAME_HEADER, (float(x) for x in raw[:n]), strict=True))
    k = int(header["points"])
    if raw.size != n + len(FRAME_COLUMNS) * k:
        raise v.fail("frame", f"{len(data)} bytes", f"{n + len(FRAME_COLUMNS) * k} float64")
    return header, raw[n:].reshape(len(FRAME_COLUMNS), k).astype(np.float64)
