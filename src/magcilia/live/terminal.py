"""The terminal view of a live read-out (``magcilia live``), its plain-text and JSON-lines forms.

Three ways to watch a :class:`~magcilia.live.pipeline.LiveReadout`:

- :func:`run_terminal`: a full-screen view drawn with ``rich`` (part of magcilia's install)
  about 12 times a second: the value ± σ in display units (big), a sparkline of the last seconds,
  the flags, the state (running, taring, DISCONNECTED with the reason, failed), the counters, the
  tare, the recording, the latency and the last events. Keys: ``t`` tare, ``r`` start/stop
  recording, ``q`` (or Ctrl-C) quit. It needs only a terminal, so it works over SSH.
- :func:`run_lines`: one plain status line a second, for a pipe or a log file.
- :func:`stream_json_lines`: one JSON object per read-out sample, **in SI units**, for other
  programs.

What is drawn is a pure function of what the read-out reports (:func:`render`), so that it can be
tested without a terminal; :func:`run_terminal` only adds the loop, the keys and the screen.

The value shown is the mean of the good readings of the last ``window`` s (0.1 s); its ± is the
σ of *one* reading (the median of theirs): noise and calibration together, an upper bound for the
mean's, since the calibration's share does not average away.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import select
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError, require
from magcilia.device.parameters import MEASURANDS
from magcilia.live.history import COLUMNS, LiveSamples
from magcilia.live.pipeline import Event, Limits, LiveReadout, LiveStatus
from magcilia.readout.inverse import NO_ESTIMATE, ReadoutFlag

if TYPE_CHECKING:
    from rich.console import Console, RenderableType

F64 = NDArray[np.float64]

#: the sparkline's levels, lowest first
SPARKS = "▁▂▃▄▅▆▇█"
#: names of the flag bits as the view shows them
FLAG_NAMES = {ReadoutFlag.OUTSIDE_SPAN: "OUTSIDE SPAN", ReadoutFlag.FOLD: "FOLD",
              ReadoutFlag.SATURATED: "SATURATED", ReadoutFlag.EXTRAPOLATED: "EXTRAPOLATED",
              ReadoutFlag.CLIPPED: "CLIPPED"}
#: the key help line
KEYS = "t tare · r start/stop recording · q quit (Ctrl-C)"

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
    good = inside & (samples.flags & np.uint8(NO_ESTIMATE) == 0) & np.isfinite(samples.value)
    age = 0.0 if now is None else now - float(samples.published[-1])
    if not good.any():
        return Reading(math.nan, math.nan, 0, int(inside.sum()), window, age)
    return Reading(float(np.mean(samples.value[good])), float(np.median(samples.sigma[good])),
                   int(good.sum()), int(inside.sum()), window, age)


def flag_fractions(samples: LiveSamples) -> dict[str, float]:
    """Fraction of ``samples`` carrying each flag (by the names of :data:`FLAG_NAMES`; all 0
    without samples)."""
    n = len(samples)
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
    r = current(samples, window)
    shown, sigma = format_value(q.to_display(r.value), q.to_display(r.sigma))
    if shown == "—":
        return f"— {q.display} (no good reading)"
    return f"{shown} ± {sigma} {q.display}"


def summary_line(status: LiveStatus, samples: LiveSamples, limits: Limits,
                 window: float = 0.1) -> str:
    """One plain line: read-out time, the value ± σ, flags and the status (for pipes and
    logs)."""
    q = MEASURANDS[limits.quantity]
    t = f"{samples.time[-1]:8.2f} s" if len(samples) else "       — s"
    flags = flag_fractions(_last_seconds(samples, 1.0))
    bad = ", ".join(f"{name} {frac:.0%}" for name, frac in flags.items() if frac > 0)
    return (f"{t}  {q.label} {value_text(samples, window)}"
            f"{f'  [{bad}]' if bad else ''}  | {status.report()}")


def render(status: LiveStatus, samples: LiveSamples, limits: Limits,
           events: Sequence[Event] = (), *, recent: LiveSamples | None = None,
           window: float = 0.1, seconds: float = 10.0, width: int = 60,
           now: float | None = None, source: str = "", notice: str = "",
           keys: bool = True) -> RenderableType:
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
    """
    rich_text = require("rich.text", package="rich", extra="live", purpose="The terminal view")
    rich_console = require("rich.console", package="rich", extra="live",
                           purpose="The terminal view")
    rich_panel = require("rich.panel", package="rich", extra="live", purpose="The terminal view")
    Text = rich_text.Text  # type: ignore[attr-defined]
    q = MEASURANDS[limits.quantity]
    scale = q.display_factor
    lines: list[Any] = []

    # state
    state = Text()
    state.append(f" {status.state.upper()} ", style=_STATE_STYLE.get(status.state, "bold"))
    if status.message:
        style = "bold red" if status.state in ("disconnected", "failed") else "yellow"
        state.append(f"  {status.message}", style=style)
    lines.append(state)

    # value
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
    if len(samples):
        end = float(samples.time[-1]) + (0.0 if now is None else
                                         max(0.0, now - float(samples.published[-1])))
        good = np.where(samples.flags & np.uint8(NO_ESTIMATE) == 0, samples.value / scale, np.nan)
        line, lo, hi = sparkline(samples.time, good, end=end, seconds=seconds, width=width)
    else:
        line, lo, hi = " " * max(1, width), math.nan, math.nan
    spark = Text(f"last {seconds:g} s ", style="dim")
    spark.append(line, style="cyan")
    if math.isfinite(lo):
        spark.append(f"  {lo:.4g} … {hi:.4g} {q.display}", style="dim")
    lines.append(spark)

    # flags
    counted = recent if recent is not None else _last_seconds(samples, window)
    fractions = flag_fractions(counted)
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
    if status.tared:
        lines.append(Text(f"tare: correction {status.correction * 1e3:+.4f} mV · drift "
                          f"{status.drift * 1e6:+.3g} µV · noise {status.noise * 1e6:.3g} µV "
                          "per reading"))
    else:
        lines.append(Text("tare: not tared (press t with the cilium unloaded)", style="yellow"))
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
        lines.append(Text(f"keys: {KEYS}", style="reverse"))
    title = f"magcilia live · {q.label}" + (f" · {source}" if source else "")
    return rich_panel.Panel(rich_console.Group(*lines),  # type: ignore[attr-defined]
                            title=title, title_align="left")


def _last_seconds(samples: LiveSamples, seconds: float) -> LiveSamples:
    """The samples of ``samples`` within ``seconds`` of its newest."""
    if not len(samples):
        return samples
    keep = samples.time >= samples.time[-1] - seconds
    return LiveSamples(samples.quantity, samples.unit,
                       **{name: getattr(samples, name)[keep] for name in COLUMNS})


# -- the view: loop, keys, screen ----------------------------------------------------------------
@contextlib.contextmanager
def _keypresses(stream: IO[str] | None) -> Iterator[Callable[[float], str]]:
    """A function that waits up to ``t`` s for keys on ``stream`` and returns them ("" if none).

    While inside, a terminal ``stream`` is in cbreak mode (keys come at once, not echoed;
    Ctrl-C still interrupts); its settings are restored on the way out, whatever happens.
    Without a terminal (or on a system without termios) the function only sleeps.
    """

    def sleep(t: float) -> str:
        time.sleep(max(0.0, t))
        return ""

    try:
        import termios
        import tty

        fd = stream.fileno() if stream is not None else -1
        tty_ok = fd >= 0 and os.isatty(fd)
    except (ImportError, OSError, ValueError, AttributeError):
        tty_ok = False
    if not tty_ok:
        yield sleep
        return
    saved = termios.tcgetattr(fd)

    def wait(t: float) -> str:
        ready, _, _ = select.select([fd], [], [], max(0.0, t))
        if not ready:
            return ""
        data = os.read(fd, 64)
        if not data:  # end of file: stop asking, keep the pace
            time.sleep(max(0.0, t))
            return ""
        return data.decode(errors="ignore")

    try:
        tty.setcbreak(fd, termios.TCSANOW)
        yield wait
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)


def _toggle_recording(live: LiveReadout, record_dir: str | Path) -> str:
    """Start or stop recording; the line to show."""
    try:
        if live.status.recording:
            path = live.stop_recording()
            return f"recording saved: {path}" if path else "no recording was open"
        path = live.start_recording(directory=record_dir)
    except (MagciliaError, OSError) as exc:
        return f"recording failed: {exc}"
    return f"recording to {path} (r stops it)"


def run_terminal(live: LiveReadout, *, record_dir: str | Path = ".", refresh: float = 12.0,
                 seconds: float | None = None, console: Console | None = None,
                 keys: IO[str] | None = None, window: float = 0.1,
                 spark_seconds: float = 10.0,
                 stop: Callable[[], bool] | None = None) -> LiveStatus:
    """Show a started live read-out in the terminal until ``q``, Ctrl-C, ``seconds`` or
    ``stop``.

    Keys (read from ``keys`` when it is a terminal): ``t`` tare, ``r`` start/stop recording
    (into ``record_dir``), ``q`` quit. The terminal's settings are restored on the way out;
    the read-out keeps running (the caller stops it).

    Parameters
    ----------
    live : LiveReadout
        A started read-out.
    record_dir : str or Path
        Where recordings started with ``r`` go (made when needed).
    refresh : float
        Screen refreshes per second, Hz.
    seconds : float, optional
        Stop after this many seconds, s (default: until ``q`` or Ctrl-C).
    console : rich.console.Console, optional
        Where to draw (default: the terminal on stdout; the full screen when it is one).
    keys : file, optional
        Where keys come from (default ``sys.stdin``).
    window : float
        Seconds of good readings averaged into the value shown, s.
    spark_seconds : float
        Seconds the sparkline shows, s.
    stop : callable, optional
        Asked about ten times a second; the view ends when it returns True (a stop signal:
        the command's one way to end, like ``seconds``).

    Returns
    -------
    LiveStatus
        The read-out's status when the view ended.
    """
    rich_console = require("rich.console", package="rich", extra="live",
                           purpose="The terminal view")
    rich_live = require("rich.live", package="rich", extra="live", purpose="The terminal view")
    refresh = v.positive("refresh", refresh, "Hz", "frequency")
    if seconds is not None:
        seconds = v.positive("seconds", seconds, "s", "duration")
    con = console if console is not None else rich_console.Console()  # type: ignore[attr-defined]
    period = 1.0 / refresh
    start = time.monotonic()
    cursor = live.history.total
    limits, limits_at = live.limits(), start
    notice = ""

    def frame() -> RenderableType:
        nonlocal cursor, limits, limits_at
        now = time.monotonic()
        if now - limits_at > 1.0:
            limits, limits_at = live.limits(), now
        recent, cursor, _ = live.history.since(cursor)
        samples = live.history.last(spark_seconds, live.rate)
        return render(live.status, samples, limits, live.events[-3:], recent=recent,
                      window=window, seconds=spark_seconds, width=max(10, con.width - 40),
                      now=time.time(), source=live.source.name, notice=notice)

    display = rich_live.Live(  # type: ignore[attr-defined]
        frame(), console=con, screen=con.is_terminal, auto_refresh=False,
        redirect_stdout=False, redirect_stderr=False, transient=False)
    try:
        with _keypresses(keys if keys is not None else sys.stdin) as wait, display:
            done = False
            while not done:
                tick = time.monotonic()
                if (seconds is not None and tick - start >= seconds) or _asked(stop):
                    break
                display.update(frame(), refresh=True)
                deadline = tick + period
                while not done and (left := deadline - time.monotonic()) > 0 \
                        and not _asked(stop):
                    for key in wait(left).lower():
                        if key == "q":
                            done = True
                        elif key == "t":
                            live.tare()
                            notice = ("taring: keep the cilium unloaded for "
                                      f"{live.tare_seconds:g} s")
                        elif key == "r":
                            notice = _toggle_recording(live, record_dir)
    except KeyboardInterrupt:
        pass
    status = live.status
    if con.is_terminal:
        con.print(f"magcilia live: {status.report()}", highlight=False, soft_wrap=True)
    return status


def run_lines(live: LiveReadout, out: IO[str] | None = None, *, seconds: float | None = None,
              interval: float = 1.0, window: float = 0.1,
              stop: Callable[[], bool] | None = None) -> LiveStatus:
    """Print one plain status line every ``interval`` s (and each event as it happens) until
    ``seconds`` or ``stop`` (then a last one) or Ctrl-C: the view for a pipe or a log file.

    Parameters
    ----------
    live : LiveReadout
        A started read-out.
    out : file, optional
        Where the lines go (default ``sys.stdout``).
    seconds : float, optional
        Stop after this many seconds, s (default: until Ctrl-C).
    interval : float
        Seconds between lines, s.
    window : float
        Seconds of good readings averaged into the value shown, s.
    stop : callable, optional
        Asked about ten times a second; the view ends when it returns True (a stop signal:
        the command's one way to end, like ``seconds``).

    Returns
    -------
    LiveStatus
        The read-out's status at the end.
    """
    out = sys.stdout if out is None else out
    interval = v.positive("interval", interval, "s", "duration")
    if seconds is not None:
        seconds = v.positive("seconds", seconds, "s", "duration")
    start = time.monotonic()
    next_line = start + interval
    seen = 0
    limits = live.limits()
    try:
        while True:
            now = time.monotonic()
            end = (seconds is not None and now - start >= seconds) or _asked(stop)
            events = live.events
            lines = [f"event: {e.report()}" for e in events[seen:]]
            seen = len(events)
            if now >= next_line or end:
                next_line += interval * max(1, math.ceil((now - next_line) / interval))
                samples = live.history.last(1.0, live.rate)
                lines.append(summary_line(live.status, samples, limits, window))
            if lines:
                out.write("\n".join(lines) + "\n")
                out.flush()
            if end or not live.running:
                break
            time.sleep(max(0.001, min(0.1, next_line - time.monotonic())))
    except KeyboardInterrupt:
        pass
    except BrokenPipeError:
        _silence(out)
    return live.status


def _asked(stop: Callable[[], bool] | None) -> bool:
    """Whether the caller's ``stop`` asks the view to end."""
    return stop is not None and bool(stop())


def _number(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def stream_json_lines(live: LiveReadout, out: IO[str] | None = None, *,
                      seconds: float | None = None, every: int = 1,
                      stop: Callable[[], bool] | None = None) -> LiveStatus:
    """Write one JSON object per read-out sample (or per ``every``-th) to ``out``, in SI.

    Each sample is a line ``{"t": s since the read-out started, "value": SI or null,
    "sigma": SI or null, "flags": ReadoutFlag bits, "unit": "N", "raw_V": V}`` (``value`` and
    ``sigma`` are null where ``flags`` is not 0). Events (start, tare, disconnected,
    reconnected, recording) come as ``{"event": kind, "text": ..., "t": s}`` lines, samples the
    stream fell behind on as ``{"event": "lost", ...}`` and a failed read-out as
    ``{"event": "failed", ...}`` (the stream ends). Lines are flushed per batch; the stream ends
    at ``seconds``, at ``stop``, on Ctrl-C, or quietly when the reader goes away (a closed
    pipe, e.g. ``| head``).

    Parameters
    ----------
    live : LiveReadout
        A started read-out.
    out : file, optional
        Where the lines go (default ``sys.stdout``).
    seconds : float, optional
        Stop after this many seconds, s (default: until Ctrl-C or a closed pipe).
    every : int
        Write every ``every``-th sample (counted from the read-out's first).
    stop : callable, optional
        Asked about ten times a second; the view ends when it returns True (a stop signal:
        the command's one way to end, like ``seconds``).

    Returns
    -------
    LiveStatus
        The read-out's status at the end.
    """
    out = sys.stdout if out is None else out
    every = v.integer("every", every, 1)
    if seconds is not None:
        seconds = v.positive("seconds", seconds, "s", "duration")
    unit = live.readout.unit
    start = time.monotonic()
    cursor = 0  # every sample from the read-out's start (a replay may be ahead already)
    seen = 0
    try:
        while True:
            ended = not live.running  # what came before the end is written, then the stream ends
            lines: list[str] = []
            events = live.events
            lines.extend(json.dumps({"event": e.kind, "text": e.text, "t": round(e.time, 6)},
                                    ensure_ascii=False) for e in events[seen:])
            seen = len(events)
            samples, cursor, lost = live.history.since(cursor)
            if lost:
                lines.append(json.dumps({"event": "lost", "text": f"{lost} samples lost (this "
                                         "stream fell behind)", "t": None}))
            index = cursor - len(samples) + np.arange(len(samples))
            for k in np.nonzero(index % every == 0)[0]:
                lines.append(json.dumps({
                    "t": round(float(samples.time[k]), 6), "value": _number(samples.value[k]),
                    "sigma": _number(samples.sigma[k]), "flags": int(samples.flags[k]),
                    "unit": unit, "raw_V": _number(samples.raw[k])}))
            if not live.running and live.status.state == "failed":
                lines.append(json.dumps({"event": "failed", "text": live.status.message,
                                         "t": None}, ensure_ascii=False))
            if lines:
                out.write("\n".join(lines) + "\n")
                out.flush()
            if ended or (seconds is not None and time.monotonic() - start >= seconds) \
                    or _asked(stop):
                break
            left = 0.1 if seconds is None else min(0.1, start + seconds - time.monotonic())
            live.history.wait(cursor, max(left, 0.0))
    except KeyboardInterrupt:
        pass
    except BrokenPipeError:
        _silence(out)
    return live.status


def _silence(out: IO[str]) -> None:
    """Point a stream whose reader went away at /dev/null, so that flushing it at exit does
    not raise again (Python's advice for ``BrokenPipeError``)."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, out.fileno())
        os.close(devnull)
