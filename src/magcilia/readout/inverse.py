"""Read-out: turn sensor outputs (V) back into a tilt angle, a tip force or a flow speed.

:class:`Readout` precomputes a dense table of output vs quantity over a span (the paper's rigid
tilt for ``"angle"``; large-deflection bending of :func:`magcilia.bend` for ``"force"`` and
``"flow"``), keeps the monotone branch that contains the span's start (recording where the output
folds back), and inverts it by linear interpolation, resampled on a uniform output grid so that a
reading's cell is found by arithmetic instead of a search (the fast path,
:meth:`Readout.estimate`). :meth:`Readout.read` adds 1-σ uncertainties (sensor noise through
the local slope, the calibration covariance of a :class:`~magcilia.CalibrationResult`, and for a
force or flow the Young's modulus's uncertainty: :mod:`magcilia.readout.scale`) and flags.

The table's stated error bound (:attr:`Readout.table_error`) is measured, not assumed: the table
uses every other point of a grid twice as dense, and the bound is the largest difference between
the table's estimate and the directly solved quantity at the skipped mid-points.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, si
from magcilia.calibration import CalibrationResult, ParameterCovariance
from magcilia.calibration.posterior import Posterior
from magcilia.device.actuation import Actuation
from magcilia.device.parameters import MEASURANDS
from magcilia.device.sensor import DEFAULT_BANDWIDTH, flag_names
from magcilia.device.setup import Setup
from magcilia.device.stiffness import Modulus
from magcilia.mechanics import Flow, output_at
from magcilia.readout import compiled as compiled_read
from magcilia.readout.calibration_sigma import POSTERIOR_DRAWS, calibration_sigma
from magcilia.readout.edges import (
    EDGE_SIGMAS,
    EDGE_TOLERANCE,
    EDGES,
    edge_table,
    noise_reach,
    outside_text,
    read_beyond,
)
from magcilia.readout.forward import (
    ELEMENT,
    check_actuated,
    compensation_text,
    direct_field,
    model_fields,
    model_output,
)
from magcilia.readout.protocol import FLAG_DTYPE, OUTPUT, Flag, tare_flags
from magcilia.readout.result import NO_ESTIMATE, ReadoutFlag, ReadoutResult, summary_line
from magcilia.readout.scale import modulus_sigma, scales_exactly
from magcilia.readout.table import InverseTable, _interp
from magcilia.readout.tare import Tare

__all__ = [
    "BLOCK", "EDGES", "EDGE_SIGMAS", "EDGE_TOLERANCE", "ELEMENT", "NO_ESTIMATE",
    "POSTERIOR_DRAWS", "QUANTITIES", "InverseTable", "Readout", "ReadoutFlag", "ReadoutResult",
    "check_actuated", "compensation_text", "direct_field", "model_fields", "model_output",
    "summary_line",
]

F64 = NDArray[np.float64]

#: what a read-out can estimate (the registry's measurands)
QUANTITIES = tuple(MEASURANDS)
#: readings per block of :meth:`Readout.read` (its temporaries stay in the CPU's cache)
BLOCK = 65536


@dataclass(frozen=True, eq=False, init=False, repr=False)
class Readout(Display):
    """Inverse read-out of one quantity from the sensor output (immutable).

    Parameters
    ----------
    setup : Setup
        The (calibrated) sensor setup; its dipole layout resolved by the layout rule at the
        sensing element (:meth:`~magcilia.Setup.resolve_layout`: a converged layout converges
        there, a given one is warned about above 1 % off); ``.setup`` is the setup used.
    quantity : {"angle", "force", "flow"}
        Rigid tilt angle (rad), dead tip force along +x (N; needs ``tip_radius > 0``) or the
        speed of ``flow`` (m/s).
    span : (float, float)
        Range of the quantity, SI (rad, N or m/s), low < high; the table starts at ``low``.
    calibration : CalibrationResult or ParameterCovariance, optional
        Its parameter covariance (standard errors and correlations) is propagated to the
        estimates through the table's parameter Jacobian.
    flow : Flow, optional
        Profile for ``"flow"`` (scaled to each speed); default uniform water flow.
    table_size : int
        Table points (≥ 9); the table is checked against direct solves at its mid-points.
    edge : {"extrapolate", "clip", "blank"}
        What a reading just beyond an end of the span gets, within ``edge_tolerance`` of it (a
        zero-load baseline whose noise dips below 0, a full-scale load whose noise rises above
        the span): ``"extrapolate"`` (default) the model continued past the end (the table
        extended by direct solves beyond the span: the same accuracy as within), flag
        EXTRAPOLATED; ``"clip"`` the end's value, flag CLIPPED, with the distance from the
        model's estimate to the end as ``sigma_edge``; ``"blank"`` no estimate (OUTSIDE_SPAN, as
        magcilia 0.1). Readings further out are OUTSIDE_SPAN. All of them also get BELOW_SPAN or
        ABOVE_SPAN. The end at a fold is never continued (a reading beyond the turn stays
        OUTSIDE_SPAN), nor past a turn of the output beyond the span, nor where the model
        cannot be solved (``edge_reach`` says how far each end reaches).
    edge_tolerance : float, optional
        How far beyond each end of the span readings are estimated, in the quantity's SI unit
        (rad, N, m/s). Default, for each end: :data:`EDGE_TOLERANCE` (5 %) of the span's width,
        or more where the output moves by less than :data:`EDGE_SIGMAS` (5) σ of the sensor's
        noise over :data:`~magcilia.device.sensor.DEFAULT_BANDWIDTH` within it (a flow speed
        from rest, where drag ∝ U²): then as far as it takes (doubling), up to the span's
        width.
    actuation : Actuation, optional
        A known, constant actuation field (:class:`~magcilia.Actuation`) acting while the readings
        are taken: the table is then built from the cilium bent by the quantity *and* the
        actuation (its couple and force on the magnetization, :func:`magcilia.bend`) plus the
        actuation's direct field at the element, so that readings taken under it invert to the
        external load (compensation; :func:`model_output`). A field that flips the element or
        saturates it over the whole span is refused (:attr:`sensor_flags` keeps the rest of
        :meth:`Sensor.check`'s flags); for a varying actuation (a coil current per reading) see
        :class:`magcilia.readout.actuated.ActuatedReadout`. Without one, every result is
        exactly today's.

    Attributes
    ----------
    table : InverseTable
        The monotone table and its uniform-grid fast path.
    edge : str
        As given.
    edge_tolerance : (float, float)
        The tolerance below the span's low end and above its high end, SI.
    edge_tables : (InverseTable or None, InverseTable or None)
        The model continued beyond the span's low and high ends (None where not continued).
    baseline : Tare or None
        The zero-load baseline of :meth:`tare` (None: untared).
    table_quantity, table_output : ndarray, shape (t,)
        The table (quantity in SI, output in V).
    table_error : float
        Largest interpolation error found at the mid-points, in the quantity's unit.
    fold : float or None
        Quantity at which the output folds back inside the span (None if monotone).
    output_range : (float, float)
        Outputs (V) at the start and the end of the usable branch.
    calibration : ParameterCovariance, Posterior or None
        The calibration uncertainty propagated to the estimates: a covariance (linearised at
        the setup) or posterior samples (the spread of the model over
        :data:`POSTERIOR_DRAWS` of them).
    sigma_calibration : ndarray, shape (t,)
        1-σ output uncertainty (V) from the calibration at the table nodes.
    modulus : Modulus
        The setup's Young's modulus, its 1 σ and source (:attr:`magcilia.Setup.modulus`).
    sigma_modulus : ndarray, shape (t,)
        1-σ output uncertainty (V) from the modulus at the table nodes (the force scale,
        :mod:`magcilia.readout.scale`; zeros for an angle or a modulus taken as exact).
    edge_reach : (float, float)
        How far (SI, ≥ 0) the model is continued below the span's low end and above its high
        end: ``edge_tolerance``, less where the output turns or the model fails, 0 at a fold
        end or with ``edge="blank"``.
    actuation : Actuation or None
        As given.
    sensor_flags : int
        :class:`~magcilia.device.sensor.SensorFlag` bits of the total field at the element over
        the table (union; 0 without an actuation: not checked).

    Examples
    --------
    >>> import magcilia as mc
    >>> r = mc.Readout(mc.Setup.paper(), quantity="angle", span=(0.0, 0.5))
    >>> v = mc.Setup.paper().output([0.2])
    >>> round(float(r.estimate(v)[0]), 4)
    0.2
    """

    setup: Setup
    quantity: str
    unit: str
    span: tuple[float, float]
    calibration: ParameterCovariance | Posterior | None
    flow: Flow
    table: InverseTable
    sigma_calibration: F64
    modulus: Modulus
    sigma_modulus: F64
    edge: str
    edge_tolerance: tuple[float, float]
    edge_tables: tuple[InverseTable | None, InverseTable | None]
    baseline: Tare | None
    actuation: Actuation | None
    sensor_flags: int

    def __init__(self, setup: Setup, quantity: str = "angle",
                 span: tuple[float, float] | None = None,
                 calibration: CalibrationResult | ParameterCovariance | Posterior | None = None,
                 flow: Flow | None = None,
                 table_size: int = 257, edge: str = "extrapolate",
                 edge_tolerance: float | None = None,
                 actuation: Actuation | None = None) -> None:
        if not isinstance(setup, Setup):
            raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
        setup = setup.resolve_layout()  # the layout rule at the sensing element
        quantity = v.choice("quantity", quantity, QUANTITIES)
        unit = MEASURANDS[quantity].unit
        if span is None or np.size(span) != 2:
            raise v.fail("span", span, f"a pair (low, high) in {unit}")
        lo = v.real("span low", span[0], unit)
        hi = v.real("span high", span[1], unit)
        if hi <= lo:
            raise v.fail("span", (lo, hi), "a pair (low, high) with high > low")
        if flow is not None and not isinstance(flow, Flow):
            raise v.fail("flow", type(flow).__name__, "a magcilia.Flow")
        if actuation is not None and not isinstance(actuation, Actuation):
            raise v.fail("actuation", type(actuation).__name__,
                         "a magcilia Actuation (Actuation.uniform(b), Actuation.magpylib(source))")
        edge = v.choice("edge", edge, EDGES)
        given = (None if edge_tolerance is None else
                 v.non_negative("edge_tolerance", edge_tolerance, unit, "tolerance"))
        if isinstance(calibration, CalibrationResult):
            calibration = calibration.uncertainty
        flow = flow if flow is not None else Flow.uniform(1.0)
        grid = np.linspace(lo, hi, 2 * v.integer("table_size", table_size, 9) - 1)
        flags = 0
        if actuation is None:
            volts_grid = output_at(setup, quantity, grid, flow)
        else:
            fields = model_fields(setup, quantity, grid, flow, actuation)
            flags = check_actuated(setup, fields, actuation)
            volts_grid = setup.sensor.voltage(fields[:, 0])
        table = InverseTable.build(grid, volts_grid, f"{quantity} {lo:.6g}…{hi:.6g} {unit}")
        base = EDGE_TOLERANCE * (hi - lo) if given is None else given
        tolerance = (base, base)
        if given is None and edge != "blank":
            volts = EDGE_SIGMAS * setup.sensor.output_noise_rms(*DEFAULT_BANDWIDTH)
            tolerance = (noise_reach(setup, quantity, flow, lo, -1.0, table.output[0], base,
                                      hi - lo, volts, actuation),
                         base if table.fold is not None else
                         noise_reach(setup, quantity, flow, hi, 1.0, table.output[-1], base,
                                      hi - lo, volts, actuation))
        edges: list[InverseTable | None] = [None, None]
        step = (hi - lo) / (grid.size - 1)
        for i, (end, sign, volts_end) in enumerate(((lo, -1.0, table.output[0]),
                                                    (hi, 1.0, table.output[-1]))):
            if edge == "blank" or tolerance[i] == 0.0 or (i and table.fold is not None):
                continue
            points = int(min(max(2 * math.ceil(tolerance[i] / step) + 1, 9), grid.size))
            edges[i] = edge_table(setup, quantity, flow, end, sign * tolerance[i], points,
                                   volts_end, actuation)
        for name, value in (("setup", setup), ("quantity", quantity), ("unit", unit),
                            ("span", (lo, hi)), ("calibration", calibration), ("flow", flow),
                            ("table", table), ("edge", edge), ("edge_tolerance", tolerance),
                            ("edge_tables", tuple(edges)), ("baseline", None),
                            ("actuation", actuation), ("sensor_flags", flags)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "sigma_calibration", calibration_sigma(
            setup, quantity, flow, table.quantity, calibration, actuation))
        object.__setattr__(self, "modulus", setup.modulus)
        object.__setattr__(self, "sigma_modulus", modulus_sigma(
            lambda s, q: model_output(s, quantity, q, flow, actuation), setup, quantity,
            table.quantity, table.output, actuation is not None))

    # -- the table --------------------------------------------------------------------------------
    @property
    def table_quantity(self) -> F64:
        """Quantity at the table nodes, SI, shape (t,)."""
        return self.table.quantity

    @property
    def table_output(self) -> F64:
        """Output at the table nodes, V, shape (t,)."""
        return self.table.output

    @property
    def table_error(self) -> float:
        """Largest interpolation error found at the mid-points, in the quantity's unit."""
        return self.table.error

    @property
    def fold(self) -> float | None:
        """Quantity at which the output folds back inside the span (None if monotone)."""
        return self.table.fold

    @property
    def output_range(self) -> tuple[float, float]:
        """Outputs (V) at the start and the end of the usable branch."""
        return self.table.output_range

    @property
    def edge_reach(self) -> tuple[float, float]:
        """How far (SI) the model is continued below the span's low end and above its high end
        (see the class docstring)."""
        return tuple(0.0 if t is None else abs(float(t.quantity[-1] - t.quantity[0]))
                     for t in self.edge_tables)  # type: ignore[return-value]

    @property
    def edge_error(self) -> float:
        """Largest interpolation error of the edge tables at their mid-points, in the quantity's
        unit (0 without them): as :attr:`table_error`, for readings beyond the span."""
        return max((t.error for t in self.edge_tables if t is not None), default=0.0)

    # -- the read-out protocol (:mod:`magcilia.readout.protocol`) ------------------------------
    @property
    def inputs(self) -> tuple[str, ...]:
        """What one sample holds: the sensor output, ``("output",)`` (V)."""
        return (OUTPUT,)

    @cached_property
    def rest(self) -> F64:
        """The model's output at rest (angle 0, force 0, flow 0; under the actuation if any), V,
        shape (1,)."""
        rest = model_output(self.setup, self.quantity, np.zeros(1), self.flow, self.actuation)
        rest.setflags(write=False)
        return rest

    # -- tare -----------------------------------------------------------------------------------
    def tare(self, baseline_volts: ArrayLike) -> Readout:
        """A copy of this read-out whose zero is the mean of unloaded readings.

        Every reading then gets the correction ``V_rest − mean(baseline)`` added (``V_rest``:
        the model's output at angle 0, force 0 or flow 0), as the live read-out's tare does
        (:class:`~magcilia.readout.tare.Tare`); the baseline's standard error, an error shared by
        all readings, adds to ``sigma_calibration``, and its spread, the measured noise of one
        reading, replaces the sensor model's noise in :meth:`read` unless ``noise`` is given.

        Parameters
        ----------
        baseline_volts : array-like, any shape
            Raw outputs (V) with the cilium unloaded, at least 2 finite ones (NaN are skipped);
            a previous tare is replaced, not added to.

        Returns
        -------
        Readout
            The tared read-out (same table; ``baseline`` set).

        Examples
        --------
        >>> import magcilia as mc
        >>> r = mc.Readout(mc.Setup.paper(), quantity="angle", span=(0.0, 0.5))
        >>> drifted = mc.Setup.paper().output([0.0, 0.0, 0.2]) + 1e-3   # a 1 mV offset
        >>> tared = r.tare(drifted[:2])
        >>> round(float(tared.estimate(drifted[2:])[0]), 4)
        0.2
        """
        new = copy.copy(self)
        object.__setattr__(new, "baseline", Tare.from_readings(baseline_volts, float(self.rest[0])))
        return new

    # -- use ------------------------------------------------------------------------------------
    def estimate(self, volts: ArrayLike) -> F64:
        """The quantity for each reading (fast path: the monotone table), same shape as ``volts``.

        Readings within the edge tolerance beyond an end of the span are extrapolated or clipped
        as ``edge`` says (with ``edge="blank"`` they raise); a tare's correction is added first.

        Parameters
        ----------
        volts : array-like, any shape
            Sensor outputs, V.

        Returns
        -------
        ndarray
            Estimates in SI (rad, N or m/s).

        Raises
        ------
        MagciliaError
            If a reading lies outside the span's output range (or beyond the fold) by more than
            the edge tolerance, naming the first such reading; use :meth:`read` to flag rather
            than raise.
        """
        x = np.asarray(volts, dtype=np.float64)
        passes = compiled_read.kernels()
        if passes is not None:  # one compiled pass, the tare's correction in it
            flat = x.reshape(-1)
            value = np.empty(flat.size)
            correction = 0.0 if self.baseline is None else self.baseline.correction
            if not passes[1](flat, correction, self._packed.cells, self._packed.consts, value):
                return value.reshape(x.shape)
            x = x + correction
        else:
            if self.baseline is not None:
                x = x + self.baseline.correction
            flat = x.reshape(-1)
            ends = self.table.volts[[0, -1]]  # (readings beyond them, NaN too: replaced below)
            value = self.table.lookup(np.fmin(np.fmax(flat, ends[0]), ends[1]))
        table = self.table
        if x.size and not (x.min() >= table.volts[0] and x.max() <= table.volts[-1]):  # and NaN
            flat = x.reshape(-1)
            out = np.flatnonzero(~table.inside(flat))
            beyond, _, _, flags = self._beyond(flat[out])
            bad = out[flags & FLAG_DTYPE(Flag.OUTSIDE_SPAN) != 0]
            if bad.size:
                first = np.unravel_index(int(bad[0]), x.shape)
                where = f"volts[{', '.join(map(str, first))}]" if x.ndim else "volts"
                raise v.fail(where, f"{float(x[first]):.6g} V", outside_text(
                    self.quantity, self.span, self.unit, self.table, self.edge_tables, self.edge))
            value[out] = beyond
        return value.reshape(x.shape)

    def _beyond(self, x: F64) -> tuple[F64, F64, F64, NDArray[np.uint16]]:
        """:func:`~magcilia.readout.edges.read_beyond` of readings ``x`` (V, (b,))."""
        return read_beyond(self.table, self.edge_tables, self.edge, x)

    def read(self, volts: ArrayLike,
             bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH,
             noise: ArrayLike | None = None) -> ReadoutResult:
        """Estimates with 1-σ uncertainties and flags (never raises for out-of-span readings).

        The 1-σ of a force or flow includes the force scale (``sigma_scale``: the Young's
        modulus's uncertainty, systematic, :mod:`magcilia.readout.scale`) until E is fitted from
        load data, given with its σ, or measured; ``sigma_noise`` is the noise alone.

        Parameters
        ----------
        volts : array-like, any shape
            Sensor outputs, V (NaN readings are flagged OUTSIDE_SPAN). A tare's correction is
            added first.
        bandwidth : (float, float)
            Noise bandwidth (f_low, f_high), Hz, of each reading (see
            :meth:`magcilia.Sensor.noise_rms`).
        noise : float or array-like of one value, optional
            Output noise RMS of each reading, V, measured (the spread of unloaded readings);
            default :meth:`reading_noise`'s (the tare's spread, else the sensor model's).
        """
        noise_v = self.reading_noise(noise, bandwidth)
        shape = np.shape(volts)
        x = np.asarray(volts, dtype=np.float64).reshape(-1)
        n, base = x.size, self.baseline
        correction = 0.0 if base is None else base.correction
        passes = compiled_read.kernels()
        if passes is not None:  # one compiled pass; the few readings beyond the table below
            parts: tuple[Any, ...] = compiled_read.read_parts(
                passes[0], self._packed, x, correction, float(noise_v),
                0.0 if base is None else float(base.standard_error), self._read_block)
        else:
            if base is not None:
                x = x + correction
            parts = (*(np.empty(n) for _ in range(6)), np.empty(n, dtype=FLAG_DTYPE))
            for start in range(0, n, BLOCK):
                part = slice(start, start + BLOCK)
                self._read_block(x[part], noise_v, *(p[part] for p in parts))
        if base is not None:
            np.bitwise_or(parts[-1], FLAG_DTYPE(tare_flags(base)),
                          out=parts[-1])  # a tare taken under load
        if len(shape) != 1:
            parts = tuple(None if p is None else p.reshape(shape) for p in parts)
        return ReadoutResult.of(self.quantity, self.unit, parts, self.table.error,
                                self._scale_note, self.modulus.relative)

    @cached_property
    def _packed(self) -> compiled_read.Packed:
        """The arguments of the compiled passes (:func:`~magcilia.readout.compiled.pack`)."""
        mode = (0 if not self.sigma_modulus.any() else
                1 if scales_exactly(self.quantity, self.actuation is not None) else 2)
        return compiled_read.pack(self.table, self.setup.sensor, self.table.quantity,
                                  self.sigma_calibration, self.sigma_modulus, mode,
                                  self.modulus.relative)

    @cached_property
    def _scale_note(self) -> str:
        """:attr:`scale_note`, formatted once (every :meth:`read` hands it on)."""
        return self.scale_note

    @property
    def scale_note(self) -> str:
        """Where the force scale comes from (:meth:`magcilia.Modulus.note`); "" for an angle."""
        return "" if self.quantity == "angle" else self.modulus.note()

    def reading_noise(self, noise: ArrayLike | None = None,
                      bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH) -> float:
        """One reading's output noise RMS, V, as :meth:`read` takes it: ``noise``, else the
        tare's spread, else the sensor model's over ``bandwidth`` (remembered per band)."""
        if noise is not None:
            if np.size(noise) != 1:
                raise v.fail("noise", v.short(noise), "one noise RMS in V (one channel)")
            return v.non_negative("noise", np.ravel(noise)[0], "V", "noise")
        if self.baseline is not None:
            return float(self.baseline.noise)
        return float(compiled_read.remembered(self.__dict__.setdefault("_noise_memo", {}),
                                              bandwidth, self.setup.sensor.output_noise_rms))

    def _read_block(self, x: F64, noise_v: float, value: F64, sigma: F64, s_noise: F64,
                    s_cal: F64, s_edge: F64, s_scale: F64, flags: NDArray[np.uint16]) -> None:
        """:meth:`read` of readings ``x`` (V, (b,), tare applied) with output noise ``noise_v``
        (V), into the result arrays (b,): one interpolation step gives the estimate and the
        table's slope; the few readings beyond the span take :meth:`_beyond`."""
        table = self.table
        sensor = self.setup.sensor
        inside = table.inside(x)
        np.logical_not(inside, out=flags, casting="unsafe")  # OUTSIDE_SPAN = 1
        if table.ambiguous is not None:
            amb = (x >= table.ambiguous[0]) & (x <= table.ambiguous[1]) & inside
            flags |= amb.astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.FOLD)
        with np.errstate(invalid="ignore"):
            sat = ~sensor.in_range(sensor.field(x))
        flags |= sat.astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.SATURATED)
        value[:], slope = table.value_and_slope(x)
        s_edge[:] = 0.0
        out = np.flatnonzero(~inside)
        if out.size:
            value[out], slope[out], s_edge[out], beyond = self._beyond(x[out])
            flags[out] = beyond | (flags[out] & FLAG_DTYPE(Flag.SATURATED))
        np.multiply(slope, noise_v, out=s_noise)
        tare_error = 0.0 if self.baseline is None else self.baseline.standard_error
        self._scale_block(value, slope, s_scale)
        if self.sigma_calibration.any():
            np.multiply(self._at_estimates(value, self.sigma_calibration), slope, out=s_cal)
            if tare_error:
                np.hypot(s_cal, slope * tare_error, out=s_cal)
            np.hypot(s_noise, s_cal, out=sigma)
        elif tare_error:
            np.multiply(slope, tare_error, out=s_cal)
            np.hypot(s_noise, s_cal, out=sigma)
        else:  # hypot(s, 0) = s exactly
            s_cal[:] = 0.0
            sigma[:] = s_noise
        if out.size:
            sigma[out] = np.hypot(sigma[out], s_edge[out])
        if self.sigma_modulus.any():
            np.hypot(sigma, s_scale, out=sigma)
        flagged = (flags & FLAG_DTYPE(NO_ESTIMATE)).astype(bool)
        for arr in (value, sigma, s_noise, s_cal, s_edge, s_scale):
            np.copyto(arr, np.nan, where=flagged)

    def _at_estimates(self, value: F64, profile: F64) -> F64:
        """``profile`` (t,), given at the table nodes, at the estimates ``value`` (SI, (b,);
        clipped to the table), linear in between: one arithmetic step, as the table's own."""
        q = self.table.quantity  # steps of q[1] - q[0] (the last may be shorter), increasing
        vq = np.fmin(np.fmax(value, q[0]), q[-1])
        j = np.minimum((vq - q[0]) / (q[1] - q[0]), q.size - 1).astype(np.intp)
        j -= vq < q[j]  # at or below vq (rounding): then at most one knot ahead
        return _interp(vq, j, 1, q, profile)

    def _scale_block(self, value: F64, slope: F64, out: F64) -> None:
        """The force scale's 1 σ of readings with estimates ``value`` (SI, (b,)) and slopes
        |dq/dV| (b,), into ``out``: exactly ``|F| · σ_E/E`` for a tip force without actuation,
        else the modulus's output σ at the estimate through the slope
        (:mod:`magcilia.readout.scale`); 0 without one."""
        if not self.sigma_modulus.any():
            out[:] = 0.0
        elif scales_exactly(self.quantity, self.actuation is not None):
            np.multiply(np.abs(value), self.modulus.relative, out=out)
        else:
            np.multiply(self._at_estimates(value, self.sigma_modulus), slope, out=out)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description of the table (SI)."""
        return {"quantity": self.quantity, "unit": self.unit, "span": list(self.span),
                "fold": self.fold, "output_range_V": list(self.output_range),
                "table_error": self.table_error, "table_size": int(self.table_quantity.size),
                "edge": self.edge, "edge_tolerance": list(self.edge_tolerance),
                "edge_reach": list(self.edge_reach), "edge_error": self.edge_error,
                "tare": None if self.baseline is None else self.baseline.to_dict(),
                "modulus": None if self.quantity == "angle" else self.modulus.to_dict(),
                **({} if self.actuation is None else {
                    "actuation": self.actuation.to_dict(),
                    "direct_field_T": direct_field(self.actuation).tolist(),
                    "sensor_flags": self.sensor_flags,
                    "sensor_flag_names": flag_names(self.sensor_flags)})}

    def report(self) -> str:
        """One line: the span, its output range, the fold if any, the table's error and, for a
        force or flow, where the force scale comes from."""
        q = MEASURANDS[self.quantity]
        lo, hi = (q.to_display(x) for x in self.span)
        text = (f"{q.label} read-out over {lo:.4g}…{hi:.4g} {q.display}: outputs "
                f"{min(self.output_range) * 1e3:.6g}…{max(self.output_range) * 1e3:.6g} mV, "
                "table error ≤ "
                f"{q.to_display(self.table_error):.2g} {q.display}")
        if self.fold is not None:
            text += f"; folds at {q.to_display(self.fold):.4g} {q.display}"
        low, high = (q.to_display(x) for x in self.edge_reach)
        if self.edge == "blank" or not (low or high):
            text += "; no estimate beyond the span"
        else:
            done = "extrapolated" if self.edge == "extrapolate" else "clipped"
            text += (f"; {done} up to {low:.4g} {q.display} below and {high:.4g} "
                     f"{q.display} above the span")
        if self.baseline is not None:
            text += f"; {self.baseline.report()}"
        if self.actuation is not None:
            text += f"; {compensation_text(self.setup, self.actuation, self.sensor_flags)}"
        if self.scale_note:
            text += f"; {self.scale_note}"
        return text

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        q = MEASURANDS[self.quantity]
        lo, hi = self.table.output_range
        return [("", self.quantity), ("span", f"{q.text(self.span[0])}…{q.text(self.span[1])}"),
                ("output", f"{si(lo, 'V')}…{si(hi, 'V')}"),
                ("calibrated", "yes" if self.calibration is not None else "no"),
                ("table error", q.text(self.table_error)), ("setup", repr(self.setup))]

