"""The read-out protocol's shared parts: one flag set, one tare for one channel or several."""

from __future__ import annotations

import json

import numpy as np
import pytest

import magcilia as mc
from magcilia.readout.protocol import FLAG_DTYPE, Flag, flag_names
from magcilia.readout.tare import Tare


def test_flag_bits_are_distinct_powers_of_two_that_fit_the_dtype():
    bits = [f.value for f in Flag]
    assert len(set(bits)) == len(bits)
    assert all(b & (b - 1) == 0 for b in bits)
    assert max(bits) <= np.iinfo(FLAG_DTYPE).max


def test_former_flag_names_mean_the_same_bits():
    assert Flag.BEYOND_SPAN is Flag.ABOVE_SPAN
    assert mc.ReadoutFlag.SATURATED.value == Flag.SATURATED.value
    assert mc.ForceFlag.AMBIGUOUS.value == Flag.AMBIGUOUS.value


def test_flag_names_lists_the_bits_set():
    assert flag_names(Flag.SATURATED | Flag.ZERO_DRIFT) == ("SATURATED", "ZERO_DRIFT")
    assert flag_names(np.uint16(Flag.TARE_UNDER_LOAD)) == ("TARE_UNDER_LOAD",)
    assert flag_names(0) == ()


def test_one_channel_tare_is_mean_and_spread():
    rng = np.random.default_rng(3)
    x = 2e-3 + 1e-5 * rng.standard_normal(400)
    t = Tare.from_readings(x, rest=1.5e-3)
    assert t.channels == 1
    assert t.correction == pytest.approx(1.5e-3 - x.mean(), rel=1e-12)
    assert t.noise == pytest.approx(x.std(ddof=1), rel=1e-12)
    assert t.standard_error == pytest.approx(x.std(ddof=1) / 20.0, rel=1e-12)
    assert isinstance(t.correction, float)


def test_channel_tare_matches_each_column_alone_and_skips_nan():
    rng = np.random.default_rng(4)
    x = np.array([1e-5, -2e-5, 3e-5]) + 1e-7 * rng.standard_normal((50, 3))
    x[7, 1] = np.nan
    t = Tare.from_readings(x, rest=[0.0, 1e-6, 0.0], unit="T", names=("x", "y", "z"))
    for c in range(3):
        one = Tare.from_readings(x[:, c], rest=t.rest[c], unit="T")
        assert t.mean[c] == pytest.approx(one.mean, rel=1e-12)
        assert t.noise[c] == pytest.approx(one.noise, rel=1e-12)
        assert t.count[c] == one.count
    assert t.count.tolist() == [50, 49, 50]
    content = json.loads(json.dumps(t.to_dict()))
    assert content["names"] == ["x", "y", "z"] and content["unit"] == "T"
    assert "G" in t.report() and len(repr(t)) <= 120


@pytest.mark.parametrize(("readings", "message"), [
    ([[1e-5, 2e-5], [np.nan, 3e-5]], "at least 2 finite readings per channel; got 1 for x"),
    ([[1e-5, 2e-5], [1e-5, 3e-5]], "x is constant"),
    ([1e-5, 2e-5, 3e-5], "shape (..., 2)"),
])
def test_channel_tare_refuses_what_it_cannot_use(readings, message):
    with pytest.raises(mc.MagciliaError, match=message.replace("(", r"\(").replace(")", r"\)")):
        Tare.from_readings(readings, rest=[0.0, 0.0], unit="T", names=("x", "y"))


def test_biaxial_tare_is_the_one_tare():
    setup = mc.Setup.paper(tip_radius=5e-5)
    mag = mc.Magnetometer(field_range=1e-3, resolution=1e-10, noise=2e-8, rate=100.0, name="mag")
    readout = mc.BiaxialReadout(setup, mag, span=1e-4, table_size=(9, 16))
    base = readout.rest + 1e-7 * np.array([[1.0, 0.0, -1.0], [-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]])
    tared = readout.tare(base)
    assert isinstance(tared.baseline, Tare) and tared.baseline.unit == "T"
    assert tared.baseline.names == tuple(c.name for c in readout.channels)
    np.testing.assert_allclose(tared.baseline.correction, readout.rest - base.mean(axis=0),
                               rtol=1e-12, atol=1e-20)


# -- the single-output read-outs on the protocol --------------------------------------------------

SETUP = mc.Setup.paper(tip_radius=5e-5)


def test_readout_follows_the_protocol():
    from magcilia.acquire.source import OUTPUT
    from magcilia.readout.protocol import ReadoutValues, SensorReadout

    r = mc.Readout(SETUP, quantity="force", span=(0.0, 1e-4), table_size=33)
    assert isinstance(r, SensorReadout)
    assert r.inputs == (OUTPUT,)
    assert r.rest.shape == (1,)
    np.testing.assert_allclose(r.rest, SETUP.output([0.0]), rtol=1e-12)
    result = r.read(SETUP.output(np.zeros(3)), noise=[1e-6])
    assert isinstance(result, ReadoutValues)
    assert result.flags.dtype == FLAG_DTYPE and result.unit == "N"
    np.testing.assert_allclose(result.value, 0.0, atol=1e-9)
    tared = r.tare(r.rest + np.array([1e-5, 1.2e-5, 0.8e-5]))
    assert tared.baseline.rest == pytest.approx(float(r.rest[0]), rel=1e-15)


def test_readout_refuses_several_noise_values():
    r = mc.Readout(SETUP, quantity="angle", span=(0.0, 0.5), table_size=17)
    with pytest.raises(mc.MagciliaError, match="noise must be one noise RMS"):
        r.read([0.0], noise=[1e-6, 2e-6])


def test_actuated_readout_reads_protocol_samples_as_output_and_level():
    from magcilia.readout.actuated import LEVEL, ActuatedReadout
    from magcilia.readout.forward import model_output

    coil = mc.Actuation.uniform((1e-4, 0.0, 0.0))
    r = ActuatedReadout(SETUP, "force", (0.0, 1e-4), coil, levels=[-1.0, 0.0, 1.0],
                        table_size=33)
    assert r.inputs == ("output", LEVEL) and r.rest.shape == (2,)
    levels = np.array([-0.5, 0.0, 0.5])
    volts = np.array([model_output(SETUP, "force", [4e-5], actuation=coil.scaled(k))[0]
                      for k in levels])
    pairs = np.column_stack([volts, levels])
    both = r.read(pairs)
    np.testing.assert_array_equal(both.value, r.read(volts, level=levels).value)
    np.testing.assert_allclose(both.value, 4e-5, rtol=1e-3)
    tared = r.tare(np.column_stack([r.rest[0] + np.array([1e-5, 2e-5]), [0.0, 0.0]]))
    assert tared.baseline.correction == pytest.approx(-1.5e-5, rel=1e-6)
    with pytest.raises(mc.MagciliaError, match="one level for the whole tare"):
        r.tare(np.array([[0.0, 0.0], [1e-5, 1.0]]))


@pytest.mark.parametrize(("calibrated", "quantity"), [(False, "angle"), (True, "angle"),
                                                      (True, "force")])
def test_compiled_read_equals_the_numpy_path(monkeypatch, calibrated, quantity):
    """The one compiled pass (readout/compiled.py) against the NumPy reference, reading by
    reading, across the span, its edges, a fold, saturation and NaN."""
    from magcilia.model import compiled

    setup = mc.Setup.paper(position=(1e-3, 0.0, 0.0), tip_radius=5e-5)
    cal = mc.ParameterCovariance(correlation_names=("x", "offset"),
                                 stderr={"x": 2e-5, "offset": 2e-5},
                                 correlation=np.array([[1.0, 0.4], [0.4, 1.0]]))
    cal = cal if calibrated else None
    span = (0.0, np.radians(85.0)) if quantity == "angle" else (0.0, 2e-4)
    r = mc.Readout(setup, quantity=quantity, span=span, table_size=40, calibration=cal)
    r = r.tare(r.rest + [1e-6, -1e-6, 2e-6])
    lo, hi = sorted(r.output_range)
    rng = np.random.default_rng(5)
    volts = np.concatenate([rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), 5000),
                            [np.nan, np.inf, -np.inf, 1e3, lo, hi]])
    fast = r.read(volts)
    monkeypatch.setattr(compiled, "ENABLED", False)
    slow = r.read(volts)
    np.testing.assert_array_equal(fast.flags, slow.flags)
    for name in ("value", "sigma", "sigma_noise", "sigma_calibration", "sigma_edge",
                 "sigma_scale"):
        np.testing.assert_allclose(getattr(fast, name), getattr(slow, name), rtol=1e-12,
                                   atol=0.0, err_msg=name)
