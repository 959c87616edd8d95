"""Read-out: turn sensor outputs (V) back into a tilt angle, a tip force or a flow speed.

:class:`Readout` precomputes a dense table of output vs quantity over a span (the paper's rigid
tilt for ``"angle"``; large-deflection bending of :func:`magcilia.bend` for ``"force"`` and
``"flow"``), keeps the monotone branch that contains the span's start (recording where the output
folds back), and inverts it by linear interpolation, resampled on a uniform output grid so that a
reading's cell is found by arithmetic instead of a search (the fast path,
:meth:`Readout.estimate`). :meth:`Readout.read` adds 1-σ uncertainties (sensor noise over a
bandwidth through the local slope, the calibration covariance when a
:class:`~magcilia.CalibrationResult` is given, and for a force or flow the Young's modulus's
uncertainty, the force scale: :mod:`magcilia.readout.scale`) and flags.

The table's stated error bound (:attr:`Readout.table_error`) is measured, not assumed: the table
uses every other point of a grid twice as dense, and the bound is the largest difference between
the table's estimate and the directly solved quantity at the skipped mid-points.
"""

from __future__ import annotations

import copy
import dataclasses
import enum
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, column, dataframe, si
from magcilia._errors import MagciliaError
from magcilia.calibration import CalibrationResult, ParameterCovariance
from magcilia.calibration.posterior import Posterior
from magcilia.device.actuation import Actuation
from magcilia.device.parameters import MEASURANDS, PARAMETERS
from magcilia.device.sensor import DEFAULT_BANDWIDTH, SensorFlag, flag_names
from magcilia.device.setup import Setup
from magcilia.device.stiffness import Modulus
from magcilia.mechanics import Flow, output_at, poses_at
from magcilia.readout.branch import first_turn
from magcilia.readout.scale import modulus_sigma, scales_exactly
from magcilia.readout.tare import Tare

F64 = NDArray[np.float64]

#: what a read-out can estimate (the registry's measurands)
QUANTITIES = tuple(MEASURANDS)
#: readings per block of :meth:`Readout.read` (its temporaries stay in the CPU's cache)
BLOCK = 65536
#: posterior samples a :class:`Readout` runs through the model for ``sigma_calibration`` (the
#: Monte-Carlo error of a standard deviation from n draws is about 1/sqrt(2 n): 6 %)
POSTERIOR_DRAWS = 128


class ReadoutFlag(enum.IntFlag):
    """Bit flags of a reading (combine with ``|``; 0 is a good reading).

    OUTSIDE_SPAN, FOLD and SATURATED leave a reading without an estimate (NaN,
    :data:`NO_ESTIMATE`); EXTRAPOLATED and CLIPPED readings have one (see :class:`Readout`'s
    ``edge``); BELOW_SPAN and ABOVE_SPAN say on which side of the span a reading lies beyond it.
    """

    OK = 0
    #: no estimate: beyond the span by more than its edge tolerance, beyond the fold, or NaN
    OUTSIDE_SPAN = 1
    #: the span extends past a fold and this output also occurs beyond it (ambiguous branch)
    FOLD = 2
    #: beyond the sensor's linear range (±field_range on the sensitive axis)
    SATURATED = 4
    #: beyond an end of the span but within the edge tolerance: estimated by the model continued
    #: past the end (``edge="extrapolate"``)
    EXTRAPOLATED = 8
    #: beyond an end of the span but within the edge tolerance: set to the end (``edge="clip"``)
    CLIPPED = 16
    #: the reading lies beyond the span's low end (quantity below ``span[0]``)
    BELOW_SPAN = 32
    #: the reading lies beyond the span's high end (quantity above ``span[1]``)
    ABOVE_SPAN = 64


#: the flags that leave a reading without an estimate (value and sigma NaN)
NO_ESTIMATE = ReadoutFlag.OUTSIDE_SPAN | ReadoutFlag.FOLD | ReadoutFlag.SATURATED
#: how readings beyond the span's ends (within the edge tolerance) are read
EDGES = ("extrapolate", "clip", "blank")
#: default edge tolerance: at least this fraction of the span's width …
EDGE_TOLERANCE = 0.05
#: … and at least as far as the output moves by this many σ of the sensor's noise (over
#: DEFAULT_BANDWIDTH) from the span's end, up to the span's width
EDGE_SIGMAS = 5.0


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
    flags : ndarray of uint8
        :class:`ReadoutFlag` bits.
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
    flags: NDArray[np.uint8]
    table_error: float
    scale_note: str = ""

    @property
    def ok(self) -> NDArray[np.bool_]:
        """True where no flag is set (a reading within the span)."""
        return np.asarray(self.flags == 0)

    @property
    def estimated(self) -> NDArray[np.bool_]:
        """True where the reading has an estimate (no flag of :data:`NO_ESTIMATE`: within the
        span, or EXTRAPOLATED or CLIPPED within the edge tolerance)."""
        return np.asarray(self.flags & np.uint8(NO_ESTIMATE) == 0)

    def counts(self) -> dict[str, int]:
        """Readings per flag name (lower case, as in the CSV's ``flag_names``), and ``"readings"``,
        ``"estimated"`` and ``"ok"``."""
        out = {"readings": int(self.flags.size), "estimated": int(self.estimated.sum()),
               "ok": int(self.ok.sum())}
        bits = np.bincount(self.flags.reshape(-1), minlength=256)
        for f in ReadoutFlag:
            if f:
                out[str(f.name).lower()] = int(bits[(np.arange(256) & int(f)) != 0].sum())
        return out

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
                [(q.text(v, 5).split(" ")[0], q.text(s).split(" ")[0], ReadoutFlag(int(f)).name
                  or "ok") for v, s, f in zip(self.value, self.sigma, self.flags, strict=True)])

    def to_dataframe(self) -> Any:
        """The estimates as a ``pandas.DataFrame``, one row per reading, SI, columns named by
        quantity and unit: the value (``force_N``, ``angle_rad``, ``flow_m_per_s``), ``sigma_*``,
        ``sigma_noise_*``, ``sigma_calibration_*``, ``sigma_edge_*``, ``sigma_scale_*`` (same
        unit) and ``flags``
        (:class:`ReadoutFlag` bits, 0 a good reading; NaN values where flagged)."""
        return dataframe({
            column(self.quantity, self.unit): self.value,
            column("sigma", self.unit): self.sigma,
            column("sigma_noise", self.unit): self.sigma_noise,
            column("sigma_calibration", self.unit): self.sigma_calibration,
            column("sigma_edge", self.unit): self.sigma_edge,
            column("sigma_scale", self.unit): self.sigma_scale,
            "flags": self.flags})


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


@dataclass(frozen=True, eq=False)
class InverseTable:
    """The monotone branch of the output vs a quantity, ready to invert (immutable).

    Built by :meth:`build` from a dense sweep: the branch that contains the sweep's start, every
    other point of it as the table, the skipped points to measure the interpolation error, and
    the table resampled on a uniform output grid so that a reading's cell is found by arithmetic
    instead of a search.

    Attributes
    ----------
    quantity, output : ndarray, shape (t,)
        The table: quantity (SI) and output (V), in sweep order.
    error : float
        Largest interpolation error at the skipped points, in the quantity's unit.
    fold : float or None
        Quantity at which the output folds back inside the sweep (None if monotone).
    ambiguous : (float, float) or None
        Output range (V) that also occurs beyond the fold.
    volts, values, slope : ndarray, shape (t,)
        The table sorted by increasing output, and dquantity/dV there.
    cell_start, cell_step : ndarray, shape (c,)
        The quantity at the start of each of ``c`` uniform output cells from ``volts[0]`` to
        ``volts[-1]``, and its change over the cell.
    cells_per_volt : float
        Cells per volt of output.
    cell_knot : ndarray of intp, shape (c,)
        For each cell, a table interval (index into ``volts``) at or below its readings; at most
        ``knot_steps`` knots lie between it and any reading of the cell.
    knot_steps : int
        Forward steps that find a reading's table interval from ``cell_knot``.
    """

    quantity: F64
    output: F64
    error: float
    fold: float | None
    ambiguous: tuple[float, float] | None
    volts: F64
    values: F64
    slope: F64
    cell_start: F64
    cell_step: F64
    cells_per_volt: float
    cell_knot: NDArray[np.intp]
    knot_steps: int

    @classmethod
    def build(cls, grid: F64, volts: F64, where: str) -> InverseTable:
        """The table of a sweep ``grid`` (quantity, increasing) with outputs ``volts`` (V);
        ``where`` names the sweep in errors."""
        dv = np.diff(volts)
        nonzero = np.nonzero(dv != 0.0)[0]
        if nonzero.size == 0:
            raise v.fail("span", where, "a span over which the output changes")
        sign = float(np.sign(dv[nonzero[0]]))
        end = int(first_turn(volts, flat=True))  # last index of the (strictly monotone) branch
        folds = end < grid.size - 1
        if end < 2:
            raise v.fail("span", where, f"a span whose output is monotone near its start (it "
                         f"folds at {grid[end]:.6g})")
        beyond = volts[end:]
        even = np.arange(0, end + 1, 2)
        if even[-1] != end:
            even = np.append(even, end)
        order = slice(None) if sign > 0 else slice(None, None, -1)
        xp = np.ascontiguousarray(volts[even][order])  # increasing outputs
        fp = np.ascontiguousarray(grid[even][order])
        n_cells = 16 * (xp.size - 1)
        cells = np.interp(np.linspace(xp[0], xp[-1], n_cells + 1), xp, fp)
        per_volt = n_cells / float(xp[-1] - xp[0])
        # the intervals at half a cell below and above each cell (a margin for rounding)
        first, last = np.clip(np.searchsorted(
            xp, xp[0] + (np.arange(n_cells) + np.array([[-0.5], [1.5]])) / per_volt,
            side="right") - 1, 0, xp.size - 1)
        table = cls(
            quantity=grid[even], output=volts[even], error=0.0,
            fold=float(grid[end]) if folds else None,
            ambiguous=(float(beyond.min()), float(beyond.max())) if folds else None,
            volts=xp, values=fp, slope=np.gradient(fp, xp), cell_start=cells[:-1].copy(),
            cell_step=np.diff(cells), cells_per_volt=per_volt,
            cell_knot=first.astype(np.intp), knot_steps=int(np.max(last - first)),
        )
        odd = np.arange(1, end, 2)
        if odd.size:
            error = float(np.max(np.abs(table.lookup(volts[odd]) - grid[odd])))
            table = dataclasses.replace(table, error=error)
        return table

    @property
    def output_range(self) -> tuple[float, float]:
        """Outputs (V) at the start and the end of the branch."""
        return float(self.output[0]), float(self.output[-1])

    def inside(self, x: F64) -> NDArray[np.bool_]:
        """Whether readings (V) lie within the table's output range (False for NaN)."""
        return np.asarray((x >= self.volts[0]) & (x <= self.volts[-1]))

    def lookup(self, x: F64) -> F64:
        """Uniform-grid linear interpolation of readings (V, any shape) assumed inside the
        table (readings outside get the end cells' lines)."""
        return self._cells(x)[0]

    def _cells(self, x: F64) -> tuple[F64, NDArray[np.intp]]:
        """:meth:`lookup` and each reading's cell index (same shape as ``x``)."""
        u = np.subtract(x, self.volts[0], out=np.empty(np.shape(x)))
        u *= self.cells_per_volt
        i = np.minimum(u, self.cell_start.size - 1).astype(np.intp)  # u ≥ 0 inside
        u -= i
        value = self.cell_step[i]
        value *= u
        value += self.cell_start[i]
        return value, i

    def value_and_slope(self, x: F64) -> tuple[F64, F64]:
        """Estimates (as :meth:`lookup`) and |dquantity/dV| (the table's slope interpolated
        linearly in output, as ``np.interp`` over ``volts``), same shape as ``x``; readings
        outside the table are taken at its nearest end (NaN at the start)."""
        xc = np.fmax(x, self.volts[0])  # NaN -> the start
        np.fmin(xc, self.volts[-1], out=xc)
        value, i = self._cells(xc)
        return value, np.abs(_interp(xc, self.cell_knot[i], self.knot_steps, self.volts,
                                     self.slope))


def _interp(x: F64, j: NDArray[np.intp], steps: int, xp: F64, fp: F64) -> F64:
    """``np.interp(x, xp, fp)`` for ``x`` within [xp[0], xp[-1]] (same shape as ``j``), given
    intervals ``j`` at or below each x with at most ``steps`` knots in between; the same
    arithmetic as NumPy's, so the same numbers (``j`` is updated in place)."""
    ahead = np.append(xp[1:], math.inf)
    for _ in range(steps):
        j += x >= ahead[j]
    rate = np.append(np.diff(fp) / np.diff(xp), 0.0)
    out = np.subtract(x, xp[j])
    out *= rate[j]
    out += fp[j]
    return out


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
            tolerance = (_noise_reach(setup, quantity, flow, lo, -1.0, table.output[0], base,
                                      hi - lo, volts, actuation),
                         base if table.fold is not None else
                         _noise_reach(setup, quantity, flow, hi, 1.0, table.output[-1], base,
                                      hi - lo, volts, actuation))
        edges: list[InverseTable | None] = [None, None]
        step = (hi - lo) / (grid.size - 1)
        for i, (end, sign, volts_end) in enumerate(((lo, -1.0, table.output[0]),
                                                    (hi, 1.0, table.output[-1]))):
            if edge == "blank" or tolerance[i] == 0.0 or (i and table.fold is not None):
                continue
            points = int(min(max(2 * math.ceil(tolerance[i] / step) + 1, 9), grid.size))
            edges[i] = _edge_table(setup, quantity, flow, end, sign * tolerance[i], points,
                                   volts_end, actuation)
        for name, value in (("setup", setup), ("quantity", quantity), ("unit", unit),
                            ("span", (lo, hi)), ("calibration", calibration), ("flow", flow),
                            ("table", table), ("edge", edge), ("edge_tolerance", tolerance),
                            ("edge_tables", tuple(edges)), ("baseline", None),
                            ("actuation", actuation), ("sensor_flags", flags)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "sigma_calibration", _calibration_sigma(
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
        rest = float(model_output(self.setup, self.quantity, np.zeros(1), self.flow,
                                  self.actuation)[0])
        new = copy.copy(self)
        object.__setattr__(new, "baseline", Tare.from_readings(baseline_volts, rest))
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
        if self.baseline is not None:
            x = x + self.baseline.correction
        table = self.table
        if x.size and not (x.min() >= table.volts[0] and x.max() <= table.volts[-1]):  # and NaN
            flat = x.reshape(-1)
            out = np.flatnonzero(~table.inside(flat))
            beyond, _, _, flags = self._beyond(flat[out])
            bad = out[flags & np.uint8(ReadoutFlag.OUTSIDE_SPAN) != 0]
            if bad.size:
                first = np.unravel_index(int(bad[0]), x.shape)
                where = f"volts[{', '.join(map(str, first))}]" if x.ndim else "volts"
                raise v.fail(where, f"{float(x[first]):.6g} V", f"within the span's output range "
                             f"{min(self.output_range):.6g}…{max(self.output_range):.6g} V "
                             f"({self._span_text()}){self._reach_text()}")
            value = table.lookup(flat)
            value[out] = beyond
            return value.reshape(x.shape)
        return table.lookup(x.reshape(-1)).reshape(x.shape)

    def _span_text(self) -> str:
        lo, hi = self.span
        text = f"{self.quantity} {lo:.4g}…{hi:.4g} {self.unit}"
        return text + (f", folding at {self.fold:.4g} {self.unit}" if self.fold is not None else "")

    def _reach_text(self) -> str:
        """``, or within ... beyond its ends (a…b V)`` where the span's ends are continued."""
        low, high = self.edge_reach
        if not (low or high):
            return ""
        ends = [t.volts[[0, -1]] for t in self.edge_tables if t is not None]
        a = min(self.table.volts[0], *(e[0] for e in ends))
        b = max(self.table.volts[-1], *(e[1] for e in ends))
        reach = f"{low:.4g} {self.unit} below" if low else ""
        reach += (" and " if low and high else "") + (f"{high:.4g} {self.unit} above" if high
                                                       else "")
        return f", or up to {reach} it ({a:.6g}…{b:.6g} V, edge={self.edge!r})"

    def _beyond(self, x: F64) -> tuple[F64, F64, F64, NDArray[np.uint8]]:
        """Readings ``x`` (V, (b,)) outside the table's output range (or NaN): estimates, the
        slope |dquantity/dV| for σ, the clipping distance (SI) and the flags (OUTSIDE_SPAN and
        BELOW/ABOVE_SPAN beyond the reach; EXTRAPOLATED or CLIPPED within it), all (b,)."""
        table = self.table
        value = np.full(x.size, np.nan)
        slope = np.full(x.size, np.nan)
        bias = np.zeros(x.size)
        flags = np.full(x.size, np.uint8(ReadoutFlag.OUTSIDE_SPAN))
        low_at_bottom = bool(table.output[0] == table.volts[0])  # output rises with the quantity
        for bottom in (True, False):
            low_end = bottom == low_at_bottom
            if not low_end and table.fold is not None:
                continue  # beyond the turn at the fold: no direction, no estimate
            side = np.flatnonzero(x < table.volts[0] if bottom else x > table.volts[-1])
            direction = np.uint8(ReadoutFlag.BELOW_SPAN if low_end else ReadoutFlag.ABOVE_SPAN)
            flags[side] |= direction
            ext = self.edge_tables[0 if low_end else 1]
            if ext is None or not side.size:
                continue
            side = side[ext.inside(x[side])]
            if not side.size:
                continue
            est, est_slope = ext.value_and_slope(x[side])
            if self.edge == "clip":
                end = table.quantity[0 if low_end else -1]
                value[side] = end
                bias[side] = np.abs(est - end)
                slope[side] = abs(float(table.slope[0 if bottom else -1]))
                flags[side] = direction | np.uint8(ReadoutFlag.CLIPPED)
            else:
                value[side] = est
                slope[side] = est_slope
                flags[side] = direction | np.uint8(ReadoutFlag.EXTRAPOLATED)
        return value, slope, bias, flags

    def read(self, volts: ArrayLike,
             bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH,
             noise: float | None = None) -> ReadoutResult:
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
        noise : float, optional
            Output noise RMS of each reading, V, measured (e.g. the spread of unloaded readings);
            replaces the sensor model's noise over ``bandwidth``. Default: the spread measured by
            :meth:`tare` if tared, else the sensor model's.
        """
        sensor = self.setup.sensor
        if noise is not None:
            noise_v = v.non_negative("noise", noise, "V", "noise")
        elif self.baseline is not None:
            noise_v = self.baseline.noise
        else:
            noise_v = sensor.output_noise_rms(*bandwidth)
        shape = np.shape(volts)
        x = np.asarray(volts, dtype=np.float64).reshape(-1)
        if self.baseline is not None:
            x = x + self.baseline.correction
        value, sigma, s_noise, s_cal, s_edge, s_scale = (np.empty(x.size) for _ in range(6))
        flags = np.empty(x.size, dtype=np.uint8)
        for start in range(0, x.size, BLOCK):
            part = slice(start, start + BLOCK)
            self._read_block(x[part], noise_v, value[part], sigma[part], s_noise[part],
                             s_cal[part], s_edge[part], s_scale[part], flags[part])
        return ReadoutResult(
            quantity=self.quantity, unit=self.unit, value=value.reshape(shape),
            sigma=sigma.reshape(shape), sigma_noise=s_noise.reshape(shape),
            sigma_calibration=s_cal.reshape(shape), sigma_edge=s_edge.reshape(shape),
            sigma_scale=s_scale.reshape(shape), flags=flags.reshape(shape),
            table_error=self.table_error, scale_note=self.scale_note,
        )

    @property
    def scale_note(self) -> str:
        """Where the force scale comes from (:meth:`magcilia.Modulus.note`); "" for an angle."""
        return "" if self.quantity == "angle" else self.modulus.note()

    def _read_block(self, x: F64, noise_v: float, value: F64, sigma: F64, s_noise: F64,
                    s_cal: F64, s_edge: F64, s_scale: F64, flags: NDArray[np.uint8]) -> None:
        """:meth:`read` of readings ``x`` (V, (b,), tare applied) with output noise ``noise_v``
        (V), into the result arrays (b,): one interpolation step gives the estimate and the
        table's slope; the few readings beyond the span take :meth:`_beyond`."""
        table = self.table
        sensor = self.setup.sensor
        inside = table.inside(x)
        np.logical_not(inside, out=flags, casting="unsafe")  # OUTSIDE_SPAN = 1
        if table.ambiguous is not None:
            amb = (x >= table.ambiguous[0]) & (x <= table.ambiguous[1]) & inside
            flags |= amb.view(np.uint8) * np.uint8(ReadoutFlag.FOLD)
        with np.errstate(invalid="ignore"):
            sat = ~sensor.in_range(sensor.field(x))
        flags |= sat.view(np.uint8) * np.uint8(ReadoutFlag.SATURATED)
        value[:], slope = table.value_and_slope(x)
        s_edge[:] = 0.0
        out = np.flatnonzero(~inside)
        if out.size:
            value[out], slope[out], s_edge[out], beyond = self._beyond(x[out])
            flags[out] = beyond | (flags[out] & np.uint8(ReadoutFlag.SATURATED))
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
        flagged = (flags & np.uint8(NO_ESTIMATE)).astype(bool)
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


def _noise_reach(setup: Setup, quantity: str, flow: Flow, end: float, sign: float,
                 end_volts: float, start: float, cap: float, volts: float,
                 actuation: Actuation | None = None) -> float:
    """How far (SI, from ``start`` doubling up to ``cap``) beyond a span's ``end`` in the
    direction ``sign`` the model's output moves by ``volts`` (V) from ``end_volts``; where the
    model cannot be solved, the reach reached so far."""
    reach = start
    while reach < cap:
        try:
            out = model_output(setup, quantity, np.array([end + sign * reach]), flow,
                               actuation)[0]
        except MagciliaError:
            return reach
        if abs(out - end_volts) >= volts:
            return reach
        reach = min(2.0 * reach, cap)
    return reach


def _edge_table(setup: Setup, quantity: str, flow: Flow, end: float, reach: float, points: int,
                end_volts: float, actuation: Actuation | None = None) -> InverseTable | None:
    """The model continued from a span's ``end`` (SI) by ``reach`` (signed, SI) over ``points``
    directly solved points, as a table whose output at ``end`` is ``end_volts`` (V, the span
    table's, so that no reading falls between the two); it ends where the output turns. None
    where the model cannot be solved there or its output does not change."""
    grid = end + np.linspace(0.0, reach, points)
    try:
        volts = model_output(setup, quantity, grid, flow, actuation)
        volts[0] = end_volts
        return InverseTable.build(grid, volts, f"{quantity} beyond {end:.6g}")
    except MagciliaError:
        return None


def _calibration_sigma(setup: Setup, quantity: str, flow: Flow, nodes: F64,
                       calibration: ParameterCovariance | Posterior | None,
                       actuation: Actuation | None = None) -> F64:
    """1-σ output uncertainty (V) from the calibration covariance at the table ``nodes``, or
    from the spread of the model's output over posterior samples."""
    params = setup.params()
    if isinstance(calibration, Posterior):
        return _posterior_sigma(setup, quantity, flow, nodes, calibration, actuation)
    names, cov = _parameter_covariance(calibration, params)
    if not names:
        return np.zeros(nodes.size)
    q = np.linspace(nodes[0], nodes[-1], 33)
    jac = np.empty((q.size, len(names)))
    for j, name in enumerate(names):  # outputs are linear in the offset: any step is exact
        h = 1.0 if name == "offset" else 1e-3 * max(abs(params[name]), math.sqrt(cov[j, j]))
        up = model_output(setup.replace(**{name: params[name] + h}), quantity, q, flow,
                          actuation)
        down = model_output(setup.replace(**{name: params[name] - h}), quantity, q, flow,
                            actuation)
        jac[:, j] = (up - down) / (2.0 * h)
    var = np.einsum("qi,ij,qj->q", jac, cov, jac)
    return np.interp(nodes, q, np.sqrt(np.clip(var, 0.0, None)))


def _posterior_sigma(setup: Setup, quantity: str, flow: Flow, nodes: F64,
                     posterior: Posterior, actuation: Actuation | None = None) -> F64:
    """1-σ output spread (V) at the table ``nodes`` over :data:`POSTERIOR_DRAWS` posterior samples
    (evenly thinned: deterministic) of the setup's continuous parameters; the others keep the
    setup's values."""
    params = setup.params()
    cols = [i for i, n in enumerate(posterior.names)
            if n in params and PARAMETERS[n].domain != "integer"]
    if not cols:
        raise v.fail("calibration", f"a posterior of {', '.join(posterior.names)}",
                     "a posterior of setup parameters (height, base_radius, x, y, z, offset)")
    q = np.linspace(nodes[0], nodes[-1], 33)
    draws = posterior.draws(POSTERIOR_DRAWS)[:, cols]
    names = [posterior.names[i] for i in cols]
    out = np.array([model_output(setup.replace(**dict(zip(names, map(float, d), strict=True))),
                                 quantity, q, flow, actuation) for d in draws])
    spread = out.std(axis=0, ddof=1) if len(out) > 1 else np.zeros(q.size)
    return np.interp(nodes, q, spread)


def _parameter_covariance(cal: ParameterCovariance | None,
                          params: dict[str, float]) -> tuple[list[str], F64]:
    """Names of the continuous setup parameters with a finite covariance, and that covariance
    (SI; :meth:`ParameterCovariance.matrix`)."""
    if cal is None:
        return [], np.zeros((0, 0))
    all_names = list(cal.correlation_names)
    full = cal.matrix()
    keep = [i for i, n in enumerate(all_names)
            if n in params and PARAMETERS[n].domain != "integer"
            and math.isfinite(full[i, i]) and full[i, i] > 0.0]
    sub = full[np.ix_(keep, keep)]
    return [all_names[i] for i in keep], np.where(np.isfinite(sub), sub, 0.0)


# -- readings under a known actuation (compensation) ---------------------------------------------

#: the sensing element in the board frame, m (the README's sensor frame: the origin)
ELEMENT = (0.0, 0.0, 0.0)


def direct_field(actuation: Actuation) -> F64:
    """The actuation's own field at the sensing element (the origin), T, shape (3,): what it adds
    to the reading whatever the cilium does."""
    b = np.asarray(actuation.field(np.array(ELEMENT)), dtype=np.float64)
    if not np.all(np.isfinite(b)):
        raise v.fail("actuation", "a field that is not finite at the sensing element",
                     "a source away from the element (the origin)")
    return b


def model_fields(setup: Setup, quantity: str, values: ArrayLike, flow: Flow | None,
                 actuation: Actuation) -> F64:
    """The total field at the element, T, shape (a, 3), for ``values`` (shape (a,), SI) of a
    measurand read while ``actuation`` acts: the cilium's field in the shape that the load and
    the actuation together bend it to (:func:`magcilia.bend_sweep` with ``actuation=``; a rigid
    tilt, ``"angle"``, is not bent by it) plus the actuation's :func:`direct_field`."""
    direct = direct_field(actuation)
    pose, azimuth = poses_at(setup, quantity, values, flow, actuation)
    return np.asarray(setup.field(pose, azimuth=azimuth) + direct, dtype=np.float64)


def model_output(setup: Setup, quantity: str, values: ArrayLike, flow: Flow | None = None,
                 actuation: Actuation | None = None) -> F64:
    """The model's sensor output (V), shape (a,), at ``values`` (shape (a,), SI) of a measurand:
    :func:`magcilia.mechanics.output_at` without an actuation (exactly), else
    ``sensor.voltage(B_x)`` of :func:`model_fields` (the actuation's bending and direct field
    included)."""
    if actuation is None:
        return output_at(setup, quantity, values, flow)
    return np.asarray(setup.sensor.voltage(
        model_fields(setup, quantity, values, flow, actuation)[:, 0]), dtype=np.float64)


def check_actuated(setup: Setup, fields: F64, actuation: Actuation) -> int:
    """:meth:`Sensor.check` of the total fields ``fields`` (a, 3), T, at the element under
    ``actuation``: raises where the element's magnetization may flip (FLIPPED_RISK anywhere) or
    where B_x is beyond the range over every value (the read-out would see nothing); returns the
    union of the flags (int) otherwise."""
    sensor = setup.sensor
    flags = sensor.check(fields)
    union = int(np.bitwise_or.reduce(flags)) if flags.size else 0
    direct = direct_field(actuation) / 1e-4
    what = "a direct field of (" + ", ".join(f"{c:.4g}" for c in direct) + ") G at the element"
    if union & SensorFlag.FLIPPED_RISK:
        peak = float(np.max(np.linalg.norm(fields, axis=-1))) / 1e-4
        raise v.fail("actuation", what, f"a field that keeps |B| at the element within the "
                     f"{sensor.name}'s {sensor.flip_field / 1e-4:.3g} G flip field (it reaches "
                     f"{peak:.4g} G): lower the field or its scale, or pulse set/reset and use a "
                     "sensor with a wider range")
    if np.all(flags & np.uint8(SensorFlag.BEYOND_RANGE)):
        bx = float(np.min(np.abs(fields[:, 0]))) / 1e-4
        raise v.fail("actuation", what, f"a field that keeps B_x within the {sensor.name}'s "
                     f"±{sensor.field_range / 1e-4:.3g} G range (|B_x| ≥ {bx:.4g} G over the "
                     "whole span): lower the field along x, buck it with the offset strap, or "
                     "use a sensor with a wider range")
    return union


def compensation_text(setup: Setup, actuation: Actuation, flags: int) -> str:
    """One line: the actuation compensated, its direct field at the element (gauss) and output
    (mV), and the sensor's flags under it."""
    b = direct_field(actuation)
    volts = setup.sensor.scale * b[0]
    text = (f"compensating {actuation.describe()}: direct field ("
            + ", ".join(f"{c / 1e-4:.4g}" for c in b)
            + f") G at the element ({volts * 1e3:+.4g} mV), its bending modelled")
    if flags:
        text += f"; sensor flags {flag_names(flags)}"
    return text
