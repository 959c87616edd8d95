"""``magcilia record --coil``: the simulated coil against mc.bend + Setup.field, the coil sequence,
the recording read back and fitted by the coil experiment, the NI analog-output route."""

from __future__ import annotations

import sys
import types
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.coil import CoilSequence, record_coil
from magcilia.acquire.coil_output import NidaqCoilOutput
from magcilia.acquire.simulated_coil import ACTUATION_COLUMNS, Drifts, SimulatedCoilSource
from magcilia.cli import main
from magcilia.io.recordings import Measurement, read_samples

SETUP = mc.presets.load("force-sensor")  # tip radius 0.05 mm: a field's couple is defined
QUIET = SETUP.replace(noise_density=0.0)
FIELDS = np.array([[0.0, 0.0, 0.0], [5e-4, 0.0, 0.0], [0.0, 5e-4, 0.0], [0.0, 0.0, 5e-4],
                   [-3e-4, 2e-4, 1e-4]])


def _reference(setup: mc.Setup, force: float, b: np.ndarray) -> float:
    """The output by hand: the bent hair's field plus the applied field, through the sensor."""
    act = mc.Actuation.uniform(b) if np.any(b) else None
    bx = float(setup.field(mc.bend(setup, force, actuation=act))[0, 0]) + b[0]
    return float(setup.sensor.voltage(bx))


@pytest.mark.parametrize("force", [0.0, 2e-6])
def test_the_simulated_coil_is_the_bent_hair_plus_the_applied_field(force: float) -> None:
    source = SimulatedCoilSource(QUIET, force, readout_noise=0.0, rng=0)
    with source:
        for b in FIELDS:
            source.set_field(b)
            block = source.read(3)
            np.testing.assert_allclose(block["output"], _reference(QUIET, force, b), rtol=0,
                                       atol=1e-12)
            np.testing.assert_array_equal(np.column_stack(
                [block[c] for c in ACTUATION_COLUMNS]), np.tile(b, (3, 1)))


def test_drifted_scales_equal_a_setup_with_those_values() -> None:
    """Sensitivity, magnetization and stiffness scaled by the drifts: the same output as a setup
    built with the scaled values (an independent route through mc.bend)."""
    drifts = Drifts(sensitivity=-0.03 / 10.0, magnetization=-0.05 / 10.0, stiffness=0.02 / 10.0)
    source = SimulatedCoilSource(QUIET, 1e-6, field=(2e-4, 3e-4, 0.0), readout_noise=0.0,
                                 drifts=drifts, rate=1.0, rng=0)
    with source:
        block = source.read(11)
    s, m, k = 0.97, 0.95, 1.02  # at 10 s (sample 10)
    drifted = QUIET.replace(sensitivity=QUIET.sensor.sensitivity * s,
                            magnetization_scale=QUIET.params()["magnetization_scale"] * m,
                            youngs_modulus=QUIET.youngs_modulus * k)
    assert block["output"][-1] == pytest.approx(
        _reference(drifted, 1e-6, np.array([2e-4, 3e-4, 0.0])), abs=1e-9)


def test_a_coil_sequence_from_text_and_from_a_file(tmp_path: Path) -> None:
    seq = CoilSequence.parse("0,0,0; 5,0,0; 0.5mT,0,-2")
    np.testing.assert_allclose(seq.fields, [[0, 0, 0], [5e-4, 0, 0], [5e-4, 0, -2e-4]])
    path = tmp_path / "steps.csv"
    path.write_text("bx_G,by_G,bz_G,dwell_s\n0,0,0,0.5\n3,0,0,\n")
    steps = CoilSequence.from_text(str(path)).steps
    assert [s.dwell for s in steps] == [0.5, None]
    assert steps[1].field == pytest.approx((3e-4, 0.0, 0.0))
    for bad in ("5,0", "a,b,c", ";"):
        with pytest.raises(mc.MagciliaError, match="--coil") as err:
            CoilSequence.parse(bad)
        assert "\n" not in str(err.value)


@pytest.mark.parametrize(("steps", "words"), [
    ("0,0,0;7,0,0", "within the sensor's range"),
    ("0,0,0;3,0,25", "flip the sensor's element"),
])
def test_a_field_beyond_range_or_flip_is_refused_before_anything_runs(
        steps: str, words: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "coil.tdms"
    assert main(["record", "--coil", steps, "--setup", "force-sensor", "--record",
                 str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("magcilia: error: --coil step 2")
    assert words in err and not out.exists() and not list(tmp_path.iterdir())


def test_a_sharp_tip_or_a_device_without_a_coil_output_is_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for args, words in ((["--setup", "paper"], "tip radius"),
                        (["--setup", "force-sensor", "--source", "nidaq:Dev1/ai0"],
                         "--coil-output")):
        assert main(["record", "--coil", "0,0,0", *args, "--record",
                     str(tmp_path / "c.tdms")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err
    assert not list(tmp_path.iterdir())


def test_record_coil_round_trips_and_fits(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """The CLI's recording holds actuation_*_T and no angle; its steps, as a Measurement, fit the
    coil experiment's model at the truth and not at a wrong sensitivity."""
    from magcilia.calibration.experiments import experiment
    from magcilia.calibration.problem import Problem

    out = tmp_path / "coil.tdms"
    steps = ";".join(",".join(f"{x * 1e4:g}" for x in b) for b in FIELDS)
    assert main(["record", "--coil", steps, "--setup", "force-sensor", "--samples", "400",
                 "--record", str(out), "--json", "--si"]) == 0
    import json

    doc = json.loads(capsys.readouterr().out)
    cols = read_samples(out, required=("voltage_V",))
    assert "angle_deg" not in cols and set(ACTUATION_COLUMNS) <= set(cols)
    assert cols["voltage_V"].size == 400 * len(FIELDS)
    applied = np.column_stack([cols[c] for c in ACTUATION_COLUMNS]).reshape(len(FIELDS), 400, 3)
    np.testing.assert_allclose(applied, np.repeat(FIELDS[:, None, :], 400, axis=1), rtol=1e-12,
                               atol=0)  # (the command's gauss, parsed)
    means = cols["voltage_V"].reshape(len(FIELDS), 400).mean(axis=1)
    np.testing.assert_allclose(means, [p["mean_V"] for p in doc["points"]], rtol=0, atol=1e-12)
    truth = np.array([_reference(SETUP, 0.0, b) for b in FIELDS])
    sem = np.array([p["sem_V"] for p in doc["points"]])
    assert np.all(np.abs(means - truth) < 5 * sem)  # the recording is the model, within noise
    a = len(FIELDS)
    data = Measurement(np.zeros(a), means, sem, np.full(a, 400), np.zeros(a, np.int64),
                       np.zeros(a, np.int64), actuation=FIELDS)
    names = ("x", "y", "magnetization_scale", "sensitivity")
    bounds = {"x": (-3e-3, 3e-3), "y": (-3e-3, 3e-3), "magnetization_scale": (0.05, 5.0),
              "sensitivity": (1.0, 50.0)}
    problem = Problem([experiment(data)], SETUP, names, bounds)
    p = np.array([[*(SETUP.params()[n] for n in names[:3]), SETUP.sensor.sensitivity]])
    assert np.abs(problem.residuals(p)).max() < 5.0  # in σ
    p[0, 3] *= 1.01  # 1 % in sensitivity: 0.4 mV on a 5 G step
    assert np.abs(problem.residuals(p)).max() > 20.0


# -- the NI route, against a stand-in for nidaqmx --------------------------------------------
class _FakeTask:
    log: ClassVar[list[tuple[Any, ...]]] = []
    current: ClassVar[float] = 0.5  # the sense channels' volts

    def __init__(self) -> None:
        self.ai_channels = types.SimpleNamespace(
            add_ai_voltage_chan=lambda *a, **k: self.log.append(("ai", a, k)))
        self.ao_channels = types.SimpleNamespace(
            add_ao_voltage_chan=lambda *a, **k: self.log.append(("ao", a, k)))
        self.timing = types.SimpleNamespace(
            cfg_samp_clk_timing=lambda *a, **k: self.log.append(("clock", a, k)))
        self.in_stream = types.SimpleNamespace(avail_samp_per_chan=0)

    def start(self) -> None:
        self.log.append(("start",))

    def write(self, value: Any, auto_start: bool = False) -> None:
        self.log.append(("write", value, auto_start))

    def read(self, number_of_samples_per_channel: int) -> list[list[float]]:
        return [[self.current] * number_of_samples_per_channel] * 3

    def close(self) -> None:
        self.log.append(("close",))


class _FakeReader:
    def __init__(self, stream: Any) -> None:
        pass

    def read_many_sample(self, data: np.ndarray, number_of_samples_per_channel: int,
                         timeout: float) -> int:
        data[:] = 0.125
        return number_of_samples_per_channel


@pytest.fixture
def fake_nidaqmx(monkeypatch: pytest.MonkeyPatch) -> type[_FakeTask]:
    errors = types.ModuleType("nidaqmx.errors")
    errors.DaqError = type("DaqError", (Exception,), {})  # type: ignore[attr-defined]
    errors.DaqNotFoundError = type("DaqNotFoundError", (Exception,), {})  # type: ignore[attr-defined]
    constants = types.ModuleType("nidaqmx.constants")
    constants.TerminalConfiguration = types.SimpleNamespace(DEFAULT="default")  # type: ignore[attr-defined]
    constants.AcquisitionType = types.SimpleNamespace(CONTINUOUS="continuous")  # type: ignore[attr-defined]
    readers = types.ModuleType("nidaqmx.stream_readers")
    readers.AnalogMultiChannelReader = _FakeReader  # type: ignore[attr-defined]
    root = types.ModuleType("nidaqmx")
    root.Task = _FakeTask  # type: ignore[attr-defined]
    for name, module in (("nidaqmx", root), ("nidaqmx.errors", errors),
                         ("nidaqmx.constants", constants), ("nidaqmx.stream_readers", readers)):
        monkeypatch.setitem(sys.modules, name, module)
    _FakeTask.log = []
    return _FakeTask


def test_the_coil_output_writes_field_over_constant_before_the_samples(
        fake_nidaqmx: type[_FakeTask], tmp_path: Path) -> None:
    from magcilia.acquire.nidaq import NidaqSource

    coil = NidaqCoilOutput("Dev1/ao0,ao1,ao2", [1e-4, 1e-4, -2e-4])  # 1 G/V, z reversed
    assert coil.channels == ("Dev1/ao0", "Dev1/ao1", "Dev1/ao2")
    seq = CoilSequence.of([[0.0, 0.0, 0.0], [3e-4, 0.0, 0.0], [0.0, 1e-4, 4e-4]])
    result = record_coil(NidaqSource("Dev1/ai0"), tmp_path / "ni.tdms", seq, driver=coil,
                         samples=50)
    log = fake_nidaqmx.log
    assert [e[1] for e in log if e[0] == "ao"] == [("Dev1/ao0",), ("Dev1/ao1",), ("Dev1/ao2",)]
    writes = [e[1] for e in log if e[0] == "write"]
    np.testing.assert_allclose(writes, [[0, 0, 0], [3, 0, 0], [0, 1, -2], [0, 0, 0]])  # volts
    assert [p.field for p in result.points] == [tuple(b) for b in seq.fields]
    cols = read_samples(tmp_path / "ni.tdms", required=("voltage_V",))
    np.testing.assert_array_equal(cols["actuation_z_T"][-50:], 4e-4)
    assert log[-1] == ("close",)


def test_a_measured_current_is_the_field_recorded(fake_nidaqmx: type[_FakeTask]) -> None:
    coil = NidaqCoilOutput("Dev1/ao0,ao1,ao2", 1e-4, sense="Dev1/ai1,ai2,ai3",
                           sense_constant=[2e-4, 2e-4, 2e-4])
    np.testing.assert_allclose(coil.set_field([3e-4, 0.0, 0.0]), [1e-4] * 3)  # 0.5 V x 2 G/V
    for bad, words in ((lambda: coil.volts([0.0, 0.0, 2e-3]), "within the outputs"),
                       (lambda: NidaqCoilOutput("Dev1/ao0", 1e-4).volts([0, 1e-4, 0]),
                        "zero on the axes without an output"),
                       (lambda: NidaqCoilOutput("ao0", 1e-4), "one to three NI channels")):
        with pytest.raises(mc.MagciliaError, match=words):
            bad()
