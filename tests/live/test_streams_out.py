"""Streams out (issue 30 item 2): the LSL stream's channels, rows and description, the example
consumers run against a short live read-out (LSL on localhost; the dashboard's WebSocket with its
token), and the one-line error without pylsl."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import uuid
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.simulated import Script, SimulatedSource
from magcilia.live import LiveReadout
from magcilia.live.history import LiveSamples
from magcilia.live.lsl import StreamChannel, stream_channels, stream_info, stream_rows
from magcilia.readout.protocol import Flag

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
pylsl = pytest.importorskip("pylsl", reason="pylsl (the lsl extra) is not installed")


def _setup() -> mc.Setup:
    from magcilia.io import presets

    return presets.setup("force-sensor")


def _live(value: float = 1e-5) -> LiveReadout:
    setup = _setup()
    readout = mc.Readout(setup, "force", span=(-2e-5, 2e-5))
    source = SimulatedSource(setup, Script.constant(value, "force"), rate=10000.0,
                             realtime=True, rng=0, readout_noise=2e-5)
    return LiveReadout(source, readout, rate=500, tare_at_start=False)


def _samples(value: np.ndarray, sigma: np.ndarray, flags: np.ndarray) -> LiveSamples:
    m = len(flags)
    zeros = np.zeros(m)
    return LiveSamples("force", "N", np.arange(m) * 0.01, zeros, value, sigma,
                       flags.astype(np.uint16), zeros, zeros, zeros)


# -- the stream's construction (no sockets) ------------------------------------------------------

def test_channels_rows_and_description_of_one_output() -> None:
    live = _live()
    chans = stream_channels(live.sensor)
    assert chans == (StreamChannel("force", "N", "value"), StreamChannel("sigma_force", "N",
                     "sigma"), StreamChannel("flags", "bits", "flags"))
    flags = np.array([0, int(Flag.OUTSIDE_SPAN), 0])
    rows = stream_rows(_samples(np.array([1e-6, np.nan, 3e-6]), np.array([1e-7, np.nan, 2e-7]),
                                flags))
    np.testing.assert_array_equal(rows[[0, 2]], [[1e-6, 1e-7, 0], [3e-6, 2e-7, 0]])
    assert np.isnan(rows[1, :2]).all() and rows[1, 2] == int(Flag.OUTSIDE_SPAN)
    root = ET.fromstring(stream_info(live, "cil-test").as_xml())
    assert root.findtext("name") == "cil-test" and root.findtext("type") == "Force"
    assert root.findtext("channel_format") == "double64"
    assert float(root.findtext("nominal_srate") or 0) == 500.0
    labels = [(c.findtext("label"), c.findtext("unit"), c.findtext("type"))
              for c in root.iter("channel")]
    assert labels == [("force", "N", "value"), ("sigma_force", "N", "sigma"),
                      ("flags", "bits", "flags")]
    assert root.findtext("desc/magcilia/samples_checked") == "yes"
    assert root.findtext("desc/magcilia/source") == "sim"


def test_channels_of_force_vectors_and_arrays() -> None:
    from magcilia.live.readouts import LiveSensor

    vector = LiveSensor(None, None, "vector", "force", "N", ("x", "y", "z"), "T", np.zeros(3),
                        np.zeros(3), (2,), (), (), np.zeros((1, 2)), 1e-5)
    assert [c.label for c in stream_channels(vector)] == ["fx", "fy", "sigma_fx", "sigma_fy",
                                                          "flags"]
    array = LiveSensor(None, None, "array", "force", "N", ("a",), "T", np.zeros(1),
                       np.zeros(1), (2, 2), (2,), ("c1", "c2"), np.zeros((2, 2)), 1e-5)
    assert [c.label for c in stream_channels(array)] == [
        "c1.fx", "c1.fy", "c2.fx", "c2.fy", "sigma_c1.fx", "sigma_c1.fy", "sigma_c2.fx",
        "sigma_c2.fy", "c1.flags", "c2.flags"]
    value = np.arange(12.0).reshape(3, 2, 2)
    rows = stream_rows(_samples(value, value / 10, np.array([[0, 1], [2, 3], [4, 5]])))
    np.testing.assert_array_equal(rows[1], [4, 5, 6, 7, 0.4, 0.5, 0.6, 0.7, 2, 3])


def test_bad_stream_name_and_missing_pylsl_are_one_line_errors() -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    bad = subprocess.run([sys.executable, "-m", "magcilia", "live", "--lsl", "two words",
                          "--duration", "1"], capture_output=True, text=True, timeout=120,
                         env=env, check=False)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert bad.stderr.startswith("magcilia: error: --lsl")
    code = ("import sys; sys.modules['pylsl'] = None; from magcilia.cli import run; "
            "sys.argv = ['magcilia', 'live', '--lsl', '--duration', '1']; run()")
    missing = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             timeout=120, env=env, check=False)
    assert missing.returncode != 0 and "Traceback" not in missing.stderr
    lines = [x for x in missing.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and "pylsl" in lines[0] and "lsl" in lines[0]


# -- the example consumers against a short live run ----------------------------------------------

def _consumer(*args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, *args], capture_output=True, text=True,
                          timeout=timeout, check=False)


def test_lsl_consumer_receives_the_live_run() -> None:
    name = f"magcilia-test-{uuid.uuid4().hex[:8]}"
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    live = subprocess.Popen([sys.executable, "-m", "magcilia", "live", "--lsl", name,
                             "--duration", "60", "--rate", "200", "--json-lines", "--every",
                             "50"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env)
    try:
        got = _consumer(str(EXAMPLES / "lsl_consumer.py"), name, "--seconds", "1.5",
                        "--timeout", "30", "--json")
    finally:  # SIGTERM ends the read-out the one clean way (exit 0), outlet closed first
        live.send_signal(signal.SIGTERM)
        out, err = live.communicate(timeout=60)
    if got.returncode == 1 and "no LSL stream" in got.stderr:
        pytest.skip(f"LSL could not reach its own stream here (no multicast/sockets?): "
                    f"{got.stderr.strip()}")
    assert got.returncode == 0, got.stderr
    assert live.returncode == 0, err
    assert f"publishing the LSL stream {name!r} (Force, 3 channels at 200 Hz)" in err
    summary = json.loads(got.stdout.strip().splitlines()[-1])
    assert summary["type"] == "Force" and summary["rate_Hz"] == 200.0
    assert [c["unit"] for c in summary["channels"]] == ["N", "N", "bits"]
    assert summary["samples"] >= 100  # 1.5 s at 200 Hz, minus start-up
    assert summary["median_step_s"] == pytest.approx(1 / 200, rel=1e-3)  # the device's clock
    lines = [json.loads(x) for x in out.splitlines() if x.startswith('{"t"')]
    assert lines and all(x["unit"] == "N" for x in lines)


def test_websocket_consumer_reads_the_dashboard_with_its_token(tmp_path: Path) -> None:
    pytest.importorskip("starlette", reason="the dashboard extra is not installed")
    from magcilia.live.dashboard import DashboardServer

    live = _live()
    with live, DashboardServer(live, port=0, record_dir=tmp_path) as server:
        live.wait(300)
        got = _consumer(str(EXAMPLES / "websocket_consumer.py"), server.url, "--frames", "4",
                        "--tare", "--json")
        deadline = time.monotonic() + 20.0  # the tare the command started takes 0.5 s of data
        while live.zero.tared_at is None and time.monotonic() < deadline:
            live.history.wait(live.history.total, 0.1)
        tared_at = live.zero.tared_at
    assert got.returncode == 0, got.stderr
    summary = json.loads(got.stdout.strip().splitlines()[-1])
    assert summary["quantity"] == "force" and summary["si_unit"] == "N"
    assert summary["frames"] == 4 and summary["points"] > 0
    assert summary["tare"] is not None and tared_at is not None  # the command took the token
    assert np.isfinite(summary["last_value"])
