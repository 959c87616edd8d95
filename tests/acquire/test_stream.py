"""Continuous recordings (``record_stream``, ``magcilia record --duration``) never stop short and
never destroy: a million samples past the ring buffer's size, a paced recording faster than real
time whose every sample is in the file or counted, a serial device's own rate deciding the number
of samples, a source that stalls ending in a file that says where, and an existing ``--out`` that
a failing source leaves byte-identical (``--force`` replaces it only at the first flushed chunk).

No test here measures wall time: speed is ``benchmarks/bench_acquire.py``'s.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import is_temporary
from magcilia._errors import AcquisitionError
from magcilia.acquire import SimulatedSource, record_stream
from magcilia.acquire.source import OUTPUT, Block, Channel, Source
from magcilia.cli import main
from magcilia.io import RecordingWriter, read_samples, recording_properties

SETUP = mc.Setup.paper()
#: stall allowance of serial tests, s: long enough for a loaded machine
LOADED = 10.0


def hidden(folder: Path) -> list[str]:
    """Hidden files in ``folder`` (a temporary recording left behind would show here)."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_a_million_samples_past_the_ring_are_all_in_the_file(tmp_path: Path) -> None:
    path = tmp_path / "long.tdms"
    source = SimulatedSource(SETUP, 0.3, rate=1000.0, rng=0)  # not paced: as fast as it goes
    result = record_stream(source, path, 1000.0, buffer_seconds=10.0)  # ring: 10^4 samples
    assert result.samples == 1_000_000 and result.overruns == 0
    cols = read_samples(path, required=("voltage_V",))
    assert cols["voltage_V"].size == 1_000_000
    np.testing.assert_array_equal(cols["time_s"], np.arange(1_000_000) / 1000.0)
    props = recording_properties(path)
    assert props["complete"] is True and props["samples"] == props["planned_samples"] == 1_000_000
    assert props["chunk_samples"] == 500 and props["flush_interval_s"] == 0.5


def test_a_paced_recording_past_the_ring_keeps_or_counts_every_sample(tmp_path: Path) -> None:
    """Paced at 25x real time through the same path as a device (ring of 2 s = 2000 samples):
    every sample asked for is in the file, and any the ring overwrote on a loaded machine are
    the gaps in the sample times, counted as overruns."""
    path = tmp_path / "paced.tdms"
    source = SimulatedSource(SETUP, 0.3, rate=1000.0, realtime=True, speed=25.0, rng=1)
    result = record_stream(source, path, 25.0, buffer_seconds=2.0)
    assert result.samples == 25_000
    index = np.rint(read_samples(path, required=("voltage_V",))["time_s"] * 1000.0)
    assert index.size == 25_000 and index[0] == 0 and np.all(np.diff(index) >= 1)
    assert int(index[-1]) + 1 - index.size == result.overruns == result.counters.dropped


class _Hangs(Source):
    """Delivers ``good`` samples at once, then nothing until it is closed (a stalled device)."""

    def __init__(self, good: int) -> None:
        super().__init__()
        self.rate, self.channels, self.name = 1000.0, (Channel(OUTPUT),), "test-device"
        self.realtime, self.good, self._i = True, good, 0
        self._closed = threading.Event()

    def _open(self) -> None:
        self._closed.clear()

    def _close(self) -> None:
        self._closed.set()

    def _read(self, n: int) -> Block:
        if self._i + n > self.good:
            self._closed.wait()
            raise AcquisitionError("test-device: closed")
        t = (self._i + np.arange(n)) / self.rate
        self._i += n
        return Block(t, np.full((1, n), 0.5), self.channels, first=int(t[0] * self.rate))


def test_a_source_that_stalls_ends_with_a_file_that_says_where(tmp_path: Path) -> None:
    path = tmp_path / "stalled.tdms"
    with pytest.raises(AcquisitionError) as err:
        record_stream(_Hangs(2500), path, 10.0, stall=0.2, chunk=500)
    message = str(err.value)
    assert "\n" not in message and "stopped after 2500 of 10000 samples" in message
    assert "no samples for 0.2 s" in message and str(path) in message
    assert read_samples(path, required=("voltage_V",))["voltage_V"].size == 2500
    props = recording_properties(path)
    assert props["complete"] is False and "after 2500 of 10000 samples" in props["stopped"]


def test_an_existing_out_is_refused_without_force(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "precious.tdms"
    out.write_bytes(b"an earlier recording")
    for how in (["--angles", "0:10:5"], ["--duration", "0.1"]):
        assert main(["record", "--source", "sim", *how, "--record", str(out)]) == 2
        err = capsys.readouterr().err
        assert "exists; pass --force" in err and err.count("\n") == 1
    assert out.read_bytes() == b"an earlier recording" and hidden(tmp_path) == []
    with pytest.raises(mc.MagciliaError, match="exists; pass --force"):
        RecordingWriter(out, overwrite=False).open()


@pytest.mark.parametrize("how", [["--angles", "0:10:5"], ["--duration", "5"]],
                         ids=["sweep", "duration"])
def test_a_failing_source_leaves_an_existing_out_byte_identical(
        how: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "precious.tdms"
    main(["record", "--source", "sim", "--angles", "0:10:5", "--samples", "50", "--out",
          str(out)])
    before = out.read_bytes()
    port = str(tmp_path / "ttyMISSING")
    assert main(["record", "--source", f"serial:{port}", *how, "--out", str(out),
                 "--force"]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and "Traceback" not in err
    assert out.read_bytes() == before and hidden(tmp_path) == []


def test_force_replaces_only_at_the_first_flushed_chunk(tmp_path: Path) -> None:
    out = tmp_path / "run.tdms"
    out.write_bytes(b"old")
    rec = RecordingWriter(out, chunk=100, flush_interval=None, metadata={"source": "t"}).open()
    (temp,) = hidden(tmp_path)
    assert temp.startswith(".run.magcilia-partial-") and temp.endswith(".tdms")
    assert is_temporary(temp)  # magcilia._atomic's naming: the next run removes it after a kill
    rec.write(np.arange(60.0), np.zeros(60))
    assert out.read_bytes() == b"old"  # 60 samples pending, nothing flushed yet
    rec.write(np.arange(60.0, 120.0), np.ones(60))
    assert out.read_bytes() != b"old" and hidden(tmp_path) == []  # the first chunk replaced it
    rec.close()
    assert read_samples(out, required=("voltage_V",))["voltage_V"].size == 120
    # a recording that fails before its first sample leaves the old file and no temporary one;
    # one that fails with samples pending keeps them (flushed, they replace the old file)
    out.write_bytes(b"old")
    rec = RecordingWriter(out, chunk=100).open()
    assert rec.abort("the device vanished") is False
    assert out.read_bytes() == b"old" and hidden(tmp_path) == []
    rec = RecordingWriter(out, chunk=100).open()
    rec.write(np.arange(10.0), np.zeros(10))
    assert rec.abort("the device vanished") is True and hidden(tmp_path) == []
    assert read_samples(out, required=("voltage_V",))["voltage_V"].size == 10
    assert recording_properties(out)["stopped"] == "the device vanished"


def test_the_temporary_file_of_a_killed_force_recording_is_removed_by_the_next(
        tmp_path: Path) -> None:
    """A ``record --force`` killed before its first chunk leaves its hidden file beside the old
    one (its lock dies with it); the next recording into the folder removes it."""
    import subprocess
    import sys

    out = tmp_path / "run.tdms"
    out.write_bytes(b"old")
    child = subprocess.run([sys.executable, "-c", (
        "import os, sys, pathlib; from magcilia.io import RecordingWriter; "
        "RecordingWriter(pathlib.Path(sys.argv[1]), metadata={'source': 't'}).open(); "
        "os._exit(0)"), str(out)], capture_output=True, text=True, timeout=120, check=False)
    assert child.returncode == 0, child.stderr
    (left,) = hidden(tmp_path)  # the killed writer's, unlocked, its process gone
    assert is_temporary(left) and out.read_bytes() == b"old"
    with RecordingWriter(tmp_path / "next.tdms", metadata={"source": "t"}) as rec:
        rec.write(np.arange(10.0), np.zeros(10))
    assert hidden(tmp_path) == [] and out.read_bytes() == b"old"


def test_where_an_open_file_cannot_be_renamed_it_replaces_the_old_one_when_closed(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Windows refuses to rename an open file: the new recording then stays under its temporary
    name until it closes, and the old file until then."""
    out = tmp_path / "run.tdms"
    out.write_bytes(b"old")
    rename = Path.replace
    writer: list[RecordingWriter] = []

    def like_windows(self: Path, target: str | os.PathLike[str]) -> Path:
        if writer and writer[0]._file is not None:  # the file is still open
            raise PermissionError(13, "The process cannot access the file")
        return rename(self, target)

    monkeypatch.setattr(Path, "replace", like_windows)
    writer.append(RecordingWriter(out, chunk=50).open())
    writer[0].write(np.arange(120.0), np.zeros(120))
    assert writer[0].chunks == 2 and out.read_bytes() == b"old" and len(hidden(tmp_path)) == 1
    writer[0].close()
    assert hidden(tmp_path) == []
    assert read_samples(out, required=("voltage_V",))["voltage_V"].size == 120


def test_a_file_killed_before_its_first_chunk_says_what_it_was(tmp_path: Path) -> None:
    """What a kill leaves between opening and the first flushed chunk: the first segment alone
    (the file is unbuffered, so it is on disk as soon as ``open`` returns)."""
    path = tmp_path / "early.tdms"
    planned = [0.0, 10.0, 20.0]
    rec = RecordingWriter(path, chunk=500, metadata={
        "source": "sim", "rate_Hz": 1000.0, "channels": {"output": "V"},
        "planned_angles_deg": planned}).open()
    rec.write(np.arange(100.0), np.zeros(100), angle_deg=np.zeros(100))  # pending, not flushed
    props = recording_properties(path)
    assert props["complete"] is False and "samples" not in props and "stopped" not in props
    assert props["planned_angles_deg"] == "[0.0, 10.0, 20.0]" and props["rate_Hz"] == 1000.0
    assert props["channels"] == '{"output": "V"}' and props["chunk_samples"] == 500
    rec.abort("the test is over")


@pytest.mark.skipif(os.name != "posix", reason="the emulator needs a pseudo-terminal")
def test_serial_duration_records_the_full_duration_at_the_devices_rate(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("serial")
    from magcilia.acquire.emulator import DeviceEmulator
    from magcilia.acquire.serial import SerialSource

    out = tmp_path / "serial.tdms"
    with DeviceEmulator(SimulatedSource(SETUP, 0.3, rate=2000.0, rng=2)) as device:
        assert main(["record", "--source", f"serial:{device.port}", "--duration", "0.6",
                     "--out", str(out), "--json"]) == 0
        again = record_stream(SerialSource(device.port, stall=LOADED), tmp_path / "lib.tdms",
                              0.25)
    assert '"samples": 1200' in capsys.readouterr().out
    cols = read_samples(out, required=("voltage_V",))
    assert cols["voltage_V"].size == 1200  # 0.6 s at the 2 kHz the device announced
    np.testing.assert_allclose(np.diff(cols["time_s"]), 1 / 2000.0, rtol=1e-9)
    props = recording_properties(out)
    assert props["complete"] is True and props["rate_Hz"] == 2000.0
    assert again.samples == 500


@pytest.mark.skipif(os.name != "posix", reason="POSIX signals")
def test_a_signal_stops_record_with_its_file_closed_and_one_line(
        tmp_path: Path, magcilia_command: Any) -> None:
    """Ctrl-C, SIGTERM (a service stopping) and SIGHUP (a closed SSH session) end ``record`` the
    same way: the file closed, marked incomplete and saying where it stopped, every flushed
    sample readable, one line on stderr, exit status 1 (the three run side by side)."""
    import signal
    import subprocess
    import time

    cmd = magcilia_command
    children = {}
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        out = tmp_path / f"{sig.name}.tdms"
        children[sig] = (out, subprocess.Popen(
            [*cmd.argv, "record", "--source", "sim", "--duration", "600", "--source-rate", "1000",
             "--record", str(out)], stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, env=cmd.env()))
    deadline = time.monotonic() + 120  # a guard against a hang, not a speed check
    for sig, (out, proc) in children.items():
        while not (out.exists() and out.stat().st_size > 20_000):  # past the first data chunk
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.05)
        proc.send_signal(sig)
    for sig, (out, proc) in children.items():
        _, err = proc.communicate(timeout=120)
        lines = err.decode().splitlines()
        assert proc.returncode == 1 and len(lines) == 1, err.decode()
        assert lines[0].startswith(f"magcilia: {sig.name} stopped the recording; what it holds "
                                   f"so far is kept in {out}, marked incomplete (stopped after ")
        props = recording_properties(out)
        assert props["complete"] is False and props["stopped"].endswith(": interrupted")
        volts = read_samples(out, ("time_s", "voltage_V"))["voltage_V"]
        assert volts.size == props["samples"] > 0 and np.isfinite(volts).all()
