"""The plain-text and JSON-lines forms of a live read-out (``magcilia live`` without a terminal,
``magcilia live --json-lines``): :func:`run_lines` prints one status line a second for a pipe or a
log file; :func:`stream_json_lines` writes one JSON object per read-out sample, **in SI units**,
for other programs.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
import time
from collections.abc import Callable
from typing import IO

import numpy as np

from magcilia import _validate as v
from magcilia._atomic import jsonable
from magcilia.live.pipeline import LiveReadout, LiveStatus
from magcilia.live.render import summary_line


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
    "sigma": SI or null, "flags": Flag bits, "unit": "N", "raw_V": V}`` (``value`` and
    ``sigma`` are null where ``flags`` is not 0). A 3-axis sensor's force vector is
    ``{"t", "value": [fx, fy], "sigma": [σx, σy], "flags": bits, "unit": "N"}``, an array's
    one ``[fx, fy]`` per cilium in the array's order (``"flags"``: one int per cilium); a
    component is null where the estimate has none (OUTSIDE_SPAN, UNDETERMINED, SATURATED).
    Events (start, tare, disconnected,
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
    unit = live.sensor.unit
    scalar = live.sensor.kind == "scalar"
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
                if scalar:
                    lines.append(json.dumps({
                        "t": round(float(samples.time[k]), 6),
                        "value": _number(samples.value[k]), "sigma": _number(samples.sigma[k]),
                        "flags": int(samples.flags[k]), "unit": unit,
                        "raw_V": _number(samples.raw[k])}))
                else:
                    lines.append(json.dumps({
                        "t": round(float(samples.time[k]), 6),
                        "value": jsonable(samples.value[k]), "sigma": jsonable(samples.sigma[k]),
                        "flags": np.asarray(samples.flags[k]).tolist(), "unit": unit}))
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

