"""The terminal view of ``magcilia live``: what it draws (no terminal), the JSON-lines stream, the
plain-text lines, a source unplugged mid-stream, and the real view under a pseudo-terminal (tmux
for the screen and the keys, pexpect for quitting)."""

from __future__ import annotations

import io
import json
import math
import re
import shutil
import signal
import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.acquire.source import Counters
from magcilia.cli import main
from magcilia.io.recording_file import recording_properties
from magcilia.io.recordings import read_samples
from magcilia.live import Event, Limits, LiveReadout, LiveSamples, LiveStatus
from magcilia.live.terminal import (
    SPARKS,
    big_text,
    current,
    format_value,
    render,
    sparkline,
    stream_json_lines,
    summary_line,
)

rich_console = pytest.importorskip("rich.console")



def text_of(renderable: object, width: int = 120) -> str:
    console = rich_console.Console(record=True, width=width, file=io.StringIO(),
                                   color_system=None)
    console.print(renderable)
    return console.export_text()


def make_status(state: str = "running", message: str = "") -> LiveStatus:
    return LiveStatus(state=state, message=message, counters=Counters(40000, 12, 3),
                      overruns=7, samples=4000, rate=1000.0, tared=True, correction=-3e-4,
                      drift=2e-8, noise=6.8e-6, recording="rec/live-1.tdms",
                      latency_median=2e-4, latency_p99=1.3e-3)


def make_samples(value: np.ndarray, flags: np.ndarray | None = None,
                 sigma: float = 2e-6) -> LiveSamples:
    m = value.size
    t = np.arange(m) / 1000.0
    flags = np.zeros(m, np.uint8) if flags is None else flags
    bad = np.where(flags != 0, np.nan, 1.0)
    return LiveSamples("force", "N", time=t, raw=np.full(m, 4e-3), value=value * bad,
                       sigma=np.full(m, sigma) * bad, flags=flags,
                       correction=np.full(m, -3e-4), received=1e9 + t, published=1e9 + t)


LIMITS = Limits("force", "N", (-3e-4, 3e-4), (-3e-4, 3e-4), 2e-6, "span")


# -- (a) what is drawn -------------------------------------------------------------------------
def test_render_value_sigma_flags_sparkline() -> None:
    ramp = np.linspace(-1e-4, 2e-4, 2000)
    value = np.concatenate([ramp, np.full(1000, 1e-4)])
    flags = np.zeros(value.size, np.uint8)
    flags[-40:-20] = 1  # 20 of the last 100 outside the span
    flags[-20:-10] = 4  # 10 saturated
    samples = make_samples(value, flags)
    events = [Event(0.0, "start", "sim at 10000 Hz"), Event(0.5, "tare", "zero at 3.9 mV"),
              Event(1.0, "recording", "started rec/live-1.tdms"),
              Event(2.0, "tare", "zero at 4.0 mV")]
    out = text_of(render(make_status(), samples, LIMITS, events, seconds=3.0, width=30))
    assert "+0.1000 ± 0.0020 mN" in out  # the mean of the good readings of the last 0.1 s
    assert "tip force" in out and "RUNNING" in out
    assert "OUTSIDE SPAN 20%" in out and "SATURATED 10%" in out and "FOLD" not in out
    line = next(x for x in out.splitlines() if "last 3 s" in x)
    assert SPARKS[0] in line and SPARKS[-1] in line  # the ramp spans the whole scale
    assert re.search(r"-0\.09\d* … 0\.19\d* mN", line), line
    assert "12 dropped (7 by overruns)" in out and "3 corrupt" in out
    assert "40000 delivered" in out
    assert "correction -0.3000 mV" in out and "recording: rec/live-1.tdms" in out
    assert "median 0.2 ms" in out and "p99 1.3 ms" in out
    assert "start: sim" not in out  # only the last three events
    assert out.count("tare: zero at") == 2 and "t tare" in out and "q quit" in out


def test_render_disconnected_stale_and_empty() -> None:
    samples = make_samples(np.full(500, 1e-4))
    status = make_status("disconnected", "sim: unplugged; retrying every 1 s")
    now = float(samples.published[-1]) + 2.5
    out = text_of(render(status, samples, LIMITS, [], now=now, seconds=4.0, width=40))
    assert "DISCONNECTED" in out and "unplugged; retrying" in out
    assert "STALE: last reading 2.5 s ago" in out
    spark = next(x for x in out.splitlines() if "last 4 s" in x)
    # the 0.5 s of readings sit 2.5 s back: the gap scrolls in from the right
    assert re.search(f" {SPARKS[3]}{{4,6}} {{24,26}} ", spark), spark
    empty = make_samples(np.zeros(0))
    out = text_of(render(make_status("starting"), empty, LIMITS))
    assert "no readings yet" in out and "STARTING" in out
    flagged = make_samples(np.full(200, 1e-4), np.full(200, 2, np.uint8))
    out = text_of(render(make_status(), flagged, LIMITS))
    assert "no good reading" in out and "FOLD 100%" in out


def test_pieces() -> None:
    assert format_value(1e-4 * 1e3, 2.1e-6 * 1e3) == ("+0.1000", "0.0021")
    assert format_value(-12.3456, 0.5) == ("-12.35", "0.50")
    assert format_value(math.nan, 1.0) == ("—", "—")
    rows = big_text("+0.25")
    assert len(rows) == 3 and len({len(r) for r in rows}) == 1 and "█" in "".join(rows)
    line, lo, hi = sparkline(np.arange(9.0), np.array([0, 1, 2, 3, 4, 5, 6, 7, np.nan]),
                             end=9.0, seconds=9.0, width=9)
    assert line == SPARKS + " " and (lo, hi) == (0.0, 7.0)
    assert sparkline(np.arange(3.0), np.full(3, np.nan), end=3, seconds=3, width=3)[0] == "   "
    r = current(make_samples(np.linspace(0, 1e-3, 1000)), window=0.1)
    assert r.count == 101 and r.value == pytest.approx(0.95e-3, rel=1e-3)
    line = summary_line(make_status(), make_samples(np.full(100, 1e-4)), LIMITS)
    assert "tip force +0.1000 ± 0.0020 mN" in line and "running:" in line


# -- (b) JSON lines ----------------------------------------------------------------------------
def paper_live() -> LiveReadout:
    setup = mc.Setup.paper(tip_radius=5e-5)
    source = SimulatedSource(setup, Script.constant(1e-4, "force"), rate=10000, realtime=True,
                             rng=0)
    return LiveReadout(source, mc.Readout(setup, "force", span=(-3e-4, 3e-4)))


def test_json_lines_from_a_live_readout() -> None:
    out = io.StringIO()
    with paper_live() as live:
        status = stream_json_lines(live, out, seconds=1.0)
    lines = [json.loads(x) for x in out.getvalue().splitlines()]
    assert lines[0]["event"] == "start"
    rows = [x for x in lines if "value" in x]
    # a real-time source: about 1000 in the second, never more; fewer when this machine lags
    # behind (a busy CI runner), so the lower bound only asks that values stream
    assert 50 <= len(rows) <= 1100 and status.state == "running"
    assert set(rows[0]) == {"t", "value", "sigma", "flags", "unit", "raw_V"}
    assert all(r["unit"] == "N" and r["flags"] == 0 for r in rows)
    value = np.array([r["value"] for r in rows])
    sigma = np.array([r["sigma"] for r in rows])
    assert np.all(sigma > 0) and np.all(np.diff([r["t"] for r in rows]) > 0)
    # SI: ≈ 1e-4 N. The reported σ (the sensor model's, untared) leaves out the simulated
    # amplifier noise, so compare with the readings' own scatter
    spread = value.std()
    assert abs(np.median(value) - 1e-4) < 0.05e-4
    assert np.mean(np.abs(value - 1e-4) < 4 * spread) > 0.99


def test_json_lines_every_and_cli(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["live", "--json-lines", "--duration", "1", "--tip-radius", "0.05mm",
                 "--every", "10"])
    out = capsys.readouterr().out
    assert code == 0
    lines = [json.loads(x) for x in out.splitlines()]
    rows = [x for x in lines if "value" in x]
    kinds = [x["event"] for x in lines if "event" in x]
    assert kinds[:2] == ["start", "tare"]
    assert 40 <= len(rows) <= 110  # every 10th of ~1000 readings (fewer on a lagging machine)
    assert np.allclose(np.diff([r["t"] for r in rows]), 0.01, atol=1e-6)
    # the simulated cilium rests for its first 3 s: ≈ 0 N after the tare
    tared = [r["value"] for r in rows if r["t"] > 0.6]
    assert abs(np.mean(tared)) < 2e-5


def test_plain_lines_when_not_a_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["live", "--duration", "1.2", "--tip-radius", "0.05mm"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("event:") and "start: sim" in out[0]
    status = [x for x in out if "| running:" in x]
    # one line a second and one at the end (one alone if a loaded machine wakes after 1.2 s)
    assert 1 <= len(status) <= 2 and "tip force" in status[0]
    assert re.search(r" [mµ]N ", status[0])  # the unit of the value's magnitude


@pytest.mark.parametrize(
    ("args", "match"),
    [(["--every", "0"], "--every must be"), (["--duration", "-1"], "--duration must be"),
     (["--source", "serial:/dev/magcilia-missing"], "does not exist")],
    ids=["every", "duration", "missing-port"],
)
def test_cli_errors(args: list[str], match: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["live", "--tip-radius", "0.05mm", *args]) == 2
    err = capsys.readouterr().err
    assert match in err and len(err.strip().splitlines()) == 1


def test_json_lines_into_head(magcilia_command: Any) -> None:
    # --duration far beyond the guards' timeouts: it must end with the pipe, not at --duration
    producer = subprocess.Popen([*magcilia_command.argv, "live", "--json-lines", "--tip-radius",
                                 "0.05mm", "--duration", "3600"], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, env=magcilia_command.env())
    assert producer.stdout is not None and producer.stderr is not None
    try:
        head = subprocess.run(["head", "-n", "3"], stdin=producer.stdout, capture_output=True,
                              check=True, timeout=120)
        producer.stdout.close()
        assert producer.wait(timeout=120) == 0
    finally:
        if producer.poll() is None:
            producer.kill()
            producer.wait()
    err = producer.stderr.read().decode()
    producer.stderr.close()
    assert "Traceback" not in err and "Error" not in err, err
    lines = head.stdout.decode().splitlines()
    assert len(lines) == 3 and json.loads(lines[0])["event"] == "start"


# -- (d) a source unplugged mid-stream ---------------------------------------------------------
def wait_until(check: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        if time.monotonic() > deadline:
            pytest.fail(f"no {what} within {timeout} s")
        time.sleep(0.02)


def test_unplugged_source_recovers(tmp_path: Path, unplugged: Any) -> None:
    setup = mc.Setup.paper(tip_radius=5e-5)
    source = unplugged(setup, Script.constant(1e-4, "force"), rate=10000, realtime=True, rng=0,
                       readout_noise=2e-5)
    readout = mc.Readout(setup, "force", span=(-3e-4, 3e-4))
    # the unplugged source fails at once; a long stall keeps a loaded machine's pauses from
    # counting as a second disconnection
    live = LiveReadout(source, readout, reconnect=0.2, stall=5.0)
    stream = io.StringIO()
    with live:
        path = live.start_recording(tmp_path / "r.tdms")
        streamer = threading.Thread(target=stream_json_lines, args=(live, stream),
                                    kwargs={"seconds": 600.0})  # ends with the read-out
        streamer.start()
        live.wait(200)
        source.unplug()
        wait_until(lambda: live.status.state == "disconnected", 30.0, "disconnection")
        time.sleep(0.5)  # a few failed reopenings
        down = live.history.total
        status = live.status
        samples = live.history.last(2.0, live.rate)
        out = text_of(render(status, samples, live.limits(), live.events, now=time.time() + 1))
        assert "DISCONNECTED" in out and "retrying every 0.2 s" in out
        assert "sim: device vanished" in out and "STALE" in out
        assert live.history.total == down and status.recording == str(path)
        source.plug()
        wait_until(lambda: live.status.state == "running", 30.0, "reconnection")
        back = live.wait(200)
        assert np.all(back.flags == 0) and np.median(back.value) == pytest.approx(1e-4, rel=0.05)
        assert np.all(back.time > samples.time[-1])  # the clock went on over the gap
        out = text_of(render(live.status, live.history.last(2.0, live.rate), live.limits(),
                             live.events, now=time.time()))
        assert "RUNNING" in out and "reconnected: sim is back" in out and "STALE" not in out
        live.stop_recording()
    streamer.join(60)
    assert not streamer.is_alive()
    kinds = [e.kind for e in live.events]
    assert kinds.count("disconnected") == 1 and kinds.count("reconnected") == 1
    events = [json.loads(x) for x in stream.getvalue().splitlines() if '"event"' in x]
    assert [e["event"] for e in events if e["event"] in ("disconnected", "reconnected")] == [
        "disconnected", "reconnected"]
    recorded = read_samples(path, required=("voltage_V",))
    assert recorded["voltage_V"].size > 3000 and recording_properties(path)["complete"]


# -- (c) the real view under a pseudo-terminal -------------------------------------------------
class Tmux:
    """A detached tmux session on a private socket, 100 x 30, running one shell command."""

    def __init__(self, tmp: Path, command: str) -> None:
        self.base = [shutil.which("tmux") or "tmux", "-S", str(tmp / "tmux.sock")]
        env = {"PATH": "/usr/bin:/bin", "TERM": "xterm-256color", "HOME": str(tmp),
               "LANG": "C.UTF-8"}
        subprocess.run([*self.base, "new-session", "-d", "-x", "100", "-y", "30", "-c", str(tmp),
                        "-e", "TERM=xterm-256color", "-e", "LANG=C.UTF-8", command],
                       check=True, env=env, timeout=10)
        self.env = env

    def screen(self) -> str:
        return subprocess.run([*self.base, "capture-pane", "-p"], capture_output=True,
                              text=True, check=True, env=self.env, timeout=10).stdout

    def keys(self, *keys: str) -> None:
        subprocess.run([*self.base, "send-keys", *keys], check=True, env=self.env, timeout=10)

    def expect(self, pattern: str, timeout: float = 60.0) -> re.Match[str]:
        deadline = time.monotonic() + timeout
        while True:
            screen = self.screen()
            if found := re.search(pattern, screen):
                return found
            if time.monotonic() > deadline:
                pytest.fail(f"{pattern!r} not on the screen within {timeout} s:\n{screen}")
            time.sleep(0.1)

    def close(self) -> None:
        subprocess.run([*self.base, "kill-server"], check=False, env=self.env, timeout=10,
                       capture_output=True)


@pytest.mark.skipif(shutil.which("tmux") is None, reason="tmux is not installed")
def test_view_in_tmux_starts_updates_tares_records_quits(tmp_path: Path,
                                                         magcilia_command: Any) -> None:
    command = (f"{magcilia_command.shell()} live --tip-radius 0.05mm --record-dir rec "
               "2> err.txt; echo $? > rc.txt; stty -a > stty.txt; sleep 600")
    tmux = Tmux(tmp_path, command)
    try:
        first = tmux.expect(r"(\d+) readings at 1000 Hz")
        tmux.expect(r"tip force: [+-]\d\.\d+ ± \d\.\d+ mN")
        tmux.expect(r"tare: correction")  # the tare at start
        second = tmux.expect(rf"(?<!\d)(?!{first[1]}\b)(\d+) readings at 1000 Hz")
        assert int(second[1]) > int(first[1])  # it updates
        assert "last 10 s" in tmux.screen() and "flags: all" in tmux.screen()
        tmux.keys("t")
        tmux.expect(r"taring: keep the cilium unloaded")
        tmux.expect(r"(?s)tare: zero at.*tare: zero at")  # a second tare event
        tmux.keys("r")
        tmux.expect(r"recording: rec/live-\d{8}-\d{6}\.tdms")
        time.sleep(0.5)
        tmux.keys("r")
        saved = tmux.expect(r"recording saved: (rec/live-\d{8}-\d{6}\.tdms)")
        tmux.expect(r"recording: off")
        path = tmp_path / saved[1]
        assert recording_properties(path)["complete"]
        assert read_samples(path, required=("voltage_V",))["voltage_V"].size > 1000
        tmux.keys("q")
        wait_until((tmp_path / "rc.txt").is_file, 60.0, "exit")
        assert (tmp_path / "rc.txt").read_text().strip() == "0"
        assert (tmp_path / "err.txt").read_text() == ""
        after = tmux.expect(r"magcilia live: running: \d+ samples")
        assert "Traceback" not in after.string and "╭" not in after.string  # screen restored
        stty = (tmp_path / "stty.txt").read_text().split()
        assert "icanon" in stty and "echo" in stty  # the terminal's settings are back
    finally:
        tmux.close()


@pytest.mark.parametrize("how", ["q", "ctrl-c", "sigterm"])
def test_view_under_pexpect_quits_cleanly(how: str, tmp_path: Path,
                                          magcilia_command: Any) -> None:
    pexpect = pytest.importorskip("pexpect")
    program, *args = magcilia_command.argv
    bare = {"PATH": "/usr/bin:/bin", "TERM": "xterm-256color", "LANG": "C.UTF-8",
            "HOME": str(tmp_path)}
    # a stall long enough for a loaded machine: each expect waits up to 90 s
    child = pexpect.spawn(program, [*args, "live", "--tip-radius", "0.05mm", "--record-dir",
                                    "rec"],
                          dimensions=(30, 100), cwd=str(tmp_path),
                          env=magcilia_command.env(bare),
                          encoding="utf-8", codec_errors="replace", timeout=90)
    try:
        child.expect("tip force")
        child.expect("readings at 1000 Hz")
        child.sendline("r")  # a recording is open when it is told to quit
        child.expect(r"recording: rec/live-")
        if how == "q":
            child.send("q")
        elif how == "ctrl-c":
            child.sendcontrol("c")
        else:
            child.kill(signal.SIGTERM)
        child.expect("magcilia live: ")
        child.expect(pexpect.EOF)
        child.close()
        assert child.exitstatus == 0, child.before
        assert "Traceback" not in (child.before or "")
        (path,) = (tmp_path / "rec").glob("live-*.tdms")
        assert recording_properties(path)["complete"]  # closed complete, not half-written
    finally:
        if child.isalive():
            child.terminate(force=True)
