"""The terminal view of a live read-out (``magcilia live``), its plain-text and JSON-lines forms.

Three ways to watch a :class:`~magcilia.live.pipeline.LiveReadout`:

- :func:`run_terminal`: a full-screen view drawn with ``rich`` (part of magcilia's install)
  about 12 times a second: the value ± σ in display units (big), a sparkline of the last seconds,
  the flags, the state (running, taring, DISCONNECTED with the reason, failed), the counters, the
  tare, the recording, the latency and the last events. Keys: ``t`` tare, ``r`` start/stop
  recording, ``q`` (or Ctrl-C) quit. It needs only a terminal, so it works over SSH.
- :func:`run_lines`: one plain status line a second, for a pipe or a log file
  (:mod:`magcilia.live.streams`).
- :func:`stream_json_lines`: one JSON object per read-out sample, **in SI units**, for other
  programs (:mod:`magcilia.live.streams`).

A 3-axis sensor's view shows the force's magnitude and direction, each component with its σ and
a sparkline of each; an array's a map of its cilia (magnitude and an arrow each, at their places
on the board) and a chosen cilium's value and traces (keys ``n``/``p``).

What is drawn is a pure function of what the read-out reports (:func:`render`, in
:mod:`magcilia.live.render`), so that it can be tested without a terminal; :func:`run_terminal`
only adds the loop, the keys and the screen.
"""

from __future__ import annotations

import contextlib
import os
import select
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, TYPE_CHECKING

from magcilia import _validate as v
from magcilia._errors import MagciliaError, require
from magcilia.live.pipeline import LiveReadout, LiveStatus
from magcilia.live.render import (
    FLAG_NAMES,
    KEYS,
    SPARKS,
    Reading,
    big_text,
    current,
    flag_fractions,
    format_value,
    render,
    sparkline,
    summary_line,
    value_text,
)
from magcilia.live.streams import _asked, run_lines, stream_json_lines

if TYPE_CHECKING:
    from rich.console import Console, RenderableType

__all__ = ["FLAG_NAMES", "KEYS", "SPARKS", "Reading", "big_text", "current", "flag_fractions",
           "format_value", "render", "run_lines", "run_terminal", "sparkline",
           "stream_json_lines", "summary_line", "value_text"]


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
    (into ``record_dir``), ``n``/``p`` the next/previous cilium of an array, ``q`` quit. The
    terminal's settings are restored on the way out; the read-out keeps running (the caller
    stops it).

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
    chosen = 0
    cilia = max(1, len(live.sensor.names))

    def frame() -> RenderableType:
        nonlocal cursor, limits, limits_at
        now = time.monotonic()
        if now - limits_at > 1.0:
            limits, limits_at = live.limits(), now
        recent, cursor, _ = live.history.since(cursor)
        samples = live.history.last(spark_seconds, live.rate)
        return render(live.status, samples, limits, live.events[-3:], recent=recent,
                      window=window, seconds=spark_seconds, width=max(10, con.width - 40),
                      now=time.time(), source=live.source.name, notice=notice,
                      names=live.sensor.names, positions=live.sensor.positions, chosen=chosen)

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
                        elif key in "np" and cilia > 1:  # an array: the cilium traced
                            chosen = (chosen + (1 if key == "n" else -1)) % cilia
                            notice = f"cilium {live.sensor.names[chosen]}"
    except KeyboardInterrupt:
        pass
    status = live.status
    if con.is_terminal:
        con.print(f"magcilia live: {status.report()}", highlight=False, soft_wrap=True)
    return status


