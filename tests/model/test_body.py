"""The body of revolution in plain numbers, and the spec the model layer takes instead of a
Setup."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

import magcilia as mc
from magcilia.model import ModelSpec, as_spec, body, exact_field, tilt_output_batch
from magcilia.model import pose as pose_model

U = np.array([0.0, 0.15, 0.4, 0.72, 1.0])
RHO = np.array([1.0, 1.2, 0.9, 0.5, 0.1])


@pytest.mark.parametrize("n", [1, 3, 7, 40])
def test_slice_means_are_exact_integrals(n: int) -> None:
    mean2, mean4 = body.slice_means(U, RHO, n)
    edges = np.linspace(0.0, 1.0, n + 1)
    for i in range(n):
        breaks = [u for u in U if edges[i] < u < edges[i + 1]]
        ref2 = quad(lambda t: np.interp(t, U, RHO) ** 2, edges[i], edges[i + 1], points=breaks)[0]
        ref4 = quad(lambda t: np.interp(t, U, RHO) ** 4, edges[i], edges[i + 1], points=breaks)[0]
        assert mean2[i] == pytest.approx(n * ref2, rel=1e-12)
        assert mean4[i] == pytest.approx(n * ref4, rel=1e-12)


def test_batch_of_shapes_equals_one_at_a_time() -> None:
    rho = np.stack([RHO, RHO * [1.0, 0.8, 1.1, 0.7, 0.0]])
    mean2, mean4 = body.slice_means(U, rho, 5)
    for row, r in enumerate(rho):
        one2, one4 = body.slice_means(U, r, 5)
        np.testing.assert_allclose(mean2[row], one2, rtol=1e-15)
        np.testing.assert_allclose(mean4[row], one4, rtol=1e-15)


def test_frustum_volume_and_rings() -> None:
    u, rho = body.frustum_shape(0.25)
    h, rb = 3e-3, 2e-4
    rt = 0.25 * rb
    assert body.volume(h, rb, u, rho) == pytest.approx(
        math.pi * h / 3 * (rb**2 + rb * rt + rt**2), rel=1e-14)
    # a cylinder's rms ring is r / sqrt(2), its mean ring r; shares are equal
    u, rho = body.frustum_shape(1.0)
    radius, share = body.slice_rings(u, rho, 4, "rms")
    np.testing.assert_allclose(radius, 1 / math.sqrt(2), rtol=1e-15)
    np.testing.assert_allclose(share, 0.25, rtol=1e-15)
    assert body.slice_rings(u, rho, 4, "mean")[0] == pytest.approx(np.ones(4))


def test_contains_is_the_profile() -> None:
    inside = body.contains(3e-3, 2e-4, U, RHO, [1.2e-3, 1.2e-3, -1e-6, 3.1e-3],
                           [0.9 * 2e-4 * 0.9, 1.1 * 2e-4 * 0.9, 0.0, 0.0])
    assert inside.tolist() == [True, False, False, False]


def test_the_model_layer_takes_a_spec_without_the_setup() -> None:
    setup = mc.Setup.paper(ring="rms", n_loops=8)
    spec = setup.spec
    assert isinstance(spec, ModelSpec) and as_spec(setup) is spec
    angles = np.radians([0.0, 20.0, 60.0])
    np.testing.assert_array_equal(pose_model.output(spec, angles), setup.output(angles))
    np.testing.assert_array_equal(tilt_output_batch(spec, {}, angles)[0],
                                  tilt_output_batch(setup, {}, angles)[0])
    np.testing.assert_allclose(tilt_output_batch(spec, {}, angles)[0], setup.output(angles),
                               rtol=1e-13)
    np.testing.assert_array_equal(exact_field(spec, angles, n_slices=20),
                                  mc.exact_field(setup, angles, n_slices=20))
    assert spec.params() == setup.params()
    with pytest.raises(mc.MagciliaError, match="model must be a magcilia Setup"):
        as_spec("paper")  # type: ignore[arg-type]


def test_public_centreline_and_outside_check() -> None:
    setup = mc.Setup.paper()
    line = setup.centreline([0.0, 0.3])
    assert isinstance(line, mc.Centreline) and line.length == setup.cilium.height
    np.testing.assert_allclose(line.tip[1], setup.cilium.height * np.array(
        [math.sin(0.3), 0.0, math.cos(0.3)]), rtol=1e-14)
    mid = setup.base_centre + [0.0, 0.0, 1e-3]  # on the upright axis
    with pytest.raises(mc.MagciliaError, match="points must be observer positions outside"):
        setup.check_outside(mid, [0.0])
    setup.check_outside(mid + [1e-3, 0.0, 0.0], [0.0])  # beside it: fine
    with pytest.raises(mc.MagciliaError, match="centreline length"):
        setup.centreline(mc.Centreline.straight(1e-3, [0.0]))
