"""The coil calibration (issue 29, item 1): exact-body synthetic coil data, no tilt, a ±0.15 mm
height prior: height, base radius, x, y, z and the magnetization scale recovered within 2σ, the 2σ
intervals covering the truth at the nominal rate over many noise draws; and what the fit says when
the data cannot determine a combination (no size information, fields along one axis)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binom

import magcilia as mc
from magcilia.calibration.coil_model import coil_bounds, default_sequence
from magcilia.calibration.joint import YOUNGS_BOUNDS, joint_problem
from magcilia.calibration.joint_result import joint_result
from magcilia.calibration.layout import as_layout
from magcilia.calibration.problem import DEFAULT_BOUNDS

sys.path.insert(0, str(Path(__file__).parent))
import coil_truth as ct

#: the coverage study: a 3-axis part with a ±2 mT linear range (the default sequence reaches
#: 15 G), 0.5 nT standard error per condition (2000 samples of a ~20 nT RMS part), the paper's
#: force-sensor cilium (coil_truth.TRUTH); a ±0.15 mm measured height
RANGE, SE, PRIOR = 2e-3, 5e-10, 1.5e-4
#: the parameters the issue asks to be recovered (the modulus is reported, not required)
RECOVERED = ("height", "base_radius", "x", "y", "z", "magnetization_scale")


@pytest.fixture(scope="module")
def exact() -> tuple[mc.Setup, np.ndarray, np.ndarray]:
    truth = ct.truth()
    applied = default_sequence(RANGE)
    return truth, applied, ct.exact_cilium(truth, applied)


def _coverage(exact: tuple[mc.Setup, np.ndarray, np.ndarray], seeds: int) -> None:
    truth, applied, cilium = exact
    rng = np.random.default_rng(2929)
    recs = [ct.recording(applied, cilium, SE, rng) for _ in range(seeds)]
    heights = truth.cilium.height + PRIOR * rng.standard_normal(seeds)
    x, se = ct.local_fits(truth, recs, heights, PRIOR)
    values = {**truth.params(), "youngs_modulus": truth.youngs_modulus}
    z = (x - np.array([values[n] for n in ct.NAMES])) / se
    lo, hi = binom.ppf([0.0005, 0.9995], seeds, 0.95)  # a 99.9 % binomial band
    for k, name in enumerate(ct.NAMES):
        inside = int(np.sum(np.abs(z[:, k]) < 2.0))
        assert lo <= inside <= hi, (name, inside, seeds)
        # honest, not inflated: the spread of the errors in units of σ is near 1
        spread = float(np.std(z[:, k]))
        assert 1.0 - 3.0 / np.sqrt(seeds) < spread < 1.0 + 3.0 / np.sqrt(seeds), (name, spread)
    # seed 0 alone: every recovered parameter within 2σ of the truth
    assert all(abs(z[0, ct.NAMES.index(n)]) < 2.0 for n in RECOVERED)


def test_coverage_over_8_seeds(exact: tuple[mc.Setup, np.ndarray, np.ndarray]) -> None:
    """The default run's short form (~1 s a fit); the issue's ≥ 100 seeds: the slow test."""
    _coverage(exact, 8)


@pytest.mark.slow
def test_coverage_over_100_seeds(exact: tuple[mc.Setup, np.ndarray, np.ndarray]) -> None:
    _coverage(exact, 100)


def _result(truth: mc.Setup, applied: np.ndarray, priors: dict[str, tuple[float, float]]
            ) -> mc.CalibrationResult:
    """The result at the truth (no search): what the fit's uncertainty says of these data."""
    lay = as_layout((16, 5), truth, 2e-4)
    box = {**DEFAULT_BOUNDS, "youngs_modulus": YOUNGS_BOUNDS, **coil_bounds(truth)}
    box = {n: box[n] for n in ct.NAMES}
    m = ct.recording(applied, ct.exact_cilium(truth, applied, 50), SE, np.random.default_rng(0))
    problem = joint_problem([m], truth, lay, box, ct.NAMES, priors)
    x = np.array([{**truth.params(), "youngs_modulus": truth.youngs_modulus}[n]
                  for n in ct.NAMES])
    return joint_result(problem, lay, truth, box, x, False, time.perf_counter())


def test_without_size_information_the_scale_is_undetermined() -> None:
    truth = ct.truth()
    res = _result(truth, default_sequence(RANGE), {})
    found = [w for w in res.diagnostics if w.kind == "undetermined"]
    assert len(found) == 1
    assert set(found[0].parameters) >= {"height", "base_radius", "x", "y", "z"}
    assert "scale symmetry" in found[0].message and "--prior height=" in found[0].message
    assert all(res.uncertainty.stderr[n] == np.inf for n in ("height", "base_radius", "x"))
    # a size prior determines it: the note says the prior does
    res = _result(truth, default_sequence(RANGE), {"height": (truth.cilium.height, PRIOR)})
    assert not [w for w in res.diagnostics if w.kind == "undetermined"]
    assert [w for w in res.diagnostics if w.kind == "prior_only"]
    assert all(np.isfinite(res.uncertainty.stderr[n]) for n in ct.NAMES)


def test_fields_along_one_axis_leave_a_combination_open() -> None:
    truth = ct.truth()
    along_x = np.linspace(-1.5e-3, 1.5e-3, 13)[:, None] * np.array([1.0, 0.0, 0.0])
    res = _result(truth, along_x, {"height": (truth.cilium.height, PRIOR)})
    found = [w for w in res.diagnostics if w.kind == "undetermined"]
    assert len(found) == 1 and "practically undetermined" in found[0].message
    assert "magnetization_scale" in found[0].parameters
