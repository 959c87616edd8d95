"""The live read-out's memory: the last seconds of output samples, read by any number of views.

One writer (the read-out thread) appends; each view keeps its own *cursor* (how many samples it
has seen) and asks for what came since. Views never block the writer for longer than a copy of
what they asked for, and a view that falls behind loses the oldest samples (counted), never the
read-out's.

Each sample holds, per column, a scalar or an array of a fixed shape: a single-axis read-out's
value is a number, a 3-axis sensor's a force vector (2,), an array's one force vector per cilium
(C, 2); ``raw`` and ``correction`` hold one entry per channel read (c,) when there are several.

Shape letters: ``m`` output samples, ``c`` channels, ``C`` cilia.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, column, count, dataframe
from magcilia.device.parameters import MEASURANDS
from magcilia.readout.protocol import FLAG_DTYPE, Flag

F64 = NDArray[np.float64]

#: the columns of a LiveSamples, in order
COLUMNS = ("time", "raw", "value", "sigma", "flags", "correction", "received", "published")
#: the flags that leave a sample without a value (NaN value and σ)
NO_ESTIMATE = Flag.OUTSIDE_SPAN | Flag.FOLD | Flag.SATURATED | Flag.UNDETERMINED


@dataclass(frozen=True, eq=False, repr=False)
class LiveSamples(Display):
    """Output samples of a live read-out (immutable; arrays of shape (m,) for a single-axis
    read-out, (m, ...) for the others).

    Attributes
    ----------
    quantity : str
        ``"angle"``, ``"force"`` or ``"flow"``.
    unit : str
        SI unit of ``value`` and ``sigma``.
    time : ndarray, shape (m,)
        Time of each sample, s since the read-out started (centre of its averaging window).
    raw : ndarray, shape (m,) or (m, c)
        Averaged (set/reset-demodulated) readings before the tare correction: the sensor output,
        V; several field channels, T (one column per channel).
    value, sigma : ndarray, shape (m,), (m, 2) or (m, C, 2)
        Estimate and its 1-σ uncertainty, SI: a number, a force vector (Fx, Fy), or one per
        cilium (NaN where a flag of :data:`NO_ESTIMATE` is set).
    flags : ndarray of uint16, shape (m,) or (m, C)
        :class:`~magcilia.readout.protocol.Flag` bits (0: a good reading; EXTRAPOLATED or
        CLIPPED readings just beyond the span have values).
    correction : ndarray, shape (m,) or (m, c)
        Tare + zero-tracking correction added to ``raw`` before the read-out (its unit).
    received : ndarray
        Wall-clock time (:func:`time.time`) at which the window's last sample reached the
        computer, s.
    published : ndarray
        Wall-clock time at which the estimate was ready, s.
    """

    quantity: str
    unit: str
    time: F64
    raw: F64
    value: F64
    sigma: F64
    flags: NDArray[np.uint16]
    correction: F64
    received: F64
    published: F64

    def __post_init__(self) -> None:
        for name in COLUMNS:
            arr = np.asarray(getattr(self, name),
                             dtype=FLAG_DTYPE if name == "flags" else np.float64)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return int(self.time.size)

    @property
    def kind(self) -> str:
        """``"scalar"`` (one value per sample), ``"vector"`` (a force vector) or ``"array"``
        (one force vector per cilium)."""
        return ("scalar", "vector", "array")[min(self.value.ndim, 3) - 1]

    @property
    def good(self) -> NDArray[np.bool_]:
        """Whether each estimate has a value (no flag of :data:`NO_ESTIMATE`), shape of
        ``flags``."""
        return np.asarray(self.flags & FLAG_DTYPE(NO_ESTIMATE) == 0)

    @property
    def magnitude(self) -> F64:
        """|F| of each force vector, N, shape of ``flags`` (a scalar read-out: ``value``)."""
        if self.kind == "scalar":
            return self.value
        return np.asarray(np.hypot(self.value[..., 0], self.value[..., 1]))

    @property
    def direction(self) -> F64:
        """Direction atan2(Fy, Fx) of each force vector, rad, shape of ``flags`` (NaN for a
        scalar read-out)."""
        if self.kind == "scalar":
            return np.full(self.value.shape, np.nan)
        return np.asarray(np.arctan2(self.value[..., 1], self.value[..., 0]))

    def first(self, count: int) -> LiveSamples:
        """The first ``count`` samples."""
        return LiveSamples(self.quantity, self.unit,
                           **{name: getattr(self, name)[:count] for name in COLUMNS})

    @property
    def latency(self) -> F64:
        """Sample in -> value out for each sample, s (``published − received``)."""
        return np.asarray(self.published - self.received)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; flagged values are NaN, written as null)."""
        out: dict[str, Any] = {"quantity": self.quantity, "unit": self.unit}
        out.update({name: getattr(self, name).tolist() for name in COLUMNS})
        return out

    def report(self) -> str:
        """One line: how many samples over what time, the last good value, the latency."""
        if not len(self):
            return f"no {self.quantity} samples"
        q = MEASURANDS[self.quantity]
        if self.kind != "scalar":
            good = self.good.reshape(len(self), -1)
            n_good = int(good.all(axis=1).sum())
            mag = np.where(good, self.magnitude.reshape(len(self), -1), np.nan)[-1]
            last = (f"last |F| up to {q.to_display(float(np.nanmax(mag))):.4g} {q.display}"
                    if np.isfinite(mag).any() else "no good reading")
            lat = self.latency * 1e3
            what = "force vectors" if self.kind == "vector" else \
                f"array samples ({self.value.shape[1]} cilia)"
            return (f"{len(self)} {what} over {self.time[-1] - self.time[0]:.3g} s, {n_good} "
                    f"good; {last}; latency median {np.median(lat):.2g} ms, max "
                    f"{np.max(lat):.2g} ms")
        index = np.nonzero(self.good)[0]
        last = (f"last {q.to_display(self.value[index[-1]]):.4g} ± "
                f"{q.to_display(self.sigma[index[-1]]):.2g} {q.display}" if index.size
                else "no good reading")
        lat = self.latency * 1e3
        return (f"{len(self)} {self.quantity} samples over {self.time[-1] - self.time[0]:.3g} s, "
                f"{index.size} good; {last}; latency median {np.median(lat):.2g} ms, "
                f"max {np.max(lat):.2g} ms")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        q = MEASURANDS[self.quantity]
        items = [("", self.quantity), ("", count(self.time.size, "sample"))]
        if self.time.size and self.kind != "scalar":
            items += [("time", f"{self.time[0]:.4g}…{self.time[-1]:.4g} s"),
                      ("shape", " × ".join(str(k) for k in self.value.shape[1:]))]
        elif self.time.size:
            last = f"{q.text(float(self.value[-1]))} ± {q.text(float(self.sigma[-1]))}"
            items += [("time", f"{self.time[0]:.4g}…{self.time[-1]:.4g} s"), ("last", last)]
        return items

    def to_dataframe(self) -> Any:
        """The samples as a ``pandas.DataFrame``, SI, one row per reading: ``time_s``, ``raw_V``,
        the value and ``sigma`` named by quantity and unit (``force_N``, ``sigma_N``), ``flags``,
        ``correction_V``, ``received_s``, ``published_s``. A force vector: ``force_x_N``,
        ``force_y_N``, ``sigma_x_N``, ``sigma_y_N``, ``flags``; an array: one row per reading
        and cilium (``cilium`` its index) with those columns; the channels' raw readings and
        corrections are left out of both."""
        if self.kind != "scalar":
            m = len(self)
            per = int(np.prod(self.flags.shape[1:], dtype=np.int64))
            cols: dict[str, Any] = {"time_s": np.repeat(self.time, per)}
            if self.kind == "array":
                cols["cilium"] = np.tile(np.arange(per), m)
            value = self.value.reshape(m * per, 2)
            sigma = self.sigma.reshape(m * per, 2)
            cols.update({column(f"{self.quantity}_x", self.unit): value[:, 0],
                         column(f"{self.quantity}_y", self.unit): value[:, 1],
                         column("sigma_x", self.unit): sigma[:, 0],
                         column("sigma_y", self.unit): sigma[:, 1],
                         "flags": self.flags.reshape(-1),
                         "published_s": np.repeat(self.published, per)})
            return dataframe(cols)
        return dataframe({"time_s": self.time, "raw_V": self.raw,
                          column(self.quantity, self.unit): self.value,
                          column("sigma", self.unit): self.sigma, "flags": self.flags,
                          "correction_V": self.correction, "received_s": self.received,
                          "published_s": self.published})


class History:
    """A ring of the last ``capacity`` output samples with cursors (see the module docstring).

    Parameters
    ----------
    quantity, unit : str
        What the samples estimate.
    capacity : int
        Samples kept.
    shapes : mapping of str to tuple of int, optional
        The shape of one sample of a column where it is not a number: ``value`` and ``sigma``
        (2,) for a force vector or (C, 2) for an array, ``flags`` (C,) for an array, ``raw``
        and ``correction`` (c,) for several channels.
    names : tuple of str
        The cilia of an array read-out, in order (() otherwise).
    """

    def __init__(self, quantity: str, unit: str, capacity: int,
                 shapes: dict[str, tuple[int, ...]] | None = None,
                 names: tuple[str, ...] = ()) -> None:
        self.quantity = quantity
        self.unit = unit
        self.capacity = v.integer("capacity", capacity, 1)
        self.shapes = {name: tuple((shapes or {}).get(name, ())) for name in COLUMNS}
        self.names = tuple(names)
        self._ring = {name: np.full((self.capacity, *self.shapes[name]), 0 if name == "flags"
                                    else np.nan, dtype=FLAG_DTYPE if name == "flags"
                                    else np.float64) for name in COLUMNS}
        self._total = 0
        self._lock = threading.Condition()

    @property
    def total(self) -> int:
        """Samples appended so far (the cursor of a view that has seen them all)."""
        return self._total

    def append(self, columns: F64 | dict[str, Any]) -> None:
        """Append m samples: a mapping of every column of :data:`COLUMNS` to its values (shape
        (m, *its shape)), or, when every column is a number, an array (len(COLUMNS), m) in
        :data:`COLUMNS` order."""
        cols = dict(zip(COLUMNS, columns, strict=True)) if not isinstance(columns, dict) \
            else columns
        m = int(np.shape(cols["time"])[0])
        kept = min(m, self.capacity)
        first = (self._total + m - kept) % self.capacity
        split = min(kept, self.capacity - first)  # the part before the ring wraps
        with self._lock:
            for name in COLUMNS:
                new, ring = np.asarray(cols[name])[m - kept:], self._ring[name]
                ring[first:first + split] = new[:split]
                ring[:kept - split] = new[split:]
            self._total += m
            self._lock.notify_all()

    def since(self, cursor: int, limit: int | None = None) -> tuple[LiveSamples, int, int]:
        """Samples appended since ``cursor``: (samples, new cursor, samples lost because the
        view fell more than ``capacity`` behind). With ``limit``, at most the newest ``limit``
        (the others count as skipped, not lost)."""
        with self._lock:
            total = self._total
            start = max(cursor, total - self.capacity, 0)
            lost = max(0, start - cursor)
            if limit is not None:
                start = max(start, total - limit)
            idx = np.arange(start, total) % self.capacity
            block = {name: self._ring[name][idx] for name in COLUMNS}
        return LiveSamples(self.quantity, self.unit, **block), total, lost

    def last(self, seconds: float, rate: float) -> LiveSamples:
        """The samples of the last ``seconds`` at output ``rate`` Hz (at most ``capacity``)."""
        n = min(self.capacity, max(1, round(seconds * rate)))
        return self.since(self._total - n)[0]

    def wait(self, cursor: int, timeout: float) -> bool:
        """Wait up to ``timeout`` s for samples past ``cursor``; whether there are some."""
        with self._lock:
            return self._lock.wait_for(lambda: self._total > cursor, timeout)
