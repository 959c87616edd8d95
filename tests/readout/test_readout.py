"""Read-out: round trips through the mechanics and the field model, the table's error bound,
flags (span, fold, saturation), and 1-σ uncertainties against Monte Carlo."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import write_json
from magcilia.io import example_path
from magcilia.mechanics import Flow
from magcilia.readout import inverse
from magcilia.readout.inverse import NO_ESTIMATE, ReadoutFlag
from magcilia.readout.protocol import FLAG_DTYPE

POSITION = (1.4727e-3, 1.9891e-3, 0.3804e-3)


@pytest.fixture(scope="module")
def setup() -> mc.Setup:
    return mc.Setup.paper(height=3e-3, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=2.0e6,
                          position=POSITION, n_loops=12, dipoles_per_loop=4)


@pytest.fixture(scope="module")
def force_readout(setup: mc.Setup) -> mc.Readout:
    return mc.Readout(setup, quantity="force", span=(0.0, 2e-4))


def test_force_round_trip(setup: mc.Setup, force_readout: mc.Readout) -> None:
    forces = np.array([[1e-6, 3.3e-5, 7.7e-5], [1.234e-4, 1.7e-4, 1.99e-4]])
    volts = np.array([[setup.output(mc.bend(setup, force=f))[0] for f in row] for row in forces])
    est = force_readout.estimate(volts)
    assert est.shape == (2, 3)
    assert force_readout.table_error < 1e-8  # stated bound, N
    np.testing.assert_allclose(est, forces, atol=2 * force_readout.table_error + 1e-12)
    assert force_readout.fold is None


def test_angle_and_flow_round_trips(setup: mc.Setup) -> None:
    angles = np.radians([3.0, 20.0, 47.0, 79.0])
    r = mc.Readout(setup, quantity="angle", span=(0.0, math.radians(85.0)))
    np.testing.assert_allclose(r.estimate(setup.output(angles)), angles,
                               atol=2 * r.table_error + 1e-12)
    assert r.table_error < 1e-5
    flow = Flow.uniform(1.0)
    rf = mc.Readout(setup, quantity="flow", span=(0.0, 1.0), flow=flow, table_size=65)
    speeds = np.array([0.3, 0.6, 0.9])
    volts = setup.output(mc.bend_sweep(setup, speeds=speeds, flow=flow))
    np.testing.assert_allclose(rf.estimate(volts), speeds, atol=2 * rf.table_error)
    assert rf.table_error < 1e-2


def test_table_error_bound_is_honest(setup: mc.Setup) -> None:
    # a coarse table: its stated bound covers the errors at arbitrary points
    r = mc.Readout(setup, quantity="angle", span=(0.0, 1.2), table_size=9)
    q = np.linspace(0.0, 1.2, 401)
    err = np.abs(r.estimate(setup.output(q)) - q).max()
    assert 0.3 * r.table_error < err <= 1.5 * r.table_error


def test_outside_span_raises_naming_the_reading(force_readout: mc.Readout) -> None:
    lo, hi = sorted(force_readout.output_range)
    volts = np.array([0.5 * (lo + hi), lo - 1e-4, hi + 1.0])
    with pytest.raises(mc.MagciliaError, match=r"volts\[1\] must be within the span's output") as e:
        force_readout.estimate(volts)
    assert "force 0…0.0002 N" in str(e.value)
    with pytest.raises(mc.MagciliaError, match="must be within"):
        force_readout.estimate([np.nan])


def test_read_flags_outside_span_and_saturation(force_readout: mc.Readout,
                                                setup: mc.Setup) -> None:
    lo, hi = sorted(force_readout.output_range)
    saturated = setup.sensor.voltage(7e-4)  # 7 gauss
    res = force_readout.read([0.5 * (lo + hi), lo - 1e-4, saturated])
    # the output falls with the force: below the range is above the span (beyond its tolerance)
    assert res.flags.tolist() == [0, ReadoutFlag.OUTSIDE_SPAN | ReadoutFlag.ABOVE_SPAN,
                                  ReadoutFlag.OUTSIDE_SPAN | ReadoutFlag.SATURATED
                                  | ReadoutFlag.BELOW_SPAN]
    assert np.isfinite(res.value[0]) and np.isnan(res.value[1:]).all()
    assert np.isnan(res.sigma[1:]).all() and res.sigma[0] > 0
    assert res.ok.tolist() == [True, False, False]
    assert "1/3 readings estimated" in res.summary()


def test_fold_restricts_to_the_first_branch() -> None:
    # with the base 1 mm beside the element the output vs tilt turns back near 44 deg
    s = mc.Setup.paper(position=(1e-3, 0.0, 0.0))
    r = mc.Readout(s, quantity="angle", span=(0.0, math.radians(85.0)))
    assert r.fold is not None and math.radians(35) < r.fold < math.radians(55)
    start, turn = r.output_range
    assert turn == pytest.approx(s.output([r.fold])[0], rel=1e-12)
    fine = s.output(np.linspace(0.0, math.radians(85.0), 20001))
    extreme = fine.min() if turn < start else fine.max()
    assert turn == pytest.approx(extreme, abs=1e-4 * abs(start - turn))  # grid resolution
    # a reading that also occurs beyond the fold is ambiguous; one beyond the turn is outside
    end = s.output([math.radians(85.0)])[0]
    v_amb = 0.5 * (turn + end)
    beyond = turn - 1e-4 * np.sign(start - turn)
    clear = s.output([math.radians(5.0)])[0]
    res = r.read([v_amb, clear, beyond])
    assert res.flags[0] == ReadoutFlag.FOLD and res.flags[1] == 0
    assert res.flags[2] & ReadoutFlag.OUTSIDE_SPAN
    # the estimate keeps to the branch of the span's start
    est = r.estimate([v_amb])[0]
    assert 0.0 < est < r.fold
    assert s.output([est])[0] == pytest.approx(v_amb, abs=1e-4 * abs(start - turn))


def test_sigma_matches_monte_carlo_on_the_noise_model(setup: mc.Setup,
                                                      force_readout: mc.Readout) -> None:
    true = 1.2e-4
    v_true = setup.output(mc.bend(setup, force=true))[0]
    n, rate = 4096, 1000.0
    noise = setup.sensor.noise(n, rate, rng=7, size=40)
    readings = v_true + noise
    res = force_readout.read(readings, bandwidth=(rate / n, rate / 2))
    assert res.ok.all()
    empirical = np.std(res.value - true)
    assert np.mean(res.value) == pytest.approx(true, abs=3 * empirical / math.sqrt(noise.size))
    assert float(np.median(res.sigma)) == pytest.approx(empirical, rel=0.05)
    assert np.all(res.sigma_calibration == 0.0)


def _calibration(stderr: dict[str, float], corr: float) -> mc.ParameterCovariance:
    """What read-out takes of a calibration: standard errors and their correlation."""
    matrix = np.array([[1.0, corr], [corr, 1.0]])
    return mc.ParameterCovariance(correlation_names=tuple(stderr), stderr=stderr,
                                  correlation=matrix)


def test_calibration_covariance_matches_monte_carlo(setup: mc.Setup) -> None:
    stderr = {"x": 2e-5, "offset": 2e-5}
    cal = _calibration(stderr, corr=0.4)
    span = (0.0, math.radians(80.0))
    r = mc.Readout(setup, quantity="angle", span=span, calibration=cal)
    true = math.radians(40.0)
    v_true = setup.output([true])[0]
    res = r.read([v_true])
    # Monte Carlo: draw the parameters, compute the output the true sensor would give, and
    # read it with the nominal table
    rng = np.random.default_rng(3)
    cov = np.array([[1.0, 0.4], [0.4, 1.0]]) * np.outer([2e-5, 2e-5], [2e-5, 2e-5])
    draws = rng.multivariate_normal([0.0, 0.0], cov, size=400)
    volts = np.array([setup.replace(x=setup.position[0] + dx, offset=do).output([true])[0]
                      for dx, do in draws])
    spread = np.std(r.estimate(volts))
    assert res.sigma_calibration[0] == pytest.approx(spread, rel=0.1)
    assert res.sigma[0] == pytest.approx(math.hypot(res.sigma_noise[0], spread), rel=0.1)


def test_bad_arguments(setup: mc.Setup) -> None:
    with pytest.raises(mc.MagciliaError, match="quantity must be one of"):
        mc.Readout(setup, quantity="pressure", span=(0, 1))
    with pytest.raises(mc.MagciliaError, match="span must be a pair"):
        mc.Readout(setup, quantity="angle", span=(1.0, 0.0))
    with pytest.raises(mc.MagciliaError, match="tip compliance is infinite"):
        mc.Readout(mc.Setup.paper(), quantity="force", span=(0.0, 1e-4))
    with pytest.raises(mc.MagciliaError, match="f_high must be greater"):
        mc.Readout(setup, quantity="angle", span=(0, 1)).read([0.0], bandwidth=(10.0, 1.0))


def test_calibration_uncertainty_from_a_real_fit_obeys_the_hat_matrix_trace(tmp_path: Path) -> None:
    """Least squares: the fitted curve's variances at the m fitted angles sum to σ² · rank(J).
    Propagated through the read-out table (and a result.json round trip) the same must hold.
    The identity is linear; y is kept away from 0, where B_x's slope in y vanishes (it is even in
    y) and the linearised σ of y (metres) lies far beyond the read-out's difference step."""
    data = mc.read_measurements(example_path())
    fit = mc.calibrate(data, initial=mc.Setup.paper_initial(y=1e-3), bounds={"y": (0.5e-3, 3e-3)},
                       rng=0)
    write_json(tmp_path / "result.json", fit.to_dict())  # as magcilia calibrate writes it
    covariance = mc.ParameterCovariance.load(tmp_path)  # a folder holding result.json works too
    assert covariance.correlation_names == fit.correlation_names
    null = 1 if any("along 1 combination" in w for w in fit.warnings) else 0
    setup = fit.setup
    for cal in (fit, covariance):
        r = mc.Readout(setup, quantity="angle", span=(0.0, math.radians(85.0)), calibration=cal)
        res = r.read(setup.output(data.angles))
        slope = np.gradient(setup.output(data.angles), data.angles)
        var_v = (res.sigma_calibration * slope) ** 2
        m, p = len(data), len(fit.correlation_names)
        assert var_v.sum() == pytest.approx(fit.cost / (m - p) * (p - null), rel=0.05)


def test_parameter_covariance_load_errors(tmp_path: Path) -> None:
    with pytest.raises(mc.MagciliaError, match="no such file"):
        mc.ParameterCovariance.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"stderr": {}}')
    with pytest.raises(mc.MagciliaError, match="not a calibration result"):
        mc.ParameterCovariance.load(bad)


def _reference_read(r: mc.Readout, volts: np.ndarray, noise: float) -> tuple[np.ndarray, ...]:
    """What read returns, computed the straightforward way (np.interp, one array per step,
    reading by reading beyond the span)."""
    x = np.asarray(volts, dtype=np.float64)
    table, sensor = r.table, r.setup.sensor
    inside = (x >= table.volts[0]) & (x <= table.volts[-1])
    flags = np.where(inside, 0, int(ReadoutFlag.OUTSIDE_SPAN))
    if table.ambiguous is not None:
        amb = (x >= table.ambiguous[0]) & (x <= table.ambiguous[1]) & inside
        flags |= np.where(amb, int(ReadoutFlag.FOLD), 0)
    with np.errstate(invalid="ignore"):
        sat = ~(np.abs((x - sensor.offset) / sensor.scale) <= sensor.field_range)  # and NaN
    flags |= np.where(sat, int(ReadoutFlag.SATURATED), 0)
    value = table.lookup(np.where(inside, x, table.volts[0]))
    slope = np.abs(np.interp(x, table.volts, table.slope))
    bias = np.zeros(x.size)
    rising = table.output[0] < table.output[-1]  # the span's low end at the lowest output
    for i in np.flatnonzero(~inside & ~np.isnan(x)):
        low_end = (x[i] < table.volts[0]) == rising
        if not low_end and r.fold is not None:
            continue
        flags[i] |= ReadoutFlag.BELOW_SPAN if low_end else ReadoutFlag.ABOVE_SPAN
        ext = r.edge_tables[0 if low_end else 1]
        if ext is None or not ext.volts[0] <= x[i] <= ext.volts[-1]:
            continue
        flags[i] &= ~ReadoutFlag.OUTSIDE_SPAN
        est = ext.lookup(x[i:i + 1])[0]
        if r.edge == "clip":
            flags[i] |= ReadoutFlag.CLIPPED
            end = r.span[0] if low_end else r.span[1]
            value[i], bias[i] = end, abs(est - end)
            slope[i] = abs(np.interp(end, table.quantity[::1 if rising else -1],
                                     table.slope[::1 if rising else -1]))
        else:
            flags[i] |= ReadoutFlag.EXTRAPOLATED
            value[i] = est
            slope[i] = abs(np.interp(x[i], ext.volts, ext.slope))
    s_noise = noise * slope
    s_cal = np.interp(value, table.quantity, r.sigma_calibration) * slope
    nan = np.where(flags & int(NO_ESTIMATE), np.nan, 1.0)
    return (value * nan, np.sqrt(s_noise**2 + s_cal**2 + bias**2) * nan, s_noise * nan,
            s_cal * nan, bias * nan, flags.astype(FLAG_DTYPE))


@pytest.fixture(scope="module")
def folding_calibrated() -> mc.Readout:
    s = mc.Setup.paper(position=(1e-3, 0.0, 0.0))
    return mc.Readout(s, quantity="angle", span=(0.0, math.radians(85.0)), table_size=40,
                      calibration=_calibration({"x": 2e-5, "offset": 2e-5}, corr=0.4))


@pytest.fixture(scope="module")
def clipping(setup: mc.Setup) -> mc.Readout:
    return mc.Readout(setup, quantity="force", span=(0.0, 2e-4), edge="clip", table_size=65,
                      calibration=_calibration({"x": 2e-5, "offset": 2e-5}, corr=0.4))


@pytest.fixture(scope="module")
def blanking(setup: mc.Setup) -> mc.Readout:
    return mc.Readout(setup, quantity="angle", span=(0.0, 1.0), edge="blank", table_size=65)


@pytest.mark.parametrize("which", ["force", "folding_calibrated", "clipping", "blanking"])
@pytest.mark.parametrize("block", [65536, 1000], ids=["one-block", "blocks"])
def test_read_equals_the_straightforward_computation(which: str, block: int,
                                                     request: pytest.FixtureRequest,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    r: mc.Readout = request.getfixturevalue(f"{which}_readout" if which == "force" else which)
    monkeypatch.setattr(inverse, "BLOCK", block)
    table, sensor = r.table, r.setup.sensor
    lo, hi = table.volts[0], table.volts[-1]
    width = hi - lo
    edges = [lo, hi, np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf), np.nan, np.inf,
             -np.inf, 1e308, -1e308, sensor.voltage(7e-4), sensor.voltage(-7e-4)]
    x = np.concatenate([np.random.default_rng(1).uniform(lo - 0.2 * width, hi + 0.2 * width,
                                                         3000),
                        table.volts, table.output, np.linspace(lo, hi, 1001),
                        table.ambiguous or [], edges])
    res = r.read(x, noise=1e-4)
    expected = _reference_read(r, x, 1e-4)
    for name, want in zip(("value", "sigma", "sigma_noise", "sigma_calibration", "sigma_edge",
                           "flags"),
                          expected, strict=True):
        got = getattr(res, name)
        assert got.dtype == want.dtype and got.shape == x.shape, name
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=0.0, err_msg=name)
    flags = res.flags[-len(edges):]
    assert not (flags[:2] & ReadoutFlag.OUTSIDE_SPAN).any()  # at the ends
    beyond = flags[2:4] & (ReadoutFlag.EXTRAPOLATED | ReadoutFlag.CLIPPED)  # one step beyond
    if which == "blanking":
        assert (flags[2:4] & ReadoutFlag.OUTSIDE_SPAN).all() and not beyond.any()
    else:  # an estimate, but beyond the turn at a fold
        assert np.count_nonzero(beyond) == (1 if r.fold is not None else 2)
    assert (flags[4:9] & ReadoutFlag.OUTSIDE_SPAN).all()  # NaN, infinite, huge
    assert (flags[-2:] & ReadoutFlag.SATURATED).all()
    if which == "folding_calibrated":
        assert (res.flags & ReadoutFlag.FOLD).any() and (res.sigma_calibration[res.ok] > 0).all()


def test_read_and_estimate_keep_the_shape_of_the_readings(force_readout: mc.Readout) -> None:
    lo, hi = force_readout.table.volts[[0, -1]]
    mid = 0.5 * (lo + hi)
    res = force_readout.read(mid, noise=1e-4)
    assert res.value.shape == res.sigma.shape == res.flags.shape == ()
    assert float(res.value) == force_readout.estimate(mid) == force_readout.estimate([mid])[0]
    grid = np.full((2, 0, 3), mid)
    assert force_readout.read(grid).value.shape == (2, 0, 3)
    assert force_readout.estimate(grid).shape == (2, 0, 3)
