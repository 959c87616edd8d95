"""The browser dashboard: decimation and frames, the HTTP and WebSocket API on a real server,
faults (browsers that vanish or stall, a port in use, an unplugged source), the CLI, and the page
itself in a headless Chromium (the value follows a force step in time, tare, record, screenshot).
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import socket
import struct
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
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
from magcilia.live.history import COLUMNS

SETUP = mc.Setup.paper(tip_radius=5e-5)
SPAN = (-3e-4, 3e-4)
ROOT = Path(__file__).resolve().parents[2]
SCREENSHOT = ROOT / "docs" / "images" / "dashboard.png"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync"]
#: the stated sample-to-screen budget (p99), s
BUDGET = 0.25


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


def _get(server: DashboardServer, path: str, method: str = "GET") -> Any:
    request = urllib.request.Request(server.url + path, method=method)
    with urllib.request.urlopen(request, timeout=5) as response:
        body = response.read()
        kind = response.headers["Content-Type"]
    return json.loads(body) if kind.startswith("application/json") else body


def _eventually(condition: Any, timeout: float = 3.0) -> bool:
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


def test_tare_is_asked_for_and_noted(served: DashboardServer) -> None:
    live = served.dashboard.live
    before = sum(e.kind == "tare" for e in live.events)
    assert _get(served, "api/tare", "POST") == {"tare": "started"}
    assert _eventually(lambda: sum(e.kind == "tare" for e in live.events) == before + 1)


# -- the WebSocket ----------------------------------------------------------------------------
def _ws_url(server: DashboardServer) -> str:
    return server.url.replace("http://", "ws://") + "ws"


def test_a_browser_gets_the_window_then_frames_and_status(served: DashboardServer) -> None:
    from websockets.sync.client import connect

    frames: list[tuple[dict[str, float], np.ndarray]] = []
    statuses: list[dict[str, Any]] = []
    with connect(_ws_url(served), open_timeout=5) as ws:
        deadline = time.monotonic() + 3
        while (len(frames) < 10 or not statuses) and time.monotonic() < deadline:
            message = ws.recv(timeout=2)
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
    assert time.time() - first_header["received"] < 2
    assert statuses[0]["state"] == "running" and statuses[0]["clients"] >= 1
    latency = served.screen_latency()
    assert latency.size >= 9 and np.all(latency > 0) and np.median(latency) < 0.5


def _raw_websocket(server: DashboardServer, buffer: int | None = None) -> socket.socket:
    """A WebSocket opened by hand, to misbehave with."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if buffer is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, buffer)
    sock.settimeout(5)
    sock.connect(("127.0.0.1", server.port))
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET /ws HTTP/1.1\r\nHost: 127.0.0.1:{server.port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
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
        with connect(_ws_url(served), open_timeout=5) as ws:
            t0, frames = time.monotonic(), 0
            while time.monotonic() - t0 < 1.5:
                frames += isinstance(ws.recv(timeout=2), bytes)
        assert frames >= 0.6 * 1.5 * served.dashboard.fps
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
            connect(_ws_url(server), open_timeout=5) as ws:
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and not (
                "disconnected" in states and states[-1] == "running" and len(times) > 200):
            message = ws.recv(timeout=2)
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
    child = pexpect.spawn(sys.executable, ["-c", "from magcilia.cli import run; run()",
                                           "dashboard", "--port", "0", "--tip-radius", "0.05mm",
                                           "--record-dir", str(tmp_path)],
                          encoding="utf-8", timeout=20)
    try:
        child.expect(r"http://127\.0\.0\.1:(\d+)/")
        port = int(child.match.group(1))
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/status", timeout=5) as r:
            assert json.loads(r.read())["state"] in ("taring", "running")
        child.sendintr()
        child.expect("stopped")
        child.expect(pexpect.EOF)
    finally:
        child.close()
    assert child.exitstatus == 0


# -- the page in a real browser ---------------------------------------------------------------
def _find_chromium() -> str | None:
    for candidate in ("/usr/bin/chromium", shutil.which("chromium"),
                      shutil.which("chromium-browser")):
        if candidate and Path(candidate).exists():
            return candidate
    return None


@pytest.fixture(scope="session")
def chromium() -> str:
    """Debian's Chromium, installed with apt-get where it is missing and we may."""
    path = _find_chromium()
    if path is not None:
        return path
    if not (hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("apt-get")):
        pytest.skip("no Chromium: not installed, and installing it needs root and apt-get")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    why = "apt-get install -y chromium did not install it"
    try:
        for command in (["apt-get", "install", "-y", "chromium"], ["apt-get", "update"],
                        ["apt-get", "install", "-y", "chromium"]):
            subprocess.run(command, env=env, capture_output=True, timeout=600, check=False)
            if _find_chromium():
                break
    except subprocess.TimeoutExpired:
        why = "apt-get took longer than 600 s"
    path = _find_chromium()
    if path is None:
        pytest.skip(f"no Chromium: {why}")
    return path


@pytest.fixture(scope="module")
def browser(chromium: str) -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as p:
        launched = p.chromium.launch(executable_path=chromium, headless=True,
                                     args=CHROMIUM_ARGS)
        yield launched
        launched.close()


def _value_after_step(page: Any, source: SimulatedSource, force: float) -> float:
    """Seconds from ``set_value(force)`` (N) until the page's value has come more than half
    the way (from a flagged reading: until it is within 0.05 mN)."""
    before = page.evaluate("window.magcilia.lastValue")
    target = force * 1e3
    near = abs(target - before) / 2 if before is not None else 0.05
    t0 = time.monotonic()
    source.set_value(force)
    page.wait_for_function(f"() => {{ const v = window.magcilia.lastValue; "
                           f"return v !== null && Math.abs(v - {target}) < {near}; }}",
                           polling="raf", timeout=5000)
    return time.monotonic() - t0


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
    steps: list[float] = []
    try:
        with live, DashboardServer(live, port=0, record_dir=tmp_path) as server:
            page.goto(server.url)
            page.wait_for_function("() => window.magcilia.lastValue !== null && "
                                   "window.magcilia.status && window.magcilia.status.tared",
                                   timeout=10000)
            time.sleep(0.5)
            # the step the issue asks for: 0.15 mN, then back and a few more for the picture
            steps.append(_value_after_step(page, source, 1.5e-4))
            time.sleep(1.0)
            steps.append(_value_after_step(page, source, 0.0))
            time.sleep(0.8)
            steps.append(_value_after_step(page, source, -1e-4))
            time.sleep(0.8)
            source.set_value(3.6e-4)  # beyond the span: flagged, no value
            page.wait_for_function("() => window.magcilia.lastFlags & 1", timeout=5000)
            assert "OUTSIDE SPAN" in page.inner_text("#badges")
            assert page.inner_text("#value") == "—"
            time.sleep(0.6)
            steps.append(_value_after_step(page, source, 0.0))
            time.sleep(0.5)

            tares = sum(e.kind == "tare" for e in live.events)
            page.click("#tare")
            assert _eventually(lambda: sum(e.kind == "tare" for e in live.events) == tares + 1)

            page.click("#record")
            page.wait_for_function("() => window.magcilia.status.recording", timeout=5000)
            assert "Stop" in page.inner_text("#record")
            steps.append(_value_after_step(page, source, 2e-4))
            time.sleep(1.0)
            page.click("#record")
            page.wait_for_function("() => !window.magcilia.status.recording", timeout=5000)
            time.sleep(0.8)
            value = float(page.evaluate("window.magcilia.lastValue"))
            text = page.inner_text("#value")
            SCREENSHOT.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(SCREENSHOT))
            screen = server.screen_latency()
    finally:
        page.close()
    print(f"\nstep to page: {', '.join(f'{s * 1e3:.0f}' for s in steps)} ms; screen latency "
          f"median {np.median(screen) * 1e3:.1f} ms, p99 {np.quantile(screen, 0.99) * 1e3:.1f} "
          f"ms over {screen.size} frames")
    assert max(steps) < BUDGET and np.median(steps) < 0.15
    assert np.median(screen) < 0.1 and np.quantile(screen, 0.99) < BUDGET
    assert value == pytest.approx(0.2, abs=0.03) and abs(float(text) - value) < 0.03
    assert not errors, errors

    (path,) = tmp_path.glob("live-*.tdms")
    assert read_samples(path, required=("voltage_V",))["voltage_V"].size > 5000
    recorded = TdmsFile.read(path)["readout"]["value"][:]
    assert np.nanmedian(recorded[-500:]) == pytest.approx(2e-4, rel=0.1)
    assert SCREENSHOT.stat().st_size > 20_000


def test_the_page_says_when_the_source_is_unplugged_and_recovers(
        browser: Any, readout: mc.Readout, tmp_path: Path, unplugged: Any) -> None:
    source = _source(0.0, unplugged, good=200, down=1.0)
    live = LiveReadout(source, readout, rate=1000, reconnect=0.1, tracking=None)
    page = browser.new_page()
    try:
        with live, DashboardServer(live, port=0, record_dir=tmp_path) as server:
            page.goto(server.url)
            page.wait_for_function("() => document.getElementById('badges').innerText"
                                   ".includes('DISCONNECTED')", timeout=5000)
            assert "retrying" in page.inner_text("#message")
            page.wait_for_function("() => document.getElementById('badges').innerText"
                                   " === 'OK'", timeout=5000)
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
        "magcilia: error: The browser dashboard needs the optional package 'uvicorn'; install "
        "it with: pip install 'magcilia[dashboard]'")
    assert opened == []
