"""The compiled kernels against the NumPy reference (≤ 1e-12 relative), the fallback without numba,
and non-finite results where an observer sits on a dipole."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable

import numpy as np
import pytest

import magcilia as mc
from magcilia.model import compiled, pose_field
from magcilia.model.batch import TiltBatch, tilt_field_batch, tilt_output_batch
from magcilia.model.kernels import dipole_field

RTOL = 1e-12
ANGLES = np.radians(np.linspace(-20.0, 85.0, 33))
#: a measured shape with knots inside slices and on slice edges (exact binary fractions)
PROFILE = mc.Cilium.from_profile(np.array([0.0, 0.25, 0.5, 0.6, 0.75, 1.0]) * 2.0**-9,
                                 np.array([1.0, 1.2, 0.9, 1.0, 0.5, 0.2]) * 2.0**-12)
SETUPS = {
    "frustum": mc.Setup.paper(),
    "frustum-rms": mc.Setup.paper(ring="rms"),
    "profile": mc.Setup.paper(cilium=PROFILE, position=(1.5e-3, 0.1e-3, 0.2e-3)),
    "profile-rms": mc.Setup.paper(cilium=PROFILE, ring="rms", position=(-1e-3, 0.0, 0.1e-3)),
}


def _with_numpy(fn: Callable[[], np.ndarray]) -> np.ndarray:
    """``fn()`` with the compiled kernels switched off: the NumPy reference."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(compiled, "ENABLED", False)
        return fn()


def assert_agree(ours: np.ndarray, ref: np.ndarray) -> None:
    """Equal to RTOL relative to the largest magnitude of each row (first axis)."""
    assert ours.shape == ref.shape
    scale = np.abs(ref).reshape(ref.shape[0], -1).max(axis=1)
    err = np.abs(ours - ref).reshape(ref.shape[0], -1).max(axis=1)
    assert (err <= RTOL * scale).all(), float((err / scale).max())


def _sets(seed: int) -> dict[str, np.ndarray]:
    """300 parameter sets with every (n, k) in 1..10 three times; the element stays outside."""
    rng = np.random.default_rng(seed)
    n, k = (g.ravel() for g in np.meshgrid(np.arange(1, 11), np.arange(1, 11)))
    size = 3 * n.size
    return {"height": rng.uniform(1e-3, 4e-3, size),
            "base_radius": rng.uniform(0.1e-3, 0.3e-3, size),
            "tip_radius": rng.uniform(0.01e-3, 0.1e-3, size), "x": rng.uniform(-3e-3, 3e-3, size),
            "y": rng.uniform(-2e-3, 2e-3, size), "z": rng.uniform(0.0, 1e-3, size),
            "n_loops": np.tile(n, 3), "dipoles_per_loop": np.tile(k, 3),
            "magnetization_scale": rng.uniform(0.1, 1.0, size), "offset": rng.normal(0, 0.1, size)}


def test_numba_is_available_here() -> None:
    # the comparisons below are empty if the compiled kernels silently fell back to NumPy
    assert compiled.kernels() is not None


@pytest.mark.parametrize("name", list(SETUPS))
@pytest.mark.parametrize("what", ["output", "field", "field-x"])
def test_batch_matches_the_numpy_reference(name: str, what: str) -> None:
    setup, params = SETUPS[name], _sets(len(name))

    def run() -> np.ndarray:
        if what == "output":
            return tilt_output_batch(setup, params, ANGLES)
        return tilt_field_batch(setup, params, ANGLES, x_only=what == "field-x")

    ours, ref = run(), _with_numpy(run)
    assert np.isfinite(ref).all()
    assert_agree(ours, ref)


def test_batch_in_blocks_of_angles_matches_the_numpy_reference() -> None:
    angles = np.linspace(-0.2, 1.5, 2 * compiled.ANGLE_BLOCK + 3)
    params = {key: val[::10] for key, val in _sets(3).items()}
    for setup in (SETUPS["frustum"], SETUPS["profile-rms"]):
        batch = TiltBatch(setup, angles)
        assert_agree(batch.output(params), _with_numpy(lambda b=batch: b.output(params)))


def test_prepared_batch_matches_the_wrappers() -> None:
    setup, params = SETUPS["profile"], _sets(7)
    batch = TiltBatch(setup, ANGLES)
    np.testing.assert_array_equal(batch.output(params), tilt_output_batch(setup, params, ANGLES))
    np.testing.assert_array_equal(batch.field(params), tilt_field_batch(setup, params, ANGLES))
    assert not batch.field(params, x_only=True)[..., 1:].any()
    assert batch.output({}).shape == (1, ANGLES.size)
    np.testing.assert_array_equal(batch.output({})[0], setup.output(ANGLES))


@pytest.mark.parametrize("name", list(SETUPS))
def test_setup_paths_match_the_numpy_reference(name: str) -> None:
    setup = SETUPS[name]
    angles = np.concatenate([ANGLES, np.linspace(-0.3, 1.5, compiled.ANGLE_BLOCK + 7)])  # 2 blocks
    for method in (setup.output, setup.field):
        assert_agree(method(angles)[None], _with_numpy(lambda m=method: m(angles))[None])
    line = mc.Centreline.straight(setup.cilium.height, ANGLES[::4])
    points = np.random.default_rng(1).uniform(-3e-3, 3e-3, (40, 3)) * [1, 1, 0.1]
    ours = setup.field_at(points, line)
    assert_agree(ours, _with_numpy(lambda: setup.field_at(points, line)))
    np.testing.assert_allclose(ours[:, 0, :], setup.field_at(points[:1], line)[:, 0, :],
                               rtol=RTOL)


@pytest.mark.parametrize(("n_obs", "n_dip"),
                         [(1, 1), (5, 3), (200, 70), (3, compiled.DIPOLE_BLOCK + 5), (0, 4),
                          (4, 0)],
                         ids=["1x1", "5x3", "200x70", "block-boundary", "no-observer", "no-dipole"])
def test_dipole_kernel_matches_the_numpy_reference(n_obs: int, n_dip: int) -> None:
    rng = np.random.default_rng(n_obs + n_dip)
    pos = rng.uniform(-1e-3, 1e-3, (n_dip, 3))
    mom = rng.normal(size=(n_dip, 3)) * 1e-6
    obs = rng.uniform(-2e-3, 2e-3, (n_obs, 3))
    if n_dip and n_obs:  # observers in the cloud, some a micrometre from a dipole
        near = n_obs // 2
        obs[:near] = pos[rng.integers(0, n_dip, near)] + rng.normal(size=(near, 3)) * 1e-6
    ours, ref = dipole_field(obs, pos, mom), _with_numpy(lambda: dipole_field(obs, pos, mom))
    assert ours.shape == (n_obs, 3)
    np.testing.assert_allclose(ours, ref, rtol=RTOL, atol=RTOL * np.abs(ref).max(initial=0.0))


def test_pose_kernel_matches_the_numpy_reference() -> None:
    rng = np.random.default_rng(4)
    pos = rng.uniform(-1e-3, 1e-3, (6, 40, 3)) + [0.0, 0.0, 2e-3]
    mom = rng.normal(size=(6, 40, 3)) * 1e-6
    for n_obs in (2, 150):  # both NumPy routes: vectorised over poses, and pose by pose
        obs = rng.uniform(-2e-3, 2e-3, (n_obs, 3))
        assert_agree(pose_field(obs, pos, mom), _with_numpy(lambda o=obs: pose_field(o, pos, mom)))


def test_an_element_on_a_dipole_gives_a_nonfinite_row_in_both_paths() -> None:
    h, rb, depth = 2.0**-9, 2.0**-12, 2.0**-10  # exact in binary: the element exactly on it
    setup = mc.Setup.paper(height=h, base_radius=rb, depth=depth, n_loops=1, dipoles_per_loop=1,
                           position=(0.0, 0.0, 0.0))
    params = {"x": np.array([-rb / 2, 1e-3]), "z": np.array([-h / 2 - depth, 0.0]),
              "y": np.zeros(2)}
    for run in (lambda: tilt_output_batch(setup, params, np.array([0.0, 0.3])),
                lambda: tilt_field_batch(setup, params, np.array([0.0, 0.3]))):
        ours, ref = run(), _with_numpy(run)
        assert not np.isfinite(ours[0, 0]).all() and not np.isfinite(ref[0, 0]).all()
        assert np.isfinite(ours[1]).all()
        assert_agree(ours[1:], ref[1:])
    on = dipole_field(np.zeros((2, 3)) + [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], np.zeros((1, 3)),
                      np.ones((1, 3)))
    assert not np.isfinite(on[0]).any() and np.isfinite(on[1]).all()


def test_without_numba_the_kernels_fall_back(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba raises ImportError
    assert compiled._compile.__wrapped__() is None
    monkeypatch.setattr(compiled, "ENABLED", False)
    assert compiled.kernels() is None
    assert np.isfinite(mc.Setup.paper().output(ANGLES)).all()


def test_importing_magcilia_does_not_import_numba() -> None:
    code = "import sys, magcilia; sys.exit('numba' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0
