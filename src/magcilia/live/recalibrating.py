"""The live read-out's in-use re-calibration (``magcilia live --recalibrate EVERY``).

:class:`LiveRecalibration` sits between a source whose blocks carry the applied coil field
(``actuation_x_T``, ``actuation_y_T``, ``actuation_z_T``: the simulated coil,
:class:`~magcilia.acquire.simulated_coil.SimulatedCoilSource`) and the read-out: each block's
samples go through a :class:`~magcilia.readout.recalibration_stream.PulseTracker`, which finds
the pulses, re-estimates the drifts and holds the pulse samples at the level before them; the
samples are then mapped back to the calibrated scale (:meth:`Recalibration.correct`: offset and
sensitivity at once, the magnetization once it is precise enough, see ``level_sigma``) and the
pipeline flags the readings that held pulse samples ``Flag.COIL_PULSE`` (no value is shown for
them). :meth:`LiveRecalibration.text` is the status line's part: when it last re-calibrated and
what changed.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._validate import fail
from magcilia.acquire.simulated_coil import ACTUATION_COLUMNS
from magcilia.acquire.source import Block
from magcilia.readout.protocol import FLAG_DTYPE, Flag
from magcilia.readout.recalibration import Recalibration
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
    level_sigma : float
        The magnetization (and the stiffness) enter the correction only once their σ moves
        the rest level, S·s·m·B₀ₓ, by less than this, V: pulses alone fix M to a few % (a
        rest window to 0.1 %), and the rest field is large beside a load's (for the
        force-sensor hair a 1 % error in M reads as ~2 µN); until then the tare and zero
        tracking keep the level, and the status shows the estimate with its σ.
    """

    def __init__(self, tracker: PulseTracker, *, force: bool = True,
                 level_sigma: float = 2e-6) -> None:
        if not isinstance(tracker, PulseTracker):
            raise fail("tracker", type(tracker).__name__, "a PulseTracker")
        self.tracker = tracker
        self.force = bool(force)
        self.level_sigma = v.positive("level_sigma", level_sigma, "V", "voltage")
        self.now = 0.0

    @property
    def applied(self) -> Recalibration:
        """The state the samples are corrected with: the tracker's, with the magnetization and
        stiffness left at the calibration's while too uncertain (``level_sigma``)."""
        state = self.tracker.state
        rc = self.tracker.recalibrator
        level = abs(rc.scale * rc.rest_field) * state.sigma["magnetization"]
        if "magnetization" in state.determined and level < self.level_sigma:
            return state
        keep = ("magnetization", "stiffness")
        return replace(state, values={**state.values, **{k: state.reference[k] for k in keep}},
                       sigma={**state.sigma, **dict.fromkeys(keep, 0.0)})

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
        return self.applied.correct(held), mask

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
        return self.applied.force_scale if self.force else 1.0

    def text(self) -> str:
        """``recal 12 s ago: S −1.8±0.1 %, offset +0.30±0.01 mV``, or "" before any pulse."""
        if not self.tracker.updates:
            return ""
        return self.tracker.state.status_text(self.now)
