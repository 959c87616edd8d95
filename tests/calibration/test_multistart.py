"""The global search finds the best fit of recordings drawn across the default bounds."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.synthetic import synthetic_recording
from magcilia.calibration import DEFAULT_BOUNDS, INTEGER
from magcilia.io.recordings import measurement_from_samples

ANGLES = np.radians(np.linspace(0.0, 85.0, 33))


def _drawn(seed: int) -> tuple[mc.Measurement, mc.Setup]:
    """A recording of a setup drawn uniformly across the default bounds (every n and k)."""
    rng = np.random.default_rng(seed)
    while True:
        draw = {p: (int(rng.integers(lo, hi + 1)) if p in INTEGER else float(rng.uniform(lo, hi)))
                for p, (lo, hi) in DEFAULT_BOUNDS.items()}
        truth = mc.Setup.paper_initial().replace(**draw)
        try:
            rec = synthetic_recording(truth, ANGLES, samples_per_angle=200, rng=rng)
        except mc.MagciliaError:  # the element inside this cilium: draw again
            continue
        return measurement_from_samples(rec.angle_deg, rec.voltage), truth


def _truth_cost(data: mc.Measurement, truth: mc.Setup) -> float:
    """The cost of the true parameters, polished with n and k held."""
    held = {**DEFAULT_BOUNDS, "n_loops": (truth.n_loops,) * 2,
            "dipoles_per_loop": (truth.dipoles_per_loop,) * 2}
    return mc.calibrate(data, initial=truth, bounds=held, starts=1).cost


@pytest.mark.parametrize("seed", range(8))
def test_best_fit_found_across_the_bounds(seed: int) -> None:
    data, truth = _drawn(seed)
    fit = mc.calibrate(data, rng=seed)
    assert fit.cost <= 1.05 * _truth_cost(data, truth)
    assert fit.evaluations > 0 and fit.elapsed < 30


def test_one_slice_of_two_dipoles_is_found() -> None:
    # n = 1, k = 2 differs in kind from the near-continuous body of many dipoles: the search must
    # reach it from the paper's initial n = 6, k = 3
    truth = mc.Setup.paper().replace(n_loops=1, dipoles_per_loop=2)
    rec = synthetic_recording(truth, ANGLES, samples_per_angle=400, rng=11)
    data = measurement_from_samples(rec.angle_deg, rec.voltage)
    fit = mc.calibrate(data, rng=0)
    assert fit.cost <= 1.05 * _truth_cost(data, truth)


def test_more_restarts_never_do_worse() -> None:
    data, _ = _drawn(20)
    one = mc.calibrate(data, rng=3, starts=64)
    three = mc.calibrate(data, rng=3, starts=64, restarts=3)
    assert three.cost <= one.cost * (1 + 1e-9)
    assert len(three.restart_costs) == 3 and three.restart_costs[0] == pytest.approx(one.cost)


def test_same_fit_without_numba(monkeypatch: pytest.MonkeyPatch) -> None:
    # the NumPy reference model (used where numba cannot be imported) gives the same search
    from magcilia.model import compiled

    data, _ = _drawn(5)
    fast = mc.calibrate(data, rng=2, starts=32)
    monkeypatch.setattr(compiled, "ENABLED", False)
    slow = mc.calibrate(data, rng=2, starts=32)
    assert slow.cost == pytest.approx(fast.cost, rel=1e-6)
    assert slow.values["n_loops"] == fast.values["n_loops"]
