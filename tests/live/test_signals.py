"""Every way ``magcilia live`` and ``magcilia dashboard`` are stopped — Ctrl-C (SIGINT), SIGTERM
or a closed SSH session (SIGHUP) at any moment, ``--duration`` — is one clean stop: exit status
0, no traceback, the last line says so, an open recording closed complete.

The mechanisms first, in-process: a signal is a stop request (never an exception thrown into
whatever runs), the views end on it, and the dashboard's server is really gone when ``stop()``
returns even after a Ctrl-C interrupted the wait (on Python ≤ 3.12 an interrupted
``Thread.join`` marks a running thread as ended: the server's socket was then closed under it,
the race behind a traceback in uvicorn's ``_stop_serving``) or the start. Then the commands
themselves, run side by side and stopped at several moments (``signal_children.py``): many
forks of one process that imported magcilia once (so that a 1-in-10 race is met with high
probability within a few seconds) and a few ``python -m magcilia`` (the real entry).
"""

from __future__ import annotations

import io
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.cli import main
from magcilia.cli._signals import STOP_SIGNALS, stop_signals
from magcilia.live import LiveReadout
from magcilia.live import dashboard as dashboard_module
from magcilia.live.dashboard import DashboardServer, bind_socket
from magcilia.live.terminal import run_lines, stream_json_lines

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")

SETUP = mc.Setup.paper(tip_radius=5e-5)
#: seconds any single wait may take before a test calls it a hang (not a timing)
HANG = 30.0
#: each case's count: a few by default (~40 children, a few seconds), many with
#: MAGCILIA_FUZZ=long
REPEAT = 5 if os.environ.get("MAGCILIA_FUZZ") == "long" else 1


def _live() -> LiveReadout:
    source = SimulatedSource(SETUP, Script.constant(0.0, "force"), rate=10000.0, realtime=True,
                             rng=0, readout_noise=2e-5)
    return LiveReadout(source, mc.Readout(SETUP, "force", span=(-3e-4, 3e-4)), rate=1000,
                       tare_at_start=False)


# -- a signal is a stop request ----------------------------------------------------------------
def test_the_first_signal_is_the_request_the_others_are_ignored() -> None:
    before = {name: signal.getsignal(getattr(signal, name)) for name in STOP_SIGNALS}
    with stop_signals() as stop:
        assert not stop.requested and not stop()
        signal.raise_signal(signal.SIGTERM)  # nothing is raised into this code
        assert stop.signal == "SIGTERM" and stop()
        signal.raise_signal(signal.SIGINT)
        signal.raise_signal(signal.SIGHUP)
        assert stop.signal == "SIGTERM"  # the first one counts
        stop.wait()  # returns at once: a stop was requested
    assert {name: signal.getsignal(getattr(signal, name)) for name in STOP_SIGNALS} == before


def test_waiting_ends_at_the_request_or_when_the_condition_holds() -> None:
    with stop_signals() as stop:
        ends = time.monotonic() + 0.3
        stop.wait(until=lambda: time.monotonic() > ends)
        assert not stop.requested
        timer = threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT))
        timer.start()
        stop.wait()
        timer.join()
        assert stop.signal == "SIGINT"


def test_outside_the_main_thread_nothing_is_installed() -> None:
    seen: list[object] = []

    def inside() -> None:
        with stop_signals() as stop:
            seen.append(stop.requested)

    before = signal.getsignal(signal.SIGINT)
    worker = threading.Thread(target=inside)
    worker.start()
    worker.join(HANG)
    assert seen == [False] and signal.getsignal(signal.SIGINT) is before


@pytest.mark.parametrize("view", ["lines", "json"])
def test_the_views_end_on_the_request_with_their_last_line(view: str) -> None:
    out = io.StringIO()
    asked: list[bool] = []

    def stop() -> bool:  # a stop is requested at the third look
        asked.append(len(asked) >= 2)
        return asked[-1]

    with _live() as live:
        live.wait(50)
        if view == "lines":
            status = run_lines(live, out, interval=HANG, seconds=HANG, stop=stop)
        else:
            status = stream_json_lines(live, out, seconds=HANG, stop=stop)
    assert status.state == "running"
    assert asked == [False, False, True]  # it ended at the request, not at its time limit
    lines = out.getvalue().splitlines()
    if view == "lines":  # the status at the stop, as at the end of --duration
        assert lines[0].startswith("event:") and "| running: " in lines[-1]
    else:
        assert all(json.loads(line) for line in lines)


# -- the dashboard's server ends before stop() returns ---------------------------------------------
@pytest.fixture
def thread_errors(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """What any thread raised while the test ran (threading.excepthook)."""
    errors: list[str] = []
    monkeypatch.setattr(threading, "excepthook",
                        lambda args: errors.append(f"{args.thread}: {args.exc_value!r}"))
    return errors


def _server_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "magcilia-dashboard"]


def _port_is_free(port: int) -> bool:
    try:
        bind_socket("127.0.0.1", port).close()
    except mc.MagciliaError:
        return False
    return True


def test_a_ctrl_c_in_wait_still_stops_the_server_before_stop_returns(
        tmp_path: Path, thread_errors: list[str]) -> None:
    live = _live()
    server = DashboardServer(live, port=0, record_dir=tmp_path)
    with server:
        port = server.port
        main = threading.main_thread().ident
        assert main is not None
        threading.Timer(0.3, signal.pthread_kill, (main, signal.SIGINT)).start()
        with pytest.raises(KeyboardInterrupt):
            server.wait()  # a real SIGINT lands in it, as Ctrl-C does in serve()
    assert not _server_threads() and not server.serving
    assert _port_is_free(port) and thread_errors == []


def test_an_interrupted_start_leaves_no_server_behind(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, thread_errors: list[str]) -> None:
    class Interrupted:  # the dashboard's clock: Ctrl-C once the server's thread has started
        time, sleep = staticmethod(time.time), staticmethod(time.sleep)

        @staticmethod
        def monotonic() -> float:
            raise KeyboardInterrupt

    monkeypatch.setattr(dashboard_module, "time", Interrupted)
    server = DashboardServer(_live(), port=0, record_dir=tmp_path)
    with pytest.raises(KeyboardInterrupt):
        server.start()
    monkeypatch.undo()
    assert not _server_threads() and _port_is_free(server.port) and thread_errors == []
    server.stop()  # idempotent


# -- the commands, stopped at every moment ---------------------------------------------------------
def _cases() -> list[dict[str, Any]]:
    """The moments and signals (signal_children.py says what each moment is)."""
    cases: list[dict[str, Any]] = []
    # the real entry, python -m magcilia (first: the slowest to start)
    real = [("dashboard", "setup", "SIGINT"), ("dashboard", "recording", "SIGTERM"),
            ("live", "running", "SIGINT")]

    def add(command: str, start: str, moment: str, sig: str, delay: float = 0.0) -> None:
        cases.append({"id": f"{len(cases)}-{start}-{command}-{moment}-{sig}-{delay:g}",
                      "command": command, "start": start, "moment": moment, "signal": sig,
                      "delay": delay})

    for command, moment, sig in real:
        add(command, "exec", moment, sig)
    for _ in range(REPEAT):
        for sig in ("SIGINT", "SIGTERM", "SIGHUP"):
            for delay in (0.0, 0.05, 0.1, 0.2, 0.4):  # from the setup through the start
                add("dashboard", "fork", "setup", sig, delay)
            for delay in (0.0, 0.02, 0.1):  # the server has just begun to listen
                add("dashboard", "fork", "listening", sig, delay)
            for _ in range(2):
                add("dashboard", "fork", "recording", sig)
            add("live", "fork", "running", sig)
        for sig in ("SIGINT", "SIGTERM"):
            for delay in (0.0, 0.1):
                add("live", "fork", "setup", sig, delay)
        add("live", "fork", "duration", "")
    return cases


@pytest.fixture(scope="module")
def stopped(tmp_path_factory: pytest.TempPathFactory,
            magcilia_command: Any) -> list[dict[str, Any]]:
    """Every case run (side by side), with what each child did."""
    folder = tmp_path_factory.mktemp("signals")
    (folder / "cases.json").write_text(json.dumps(_cases()))
    script = Path(__file__).with_name("signal_children.py")
    done = subprocess.run([sys.executable, str(script), str(folder / "cases.json"),
                           str(folder)], capture_output=True, text=True, timeout=600,
                          check=False, env=magcilia_command.env(), cwd=folder)
    assert done.returncode == 0, done.stderr
    results: list[dict[str, Any]] = json.loads(done.stdout)
    return results


def test_every_signal_at_every_moment_ends_with_status_0_and_no_traceback(
        stopped: list[dict[str, Any]]) -> None:
    assert len(stopped) == len(_cases())
    failed = [(r["case"]["id"], r["status"],
               [x for x in r["stderr"].splitlines() if not x.startswith("magcilia: info: ")],
               r["stdout"][-300:])
              for r in stopped
              if r["status"] != 0 or any(not x.startswith("magcilia: info: ")
                                         for x in r["stderr"].splitlines())]
    assert failed == [], failed  # stderr: only the -v lines, never a traceback or an error


def test_the_dashboard_says_it_stopped_and_names_the_recording_it_closed(
        stopped: list[dict[str, Any]]) -> None:
    for r in (r for r in stopped if r["case"]["command"] == "dashboard"):
        lines = r["stdout"].splitlines()
        assert lines[-1] == "magcilia dashboard: stopped", (r["case"]["id"], lines)
        if r["recording"] is not None:
            assert lines[-2] == f"recording closed: {r['recording']}", (r["case"]["id"], lines)


def test_an_open_recording_is_closed_complete_whatever_the_signal(
        stopped: list[dict[str, Any]]) -> None:
    recorded = [r for r in stopped if r["case"]["moment"] == "recording"]
    assert {r["case"]["signal"] for r in recorded} == {"SIGINT", "SIGTERM", "SIGHUP"}
    for r in recorded:
        assert r["complete"] is True and r["samples"] > 0, (r["case"]["id"], r["complete"])


def test_live_ends_on_a_signal_as_at_the_end_of_its_duration(
        stopped: list[dict[str, Any]]) -> None:
    for r in (r for r in stopped if r["case"]["command"] == "live"):
        lines = r["stdout"].splitlines()
        if r["case"]["moment"] == "setup" and "start: sim" not in r["stdout"]:
            assert lines == [], (r["case"]["id"], lines)  # stopped before it opened anything
        else:  # the status line at the stop, as --duration prints it at its end
            assert " | " in lines[-1] and not lines[-1].startswith("event:"), lines[-3:]


def test_the_moments_were_met(stopped: list[dict[str, Any]]) -> None:
    """The cases reached what they were meant to: some setups stopped before the server
    listened, the rest after; every recording case had samples on disk."""
    setups = [r for r in stopped
              if r["case"]["command"] == "dashboard" and r["case"]["moment"] == "setup"]
    before = [r for r in setups if "http://" not in r["stdout"]]
    assert before, "no signal landed before the server listened"
    listening = [r for r in stopped if r["case"]["moment"] == "listening"]
    assert all("http://" in r["stdout"] for r in listening)
    assert sorted(r["case"]["id"] for r in stopped) == sorted(c["id"] for c in _cases())


def test_a_port_is_free_once_the_server_stopped(tmp_path: Path) -> None:
    """The port a stopped server used can be listened on again at once."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = DashboardServer(_live(), port=port, record_dir=tmp_path)
    with server:
        pass
    assert _port_is_free(port)


def test_a_server_that_dies_ends_the_command_with_one_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        thread_errors: list[str]) -> None:
    import uvicorn

    async def boom(self: Any) -> None:
        raise RuntimeError("boom")

    monkeypatch.setattr(uvicorn.Server, "main_loop", boom)  # dies once it listens
    assert main(["dashboard", "--port", "0", "--span", "-0.2:0.2", "--record-dir",
                 str(tmp_path)]) == 2
    out, err = capsys.readouterr()
    assert "magcilia dashboard: http://" in out and "stopped" not in out
    assert err == "magcilia: error: the dashboard server stopped: RuntimeError: boom\n"
    assert not _server_threads() and thread_errors == []
