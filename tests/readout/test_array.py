"""Arrays under loads (readout/array.py): tables, crosstalk, the inverse, metrics vs pitch."""

from __future__ import annotations

import json

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import json_text
from magcilia.device.array import CiliaArray
from magcilia.device.magnetometer import Magnetometer
from magcilia.model.centreline import SpatialCentreline
from magcilia.readout.array import (
    ArrayFlag,
    ArrayReadout,
    array_metrics,
    field_for_loads,
    loaded_poses,
)

PART = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0, name="part")
SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0.0, 0.0, 0.0))
SPAN = 2e-5


@pytest.fixture(scope="module")
def readout() -> ArrayReadout:
    return ArrayReadout(CiliaArray.grid(SETUP, 4, 4, 2e-3, sensor=PART), SPAN)


def _loads(rng: np.random.Generator, n: int) -> np.ndarray:
    """Random horizontal forces within 0.9 of the span, uniform over the disc."""
    mag = 0.9 * SPAN * np.sqrt(rng.uniform(0.0, 1.0, n))
    phi = rng.uniform(-np.pi, np.pi, n)
    return np.stack([mag * np.cos(phi), mag * np.sin(phi)], axis=1)


def test_noise_free_loads_are_recovered_exactly(readout: ArrayReadout) -> None:
    array = readout.array
    for seed in range(3):
        forces = _loads(np.random.default_rng(seed), len(array))
        est = readout.read(array.to_sensor(field_for_loads(array, forces)))
        assert est.converged and not est.flags.any()
        assert np.abs(est.force - forces).max() <= 1e-6 * SPAN
        np.testing.assert_allclose(est.magnitude, np.hypot(*forces.T), rtol=0, atol=1e-6 * SPAN)


def test_noisy_estimates_lie_within_two_sigma_about_95_percent(readout: ArrayReadout) -> None:
    array = readout.array
    inside, total, chi2 = 0, 0, []
    for seed in range(30):
        rng = np.random.default_rng(100 + seed)
        forces = _loads(rng, len(array))
        est = readout.read(array.readings(field_for_loads(array, forces), rng=rng))
        inside += int(np.count_nonzero(np.abs(est.force - forces) <= 2.0 * est.sigma))
        total += forces.size
        chi2.append(est.chi2)
    assert 0.92 <= inside / total <= 0.98, inside / total  # 960 components
    # the residuals fit the noise model: chi² ≈ readings − unknowns = 48 − 32
    assert 12.0 < np.mean(chi2) < 20.0


def test_table_model_matches_the_exact_elastica(readout: ArrayReadout) -> None:
    array = readout.array
    forces = _loads(np.random.default_rng(5), len(array))
    exact = field_for_loads(array, forces)
    np.testing.assert_allclose(readout.field(forces), exact, rtol=0,
                               atol=1e-8 * np.abs(exact - array.field()).max())
    assert readout.table_error.max() < 1e-3 * 3e-7  # far below the sensor's noise
    assert readout.tables[0].error[0] < 1e-8 * SETUP.cilium.height


def test_rings_fixed_in_the_board_differ_from_turned_rings_only_by_the_ring_harmonic() -> None:
    array = CiliaArray.grid(SETUP, 1, 2, 2e-3, sensor=PART)
    forces = np.array([[0.0, 1e-5], [-7e-6, 3e-6]])
    board = field_for_loads(array, forces)
    shapes = [mc.bend(SETUP, force=float(np.hypot(*f))) for f in forces]
    turned = SpatialCentreline(
        shapes[0].s,
        *(np.concatenate([getattr(SpatialCentreline.from_planar(s, float(np.arctan2(f[1], f[0]))),
                                  name) for s, f in zip(shapes, forces, strict=True)])
          for name in ("points", "tangents", "normals")))
    diff = np.abs(array.field(turned) - board).max()
    assert 0.0 < diff < 1e-4 * np.abs(board).max()


def test_crosstalk_matrix_is_the_derivative_at_rest(readout: ArrayReadout) -> None:
    array = readout.array
    ct = readout.crosstalk()
    assert ct.matrix.shape == (48, 32)
    h = 1e-3 * SPAN
    for c, axis in ((0, 0), (5, 1), (10, 0)):
        plus, minus = np.zeros((16, 2)), np.zeros((16, 2))
        plus[c, axis], minus[c, axis] = h, -h
        fd = (array.to_sensor(field_for_loads(array, plus))
              - array.to_sensor(field_for_loads(array, minus))).reshape(-1) / (2 * h)
        np.testing.assert_allclose(ct.matrix[:, 2 * c + axis], fd, rtol=0,
                                   atol=1e-5 * np.abs(fd).max())
    # the ratio, by hand: spectral norms of the 3x2 blocks, the site is the sensor below
    blocks = ct.matrix.reshape(16, 3, 16, 2)
    c = 5
    norms = [np.linalg.norm(blocks[s, :, c, :], 2) for s in range(16)]
    assert ct.site[c] == c
    assert ct.ratio[c] == pytest.approx(max(norms[:c] + norms[c + 1:]) / norms[c], rel=1e-12)
    rows = ct.table()
    assert rows[c]["cilium"] == "r2c2" and rows[c]["ratio"] == pytest.approx(ct.ratio[c])
    json.loads(json_text(ct.to_dict()))
    assert "ratio" in ct.report()
    assert list(ct.to_dataframe().columns)[:2] == ["cilium", "site"]


def test_flags_beyond_span_and_saturated() -> None:
    small = PART.replace(field_range=1.5e-3, resolution=1e-7)  # the rest field: ~0.8 mT
    array = CiliaArray.grid(SETUP, 2, 2, 2.5e-3, sensor=small)
    ro = ArrayReadout(array, SPAN)
    forces = np.array([[1.3 * SPAN, 0.0], [0.0, 0.5 * SPAN], [0.2 * SPAN, -0.2 * SPAN],
                       [0.0, 0.0]])
    field = field_for_loads(array, forces)
    est = ro.read(array.readings(field, noisy=False))
    assert est.flags[0] & ArrayFlag.BEYOND_SPAN
    assert not est.flags[1:].any() or array.saturated(array.readings(field, noisy=False)).any()
    # a clipped reading: left out of the fit, and the cilia it informs flagged
    readings = array.readings(field, noisy=False)
    readings[1, 0] = 1.5e-3
    est = ro.read(readings)
    assert est.readings_used == 11
    assert est.flags[1] & ArrayFlag.SATURATED
    assert "SATURATED" in est.report()


def test_not_converged_is_flagged(readout: ArrayReadout) -> None:
    array = readout.array
    forces = _loads(np.random.default_rng(9), len(array))
    y = array.to_sensor(field_for_loads(array, forces))
    one = ArrayReadout(array, SPAN, max_iterations=1)
    est = one.read(y)
    assert not est.converged and np.all(est.flags & ArrayFlag.NOT_CONVERGED)


def test_singular_problems_are_refused() -> None:
    with pytest.raises(mc.MagciliaError, match=r"at least as many readings as unknowns: 8"):
        ArrayReadout(CiliaArray.grid(SETUP, 2, 2, 2e-3, sensors=[PART.replace(
            position=(0.0, 0.0, -1e-3))]), SPAN)
    far = SETUP.replace(position=(60e-3, 0.0, 0.0))
    sensors = [PART.replace(position=(x, y, 0.0)) for x in (-1e-3, 1e-3) for y in (-1e-3, 1e-3)]
    unreached = r"whose load reaches a sensor.*on c2 moves no reading.*got 'cilium c2'"
    with pytest.raises(mc.MagciliaError, match=unreached):
        ArrayReadout(CiliaArray((SETUP, far), tuple(sensors)), SPAN)


def test_cilia_that_touch_when_bent_are_refused() -> None:
    array = CiliaArray.grid(SETUP, 1, 2, 0.8e-3, sensor=PART)
    with pytest.raises(mc.MagciliaError, match=r"meet.*cilia r1c1 and r1c2"):
        ArrayReadout(array, 5e-5)
    ArrayReadout(array, 4e-6)  # small loads: clear
    with pytest.raises(mc.MagciliaError, match=r"can tell apart.*r1c\d and r1c\d"):
        ArrayReadout(array, 1e-6)  # too small for the noise to tell the two apart


def test_estimate_result_protocol(readout: ArrayReadout) -> None:
    array = readout.array
    forces = _loads(np.random.default_rng(2), len(array))
    est = readout.read(array.readings(field_for_loads(array, forces), rng=0))
    doc = json.loads(json_text(est.to_dict()))
    assert len(doc["cilia"]) == 16 and doc["cilia"][0]["cilium"] == "r1c1"
    frame = est.to_dataframe()
    assert list(frame.columns)[:3] == ["cilium", "Fx_N", "Fy_N"]
    np.testing.assert_allclose(frame["force_N"], est.magnitude)
    assert est.report().count("\n") == 18  # a title, a header, 16 cilia, the force scale
    assert est.report().endswith("force scale: modulus given, taken as exact (E 1 MPa)")
    assert np.all(est.sigma_direction > 0.0)
    with pytest.raises(mc.MagciliaError, match="readings"):
        readout.read(np.zeros((3, 3)))


def test_metrics_against_pitch() -> None:
    metrics = array_metrics(SETUP, [2e-3, 3e-3, 5e-3], sensor=PART, span=SPAN, rows=3,
                            cols=3)
    med = [r["ratio_median"] for r in metrics.table()]
    assert med[0] > med[1] > med[2]  # crosstalk falls with the pitch
    mdf = [r["minimum_max_N"] for r in metrics.table()]
    assert mdf[0] > mdf[1] > mdf[2] > metrics.isolated  # approaching one cilium alone
    assert metrics.ratio.shape == metrics.minimum.shape == (3, 9)
    json.loads(json_text(metrics.to_dict()))
    assert "pitch mm" in metrics.report()
    assert len(metrics.to_dataframe()) == 3


def test_loaded_poses_keep_each_cilium_length() -> None:
    array = CiliaArray.grid(SETUP, 1, 2, 2e-3, sensor=PART)
    poses = loaded_poses(array, np.array([[1e-5, 0.0, 0.0], [0.0, 0.0, 0.0]]))
    assert isinstance(poses, SpatialCentreline) and len(poses) == 2
    np.testing.assert_allclose(poses.normals[:, 0], [[1.0, 0.0, 0.0]] * 2, atol=1e-12)
    assert poses.tip[0, 0] > 0.0 and poses.tip[1, 0] == 0.0


def test_sensor_in_reach_of_a_bent_cilium_is_refused() -> None:
    shape = mc.bend(SETUP, force=SPAN)
    # a point the cilium passes through when bent toward -y by the span (clear at rest)
    point = SETUP.base_centre + np.array([0.0, -shape.points[0, 90, 0], shape.points[0, 90, 2]])
    sensors = (PART.replace(position=(0.0, 0.0, 0.0)),
               PART.replace(position=(2e-3, 0.0, 0.0)), PART.replace(position=tuple(point)))
    array = CiliaArray((SETUP,), sensors)  # clear of the upright cilium
    with pytest.raises(mc.MagciliaError, match=r"cilium c1 bent toward it by .*got 'sensor 3"):
        ArrayReadout(array, SPAN)
    ArrayReadout(array, 0.3 * SPAN)  # smaller loads do not reach it


def test_vertical_components_compress_or_stretch() -> None:
    array = CiliaArray.grid(SETUP, 1, 2, 2e-3, sensor=PART)
    push, pull = loaded_poses(array, np.array([[1e-5, 0.0, -1e-5], [1e-5, 0.0, 1e-5]])).tip
    alone = loaded_poses(array, np.array([[1e-5, 0.0], [0.0, 0.0]])).tip[0]
    assert push[0] > alone[0] > pull[0] > 0.0  # a push down bends further, a pull less
    straight = loaded_poses(array, np.array([[0.0, 0.0, -1e-6], [0.0, 0.0, 1e-6]]))
    np.testing.assert_allclose(straight.tip[:, :2], 0.0, atol=1e-15)
    ro = ArrayReadout(array, SPAN, table_size=9)
    with pytest.raises(mc.MagciliaError, match="horizontal forces"):
        ro.field(np.array([[1e-5, 0.0, 1e-6], [0.0, 0.0, 0.0]]))
