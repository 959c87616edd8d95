"""Three-axis magnetometers: datasheet presets, the digital reading (rotation, noise, clipping,
LSB rounding), saturation per axis, files and bad input."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import json_text
from magcilia.constants import GAUSS
from magcilia.device.magnetometer import MAGNETOMETERS, Magnetometer, rotation_matrix

#: a preset's required extras (the parts whose noise the datasheets available could not confirm)
EXTRA = {"MLX90393": {"noise": 1e-6}, "TLV493D-A1B6": {"noise": 1e-4}}


def _rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _random_rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


# -- presets --------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(MAGNETOMETERS))
def test_every_preset_builds_and_reads(name: str) -> None:
    m = Magnetometer.preset(name, **EXTRA.get(name, {}))
    assert m.name.startswith(name.split("-", 1)[0])
    rng = np.array(m.field_range)
    lsb = np.array(m.resolution)
    assert np.all(rng > 100 * lsb)  # at least a few bits of range
    b = 0.3 * rng  # inside the range on every axis
    np.testing.assert_allclose(m.measure(b, noisy=False), b, atol=0.5 * lsb.max())
    assert m.in_range(b) and not m.saturated(b).any()


def test_preset_names_are_case_insensitive_and_checked() -> None:
    assert Magnetometer.preset("lis3mdl").name == Magnetometer.lis3mdl().name
    assert Magnetometer.preset("tlv493d", noise=1e-4).name.startswith("TLV493D-A1B6")
    with pytest.raises(mc.MagciliaError, match=r"magnetometer preset must be one of 'MLX90393'.*"
                                               r"got 'HMC5883L'"):
        Magnetometer.preset("HMC5883L")
    with pytest.raises(mc.MagciliaError, match="keyword must be a setting of the preset"):
        Magnetometer.preset("LIS3MDL", gain_sel=3)


def test_lis3mdl_full_scales_follow_the_datasheet_gains() -> None:
    # AN4602 Table 2: 6842, 3421, 2281, 1711 LSB/gauss at ±4, 8, 12, 16 gauss
    for gauss, per_gauss in ((4, 6842), (8, 3421), (12, 2281), (16, 1711)):
        m = Magnetometer.lis3mdl(full_scale=gauss * GAUSS)
        assert m.field_range == pytest.approx((gauss * GAUSS,) * 3)
        assert m.resolution[0] == pytest.approx(GAUSS / per_gauss)
        # the 16-bit word covers the range: range / LSB within 2^15
        assert m.field_range[0] / m.resolution[0] <= 2**15
    m = Magnetometer.lis3mdl()
    assert m.noise == pytest.approx((3.2e-3 * GAUSS, 3.2e-3 * GAUSS, 4.1e-3 * GAUSS))  # z noisier
    with pytest.raises(mc.MagciliaError, match=r"full_scale must be one of 4e-4, 8e-4.*got 0.0005"):
        Magnetometer.lis3mdl(full_scale=5e-4)
    with pytest.raises(mc.MagciliaError, match="noise must be given for the LIS3MDL at rate 300"):
        Magnetometer.lis3mdl(rate=300.0)
    assert Magnetometer.lis3mdl(rate=300.0, noise=5e-7).rate == 300.0
    with pytest.raises(mc.MagciliaError, match="rate must be one of the part's output data rates"):
        Magnetometer.lis3mdl(rate=100.0)


def test_mlx90393_gain_and_resolution_table() -> None:
    base = Magnetometer.mlx90393(noise=1e-6)  # GAIN_SEL 7, RES 0
    assert base.resolution == pytest.approx((0.150e-6, 0.150e-6, 0.242e-6))
    assert base.resolution[2] / base.resolution[0] == pytest.approx(1.61, rel=0.01)  # z coarser
    # each RES step doubles the LSB (to the table's three digits)
    for res in range(1, 4):
        m = Magnetometer.mlx90393(res=res, noise=1e-6)
        np.testing.assert_allclose(m.resolution, np.array(base.resolution) * 2**res, rtol=3e-3)
    coarse = Magnetometer.mlx90393(gain_sel=0, res=1, noise=1e-6)
    assert coarse.resolution[0] == pytest.approx(1.502e-6)
    # range: the 16-bit word, capped at the part's 50 mT
    assert base.field_range[0] == pytest.approx(0.150e-6 * 2**15)
    assert Magnetometer.mlx90393(gain_sel=0, res=3, noise=1e-6).field_range == (0.05,) * 3
    # rate: one XYZ conversion (Table 18): 200.37 ms at DIG_FILT 7, OSR 3
    assert base.rate == pytest.approx(1e3 / 200.37)
    assert Magnetometer.mlx90393(dig_filt=0, osr=0, noise=1e-6).rate == pytest.approx(1e3 / 1.27)
    with pytest.raises(mc.MagciliaError, match="gain_sel must be one of 0, 1, 2, 3, 4, 5, 6, 7"):
        Magnetometer.mlx90393(gain_sel=8, noise=1e-6)
    with pytest.raises(mc.MagciliaError, match="noise must be given for the MLX90393 preset"):
        Magnetometer.mlx90393()


def test_mmc5983ma_and_tlv493d_figures() -> None:
    m = Magnetometer.mmc5983ma()
    assert m.field_range[0] == pytest.approx(8 * GAUSS)
    assert m.resolution[0] == pytest.approx(6.25e-9)  # 0.0625 mG: 16384 counts per gauss
    assert m.field_range[0] / m.resolution[0] <= 2**17  # the 18-bit word (±2^17) covers ±8 G
    assert m.noise[0] == pytest.approx(40e-9)
    assert Magnetometer.mmc5983ma(bits=16).resolution[0] == pytest.approx(25e-9)
    assert Magnetometer.mmc5983ma(rate=1000).rate == 1000.0
    t = Magnetometer.tlv493d(noise=1e-4)
    assert t.field_range[0] == pytest.approx(0.130) and t.resolution[0] == pytest.approx(98e-6)
    assert t.rate == 3300.0 and Magnetometer.tlv493d("ultra_low_power", noise=1e-4).rate == 10.0
    with pytest.raises(mc.MagciliaError, match="noise must be given for the TLV493D"):
        Magnetometer.tlv493d()
    with pytest.raises(mc.MagciliaError, match="mode must be one of 'fast'"):
        Magnetometer.tlv493d("turbo", noise=1e-4)


def test_preset_overrides_place_the_part() -> None:
    r = _rz(0.4)
    m = Magnetometer.preset("MMC5983MA", position=(1e-3, 2e-3, 0.5e-3), rotation=r,
                            name="site 3")
    assert m.position == (1e-3, 2e-3, 0.5e-3) and m.name == "site 3"
    np.testing.assert_allclose(m.rotation, r)


# -- the reading ----------------------------------------------------------------------------------
def test_rotation_round_trip_and_axes() -> None:
    m = Magnetometer(field_range=1.0, resolution=1e-9, noise=1e-9, rate=10.0,
                     rotation=_random_rotation(3))
    b = np.random.default_rng(0).normal(size=(7, 3)) * 1e-4
    np.testing.assert_allclose(m.to_board(m.to_sensor(b)), b, atol=1e-18)
    np.testing.assert_allclose(np.linalg.norm(m.to_sensor(b), axis=1), np.linalg.norm(b, axis=1))
    # a sensor turned 90 deg about z reads the board's +y field on its +x axis
    turned = m.replace(rotation=_rz(math.pi / 2))
    np.testing.assert_allclose(turned.to_sensor([0.0, 1e-4, 0.0]), [1e-4, 0.0, 0.0], atol=1e-20)


def test_values_beyond_range_clip_per_axis() -> None:
    m = Magnetometer(field_range=(1e-3, 2e-3, 3e-3), resolution=1e-6, noise=1e-7, rate=10.0)
    b = np.array([[5e-3, -5e-3, 1e-3], [-0.9e-3, 1.9e-3, -4e-3]])
    out = m.measure(b, noisy=False)
    np.testing.assert_allclose(out, [[1e-3, -2e-3, 1e-3], [-0.9e-3, 1.9e-3, -3e-3]], atol=1e-15)
    np.testing.assert_array_equal(m.saturated(b), [[True, True, False], [False, False, True]])
    np.testing.assert_array_equal(m.in_range(b), [False, False])
    # a rotated part clips on its own axes: 45 deg about z puts (2, 0, 0) mT at (1.41, -1.41)
    turned = m.replace(rotation=_rz(math.pi / 4))
    np.testing.assert_array_equal(turned.saturated([2e-3, 0.0, 0.0]), [True, False, False])


def test_lsb_rounding() -> None:
    lsb = 1e-6
    m = Magnetometer(field_range=1e-3, resolution=lsb, noise=1e-9, rate=10.0)
    b = np.array([[0.4e-6, 0.6e-6, -1.4e-6], [2.49e-6, -2.51e-6, 0.0]])
    out = m.measure(b, noisy=False)
    np.testing.assert_allclose(out, [[0.0, 1e-6, -1e-6], [2e-6, -3e-6, 0.0]], atol=1e-15)
    steps = out / lsb
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)  # whole LSBs only
    assert np.all(np.abs(out - b) <= lsb / 2 + 1e-15)


def test_noise_statistics_are_seeded_and_per_axis() -> None:
    m = Magnetometer(field_range=1.0, resolution=1e-12, noise=(1e-7, 2e-7, 4e-7), rate=100.0)
    b = np.tile([1e-5, -2e-5, 3e-5], (20000, 1))
    reading = m.measure(b, rng=4)
    np.testing.assert_array_equal(reading, m.measure(b, rng=4))
    assert not np.array_equal(reading, m.measure(b, rng=5))
    err = reading - b
    np.testing.assert_allclose(err.std(axis=0), m.sigma, rtol=0.03)
    assert np.all(np.abs(err.mean(axis=0)) < 4 * m.sigma / math.sqrt(len(b)))
    # the noise lives on the sensor's axes: a turned part keeps its per-axis spread
    turned = m.replace(rotation=_rz(0.7))
    err_s = turned.measure(b, rng=6) - turned.to_sensor(b)
    np.testing.assert_allclose(err_s.std(axis=0), m.sigma, rtol=0.03)


# -- files and display --------------------------------------------------------------------------
def test_to_dict_from_dict_round_trip() -> None:
    m = Magnetometer.preset("LIS3MDL", full_scale=1.2e-3, position=(1e-3, -2e-3, 3e-4),
                            rotation=_random_rotation(7))
    doc = json.loads(json_text(m.to_dict()))
    assert doc["resolution_T"] == pytest.approx([GAUSS / 2281] * 3)
    back = Magnetometer.from_dict(doc)
    assert json_text(back.to_dict()) == json_text(m.to_dict())
    np.testing.assert_array_equal(back.rotation, m.rotation)
    with pytest.raises(mc.MagciliaError, match="magnetometer key must be one of name"):
        Magnetometer.from_dict({**doc, "gain": 2})
    with pytest.raises(mc.MagciliaError, match="noise_T"):
        Magnetometer.from_dict({k: val for k, val in doc.items() if k != "noise_T"})


def test_report_and_repr_use_gauss_and_mm() -> None:
    m = Magnetometer.lis3mdl(position=(1e-3, 0.0, 2e-3))
    text = m.report()
    assert "±4 G" in text and "3.2/3.2/4.1 mG" in text and "(1, 0, 2) mm" in text
    assert "155 Hz" in text
    assert repr(m).startswith("Magnetometer(LIS3MDL") and len(repr(m)) <= 120


# -- bad input ------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"field_range": 0.0}, "field_range must be a positive number or three of them"),
        ({"field_range": (1e-3, -1e-3, 1e-3)}, "field_range must be a positive number"),
        ({"resolution": -1e-9}, "resolution must be a positive number"),
        ({"noise": math.nan}, "noise must be a positive number"),
        ({"rate": 0.0}, "rate must be a positive frequency in Hz"),
        ({"position": (0.0, 1.0)}, "position must be three numbers"),
        ({"name": ""}, "name must be a non-empty string"),
    ],
)
def test_bad_fields_give_one_line_errors(kwargs: dict[str, object], message: str) -> None:
    base = {"field_range": 1e-3, "resolution": 1e-8, "noise": 1e-8, "rate": 10.0}
    with pytest.raises(mc.MagciliaError) as err:
        Magnetometer(**{**base, **kwargs})
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def test_bad_rotations_say_what_is_wrong() -> None:
    with pytest.raises(mc.MagciliaError, match=r"orthonormalise.*max \|RᵀR − I\| = 0.21"):
        rotation_matrix(np.diag([1.0, 1.1, 1.0]))
    with pytest.raises(mc.MagciliaError, match=r"flip the sign of one column; got .a reflection"):
        rotation_matrix(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(mc.MagciliaError,
                       match=r"rotation must be a 3 × 3 rotation matrix.*\(2, 2\)"):
        rotation_matrix(np.eye(2))
    from scipy.spatial.transform import Rotation

    r = Rotation.from_euler("xyz", [0.1, 0.2, 0.3])
    np.testing.assert_allclose(rotation_matrix(r), r.as_matrix())


def test_nan_and_misshapen_fields_are_refused() -> None:
    m = Magnetometer.mmc5983ma()
    with pytest.raises(mc.MagciliaError, match=r"field must be finite \(no NaN or inf\); got 'an "
                                               r"array containing nan'"):
        m.measure([[0.0, math.nan, 0.0]])
    with pytest.raises(mc.MagciliaError, match=r"field must be an array of shape \(\.\.\., 3\)"):
        m.in_range([1e-5, 2e-5])
    with pytest.raises(mc.MagciliaError, match="reading must be finite"):
        m.to_board([math.inf, 0.0, 0.0])
