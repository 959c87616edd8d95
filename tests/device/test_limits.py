"""Limits wherever a size or a number comes from input (issue 12): the registry's bounds, the
model's size, angle grids, approximation grids, calibration bounds, and no NaN leaving the
checked model without an error."""

from __future__ import annotations

import math
import re
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import magcilia as mc
from magcilia.approximation.curve import MAX_GRID
from magcilia.approximation.lookup import MAX_TABLE_SIZE
from magcilia.approximation.piecewise import MAX_CORNERS
from magcilia.calibration import search
from magcilia.calibration.problem import NONFINITE_COST, Problem
from magcilia.cli import main
from magcilia.cli._common import MAX_ANGLES, angle_grid
from magcilia.device.cilium import MAX_PROFILE_POINTS
from magcilia.device.parameters import (
    MAX_DIPOLES,
    MAX_DIPOLES_PER_LOOP,
    MAX_LOOPS,
    PARAMETERS,
    check_ranges,
)
from magcilia.io.recordings import Measurement, example_path, read_measurements
from magcilia.model import pose, tilt_output_batch

NUMERIC = [n for n, p in PARAMETERS.items() if p.domain != "choice"]


# -- the registry ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", NUMERIC)
def test_every_number_has_finite_limits(name: str) -> None:
    p = PARAMETERS[name]
    assert math.isfinite(p.maximum) and p.maximum > 0
    if p.domain in ("positive", "nonzero"):
        assert 0 < p.minimum < p.maximum
    assert p.limits and p.limits in p.allowed_within


@pytest.mark.parametrize("name", NUMERIC)
def test_values_beyond_the_limits_are_refused_naming_them(name: str) -> None:
    p = PARAMETERS[name]
    big = p.maximum * 10 if p.domain != "integer" else p.maximum + 1
    with pytest.raises(mc.MagciliaError) as err:
        p.check(big)
    assert str(err.value).startswith(f"{name} must be ") and p.limits in str(err.value)
    if p.domain in ("positive", "nonzero"):
        with pytest.raises(mc.MagciliaError, match="within"):
            p.check(p.minimum / 10)
    with pytest.raises(mc.MagciliaError, match=re.escape(p.limits)):
        p.check_range(0.5 * big, big, "range")


@pytest.mark.parametrize("name", NUMERIC)
def test_a_setup_at_each_limit_is_finite_or_refused(name: str) -> None:
    """Every parameter at its smallest and largest value: a finite output, or a one-line error
    (the element inside the cilium) — never NaN, inf or another exception."""
    p = PARAMETERS[name]
    low = {"positive": p.minimum, "nonzero": -p.maximum, "real": -p.maximum,
           "integer": 1}.get(p.domain, 0.0)
    for value in (low, p.maximum):
        message = ""
        try:
            out = mc.Setup.paper(**{name: value}).output([0.0, 0.5, 1.4])
        except mc.MagciliaError as exc:
            message = str(exc)
        else:
            assert np.isfinite(out).all(), (name, value, out)
        assert "\n" not in message


def test_a_400_digit_number_is_refused_in_one_short_line() -> None:
    with pytest.raises(mc.MagciliaError) as err:
        PARAMETERS["gain"].check(10**400)
    text = str(err.value)
    assert text.startswith("gain must be a non-zero finite number, with |gain| within")
    assert "(401 characters)" in text and len(text) < 200


def test_positions_are_bounded() -> None:
    with pytest.raises(mc.MagciliaError, match=r"z must be a finite number in m, within \[-1, 1\]"):
        mc.Setup.paper(z=1e306)
    with pytest.raises(mc.MagciliaError, match="x must be"):
        mc.Setup.paper(position=(2.0, 0.0, 0.0))


def test_model_size_limits() -> None:
    assert MAX_DIPOLES < MAX_LOOPS * MAX_DIPOLES_PER_LOOP
    with pytest.raises(mc.MagciliaError, match="n_loops must be an integer >= 1, at most 1000"):
        mc.Setup.paper(n_loops=10**9)
    with pytest.raises(mc.MagciliaError, match="at most 1000"):
        mc.Setup.paper(n_loops=2**63 - 1)
    with pytest.raises(mc.MagciliaError, match=r"n_loops \* dipoles_per_loop must be at most "
                                                r"100000 dipoles per cilium; got 1000 x 101"):
        mc.Setup.paper(n_loops=1000, dipoles_per_loop=101)
    big = mc.Setup.paper(n_loops=1000, dipoles_per_loop=100)  # the largest model
    assert np.isfinite(big.output([0.0, 0.5])).all()


def test_range_checks_include_the_limits() -> None:
    with pytest.raises(mc.MagciliaError, match=r"bounds\['n_loops'\] must be whole numbers >= 1, "
                                                "at most 1000"):
        check_ranges({"n_loops": (1, 1_000_000)})
    with pytest.raises(mc.MagciliaError, match="must be at most 100000 dipoles"):
        check_ranges({"n_loops": (1, 1000), "dipoles_per_loop": (1, 1000)})
    check_ranges({"n_loops": (1, 1000), "dipoles_per_loop": (1, 100)})


def test_profile_points_are_bounded() -> None:
    n = MAX_PROFILE_POINTS + 1
    s = np.linspace(0.0, 3e-3, n)
    with pytest.raises(mc.MagciliaError, match=f"profile must be at most {MAX_PROFILE_POINTS}"):
        mc.Cilium.from_profile(s, np.full(n, 1e-4))
    with pytest.raises(mc.MagciliaError, match=r"profile radius must be radii within"):
        mc.Cilium.from_profile([0.0, 1e-3], [1e-4, 5.0])
    ok = mc.Cilium.from_profile(s[:-1], np.full(n - 1, 1e-4))
    assert np.isfinite(mc.Setup.paper(cilium=ok).output([0.0, 0.5])).all()


# -- NaN never leaves the checked model ------------------------------------------------------------
def _element_on_a_dipole() -> mc.Setup:
    """A waisted profile whose single ring dipole lies outside the body, on the element."""
    h, rb = 2e-3, 2e-4
    cilium = mc.Cilium.from_profile([0.0, h / 2, h], [rb, rb / 10, rb])
    return mc.Setup.paper(cilium=cilium, n_loops=1, dipoles_per_loop=1,
                          position=(-rb, 0.0, -h / 2 - 0.71e-3))


@pytest.mark.parametrize("method", ["output", "field"])
def test_element_on_a_dipole_is_an_error_naming_the_angle(method: str) -> None:
    setup = _element_on_a_dipole()
    with pytest.raises(mc.MagciliaError) as err:
        getattr(setup, method)([0.0, 0.5])
    text = str(err.value)
    assert text.startswith(f"the model's {method} at tilt 0 deg is not finite")
    assert "lies 0 m from one of the model's dipoles" in text and "\n" not in text


def test_element_on_a_dipole_for_centrelines() -> None:
    setup = _element_on_a_dipole()
    line = mc.Centreline.straight(setup.cilium.height, np.array([0.5, 0.0]))
    with pytest.raises(mc.MagciliaError, match="field at centreline 1 at the point"):
        setup.output(line)


def test_batch_kernels_stay_unchecked() -> None:
    """The raw batch gives NaN (the optimisers' fast path); the calibration's cost maps it to a
    bad but finite value."""
    h, rb, depth = 2.0**-9, 2.0**-12, 2.0**-10  # exact in binary: the element exactly on it
    initial = mc.Setup.paper(height=h, base_radius=rb, depth=depth, n_loops=1,
                             dipoles_per_loop=1, position=(0.0, 0.0, 0.0))
    params = {"x": np.array([-rb / 2, 1e-3]), "z": np.array([-h / 2 - depth, 0.0]),
              "y": np.zeros(2)}
    with np.errstate(all="ignore"):
        raw = tilt_output_batch(initial, params, np.array([0.0]))
    assert np.isnan(raw[0]).all() and np.isfinite(raw[1]).all()
    data = Measurement(angles=np.array([0.0, 0.5]), volts=np.array([0.1, 0.2]),
                       sem=np.zeros(2), counts=np.ones(2, dtype=np.int64),
                       saturated=np.zeros(2, dtype=np.int64), nonfinite=np.zeros(2, dtype=np.int64))
    problem = Problem.paper(data, initial, "offset", 0, False)
    full = {"height": np.full(2, h), "base_radius": np.full(2, rb), **params,
            "n_loops": np.ones(2), "dipoles_per_loop": np.ones(2)}
    cost = problem.cost(full)
    assert cost[0] == NONFINITE_COST and cost[1] < NONFINITE_COST


def test_block_evaluation_matches_one_call(monkeypatch: pytest.MonkeyPatch) -> None:
    setup = mc.Setup.paper()
    angles = np.linspace(0.0, 1.4, 1001)
    whole_out, whole_field = setup.output(angles), setup.field(angles)
    monkeypatch.setattr(pose, "BLOCK_PAIRS", 64)  # blocks of 6 angles for 10 dipoles
    fresh = mc.Setup.paper()
    np.testing.assert_array_equal(fresh.output(angles), whole_out)
    np.testing.assert_array_equal(fresh.field(angles), whole_field)


# -- calibration -----------------------------------------------------------------------------------
def test_calibrate_on_nan_data_fails_at_once_naming_the_data(
        monkeypatch: pytest.MonkeyPatch) -> None:
    m = read_measurements(example_path())
    volts = m.volts.copy()
    volts[3] = np.nan
    bad = Measurement(angles=m.angles, volts=volts, sem=m.sem, counts=m.counts,
                      saturated=m.saturated, nonfinite=m.nonfinite, source="bench.csv")

    def started(*_: object, **__: object) -> None:
        raise AssertionError("the search started on NaN data")

    # "at once": before any search (a search that fails later would raise AssertionError)
    monkeypatch.setattr(search, "search", started)
    monkeypatch.setattr(search, "polish", started)
    with pytest.raises(mc.MagciliaError, match=r"bench\.csv: voltage_V of angle 4 of \d+ is nan; "
                                                "calibration needs finite data"):
        mc.calibrate(bad, rng=0)


def test_calibration_bounds_are_limited() -> None:
    m = read_measurements(example_path())
    with pytest.raises(mc.MagciliaError, match=r"bounds\['n_loops'\] must be whole numbers"):
        mc.calibrate(m, bounds={"n_loops": (1, 1_000_000)})
    with pytest.raises(mc.MagciliaError, match=f"at most {search.MAX_FIT_DIPOLES} dipoles per "
                                                "cilium; got 100 x 100 = 10000; narrow"):
        mc.calibrate(m, bounds={"n_loops": (1, 100), "dipoles_per_loop": (1, 100)})


# -- command line and approximation ----------------------------------------------------------------
@pytest.mark.parametrize("text", ["0:85:1e-9", "0:1e9", "-1e308:1e308:1"])
def test_angle_grids_are_bounded(text: str) -> None:
    with pytest.raises(mc.MagciliaError, match=f"at most {MAX_ANGLES} angles"):
        angle_grid(text)


def test_the_largest_angle_grid_is_allowed() -> None:
    assert angle_grid("0:99.9999:0.0001").size == MAX_ANGLES


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["approximate", "--setup", "paper", "--grid", "100000000"],
         f"grid must be at most {MAX_GRID}"),
        (["approximate", "--setup", "paper", "--corners", "40"],
         f"corners must be at most {MAX_CORNERS}"),
        (["approximate", "--setup", "paper", "--table-size", "1000000000"],
         f"size must be at most {MAX_TABLE_SIZE}"),
        (["field", "--setup", "paper", "--angles", "0:85:1e-9"], f"at most {MAX_ANGLES} angles"),
        (["calibrate", str(example_path()), "--out", "{out}", "--bound", "n_loops=1:1000000"],
         "--bound must be whole numbers >= 1, at most 1000; got 'n_loops=1:1000000'"),
    ],
    ids=["grid", "corners", "table", "angles", "bound"],
)
def test_cli_sizes_fail_fast(args: list[str], match: str, tmp_path: object,
                             capsys: pytest.CaptureFixture[str]) -> None:
    """Refused before the work: the peak of Python and NumPy allocations stays small (the sizes
    asked for would take gigabytes; imports take tens of MB), a measure that holds on any
    machine, unlike a time."""
    tracemalloc.start()
    try:
        code = main([a.replace("{out}", str(tmp_path) + "/cal") for a in args])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    err = capsys.readouterr().err
    assert code == 2 and match in err and err.count("\n") == 1
    assert peak < 200e6, f"{peak / 1e6:.0f} MB allocated before refusing"


@settings(max_examples=30, deadline=None)
@given(st.floats(allow_nan=True, allow_infinity=True),
       st.floats(allow_nan=True, allow_infinity=True))
def test_approximation_ranges(lo: float, hi: float) -> None:
    """Any tilt range: an approximation and a table, or a one-line error; never a warning."""
    setup = mc.Setup.paper()
    message = ""
    try:
        approx = mc.piecewise_linear(setup, corners=1, angle_range=(lo, hi), grid=21)
        table = mc.lookup_table(setup, 8, angle_range=(lo, hi), quantity="output", grid=21)
    except mc.MagciliaError as exc:
        message = str(exc)
    else:
        assert np.isfinite(approx.values).all() and np.isfinite(table.y).all()
    assert "\n" not in message
