"""Replay: ``live --record`` then ``live --source FILE`` gives the values the live run gave
(within 1e-3 σ), with its tares and zero tracking; ``readout FILE`` of a live recording reads
what the view read."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.acquire import SimulatedSource
from magcilia.acquire.replay import EndOfRecordingError, ReplaySource
from magcilia.acquire.source import OUTPUT
from magcilia.cli._live import demo_script
from magcilia.live import LiveReadout
from magcilia.live.replay import replay
from magcilia.readout.protocol import Flag

pytest.importorskip("nptdms")

SETUP = mc.Setup.paper(tip_radius=5e-5)


def _until(live: LiveReadout, outputs: int) -> None:
    deadline = time.monotonic() + 120.0  # only against a hang
    while live.history.total < outputs and live.running:
        if time.monotonic() > deadline:
            pytest.fail(f"{live.history.total} of {outputs} outputs")
        time.sleep(0.005)


def _recorded_run(path: Path, *, set_reset: int | None = None) -> LiveReadout:
    """A live run of the drifting, pushing simulation (not paced), recorded from its first
    sample, with a second tare asked for during the run (wherever it lands: at rest it is taken,
    across a push it is refused — the replay must do the same at the same sample)."""
    readout = mc.Readout(SETUP, "force", span=(-3e-4, 3e-4))
    source = SimulatedSource(SETUP, demo_script("force", 2e-4), rate=2000.0, rng=3, bias=3e-4,
                             readout_noise=2e-5, drift=2e-7, set_reset=set_reset)
    with LiveReadout(source, readout, rate=100, batch=0.05, tare_at_start=True,
                     tare_seconds=0.2, record=path, history=100) as live:
        _until(live, 700)
        live.tare(wait=30.0)
        _until(live, 1200)
    return live


@pytest.mark.parametrize("set_reset", [None, 5], ids=["plain", "set-reset"])
def test_a_replay_gives_the_live_values(tmp_path: Path, set_reset: int | None) -> None:
    path = tmp_path / "run.tdms"
    live = _recorded_run(path, set_reset=set_reset)
    shown = live.history.since(0)[0]
    again = replay(path)
    assert again.source.realtime is False
    with again:
        deadline = time.monotonic() + 120.0
        while again.running and time.monotonic() < deadline:
            time.sleep(0.01)
    replayed = again.history.since(0)[0]
    assert "finished" in again.status.message
    assert len(replayed) == len(shown) >= 1200
    np.testing.assert_array_equal(replayed.time, shown.time)
    np.testing.assert_array_equal(replayed.flags, shown.flags)
    good = np.isfinite(shown.value)
    assert np.array_equal(good, np.isfinite(replayed.value))
    assert np.max(np.abs(replayed.value[good] - shown.value[good]) / shown.sigma[good]) < 1e-3
    np.testing.assert_allclose(replayed.sigma[good], shown.sigma[good], rtol=1e-6)
    np.testing.assert_allclose(replayed.correction, shown.correction, rtol=0, atol=1e-12)
    taken = [e.text for e in live.events if e.kind == "tare"]
    assert [e.text for e in again.events if e.kind == "tare"] == taken
    assert len(taken) == 2


def test_the_replay_source_reads_the_recording_in_chunks(tmp_path: Path) -> None:
    path = tmp_path / "run.tdms"
    _recorded_run(path)
    src = ReplaySource(path)
    assert src.rate == 2000.0 and [c.name for c in src.channels] == [OUTPUT]
    assert src.tare_samples and 0 in src.tare_samples and src.recorded_clock
    with src:
        first = src.read(300)
        second = src.read(300)
        assert first.first == 0 and second.first == 300
        assert np.all(np.diff(np.concatenate([first.time, second.time])) > 0)
        src.read(src.length - 600)
        with pytest.raises(EndOfRecordingError, match="end of the recording"):
            src.read(1)
    assert src.finished
    with pytest.raises(MagciliaError, match="no such file"):
        ReplaySource(tmp_path / "none.tdms")


def test_only_live_recordings_replay(tmp_path: Path) -> None:
    from magcilia.acquire import record_stream

    path = tmp_path / "stream.tdms"
    record_stream(SimulatedSource(SETUP, 0.1, rng=0), path, seconds=0.2)
    with pytest.raises(MagciliaError, match="not a live read-out's recording"):
        replay(path)


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "magcilia", *args], cwd=cwd, text=True,
                          capture_output=True, timeout=300, check=False)


def _lines(text: str) -> list[dict[str, object]]:
    return [d for d in (json.loads(x) for x in text.splitlines() if x.startswith("{"))
            if "value" in d]


def test_live_record_then_source_gives_the_same_values(tmp_path: Path) -> None:
    """The done-when check through the command line: ``live --record`` then ``live --source``
    of the same file (not a terminal: as fast as it goes), value for value within 1e-3 σ; then
    ``readout FILE`` (no setup: the stored one) gives the view's values too."""
    rec = tmp_path / "live.tdms"
    first = _cli("live", "--source-rate", "2000", "--rate", "100", "--duration", "1",
                 "--record", str(rec), "--json-lines", cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    assert f"recording closed: {rec}" in first.stdout
    again = _cli("live", "--source", str(rec), "--json-lines", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    shown, replayed = _lines(first.stdout), _lines(again.stdout)
    assert len(shown) >= 60
    by_time = {d["t"]: d for d in replayed}
    matched = 0
    for d in shown:
        r = by_time.get(d["t"])
        if r is None:
            continue
        matched += 1
        assert r["flags"] == d["flags"]
        if d["value"] is not None:
            assert abs(r["value"] - d["value"]) < 1e-3 * d["sigma"]  # type: ignore[operator]
    assert matched >= len(shown) - 2  # (the view may stop one batch before the recording)
    out = tmp_path / "values.csv"
    read = _cli("readout", str(rec), "--out", str(out), "--si", cwd=tmp_path)
    assert read.returncode == 0, read.stderr
    assert "a live recording" in read.stdout
    table = np.genfromtxt(out, delimiter=",", names=True)
    rows = {round(float(t), 6): (v, s) for t, v, s in zip(table["time_s"], table["force_N"],
                                                          table["sigma_force_N"], strict=True)}
    for d in shown:
        row = rows.get(round(float(d["t"]), 6))  # type: ignore[arg-type]
        if row is not None and d["value"] is not None:
            assert abs(row[0] - d["value"]) < 1e-3 * d["sigma"]  # type: ignore[operator]
            assert row[1] == pytest.approx(d["sigma"], rel=1e-3)


def test_a_recorded_source_with_record_is_refused(tmp_path: Path) -> None:
    rec = tmp_path / "live.tdms"
    done = _cli("live", "--source", str(rec), "--record", str(tmp_path / "b.tdms"),
                "--json-lines", cwd=tmp_path)
    assert done.returncode == 2 and "--record" in done.stderr


def test_flags_of_the_view_are_replayed(tmp_path: Path) -> None:
    """A run whose first tare is under load: TARE_UNDER_LOAD on every estimate, live and
    replayed."""
    readout = mc.Readout(SETUP, "force", span=(-3e-4, 3e-4))

    def pushed(t: np.ndarray) -> np.ndarray:
        return np.where(np.mod(t, 0.2) < 0.1, 1e-4, 0.0)
    source = SimulatedSource(SETUP, mc.acquire.Script.from_function(pushed, "force"),
                             rate=2000.0, rng=0, readout_noise=2e-5)
    path = tmp_path / "loaded.tdms"
    with LiveReadout(source, readout, rate=100, tare_at_start=True, record=path) as live:
        _until(live, 300)
    again = replay(path)
    with again:
        while again.running:
            time.sleep(0.01)
    flags = again.history.since(0)[0].flags
    assert (flags[100:] & Flag.TARE_UNDER_LOAD).all()
