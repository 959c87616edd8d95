"""Field kernels vs magpylib, and physical invariants (superposition, rotation, scaling)."""

from __future__ import annotations

import magpylib as magpy
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from magcilia.model.kernels import CHUNK_PAIRS, dipole_field, dipole_field_batch, tilt_field


def _scene(seed: int, n_obs: int, n_dip: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    obs = rng.uniform(-2e-3, 2e-3, (n_obs, 3))
    pos = rng.uniform(-1e-3, 1e-3, (n_dip, 3)) + np.array([0.0, 0.0, 4e-3])
    mom = rng.normal(size=(n_dip, 3)) * 1e-6
    return obs, pos, mom


@pytest.mark.parametrize(("n_obs", "n_dip"), [(1, 1), (7, 3), (300, 50), (5, CHUNK_PAIRS + 7)],
                         ids=["1x1", "7x3", "300x50", "chunk-boundary"])
def test_dipole_kernel_matches_magpylib(n_obs: int, n_dip: int) -> None:
    obs, pos, mom = _scene(1, n_obs, n_dip)
    ours = dipole_field(obs, pos, mom)
    ref = magpy.func.dipole_field(
        "B", np.repeat(obs, n_dip, axis=0), np.tile(mom, (n_obs, 1)), np.tile(pos, (n_obs, 1))
    ).reshape(n_obs, n_dip, 3).sum(axis=1)
    np.testing.assert_allclose(ours, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


def test_batch_kernel_matches_single_kernel() -> None:
    obs, pos, mom = _scene(2, 9, 12)
    pos2 = pos[None] + np.array([[[1e-4, 0, 0]], [[0, -2e-4, 1e-4]]])
    mom2 = np.stack([mom, 2 * mom])
    batch = dipole_field_batch(obs, pos2, mom2)
    for i in range(2):
        np.testing.assert_allclose(batch[i], dipole_field(obs, pos2[i], mom2[i]), rtol=1e-13)


def test_tilt_kernel_matches_moved_dipoles() -> None:
    rng = np.random.default_rng(3)
    body = rng.uniform(-2e-4, 2e-4, (10, 3)) + np.array([0, 0, 1.5e-3])
    m = rng.uniform(0.1, 1.0, 10) * 1e-6
    base = np.array([1e-3, 0.5e-3, 1e-3])
    angles = np.radians([-40.0, 0.0, 25.0, 80.0])
    bx, by, bz = tilt_field(np.cos(angles), np.sin(angles), -base, body, m)
    for i, th in enumerate(angles):
        rot = Rotation.from_rotvec([0.0, th, 0.0])
        pos = rot.apply(body) + base
        mom = rot.apply(np.outer(m, [0.0, 0.0, 1.0]))
        ref = dipole_field(np.zeros((1, 3)), pos, mom)[0]
        np.testing.assert_allclose([bx[i], by[i], bz[i]], ref, rtol=1e-12, atol=1e-22)


@given(seed=st.integers(0, 2**32 - 1), split=st.integers(1, 19))
def test_superposition(seed: int, split: int) -> None:
    obs, pos, mom = _scene(seed, 4, 20)
    whole = dipole_field(obs, pos, mom)
    parts = (dipole_field(obs, pos[:split], mom[:split])
             + dipole_field(obs, pos[split:], mom[split:]))
    np.testing.assert_allclose(whole, parts, rtol=1e-10, atol=1e-12 * np.abs(whole).max())


@given(seed=st.integers(0, 2**32 - 1), angle=st.floats(-np.pi, np.pi))
def test_rotation_about_z_of_the_scene(seed: int, angle: float) -> None:
    obs, pos, mom = _scene(seed, 3, 6)
    rot = Rotation.from_rotvec([0.0, 0.0, angle])
    rotated = dipole_field(rot.apply(obs), rot.apply(pos), rot.apply(mom))
    np.testing.assert_allclose(rotated, rot.apply(dipole_field(obs, pos, mom)), rtol=1e-9,
                               atol=1e-12 * np.abs(rotated).max())


@given(seed=st.integers(0, 2**32 - 1), scale=st.floats(0.01, 100.0))
def test_scaling_of_lengths(seed: int, scale: float) -> None:
    # B ~ m / r^3: scaling all lengths by s with fixed moments divides B by s^3
    obs, pos, mom = _scene(seed, 3, 6)
    scaled = dipole_field(scale * obs, scale * pos, mom)
    np.testing.assert_allclose(scaled * scale**3, dipole_field(obs, pos, mom), rtol=1e-10)


def test_near_field_accuracy_of_the_split_products() -> None:
    # observers 1 µm from dipoles of a 1 mm cloud: the documented worst case stays below 1e-11
    rng = np.random.default_rng(5)
    pos = rng.uniform(-1e-3, 1e-3, (50, 3))
    mom = rng.normal(size=(50, 3)) * 1e-6
    obs = pos[:5] + rng.normal(size=(5, 3)) * 1e-6
    ref = magpy.func.dipole_field(
        "B", np.repeat(obs, 50, axis=0), np.tile(mom, (5, 1)), np.tile(pos, (5, 1))
    ).reshape(5, 50, 3).sum(axis=1)
    np.testing.assert_allclose(dipole_field(obs, pos, mom), ref, rtol=1e-11)
