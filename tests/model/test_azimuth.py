"""Tilt toward any azimuth (model/azimuth.py, Setup.field(pose, azimuth))."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc

ANGLES = np.radians(np.arange(-60.0, 61.0, 10.0))


def test_tilt_toward_minus_x_is_a_negative_tilt() -> None:
    setup = mc.Setup.paper(n_loops=6, dipoles_per_loop=4)  # even k: rings symmetric under π
    np.testing.assert_allclose(setup.field(ANGLES, azimuth=np.pi), setup.field(-ANGLES),
                               rtol=1e-12, atol=1e-18)


@pytest.mark.parametrize("azimuth", [0.3, np.pi / 2, 2.0, -1.1])
def test_field_matches_magpylib_with_the_cilium_turned_about_the_vertical(azimuth: float) -> None:
    # independent: the model's dipoles for the tilt toward +x, turned in magpylib by the azimuth
    # about the vertical axis through the base centre
    setup = mc.Setup.paper(n_loops=5, dipoles_per_loop=3, ring="rms")
    base = np.array([setup.position[0], setup.position[1], 0.0])
    for theta in (0.0, 0.4, 1.2):
        collection = setup.to_magpylib(theta, sensor=False)
        collection.rotate_from_angax(np.degrees(azimuth), "z", anchor=base)
        expected = collection.getB((0.0, 0.0, 0.0))
        got = setup.field(np.array([theta]), azimuth=azimuth)[0]
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.linalg.norm(expected))


def test_output_reads_the_turned_field_on_the_sensitive_axis() -> None:
    setup = mc.Setup.paper(offset=1e-3)
    b = setup.field(ANGLES, azimuth=0.7)
    np.testing.assert_allclose(setup.output(ANGLES, azimuth=0.7),
                               setup.sensor.scale * b[:, 0] + 1e-3, rtol=1e-13)
    assert np.array_equal(setup.output(ANGLES, azimuth=0.0), setup.output(ANGLES))


def test_azimuth_must_be_finite() -> None:
    with pytest.raises(mc.MagciliaError, match="azimuth"):
        mc.Setup.paper().field(ANGLES, azimuth=float("nan"))


def test_the_one_rotation_about_z_and_its_exact_inverse() -> None:
    from magcilia.model.azimuth import turn_about_z, turn_xy

    gen = np.random.default_rng(4)
    vec = gen.normal(size=(7, 5, 3))
    phi = gen.uniform(-7.0, 7.0, (7, 1))
    turned = turn_about_z(vec, phi)
    # the rotation matrix about z, built independently
    c, s = np.cos(phi[:, 0]), np.sin(phi[:, 0])
    rot = np.zeros((7, 3, 3))
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1], rot[:, 2, 2] = c, -s, s, c, 1.0
    np.testing.assert_allclose(turned, np.einsum("aij,amj->ami", rot, vec), rtol=0, atol=1e-14)
    np.testing.assert_allclose(turn_about_z(turned, phi, inverse=True), vec, rtol=0, atol=1e-14)
    # the inverse is the turn by -phi exactly (the sine's sign flipped)
    assert np.array_equal(turn_about_z(vec, phi, inverse=True), turn_about_z(vec, -phi))
    x, y = turn_xy(vec[..., 0], vec[..., 1], phi)
    assert np.array_equal(np.stack([x, y], -1), turned[..., :2])
