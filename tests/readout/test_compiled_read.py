"""The compiled read-out passes (readout/compiled.py) against the NumPy reference, reading by
reading: random readings across and beyond the span, NaN and infinities, the table's knots and
cell boundaries exactly, saturation inside the span, a fold, every force-scale mode, a tare,
and the shapes a caller passes."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.model import compiled
from magcilia.readout import compiled as compiled_read

PARTS = ("value", "sigma", "sigma_noise", "sigma_calibration", "sigma_edge", "sigma_scale")
CAL = mc.ParameterCovariance(correlation_names=("x", "offset"),
                             stderr={"x": 2e-5, "offset": 2e-5},
                             correlation=np.array([[1.0, 0.4], [0.4, 1.0]]))


def _setup(**changes: float) -> mc.Setup:
    return mc.Setup.paper(position=(1e-3, 0.0, 0.0), tip_radius=5e-5, **changes)


# (quantity, span, table size, calibrated, tared, sensor field range (T) or None)
CASES = {
    "angle": ("angle", (0.0, 0.5), 40, False, False, None),
    "angle-fold-257": ("angle", (0.0, math.radians(85.0)), 257, False, False, None),  # 4 steps
    "angle-cal-tare": ("angle", (0.0, math.radians(85.0)), 40, True, True, None),
    "force": ("force", (0.0, 2e-4), 40, False, False, None),  # |F| · σ_E/E
    "force-cal-tare": ("force", (0.0, 2e-4), 40, True, True, None),
    "flow": ("flow", (0.0, 0.5), 40, False, True, None),  # the modulus's σ through the slope
    "flow-untared": ("flow", (0.0, 0.5), 40, False, False, None),  # σ_cal zeroed, σ_scale not
    "angle-saturating": ("angle", (0.0, 0.5), 40, False, False, 3.3e-4),
    "force-saturating": ("force", (0.0, 2e-4), 40, False, False, 3.3e-4),  # σ_scale formed
}


def _readout(name: str) -> mc.Readout:
    quantity, span, size, calibrated, tared, field_range = CASES[name]
    setup = _setup() if field_range is None else _setup(field_range=field_range)
    r = mc.Readout(setup, quantity=quantity, span=span, table_size=size,
                   calibration=CAL if calibrated else None)
    return r.tare(r.rest + [1e-6, -1e-6, 2e-6]) if tared else r


def _readings(r: mc.Readout, rng: np.random.Generator) -> np.ndarray:
    """Random readings over the span and 20 % beyond each side, every knot and cell boundary
    of the table exactly (less the tare's correction, which the pass adds), NaN, ±inf."""
    t = r.table
    lo, hi = t.volts[0], t.volts[-1]
    cells = lo + np.arange(t.cell_start.size + 1) / t.cells_per_volt
    exact = np.concatenate([t.volts, cells, [lo, hi, np.nextafter(lo, -1), np.nextafter(hi, 2)]])
    correction = 0.0 if r.baseline is None else r.baseline.correction
    return np.concatenate([rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), 3000),
                           exact - correction, [np.nan, np.inf, -np.inf, 1e3, -1e3]])


def _numpy(monkeypatch: pytest.MonkeyPatch, call: Callable[[], Any]) -> Any:
    with monkeypatch.context() as m:
        m.setattr(compiled, "ENABLED", False)
        return call()


@pytest.mark.parametrize("name", list(CASES))
def test_read_pass_equals_the_numpy_path(monkeypatch: pytest.MonkeyPatch, name: str) -> None:
    pytest.importorskip("numba")
    r = _readout(name)
    volts = _readings(r, np.random.default_rng(7))
    slow = _numpy(monkeypatch, lambda: r.read(volts))
    with monkeypatch.context() as m:  # the arrays as one block, as a large read's
        m.setattr(compiled_read, "ONE_BLOCK", 1)
        block = r.read(volts)
    assert block.value.base is not None and block.value.base is block.flags.base
    fast = r.read(volts)  # an array each, as a live read-out's few readings
    for got in (fast, block):
        np.testing.assert_array_equal(got.flags, slow.flags)
        for part in PARTS:
            np.testing.assert_allclose(getattr(got, part), getattr(slow, part), rtol=1e-12,
                                       atol=0.0, err_msg=part)
    # what the case is there to cover happened
    flags = fast.flags
    assert (flags & mc.ReadoutFlag.OUTSIDE_SPAN).any() and (flags == 0).any()
    if CASES[name][5] is not None:
        assert (flags == mc.ReadoutFlag.SATURATED).sum() > 100  # inside the span
    if name == "angle-fold-257":
        assert r.table.knot_steps > 1 and (flags & mc.ReadoutFlag.FOLD).any()
    # the parts that come zeroed from the allocator: 0 with an estimate, NaN without
    good = fast.estimated
    assert np.isnan(fast.sigma_edge[~good]).all()
    assert (fast.sigma_edge[good & (flags == 0)] == 0.0).all()
    assert np.isnan(fast.value[~good]).all() and np.isfinite(fast.sigma[good]).all()


@pytest.mark.parametrize("name", ["angle", "force-cal-tare", "flow"])
def test_estimate_pass_equals_the_numpy_path(monkeypatch: pytest.MonkeyPatch,
                                             name: str) -> None:
    pytest.importorskip("numba")
    r = _readout(name)
    t = r.table
    volts = _readings(r, np.random.default_rng(3))
    correction = 0.0 if r.baseline is None else r.baseline.correction
    inside = t.inside(volts + correction) | r.read(volts).estimated  # within the edges
    within = volts[inside].reshape(-1, 1)[: (inside.sum() // 4) * 4].reshape(4, -1)
    fast = r.estimate(within)
    assert fast.shape == within.shape
    np.testing.assert_array_equal(fast, _numpy(monkeypatch, lambda: r.estimate(within)))
    np.testing.assert_array_equal(fast, r.read(within).value)  # the same numbers as read
    beyond = np.array([t.volts[0], np.nan]) - correction
    for p in (True, False):
        with monkeypatch.context() as m:
            m.setattr(compiled, "ENABLED", p)
            with pytest.raises(mc.MagciliaError, match=r"volts\[1\]"):
                r.estimate(beyond)


def test_shapes_and_empty() -> None:
    r = _readout("force")
    v = float(np.mean(r.output_range))
    assert r.estimate(v).shape == ()
    assert r.read(v).value.shape == ()
    assert r.read(np.full((2, 3), v)).sigma_scale.shape == (2, 3)
    empty = r.read(np.zeros(0))
    assert empty.value.shape == (0,) and empty.flags.dtype == np.uint16
    assert r.estimate([]).shape == (0,)


@pytest.mark.parametrize("seed", range(4))
def test_linear_outputs_are_exactly_the_sensor_test(seed: int) -> None:
    """The saturation bounds in volts pass exactly the readings the division test passes: the
    bound itself does, its next float outwards does not."""
    rng = np.random.default_rng(seed)
    for _ in range(200):
        offset, scale = rng.normal(0.0, 1e-3), rng.choice([-1.0, 1.0]) * 10 ** rng.uniform(0, 3)
        field_range = 10 ** rng.uniform(-6, -2)
        lo, hi = compiled_read.linear_outputs(offset, scale, field_range)

        def linear(x: float, o: float = offset, s: float = scale, f: float = field_range) -> bool:
            return bool(np.abs((np.float64(x) - o) / s) <= f)  # Sensor.in_range(field(x))

        assert linear(lo) and linear(hi) and lo < offset < hi
        assert not linear(math.nextafter(lo, -math.inf))
        assert not linear(math.nextafter(hi, math.inf))
    assert compiled_read.linear_outputs(0.0, 75.0, math.inf) == (-math.inf, math.inf)
    lo, hi = compiled_read.linear_outputs(math.nan, 75.0, 1e-3)
    assert not lo <= hi  # nothing passes


@pytest.mark.parametrize("name", ["force", "force-saturating", "force-cal-tare"])
def test_force_scale_formed_from_the_value(name: str) -> None:
    """A tip force's σ_scale, left by the pass for the result to form (|value| · σ_E/E): the
    numbers of the definition, NaN where no estimate, kept once formed, in the sum of σ, in
    to_dict, through dataclasses.replace and pickling; a result of the constructor keeps its
    own array."""
    import dataclasses
    import pickle

    r = _readout(name)
    res = r.read(_readings(r, np.random.default_rng(5)).reshape(-1, 1))
    rel = r.modulus.relative
    assert rel > 0.0 and "sigma_scale" not in res.__dict__  # not formed yet
    scale = res.sigma_scale
    assert scale.shape == res.value.shape and res.sigma_scale is scale  # formed once, kept
    np.testing.assert_array_equal(scale, np.abs(res.value) * rel)
    assert np.isnan(scale[~res.estimated]).all()
    parts = np.hypot(np.hypot(res.sigma_noise, res.sigma_calibration),
                     np.hypot(res.sigma_edge, scale))
    np.testing.assert_allclose(res.sigma, parts, rtol=1e-12)
    again = pickle.loads(pickle.dumps(r.read(res.value[:0, 0])))  # formed after a round trip
    assert again.sigma_scale.shape == (0,)
    copy = pickle.loads(pickle.dumps(r.read(_readings(r, np.random.default_rng(5)))))
    np.testing.assert_array_equal(copy.sigma_scale, scale[:, 0])
    assert dataclasses.replace(res, quantity="force").sigma_scale is scale
    np.testing.assert_array_equal(np.array(res.to_dict()["sigma_scale"], float), scale)
    own = dataclasses.replace(res, sigma_scale=np.zeros_like(scale))
    assert (own.sigma_scale == 0.0).all()
    with pytest.raises(AttributeError, match="sigma_scales"):
        _ = res.sigma_scales  # type: ignore[attr-defined]
