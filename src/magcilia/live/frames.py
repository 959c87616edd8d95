"""What the dashboard sends each browser: output samples averaged into display bins
(:func:`decimate`, :func:`display_factor`) and packed into binary frames (:func:`encode_frame`,
:func:`decode_frame`). Pure functions: arrays in, bytes out (the server is
:mod:`magcilia.live.dashboard`; the page's ``dashboard.js`` reads the same layout).

Two layouts, one format: a single-axis read-out's frames are version 1 (:data:`FRAME_HEADER`,
then the :data:`FRAME_COLUMNS`); force vectors' are version 2 (:data:`VECTOR_HEADER`: the same
header and the number of cilia C, 1 for a 3-axis sensor; then the column ``time`` and, per cilium
in the array's order, the :data:`VECTOR_COLUMNS`).
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
#: columns of a force-vector frame per cilium, after ``time``: Fx, Fy and their σ in display
#: units, flag bits (Flag, OR over the bin)
VECTOR_COLUMNS = ("fx", "fy", "sigma_x", "sigma_y", "flags")
#: header of a force-vector frame: :data:`FRAME_HEADER` and the number of cilia
VECTOR_HEADER = (*FRAME_HEADER, "cilia")
VECTOR_VERSION = 2


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
    ndarray, shape (5, k), or (1 + 5 C, k) for force vectors
        Rows ``time`` (s, mean), ``raw`` (V, mean), ``value`` and ``sigma`` (SI, mean of the
        unflagged samples; NaN where all are flagged), ``flags`` (bitwise OR of the bin's
        flags, so the worst flag stays), with ``k = (m − start) // factor``. Force vectors
        (C = 1 for a 3-axis sensor): ``time``, then per cilium Fx, Fy, σx, σy (N, means of the
        samples with a value) and ``flags``.
    """
    factor = v.integer("factor", factor, 1)
    k = max(0, (len(samples) - start) // factor)
    stop = start + k * factor

    def bins(x: NDArray[Any]) -> NDArray[Any]:
        return np.asarray(x[start:stop]).reshape(k, factor, *np.shape(x)[1:])

    if samples.kind != "scalar":
        return _decimate_vectors(samples, bins, k)
    out = np.empty((5, k))
    if k == 0:
        return out

    out[0] = bins(samples.time).mean(axis=1)
    out[1] = bins(samples.raw).mean(axis=1)
    value, sigma = bins(samples.value), bins(samples.sigma)
    good = np.isfinite(value)
    count = good.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        out[2] = np.where(good, value, 0.0).sum(axis=1) / count
        out[3] = np.where(good, sigma, 0.0).sum(axis=1) / count
    out[2:4, count == 0] = np.nan
    out[4] = np.bitwise_or.reduce(bins(samples.flags), axis=1)
    return out


def _decimate_vectors(samples: LiveSamples, bins: Any, k: int) -> F64:
    """:func:`decimate` of force vectors: (1 + 5 C, k)."""
    c_n = int(np.prod(samples.flags.shape[1:], dtype=np.int64))
    out = np.empty((1 + len(VECTOR_COLUMNS) * c_n, k))
    if k == 0:
        return out
    out[0] = bins(samples.time).mean(axis=1)
    value = bins(samples.value).reshape(k, -1, c_n, 2)
    sigma = bins(samples.sigma).reshape(value.shape)
    good = np.isfinite(value).all(axis=-1)
    count = good.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(good[..., None], value, 0.0).sum(axis=1) / count[..., None]
        spread = np.where(good[..., None], sigma, 0.0).sum(axis=1) / count[..., None]
    mean[count == 0] = np.nan
    spread[count == 0] = np.nan
    flags = np.bitwise_or.reduce(bins(samples.flags).reshape(k, -1, c_n), axis=1)
    per = np.concatenate([mean, spread, flags[..., None].astype(np.float64)], axis=-1)  # k,C,5
    out[1:] = per.transpose(1, 2, 0).reshape(-1, k)
    return out


def encode_frame(frame: int, columns: F64, *, received: float, sent: float,
                 bin_seconds: float, lost: int = 0, cilia: int = 0) -> bytes:
    """A binary frame: little-endian float64, the :data:`FRAME_HEADER` then the columns.

    Parameters
    ----------
    frame : int
        Frame id (the browser sends it back once drawn).
    columns : ndarray, shape (5, k), or (1 + 5 C, k) with ``cilia``
        :data:`FRAME_COLUMNS` in display units; with ``cilia`` C > 0, ``time`` and per cilium
        the :data:`VECTOR_COLUMNS` (a version-2 frame).
    received : float
        Wall time at which the newest sample arrived, s (:func:`time.time`).
    sent : float
        Wall time of sending, s.
    bin_seconds : float
        Seconds per point, s.
    lost : int
        Output samples this browser missed since the last frame (it fell behind).
    cilia : int
        0 for a single-axis read-out's frame; the number of force vectors per sample else.
    """
    columns = np.asarray(columns, dtype="<f8")
    rows = _rows(cilia)
    if columns.ndim != 2 or columns.shape[0] != rows:
        raise v.fail("columns", columns.shape, f"an array of shape ({rows}, k)")
    header = [FRAME_VERSION, frame, columns.shape[1], received, sent, bin_seconds, lost]
    if cilia:
        header = [VECTOR_VERSION, *header[1:], cilia]
    return np.array(header, dtype="<f8").tobytes() + columns.tobytes()


def _rows(cilia: int) -> int:
    """Columns of a frame: :data:`FRAME_COLUMNS`, or ``time`` and 5 per cilium."""
    return 1 + len(VECTOR_COLUMNS) * cilia if cilia else len(FRAME_COLUMNS)


def decode_frame(data: bytes) -> tuple[dict[str, float], F64]:
    """The header (:data:`FRAME_HEADER` names; :data:`VECTOR_HEADER` for force vectors) and
    columns (shape (5, k), or (1 + 5 C, k)) of a frame."""
    raw = np.frombuffer(data, dtype="<f8")
    names = VECTOR_HEADER if raw.size and raw[0] == VECTOR_VERSION else FRAME_HEADER
    n = len(names)
    if raw.size < n or raw[0] not in (FRAME_VERSION, VECTOR_VERSION):
        raise v.fail("frame", f"{len(data)} bytes", f"a version-{FRAME_VERSION} or "
                     f"{VECTOR_VERSION} dashboard frame")
    header = dict(zip(names, (float(x) for x in raw[:n]), strict=True))
    k = int(header["points"])
    rows = _rows(int(header.get("cilia", 0)))
    if raw.size != n + rows * k:
        raise v.fail("frame", f"{len(data)} bytes", f"{n + rows * k} float64")
    return header, raw[n:].reshape(rows, k).astype(np.float64)
