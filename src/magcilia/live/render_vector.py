"""The terminal view of force vectors: a 3-axis sensor's (magnitude, direction, each component
with its σ, a sparkline of each) and an array's (a map of the cilia at their places on the board,
each with its magnitude and an arrow, and a chosen cilium's value and trace). Pure functions of
the samples (:func:`current_vectors`, :func:`vector_lines`), drawn by
:func:`magcilia.live.render.render`.

σ of the magnitude and of the direction follow from the components' σ to first order, the two
taken as independent: ``σ|F| = √((Fx σx)² + (Fy σy)²) / |F|``, ``σφ = √((Fy σx)² + (Fx σy)²) /
|F|²``; a vector within 3 σ of zero (NEAR_ZERO) has no direction.

Shape letters: ``m`` samples, ``C`` cilia (1 for a 3-axis sensor).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia.device.parameters import MEASURANDS
from magcilia.live.history import LiveSamples
from magcilia.readout.protocol import FLAG_DTYPE, Flag

F64 = NDArray[np.float64]

#: arrows for eight directions, counter-clockwise from +x
ARROWS = "→↗↑↖←↙↓↘"


def view_flag_names(*flags: Flag) -> dict[Flag, str]:
    """The names the views show for ``flags``: each :class:`Flag`'s name with spaces
    (``TARE_UNDER_LOAD`` → ``TARE UNDER LOAD``), in the order given."""
    return {flag: str(flag.name).replace("_", " ") for flag in flags}


#: names of the flag bits a force vector's view shows (NEAR_ZERO is said by the direction's "—")
VECTOR_FLAG_NAMES = view_flag_names(Flag.OUTSIDE_SPAN, Flag.SATURATED, Flag.EXTRAPOLATED,
                                    Flag.ABOVE_SPAN, Flag.AMBIGUOUS, Flag.UNDETERMINED,
                                    Flag.NOT_CONVERGED, Flag.MISSING, Flag.TARE_UNDER_LOAD,
                                    Flag.ZERO_DRIFT)
#: a direction within this many σ of the magnitude from zero is undefined (as the read-outs')
NEAR_ZERO_SIGMAS = 3.0


@dataclass(frozen=True, eq=False)
class VectorReading:
    """The current force vector(s) as the views show them (immutable; SI; shapes (C, ...)).

    Attributes
    ----------
    value, sigma : ndarray, shape (C, 2)
        Mean (Fx, Fy) of the good readings of the last ``window`` s and the σ of one reading
        (their median σ), N (NaN where none was good).
    magnitude, sigma_magnitude : ndarray, shape (C,)
        |F| of ``value`` and its σ, N.
    direction, sigma_direction : ndarray, shape (C,)
        atan2(Fy, Fx) and its σ, rad (NaN within 3 σ of zero).
    flags : ndarray of uint16, shape (C,)
        OR of the window's flags.
    count : ndarray of int, shape (C,)
        Good readings averaged.
    age : float
        Seconds since the newest reading was published (NaN without readings).
    """

    value: F64
    sigma: F64
    magnitude: F64
    sigma_magnitude: F64
    direction: F64
    sigma_direction: F64
    flags: NDArray[np.uint16]
    count: NDArray[np.int64]
    age: float


def current_vectors(samples: LiveSamples, window: float = 0.1,
                    now: float | None = None) -> VectorReading:
    """The current force vector of each cilium (one for a 3-axis sensor): the mean of the good
    readings of the last ``window`` s of ``samples`` (see :class:`VectorReading`)."""
    m = len(samples)
    value = samples.value.reshape(m, -1, 2)
    sigma = samples.sigma.reshape(value.shape)
    flags = samples.flags.reshape(m, -1)
    c_n = value.shape[1]
    if not m:
        nan = np.full(c_n, np.nan)
        return VectorReading(np.full((c_n, 2), np.nan), np.full((c_n, 2), np.nan), nan, nan,
                             nan, nan, np.zeros(c_n, FLAG_DTYPE), np.zeros(c_n, np.int64),
                             math.nan)
    inside = samples.time >= samples.time[-1] - window
    good = inside[:, None] & np.isfinite(value).all(axis=-1)
    count = good.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(good[..., None], value, 0.0).sum(axis=0) / count[:, None]
        med = np.nanmedian(np.where(good[..., None], sigma, np.nan), axis=0) if good.any() \
            else np.full((c_n, 2), np.nan)
    mean[count == 0] = np.nan
    fx, fy = mean[:, 0], mean[:, 1]
    sx, sy = med[:, 0], med[:, 1]
    mag = np.hypot(fx, fy)
    with np.errstate(invalid="ignore", divide="ignore"):
        s_mag = np.hypot(fx * sx, fy * sy) / mag
        s_dir = np.hypot(fy * sx, fx * sy) / mag**2
    near = ~(mag > NEAR_ZERO_SIGMAS * np.maximum(sx, sy))
    direction = np.where(near, np.nan, np.arctan2(fy, fx))
    s_mag = np.where(mag > 0, s_mag, np.maximum(sx, sy))
    age = 0.0 if now is None else now - float(samples.published[-1])
    flag_or = np.bitwise_or.reduce(np.where(inside[:, None], flags, 0).astype(FLAG_DTYPE),
                                   axis=0)
    return VectorReading(mean, med, mag, s_mag, direction, np.where(near, np.nan, s_dir),
                         flag_or, count.astype(np.int64), age)


def arrow(direction: float) -> str:
    """The arrow nearest ``direction`` (rad, counter-clockwise from +x); "·" for NaN."""
    if not math.isfinite(direction):
        return "·"
    return ARROWS[round(direction / (math.pi / 4.0)) % 8]


def flag_text(bits: int) -> str:
    """The names of the shown flag bits set in ``bits``, joined (e.g. ``ABOVE SPAN``)."""
    return " ".join(name for flag, name in VECTOR_FLAG_NAMES.items() if bits & flag)


def vector_fractions(samples: LiveSamples) -> dict[str, float]:
    """Fraction of the estimates of ``samples`` (every cilium's) carrying each flag of
    :data:`VECTOR_FLAG_NAMES` (all 0 without samples)."""
    n = samples.flags.size
    return {name: float(np.count_nonzero(samples.flags & FLAG_DTYPE(flag))) / n if n else 0.0
            for flag, name in VECTOR_FLAG_NAMES.items()}


def _degrees(direction: float, sigma: float) -> str:
    if not math.isfinite(direction):
        return "direction — (near zero)"
    s = f" ± {math.degrees(sigma):.2g}°" if math.isfinite(sigma) else ""
    return f"toward {math.degrees(direction):+.1f}°{s} {arrow(direction)}"


def grid_of(positions: F64) -> tuple[NDArray[np.intp], NDArray[np.intp], int, int]:
    """Rows (from the top: largest y) and columns (smallest x first) of cilia at ``positions``
    (C, 2), m, on a regular or irregular board: each distinct x (y) within 1 µm is a column
    (row). Returns (row of each, column of each, rows, columns)."""
    def rank(values: F64, reverse: bool) -> tuple[NDArray[np.intp], int]:
        keys = np.round(values / 1e-6)
        distinct = np.unique(keys)
        if reverse:
            distinct = distinct[::-1]
        index = {k: i for i, k in enumerate(distinct)}
        return np.array([index[k] for k in keys], dtype=np.intp), distinct.size

    cols, n_cols = rank(positions[:, 0], False)
    rows, n_rows = rank(positions[:, 1], True)
    return rows, cols, n_rows, n_cols


def trace_line(label: str, time_s: F64, values: F64, *, end: float, seconds: float, width: int,
               unit: str, sparkline: Any) -> Any:
    """One sparkline row as ``rich`` Text: ``label``, the line of ``values`` (display units,
    NaN for none) over the ``seconds`` up to ``end``, and its lowest and highest bin."""
    from rich.text import Text

    if time_s.size:
        line, lo, hi = sparkline(time_s, values, end=end, seconds=seconds, width=width)
    else:
        line, lo, hi = " " * max(1, width), math.nan, math.nan
    spark = Text(f"{label}last {seconds:g} s ", style="dim")
    spark.append(line, style="cyan")
    if math.isfinite(lo):
        spark.append(f"  {lo:.4g} … {hi:.4g} {unit}", style="dim")
    return spark


def vector_lines(samples: LiveSamples, *, window: float, seconds: float, width: int,
                 now: float | None, names: Sequence[str] = (), positions: F64 | None = None,
                 chosen: int = 0, sparkline: Any = None, big_text: Any = None) -> list[Any]:
    """The value lines of the terminal view of force vectors (``rich`` Text and Table objects).

    Parameters
    ----------
    samples : LiveSamples
        The last ``seconds`` of output, values (m, 2) or (m, C, 2).
    window, seconds, width, now
        As for :func:`magcilia.live.render.render`.
    names : sequence of str
        The cilia (an array).
    positions : ndarray, shape (C, 2), optional
        Their bases on the board, m (an array's map; default: one row).
    chosen : int
        The cilium whose value and trace are shown (an array).
    sparkline, big_text : callable
        :func:`magcilia.live.render.sparkline` and :func:`~magcilia.live.render.big_text` (none:
        no sparklines, no big digits).
    """
    from rich.table import Table
    from rich.text import Text

    q = MEASURANDS["force"]
    k = q.display_factor
    r = current_vectors(samples, window, now)
    stale = len(samples) > 0 and now is not None and r.age > 1.0
    style = "dim" if stale else "bold cyan"
    lines: list[Any] = []
    c_n = r.magnitude.size
    array = samples.value.ndim == 3
    if array:
        table = Table(show_header=False, box=None, padding=(0, 1), pad_edge=False)
        pos = positions if positions is not None and len(positions) == c_n else \
            np.stack([np.arange(c_n, dtype=np.float64), np.zeros(c_n)], axis=-1)
        rows, cols, n_rows, n_cols = grid_of(np.asarray(pos, dtype=np.float64))
        cells: list[list[Any]] = [[Text("") for _ in range(n_cols)] for _ in range(n_rows)]
        for c in range(c_n):
            label = names[c] if c < len(names) else f"c{c + 1}"
            mag = r.magnitude[c] / k
            bad = int(r.flags[c]) & ~int(Flag.NEAR_ZERO)
            cell = Text(f"{label} ", style="bold reverse" if c == chosen else "bold")
            cell.append(f"{mag:.4f}" if math.isfinite(mag) else "—",
                        style="bold red" if bad else style)
            cell.append(arrow(float(r.direction[c])), style=style)
            cells[rows[c]][cols[c]] = cell
        for row in cells:
            table.add_row(*row)
        lines.append(Text(f"|F| per cilium ({q.display}) and direction, at their places on the "
                          "board (+y up); red: flagged", style="dim"))
        lines.append(table)
    c = min(max(chosen, 0), c_n - 1) if array else 0
    label = (names[c] if c < len(names) else f"c{c + 1}") if array else ""
    mag, s_mag = r.magnitude[c] / k, r.sigma_magnitude[c] / k
    shown = f"{mag:.4f}" if math.isfinite(mag) else "—"
    if not array and big_text is not None:
        for row in big_text(shown):
            lines.append(Text(f"  {row}", style=style))
    value = Text(f"{'cilium ' + label + ' ' if array else ''}|F|: ", style="bold")
    if not math.isfinite(mag):
        value.append(f"— {q.display}", style="bold")
        value.append("  no good reading in the last " f"{window:g} s" if len(samples)
                     else "  no readings yet", style="yellow")
    else:
        value.append(f"{shown} ± {s_mag:.2g} {q.display}  ", style=style)
        value.append(_degrees(float(r.direction[c]), float(r.sigma_direction[c])), style=style)
        value.append(f"  (mean of {int(r.count[c])} readings over {window:g} s)", style="dim")
    if stale:
        value.append(f"  STALE: last reading {r.age:.1f} s ago", style="bold red")
    lines.append(value)
    comps = Text("   ")
    for axis in range(2):
        v_, s_ = r.value[c, axis] / k, r.sigma[c, axis] / k
        comps.append(f"F{'xy'[axis]} ", style="bold")
        comps.append(f"{v_:+.4f} ± {s_:.2g} {q.display}   " if math.isfinite(v_) else
                     f"— {q.display}   ", style=style)
    bad = int(r.flags[c]) & ~int(Flag.NEAR_ZERO)
    if bad:
        comps.append(flag_text(bad), style="bold red")
    lines.append(comps)
    if sparkline is not None:
        m = len(samples)
        end = (float(samples.time[-1]) + (0.0 if now is None else max(
            0.0, now - float(samples.published[-1])))) if m else 0.0
        series = samples.value.reshape(m, -1, 2)[:, c] / k
        for axis in range(2):
            lines.append(trace_line(f"F{'xy'[axis]} ", samples.time, series[:, axis], end=end,
                                    seconds=seconds, width=width, unit=q.display,
                                    sparkline=sparkline))
    return lines
