"""Raw samples reduced to per-condition means: the one reduction every recording reader uses.

A condition is a tilt angle at a tilt azimuth (or a load at an azimuth: a ``force_N`` or
``flow_m_per_s`` column in place of the angle); the observable is the single-axis output (V) or
the three field components of a 3-axis sensor (T). :func:`measurement_from_samples` (and every
reader of :mod:`magcilia.io.recordings` through it) reduces the samples in one pass over pieces of
:data:`REDUCE_SAMPLES` samples: the runs of equal conditions (the angle; with an azimuth column,
the pair as one complex key) are grouped, their sums gathered per condition with
``np.bincount``, in a two-pass form accurate on a large offset, and the pieces merged with Chan's
formulas (:mod:`magcilia.io.moments`). The result does not depend on the pieces.

With set/reset samples the offset-free reading of a condition is
``(mean(V_set) − mean(V_reset))/2`` (the bridge flips polarity, the offset does not; HMC1021
datasheet): :func:`~magcilia.io.readings.reading` for one condition's samples.

Angles are tilt angles in degrees: a finite ``|angle_deg|`` above :data:`MAX_ANGLE_DEG` (a column
in the wrong unit, or garbage) is an error rather than grouped, so the grouping by rounding to
:data:`~magcilia.io.columns.ANGLE_DECIMALS` decimals never overflows; azimuths, loads
(:data:`MAX_LOAD`) and field components (:data:`MAX_FIELD_T`) likewise. NaN/inf samples and
outputs beyond the sensor's range follow the policies :data:`NAN_POLICIES` and
:data:`SATURATION_POLICIES`; the quality checks (:mod:`magcilia.io.quality`) and the policy for
what they flag follow the reduction (``_measure``).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.constants import GAUSS
from magcilia.device.sensor import Sensor
from magcilia.io.coil_samples import applied_fields, coil_flagged, coil_note
from magcilia.io.columns import (
    ACTUATION_KEYS,
    ANGLE_DECIMALS,
    FIELD_KEYS,
    LOAD_UNITS,
    actuation_ids,
    scaled,
)
from magcilia.io.measurement import Measurement
from magcilia.io.moments import Moments, by_value, group_moments, grow_rows, summarize
from magcilia.io.quality import SUSPECT_POLICIES, screen
from magcilia.io.readings import _polarity_error, beyond_range
from magcilia.io.recording_state import RawRecording
from magcilia.units import ZERO_CELSIUS

F64 = NDArray[np.float64]
logger = logging.getLogger(__name__)
NAN_POLICIES = ("raise", "omit")
SATURATION_POLICIES = ("raise", "omit", "keep")
#: Largest |tilt angle| accepted, deg; beyond it the column is in the wrong unit or garbage.
MAX_ANGLE_DEG = 360.0
#: Largest |tilt azimuth| accepted, deg (as the angle).
MAX_AZIMUTH_DEG = 360.0
#: Largest |load| accepted, N or m/s (a meganewton or 1,000 km/s: no cilium; beyond it the column is
#: in the wrong unit or garbage, and grouping by rounding would overflow).
MAX_LOAD = 1e6
#: Largest |field component| of 3-axis data accepted, T (the strongest laboratory magnets make
#: tens of T; a magnetometer saturates at mT): beyond it the column is in the wrong unit or garbage.
MAX_FIELD_T = 100.0


#: Samples reduced at a time: arrays of a few MB, which the allocator reuses (a fresh array of a
#: whole recording's size costs page faults that take longer than the arithmetic).
REDUCE_SAMPLES = 1 << 20


class _Reduction:
    """A recording's samples reduced to per-condition statistics as they come, block by block.

    A condition is a pair (azimuth, angle), held as one complex key ``azimuth_deg + 1j·angle_deg``
    (both rounded to :data:`ANGLE_DECIMALS` decimals): NumPy sorts complex numbers by their real
    part, then their imaginary part, so the conditions come ordered by azimuth, then angle, and
    ``np.union1d``/``np.searchsorted`` merge them as they did the angles alone. Without an azimuth
    column the samples are grouped by their angle (a real key, as always) and the block's few
    distinct angles become conditions at azimuth 0.

    The statistics per condition are ``width`` columns: 1 (the output), 2 (set/reset: reset, set)
    or 3 (the field components B_x, B_y, B_z).

    :meth:`add` never raises: the first sample of each kind of problem is noted and
    :meth:`measurement` raises the error the whole recording deserves, in the order the checks
    have always had (an angle beyond ±:data:`MAX_ANGLE_DEG`, an azimuth beyond
    ±:data:`MAX_AZIMUTH_DEG`, a non-finite or unlabelled sample under nan_policy 'raise', a
    saturated one under saturation 'raise', then per condition), so that a reader's errors on a
    later block come first. Blocks are merged with Chan's parallel formulas (Chan, Golub &
    LeVeque 1983): the result does not depend on where blocks are cut.
    """

    def __init__(self, sensor: Sensor | None, nan_policy: str, saturation: str, source: str):
        self.nan_policy = v.choice("nan_policy", nan_policy, NAN_POLICIES)
        self.saturation = v.choice("saturation", saturation, SATURATION_POLICIES)
        self.sensor, self.source = sensor or Sensor(), source
        self.samples = self.no_angle = 0
        self.problems: dict[str, str] = {}  # "far", "bad", "saturated" -> message of the first
        # distinct conditions azimuth_deg + 1j * angle_deg (rounded), increasing: shape (c,)
        self.conds = np.zeros(0, np.complex128)
        self.counts = np.zeros((0, 2), np.int64)  # non-finite and saturated samples per condition
        self.peak = np.zeros(0)  # largest |value| used per condition
        self.width = 0  # statistics per condition (1, 2 or 3, see above); 0 before samples
        self.field = self.azimuth = False  # 3-axis field samples; an azimuth column
        self.load: str | None = None  # "force" or "flow" for a load recording
        #: a coil recording: its distinct applied fields (µT, rounded) -> condition index
        self.coil: dict[tuple[float, float, float], int] | None = None
        self.flagged = 0  # coil samples dropped by the sensor's checks (COIL_DROP)
        self.fluid = "water"
        #: the temperatures of the samples used (finite ones), K: lowest, highest, sum, count
        self.temps = [math.inf, -math.inf, 0.0, 0]
        self.stats = Moments(np.zeros((0, 0), np.int64), *np.zeros((3, 0, 0)))  # shapes (c, w)

    def add_columns(self, cols: Mapping[str, F64]) -> None:
        """Add a reader's columns (keys as :func:`read_samples` returns them)."""
        x, y, z = FIELD_KEYS
        fields = (cols[x], cols[y], cols[z]) if x in cols else None
        condition = cols.get("angle_deg")
        for kind, (key, factor, _) in LOAD_UNITS.items():
            if key in cols:  # a load recording: grouped by the load (in uN or mm/s)
                self.load, condition = kind, scaled(cols[key], factor)
        applied = None
        if ACTUATION_KEYS[0] in cols:  # a coil recording: grouped by the applied field
            self.coil = {} if self.coil is None else self.coil
            applied = tuple(np.asarray(cols[k], dtype=np.float64) for k in ACTUATION_KEYS)
            condition = actuation_ids(applied, self.coil)
        assert condition is not None  # (the readers require an angle, a load or a coil field)
        temps = cols.get("temperature_K")  # (a reader's block may still hold its °C column)
        if temps is None and "temperature_degC" in cols:
            temps = cols["temperature_degC"] + ZERO_CELSIUS
        self.add(condition, cols.get("voltage_V"), cols.get("setreset"),
                 azimuth=cols.get("azimuth_deg"), fields=fields, applied=applied,
                 temperature=temps)

    def add(self, ang: F64, volt: F64 | None, sr: F64 | None = None, *,
            azimuth: F64 | None = None, fields: tuple[F64, F64, F64] | None = None,
            applied: tuple[F64, ...] | None = None, temperature: F64 | None = None) -> None:
        """Add samples (shapes (s,): angle in deg, output in V or None, +1/−1 set/reset or None,
        azimuth in deg or None (0), the field components in T or None, the temperature in K or
        None), in pieces of :data:`REDUCE_SAMPLES`. Every block of a recording has the same kinds
        of columns."""
        if not self.width:
            self.field, self.azimuth = fields is not None, azimuth is not None
            self.width = 3 if self.field else (1 if sr is None else 2)
            self.stats = Moments(np.zeros((0, self.width), np.int64),
                                 *np.zeros((3, 0, self.width)))
        for s in range(0, ang.size, REDUCE_SAMPLES):
            part = slice(s, s + REDUCE_SAMPLES)
            self._add(ang[part], None if volt is None else volt[part],
                      None if sr is None else sr[part],
                      None if azimuth is None else azimuth[part],
                      None if fields is None else (fields[0][part], fields[1][part],
                                                   fields[2][part]),
                      None if applied is None else tuple(c[part] for c in applied),
                      None if temperature is None else temperature[part])

    def _note(self, kind: str, where: NDArray[np.bool_], message: Callable[[int], str]) -> None:
        if kind not in self.problems and where.any():
            self.problems[kind] = message(int(np.argmax(where)))

    def _add(self, ang: F64, volt: F64 | None, sr: F64 | None, az: F64 | None,
             fields: tuple[F64, F64, F64] | None, applied: tuple[F64, ...] | None = None,
             temperature: F64 | None = None) -> None:
        source, offset = self.source, self.samples
        self.samples += ang.size
        finite = np.isfinite(ang)
        if applied is not None:
            comps = np.stack(applied)
            with np.errstate(invalid="ignore"):
                far_applied = np.asarray(np.isfinite(comps) & (np.abs(comps) > MAX_FIELD_T))
            self._note("far", np.asarray(far_applied.any(axis=0)), lambda i: (
                f"{source}: sample {offset + i + 1} has an applied field "
                f"({', '.join(f'{c:.6g}' for c in comps[:, i])}) T beyond ±MAX_FIELD_T = "
                f"{MAX_FIELD_T:g} T; actuation_x_T, actuation_y_T, actuation_z_T must be in "
                "tesla (check the columns and their units)"))
        elif self.load is None:
            self._note("far", finite & (np.abs(ang) > MAX_ANGLE_DEG), lambda i: (
                f"{source}: sample {offset + i + 1} has angle_deg={ang[i]:.6g}, beyond "
                f"±{MAX_ANGLE_DEG:g} deg; angle_deg must be the tilt in degrees (check the "
                "column and its unit)"))
        else:  # (in uN or mm/s here)
            name, factor, _ = LOAD_UNITS[self.load]
            self._note("far", finite & (np.abs(ang) > MAX_LOAD * factor), lambda i: (
                f"{source}: sample {offset + i + 1} has {name}={ang[i] / factor:.6g}, beyond "
                f"±MAX_LOAD = {MAX_LOAD:g} (N or m/s); {name} must be in SI units (check the "
                "column and its unit)"))
        if az is not None:
            finite_az = np.isfinite(az)
            self._note("far_azimuth", finite_az & (np.abs(az) > MAX_AZIMUTH_DEG), lambda i: (
                f"{source}: sample {offset + i + 1} has azimuth_deg={az[i]:.6g}, beyond "
                f"±{MAX_AZIMUTH_DEG:g} deg; azimuth_deg must be the tilt direction in degrees "
                "(check the column and its unit)"))
            finite &= finite_az
        if fields is None:
            assert volt is not None
            bad = ~(finite & np.isfinite(volt))
        else:
            bad = ~(finite & np.isfinite(fields[0]) & np.isfinite(fields[1])
                    & np.isfinite(fields[2]))
            comps = np.stack(fields)
            with np.errstate(invalid="ignore"):
                far = np.asarray(np.isfinite(comps) & (np.abs(comps) > MAX_FIELD_T))

            def far_field(i: int) -> str:
                j = int(np.argmax(far[:, i]))
                return (f"{source}: sample {offset + i + 1} has {FIELD_KEYS[j]}="
                        f"{comps[j, i]:.6g}, beyond ±MAX_FIELD_T = {MAX_FIELD_T:g} T; the field "
                        "columns must be in tesla (check the columns and their units)")

            self._note("far_field", np.asarray(far.any(axis=0)), far_field)
        if sr is not None:
            bad |= (sr != 1.0) & (sr != -1.0)
        if self.nan_policy == "raise":
            def values(i: int) -> str:
                name = "angle_deg" if self.load is None else (
                    f"{self.load}_{LOAD_UNITS[self.load][2].replace('/', '_per_')}")
                cols = [(name, ang), ("azimuth_deg", az), ("voltage_V", volt),
                        *zip(FIELD_KEYS, fields or (None, None, None), strict=True)]
                return ", ".join(f"{k}={c[i]}" for k, c in cols if c is not None)

            self._note("bad", bad, lambda i: (
                f"{source}: sample {offset + i + 1} "
                + (f"is not finite ({values(i)})" if sr is None or not finite[i]
                   or (volt is not None and not math.isfinite(volt[i]))
                   else f"has setreset={sr[i]:g}, neither +1 (set) nor -1 (reset)")
                + "; clean the file or pass nan_policy='omit' (CLI: --nan-policy omit)"))
        if applied is not None:  # a coil sample's total field, checked by the sensor's rules
            sat = ~bad & coil_flagged(self.sensor, np.stack(applied), volt, sr, fields, bad)
        elif volt is not None and fields is None:  # (3-axis data are not range-checked here)
            out = volt
            sat = ~bad & beyond_range(out, self.sensor)
            if self.saturation == "raise":
                self._note("saturated", sat, lambda i: (
                    f"{source}: sample {offset + i + 1} (voltage_V={out[i]:.6g} at {ang[i]:g} "
                    f"{'deg' if self.load is None else LOAD_UNITS[self.load][2]}) "
                    f"is beyond the sensor's linear range (±{self.sensor.field_range / GAUSS:g} "
                    f"gauss = ±{self.sensor.field_range * abs(self.sensor.scale):.4g} V); check "
                    "gain and offset, or pass saturation='omit' (CLI: --saturation omit) to drop "
                    "such samples"))
        else:
            sat = np.zeros(ang.size, dtype=bool)
        if self.problems:  # the recording is refused (and a far angle must not be rounded)
            return
        on: slice | NDArray[np.bool_] = slice(None) if finite.all() else finite  # no copy if all
        if az is None:  # grouped by angle alone (the fast path), at azimuth 0
            angles, group = by_value(np.round(ang[on], ANGLE_DECIMALS))
            conds = np.zeros(angles.size, np.complex128)
            conds.imag = angles
        else:
            angles = ang[on]
            key = np.empty(angles.size, np.complex128)
            key.real, key.imag = az[on], angles
            conds, group = by_value(np.round(key, ANGLE_DECIMALS))
        self.no_angle += ang.size - group.size  # (nan_policy 'omit')
        a, k = conds.size, self.width
        counts = np.stack([np.bincount(group[bad[on]], minlength=a),
                           np.bincount(group[sat[on]], minlength=a)], axis=1)
        use = ~bad & ~sat if self.saturation == "omit" or applied is not None else ~bad
        if applied is not None:
            self.flagged += int(sat[on].sum())
        if temperature is not None:  # the range the samples used were taken over
            t = temperature[use & finite]
            t = t[np.isfinite(t)]
            if t.size:
                t_lo, t_hi, total, count_t = self.temps
                self.temps = [min(t_lo, float(t.min())), max(t_hi, float(t.max())),
                              total + float(t.sum()), count_t + t.size]
        if not use.all():
            keep = use & finite
            group = group[use[on]]
            volt = None if volt is None else volt[keep]
            sr = None if sr is None else sr[keep]
            fields = None if fields is None else (fields[0][keep], fields[1][keep],
                                                  fields[2][keep])
        if fields is not None:  # each component grouped alike: statistics of shape (a, 3)
            parts = [group_moments(group, f, a) for f in fields]
            stats = Moments(np.stack([p[0].n for p in parts], axis=1),
                            np.stack([p[0].hi for p in parts], axis=1),
                            np.stack([p[0].lo for p in parts], axis=1),
                            np.stack([p[0].m2 for p in parts], axis=1))
            peak = np.max([p[1] for p in parts], axis=0)
        else:
            assert volt is not None
            flat, flat_peak = group_moments(group if sr is None else 2 * group + (sr > 0), volt,
                                            a * k)
            stats, peak = flat.reshape(a, k), flat_peak.reshape(a, k).max(axis=1)
        self._merge(conds, counts, stats, peak)

    def _merge(self, conds: NDArray[np.complex128], counts: NDArray[np.int64], block: Moments,
               peak: F64) -> None:
        """Merge a block's per-condition statistics (shapes (b,), (b, 2) and (b, w)) into ours."""
        union = np.union1d(self.conds, conds)
        if union.size > self.conds.size:  # conditions not seen before: make room
            old = np.searchsorted(union, self.conds)
            self.counts, self.peak = (grow_rows(x, old, union.size)
                                      for x in (self.counts, self.peak))
            self.stats = Moments(*(grow_rows(x, old, union.size) for x in self.stats))
            self.conds = union
        at = np.searchsorted(self.conds, conds)
        self.counts[at] += counts
        self.peak[at] = np.maximum(self.peak[at], peak)
        n, hi, lo, m2 = self.stats
        na, new = n[at], n[at] == 0
        with np.errstate(invalid="ignore", over="ignore"):  # overflow: checked at the end
            share = block.n / np.maximum(na + block.n, 1)
            delta = (block.hi - hi[at]) + (block.lo - lo[at])  # (hi - hi: exact)
            hi[at] = np.where(new, block.hi, hi[at])
            lo[at] = np.where(new, block.lo, lo[at] + delta * share)
            m2[at] = np.where(new, block.m2, m2[at] + block.m2 + delta * delta * na * share)
        n[at] = na + block.n

    def _condition(self, i: int) -> str:
        """Condition ``i`` in words: ``"40 deg"``, ``"40 deg at azimuth 90 deg"``."""
        c = self.conds[i]
        if self.coil is not None:
            b = self._applied()[i]
            return "applied field (" + ", ".join(f"{x / GAUSS:.4g}" for x in b) + ") G"
        unit = "deg" if self.load is None else LOAD_UNITS[self.load][2]
        return f"{c.imag:g} {unit}" + (f" at azimuth {c.real:g} deg" if self.azimuth else "")

    def _applied(self) -> F64:
        """A coil recording's applied field of each condition, T, (c, 3)."""
        assert self.coil is not None
        return applied_fields(self.coil, self.conds.imag)

    def _readings(self) -> tuple[F64, F64, NDArray[np.int64], F64 | None, F64 | None]:
        """Per condition: output and its standard error (V; NaN for field data), samples used,
        and the field and its standard errors (T, shapes (c, 3); None for output data)."""
        if not self.field:
            volts, sem, count = summarize(self.stats)
            return volts, sem, count, None, None
        n, hi, lo, m2 = self.stats
        comps = [summarize(Moments(n[:, j:j + 1], hi[:, j:j + 1], lo[:, j:j + 1], m2[:, j:j + 1]))
                 for j in range(3)]
        fields = np.stack([c[0] for c in comps], axis=1)
        field_sem = np.stack([c[1] for c in comps], axis=1)
        nan = np.full(self.conds.size, np.nan)
        return nan, nan.copy(), comps[0][2], fields, field_sem

    def measurement(self) -> Measurement:
        """The :class:`Measurement` of the samples added, or the error the recording deserves."""
        source = self.source
        if not self.samples:
            raise v.fail(f"{source}", "no samples", "a recording with at least two angles")
        for kind in ("far", "far_azimuth", "bad", "far_field", "saturated"):
            if kind in self.problems:
                raise MagciliaError(self.problems[kind])
        n, hi, lo, _ = self.stats
        volts, sem, count, fields, field_sem = self._readings()
        has = count > 0  # conditions left with a usable sample
        with np.errstate(over="ignore", invalid="ignore"):  # a sum beyond the doubles overflows
            sums = np.isfinite((hi + lo) * n).all(axis=1)  # (as when summed in one piece)
        readings: NDArray[np.bool_] = np.asarray(
            np.isfinite(volts) & np.isfinite(sem) if fields is None or field_sem is None
            else np.isfinite(fields).all(axis=1) & np.isfinite(field_sem).all(axis=1))
        wrong = has & ~(readings & sums & (n.min(axis=1) > 0))
        if wrong.any():  # the first condition missing a polarity, or whose reading overflows
            i = int(np.argmax(wrong))
            if n[i].min() == 0:
                raise _polarity_error(f"{source}: angle {self._condition(i)}", n[i])
            unit, need = (("T", "field_x_T, field_y_T and field_z_T must be in tesla")
                          if self.field else ("V", "voltage_V must be in volts"))
            raise MagciliaError(
                f"{source}: the reading at {self._condition(i)} overflows (samples up to "
                f"{self.peak[i]:.3g} {unit}); {need}"
            )
        if has.sum() < 2:
            what = ("usable condition(s) (azimuth, angle)" if self.azimuth
                    else "usable angle(s)")
            raise MagciliaError(
                f"{source}: the recording has {has.sum()} {what}; calibration needs at "
                "least two distinct angles (rows of angle_deg, "
                + ("field_x_T, field_y_T, field_z_T)" if self.field else "voltage_V)")
            )
        if fields is None and np.ptp(volts[has]) == 0.0:
            raise MagciliaError(
                f"{source}: all readings are equal ({volts[has][0]:.6g} V); the sensor output "
                "does not vary with the angle (check the wiring, the gain and that the cilium is "
                "magnetized)"
            )
        if fields is not None and not np.ptp(fields[has], axis=0).any():
            b = ", ".join(f"{x:.6g}" for x in fields[has][0])
            raise MagciliaError(
                f"{source}: all field readings are equal (B = ({b}) T); the field does not vary "
                "with the angle (check the magnetometer, its axes and that the cilium is "
                "magnetized)"
            )
        nonfinite, saturated = self.counts.T
        metadata: dict[str, Any] = {}
        if self.coil is not None and (self.no_angle or not has.all()):
            lost = nonfinite + saturated  # (a coil recording always drops flagged samples)
            metadata["dropped"] = {"no_angle": self.no_angle, "conditions": int((~has).sum()),
                                   "samples": int(lost[~has].sum())}
        elif self.no_angle or not has.all():  # dropped samples no condition's counts can hold
            lost = nonfinite + (saturated if self.saturation == "omit" else 0)
            metadata["dropped"] = {"no_angle": self.no_angle,
                                   "angles_deg": self.conds.imag[~has].tolist(),
                                   "samples": int(lost[~has].sum())}
            if self.azimuth:
                metadata["dropped"]["azimuths_deg"] = self.conds.real[~has].tolist()
        logger.info("%s: %d samples reduced to %d conditions", source, self.samples,
                    int(has.sum()))
        loads = None if self.load is None else self.conds.imag[has] / LOAD_UNITS[self.load][1]
        if self.load == "flow":
            metadata["fluid"] = self.fluid
        if self.temps[3]:
            t_lo, t_hi, total, count_t = self.temps
            metadata["temperature_K"] = {"min": t_lo, "max": t_hi, "mean": total / count_t,
                                         "samples": int(count_t)}
        applied = None
        if self.coil is not None:
            applied = self._applied()[has]
            if self.flagged:
                metadata["notes"] = [coil_note(self.flagged, self.sensor)]
        return Measurement(
            angles=(np.radians(self.conds.imag[has]) if loads is None and applied is None
                    else np.zeros(int(has.sum()))), volts=volts[has], sem=sem[has],
            counts=count[has], saturated=saturated[has], nonfinite=nonfinite[has],
            set_reset=self.width == 2, source=source, metadata=metadata,
            azimuths=np.radians(self.conds.real[has]),
            fields=None if fields is None else fields[has],
            field_sem=None if field_sem is None else field_sem[has],
            forces=loads if self.load == "force" else None,
            speeds=loads if self.load == "flow" else None,
            actuation=applied,
        )


def measurement_from_samples(
    angle_deg: ArrayLike,
    voltage: ArrayLike | None = None,
    *,
    setreset: ArrayLike | None = None,
    azimuth_deg: ArrayLike | None = None,
    field: ArrayLike | None = None,
    sensor: Sensor | None = None,
    nan_policy: str = "raise",
    saturation: str = "raise",
    source: str = "<array>",
    suspect: str = "keep",
) -> Measurement:
    """Reduce raw samples to a :class:`Measurement`, in one pass over pieces of
    :data:`REDUCE_SAMPLES` samples (per-condition means and standard errors accurate on a large
    offset; the result does not depend on the pieces).

    Samples are grouped per condition (azimuth, angle); the conditions come ordered by azimuth,
    then angle.

    Parameters
    ----------
    angle_deg : array-like, shape (s,)
        Tilt angle of each sample, degrees (the file convention).
    voltage : array-like, shape (s,), optional
        Sensor output of each sample, V (the single-axis AMR output; give it or ``field``).
    setreset : array-like, shape (s,), optional
        +1 for samples after a set pulse, −1 after a reset pulse (with ``voltage`` only).
    azimuth_deg : array-like, shape (s,), optional
        Tilt direction of each sample, degrees, finite and within ±:data:`MAX_AZIMUTH_DEG`
        (default 0: the paper's tilt toward +x).
    field : array-like, shape (s, 3), optional
        3-axis magnetometer samples (B_x, B_y, B_z) at the sensing point, T (instead of
        ``voltage``; not range-checked: ``sensor`` and ``saturation`` apply to voltages only).
    sensor : Sensor, optional
        Used to flag output samples beyond the linear range (|V − offset| / |scale| >
        field_range); default the HMC1021Z preset at the paper's settings.
    nan_policy : {"raise", "omit"}
        What to do with NaN/inf samples (in any column used).
    saturation : {"raise", "omit", "keep"}
        What to do with output samples beyond the sensor's range.
    source : str
        Name used in messages.
    suspect : {"keep", "omit", "raise"}
        Samples that the quality checks flag (:mod:`magcilia.io.quality`: conditions with far
        fewer samples than the others, outliers within their condition, duplicated blocks of
        rows): kept and counted in ``metadata["quality"]``, left out (and counted), or an error.

    Examples
    --------
    >>> b = [[1e-5, 0, 2e-5]] * 2 + [[2e-5, 0, 2e-5]] * 2 + [[1e-5, 1e-5, 2e-5]] * 2
    >>> m = measurement_from_samples([0, 0, 10, 10, 0, 0], field=b,
    ...                              azimuth_deg=[0, 0, 0, 0, 90, 90])
    >>> m.observable, len(m), np.degrees(m.azimuths).tolist(), m.fields[:, 1].tolist()
    ('field', 3, [0.0, 0.0, 90.0], [0.0, 0.0, 1e-05])
    """
    _Reduction(sensor, nan_policy, saturation, source)  # the policies checked first
    ang = np.asarray(angle_deg, dtype=np.float64).ravel()
    if (voltage is None) == (field is None):
        raise v.fail(f"{source}: samples", "both voltage and field" if voltage is not None
                     else "neither voltage nor field",
                     "one observable: voltage (V, shape (s,)) or field (T, shape (s, 3))")
    if field is not None and setreset is not None:
        raise v.fail(f"{source}: setreset", "given with field samples",
                     "left out (set/reset differences are for the single-axis output)")
    volt = None if voltage is None else np.asarray(voltage, dtype=np.float64).ravel()
    sr = None if setreset is None else np.asarray(setreset, dtype=np.float64).ravel()
    az = None if azimuth_deg is None else np.asarray(azimuth_deg, dtype=np.float64).ravel()
    b = None if field is None else np.asarray(field, dtype=np.float64)
    if b is not None and (b.ndim != 2 or b.shape[1] != 3):
        raise v.fail(f"{source}: field", f"shape {b.shape}", "shape (samples, 3): B_x, B_y, B_z")
    fields = None if b is None else (b[:, 0], b[:, 1], b[:, 2])
    sizes = [x.size for x in (ang, volt, sr, az) if x is not None] + (
        [] if b is None else [b.shape[0]])
    if len(set(sizes)) > 1:
        raise v.fail(f"{source}: columns", "lengths " + ", ".join(map(str, sizes)),
                     "of equal length")
    cols = {"angle_deg": ang, **({} if volt is None else {"voltage_V": volt}),
            **({} if sr is None else {"setreset": sr}),
            **({} if az is None else {"azimuth_deg": az}),
            **({} if fields is None else dict(zip(FIELD_KEYS, fields, strict=True)))}
    policy = v.choice("suspect", suspect, SUSPECT_POLICIES)
    return _measure(lambda: _Reduction(sensor, nan_policy, saturation, source),
                    RawRecording(cols), policy)


class _Following:
    """A reduction fed block by block as a reader reads (:attr:`_How.blocks`)."""

    def __init__(self, start: Callable[[], _Reduction]):
        self.start, self.reduction, self.samples = start, start(), 0

    def __call__(self, block: dict[str, F64] | None) -> None:
        if block is None:  # the reader starts again
            self.reduction, self.samples = self.start(), 0
            return
        self.reduction.add_columns(block)
        self.samples += next(iter(block.values())).size


def _measure(start: Callable[[], _Reduction], raw: RawRecording, policy: str,
             followed: _Following | None = None) -> Measurement:
    """A reader's columns reduced (the reduction's errors first; or the reduction that
    ``followed`` the reading, where it saw every sample), checked (:func:`check_quality`),
    the flagged samples kept, omitted (reduced again without them) or refused by ``policy``, and
    the notes of the reader, the file and the checks kept in the measurement's metadata
    (``notes``, ``recording``, ``quality``)."""
    cols = raw.columns
    n = next(iter(cols.values())).size if cols else 0
    if followed is not None and followed.samples == n and n:
        reduction = followed.reduction
    else:
        reduction = start()
        reduction.add_columns(cols)
    m = reduction.measurement()
    source = reduction.source
    quality, kept = screen(cols, policy, source)
    if kept is not cols:  # the flagged samples omitted: reduced again without them
        reduction = start()
        reduction.add_columns(kept)
        m = reduction.measurement()
    state = raw.state
    notes = list(raw.notes) + list(m.metadata.get("notes") or [])
    if m.load_kind is None and m.single_azimuth and not m.is_coil:  # (a sweep of tilt angles)
        notes += state.notes(m.angles_deg, m.counts, where=source)
    metadata = dict(m.metadata)
    if notes:
        metadata["notes"] = notes
    if state.own or state.complete is not None:
        metadata["recording"] = state.to_dict()
        missing = state.missing_angles(m.angles_deg)
        if state.planned_angles_deg is not None:
            metadata["recording"]["missing_angles_deg"] = missing.tolist()
    metadata["quality"] = quality.to_dict()
    return dataclasses.replace(m, metadata=metadata)
