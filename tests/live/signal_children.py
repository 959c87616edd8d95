"""Run ``magcilia live`` and ``magcilia dashboard`` many times side by side and stop each with a
signal at a chosen moment (a script for ``test_signals.py``; it prints one JSON list).

``python signal_children.py CASES.json FOLDER``: each case is ``{"id", "command": "dashboard" |
"live", "start": "exec" | "fork", "moment", "signal", "delay"}``. ``exec`` children are
``sys.executable -m magcilia`` (the real entry, with its imports); ``fork`` children are forks of
this process, which has imported magcilia and the server's packages once, running
``magcilia.cli.main`` (the same command, without a second of imports each: many of them fit in a
few seconds). Moments:

- ``setup``: ``delay`` s after the command's first log line (``-v``: "setting up the live
  read-out"), i.e. while it builds the read-out, opens the source or starts the server;
- ``listening``: ``delay`` s after the dashboard printed its URL (the server just listens);
- ``recording``: the dashboard's page read for its token, a recording started through
  ``POST /api/record`` and holding samples on disk, then the signal;
- ``running``: ``delay`` s after ``live`` printed its start event (status lines flowing);
- ``duration``: no signal; ``live --duration 1`` ends by itself.

Each result holds the case, the exit status (negative: killed by that signal; ``"hang"`` if it
did not end within ``HANG`` s of the signal, then killed), stdout, stderr and the recording
(path, and whether it reads complete with how many samples).
"""

from __future__ import annotations

import contextlib
import gc
import io
import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time
import traceback
import urllib.request
from pathlib import Path
from typing import Any

#: seconds a child may take to end after its signal (or to reach its moment) before it is
#: called a hang and killed: a guard, not a timing
HANG = 60.0
#: children alive at once
AT_ONCE = 12
SETUP_LINE = "magcilia: info: setting up the live read-out"
SPAN = ["--span", "-0.2:0.2"]  # skips the design-range search: a cheaper setup


def arguments(case: dict[str, Any], folder: Path) -> list[str]:
    """The command line of ``case`` (after ``magcilia``)."""
    verbose = ["-v"] if case["moment"] == "setup" else []
    if case["command"] == "dashboard":
        span = [] if case["moment"] == "setup" else SPAN  # the full setup, to land inside it
        return [*verbose, "dashboard", "--source", "sim", "--port", "0", *span,
                "--record-dir", str(folder / f"rec-{case['id']}")]
    duration = ["--duration", "1"] if case["moment"] == "duration" else []
    return [*verbose, "live", "--source", "sim", *SPAN, *duration]


class Child:
    """One running command, its files and how far its case has gone."""

    def __init__(self, case: dict[str, Any], folder: Path) -> None:
        self.case = case
        self.out = folder / f"{case['id']}.out"
        self.err = folder / f"{case['id']}.err"
        args = arguments(case, folder)
        with self.out.open("wb") as out, self.err.open("wb") as err:
            if case["start"] == "exec":
                self.popen: subprocess.Popen[bytes] | None = subprocess.Popen(
                    [sys.executable, "-m", "magcilia", *args], stdout=out, stderr=err,
                    stdin=subprocess.DEVNULL, cwd=folder)
                self.pid = self.popen.pid
            else:
                self.popen = None
                self.pid = _fork(args, out.fileno(), err.fileno())
        self.started = time.monotonic()
        self.due: float | None = None  # when to send the signal
        self.signalled: float | None = None
        self.status: int | str | None = None
        self.recording: str | None = None
        self.recording_size = 0
        self.cpu: float | None = None  # s of CPU the child used (forks)

    def text(self, which: str) -> str:
        path = self.out if which == "out" else self.err
        return path.read_text(errors="replace")

    def step(self) -> None:
        """Send the signal when the moment has come; note the end (or a hang)."""
        if self.status is None:
            self._reap()
        if self.status is not None:
            return
        now = time.monotonic()
        waited = now - (self.signalled if self.signalled is not None else self.started)
        if waited > HANG:
            os.kill(self.pid, signal.SIGKILL)
            self._reap(block=True)
            self.status = "hang"
        elif self.signalled is None and self._moment_came(now):
            os.kill(self.pid, getattr(signal, self.case["signal"]))
            self.signalled = now

    def _moment_came(self, now: float) -> bool:
        moment, delay = self.case["moment"], self.case["delay"]
        marker = {"setup": (SETUP_LINE, "err"), "running": ("start: sim", "out"),
                  "listening": ("magcilia dashboard: http://", "out")}.get(moment)
        if self.due is None:
            if marker is not None and marker[0] in self.text(marker[1]):
                self.due = now + delay
            elif moment == "recording" and (url := _url(self.text("out"))):
                self.recording = _start_recording(url)
                self.recording_size = Path(self.recording).stat().st_size
                self.due = math.inf  # once samples are on disk
        if self.recording is not None and self.due == math.inf \
                and Path(self.recording).stat().st_size > self.recording_size:
            self.due = now
        return self.due is not None and now >= self.due

    def _reap(self, block: bool = False) -> None:
        if self.popen is not None:
            code = self.popen.wait() if block else self.popen.poll()
            if code is not None:
                self.status = code
            return
        pid, status, usage = os.wait4(self.pid, 0 if block else os.WNOHANG)
        if pid:
            self.status = os.waitstatus_to_exitcode(status)
            self.cpu = usage.ru_utime + usage.ru_stime

    def result(self) -> dict[str, Any]:
        out: dict[str, Any] = {"case": self.case, "status": self.status,
                               "stdout": self.text("out"), "stderr": self.text("err"),
                               "recording": self.recording, "cpu_s": self.cpu,
                               "lived_s": time.monotonic() - self.started}
        if self.recording is not None:
            from magcilia.io.recording_file import recording_properties

            try:
                props = recording_properties(self.recording)
                out["complete"] = bool(props["complete"])
                out["samples"] = int(props["samples"])
            except Exception as exc:  # noqa: BLE001 (reported, the test fails on it)
                out["complete"], out["samples"] = f"unreadable: {exc}", 0
        return out


def _fork(args: list[str], out: int, err: int) -> int:
    """A fork of this process running ``magcilia ARGS`` with stdout and stderr on ``out`` and
    ``err``; it exits with the command's status."""
    pid = os.fork()
    if pid:
        return pid
    code = 70
    try:
        os.dup2(out, 1)
        os.dup2(err, 2)
        from magcilia.cli import main

        code = main(args)
    except BaseException:  # noqa: BLE001 (a traceback the test must see)
        traceback.print_exc()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return 0  # never reached


def _url(text: str) -> str | None:
    found = re.search(r"http://127\.0\.0\.1:\d+/", text)
    return found.group(0) if found else None


def _start_recording(url: str) -> str:
    """Read the page's token and start a recording as the page does; the file's path."""
    with urllib.request.urlopen(url, timeout=HANG) as page:
        token = re.findall(r'<meta name="magcilia-token" content="([^"]*)">',
                           page.read().decode())[0]
    request = urllib.request.Request(
        url + "api/record", method="POST", data=b'{"action": "start"}',
        headers={"X-Magcilia-Token": token, "Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=HANG) as answer:
        return str(json.loads(answer.read())["recording"])


async def _app(scope: Any, receive: Any, send: Any) -> None:
    """An ASGI app that does nothing (uvicorn's protocols are loaded for it)."""


def run(cases: list[dict[str, Any]], folder: Path) -> list[dict[str, Any]]:
    """Run every case, ``AT_ONCE`` at a time; their results in the order of ``cases``."""
    # what the forks share: the CLI and the server's packages, imported once (no threads yet)
    import uvicorn
    from uvicorn.config import WS_PROTOCOLS

    import magcilia.cli
    from magcilia.live.dashboard import require_server

    require_server()
    ws = "websockets-sansio" if "websockets-sansio" in WS_PROTOCOLS else "auto"
    uvicorn.Config(app=_app, ws=ws, lifespan="off").load()  # its protocols
    with contextlib.redirect_stdout(io.StringIO()):  # the read-out's code, compiled and cached
        assert magcilia.cli.main(["live", "--source", "sim", "--duration", "0.05"]) == 0
    assert threading.active_count() == 1, threading.enumerate()  # nothing runs: fork is safe
    gc.freeze()  # the forks share these pages instead of copying them when collecting
    sys.stdout.flush()
    waiting = list(cases)
    running: list[Child] = []
    done: list[Child] = []
    while waiting or running:
        while waiting and len(running) < AT_ONCE:
            running.append(Child(waiting.pop(0), folder))
        for child in running:
            child.step()
        for child in [c for c in running if c.status is not None]:
            running.remove(child)
            done.append(child)
        time.sleep(0.01)
    order = {case["id"]: i for i, case in enumerate(cases)}
    return [c.result() for c in sorted(done, key=lambda c: order[c.case["id"]])]


if __name__ == "__main__":
    results = run(json.loads(Path(sys.argv[1]).read_text()), Path(sys.argv[2]).resolve())
    print(json.dumps(results))
