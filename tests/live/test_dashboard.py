"""The browser dashboard: decimation and frames, the HTTP and WebSocket API on a real server,
the guard (a foreign Host, Origin or token is refused: every forbidden request in-process and on
the wire), one recording per file under concurrent requests, SIGTERM/SIGHUP closing a recording,
faults (browsers that vanish or stall, a port in use, an unplugged source), the CLI, and the page
itself in a headless Chromium (the value follows a force step, tare, record, a screenshot).

Speed (step to page, screen latency) is measured by ``benchmarks/bench_live.py``; the waits here
are generous guards against a hang, not timings. The README's picture comes from
``scripts/dashboard_screenshot.py``; the browser test's screenshot goes to a temporary folder.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.acquire import Script, SimulatedSource
from magcilia.cli import main
from magcilia.live import LiveReadout, LiveSamples
from magcilia.live.dashboard import (
    FRAME_COLUMNS,
    MAX_POINTS,
    DashboardServer,
    bind_socket,
    decimate,
    decode_frame,
    display_factor,
    encode_frame,
    exposure_warning,
)
from magcilia.live.guard import TOKEN_HEADER, Guard, split_host
from magcilia.live.history import COLUMNS

SETUP = mc.Setup.paper(tip_radius=5e-5)
SPAN = (-3e-4, 3e-4)
#: seconds any single wait may take before a test calls it a hang (not a timing)
HANG = 10.0
EVIL = "http://evil.example"


@pytest.fixture(scope="module")
def readout() -> mc.Readout:
    return mc.Readout(SETUP, "force", span=SPAN)


def _source(value: float = 0.0, cls: type[SimulatedSource] = SimulatedSource,
            **kw: Any) -> SimulatedSource:
    return cls(SETUP, Script.constant(value, "force"), rate=10000.0, realtime=True, rng=0,
               readout_noise=2e-5, **kw)


@pytest.fixture(scope="module")
def served(readout: mc.Readout,
           tmp_path_factory: pytest.TempPathFactory) -> Iterator[DashboardServer]:
    """A running read-out with its dashboard on a free port."""
    live = LiveReadout(_source(), readout, rate=1000, tare_at_start=True)
    record_dir = tmp_path_factory.mktemp("records")
    with live, DashboardServer(live, port=0, record_dir=record_dir) as server:
        live.wait(700)  # past the tare at the start
        yield server


def _get(server: DashboardServer, path: str, method: str = "GET",
         headers: dict[str, str] | None = None, body: Any = None) -> Any:
    """A request as the page sends it (commands with the token), the answer's JSON or bytes."""
    headers = dict(headers or {})
    if method != "GET":
        headers.setdefault("X-Magcilia-Token", server.token)
        headers.setdefault("Content-Type", "application/json")
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(server.url + path, method=method, headers=headers,
                                     data=data)
    with urllib.request.urlopen(request, timeout=HANG) as response:
        answer = response.read()
        kind = response.headers["Content-Type"]
    return json.loads(answer) if kind.startswith("application/json") else answer


def _eventually(condition: Any, timeout: float = HANG) -> bool:
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.02)
    return bool(condition())


def _samples(value: np.ndarray, flags: np.ndarray) -> LiveSamples:
    m = value.size
    cols = {name: np.zeros(m) for name in COLUMNS}
    cols.update(time=np.arange(m) * 1e-3, raw=np.arange(m) * 1e-6, value=value,
                sigma=np.full(m, 2.0), flags=flags)
    return LiveSamples("force", "N", **cols)


# -- decimation and frames ---------------------------------------------------------------------
@pytest.mark.parametrize(("window", "rate", "factor"), [(10, 1000, 5), (10, 10000, 50),
                                                        (1, 1000, 1), (10, 100, 1),
                                                        (60, 1000, 30)])
def test_a_window_fits_in_the_display_points(window: float, rate: float, factor: int) -> None:
    assert display_factor(window, rate) == factor
    assert window * rate / factor <= MAX_POINTS


def test_decimation_averages_keeps_the_worst_flag_and_nan_where_all_are_flagged() -> None:
    value = np.arange(12, dtype=float)
    flags = np.zeros(12, dtype=np.uint8)
    value[4:8] = np.nan  # the second bin: all flagged
    flags[4:8] = [1, 4, 1, 1]
    value[9] = np.nan  # the third bin: one flagged
    flags[9] = 2
    out = decimate(_samples(value, flags), 4)
    assert out.shape == (5, 3)
    assert out[0] == pytest.approx([1.5e-3, 5.5e-3, 9.5e-3])
    assert out[1] == pytest.approx([1.5e-6, 5.5e-6, 9.5e-6])
    assert out[2, 0] == pytest.approx(1.5) and np.isnan(out[2, 1])
    assert out[2, 2] == pytest.approx((8 + 10 + 11) / 3)
    assert out[3, 0] == 2.0 and np.isnan(out[3, 1]) and out[3, 2] == 2.0
    assert out[4].tolist() == [0, 5, 2]  # the bits of the bin together


def test_decimation_starts_where_told_and_drops_a_partial_bin() -> None:
    s = _samples(np.arange(10.0), np.zeros(10, dtype=np.uint8))
    out = decimate(s, 3, start=2)
    assert out[2].tolist() == [3.0, 6.0]
    assert decimate(s, 20).shape == (5, 0)
    big = _samples(np.zeros(10_000), np.zeros(10_000, dtype=np.uint8))
    assert decimate(big, display_factor(10, 1000)).shape[1] <= MAX_POINTS


def test_a_frame_survives_the_round_trip() -> None:
    cols = np.random.default_rng(0).standard_normal((len(FRAME_COLUMNS), 7))
    cols[2, 3] = np.nan
    data = encode_frame(42, cols, received=1.7e9 + 0.25, sent=1.7e9 + 0.5, bin_seconds=5e-3,
                        lost=3)
    assert len(data) == 8 * (7 + 5 * 7)
    header, back = decode_frame(data)
    assert header["frame"] == 42 and header["points"] == 7 and header["lost"] == 3
    assert header["received"] == 1.7e9 + 0.25 and header["bin_seconds"] == 5e-3
    np.testing.assert_array_equal(back, cols)
    with pytest.raises(MagciliaError, match="frame must be"):
        decode_frame(data[:-8])


def test_only_local_hosts_go_without_a_warning() -> None:
    for host in ("127.0.0.1", "localhost", "::1", "[::1]"):
        assert exposure_warning(host) is None
    text = exposure_warning("0.0.0.0")
    assert text is not None and "anyone on the network" in text and "\n" not in text
    assert "token" in text  # what the token does and does not do


# -- the guard: its rules, pure --------------------------------------------------------------
@pytest.mark.parametrize(("value", "parts"), [
    ("127.0.0.1:8050", ("127.0.0.1", 8050)), ("LocalHost:80", ("localhost", 80)),
    ("[::1]:8050", ("::1", 8050)), ("[::1]", ("::1", None)), ("localhost.", ("localhost", None)),
    ("evil.example", ("evil.example", None))])
def test_a_host_header_splits_into_name_and_port(value: str, parts: tuple[str, int | None]
                                                 ) -> None:
    assert split_host(value) == parts


def test_on_this_computer_only_ip_addresses_and_localhost_name_the_dashboard() -> None:
    guard = Guard.serving("127.0.0.1")
    for host in ("127.0.0.1:8050", "localhost:8050", "[::1]:8050", "LOCALHOST", "127.0.0.1:9",
                 "10.0.0.7:8050"):  # the port is not compared (an SSH tunnel to another port)
        assert guard.host_allowed(host), host
    for host in ("evil.example:8050", "127.0.0.1.evil.example", "localhost.evil.example",
                 "evil.example:8050@127.0.0.1", "", None, "2130706433:8050",
                 socket.gethostname()):
        assert not guard.host_allowed(host), host
    wide = Guard.serving("0.0.0.0")  # beyond this computer: also its own name
    assert wide.host_allowed(f"{socket.gethostname()}:8050")
    assert not wide.host_allowed("evil.example:8050")
    assert Guard.serving("lab-pc.example").host_allowed("LAB-PC.example:8050")


def test_the_page_s_own_origin_is_http_and_the_same_host_and_port() -> None:
    same = Guard.same_origin
    assert same("http://127.0.0.1:8050", "127.0.0.1:8050")
    assert same("http://localhost", "localhost:80") and same("http://[::1]:8050", "[::1]:8050")
    for origin in ("http://evil.example", "http://127.0.0.1:3000", "https://127.0.0.1:8050",
                   "null", "", "file://", "http://127.0.0.1:8050/x", "http://a@127.0.0.1:8050"):
        assert not same(origin, "127.0.0.1:8050"), origin


def test_each_run_has_its_own_token_compared_whole() -> None:
    a, b = Guard.serving(), Guard.serving()
    assert a.token != b.token and len(a.token) >= 40
    assert a.token_ok(a.token) and not a.token_ok(b.token)
    assert not a.token_ok(None) and not a.token_ok("") and not a.token_ok(a.token[:-1])
    assert a.token not in repr(a)


# -- the HTTP API -----------------------------------------------------------------------------
def test_info_tells_what_is_measured_in_display_units(served: DashboardServer) -> None:
    info = _get(served, "api/info")
    assert info["quantity"] == "force" and info["unit"] == "mN"
    assert info["span"] == pytest.approx([-0.3, 0.3])
    assert 0 < info["minimum"] < 0.1 and info["range"][1] <= 0.3 + 1e-9
    assert info["setup"]["cilium"]["tip_radius"] == "0.05 mm"
    assert info["calibration"] is None and info["rate_Hz"] == 1000
    assert info["factor"] == 5 and info["source"]["name"] == "sim"


def test_status_and_the_page_and_its_files(served: DashboardServer) -> None:
    status = _get(served, "api/status")
    assert status["state"] == "running" and status["overruns"] == 0 and status["tared"]
    page = _get(served, "").decode()
    assert "static/uPlot.iife.min.js" in page and "http" not in page.split("<body>")[1]
    assert _get(served, "static/uPlot.iife.min.js").startswith(b"/*! https://github.com/leeoniya")
    assert b"MIT License" in _get(served, "static/LICENSE-uPlot.txt")
    with pytest.raises(urllib.error.HTTPError, match="404"):
        _get(served, "static/..%2Fdashboard.py")


def test_the_page_holds_this_run_s_token_and_is_never_cached(served: DashboardServer) -> None:
    with urllib.request.urlopen(served.url, timeout=HANG) as response:
        page = response.read().decode()
        assert response.headers["Cache-Control"] == "no-store"
    assert _page_token(page) == served.token == served.app.state.guard.token
    assert served.token.encode() not in _get(served, "static/dashboard.js")  # the page only


def test_tare_is_asked_for_and_noted(served: DashboardServer) -> None:
    live = served.dashboard.live
    before = sum(e.kind == "tare" for e in live.events)
    assert _get(served, "api/tare", "POST") == {"tare": "started"}
    assert _eventually(lambda: sum(e.kind == "tare" for e in live.events) == before + 1)


def _page_token(page: str) -> str:
    """The token a script reads from the page, as the page's own script does."""
    found = re.findall(r'<meta name="magcilia-token" content="([^"]*)">', page)
    assert len(found) == 1
    return found[0]


# -- the guard: every forbidden request, in-process -------------------------------------------
def _asgi(app: Any, path: str, method: str = "GET", headers: dict[str, str] | None = None,
          body: bytes = b"", websocket: bool = False) -> tuple[int, bytes]:
    """One request to the ASGI ``app`` in this process: (HTTP status, body); a WebSocket
    handshake gives 101 when the app accepts it and 403 when it closes it first."""
    raw = [(k.lower().encode(), v.encode()) for k, v in (headers or {}).items()]
    scope: dict[str, Any] = {
        "type": "websocket" if websocket else "http", "asgi": {"version": "3.0"},
        "http_version": "1.1", "scheme": "ws" if websocket else "http", "path": path,
        "raw_path": path.encode(), "query_string": b"", "root_path": "", "headers": raw,
        "client": ("127.0.0.1", 50000), "server": ("127.0.0.1", 8050)}
    if not websocket:
        scope["method"] = method

    async def run() -> tuple[int, bytes]:
        answer: asyncio.Future[tuple[int, bytes]] = asyncio.get_running_loop().create_future()
        started: list[int] = []
        chunks: list[bytes] = []
        asked = False

        async def receive() -> dict[str, Any]:
            nonlocal asked
            if not asked:
                asked = True
                return ({"type": "websocket.connect"} if websocket else
                        {"type": "http.request", "body": body, "more_body": False})
            await asyncio.sleep(HANG)
            return {"type": "websocket.disconnect" if websocket else "http.disconnect"}

        async def send(message: dict[str, Any]) -> None:
            kind = message["type"]
            if answer.done():
                return
            if kind == "websocket.accept":
                answer.set_result((101, b""))
            elif kind == "websocket.close":
                answer.set_result((403, b""))
            elif kind == "http.response.start":
                started.append(message["status"])
            elif kind == "http.response.body":
                chunks.append(message.get("body", b""))
                if not message.get("more_body", False):
                    answer.set_result((started[0], b"".join(chunks)))

        task = asyncio.create_task(app(scope, receive, send))
        try:
            return await asyncio.wait_for(answer, HANG)
        finally:
            task.cancel()
            with contextlib.suppress(BaseException):
                await task

    return asyncio.run(run())


def _forbidden(port: int, token: str) -> dict[str, tuple[str, str, dict[str, str]]]:
    """(method, path, headers) of requests that the dashboard must refuse, by name."""
    own, evil = f"127.0.0.1:{port}", f"evil.example:{port}"
    good = {"Host": own, TOKEN_HEADER: token}
    return {
        "tare from another site": ("POST", "/api/tare", {**good, "Origin": EVIL}),
        "record from another site": ("POST", "/api/record", {**good, "Origin": EVIL}),
        "tare from a null origin": ("POST", "/api/tare", {**good, "Origin": "null"}),
        "record from a null origin": ("POST", "/api/record", {**good, "Origin": "null"}),
        "tare from another local page": ("POST", "/api/tare",
                                         {**good, "Origin": "http://127.0.0.1:3000"}),
        "tare from https": ("POST", "/api/tare", {**good, "Origin": f"https://{own}"}),
        "tare without the token": ("POST", "/api/tare", {"Host": own}),
        "record without the token": ("POST", "/api/record",
                                     {"Host": own, "Origin": f"http://{own}"}),
        "tare with a wrong token": ("POST", "/api/tare", {**good, TOKEN_HEADER: token[:-2]}),
        "record with another run's token": ("POST", "/api/record",
                                            {**good, TOKEN_HEADER: Guard.serving().token}),
        "the page under a rebound name": ("GET", "/", {"Host": evil}),
        "a file under a rebound name": ("GET", "/static/dashboard.js", {"Host": evil}),
        "the status under a rebound name": ("GET", "/api/status", {"Host": evil}),
        # DNS rebinding: to the browser, evil.example's page and this server are one origin
        "tare under a rebound name": ("POST", "/api/tare",
                                      {**good, "Host": evil, "Origin": f"http://{evil}"}),
        "the page without a Host": ("GET", "/", {}),
        "status asked by another site": ("GET", "/api/status", {"Host": own, "Origin": EVIL}),
    }


FORBIDDEN = list(_forbidden(1, "x"))
FORBIDDEN_WS = {
    "a foreign Host": {"Host": "evil.example:8050"},
    "a rebound name with its own Origin": {"Host": "evil.example:8050",
                                           "Origin": "http://evil.example:8050"},
    "another site's Origin": {"Host": "127.0.0.1:8050", "Origin": EVIL},
    "a null Origin": {"Host": "127.0.0.1:8050", "Origin": "null"},
    "another local page": {"Host": "127.0.0.1:8050", "Origin": "http://127.0.0.1:3000"},
}


@pytest.mark.parametrize("case", FORBIDDEN)
def test_a_forbidden_request_is_refused_and_nothing_acts(served: DashboardServer,
                                                         case: str) -> None:
    method, path, headers = _forbidden(served.port, served.token)[case]
    live = served.dashboard.live
    assert _eventually(lambda: live.status.state == "running")  # no tare under way
    status, body = _asgi(served.app, path, method, headers, b'{"action": "start"}')
    assert status == 403
    error = json.loads(body)["error"]
    assert "\n" not in error and served.token not in error
    assert live.status.state == "running" and live.recording is None  # neither tare nor record


@pytest.mark.parametrize("case", list(FORBIDDEN_WS))
def test_a_forbidden_websocket_handshake_is_refused(served: DashboardServer, case: str) -> None:
    before = served.dashboard.clients
    assert _asgi(served.app, "/ws", headers=FORBIDDEN_WS[case], websocket=True) == (403, b"")
    assert served.dashboard.clients == before


def test_its_own_page_and_scripts_are_served(served: DashboardServer) -> None:
    own = f"127.0.0.1:{served.port}"
    for host in (own, f"localhost:{served.port}", f"[::1]:{served.port}", "localhost:9000"):
        status, page = _asgi(served.app, "/", headers={"Host": host})
        assert status == 200 and _page_token(page.decode()) == served.token
    live = served.dashboard.live
    tares = sum(e.kind == "tare" for e in live.events)
    for origin in (f"http://{own}", None):  # the page, a script (no Origin: not a browser)
        headers = {"Host": own, TOKEN_HEADER: served.token}
        if origin:
            headers["Origin"] = origin
        assert _asgi(served.app, "/api/tare", "POST", headers) == (200, b'{"tare":"started"}')
    assert _eventually(lambda: sum(e.kind == "tare" for e in live.events) == tares + 1)
    status, _ = _asgi(served.app, "/api/record", "POST", {"Host": own, TOKEN_HEADER: served.token},
                      b'{"action": "begin"}')
    assert status == 400 and live.recording is None


# -- the guard on the wire (uvicorn) ----------------------------------------------------------
def test_the_server_refuses_a_foreign_host_and_a_cross_site_command(
        served: DashboardServer) -> None:
    live = served.dashboard.live
    tares = sum(e.kind == "tare" for e in live.events)
    for path, method, headers in (
            ("", "GET", {"Host": f"evil.example:{served.port}"}),
            ("api/tare", "POST", {"Origin": EVIL, "Content-Type": "text/plain"}),
            ("api/record", "POST", {"Origin": EVIL, "Content-Type": "text/plain"}),
            ("api/record", "POST", {"X-Magcilia-Token": "guessed"})):
        with pytest.raises(urllib.error.HTTPError) as err:
            _get(served, path, method, headers)
        assert err.value.code == 403
        err.value.close()
    assert _raw_handshake(served, host="evil.example").startswith(b"HTTP/1.1 403")
    assert sum(e.kind == "tare" for e in live.events) == tares and live.recording is None


def test_a_websocket_from_another_page_is_refused_its_own_page_streams(
        served: DashboardServer) -> None:
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    for origin in (EVIL, "null", f"http://127.0.0.1:{served.port + 1}"):
        with pytest.raises(InvalidStatus) as err:
            connect(_ws_url(served), origin=origin, open_timeout=HANG)
        assert err.value.response.status_code == 403, origin
    own = served.url.rstrip("/")
    with connect(_ws_url(served), origin=own, open_timeout=HANG) as ws:
        assert ws.recv(timeout=HANG)


# -- one recording per file ------------------------------------------------------------------
def _all_at_once(server: DashboardServer, bodies: list[Any]) -> list[dict[str, Any]]:
    """POST /api/record with each body, all released at the same moment."""
    gate = threading.Barrier(len(bodies))

    def one(body: Any) -> dict[str, Any]:
        gate.wait(HANG)
        answer: dict[str, Any] = _get(server, "api/record", "POST", body=body)
        return answer

    with ThreadPoolExecutor(len(bodies)) as pool:
        return list(pool.map(one, bodies))


def _recording_events(path: Path) -> list[int]:
    from nptdms import TdmsFile

    return [int(c) for c in TdmsFile.read(path)["events"]["event_code"][:]]


def test_concurrent_record_requests_make_one_recording_in_one_file(
        served: DashboardServer) -> None:
    from magcilia.io.recording_file import recording_properties

    folder, live = served.dashboard.record_dir, served.dashboard.live
    before = set(folder.glob("*.tdms"))
    started = _all_at_once(served, [{"action": "start"}] * 16)
    assert sum(r["started"] for r in started) == 1
    (path,) = {r["recording"] for r in started}
    assert set(folder.glob("*.tdms")) - before == {Path(path)} and live.recording == Path(path)
    stopped = _all_at_once(served, [{"action": "stop"}] * 16)
    assert [r["stopped"] for r in stopped if r["stopped"]] == [path]
    assert live.recording is None and recording_properties(path)["complete"] is True
    assert _recording_events(Path(path)) == [4, 4]  # one start and one stop: one recording

    # the button's toggle (an empty body), 16 at once: start, stop, start … one after another
    toggled = _all_at_once(served, [None] * 16)
    opened = [r["recording"] for r in toggled if r["started"]]
    closed = [r["stopped"] for r in toggled if r["stopped"]]
    assert len(opened) == len(closed) == 8 and sorted(opened) == sorted(closed)
    assert len(set(opened)) == 8 and live.recording is None
    assert set(folder.glob("*.tdms")) - before == {Path(path), *map(Path, opened)}
    for name in opened:
        assert recording_properties(name)["complete"] is True
        assert _recording_events(Path(name)) == [4, 4]


def test_concurrent_starts_in_python_never_share_a_file(readout: mc.Readout,
                                                        tmp_path: Path) -> None:
    live = LiveReadout(_source(), readout, rate=1000, tare_at_start=False)
    gate = threading.Barrier(8)

    def start(_: int) -> Path:
        gate.wait(HANG)
        return live.start_recording(directory=tmp_path)

    with live, ThreadPoolExecutor(8) as pool:
        paths = list(pool.map(start, range(8)))
    assert len(set(paths)) == 8 and sorted(tmp_path.glob("*.tdms")) == sorted(paths)
    for path in paths:  # each closed complete by the next start, the last by stop()
        assert _recording_events(path) == [4, 4]


@contextlib.contextmanager
def _dashboard_process(folder: Path) -> Iterator[tuple[subprocess.Popen[str], str, list[str]]]:
    """``python -m magcilia dashboard`` (the tree under test) on a free port: the process, its
    URL and the lines it prints (stdout and stderr; whole once it has ended). Killed if it is
    still running at the end."""
    with subprocess.Popen(
            [sys.executable, "-m", "magcilia", "dashboard", "--port", "0", "--record-dir",
             str(folder / "recordings")], cwd=folder, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True) as child:
        assert child.stdout is not None
        stream = child.stdout
        lines: list[str] = []
        reader = threading.Thread(target=lambda: lines.extend(stream), daemon=True)
        reader.start()
        try:
            assert _eventually(lambda: any("http://" in x for x in lines)
                               or child.poll() is not None, 3 * HANG), "no start in time"
            found = re.search(r"http://127\.0\.0\.1:\d+/", "".join(lines))
            assert found is not None, "".join(lines)
            yield child, found.group(0), lines
        finally:
            if child.poll() is None:
                child.kill()
            child.wait()
            reader.join(HANG)


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
def test_a_signal_closes_the_open_recording_complete(signum: int, tmp_path: Path) -> None:
    from magcilia.io.recording_file import recording_properties

    with _dashboard_process(tmp_path) as (child, url, lines):
        with urllib.request.urlopen(url, timeout=HANG) as response:
            token = _page_token(response.read().decode())
        request = urllib.request.Request(
            url + "api/record", method="POST", data=b'{"action": "start"}',
            headers={"X-Magcilia-Token": token, "Content-Type": "application/json"})
        with urllib.request.urlopen(request, timeout=HANG) as response:
            path = Path(json.loads(response.read())["recording"])
        size = path.stat().st_size
        assert _eventually(lambda: path.stat().st_size > size)  # samples on disk
        child.send_signal(signum)
        assert child.wait(timeout=3 * HANG) == 0
    out = "".join(lines)
    assert f"recording closed: {path}" in out and "Traceback" not in out
    properties = recording_properties(path)
    assert properties["complete"] is True and properties["samples"] > 0


# -- the WebSocket ----------------------------------------------------------------------------
def _ws_url(server: DashboardServer) -> str:
    return server.url.replace("http://", "ws://") + "ws"


def test_a_browser_gets_the_window_then_frames_and_status(served: DashboardServer) -> None:
    from websockets.sync.client import connect

    frames: list[tuple[dict[str, float], np.ndarray]] = []
    statuses: list[dict[str, Any]] = []
    opened = time.time()
    with connect(_ws_url(served), open_timeout=HANG) as ws:
        deadline = time.monotonic() + HANG
        while (len(frames) < 10 or not statuses) and time.monotonic() < deadline:
            message = ws.recv(timeout=HANG)
            if isinstance(message, bytes):
                frames.append(decode_frame(message))
                ws.send(json.dumps({"drawn": int(frames[-1][0]["frame"])}))
            else:
                statuses.append(json.loads(message))
    first_header, first = frames[0]
    assert first.shape[1] >= 200 // 5  # the history so far, decimated
    assert first.shape[1] <= MAX_POINTS
    times = np.concatenate([cols[0] for _, cols in frames])
    assert np.all(np.diff(times) > 0)  # no bin twice, none out of order
    assert np.diff(times) == pytest.approx(5e-3, rel=1e-6)  # and none missing
    values = np.concatenate([cols[2] for _, cols in frames])
    assert np.nanmedian(values) == pytest.approx(0.0, abs=0.02)  # mN, unloaded
    assert all(h["bin_seconds"] == pytest.approx(5e-3) for h, _ in frames)
    # the wall time (time.time(), not a monotonic clock) at which the newest sample came
    assert opened - 10 * HANG < first_header["received"] <= time.time()
    assert statuses[0]["state"] == "running" and statuses[0]["clients"] >= 1
    latency = served.screen_latency()  # measured (its size: bench_live.py)
    assert latency.size >= 9 and np.all(latency > 0) and np.all(np.isfinite(latency))


def _handshake(server: DashboardServer, buffer: int | None = None,
               host: str = "127.0.0.1") -> socket.socket:
    """A socket that has sent a WebSocket handshake by hand (Host ``host``:port)."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if buffer is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, buffer)
    sock.settimeout(HANG)
    sock.connect(("127.0.0.1", server.port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET /ws HTTP/1.1\r\nHost: {host}:{server.port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    return sock


def _raw_handshake(server: DashboardServer, host: str) -> bytes:
    """The server's first answer to a handshake by hand with Host ``host``."""
    with _handshake(server, host=host) as sock:
        return sock.recv(4096)


def _raw_websocket(server: DashboardServer, buffer: int | None = None) -> socket.socket:
    """A WebSocket opened by hand, to misbehave with."""
    sock = _handshake(server, buffer)
    assert sock.recv(12) == b"HTTP/1.1 101"
    return sock


def test_a_browser_that_vanishes_ends_only_its_own_loop(served: DashboardServer,
                                                        capfd: pytest.CaptureFixture[str],
                                                        caplog: pytest.LogCaptureFixture
                                                        ) -> None:
    live, dashboard = served.dashboard.live, served.dashboard
    assert _eventually(lambda: dashboard.clients == 0)  # the other tests' browsers are gone
    for _ in range(3):
        sock = _raw_websocket(served)
        sock.recv(4096)
        # pull the plug: no close handshake, the connection is reset
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        sock.close()
    total = live.history.total
    assert _eventually(lambda: dashboard.clients == 0)
    time.sleep(0.2)
    assert live.running and live.history.total >= total + 150
    assert live.status.overruns == 0 and _get(served, "api/status")["state"] == "running"
    out, err = capfd.readouterr()
    assert "Traceback" not in out + err and "Exception" not in out + err
    assert not [r for r in caplog.records if r.levelname in ("WARNING", "ERROR", "CRITICAL")]


def test_a_stalled_browser_slows_neither_acquisition_nor_the_others(
        served: DashboardServer) -> None:
    from websockets.sync.client import connect

    live = served.dashboard.live
    stalled = _raw_websocket(served, buffer=4096)  # never reads again
    try:
        with connect(_ws_url(served), open_timeout=HANG) as ws:
            # the other browser keeps getting frames (how many per second: bench_live.py)
            t0, frames = time.monotonic(), 0
            while frames < 20 and time.monotonic() - t0 < HANG:
                frames += isinstance(ws.recv(timeout=HANG), bytes)
        assert frames == 20
        assert live.status.overruns == 0 and live.status.counters.dropped == 0
    finally:
        stalled.close()


def test_an_unplugged_source_is_shown_and_the_view_recovers(readout: mc.Readout,
                                                            tmp_path: Path,
                                                            unplugged: Any) -> None:
    from websockets.sync.client import connect

    source = _source(1e-4, unplugged, good=60, down=0.4)
    live = LiveReadout(source, readout, rate=1000, reconnect=0.1, tracking=None)
    states: list[str] = []
    messages: list[str] = []
    times: list[float] = []
    with live, DashboardServer(live, port=0, record_dir=tmp_path) as server, \
            connect(_ws_url(server), open_timeout=HANG) as ws:
        deadline = time.monotonic() + HANG
        while time.monotonic() < deadline and not (
                "disconnected" in states and states[-1] == "running" and len(times) > 200):
            message = ws.recv(timeout=HANG)
            if isinstance(message, bytes):
                times.extend(decode_frame(message)[1][0])
            else:
                status = json.loads(message)
                states.append(status["state"])
                messages.append(status["message"])
    assert "disconnected" in states and states[-1] == "running"
    assert any("retrying" in m for m in messages)
    gaps = np.diff(times)
    assert gaps.max() > 0.3 and np.all(gaps > 0)  # a gap, then the samples came back


# -- the server and the CLI -----------------------------------------------------------------
def test_a_port_in_use_is_one_clear_line(served: DashboardServer) -> None:
    with pytest.raises(MagciliaError) as err:
        bind_socket("127.0.0.1", served.port)
    assert str(err.value) == (f"127.0.0.1:{served.port} is already in use; choose another "
                              "with --port or stop what uses it")


def test_the_cli_reports_a_port_in_use_and_exits_2(served: DashboardServer, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["dashboard", "--port", str(served.port), "--tip-radius", "0.05mm",
                 "--record-dir", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.strip() == (f"magcilia: error: 127.0.0.1:{served.port} is already in use; "
                           "choose another with --port or stop what uses it")


def test_the_cli_serves_until_ctrl_c_and_stops_cleanly(tmp_path: Path) -> None:
    pexpect = pytest.importorskip("pexpect")
    child = pexpect.spawn(sys.executable, ["-m", "magcilia", "dashboard", "--port", "0",
                                           "--tip-radius", "0.05mm", "--record-dir",
                                           str(tmp_path)],
                          encoding="utf-8", timeout=3 * HANG, cwd=str(tmp_path))
    try:
        child.expect(r"http://127\.0\.0\.1:(\d+)/")
        port = int(child.match.group(1))
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/status", timeout=HANG) as r:
            assert json.loads(r.read())["state"] in ("taring", "running")
        child.sendintr()
        child.expect("stopped")
        child.expect(pexpect.EOF)
    finally:
        child.close()
    assert child.exitstatus == 0


# -- the page in a real browser ---------------------------------------------------------------
def _value_after_step(page: Any, source: SimulatedSource, force: float) -> None:
    """Set the simulated force (N) and wait until the page's value has come more than half the
    way (from a flagged reading: to within 0.05 mN)."""
    before = page.evaluate("window.magcilia.lastValue")
    target = force * 1e3
    near = abs(target - before) / 2 if before is not None else 0.05
    source.set_value(force)
    page.wait_for_function(f"() => {{ const v = window.magcilia.lastValue; "
                           f"return v !== null && Math.abs(v - {target}) < {near}; }}",
                           polling="raf", timeout=HANG * 1e3)


def test_the_page_follows_a_force_step_tares_records_and_shows_it_all(
        browser: Any, readout: mc.Readout, tmp_path: Path) -> None:
    from nptdms import TdmsFile

    from magcilia.io.recordings import read_samples

    source = _source(0.0)
    live = LiveReadout(source, readout, rate=1000, tare_at_start=True)
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    wait = HANG * 1e3  # ms
    records = tmp_path / "records"
    try:
        with live, DashboardServer(live, port=0, record_dir=records) as server:
            page.goto(server.url)
            page.wait_for_function("() => window.magcilia.lastValue !== null && "
                                   "window.magcilia.status && window.magcilia.status.tared",
                                   timeout=2 * wait)
            _value_after_step(page, source, 1.5e-4)  # the step of the issue: 0.15 mN
            _value_after_step(page, source, 0.0)
            source.set_value(3.6e-4)  # beyond the span: flagged, no value
            page.wait_for_function("() => window.magcilia.lastFlags & 1", timeout=wait)
            assert "OUTSIDE SPAN" in page.inner_text("#badges")
            assert page.inner_text("#value") == "—"
            _value_after_step(page, source, 0.0)

            # the buttons carry the page's token; the same request without it is refused (from
            # a second tab: the refusal is a console error there)
            other = browser.new_page()
            try:
                other.goto(server.url)
                refused = other.evaluate("fetch('api/tare', {method: 'POST'})"
                                         ".then(r => r.status)")
            finally:
                other.close()
            assert refused == 403 and live.status.state == "running"
            tares = sum(e.kind == "tare" for e in live.events)
            page.click("#tare")
            assert _eventually(lambda: sum(e.kind == "tare" for e in live.events) == tares + 1)

            page.click("#record")
            page.wait_for_function("() => window.magcilia.status.recording", timeout=wait)
            assert "Stop" in page.inner_text("#record")
            _value_after_step(page, source, 2e-4)
            time.sleep(1.0)  # a second of recording at 0.2 mN
            page.click("#record")
            page.wait_for_function("() => !window.magcilia.status.recording", timeout=wait)
            value = float(page.evaluate("window.magcilia.lastValue"))
            text = page.inner_text("#value")
            page.screenshot(path=str(tmp_path / "dashboard.png"))
    finally:
        page.close()
    assert value == pytest.approx(0.2, abs=0.03) and abs(float(text) - value) < 0.03
    assert not errors, errors

    (path,) = records.glob("live-*.tdms")
    assert read_samples(path, required=("voltage_V",))["voltage_V"].size > 5000
    recorded = TdmsFile.read(path)["readout"]["value"][:]
    assert np.nanmedian(recorded[-500:]) == pytest.approx(2e-4, rel=0.1)
    assert (tmp_path / "dashboard.png").stat().st_size > 20_000  # a page, drawn


def test_the_page_says_when_the_source_is_unplugged_and_recovers(
        browser: Any, readout: mc.Readout, tmp_path: Path, unplugged: Any) -> None:
    source = _source(0.0, unplugged, good=200, down=1.0)
    live = LiveReadout(source, readout, rate=1000, reconnect=0.1, tracking=None)
    page = browser.new_page()
    try:
        with live, DashboardServer(live, port=0, record_dir=tmp_path) as server:
            page.goto(server.url)
            page.wait_for_function("() => document.getElementById('badges').innerText"
                                   ".includes('DISCONNECTED')", timeout=HANG * 1e3)
            assert "retrying" in page.inner_text("#message")
            page.wait_for_function("() => document.getElementById('badges').innerText"
                                   " === 'OK'", timeout=HANG * 1e3)
            assert page.inner_text("#message") == ""
    finally:
        page.close()


def test_a_missing_server_package_is_named_before_anything_opens(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "uvicorn", None)  # import uvicorn -> ImportError
    opened: list[str] = []
    monkeypatch.setattr(LiveReadout, "start", lambda self: opened.append("start"))
    assert main(["dashboard", "--port", "0"]) == 2
    assert capsys.readouterr().err.strip() == (
        "magcilia: error: The browser dashboard needs the package 'uvicorn'; install "
        "it with: pip install 'magcilia[dashboard]'")
    assert opened == []
