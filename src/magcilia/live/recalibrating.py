"""The live read-out's in-use re-calibration (``magcilia live --recalibrate EVERY``).

:class:`LiveRecalibration` sits between a source whose blocks carry the applied coil field
(``actuation_x_T``, ``actuation_y_T``, ``actuation_z_T``: the simulated coil,
:class:`~magcilia.acquire.simulated_coil.SimulatedCoilSource`) and the read-out: each block's
samples go through a :class:`~magcilia.readout.recalibration_stream.PulseTracker`, which finds
the pulses, re-estimates the drifts and holds the pulse samples at the level before them; the
samples are then mapped back to the calibrated scale (:meth:`Recalibration.correct`) and the
pipeline flags the readings that held pulse samples ``Flag.COIL_PULSE`` (no value is shown for
them). :meth:`LiveRecalibration.text` is the status line's part: when it last re-calibrated and
what changed.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from magcilia._validate import fail
from magcilia.acquire.simulated_coil import ACTUATION_COLUMNS
from magcilia.acquire.source import Block
from magcilia.readout.protocol import FLAG_DTYPE, Flag
from magcilia.readout.recalibration_stream import PulseTracker

F64 = NDArray[np.float64]


class LiveRecalibration:
    """Coil pulses in a live read-out (see the module docstring).

    Parameters
    ----------
    tracker : PulseTracker
        Finds the pulses and keeps the re-calibration's state.
    force : bool
        The read-out reads a force: its values are scaled by the stiffness's drift.
    """

    def __init__(self, tracker: PulseTracker, *, force: bool = True) -> None:
        if not isinstance(tracker, PulseTracker):
            raise fail("tracker", type(tracker).__name__, "a PulseTracker")
        self.tracker = tracker
        self.force = bool(force)
        self.now = 0.0

    def process(self, block: Block, raw: F64) -> tuple[F64, NDArray[np.bool_]]:
        """The block's outputs (n,), V, corrected and with the pulse samples held, and the mask
        of the pulse samples (n,)."""
        names = {c.name for c in block.channels}
        if not set(ACTUATION_COLUMNS) <= names:
            raise fail("source", "one without the coil's field channels", "a source that "
                       "records the applied field (actuation_x_T, _y_T, _z_T) for --recalibrate")
        applied = np.column_stack([block[c] for c in ACTUATION_COLUMNS])
        held, mask = self.tracker.push(block.time, raw, applied, block.setreset)
        if block.time.size:
            self.now = float(block.time[-1])
        return self.tracker.state.correct(held), mask

    def flag(self, value: NDArray[np.float64], flags: NDArray[np.uint16], pulsed: NDArray[np.bool_],
             factor: int) -> tuple[NDArray[np.float64], NDArray[np.uint16]]:
        """Readings (m,) of ``factor`` samples each: the values scaled (:attr:`scale`) and the
        flags with COIL_PULSE where a reading held a pulse sample (``pulsed``, (m·factor,))."""
        on = pulsed.reshape(-1, factor).any(axis=1)
        bit = np.where(on, FLAG_DTYPE(Flag.COIL_PULSE), FLAG_DTYPE(0))
        return np.asarray(value * self.scale), np.asarray(flags | bit, dtype=FLAG_DTYPE)

    @property
    def scale(self) -> float:
        """Factor on the read-out's values: the stiffness's drift for a force, else 1."""
        return self.tracker.state.force_scale if self.force else 1.0

    def text(self) -> str:
        """``recal 12 s ago: S −1.8±0.1 %, offset +0.30±0.01 mV``, or "" before any pulse."""
        if not self.tracker.updates:
            return ""
        return self.tracker.state.status_text(self.now)
