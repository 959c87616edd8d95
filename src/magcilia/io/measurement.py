"""The per-condition summary of a recording: :class:`Measurement` (SI).

A condition is a tilt angle toward an azimuth, or a known load (tip force or flow speed) toward
an azimuth; each holds the mean output (single-axis sensor) or the mean field (3-axis
magnetometer) with its standard error and the sample counts. :mod:`magcilia.io.recordings` reads
files into it; calibration fits it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, count, dataframe, number, si
from magcilia._errors import MagciliaError
from magcilia._validate import printable
from magcilia.constants import GAUSS
from magcilia.io.columns import ACTUATION_KEYS, FIELD_KEYS
from magcilia.io.quality import RecordingQuality

F64 = NDArray[np.float64]
#: the unit of each column of :meth:`Measurement.columns` (counts: dimensionless, ``"1"``)
COLUMN_UNITS = {"angle_rad": "rad", "azimuth_rad": "rad", "force_N": "N", "speed_m_per_s": "m/s",
                **dict.fromkeys(ACTUATION_KEYS, "T"), "output_V": "V", "sem_V": "V",
                **dict.fromkeys(FIELD_KEYS, "T"), **{f"sem_{k}": "T" for k in FIELD_KEYS},
                "count": "1", "saturated": "1", "nonfinite": "1"}
#: the columns that say the condition (coordinates of :meth:`Measurement.to_xarray`)
CONDITION_COLUMNS = ("angle_rad", "azimuth_rad", "force_N", "speed_m_per_s", *ACTUATION_KEYS)


@dataclass(frozen=True, eq=False, repr=False)
class Measurement(Display):
    """Per-condition summary of a recording (SI units): a condition is a tilt angle and a tilt
    azimuth (today's recordings: one azimuth, 0, so one condition per angle).

    Attributes
    ----------
    angles : ndarray, shape (a,)
        Tilt angle of each condition, rad (increasing within each azimuth; the distinct angles,
        increasing, for a recording at one azimuth).
    volts : ndarray, shape (a,)
        Mean output per condition, V (offset-free when set/reset samples were given; NaN for
        3-axis field data).
    sem : ndarray, shape (a,)
        Standard error of each mean, V (sample std / sqrt(count); 0 for a single sample; NaN for
        3-axis field data).
    counts : ndarray of int, shape (a,)
        Samples used per condition.
    saturated : ndarray of int, shape (a,)
        Output samples beyond the sensor's linear range per condition (dropped if the policy was
        'omit'; 3-axis field data are not range-checked: 0).
    nonfinite : ndarray of int, shape (a,)
        NaN/inf samples dropped per condition (nan_policy 'omit').
    set_reset : bool
        Whether the readings are set/reset differences.
    source : str
        Where the data came from (file name).
    metadata : dict
        JSON-ready notes. ``metadata["dropped"]`` (present only when needed) counts the dropped
        samples that no angle's counts can hold: ``no_angle`` (samples whose angle was NaN/inf,
        nan_policy 'omit'), ``angles_deg`` (angles left without a usable sample) and ``samples``
        (how many samples those angles had); :meth:`report` says them. From the readers:
        ``quality`` (:meth:`magcilia.io.quality.RecordingQuality.to_dict`: what the checks of
        the samples flagged), ``notes`` (one line each: damage the reader read past, a recording
        cut short and the planned angles it lacks) and, for magcilia's recordings, ``recording``
        (complete, planned and missing angles, why it stopped); :meth:`notes` says them.
    azimuths : ndarray, shape (a,)
        Tilt direction φ of each condition, rad (0: tilt toward +x, the paper's path; the tilt
        axis is horizontal, perpendicular to φ). Conditions are ordered by azimuth, then angle.
        Default: all 0.
    fields : ndarray, shape (a, 3), or None
        For a 3-axis magnetometer at the sensing point: mean field (B_x, B_y, B_z) per condition,
        T (axes as in the frame figure); ``volts`` and ``sem`` are then NaN. None for the
        single-axis sensor's output.
    field_sem : ndarray, shape (a, 3), or None
        Standard errors of ``fields``, T (None with ``fields``).
    forces : ndarray, shape (a,), or None
        A load experiment under known tip forces: the dead force at the tip of each condition, N
        (a force gauge or weights), perpendicular to the upright cilium toward ``azimuths``;
        ``angles`` are then 0 (the cilium stands upright and bends). None for tilt experiments.
    speeds : ndarray, shape (a,), or None
        A load experiment under known uniform flow speeds, m/s, the flow toward ``azimuths``, in
        the fluid named by ``metadata["fluid"]`` (``"water"`` when absent; see
        :data:`magcilia.mechanics.FLUIDS`). At most one of ``forces`` and ``speeds``.
    actuation : ndarray, shape (a, 3), or None
        A coil experiment: the applied uniform field (B_x, B_y, B_z) at the cilium of each
        condition, T, board frame (a Helmholtz coil's current times its constant; file columns
        ``actuation_x_T``, ``actuation_y_T``, ``actuation_z_T``); ``angles`` and ``azimuths`` are
        then 0 (the upright cilium bends under the field's couple) and the observable holds the
        applied field too. None for tilt and load experiments.
    """

    angles: F64
    volts: F64
    sem: F64
    counts: NDArray[np.int64]
    saturated: NDArray[np.int64]
    nonfinite: NDArray[np.int64]
    set_reset: bool = False
    source: str = "<array>"
    metadata: dict[str, Any] = field(default_factory=dict)
    azimuths: F64 = field(default_factory=lambda: np.zeros(0))
    fields: F64 | None = None
    field_sem: F64 | None = None
    forces: F64 | None = None
    speeds: F64 | None = None
    actuation: F64 | None = None

    def __post_init__(self) -> None:
        if self.forces is not None and self.speeds is not None:
            raise v.fail("Measurement loads", "both forces and speeds",
                         "one kind of load per recording (record force and flow separately)")
        if np.size(self.azimuths) == 0:
            object.__setattr__(self, "azimuths", np.zeros(np.shape(self.angles)))
        if (self.fields is None) != (self.field_sem is None):
            raise v.fail("field_sem", "given without fields" if self.fields is None
                         else "missing", "both fields and field_sem, or neither")
        if self.actuation is not None and self.loads is not None:
            raise v.fail("Measurement actuation", f"given with {self.load_kind} loads",
                         "one stimulus per recording (record coil fields and loads separately)")
        for name in ("angles", "volts", "sem", "counts", "saturated", "nonfinite", "azimuths",
                     "fields", "field_sem", "forces", "speeds", "actuation"):
            value = getattr(self, name)
            if value is None:
                continue
            arr = np.array(value)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        a = self.angles.shape
        for name in ("volts", "sem", "counts", "saturated", "nonfinite", "azimuths", "fields",
                     "field_sem", "forces", "speeds", "actuation"):
            value = getattr(self, name)
            want = (*a, 3) if name in ("fields", "field_sem", "actuation") else a
            if value is not None and value.shape != want:
                raise v.fail(f"Measurement {name}", f"shape {value.shape}",
                             f"shape {want}: one " + ("row (B_x, B_y, B_z)" if len(want) == 2
                                                      else "value") + " per angle")
        if not np.isfinite(self.azimuths).all():
            raise v.fail("Measurement azimuths", self.azimuths.tolist(), "finite angles in rad")
        loads = self.loads
        if loads is not None:
            if not np.isfinite(loads).all():
                raise v.fail(f"Measurement {self.load_kind}", loads.tolist(), "finite loads")
            if np.any(self.angles != 0.0):
                raise v.fail("Measurement angles", "non-zero with loads",
                             "zeros: a load experiment bends the upright cilium")
        if self.actuation is not None:
            if not np.isfinite(self.actuation).all():
                raise v.fail("Measurement actuation", "not finite everywhere",
                             "finite applied fields in T")
            if np.any(self.angles != 0.0) or np.any(self.azimuths != 0.0):
                raise v.fail("Measurement angles", "non-zero with applied fields",
                             "zeros: a coil experiment bends the upright cilium")

    @property
    def load_kind(self) -> str | None:
        """``"force"`` or ``"flow"`` for a load experiment, None for a tilt experiment."""
        return "force" if self.forces is not None else "flow" if self.speeds is not None else None

    @property
    def loads(self) -> F64 | None:
        """The loads of a load experiment (forces N or speeds m/s, shape (a,)), else None."""
        return self.forces if self.forces is not None else self.speeds

    @property
    def is_coil(self) -> bool:
        """Whether this is a coil experiment (applied uniform fields, :attr:`actuation`)."""
        return self.actuation is not None

    @property
    def fluid(self) -> str:
        """The fluid of a flow experiment (``metadata["fluid"]``, default ``"water"``)."""
        return str(self.metadata.get("fluid", "water"))

    @property
    def temperature_range(self) -> tuple[float, float] | None:
        """The (lowest, highest) temperature of the samples used, K (a recording with a
        temperature column, ``metadata["temperature_K"]``), else None."""
        t = self.metadata.get("temperature_K")
        return None if not t else (float(t["min"]), float(t["max"]))

    @property
    def observable(self) -> str:
        """``"output"`` (the single-axis sensor's voltage) or ``"field"`` (3-axis data)."""
        return "output" if self.fields is None else "field"

    def __len__(self) -> int:
        return int(self.angles.size)

    @property
    def angles_deg(self) -> F64:
        """Angles in degrees, shape (a,)."""
        return np.degrees(self.angles)

    def require_single_path(self, user: str, fix: str) -> None:
        """A one-line error unless these are single-axis outputs along the paper's path (every
        azimuth 0), for the consumers that handle only those.

        Parameters
        ----------
        user : str
            Who needs them, e.g. ``"calibrate(..., model='paper')"``.
        fix : str
            What to do instead, e.g. ``"use calibrate(..., model='physical')"``.

        Examples
        --------
        >>> m = Measurement(np.radians([0.0, 10.0]), np.full(2, np.nan), np.full(2, np.nan),
        ...                 np.ones(2, np.int64), np.zeros(2, np.int64), np.zeros(2, np.int64),
        ...                 fields=np.ones((2, 3)), field_sem=np.zeros((2, 3)))
        >>> try:
        ...     m.require_single_path("sensitivity", "leave the data out")
        ... except MagciliaError as exc:
        ...     print(str(exc).partition("; ")[2])
        got 3-axis field data; leave the data out
        """
        got = []
        if self.load_kind is not None:
            got.append(f"{self.load_kind} loads (a load experiment)")
        if self.fields is not None:
            got.append("3-axis field data")
        if np.any(self.azimuths != 0.0):
            got.append("azimuths " + ", ".join(f"{a:g}" for a in self._azimuths_deg()) + " deg")
        coil = "applied coil fields (a coil experiment)" if self.actuation is not None else ""
        if got or coil:
            what = " at ".join(got) + (f" under {coil}" if got and coil else coil)
            raise MagciliaError(f"{printable(str(self.source))}: {user} needs a single-axis "
                                f"output at azimuth 0; got {what}; {fix}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (SI: angles in rad, volts in V)."""
        return {
            "source": self.source, "set_reset": self.set_reset,
            "angle_rad": self.angles.tolist(), "voltage_V": self.volts.tolist(),
            "sem_V": self.sem.tolist(), "count": self.counts.tolist(),
            "saturated": self.saturated.tolist(), "nonfinite": self.nonfinite.tolist(),
            "metadata": dict(self.metadata), "azimuth_rad": self.azimuths.tolist(),
            **({} if self.fields is None or self.field_sem is None else {
                "field_T": self.fields.tolist(), "field_sem_T": self.field_sem.tolist()}),
            **({} if self.forces is None else {"force_N": self.forces.tolist()}),
            **({} if self.speeds is None else {"speed_m_per_s": self.speeds.tolist()}),
            **({} if self.actuation is None else {"actuation_T": self.actuation.tolist()}),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Measurement:
        """Rebuild from :meth:`to_dict` output."""
        with v.rebuilding("measurement data", "Measurement"):
            return cls(
                angles=np.asarray(data["angle_rad"], dtype=np.float64),
                volts=np.asarray(data["voltage_V"], dtype=np.float64),
                sem=np.asarray(data["sem_V"], dtype=np.float64),
                counts=np.asarray(data["count"], dtype=np.int64),
                saturated=np.asarray(data["saturated"], dtype=np.int64),
                nonfinite=np.asarray(data["nonfinite"], dtype=np.int64),
                set_reset=bool(data["set_reset"]), source=str(data["source"]),
                metadata=dict(data.get("metadata") or {}),
                azimuths=np.asarray(data.get("azimuth_rad") or [], dtype=np.float64),
                fields=(None if data.get("field_T") is None
                        else np.asarray(data["field_T"], dtype=np.float64)),
                field_sem=(None if data.get("field_sem_T") is None
                           else np.asarray(data["field_sem_T"], dtype=np.float64)),
                forces=(None if data.get("force_N") is None
                        else np.asarray(data["force_N"], dtype=np.float64)),
                speeds=(None if data.get("speed_m_per_s") is None
                        else np.asarray(data["speed_m_per_s"], dtype=np.float64)),
                actuation=(None if data.get("actuation_T") is None
                           else np.asarray(data["actuation_T"], dtype=np.float64)),
            )

    @property
    def single_azimuth(self) -> bool:
        """Whether every condition has the same azimuth (one tilt path)."""
        return bool(self.azimuths.size == 0 or np.all(self.azimuths == self.azimuths[0]))

    def _azimuths_deg(self) -> list[float]:
        """The distinct azimuths, deg, increasing."""
        return np.unique(np.degrees(self.azimuths)).tolist()

    def _conditions_text(self) -> str:
        """``33 angles 0..85 deg``, ``… at azimuth 90 deg``, or ``34 conditions: 2 azimuths
        (0, 90 deg) × angles -40..40 deg``."""
        deg = self.angles_deg
        span = f"{deg.min():.4g}..{deg.max():.4g} deg"
        if self.actuation is not None:
            b = np.linalg.norm(self.actuation, axis=1) / GAUSS
            return (f"{len(self)} applied fields (coil): |B| {b.min():.4g}..{b.max():.4g} "
                    "gauss")
        loads = self.loads
        if loads is not None:
            scale, unit = (1e3, "mN") if self.forces is not None else (1e3, "mm/s")
            what = "forces" if self.forces is not None else f"flow speeds ({self.fluid})"
            span = f"{what} {loads.min() * scale:.4g}..{loads.max() * scale:.4g} {unit}"
            az = self._azimuths_deg()
            return (f"{len(self)} loads: {span} toward azimuth "
                    f"{', '.join(f'{a:g}' for a in az)} deg")
        if self.single_azimuth:
            at = np.degrees(self.azimuths[0]) if len(self) else 0.0
            return f"{len(self)} angles {span}" + (f" at azimuth {at:g} deg" if at else "")
        az = self._azimuths_deg()
        return (f"{len(self)} conditions: {count(len(az), 'azimuth')} "
                f"({', '.join(f'{a:g}' for a in az)} deg) × angles {span}")

    def notes(self) -> list[str]:
        """What to know beyond the numbers, one line each (empty when there is nothing to say):
        the reader's notes on the file (``metadata["notes"]``: damage read past, a recording cut
        short and the planned angles it lacks) and what the quality checks flagged
        (``metadata["quality"]``, :mod:`magcilia.io.quality`), with what was done with it."""
        out = [printable(str(n)) for n in self.metadata.get("notes") or []]
        quality = self.metadata.get("quality")
        if isinstance(quality, Mapping) and quality.get("flagged"):
            out.append(RecordingQuality.from_dict(quality).report())
        return out

    def report(self) -> str:
        """One line: source, conditions (angles, azimuths), observable, samples and what was
        dropped; then, one per line, the :meth:`notes`."""
        text = (f"{self.source}: {self._conditions_text()}"
                + (", 3-axis field" if self.fields is not None else "")
                + f", {int(self.counts.sum())} samples"
                + (" (set/reset differences)" if self.set_reset else ""))
        dropped = [f"{int(n.sum())} {what}" for n, what in ((self.saturated, "saturated"),
                                                            (self.nonfinite, "non-finite"))
                   if n.sum()]
        lost = self.metadata.get("dropped") or {}
        if lost.get("no_angle"):
            dropped.append(f"{lost['no_angle']} without a finite "
                           + ("applied field" if self.is_coil else "angle")
                           + (" or azimuth" if "azimuths_deg" in lost else ""))
        if lost.get("conditions"):
            dropped.append(f"{lost['samples']} at {lost['conditions']} applied field(s) left "
                           "with no usable sample")
        if lost.get("angles_deg"):
            where = [f"{a:g}" for a in lost["angles_deg"]]
            if "azimuths_deg" in lost:
                where = [f"{a} at {z:g}" for a, z in zip(where, lost["azimuths_deg"], strict=True)]
            what = "condition(s)" if "azimuths_deg" in lost else "angle(s)"
            dropped.append(f"{lost['samples']} at {len(where)} {what} left with no "
                           f"usable sample ({', '.join(where)} deg)")
        return "\n".join([text + (f"; {', '.join(dropped)}" if dropped else ""),
                          *(f"note: {n}" for n in self.notes())])

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        deg = np.degrees(self.angles)
        n = len(self)
        items = [("", count(n, "applied field" if self.actuation is not None else "load"
                            if self.loads is not None else "angle"
                            if self.single_azimuth else "condition"))]
        if not self.single_azimuth or (n and self.azimuths[0] != 0.0):
            items.append(("azimuths", ", ".join(f"{a:g}" for a in self._azimuths_deg())
                          + " deg"))
        loads = self.loads
        if loads is not None:
            unit = "mN" if self.forces is not None else "mm/s"
            items.append(("forces" if self.forces is not None else f"speeds ({self.fluid})",
                          f"{number(loads.min() * 1e3)}…{number(loads.max() * 1e3)} {unit}"
                          if n else "-"))
        elif self.actuation is not None:
            b = np.linalg.norm(self.actuation, axis=1) / GAUSS
            items.append(("|B| coil", f"{number(b.min())}…{number(b.max())} G" if n else "-"))
        else:
            items.append(("angles", f"{number(deg.min())}…{number(deg.max())} deg"
                          if n else "-"))
        if self.fields is not None and self.field_sem is not None:
            norm = np.linalg.norm(self.fields, axis=1)
            items += [("|B|", f"{si(norm.min(), 'T')}…{si(norm.max(), 'T')}" if n else "-"),
                      ("median s.e.", si(float(np.median(self.field_sem)), "T") if n else "-")]
        else:
            items += [("output", f"{si(self.volts.min(), 'V')}…{si(self.volts.max(), 'V')}"
                       if n else "-"),
                      ("median s.e.", si(float(np.median(self.sem)), "V") if n else "-")]
        items.append(("samples", str(int(self.counts.sum()))))
        if self.saturated.any():
            items.append(("saturated", str(int(self.saturated.sum()))))
        if self.set_reset:
            items.append(("", "set/reset"))
        return [*items, ("source", self.source)]

    def _display_table(self) -> Table:
        az = [] if self.single_azimuth else ["azimuth (deg)"]
        azimuths = np.degrees(self.azimuths)
        if self.fields is not None and self.field_sem is not None:
            header = (*az, "angle (deg)", "B_x (µT)", "B_y (µT)", "B_z (µT)", "s.e. B_x (nT)",
                      "s.e. B_y (nT)", "s.e. B_z (nT)", "samples")
            rows = [[*([number(z, 5)] if az else []), number(a, 5),
                     *(number(x * 1e6, 5) for x in b), *(number(x * 1e9) for x in e), str(int(n))]
                    for z, a, b, e, n in zip(azimuths, self.angles_deg, self.fields,
                                             self.field_sem, self.counts, strict=True)]
            return header, rows
        return ((*az, "angle (deg)", "output (mV)", "s.e. (µV)", "samples"),
                [(*([number(z, 5)] if az else []), number(a, 5), number(v * 1e3, 5),
                  number(e * 1e6), str(int(n)))
                 for z, a, v, e, n in zip(azimuths, self.angles_deg, self.volts, self.sem,
                                          self.counts, strict=True)])

    def to_dataframe(self) -> Any:
        """The reduced measurements as a ``pandas.DataFrame``, one row per condition, SI: columns
        ``angle_rad``, ``azimuth_rad``, then ``output_V`` (mean) and ``sem_V`` (its standard
        error) for the single-axis output, or ``field_x_T``, ``field_y_T``, ``field_z_T`` and
        ``sem_field_x_T``, ``sem_field_y_T``, ``sem_field_z_T`` for 3-axis field data, then
        ``count``, ``saturated``, ``nonfinite`` (samples per condition); a load experiment has
        ``force_N`` or ``speed_m_per_s`` after ``azimuth_rad``, a coil experiment
        ``actuation_x_T``, ``actuation_y_T``, ``actuation_z_T``."""
        return dataframe(self.columns())

    def columns(self) -> dict[str, Any]:
        """The columns of :meth:`to_dataframe` and :meth:`to_xarray` by name (SI, the unit in
        the name), each shape (a,)."""
        if self.fields is not None and self.field_sem is not None:
            values = {**{k: self.fields[:, j] for j, k in enumerate(FIELD_KEYS)},
                      **{f"sem_{k}": self.field_sem[:, j] for j, k in enumerate(FIELD_KEYS)}}
        else:
            values = {"output_V": self.volts, "sem_V": self.sem}
        loads = {} if self.forces is None else {"force_N": self.forces}
        loads.update({} if self.speeds is None else {"speed_m_per_s": self.speeds})
        if self.actuation is not None:
            loads.update({k: self.actuation[:, j] for j, k in enumerate(ACTUATION_KEYS)})
        return {"angle_rad": self.angles, "azimuth_rad": self.azimuths, **loads, **values,
                "count": self.counts, "saturated": self.saturated, "nonfinite": self.nonfinite}

    def to_xarray(self) -> Any:
        """The reduced measurements as an ``xarray.Dataset`` along ``condition``: the columns of
        :meth:`to_dataframe` as variables with ``units`` attributes (SI), the condition (angle,
        azimuth, load or applied field) as coordinates, ``source``, ``set_reset``, the
        :meth:`notes` (one per line) and the ``metadata`` (JSON) as attributes. Needs xarray
        (the ``export`` extra; one line without it)."""
        from magcilia.io.export_xarray import dataset

        return dataset(self.columns(), COLUMN_UNITS, dim="condition", coords=CONDITION_COLUMNS,
                       attrs={"source": self.source, "set_reset": self.set_reset,
                              "notes": "\n".join(self.notes()), "metadata": dict(self.metadata)})
