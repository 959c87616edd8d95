"""What the terminal views of a live read-out show, as pure functions of what it reports: the
current value (:func:`current`), sparklines, big digits, the flags, one summary line and the whole
``rich`` view (:func:`render`), so that they can be tested without a terminal
(:mod:`magcilia.live.terminal` adds the loop, the keys and the screen). A 3-axis sensor's or an
array's view comes from :mod:`magcilia.live.render_vector`.

The value shown is the mean of the good readings of the last ``window`` s (0.1 s); its ± is the
σ of *one* reading (the median of theirs): noise and calibration together, an upper bound for the
mean's, since the calibration's share does not average away.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import require
from magcilia.device.parameters import MEASURANDS
from magcilia.live.history import COLUMNS, LiveSamples
from magcilia.live.render_vector import (
    current_vectors,
    trace_line,
    vector_fractions,
    vector_lines,
    view_flag_names,
)
from magcilia.live.status import Event, Limits, LiveStatus
from magcilia.readout.protocol import Flag

if TYPE_CHECKING:
    from rich.console import RenderableType

F64 = NDArray[np.float64]


#: the sparkline's levels, lowest first
SPARKS = "▁▂▃▄▅▆▇█"
#: names of the flag bits as the view shows them
FLAG_NAMES = view_flag_names(Flag.OUTSIDE_SPAN, Flag.FOLD, Flag.SATURATED, Flag.EXTRAPOLATED,
                             Flag.CLIPPED, Flag.TARE_UNDER_LOAD, Flag.ZERO_DRIFT,
                             Flag.TEMPERATURE_OUTSIDE, Flag.COIL_PULSE)
#: the key help line
KEYS = "t tare · r start/stop recording · q quit (Ctrl-C)"
#: the key help line of an array's view
ARRAY_KEYS = "t tare · r start/stop recording · n/p next/previous cilium · q quit (Ctrl-C)"

_STATE_STYLE = {"running": "bold green", "taring": "bold yellow", "starting": "bold yellow",
                "disconnected": "bold white on red", "failed": "bold white on red",
                "stopped": "bold"}

# a 3x5 pixel font drawn with half blocks on 3 rows: each glyph is 5 rows of pixels
_FONT = {
    "0": ("111", "101", "101", "101", "111"), "1": ("010", "110", "010", "010", "111"),
    "2": ("111", "001", "111", "100", "111"), "3": ("111", "001", "111", "001", "111"),
    "4": ("101", "101", "111", "001", "001"), "5": ("111", "100", "111", "001", "111"),
    "6": ("111", "100", "111", "101", "111"), "7": ("111", "001", "001", "001", "001"),
    "8": ("111", "101", "111", "101", "111"), "9": ("111", "101", "111", "001", "111"),
    "-": ("000", "000", "111", "000", "000"), "+": ("000", "010", "111", "010", "000"),
    ".": ("0", "0", "0", "0", "1"), " ": ("0", "0", "0", "0", "0"),
    "—": ("000", "000", "111", "000", "000"),
}
_HALF = {("0", "0"): " ", ("1", "0"): "▀", ("0", "1"): "▄", ("1", "1"): "█"}


# -- what is shown: pure functions --------------------------------------------------------------
@dataclass(frozen=True)
class Reading:
    """The current value of a live read-out as the views show it (immutable; SI).

    Attributes
    ----------
    value : float
        Mean of the good readings of the last ``window`` s, SI (NaN if none was good).
    sigma : float
        σ of one of those readings (their median σ), SI (NaN if none was good).
    count : int
        Good readings averaged.
    total : int
        Readings in the window.
    window : float
        The window, s.
    age : float
        Seconds since the newest reading was published (wall clock; NaN without readings).
    """

    value: float
    sigma: float
    count: int
    total: int
    window: float
    age: float


def current(samples: LiveSamples, window: float = 0.1, now: float | None = None) -> Reading:
    """The current value: mean of the good readings of the last ``window`` s of ``samples``.

    Parameters
    ----------
    samples : LiveSamples
        The newest output samples (at least the last ``window`` s).
    window : float
        Seconds averaged, s.
    now : float, optional
        Wall-clock time (:func:`time.time`), s, for the readings' age; default the newest
        reading's publication time.
    """
    if not len(samples):
        return Reading(math.nan, math.nan, 0, 0, window, math.nan)
    inside = samples.time >= samples.time[-1] - window
    good = inside & samples.good & np.isfinite(samples.value)
    age = 0.0 if now is None else now - float(samples.published[-1])
    if not good.any():
        return Reading(math.nan, math.nan, 0, int(inside.sum()), window, age)
    return Reading(float(np.mean(samples.value[good])), float(np.median(samples.sigma[good])),
                   int(good.sum()), int(inside.sum()), window, age)


def flag_fractions(samples: LiveSamples) -> dict[str, float]:
    """Fraction of ``samples`` carrying each flag (by the names of :data:`FLAG_NAMES`; all 0
    without samples)."""
    n = samples.flags.size  # every estimate: one per reading, or per cilium and reading
    return {name: float(np.count_nonzero(samples.flags & flag)) / n if n else 0.0
            for flag, name in FLAG_NAMES.items()}


def sparkline(time_s: F64, values: F64, *, end: float, seconds: float,
              width: int) -> tuple[str, float, float]:
    """A sparkline of ``values`` over the ``seconds`` up to ``end``: one character per time bin
    (the bin's mean), scaled from the lowest to the highest bin; a space where a bin has no
    finite value.

    Parameters
    ----------
    time_s, values : ndarray, shape (m,)
        Sample times (s) and values (any unit; NaN for none).
    end : float
        Time at the right edge, s.
    seconds : float
        Time span shown, s.
    width : int
        Characters (bins).

    Returns
    -------
    (str, float, float)
        The line and the lowest and highest bin means (NaN if no bin has a value).

    Examples
    --------
    >>> sparkline(np.array([0.5, 1.5, 2.5]), np.array([0.0, 1.0, np.nan]), end=4.0,
    ...           seconds=4.0, width=4)
    ('▁█  ', 0.0, 1.0)
    """
    width = max(1, int(width))
    t = np.asarray(time_s, dtype=np.float64)
    x = np.asarray(values, dtype=np.float64)
    idx = np.floor((t - (end - seconds)) / seconds * width)
    ok = np.isfinite(x) & np.isfinite(idx) & (idx >= 0) & (idx < width)
    bins = idx[ok].astype(np.int64)
    counts = np.bincount(bins, minlength=width)[:width]
    sums = np.bincount(bins, weights=x[ok], minlength=width)[:width]
    with np.errstate(invalid="ignore", divide="ignore"):
        means = np.where(counts > 0, sums / np.maximum(counts, 1), np.nan)
    if not np.isfinite(means).any():
        return " " * width, math.nan, math.nan
    lo, hi = float(np.nanmin(means)), float(np.nanmax(means))
    span = hi - lo
    if span <= 1e-12 * max(abs(lo), abs(hi), 1e-300):
        levels = np.full(width, len(SPARKS) // 2 - 1)
    else:
        levels = np.clip(np.rint((means - lo) / span * (len(SPARKS) - 1)), 0, len(SPARKS) - 1)
    chars = [SPARKS[int(k)] if np.isfinite(m) else " "
             for k, m in zip(np.nan_to_num(levels), means, strict=True)]
    return "".join(chars), lo, hi


def format_value(value: float, sigma: float) -> tuple[str, str]:
    """``value`` (signed) and ``sigma`` as text with the decimals that σ's two significant
    digits need (same unit for both; "—" for NaN).

    Examples
    --------
    >>> format_value(0.26348, 0.0061)
    ('+0.2635', '0.0061')
    """
    if not math.isfinite(value):
        return "—", "—"
    if math.isfinite(sigma) and sigma > 0:
        decimals = min(8, max(0, 1 - math.floor(math.log10(sigma))))
        return f"{value:+.{decimals}f}", f"{sigma:.{decimals}f}"
    return f"{value:+.4g}", "—"


def big_text(text: str) -> list[str]:
    """``text`` (digits, sign, point) in a font three lines high (other characters are left
    out)."""
    glyphs = [_FONT[c] for c in text if c in _FONT]
    rows = []
    for top, bottom in ((0, 1), (2, 3), (4, None)):
        row = []
        for g in glyphs:
            low = g[bottom] if bottom is not None else "0" * len(g[top])
            row.append("".join(_HALF[a, b] for a, b in zip(g[top], low, strict=True)))
        rows.append(" ".join(row))
    return rows


def value_text(samples: LiveSamples, window: float = 0.1) -> str:
    """The current value ± σ in display units, one line (e.g. ``+0.2635 ± 0.0061 mN``)."""
    q = MEASURANDS[samples.quantity]
    if samples.value.ndim > 1:  # force vectors: each cilium's |F| ± σ and its direction
        return _vectors_text(samples, window)
    r = current(samples, window)
    (shown, sigma), unit = _in_display(samples.quantity, r.value, r.sigma)
    if shown == "—":
        return f"— {q.display} (no good reading)"
    return f"{shown} ± {sigma} {unit}"


def _in_display(quantity: str, value: float, sigma: float) -> tuple[tuple[str, str], str]:
    """``value`` ± ``sigma`` (SI) as text in the display unit of their magnitude (µN for a
    µN-scale force: :func:`magcilia.report.units.unit_for`, the console's one rule)."""
    from magcilia.report.units import in_unit, output_units, unit_for

    size = max(abs(value), sigma if math.isfinite(sigma) else 0.0)
    unit = unit_for(output_units(), quantity, size if math.isfinite(size) else 0.0)
    return format_value(in_unit(value, unit, quantity), in_unit(sigma, unit, quantity)), unit


def _vectors_text(samples: LiveSamples, window: float) -> str:
    """The current force vector (one cilium) or the largest of an array's, one line."""
    q = MEASURANDS[samples.quantity]
    r = current_vectors(samples, window)
    if not np.isfinite(r.magnitude).any():
        return f"— {q.display} (no good reading)"
    k = int(np.nanargmax(r.magnitude))
    (shown, sigma), unit = _in_display(samples.quantity, float(r.magnitude[k]),
                                       float(r.sigma_magnitude[k]))
    toward = (f" toward {math.degrees(r.direction[k]):+.1f}°" if math.isfinite(r.direction[k])
              else " (direction —, near zero)")
    which = f" (largest of {r.magnitude.size} cilia: #{k})" if r.magnitude.size > 1 else ""
    return f"|F| {shown} ± {sigma} {unit}{toward}{which}"


def summary_line(status: LiveStatus, samples: LiveSamples, limits: Limits,
                 window: float = 0.1) -> str:
    """One plain line: read-out time, the value ± σ, flags and the status (for pipes and
    logs)."""
    q = MEASURANDS[limits.quantity]
    t = f"{samples.time[-1]:8.2f} s" if len(samples) else "       — s"
    flags = flag_fractions(_last_seconds(samples, 1.0))
    bad = ", ".join(f"{name} {frac:.0%}" for name, frac in flags.items() if frac > 0)
    label = f"{q.label} (dynamic)" if limits.mode else q.label
    return (f"{t}  {label} {value_text(samples, window)}"
            f"{f'  [{bad}]' if bad else ''}  | {status.report()}")


def render(status: LiveStatus, samples: LiveSamples, limits: Limits,
           events: Sequence[Event] = (), *, recent: LiveSamples | None = None,
           window: float = 0.1, seconds: float = 10.0, width: int = 60,
           now: float | None = None, source: str = "", notice: str = "",
           keys: bool = True, names: Sequence[str] = (), positions: F64 | None = None,
           chosen: int = 0) -> RenderableType:
    """What the terminal view shows, as a ``rich`` renderable (no terminal needed).

    Parameters
    ----------
    status : LiveStatus
        :attr:`LiveReadout.status`.
    samples : LiveSamples
        The last ``seconds`` of output (:meth:`History.last`): the value and the sparkline.
    limits : Limits
        :meth:`LiveReadout.limits`: the quantity, its unit and the range.
    events : sequence of Event
        The read-out's events (the last three are shown).
    recent : LiveSamples, optional
        The samples since the last refresh, whose flags are counted (default: the last
        ``window`` s of ``samples``).
    window : float
        Seconds of good readings averaged into the value shown, s.
    seconds : float
        Seconds the sparkline shows, s.
    width : int
        Characters of the sparkline.
    now : float, optional
        Wall-clock time (:func:`time.time`), s: the sparkline ends there (it scrolls on while no
        samples come) and a value older than 1 s is marked stale. Default: the newest sample's.
    source : str
        The source's name, for the title.
    notice : str
        A line about the last key pressed (e.g. where a recording went), or "".
    keys : bool
        Show the key help line.
    names, positions, chosen
        A force vector's or an array's view (:func:`~magcilia.live.render_vector.vector_lines`):
        the cilia, their bases on the board (C, 2), m, and the cilium whose trace is shown.
    """
    rich_text = require("rich.text", package="rich", extra="live", purpose="The terminal view")
    rich_console = require("rich.console", package="rich", extra="live",
                           purpose="The terminal view")
    rich_panel = require("rich.panel", package="rich", extra="live", purpose="The terminal view")
    Text = rich_text.Text  # type: ignore[attr-defined]
    q = MEASURANDS[limits.quantity]
    lines: list[Any] = []

    # state
    state = Text()
    state.append(f" {status.state.upper()} ", style=_STATE_STYLE.get(status.state, "bold"))
    if status.message:
        style = "bold red" if status.state in ("disconnected", "failed") else "yellow"
        state.append(f"  {status.message}", style=style)
    lines.append(state)

    if samples.kind != "scalar":
        lines.extend(vector_lines(samples, window=window, seconds=seconds, width=width, now=now,
                                  names=names, positions=positions, chosen=chosen,
                                  sparkline=sparkline, big_text=big_text))
    else:
        lines.extend(_scalar_lines(samples, q, window=window, seconds=seconds, width=width,
                                   now=now))

    # flags
    counted = recent if recent is not None else _last_seconds(samples, window)
    fractions = flag_fractions(counted) if counted.kind == "scalar" else \
        vector_fractions(counted)
    flags = Text("flags: ", style="bold")
    if not len(counted):
        flags.append("no new readings", style="dim")
    elif not any(fractions.values()):
        flags.append(f"all {len(counted)} readings good", style="green")
    else:
        flags.append("  ".join(f"{name} {frac:.0%}" for name, frac in fractions.items()
                               if frac > 0), style="bold red")
        flags.append(f"  (of {len(counted)} readings)", style="dim")
    lines.append(flags)

    # counters, tare, recording, latency, range
    c = status.counters
    lines.append(Text(f"samples: {c.samples} delivered · {c.dropped} dropped ({status.overruns} "
                      f"by overruns) · {c.corrupt} corrupt · {status.samples} readings at "
                      f"{status.rate:g} Hz", style="red" if c.dropped or c.corrupt else ""))
    if c.unverified:
        lines.append(Text(status.unverified_text, style="yellow"))
    if status.tared and np.ndim(status.correction):
        lines.append(Text(f"tare: {np.size(status.correction)} channels · largest correction "
                          f"{np.max(np.abs(status.correction)) * 1e4:.4g} G · largest drift "
                          f"{np.max(np.abs(status.drift)) * 1e7:.3g} mG · noise up to "
                          f"{np.max(status.noise) * 1e7:.3g} mG per reading"))
    elif status.tared:
        lines.append(Text(f"tare: correction {status.correction * 1e3:+.4f} mV · drift "
                          f"{status.drift * 1e6:+.3g} µV · noise {status.noise * 1e6:.3g} µV "
                          "per reading"))
    else:
        lines.append(Text("tare: not tared (press t with the cilium unloaded)", style="yellow"))
    if status.recalibration:
        lines.append(Text(f"re-calibration: {status.recalibration}", style="cyan"))
    if status.temperature:
        lines.append(Text(f"temperature: {status.temperature}", style="bold red" if "OUTSIDE"
                          in status.temperature else ""))
    if status.recording:
        lines.append(Text(f"recording: {status.recording}", style="bold magenta"))
    else:
        lines.append(Text("recording: off", style="dim"))
    lat = (f"latency: median {status.latency_median * 1e3:.2g} ms · p99 "
           f"{status.latency_p99 * 1e3:.2g} ms" if math.isfinite(status.latency_median)
           else "latency: —")
    lines.append(Text(lat))
    lines.append(Text(limits.report(), style="dim"))

    # events, notice, keys
    lines.append(Text("events:", style="bold"))
    for e in list(events)[-3:]:
        style = "red" if e.kind == "disconnected" else ""
        lines.append(Text(f"  {e.report()}", style=style, overflow="ellipsis", no_wrap=True))
    if notice:
        lines.append(Text(notice, style="bold yellow"))
    if keys:
        help_line = ARRAY_KEYS if samples.kind == "array" else KEYS
        lines.append(Text(f"keys: {help_line}", style="reverse"))
    title = (f"magcilia live · {q.label}" + (" · dynamic read-out" if limits.mode else "")
             + (f" · {source}" if source else ""))
    return rich_panel.Panel(rich_console.Group(*lines),  # type: ignore[attr-defined]
                            title=title, title_align="left")


def _scalar_lines(samples: LiveSamples, q: Any, *, window: float, seconds: float, width: int,
                  now: float | None) -> list[Any]:
    """The value (big digits and a line) and the sparkline of a single-axis read-out."""
    from rich.text import Text

    scale = q.display_factor
    lines: list[Any] = []
    r = current(samples, window, now)
    stale = len(samples) > 0 and (now is not None and r.age > 1.0)
    shown, sigma = format_value(r.value / scale, r.sigma / scale)
    style = "dim" if stale else "bold cyan"
    for row in big_text(shown if shown != "—" else "—"):
        lines.append(Text(f"  {row}", style=style))
    value = Text(f"{q.label}: ", style="bold")
    if shown == "—":
        value.append(f"— {q.display}", style="bold")
        value.append("  no good reading in the last "
                     f"{window:g} s" if len(samples) else "  no readings yet", style="yellow")
    else:
        value.append(f"{shown} ± {sigma} {q.display}", style=style)
        value.append(f"  (mean of {r.count} readings over {window:g} s; ± σ of one reading)",
                     style="dim")
    if stale:
        value.append(f"  STALE: last reading {r.age:.1f} s ago", style="bold red")
    lines.append(value)

    # sparkline
    end = float(samples.time[-1]) + (0.0 if now is None else max(
        0.0, now - float(samples.published[-1]))) if len(samples) else 0.0
    good = np.where(samples.good, samples.value / scale, np.nan)
    lines.append(trace_line("", samples.time, good, end=end, seconds=seconds, width=width,
                            unit=q.display, sparkline=sparkline))
    return lines


def _last_seconds(samples: LiveSamples, seconds: float) -> LiveSamples:
    """The samples of ``samples`` within ``seconds`` of its newest."""
    if not len(samples):
        return samples
    keep = samples.time >= samples.time[-1] - seconds
    return LiveSamples(samples.quantity, samples.unit,
                       **{name: getattr(samples, name)[keep] for name in COLUMNS})


