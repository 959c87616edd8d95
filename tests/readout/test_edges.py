"""Read-out at the span's edges (extrapolate, clip, blank) and the tare (issue 13, item 2).

The reference is the forward model itself: readings are made by the model at known quantities,
or the exact inverse of a reading is found by root finding on the model."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

import magcilia as mc
from magcilia.live.zero import Zero
from magcilia.mechanics import output_at
from magcilia.readout.inverse import EDGE_SIGMAS, EDGE_TOLERANCE, NO_ESTIMATE, ReadoutFlag
from magcilia.readout.tare import Tare

F = ReadoutFlag
SPAN = (0.0, 2e-4)  # N
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(scope="module")
def setup() -> mc.Setup:
    """The bundled force sensor (examples/force-sensor.toml) with fewer dipole slices and a
    given modulus, 3.4 MPa (taken as exact: these tests are about the span's edges, with the
    loads they were written for; the force scale's σ is tests/readout/test_force_scale.py's)."""
    return mc.load_setup(EXAMPLES / "force-sensor.toml").replace(n_loops=12,
                                                                 youngs_modulus=3.4e6)


@pytest.fixture(scope="module")
def readouts(setup: mc.Setup) -> dict[str, mc.Readout]:
    return {edge: mc.Readout(setup, quantity="force", span=SPAN, edge=edge, table_size=129)
            for edge in ("extrapolate", "clip", "blank")}


def _baseline(setup: mc.Setup, force: float, n: int = 50, seed: int = 13) -> np.ndarray:
    """``n`` readings at a constant ``force`` (N) with the sensor's noise at 1 kHz, seeded."""
    rest = output_at(setup, "force", np.array([force]))[0]
    return rest + setup.sensor.noise(n, 1000.0, rng=seed)


def test_zero_load_baseline_reads_back_zero(setup: mc.Setup,
                                            readouts: dict[str, mc.Readout]) -> None:
    """The issue's case: noise pushes about half of a zero-load baseline below 0."""
    volts = _baseline(setup, 0.0)
    before = readouts["blank"].read(volts)
    blank = int(np.count_nonzero(before.flags & F.OUTSIDE_SPAN))
    assert 15 <= blank <= 35  # magcilia 0.1 left these blank
    assert (before.flags[before.flags != 0] == F.OUTSIDE_SPAN | F.BELOW_SPAN).all()
    after = readouts["extrapolate"].read(volts)
    assert after.estimated.all()  # none blank now
    below = after.flags != 0
    assert np.count_nonzero(below) == blank
    assert (after.flags[below] == F.EXTRAPOLATED | F.BELOW_SPAN).all()
    assert (after.value[below] < 0).all() and (after.value[~below] >= 0).all()
    # the mean reads back 0 within its standard error, and sigma is that of the noise
    spread = float(np.std(after.value, ddof=1))
    assert abs(float(np.mean(after.value))) < 3 * spread / math.sqrt(volts.size)
    assert float(np.median(after.sigma)) == pytest.approx(spread, rel=0.5)
    assert np.isfinite(after.sigma).all() and (after.sigma_edge == 0).all()
    # clipped: the same readings at 0, with the clipping distance in sigma
    clipped = readouts["clip"].read(volts)
    assert (clipped.flags[below] == F.CLIPPED | F.BELOW_SPAN).all()
    assert (clipped.value[below] == 0.0).all()
    np.testing.assert_allclose(clipped.sigma_edge[below], -after.value[below], rtol=1e-12)
    assert (clipped.sigma[below] >= clipped.sigma_edge[below]).all()


def test_full_scale_reads_back_the_top_of_the_span(setup: mc.Setup,
                                                   readouts: dict[str, mc.Readout]) -> None:
    volts = _baseline(setup, SPAN[1], seed=5)
    before = readouts["blank"].read(volts)
    assert 10 <= np.count_nonzero(before.flags) <= 40
    after = readouts["extrapolate"].read(volts)
    above = after.flags != 0
    assert after.estimated.all() and (after.flags[above] == F.EXTRAPOLATED | F.ABOVE_SPAN).all()
    assert (after.value[above] > SPAN[1]).all()
    spread = float(np.std(after.value, ddof=1))
    assert float(np.mean(after.value)) == pytest.approx(SPAN[1], abs=3 * spread / math.sqrt(50))


def test_extrapolation_against_the_forward_model(setup: mc.Setup,
                                                 readouts: dict[str, mc.Readout]) -> None:
    r = readouts["extrapolate"]
    tol = EDGE_TOLERANCE * (SPAN[1] - SPAN[0])  # the noise moves the output less than that
    assert r.edge_tolerance == pytest.approx((tol, tol))
    assert r.edge_reach == pytest.approx((tol, tol))
    assert 0 < r.edge_error < 1e-9 and r.to_dict()["edge_error"] == r.edge_error
    assert "clipped up to 0.01 mN below and 0.01 mN above" in readouts["clip"].report()
    assert "no estimate beyond the span" in readouts["blank"].report()
    # up to the reach, not onto it: a reading made exactly at the end of the reach lands on either
    # side of it by the last bit of the model's rounding (BLAS, numba, CPU)
    inner = (1.0 - 1e-6) * tol
    forces = np.concatenate([np.linspace(-inner, 0.0, 7), SPAN[1] + np.linspace(0.0, inner, 7)])
    volts = output_at(setup, "force", forces)
    res = r.read(volts)
    assert res.estimated.all()
    bound = 2 * max(r.table_error, r.edge_error) + 1e-13
    np.testing.assert_allclose(res.value, forces, atol=bound)
    np.testing.assert_allclose(r.estimate(volts), res.value, rtol=0, atol=0)
    # just beyond the reach: no estimate, and which side it is on
    past = output_at(setup, "force", np.array([-1.2 * tol, SPAN[1] + 1.2 * tol]))
    far = r.read(past)
    assert far.flags.tolist() == [F.OUTSIDE_SPAN | F.BELOW_SPAN, F.OUTSIDE_SPAN | F.ABOVE_SPAN]
    assert np.isnan(far.value).all() and np.isnan(far.sigma).all()
    with pytest.raises(mc.MagciliaError, match=r"volts\[0\] must be within the span's output "
                       r"range .* or up to 1e-05 N below and 1e-05 N above it"):
        r.estimate(past)


def test_angle_edges_against_the_exact_inverse_by_root_finding() -> None:
    setup = mc.Setup.paper()
    span = (math.radians(10.0), math.radians(60.0))
    r = mc.Readout(setup, quantity="angle", span=span, edge_tolerance=math.radians(4.0))
    assert r.report().endswith("extrapolated up to 4 deg below and 4 deg above the span")
    out = setup.output
    for end, sign in ((span[0], -1.0), (span[1], 1.0)):
        v_end, v_far = out([end, end + sign * math.radians(4.0)])
        for reading in np.linspace(v_end, v_far, 9)[1:-1]:
            exact = brentq(lambda a, x=reading: out([a])[0] - x, end - 0.1, end + 0.1,
                           xtol=1e-14)
            assert sign * (exact - end) > 0  # beyond the span
            res = r.read([reading])
            assert res.flags[0] == F.EXTRAPOLATED | (F.BELOW_SPAN if sign < 0 else F.ABOVE_SPAN)
            assert res.value[0] == pytest.approx(exact, abs=2 * r.table_error + 1e-12)


@settings(max_examples=60, deadline=None)
@given(st.floats(-1.0, 1.0), st.booleans())
def test_round_trip_near_both_edges(where: float, top: bool) -> None:
    """Forward then inverse near either end, inside or within the tolerance beyond it."""
    r = _angle_readout()
    lo, hi = r.span
    tol = r.edge_tolerance[1 if top else 0]
    angle = (hi if top else lo) + where * tol
    res = r.read(r.setup.output([angle]))
    assert res.estimated[0]
    assert res.value[0] == pytest.approx(angle, abs=2 * r.table_error + 1e-12)
    if abs(where) > 1e-9:  # closer, the output's rounding decides the side
        beyond = angle > hi if top else angle < lo
        assert bool(res.flags[0] & F.EXTRAPOLATED) == beyond


_ANGLE: list[mc.Readout] = []


def _angle_readout() -> mc.Readout:
    if not _ANGLE:
        _ANGLE.append(mc.Readout(mc.Setup.paper(), quantity="angle", span=(0.2, 1.0),
                                 table_size=65))
    return _ANGLE[0]


def test_a_fold_end_is_never_continued() -> None:
    s = mc.Setup.paper(position=(1e-3, 0.0, 0.0))
    r = mc.Readout(s, quantity="angle", span=(0.1, math.radians(85.0)), table_size=40)
    assert r.fold is not None
    assert r.edge_tables[1] is None and r.edge_reach[1] == 0.0 and r.edge_reach[0] > 0
    start, turn = r.output_range
    beyond = turn - 1e-4 * np.sign(start - turn)  # past the turn
    below = s.output([0.1 - 0.5 * r.edge_tolerance[0]])[0]
    res = r.read([beyond, below])
    assert res.flags[0] == F.OUTSIDE_SPAN  # no side: the fold is inside the span
    assert res.flags[1] == F.EXTRAPOLATED | F.BELOW_SPAN
    bound = 2 * r.edge_tables[0].error + 1e-12  # type: ignore[union-attr]
    assert res.value[1] == pytest.approx(0.1 - 0.5 * r.edge_tolerance[0], abs=bound)


def test_flow_from_rest_is_continued_to_negative_speeds(setup: mc.Setup) -> None:
    flow = mc.Flow.uniform(1.0)
    r = mc.Readout(setup, quantity="flow", span=(0.0, 0.5), flow=flow, table_size=33,
                   edge_tolerance=0.1)
    assert r.edge_reach == pytest.approx((0.1, 0.1))
    speeds = np.array([-0.08, -0.03, 0.55])
    volts = setup.output(mc.bend_sweep(setup, speeds=speeds, flow=flow))
    res = r.read(volts)
    assert (res.flags & F.EXTRAPOLATED).all()
    np.testing.assert_allclose(res.value, speeds, atol=2e-3)


def test_the_default_tolerance_covers_the_noise_at_a_flat_end(setup: mc.Setup) -> None:
    """From rest a flow speed moves the output ∝ U²: 5 % of the span is within the noise, so
    the default reaches further, until the output has moved by 5 σ."""
    flow = mc.Flow.uniform(1.0)
    r = mc.Readout(setup, quantity="flow", span=(0.0, 0.5), flow=flow, table_size=33)
    low, high = r.edge_tolerance
    assert low > 2 * EDGE_TOLERANCE * 0.5 and high >= EDGE_TOLERANCE * 0.5
    noise = setup.sensor.output_noise_rms(0.5, 500.0)
    rest, reach = output_at(setup, "flow", np.array([0.0, -low]), flow)
    assert abs(reach - rest) >= EDGE_SIGMAS * noise
    shorter = output_at(setup, "flow", np.array([-low / 2]), flow)[0]
    assert abs(shorter - rest) < EDGE_SIGMAS * noise  # doubling: no further than needed × 2
    res = r.read(rest + setup.sensor.noise(50, 1000.0, rng=13))
    assert res.estimated.all()
    fixed = mc.Readout(setup, quantity="flow", span=(0.0, 0.5), flow=flow, table_size=33,
                       edge_tolerance=0.025)
    assert fixed.edge_tolerance == (0.025, 0.025)
    assert not fixed.read(rest + setup.sensor.noise(50, 1000.0, rng=13)).estimated.all()


def test_edge_arguments_are_checked(setup: mc.Setup) -> None:
    with pytest.raises(mc.MagciliaError, match="edge must be one of 'extrapolate', 'clip'"):
        mc.Readout(mc.Setup.paper(), quantity="angle", span=(0, 1), edge="wrap")
    with pytest.raises(mc.MagciliaError, match="edge_tolerance must be a non-negative"):
        mc.Readout(mc.Setup.paper(), quantity="angle", span=(0, 1), edge_tolerance=-0.1)
    r = mc.Readout(mc.Setup.paper(), quantity="angle", span=(0, 1), edge_tolerance=0.0)
    assert r.edge_reach == (0.0, 0.0) and "no estimate beyond the span" in r.report()
    doc = r.to_dict()
    assert doc["edge"] == "extrapolate" and doc["edge_tolerance"] == [0.0, 0.0]
    assert doc["tare"] is None


def test_flag_names_keep_their_bits() -> None:
    names = ("OUTSIDE_SPAN", "FOLD", "SATURATED", "EXTRAPOLATED", "CLIPPED", "BELOW_SPAN",
             "ABOVE_SPAN")  # the single output's own flags; the one Flag set holds more
    assert [int(F[n]) for n in names] == [1, 2, 4, 8, 16, 32, 64]
    assert NO_ESTIMATE == F.OUTSIDE_SPAN | F.FOLD | F.SATURATED


# -- tare ---------------------------------------------------------------------------------------
def test_tare_removes_an_offset_and_adds_its_standard_error(
        setup: mc.Setup, readouts: dict[str, mc.Readout]) -> None:
    r = readouts["extrapolate"]
    drift = 3e-4  # V: the lab's field and the bridge offset, unknown to the model
    baseline = _baseline(setup, 0.0, n=500, seed=3) + drift
    forces = np.array([0.0, 5e-5, 1.5e-4])
    volts = output_at(setup, "force", forces) + drift
    untared = r.read(volts)  # wrong: blank beyond the tolerance, or far off
    assert not (np.abs(untared.value - forces) < 1e-5).any()
    tared = r.tare(baseline)
    assert r.baseline is None and tared.baseline is not None  # a copy; the original unchanged
    b = tared.baseline
    assert b.count == 500 and b.mean == pytest.approx(float(np.mean(baseline)), rel=1e-15)
    assert b.correction == pytest.approx(output_at(setup, "force", np.zeros(1))[0] - b.mean)
    assert b.noise == pytest.approx(float(np.std(baseline, ddof=1)))
    res = tared.read(volts)
    assert res.estimated.all()
    se_force = b.standard_error * abs(float(r.table.slope[-1]))
    np.testing.assert_allclose(res.value, forces, atol=5 * se_force + 2 * r.table_error)
    # the tared zero is the baseline mean: its own mean reads exactly 0
    assert tared.estimate([b.mean])[0] == pytest.approx(0.0, abs=1e-12)
    # sigma: measured noise of one reading, and the standard error as a shared (calibration) part
    slope = np.abs(np.interp(volts + b.correction, r.table.volts, r.table.slope))
    np.testing.assert_allclose(res.sigma_noise, slope * b.noise, rtol=1e-12)
    np.testing.assert_allclose(res.sigma_calibration, slope * b.standard_error, rtol=1e-12)
    np.testing.assert_allclose(res.sigma, np.hypot(res.sigma_noise, res.sigma_calibration),
                               rtol=1e-12)
    assert tared.read(volts, noise=1e-6).sigma_noise == pytest.approx(slope * 1e-6, rel=1e-12)
    assert tared.to_dict()["tare"]["count"] == 500 and "tare: zero at" in tared.report()


def test_tare_with_a_calibration_adds_in_quadrature(setup: mc.Setup) -> None:
    cov = mc.ParameterCovariance(correlation_names=("offset",), stderr={"offset": 2e-6},
                                 correlation=np.eye(1))
    r = mc.Readout(setup, quantity="force", span=SPAN, calibration=cov, table_size=65)
    v = output_at(setup, "force", np.array([1e-4]))
    plain = r.read(v, noise=1e-6)
    tared = r.tare(_baseline(setup, 0.0, n=100)).read(v, noise=1e-6)
    slope = abs(float(np.interp(v[0], r.table.volts, r.table.slope)))
    se = r.tare(_baseline(setup, 0.0, n=100)).baseline.standard_error  # type: ignore[union-attr]
    assert tared.sigma_calibration[0] == pytest.approx(
        math.hypot(plain.sigma_calibration[0], slope * se), rel=1e-6)


def test_live_zero_and_readout_tare_share_the_arithmetic(setup: mc.Setup,
                                                          readouts: dict[str, mc.Readout]) -> None:
    baseline = _baseline(setup, 0.0, n=64) + 1e-4
    tared = readouts["extrapolate"].tare(baseline)
    zero = Zero(output_at(setup, "force", np.zeros(1))[0], tau=None)
    zero.tare(baseline, at=0.0)
    assert zero.correction == tared.baseline.correction  # type: ignore[union-attr]
    assert zero.noise == tared.baseline.noise  # type: ignore[union-attr]


def test_tare_needs_two_finite_readings(readouts: dict[str, mc.Readout]) -> None:
    with pytest.raises(mc.MagciliaError, match="tare needs at least 2 finite readings; got 1"):
        readouts["extrapolate"].tare([1e-3, np.nan])
    t = Tare.from_readings([[1.0, 3.0], [np.nan, 2.0]], rest=2.0)
    assert (t.mean, t.count, t.correction, t.noise) == (2.0, 3, 0.0, 1.0)
    assert t.standard_error == pytest.approx(1 / math.sqrt(3))
