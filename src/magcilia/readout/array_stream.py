"""An array read-out over a stream of frames: every call starts warm from the one before.

:class:`ArrayStream` wraps an :class:`~magcilia.ArrayReadout` (:meth:`ArrayReadout.stream`) and
follows the read-out protocol (:mod:`magcilia.readout.protocol`): its :meth:`ArrayStream.read`
is the read-out's, with ``start`` the last estimate of the call before (when it converged inside
the box), so that chunks of a live array (:mod:`magcilia.live`) start from the last frame
instead of from rest. It holds that one estimate and nothing else; the estimates are those of
:meth:`ArrayReadout.read` (the start changes the work, not the result).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia._display import Display, Item
from magcilia.readout.array_results import ArrayEstimate, ArrayEstimates
from magcilia.readout.tare import Tare

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False, repr=False)
class ArrayStream(Display):
    """An :class:`~magcilia.ArrayReadout` read frame after frame, each call warm-started (its
    fields fixed; it holds the last frame's forces, the one thing a call changes).

    Parameters
    ----------
    readout : ArrayReadout
        The read-out (its ``read(samples, noise=, start=)``).

    Attributes
    ----------
    readout : ArrayReadout
    last : ndarray, shape (C, 2), or None
        The last frame's forces, N (None before the first call, or after one that did not
        converge: the next starts cold).
    """

    readout: Any
    _held: list[F64 | None] = field(default_factory=lambda: [None], repr=False)
    _lock: Any = field(default_factory=threading.Lock, repr=False)

    @property
    def last(self) -> F64 | None:
        """The last frame's forces, N, (C, 2), or None (a copy)."""
        with self._lock:
            held = self._held[0]
        return None if held is None else held.copy()

    @property
    def inputs(self) -> tuple[str, ...]:
        """The read-out's inputs (every sensor's three axes)."""
        return tuple(self.readout.inputs)

    @property
    def rest(self) -> F64:
        """The read-out's readings at rest, T, (3 S,)."""
        return np.asarray(self.readout.rest, dtype=np.float64)

    @property
    def baseline(self) -> Tare | None:
        """The read-out's tare."""
        return self.readout.baseline

    @property
    def sigma(self) -> F64:
        """The read-out's noise per input, T, (3 S,)."""
        return np.asarray(self.readout.sigma, dtype=np.float64)

    def read(self, samples: ArrayLike, /, *, noise: ArrayLike | None = None
             ) -> ArrayEstimate | ArrayEstimates:
        """:meth:`ArrayReadout.read` of the next frames (n, 3 S) or one (3 S,), T, started
        from the last estimate of the call before."""
        start = self.last
        est = self.readout.read(samples, noise=noise, start=start)
        force = np.asarray(est.force).reshape(-1, *np.shape(est.force)[-2:])
        converged = np.atleast_1d(np.asarray(est.converged))
        last = force[-1] if force.shape[0] and converged[-1] else None
        if last is not None and not np.all(np.isfinite(last)):
            last = None
        with self._lock:
            self._held[0] = None if last is None else last.copy()
        return est

    def tare(self, baseline: ArrayLike, /) -> ArrayStream:
        """A stream of the tared read-out (:meth:`ArrayReadout.tare`), starting cold."""
        return ArrayStream(self.readout.tare(baseline))

    def to_dict(self) -> dict[str, Any]:
        """The read-out's JSON-ready summary."""
        return dict(self.readout.to_dict())

    def report(self) -> str:
        """The read-out's report, and where the next call starts."""
        return (f"{self.readout.report()}; read as a stream: the next call starts "
                f"{'cold' if self.last is None else 'warm from the last frame'}")

    def _display_items(self) -> list[Item]:
        return [*self.readout._display_items(),
                ("next start", "cold" if self.last is None else "warm")]
