"""The live read-out's memory: the last seconds of output samples, read by any number of views.

One writer (the read-out thread) appends; each view keeps its own *cursor* (how many samples it
has seen) and asks for what came since. Views never block the writer for longer than a copy of
what they asked for, and a view that falls behind loses the oldest samples (counted), never the
read-out's.

Shape letters: ``m`` output samples.
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
from magcilia.readout.inverse import NO_ESTIMATE

F64 = NDArray[np.float64]

#: the columns of a LiveSamples, in order (flags are stored as float in the ring)
COLUMNS = ("time", "raw", "value", "sigma", "flags", "correction", "received", "published")


@dataclass(frozen=True, eq=False, repr=False)
class LiveSamples(Display):
    """Output samples of a live read-out (immutable; arrays of shape (m,)).

    Attributes
    ----------
    quantity : str
        ``"angle"``, ``"force"`` or ``"flow"``.
    unit : str
        SI unit of ``value`` and ``sigma``.
    time : ndarray
        Time of each sample, s since the read-out started (centre of its averaging window).
    raw : ndarray
        Averaged (set/reset-demodulated) sensor output, V, before the tare correction.
    value, sigma : ndarray
        Estimate and its 1-σ uncertainty, SI (NaN where a flag of
        :data:`~magcilia.readout.inverse.NO_ESTIMATE` is set).
    flags : ndarray of uint16
        :class:`~magcilia.readout.inverse.ReadoutFlag` bits (0: a good reading; EXTRAPOLATED or
        CLIPPED readings just beyond the span have values).
    correction : ndarray
        Tare + zero-tracking correction added to ``raw`` before the read-out, V.
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
                             dtype=np.uint16 if name == "flags" else np.float64)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return int(self.time.size)

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
        good = np.nonzero(self.flags & np.uint16(NO_ESTIMATE) == 0)[0]
        last = (f"last {q.to_display(self.value[good[-1]]):.4g} ± "
                f"{q.to_display(self.sigma[good[-1]]):.2g} {q.display}" if good.size
                else "no good reading")
        lat = self.latency * 1e3
        return (f"{len(self)} {self.quantity} samples over {self.time[-1] - self.time[0]:.3g} s, "
                f"{good.size} good; {last}; latency median {np.median(lat):.2g} ms, "
                f"max {np.max(lat):.2g} ms")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        q = MEASURANDS[self.quantity]
        items = [("", self.quantity), ("", count(self.time.size, "sample"))]
        if self.time.size:
            last = f"{q.text(float(self.value[-1]))} ± {q.text(float(self.sigma[-1]))}"
            items += [("time", f"{self.time[0]:.4g}…{self.time[-1]:.4g} s"), ("last", last)]
        return items

    def to_dataframe(self) -> Any:
        """The samples as a ``pandas.DataFrame``, SI, one row per reading: ``time_s``, ``raw_V``,
        the value and ``sigma`` named by quantity and unit (``force_N``, ``sigma_N``), ``flags``,
        ``correction_V``, ``received_s``, ``published_s``."""
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
    """

    def __init__(self, quantity: str, unit: str, capacity: int) -> None:
        self.quantity = quantity
        self.unit = unit
        self.capacity = v.integer("capacity", capacity, 1)
        self._ring = np.full((len(COLUMNS), self.capacity), np.nan)
        self._total = 0
        self._lock = threading.Condition()

    @property
    def total(self) -> int:
        """Samples appended so far (the cursor of a view that has seen them all)."""
        return self._total

    def append(self, columns: F64) -> None:
        """Append samples: ``columns`` of shape (len(COLUMNS), m), in :data:`COLUMNS` order."""
        m = columns.shape[1]
        kept = min(m, self.capacity)
        with self._lock:
            idx = (self._total + m - kept + np.arange(kept)) % self.capacity
            columns = columns[:, m - kept:]
            self._ring[:, idx] = columns
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
            block = self._ring[:, idx]
        return self._samples(block), total, lost

    def last(self, seconds: float, rate: float) -> LiveSamples:
        """The samples of the last ``seconds`` at output ``rate`` Hz (at most ``capacity``)."""
        n = min(self.capacity, max(1, round(seconds * rate)))
        return self.since(self._total - n)[0]

    def wait(self, cursor: int, timeout: float) -> bool:
        """Wait up to ``timeout`` s for samples past ``cursor``; whether there are some."""
        with self._lock:
            return self._lock.wait_for(lambda: self._total > cursor, timeout)

    def _samples(self, block: F64) -> LiveSamples:
        values = dict(zip(COLUMNS, block, strict=True))
        return LiveSamples(self.quantity, self.unit, **values)

