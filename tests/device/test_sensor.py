"""The AMR sensor model: conversions, range flags and the white + 1/f noise model."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.constants import GAUSS


def test_hmc1021z_preset() -> None:
    s = mc.Sensor.hmc1021z()
    assert s.scale == pytest.approx(75.0)  # 1.0 mV/V/gauss x 7.5 V
    assert s.field_range == pytest.approx(6 * GAUSS)
    assert mc.Sensor.hmc1021z(bridge_voltage=5.0, gain=100.0).scale == pytest.approx(5000.0)


def test_voltage_field_round_trip() -> None:
    s = mc.Sensor.hmc1021z(offset=1.2e-3, gain=-3.0)
    b = np.linspace(-5e-4, 5e-4, 11)
    np.testing.assert_allclose(s.field(s.voltage(b)), b, rtol=1e-12, atol=1e-20)


def test_range_flags() -> None:
    s = mc.Sensor()
    assert s.in_range([0.0, 5.9 * GAUSS, -6.0 * GAUSS]).all()
    assert not s.in_range([6.01 * GAUSS]).any()


def test_white_noise_level() -> None:
    s = mc.Sensor(flicker_corner=0.0)
    x = s.noise(4096, 1000.0, rng=0, size=64)
    expected = s.scale * s.noise_density * math.sqrt(500.0)
    assert x.std() == pytest.approx(expected, rel=0.02)


def test_flicker_noise_spectrum() -> None:
    # averaged periodogram: PSD(f) / PSD_white ~ 1 + fc / f
    s = mc.Sensor(flicker_corner=20.0)
    rate, n = 1000.0, 4000
    x = s.noise(n, rate, rng=np.random.default_rng(1), size=200)
    psd = (np.abs(np.fft.rfft(x, axis=-1)) ** 2).mean(axis=0) * 2.0 / (rate * n)
    f = np.fft.rfftfreq(n, 1 / rate)
    white = (s.scale * s.noise_density) ** 2
    for f0 in (2.0, 10.0, 100.0):
        band = (f > 0.8 * f0) & (f < 1.25 * f0)
        assert psd[band].mean() / white == pytest.approx(1 + 20.0 / f0, rel=0.15)


def test_noise_is_reproducible_with_rng() -> None:
    s = mc.Sensor()
    np.testing.assert_array_equal(s.noise(100, 1e3, rng=0), s.noise(100, 1e3, rng=0))
    assert not np.array_equal(s.noise(100, 1e3, rng=0), s.noise(100, 1e3, rng=1))


def test_noise_rms_band() -> None:
    s = mc.Sensor()
    # datasheet: ~85 ugauss resolution in a 10 Hz band (with the 1/f part)
    assert s.noise_rms(0.1, 10.0) / GAUSS == pytest.approx(85e-6, rel=0.25)
    with pytest.raises(mc.MagciliaError, match="f_high must be greater"):
        s.noise_rms(10.0, 1.0)
