"""The start-up coil self-test in the robust metric (``RobustSpec(self_test=CoilSelfTest())``,
``optimise --objective robust --self-test coil``): it recovers a device's magnetization and
stiffness within their noise σ, it agrees with the public ``Recalibrator`` fitted on windows of
perturbed ``Setup`` s bent by ``mc.bend``, it changes nothing with zero tolerances, and it removes
the modulus's error that no design can."""

from __future__ import annotations

import json

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.cli import main
from magcilia.design.robust import (
    RobustSpec,
    Tolerances,
    _devices,
    calibration_free_error,
    device_parameters,
)
from magcilia.design.self_test import WINDOWS, CoilSelfTest, estimate, measure
from magcilia.readout.recalibration_windows import PulseWindow, RestWindow, StrapWindow

SETUP = mc.Setup.paper(tip_radius=5e-5, layout="converged").resolve_layout()
SPAN = 1.2e-4  # N: within the paper cilium's force range
NONE = Tolerances(0.0, 0.0, 0.0, 0.0, 0.0)
#: the composite's tolerances alone (the geometry exact): what the self-test must recover
MATERIAL = Tolerances(0.0, 0.0, 0.0, 0.10, 0.30)


def _sigma(test: CoilSelfTest, prm: dict[str, np.ndarray], own: np.ndarray
           ) -> dict[str, np.ndarray]:
    """Each estimate's σ by linear propagation of every window's noise (one window at a time
    moved by its σ: strap, rest and the pulses' odd parts, as ``measure`` draws them)."""
    clean = measure(SETUP, CoilSelfTest(test.level, test.window, test.cycles, noise=False),
                    prm, own,
                    np.random.default_rng(0))
    base = estimate(SETUP, test, clean)
    sigma = test.window_noise(SETUP)
    var = {n: np.zeros(own.size) for n in ("magnetization", "stiffness")}
    for j, factor in enumerate((np.sqrt(0.5), 1.0, np.sqrt(0.5), np.sqrt(0.5))):
        moved = [a.copy() for a in clean]
        moved[j] += factor * sigma
        est = estimate(SETUP, test, (moved[0], moved[1], moved[2], moved[3]))
        for name in var:
            var[name] += (est[name] - base[name]) ** 2
    return {n: np.sqrt(a) for n, a in var.items()}


def test_the_self_test_recovers_magnetization_and_stiffness_within_sigma() -> None:
    test = CoilSelfTest()
    spec = RobustSpec(MATERIAL, samples=32, seed=2, self_test=test)
    prm, own = _devices(SETUP, spec)
    stiffness = prm["youngs_modulus"] / SETUP.youngs_modulus
    assert np.ptp(own) > 0.2 and np.ptp(stiffness) > 0.5  # the devices differ
    # noise-free: the Recalibrator's model (linear in m²/k) is all that is left
    exact = estimate(SETUP, test, measure(SETUP, CoilSelfTest(noise=False), prm, own,
                                          np.random.default_rng(0)))
    np.testing.assert_allclose(exact["magnetization"], own, rtol=1e-4)
    np.testing.assert_allclose(exact["stiffness"], stiffness, rtol=3e-3)
    np.testing.assert_allclose(exact["sensitivity"], 1.0, rtol=1e-4)
    # with the sensor's noise: within 4σ each, and the σ-normalised errors spread about as σ
    est = estimate(SETUP, test, measure(SETUP, test, prm, own, np.random.default_rng(7)))
    sigma = _sigma(test, prm, own)
    for name, truth in (("magnetization", own), ("stiffness", stiffness)):
        z = (est[name] - truth) / sigma[name]
        assert np.abs(z).max() < 4.0, (name, z)
        assert 0.5 < np.std(z) < 1.6, (name, np.std(z))


def test_the_closed_form_agrees_with_the_public_recalibrator() -> None:
    """Independent path: each device built as a perturbed ``Setup``, its windows from
    ``mc.bend(..., actuation=mc.Actuation.uniform(B))`` and ``Setup.field``, fitted by the public
    ``Recalibrator`` (Gauss–Newton over the four pulses as separate windows, nothing held)."""
    test = CoilSelfTest(noise=False)
    spec = RobustSpec(samples=3, seed=5, self_test=test)
    prm, own = _devices(SETUP, spec)
    est = estimate(SETUP, test, measure(SETUP, test, prm, own, np.random.default_rng(0)))
    recalibrator = mc.Recalibrator(SETUP, hold=())
    sigma, b = test.window_noise(SETUP), test.pulse(SETUP)
    drawn = device_parameters(SETUP, spec)
    for i in range(spec.samples):
        device = SETUP.replace(**{k: float(a[i]) for k, a in drawn.items()})

        def output(field: np.ndarray, device: mc.Setup = device) -> float:
            shape = mc.bend(device, 0.0, actuation=mc.Actuation.uniform(field)
                            if np.any(field) else None)
            return float(device.sensor.voltage(np.ravel(device.field(shape))[0] + field[0]))

        rest, offset = output(np.zeros(3)), float(device.sensor.offset)
        windows: list[PulseWindow | RestWindow | StrapWindow] = [
            StrapWindow(offset, sigma, offset, sigma), RestWindow(rest, sigma)]
        for field in b * np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]]):
            windows.append(PulseWindow((field[0], field[1], field[2]), rest, sigma,
                                       output(field), sigma))
        fit = recalibrator.update(windows)
        for name in ("sensitivity", "magnetization", "stiffness"):
            assert fit.values[name] == pytest.approx(est[name][i], rel=5e-4), name


def test_zero_tolerances_the_self_test_changes_nothing() -> None:
    spec = RobustSpec(NONE, samples=4, points=9, self_test=CoilSelfTest(noise=False))
    err = calibration_free_error(SETUP, SPAN, spec)
    assert err.rms < 1e-9 and err.worst < 1e-9 and err.failed == 0
    assert err.self_test is spec.self_test and "coil self-test" in err.report()
    assert err.to_dict()["self_test"]["duration_s"] == pytest.approx(WINDOWS * 0.25 * 4)
    # with the sensor's noise: a small error, the noise's
    noisy = calibration_free_error(SETUP, SPAN, RobustSpec(NONE, samples=16, points=9,
                                                           self_test=CoilSelfTest()))
    assert 0.0 < noisy.rms < 0.02


def test_the_self_test_removes_the_modulus_error() -> None:
    """Where the modulus dominates (±30 %, a small placement tolerance), the nominal model
    reads ~15 % off whatever the design; read after the self-test, a small part of it."""
    spec = RobustSpec(Tolerances(10e-6, 0.0, 0.0, 0.0, 0.30), samples=32, seed=4, points=9)
    without = calibration_free_error(SETUP, SPAN, spec)
    with_test = calibration_free_error(SETUP, SPAN,
                                       RobustSpec(spec.tolerances, samples=32, seed=4, points=9,
                                                  self_test=CoilSelfTest()))
    assert without.rms > 0.1
    assert with_test.rms <= without.rms and with_test.rms < 0.25 * without.rms


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"level": 1.5}, "self-test level must be a fraction of the sensor's range in \\(0, 1\\)"),
    ({"window": 0.0}, "self-test window must be"),
    ({"noise": "yes"}, "self-test noise must be True or False"),
])
def test_bad_self_tests(kwargs: dict[str, object], message: str) -> None:
    with pytest.raises(MagciliaError, match=message):
        CoilSelfTest(**kwargs)  # type: ignore[arg-type]
    with pytest.raises(MagciliaError, match="self_test must be None or a"):
        RobustSpec(self_test="coil")  # type: ignore[arg-type]


FAST = ["--designs", "16", "--refine", "4", "--polish", "0", "--workers", "1", "--quiet",
        "--devices", "4"]


def test_the_command_reads_after_the_self_test(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["optimise", "--objective", "robust", *FAST, "--self-test", "coil",
                 "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["robust"]["self_test"]["duration_s"] == pytest.approx(WINDOWS * 0.25 * 4)
    assert 0.0 < doc["best"]["calibration_free_error"] < 1.0
    from magcilia.cli.optimise import optimise_text
    from magcilia.report.units import output_units

    assert "read after a coil self-test (7 s)" in optimise_text(doc, output_units(False))
    assert main(["optimise", *FAST, "--self-test", "coil"]) == 2
    err = capsys.readouterr().err
    assert "--self-test must be given with --objective robust only" in err
    assert err.count("\n") == 1


def test_a_self_test_that_cannot_separate_falls_back_to_the_nominal_model() -> None:
    """On the hair's plane of symmetry (y = 0) a y pulse bends the hair without changing B_x:
    the test cannot separate the sensitivity from m²/k, every device's self-test fails and it is
    read with the nominal model, exactly as without the self-test."""
    on_plane = SETUP.replace(y=0.0).resolve_layout()
    spec = RobustSpec(MATERIAL, samples=8, seed=1, points=9)
    without = calibration_free_error(on_plane, SPAN, spec)
    tested = calibration_free_error(on_plane, SPAN, RobustSpec(
        MATERIAL, samples=8, seed=1, points=9, self_test=CoilSelfTest(noise=False)))
    assert tested.self_test_failed == 8 and without.rms > 0.05
    assert tested.rms == pytest.approx(without.rms, rel=1e-9)
