"""Bounded work in calibration: ``plan --budget`` (MAX_WORK, MAX_INFORMATION) and ``--restarts``
/ ``--starts`` (MAX_RESTARTS, MAX_STARTS) are refused beyond their limits in one line before any
work, the work done stays within the bound that defines the limit (counted, not timed), the
memory does not grow with it, and progress is reported as the work goes."""

from __future__ import annotations

import importlib
import tracemalloc

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.calibration import doptimal as plan_module  # the design search (moved out of plan)
from magcilia.calibration.plan import RESTARTS, plan_calibration
from magcilia.calibration.plan_size import MAX_INFORMATION, MAX_WORK, exchange_work
from magcilia.cli import main
from magcilia.io import example_path, read_measurements

search_module = importlib.import_module("magcilia.calibration.search")
SETUP = mc.Setup.paper()
DEFAULT_LIMIT = 2974  # the largest budget for `magcilia plan`'s default 70 candidates, p = 7


class Counter:
    """Counts the candidate designs whose log det the exchange evaluates."""

    def __init__(self) -> None:
        self.matrices = 0

    def __call__(self, monkeypatch: pytest.MonkeyPatch) -> Counter:
        original = plan_module._criterion

        def counted(M: np.ndarray, nuis: np.ndarray) -> np.ndarray:
            self.matrices += int(np.prod(M.shape[:-2], dtype=np.int64))
            return original(M, nuis)

        monkeypatch.setattr(plan_module, "_criterion", counted)
        return self


def test_the_default_limit() -> None:
    assert exchange_work(DEFAULT_LIMIT, 70, 7, RESTARTS) <= MAX_WORK
    assert exchange_work(DEFAULT_LIMIT + 1, 70, 7, RESTARTS) > MAX_WORK


def test_a_budget_beyond_the_limit_is_refused_before_any_work(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    counter = Counter()(monkeypatch)
    assert main(["plan", "--setup", "paper", "--budget", str(DEFAULT_LIMIT + 1), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith(f"magcilia: error: budget must be at most {DEFAULT_LIMIT} readings "
                          "for 70 candidates and 7 parameters (MAX_WORK")
    assert counter.matrices == 0
    # more candidates lower the limit: 343 angles (0.25 deg) x 2 azimuths
    with pytest.raises(MagciliaError, match=r"at most 145 readings for 684 candidates"):
        plan_calibration(SETUP, 500, angles=np.radians(np.arange(0.0, 85.5, 0.25)))
    assert counter.matrices == 0


def test_too_many_candidates_are_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    counter = Counter()(monkeypatch)
    angles = np.radians(np.linspace(0.0, 85.0, 100_000))
    azimuths = np.radians(np.arange(0.0, 360.0, 30.0))  # 12: p = 5 + 36 for the field
    with pytest.raises(MagciliaError, match=f"at most {MAX_INFORMATION:,} entries"):
        plan_calibration(SETUP, 5, sensor="field", angles=angles, azimuths=azimuths)
    assert counter.matrices == 0


@pytest.mark.parametrize(("budget", "step", "sensor"), [(40, 2.5, "output"), (12, 5.0, "field"),
                                                       (300, 5.0, "output")])
def test_the_work_done_stays_within_the_bound(monkeypatch: pytest.MonkeyPatch, budget: int,
                                              step: float, sensor: str) -> None:
    counter = Counter()(monkeypatch)
    calls: list[tuple[int, int]] = []
    angles = np.radians(np.arange(0.0, 85.0 + 1e-9, step))
    plan = plan_calibration(SETUP, budget, sensor=sensor, angles=angles,
                            progress=lambda done, total: calls.append((done, total)))
    c = angles.size * 2
    p = len(plan.design.names)
    assert counter.matrices * p**3 <= exchange_work(budget, c, p, RESTARTS)
    assert calls == [(i, RESTARTS + 1) for i in range(1, RESTARTS + 2)]


@pytest.mark.slow
def test_a_plan_at_the_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    """`magcilia plan paper --budget 2974`: counted work within the bound, memory flat (about
    a minute)."""
    counter = Counter()(monkeypatch)
    tracemalloc.start()
    try:
        plan = plan_calibration(SETUP, DEFAULT_LIMIT)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert plan.design.budget == DEFAULT_LIMIT
    assert counter.matrices * 7**3 <= exchange_work(DEFAULT_LIMIT, 70, 7, RESTARTS)
    assert peak < 50e6


# -- restarts and starts ----------------------------------------------------------------------

@pytest.mark.parametrize(("option", "limit"), [("--restarts", search_module.MAX_RESTARTS),
                                               ("--starts", search_module.MAX_STARTS)])
def test_calibrate_refuses_beyond_the_search_limits(tmp_path: object, option: str, limit: int,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    out = f"{tmp_path}/fit"
    assert main(["calibrate", str(example_path()), "--out", out, option, str(limit + 1),
                 "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"at most {limit} (MAX_" in err


def test_restarts_at_the_limit_count_and_hold_no_memory(monkeypatch: pytest.MonkeyPatch) -> None:
    """MAX_RESTARTS restarts: one global search and one polish each (counted, their work not
    done), progress after each, and no memory kept per restart beyond a cost and a vector."""
    data = read_measurements(example_path())
    searches: list[int] = []
    polished: list[float] = []
    real_polish = search_module._polish
    first: list[tuple[float, np.ndarray]] = []

    def counted_search(problem, space, x_init, gen, starts):  # type: ignore[no-untyped-def]
        searches.append(starts)
        return x_init

    def counted_polish(problem, x, lower, upper, integrality):  # type: ignore[no-untyped-def]
        if not first:  # one real polish; the others return its result
            first.append(real_polish(problem, x, lower, upper, integrality))
        polished.append(first[0][0])
        return first[0]

    monkeypatch.setattr(search_module, "search", counted_search)
    monkeypatch.setattr(search_module, "_polish", counted_polish)
    calls: list[tuple[int, int]] = []
    limit = search_module.MAX_RESTARTS
    tracemalloc.start()
    try:
        fit = search_module.calibrate(data, rng=0, restarts=limit,
                                      progress=lambda d, t: calls.append((d, t)))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert searches == [256] * limit
    assert len(polished) >= limit  # one per restart (and the final refits)
    assert calls[-1] == (limit, limit) and len(calls) == limit
    assert len(fit.restart_costs) == limit
    assert peak < 30e6  # bytes


def test_starts_are_bounded_by_the_angles_they_are_fitted_to(tmp_path: object) -> None:
    from pathlib import Path

    from magcilia.acquire.synthetic import synthetic_recording

    rec = synthetic_recording(SETUP, np.radians(np.linspace(0.0, 85.0, 1001)),
                              samples_per_angle=2, rng=0)
    path = Path(str(tmp_path)) / "fine.csv"
    path.write_text("angle_deg,voltage_V\n" + "".join(
        f"{a:.17g},{v:.17g}\n" for a, v in zip(rec.angle_deg, rec.voltage, strict=True)))
    data = read_measurements(path)
    most = search_module.MAX_START_ANGLES // 1001
    with pytest.raises(MagciliaError, match=f"starts must be at most {most} for 1001 angles "
                                            r"\(MAX_START_ANGLES"):
        search_module.calibrate(data, rng=0, starts=most + 1)
