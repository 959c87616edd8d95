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

import contextlib
import errno
import json
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
from magcilia.live.feed import LATENCIES, RECORD_ACTIONS, STATUS_PERIOD, Dashboard
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

F64 = NDArray[np.float64]
__all__ = ["FRAME_COLUMNS", "FRAME_HEADER", "FRAME_VERSION", "LATENCIES", "LOCAL_HOSTS",
           "MAX_POINTS", "RECORD_ACTIONS", "STATUS_PERIOD", "Dashboard", "DashboardServer",
           "bind_socket", "dashboard_app", "decimate", "decode_frame", "display_factor",
           "encode_frame", "exposure_warning",
           "require_server", "serve"]

#: hosts that only this computer reaches
LOCAL_HOSTS = tuple(sorted(LOOPBACK))
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


def _static_files() -> dict[str, bytes]:
    folder = resources.files("magcilia.live").joinpath("static")
    return {f.name: f.read_bytes() for f in folder.iterdir() if f.is_file()}


_MEDIA = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
          ".css": "text/css; charset=utf-8", ".txt": "text/plain; charset=utf-8"}


# -- the dashboard ---------------------------------------------------------------------------
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
