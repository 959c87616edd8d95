"""Centrelines: construction from angles (exact arc), interpolation, straight tilt."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc


def test_circular_arc_from_angles() -> None:
    # constant curvature kappa: x = (1 - cos(kappa s))/kappa, z = sin(kappa s)/kappa
    length, kappa = 3e-3, 400.0
    s = np.linspace(0.0, length, 41)
    line = mc.Centreline.from_angles(s, kappa * s)
    np.testing.assert_allclose(line.tip[0, 0], (1 - np.cos(kappa * length)) / kappa, rtol=1e-7)
    np.testing.assert_allclose(line.tip[0, 2], np.sin(kappa * length) / kappa, rtol=1e-7)
    q = np.linspace(0.0, length, 17)
    pts, ang = line.frames(q)
    np.testing.assert_allclose(pts[0, :, 0], (1 - np.cos(kappa * q)) / kappa, atol=1e-10)
    np.testing.assert_allclose(ang[0], kappa * q, atol=1e-12)


def test_straight_lines() -> None:
    line = mc.Centreline.straight(2e-3, [0.0, np.pi / 6])
    assert len(line) == 2
    np.testing.assert_allclose(line.tip, [[0, 0, 2e-3], [1e-3, 0, 2e-3 * np.cos(np.pi / 6)]])
    pts, _ = line.frames([1e-3])
    np.testing.assert_allclose(pts[:, 0], line.tip / 2, atol=1e-18)


def test_arrays_are_read_only() -> None:
    line = mc.Centreline.straight(1e-3, [0.1])
    with pytest.raises(ValueError, match="read-only"):
        line.angles[0, 0] = 1.0


@pytest.mark.parametrize(
    ("s", "angles", "match"),
    [([0.0], [0.0], "s must be strictly increasing"),
     ([0.1, 0.2], [0.0, 0.0], "s must be strictly increasing"),
     ([0.0, 1e-3], [0.0, np.nan], "angles must be finite"),
     ([0.0, 1e-3], [0.0, 0.1, 0.2], "angles must be shape")],
    ids=["one-point", "not-from-zero", "nan", "shape"],
)
def test_bad_centrelines(s: list, angles: list, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        mc.Centreline(np.asarray(s), np.asarray(angles), np.zeros((1, len(angles), 3)))
