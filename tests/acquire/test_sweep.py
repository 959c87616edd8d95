"""The guided calibration sweep and continuous recording: a simulated sweep that calibrate fits
within the noise, offset-free set/reset readings, asked angles, faults that keep what was
recorded, the `record` command, and the NI-DAQmx adapter at its boundary."""

from __future__ import annotations

import functools
import json
import math
import sys
import types
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import AcquisitionError
from magcilia.acquire import (
    NidaqSource,
    SimulatedSource,
    record_stream,
    record_sweep,
    source_from_spec,
)
from magcilia.cli import main
from magcilia.io import read_samples, recording_properties

TRUTH = mc.Setup.paper()
ANGLES = np.radians(np.arange(0.0, 82.5, 2.5))


def test_a_simulated_sweep_calibrates_within_the_noise(tmp_path: Path) -> None:
    path = tmp_path / "run.tdms"
    source = SimulatedSource(TRUTH, rng=3, bias=2e-3)
    result = record_sweep(source, path, angles=ANGLES, samples=2000, sensor=TRUTH.sensor,
                          metadata={"setup_name": "paper"})
    assert result.complete and len(result.points) == ANGLES.size
    assert result.counters.samples == 2000 * ANGLES.size and result.counters.dropped == 0
    data = mc.read_measurements(path)
    np.testing.assert_allclose(data.angles, ANGLES, atol=1e-12)
    sem = float(np.median(data.sem))
    np.testing.assert_allclose(data.volts - 2e-3, TRUTH.output(ANGLES), atol=5 * sem)
    fit = mc.calibrate(data, initial=TRUTH, rng=0, restarts=1)
    assert fit.rms < 1.5 * sem  # the model fits to within the noise of each angle's mean
    props = recording_properties(path)
    assert props["complete"] is True and props["setup_name"] == "paper"
    assert json.loads(props["planned_angles_deg"])[1] == pytest.approx(2.5)


def test_set_reset_readings_are_offset_free(tmp_path: Path) -> None:
    source = SimulatedSource(TRUTH, rng=4, bias=40e-3, set_reset=200)  # a large lab field
    result = record_sweep(source, tmp_path / "sr.tdms", angles=ANGLES[::8], samples=2000)
    field = TRUTH.output(ANGLES[::8]) - TRUTH.sensor.offset
    np.testing.assert_allclose([p.mean for p in result.points], field, atol=2e-5)
    data = mc.read_measurements(tmp_path / "sr.tdms")
    assert data.set_reset
    np.testing.assert_allclose(data.volts, [p.mean for p in result.points], rtol=1e-12)


def test_asked_angles_and_the_saturation_flag(tmp_path: Path) -> None:
    answers = iter([0.1, 0.5, None])
    seen: list[float] = []
    hot = TRUTH.replace(magnetization_scale=30.0)  # a field beyond ±6 gauss
    result = record_sweep(SimulatedSource(hot, rng=0), tmp_path / "a.tdms",
                          ask=lambda i: next(answers), samples=500, sensor=hot.sensor,
                          on_point=lambda p: seen.append(p.angle))
    assert seen == [0.1, 0.5] and len(result.points) == 2
    assert all(p.saturated == 500 for p in result.points)
    assert "SATURATED" in result.points[0].report()


class _Unplugged(SimulatedSource):
    """Vanishes on its fourth read."""

    def _read(self, n: int) -> Any:
        if self.counters.samples >= 3 * n:
            raise AcquisitionError("serial:/dev/ttyACM0 vanished (unplugged?)")
        return super()._read(n)


def test_a_fault_keeps_the_recording_and_says_where(tmp_path: Path) -> None:
    path = tmp_path / "cut.tdms"
    with pytest.raises(AcquisitionError) as err:
        record_sweep(_Unplugged(TRUTH, rng=0), path, angles=ANGLES[:6], samples=300, chunk=100)
    message = str(err.value)
    assert "stopped at angle 4" in message and "vanished" in message and str(path) in message
    assert "\n" not in message
    assert mc.read_measurements(path).counts.tolist() == [300, 300, 300]
    props = recording_properties(path)
    assert props["complete"] is False and "stopped at angle 4" in props["stopped"]


@pytest.mark.parametrize("kind", ["sweep", "stream"])
def test_a_chunk_below_one_is_refused_before_the_source_opens(kind: str, tmp_path: Path) -> None:
    source = SimulatedSource(TRUTH, rng=0)
    path = tmp_path / "never.tdms"
    record: Any = (functools.partial(record_sweep, angles=ANGLES[:2], samples=10)
                   if kind == "sweep" else functools.partial(record_stream, seconds=0.01))
    with pytest.raises(mc.MagciliaError, match=r"^chunk must be .*; got 0$"):
        record(source, path, chunk=0)
    assert not path.exists() and not source.is_open


def test_continuous_recording_through_the_ring_buffer(tmp_path: Path) -> None:
    source = SimulatedSource(TRUTH, 0.3, rate=50_000.0, realtime=True, rng=1)
    result = record_stream(source, tmp_path / "s.tdms", 0.5, chunk=5000)
    assert result.samples == 25_000 and result.overruns == 0
    cols = read_samples(tmp_path / "s.tdms", required=("voltage_V",))
    assert cols["voltage_V"].size == 25_000
    np.testing.assert_allclose(np.diff(cols["time_s"]), 1 / 50_000.0)


def test_record_command_then_calibrate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "cli.tdms"
    assert main(["record", "--source", "sim", "--setup", "paper", "--angles", "0:80:10",
                 "--samples", "400", "--rate", "1000", "--out", str(out), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["complete"] and len(doc["points"]) == 9 and doc["dropped"] == 0
    assert main(["calibrate", str(out), "--out", str(tmp_path / "fit"), "--quiet",
                 "--restarts", "1"]) == 0
    assert (tmp_path / "fit" / "fitted_setup.toml").is_file()
    assert main(["record", "--source", "sim", "--duration", "0.2", "--rate", "5000",
                 "--out", str(tmp_path / "cont.tdms")]) == 0
    assert "0 overruns" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--source", "usb", "--angles", "0:10:5"], "--source must be one of"),
        (["--angles", "0:10:5", "--out-csv"], "No such option"),
        (["--source", "nidaq:Dev1/ai0", "--angles", "0:10:5"], "NI-DAQmx driver not found"),
    ],
    ids=["unknown-source", "bad-option", "no-ni-driver"],
)
def test_record_errors_are_one_line(args: list[str], match: str, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "x.tdms"
    code = main(["record", *args, "--out", str(out)])
    err = capsys.readouterr().err
    assert code in (1, 2) and match in err and "Traceback" not in err
    assert not out.exists()
    assert main(["record", "--angles", "0:10:5", "--out", str(tmp_path / "x.csv")]) == 2
    assert ".tdms file" in capsys.readouterr().err


def test_record_asks_for_angles(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("skimage")
    from PIL import Image

    tape = np.full((240, 320), 40, dtype=np.uint8)  # a bright stripe leaning 20 deg right
    yy, xx = np.mgrid[0:240, 0:320]
    along = np.cos(np.radians(20.0)) * (200 - yy) + np.sin(np.radians(20.0)) * (xx - 140)
    across = np.cos(np.radians(20.0)) * (xx - 140) - np.sin(np.radians(20.0)) * (200 - yy)
    tape[(np.abs(across) < 4) & (along > 0) & (along < 170)] = 230
    Image.fromarray(tape).save(tmp_path / "tilt.png")
    answers = iter(["10", "not a number", str(tmp_path / "tilt.png"), ""])
    monkeypatch.setattr("click.prompt", lambda *a, **k: next(answers))
    out = tmp_path / "asked.tdms"
    assert main(["record", "--samples", "200", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "neither a number of degrees nor a photo" in captured.err
    assert "photo: " in captured.out  # the measured tilt is shown
    assert mc.read_measurements(out).angles_deg.tolist() == pytest.approx([10.0, 20.0], abs=0.2)


# -- NI-DAQmx at its boundary ------------------------------------------------------------------
class _FakeTask:
    """Stands in for nidaqmx.Task: records what the adapter asks of it."""

    log: ClassVar[list[tuple[Any, ...]]] = []

    def __init__(self) -> None:
        self.ai_channels = types.SimpleNamespace(
            add_ai_voltage_chan=lambda *a, **k: self.log.append(("ai", a, k)))
        self.do_channels = types.SimpleNamespace(
            add_do_chan=lambda *a, **k: self.log.append(("do", a, k)))
        self.timing = types.SimpleNamespace(
            cfg_samp_clk_timing=lambda *a, **k: self.log.append(("clock", a, k)))
        self.in_stream = types.SimpleNamespace(avail_samp_per_chan=0)

    def start(self) -> None:
        self.log.append(("start",))

    def write(self, value: bool) -> None:
        self.log.append(("line", value))

    def close(self) -> None:
        self.log.append(("close",))


class _FakeReader:
    def __init__(self, stream: Any) -> None:
        self.count = 0.0

    def read_many_sample(self, data: np.ndarray, number_of_samples_per_channel: int,
                         timeout: float) -> int:
        data[:] = 1.25
        return number_of_samples_per_channel


def _fake_nidaqmx(monkeypatch: pytest.MonkeyPatch) -> None:
    errors = types.ModuleType("nidaqmx.errors")
    errors.DaqError = type("DaqError", (Exception,), {})  # type: ignore[attr-defined]
    errors.DaqNotFoundError = type("DaqNotFoundError", (Exception,), {})  # type: ignore[attr-defined]
    constants = types.ModuleType("nidaqmx.constants")
    constants.TerminalConfiguration = types.SimpleNamespace(  # type: ignore[attr-defined]
        DEFAULT="default", DIFF="diff", RSE="rse", NRSE="nrse", PSEUDO_DIFF="pseudo")
    constants.AcquisitionType = types.SimpleNamespace(CONTINUOUS="continuous")  # type: ignore[attr-defined]
    readers = types.ModuleType("nidaqmx.stream_readers")
    readers.AnalogMultiChannelReader = _FakeReader  # type: ignore[attr-defined]
    root = types.ModuleType("nidaqmx")
    root.Task = _FakeTask  # type: ignore[attr-defined]
    for name, module in (("nidaqmx", root), ("nidaqmx.errors", errors),
                         ("nidaqmx.constants", constants), ("nidaqmx.stream_readers", readers)):
        monkeypatch.setitem(sys.modules, name, module)


def test_nidaq_adapter_configures_the_task_as_documented(monkeypatch: pytest.MonkeyPatch) -> None:
    _fake_nidaqmx(monkeypatch)
    _FakeTask.log = []
    source = NidaqSource("Dev1/ai0", rate=1000.0, voltage_range=2.0, terminal="rse",
                         set_reset_line="Dev1/port0/line0", set_reset=100)
    with source:
        block = source.read(250)
    log = _FakeTask.log
    assert ("ai", ("Dev1/ai0",), {"terminal_config": "rse", "min_val": -2.0, "max_val": 2.0}) in log
    assert ("clock", (1000.0,), {"sample_mode": "continuous", "samps_per_chan": 10_000}) in log
    assert ("do", ("Dev1/port0/line0",), {}) in log
    assert [e[1] for e in log if e[0] == "line"] == [True, False, True]  # set, reset, set
    assert block.setreset is not None and block.setreset[[0, 100, 200]].tolist() == [1, -1, 1]
    np.testing.assert_array_equal(block.data, 1.25)
    assert log[-1] == ("close",)


def test_nidaq_without_its_driver_is_one_line() -> None:
    pytest.importorskip("nidaqmx")
    with pytest.raises(AcquisitionError) as err:
        NidaqSource("Dev1/ai0").open()
    assert "NI-DAQmx driver not found" in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(mc.MagciliaError, match="channel must be an NI physical channel"):
        NidaqSource("ai0")
    assert isinstance(source_from_spec("nidaq:Dev2/ai1", setup=TRUTH), NidaqSource)
    assert math.isclose(source_from_spec("sim", setup=TRUTH, rate=500.0).rate, 500.0)


def test_the_sweep_through_the_serial_emulator_matches_with_one_percent_corrupt(
        tmp_path: Path) -> None:
    """The same sweep, once from the simulated sensor directly and once through the framed
    protocol on a pseudo-terminal with 1 % of frames damaged: the same means within noise, and the
    drops reported."""
    pytest.importorskip("serial")
    from magcilia.acquire.emulator import DeviceEmulator
    from magcilia.acquire.serial import SerialSource

    angles = ANGLES[::4]
    direct = record_sweep(SimulatedSource(TRUTH, rng=7), tmp_path / "direct.tdms",
                          angles=angles, samples=2000)
    device = SimulatedSource(TRUTH, rng=8)
    with DeviceEmulator(device, samples_per_frame=16, realtime=False, corrupt=0.01,
                        rng=9) as emulator:
        plan = iter(angles)

        def tilt_the_device(i: int) -> float | None:  # the hand that tilts the holder
            angle = next(plan, None)
            if angle is not None:
                device.set_value(float(angle))
            return angle

        serial = record_sweep(SerialSource(emulator.port, stall=10.0), tmp_path / "serial.tdms",
                              ask=tilt_the_device, samples=2000, settle=0.2)
    for a, b in zip(direct.points, serial.points, strict=True):
        assert b.mean == pytest.approx(a.mean, abs=5 * math.hypot(a.sem, b.sem))
    assert serial.counters.corrupt > 0 and serial.counters.dropped > 0
    assert serial.counters.dropped == 16 * serial.counters.corrupt  # each damaged frame: 16
    data = mc.read_measurements(tmp_path / "serial.tdms")
    assert data.counts.tolist() == [2000] * angles.size
