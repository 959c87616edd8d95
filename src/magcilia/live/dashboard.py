"""The browser dashboard of a live read-out (needs ``starlette`` and ``uvicorn``).

::

    LiveReadout.history ─► per browser: cursor ─► decimate ─► binary frame ─► WebSocket ─► uPlot
                                                                    ▲                       │
                                  screen latency = now − received ──┴── {"drawn": id} ◄─────┘

An ASGI app (:func:`dashboard_app`, Starlette) serves one page (``static/``: plain JavaScript,
uPlot shipped with its licence, nothing fetched from the network) and a WebSocket ``/ws``. Each
connected browser gets its own loop that runs ``fps`` times per second: it takes the output
samples that came since its own cursor (:meth:`History.since`; nothing is queued for it by the
read-out, so a slow or vanished browser costs the acquisition nothing), averages them into display
bins so that a ``window``-second trace has at most :data:`MAX_POINTS` points, and sends one
binary frame (:func:`encode_frame`; both in :mod:`magcilia.live.frames`). A few times per second
it also sends the status as JSON.

**Screen latency**: after drawing a frame (uPlot's ``setData`` inside ``requestAnimationFrame``,
then a task after the paint) the page answers ``{"drawn": frame_id}``; the server takes
``time.time() −`` the wall time at which the frame's newest sample reached the computer. That
round trip on one clock is an upper bound of sample-to-screen (it includes the answer's way back);
:meth:`Dashboard.screen_latency` keeps the last 1000.

The HTTP API: ``GET /api/info`` (what is measured, limits, setup, calibration), ``GET
/api/status``, ``POST /api/tare``, ``POST /api/record`` (start/stop a recording: a JSON body
``{"action": "start" | "stop" | "toggle"}``, no body: toggle). The app obeys only its own page
(:mod:`magcilia.live.guard`): a foreign ``Host`` (DNS rebinding) or ``Origin`` (another site) is
refused, and commands carry the per-run token that the served page holds.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import errno
import itertools
import json
import math
import os
import socket
import threading
import time
import webbrowser
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, Self

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError, require
from magcilia.device.parameters import MEASURANDS
from magcilia.io.setup_files import setup_to_dict
from magcilia.live.frames import (
    FRAME_COLUMNS,
    FRAME_HEADER,
    FRAME_VERSION,
    MAX_POINTS,
    decimate,
    decode_frame,
    display_factor,
    encode_frame,
)
from magcilia.live.guard import LOOPBACK, TOKEN_META, Guard, OwnPageOnly
from magcilia.live.pipeline import LiveReadout

if TYPE_CHECKING:
    from starlette.applications import Starlette
    from starlette.requests import Request
    from starlette.responses import Response
    from starlette.websockets import WebSocket

F64 = NDArray[np.float64]
__all__ = ["FRAME_COLUMNS", "FRAME_HEADER", "FRAME_VERSION", "LOCAL_HOSTS", "MAX_POINTS",
           "RECORD_ACTIONS", "Dashboard", "DashboardServer", "bind_socket", "dashboard_app",
           "decimate", "decode_frame", "display_factor", "encode_frame", "exposure_warning",
           "require_server", "serve"]

#: seconds between status messages to each browser
STATUS_PERIOD = 0.25
#: screen latencies kept
LATENCIES = 1000
#: hosts that only this computer reaches
LOCAL_HOSTS = tuple(sorted(LOOPBACK))
#: what ``POST /api/record`` can be asked to do
RECORD_ACTIONS = ("start", "stop", "toggle")
_PURPOSE = "The browser dashboard"


# -- small helpers ---------------------------------------------------------------------------
def exposure_warning(host: str) -> str | None:
    """The warning to print when ``host`` makes the dashboard reachable from other computers
    (None for this computer only)."""
    if host.strip().strip("[]").lower() in LOCAL_HOSTS:
        return None
    return (f"--host {host} makes the dashboard (with its tare and record buttons, and no "
            "authentication) reachable by anyone on the network: its token keeps other web "
            "sites out, not people who can open the page")


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


def _static_files() -> dict[str, bytes]:
    folder = resources.files("magcilia.live").joinpath("static")
    return {f.name: f.read_bytes() for f in folder.iterdir() if f.is_file()}


_MEDIA = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
          ".css": "text/css; charset=utf-8", ".txt": "text/plain; charset=utf-8"}


# -- the dashboard ---------------------------------------------------------------------------
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
        self.quantity = MEASURANDS[live.readout.quantity]
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
        return _jsonable({
            "quantity": r.quantity, "label": q.label, "unit": q.display, "si_unit": r.unit,
            "span": [q.to_display(x) for x in r.span],
            "range": [q.to_display(x) for x in limits.range],
            "minimum": q.to_display(limits.minimum), "limited_by": limits.limited_by,
            "readout": r.report(), "scale_note": r.scale_note, "setup": setup_to_dict(r.setup),
            "calibration": r.calibration.report() if r.calibration is not None else None,
            "source": {"name": live.source.name, "rate_Hz": live.source.rate},
            "rate_Hz": live.rate, "window_s": self.window, "fps": self.fps,
            "points": MAX_POINTS, "factor": display_factor(self.window, live.rate),
            "columns": list(FRAME_COLUMNS), "header": list(FRAME_HEADER),
        })

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
        columns[1] *= 1e3  # V -> mV
        columns[2:4] /= self.quantity.display_factor
        received = float(samples.received[end - first - 1])
        frame_id = next(self._frames)
        if len(client.pending) > 256:  # a browser that does not answer
            client.pending.clear()
        client.pending[frame_id] = received
        return encode_frame(frame_id, columns, received=received, sent=time.time(),
                            bin_seconds=factor / live.rate, lost=max(0, skipped))

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


def dashboard_app(live: LiveReadout, *, window: float = 10.0, record_dir: str | Path = ".",
                  fps: float = 30.0, host: str = "127.0.0.1") -> Starlette:
    """The dashboard as an ASGI app (Starlette); its :class:`Dashboard` is
    ``app.state.dashboard``, its :class:`~magcilia.live.guard.Guard` (the Host names it answers
    to and this run's token) ``app.state.guard``.

    Parameters
    ----------
    live : LiveReadout
        The read-out shown.
    window : float
        Seconds shown on the plots, s.
    record_dir : str or Path
        Where the record button writes ``live-DATE-TIME.tdms``.
    fps : float
        Frames per second sent to each browser, Hz.
    host : str
        The address the server listens on (which Host names are its own:
        :meth:`Guard.serving <magcilia.live.guard.Guard.serving>`).
    """
    require("starlette", package="starlette", extra="dashboard", purpose=_PURPOSE)
    from starlette.applications import Starlette
    from starlette.concurrency import run_in_threadpool
    from starlette.middleware import Middleware
    from starlette.responses import JSONResponse, Response
    from starlette.routing import Route, WebSocketRoute

    dashboard = Dashboard(live, window=window, record_dir=record_dir, fps=fps)
    guard = Guard.serving(host)
    files = _static_files()
    marker = f'<meta name="{TOKEN_META}" content="">'.encode()
    if files["index.html"].count(marker) != 1:
        raise MagciliaError(f"the dashboard page lacks its token tag {marker.decode()}")
    page = files["index.html"].replace(
        marker, f'<meta name="{TOKEN_META}" content="{guard.token}">'.encode())

    async def index(_: Request) -> Response:
        # the token is this run's: the page must never come from a cache
        return Response(page, media_type=_MEDIA[".html"], headers={"Cache-Control": "no-store"})

    async def static(request: Request) -> Response:
        name = request.path_params["name"]
        if name not in files:
            return Response("not found", status_code=404, media_type=_MEDIA[".txt"])
        return Response(files[name], media_type=_MEDIA.get(Path(name).suffix, _MEDIA[".txt"]),
                        headers={"Cache-Control": "no-cache"})

    async def info(_: Request) -> Response:
        return JSONResponse(dashboard.info())

    async def status(_: Request) -> Response:
        return JSONResponse(dashboard.status(max_age=0.0))

    async def tare(_: Request) -> Response:
        return JSONResponse(dashboard.tare())

    async def record(request: Request) -> Response:
        body = await request.body()
        try:
            action = json.loads(body).get("action", "toggle") if body.strip() else "toggle"
        except (ValueError, AttributeError):
            action = None
        if action not in RECORD_ACTIONS:
            return JSONResponse({"error": "the body must be {\"action\": \"start\"}, "
                                 "\"stop\" or \"toggle\" (or empty: toggle)"}, status_code=400)
        try:
            result = await run_in_threadpool(dashboard.record, action)
        except (MagciliaError, OSError) as exc:
            return JSONResponse({"error": str(exc)}, status_code=500)
        return JSONResponse(result)

    app = Starlette(routes=[
        Route("/", index), Route("/static/{name:str}", static), Route("/api/info", info),
        Route("/api/status", status), Route("/api/tare", tare, methods=["POST"]),
        Route("/api/record", record, methods=["POST"]), WebSocketRoute("/ws", dashboard.stream),
    ], middleware=[Middleware(OwnPageOnly, guard=guard)])
    app.state.dashboard = dashboard
    app.state.guard = guard
    return app


# -- the server ------------------------------------------------------------------------------
def require_server() -> None:
    """Check that the dashboard's packages are there (starlette, uvicorn, websockets).

    Raises
    ------
    MissingDependencyError
        Naming the package and ``pip install 'magcilia[dashboard]'``.
    """
    for module in ("starlette", "uvicorn", "websockets"):
        require(module, package=module, extra="dashboard", purpose=_PURPOSE)


def bind_socket(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host``:``port`` (0: a free port).

    Raises
    ------
    MagciliaError
        If the port is in use or the host is not an address of this computer.
    """
    port = v.integer("port", port, 0)
    if port > 65535:
        raise v.fail("port", port, "a TCP port, 0…65535")
    try:
        family, kind, proto, _, address = socket.getaddrinfo(
            host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)[0]
    except socket.gaierror as exc:
        why = f"an address or name of this computer ({exc.strerror})"
        raise v.fail("--host", host, why) from None
    sock = socket.socket(family, kind, proto)
    try:
        if os.name != "nt":  # on Windows, SO_REUSEADDR would let two servers share the port
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(128)
    except OSError as exc:
        sock.close()
        if exc.errno in (errno.EADDRINUSE, errno.EACCES) or getattr(exc, "winerror", 0) == 10048:
            what = "is already in use" if exc.errno != errno.EACCES else "is not allowed"
            raise MagciliaError(f"{_hostport(host, port)} {what}; choose another with --port "
                                "or stop what uses it") from None
        raise MagciliaError(f"cannot listen on {_hostport(host, port)}: "
                            f"{exc.strerror or exc}") from None
    sock.setblocking(False)
    return sock


def _hostport(host: str, port: int) -> str:
    return f"[{host}]:{port}" if ":" in host else f"{host}:{port}"


class DashboardServer:
    """The dashboard served by uvicorn in a background thread (a context manager).

    Parameters
    ----------
    live : LiveReadout
        The read-out shown (started and stopped by the caller).
    host : str
        Address to listen on; anything but this computer's (127.0.0.1, localhost, ::1) exposes
        the dashboard's buttons to the network (:func:`exposure_warning`). Requests whose Host
        names another server, or that come from another page, are refused
        (:mod:`magcilia.live.guard`).
    port : int
        TCP port (0: a free one; :attr:`url` tells which).
    window, record_dir, fps
        As for :func:`dashboard_app`.

    Examples
    --------
    ::

        with live, DashboardServer(live, port=0) as server:
            print(server.url)  # http://127.0.0.1:PORT/
            ...
    """

    def __init__(self, live: LiveReadout, host: str = "127.0.0.1", port: int = 8050, *,
                 window: float = 10.0, record_dir: str | Path = ".",
                 fps: float = 30.0) -> None:
        self.app = dashboard_app(live, window=window, record_dir=record_dir, fps=fps, host=host)
        self.dashboard: Dashboard = self.app.state.dashboard
        self.guard: Guard = self.app.state.guard
        self.host = host
        self.port = port
        self._server: Any = None
        self._socket: socket.socket | None = None
        self._thread: threading.Thread | None = None
        self._ended = threading.Event()
        #: why the server thread ended by itself (``"Type: message"``; None otherwise)
        self.failure: str | None = None

    @property
    def token(self) -> str:
        """This run's token: commands (``POST``) carry it in the ``X-Magcilia-Token`` header."""
        return self.guard.token

    @property
    def url(self) -> str:
        """The page's address (with the port bound)."""
        host = {"0.0.0.0": "127.0.0.1", "::": "::1", "": "127.0.0.1"}.get(self.host, self.host)
        return f"http://{_hostport(host, self.port)}/"

    def start(self, timeout: float = 10.0) -> Self:
        """Bind the port and start serving; returns once the server accepts connections.

        Interrupted (Ctrl-C) before that, it stops the server it began and raises again: no
        server is left running without an owner.

        Raises
        ------
        MagciliaError
            If the port is in use or the server did not start within ``timeout`` s.
        """
        if self._thread is not None:
            return self
        uvicorn: Any = require("uvicorn", package="uvicorn", extra="dashboard",
                               purpose=_PURPOSE)
        from uvicorn.config import WS_PROTOCOLS

        sock = bind_socket(self.host, self.port)
        self.port = int(sock.getsockname()[1])
        try:
            config = uvicorn.Config(
                self.app, log_level="warning", access_log=False, log_config=None,
                lifespan="off",
                ws="websockets-sansio" if "websockets-sansio" in WS_PROTOCOLS else "auto",
                ws_per_message_deflate=False, timeout_graceful_shutdown=3)
            server = uvicorn.Server(config)
        except BaseException:
            sock.close()
            raise
        # uvicorn in a thread of its own installs no signal handlers (it does so only in the
        # main thread): stopping is ours, through should_exit (stop())
        self._server, self._socket, self._ended = server, sock, threading.Event()
        self.failure = None
        self._thread = threading.Thread(target=self._serve, args=(sock,),
                                        name="magcilia-dashboard", daemon=True)
        try:
            self._thread.start()
            deadline = time.monotonic() + timeout
            while not server.started:
                if self._ended.is_set() or time.monotonic() > deadline:
                    why = (f"failed: {self.failure or 'it ended'}" if self._ended.is_set()
                           else f"did not start within {timeout:g} s")
                    raise MagciliaError(f"the dashboard server on "
                                        f"{_hostport(self.host, self.port)} {why}")
                time.sleep(0.01)
        except BaseException:
            self.stop()
            raise
        return self

    def _serve(self, sock: socket.socket) -> None:
        """The server thread: serve on ``sock`` until told to stop, then close it. Once this
        thread runs, the socket is its alone (uvicorn's shutdown closes it too): closed by
        another thread while the server still listens, it breaks the server's shutdown."""
        try:
            if not self._server.should_exit:  # not stopped before it began
                self._server.run(sockets=[sock])
        except BaseException as exc:  # noqa: BLE001 (the owner reports it in one line)
            self.failure = f"{type(exc).__name__}: {exc}"
        finally:
            sock.close()
            self._ended.set()

    @property
    def serving(self) -> bool:
        """Whether the server thread runs (it started and has not ended)."""
        return self._thread is not None and not self._ended.is_set()

    def wait(self) -> None:
        """Block until the server stops (KeyboardInterrupt passes through)."""
        # an Event, not Thread.join: on Python ≤ 3.12 a join that Ctrl-C interrupts marks the
        # still-running thread as ended (CPython issue 90882), and stop() would then not wait
        while self._thread is not None and not self._ended.wait(0.2):
            pass

    def stop(self, timeout: float = 10.0) -> None:
        """Close the browsers' connections and stop serving (idempotent); returns once the
        server thread has ended and the port is free (or after ``timeout`` s, then 5 s more
        with the connections cut, for a server that hangs).

        Parameters
        ----------
        timeout : float
            Seconds given to a graceful shutdown, s.
        """
        server, thread, sock = self._server, self._thread, self._socket
        self._thread = self._socket = None
        if thread is None:
            return
        server.should_exit = True
        # a thread that is not alive yet was interrupted in its start: it ends at once, if at all
        if not self._ended.wait(timeout if thread.is_alive() else 0.5) and thread.is_alive():
            server.force_exit = True
            self._ended.wait(5.0)
        if not self._ended.is_set() and not thread.is_alive() and sock is not None:
            sock.close()  # the thread never ran; one that hangs keeps its socket

    def screen_latency(self) -> F64:
        """The last (up to 1000) sample-to-screen latencies, s (oldest first)."""
        return self.dashboard.screen_latency()

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.stop()


def serve(live: LiveReadout, host: str = "127.0.0.1", port: int = 8050, *,
          window: float = 10.0, record_dir: str | Path = ".", open_browser: bool = False,
          on_ready: Callable[[str], object] | None = None) -> None:
    """Serve the dashboard of ``live`` until Ctrl-C (returns then, with the server stopped).

    Parameters
    ----------
    live : LiveReadout
        The read-out shown (started and stopped by the caller).
    host, port
        Where to listen (see :class:`DashboardServer`).
    window : float
        Seconds shown on the plots, s.
    record_dir : str or Path
        Where the record button writes recordings.
    open_browser : bool
        Open the page in a browser tab.
    on_ready : callable, optional
        Called with the page's URL once the server listens.

    Raises
    ------
    MagciliaError
        If the port is in use (``"127.0.0.1:8050 is already in use; …"``).
    """
    server = DashboardServer(live, host, port, window=window, record_dir=record_dir)
    with server:
        if on_ready is not None:
            on_ready(server.url)
        if open_browser:
            webbrowser.open(server.url, new=2)
        with contextlib.suppress(KeyboardInterrupt):
            server.wait()
