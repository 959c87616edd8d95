"""The AMR sensor model: conversions, range flags and the white + 1/f noise model."""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import json_text
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


# -- the HMC1021's limits beyond B_x: cross-axis effect, flipping, range of the total field -------
G = GAUSS
PAPER_ANGLES = np.radians(np.linspace(0.0, 85.0, 18))


def test_cross_axis_defaults_reproduce_the_datasheet_figure() -> None:
    s = mc.Sensor()
    assert s.cross_axis == 0.003 and s.flip_field == pytest.approx(20 * G)
    # H0 = 1 G * 1 G / (0.3 % of 6 G) = 55.6 G
    assert s.anisotropy_field == pytest.approx(G * G / (0.003 * 6 * G))
    assert s.anisotropy_field / G == pytest.approx(55.56, rel=1e-3)
    # the datasheet's test: 1 G cross field at ±1 G applied gives ±0.3 %FS (to first order)
    err = s.cross_axis_error([[1 * G, 1 * G, 0.0], [-1 * G, 1 * G, 0.0]])
    np.testing.assert_allclose(np.abs(err), 0.003 * s.field_range, rtol=0.02)
    # exactly B_x H0 / (H0 + B_y) - B_x
    h0 = s.anisotropy_field
    np.testing.assert_allclose(err, [-G * G / (h0 + G), G * G / (h0 + G)], rtol=1e-12)


def test_cross_axis_term_signs_and_limits() -> None:
    s = mc.Sensor(offset=1e-3)
    b = np.array([[0.5 * G, 2 * G, 7 * G], [0.5 * G, -2 * G, 0.0]])
    after_set, after_reset = s.cross_axis_error(b), s.cross_axis_error(b, polarity=-1)
    assert after_set[0] < 0 < after_set[1]  # a cross field along the magnetization stiffens it
    np.testing.assert_allclose(after_reset, after_set[::-1], rtol=1e-12)  # reset swaps the roles
    # B_z (out of the die) and B_y = 0 leave no cross-axis term
    assert s.cross_axis_error([[G, 0.0, 5 * G]]) == pytest.approx([0.0], abs=0.0)
    # with no cross field the output is the paper's output, bit for bit
    bx = np.linspace(-5 * G, 5 * G, 11)
    zero_cross = np.stack([bx, np.zeros_like(bx), np.full_like(bx, 3 * G)], axis=-1)
    np.testing.assert_array_equal(s.output_with_cross_axis(zero_cross), s.voltage(bx))
    # cross_axis = 0 turns the effect off whatever the cross field
    off = mc.Sensor(cross_axis=0.0)
    assert math.isinf(off.anisotropy_field)
    np.testing.assert_array_equal(off.output_with_cross_axis(b), off.voltage(b[:, 0]))
    # beyond -H0 the magnetization has reversed: no model value
    flipped = s.field_with_cross_axis([[G, -1.5 * s.anisotropy_field, 0.0]])
    assert np.isnan(flipped).all()


def test_check_flags_each_limit() -> None:
    s = mc.Sensor()
    f = mc.SensorFlag
    b = np.array([
        [0.3 * G, 0.0, 0.1 * G],      # quiet: ok
        [7 * G, 0.0, 0.0],            # B_x beyond ±6 G (and |B|)
        [1 * G, 0.0, 8 * G],          # |B| beyond 6 G, B_x within
        [3 * G, 2 * G, 0.0],          # cross-axis error ~ 1 mG >> noise
        [0.2 * G, 0.0, 25 * G],       # beyond the 20 G flip field
    ])
    flags = s.check(b)
    assert flags.dtype == np.uint8 and flags.shape == (5,)
    assert flags[0] == f.OK
    assert flags[1] == f.BEYOND_RANGE | f.TOTAL_BEYOND_RANGE
    assert flags[2] == f.TOTAL_BEYOND_RANGE
    assert flags[3] == f.CROSS_FIELD
    assert flags[4] & f.FLIPPED_RISK and flags[4] & f.TOTAL_BEYOND_RANGE
    # CROSS_FIELD compares with the noise of the band: a wide enough band hides the term
    assert s.check(b[3], bandwidth=(0.5, 5e9)) == f.OK
    assert s.check(b[3]).shape == ()


def test_existing_outputs_do_not_see_the_cross_axis_term() -> None:
    # Setup.output stays scale * B_x + offset (the paper's model): the term is an explicit extra
    for setup in (mc.Setup.paper(), mc.Setup.paper(cross_axis=0.05, flip_field=1e-3)):
        np.testing.assert_array_equal(setup.output(PAPER_ANGLES),
                                      setup.sensor.voltage(setup.field(PAPER_ANGLES)[:, 0]))
    np.testing.assert_array_equal(mc.Setup.paper(cross_axis=0.05).output(PAPER_ANGLES),
                                  mc.Setup.paper().output(PAPER_ANGLES))


def test_paper_initial_placement_is_beyond_the_flip_field() -> None:
    initial = mc.Setup.paper_initial().check_sensor(PAPER_ANGLES)
    bz = initial.field[:, 2] / G
    # Table I's initial placement (cilium centred over the element): 27.7 G at 0 deg, 47.7 at 85
    assert bz[0] == pytest.approx(27.67, abs=0.05) and bz[-1] == pytest.approx(47.7, abs=0.1)
    assert np.all(np.diff(bz) > 0)
    assert np.all(initial.flags & mc.SensorFlag.FLIPPED_RISK)
    assert not initial.ok and "flip field: pulse set/reset" in initial.summaries()[0]
    paper = mc.Setup.paper().check_sensor(PAPER_ANGLES)
    assert paper.magnitude.max() < 0.7 * G  # the fitted placement: well inside
    assert not np.any(paper.flags & (mc.SensorFlag.FLIPPED_RISK | mc.SensorFlag.BEYOND_RANGE
                                     | mc.SensorFlag.TOTAL_BEYOND_RANGE))
    # ... but its ~0.5 G cross field changes B_x by ~1 %, far above one reading's noise
    assert np.all(paper.flags == mc.SensorFlag.CROSS_FIELD)
    np.testing.assert_allclose(paper.cross_error / paper.field[:, 0], -0.0095, atol=0.0015)


def test_sensor_check_result_and_azimuth() -> None:
    setup = mc.Setup.paper()
    check = setup.check_sensor(PAPER_ANGLES[:4], azimuth=0.7)
    np.testing.assert_allclose(check.field, setup.field(PAPER_ANGLES[:4], azimuth=0.7))
    doc = json.loads(json_text(check.to_dict()))
    assert doc["azimuth_rad"] == 0.7 and len(doc["poses"]) == 4
    assert doc["poses"][0]["flag_names"] in ("ok", "CROSS_FIELD")
    assert doc["flip_field_T"] == pytest.approx(2e-3)
    text = check.report()
    assert text.splitlines()[0].startswith("HMC1021Z:") and len(text.splitlines()) == 5
    assert repr(check).startswith("SensorCheck(HMC1021Z")
    # centrelines: no angle labels
    bent = setup.check_sensor(setup.centreline(PAPER_ANGLES[:2]))
    assert np.isnan(bent.poses).all() and bent.summaries()[0].startswith("B = (")


def test_new_sensor_parameters_are_checked_and_routed() -> None:
    setup = mc.Setup.paper(cross_axis=0.01, flip_field=3e-3)
    assert setup.sensor.cross_axis == 0.01 and setup.value("flip_field") == 3e-3
    with pytest.raises(mc.MagciliaError, match="cross_axis must be a non-negative fraction"):
        mc.Sensor(cross_axis=-0.1)
    with pytest.raises(mc.MagciliaError, match="flip_field must be a positive field in T"):
        mc.Setup.paper(flip_field=0.0)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda s: s.check([[math.nan, 0.0, 0.0]]), "b must be finite (no NaN or inf)"),
        (lambda s: s.check([1e-4, 0.0]), "b must be an array of shape (..., 3)"),
        (lambda s: s.output_with_cross_axis([0.0, 0.0, 0.0], polarity=0),
         "polarity must be +1 (after a set pulse) or -1"),
        (lambda s: s.cross_axis_error([[0.0, math.inf, 0.0]]), "b must be finite"),
    ],
)
def test_bad_fields_are_refused(call: Any, message: str) -> None:
    with pytest.raises(mc.MagciliaError) as err:
        call(mc.Sensor())
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


# -- the calibration's warning ------------------------------------------------------------------
@pytest.fixture(scope="module")
def paper_data() -> mc.Measurement:
    from magcilia.acquire.synthetic import synthetic_recording
    from magcilia.io.recordings import measurement_from_samples

    rec = synthetic_recording(mc.Setup.paper(), np.radians(np.linspace(0.0, 85.0, 33)),
                              samples_per_angle=50, rng=2)
    return measurement_from_samples(rec.angle_deg, rec.voltage, source="synthetic")


def test_the_initial_placement_is_flagged_but_a_fit_from_it_is_not_warned(
        paper_data: mc.Measurement) -> None:
    # Table I's initial placement overloads the element (28-48 G along z): check_sensor says so,
    # but a fit only starts there, so its result warns about the fitted placement alone
    check = mc.Setup.paper_initial().check_sensor(paper_data.angles)
    assert (check.flags & mc.SensorFlag.FLIPPED_RISK).all()
    assert check.field[:, 2].min() > 27 * G and check.magnitude.max() < 49 * G
    fit = mc.calibrate(paper_data, rng=0, starts=16)  # from Table I's initial placement
    assert "sensor_field" not in [w.kind for w in fit.diagnostics]


def test_calibration_warns_about_a_fitted_placement_on_the_element(
        paper_data: mc.Measurement) -> None:
    # the whole geometry held with the cilium 0.2 mm over the element: the fit keeps it there
    over = mc.Setup.paper(x=0.0, y=0.0, z=0.2e-3)
    fit = mc.calibrate(paper_data, initial=over, fixed=mc.calibration.PARAMETERS, rng=0, starts=8)
    assert fit.setup.check_sensor(paper_data.angles).magnitude.max() > 6 * G  # 10.2 G at 85 deg
    notes = [w for w in fit.diagnostics if w.kind == "sensor_field"]
    assert len(notes) == 1 and notes[0].message.startswith("the fitted placement puts |B| = ")
    assert "±6 gauss linear range" in notes[0].message and "set/reset" in notes[0].message
    assert notes[0].parameters == ("x", "y", "z") and notes[0].message in fit.warnings


def test_joint_calibration_warns_about_its_tilt_experiments(paper_data: mc.Measurement) -> None:
    import dataclasses

    turned = dataclasses.replace(paper_data, azimuths=np.full(len(paper_data), 0.5),
                                 source="azimuth 0.5")
    over = mc.Setup.paper(x=0.0, y=0.0, z=0.2e-3)
    fit = mc.calibrate([paper_data, turned], model="physical", initial=over,
                       fixed=("height", "base_radius", "x", "y", "z"), rng=0, starts=4,
                       layout=(8, 5))
    notes = [w for w in fit.diagnostics if w.kind == "sensor_field"]
    assert len(notes) == 1 and notes[0].message.startswith("the fitted placement puts |B| = ")
    assert notes[0].message in fit.warnings
    clean = mc.calibrate([paper_data, turned], model="physical", rng=0, starts=4, layout=(8, 5))
    assert "sensor_field" not in [w.kind for w in clean.diagnostics]
