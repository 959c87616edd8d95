"""The single-output read-out in one compiled pass: value, 1-σ parts and flags of each reading.

:meth:`magcilia.Readout.read` runs :func:`read_inside` (compiled by numba on first use, cached on
disk, as :mod:`magcilia.model.compiled`'s kernels) over all readings at once; it does, reading
by reading, exactly the arithmetic of the NumPy path (``Readout._read_block``), which stays the
reference (tests hold the two to 1e-12 relative: the kernel sums squares where NumPy calls
``hypot``, a difference of an ulp or two) and runs where numba is missing or
``magcilia.model.compiled.ENABLED`` is False. Readings beyond the table's output range (or NaN)
are only flagged here: the caller reads them by the NumPy path (:meth:`Readout._beyond`); they
are few.

Shape letters: ``b`` readings, ``t`` table nodes, ``c`` uniform output cells, ``k`` knots.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from magcilia.model import compiled as _model

if TYPE_CHECKING:
    from magcilia.device.sensor import Sensor
    from magcilia.readout.table import InverseTable

F64 = NDArray[np.float64]

#: the flag bits the kernel sets (those of :class:`magcilia.readout.protocol.Flag`)
_OUTSIDE, _FOLD, _SATURATED = 1, 2, 4


def _at(vq: float, q: F64, rate: F64, fp: F64) -> float:
    """``profile`` at ``vq`` (within [q[0], q[-1]]) on the table's nodes ``q`` (uniform steps
    but the last), linear, as ``Readout._at_estimates``."""
    n = q.size
    j = min(int((vq - q[0]) / (q[1] - q[0])), n - 1)
    if vq < q[j]:
        j -= 1
    if j + 1 < n and vq >= q[j + 1]:
        j += 1
    return (vq - q[j]) * rate[j] + fp[j]


def read_inside(x: F64, v0: float, v_end: float, cells_per_volt: float, cell_start: F64,
                cell_step: F64, cell_knot: NDArray[np.intp], knot_steps: int, volts: F64,
                slope: F64, slope_rate: F64, amb_lo: float, amb_hi: float, offset: float,
                scale: float, field_range: float, noise: float, tare_error: float, q: F64,
                cal: F64, cal_rate: F64, has_cal: bool, modulus: F64, modulus_rate: F64,
                scale_mode: int, relative: float, value: F64, sigma: F64, s_noise: F64,
                s_cal: F64, s_edge: F64, s_scale: F64, flags: NDArray[np.uint16]) -> int:
    """Read every reading ``x`` (V, (b,), tare applied) into the result arrays (b,) (numba
    source); returns how many lie outside [``v0``, ``v_end``] (or are NaN): those get only
    their OUTSIDE_SPAN and SATURATED flags, for the caller to read.

    ``amb_lo > amb_hi`` when the table has no ambiguous range. ``scale_mode``: 0 no force scale,
    1 exactly ``|value| · relative``, 2 the modulus's output σ (``modulus``, (t,)) through the
    slope. ``slope_rate``, ``cal_rate``, ``modulus_rate``: the profiles' slopes between nodes
    (a 0 appended), as ``readout.table._interp`` uses them.
    """
    n_cells = cell_start.size
    n_knots = volts.size
    q_lo, q_hi = q[0], q[q.size - 1]
    nan = math.nan
    outside = 0
    for r in range(x.size):
        xi = x[r]
        f = 0
        if not abs((xi - offset) / scale) <= field_range:
            f = _SATURATED
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
            s_scale[r] = nan
            continue
        u = (xi - v0) * cells_per_volt
        i = min(int(u), n_cells - 1)
        est = cell_step[i] * (u - i) + cell_start[i]
        j = cell_knot[i]
        for _ in range(knot_steps):
            if j + 1 < n_knots and xi >= volts[j + 1]:
                j += 1
        dq = abs((xi - volts[j]) * slope_rate[j] + slope[j])
        sn = dq * noise
        vq = min(max(est, q_lo), q_hi)
        if scale_mode == 0:
            ss = 0.0
        elif scale_mode == 1:
            ss = abs(est) * relative
        else:
            ss = _at(vq, q, modulus_rate, modulus) * dq
        if has_cal:
            sc = _at(vq, q, cal_rate, cal) * dq
            if tare_error:
                sc = math.sqrt(sc * sc + (dq * tare_error) ** 2)
            sg = math.sqrt(sn * sn + sc * sc)
        elif tare_error:
            sc = dq * tare_error
            sg = math.sqrt(sn * sn + sc * sc)
        else:
            sc = 0.0
            sg = sn
        if scale_mode:
            sg = math.sqrt(sg * sg + ss * ss)
        value[r] = est
        sigma[r] = sg
        s_noise[r] = sn
        s_cal[r] = sc
        s_edge[r] = 0.0
        s_scale[r] = ss
    return outside


def _rates(xp: F64, fp: F64) -> F64:
    """The slopes of ``fp`` over ``xp`` between nodes, a 0 appended (as ``table._interp``)."""
    return np.append(np.diff(fp) / np.diff(xp), 0.0)


def table_arguments(table: InverseTable, sensor: Sensor) -> tuple[Any, ...]:
    """The arguments of :func:`read_inside` from ``v0`` to ``field_range``."""
    amb = table.ambiguous if table.ambiguous is not None else (math.inf, -math.inf)
    return (float(table.volts[0]), float(table.volts[-1]), float(table.cells_per_volt),
            table.cell_start, table.cell_step, table.cell_knot, int(table.knot_steps),
            table.volts, table.slope, _rates(table.volts, table.slope), float(amb[0]),
            float(amb[1]), float(sensor.offset), float(sensor.scale), float(sensor.field_range))


def profile_arguments(q: F64, calibration: F64, modulus: F64, scale_mode: int,
                      relative: float) -> tuple[Any, ...]:
    """The arguments of :func:`read_inside` from ``q`` to ``relative``: the table's quantity
    nodes (t,), the calibration's and the modulus's output σ there (V, (t,)), how the force
    scale is read (see :func:`read_inside`) and the modulus's relative σ."""
    return (q, calibration, _rates(q, calibration), bool(calibration.any()), modulus,
            _rates(q, modulus), int(scale_mode), float(relative))


@cache
def _compile() -> Callable[..., int] | None:
    try:
        import numba
    except ImportError:
        return None
    def njit(fn: Callable[..., object]) -> Callable[..., object]:
        try:
            return numba.njit(fn, cache=True, error_model="numpy",
                              nogil=True)
        except RuntimeError:  # no writable cache folder
            return numba.njit(fn, cache=False, error_model="numpy",
                              nogil=True)

    read_inside.__globals__["_at"] = njit(_at)  # the kernel calls the compiled helper
    return njit(read_inside)  # type: ignore[return-value]


def kernel() -> Callable[..., int] | None:
    """The compiled :func:`read_inside`, or None where numba is missing or the compiled
    kernels are switched off (:data:`magcilia.model.compiled.ENABLED`)."""
    return _compile() if _model.ENABLED else None
