"""Temperature: the coefficients' model, the simulated source's temperature channel and the
compensated read-out (issue #29 item 4)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.device.temperature import COEFFICIENTS, TemperatureModel, TemperatureProfile
from magcilia.readout.protocol import Flag, SensorReadout

SPAN = (-4e-5, 4e-5)  # N


@pytest.fixture(scope="module")
def force_setup() -> mc.Setup:
    preset = mc.presets.load("force-sensor")
    return preset.replace(youngs_modulus=preset.youngs_modulus, youngs_modulus_sigma=0.0)


@pytest.fixture(scope="module")
def force_readout(force_setup: mc.Setup) -> mc.Readout:
    return mc.Readout(force_setup, quantity="force", span=SPAN, table_size=65)


def test_output_and_to_reference_are_inverse() -> None:
    m = TemperatureModel(offset_tempco=3e-8, drive="current")
    rng = np.random.default_rng(0)
    ref = rng.uniform(1e-3, 5e-3, 50)
    temps = rng.uniform(280.0, 320.0, 50)
    hot = m.output(ref, temps, offset=2e-4, scale=75.0)
    back, sigma = m.to_reference(hot, temps, offset=2e-4, scale=75.0)
    np.testing.assert_allclose(back, ref, rtol=1e-12, atol=1e-15)
    assert np.all(sigma > 0.0)
    # at the reference nothing changes and nothing is uncertain
    same, s0 = m.to_reference(ref, m.reference, offset=2e-4, scale=75.0)
    np.testing.assert_array_equal(same, ref)
    np.testing.assert_array_equal(s0, 0.0)


def test_sigma_against_finite_differences() -> None:
    """The σ of to_reference is the first-order propagation of each coefficient's σ."""
    m = TemperatureModel()
    volts, temp, off, scale = np.array([3e-3]), 310.0, 1e-4, 75.0
    var = 0.0
    for name in ("sensitivity_tempco", "offset_tempco", "magnetization_tempco"):
        h = 1e-3 * (getattr(m, f"{name}_sigma"))
        up = m.replace(**{name: getattr(m, name) + h}).to_reference(volts, temp, off, scale)[0]
        dn = m.replace(**{name: getattr(m, name) - h}).to_reference(volts, temp, off, scale)[0]
        var += ((up - dn) / (2 * h) * getattr(m, f"{name}_sigma")) ** 2
    np.testing.assert_allclose(m.to_reference(volts, temp, off, scale)[1], np.sqrt(var),
                               rtol=1e-3)


def test_defaults_follow_their_sources() -> None:
    m = TemperatureModel()
    assert m.sensitivity_tempco == pytest.approx(-3000e-6)       # HMC1021 at a fixed voltage
    assert m.scale_tempco[0] == pytest.approx(-3000e-6)
    current = m.replace(drive="current").scale_tempco[0]          # datasheet: −600 ppm/°C
    assert -700e-6 < current < -400e-6
    assert m.modulus_tempco == pytest.approx(1.0 / m.reference)    # entropic rubber
    assert -60e-6 < m.magnetization_tempco < -30e-6               # bulk Co, Bloch T^1.5
    assert m.temperature_from_resistance(m.resistance(1100.0, 303.15), 1100.0) == \
        pytest.approx(303.15)
    assert set(m.to_dict()) >= {"reference_K", "sensitivity_tempco_per_K"}
    assert "ppm/K" in m.report()


def test_profile() -> None:
    p = TemperatureProfile.ramp(313.0, 293.0, 10.0)  # a falling ramp holds at its end
    np.testing.assert_allclose(p.values(np.array([0.0, 5.0, 50.0])), [313.0, 303.0, 293.0])
    np.testing.assert_allclose(TemperatureProfile.drift(300.0, 0.1).values(100.0), 310.0)
    with pytest.raises(mc.MagciliaError, match="start"):
        TemperatureProfile(-3.0)


def test_simulated_source_emits_temperature(force_setup: mc.Setup) -> None:
    prof = TemperatureProfile.ramp(293.15, 313.15, 1.0)
    with SimulatedSource(force_setup, Script.constant(2e-5, "force"), rate=100.0, rng=3,
                         temperature=prof, readout_noise=0.0) as src:
        block = src.read(100)
    assert [c.name for c in block.channels] == ["output", "temperature_K"]
    np.testing.assert_allclose(block.data[1], prof.values(block.time))
    # zero coefficients: the same output as without a temperature
    with SimulatedSource(force_setup, Script.constant(2e-5, "force"), rate=100.0, rng=3,
                         temperature=prof, thermal=TemperatureModel.zero(),
                         readout_noise=0.0) as src:
        zero = src.read(100).data
    with SimulatedSource(force_setup, Script.constant(2e-5, "force"), rate=100.0, rng=3,
                         readout_noise=0.0) as src:
        plain = src.read(100).data
    np.testing.assert_allclose(zero[0], plain[0], rtol=1e-12, atol=1e-15)


def test_zero_coefficients_compensation_is_identity(force_setup: mc.Setup,
                                                    force_readout: mc.Readout) -> None:
    volts = force_setup.output(np.zeros(1)) + np.linspace(-2e-4, 2e-4, 9)
    plain = force_readout.read(volts)
    thermal = mc.ThermalReadout(force_readout, TemperatureModel.zero(),
                                calibrated_range=(280.0, 330.0))
    res = thermal.read(np.column_stack([volts, np.linspace(290.0, 320.0, 9)]))
    np.testing.assert_array_equal(res.value, plain.value)
    np.testing.assert_array_equal(res.sigma, plain.sigma)
    np.testing.assert_array_equal(res.flags, plain.flags)
    assert isinstance(thermal, SensorReadout)


def test_ramp_compensated_within_2_sigma(force_setup: mc.Setup,
                                         force_readout: mc.Readout) -> None:
    """A simulated 20 K ramp at rest and under a load: compensated within 2σ of the truth, the
    uncompensated error far beyond it (the benchmark's check at a small size)."""
    rng_truth = np.random.default_rng(29)
    m = TemperatureModel()
    truth = dataclasses.replace(m, **{n: getattr(m, n) + getattr(m, f"{n}_sigma")
                                      * rng_truth.standard_normal() for n in COEFFICIENTS})
    with SimulatedSource(force_setup, Script.constant(0.0, "force"), rate=100.0, rng=5,
                         readout_noise=2e-5, temperature=293.15, thermal=truth) as src:
        rest = src.read(200).data
    tared = mc.ThermalReadout(force_readout).tare(rest.T)
    assert tared.calibrated_range[0] == pytest.approx(293.15)
    for force in (0.0, 2e-5):
        prof = TemperatureProfile.ramp(293.15, 313.15, 5.0)
        with SimulatedSource(force_setup, Script.constant(force, "force"), rate=100.0, rng=6,
                             readout_noise=2e-5, temperature=prof, thermal=truth) as src:
            data = src.read(500).data
        res = tared.read(data.T)
        hot = slice(450, None)
        err = res.value[hot] - force
        assert np.mean(np.abs(err) <= 2.0 * res.sigma[hot]) >= 0.95
        assert abs(np.mean(err)) <= 2.0 * np.median(res.sigma[hot])
        plain = force_readout.tare(rest[0]).read(data[0])
        assert abs(np.nanmean(plain.value[hot] - force)) > 3.0 * abs(np.mean(err))
        # beyond the tare's 293.15 K every reading is flagged, the note says so
        assert np.all(res.flags[hot] & Flag.TEMPERATURE_OUTSIDE)
        assert res.outside >= 450
        assert "calibrated range" in tared.outside_note(data[1])


def test_nan_temperature_and_bad_samples(force_readout: mc.Readout) -> None:
    thermal = mc.ThermalReadout(force_readout)
    v0 = float(force_readout.rest[0])
    res = thermal.read(np.array([[v0, np.nan], [v0, thermal.model.reference]]))
    assert np.isnan(res.value[0]) and res.flags[0] & Flag.MISSING
    assert res.value[1] == pytest.approx(0.0, abs=1e-9)
    assert not res.flags[1] & Flag.TEMPERATURE_OUTSIDE
    with pytest.raises(mc.MagciliaError, match="shape"):
        thermal.read(np.zeros(5))
    assert "temperature" in res.report()


def test_a_stiffer_hair_bends_under_a_force_as_a_smaller_force_bends_it(
        force_setup: mc.Setup) -> None:
    """The modulus's rule, checked on the elastica: F at E·e(T) gives the output F/e(T) gives
    at E (the simulated source's and the compensation's rule, against a direct solve)."""
    from magcilia.mechanics import output_at

    e = TemperatureModel().load_factor(313.15)
    forces = np.array([1e-5, 3e-5])
    stiffer = force_setup.replace(youngs_modulus=force_setup.youngs_modulus * e,
                                  youngs_modulus_sigma=0.0)
    np.testing.assert_allclose(output_at(stiffer, "force", forces),
                               output_at(force_setup, "force", forces / e), rtol=1e-9)


def test_noise_free_ramp_reads_the_truth(force_setup: mc.Setup,
                                         force_readout: mc.Readout) -> None:
    """Without noise the compensated estimates equal the applied force within the table's
    error (the forward model of the source, the inverse of the read-out)."""
    quiet = force_setup.replace(noise_density=0.0)
    readout = mc.Readout(quiet, quantity="force", span=SPAN, table_size=65)
    prof = TemperatureProfile.ramp(283.15, 323.15, 1.0)
    m = TemperatureModel(drive="current")
    for force in (0.0, 2.5e-5):
        with SimulatedSource(quiet, Script.constant(force, "force"), rate=50.0,
                             readout_noise=0.0, temperature=prof, thermal=m) as src:
            data = src.read(50).data
        res = mc.ThermalReadout(readout, m).read(data.T)
        np.testing.assert_allclose(res.value, force, atol=10 * readout.table_error + 1e-12)


def test_angle_read_out_is_compensated_without_the_modulus() -> None:
    setup = mc.Setup.paper().replace(noise_density=0.0)
    readout = mc.Readout(setup, quantity="angle", span=(0.0, 0.5), table_size=65)
    prof = TemperatureProfile.ramp(293.15, 313.15, 1.0)
    with SimulatedSource(setup, 0.3, rate=50.0, readout_noise=0.0, temperature=prof) as src:
        data = src.read(50).data
    res = mc.ThermalReadout(readout).read(data.T)
    np.testing.assert_allclose(res.value, 0.3, atol=10 * readout.table_error)
    np.testing.assert_array_equal(res.load_factor, 1.0)
    plain = readout.read(data[0])
    assert np.nanmax(np.abs(plain.value - 0.3)) > 100 * readout.table_error
    back = res.as_readout_result()
    np.testing.assert_allclose(back.sigma ** 2, back.sigma_noise ** 2 + back.sigma_calibration ** 2
                               + back.sigma_edge ** 2 + back.sigma_scale ** 2, rtol=1e-12)


def test_an_actuated_read_out_is_refused() -> None:
    actuated = mc.Readout(mc.Setup.paper(), span=(0.0, 0.5), table_size=17,
                          actuation=mc.Actuation.uniform([0.0, 0.0, 1e-4]))
    with pytest.raises(mc.MagciliaError, match="actuation"):
        mc.ThermalReadout(actuated)
