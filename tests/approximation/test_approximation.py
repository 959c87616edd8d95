"""Piecewise-linear read-out approximations and lookup tables: exact recovery of piecewise-linear
data and its corners, the straight-line special case, reported vs evaluated errors, the inverse,
folds and bad input."""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.approximation import PiecewiseLinear, fit_piecewise_linear, hat_basis

RANGE = (0.0, math.radians(85.0))


def _pl(knots: list[float], values: list[float]):  # exact piecewise-linear "sensor"
    k, v = np.asarray(knots), np.asarray(values)
    return lambda t: np.interp(t, k, v)


@pytest.mark.parametrize(
    ("knots", "values"),
    [
        ([0.0, 0.7, 1.4835298641951802], [2.9e-3, 2.2e-3, 1.8e-3]),
        ([0.0, 0.23, 0.61, 1.4835298641951802], [2.9e-3, 2.7e-3, 2.1e-3, 1.85e-3]),
        ([0.0, 0.2, 0.5, 0.9, 1.4835298641951802], [1.0, 2.0, 1.7, 2.5, 2.4]),
    ],
    ids=["one-corner", "two-corners", "three-corners-non-monotonic"],
)
def test_recovers_exact_piecewise_linear_data_and_corners(
    knots: list[float], values: list[float]
) -> None:
    corners = len(knots) - 2
    approx = mc.piecewise_linear(_pl(knots, values), corners=corners, angle_range=RANGE, grid=801)
    scale = max(abs(x) for x in values)
    np.testing.assert_allclose(approx.breakpoints, knots[1:-1], atol=1e-6)
    np.testing.assert_allclose(approx.knots, knots, atol=1e-6)
    np.testing.assert_allclose(approx.values, values, atol=1e-7 * scale)
    assert approx.max_error < 1e-7 * scale
    assert approx.breakpoints.shape == (corners,)


def test_straight_line_is_the_least_squares_line() -> None:
    setup = mc.Setup.paper()
    approx = mc.piecewise_linear(setup, corners=0, angle_range=(0.0, math.radians(40.0)), grid=501)
    t = np.linspace(0.0, math.radians(40.0), 501)
    slope, intercept = np.polyfit(t, setup.output(t), 1)
    assert approx.breakpoints.shape == (0,)
    np.testing.assert_allclose(approx.values, intercept + slope * approx.knots, rtol=1e-10)
    # a line over a reduced range is far better than over the full range (the paper's remark)
    full = mc.piecewise_linear(setup, corners=0, angle_range=RANGE)
    assert approx.max_error < 0.5 * full.max_error


def test_reported_errors_match_evaluated_errors() -> None:
    setup = mc.Setup.paper()
    approx = mc.piecewise_linear(setup, corners=2, angle_range=RANGE)
    t = np.linspace(*RANGE, 20001)
    v = setup.output(t)
    err = approx(t) - v
    assert np.abs(err).max() == pytest.approx(approx.max_error, rel=0.01)
    assert np.sqrt(np.mean(err**2)) == pytest.approx(approx.rms_error, rel=0.01)
    angle_err = np.abs(approx.inverse(v) - t).max()
    assert angle_err == pytest.approx(approx.max_angle_error, rel=0.01)
    # more corners never fit worse (least squares, nested spaces)
    rms = [mc.piecewise_linear(setup, corners=c).rms_error for c in (0, 1, 2, 3)]
    assert all(b <= a * (1 + 1e-9) for a, b in itertools.pairwise(rms))
    # the paper: two corners approximate the calibrated curve well (here: within 2 % of its span)
    assert approx.max_error < 0.02 * np.ptp(v)


def test_continuous_least_squares_optimum_is_local_minimum() -> None:
    # moving any corner a little can only increase the squared error
    setup = mc.Setup.paper()
    t = np.linspace(*RANGE, 1001)
    y = setup.output(t)
    knots, values = fit_piecewise_linear(t, y, 2)
    basis = hat_basis(t, knots)
    best = float(np.sum((basis @ values - y) ** 2))
    for i in (1, 2):
        for d in (-0.01, 0.01):
            k = knots.copy()
            k[i] += d
            b = hat_basis(t, k)
            coef, *_ = np.linalg.lstsq(b, y, rcond=None)
            assert np.sum((b @ coef - y) ** 2) >= best


def test_hat_basis_partition_of_unity_and_interpolation() -> None:
    knots = np.array([0.0, 0.3, 1.0, 1.2])
    x = np.linspace(0.0, 1.2, 97)
    b = hat_basis(x, knots)
    np.testing.assert_allclose(b.sum(axis=1), 1.0)
    np.testing.assert_allclose(hat_basis(knots, knots), np.eye(4), atol=1e-15)


def test_call_inverse_round_trip_and_extrapolation() -> None:
    approx = mc.piecewise_linear(mc.Setup.paper(), corners=2)
    t = np.linspace(-0.2, 1.7, 101)  # beyond the range: end segments continued
    np.testing.assert_allclose(approx.inverse(approx(t)), t, atol=1e-12)
    s = approx.slopes
    assert approx(np.array([-0.1]))[0] == pytest.approx(approx.values[0] - 0.1 * s[0])
    assert approx(t.reshape(1, -1)).shape == (1, 101)
    increasing = mc.piecewise_linear(_pl([0.0, 0.5, 1.0], [0.0, 1.0, 1.5]), 1, (0.0, 1.0))
    np.testing.assert_allclose(increasing.inverse([0.5, 1.25]), [0.25, 0.75], atol=1e-9)


def test_fold_error_names_the_angle() -> None:
    # the sin curve turns at 90 deg
    approx = mc.piecewise_linear(np.sin, corners=2, angle_range=(0.0, math.pi))
    assert not approx.invertible and approx.folds
    with pytest.raises(mc.MagciliaError, match=r"folds .* at 90 deg"):
        approx.inverse([0.5])
    with pytest.raises(mc.MagciliaError, match="lookup table needs a strictly monotonic"):
        mc.lookup_table(np.sin, 16, angle_range=(0.0, math.pi))
    # a real placement: the element right below the cilium's plane of tilt (y = 0)
    centred = mc.piecewise_linear(mc.Setup.paper(y=0.0), corners=2)
    with pytest.raises(mc.MagciliaError, match=r"folds \(turns or is flat\) at 56\.\d+ deg"):
        centred.inverse([1e-3])
    assert math.isfinite(mc.piecewise_linear(np.sin, 1, (0.0, 1.0)).max_angle_error)


def test_to_dict_round_trip() -> None:
    approx = mc.piecewise_linear(mc.Setup.paper(), corners=2)
    doc = json.loads(json.dumps(approx.to_dict()))
    again = PiecewiseLinear.from_dict(doc)
    np.testing.assert_array_equal(again.knots, approx.knots)
    np.testing.assert_array_equal(again.values, approx.values)
    assert again.max_error == approx.max_error
    assert doc["breakpoints_rad"] == approx.breakpoints.tolist()
    with pytest.raises(mc.MagciliaError, match=r"PiecewiseLinear\.to_dict"):
        PiecewiseLinear.from_dict({"knots_rad": [0, 1]})


@pytest.mark.parametrize("quantity", ["inverse", "output"])
def test_lookup_table_error_bound_matches_evaluated_error(quantity: str) -> None:
    setup = mc.Setup.paper()
    t = np.linspace(*RANGE, 20001)
    v = setup.output(t)
    bounds = []
    for size in (16, 32):
        table = mc.lookup_table(setup, size, quantity=quantity)
        err = np.abs(table(v) - t).max() if quantity == "inverse" else np.abs(table(t) - v).max()
        assert err <= table.error_bound * 1.02
        assert err >= 0.5 * table.error_bound  # the bound is tight, not vacuous
        bounds.append(table.error_bound)
        assert table.size == size
    assert bounds[0] / bounds[1] == pytest.approx((31 / 15) ** 2, rel=0.05)  # h^2 scaling


def test_lookup_table_nodes_are_exact() -> None:
    setup = mc.Setup.paper()
    table = mc.lookup_table(setup, 9)
    np.testing.assert_allclose(setup.output(table.y), table.x, rtol=0, atol=1e-12)
    assert table.to_dict()["x_unit"] == "V"


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"angle_range": (0.5, 0.5)}, "angle_range must be a non-empty range"),
        ({"angle_range": (1.0, 0.0)}, "angle_range must be a non-empty range"),
        ({"angle_range": (0.0, math.inf)}, "angle_range must be a finite"),
        ({"angle_range": (0.0,)}, "angle_range must be a .start, stop. pair"),
        ({"corners": -1}, "corners must be an integer >= 0"),
        ({"corners": 9, "grid": 10}, "corners must be at most 8 for a grid of 10"),
        ({"corners": 1.5}, "corners must be an integer"),
        ({"grid": 2}, "grid must be an integer >= 3"),
    ],
    ids=["empty", "reversed", "infinite", "one-number", "negative-corners", "too-many-corners",
         "fractional-corners", "tiny-grid"],
)
def test_bad_input(kwargs: dict, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        mc.piecewise_linear(mc.Setup.paper(), **kwargs)


def test_bad_curves() -> None:
    with pytest.raises(mc.MagciliaError, match="curve output must be finite"):
        mc.piecewise_linear(lambda t: np.where(t > 0.5, np.inf, t), 1, (0.0, 1.0), grid=11)
    with pytest.raises(mc.MagciliaError, match="curve output must be shape"):
        mc.piecewise_linear(lambda t: t[:-1], 1, (0.0, 1.0))
    with pytest.raises(mc.MagciliaError, match="curve must be a magcilia Setup or a callable"):
        mc.piecewise_linear("paper", 1)  # type: ignore[arg-type]
    with pytest.raises(mc.MagciliaError, match="size must be an integer >= 2"):
        mc.lookup_table(mc.Setup.paper(), 1)
    with pytest.raises(mc.MagciliaError, match="quantity must be one of"):
        mc.lookup_table(mc.Setup.paper(), 8, quantity="angle")
    with pytest.raises(mc.MagciliaError, match="tilt must be finite"):
        mc.piecewise_linear(mc.Setup.paper(), 1)([math.nan])
