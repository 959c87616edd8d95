"""What a recording says about itself, and what a reader says about it: the file's own word on
whether it is complete and what was planned (:class:`RecordingState`, from the properties that
:mod:`magcilia.io.recording_file` writes), and a reader's raw columns with its notes
(:class:`RawRecording`).

magcilia's recordings (TDMS) carry the root properties ``complete`` (False until the writer
closes the file as planned), ``planned_angles_deg`` (a sweep's angles, a JSON list),
``samples_per_angle``, and once closed ``samples`` and, if it ended early, ``stopped`` (why and
where). From them:

- a recording cut before its first chunk (``complete`` False, not a sample on disk) is one error
  line saying so, whatever else is missing (:meth:`RecordingState.require_samples`);
- a recording cut short (``complete`` False) is read, and noted as incomplete, with the planned
  angles it never reached (:meth:`RecordingState.notes`);
- a recording that says it is complete must hold what it planned: every planned angle with
  ``samples_per_angle`` samples and no other angle (else it is damaged: an error).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia._display import Display, Item
from magcilia._errors import MagciliaError
from magcilia._validate import printable

F64 = NDArray[np.float64]

#: planned and recorded angles this close (deg) are the same angle
ANGLE_MATCH_DEG = 1e-6
#: most planned angles read from a file's properties
MAX_PLANNED = 1_000_000


def _bool(value: Any) -> bool | None:
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer) and value in (0, 1):
        return bool(value)
    return None


def _count(value: Any) -> int | None:
    if isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_):
        return int(value) if value >= 0 else None
    return None


def _angles(value: Any) -> tuple[float, ...] | None:
    """Planned angles from a property: a JSON list (or a list), finite numbers; else None."""
    if isinstance(value, str):
        try:
            value = json.loads(value[:40 * MAX_PLANNED])
        except ValueError:
            return None
    if not isinstance(value, list | tuple) or len(value) > MAX_PLANNED:
        return None
    if not all(isinstance(a, int | float) and not isinstance(a, bool) and math.isfinite(a)
               for a in value):
        return None
    return tuple(float(a) for a in value)


def _degrees(values: ArrayLike) -> str:
    shown = [f"{a:g}" for a in np.asarray(values, dtype=np.float64)[:12]]
    more = len(np.atleast_1d(values)) - len(shown)
    return ", ".join(shown) + (f", … ({more} more)" if more > 0 else "") + " deg"


@dataclass(frozen=True, repr=False)
class RecordingState(Display):
    """What a recording file says about itself (None where it says nothing).

    Attributes
    ----------
    own : bool
        Written by magcilia (the property ``magcilia_version``).
    complete : bool or None
        Closed as planned (True), cut short (False), or not said (another program's file).
    planned_angles_deg : tuple of float or None
        A sweep's planned tilt angles, deg, in the order planned.
    samples_per_angle : int or None
        Samples recorded at each planned angle.
    samples : int or None
        Samples in the file, as its closing note says.
    stopped : str or None
        Why and where it stopped early.
    """

    own: bool = False
    complete: bool | None = None
    planned_angles_deg: tuple[float, ...] | None = None
    samples_per_angle: int | None = None
    samples: int | None = None
    stopped: str | None = None

    @classmethod
    def from_properties(cls, props: Mapping[str, Any]) -> RecordingState:
        """The state of a file's root properties (unreadable values are left out)."""
        stopped = props.get("stopped")
        return cls(own="magcilia_version" in props, complete=_bool(props.get("complete")),
                   planned_angles_deg=_angles(props.get("planned_angles_deg")),
                   samples_per_angle=_count(props.get("samples_per_angle")),
                   samples=_count(props.get("samples")),
                   stopped=printable(stopped)[:300] if isinstance(stopped, str) else None)

    def require_samples(self, path: str | Path, samples: int) -> None:
        """The error for a recording cut before its first chunk (``complete`` False, no sample
        in the file); nothing otherwise."""
        if self.complete is False and samples == 0:
            how = f"; {self.stopped}" if self.stopped else ""
            raise MagciliaError(f"{path}: the recording was cut before its first chunk "
                                f"(complete=False, no samples on disk{how}); record again")

    def _planned(self) -> tuple[F64, NDArray[np.int64]] | None:
        if self.planned_angles_deg is None:
            return None
        planned = np.round(np.asarray(self.planned_angles_deg, np.float64), 6)
        distinct, times = np.unique(planned, return_counts=True)
        return np.asarray(distinct, dtype=np.float64), times.astype(np.int64)

    def incomplete_note(self) -> str | None:
        """``the recording is incomplete (…)`` for a recording cut short, else None."""
        if self.complete is not False:
            return None
        return ("the recording is incomplete (complete=False: it was cut short"
                + (f"; {self.stopped})" if self.stopped else ")"))

    def missing_angles(self, angles_deg: ArrayLike) -> F64:
        """The planned angles (deg) that ``angles_deg`` (the recorded ones) lacks; empty without
        a plan."""
        plan = self._planned()
        if plan is None:
            return np.zeros(0)
        recorded = np.asarray(angles_deg, dtype=np.float64).ravel()
        near = np.abs(plan[0][:, None] - recorded[None, :]) <= ANGLE_MATCH_DEG
        return plan[0][~near.any(axis=1)] if recorded.size else plan[0]

    def notes(self, angles_deg: ArrayLike, counts: ArrayLike, where: str = "") -> list[str]:
        """What the recorded conditions (tilt angles, deg, and samples per angle, shapes (a,))
        say against the plan: for a recording cut short, that it is incomplete and which planned
        angles it never reached; for a complete one, nothing.

        ``where`` (the file) starts the error.

        Raises
        ------
        MagciliaError
            For a recording that says it is complete but lacks planned angles, holds angles not
            planned, or another number of samples at an angle than planned (damage).
        """
        recorded = np.asarray(angles_deg, dtype=np.float64).ravel()
        n = np.asarray(counts, dtype=np.int64).ravel()
        plan = self._planned()
        missing = self.missing_angles(recorded)
        out: list[str] = []
        incomplete = self.incomplete_note()
        if incomplete is not None:
            text = incomplete
            if plan is not None:
                text += (f"; {plan[0].size - missing.size} of {plan[0].size} planned angles "
                         "recorded" + (f", missing {_degrees(missing)}" if missing.size else ""))
            out.append(text)
        if plan is None:
            return out
        distance = np.abs(recorded[:, None] - plan[0][None, :])
        nearest = distance.argmin(axis=1) if plan[0].size else np.zeros(recorded.size, int)
        unplanned = (distance.min(axis=1) > ANGLE_MATCH_DEG if plan[0].size
                     else np.ones(recorded.size, bool))
        damage: list[str] = []
        if unplanned.any():
            damage.append(f"{int(unplanned.sum())} recorded angle(s) were never planned "
                          f"({_degrees(recorded[unplanned])})")
        if self.samples_per_angle is not None:
            want = self.samples_per_angle * plan[1][nearest]
            off = ~unplanned & (n != want)
            if self.complete is False and off.any():  # the last angle may be cut
                off[int(np.flatnonzero(off)[-1])] = False
            if off.any():
                i = int(np.flatnonzero(off)[0])
                damage.append(f"{int(off.sum())} angle(s) hold another number of samples than "
                              f"planned ({recorded[i]:g} deg: {n[i]} of {want[i]})")
        if self.complete and missing.size:
            damage.insert(0, f"{missing.size} planned angle(s) are missing "
                             f"({_degrees(missing)})")
        if damage and self.complete:
            raise MagciliaError(f"{where}: the file says it is complete, but " + "; ".join(damage)
                                + "; the file is damaged: copy it again from where it was "
                                "recorded")
        return out + damage

    def report(self) -> str:
        """One line: complete or cut short (and where), the plan."""
        state = {True: "complete", False: "cut short", None: "completeness not recorded"}[
            self.complete]
        text = f"recording {state}" + (f" ({self.stopped})" if self.stopped else "")
        if self.planned_angles_deg is not None:
            text += f"; {len(self.planned_angles_deg)} planned angles"
            if self.samples_per_angle is not None:
                text += f" × {self.samples_per_angle} samples"
        return text + ("" if self.samples is None else f"; {self.samples} samples")

    def _display_items(self) -> list[Item]:
        return [("complete", {True: "yes", False: "no", None: "-"}[self.complete]),
                ("planned angles", "-" if self.planned_angles_deg is None
                 else str(len(self.planned_angles_deg))),
                ("samples", "-" if self.samples is None else str(self.samples)),
                ("stopped", self.stopped or "-")]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (angles in deg, as in the file)."""
        return {"own": self.own, "complete": self.complete,
                "planned_angles_deg": (None if self.planned_angles_deg is None
                                       else list(self.planned_angles_deg)),
                "samples_per_angle": self.samples_per_angle, "samples": self.samples,
                "stopped": self.stopped}


@dataclass(frozen=True)
class RawRecording:
    """A reader's output: the raw sample columns (by key: ``angle_deg``, ``voltage_V``, ...;
    deg, V, s, T; shapes (s,)), the reader's notes on the file (one line each, without the file
    name: damage it could read past, a recording cut short) and the file's word on itself."""

    columns: dict[str, F64]
    notes: tuple[str, ...] = ()
    state: RecordingState = field(default_factory=RecordingState)
