"""Crash-safe recordings: round trip with metadata, a file cut inside its last chunk, a full disk,
and 20 recorders killed with SIGKILL at random moments whose files all open with at most the
chunk in progress lost."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.io import RecordingWriter, read_samples, recording_properties

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
        print(rec.chunks, flush=True)
"""


def test_round_trip_with_metadata(tmp_path: Path) -> None:
    path = tmp_path / "run.tdms"
    with RecordingWriter(path, metadata={"source": "sim", "rate_Hz": 1000.0,
                                         "channels": {"output": "V"}}, chunk=64) as rec:
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
        cols = read_samples(tmp_path / "c.tdms")
        n = cols["voltage_V"].size
        assert 400 <= n <= 500 and {a.size for a in cols.values()} == {n}
        np.testing.assert_array_equal(cols["voltage_V"], np.arange(n))
    rec.abort("the test is over")


def test_twenty_kills_lose_at_most_the_chunk_in_progress(tmp_path: Path) -> None:
    rng = np.random.default_rng(20)
    chunk = 1000
    seen = []
    for k in range(20):
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
        cols = read_samples(path)  # every file opens
        n = cols["voltage_V"].size
        assert n >= reported * chunk, f"kill {k}: {n} samples, {reported} chunks reported"
        np.testing.assert_array_equal(cols["voltage_V"], np.arange(n))  # nothing corrupt
        assert recording_properties(path)["complete"] is False
        seen.append((reported, n))
    assert max(r for r, _ in seen) >= 20, seen  # the kills came while chunks were being written
