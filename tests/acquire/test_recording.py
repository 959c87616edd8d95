"""Crash-safe recordings: round trip with metadata, a file cut inside its last chunk, a full disk,
20 writers killed with SIGKILL at random moments whose files all open with at most the chunk in
progress lost, and ``magcilia record --duration`` killed at any moment after its first second
keeping all but at most about a second of the samples its source delivered (3 kills by default,
20 with ``MAGCILIA_FUZZ=long``)."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.io import RecordingWriter, read_samples, recording_properties
from magcilia.io.recordings import read_recording

CHILD = """
import sys, numpy as np
from magcilia.io.recording_file import RecordingWriter
chunk = int(sys.argv[2])
with RecordingWriter(sys.argv[1], metadata={"source": "kill-test"}, chunk=chunk) as rec:
    i = 0
    while True:
        n = 250
        idx = np.arange(i, i + n, dtype=float)
        rec.write(idx / 1e3, idx, angle_deg=np.full(n, 1.0))
        i += n
        print(rec.samples, flush=True)
"""

#: ``magcilia record --duration`` as it runs from the command line, its simulated source telling
#: on stdout how many samples it has delivered after each read
RECORD_CHILD = """
import sys
from magcilia.acquire.simulated import SimulatedSource
from magcilia.cli import main

read = SimulatedSource._read

def told(self, n):
    block = read(self, n)
    print(self._index, flush=True)
    return block

SimulatedSource._read = told
sys.exit(main(["record", "--source", "sim", "--duration", "60", "--rate", sys.argv[2],
               "--out", sys.argv[1], "--quiet"]))
"""
#: SIGKILLs of ``record --duration``: a few by default, many with MAGCILIA_FUZZ=long
RECORD_KILLS = 20 if os.environ.get("MAGCILIA_FUZZ") == "long" else 3
#: the most a killed recording may lose of what its source delivered, s of samples ("about a
#: second": half a second waiting in the ring for the consumer's piece, half a second pending in
#: the writer, and a loaded machine's scheduling)
LOSS_SECONDS = 1.0


def test_round_trip_with_metadata(tmp_path: Path) -> None:
    path = tmp_path / "run.tdms"
    with RecordingWriter(path, metadata={"source": "sim", "rate_Hz": 1000.0,
                                         "channels": {"output": "V"}}, chunk=64,
                         flush_interval=None) as rec:
        for k in range(5):
            t = np.arange(k * 50, (k + 1) * 50) / 1e3
            rec.write(t, np.sin(t), angle_deg=np.full(50, 10.0 * k),
                      setreset=np.where(np.arange(50) < 25, 1, -1))
    assert rec.samples == 250 and rec.chunks == 4  # 3 full chunks and the rest at close
    cols = read_samples(path)
    np.testing.assert_array_equal(cols["time_s"], np.arange(250) / 1e3)
    np.testing.assert_array_equal(cols["voltage_V"], np.sin(np.arange(250) / 1e3))
    assert set(np.unique(cols["setreset"])) == {-1.0, 1.0}
    props = recording_properties(path)
    assert props["complete"] is True and props["samples"] == 250 and props["source"] == "sim"
    assert props["channels"] == '{"output": "V"}' and "magcilia_version" in props


def test_bad_calls(tmp_path: Path) -> None:
    with pytest.raises(mc.MagciliaError, match=r"recording file must be a path ending in \.tdms"):
        RecordingWriter(tmp_path / "run.csv").open()
    rec = RecordingWriter(tmp_path / "a.tdms")
    rec.write([0.0], [1.0])
    with pytest.raises(mc.MagciliaError, match="recording channels must be"):
        rec.write([0.0], [1.0], angle_deg=[2.0])
    with pytest.raises(mc.MagciliaError, match="the same number of samples"):
        rec.write([0.0, 1.0], [1.0])
    rec.close()


class _FullDisk:
    """A file that accepts ``room`` bytes, then fails as a full disk does."""

    def __init__(self, inner: Any, room: int) -> None:
        self.inner, self.room = inner, room

    def write(self, data: bytes) -> int:
        if self.room < len(data):
            raise OSError(errno.ENOSPC, "No space left on device")
        self.room -= len(data)
        return int(self.inner.write(data))

    def __getattr__(self, name: str) -> Any:
        return getattr(self.inner, name)


def test_a_full_disk_is_one_line_and_keeps_what_was_written(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "full.tdms"
    real_open = Path.open

    def small_disk(self: Path, *args: Any, **kwargs: Any) -> Any:
        return _FullDisk(real_open(self, *args, **kwargs), room=20_000)

    monkeypatch.setattr(Path, "open", small_disk)
    rec = RecordingWriter(path, chunk=100).open()

    def fill_the_disk() -> None:
        for k in range(100):
            rec.write(np.arange(100.0) + 100 * k, np.zeros(100))

    with pytest.raises(mc.MagciliaError) as err:
        fill_the_disk()
    message = str(err.value)
    assert "writing failed after" in message and "No space left" in message
    assert "\n" not in message
    assert rec.abort("disk full") is True
    monkeypatch.undo()
    cols = read_samples(path, required=("voltage_V",))
    assert cols["voltage_V"].size == rec.samples > 0


def test_a_file_cut_inside_its_last_chunk_opens(tmp_path: Path) -> None:
    path = tmp_path / "cut.tdms"
    rec = RecordingWriter(path, chunk=100).open()
    rec.write(np.arange(500.0), np.arange(500.0), angle_deg=np.zeros(500))
    data = path.read_bytes()  # never closed: "complete" is still False
    for cut in (len(data) - 1, len(data) - 700, len(data) - 2500):
        (tmp_path / "c.tdms").write_bytes(data[:cut])
        raw = read_recording(tmp_path / "c.tdms")
        cols = raw.columns
        n = cols["voltage_V"].size
        assert 400 <= n <= 500 and {a.size for a in cols.values()} == {n}
        assert not [note for note in raw.notes if "CRC" in note or "checksum" in note]
        np.testing.assert_array_equal(cols["voltage_V"], np.arange(n))
    rec.abort("the test is over")


def test_writers_killed_at_random_lose_at_most_the_chunk_in_progress(tmp_path: Path) -> None:
    rng = np.random.default_rng(20)
    chunk = 1000
    seen = []
    for k in range(20 if os.environ.get("MAGCILIA_FUZZ") == "long" else 5):
        path = tmp_path / f"kill{k}.tdms"
        child = subprocess.Popen([sys.executable, "-c", CHILD, str(path), str(chunk)],
                                 stdout=subprocess.PIPE, text=True)
        assert child.stdout is not None
        reported = 0
        line = child.stdout.readline()  # the recorder is running
        deadline = time.monotonic() + float(rng.uniform(0.0, 0.3))
        while line and time.monotonic() < deadline:
            reported = int(line)
            line = child.stdout.readline()
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
        child.stdout.close()
        raw = read_recording(path)  # every file opens
        cols = raw.columns
        n = cols["voltage_V"].size
        assert n >= reported, f"kill {k}: {n} samples, {reported} reported flushed"
        np.testing.assert_array_equal(cols["voltage_V"], np.arange(n))  # nothing corrupt
        assert not [note for note in raw.notes if "CRC" in note or "checksum" in note], (
            f"kill {k}: every flushed chunk verifies", raw.notes)
        assert recording_properties(path)["complete"] is False
        seen.append((reported, n))
    assert max(r for r, _ in seen) >= 5 * chunk, seen  # the kills came while writing chunks


def _kill_when_delivered(child: subprocess.Popen[str], target: int, delivered: list[int]) -> None:
    """Kill ``child`` once its source has delivered ``target`` samples; then read what it said
    before dying (the pipe keeps it): ``delivered`` gets the last count."""
    assert child.stdout is not None
    last = 0
    for line in child.stdout:
        last = int(line)
        if last >= target:
            child.kill()
            break
    for line in child.stdout:  # said before the kill, still in the pipe
        last = int(line)
    child.stdout.close()
    child.wait()
    delivered.append(last)


@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL")
def test_record_duration_killed_at_any_moment_keeps_all_but_a_second(tmp_path: Path) -> None:
    """``record --duration 60`` at 1 kHz, killed at seeded random moments from 1 s to 3 s of
    delivered samples (the children run side by side): each file opens, is marked incomplete,
    holds the samples in order, exactly, and lacks at most LOSS_SECONDS of those delivered."""
    rate = 1000
    rng = np.random.default_rng(25)
    targets = [int(rate * rng.uniform(1.0, 3.0)) for _ in range(RECORD_KILLS)]
    for start in range(0, RECORD_KILLS, 4):  # four at a time
        batch = range(start, min(start + 4, RECORD_KILLS))
        children, threads, delivered = [], [], [[] for _ in batch]
        for k, got in zip(batch, delivered, strict=True):
            child = subprocess.Popen(
                [sys.executable, "-c", RECORD_CHILD, str(tmp_path / f"k{k}.tdms"), str(rate)],
                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            children.append(child)
            threads.append(threading.Thread(target=_kill_when_delivered,
                                            args=(child, targets[k], got)))
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(timeout=120)
        for k, child, (count,) in zip(batch, children, delivered, strict=True):
            assert child.returncode == -signal.SIGKILL
            path = tmp_path / f"k{k}.tdms"
            props = recording_properties(path)
            assert props["complete"] is False and props["planned_samples"] == 60 * rate
            raw = read_recording(path, required=("voltage_V",))
            n = raw.columns["voltage_V"].size
            assert count - LOSS_SECONDS * rate <= n <= count, (k, count, n)
            assert not [note for note in raw.notes if "CRC" in note or "checksum" in note], (
                k, raw.notes)  # every flushed chunk verifies
            np.testing.assert_array_equal(read_samples(path, required=("voltage_V",))["time_s"],
                                          np.arange(n) / rate)
            print(f"kill {k}: {count} samples delivered, {n} in the file")
