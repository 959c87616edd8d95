"""The batched uniform-field bend (mechanics.field_batch) against mc.bend(..., actuation=), one
set and one field at a time (the planar and the general path of bend)."""

import numpy as np
import pytest

import magcilia as mc
from magcilia.mechanics.field_batch import field_batch, in_plane
from magcilia.mechanics.spatial import flip_field

FIELDS = np.array([[5e-4, 0.0, 0.0], [3e-4, 3e-4, 1e-4], [0.0, 0.0, 5e-4],
                   [-2e-4, 1e-4, -3e-4], [0.0, -4e-4, 0.0], [4e-3, 0.0, 2e-3]])


def _setup() -> mc.Setup:
    return mc.Setup.paper(height=3.26e-3, base_radius=1.8e-4, tip_radius=5e-5,
                          youngs_modulus=5e5)


def test_matches_bend_for_every_set_and_field() -> None:
    s = _setup()
    heights = np.array([3.26e-3, 3.0e-3, 2.5e-3])
    radii = np.array([1.8e-4, 2.0e-4, 1.5e-4])
    moduli = np.array([5e5, 8e5, 2e5])
    scales = np.array([1.0, 0.5, 2.0])
    shapes = field_batch(s, heights, radii, moduli, scales * s.spec.magnetization, FIELDS)
    assert shapes.ok.all()
    for i in range(heights.size):
        one = s.replace(height=heights[i], base_radius=radii[i], youngs_modulus=moduli[i],
                        magnetization_scale=scales[i])
        for j, b in enumerate(FIELDS):
            ref = mc.bend(one, 0.0, actuation=mc.Actuation.uniform(b))
            psi = shapes.planes[j]
            p = shapes.points[i, j]
            mine = np.stack([p[:, 0] * np.cos(psi), p[:, 0] * np.sin(psi), p[:, 2]], axis=1)
            # the same collocation and Newton tolerance: agreement far below a micrometre
            np.testing.assert_allclose(mine, ref.points[0], rtol=0, atol=1e-12)


def test_axial_field_and_planes() -> None:
    planes, bh, bz = in_plane(FIELDS)
    np.testing.assert_allclose(planes[:2], [0.0, np.pi / 4])
    assert bh[2] == 0.0 and bz[2] == 5e-4
    s = _setup()
    below = 0.5 * flip_field(s)  # against the magnetization, below the flip: straight
    shapes = field_batch(s, np.array([s.cilium.height]), np.array([s.cilium.base_radius]),
                         np.array([s.youngs_modulus]), np.array([s.spec.magnetization]),
                         np.array([[0.0, 0.0, -below]]))
    assert shapes.ok.all()
    np.testing.assert_allclose(shapes.points[0, 0, :, 0], 0.0, atol=0)


@pytest.mark.parametrize(("scale", "bx"), [(0.0, 1e-3), (1.0, 0.0)])
def test_zero_field_or_unmagnetized_is_straight(scale: float, bx: float) -> None:
    s = _setup()
    shapes = field_batch(s, np.array([s.cilium.height]), np.array([s.cilium.base_radius]),
                         np.array([s.youngs_modulus]), np.array([scale * s.spec.magnetization]),
                         np.array([[0.0, 0.0, 0.0], [bx, 0.0, bx]]))
    assert shapes.ok.all()
    np.testing.assert_allclose(shapes.angles, 0.0, atol=0)
