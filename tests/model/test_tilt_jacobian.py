"""Analytic derivatives of the batched tilt model (issue 27, item 2): every column of
``TiltBatch.output_jacobian`` / ``field_jacobian`` against central differences of the model
itself, for frustums and measured profiles, both ring rules, several (n, k), compiled and NumPy;
the compiled pass against the NumPy reference; non-finite flags where the element sits on a
dipole."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

import magcilia as mc
from magcilia.model import compiled
from magcilia.model.batch import JACOBIAN_NAMES, TiltBatch

ANGLES = np.radians(np.linspace(-20.0, 85.0, 19))
PROFILE = mc.Cilium.from_profile(np.array([0.0, 0.25, 0.5, 0.6, 0.75, 1.0]) * 2.0**-9,
                                 np.array([1.0, 1.2, 0.9, 1.0, 0.5, 0.2]) * 2.0**-12)
SETUPS = {
    "cone": mc.Setup.paper_initial(),  # tip radius 0: the taper's own derivative vanishes
    "frustum": mc.Setup.paper(),
    "frustum-rms": mc.Setup.paper(ring="rms"),
    "profile": mc.Setup.paper(cilium=PROFILE, position=(1.5e-3, 0.1e-3, 0.2e-3)),
    "profile-rms": mc.Setup.paper(cilium=PROFILE, ring="rms", position=(-1e-3, 0.3e-3, 0.1e-3)),
}
#: (n, k) of the sets: one slice, one dipole, odd and even rings, many slices
LAYOUTS = [(1, 1), (1, 4), (3, 1), (2, 3), (5, 2), (6, 7), (10, 10)]
#: relative tolerance of a column against central differences (their truncation and rounding
#: errors are ~1e-9 here; analytic and differenced columns share nothing but the model)
RTOL_DIFF = 1e-6
#: compiled against NumPy: both analytic, only rounding differs
RTOL_REF = 1e-10


def _sets(seed: int) -> dict[str, np.ndarray]:
    """One set per layout, the element well outside the cilium, y away from 0 (B_x is even in
    y: its y column vanishes at y = 0)."""
    rng = np.random.default_rng(seed)
    size = len(LAYOUTS)
    return {"height": rng.uniform(2e-3, 4e-3, size),
            "base_radius": rng.uniform(0.1e-3, 0.3e-3, size),
            "x": rng.choice([-1.0, 1.0], size) * rng.uniform(0.8e-3, 3e-3, size),
            "y": rng.uniform(0.2e-3, 2e-3, size), "z": rng.uniform(0.0, 1e-3, size),
            "n_loops": np.array([n for n, _ in LAYOUTS]),
            "dipoles_per_loop": np.array([k for _, k in LAYOUTS]),
            "magnetization_scale": rng.uniform(0.5, 1.5, size),
            "offset": rng.normal(0.0, 0.01, size)}


def _numpy(fn: Callable[[], object]) -> object:
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(compiled, "ENABLED", False)
        return fn()


def _differences(value: Callable[[dict[str, np.ndarray]], np.ndarray],
                 params: dict[str, np.ndarray], name: str) -> np.ndarray:
    """Central differences of ``value`` in parameter ``name`` (relative step 1e-6)."""
    base = params[name]
    h = 1e-6 * np.abs(base)
    up, down = dict(params), dict(params)
    up[name], down[name] = base + h, base - h
    shape = (-1,) + (1,) * (value(params).ndim - 1)
    return (value(up) - value(down)) / (2.0 * h.reshape(shape))


def _check_columns(jac: np.ndarray, value: Callable[[dict[str, np.ndarray]], np.ndarray],
                   params: dict[str, np.ndarray]) -> None:
    for c, name in enumerate(JACOBIAN_NAMES):
        ref = _differences(value, params, name)
        for i in range(ref.shape[0]):  # each set against its own largest derivative
            scale = np.abs(ref[i]).max()
            assert scale > 0.0, (name, i)
            err = np.abs(jac[i, ..., c] - ref[i]).max() / scale
            assert err <= RTOL_DIFF, (name, LAYOUTS[i], err)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("name", list(SETUPS))
def test_output_columns_match_central_differences(name: str, engine: str) -> None:
    batch, params = TiltBatch(SETUPS[name], ANGLES), _sets(len(name))

    def run() -> tuple[np.ndarray, np.ndarray]:
        return batch.output_jacobian(params)

    out, jac = run() if engine == "compiled" else _numpy(run)  # type: ignore[misc]
    assert out.shape == (len(LAYOUTS), ANGLES.size)
    assert jac.shape == (len(LAYOUTS), ANGLES.size, len(JACOBIAN_NAMES))
    np.testing.assert_allclose(out, batch.output(params), rtol=1e-12, atol=1e-15)
    _check_columns(jac, batch.output, params)


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("name", ["frustum", "profile-rms"])
def test_field_columns_match_central_differences(name: str, engine: str) -> None:
    batch, params = TiltBatch(SETUPS[name], ANGLES), _sets(7)

    def run() -> tuple[np.ndarray, np.ndarray]:
        return batch.field_jacobian(params)

    out, jac = run() if engine == "compiled" else _numpy(run)  # type: ignore[misc]
    assert jac.shape == (len(LAYOUTS), ANGLES.size, 3, len(JACOBIAN_NAMES))
    np.testing.assert_allclose(out, batch.field(params), rtol=1e-12, atol=1e-20)
    _check_columns(jac, batch.field, params)


@pytest.mark.parametrize("name", list(SETUPS))
def test_compiled_derivatives_match_the_numpy_reference(name: str) -> None:
    batch, params = TiltBatch(SETUPS[name], ANGLES), _sets(3)
    for method in (batch.output_jacobian, batch.field_jacobian):
        ours = method(params)
        ref = _numpy(lambda m=method: m(params))
        for a, b in zip(ours, ref, strict=True):  # type: ignore[call-overload]
            scale = np.abs(b).reshape(b.shape[0], -1).max(axis=1)
            err = np.abs(a - b).reshape(b.shape[0], -1).max(axis=1)
            assert (err <= RTOL_REF * scale).all(), float((err / scale).max())


def test_magnetization_column_is_the_value_over_the_scale() -> None:
    # the output is linear in the magnetization: an identity, not a difference
    batch, params = TiltBatch(SETUPS["frustum"], ANGLES), _sets(5)
    out, jac = batch.output_jacobian(params)
    expected = (out - params["offset"][:, None]) / params["magnetization_scale"][:, None]
    np.testing.assert_allclose(jac[..., 5], expected, rtol=1e-12)


def test_an_element_on_a_dipole_is_flagged_in_both_paths() -> None:
    h, rb, depth = 2.0**-9, 2.0**-12, 2.0**-10  # exact in binary: the element exactly on it
    setup = mc.Setup.paper(height=h, base_radius=rb, depth=depth, n_loops=1, dipoles_per_loop=1,
                           position=(0.0, 0.0, 0.0))
    batch = TiltBatch(setup, np.array([0.0, 0.3]))
    params = {"x": np.array([-rb / 2, 1e-3]), "z": np.array([-h / 2 - depth, 0.0]),
              "y": np.zeros(2)}
    for run in (lambda: batch.output_jacobian(params), lambda: batch.field_jacobian(params)):
        for out, jac in (run(), _numpy(run)):  # type: ignore[misc]
            assert not np.isfinite(jac[0, 0]).all()
            assert np.isfinite(out[1]).all() and np.isfinite(jac[1]).all()
