"""One result protocol: every result is frozen, has ``to_dict()`` (SI, JSON-ready) and
``report()`` (text for people), and ``from_dict()`` rebuilds those that files carry back."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import json
import math
import pkgutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia
import magcilia as mc
from magcilia._atomic import json_text
from magcilia.acquire.synthetic import synthetic_recording
from magcilia.analysis import placement_map
from magcilia.io import Measurement, fixed_point_format, measurement_from_samples
from magcilia.readout.actuated import measure_coupling

SETUP = mc.Setup.paper()
TAPERED = mc.Setup.paper(tip_radius=5e-5, n_loops=16, dipoles_per_loop=4)  # 0.5 % off
ANGLES = np.radians(np.linspace(0.0, 85.0, 12))


def _measurement() -> Measurement:
    rec = synthetic_recording(SETUP, ANGLES, samples_per_angle=20, rng=1)
    return measurement_from_samples(rec.angle_deg, rec.voltage, source="synthetic")


def _calibration() -> mc.CalibrationResult:
    return mc.calibrate(_measurement(), initial=SETUP, rng=0, starts=8,
                        bounds={"n_loops": (2, 2), "dipoles_per_loop": (5, 5)})


def _joint() -> Any:
    data = _measurement()
    shifted = dataclasses.replace(data, azimuths=np.full(len(data), 0.5), source="azimuth 0.5")
    return mc.calibrate([data, shifted], model="physical", initial=SETUP, rng=0, starts=4,
                        layout=(8, 5))


def _sweep() -> Any:
    from magcilia.acquire import SimulatedSource, record_sweep

    path = Path(tempfile.mkdtemp()) / "sweep.tdms"
    return record_sweep(SimulatedSource(SETUP, rng=0), path, angles=[0.0, 0.3], samples=50)


def _coil_sweep() -> Any:
    from magcilia.acquire.coil import CoilSequence, record_coil
    from magcilia.acquire.simulated_coil import SimulatedCoilSource

    path = Path(tempfile.mkdtemp()) / "coil.tdms"
    return record_coil(SimulatedCoilSource(TAPERED, rng=0), path,
                       CoilSequence.of([[0.0, 0.0, 0.0], [2e-4, 0.0, 0.0]]), samples=50)


def _recalibration() -> tuple[Any, Any]:
    from magcilia.readout.recalibration import Recalibrator
    from magcilia.readout.recalibration_windows import PulseWindow

    window = PulseWindow.of([5e-4, 0.0, 0.0], [0.0, 1e-6, -1e-6], [0.0375, 0.0375, 0.03751])
    rc = Recalibrator(TAPERED, points=3)
    return rc.update([window, window]), window


def _stream() -> Any:
    from magcilia.acquire import SimulatedSource, record_stream

    path = Path(tempfile.mkdtemp()) / "stream.tdms"
    return record_stream(SimulatedSource(SETUP, rng=0), path, 0.1)


def _live() -> Any:
    from magcilia.acquire import SimulatedSource
    from magcilia.live import LiveReadout

    live = LiveReadout(SimulatedSource(SETUP, 0.2, rng=0),
                       mc.Readout(SETUP, span=(-0.5, 0.5), table_size=17), rate=100,
                       tare_at_start=True, tare_seconds=0.1)
    with live:
        live.wait(20)
    return live


def _gather_example() -> Any:
    from magcilia.io.export_recording import gather
    from magcilia.io.recordings import example_path

    return gather(example_path())


def _biaxial() -> Any:
    from magcilia.device.magnetometer import Magnetometer

    sensor = Magnetometer(field_range=1e-3, resolution=1e-9, noise=2e-8, rate=100.0)
    return mc.BiaxialReadout(TAPERED, sensor, span=1e-4, table_size=(9, 16))


def _identifiability() -> Any:
    from magcilia.calibration.coil_rows import coil_jacobian
    from magcilia.calibration.identifiability import experiment_information

    fields = 4e-4 * np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0], [0.6, 0.6, 0.5],
                              [0, 0, -1]])
    rows = coil_jacobian(TAPERED, fields, measure="field")
    return mc.calibration.identify(experiment_information(rows, 1e-8),
                                   ("height", "base_radius", "x", "y", "z",
                                    "magnetization_scale", "youngs_modulus"), TAPERED)


FACTORIES: dict[str, Callable[[], Any]] = {
    "Measurement": _measurement,
    "CalibrationResult": _calibration,
    "ParameterCovariance": lambda: _calibration().uncertainty,
    "JointCalibrationResult": _joint,
    "ExperimentFit": lambda: _joint().experiments[0],
    "FitParameter": lambda: _calibration().parameters[0],
    "OATResult": lambda: mc.oat_sweep(SETUP, "x", [1.2e-3, 1.5e-3], angles=ANGLES),
    "PlacementMap": lambda: placement_map(SETUP, [1.2e-3, 1.6e-3], [1.8e-3, 2.2e-3],
                                          angles=ANGLES),
    "SensitivityStudy": lambda: mc.sensitivity_study(SETUP, points=3, map_points=3,
                                                     angles=ANGLES),
    "SobolResult": lambda: mc.sobol_indices(SETUP, n_base=16, angles=ANGLES, rng=0),
    "PlacementTolerance": lambda: mc.placement_tolerance(SETUP, angles=ANGLES),
    "Tolerances": mc.Tolerances,
    "CoilSelfTest": mc.CoilSelfTest,
    "CalibrationFreeError": lambda: mc.calibration_free_error(TAPERED, 1e-5),
    "PiecewiseLinear": lambda: mc.piecewise_linear(SETUP, corners=1, grid=101),
    "LookupTable": lambda: mc.lookup_table(SETUP, 16),
    "FixedPointFormat": lambda: fixed_point_format(mc.piecewise_linear(SETUP, corners=1,
                                                                       grid=101)),
    "BentShape": lambda: mc.bend(TAPERED, force=1e-4),
    "SpatialBentShape": lambda: mc.bend(TAPERED, force=1e-4, azimuth=0.5),
    "Actuation": lambda: mc.Actuation.uniform((0.0, 0.0, 5e-3)),
    "Readout": lambda: mc.Readout(SETUP, quantity="angle", span=(0.0, 0.5), table_size=17),
    "ReadoutResult": lambda: mc.Readout(SETUP, span=(0.0, 0.5), table_size=17).read(
        SETUP.output([0.1, 0.3, 2.0])),
    "Tare": lambda: mc.Readout(SETUP, span=(0.0, 0.5), table_size=17).tare(
        SETUP.output([0.0, 0.0]) + [1e-5, -1e-5]).baseline,
    "RestCheck": lambda: mc.Readout(SETUP, span=(0.0, 0.5), table_size=17).tare(
        SETUP.output(np.zeros(40)) + np.where(np.arange(40) < 20, 0.0, 1e-4)).baseline.check,
    "BiaxialReadout": _biaxial,
    "ForceVectorResult": lambda: _biaxial().read(_biaxial().model([1e-5, 5e-5], [0.0, -3e-5])),
    "Channel": lambda: _biaxial().channels[0],
    "DesignMetrics": lambda: mc.design_metrics(TAPERED, points=11),
    "Metric": lambda: mc.design_metrics(TAPERED, points=11).angle,
    "SweepResult": _sweep,
    "SweepPoint": lambda: _sweep().points[0],
    "CoilResult": _coil_sweep,  # issue 29: record --coil
    "CoilPoint": lambda: _coil_sweep().points[0],
    "PulseWindow": lambda: _recalibration()[1],  # issue 29: in-use re-calibration
    "Recalibration": lambda: _recalibration()[0],
    "StreamResult": _stream,
    "LiveSamples": lambda: _live().history.last(1.0, 100.0),
    "LiveStatus": lambda: _live().status,
    "Limits": lambda: _live().limits(),
    "Event": lambda: _live().events[0],
    "Posterior": lambda: importlib.import_module("magcilia.calibration").sample_posterior(
        lambda P: -0.5 * np.sum(((P - [3e-3, 1e-5]) / [1e-4, 1e-6]) ** 2, axis=1),
        [3e-3, 1e-5], names=["height", "offset"], bounds=[(2e-3, 4e-3), (-1e-4, 1e-4)],
        n_effective=100, rng=0),
    "Design": lambda: mc.calibration.d_optimal(np.stack([np.ones(5), np.linspace(-1, 1, 5)], 1),
                                               4, names=["offset", "x"]),
    "CalibrationPlan": lambda: mc.calibration.plan_calibration(SETUP, 6, angles=ANGLES,
                                                               prior_sd={"height": 1e-4}),
    "CoilPlan": lambda: mc.calibration.plan_coil(TAPERED, 8, measure="field",
                                                 prior_sd={"height": 1.5e-4},
                                                 magnitudes=[4e-4]),
    "Identifiability": _identifiability,
    "IdentifiabilityTable": lambda: importlib.import_module(
        "magcilia.analysis.identifiability_table").IdentifiabilityTable(
        rows=(("force-sensor", "MMC5983MA", "coil only", _identifiability()),),
        modulus_sigma={"force-sensor": 1e5}),
    "Magnetometer": lambda: mc.Magnetometer.preset("LIS3MDL", position=(1e-3, 0.0, 0.0)),
    "Modulus": lambda: SETUP.modulus,
    "SensorCheck": lambda: mc.Setup.paper_initial().check_sensor(ANGLES),
    "TiltMeasurement": lambda: importlib.import_module("magcilia.acquire.photo").measure_tilt(
        np.where(np.abs(np.add.outer(np.arange(120.0) * 0.17, np.arange(160.0) - 80)) < 3,
                 0.9, 0.2)),
}
def _array() -> Any:
    from magcilia.device.magnetometer import Magnetometer

    part = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0)
    setup = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0.0, 0.0, 0.0))
    return mc.ArrayReadout(mc.CiliaArray.grid(setup, 2, 2, 2e-3, sensor=part), 2e-5,
                           table_size=9)


FACTORIES.update({
    "ArrayReadout": _array,
    "ArrayStream": lambda: _array().stream(),  # issue 27: frame after frame, warm
    "Crosstalk": lambda: _array().crosstalk(),
    "ArrayEstimate": lambda: _array().read(_array().rest),
    "ArrayEstimates": lambda: _array().read(np.stack([_array().rest] * 2)),
    "ArrayMetrics": lambda: mc.array_metrics(
        _array().array.cilia[0], [2e-3, 3e-3], sensor=_array().array.sensors[0], span=2e-5,
        rows=2, cols=2, table_size=9),
})
FACTORIES.update({  # issue 15: sensing while actuating
    "ActuatedReadout": lambda: mc.ActuatedReadout(
        TAPERED, "force", (0.0, 1e-4), mc.Actuation.uniform((1e-4, 0.0, 0.0)), [0.0, 1.0],
        table_size=9),
    "Coupling": lambda: measure_coupling([0.0, 0.5, 1.0], [1e-3, 1.5e-3, 2.1e-3]),
})


def _batch() -> Any:
    from magcilia.batch import calibrate_batch

    folder = Path(tempfile.mkdtemp())
    rec = synthetic_recording(SETUP, ANGLES, samples_per_angle=3, rng=2)
    for name in ("a", "b"):
        (folder / f"{name}.csv").write_text("angle_deg,voltage_V\n" + "".join(
            f"{a!r},{v!r}\n" for a, v in zip(rec.angle_deg, rec.voltage, strict=True)))
    return calibrate_batch(str(folder / "*.csv"), folder / "out", workers=1, starts=8,
                           figures=False, progress=False)


FACTORIES["BatchResult"] = _batch


def _optimum() -> Any:
    return mc.optimise_design(TAPERED, n=32, refine=4, rng=0, workers=1, points=31,
                              min_force=1e-5)


FACTORIES.update({"DesignOptimum": _optimum, "Candidate": lambda: _optimum().best})
FACTORIES.update({  # issue 25: what the readers say of a recording
    "RecordingQuality": lambda: importlib.import_module("magcilia.io.quality").check_samples(
        np.r_[np.repeat([0.0, 10.0], 40), 5.0], np.r_[np.repeat([1e-3, 2e-3], 40), 1.5e-3]),
    "RecordingState": lambda: importlib.import_module(
        "magcilia.io.recording_state").RecordingState.from_properties(
        {"magcilia_version": "0", "complete": False, "planned_angles_deg": "[0, 10, 20]",
         "samples_per_angle": 40, "stopped": "stopped at angle 3: interrupted"}),
})
FACTORIES["BatchFit"] = lambda: importlib.import_module("magcilia.fitting").fit_batch(  # issue 26
    lambda x, which: np.stack([10.0 * (x[:, 1] - x[:, 0] ** 2), 1.0 - x[:, 0]], axis=1),
    [[-1.2, 1.0], [2.0, -1.0]], [-5.0, -5.0], [5.0, 5.0], maxiter=200)
FACTORIES.update({  # issue 28: the cilium in time
    "Modes": lambda: mc.modes(TAPERED, "water"),
    "FrequencyResponse": lambda: mc.frequency_response(TAPERED, [0.0, 10.0, 100.0],
                                                       fluid="water"),
    "TransientResponse": lambda: mc.simulate_response(
        mc.presets.load("force-sensor"), np.r_[0.0, np.full(9, 1e-6)], 1e4, fluid=mc.AIR),
    "DynamicReadout": lambda: mc.DynamicReadout(
        mc.Readout(mc.presets.load("force-sensor"), quantity="force", span=(-2e-5, 2e-5),
                   table_size=17), 1e4, fluid=mc.AIR),
})
FACTORIES["RingdownResult"] = lambda: mc.ringdown(  # issue 28: a flicked cilium's ring-down
    0.1 + np.exp(-20.0 * np.arange(2000) / 5e3) * np.cos(2 * np.pi * 150.0 * np.arange(2000) / 5e3)
    + np.random.default_rng(0).normal(0.0, 1e-3, 2000), 5e3)
FACTORIES.update({  # issue 29: temperature
    "TemperatureModel": lambda: mc.TemperatureModel(drive="current", temperature_sigma=0.1),
    "ThermalReadout": lambda: mc.ThermalReadout(
        mc.Readout(SETUP, span=(0.0, 0.5), table_size=17), calibrated_range=(290.0, 300.0)),
    "ThermalResult": lambda: mc.ThermalReadout(
        mc.Readout(SETUP, span=(0.0, 0.5), table_size=17)).read(
        np.column_stack([SETUP.output([0.1, 0.2]), [293.15, 310.0]])),
    "RecordingExport": _gather_example,  # issue 30: magcilia export
})
ROUND_TRIPS = ("Measurement", "ParameterCovariance", "PiecewiseLinear", "LookupTable",
               "Magnetometer", "ExperimentFit", "TemperatureModel")


@pytest.fixture(scope="module", params=sorted(FACTORIES))
def result(request: pytest.FixtureRequest) -> Any:
    return FACTORIES[request.param]()


def test_results_are_frozen(result: Any) -> None:
    assert dataclasses.is_dataclass(result)
    field = dataclasses.fields(result)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(result, field, None)


def test_to_dict_is_json(result: Any) -> None:
    doc = json.loads(json_text(result.to_dict()))
    assert isinstance(doc, dict) and doc


def test_report_is_text(result: Any) -> None:
    text = result.report()
    assert isinstance(text, str) and text.strip()
    assert "Traceback" not in text


@pytest.mark.parametrize("name", ROUND_TRIPS)
def test_from_dict_round_trips(name: str) -> None:
    result = FACTORIES[name]()
    back = type(result).from_dict(json.loads(json_text(result.to_dict())))
    assert json_text(back.to_dict()) == json_text(result.to_dict())


#: factories of a class already listed under its own name (a second way to make it: the physical
#: model's CalibrationResult, under its former class name)
SECOND_FACTORIES = {"JointCalibrationResult"}


def test_every_result_class_is_checked_here() -> None:
    """Each class of the package that has ``to_dict`` is a result and is in FACTORIES."""
    found = set()
    for info in pkgutil.walk_packages(magcilia.__path__, "magcilia."):
        module = importlib.import_module(info.name)
        for name, obj in vars(module).items():
            if (inspect.isclass(obj) and obj.__module__ == module.__name__
                    and obj.__name__ == name and not getattr(obj, "_is_protocol", False)
                    and callable(getattr(obj, "to_dict", None))):
                found.add(name)
    assert found == set(FACTORIES) - SECOND_FACTORIES


def test_calibration_result_holds_its_covariance() -> None:
    fit = _calibration()
    assert isinstance(fit.uncertainty, mc.ParameterCovariance)
    assert fit.stderr is fit.uncertainty.stderr
    assert fit.correlation_names == fit.uncertainty.correlation_names
    doc = fit.to_dict()
    assert doc["covariance"]["names"] == list(fit.correlation_names)
    back = mc.ParameterCovariance.from_dict(json.loads(json_text(doc)))
    for key, value in fit.stderr.items():
        assert back.stderr[key] == pytest.approx(value) or (math.isinf(value)
                                                           and math.isinf(back.stderr[key]))


def test_readout_is_frozen_and_takes_a_calibration_result() -> None:
    fit = _calibration()
    r = mc.Readout(fit.setup, quantity="angle", span=(0.0, 1.0), calibration=fit, table_size=17)
    assert r.calibration is fit.uncertainty
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.quantity = "force"  # type: ignore[misc]
    assert r.table.error == r.table_error
