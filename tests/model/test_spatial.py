"""The field model on centrelines in space (SpatialCentreline): model/pose.py, model/layout.py."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia.model.centreline import SpatialCentreline

AZIMUTHS = [0.3, np.pi / 2, 2.0, np.pi, -1.1]


def _setup(k: int) -> mc.Setup:
    return mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, n_loops=3, dipoles_per_loop=k)


def _bent(setup: mc.Setup) -> mc.Centreline:
    return mc.bend_sweep(setup, forces=[5e-6, 2e-5])


@pytest.mark.parametrize("k", [3, 4], ids=["odd-k", "even-k"])
@pytest.mark.parametrize("shape", ["straight", "bent"])
def test_turned_planar_shape_equals_the_azimuth_path(k: int, shape: str) -> None:
    setup = _setup(k)
    planar = (mc.Centreline.straight(setup.cilium.height, [0.0, 0.4, 1.1]) if shape == "straight"
              else _bent(setup))
    for phi in AZIMUTHS:
        expected = setup.field(planar, azimuth=phi)
        got = setup.field(SpatialCentreline.from_planar(planar, phi))
        np.testing.assert_allclose(got, expected, rtol=0,
                                   atol=1e-12 * np.abs(expected).max())
        # a SpatialCentreline with an azimuth is turned by it
        composed = setup.field(SpatialCentreline.from_planar(planar, 0.5), azimuth=phi - 0.5)
        np.testing.assert_allclose(composed, expected, rtol=0,
                                   atol=1e-12 * np.abs(expected).max())
        out = setup.output(SpatialCentreline.from_planar(planar, phi))
        np.testing.assert_allclose(out, setup.output(planar, azimuth=phi), rtol=1e-11)


def test_azimuth_zero_planar_path_is_unchanged() -> None:
    setup = _setup(3)
    planar = _bent(setup)
    spatial = SpatialCentreline.from_planar(planar, 0.0)
    np.testing.assert_allclose(setup.field(spatial), setup.field(planar), rtol=1e-13,
                               atol=1e-13 * np.abs(setup.field(planar)).max())
    pos_p, mom_p = setup.dipoles(planar)
    pos_s, mom_s = setup.dipoles(spatial)
    np.testing.assert_allclose(pos_s, pos_p, rtol=0, atol=1e-17)
    np.testing.assert_allclose(mom_s, mom_p, rtol=0, atol=1e-12 * np.abs(mom_p).max())


def _helix(setup: mc.Setup) -> SpatialCentreline:
    """An out-of-plane shape: the tangent leans by a growing angle toward a turning azimuth."""
    s = np.linspace(0.0, setup.cilium.height, 65)
    lean = 0.9 * s / s[-1]
    turn = 2.5 * s / s[-1]
    t = np.stack([np.sin(lean) * np.cos(turn), np.sin(lean) * np.sin(turn), np.cos(lean)], -1)
    return SpatialCentreline.from_tangents(s, t)


def test_out_of_plane_shape_against_magpylib_dipoles() -> None:
    setup = _setup(5)
    shape = _helix(setup)
    observers = np.array([[0.0, 0.0, 0.0], [1.5e-3, -1e-3, 0.2e-3], [-2e-3, 2.5e-3, 5e-3]])
    collection = setup.to_magpylib(shape, sensor=False)
    expected = collection.getB(observers)
    got = setup.field_at(observers, shape)[0]
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    np.testing.assert_allclose(setup.field(shape)[0], expected[0], rtol=1e-12)
    # the dipoles sit on their rings: perpendicular to the tangent at the slice mid-points
    pos, mom = setup.dipoles(shape)
    assert pos.shape == mom.shape == (1, setup.n_loops * setup.dipoles_per_loop, 3)
    total = np.linalg.norm(mom[0], axis=1).sum()
    assert total == pytest.approx(setup.moment, rel=1e-12)


def test_out_of_plane_frames_interpolate_between_grid_points() -> None:
    # the field of coarser samplings of a helix converges to the fine one's (the frames between
    # grid points follow the shape, to second order in the grid step)
    setup = _setup(4)
    fine = _helix(setup)
    ref = setup.field(fine)

    def error(step: int) -> float:
        c = SpatialCentreline(fine.s[::step], fine.points[:, ::step], fine.tangents[:, ::step],
                              fine.normals[:, ::step])
        return float(np.abs(setup.field(c) - ref).max() / np.abs(ref).max())

    assert error(8) < 2e-2
    assert error(4) < 0.4 * error(8)
    assert error(2) < 0.4 * error(4)


def test_inside_check_follows_the_shape_in_space() -> None:
    setup = _setup(3)
    planar = mc.Centreline.straight(setup.cilium.height, [0.6])
    spatial = SpatialCentreline.from_planar(planar, np.pi / 2)
    mid = setup.base_centre + 0.5 * spatial.tip[0]
    with pytest.raises(mc.MagciliaError, match="outside the cilium"):
        setup.field_at(mid, spatial)
    setup.field_at(setup.base_centre + 0.5 * planar.tip[0], spatial)  # bent the other way: clear
    with pytest.raises(mc.MagciliaError, match="outside the cilium"):
        setup.check_outside(mid, spatial)


def test_length_is_checked() -> None:
    setup = _setup(3)
    wrong = SpatialCentreline.from_planar(mc.Centreline.straight(1e-3, [0.1]), 0.0)
    with pytest.raises(mc.MagciliaError, match="centreline length"):
        setup.field(wrong)
    with pytest.raises(mc.MagciliaError, match="one centreline"):
        setup.to_magpylib(SpatialCentreline.from_planar(
            mc.Centreline.straight(setup.cilium.height, [0.1, 0.2]), 0.0))


def test_exact_reference_accepts_shapes_in_space() -> None:
    from magcilia.model.azimuth import field_from_tilt_frame, placement_in_tilt_frame
    from magcilia.model.exact import exact_field, single_dipole_field

    setup = _setup(5)
    planar = _bent(setup)
    spatial = SpatialCentreline.from_planar(planar, 0.0)
    np.testing.assert_allclose(exact_field(setup, spatial, n_slices=40),
                               exact_field(setup, planar, n_slices=40), rtol=1e-10, atol=1e-18)
    np.testing.assert_allclose(single_dipole_field(setup, spatial),
                               single_dipole_field(setup, planar), rtol=1e-12, atol=1e-18)
    phi = 1.2  # turned: the planar shape seen from a placement turned by -phi
    x, y = placement_in_tilt_frame(setup.position[0], setup.position[1], phi)
    turned = setup.replace(position=(float(x), float(y), setup.position[2]))
    expected = field_from_tilt_frame(exact_field(turned, planar, n_slices=40), phi)
    np.testing.assert_allclose(exact_field(setup, SpatialCentreline.from_planar(planar, phi),
                                           n_slices=40), expected, rtol=1e-10)
    # the exact body and the dipole model agree on a shape in space (model accuracy)
    fine = setup.replace(n_loops=60, dipoles_per_loop=12, ring="rms")
    helix = _helix(fine)
    expected = exact_field(fine, helix, n_slices=400)
    np.testing.assert_allclose(fine.field(helix), expected, rtol=0,
                               atol=2e-3 * np.linalg.norm(expected))
