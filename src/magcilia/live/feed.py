"""What the dashboard feeds each browser (:class:`Dashboard`): what is measured (``/api/info``),
the status, the tare and record commands, and over the WebSocket one binary frame per tick of
what came since that browser's own cursor (:mod:`magcilia.live.frames`), plus the screen
latencies the browsers' acknowledgements measure. The ASGI app and its server are
:mod:`magcilia.live.dashboard`.

A single-axis read-out's frames carry the value, its σ and the raw output (version 1); a 3-axis
sensor's and an array's carry every force vector's Fx, Fy, their σ and flags (version 2), and its
info the cilia's names and places on the board (mm) for the page's polar view and map.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import itertools
import json
import math
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.device.parameters import MEASURANDS
from magcilia.live.frames import (
    FRAME_COLUMNS,
    FRAME_HEADER,
    MAX_POINTS,
    VECTOR_COLUMNS,
    VECTOR_HEADER,
    decimate,
    display_factor,
    encode_frame,
)
from magcilia.live.pipeline import LiveReadout

if TYPE_CHECKING:
    from starlette.websockets import WebSocket

F64 = NDArray[np.float64]

#: seconds between status messages to each browser
STATUS_PERIOD = 0.25
#: screen latencies kept
LATENCIES = 1000
#: what ``POST /api/record`` can be asked to do
RECORD_ACTIONS = ("start", "stop", "toggle")


def _jsonable(obj: Any) -> Any:
    """``obj`` with non-finite floats as None and numpy scalars as Python ones (for JSON)."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(x) for k, x in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(x) for x in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if obj is None or isinstance(obj, bool | int | float | str):
        return obj
    return str(obj)


class _Client:
    """One browser's cursor and the frames it has not yet acknowledged."""

    def __init__(self) -> None:
        self.history: object = None
        self.cursor = 0
        self.factor = 1
        self.pending: dict[int, float] = {}
        self.closed = False


class Dashboard:
    """What the dashboard app serves, and the screen latencies it measured.

    Parameters
    ----------
    live : LiveReadout
        The read-out shown (started or not; the page waits for samples).
    window : float
        Seconds shown on the plots, s.
    record_dir : str or Path
        Where the record button writes ``live-DATE-TIME.tdms``.
    fps : float
        Frames per second sent to each browser, Hz.
    """

    def __init__(self, live: LiveReadout, *, window: float = 10.0,
                 record_dir: str | Path = ".", fps: float = 30.0) -> None:
        if not isinstance(live, LiveReadout):
            raise v.fail("live", type(live).__name__, "a magcilia LiveReadout")
        self.live = live
        self.window = v.positive("window", window, "s", "duration")
        self.record_dir = Path(record_dir)
        self.fps = v.positive("fps", fps, "Hz", "frequency")
        self.quantity = MEASURANDS[live.sensor.quantity]
        self._latencies: collections.deque[float] = collections.deque(maxlen=LATENCIES)
        self._latency_lock = threading.Lock()
        self._frames = itertools.count(1)
        self._status: dict[str, Any] = {}
        self._status_at = -math.inf
        self._record_lock = threading.Lock()
        self.clients = 0

    # -- what the page asks for ---------------------------------------------------------------
    def info(self) -> dict[str, Any]:
        """What is measured, in display units: quantity, unit, span, limits, setup (as in a
        setup file), calibration report, source and rates (JSON-ready)."""
        live, r, q = self.live, self.live.readout, self.quantity
        limits = live.limits()
        sensor = live.sensor
        doc: dict[str, Any] = {
            "kind": sensor.kind, "quantity": sensor.quantity, "label": q.label,
            "unit": q.display, "si_unit": sensor.unit,
            "range": [q.to_display(x) for x in limits.range],
            "minimum": q.to_display(limits.minimum), "limited_by": limits.limited_by,
            "mode": limits.mode or "static",
            "source": {"name": live.source.name, "rate_Hz": live.source.rate},
            "rate_Hz": live.rate, "window_s": self.window, "fps": self.fps,
            "points": MAX_POINTS, "factor": display_factor(self.window, live.rate)}
        if sensor.kind != "scalar":
            doc.update({
                "span": [q.to_display(x) for x in limits.span],
                "readout": sensor.report(), "scale_note": limits.scale_note,
                "setup": _sections(sensor.setup), "calibration": None,
                "cilia": list(sensor.names) or [(sensor.kind == "vector" and "F") or ""],
                "positions_mm": (sensor.positions * 1e3).tolist(),
                "inputs": list(sensor.inputs),
                "columns": ["time", *VECTOR_COLUMNS], "header": list(VECTOR_HEADER)})
        else:
            doc.update({
                "span": [q.to_display(x) for x in r.span],
                "readout": r.report(), "scale_note": r.scale_note, "setup": sensor.setup,
                "calibration": r.calibration.report() if r.calibration is not None else None,
                "columns": list(FRAME_COLUMNS), "header": list(FRAME_HEADER)})
        return _jsonable(doc)

    def status(self, max_age: float = STATUS_PERIOD / 2) -> dict[str, Any]:
        """The read-out's status (:meth:`LiveStatus.to_dict`, SI) with the limits in display
        units, the screen latency (s) and the number of browsers; recomputed at most every
        ``max_age`` s."""
        now = time.monotonic()
        if now - self._status_at < max_age:
            return self._status
        live, q = self.live, self.quantity
        limits = live.limits()
        lat = self.screen_latency()
        out = live.status.to_dict()
        out.update({
            "range": [q.to_display(x) for x in limits.range],
            "minimum": q.to_display(limits.minimum),
            "screen_latency_median_s": float(np.median(lat)) if lat.size else None,
            "screen_latency_p99_s": float(np.quantile(lat, 0.99)) if lat.size else None,
            "clients": self.clients, "time": time.time(),
            "last_event": live.events[-1].report() if live.events else None,
        })
        self._status, self._status_at = _jsonable(out), now
        return self._status

    def screen_latency(self) -> F64:
        """The last (up to 1000) sample-to-screen latencies measured, s, oldest first."""
        with self._latency_lock:
            return np.array(self._latencies, dtype=np.float64)

    def tare(self) -> dict[str, Any]:
        """Ask the read-out for a tare (returns at once)."""
        self.live.tare()
        return {"tare": "started"}

    def record(self, action: str = "toggle") -> dict[str, Any]:
        """Start or stop the recording, one request at a time (blocking: opens or closes a file).

        Parameters
        ----------
        action : {"start", "stop", "toggle"}
            ``start`` keeps a recording that is open (many starts at once make one recording),
            ``stop`` closes it (complete), ``toggle`` does what the button shows.

        Returns
        -------
        dict
            ``{"recording": path or None, "stopped": path or None, "started": bool}``: the file
            open now, the file this request closed, and whether this request opened it.
        """
        if action not in RECORD_ACTIONS:
            raise v.fail("action", action, " or ".join(RECORD_ACTIONS))
        with self._record_lock:
            open_now = self.live.recording
            if action == "toggle":
                action = "stop" if open_now is not None else "start"
            if action == "stop":
                stopped = self.live.stop_recording()
                return {"recording": None, "stopped": None if stopped is None else str(stopped),
                        "started": False}
            if open_now is not None:
                return {"recording": str(open_now), "stopped": None, "started": False}
            path = self.live.start_recording(directory=self.record_dir)  # (creates the folder)
            return {"recording": str(path), "stopped": None, "started": True}

    def toggle_recording(self) -> dict[str, Any]:
        """Stop the recording if one is open, else start one (:meth:`record` ``("toggle")``)."""
        return self.record("toggle")

    # -- the WebSocket --------------------------------------------------------------------------
    async def stream(self, websocket: WebSocket) -> None:
        """Serve one browser until it goes away (its disconnecting ends only this loop)."""
        from starlette.websockets import WebSocketDisconnect, WebSocketDisconnected

        gone = (WebSocketDisconnect, WebSocketDisconnected, OSError)
        client = _Client()
        self.clients += 1
        receiver: asyncio.Task[None] | None = None
        try:
            await websocket.accept()
            receiver = asyncio.create_task(self._receive(websocket, client))
            await self._send_loop(websocket, client)
        except gone:
            pass
        finally:
            client.closed = True
            self.clients -= 1
            if receiver is not None:
                receiver.cancel()
                with contextlib.suppress(asyncio.CancelledError, *gone):
                    await receiver

    async def _send_loop(self, websocket: WebSocket, client: _Client) -> None:
        loop = asyncio.get_running_loop()
        period = 1.0 / self.fps
        status_due = 0.0
        tick = loop.time()
        while not client.closed:
            frame = self._next_frame(client)
            if frame is not None:
                await websocket.send_bytes(frame)
            if loop.time() >= status_due:
                status_due = loop.time() + STATUS_PERIOD
                await websocket.send_text(json.dumps(self.status()))
            tick += period
            delay = tick - loop.time()
            if delay < -period:  # fell behind (a slow browser): do not catch up in a burst
                tick, delay = loop.time(), 0.0
            await asyncio.sleep(max(delay, 0.0))

    def _next_frame(self, client: _Client) -> bytes | None:
        """The frame of what came since the client's cursor (None if no whole bin yet)."""
        live = self.live
        history = live.history
        keep = max(1, round(self.window * live.rate))
        if client.history is not history:  # (re)connected or the read-out restarted
            client.history = history
            client.factor = display_factor(self.window, live.rate)
            start = max(0, history.total - keep)
            client.cursor = start - start % client.factor
        factor = client.factor
        samples, total, lost = history.since(client.cursor, limit=keep + factor)
        first = total - len(samples)
        aligned = -(-first // factor) * factor
        end = (total // factor) * factor
        if end <= aligned:
            return None
        skipped = lost + first - client.cursor
        client.cursor = end
        columns = decimate(samples, factor, aligned - first)
        cilia = 0
        if live.sensor.kind == "scalar":
            columns[1] *= 1e3  # V -> mV
            columns[2:4] /= self.quantity.display_factor
        else:
            cilia = (columns.shape[0] - 1) // len(VECTOR_COLUMNS)
            per = columns[1:].reshape(cilia, len(VECTOR_COLUMNS), -1)
            per[:, :4] /= self.quantity.display_factor
        received = float(samples.received[end - first - 1])
        frame_id = next(self._frames)
        if len(client.pending) > 256:  # a browser that does not answer
            client.pending.clear()
        client.pending[frame_id] = received
        return encode_frame(frame_id, columns, received=received, sent=time.time(),
                            bin_seconds=factor / live.rate, lost=max(0, skipped), cilia=cilia)

    async def _receive(self, websocket: WebSocket, client: _Client) -> None:
        """Read the browser's acknowledgements until it disconnects."""
        while not client.closed:
            message = await websocket.receive()
            if message["type"] == "websocket.disconnect":
                client.closed = True
                return
            text = message.get("text")
            if text and len(text) < 4096:
                self._acknowledge(client, text)

    def _acknowledge(self, client: _Client, text: str) -> None:
        try:
            drawn = json.loads(text).get("drawn")
        except (ValueError, AttributeError):
            return
        ids = drawn if isinstance(drawn, list) else [drawn]
        now = time.time()
        with self._latency_lock:
            for frame_id in ids:
                received = client.pending.pop(frame_id, None) if isinstance(
                    frame_id, int) else None
                if received is not None:
                    self._latencies.append(now - received)


def _sections(setup: dict[str, Any]) -> dict[str, Any]:
    """A setup (or array) file's tables for the page's setup box: nested tables as they are, a
    list of tables (an array's cilia or sensors) as one line per entry."""
    out: dict[str, Any] = {}
    for name, table in setup.items():
        if isinstance(table, list):
            out[name] = {str(k + 1): ", ".join(f"{a}={b}" for a, b in entry.items())
                         if isinstance(entry, dict) else str(entry)
                         for k, entry in enumerate(table)}
        elif isinstance(table, dict):
            out[name] = {k: (json.dumps(x) if isinstance(x, dict) else x)
                         for k, x in table.items()}
        else:
            out[name] = {"": table}
    return out
