"""The single-output read-out's result: :class:`ReadoutResult` (angle, force or flow with 1-σ parts
and :class:`~magcilia.readout.protocol.Flag` bits) and its one-line summary."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Display, Item, Table, column, dataframe
from magcilia.device.parameters import MEASURANDS
from magcilia.readout.protocol import Flag, flag_counts

F64 = NDArray[np.float64]

ReadoutFlag = Flag
"""The single-output read-out's flags: the one :class:`~magcilia.readout.protocol.Flag` set, under
its former name."""
#: the flags that leave a reading without an estimate (value and sigma NaN)
NO_ESTIMATE = Flag.OUTSIDE_SPAN | Flag.FOLD | Flag.SATURATED
#: the array fields of :class:`ReadoutResult`, in order
_PARTS = ("value", "sigma", "sigma_noise", "sigma_calibration", "sigma_edge", "sigma_scale",
          "flags")
#: the flags a single output raises by itself (always counted by :meth:`ReadoutResult.counts`)
_OWN = (Flag.OUTSIDE_SPAN, Flag.FOLD, Flag.SATURATED, Flag.EXTRAPOLATED, Flag.CLIPPED,
        Flag.BELOW_SPAN, Flag.ABOVE_SPAN)


@dataclass(frozen=True, eq=False, repr=False)
class ReadoutResult(Display):
    """Estimates from :meth:`Readout.read` (arrays have the shape of the readings).

    Attributes
    ----------
    quantity : str
        ``"angle"``, ``"force"`` or ``"flow"``.
    unit : str
        SI unit of ``value`` and ``sigma`` (rad, N, m/s).
    value : ndarray
        Estimates; NaN where a flag of :data:`NO_ESTIMATE` is set (EXTRAPOLATED and CLIPPED
        readings have one).
    sigma : ndarray
        1-σ uncertainty, sqrt(sigma_noise² + sigma_calibration² + sigma_edge² + sigma_scale²);
        NaN where ``value`` is.
    sigma_noise, sigma_calibration : ndarray
        Two parts: the noise of the reading (the sensor model's over the bandwidth, or the
        measured one; the only part that differs at random between readings), and the errors
        shared by all readings: the calibration covariance and a tare's standard error.
    sigma_edge : ndarray
        The third part: for CLIPPED readings the distance from the model's estimate to the
        span's end that they were set to; 0 for the others.
    sigma_scale : ndarray
        The fourth part, the force scale: the Young's modulus's relative 1 σ through the model
        (``|F| · σ_E/E`` for a tip force; :mod:`magcilia.readout.scale`), 0 for a tilt angle or a
        modulus taken as exact. Systematic: one error shared by every reading (fully
        correlated), so averaging does not reduce it.
    scale_note : str
        Where the modulus comes from (:meth:`magcilia.Modulus.note`; "" for a tilt angle).
    flags : ndarray of uint16
        :class:`~magcilia.readout.protocol.Flag` bits (:data:`~magcilia.readout.protocol.
        FLAG_DTYPE`).
    table_error : float
        Stated error bound of the interpolation table, in ``unit``.
    """

    quantity: str
    unit: str
    value: F64
    sigma: F64
    sigma_noise: F64
    sigma_calibration: F64
    sigma_edge: F64
    sigma_scale: F64
    flags: NDArray[np.uint16]
    table_error: float
    scale_note: str = ""

    @classmethod
    def of(cls, quantity: str, unit: str, parts: tuple[NDArray[Any] | None, ...],
           table_error: float, scale_note: str = "", relative: float = 0.0) -> ReadoutResult:
        """A result of ``parts``, the seven arrays ``value`` … ``flags`` in the order of the
        fields (as the constructor, without its field-by-field frozen assignments: a live
        read-out builds one per block of a few readings). ``sigma_scale`` may be None where it
        is exactly ``|value| · relative`` (a tip force: ``relative`` = σ_E/E): it is then formed
        from ``value`` on first use and kept (the same numbers, one array less to write when
        the caller does not ask for this part)."""
        result = object.__new__(cls)
        fields = result.__dict__
        fields.update(zip(_PARTS, parts, strict=True), quantity=quantity, unit=unit,
                      table_error=table_error, scale_note=scale_note)
        if parts[5] is None:
            del fields["sigma_scale"]
            fields["_scale_relative"] = relative
        return result

    if not TYPE_CHECKING:  # (for the type checker, sigma_scale is the field it is)
        def __getattr__(self, name: str) -> Any:
            """``sigma_scale`` left to form by :meth:`of`: ``|value| · relative``, kept."""
            relative = self.__dict__.get("_scale_relative")
            if name == "sigma_scale" and relative is not None:
                scale = np.abs(self.value) * relative
                self.__dict__["sigma_scale"] = scale
                return scale
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def ok(self) -> NDArray[np.bool_]:
        """True where no flag is set (a reading within the span)."""
        return np.asarray(self.flags == 0)

    @property
    def estimated(self) -> NDArray[np.bool_]:
        """True where the reading has an estimate (no flag of :data:`NO_ESTIMATE`: within the
        span, or EXTRAPOLATED or CLIPPED within the edge tolerance)."""
        return np.asarray(self.flags & int(NO_ESTIMATE) == 0)

    def counts(self) -> dict[str, int]:
        """Readings per flag name (lower case, as in the CSV's ``flag_names``), and ``"readings"``,
        ``"estimated"`` and ``"ok"``."""
        return {"readings": int(self.flags.size), "estimated": int(self.estimated.sum()),
                "ok": int(self.ok.sum()), **flag_counts(self.flags, _OWN)}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; flagged estimates are NaN, written as null)."""
        return {"quantity": self.quantity, "unit": self.unit, "value": self.value.tolist(),
                "sigma": self.sigma.tolist(), "sigma_noise": self.sigma_noise.tolist(),
                "sigma_calibration": self.sigma_calibration.tolist(),
                "sigma_edge": self.sigma_edge.tolist(),
                "sigma_scale": self.sigma_scale.tolist(), "flags": self.flags.tolist(),
                "table_error": self.table_error, "scale_note": self.scale_note}

    def summary(self) -> str:
        """The same as :meth:`report` (the name of magcilia 0.1)."""
        return self.report()

    def report(self) -> str:
        """One line: counts of estimated and flagged readings, value range, median sigma (display
        unit: deg, mN, m/s) and, for a force or flow, where the force scale comes from."""
        q = MEASURANDS[self.quantity]
        return summary_line(self, q.display, q.display_factor)

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        q, good, c = MEASURANDS[self.quantity], self.estimated, self.counts()
        items = [("", self.quantity), ("estimated", f"{c['estimated']}/{c['readings']}")]
        items += [(key, str(c[key])) for key in ("outside_span", "fold", "saturated",
                                                  "extrapolated", "clipped") if c[key]]
        if good.any():
            lo, hi = (q.text(float(f(self.value[good]))) for f in (np.min, np.max))
            items += [("range", f"{lo}…{hi}"),
                      ("median σ", q.text(float(np.median(self.sigma[good]))))]
        return items

    def _display_table(self) -> Table:
        q = MEASURANDS[self.quantity]
        return ((f"{self.quantity} ({q.display})", f"σ ({q.display})", "flags"),
                [(q.text(v, 5).split(" ")[0], q.text(s).split(" ")[0], Flag(int(f)).name
                  or "ok") for v, s, f in zip(self.value, self.sigma, self.flags, strict=True)])

    def to_dataframe(self) -> Any:
        """The estimates as a ``pandas.DataFrame``, one row per reading, SI, columns named by
        quantity and unit: the value (``force_N``, ``angle_rad``, ``flow_m_per_s``), ``sigma_*``,
        ``sigma_noise_*``, ``sigma_calibration_*``, ``sigma_edge_*``, ``sigma_scale_*`` (same
        unit) and ``flags``
        (:class:`~magcilia.readout.protocol.Flag` bits, 0 a good reading; NaN values where
        flagged)."""
        return dataframe({**self.columns(), "flags": self.flags})

    def columns(self) -> dict[str, F64]:
        """The estimates and their σ by column name (:meth:`to_dataframe`'s, without ``flags``;
        SI, the unit in the name)."""
        return {column(self.quantity, self.unit): self.value,
                column("sigma", self.unit): self.sigma,
                column("sigma_noise", self.unit): self.sigma_noise,
                column("sigma_calibration", self.unit): self.sigma_calibration,
                column("sigma_edge", self.unit): self.sigma_edge,
                column("sigma_scale", self.unit): self.sigma_scale}

    def to_xarray(self, time_s: Any = None) -> Any:
        """The estimates as an ``xarray.Dataset``: the columns of :meth:`to_dataframe` as
        variables along ``sample`` (several dimensions ``axis_0``, ``axis_1``, … for readings
        of more than one), ``units`` attributes (``unit``; flags none), ``quantity``, ``unit``,
        ``table_error`` and ``scale_note`` as attributes. Needs xarray (the ``export`` extra;
        one line without it).

        Parameters
        ----------
        time_s : array-like, shape (n,), optional
            The readings' times, s: the coordinate ``time_s`` (1-D readings only).
        """
        from magcilia import _validate as v
        from magcilia.io.export_xarray import dataset

        frame = self.columns()
        units = dict.fromkeys(frame, self.unit)
        variables: dict[str, Any] = {**frame, "flags": self.flags}
        shape = np.shape(self.value)
        dims = ("sample",) if len(shape) == 1 else tuple(f"axis_{i}" for i in range(len(shape)))
        if time_s is not None:
            times = np.asarray(time_s, dtype=np.float64)
            if len(shape) != 1 or times.shape != shape:
                raise v.fail("time_s", f"shape {times.shape}",
                             f"one time per reading, shape {shape} (1-D readings)")
            variables["time_s"] = times
            units["time_s"] = "s"
        return dataset(variables, units, dim=dims, coords=("time_s",),
                       attrs={"quantity": self.quantity, "unit": self.unit,
                              "table_error": self.table_error, "scale_note": self.scale_note})


def summary_line(result: ReadoutResult, unit: str, factor: float) -> str:
    """:meth:`ReadoutResult.report` with values shown in ``unit``, of which one is ``factor``
    in SI (``"mN"``, 1e-3): counts of estimated and flagged readings, range, median 1-σ, and the
    force scale's note."""
    c = result.counts()
    flagged = ", ".join(f"{c[key]} {name}" for key, name in (
        ("outside_span", "outside span"), ("fold", "ambiguous (fold)"),
        ("saturated", "saturated")))
    edges = ", ".join(f"{c[key]} {key}" for key in ("extrapolated", "clipped") if c[key])
    good = result.estimated
    if good.any():
        vals = result.value[good] / factor
        rng = (f"{result.quantity} {np.min(vals):.4g}…{np.max(vals):.4g} {unit}, median "
               f"1-σ {np.median(result.sigma[good]) / factor:.3g} {unit}")
    else:
        rng = "no valid estimate"
    beyond = f", {edges} beyond the span's ends" if edges else ""
    note = f"; {result.scale_note}" if result.scale_note else ""
    return (f"{c['estimated']}/{c['readings']} readings estimated ({flagged} flagged{beyond}); "
            f"{rng}{note}")

