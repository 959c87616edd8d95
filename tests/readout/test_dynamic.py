"""The dynamic read-out (:mod:`magcilia.readout.dynamic`): a Kalman filter on the hair's modal
model; its σ against seeded truth, its static limit, its settling, its streaming, its protocol."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia.mechanics.transient import simulate_response
from magcilia.readout.dynamic import DynamicReadout
from magcilia.readout.protocol import SensorReadout

BASE = mc.presets.load("force-sensor")
SETUP = BASE.replace(youngs_modulus=BASE.youngs_modulus, youngs_modulus_sigma=0.0)  # σ: noise
RATE = 10_000.0
NOISE = 2e-5  # V rms per reading
SPAN = (-4e-5, 4e-5)


@pytest.fixture(scope="module")
def static():
    return mc.Readout(SETUP, quantity="force", span=SPAN, table_size=129)


@pytest.fixture(scope="module")
def air():
    return mc.modes(SETUP, mc.AIR)


def test_sigma_covers_the_truth_at_its_stated_rate(static, air):
    """Loads that follow the filter's own model (a random walk of the stated bandwidth, held
    over each sample), seeded: the estimates lie within 1σ and 2σ of the load about 68 % and
    95 % of the time."""
    rng = np.random.default_rng(7)
    dyn = DynamicReadout(static, RATE, fluid=mc.AIR, modes=air)
    slope = np.gradient(static.table.quantity, static.table.output)[static.table.output.size // 2]
    step = 2 * np.pi * dyn.bandwidth / RATE * NOISE * abs(slope)  # N per sample
    inside1, inside2 = [], []
    for _ in range(12):
        load = np.cumsum(rng.normal(0.0, step, 2000))
        load -= load[0]
        volts = simulate_response(SETUP, load, RATE, fluid=mc.AIR, modes=air).output
        dyn.reset()
        got = dyn.read(volts + rng.normal(0.0, NOISE, volts.size), noise=NOISE)
        err = np.abs(got.value[1:] - load[:-1])[300:]  # the load over the interval before
        inside1.append(err <= got.sigma[1:][300:])
        inside2.append(err <= 2 * got.sigma[1:][300:])
    assert np.mean(inside1) == pytest.approx(0.683, abs=0.06)
    assert np.mean(inside2) == pytest.approx(0.954, abs=0.03)


def test_a_constant_load_reads_as_the_static_read_out(static, air):
    volts = mc.mechanics.output_at(SETUP, "force", [1.2e-5])[0] + np.zeros(300)
    dyn = DynamicReadout(static, RATE, fluid=mc.AIR, modes=air)
    got, want = dyn.read(volts, noise=NOISE), static.read(volts, noise=NOISE)
    assert np.allclose(got.value, want.value, rtol=1e-9, atol=0)
    assert np.allclose(got.sigma_noise, dyn.filter.noise_gain * want.sigma_noise, rtol=1e-6)
    assert np.array_equal(got.flags, want.flags)
    assert np.allclose(got.sigma_scale, want.sigma_scale) and np.allclose(
        got.sigma_calibration, want.sigma_calibration)


@pytest.mark.parametrize("fluid", [mc.AIR, mc.WATER], ids=["air", "water"])
def test_a_step_settles_within_a_period(static, fluid):
    """A force step read from the moving hair (noise-free samples, σ of the stated noise): the
    dynamic estimate is within 2σ of the force within 1.5 periods of the first mode; the static
    one still rings beyond 2σ after 5 periods in air."""
    modes = mc.modes(SETUP, fluid)
    period = round(RATE / modes.frequencies[0])
    load = np.r_[np.zeros(10), np.full(8 * period, 1.6e-5)]
    volts = simulate_response(SETUP, load, RATE, fluid=fluid, modes=modes).output
    dyn = DynamicReadout(static, RATE, fluid=fluid, modes=modes)
    got = dyn.read(volts, noise=NOISE)
    late = slice(10 + round(1.5 * period), None)
    assert np.all(np.abs(got.value[late] - 1.6e-5) <= 2 * got.sigma[late])
    if fluid is mc.AIR:
        stat = static.read(volts, noise=NOISE)
        after5 = slice(10 + 5 * period, None)
        assert np.any(~(np.abs(stat.value[after5] - 1.6e-5) <= 2 * stat.sigma[after5]))


def test_window_means_are_modelled(static, air):
    """Readings that are means of 25 samples (windows at 400 Hz, as ``magcilia live``
    averages): with ``averaged=True`` a step is within 2σ after 20 readings (7 periods of the
    ringing hair); read as samples it is not."""
    load = np.r_[np.zeros(250), np.full(24750, 1.6e-5)]
    volts = simulate_response(SETUP, load, RATE, fluid=mc.AIR, modes=air).output
    means = volts.reshape(-1, 25).mean(axis=1)
    truth = load.reshape(-1, 25)[:, -1]
    errors = {}
    for averaged in (True, False):
        got = DynamicReadout(static, 400.0, fluid=mc.AIR, modes=air, averaged=averaged).read(
            means, noise=NOISE / 5)
        errors[averaged] = np.max(np.abs(got.value - truth)[30:] / got.sigma[30:])
    assert errors[True] < 2.0 < errors[False]


def test_reading_in_chunks_equals_one_call(static, air):
    rng = np.random.default_rng(1)
    volts = simulate_response(SETUP, np.cumsum(rng.normal(0, 3e-8, 900)), RATE, fluid=mc.AIR,
                              modes=air).output + rng.normal(0, NOISE, 900)
    one = DynamicReadout(static, RATE, fluid=mc.AIR, modes=air)
    chunks = DynamicReadout(static, RATE, fluid=mc.AIR, modes=air)
    whole = one.read(volts, noise=NOISE)
    parts = [chunks.read(volts[i:i + 100], noise=NOISE) for i in range(0, 900, 100)]
    assert np.allclose(np.concatenate([p.value for p in parts]), whole.value, rtol=0,
                       atol=1e-12 * 4e-5)


def test_it_follows_the_read_out_protocol(static, air):
    dyn = DynamicReadout(static, RATE, fluid=mc.AIR, modes=air)
    assert isinstance(dyn, SensorReadout)
    assert dyn.inputs == ("output",) and np.array_equal(dyn.rest, static.rest)
    rest = np.full(200, float(static.rest[0]) + 1e-4)  # a 0.1 mV offset
    tared = dyn.tare(rest + np.random.default_rng(0).normal(0, NOISE, 200))
    assert isinstance(tared, DynamicReadout) and tared.baseline is not None
    assert dyn.baseline is None
    assert abs(tared.read(rest).value).max() < 2e-6
    text = dyn.report()
    assert "Kalman" in text and "noise σ ×" in text
    assert dyn.to_dict()["dynamic"]["rate_Hz"] == RATE


def test_no_estimate_where_the_reading_has_none(static, air):
    dyn = DynamicReadout(static, RATE, fluid=mc.AIR, modes=air)
    volts = np.full(20, float(static.rest[0]))
    volts[5] = np.nan
    got = dyn.read(volts, noise=NOISE)
    assert np.isnan(got.value[5]) and got.flags[5] != 0
    assert np.isfinite(got.value[6:]).all() and np.allclose(got.value[6:], 0.0, atol=1e-9)


def test_a_rate_too_low_for_the_first_mode_is_refused(static, air):
    with pytest.raises(mc.MagciliaError, match=r"rate must be above twice the hair's first mode "
                                               r"\(2 × 152 Hz = 304 Hz\).*got 250"):
        DynamicReadout(static, 250.0, fluid=mc.AIR, modes=air)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"bandwidth": -1.0}, "bandwidth must be a positive frequency"),
    ({"fluid": "air"}, "fluid must be a magcilia.Fluid"),
])
def test_bad_options(static, air, kwargs, message):
    with pytest.raises(mc.MagciliaError, match=message):
        DynamicReadout(static, RATE, modes=air, **kwargs)


def test_only_a_single_output_read_out():
    with pytest.raises(mc.MagciliaError, match=r"readout must be a magcilia\.Readout"):
        DynamicReadout(object(), RATE)  # type: ignore[arg-type]
