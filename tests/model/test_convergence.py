"""model/convergence.py: the probe, the error of a layout against the exact body, the smallest
converged layout."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.model import convergence as cv


def test_the_probe_turns_the_observers_about_the_base() -> None:
    setup = mc.Setup.paper()
    pts = cv.probe_points(setup)  # the element seen from the four tilt directions
    rel = pts - setup.base_centre
    assert pts.shape == (4, 3)
    np.testing.assert_allclose(np.hypot(rel[:, 0], rel[:, 1]),
                               math.hypot(*setup.base_centre[:2]), rtol=1e-12)
    np.testing.assert_allclose(rel[:, 2], -setup.base_centre[2], rtol=1e-12)
    # an observer on the axis is the same from every direction
    assert cv.probe_points(setup, [setup.base_centre - [0.0, 0.0, 1e-3]]).shape == (1, 3)


def test_observers_inside_the_tilted_body_are_left_out() -> None:
    setup = mc.Setup.paper(tip_radius=5e-5, position=(0.0, 0.0, 0.0))
    inside = setup.base_centre + [1e-3, 0.0, 0.5e-3]  # in the cilium tilted 60 deg toward +x
    exact, mask = cv.reference(setup, np.array([inside]), np.radians([0.0, 60.0]))
    assert mask.tolist() == [[True], [False]] and np.all(exact[1] == 0.0)
    err = cv.layout_error(setup, 32, 5, points=[inside], tilts=np.radians([0.0, 60.0]),
                          azimuths=[0.0])
    assert math.isfinite(err) and err < cv.TOLERANCE


def test_the_rms_ring_converges_and_the_mean_ring_does_not() -> None:
    setup = mc.Setup.paper(position=(0.5e-3, 0.0, 0.0))  # the element 0.87 mm from the base
    rms = [cv.layout_error(setup, n, 5, "rms") for n in (8, 16, 32, 64)]
    mean = [cv.layout_error(setup, n, 5, "mean") for n in (16, 64)]
    assert all(b < a for a, b in itertools.pairwise(rms))
    assert rms[-1] < cv.TOLERANCE < mean[-1]  # the mean ring plateaus
    assert 3.0 < rms[1] / rms[2] < 5.0  # O(1/n²)
    lay = cv.converged_layout(setup)
    assert lay.converged and lay.n_loops in (48, 64) and lay.text().startswith(f"{lay.n_loops}×5")


def test_errors_do_not_depend_on_the_magnetization_and_are_cached() -> None:
    a = mc.Setup.paper(tip_radius=5e-5)
    b = a.replace(magnetization_scale=0.3)
    assert cv.layout_error(a, 12, 5) == pytest.approx(cv.layout_error(b, 12, 5), rel=1e-12)
    pts = cv.probe_points(a)
    before = len(cv._REFERENCES)
    np.testing.assert_allclose(cv.reference(b, pts)[0], 0.3 * cv.reference(a, pts)[0],
                               rtol=1e-12)
    assert len(cv._REFERENCES) == before  # one reference for both


def test_no_layout_reaches_an_impossible_tolerance() -> None:
    setup = mc.Setup.paper()
    with pytest.raises(mc.MagciliaError, match="no layout up to 16 slices reaches"):
        cv.converged_layout(setup, 1e-9, slices=(8, 16), strict=True)
    best = cv.converged_layout(setup, 1e-9, slices=(8, 16))
    assert not best.converged and best.n_loops == 16
    with pytest.raises(mc.MagciliaError, match="tolerance must be a positive relative error"):
        cv.converged_layout(setup, 0.0)
