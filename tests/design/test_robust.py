"""The calibration-free read-out error (``optimise --objective robust``): the vectorised Monte
Carlo against an independent path (perturbed setups read through the public ``Readout``), its
zero, its growth with each tolerance, the modulus's exact force scale, and bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.cli import main
from magcilia.design.robust import (
    TOLERANCES,
    RobustSpec,
    Tolerances,
    calibration_free_error,
    device_outputs,
    device_parameters,
    nominal_table,
    read_errors,
    tolerance_shares,
)

SETUP = mc.Setup.paper(tip_radius=5e-5, layout="converged").resolve_layout()
SPAN = 1.2e-4  # N: within the paper cilium's force range (≥ 0.13 mN, not reached)
NONE = Tolerances(0.0, 0.0, 0.0, 0.0, 0.0)


def test_zero_tolerances_leave_only_the_models_own_error() -> None:
    err = calibration_free_error(SETUP, SPAN, RobustSpec(NONE, samples=4, points=9))
    assert err.rms < 1e-6 and err.worst < 1e-6 and err.failed == 0


@pytest.mark.parametrize("name", TOLERANCES)
def test_the_error_grows_with_each_tolerance(name: str) -> None:
    spec = RobustSpec(samples=24, seed=3, points=9)
    nominal = getattr(Tolerances(), name)
    errors = [calibration_free_error(SETUP, SPAN, spec.with_tolerances(
        Tolerances(**{n: (f * nominal if n == name else 0.0) for n in TOLERANCES}))).rms
        for f in (0.0, 0.5, 1.0)]
    assert errors[0] < 1e-6 < errors[1] < errors[2], errors


def test_a_modulus_off_scales_every_force_exactly() -> None:
    """E' = E·exp(σz): the device bends under F as the nominal under F·E/E', so it reads
    F·exp(−σz) (clipped to the span), whatever the design: the independent reference."""
    spec = RobustSpec(Tolerances(0.0, 0.0, 0.0, 0.0, 0.2), samples=32, seed=1, points=21)
    forces = np.linspace(0.0, SPAN, spec.points)
    factor = np.exp(-0.2 * spec.draws[:, 5])
    expected = (np.clip(forces[None, :] * factor[:, None], 0.0, SPAN) - forces) / SPAN
    err = calibration_free_error(SETUP, SPAN, spec)
    assert err.rms == pytest.approx(math.sqrt(np.mean(expected**2)), rel=2e-3)
    # the share: the modulus's error does not depend on the placement
    moved = SETUP.replace(x=SETUP.value("x") + 3e-4, z=SETUP.value("z") + 1e-4)
    assert calibration_free_error(moved, SPAN, spec).rms == pytest.approx(err.rms, rel=2e-3)


def test_the_monte_carlo_agrees_with_perturbed_setups_read_by_readout() -> None:
    """The same devices built as perturbed ``Setup`` s, bent one by one with ``bend_sweep`` and
    read by the nominal design's public ``Readout`` (tared at rest; a reading beyond the span at
    the span's end): the same errors, reading by reading."""
    spec = RobustSpec(samples=6, seed=11, points=9)
    forces = np.linspace(0.0, SPAN, spec.points)
    volts = device_outputs(SETUP, forces, spec)[1]
    dev = device_parameters(SETUP, spec)
    readout = mc.Readout(SETUP, "force", span=(0.0, SPAN), edge="clip", table_size=129)
    read = []
    for i in range(spec.samples):
        device = SETUP.replace(**{k: float(a[i]) for k, a in dev.items()})
        out = device.output(mc.bend_sweep(device, forces=forces))
        np.testing.assert_allclose(out, volts[i], rtol=0, atol=1e-9 * np.abs(out).max())
        tared = readout.tare(out[0] + np.array([-1e-12, 1e-12]))
        read.append(_value_or_end(tared.read(out)))
    independent = (np.array(read) - forces) / SPAN
    errors = read_errors(forces, nominal_table(SETUP, SPAN), volts, SPAN, tare=True)
    np.testing.assert_allclose(errors, independent, atol=2e-3)


def _value_or_end(result: mc.ReadoutResult) -> np.ndarray:
    """A read-out's forces, a reading beyond the span (no estimate) at the span's end."""
    value = np.array(result.value, dtype=np.float64)
    blank = np.isnan(value)
    value[blank & ((result.flags & mc.Flag.ABOVE_SPAN) != 0)] = SPAN
    value[blank & ((result.flags & mc.Flag.BELOW_SPAN) != 0)] = 0.0
    return value


def test_tolerance_shares_name_every_tolerance_and_all() -> None:
    shares = tolerance_shares(SETUP, SPAN, RobustSpec(samples=8, points=9))
    assert set(shares) == {*TOLERANCES, "all"}
    assert shares["all"].rms >= max(s.rms for n, s in shares.items() if n != "all") * 0.9


def test_untared_reads_offsets_too() -> None:
    spec = RobustSpec(Tolerances(placement=50e-6, height=0.0, base_radius=0.0,
                                 magnetization=0.0, modulus=0.0), samples=16, points=9)
    tared = calibration_free_error(SETUP, SPAN, spec).rms
    raw = calibration_free_error(SETUP, SPAN, RobustSpec(spec.tolerances, samples=16, points=9,
                                                         tare=False)).rms
    assert raw > 2.0 * tared


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"placement": -1e-6}, "tolerance placement must be a value >= 0"),
    ({"modulus": 1.5}, "tolerance modulus must be a relative tolerance below 1"),
    ({"height": math.nan}, "tolerance height must be a finite number"),
])
def test_bad_tolerances(kwargs: dict[str, float], message: str) -> None:
    with pytest.raises(MagciliaError, match=message):
        Tolerances(**kwargs)


def test_the_optimiser_chooses_the_smallest_error() -> None:
    result = mc.optimise_design(objective="robust", n=16, refine=6, polish=0, rng=0, samples=8,
                                workers=1)
    eligible = [d for d in result.designs if d.eligible]
    assert result.best.error == min(d.error for d in eligible)
    assert math.isfinite(result.reference.error) and result.robust is not None
    assert "calibration-free error" in result.report()
    with pytest.raises(MagciliaError, match="tolerances must be None unless"):
        mc.optimise_design(n=16, refine=4, tolerances=Tolerances())


FAST = ["--designs", "16", "--refine", "4", "--polish", "0", "--workers", "1", "--quiet",
        "--devices", "4"]


@pytest.mark.parametrize(("text", "message"), [
    ("placement=-5um", "tolerance placement must be a value >= 0"),
    ("height=150%", "tolerance height must be a relative tolerance below 1"),
    ("colour=5%", "--tolerance name must be one of placement, height"),
    ("height", "--tolerance must be NAME=VALUE items"),
    ("height=5%,height=6%", "each name once"),
    ("height=five%", "--tolerance height must be a percentage (5%) or a fraction"),
    ("placement=3parsec", "--tolerance placement must be a number in mm or with a length unit"),
])
def test_bad_tolerance_option_is_one_line(text: str, message: str, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "doc.json"
    assert main(["optimise", "--objective", "robust", *FAST, "--tolerance", text,
                 "--json-file", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: ") and message in err, err
    assert err.count("\n") == 1 and not out.exists()


def test_tolerance_needs_the_robust_objective(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["optimise", *FAST, "--tolerance", "height=5%"]) == 2
    assert "--tolerance must be given with --objective robust" in capsys.readouterr().err


def test_the_command_prints_and_writes_the_error(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    assert main(["optimise", "--objective", "robust", *FAST, "--tolerance",
                 "placement=0.04,modulus=20%", "--no-tare", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["robust"]["tolerances"] == {"placement_m": 4e-5, "height": 0.05,
                                           "base_radius": 0.05, "magnetization": 0.1,
                                           "modulus": 0.2}
    assert doc["robust"]["tare"] is False and doc["robust"]["samples"] == 4
    best = doc["best"]
    assert 0.0 < best["calibration_free_error"] < 1.0 and best["calibration_free_error_p95"] > 0
    from magcilia.cli.optimise import optimise_text
    from magcilia.report.units import output_units

    text = optimise_text(doc, output_units(False))
    assert "calibration-free error, RMS of the range: reference" in text
    assert "untared, under placement ±40 µm, height ±5 %" in text
