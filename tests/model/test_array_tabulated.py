"""The array's tabulated forward map and its analytic Jacobian (model/array_tabulated.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import magcilia as mc
from magcilia.device.array import CiliaArray
from magcilia.device.magnetometer import Magnetometer
from magcilia.model import compiled
from magcilia.model.array import segment_field
from magcilia.model.array_tabulated import table_field, table_field_numpy
from magcilia.readout.array import ArrayReadout

PART = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0, name="part")
SPAN = 2e-5


@pytest.fixture(scope="module")
def readout() -> ArrayReadout:
    """A 3 × 3 array with two kinds of cilia (one shorter) and turned sensors."""
    setup = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0.0, 0.0, 0.0))
    grid = CiliaArray.grid(setup, 3, 3, 2.5e-3, sensor=PART)
    short = 0.8 * setup.cilium.height
    cilia = [s.replace(height=short) if c % 4 == 1 else s for c, s in enumerate(grid.cilia)]
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    sensors = [dataclasses.replace(s, rotation=turn) if i % 2 else s
               for i, s in enumerate(grid.sensors)]
    return ArrayReadout(CiliaArray(cilia, sensors, names=grid.names), SPAN)


def _forces(seed: int, n: int, c: int) -> np.ndarray:
    f = np.random.default_rng(seed).uniform(-0.95, 0.95, (n, c, 2)) * SPAN
    f[0, :3] = 0.0  # zero load, and loads far below SMALL and just above it
    f[0, 3] = (1e-14 * SPAN, 0.0)
    f[0, 4] = (0.0, -3e-6 * SPAN)
    return f


def test_the_kernel_matches_the_numpy_reference(readout: ArrayReadout) -> None:
    model = readout._model[0]
    forces = _forces(0, 3, len(readout.array))
    field, jac = table_field(model, forces, jacobian=True)
    ref_field, ref_jac = table_field_numpy(model, forces, jacobian=True)
    assert jac is not None and ref_jac is not None
    np.testing.assert_allclose(field, ref_field, rtol=0, atol=1e-12 * np.abs(ref_field).max())
    np.testing.assert_allclose(jac, ref_jac, rtol=0, atol=1e-12 * np.abs(ref_jac).max())
    alone, none = table_field(model, forces)
    assert none is None
    np.testing.assert_allclose(alone, field, rtol=0, atol=1e-13 * np.abs(field).max())


def test_the_field_is_the_layouts_dipoles_through_the_segment_kernel(
        readout: ArrayReadout) -> None:
    """An independent route: the frames from LoadTable.frames, the dipoles from
    ArrayLayout.planar_dipoles, their field by segment_field, turned onto the sensors' axes."""
    array, lay = readout.array, readout.array.layout
    for f in _forces(1, 2, len(array)):
        pos, mom = lay.planar_dipoles(*readout._frames(f))
        each = segment_field(np.asarray(array.sensor_positions), pos, mom, lay.starts)
        expected = array.to_sensor(each.sum(axis=0)).reshape(-1)
        got, _ = table_field(readout._model[0], f[None])
        np.testing.assert_allclose(got[0], expected, rtol=0, atol=1e-12 * np.abs(expected).max())
        board, _ = table_field(readout._model[1], f[None])
        np.testing.assert_allclose(board[0], each.sum(axis=0).reshape(-1), rtol=0,
                                   atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("numpy_path", [False, True])
def test_the_jacobian_is_the_derivative(readout: ArrayReadout, numpy_path: bool,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """Against central differences of the forward map, also at and near zero load (where the
    chain through |F| and φ takes its limits)."""
    if numpy_path:
        monkeypatch.setattr(compiled, "ENABLED", False)
    model = readout._model[0]
    c_n = len(readout.array)
    forces = _forces(2, 2, c_n)
    _, jac = table_field(model, forces, jacobian=True)
    assert jac is not None
    h = 1e-4 * SPAN
    num = np.empty_like(jac)
    for k in range(2 * c_n):
        step = np.zeros(2 * c_n)
        step[k] = h
        up, _ = table_field(model, forces + step.reshape(c_n, 2))
        down, _ = table_field(model, forces - step.reshape(c_n, 2))
        num[:, :, k] = (up - down) / (2.0 * h)
    np.testing.assert_allclose(jac, num, rtol=0, atol=1e-6 * np.abs(num).max())
    # at rest it is the crosstalk matrix (central differences of the tables at 1e-4 span)
    np.testing.assert_allclose(jac[0][:, :6], readout.jacobian[:, :6], rtol=0,
                               atol=1e-6 * np.abs(readout.jacobian).max())


def test_the_jacobian_is_continuous_through_zero_load(readout: ArrayReadout) -> None:
    model = readout._model[0]
    c_n = len(readout.array)
    zero = np.zeros((1, c_n, 2))
    _, at_zero = table_field(model, zero, jacobian=True)
    assert at_zero is not None
    for phi in np.linspace(-np.pi, np.pi, 7):
        near = np.broadcast_to(1e-7 * SPAN * np.array([np.cos(phi), np.sin(phi)]),
                               (1, c_n, 2)).copy()
        _, jac = table_field(model, near, jacobian=True)
        assert jac is not None
        np.testing.assert_allclose(jac, at_zero, rtol=0, atol=1e-5 * np.abs(at_zero).max())
