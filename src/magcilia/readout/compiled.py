"""The single-output read-out in one compiled pass: value, 1-σ parts and flags of each reading.

:meth:`magcilia.Readout.read` runs :func:`read_pass` and :meth:`magcilia.Readout.estimate` runs
:func:`estimate_pass` (compiled by numba on first use, cached on disk, as every kernel:
:func:`magcilia._jit.compile_kernel`, here without bounds checks) over all readings at once, without
temporaries: the tare's correction is added, the flags set, the uniform output cell found by
arithmetic, the table interval of the slope by a guess (:attr:`InverseTable.cell_knot`) and forward
steps, and the profiles' node by a guess and one correction either way. They do, reading by reading,
exactly the arithmetic of the NumPy path (``Readout._read_block``, ``InverseTable.lookup``), which
stays the reference (tests hold the two to 1e-12 relative: the kernel sums squares where NumPy calls
``hypot``, a difference of an ulp or two) and runs where numba is missing or
``magcilia.model.compiled.ENABLED`` is False. Readings beyond the table's output range (or NaN) are
only flagged here: the caller reads them by the NumPy path (:meth:`Readout._beyond`); they are few.

The arrays a pass reads are packed once per read-out (:func:`pack`: a handful of arguments, so
that a live read-out's call of a few readings spends little in numba's dispatcher), and the
σ parts that a read-out never sets (no calibration or tare: ``sigma_calibration``; an angle:
``sigma_scale``; ``sigma_edge`` inside the span) come zeroed from the allocator and are written
only where a reading has no estimate (NaN), which saves a third of the memory traffic. The
force scale that is exactly ``|value| · σ_E/E`` (a tip force) is not written at all: the
result forms it from the value when asked (:meth:`magcilia.ReadoutResult.of`), the same numbers.
The arrays the pass does write share one fresh allocation (:func:`read_parts`).

Shape letters: ``b`` readings, ``t`` table nodes, ``c`` uniform output cells.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import TYPE_CHECKING, Any, NamedTuple, cast

import numpy as np
from numpy.typing import NDArray

from magcilia._jit import compile_kernel
from magcilia.model import compiled as _model

if TYPE_CHECKING:
    from magcilia.device.sensor import Sensor
    from magcilia.readout.table import InverseTable

F64 = NDArray[np.float64]

#: the flag bits the kernel sets (those of :class:`magcilia.readout.protocol.Flag`)
_OUTSIDE, _FOLD, _SATURATED = 1, 2, 4

#: the readings from which :func:`read_parts` allocates the arrays the pass writes as one block
#: (a live read-out's few readings take an array each: a view costs more than a small array)
ONE_BLOCK = 1 << 14
#: the force scale's array that :func:`read_pass` never writes (``scale_mode`` 1)
_NOTHING = np.empty(0)
#: the entries of :attr:`Packed.consts`, in order
CONSTS = ("v0", "v_end", "cells_per_volt", "amb_lo", "amb_hi", "sat_lo", "sat_hi",
          "knot_steps", "q0", "q_end", "nodes_per_unit", "scale_mode", "relative", "has_cal")
#: where :attr:`Packed.consts` holds whether the read-out has a calibration σ, and how it reads
#: the force scale
HAS_CAL, SCALE_MODE = CONSTS.index("has_cal"), CONSTS.index("scale_mode")
#: columns of :attr:`Packed.cells`: the cell's line, then its table interval's slope line and
#: the next interval's (output at the start, dquantity/dV there, its slope)
CELL_COLUMNS = ("start", "step", "volts", "slope", "rate", "next_volts", "next_slope",
                "next_rate")


class Packed(NamedTuple):
    """What :func:`read_pass` and :func:`estimate_pass` read of a read-out, packed (read-only).

    Attributes
    ----------
    cells : ndarray, shape (c, 8)
        Per uniform output cell, the :data:`CELL_COLUMNS`: the quantity at its start and its
        change over the cell, and the slope's lines (``InverseTable.slope``, linear in output
        between table nodes) of the table interval at or below its readings
        (:attr:`InverseTable.cell_knot`) and of the next one: 64 bytes, one cache line, hold
        all that a reading of the cell needs where at most one node lies between the interval
        and the reading (``knot_steps`` ≤ 1, the rule).
    cell_knot : ndarray of intp, shape (c,)
        :attr:`InverseTable.cell_knot` (for a table with ``knot_steps`` > 1).
    knots : ndarray, shape (t + 1, 3)
        Per table node (increasing output): the output (V; +inf appended), dquantity/dV and its
        slope to the next node (0 at the last).
    nodes : ndarray, shape (t + 1, 5)
        Per quantity node (increasing, uniform steps but the last): the quantity (+inf
        appended), the calibration's output σ (V) and its slope, the modulus's output σ (V) and
        its slope (0 at the last).
    consts : ndarray, shape (len(CONSTS),)
        The numbers :data:`CONSTS` names (``amb_lo > amb_hi`` without an ambiguous range;
        ``sat_lo``, ``sat_hi``: the outputs (V) within which the sensor is not saturated, exactly
        as :meth:`~magcilia.Sensor.in_range` decides it, see :func:`linear_outputs`;
        ``scale_mode`` 0 no force scale, 1 exactly ``|value| · relative``, 2 the modulus's
        output σ through the slope).
    """

    cells: F64
    cell_knot: NDArray[np.intp]
    knots: F64
    nodes: F64
    consts: F64


def _rates(xp: F64, fp: F64) -> F64:
    """The slopes of ``fp`` over ``xp`` between nodes, a 0 appended (as ``table._interp``)."""
    return np.append(np.diff(fp) / np.diff(xp), 0.0)


def linear_outputs(offset: float, scale: float, field_range: float) -> tuple[float, float]:
    """The outputs ``lo``, ``hi`` (V) such that ``lo <= x <= hi`` exactly where
    ``abs((x - offset) / scale) <= field_range`` in floating point (the read-out's saturation
    test, :meth:`magcilia.Sensor.in_range` of :meth:`~magcilia.Sensor.field`), found from the
    real-number bounds by a few steps of one ulp: the test is monotone in ``x`` on each side of
    the offset, so the outputs it passes are one interval; a comparison replaces a division."""

    def linear(x: float) -> bool:
        return abs((x - offset) / scale) <= field_range

    if not linear(offset):  # (a NaN parameter: nothing passes)
        return math.inf, -math.inf
    bounds = []
    for sign in (-1.0, 1.0):
        x = offset + sign * field_range * abs(scale)
        out = sign * math.inf
        if linear(x):  # step out while the next still passes
            while math.isfinite(x) and linear(nxt := math.nextafter(x, out)):
                x = nxt
        else:
            while not linear(x):
                x = math.nextafter(x, -out)
        bounds.append(x)
    return bounds[0], bounds[1]


def pack(table: InverseTable, sensor: Sensor, q: F64, calibration: F64, modulus: F64,
         scale_mode: int, relative: float) -> Packed:
    """The :class:`Packed` arguments of a read-out: its ``table``, ``sensor``, the table's
    quantity nodes ``q`` (t,), the calibration's and the modulus's output σ there (V, (t,)),
    how the force scale is read (see :class:`Packed`) and the modulus's relative σ."""
    amb = table.ambiguous if table.ambiguous is not None else (math.inf, -math.inf)
    knots = np.stack([np.append(table.volts, math.inf), np.append(table.slope, 0.0),
                      np.append(_rates(table.volts, table.slope), 0.0)], axis=1)
    j = table.cell_knot
    cells = np.concatenate([table.cell_start[:, None], table.cell_step[:, None], knots[j],
                            knots[j + 1]], axis=1)
    nodes = np.stack([np.append(q, math.inf), np.append(calibration, 0.0),
                      np.append(_rates(q, calibration), 0.0), np.append(modulus, 0.0),
                      np.append(_rates(q, modulus), 0.0)], axis=1)
    consts = np.array([table.volts[0], table.volts[-1], table.cells_per_volt, amb[0], amb[1],
                       *linear_outputs(sensor.offset, sensor.scale, sensor.field_range),
                       table.knot_steps, q[0], q[-1], 1.0 / (q[1] - q[0]), scale_mode,
                       relative, float(bool(calibration.any()))], dtype=np.float64)
    cell_knot = np.ascontiguousarray(j, dtype=np.intp)
    for a in (cells, cell_knot, knots, nodes, consts):
        a.setflags(write=False)
    return Packed(cells, cell_knot, knots, nodes, consts)


def _at(vq: float, nodes: F64, column: int, n: int, per_unit: float) -> float:
    """The profile in ``nodes[:, column]`` (slopes in ``column + 1``) at ``vq`` (within the
    nodes' range), linear: a guess of the node and one step back or forward, as
    ``Readout._at_estimates``."""
    j = min(int((vq - nodes[0, 0]) * per_unit), n - 1)
    if vq < nodes[j, 0]:
        j -= 1
    if vq >= nodes[j + 1, 0]:  # (the appended +inf ends it)
        j += 1
    return (vq - nodes[j, 0]) * nodes[j, column + 1] + nodes[j, column]


def read_pass(x: F64, correction: float, noise: float, tare_error: float, cells: F64,
              cell_knot: NDArray[np.intp], knots: F64, nodes: F64, consts: F64, value: F64,
              sigma: F64, s_noise: F64, s_cal: F64, s_edge: F64, s_scale: F64,
              flags: NDArray[np.uint16]) -> int:
    """Read every reading ``x`` (V, (b,)) plus ``correction`` (V, the tare's) into the result
    arrays (b,) (numba source); returns how many lie outside the table's output range (or are
    NaN): those get only their OUTSIDE_SPAN and SATURATED flags, for the caller to read.

    ``noise``: the output noise RMS of a reading (V); ``tare_error``: the tare's standard error
    (V, 0 without one). ``s_edge`` is expected zeroed and, without a calibration or a tare,
    ``s_cal``, without a force scale ``s_scale``: they are then written only where a reading
    has no estimate. Where the force scale is exactly ``|value| · relative`` (``scale_mode``
    1) ``s_scale`` is never written (it may have no elements): the caller forms it from
    ``value`` (:meth:`magcilia.ReadoutResult.of`). ``cells`` … ``consts``: :func:`pack`.
    """
    v0, v_end, per_volt = consts[0], consts[1], consts[2]
    amb_lo, amb_hi, sat_lo, sat_hi = consts[3], consts[4], consts[5], consts[6]
    knot_steps = int(consts[7])
    q_lo, q_hi, per_unit = consts[8], consts[9], consts[10]
    scale_mode = int(consts[11])
    relative = consts[12]
    has_cal = consts[13] != 0.0
    write_cal = has_cal or tare_error != 0.0
    last_cell = cells.shape[0] - 1
    n_nodes = nodes.shape[0] - 1
    nan = math.nan
    outside = 0
    for r in range(x.size):
        xi = x[r] + correction
        f = 0 if xi >= sat_lo and xi <= sat_hi else _SATURATED
        if not (xi >= v0 and xi <= v_end):
            flags[r] = f | _OUTSIDE
            outside += 1
            continue
        if xi >= amb_lo and xi <= amb_hi:
            f |= _FOLD
        flags[r] = f
        if f:  # FOLD or SATURATED: no estimate
            value[r] = nan
            sigma[r] = nan
            s_noise[r] = nan
            s_cal[r] = nan
            s_edge[r] = nan
            if scale_mode != 1:
                s_scale[r] = nan
            continue
        u = (xi - v0) * per_volt
        i = min(int(u), last_cell)
        est = cells[i, 1] * (u - i) + cells[i, 0]
        if knot_steps <= 1:  # the interval's slope line or the next one's, in the cell's line
            lo = (xi - cells[i, 2]) * cells[i, 4] + cells[i, 3]  # (both, then a select: no
            hi = (xi - cells[i, 5]) * cells[i, 7] + cells[i, 6]  # branch for random readings
            dq = abs(hi if xi >= cells[i, 5] else lo)  # to mispredict, no load to wait on)
        else:
            j = cell_knot[i]
            for _ in range(knot_steps):
                if xi >= knots[j + 1, 0]:
                    j += 1
            dq = abs((xi - knots[j, 0]) * knots[j, 2] + knots[j, 1])
        sn = dq * noise
        sg = sn
        if write_cal:
            if has_cal:
                sc = _at(min(max(est, q_lo), q_hi), nodes, 1, n_nodes, per_unit) * dq
                if tare_error != 0.0:
                    sc = math.sqrt(sc * sc + (dq * tare_error) ** 2)
            else:
                sc = dq * tare_error
            sg = math.sqrt(sn * sn + sc * sc)
            s_cal[r] = sc
        if scale_mode != 0:
            if scale_mode == 1:
                ss = abs(est) * relative
            else:
                ss = _at(min(max(est, q_lo), q_hi), nodes, 3, n_nodes, per_unit) * dq
            sg = math.sqrt(sg * sg + ss * ss)
            if scale_mode == 2:  # (exactly |value| · relative otherwise: the caller's to form)
                s_scale[r] = ss
        value[r] = est
        sigma[r] = sg
        s_noise[r] = sn
    return outside


def estimate_pass(x: F64, correction: float, cells: F64, consts: F64, value: F64) -> int:
    """The estimate of every reading ``x`` (V, (b,)) plus ``correction`` (V) into ``value``
    (b,) (numba source), as ``InverseTable.lookup``; returns how many lie outside the table's
    output range (or are NaN): their values are the end cells' lines (or NaN), for the caller
    to replace."""
    v0, v_end, per_volt = consts[0], consts[1], consts[2]
    last = cells.shape[0] - 1
    outside = 0
    for r in range(x.size):
        xi = x[r] + correction
        inside = xi >= v0 and xi <= v_end
        outside += not inside
        xc = xi if inside else v0  # (any cell: the caller replaces the value)
        u = (xc - v0) * per_volt
        i = min(int(u), last)
        est = cells[i, 1] * (u - i) + cells[i, 0]
        value[r] = est if inside else xi
    return outside


def read_parts(read: Callable[..., int], packed: Packed, x: F64, correction: float,
               noise: float, tare_error: float, beyond: Callable[..., None]
               ) -> tuple[NDArray[Any] | None, ...]:
    """:meth:`magcilia.Readout.read`'s arrays (b,) of readings ``x`` (V, (b,)) by the compiled
    ``read`` (:func:`read_pass`): value, sigma, sigma_noise, sigma_calibration, sigma_edge,
    sigma_scale, flags, with None for sigma_scale where it is exactly ``|value| · relative``
    (for :meth:`magcilia.ReadoutResult.of` to form when asked). The arrays the pass writes
    share one allocation (a fresh one each, one pass of page faults rather than one an array:
    it halves the time of a call of 1e6 readings), the parts written only where a reading has
    no estimate come zeroed (``np.zeros``: untouched pages cost nothing); the readings beyond
    the table are read by ``beyond(readings + correction, noise, *arrays)``
    (``Readout._read_block``, the NumPy path, into arrays of their length)."""
    n = x.size
    scale_mode = int(packed.consts[SCALE_MODE])
    write_cal = bool(packed.consts[HAS_CAL] or tare_error)
    parts: list[NDArray[Any]]
    if n >= ONE_BLOCK:
        written = 3 + write_cal + (scale_mode == 2)
        block = np.empty(n * (8 * written + 2), np.uint8)
        floats = iter(block[: 8 * n * written].view(np.float64).reshape(written, n))
        parts = [next(floats), next(floats), next(floats),
                 next(floats) if write_cal else np.zeros(n), np.zeros(n),
                 next(floats) if scale_mode == 2 else _NOTHING if scale_mode else np.zeros(n),
                 block[8 * n * written:].view(np.uint16)]
    else:  # (a live read-out's few readings: views cost more than small arrays)
        parts = [np.empty(n), np.empty(n), np.empty(n),
                 np.empty(n) if write_cal else np.zeros(n), np.zeros(n),
                 np.empty(n) if scale_mode == 2 else _NOTHING if scale_mode else np.zeros(n),
                 np.empty(n, np.uint16)]  # (_NOTHING: never written, formed from the value)
    if read(x, correction, noise, tare_error, *packed, *parts):
        out = np.flatnonzero(parts[-1] & np.uint16(_OUTSIDE))
        got = tuple(np.empty(out.size, p.dtype) for p in parts)
        beyond(x[out] + correction, noise, *got)
        for whole, got_part in zip(parts, got, strict=True):
            if whole.size:
                whole[out] = got_part
    return (*parts[:5], None if scale_mode == 1 else parts[5], parts[6])


def remembered(memo: dict[Any, float], key: Any, compute: Callable[..., float]) -> float:
    """``compute(*key)``, remembered in ``memo`` (at most 16 keys; a key that cannot be one, a
    list, is computed every time)."""
    try:
        return memo[key]
    except (KeyError, TypeError):
        value = compute(*key)
        if isinstance(key, tuple) and len(memo) < 16:
            memo[key] = value
        return value


@cache
def _compile() -> tuple[Callable[..., int], Callable[..., int]] | None:
    at = compile_kernel(_at, boundscheck=False)  # the compiled helper read_pass calls
    read = compile_kernel(read_pass, calls=(at,), boundscheck=False)
    estimate = compile_kernel(estimate_pass, boundscheck=False)
    if read is None or estimate is None:  # numba cannot be imported
        return None
    return cast("Callable[..., int]", read), cast("Callable[..., int]", estimate)


def kernels() -> tuple[Callable[..., int], Callable[..., int]] | None:
    """The compiled :func:`read_pass` and :func:`estimate_pass`, or None where numba is missing
    or the compiled kernels are switched off (:data:`magcilia.model.compiled.ENABLED`)."""
    return _compile() if _model.ENABLED else None
