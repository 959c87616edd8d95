"""CiliaArray (device/array.py): geometry, checks, the superposition field and readings."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia.device.array import CiliaArray
from magcilia.device.magnetometer import Magnetometer
from magcilia.model import compiled
from magcilia.model.centreline import SpatialCentreline

PART = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0, name="part")
SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0.0, 0.0, 0.0))


@pytest.fixture(scope="module")
def grid() -> CiliaArray:
    return CiliaArray.grid(SETUP, 4, 4, 2e-3, sensor=PART)


def _bent_poses(array: CiliaArray, seed: int = 0) -> SpatialCentreline:
    rng = np.random.default_rng(seed)
    planar = mc.bend_sweep(SETUP, forces=rng.uniform(0.0, 2e-5, len(array)))
    return SpatialCentreline.from_planar(planar, rng.uniform(-np.pi, np.pi, len(array)))


def _one(poses: SpatialCentreline, c: int) -> SpatialCentreline:
    return SpatialCentreline(poses.s, poses.points[c:c + 1], poses.tangents[c:c + 1],
                             poses.normals[c:c + 1])


def test_grid_places_cilia_and_a_sensor_under_each(grid: CiliaArray) -> None:
    assert len(grid) == grid.n_sensors == 16
    assert grid.names[:5] == ("r1c1", "r1c2", "r1c3", "r1c4", "r2c1")
    xs = np.unique(np.round(grid.bases[:, 0], 12))
    np.testing.assert_allclose(np.diff(xs), 2e-3, rtol=1e-12)
    np.testing.assert_allclose(grid.bases[:, :2].mean(axis=0), SETUP.base_centre[:2], atol=1e-15)
    np.testing.assert_allclose(grid.sensor_positions[:, :2], grid.bases[:, :2])
    np.testing.assert_allclose(grid.sensor_positions[:, 2], 0.0, atol=1e-18)
    deeper = CiliaArray.grid(SETUP, 2, 3, (1.5e-3, 2.5e-3), sensor=PART, depth=1e-3)
    np.testing.assert_allclose(deeper.bases[:, 2] - deeper.sensor_positions[:, 2], 1e-3)
    assert "cilia=6" in repr(deeper)


@pytest.mark.parametrize("posed", [False, True], ids=["rest", "bent"])
def test_field_is_the_sum_of_the_single_cilium_fields(grid: CiliaArray, posed: bool) -> None:
    poses = _bent_poses(grid) if posed else None
    pts = grid.sensor_positions
    expected = sum(c.field_at(pts, _one(poses, i) if poses is not None else np.array([0.0]))[0]
                   for i, c in enumerate(grid.cilia))
    got = grid.field(poses)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13 * np.abs(expected).max())
    np.testing.assert_allclose(grid.contributions(poses).sum(axis=0), got, rtol=0,
                               atol=1e-13 * np.abs(got).max())
    if poses is not None:  # one pose per cilium: the same
        np.testing.assert_allclose(grid.field([_one(poses, c) for c in range(len(grid))]), got,
                                   rtol=0, atol=1e-13 * np.abs(got).max())


def test_field_equals_magpylib(grid: CiliaArray) -> None:
    poses = _bent_poses(grid, 3)
    collection = grid.to_magpylib(poses, sensors=False)
    expected = collection.getB(grid.sensor_positions)
    np.testing.assert_allclose(grid.field(poses), expected, rtol=0,
                               atol=1e-12 * np.abs(expected).max())
    with_sensors = grid.to_magpylib(poses)
    assert len(with_sensors.sensors) == 16 and len(with_sensors.children) == 32


def test_segment_kernel_matches_numpy(grid: CiliaArray, monkeypatch: pytest.MonkeyPatch) -> None:
    poses = _bent_poses(grid, 4)
    fast = grid.contributions(poses)
    monkeypatch.setattr(compiled, "ENABLED", False)
    np.testing.assert_allclose(grid.contributions(poses), fast, rtol=1e-12,
                               atol=1e-14 * np.abs(fast).max())
    np.testing.assert_allclose(grid.field(poses), fast.sum(axis=0), rtol=1e-12,
                               atol=1e-14 * np.abs(fast).max())


def test_overlapping_cilia_are_refused() -> None:
    with pytest.raises(mc.MagciliaError, match=r"do not overlap at rest.*r1c1 and r1c2"):
        CiliaArray.grid(SETUP, 2, 2, 0.3e-3, sensor=PART)
    with pytest.raises(mc.MagciliaError, match="larger pitch"):
        CiliaArray.grid(SETUP, 1, 2, 0.3e-3, sensor=PART)


def test_sensor_inside_a_cilium_is_refused() -> None:
    inside = PART.replace(position=tuple(SETUP.base_centre + [0.0, 0.0, 1e-3]))
    with pytest.raises(mc.MagciliaError, match=r"inside cilium c1 at rest.*sensor 2"):
        CiliaArray((SETUP,), (PART, inside))


def test_sensor_inside_a_bent_cilium_is_refused() -> None:
    planar = mc.bend(SETUP, force=2e-5)
    spatial = SpatialCentreline.from_planar(planar, 0.0)
    point = SETUP.base_centre + spatial.points[0, 100] + [0.0, 0.0, 0.0]
    array = CiliaArray((SETUP,), (PART, PART.replace(position=tuple(point + [0.0, 0.0, 0.0]))))
    assert array.n_sensors == 2  # clear of the upright body
    with pytest.raises(mc.MagciliaError, match=r"inside cilium c1 in the given pose.*sensor 2"):
        array.field(spatial)
    array.field(SpatialCentreline.from_planar(planar, np.pi))  # bent the other way: clear


def test_bad_poses_are_refused(grid: CiliaArray) -> None:
    with pytest.raises(mc.MagciliaError, match="poses"):
        grid.field([0.0] * 3)
    with pytest.raises(mc.MagciliaError, match="poses"):
        grid.field(_one(_bent_poses(grid), 0))


def test_readings_rotate_clip_and_round(grid: CiliaArray) -> None:
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # turned 90° about z
    sensors = (PART.replace(position=(0.0, 0.0, -1e-3), rotation=rot),
               PART.replace(position=(0.0, 0.0, -2e-3), field_range=1e-5))
    array = CiliaArray((SETUP,), sensors)
    field = np.array([[1e-5, 2e-5, 3e-5], [1e-4, -1e-4, 2e-6]])
    got = array.readings(field, noisy=False)
    np.testing.assert_allclose(got[0], sensors[0].measure(field[0], noisy=False))
    np.testing.assert_allclose(got[0], np.round(np.array([2e-5, -1e-5, 3e-5]) / 1.5e-7) * 1.5e-7)
    np.testing.assert_allclose(got[1], sensors[1].measure(field[1], noisy=False))
    assert array.saturated(got).tolist() == [[False, False, False], [True, True, False]]
    np.testing.assert_allclose(array.to_sensor(field)[0], field[0] @ rot)
    noisy = array.readings(np.zeros((200, 2, 3)), rng=0)
    assert 0.5 < np.std(noisy[:, 0]) / np.sqrt(3e-7**2 + 1.5e-7**2 / 12) < 1.5
    np.testing.assert_allclose(array.sigma[0], np.sqrt(3e-7**2 + 1.5e-7**2 / 12))
